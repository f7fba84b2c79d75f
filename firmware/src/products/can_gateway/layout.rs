//! The gateway's memory layout in the ESC: the two mailboxes and the process-data buffers,
//! each with room for the largest image the PDO assignment can make.

use super::modules::{MAX_NODES, NODE_BYTES, STATUS_BYTES};
use crate::stacks::ethercat::mailbox::MAILBOX_SYNC_MANAGERS;
use coe_core::device::{SmRole, SyncManagerDesc};

/// The largest output image: every node's outputs.
pub const MAX_OUTPUT_IMAGE: usize = MAX_NODES * NODE_BYTES;
/// The largest input image: the status and every node's inputs.
pub const MAX_INPUT_IMAGE: usize = STATUS_BYTES + MAX_NODES * NODE_BYTES;

/// SyncManagers: the mailboxes as the analog products have them (the bootloader's BOOT
/// mailbox is the same), then SM2 and SM3 (three buffers each), all below 0x2000 so the
/// SPI PDI reaches them with 2-byte addresses.
pub const SYNC_MANAGERS: [SyncManagerDesc; 4] = [
    MAILBOX_SYNC_MANAGERS[0],
    MAILBOX_SYNC_MANAGERS[1],
    SyncManagerDesc::new(
        SmRole::ProcessDataOut,
        0x1100,
        MAX_OUTPUT_IMAGE as u16,
        0x64,
    ),
    SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1400, MAX_INPUT_IMAGE as u16, 0x20),
];

// Three buffers of each process-data SM fit before the next.
const _: () = assert!(0x1100 + 3 * MAX_OUTPUT_IMAGE <= 0x1400);
const _: () = assert!(0x1400 + 3 * MAX_INPUT_IMAGE <= 0x2000);
