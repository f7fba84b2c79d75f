//! The module places of the gateway: how many CAN nodes it serves, their index distance in
//! the dictionary (ETG.5001) and how many bytes of each node's data the process image
//! carries. The dictionary ([`super::od`]) and the ESC layout ([`super::layout`]) are built
//! from these.

/// Node places (modules).
pub const MAX_NODES: usize = 8;
/// Index distance between two modules' objects (0xF000:01).
pub const MODULE_DISTANCE: u16 = 0x10;
/// UNSIGNED32 words of a node's data per direction (two 8-byte PDOs).
pub const DATA_WORDS: usize = 4;
/// Bytes of a node's data per direction.
pub const NODE_BYTES: usize = DATA_WORDS * 4;
/// CAN PDOs of a node per direction the gateway exchanges.
pub const NODE_PDOS: usize = 2;
/// Mapping entries per CAN PDO in 0x8001/0x8002 + 16n.
pub const PDO_MAP_ENTRIES: usize = 8;

/// Bytes of the status TxPDO.
pub const STATUS_BYTES: usize = 4;
