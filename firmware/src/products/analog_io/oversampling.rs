//! The input oversampling objects of `analog-io` (docs/book/oversampling.md, "For
//! masters"): the block header 0x6010, the sample arrays 0x6020..0x6027, their fixed PDOs
//! 0x1A10, 0x1A11, 0x1A20..0x1A27, and the settings object 0x8000. The values are the
//! application's (`crate::io::analog::oversampling`); the PDOs are fixed (read-only
//! mappings from the defaults below), chosen by the master in 0x1C13.

pub use crate::io::analog::oversampling::SETTINGS_INDEX;
use crate::io::analog::oversampling::{
    BLOCK_INDEX, LEAD_NS, PERIOD_NS, SAMPLES_INDEX, SAMPLE_PDO, SAMPLE_PDOS, SLOTS_PER_PDO,
    STATUS_PDO, TIME_PDO,
};
use crate::io::analog::AI_CHANNELS;
use coe_core::device::oversampling::PdoReplicas;
use coe_core::od::{Access, DataType, EntryDefault, EntryDesc, ObjectDesc, Value};
use coe_core::pdo::PdoEntry;

const RO: Access = Access::RO;
const U32: DataType = DataType::Unsigned32;

/// 0x6010: the block header (status and time).
static BLOCK: [EntryDesc; 5] = [
    EntryDesc::count(4),
    EntryDesc::new(1, "Scan counter", U32, RO.tx_mappable()),
    EntryDesc::new(2, "Scans", DataType::Unsigned8, RO.tx_mappable()),
    EntryDesc::new(3, "Status", DataType::Unsigned8, RO.tx_mappable()),
    EntryDesc::new(4, "Block time", DataType::Unsigned64, RO.tx_mappable()),
];

/// Names of subindices 1..32 (the ESI wants the entries of an array named apart).
const SUB_NAMES: [&str; SLOTS_PER_PDO] = [
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
    "SubIndex 014",
    "SubIndex 015",
    "SubIndex 016",
    "SubIndex 017",
    "SubIndex 018",
    "SubIndex 019",
    "SubIndex 020",
    "SubIndex 021",
    "SubIndex 022",
    "SubIndex 023",
    "SubIndex 024",
    "SubIndex 025",
    "SubIndex 026",
    "SubIndex 027",
    "SubIndex 028",
    "SubIndex 029",
    "SubIndex 030",
    "SubIndex 031",
    "SubIndex 032",
];

/// 0x6020 + b: 32 raw AD7689 codes in conversion order (one table for the eight arrays).
static SAMPLES: [EntryDesc; SLOTS_PER_PDO + 1] = {
    let mut out = [EntryDesc::count(SLOTS_PER_PDO as u8); SLOTS_PER_PDO + 1];
    let mut i = 1;
    while i <= SLOTS_PER_PDO {
        out[i] = EntryDesc::new(
            i as u8,
            SUB_NAMES[i - 1],
            DataType::Unsigned16,
            RO.tx_mappable(),
        );
        i += 1;
    }
    out
};

/// The entries of the fixed mapping objects: sub 0 and up to 32 read-only entries (each
/// object's own defaults say how many and which).
pub(super) static MAPPING: [EntryDesc; SLOTS_PER_PDO + 1] = {
    let mut out = [EntryDesc::count(0); SLOTS_PER_PDO + 1];
    let mut i = 1;
    while i <= SLOTS_PER_PDO {
        out[i] = EntryDesc::new(i as u8, SUB_NAMES[i - 1], U32, RO);
        i += 1;
    }
    out
};

const fn mapped(index: u16, sub: u8, bits: u8) -> u32 {
    PdoEntry::new(index, sub, bits).to_u32()
}

static STATUS_MAPPING: [EntryDefault; 4] = [
    EntryDefault::new(0, 3),
    EntryDefault::new(1, mapped(BLOCK_INDEX, 1, 32)),
    EntryDefault::new(2, mapped(BLOCK_INDEX, 2, 8)),
    EntryDefault::new(3, mapped(BLOCK_INDEX, 3, 8)),
];
static TIME_MAPPING: [EntryDefault; 2] = [
    EntryDefault::new(0, 1),
    EntryDefault::new(1, mapped(BLOCK_INDEX, 4, 64)),
];
/// Sample PDO b maps 0x6020 + b : 01..20 (one mapping run each).
static SAMPLE_MAPPINGS: [[EntryDefault; 2]; SAMPLE_PDOS] = {
    let mut out = [[EntryDefault::new(0, 0); 2]; SAMPLE_PDOS];
    let mut b = 0;
    while b < SAMPLE_PDOS {
        out[b] = [
            EntryDefault::new(0, SLOTS_PER_PDO as u32),
            EntryDefault::mapping_run(
                1,
                SLOTS_PER_PDO as u8,
                mapped(SAMPLES_INDEX + b as u16, 1, 16),
            ),
        ];
        b += 1;
    }
    out
};

const SAMPLE_PDO_NAMES: [&str; SAMPLE_PDOS] = [
    "AI samples 1..32",
    "AI samples 33..64",
    "AI samples 65..96",
    "AI samples 97..128",
    "AI samples 129..160",
    "AI samples 161..192",
    "AI samples 193..224",
    "AI samples 225..256",
];

/// How many objects [`OBJECTS`] has.
pub const OBJECT_COUNT: usize = 2 + 2 * SAMPLE_PDOS + 2;

/// The objects, in index order.
pub static OBJECTS: [ObjectDesc; OBJECT_COUNT] = {
    let first = ObjectDesc::record(
        STATUS_PDO,
        "AI block status",
        DataType::PdoMapping,
        &MAPPING,
    )
    .with_defaults(&STATUS_MAPPING);
    let mut out = [first; OBJECT_COUNT];
    out[1] = ObjectDesc::record(TIME_PDO, "AI block time", DataType::PdoMapping, &MAPPING)
        .with_defaults(&TIME_MAPPING);
    let mut b = 0;
    while b < SAMPLE_PDOS {
        out[2 + b] = ObjectDesc::record(
            SAMPLE_PDO + b as u16,
            SAMPLE_PDO_NAMES[b],
            DataType::PdoMapping,
            &MAPPING,
        )
        .with_defaults(&SAMPLE_MAPPINGS[b]);
        out[3 + SAMPLE_PDOS + b] =
            ObjectDesc::array(SAMPLES_INDEX + b as u16, SAMPLE_PDO_NAMES[b], &SAMPLES);
        b += 1;
    }
    out[2 + SAMPLE_PDOS] =
        ObjectDesc::record(BLOCK_INDEX, "AI block", DataType::Unknown(0x0043), &BLOCK);
    out[OBJECT_COUNT - 1] = ObjectDesc::record(
        SETTINGS_INDEX,
        "AI oversampling settings",
        DataType::Unknown(0x0044),
        &SETTINGS,
    );
    out
};

/// 0x8000: the scan's channels and period (fixed on this board), the sample slots assigned
/// (live, from 0x1C13) and how long before SYNC0 a block closes.
static SETTINGS: [EntryDesc; 5] = [
    EntryDesc::count(6),
    EntryDesc::new(1, "AI channels", DataType::Unsigned8, RO)
        .with_default(Value::Uint(AI_CHANNELS as u64)),
    EntryDesc::new(2, "AI conversion period (ns)", U32, RO)
        .with_default(Value::Uint(PERIOD_NS as u64)),
    EntryDesc::new(3, "AI samples per cycle", DataType::Unsigned16, RO),
    EntryDesc::new(6, "Input block lead (ns)", U32, RO).with_default(Value::Uint(LEAD_NS as u64)),
];

/// The sample PDOs as one replicated PDO (ETG.2000 `OSFac`..): listed once in the ESI and
/// the SII with factors 1..8; the dictionary holds all eight.
pub const REPLICAS: PdoReplicas = PdoReplicas {
    base: SAMPLE_PDO,
    default_factor: SAMPLE_PDOS as u8,
    min_factor: 1,
    max_factor: SAMPLE_PDOS as u8,
    index_increment: 1,
};
