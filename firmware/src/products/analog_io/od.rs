//! The module's object dictionary (CiA 301 communication area, ETG.1020 sync objects,
//! CiA 401 analog I/O, manufacturer objects): [`ANALOG_OBJECTS`], which every analog
//! product has (`analog-io-can` adds its CAN objects to them), and the objects that say
//! which product it is ([`OD`] is both).
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

use super::identity::{IDENTITY, NAMES};
use super::layout::SYNC_MANAGERS;
use super::sync::FIGURES;
use super::{output_oversampling, oversampling};
use crate::io::analog::oversampling::SAMPLE_PDOS;
use crate::io::analog::process_data::{
    PDO_ENTRIES, RX_ASSIGN as RX_ASSIGN_MAX, RX_PDOS, TX_ASSIGN, TX_PDOS,
};
use crate::io::analog::{
    AI_CHANNELS, AI_FILTER_AVERAGE, AI_FILTER_LATEST, AO_CHANNELS, SETTINGS_INDEX,
};
use crate::platform::board::FULL_SCALE_UV;
use crate::products::{identity_objects, merge_objects};
use crate::stacks::diagnostics::ERROR_HISTORY;
use crate::stacks::ethercat::sync_objects;
use coe_core::od::{
    Access, DataType, EntryDefault, EntryDesc, ObjectDesc, ObjectDictionary, Value, ValueRange,
};
use coe_core::pdo::PdoEntry;

const I16: DataType = DataType::Integer16;
const I32: DataType = DataType::Integer32;
const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const RO: Access = Access::RO;
const RW: Access = Access::RW;
const RWP: Access = Access::RW_PREOP;

/// Index of the module description string (manufacturer area).
pub const MODULE_DESCRIPTION_INDEX: u16 = 0x2001;

/// The module description (0x2001): longer than the mailbox data area, so a master reads it
/// with a segmented SDO upload.
pub const MODULE_DESCRIPTION: &str = concat!(
    "EtherCAT analog I/O module: 8 analog inputs 0..10 V (AD7689, 16 bit, 1/4 divider, ",
    "2.5 V reference; 0x6401 = code >> 1, 0x7FFF = 10 V) and 2 analog outputs 0..10 V ",
    "(AD5663, x4 amplifier; 0x6411, 0x7FFF = 10 V, negative values clamp to 0 V). ",
    "LPC1754 + ET1100 on SPI. Fault values per output in 0x6443/0x6444. Firmware ",
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
/// 0x1601 an alternative (CiA 401 RPDO 2 of `analog-io-can`), both the two outputs.
pub const RX_MAPPINGS: [u16; RX_PDOS] = [0x1600, 0x1601];
/// Default entries of [`RX_MAPPINGS`].
pub const RX_DEFAULTS: [&[PdoEntry]; RX_PDOS] = [&RXPDO_DEFAULT, &RXPDO_DEFAULT];
/// The TxPDO mapping objects and their default entries: 0x1A00 the EtherCAT default (all
/// eight inputs), 0x1A01/0x1A02 four inputs each (CiA 401 TPDO 2/3 of `analog-io-can`,
/// one CAN frame each).
pub const TX_MAPPINGS: [u16; TX_PDOS] = [0x1A00, 0x1A01, 0x1A02];
/// Default entries of [`TX_MAPPINGS`].
pub const TX_DEFAULTS: [&[PdoEntry]; TX_PDOS] = [&TXPDO_DEFAULT, &TXPDO_AI_1_4, &TXPDO_AI_5_8];
/// The default RxPDO assignment (0x1C12).
pub const RX_ASSIGN_DEFAULT: [u16; 1] = [RX_MAPPINGS[0]];
/// The default TxPDO assignment (0x1C13).
pub const TX_ASSIGN_DEFAULT: [u16; 1] = [TX_MAPPINGS[0]];

/// Names of subindices 1..: as many as the largest 0x1C13 (plain and oversampling PDOs).
const SUB_NAMES: [&str; TX_PDOS + 2 + SAMPLE_PDOS] = [
    "SubIndex 001",
    "SubIndex 002",
    "SubIndex 003",
    "SubIndex 004",
    "SubIndex 005",
    "SubIndex 006",
    "SubIndex 007",
    "SubIndex 008",
    "SubIndex 009",
    "SubIndex 010",
    "SubIndex 011",
    "SubIndex 012",
    "SubIndex 013",
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

static RX_ASSIGN: [EntryDesc; RX_PDOS + 1] = assignment(&RX_ASSIGN_DEFAULT);
static TX_ASSIGNMENT: [EntryDesc; TX_PDOS + 1] = assignment(&TX_ASSIGN_DEFAULT);
/// This product's 0x1C13 holds the plain TxPDOs and the oversampling ones
/// (`super::oversampling`); it replaces the plain one of [`ANALOG_OBJECTS`].
static TX_ASSIGNMENT_OVERSAMPLING: [EntryDesc; TX_ASSIGN + 1] = assignment(&TX_ASSIGN_DEFAULT);
/// This product's 0x1C12 holds the plain RxPDOs and the output oversampling ones
/// (`super::output_oversampling`).
static RX_ASSIGNMENT_OVERSAMPLING: [EntryDesc; RX_ASSIGN_MAX + 1] = assignment(&RX_ASSIGN_DEFAULT);

/// `objects` with the object of `by`'s index replaced by `by`.
const fn replaced<const N: usize>(objects: &[ObjectDesc; N], by: ObjectDesc) -> [ObjectDesc; N] {
    let mut out = *objects;
    let mut i = 0;
    while i < N {
        if out[i].index == by.index {
            out[i] = by;
        }
        i += 1;
    }
    out
}

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

/// 0x1C32 (outputs) / 0x1C33 (inputs), served by the slave application's sync monitor, with
/// the figures of [`super::sync`] as defaults.
static SYNC_PARAMETERS: [EntryDesc; 15] = sync_objects::sync_parameters(&FIGURES);
static SYNC_OUTPUT_DEFAULTS: [EntryDefault; 3] = sync_objects::output_defaults(&FIGURES);
static SYNC_INPUT_DEFAULTS: [EntryDefault; 3] = sync_objects::input_defaults(&FIGURES);

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

/// The objects of every analog product, in index order: the communication area but the
/// objects that name the product, the sync and PDO objects, the analog I/O.
pub static ANALOG_OBJECTS: [ObjectDesc; ANALOG_OBJECT_COUNT] = [
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
    ObjectDesc::record(
        0x10F1,
        "Error settings",
        DataType::Unknown(0x0040),
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Local error reaction", U32, RW).with_default(Value::Uint(0)),
            EntryDesc::new(2, "Sync error counter limit", U16, RW)
                .with_default(Value::Uint(FIGURES.default_error_limit as u64)),
        ],
    ),
    ObjectDesc::record(RX_MAPPINGS[0], "RxPDO 1", DataType::PdoMapping, &MAPPING)
        .with_defaults(&RXPDO_DEFAULTS),
    ObjectDesc::record(RX_MAPPINGS[1], "RxPDO 2", DataType::PdoMapping, &MAPPING)
        .with_defaults(&RXPDO_DEFAULTS),
    ObjectDesc::record(TX_MAPPINGS[0], "TxPDO 1", DataType::PdoMapping, &MAPPING)
        .with_defaults(&TXPDO_1_DEFAULTS),
    ObjectDesc::record(TX_MAPPINGS[1], "TxPDO 2", DataType::PdoMapping, &MAPPING)
        .with_defaults(&TXPDO_2_DEFAULTS),
    ObjectDesc::record(TX_MAPPINGS[2], "TxPDO 3", DataType::PdoMapping, &MAPPING)
        .with_defaults(&TXPDO_3_DEFAULTS),
    ObjectDesc::array(0x1C00, "Sync manager type", &SM_TYPES),
    ObjectDesc::array(0x1C12, "RxPDO assign", &RX_ASSIGN),
    ObjectDesc::array(0x1C13, "TxPDO assign", &TX_ASSIGNMENT),
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
    ObjectDesc::array(0x6401, "Read analog input 16-bit", &AI),
    ObjectDesc::array(0x6411, "Write analog output 16-bit", &AO),
    ObjectDesc::array(0x6443, "Analog output error mode", &AO_ERROR_MODE),
    ObjectDesc::array(0x6444, "Analog output error value", &AO_ERROR_VALUE),
];

/// How many objects [`ANALOG_OBJECTS`] has.
pub const ANALOG_OBJECT_COUNT: usize = 19;

/// The objects that make the dictionary this product's: identity and names, the module
/// description.
static PRODUCT_OBJECTS: [ObjectDesc; 5] = {
    let [a, b, c, d] = identity_objects!(IDENTITY, NAMES);
    [a, b, c, d, MODULE_DESCRIPTION_OBJECT]
};

/// 0x2001, the module description.
pub const MODULE_DESCRIPTION_OBJECT: ObjectDesc = ObjectDesc::var(
    MODULE_DESCRIPTION_INDEX,
    "Module description",
    &[EntryDesc::string(
        0,
        "Module description",
        MODULE_DESCRIPTION,
    )],
);

/// The module's object dictionary.
pub static OD: ObjectDictionary = ObjectDictionary::new(&OBJECTS);
static OBJECTS: [ObjectDesc;
    ANALOG_OBJECT_COUNT + 5 + oversampling::OBJECT_COUNT + output_oversampling::OBJECT_COUNT] =
    merge_objects(&[
        &replaced(
            &replaced(
                &ANALOG_OBJECTS,
                ObjectDesc::array(0x1C13, "TxPDO assign", &TX_ASSIGNMENT_OVERSAMPLING),
            ),
            ObjectDesc::array(0x1C12, "RxPDO assign", &RX_ASSIGNMENT_OVERSAMPLING),
        ),
        &PRODUCT_OBJECTS,
        &oversampling::OBJECTS,
        &output_oversampling::OBJECTS,
    ]);

/// 0x1000: CiA 401 (0x0191) with analog inputs (bit 18) and analog outputs (bit 19).
pub const DEVICE_TYPE: u32 = 0x0191 | 1 << 18 | 1 << 19;

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};

#[cfg(test)]
mod tests {
    use super::super::device::DEVICE;
    use super::*;
    use crate::io::analog::output_blocks::OutputBlocks;
    use crate::io::analog::oversampling::InputBlocks;
    use crate::stacks::ethercat::mailbox::{MAILBOX_SIZE, TRANSFER_BUFFER};
    use coe_core::pdo::PdoDirection;
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
        // A segment: mailbox header, CoE header and the segment's command byte. The fault
        // campaign loses the answer to the first segment and expects the transfer still
        // open: at least two segments.
        let segment = MAILBOX_SIZE - 6 - 2 - 1;
        assert!(MODULE_DESCRIPTION.len() > single_frame + segment);
        assert!(MODULE_DESCRIPTION.len() <= TRANSFER_BUFFER);
        assert!(MODULE_DESCRIPTION.is_ascii());
        let (_, entry) = OD.entry(MODULE_DESCRIPTION_INDEX, 0).unwrap();
        assert_eq!(entry.byte_len(), MODULE_DESCRIPTION.len());
    }

    #[test]
    fn product_default_is_built_from_the_dictionary() {
        // Every mapping object of the dictionary has a slot in the application, and only those.
        // (The fixed oversampling PDOs are the dictionary's own: their lengths below.)
        let plain = |o: &&ObjectDesc| !InputBlocks::is_block_pdo(o.index);
        let rx_plain = |o: &&ObjectDesc| !OutputBlocks::is_block_pdo(o.index);
        assert_eq!(
            DEVICE
                .pdo_objects(PdoDirection::Rx)
                .filter(rx_plain)
                .count(),
            RX_PDOS
        );
        assert_eq!(
            DEVICE.pdo_objects(PdoDirection::Tx).filter(plain).count(),
            TX_PDOS
        );
        let pd = super::super::process_data();
        assert_eq!(pd.output_len(), 4);
        assert_eq!(pd.input_len(), 16);
        // The oversampling PDOs of each direction: mapped as long as their code says, and
        // not the plain process data's.
        let block_pdos = |direction, bits: fn(u16) -> Option<u32>| {
            let mut count = 0;
            for object in DEVICE.pdo_objects(direction) {
                if let Some(bits) = bits(object.index) {
                    let mapped: u32 = DEVICE
                        .pdo_entries(object.index)
                        .map(|e| u32::from(e.bit_len))
                        .sum();
                    assert_eq!(mapped, bits, "{:#06x}", object.index);
                    assert!(!pd.owns(object.index));
                    count += 1;
                }
            }
            count
        };
        let blocks = block_pdos(PdoDirection::Tx, InputBlocks::pdo_bits);
        assert_eq!(blocks, 2 + crate::io::analog::oversampling::SAMPLE_PDOS);
        let updates = block_pdos(PdoDirection::Rx, OutputBlocks::pdo_bits);
        assert_eq!(updates, 1 + crate::io::analog::output_blocks::UPDATE_PDOS);
        for object in DEVICE
            .pdo_objects(PdoDirection::Rx)
            .filter(rx_plain)
            .chain(DEVICE.pdo_objects(PdoDirection::Tx).filter(plain))
        {
            assert!(pd.owns(object.index), "{:#06x}", object.index);
            let entries: Vec<PdoEntry> = DEVICE.pdo_entries(object.index).collect();
            let mut buf = [0u8; 4];
            assert_eq!(pd.read(object.index, 0, &mut buf), Ok(1));
            assert_eq!(usize::from(buf[0]), entries.len());
            for (sub, entry) in (1..).zip(&entries) {
                assert_eq!(pd.read(object.index, sub, &mut buf), Ok(4));
                assert_eq!(u32::from_le_bytes(buf), entry.to_u32());
            }
        }
        // The assignments: as many PDOs as the dictionary's defaults, the same ones.
        for (assign, direction) in [(0x1C12, PdoDirection::Rx), (0x1C13, PdoDirection::Tx)] {
            let pdos: Vec<u32> = DEVICE.assigned_pdos(direction).collect();
            let mut buf = [0u8; 2];
            assert_eq!(pd.read(assign, 0, &mut buf), Ok(1));
            assert_eq!(usize::from(buf[0]), pdos.len(), "{assign:#06x}");
            for (sub, pdo) in (1..).zip(&pdos) {
                assert_eq!(pd.read(assign, sub, &mut buf), Ok(2));
                assert_eq!(
                    u32::from(u16::from_le_bytes(buf)),
                    *pdo,
                    "{assign:#06x}:{sub}"
                );
            }
        }
        let mut buf = [0u8; 2];
        assert_eq!(pd.read(0x1C12, 1, &mut buf), Ok(2));
        assert_eq!(u16::from_le_bytes(buf), 0x1600);
        assert_eq!(pd.read(0x1C13, 1, &mut buf), Ok(2));
        assert_eq!(u16::from_le_bytes(buf), 0x1A00);
        assert!(pd.is_rx_mapped(0x6411, 2));
    }
}
