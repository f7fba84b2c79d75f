//! The analog front end of the board: converters' reference, the input divider and the
//! output amplifier, and the terminal full scale they give. The conversions between
//! converter codes, process values and volts are the application's
//! (`crate::io::analog::scaling`).

/// Reference voltage of the AD7689 and the AD5663 (external 2.5 V), in microvolts.
pub const REFERENCE_UV: u32 = 2_500_000;
/// Input divider ratio (terminal voltage / ADC voltage, 1/4 divider) and output gain
/// (terminal / DAC, x4 amplifier).
pub const FRONT_END_GAIN: u32 = 4;
/// Terminal full scale in microvolts (10 V): `REFERENCE_UV * FRONT_END_GAIN`.
pub const FULL_SCALE_UV: u32 = REFERENCE_UV * FRONT_END_GAIN;
