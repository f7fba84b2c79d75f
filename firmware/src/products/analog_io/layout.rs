//! The module's memory layout in the ESC: the SyncManagers (0x1C00, SII, ESI, and what the
//! application checks at INIT -> PREOP and PREOP -> SAFEOP), and the bootstrap mailbox of
//! the BOOT state, which is the bootloader's (`crate::platform::boot::layout`).

use crate::io::analog::process_data::{MAX_IMAGE, MAX_INPUT_IMAGE, MAX_OUTPUT_IMAGE};
use crate::stacks::ethercat::mailbox::MAILBOX_SYNC_MANAGERS;
use coe_core::device::{SmRole, SyncManagerDesc};

pub use crate::platform::boot::layout::BOOTSTRAP_MAILBOX;

/// SyncManagers: the two mailboxes ([`MAILBOX_SYNC_MANAGERS`]), then the process-data
/// buffers, all in the first 8 KB of the ESC address space so the SPI PDI reaches them with
/// 2-byte addresses. Each process-data SyncManager's room is the largest image of the
/// build: [`MAX_OUTPUT_IMAGE`] at 0x1C00 (three buffers end at 0x1EBE with oversampling)
/// and [`MAX_INPUT_IMAGE`] at 0x1180 (three buffers end at 0x180A); the ESI gives them as
/// `MaxSize`, so a configuration tool takes the op modes' oversampling images. The default
/// lengths (SII, ESI `DefaultSize`) are those of the default PDOs.
pub const SYNC_MANAGERS: [SyncManagerDesc; 4] =
    sync_managers(MAX_OUTPUT_IMAGE as u16, MAX_INPUT_IMAGE as u16);

/// The same layout with room for the plain images only ([`MAX_IMAGE`]): the description of
/// a product whose dictionary has no oversampling PDOs (`analog-io-can`).
pub const PLAIN_SYNC_MANAGERS: [SyncManagerDesc; 4] =
    sync_managers(MAX_IMAGE as u16, MAX_IMAGE as u16);

const fn sync_managers(output_room: u16, input_room: u16) -> [SyncManagerDesc; 4] {
    let [mbx_out, mbx_in] = MAILBOX_SYNC_MANAGERS;
    [
        mbx_out,
        mbx_in,
        SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1C00, output_room, 0x64),
        SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1180, input_room, 0x20),
    ]
}

// Three buffers of the largest images fit, apart, below 0x2000.
const _: () = assert!(0x1180 + 3 * MAX_INPUT_IMAGE <= 0x1C00);
const _: () = assert!(0x1C00 + 3 * MAX_OUTPUT_IMAGE <= 0x2000);
