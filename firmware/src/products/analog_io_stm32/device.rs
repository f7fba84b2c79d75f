//! The module's device description: `analog-io`'s ([`analog_io::device::description`])
//! with this product's identity, names and dictionary (no oversampling PDOs: the
//! SyncManagers' room for the plain ones), the board's µC PDI (SII words 0/1 0x0E08 /
//! 0x0600) and a mailbox with CoE only: no FoE, no bootstrap mailbox.

use super::identity::{IDENTITY, NAMES};
use super::od::OD;
use crate::platform::stm32f1::esc_pdi;
use crate::products::analog_io;
use coe_core::device::{DeviceDescription, MailboxDesc, MailboxProtocols};

const ANALOG_IO: DeviceDescription = analog_io::device::description(
    IDENTITY,
    NAMES,
    &OD,
    &analog_io::layout::PLAIN_SYNC_MANAGERS,
);

/// The module.
pub static DEVICE: DeviceDescription = DeviceDescription {
    pdi: esc_pdi::PDI,
    mailbox: MailboxDesc {
        // No FoE: the board has no bootloader to take update files.
        protocols: MailboxProtocols(MailboxProtocols::COE),
        bootstrap: None,
        ..ANALOG_IO.mailbox
    },
    ..ANALOG_IO
};

const _: () = if let Err(e) = DEVICE.validate() {
    panic!("{}", e.message())
};
