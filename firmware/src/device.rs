//! The module's device description: the single source of truth for identity, names,
//! SyncManager/FMMU layout, mailbox, DC op modes, PDI configuration and EEPROM size, with
//! the object dictionary ([`crate::od::OD`]) it points at.
//!
//! The firmware's [`AppConfig`] and default [`ProcessData`] are derived from it here, the SII
//! image is generated from it (`coe_core::sii`), and the ESI XML as well; change a value here
//! and all of them follow.

use crate::app::mailbox::MAILBOX_SIZE;
use crate::app::process_data::{Mapping, ProcessData, MAX_IMAGE, RX_PDOS, TX_PDOS};
use crate::app::sync::MIN_CYCLE_TIME_NS;
use crate::app::{AppConfig, SmExpect};
use crate::od::{self, OD};
use coe_core::device::{
    CoeDetails, DcDesc, DcOpMode, DeviceDescription, EepromDesc, FmmuUsage, Identity, MailboxDesc,
    MailboxProtocols, MemoryWindow, Names, PdiConfig, PinDriver, PortType, SmRole, SyncManagerDesc,
    SyncPin, PDI_SPI_SLAVE,
};

/// Vendor ID.
///
/// PLACEHOLDER: 0 is not an ETG-assigned vendor ID. A product must replace it with the
/// manufacturer's own ID from the EtherCAT Technology Group before it ships (the thesis
/// board borrowed Beckhoff's ID 2; this project must not). This is the only place it is set.
pub const VENDOR_ID: u32 = 0x0000_0000;

/// Identity (0x1018 and SII words 8..15): placeholder vendor, the project's own product code.
pub const IDENTITY: Identity = Identity {
    vendor_id: VENDOR_ID,
    product_code: 0x0000_1754,
    revision: 0x0001_0000,
    serial_number: 0,
};

/// Names and versions (0x1008..0x100A, SII strings, ESI).
pub const NAMES: Names = Names {
    vendor_name: "Placeholder vendor (no ETG vendor ID)",
    device_name: "Analog IO 8AI 2AO",
    order_code: "AIO-8AI2AO",
    group_type: "AnalogIO",
    group_name: "Analog I/O",
    hardware_version: "LPC1754+ET1100 rev A",
    software_version: env!("CARGO_PKG_VERSION"),
};

/// SyncManagers: the two mailboxes of [`MAILBOX_SIZE`] bytes, then the process-data
/// buffers with room for [`MAX_IMAGE`] bytes each (three buffers), all in the first 8 KB of
/// the ESC address space so the SPI PDI reaches them with 2-byte addresses.
pub const SYNC_MANAGERS: [SyncManagerDesc; 4] = [
    SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, MAILBOX_SIZE as u16, 0x26),
    SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, MAILBOX_SIZE as u16, 0x22),
    SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, MAX_IMAGE as u16, 0x64),
    SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1180, MAX_IMAGE as u16, 0x20),
];

/// DC op modes, the default (SM-synchronous, as the application starts) first.
const OP_MODES: &[DcOpMode] = &[
    DcOpMode {
        name: "SM-Synchron",
        description: "SM-Synchron (outputs on the SM2 event)",
        assign_activate: 0,
        sync_mode: 1,
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
        sync_mode: 2,
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
        sync_mode: 0,
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
        protocols: MailboxProtocols(MailboxProtocols::COE),
        coe: CoeDetails(
            CoeDetails::SDO
                | CoeDetails::SDO_INFO
                | CoeDetails::PDO_ASSIGN
                | CoeDetails::PDO_CONFIG
                | CoeDetails::COMPLETE_ACCESS,
        ),
        bootstrap: None,
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

/// What the application expects of SM0..SM3: start and control byte from the layout, the
/// mailbox sizes; process-data lengths follow the PDO configuration (0 here).
pub const fn sm_expect() -> [SmExpect; 4] {
    let mut out = [SmExpect {
        start: 0,
        len: 0,
        control: 0,
    }; 4];
    let mut i = 0;
    while i < 4 {
        let sm = &SYNC_MANAGERS[i];
        out[i] = SmExpect {
            start: sm.start,
            len: if sm.role.is_mailbox() { sm.len } else { 0 },
            control: sm.control,
        };
        i += 1;
    }
    out
}

/// The application configuration.
pub const fn app_config() -> AppConfig {
    AppConfig {
        sm: sm_expect(),
        device_id: None,
    }
}

/// The default PDO configuration: the mapping objects with their default entries and the
/// assignments, from the constants the dictionary's defaults of 0x1600../0x1A00../
/// 0x1C12/0x1C13 are made of ([`od::RX_DEFAULTS`] and friends); a host test reads it back
/// against the dictionary. (Walking the dictionary here cost about 0.5 KB of flash.)
pub fn process_data() -> ProcessData {
    let rx: [Mapping; RX_PDOS] =
        core::array::from_fn(|i| Mapping::with_entries(od::RX_MAPPINGS[i], od::RX_DEFAULTS[i]));
    let tx: [Mapping; TX_PDOS] =
        core::array::from_fn(|i| Mapping::with_entries(od::TX_MAPPINGS[i], od::TX_DEFAULTS[i]));
    ProcessData::new(rx, tx, &od::RX_ASSIGN_DEFAULT, &od::TX_ASSIGN_DEFAULT)
}

#[cfg(test)]
mod tests;
