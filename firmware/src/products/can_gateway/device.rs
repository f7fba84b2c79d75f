//! The gateway's device description: the analog products' ESC setup (SII, mailboxes, DC
//! modes, PDI, EEPROM) with the gateway's identity, names, layout and dictionary; the SII
//! image and the ESI file are generated from it (`cargo xtask esi --product can-gateway`).

use super::identity::{IDENTITY, NAMES};
use super::layout::{BOOTSTRAP_MAILBOX, SYNC_MANAGERS};
use super::od::OD;
use super::sync::MIN_CYCLE_TIME_NS;
use crate::platform::board::{EEPROM_BYTES, PDI};
use crate::stacks::ethercat::op_modes::{dc_sync0, sm_synchron, FREE_RUN};
use coe_core::device::{
    CoeDetails, DcDesc, DcOpMode, DeviceDescription, EepromDesc, FmmuUsage, MailboxDesc,
    MailboxProtocols, MemoryWindow, PortType,
};

/// DC op modes, the default (SM-synchronous: the CAN cycle at the SM2 event) first.
const OP_MODES: &[DcOpMode] = &[
    sm_synchron("SM-Synchron (CAN cycle at the SM2 event)"),
    dc_sync0("DC", "DC-Synchron (CAN cycle at SYNC0)"),
    FREE_RUN,
];

/// The gateway.
pub static DEVICE: DeviceDescription = DeviceDescription {
    identity: IDENTITY,
    names: NAMES,
    od: &OD,
    sync_managers: &SYNC_MANAGERS,
    fmmus: &[
        FmmuUsage::Outputs,
        FmmuUsage::Inputs,
        FmmuUsage::MailboxState,
    ],
    mailbox: MailboxDesc {
        protocols: MailboxProtocols(MailboxProtocols::COE | MailboxProtocols::FOE),
        coe: CoeDetails(
            CoeDetails::SDO
                | CoeDetails::SDO_INFO
                | CoeDetails::PDO_ASSIGN
                | CoeDetails::COMPLETE_ACCESS,
        ),
        bootstrap: Some(BOOTSTRAP_MAILBOX),
    },
    dc: DcDesc {
        op_modes: OP_MODES,
        min_cycle_ns: MIN_CYCLE_TIME_NS,
        max_cycle_ns: u32::MAX,
    },
    pdi: PDI,
    eeprom: EepromDesc {
        size_bytes: EEPROM_BYTES,
        station_alias: 0,
        version: 1,
    },
    process_ram: MemoryWindow::new(0x1000, 0x2000),
    ports: [PortType::Mii, PortType::Mii, PortType::None, PortType::None],
    ebus_current_ma: 0,
};

const _: () = if let Err(e) = DEVICE.validate() {
    panic!("{}", e.message())
};
