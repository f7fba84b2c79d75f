//! The gateway's object dictionary, in the modular device profile's shape (ETG.5001, as
//! Beckhoff's EL6751 lays out its CANopen nodes): one module per CAN node place `n`
//! (0..[`MAX_NODES`]), each object of a module at its base + 16 n ([`MODULE_DISTANCE`]).
//!
//! | index          | what                                                        |
//! |----------------|-------------------------------------------------------------|
//! | 0x1600 + n     | RxPDO n: the node's outputs 0x7000 + 16n:01..04 (fixed)      |
//! | 0x1A00 + n     | TxPDO n: the node's inputs 0x6000 + 16n:01..04 (fixed)       |
//! | 0x1A80         | TxPDO "gateway status": 0xF100:01, :02                       |
//! | 0x1C12, 0x1C13 | PDO assignment (PREOP): which nodes' PDOs the image carries  |
//! | 0x6000 + 16n   | node inputs: its TPDO 1 and TPDO 2 data, 4 x UNSIGNED32      |
//! | 0x7000 + 16n   | node outputs: its RPDO 1 and RPDO 2 data, 4 x UNSIGNED32     |
//! | 0x8000 + 16n   | node configuration (PREOP): node-ID, identity to expect, mandatory, error control, PDO communication |
//! | 0x8001 + 16n   | the node's TPDO 1 / 2 mappings (PREOP), written to the node at its boot |
//! | 0x8002 + 16n   | the node's RPDO 1 / 2 mappings (PREOP)                      |
//! | 0xA000 + 16n   | node diagnosis: state, boot error letter, Emergency, counters |
//! | 0x10F3         | diagnosis history (ETG.1020), node events as messages       |
//! | 0xF000         | modular device profile: module distance, number of places   |
//! | 0xF030 / 0xF050 | configured / detected module ident list (product codes)    |
//! | 0xF100         | gateway status: operational and faulty nodes, bus counters   |
//! | 0xF800         | CAN master parameters (PREOP): bit rate, SYNC, timeouts, policies |
//!
//! A node's data bytes are the CAN PDOs' bytes in bus order (CANopen and EtherCAT are both
//! little-endian, so UNSIGNED32 words carry them unchanged): bytes 0..8 of the image's
//! 16 are TPDO 1 (RPDO 1), bytes 8..16 TPDO 2 (RPDO 2); a shorter PDO fills the front.

use super::identity::{IDENTITY, NAMES};
use super::layout::SYNC_MANAGERS;
use super::sync::FIGURES;
use crate::products::{identity_objects, merge_objects};
use crate::stacks::diagnostics::ERROR_HISTORY;
use crate::stacks::ethercat::sync_objects;
use coe_core::od::{
    Access, DataType, EntryDefault, EntryDesc, ObjectDesc, ObjectDictionary, Value, ValueRange,
};

pub use super::modules::*;

/// Bases of the module objects.
pub const INPUTS_BASE: u16 = 0x6000;
/// Node outputs.
pub const OUTPUTS_BASE: u16 = 0x7000;
/// Node configuration.
pub const CONFIG_BASE: u16 = 0x8000;
/// The node's TPDO mappings.
pub const TPDO_MAP_BASE: u16 = 0x8001;
/// The node's RPDO mappings.
pub const RPDO_MAP_BASE: u16 = 0x8002;
/// Node diagnosis.
pub const DIAG_BASE: u16 = 0xA000;
/// RxPDO mapping objects.
pub const RXPDO_BASE: u16 = 0x1600;
/// TxPDO mapping objects.
pub const TXPDO_BASE: u16 = 0x1A00;
/// The gateway status TxPDO.
pub const STATUS_TXPDO: u16 = 0x1A80;
/// Diagnosis history (ETG.1020).
pub const DIAG_HISTORY_INDEX: u16 = 0x10F3;
/// Modular device profile.
pub const MDP_INDEX: u16 = 0xF000;
/// Configured module ident list.
pub const CONFIGURED_MODULES_INDEX: u16 = 0xF030;
/// Detected module ident list.
pub const DETECTED_MODULES_INDEX: u16 = 0xF050;
/// Gateway status.
pub const STATUS_INDEX: u16 = 0xF100;
/// CAN master parameters.
pub const MASTER_INDEX: u16 = 0xF800;

/// Messages 0x10F3 keeps.
pub const DIAG_MESSAGES: usize = 8;
/// Bytes of one diagnosis message (0x10F3:06..): header 16, two parameters.
pub const DIAG_MESSAGE_BYTES: usize = 64;

/// Device type (0x1000): the modular device profile 5001, as the EL6751 gives it.
pub const DEVICE_TYPE: u32 = 0x0000_1389;

/// The module of an index: `(place, base)` if `index` is a module object.
pub const fn module_of(index: u16) -> Option<(usize, u16)> {
    let place = ((index & 0x0FF0) / MODULE_DISTANCE) as usize;
    let base = index & 0xF00F;
    match base {
        INPUTS_BASE | OUTPUTS_BASE | CONFIG_BASE | TPDO_MAP_BASE | RPDO_MAP_BASE | DIAG_BASE
            if place < MAX_NODES =>
        {
            Some((place, base))
        }
        _ => None,
    }
}

// ------------------------------------------------------------------ sub-indices

/// 0x8000 + 16n entries.
pub mod config_sub {
    /// Node-ID (0: the place is unused).
    pub const NODE_ID: u8 = 1;
    /// Expected device type (0x1000; 0: not checked).
    pub const DEVICE_TYPE: u8 = 2;
    /// Expected vendor-ID (0x1018:01; 0: not checked).
    pub const VENDOR_ID: u8 = 3;
    /// Expected product code (0x1018:02).
    pub const PRODUCT_CODE: u8 = 4;
    /// Expected revision (0x1018:03).
    pub const REVISION: u8 = 5;
    /// Expected serial number (0x1018:04).
    pub const SERIAL: u8 = 6;
    /// Flags: [`super::FLAG_MANDATORY`], [`super::FLAG_DISABLE_UNUSED_PDOS`].
    pub const FLAGS: u8 = 7;
    /// Guard time (ms, node guarding when no heartbeat is watched).
    pub const GUARD_TIME: u8 = 8;
    /// Life time factor.
    pub const LIFE_FACTOR: u8 = 9;
    /// Heartbeat consumer time of the gateway for the node (ms; 0: not watched).
    pub const HEARTBEAT_CONSUMER: u8 = 10;
    /// Heartbeat producer time written to the node's 0x1017 (ms).
    pub const HEARTBEAT_PRODUCER: u8 = 11;
    /// TPDO 1 COB-ID (bit 31: not used; 0x180 + node-ID by default).
    pub const TPDO1_COB_ID: u8 = 12;
    /// TPDO 1 transmission type.
    pub const TPDO1_TYPE: u8 = 13;
    /// TPDO 2 COB-ID.
    pub const TPDO2_COB_ID: u8 = 14;
    /// TPDO 2 transmission type.
    pub const TPDO2_TYPE: u8 = 15;
    /// RPDO 1 COB-ID.
    pub const RPDO1_COB_ID: u8 = 16;
    /// RPDO 1 transmission type.
    pub const RPDO1_TYPE: u8 = 17;
    /// RPDO 2 COB-ID.
    pub const RPDO2_COB_ID: u8 = 18;
    /// RPDO 2 transmission type.
    pub const RPDO2_TYPE: u8 = 19;
    /// TPDO event timer written to the node (ms; 0: not written).
    pub const TPDO_EVENT_TIMER: u8 = 20;
    /// The gateway's deadline for an event-driven TPDO (ms; 0: not supervised).
    pub const TPDO_DEADLINE: u8 = 21;
    /// Last subindex.
    pub const LAST: u8 = TPDO_DEADLINE;
}

/// 0x8000 + 16n:07 bit 0: a mandatory node (OP only while it runs).
pub const FLAG_MANDATORY: u16 = 1 << 0;
/// 0x8000 + 16n:07 bit 1: the node's PDOs 1..4 that the gateway does not use are made
/// not valid at its boot.
pub const FLAG_DISABLE_UNUSED_PDOS: u16 = 1 << 1;

/// A COB-ID's "not valid" bit (CiA 301).
pub const COB_ID_NOT_VALID: u32 = 1 << 31;
/// 0x8000 + 16n COB-ID entries: the predefined connection set's COB-ID for the node.
pub const COB_ID_DEFAULT: u32 = 0;

/// 0xA000 + 16n entries.
pub mod diag_sub {
    /// Node state ([`crate::products::can_gateway::diagnosis::NodeState`]).
    pub const STATE: u8 = 1;
    /// CiA 302-2 boot error letter (ASCII, 0: none).
    pub const BOOT_ERROR: u8 = 2;
    /// Object of the failed boot step: index << 16 | sub << 8.
    pub const BOOT_ERROR_OBJECT: u8 = 3;
    /// Last Emergency error code.
    pub const EMCY_CODE: u8 = 4;
    /// Emergencies received.
    pub const EMCY_COUNT: u8 = 5;
    /// Times the node was lost.
    pub const LOST_COUNT: u8 = 6;
    /// Synchronous TPDOs missed (both TPDOs).
    pub const TPDO_MISSED: u8 = 7;
    /// TPDOs of a wrong length (both TPDOs).
    pub const TPDO_BAD_LENGTH: u8 = 8;
    /// Last subindex.
    pub const LAST: u8 = TPDO_BAD_LENGTH;
}

/// 0xF800 entries.
pub mod master_sub {
    /// Bit rate (kbit/s; the image's, read-only).
    pub const BIT_RATE: u8 = 1;
    /// The gateway's node-ID on CAN (its heartbeat).
    pub const NODE_ID: u8 = 2;
    /// SYNC COB-ID.
    pub const SYNC_COB_ID: u8 = 3;
    /// A SYNC every this many EtherCAT cycles (0: none from the cycle).
    pub const SYNC_MULTIPLIER: u8 = 4;
    /// Free-running SYNC period (us; 0: none).
    pub const SYNC_PERIOD: u8 = 5;
    /// SDO timeout (ms).
    pub const SDO_TIMEOUT: u8 = 6;
    /// Wait for boot-up messages after the reset (ms).
    pub const BOOT_WAIT: u8 = 7;
    /// Retry of a failed optional node (ms).
    pub const RETRY: u8 = 8;
    /// The gateway's heartbeat (ms; 0: none).
    pub const HEARTBEAT: u8 = 9;
    /// Policies: [`super::POLICY_START_ALL_AT_ONCE`], [`super::POLICY_LOST_MANDATORY_AL_ERROR`].
    pub const POLICIES: u8 = 10;
    /// Last subindex.
    pub const LAST: u8 = POLICIES;
}

/// 0xF800:0A bit 0: start every node with one NMT broadcast once the mandatory nodes are
/// configured.
pub const POLICY_START_ALL_AT_ONCE: u16 = 1 << 0;
/// 0xF800:0A bit 1: a mandatory node lost in OP takes the gateway to SAFEOP with the error
/// flag and AL status 0x0018 (else only diagnosis and an Emergency).
pub const POLICY_LOST_MANDATORY_AL_ERROR: u16 = 1 << 1;

/// 0xF100 entries.
pub mod status_sub {
    /// Bit n: node place n operational (mapped, 0x1A80).
    pub const OPERATIONAL: u8 = 1;
    /// Bit n: node place n configured and not operational (mapped, 0x1A80).
    pub const FAULTY: u8 = 2;
    /// CAN frames received.
    pub const RECEIVED: u8 = 3;
    /// SYNCs sent.
    pub const SYNCS: u8 = 4;
    /// RPDOs sent.
    pub const RPDOS: u8 = 5;
    /// Frames lost: the master's outbox or the CAN task's inbox full.
    pub const OVERRUNS: u8 = 6;
    /// Last subindex.
    pub const LAST: u8 = OVERRUNS;
}

// ------------------------------------------------------------------ tables

const BOOL: DataType = DataType::Boolean;
const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const RO: Access = Access::RO;
const RW: Access = Access::RW;
const RWP: Access = Access::RW_PREOP;

/// The name of place `n`'s `kind` object, e.g. "Node 3 inputs" (places count from 1).
macro_rules! place_names {
    ($kind:literal) => {
        [
            concat!("Node 1 ", $kind),
            concat!("Node 2 ", $kind),
            concat!("Node 3 ", $kind),
            concat!("Node 4 ", $kind),
            concat!("Node 5 ", $kind),
            concat!("Node 6 ", $kind),
            concat!("Node 7 ", $kind),
            concat!("Node 8 ", $kind),
        ]
    };
}

const _: () = assert!(MAX_NODES == 8, "place_names! names eight places");

const INPUT_NAMES: [&str; MAX_NODES] = place_names!("inputs");
const OUTPUT_NAMES: [&str; MAX_NODES] = place_names!("outputs");
const CONFIG_NAMES: [&str; MAX_NODES] = place_names!("configuration");
const TPDO_MAP_NAMES: [&str; MAX_NODES] = place_names!("TPDO mapping");
const RPDO_MAP_NAMES: [&str; MAX_NODES] = place_names!("RPDO mapping");
const DIAG_NAMES: [&str; MAX_NODES] = place_names!("diagnosis");
const RXPDO_NAMES: [&str; MAX_NODES] = place_names!("RxPDO");
const TXPDO_NAMES: [&str; MAX_NODES] = place_names!("TxPDO");

static INPUT_ENTRIES: [EntryDesc; DATA_WORDS + 1] = [
    EntryDesc::count(DATA_WORDS as u8),
    EntryDesc::new(1, "TPDO 1 bytes 0..3", U32, RO.tx_mappable()),
    EntryDesc::new(2, "TPDO 1 bytes 4..7", U32, RO.tx_mappable()),
    EntryDesc::new(3, "TPDO 2 bytes 0..3", U32, RO.tx_mappable()),
    EntryDesc::new(4, "TPDO 2 bytes 4..7", U32, RO.tx_mappable()),
];

static OUTPUT_ENTRIES: [EntryDesc; DATA_WORDS + 1] = [
    EntryDesc::count(DATA_WORDS as u8),
    EntryDesc::new(1, "RPDO 1 bytes 0..3", U32, RW.rx_mappable()),
    EntryDesc::new(2, "RPDO 1 bytes 4..7", U32, RW.rx_mappable()),
    EntryDesc::new(3, "RPDO 2 bytes 0..3", U32, RW.rx_mappable()),
    EntryDesc::new(4, "RPDO 2 bytes 4..7", U32, RW.rx_mappable()),
];

const TT_RANGE: ValueRange = ValueRange::new(Value::Uint(0), Value::Uint(255));

static CONFIG_ENTRIES: [EntryDesc; config_sub::LAST as usize + 1] = [
    EntryDesc::count(config_sub::LAST),
    EntryDesc::new(1, "Node-ID", U8, RWP)
        .with_range(&ValueRange::new(Value::Uint(0), Value::Uint(127))),
    EntryDesc::new(2, "Expected device type", U32, RWP),
    EntryDesc::new(3, "Expected vendor ID", U32, RWP),
    EntryDesc::new(4, "Expected product code", U32, RWP),
    EntryDesc::new(5, "Expected revision", U32, RWP),
    EntryDesc::new(6, "Expected serial number", U32, RWP),
    EntryDesc::new(7, "Flags", U16, RWP),
    EntryDesc::new(8, "Guard time (ms)", U16, RWP),
    EntryDesc::new(9, "Life time factor", U8, RWP),
    EntryDesc::new(10, "Heartbeat consumer time (ms)", U16, RWP),
    EntryDesc::new(11, "Heartbeat producer time (ms)", U16, RWP),
    EntryDesc::new(12, "TPDO 1 COB-ID", U32, RWP),
    EntryDesc::new(13, "TPDO 1 transmission type", U8, RWP)
        .with_default(Value::Uint(1))
        .with_range(&TT_RANGE),
    EntryDesc::new(14, "TPDO 2 COB-ID", U32, RWP),
    EntryDesc::new(15, "TPDO 2 transmission type", U8, RWP)
        .with_default(Value::Uint(1))
        .with_range(&TT_RANGE),
    EntryDesc::new(16, "RPDO 1 COB-ID", U32, RWP),
    EntryDesc::new(17, "RPDO 1 transmission type", U8, RWP)
        .with_default(Value::Uint(1))
        .with_range(&TT_RANGE),
    EntryDesc::new(18, "RPDO 2 COB-ID", U32, RWP),
    EntryDesc::new(19, "RPDO 2 transmission type", U8, RWP)
        .with_default(Value::Uint(1))
        .with_range(&TT_RANGE),
    EntryDesc::new(20, "TPDO event timer (ms)", U16, RWP),
    EntryDesc::new(21, "TPDO deadline (ms)", U16, RWP),
];

const MAP_NAMES: [&str; NODE_PDOS * PDO_MAP_ENTRIES] = [
    "PDO 1 entry 1",
    "PDO 1 entry 2",
    "PDO 1 entry 3",
    "PDO 1 entry 4",
    "PDO 1 entry 5",
    "PDO 1 entry 6",
    "PDO 1 entry 7",
    "PDO 1 entry 8",
    "PDO 2 entry 1",
    "PDO 2 entry 2",
    "PDO 2 entry 3",
    "PDO 2 entry 4",
    "PDO 2 entry 5",
    "PDO 2 entry 6",
    "PDO 2 entry 7",
    "PDO 2 entry 8",
];

/// 0x8001/0x8002 + 16n: the CAN PDOs' mapping entries (`index << 16 | sub << 8 | bits`),
/// a PDO's list ending at its first 0.
static PDO_MAP_ENTRIES_TABLE: [EntryDesc; NODE_PDOS * PDO_MAP_ENTRIES + 1] = {
    let mut out =
        [EntryDesc::count((NODE_PDOS * PDO_MAP_ENTRIES) as u8); NODE_PDOS * PDO_MAP_ENTRIES + 1];
    let mut i = 1;
    while i < out.len() {
        out[i] = EntryDesc::new(i as u8, MAP_NAMES[i - 1], U32, RWP);
        i += 1;
    }
    out
};

static DIAG_ENTRIES: [EntryDesc; diag_sub::LAST as usize + 1] = [
    EntryDesc::count(diag_sub::LAST),
    EntryDesc::new(1, "Node state", U8, RO),
    EntryDesc::new(2, "Boot error", U8, RO),
    EntryDesc::new(3, "Boot error object", U32, RO),
    EntryDesc::new(4, "Last emergency code", U16, RO),
    EntryDesc::new(5, "Emergencies", U16, RO),
    EntryDesc::new(6, "Lost", U16, RO),
    EntryDesc::new(7, "TPDOs missed", U32, RO),
    EntryDesc::new(8, "TPDOs of a wrong length", U32, RO),
];

/// The fixed PDO mapping objects' entries (4 words).
static NODE_PDO_MAPPING: [EntryDesc; DATA_WORDS + 1] = [
    EntryDesc::count(DATA_WORDS as u8),
    EntryDesc::new(1, "SubIndex 001", U32, RO),
    EntryDesc::new(2, "SubIndex 002", U32, RO),
    EntryDesc::new(3, "SubIndex 003", U32, RO),
    EntryDesc::new(4, "SubIndex 004", U32, RO),
];

/// The mapping entry of a node's data word: `base + 16 n : sub`, 32 bits.
pub const fn data_mapping(base: u16, place: usize, sub: u8) -> u32 {
    ((base + place as u16 * MODULE_DISTANCE) as u32) << 16 | (sub as u32) << 8 | 32
}

const fn node_pdo_defaults(base: u16) -> [[EntryDefault; 2]; MAX_NODES] {
    let mut out = [[EntryDefault::new(0, 0); 2]; MAX_NODES];
    let mut n = 0;
    while n < MAX_NODES {
        out[n] = [
            EntryDefault::new(0, DATA_WORDS as u32),
            EntryDefault::mapping_run(1, DATA_WORDS as u8, data_mapping(base, n, 1)),
        ];
        n += 1;
    }
    out
}

static RXPDO_DEFAULTS: [[EntryDefault; 2]; MAX_NODES] = node_pdo_defaults(OUTPUTS_BASE);
static TXPDO_DEFAULTS: [[EntryDefault; 2]; MAX_NODES] = node_pdo_defaults(INPUTS_BASE);

/// The status TxPDO's entries: 0xF100:01 and :02, 16 bits each.
pub const STATUS_MAPPING: [u32; 2] = [
    (STATUS_INDEX as u32) << 16 | (status_sub::OPERATIONAL as u32) << 8 | 16,
    (STATUS_INDEX as u32) << 16 | (status_sub::FAULTY as u32) << 8 | 16,
];

static STATUS_PDO_MAPPING: [EntryDesc; 3] = [
    EntryDesc::count(2),
    EntryDesc::new(1, "SubIndex 001", U32, RO).with_default(Value::Uint(STATUS_MAPPING[0] as u64)),
    EntryDesc::new(2, "SubIndex 002", U32, RO).with_default(Value::Uint(STATUS_MAPPING[1] as u64)),
];

/// RxPDOs the assignment can hold: one per node.
pub const RX_ASSIGN_MAX: usize = MAX_NODES;
/// TxPDOs the assignment can hold: one per node and the status.
pub const TX_ASSIGN_MAX: usize = MAX_NODES + 1;

const ASSIGN_NAMES: [&str; TX_ASSIGN_MAX] = [
    "SubIndex 001",
    "SubIndex 002",
    "SubIndex 003",
    "SubIndex 004",
    "SubIndex 005",
    "SubIndex 006",
    "SubIndex 007",
    "SubIndex 008",
    "SubIndex 009",
];

/// The default assignments: every node's PDO (and the status first among the inputs).
pub const RX_ASSIGN_DEFAULT: [u16; RX_ASSIGN_MAX] = {
    let mut out = [0u16; RX_ASSIGN_MAX];
    let mut n = 0;
    while n < MAX_NODES {
        out[n] = RXPDO_BASE + n as u16;
        n += 1;
    }
    out
};
/// The default TxPDO assignment: the status, then every node's inputs.
pub const TX_ASSIGN_DEFAULT: [u16; TX_ASSIGN_MAX] = {
    let mut out = [STATUS_TXPDO; TX_ASSIGN_MAX];
    let mut n = 0;
    while n < MAX_NODES {
        out[n + 1] = TXPDO_BASE + n as u16;
        n += 1;
    }
    out
};

/// An assignment object's entries: sub 0 (writable in PREOP) and `N - 1` u16 slots with
/// `defaults`.
const fn assignment<const N: usize>(defaults: &[u16]) -> [EntryDesc; N] {
    let mut out = [EntryDesc::count((N - 1) as u8).with_access(RWP); N];
    let mut i = 1;
    while i < N {
        out[i] = EntryDesc::new(i as u8, ASSIGN_NAMES[i - 1], U16, RWP)
            .with_default(Value::Uint(defaults[i - 1] as u64));
        i += 1;
    }
    out
}

static RX_ASSIGN: [EntryDesc; RX_ASSIGN_MAX + 1] = assignment(&RX_ASSIGN_DEFAULT);
static TX_ASSIGN: [EntryDesc; TX_ASSIGN_MAX + 1] = assignment(&TX_ASSIGN_DEFAULT);

/// 0x1003 (CiA 301): the Emergencies the gateway sent.
static ERROR_FIELD: [EntryDesc; ERROR_HISTORY + 1] = {
    let mut out = [EntryDesc::count(0).with_access(RW); ERROR_HISTORY + 1];
    let mut i = 1;
    while i <= ERROR_HISTORY {
        out[i] = EntryDesc::new(i as u8, ASSIGN_NAMES[i - 1], U32, RO);
        i += 1;
    }
    out
};

/// 0x1C00: the SyncManagers' communication types, from the layout.
static SM_TYPES: [EntryDesc; 5] = [
    EntryDesc::count(4),
    EntryDesc::new(1, "SubIndex 001", U8, RO)
        .with_default(Value::Uint(SYNC_MANAGERS[0].role.sii_type() as u64)),
    EntryDesc::new(2, "SubIndex 002", U8, RO)
        .with_default(Value::Uint(SYNC_MANAGERS[1].role.sii_type() as u64)),
    EntryDesc::new(3, "SubIndex 003", U8, RO)
        .with_default(Value::Uint(SYNC_MANAGERS[2].role.sii_type() as u64)),
    EntryDesc::new(4, "SubIndex 004", U8, RO)
        .with_default(Value::Uint(SYNC_MANAGERS[3].role.sii_type() as u64)),
];

/// 0x1C32 (outputs) / 0x1C33 (inputs), served by the slave application's sync monitor, with
/// the figures of [`super::sync`] as defaults.
static SYNC_PARAMETERS: [EntryDesc; 15] = sync_objects::sync_parameters(&FIGURES);
static SYNC_OUTPUT_DEFAULTS: [EntryDefault; 3] = sync_objects::output_defaults(&FIGURES);
static SYNC_INPUT_DEFAULTS: [EntryDefault; 3] = sync_objects::input_defaults(&FIGURES);

/// 0x10F3 (ETG.1020 diagnosis history).
static DIAG_HISTORY: [EntryDesc; 5 + DIAG_MESSAGES + 1] = {
    const MESSAGE_NAMES: [&str; DIAG_MESSAGES] = [
        "Diagnosis message 001",
        "Diagnosis message 002",
        "Diagnosis message 003",
        "Diagnosis message 004",
        "Diagnosis message 005",
        "Diagnosis message 006",
        "Diagnosis message 007",
        "Diagnosis message 008",
    ];
    let mut out = [EntryDesc::count((5 + DIAG_MESSAGES) as u8); 5 + DIAG_MESSAGES + 1];
    out[1] = EntryDesc::new(1, "Maximum messages", U8, RO)
        .with_default(Value::Uint(DIAG_MESSAGES as u64));
    out[2] = EntryDesc::new(2, "Newest message", U8, RO);
    out[3] = EntryDesc::new(3, "Newest acknowledged message", U8, RW);
    out[4] = EntryDesc::new(4, "New messages available", BOOL, RO);
    out[5] = EntryDesc::new(5, "Flags", U16, RW);
    let mut i = 0;
    while i < DIAG_MESSAGES {
        out[6 + i] = EntryDesc::new(6 + i as u8, MESSAGE_NAMES[i], DataType::OctetString, RO)
            .with_bits((DIAG_MESSAGE_BYTES * 8) as u16);
        i += 1;
    }
    out
};

const MODULE_LIST_NAMES: [&str; MAX_NODES] = [
    "Module 1", "Module 2", "Module 3", "Module 4", "Module 5", "Module 6", "Module 7", "Module 8",
];

/// 0xF030 / 0xF050: one product code per place.
static MODULE_LIST: [EntryDesc; MAX_NODES + 1] = {
    let mut out = [EntryDesc::count(MAX_NODES as u8); MAX_NODES + 1];
    let mut i = 1;
    while i <= MAX_NODES {
        out[i] = EntryDesc::new(i as u8, MODULE_LIST_NAMES[i - 1], U32, RO);
        i += 1;
    }
    out
};

static STATUS_ENTRIES: [EntryDesc; status_sub::LAST as usize + 1] = [
    EntryDesc::count(status_sub::LAST),
    EntryDesc::new(1, "Nodes operational", U16, RO.tx_mappable()),
    EntryDesc::new(2, "Nodes faulty", U16, RO.tx_mappable()),
    EntryDesc::new(3, "Frames received", U32, RO),
    EntryDesc::new(4, "SYNCs sent", U32, RO),
    EntryDesc::new(5, "RPDOs sent", U32, RO),
    EntryDesc::new(6, "Frames lost", U32, RO),
];

/// The gateway's CAN bit rate (bit/s): the seed case's 1 Mbit/s.
pub const BIT_RATE: u32 = 1_000_000;

static MASTER_ENTRIES: [EntryDesc; master_sub::LAST as usize + 1] = [
    EntryDesc::count(master_sub::LAST),
    EntryDesc::new(1, "Bit rate (kbit/s)", U16, RO)
        .with_default(Value::Uint((BIT_RATE / 1000) as u64)),
    EntryDesc::new(2, "Node-ID", U8, RWP)
        .with_default(Value::Uint(0x7F))
        .with_range(&ValueRange::new(Value::Uint(1), Value::Uint(127))),
    EntryDesc::new(3, "SYNC COB-ID", U32, RWP).with_default(Value::Uint(0x80)),
    EntryDesc::new(4, "Sync multiplier", U8, RWP).with_default(Value::Uint(1)),
    EntryDesc::new(5, "SYNC period (us)", U32, RWP),
    EntryDesc::new(6, "SDO timeout (ms)", U16, RWP)
        .with_default(Value::Uint(100))
        .with_range(&ValueRange::new(Value::Uint(1), Value::Uint(60_000))),
    EntryDesc::new(7, "Boot-up wait (ms)", U16, RWP).with_default(Value::Uint(500)),
    EntryDesc::new(8, "Retry (ms)", U16, RWP).with_default(Value::Uint(1000)),
    EntryDesc::new(9, "Heartbeat (ms)", U16, RWP),
    EntryDesc::new(10, "Policies", U16, RWP),
];

static MDP_ENTRIES: [EntryDesc; 3] = [
    EntryDesc::count(2),
    EntryDesc::new(1, "Module index distance", U16, RO)
        .with_default(Value::Uint(MODULE_DISTANCE as u64)),
    EntryDesc::new(2, "Maximum number of modules", U16, RO)
        .with_default(Value::Uint(MAX_NODES as u64)),
];

/// The gateway's own objects (all but the per-node ones and the identity), in index order.
static GATEWAY_OBJECTS: [ObjectDesc; 16] = [
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[EntryDesc::new(0, "Device type", U32, RO).with_default(Value::Uint(DEVICE_TYPE as u64))],
    ),
    ObjectDesc::var(
        0x1001,
        "Error register",
        &[EntryDesc::new(0, "Error register", U8, RO)],
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
    ObjectDesc::record(
        DIAG_HISTORY_INDEX,
        "Diagnosis history",
        DataType::Unknown(0x0046),
        &DIAG_HISTORY,
    ),
    ObjectDesc::record(
        STATUS_TXPDO,
        "Gateway status TxPDO",
        DataType::PdoMapping,
        &STATUS_PDO_MAPPING,
    ),
    ObjectDesc::array(0x1C00, "Sync manager type", &SM_TYPES),
    ObjectDesc::array(0x1C12, "RxPDO assign", &RX_ASSIGN),
    ObjectDesc::array(0x1C13, "TxPDO assign", &TX_ASSIGN),
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
        MDP_INDEX,
        "Modular device profile",
        DataType::Unknown(0x0043),
        &MDP_ENTRIES,
    ),
    ObjectDesc::array(
        CONFIGURED_MODULES_INDEX,
        "Configured module ident list",
        &MODULE_LIST,
    ),
    ObjectDesc::array(
        DETECTED_MODULES_INDEX,
        "Detected module ident list",
        &MODULE_LIST,
    ),
    ObjectDesc::record(
        STATUS_INDEX,
        "Gateway status",
        DataType::Unknown(0x0044),
        &STATUS_ENTRIES,
    ),
    ObjectDesc::record(
        MASTER_INDEX,
        "CAN master parameters",
        DataType::Unknown(0x0045),
        &MASTER_ENTRIES,
    ),
];

/// One object per place from `base`, all with `entries`, named from `names`.
const fn per_place(
    base: u16,
    names: &[&'static str; MAX_NODES],
    array: bool,
    data_type: DataType,
    entries: &'static [EntryDesc],
) -> [ObjectDesc; MAX_NODES] {
    let mut out = [ObjectDesc::var(0, "", &[]); MAX_NODES];
    let mut n = 0;
    while n < MAX_NODES {
        let index = base + n as u16 * MODULE_DISTANCE;
        out[n] = if array {
            ObjectDesc::array(index, names[n], entries)
        } else {
            ObjectDesc::record(index, names[n], data_type, entries)
        };
        n += 1;
    }
    out
}

/// The fixed PDO mapping objects of the places (0x1600 + n or 0x1A00 + n).
const fn node_pdos(
    base: u16,
    names: &[&'static str; MAX_NODES],
    defaults: &'static [[EntryDefault; 2]; MAX_NODES],
) -> [ObjectDesc; MAX_NODES] {
    let mut out = [ObjectDesc::var(0, "", &[]); MAX_NODES];
    let mut n = 0;
    while n < MAX_NODES {
        out[n] = ObjectDesc::record(
            base + n as u16,
            names[n],
            DataType::PdoMapping,
            &NODE_PDO_MAPPING,
        )
        .with_defaults(&defaults[n]);
        n += 1;
    }
    out
}

static RXPDOS: [ObjectDesc; MAX_NODES] = node_pdos(RXPDO_BASE, &RXPDO_NAMES, &RXPDO_DEFAULTS);
static TXPDOS: [ObjectDesc; MAX_NODES] = node_pdos(TXPDO_BASE, &TXPDO_NAMES, &TXPDO_DEFAULTS);
static INPUTS: [ObjectDesc; MAX_NODES] =
    per_place(INPUTS_BASE, &INPUT_NAMES, true, U32, &INPUT_ENTRIES);
static OUTPUTS: [ObjectDesc; MAX_NODES] =
    per_place(OUTPUTS_BASE, &OUTPUT_NAMES, true, U32, &OUTPUT_ENTRIES);
static CONFIGS: [ObjectDesc; MAX_NODES * 3] = merge_objects(&[
    &per_place(
        CONFIG_BASE,
        &CONFIG_NAMES,
        false,
        DataType::Unknown(0x0047),
        &CONFIG_ENTRIES,
    ),
    &per_place(
        TPDO_MAP_BASE,
        &TPDO_MAP_NAMES,
        true,
        U32,
        &PDO_MAP_ENTRIES_TABLE,
    ),
    &per_place(
        RPDO_MAP_BASE,
        &RPDO_MAP_NAMES,
        true,
        U32,
        &PDO_MAP_ENTRIES_TABLE,
    ),
]);
static DIAGS: [ObjectDesc; MAX_NODES] = per_place(
    DIAG_BASE,
    &DIAG_NAMES,
    false,
    DataType::Unknown(0x0048),
    &DIAG_ENTRIES,
);

static IDENTITY_OBJECTS: [ObjectDesc; 4] = identity_objects!(IDENTITY, NAMES);

/// Objects in the dictionary.
pub const OBJECT_COUNT: usize = 4 + 16 + 8 * MAX_NODES;

static OBJECTS: [ObjectDesc; OBJECT_COUNT] = merge_objects(&[
    &IDENTITY_OBJECTS,
    &GATEWAY_OBJECTS,
    &RXPDOS,
    &TXPDOS,
    &INPUTS,
    &OUTPUTS,
    &CONFIGS,
    &DIAGS,
]);

/// The gateway's object dictionary.
pub static OD: ObjectDictionary = ObjectDictionary::new(&OBJECTS);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};
