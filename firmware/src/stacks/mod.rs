//! The fieldbus stacks: each serves a device's objects and process data on one fieldbus,
//! and none knows a product. A product composes them around its application.
//!
//! | module          | what                                                                  |
//! |-----------------|-----------------------------------------------------------------------|
//! | [`ethercat`]    | the EtherCAT slave application (ESM, mailbox, process data over the PDI) and the bootloader's slave |
//! | [`canopen`]     | the CANopen node on CAN (coe-core's node, the CAN task, its window)     |
//! | [`diagnostics`] | the device's error state both fieldbuses report: 0x1001, 0x1003, Emergency codes |
//! | [`entry_bytes`] | entry values as bytes, for the applications' object access              |

pub mod canopen;
pub mod diagnostics;
pub mod entry_bytes;
pub mod ethercat;
