//! The product: what the module is and what it offers, in one place. Its identity, the
//! channel counts and capacities the firmware is built for, the ESC memory layout, the
//! synchronisation figures it advertises, the object dictionary and the device description
//! that the SII image and the ESI file are generated from.
//!
//! Nothing here imports from [`crate::stacks::ethercat`]: the slave application is built for the
//! product (it imports from here), so the description can be read, generated and checked
//! without the application, and a change of the product shows in one place.
//!
//! | module       | what                                                              |
//! |--------------|-------------------------------------------------------------------|
//! | [`identity`] | vendor ID, product code, revision, names                          |
//! | [`capacity`] | channel counts, mailbox size, PDO and process image capacities    |
//! | [`analog`]   | the analog front end: reference, divider and gain, full scale     |
//! | [`sync`]     | sync modes offered and the figures of 0x1C32/0x1C33 (minimum cycle) |
//! | [`can`]      | the CANopen device on CAN: node-ID, PDO defaults, output source, EDS |
//! | [`layout`]   | the SyncManagers in the ESC's process RAM                         |
//! | [`od`]       | the object dictionary                                             |
//! | [`device`]   | the device description (SII, ESI) built from all of the above     |

pub mod can;
pub mod capacity;
pub mod device;
pub mod identity;
pub mod layout;
pub mod od;
pub mod sync;

#[cfg(test)]
mod tests;
