//! The module's device description: identity, names, SyncManager/FMMU layout, mailbox, DC
//! op modes, PDI configuration and EEPROM size, with the object dictionary ([`OD`]) it
//! points at; the single source the SII image (`coe_core::sii`) and the ESI XML
//! (`coe_core::esi`) are generated from, and the one the application is configured from
//! ([`super::CONFIG`], [`super::process_data`]). Change a value here (or in the modules it
//! is made of) and all of them follow. `analog-io-can` has the same description with its
//! own identity, names and dictionary ([`description`]).

use super::identity::{IDENTITY, NAMES};
use super::layout::{BOOTSTRAP_MAILBOX, SYNC_MANAGERS};
use super::od::OD;
use super::sync::MIN_CYCLE_TIME_NS;
use crate::platform::board::{EEPROM_BYTES, PDI};
use crate::stacks::ethercat::op_modes::{dc_sync0, sm_synchron, FREE_RUN};
use coe_core::device::{
    CoeDetails, DcDesc, DcOpMode, DeviceDescription, EepromDesc, FmmuUsage, Identity, MailboxDesc,
    MailboxProtocols, MemoryWindow, Names, PortType, SyncManagerDesc,
};
use coe_core::od::ObjectDictionary;

/// DC op modes, the default (SM-synchronous, as the application starts) first.
const OP_MODES: &[DcOpMode] = &[
    sm_synchron("SM-Synchron (outputs on the SM2 event)"),
    dc_sync0("DC", "DC-Synchron (outputs latched at SYNC0)"),
    FREE_RUN,
];

/// The module.
pub static DEVICE: DeviceDescription = description(IDENTITY, NAMES, &OD, &SYNC_MANAGERS);

/// The description of an analog module with `identity`, `names`, dictionary `od` and the
/// SyncManagers `sync_managers` (the layout's, with the room its PDOs need).
pub const fn description(
    identity: Identity,
    names: Names,
    od: &'static ObjectDictionary,
    sync_managers: &'static [SyncManagerDesc],
) -> DeviceDescription {
    DeviceDescription {
        identity,
        names,
        od,
        sync_managers,
        fmmus: &[
            FmmuUsage::Outputs,
            FmmuUsage::Inputs,
            FmmuUsage::MailboxState,
        ],
        mailbox: MailboxDesc {
            // FoE: firmware updates in BOOT (the bootloader; the application answers FoE with
            // "bootstrap only").
            protocols: MailboxProtocols(MailboxProtocols::COE | MailboxProtocols::FOE),
            coe: CoeDetails(
                CoeDetails::SDO
                    | CoeDetails::SDO_INFO
                    | CoeDetails::PDO_ASSIGN
                    | CoeDetails::PDO_CONFIG
                    | CoeDetails::COMPLETE_ACCESS,
            ),
            bootstrap: Some(BOOTSTRAP_MAILBOX),
        },
        dc: DcDesc {
            op_modes: OP_MODES,
            min_cycle_ns: MIN_CYCLE_TIME_NS,
            // No upper limit in the firmware beyond the u32 of 0x1C32:02.
            max_cycle_ns: u32::MAX,
        },
        pdi: PDI,
        eeprom: EepromDesc {
            size_bytes: EEPROM_BYTES,
            station_alias: 0,
            version: 1,
        },
        // ET1100: 8 KB process RAM from 0x1000.
        process_ram: MemoryWindow::new(0x1000, 0x2000),
        ports: [PortType::Mii, PortType::Mii, PortType::None, PortType::None],
        ebus_current_ma: 0,
    }
}

const _: () = if let Err(e) = DEVICE.validate() {
    panic!("{}", e.message())
};

#[cfg(test)]
mod tests;
