//! Volts <-> code, as pure functions of the board's reference and output gain.
//!
//! The AD5663 is a straight-binary 16-bit DAC: `V_dac = code / 65536 * V_REF`. A board
//! amplifier after it multiplies by `gain`, so
//!
//! ```text
//! V_out = code / 65536 * V_REF * gain
//! ```
//!
//! The reference board of this project (2.5 V external reference, ×4 amplifier, 0..10 V
//! outputs) is `OutputScale::new(2.5, 4.0)`: 1 LSB = 152.6 µV, code 0x8000 = 5.0 V, code
//! 0xFFFF = 9.99985 V (10 V itself is not reachable). The driver core knows nothing about the
//! board: the scale is always a parameter.

/// Reference voltage and gain of one output, for the conversions below.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutputScale {
    /// Reference voltage at the DAC's VREF pin (volts).
    pub vref: f32,
    /// Gain of the amplifier after the DAC (1.0 without one).
    pub gain: f32,
}

impl OutputScale {
    /// A scale with reference `vref` volts and amplifier gain `gain`.
    pub const fn new(vref: f32, gain: f32) -> Self {
        Self { vref, gain }
    }

    /// Output voltage for `code`. See [`code_to_volts`].
    pub fn volts(&self, code: u16) -> f32 {
        code_to_volts(code, self.vref, self.gain)
    }

    /// Code for `volts`, `None` outside the range. See [`volts_to_code`].
    pub fn code(&self, volts: f32) -> Option<u16> {
        volts_to_code(volts, self.vref, self.gain)
    }

    /// Code for `volts`, clamped into the range. See [`volts_to_code_clamped`].
    pub fn code_clamped(&self, volts: f32) -> u16 {
        volts_to_code_clamped(volts, self.vref, self.gain)
    }
}

/// Output voltage for `code`: `code / 65536 * vref * gain`.
pub fn code_to_volts(code: u16, vref: f32, gain: f32) -> f32 {
    code as f32 / 65536.0 * vref * gain
}

/// `volts / (vref * gain) * 65536`, not yet rounded; `None` for a full scale that is not a
/// positive finite number.
fn ideal_code(volts: f32, vref: f32, gain: f32) -> Option<f32> {
    let full_scale = vref * gain;
    if !(full_scale.is_finite() && full_scale > 0.0) {
        return None;
    }
    Some(volts / full_scale * 65536.0)
}

/// The nearest code for `volts`, or `None` if `volts` is not a number, is below 0 V, or rounds
/// to a code above 0xFFFF (that is, `volts >= (65535.5 / 65536) * vref * gain`), or if
/// `vref * gain` is not a positive number. Never panics.
pub fn volts_to_code(volts: f32, vref: f32, gain: f32) -> Option<u16> {
    let x = ideal_code(volts, vref, gain)?;
    // NaN fails both comparisons.
    if (-0.5..65535.5).contains(&x) {
        // In range: non-negative after +0.5, so `as` truncates to the rounded value.
        Some((x + 0.5) as u16)
    } else {
        None
    }
}

/// Like [`volts_to_code`] but clamps out-of-range voltages to 0 or 0xFFFF; NaN (or an invalid
/// scale) gives 0, the power-on output. Never panics.
pub fn volts_to_code_clamped(volts: f32, vref: f32, gain: f32) -> u16 {
    match ideal_code(volts, vref, gain) {
        // `as` saturates; NaN becomes 0.
        Some(x) => (x + 0.5) as u16,
        None => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOARD: OutputScale = OutputScale::new(2.5, 4.0);

    #[test]
    fn board_scale_points() {
        assert_eq!(BOARD.volts(0), 0.0);
        assert_eq!(BOARD.volts(0x8000), 5.0);
        let d = BOARD.volts(0xFFFF) - 9.999_847;
        assert!(d > -1e-5 && d < 1e-5);
        assert_eq!(BOARD.code(0.0), Some(0));
        assert_eq!(BOARD.code(5.0), Some(0x8000));
        assert_eq!(BOARD.code(2.5), Some(0x4000));
        assert_eq!(BOARD.code(9.9998), Some(0xFFFF));
    }

    #[test]
    fn round_trip_every_code() {
        for code in 0..=u16::MAX {
            assert_eq!(BOARD.code(BOARD.volts(code)), Some(code));
        }
    }

    #[test]
    fn out_of_range() {
        assert_eq!(BOARD.code(10.0), None);
        assert_eq!(BOARD.code(-0.001), None);
        assert_eq!(BOARD.code(f32::NAN), None);
        assert_eq!(BOARD.code(f32::INFINITY), None);
        assert_eq!(volts_to_code(1.0, 0.0, 4.0), None);
        assert_eq!(volts_to_code(1.0, 2.5, f32::NAN), None);
        assert_eq!(volts_to_code(1.0, -2.5, 4.0), None);
    }

    #[test]
    fn clamped() {
        assert_eq!(BOARD.code_clamped(11.0), 0xFFFF);
        assert_eq!(BOARD.code_clamped(-3.0), 0);
        assert_eq!(BOARD.code_clamped(f32::NAN), 0);
        assert_eq!(BOARD.code_clamped(f32::NEG_INFINITY), 0);
        assert_eq!(BOARD.code_clamped(5.0), 0x8000);
        assert_eq!(volts_to_code_clamped(1.0, 0.0, 1.0), 0);
    }

    #[test]
    fn unity_gain() {
        assert_eq!(volts_to_code(1.25, 2.5, 1.0), Some(0x8000));
        assert_eq!(code_to_volts(0x4000, 2.5, 1.0), 0.625);
    }
}
