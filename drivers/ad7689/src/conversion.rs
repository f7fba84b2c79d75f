//! Codes to volts and degrees, as pure functions of the reference (and the board's divider).
//!
//! - Unipolar modes: straight binary, `V = code / 65536 * VREF` (0xFFFF = VREF · 65535/65536).
//! - Bipolar modes: two's complement around COM (or the pair's negative input at VREF/2),
//!   `V = (code as i16) / 65536 * VREF`, so −VREF/2 .. +VREF/2.
//! - Temperature sensor: read as unipolar, ≈283 mV at 25 °C and ≈1 mV/°C (**UNCONFIRMED**,
//!   [`unconfirmed`](crate::unconfirmed)); the sensor needs a REF setting that powers it
//!   ([`Reference::temperature_sensor_on`](crate::Reference::temperature_sensor_on)).

use crate::unconfirmed::{TEMP_SENSOR_VOLTS_AT_25C, TEMP_SENSOR_VOLTS_PER_C};

/// Voltage at the ADC input for a unipolar `code`: `code / 65536 * vref`.
pub fn unipolar_volts(code: u16, vref: f32) -> f32 {
    code as f32 / 65536.0 * vref
}

/// Voltage (IN+ minus COM or IN−) for a bipolar, two's complement `code`:
/// `(code as i16) / 65536 * vref`.
pub fn bipolar_volts(code: u16, vref: f32) -> f32 {
    code as i16 as f32 / 65536.0 * vref
}

/// Die temperature in °C for a temperature-sensor `code` read with reference `vref`:
/// `25 + (V − 0.283 V) / 0.001 V/°C` (constants **UNCONFIRMED**).
pub fn temperature_celsius(code: u16, vref: f32) -> f32 {
    25.0 + (unipolar_volts(code, vref) - TEMP_SENSOR_VOLTS_AT_25C) / TEMP_SENSOR_VOLTS_PER_C
}

/// Scaling of a unipolar input behind a resistive divider.
///
/// The reference board divides its 0..10 V inputs by 4 to 0..2.5 V and uses a 2.5 V external
/// reference: `InputScale::new(2.5, 4.0)`, 1 LSB = 152.6 µV at the connector, 0x8000 = 5 V.
/// The driver core knows nothing about the board: the scale is always a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InputScale {
    /// Reference voltage (volts).
    pub vref: f32,
    /// Division ratio from the connector to the ADC pin (4.0 for a 1/4 divider; 1.0 without).
    pub divider: f32,
}

impl InputScale {
    /// A scale with reference `vref` volts and a 1/`divider` input divider.
    pub const fn new(vref: f32, divider: f32) -> Self {
        Self { vref, divider }
    }

    /// Voltage at the connector for a unipolar `code`: `code / 65536 * vref * divider`.
    pub fn volts(&self, code: u16) -> f32 {
        unipolar_volts(code, self.vref) * self.divider
    }

    /// Full-scale voltage at the connector (`vref * divider`; the largest code is one LSB
    /// below it).
    pub fn full_scale(&self) -> f32 {
        self.vref * self.divider
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32) -> bool {
        let d = a - b;
        d > -1e-4 && d < 1e-4
    }

    #[test]
    fn unipolar() {
        assert_eq!(unipolar_volts(0, 2.5), 0.0);
        assert_eq!(unipolar_volts(0x8000, 2.5), 1.25);
        assert_eq!(unipolar_volts(0x8000, 4.096), 2.048);
        assert!(close(unipolar_volts(0xFFFF, 2.5), 2.499_962));
    }

    #[test]
    fn bipolar() {
        assert_eq!(bipolar_volts(0x0000, 2.5), 0.0);
        assert!(close(bipolar_volts(0x7FFF, 4.096), 2.047_937_5));
        assert_eq!(bipolar_volts(0x8000, 4.096), -2.048);
        assert_eq!(bipolar_volts(0xFFFF, 2.5), -2.5 / 65536.0);
    }

    #[test]
    fn temperature() {
        // 283 mV at 4.096 V = 4528 LSB -> 25 °C; 16 LSB more -> 26 °C (about 1 °C).
        let c25 = (0.283 / 4.096 * 65536.0) as u16;
        let t = temperature_celsius(c25, 4.096);
        assert!(t > 24.9 && t < 25.1, "{t}");
        let t = temperature_celsius(c25 + 16, 4.096);
        assert!(t > 25.9 && t < 26.1, "{t}");
        // Any code gives a finite number.
        assert!(temperature_celsius(0xFFFF, 2.5).is_finite());
    }

    #[test]
    fn board_input() {
        let board = InputScale::new(2.5, 4.0);
        assert_eq!(board.volts(0), 0.0);
        assert_eq!(board.volts(0x8000), 5.0);
        assert_eq!(board.volts(0x4000), 2.5);
        assert!(close(board.volts(0xFFFF), 9.999_847));
        assert_eq!(board.full_scale(), 10.0);
    }
}
