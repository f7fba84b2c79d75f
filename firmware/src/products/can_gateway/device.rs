//! The gateway's device description: the analog products' ESC setup
//! ([`analog_io::device::description`]: SII, mailboxes, PDI, EEPROM) with the gateway's
//! identity, names, layout, dictionary, DC op modes and CoE details; the SII image and the
//! ESI file are generated from it (`cargo xtask esi --product can-gateway`).

use super::identity::{IDENTITY, NAMES};
use super::layout::SYNC_MANAGERS;
use super::od::OD;
use super::sync::MIN_CYCLE_TIME_NS;
use crate::products::analog_io;
use crate::stacks::ethercat::op_modes::{dc_sync0, sm_synchron, FREE_RUN};
use coe_core::device::{CoeDetails, DcDesc, DcOpMode, DeviceDescription, MailboxDesc};

/// DC op modes, the default (SM-synchronous: the CAN cycle at the SM2 event) first.
const OP_MODES: &[DcOpMode] = &[
    sm_synchron("SM-Synchron (CAN cycle at the SM2 event)"),
    dc_sync0("DC", "DC-Synchron (CAN cycle at SYNC0)"),
    FREE_RUN,
];

const ANALOG_IO: DeviceDescription =
    analog_io::device::description(IDENTITY, NAMES, &OD, &SYNC_MANAGERS);

/// The gateway.
pub static DEVICE: DeviceDescription = DeviceDescription {
    mailbox: MailboxDesc {
        // The nodes' PDO layouts are the gateway's configuration (0x8000 + 16n), not
        // mappings a master writes.
        coe: CoeDetails(
            CoeDetails::SDO
                | CoeDetails::SDO_INFO
                | CoeDetails::PDO_ASSIGN
                | CoeDetails::COMPLETE_ACCESS,
        ),
        ..ANALOG_IO.mailbox
    },
    dc: DcDesc {
        op_modes: OP_MODES,
        min_cycle_ns: MIN_CYCLE_TIME_NS,
        ..ANALOG_IO.dc
    },
    ..ANALOG_IO
};

const _: () = if let Err(e) = DEVICE.validate() {
    panic!("{}", e.message())
};
