//! Analog scaling: converter codes <-> CiA 401 INTEGER16 process values <-> volts. The
//! conversions live here; the front end they follow (reference, divider and gain, full
//! scale) is the product's ([`crate::platform::board`]).
//!
//! # Inputs (AD7689, 8 channels)
//!
//! The terminal range 0..10 V passes a 1/4 resistor divider to 0..2.5 V at the ADC input,
//! which converts unipolar against GND with the external 2.5 V reference (straight binary,
//! AD7689 data sheet "Transfer functions"):
//!
//! ```text
//! V_adc      = code * 2.5 V / 65536
//! V_terminal = 4 * V_adc = code * 10 V / 65536
//! AI (0x6401) = code >> 1                  (0..=32767, INTEGER16, CiA 401 "0x7FFF = full scale")
//! V_terminal = AI * 10 V / 32768           (1 LSB = 305.2 uV; 0x7FFF = 9.99969 V)
//! ```
//!
//! The value keeps 15 of the 16 converter bits, so it is never negative and a master that
//! scales with the usual "0x7FFF = 10 V" convention shows the right voltage.
//!
//! # Outputs (AD5663, 2 channels)
//!
//! The DAC runs from the same 2.5 V reference, and a x4 amplifier after it gives 0..10 V:
//!
//! ```text
//! V_dac      = D * 2.5 V / 65536,  V_terminal = 4 * V_dac = D * 10 V / 65536
//! D          = AO << 1 for AO in 0..=32767 (0x6411, INTEGER16); AO < 0 -> D = 0 (0 V)
//! V_terminal = AO * 10 V / 32768           (the same scale as the inputs)
//! ```
//!
//! A negative AO value cannot be produced by the unipolar output stage: it is clamped to 0 V
//! and reported as out of range ([`ao_in_range`]).

use crate::platform::board::FULL_SCALE_UV;

/// Converter codes per full scale (16-bit converters).
pub const CODES: u32 = 1 << 16;
/// INTEGER16 process-value steps per full scale (`0x7FFF` is one step below full scale).
pub const PV_STEPS: u32 = 1 << 15;

/// AD7689 code (unipolar straight binary) -> 0x6401 value.
pub const fn adc_code_to_ai(code: u16) -> i16 {
    (code >> 1) as i16
}

/// AD7689 code -> terminal voltage in microvolts (0..=9_999_847).
pub const fn adc_code_to_microvolts(code: u16) -> u32 {
    ((code as u64 * FULL_SCALE_UV as u64) / CODES as u64) as u32
}

/// 0x6401/0x6411 value -> terminal voltage in microvolts (negative values give negative
/// microvolts; the output stage clamps them to 0 V).
pub const fn pv_to_microvolts(value: i16) -> i32 {
    ((value as i64 * FULL_SCALE_UV as i64) / PV_STEPS as i64) as i32
}

/// True if an 0x6411 value is inside the range the output stage can produce (0..=0x7FFF).
pub const fn ao_in_range(value: i16) -> bool {
    value >= 0
}

/// 0x6411 value -> AD5663 code: `AO << 1`, negative values clamped to 0 (0 V).
pub const fn ao_to_dac_code(value: i16) -> u16 {
    if value < 0 {
        0
    } else {
        (value as u16) << 1
    }
}

/// AD5663 code -> 0x6411 value (the inverse of [`ao_to_dac_code`] for its results).
pub const fn dac_code_to_ao(code: u16) -> i16 {
    (code >> 1) as i16
}

/// 0x6444 fault value (INTEGER32 in 0x6411 units) -> AD5663 code, clamped to 0..=0x7FFF.
pub const fn fault_value_to_dac_code(value: i32) -> u16 {
    let clamped = if value < 0 {
        0
    } else if value > i16::MAX as i32 {
        i16::MAX
    } else {
        value as i16
    };
    ao_to_dac_code(clamped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_scale_end_points() {
        assert_eq!(adc_code_to_ai(0), 0);
        assert_eq!(adc_code_to_ai(0xFFFF), 0x7FFF);
        assert_eq!(adc_code_to_ai(0x8000), 0x4000);
        assert_eq!(adc_code_to_microvolts(0), 0);
        // Half scale: 5 V.
        assert_eq!(adc_code_to_microvolts(0x8000), 5_000_000);
        // Full scale: 10 V - 1 LSB (152.6 uV).
        assert_eq!(adc_code_to_microvolts(0xFFFF), 9_999_847);
        assert_eq!(pv_to_microvolts(0x4000), 5_000_000);
        assert_eq!(pv_to_microvolts(0x7FFF), 9_999_694);
        assert_eq!(pv_to_microvolts(-16384), -5_000_000);
    }

    #[test]
    fn output_scale_and_clamp() {
        assert_eq!(ao_to_dac_code(0), 0);
        assert_eq!(ao_to_dac_code(0x4000), 0x8000);
        assert_eq!(ao_to_dac_code(0x7FFF), 0xFFFE);
        assert_eq!(ao_to_dac_code(-1), 0);
        assert_eq!(ao_to_dac_code(i16::MIN), 0);
        assert!(ao_in_range(0) && ao_in_range(i16::MAX) && !ao_in_range(-1));
        for ao in [0i16, 1, 1000, 0x4000, 0x7FFF] {
            assert_eq!(dac_code_to_ao(ao_to_dac_code(ao)), ao);
        }
        assert_eq!(fault_value_to_dac_code(0x4000), 0x8000);
        assert_eq!(fault_value_to_dac_code(-5), 0);
        assert_eq!(fault_value_to_dac_code(100_000), 0xFFFE);
        assert_eq!(fault_value_to_dac_code(i32::MIN), 0);
    }

    #[test]
    fn inputs_and_outputs_share_one_scale() {
        for ao in [0i16, 123, 0x4000, 0x7FFF] {
            let code = ao_to_dac_code(ao);
            assert_eq!(adc_code_to_ai(code), ao);
            assert_eq!(
                adc_code_to_microvolts(code) as i32 / 10,
                pv_to_microvolts(ao) / 10
            );
        }
    }
}
