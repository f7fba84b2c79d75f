//! The module's device description: identity, names, SyncManager/FMMU layout, mailbox, DC
//! op modes, PDI configuration and EEPROM size, with the object dictionary ([`OD`]) it
//! points at; the single source the SII image (`coe_core::sii`) and the ESI XML
//! (`coe_core::esi`) are generated from, and the one the application is configured from
//! (`crate::stacks::ethercat::AppConfig::product`, `crate::io::analog::process_data::ProcessData::product_default`).
//! Change a value here (or in the modules it is made of) and all of them follow.

use super::identity::{IDENTITY, NAMES};
use super::layout::{BOOTSTRAP_MAILBOX, SYNC_MANAGERS};
use super::od::OD;
use super::sync::{MIN_CYCLE_TIME_NS, SYNC_MODE_DC_SYNC0, SYNC_MODE_FREE_RUN, SYNC_MODE_SM};
use coe_core::device::{
    CoeDetails, DcDesc, DcOpMode, DeviceDescription, EepromDesc, FmmuUsage, MailboxDesc,
    MailboxProtocols, MemoryWindow, PdiConfig, PinDriver, PortType, SyncPin, PDI_SPI_SLAVE,
};

/// DC op modes, the default (SM-synchronous, as the application starts) first.
const OP_MODES: &[DcOpMode] = &[
    DcOpMode {
        name: "SM-Synchron",
        description: "SM-Synchron (outputs on the SM2 event)",
        assign_activate: 0,
        sync_mode: SYNC_MODE_SM,
        cycle_time_sync0: 0,
        sync0_factor: 0,
        shift_time_sync0: 0,
        sync1_factor: 0,
        shift_time_sync1: 0,
    },
    DcOpMode {
        name: "DC",
        description: "DC-Synchron (outputs latched at SYNC0)",
        assign_activate: 0x0300,
        sync_mode: SYNC_MODE_DC_SYNC0,
        cycle_time_sync0: 0,
        sync0_factor: 1,
        shift_time_sync0: 0,
        sync1_factor: 0,
        shift_time_sync1: 0,
    },
    DcOpMode {
        name: "FreeRun",
        description: "Free Run",
        assign_activate: 0,
        sync_mode: SYNC_MODE_FREE_RUN,
        cycle_time_sync0: 0,
        sync0_factor: 0,
        shift_time_sync0: 0,
        sync1_factor: 0,
        shift_time_sync1: 0,
    },
];

/// The board's PDI: SPI mode 3, SPI_IRQ push-pull active low (falling-edge GPIO interrupt
/// on P0.22), SYNC0 push-pull active high into the CAP1.0 timer capture, 1 us SYNC pulses
/// (hardware-facts 10.C: SII words 0x0E05 / 0x0603 / 0x0064).
pub const PDI: PdiConfig = PdiConfig {
    pdi_type: PDI_SPI_SLAVE,
    enhanced_link_detect: true,
    dc_sync_unit: true,
    dc_latch_unit: true,
    spi_mode: 3,
    irq: PinDriver::PushPullActiveLow,
    sel_active_high: false,
    miso_late_sample: false,
    sync0: SyncPin {
        driver: PinDriver::PushPullActiveHigh,
        output: true,
        to_al_event: false,
    },
    sync1: SyncPin {
        driver: PinDriver::PushPullActiveLow,
        output: false,
        to_al_event: false,
    },
    sync_pulse_10ns: 100,
    extended: 0,
};

/// The module.
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
    // 16 Kbit (2 KB) SII EEPROM.
    eeprom: EepromDesc {
        size_bytes: 2048,
        station_alias: 0,
        version: 1,
    },
    // ET1100: 8 KB process RAM from 0x1000.
    process_ram: MemoryWindow::new(0x1000, 0x2000),
    ports: [PortType::Mii, PortType::Mii, PortType::None, PortType::None],
    ebus_current_ma: 0,
};

const _: () = if let Err(e) = DEVICE.validate() {
    panic!("{}", e.message())
};

#[cfg(test)]
mod tests;
