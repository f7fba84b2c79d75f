//! The output oversampling objects of `analog-io` (docs/book/oversampling.md, "The output
//! process data"): the block counter 0x7010, the update arrays 0x7020..0x7029 and their
//! fixed PDOs 0x1610, 0x1620..0x1629, chosen by the master in 0x1C12. The values go
//! through the output image to the update interrupt (`crate::io::analog::output_blocks`);
//! the dictionary only describes them.

use crate::io::analog::output_blocks::{
    COUNTER_INDEX, COUNTER_PDO, UPDATES_INDEX, UPDATES_PER_PDO, UPDATE_PDO, UPDATE_PDOS,
};
use crate::io::analog::AO_CHANNELS;
use coe_core::device::oversampling::PdoReplicas;
use coe_core::od::{Access, DataType, EntryDefault, EntryDesc, ObjectDesc};
use coe_core::pdo::PdoEntry;

const RW: Access = Access::RW;
/// Entries of one update array: AO1, AO2 of each update.
const ENTRIES: usize = UPDATES_PER_PDO * AO_CHANNELS;

/// 0x7010: the block counter (optional, the master's count of blocks).
static COUNTER: [EntryDesc; 2] = [
    EntryDesc::count(1),
    EntryDesc::new(1, "Block counter", DataType::Unsigned16, RW.rx_mappable()),
];

/// Names of the update array's entries.
const UPDATE_NAMES: [&str; ENTRIES] = [
    "AO1 update 1",
    "AO2 update 1",
    "AO1 update 2",
    "AO2 update 2",
    "AO1 update 3",
    "AO2 update 3",
    "AO1 update 4",
    "AO2 update 4",
    "AO1 update 5",
    "AO2 update 5",
];

/// 0x7020 + u: five updates of both outputs, raw AD5663 codes (one table for the ten).
static UPDATES: [EntryDesc; ENTRIES + 1] = {
    let mut out = [EntryDesc::count(ENTRIES as u8); ENTRIES + 1];
    let mut i = 1;
    while i <= ENTRIES {
        out[i] = EntryDesc::new(
            i as u8,
            UPDATE_NAMES[i - 1],
            DataType::Unsigned16,
            RW.rx_mappable(),
        );
        i += 1;
    }
    out
};

const fn mapped(index: u16, sub: u8, bits: u8) -> u32 {
    PdoEntry::new(index, sub, bits).to_u32()
}

static COUNTER_MAPPING: [EntryDefault; 2] = [
    EntryDefault::new(0, 1),
    EntryDefault::new(1, mapped(COUNTER_INDEX, 1, 16)),
];
/// Update PDO u maps 0x7020 + u : 01..0A (one mapping run each).
static UPDATE_MAPPINGS: [[EntryDefault; 2]; UPDATE_PDOS] = {
    let mut out = [[EntryDefault::new(0, 0); 2]; UPDATE_PDOS];
    let mut u = 0;
    while u < UPDATE_PDOS {
        out[u] = [
            EntryDefault::new(0, ENTRIES as u32),
            EntryDefault::mapping_run(1, ENTRIES as u8, mapped(UPDATES_INDEX + u as u16, 1, 16)),
        ];
        u += 1;
    }
    out
};

const UPDATE_PDO_NAMES: [&str; UPDATE_PDOS] = [
    "AO updates 1..5",
    "AO updates 6..10",
    "AO updates 11..15",
    "AO updates 16..20",
    "AO updates 21..25",
    "AO updates 26..30",
    "AO updates 31..35",
    "AO updates 36..40",
    "AO updates 41..45",
    "AO updates 46..50",
];

/// How many objects [`OBJECTS`] has.
pub const OBJECT_COUNT: usize = 1 + 2 * UPDATE_PDOS + 1;

/// The objects, in index order.
pub static OBJECTS: [ObjectDesc; OBJECT_COUNT] = {
    let mapping = &super::oversampling::MAPPING;
    let first = ObjectDesc::record(
        COUNTER_PDO,
        "AO block counter",
        DataType::PdoMapping,
        mapping,
    )
    .with_defaults(&COUNTER_MAPPING);
    let mut out = [first; OBJECT_COUNT];
    let mut u = 0;
    while u < UPDATE_PDOS {
        out[1 + u] = ObjectDesc::record(
            UPDATE_PDO + u as u16,
            UPDATE_PDO_NAMES[u],
            DataType::PdoMapping,
            mapping,
        )
        .with_defaults(&UPDATE_MAPPINGS[u]);
        out[2 + UPDATE_PDOS + u] =
            ObjectDesc::array(UPDATES_INDEX + u as u16, UPDATE_PDO_NAMES[u], &UPDATES);
        u += 1;
    }
    out[1 + UPDATE_PDOS] = ObjectDesc::record(
        COUNTER_INDEX,
        "AO block",
        DataType::Unknown(0x0045),
        &COUNTER,
    );
    out
};

/// The update PDOs as one replicated PDO (ETG.2000 `OSFac`..): listed once with factors
/// 1..10.
pub const REPLICAS: PdoReplicas = PdoReplicas {
    base: UPDATE_PDO,
    default_factor: UPDATE_PDOS as u8,
    min_factor: 1,
    max_factor: UPDATE_PDOS as u8,
    index_increment: 1,
};
