//! Every number or behaviour this crate relies on that is **UNCONFIRMED** (the AD7689 timing
//! table was not found; see the project's hardware facts, section 6), in one place. Verify
//! these on hardware before depending on them.
//!
//! Also **UNCONFIRMED**, without a constant (behaviour of the driver's pipeline tracking):
//! - after a CFG with SEQ = 01 ("update configuration during sequence") while *no* scan runs,
//!   the driver assumes single conversions of INx, as with SEQ = 00 (the datasheet describes
//!   01 only for a running scan);
//! - a scan of *pairs* converts the pairs whose positive input (always even in a scan,
//!   datasheet Rev. D p. 20) is at most INx: IN0, IN2, ... (INx = 7 or 6: four conversions);
//! - with INCC = 011 (temperature) every conversion is the temperature sensor, also with the
//!   sequencer on;
//! - a CFG with SEQ = 10 or 11 restarts the scan at IN0 even when INCC and INx are unchanged.

/// **UNCONFIRMED**: maximum conversion time tCONV, ns (2.2 µs). CNV must stay high at least
/// this long in read-after-conversion mode before the result can be read.
pub const T_CONV_MAX_NS: u32 = 2_200;

/// **UNCONFIRMED**: minimum acquisition time tACQ, ns (1.8 µs): from the end of a conversion
/// to the next CNV rising edge.
pub const T_ACQ_MIN_NS: u32 = 1_800;

/// **UNCONFIRMED**: minimum conversion cycle tCYC, ns (4.0 µs = 1 / 250 kSPS; the sum of the
/// two above). [`Ad7689::wait_ready`](crate::Ad7689::wait_ready) waits this long in
/// read-after-conversion mode.
pub const T_CYC_MIN_NS: u32 = T_CONV_MAX_NS + T_ACQ_MIN_NS;

/// **UNCONFIRMED** for the AD7689 itself (sibling AD7699 DS p. 5 and the PulSAR AD7685/86 give
/// it): minimum CNV high pulse tCNVH, ns. In busy-indicator mode the driver raises and lowers
/// CNV with two back-to-back pin writes, which is longer on the MCUs this crate targets.
pub const T_CNVH_MIN_NS: u32 = 10;

/// **UNCONFIRMED**: temperature sensor output at 25 °C, volts (≈283 mV, from an Analog
/// Devices forum answer, not the datasheet).
pub const TEMP_SENSOR_VOLTS_AT_25C: f32 = 0.283;

/// **UNCONFIRMED**: temperature sensor slope, volts per °C (≈1 mV/°C, ≈16 LSB/°C at 4.096 V).
pub const TEMP_SENSOR_VOLTS_PER_C: f32 = 0.001;
