//! The figures the gateway advertises in 0x1C32/0x1C33 and the ESI, and the slave
//! application enforces (`crate::stacks::ethercat::sync`).
//!
//! The process image is large for the legacy SPI PDI (up to 128 B out, 132 B in: about
//! 0.77 us per byte, README's PDI row), and the CAN side works in whole CAN cycles (a SYNC,
//! then every node's PDOs: a 1 Mbit/s frame takes 111..135 us), so the gateway's shortest
//! EtherCAT cycle is set by the CAN cycle, not the PDI: [`MIN_CYCLE_TIME_NS`] is the
//! shortest cycle a CAN cycle of one SYNC per EtherCAT cycle makes sense at, and
//! `cargo xtask bench --product can-gateway` measures the image against it.

use crate::stacks::ethercat::sync::{Figures, SyncFigures};

/// Shortest EtherCAT cycle (0x1C32:05/0x1C33:05, the ESI's DC minimum): 1 ms.
pub const MIN_CYCLE_TIME_NS: u32 = 1_000_000;
/// SM2 event to the outputs handed to the CAN master (0x1C32:06): the whole output image
/// read over SPI (128 B at about 0.77 us) plus the copy into the nodes' RPDOs.
pub const OUTPUT_CALC_COPY_NS: u32 = 120_000;
/// Inputs: latch to SM3 written (0x1C33:06): the nodes' TPDO data copied and the 132 B
/// written over SPI.
pub const INPUT_CALC_COPY_NS: u32 = 125_000;
/// Read changed outputs twice at every cycle (`crate::stacks::ethercat::confirm`): the
/// cycle is long enough for the second read.
pub const CONFIRM_OUTPUTS_MIN_CYCLE_NS: u32 = 0;
/// Default Sync Error Counter Limit (0x10F1:02).
pub const DEFAULT_SYNC_ERROR_LIMIT: u16 = 4;

/// The figures as the slave application takes them.
pub const FIGURES: SyncFigures = SyncFigures {
    min_cycle_ns: MIN_CYCLE_TIME_NS,
    output_calc_copy_ns: OUTPUT_CALC_COPY_NS,
    // Outputs reach the nodes with the CAN cycle's RPDOs, after the SYNC: not a fixed
    // delay of the device.
    output_delay_ns: 0,
    input_calc_copy_ns: INPUT_CALC_COPY_NS,
    // The whole input image (132 B at most) is in INPUT_CALC_COPY_NS.
    input_calc_copy_bytes: 132,
    input_copy_ns_per_byte: 770,
    confirm_outputs_min_cycle_ns: CONFIRM_OUTPUTS_MIN_CYCLE_NS,
    default_error_limit: DEFAULT_SYNC_ERROR_LIMIT,
};

/// The figures as a type, for the generic sync monitor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GatewayFigures;

impl Figures for GatewayFigures {
    const SYNC: SyncFigures = FIGURES;
}
