//! Firmware update: what the bootloader and the application agree on, and the bootloader's
//! logic, all host-tested against the flash/IAP model of `lpc17xx-iap`.
//!
//! | Module | What |
//! |---|---|
//! | [`layout`] | THE flash map (bootloader, application slot, staging area) and the RAM word of the boot request; `memory-app.x` and `memory-boot.x` are checked against it |
//! | [`crc32`] | CRC-32 of the update file and its header |
//! | [`header`] | the update file's header (`.efw`): identity, hardware revision, version, length, CRC |
//! | [`request`] | the application's "start the bootloader" word in RAM |
//! | [`staging`] | the FoE file store of the bootloader: a received file into the staging area, checked |
//! | [`install`] | what the bootloader does at reset: check, install from staging, start or stay |
//! | [`crate::stacks::ethercat::boot_slave`] | the bootloader's EtherCAT slave: INIT and BOOT, FoE on the bootstrap mailbox |
//!
//! Never bricked: the bootloader (sectors 0..=2) is never written by itself. A file goes to
//! the staging area first and is checked there (identity, length, CRC) before the
//! application is touched; its first kilobyte, which holds the header, is written last, so
//! a staging area or application slot whose writing was cut short has no valid header. At
//! reset a valid staged image that differs from the application is installed (application
//! slot erased from its first sector, written from the back, the header's kilobyte last,
//! verified), then the staging area is erased. Any cut leaves a valid application, a valid
//! staged image, or neither, and in every case the bootloader starts and accepts an update.

pub mod crc32;
pub mod header;
pub mod install;
pub mod layout;
pub mod request;
pub mod staging;

#[cfg(test)]
mod power_cut;
