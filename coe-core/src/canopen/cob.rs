//! The predefined connection set (CiA 301 7.3.3): the default COB-IDs a node derives from its
//! node-ID, so a simple network needs no identifier configuration.
//!
//! | object | COB-ID | configured in |
//! |---|---|---|
//! | NMT module control | 0x000 | - |
//! | SYNC | 0x080 | 0x1005 |
//! | EMCY | 0x080 + node-ID | 0x1014 |
//! | TIME | 0x100 | 0x1012 |
//! | TPDO 1..4 | 0x180 / 0x280 / 0x380 / 0x480 + node-ID | 0x1800..0x1803 |
//! | RPDO 1..4 | 0x200 / 0x300 / 0x400 / 0x500 + node-ID | 0x1400..0x1403 |
//! | SDO server -> client | 0x580 + node-ID | 0x1200 |
//! | SDO client -> server | 0x600 + node-ID | 0x1200 |
//! | NMT error control (boot-up, heartbeat, node guarding) | 0x700 + node-ID | 0x1016, 0x1017, 0x100C/0x100D |

/// NMT module control (master -> all slaves).
pub const NMT: u16 = 0x000;
/// SYNC (default of 0x1005).
pub const SYNC: u16 = 0x080;
/// EMCY base (+ node-ID; default of 0x1014).
pub const EMCY: u16 = 0x080;
/// TIME stamp (default of 0x1012).
pub const TIME: u16 = 0x100;
/// SDO server -> client base (+ node-ID).
pub const SDO_TX: u16 = 0x580;
/// SDO client -> server base (+ node-ID).
pub const SDO_RX: u16 = 0x600;
/// NMT error control base (+ node-ID).
pub const NMT_ERROR_CONTROL: u16 = 0x700;

/// The lowest and highest node-ID (0 is reserved for "all nodes" in NMT commands).
pub const NODE_IDS: core::ops::RangeInclusive<u8> = 1..=127;

/// The default COB-ID of TPDO `n` (1..=4) of node `node`; `None` outside the four PDOs of
/// the predefined set.
pub const fn tpdo(n: u8, node: u8) -> Option<u16> {
    match n {
        1..=4 => Some(0x080 + 0x100 * n as u16 + node as u16),
        _ => None,
    }
}

/// The default COB-ID of RPDO `n` (1..=4) of node `node`.
pub const fn rpdo(n: u8, node: u8) -> Option<u16> {
    match n {
        1..=4 => Some(0x100 + 0x100 * n as u16 + node as u16),
        _ => None,
    }
}

/// A node-ID is 1..=127.
pub const fn is_node_id(node: u8) -> bool {
    node >= 1 && node <= 127
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn predefined_pdo_ids() {
        assert_eq!(tpdo(1, 5), Some(0x185));
        assert_eq!(rpdo(1, 5), Some(0x205));
        assert_eq!(tpdo(2, 5), Some(0x285));
        assert_eq!(rpdo(2, 5), Some(0x305));
        assert_eq!(tpdo(4, 127), Some(0x4FF));
        assert_eq!(rpdo(4, 127), Some(0x57F));
        assert_eq!(tpdo(0, 1), None);
        assert_eq!(rpdo(5, 1), None);
    }

    #[test]
    fn node_ids() {
        assert!(!is_node_id(0));
        assert!(is_node_id(1));
        assert!(is_node_id(127));
        assert!(!is_node_id(128));
    }
}
