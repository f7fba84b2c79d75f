//! The module's memory layout in the ESC: the SyncManagers (0x1C00, SII, ESI, and what the
//! application checks at INIT -> PREOP and PREOP -> SAFEOP), and the bootstrap mailbox of
//! the BOOT state, which is the bootloader's (`crate::platform::boot::layout`).

use crate::io::analog::process_data::{MAX_IMAGE, MAX_INPUT_IMAGE, MAX_OUTPUT_IMAGE};
use crate::platform::boot::layout::MAILBOX_CONTROL;
use crate::stacks::ethercat::mailbox::MAILBOX_SIZE;
use coe_core::device::{SmRole, SyncManagerDesc};

pub use crate::platform::boot::layout::BOOTSTRAP_MAILBOX;

/// SyncManagers: the two mailboxes of [`MAILBOX_SIZE`] bytes, then the process-data
/// buffers, all in the first 8 KB of the ESC address space so the SPI PDI reaches them with
/// 2-byte addresses. The defaults are [`MAX_IMAGE`] bytes; with oversampling the master
/// sizes them up to [`MAX_INPUT_IMAGE`] at 0x1180 (three buffers end at 0x1AEA) and
/// [`MAX_OUTPUT_IMAGE`] at 0x1C00 (three buffers end at 0x1EBE).
pub const SYNC_MANAGERS: [SyncManagerDesc; 4] = [
    SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, MAILBOX_SIZE as u16, MAILBOX_CONTROL.0),
    SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, MAILBOX_SIZE as u16, MAILBOX_CONTROL.1),
    SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1C00, MAX_IMAGE as u16, 0x64),
    SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1180, MAX_IMAGE as u16, 0x20),
];

// Three buffers of the largest images fit, apart, below 0x2000.
const _: () = assert!(0x1180 + 3 * MAX_INPUT_IMAGE <= 0x1C00);
const _: () = assert!(0x1C00 + 3 * MAX_OUTPUT_IMAGE <= 0x2000);
