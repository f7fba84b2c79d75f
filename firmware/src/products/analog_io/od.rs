//! The module's object dictionary (CiA 301 communication area, ETG.1020 sync objects,
//! CiA 401 analog I/O, manufacturer objects).
//!
//! The default PDO assignment and mappings live here as the defaults of 0x1C12/0x1C13 and
//! 0x16xx/0x1Axx, made of the constants [`RX_DEFAULTS`], [`TX_DEFAULTS`] and the assignment
//! constants, and nowhere else: the SII image and the ESI file read them from this table
//! through [`super::device::DEVICE`]; the firmware's default process data
//! (`crate::io::analog::process_data::ProcessData::product_default`) is built from the same
//! constants (a host test reads it back against the table). Identity, names, SyncManager
//! types, channel counts and sync figures come from the other modules of
//! [`crate::products::analog_io`], so each value is written once.
//!
//! Which entries the application serves live (and which read as their default) is
//! documented in `crate::io::analog::objects`.

use super::can::{
    AI_INTERRUPT_ENABLE_INDEX, COMM_DEFAULTS, HEARTBEAT_CONSUMERS, PROCESS_DATA_SOURCE_INDEX,
    SOURCE_CAN, SOURCE_ETHERCAT,
};
use super::capacity::{AI_CHANNELS, AO_CHANNELS, ERROR_HISTORY, PDO_ENTRIES, RX_PDOS, TX_PDOS};
use super::identity::{IDENTITY, NAMES};
use super::layout::SYNC_MANAGERS;
use super::sync::{
    DEFAULT_SYNC_ERROR_LIMIT, INPUT_CALC_COPY_NS, MIN_CYCLE_TIME_NS, OUTPUT_CALC_COPY_NS,
    OUTPUT_DELAY_NS, SUPPORTED_MODES, SYNC_MODE_SM, SYNC_MODE_SM2_INPUTS,
};
use crate::platform::board::FULL_SCALE_UV;
use coe_core::canopen::objects::CommObjects;
use coe_core::od::{
    Access, DataType, EntryDefault, EntryDesc, ObjectDesc, ObjectDictionary, Value, ValueRange,
};
use coe_core::pdo::PdoEntry;

const BOOL: DataType = DataType::Boolean;
const I16: DataType = DataType::Integer16;
const I32: DataType = DataType::Integer32;
const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const RO: Access = Access::RO;
const RW: Access = Access::RW;
const RWP: Access = Access::RW_PREOP;

/// Manufacturer settings object (RECORD): sub 1 "AI filter" UNSIGNED8 ([`AI_FILTER_LATEST`],
/// [`AI_FILTER_AVERAGE`]), sub 2 the full scale in uV (a constant).
pub const SETTINGS_INDEX: u16 = 0x2000;
/// AI filter (`SETTINGS_INDEX`:01) value: 0x6401 is the newest sample (the default).
pub const AI_FILTER_LATEST: u8 = 0;
/// AI filter value: 0x6401 is the rounded mean of the samples of the cycle.
pub const AI_FILTER_AVERAGE: u8 = 1;

/// Index of the module description string (manufacturer area).
pub const MODULE_DESCRIPTION_INDEX: u16 = 0x2001;

/// The module description (0x2001): longer than the mailbox data area, so a master reads it
/// with a segmented SDO upload.
pub const MODULE_DESCRIPTION: &str = concat!(
    "EtherCAT analog I/O module: 8 analog inputs 0..10 V (AD7689, 16 bit, 1/4 divider, ",
    "2.5 V reference; 0x6401 = code >> 1, 0x7FFF = 10 V) and 2 analog outputs 0..10 V ",
    "(AD5663, x4 amplifier; 0x6411, 0x7FFF = 10 V, negative values clamp to 0 V). ",
    "LPC1754 + ET1100 on SPI. CoE with SDO, SDO Information, complete access and ",
    "configurable PDOs; free run, SM2-synchronous or DC SYNC0 (outputs latched at SYNC0). ",
    "Fault values per output in 0x6443/0x6444. Firmware ",
    env!("CARGO_PKG_VERSION"),
    "."
);

/// The AI entries 0x6401:`first`..`first + N - 1`.
const fn ai_entries<const N: usize>(first: u8) -> [PdoEntry; N] {
    let mut out = [PdoEntry::new(0, 0, 0); N];
    let mut i = 0;
    while i < N {
        out[i] = PdoEntry::new(0x6401, first + i as u8, 16);
        i += 1;
    }
    out
}

/// The AI default TxPDO of EtherCAT: 0x1A00 -> 0x6401:01..08.
const TXPDO_DEFAULT: [PdoEntry; AI_CHANNELS] = ai_entries(1);
/// CiA 401 TPDO 2 and 3 (one CAN frame each): 0x6401:01..04 and 0x6401:05..08.
const TXPDO_AI_1_4: [PdoEntry; 4] = ai_entries(1);
const TXPDO_AI_5_8: [PdoEntry; 4] = ai_entries(5);

/// The AO default RxPDO: 0x6411:01..02 (EtherCAT's 0x1600, CiA 401 RPDO 2's 0x1601).
const RXPDO_DEFAULT: [PdoEntry; AO_CHANNELS] =
    [PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)];

/// The RxPDO mapping objects and their default entries: 0x1600 the EtherCAT default,
/// 0x1601 CiA 401 RPDO 2 ([`super::can`]), both the two outputs.
pub const RX_MAPPINGS: [u16; RX_PDOS] = [0x1600, 0x1601];
/// Default entries of [`RX_MAPPINGS`].
pub const RX_DEFAULTS: [&[PdoEntry]; RX_PDOS] = [&RXPDO_DEFAULT, &RXPDO_DEFAULT];
/// The TxPDO mapping objects and their default entries: 0x1A00 the EtherCAT default (all
/// eight inputs), 0x1A01/0x1A02 CiA 401 TPDO 2/3 (four inputs each, one CAN frame).
pub const TX_MAPPINGS: [u16; TX_PDOS] = [0x1A00, 0x1A01, 0x1A02];
/// Default entries of [`TX_MAPPINGS`].
pub const TX_DEFAULTS: [&[PdoEntry]; TX_PDOS] = [&TXPDO_DEFAULT, &TXPDO_AI_1_4, &TXPDO_AI_5_8];
/// The default RxPDO assignment (0x1C12).
pub const RX_ASSIGN_DEFAULT: [u16; 1] = [RX_MAPPINGS[0]];
/// The default TxPDO assignment (0x1C13).
pub const TX_ASSIGN_DEFAULT: [u16; 1] = [TX_MAPPINGS[0]];

const SUB_NAMES: [&str; 8] = [
    "SubIndex 001",
    "SubIndex 002",
    "SubIndex 003",
    "SubIndex 004",
    "SubIndex 005",
    "SubIndex 006",
    "SubIndex 007",
    "SubIndex 008",
];

/// Sub 0 plus `N - 1` entries of `data_type`, named from `names`, with `defaults` as the
/// defaults of the first entries and sub 0 = `count`.
const fn entries<const N: usize>(
    count: u8,
    names: &[&'static str],
    data_type: DataType,
    access: Access,
    defaults: &[u32],
) -> [EntryDesc; N] {
    let mut out = [EntryDesc::count(count); N];
    let mut i = 1;
    while i < N {
        let mut e = EntryDesc::new(i as u8, names[i - 1], data_type, access);
        if i - 1 < defaults.len() {
            e = e.with_default(Value::Uint(defaults[i - 1] as u64));
        }
        out[i] = e;
        i += 1;
    }
    out
}

/// The entries of every PDO mapping object (0x1600.., 0x1A00..): sub 0 and
/// [`PDO_ENTRIES`] u32 slots, writable in PREOP; each object's default mapping is its own
/// ([`mapping_defaults`]).
static MAPPING: [EntryDesc; PDO_ENTRIES + 1] = {
    let mut out = entries(0, &SUB_NAMES, U32, RWP, &[]);
    out[0] = out[0].with_access(RWP);
    out
};

/// A mapping object's own defaults: sub 0 the number of entries (`N - 1`), subs 1.. the
/// entries.
const fn mapping_defaults<const N: usize>(mapped: &[PdoEntry]) -> [EntryDefault; N] {
    let mut out = [EntryDefault::new(0, (N - 1) as u32); N];
    let mut i = 1;
    while i < N {
        out[i] = EntryDefault::new(i as u8, mapped[i - 1].to_u32());
        i += 1;
    }
    out
}

/// A PDO assignment object's entries: sub 0 and `N` u16 slots, writable in PREOP.
const fn assignment<const N: usize>(defaults: &[u16]) -> [EntryDesc; N] {
    let mut words = [0u32; N];
    let mut i = 0;
    while i < defaults.len() && i < N {
        words[i] = defaults[i] as u32;
        i += 1;
    }
    let mut out = entries(i as u8, &SUB_NAMES, U16, RWP, words.split_at(i).0);
    out[0] = out[0].with_access(RWP);
    out
}

/// 0x1003 (CiA 301 7.5.2.3, `coe_core::error_history`): sub 0 the number of errors, written
/// 0 to clear the history (any state), subs 1.. the errors, newest first, read-only.
static ERROR_FIELD: [EntryDesc; ERROR_HISTORY + 1] = {
    let mut out = entries(0, &SUB_NAMES, U32, RO, &[]);
    out[0] = out[0].with_access(RW);
    out
};

/// The default mappings: both RxPDO mapping objects have the same ([`RX_DEFAULTS`]; the
/// host tests read the dictionary's defaults back against the process data's).
static RXPDO_DEFAULTS: [EntryDefault; AO_CHANNELS + 1] = mapping_defaults(&RXPDO_DEFAULT);
static TXPDO_1_DEFAULTS: [EntryDefault; AI_CHANNELS + 1] = mapping_defaults(TX_DEFAULTS[0]);
static TXPDO_2_DEFAULTS: [EntryDefault; TXPDO_AI_1_4.len() + 1] = mapping_defaults(TX_DEFAULTS[1]);
static TXPDO_3_DEFAULTS: [EntryDefault; TXPDO_AI_5_8.len() + 1] = mapping_defaults(TX_DEFAULTS[2]);

/// The CAN communication objects (0x1005.., 0x1400.., 0x1800..) with the product's
/// defaults ([`super::can::COMM_DEFAULTS`]).
static CAN: CommObjects<RX_PDOS, TX_PDOS, { HEARTBEAT_CONSUMERS + 1 }> =
    CommObjects::new(&COMM_DEFAULTS);
static RX_ASSIGN: [EntryDesc; RX_PDOS + 1] = assignment(&RX_ASSIGN_DEFAULT);
static TX_ASSIGN: [EntryDesc; TX_PDOS + 1] = assignment(&TX_ASSIGN_DEFAULT);

/// 0x1C00: the communication type of each SyncManager, from the SyncManager layout.
static SM_TYPES: [EntryDesc; 5] = {
    let types = [
        SYNC_MANAGERS[0].role.sii_type() as u32,
        SYNC_MANAGERS[1].role.sii_type() as u32,
        SYNC_MANAGERS[2].role.sii_type() as u32,
        SYNC_MANAGERS[3].role.sii_type() as u32,
    ];
    let mut out = entries(4, &SUB_NAMES, U8, RO, &types);
    out[0] = out[0].with_default(Value::Uint(4));
    out
};

/// 0x1C32 (outputs) / 0x1C33 (inputs), ETG.1020 "SM synchronisation": the subindices the
/// application's sync monitor serves (`crate::stacks::ethercat::sync::SyncMonitor`, which a test holds
/// to this description), with the figures of [`super::sync`] as defaults; the sync mode,
/// calc and copy time and delay time are each object's own ([`SYNC_OUTPUT_DEFAULTS`],
/// [`SYNC_INPUT_DEFAULTS`]).
/// 0x0E..=0x12 (RxPDO toggle failed, cycle and SM sync distances) are optional in ETG.1020 and
/// not measured here, so they are absent (a gap before 0x20; sub 0 stays 0x20).
static SYNC_PARAMETERS: [EntryDesc; 15] = [
    EntryDesc::new(0, "SubIndex 000", U8, RO).with_default(Value::Uint(0x20)),
    EntryDesc::new(1, "Sync mode", U16, RWP),
    EntryDesc::new(2, "Cycle time", U32, RWP).with_default(Value::Uint(0)),
    EntryDesc::new(3, "Shift time", U32, RO).with_default(Value::Uint(0)),
    EntryDesc::new(4, "Sync modes supported", U16, RO)
        .with_default(Value::Uint(SUPPORTED_MODES as u64)),
    EntryDesc::new(5, "Minimum cycle time", U32, RO).with_default(ns(MIN_CYCLE_TIME_NS)),
    EntryDesc::new(6, "Calc and copy time", U32, RO),
    EntryDesc::new(7, "Minimum delay time", U32, RO).with_default(Value::Uint(0)),
    EntryDesc::new(8, "Get cycle time", U16, RW).with_range(&ValueRange {
        min: Value::Uint(0),
        max: Value::Uint(2),
    }),
    EntryDesc::new(9, "Delay time", U32, RO),
    EntryDesc::new(0x0A, "Sync0 cycle time", U32, RO),
    EntryDesc::new(0x0B, "SM event missed", U16, RO),
    EntryDesc::new(0x0C, "Cycle time too small", U16, RO),
    EntryDesc::new(0x0D, "Shift time too short", U16, RO),
    EntryDesc::new(0x20, "Sync error", BOOL, RO),
];

/// 0x1C32's own defaults: SM-synchronous, the output path's calc and copy and delay times.
static SYNC_OUTPUT_DEFAULTS: [EntryDefault; 3] = [
    EntryDefault::new(1, SYNC_MODE_SM as u32),
    EntryDefault::new(6, OUTPUT_CALC_COPY_NS),
    EntryDefault::new(9, OUTPUT_DELAY_NS),
];
/// 0x1C33's own defaults: synchronous with SM2, the input path's calc and copy time.
static SYNC_INPUT_DEFAULTS: [EntryDefault; 3] = [
    EntryDefault::new(1, SYNC_MODE_SM2_INPUTS as u32),
    EntryDefault::new(6, INPUT_CALC_COPY_NS),
    EntryDefault::new(9, 0),
];

const fn ns(value: u32) -> Value {
    Value::Uint(value as u64)
}

const AI_NAMES: [&str; AI_CHANNELS] = [
    "AI 1", "AI 2", "AI 3", "AI 4", "AI 5", "AI 6", "AI 7", "AI 8",
];
const AO_NAMES: [&str; AO_CHANNELS] = ["AO 1", "AO 2"];

static AI: [EntryDesc; AI_CHANNELS + 1] =
    entries(AI_CHANNELS as u8, &AI_NAMES, I16, RO.tx_mappable(), &[]);
static AO: [EntryDesc; AO_CHANNELS + 1] =
    entries(AO_CHANNELS as u8, &AO_NAMES, I16, RW.rx_mappable(), &[]);
/// 0x6443: 1 = on a fault the output takes the 0x6444 value (the default), 0 = it keeps its value.
static AO_ERROR_MODE: [EntryDesc; AO_CHANNELS + 1] = {
    let mut out = entries(AO_CHANNELS as u8, &AO_NAMES, U8, RW, &[1, 1]);
    let mut i = 1;
    while i <= AO_CHANNELS {
        out[i] = out[i].with_range(&ValueRange {
            min: Value::Uint(0),
            max: Value::Uint(1),
        });
        i += 1;
    }
    out
};
/// 0x6444: the fault value per output, in process-value units 0..=0x7FFF (0..10 V).
static AO_ERROR_VALUE: [EntryDesc; AO_CHANNELS + 1] = {
    let mut out = entries(AO_CHANNELS as u8, &AO_NAMES, I32, RW, &[0, 0]);
    let mut i = 1;
    while i <= AO_CHANNELS {
        out[i] = out[i].with_range(&ValueRange {
            min: Value::Int(0),
            max: Value::Int(i16::MAX as i64),
        });
        i += 1;
    }
    out
};

/// The module's object dictionary.
pub static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[EntryDesc::new(0, "Device type", U32, RO).with_default(Value::Uint(DEVICE_TYPE as u64))],
    ),
    ObjectDesc::var(
        0x1001,
        "Error register",
        &[EntryDesc::new(0, "Error register", U8, RO.tx_mappable())],
    ),
    ObjectDesc::array(0x1003, "Pre-defined error field", &ERROR_FIELD),
    CAN.sync_cob_id(),
    CAN.cycle_period(),
    ObjectDesc::var(
        0x1008,
        "Device name",
        &[EntryDesc::string(0, "Device name", NAMES.device_name)],
    ),
    ObjectDesc::var(
        0x1009,
        "Hardware version",
        &[EntryDesc::string(
            0,
            "Hardware version",
            NAMES.hardware_version,
        )],
    ),
    ObjectDesc::var(
        0x100A,
        "Software version",
        &[EntryDesc::string(
            0,
            "Software version",
            NAMES.software_version,
        )],
    ),
    CAN.guard_time(),
    CAN.life_factor(),
    CAN.emcy_cob_id(),
    CAN.emcy_inhibit(),
    CAN.consumers(),
    CAN.producer(),
    ObjectDesc::record(
        0x1018,
        "Identity",
        DataType::Identity,
        &[
            EntryDesc::count(4),
            EntryDesc::new(1, "Vendor ID", U32, RO)
                .with_default(Value::Uint(IDENTITY.vendor_id as u64)),
            EntryDesc::new(2, "Product code", U32, RO)
                .with_default(Value::Uint(IDENTITY.product_code as u64)),
            EntryDesc::new(3, "Revision", U32, RO)
                .with_default(Value::Uint(IDENTITY.revision as u64)),
            EntryDesc::new(4, "Serial number", U32, RO)
                .with_default(Value::Uint(IDENTITY.serial_number as u64)),
        ],
    ),
    CAN.sync_overflow(),
    CAN.error_behaviour(),
    // Manufacturer record types 0x0040.. (ETG.1000.6: device-specific complex types).
    ObjectDesc::record(
        0x10F1,
        "Error settings",
        DataType::Unknown(0x0040),
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Local error reaction", U32, RW).with_default(Value::Uint(0)),
            EntryDesc::new(2, "Sync error counter limit", U16, RW)
                .with_default(Value::Uint(DEFAULT_SYNC_ERROR_LIMIT as u64)),
        ],
    ),
    CAN.sdo_server(),
    CAN.rpdo(0),
    CAN.rpdo(1),
    ObjectDesc::record(RX_MAPPINGS[0], "RxPDO 1", DataType::PdoMapping, &MAPPING)
        .with_defaults(&RXPDO_DEFAULTS),
    ObjectDesc::record(RX_MAPPINGS[1], "RxPDO 2", DataType::PdoMapping, &MAPPING)
        .with_defaults(&RXPDO_DEFAULTS),
    CAN.tpdo(0),
    CAN.tpdo(1),
    CAN.tpdo(2),
    ObjectDesc::record(TX_MAPPINGS[0], "TxPDO 1", DataType::PdoMapping, &MAPPING)
        .with_defaults(&TXPDO_1_DEFAULTS),
    ObjectDesc::record(TX_MAPPINGS[1], "TxPDO 2", DataType::PdoMapping, &MAPPING)
        .with_defaults(&TXPDO_2_DEFAULTS),
    ObjectDesc::record(TX_MAPPINGS[2], "TxPDO 3", DataType::PdoMapping, &MAPPING)
        .with_defaults(&TXPDO_3_DEFAULTS),
    ObjectDesc::array(0x1C00, "Sync manager type", &SM_TYPES),
    ObjectDesc::array(0x1C12, "RxPDO assign", &RX_ASSIGN),
    ObjectDesc::array(0x1C13, "TxPDO assign", &TX_ASSIGN),
    // Record type 0x0042: the ETG.1020 SM synchronisation record (as SSC/SOES name it).
    ObjectDesc::record(
        0x1C32,
        "SM output parameter",
        DataType::Unknown(0x0042),
        &SYNC_PARAMETERS,
    )
    .with_defaults(&SYNC_OUTPUT_DEFAULTS),
    ObjectDesc::record(
        0x1C33,
        "SM input parameter",
        DataType::Unknown(0x0042),
        &SYNC_PARAMETERS,
    )
    .with_defaults(&SYNC_INPUT_DEFAULTS),
    ObjectDesc::record(
        SETTINGS_INDEX,
        "Analog input settings",
        DataType::Unknown(0x0041),
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AI filter", U8, RW)
                .with_default(Value::Uint(AI_FILTER_LATEST as u64))
                .with_range(&ValueRange {
                    min: Value::Uint(AI_FILTER_LATEST as u64),
                    max: Value::Uint(AI_FILTER_AVERAGE as u64),
                }),
            EntryDesc::new(2, "Full scale (uV)", U32, RO)
                .with_default(Value::Uint(FULL_SCALE_UV as u64)),
        ],
    ),
    ObjectDesc::var(
        MODULE_DESCRIPTION_INDEX,
        "Module description",
        &[EntryDesc::string(
            0,
            "Module description",
            MODULE_DESCRIPTION,
        )],
    ),
    ObjectDesc::var(
        PROCESS_DATA_SOURCE_INDEX,
        "Process data source",
        &[EntryDesc::new(0, "Process data source", U8, RW)
            .with_default(Value::Uint(SOURCE_ETHERCAT as u64))
            .with_range(&ValueRange {
                min: Value::Uint(SOURCE_ETHERCAT as u64),
                max: Value::Uint(SOURCE_CAN as u64),
            })],
    ),
    ObjectDesc::array(0x6401, "Read analog input 16-bit", &AI),
    ObjectDesc::array(0x6411, "Write analog output 16-bit", &AO),
    ObjectDesc::var(
        AI_INTERRUPT_ENABLE_INDEX,
        "Analog input global interrupt enable",
        &[
            EntryDesc::new(0, "Analog input global interrupt enable", BOOL, RW)
                .with_default(Value::Uint(0)),
        ],
    ),
    ObjectDesc::array(0x6443, "Analog output error mode", &AO_ERROR_MODE),
    ObjectDesc::array(0x6444, "Analog output error value", &AO_ERROR_VALUE),
]);

/// 0x1000: CiA 401 (0x0191) with analog inputs (bit 18) and analog outputs (bit 19).
pub const DEVICE_TYPE: u32 = 0x0191 | 1 << 18 | 1 << 19;

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};

#[cfg(test)]
mod tests {
    use super::super::capacity::{MAILBOX_SIZE, TRANSFER_BUFFER};
    use super::*;
    use std::vec::Vec;

    #[test]
    fn device_type_is_cia401_analog_io() {
        assert_eq!(DEVICE_TYPE, 0x000C_0191);
    }

    #[test]
    fn objects_in_index_order_with_the_required_ones() {
        let indices: Vec<u16> = OD.iter().map(|o| o.index).collect();
        assert!(indices.windows(2).all(|w| w[0] < w[1]), "{indices:x?}");
        for index in [
            0x1000, 0x1001, 0x1003, 0x1008, 0x1009, 0x100A, 0x1018, 0x10F1, 0x1600, 0x1A00, 0x1C00,
            0x1C12, 0x1C13, 0x1C32, 0x1C33, 0x6401, 0x6411, 0x6443, 0x6444,
        ] {
            assert!(OD.find(index).is_some(), "{index:#06x} missing");
        }
    }

    #[test]
    fn io_objects_are_integer16_and_mappable_the_right_way() {
        let ai = OD.find(0x6401).unwrap();
        assert_eq!(ai.max_subindex(), 8);
        assert!(ai.entries[1..].iter().all(|e| e.data_type() == I16
            && e.access.is_tx_mappable()
            && !e.access.is_rx_mappable()));
        let ao = OD.find(0x6411).unwrap();
        assert_eq!(ao.max_subindex(), 2);
        assert!(ao.entries[1..]
            .iter()
            .all(|e| e.data_type() == I16 && e.access.is_rx_mappable()));
    }

    #[test]
    fn sync_manager_types_follow_the_layout() {
        let types: Vec<Value> = OD
            .find(0x1C00)
            .unwrap()
            .entries
            .iter()
            .map(|e| e.default())
            .collect();
        assert_eq!(
            types,
            [4u64, 1, 2, 3, 4].map(Value::Uint),
            "0x1C00: 4 SMs, mailbox out/in, outputs, inputs"
        );
    }

    #[test]
    fn module_description_needs_a_segmented_upload() {
        // Mailbox data area: mailbox size minus mailbox header (6), CoE header (2) and the
        // SDO initiate response (8 incl. the size) - an expedited or single-frame normal
        // upload cannot carry it.
        let single_frame = MAILBOX_SIZE - 6 - 2 - 8;
        assert!(MODULE_DESCRIPTION.len() > 2 * single_frame);
        assert!(MODULE_DESCRIPTION.len() <= TRANSFER_BUFFER);
        assert!(MODULE_DESCRIPTION.is_ascii());
        let (_, entry) = OD.entry(MODULE_DESCRIPTION_INDEX, 0).unwrap();
        assert_eq!(entry.byte_len(), MODULE_DESCRIPTION.len());
    }
}
