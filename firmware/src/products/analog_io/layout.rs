//! The module's memory layout in the ESC: the SyncManagers (0x1C00, SII, ESI, and what the
//! application checks at INIT -> PREOP and PREOP -> SAFEOP) and the bootstrap mailbox of the
//! BOOT state (SII, ESI, and what the application and the bootloader check at INIT -> BOOT).

use super::capacity::{BOOTSTRAP_MAILBOX_SIZE, MAILBOX_SIZE, MAX_IMAGE};
use coe_core::device::{MemoryWindow, SmRole, SyncManagerDesc};

/// SyncManagers: the two mailboxes of [`MAILBOX_SIZE`] bytes, then the process-data
/// buffers with room for [`MAX_IMAGE`] bytes each (three buffers), all in the first 8 KB of
/// the ESC address space so the SPI PDI reaches them with 2-byte addresses.
pub const SYNC_MANAGERS: [SyncManagerDesc; 4] = [
    SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, MAILBOX_SIZE as u16, 0x26),
    SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, MAILBOX_SIZE as u16, 0x22),
    SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, MAX_IMAGE as u16, 0x64),
    SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1180, MAX_IMAGE as u16, 0x20),
];

/// The bootstrap mailbox (BOOT state, FoE only; SII words 0x14..0x17, ESI `BootStrap`):
/// master -> slave at 0x1000, slave -> master right after it. The process-data buffers it
/// covers are not in use in BOOT.
pub const BOOTSTRAP_MAILBOX: (MemoryWindow, MemoryWindow) = (
    MemoryWindow::new(0x1000, BOOTSTRAP_MAILBOX_SIZE as u16),
    MemoryWindow::new(
        0x1000 + BOOTSTRAP_MAILBOX_SIZE as u16,
        BOOTSTRAP_MAILBOX_SIZE as u16,
    ),
);
