//! The figures the image advertises in 0x1C32/0x1C33 and the ESI, and the slave application
//! enforces (`crate::stacks::ethercat::sync`), measured on the image of the analog
//! products. `analog-io-can` advertises the same: its CAN window's rule sets the minimum
//! cycle of both (below).

use crate::stacks::ethercat::sync::{Figures, SyncFigures};

/// Shortest cycle the module handles: 0x1C32:05/0x1C33:05, the dictionary's default of
/// both in the ESI, the device description's DC minimum, and the limit the application
/// enforces on the SYNC0 cycle (AL status 0x0035) and on 0x1C32:02.
///
/// The rule: at least the shortest DC cycle with 2 AO + 8 AI that the release image sustains
/// on the co-simulated LPC1754 under a real master's traffic (`cargo xtask bench`: SDO
/// exchanges back to back in OP, frame jitter, moving inputs; no missed SYNC0, no stale
/// output, no late input, no lost sample; docs/book/traffic.md), plus
/// [`MIN_CYCLE_MARGIN_PERCENT`], and at least the shortest sustained with the time model's
/// cycles per instruction 20 % higher: 229 us sustained, 228 us not, so 263.4 us; 256 us at
/// CPI 3/2; rounded up to 270 us. The
/// bench prints the figures and fails when this constant is below them; after any change of the
/// firmware or of the co-simulator's time model, `cargo xtask bench --min-cycle` runs that
/// rule alone (and says when the constant could be lower): set the constant here. What
/// holds it up is the mailbox task's longest step under the lock of the PDI side (one
/// request through the SDO server, up to about 60 us). The CAN window has a rule of its
/// own: every kind of CANopen node call fits right after a cycle's outputs at this cycle
/// (`crate::stacks::canopen::window`, `every_kind_fits_after_the_outputs_at_the_advertised_minimum` in `analog-io-can`): the
/// SDO call's bound needs about 90 us.
pub const MIN_CYCLE_TIME_NS: u32 = 270_000;
/// Margin of [`MIN_CYCLE_TIME_NS`] over the measured minimum DC cycle, in percent: the
/// measurement rests on a time model no board has confirmed (the co-simulator's flat cycles
/// per instruction behind the flash accelerator). Its size comes from the bench's
/// sensitivity run: with every instruction 20 % dearer the shortest sustained cycle grows by
/// 12 to 18 % (docs/book/traffic.md).
pub const MIN_CYCLE_MARGIN_PERCENT: u32 = 15;
/// Outputs: SM2 event to outputs copied and staged (0x1C32:06): SM2 read over SPI (4.5 us)
/// plus unpack and staging.
pub const OUTPUT_CALC_COPY_NS: u32 = 8_000;
/// Outputs: SYNC0 edge to both DAC outputs updated (0x1C32:09): the write path (two 24-bit
/// frames, about 2.1 us at 25 MHz) bounds the LDAC path (about 0.3 us).
pub const OUTPUT_DELAY_NS: u32 = 3_000;
/// Inputs: latch to SM3 written (0x1C33:06): pack plus the 16-byte SM3 write (11.5 us).
pub const INPUT_CALC_COPY_NS: u32 = 15_000;
/// The SM3 bytes [`INPUT_CALC_COPY_NS`] covers: the eight one-value inputs.
pub const INPUT_CALC_COPY_BYTES: u16 = 16;
/// Each SM3 byte beyond those (0x1C33:06 with the oversampling blocks: 526 B with 8 sample
/// PDOs): the block's cut from the ADC ring, its packing and its write over the legacy SPI.
/// Measured on the image, from each SYNC0 edge to the block's last byte in SM3: at most
/// 215 us for 206 B (270 us, 3 sample PDOs), 270 us for 270 B (500 us, 4), 500 us for
/// 526 B (1 ms, 8); 1.1 us per byte covers each by 2 to 15 %. `oversampling_image.rs`
/// checks 0x1C33:06 against the measurement at 1 ms.
pub const INPUT_COPY_NS_PER_BYTE: u32 = 1_100;
/// Shortest DC cycle at which the application reads changed outputs twice before it takes
/// them (`crate::stacks::ethercat::confirm`, against a bit flipped on the SPI or SPI_SEL dropped in the
/// middle of the SM2 read). The second read costs one more SPI access per cycle whose
/// outputs changed, which the shortest cycles do not have; in SM-synchronous and free-run
/// mode the outputs are always read twice when they change.
///
/// The rule, as for [`MIN_CYCLE_TIME_NS`]: at least the minimum DC cycle with the second
/// read plus [`MIN_CYCLE_MARGIN_PERCENT`]. The bench does not check it: measured by hand
/// with this constant set to 0 (`cargo xtask bench`, formula F1: 53.2 us, + 15 % = 61.2 us);
/// re-measure after a change of the cycle's code.
pub const CONFIRM_OUTPUTS_MIN_CYCLE_NS: u32 = 62_000;
/// Default Sync Error Counter Limit (0x10F1:02).
pub const DEFAULT_SYNC_ERROR_LIMIT: u16 = 4;

/// The figures as the slave application takes them.
pub const FIGURES: SyncFigures = SyncFigures {
    min_cycle_ns: MIN_CYCLE_TIME_NS,
    output_calc_copy_ns: OUTPUT_CALC_COPY_NS,
    output_delay_ns: OUTPUT_DELAY_NS,
    input_calc_copy_ns: INPUT_CALC_COPY_NS,
    input_calc_copy_bytes: INPUT_CALC_COPY_BYTES,
    input_copy_ns_per_byte: INPUT_COPY_NS_PER_BYTE,
    confirm_outputs_min_cycle_ns: CONFIRM_OUTPUTS_MIN_CYCLE_NS,
    default_error_limit: DEFAULT_SYNC_ERROR_LIMIT,
};

/// The figures as a type, for the generic sync monitor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnalogFigures;

impl Figures for AnalogFigures {
    const SYNC: SyncFigures = FIGURES;
}
