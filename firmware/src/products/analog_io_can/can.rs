//! The module as a CANopen device on CAN (CiA 301 / CiA 401): node-ID and bit rate, the
//! defaults of the communication parameters (the CiA 401 PDO set), the objects that decide
//! which fieldbus drives the outputs, and what the EDS says beyond the dictionary.
//!
//! # CiA 401 PDOs
//!
//! CiA 401 gives PDO 1 to digital I/O, which this module has not, so RPDO 1 and TPDO 1 are
//! not valid by default (their mappings, 0x1600 and 0x1A00, are the EtherCAT side's
//! default PDOs; 0x1A00 holds all eight inputs, 128 bits, more than a CAN frame).
//! The analog PDOs:
//!
//! | PDO | COB-ID | mapping | transmission |
//! |---|---|---|---|
//! | RPDO 2 | 0x300 + node-ID | 0x1601: 0x6411:01, 0x6411:02 (AO 1, AO 2) | 255: applied on reception |
//! | TPDO 2 | 0x280 + node-ID | 0x1A01: 0x6401:01..04 (AI 1..4) | 255: event-driven |
//! | TPDO 3 | 0x380 + node-ID | 0x1A02: 0x6401:05..08 (AI 5..8) | 255: event-driven |
//!
//! Event-driven analog inputs go out when the node becomes operational, on their event
//! timer (0x1800+n:05, 0 by default) and, with 0x6423 "global interrupt enable" TRUE, when
//! their values change (limited by the inhibit time); for a SYNC-driven exchange set the
//! transmission type to 1..240 (every n-th SYNC).
//!
//! # Which fieldbus drives the outputs
//!
//! [`PROCESS_DATA_SOURCE_INDEX`] (UNSIGNED8) chooses: [`SOURCE_ETHERCAT`] (the default) or
//! [`SOURCE_CAN`]. It can only change while neither fieldbus runs process data (the ESM in
//! INIT or PREOP, the CAN node not operational; 0x08000022 otherwise). The other fieldbus
//! keeps serving SDOs and its inputs: CAN TPDOs go out whatever the source; EtherCAT
//! reaches SAFEOP/OP with the source on CAN only without RxPDOs assigned (0x001D invalid
//! output configuration otherwise); RPDOs arriving while EtherCAT is the source are dropped.

use crate::io::analog::process_data::{RX_PDOS, TX_PDOS};
use coe_core::canopen::cob;
use coe_core::canopen::params::{CommDefaults, PdoDefault};
use coe_core::eds::EdsInfo;

/// The node-ID unless configured otherwise (CiA 301: 1..=127). The board has no node-ID
/// switch; UNCONFIRMED: a product fixes it here or adds LSS (CiA 305).
pub const DEFAULT_NODE_ID: u8 = 5;

/// The CAN bit rate unless configured otherwise (bit/s).
pub const DEFAULT_BIT_RATE: u32 = 500_000;

/// Heartbeat consumer entries (0x1016:01..).
pub const HEARTBEAT_CONSUMERS: usize = 4;

/// Emergencies that can wait for the CAN bus.
pub const CAN_EMERGENCY_QUEUE: usize = 4;

/// Which fieldbus drives the outputs (manufacturer object, UNSIGNED8).
pub const PROCESS_DATA_SOURCE_INDEX: u16 = 0x2002;
/// [`PROCESS_DATA_SOURCE_INDEX`] value: EtherCAT drives the outputs (the default).
pub const SOURCE_ETHERCAT: u8 = 0;
/// [`PROCESS_DATA_SOURCE_INDEX`] value: CAN drives the outputs.
pub const SOURCE_CAN: u8 = 1;

/// CiA 401 0x6423 "analog input global interrupt enable" (BOOLEAN): event-driven TPDOs go
/// out on a change of the inputs. No effect on EtherCAT.
pub const AI_INTERRUPT_ENABLE_INDEX: u16 = 0x6423;

/// The communication parameters' defaults: the CiA 401 PDO set above, no heartbeat (node
/// guarding answers until 0x1017 is set), pre-operational on a communication error.
pub static COMM_DEFAULTS: CommDefaults<RX_PDOS, TX_PDOS> = CommDefaults {
    rpdo: [
        PdoDefault::new(0x200, false, 255),
        PdoDefault::new(0x300, true, 255),
    ],
    tpdo: [
        PdoDefault::new(0x180, false, 255),
        PdoDefault::new(0x280, true, 255),
        PdoDefault::new(0x380, true, 255),
    ],
    heartbeat_ms: 0,
    guard_time_ms: 0,
    life_factor: 0,
    emcy_inhibit_100us: 0,
    error_behaviour: 0,
};

/// The EDS's own facts.
pub const EDS_INFO: EdsInfo = EdsInfo {
    file_version: 1,
    file_revision: 0,
    date: "11-26-2026",
    created_by: "cargo xtask esi",
    // 10, 20, 50, 125, 250, 500, 1000 kbit/s; not 800 (no exact timing at 100 MHz).
    bit_rates: [true, true, true, true, true, true, false, true],
    granularity: 8,
};

const _: () = assert!(cob::is_node_id(DEFAULT_NODE_ID));

#[cfg(test)]
mod tests {
    use super::*;
    use crate::platform::chip::can::bit_timing;
    use coe_core::eds::BIT_RATES_KBIT;

    /// PCLK of CAN1 (the hardware layer's `PCLK_HZ`, CCLK / 1; that layer is not compiled on
    /// the host).
    const CAN_PCLK_HZ: u32 = 100_000_000;

    #[test]
    fn the_eds_lists_the_bit_rates_the_driver_can_time() {
        for (kbit, listed) in BIT_RATES_KBIT.iter().zip(EDS_INFO.bit_rates) {
            let timed = bit_timing(CAN_PCLK_HZ, u32::from(*kbit) * 1000).is_some();
            assert_eq!(listed, timed, "{kbit} kbit/s");
        }
        assert!(bit_timing(CAN_PCLK_HZ, DEFAULT_BIT_RATE).is_some());
    }
}
