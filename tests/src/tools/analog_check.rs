//! What a master's analog process data must be against the board's converters, for system
//! tests whose master runs outside the board's thread (a script in its own process, ethercrab
//! on a veth pair): the values it read at the analog inputs (0x6401) against the voltages the
//! AD7689 model was given, and the values it wrote to the analog outputs (0x6411) against the
//! codes the AD5663 model was loaded with.
//!
//! The scale is the module's (0..10 V, `0x7FFF` one step below full scale, hardware-facts
//! sections 5 and 6), written here from the data sheets' transfer functions and not taken from
//! the firmware, so a firmware that scales wrongly fails. The tolerances come from the
//! converters' resolution: an input value is its voltage truncated to a 0x6401 step (the
//! AD7689 model converts with `floor` and has no noise; the value keeps the top 15 of its 16
//! bits), and an output's voltage is the one its value asks for to within half a DAC code.

use crate::models::dac::{DacUpdate, GAIN, VREF};

/// Terminal full scale of the inputs and outputs (V).
pub const FULL_SCALE_V: f64 = 10.0;
/// One step of 0x6401 or 0x6411 (V): full scale / 32 768 (305.2 uV).
pub const PV_STEP_V: f64 = FULL_SCALE_V / 32768.0;
/// One AD5663 code at the terminal (V): 2.5 V / 65 536 x 4 (152.6 uV).
pub const DAC_CODE_V: f64 = VREF * GAIN / 65536.0;

/// Constant voltages for the eight analog inputs (V): all different, so a channel swapped or
/// shifted shows, spread over the 0..10 V range.
pub const AI_LEVELS_V: [f64; 8] = [0.35, 1.6, 2.85, 4.1, 5.35, 6.6, 7.85, 9.1];

/// An input value `value` read at a terminal held at `volts` is the voltage truncated to a
/// 0x6401 step: `0 <= volts - value * step < step`.
pub fn check_input(ch: usize, volts: f64, value: i16) -> Result<(), String> {
    let below = volts - f64::from(value) * PV_STEP_V;
    if (0.0..PV_STEP_V).contains(&below) {
        Ok(())
    } else {
        Err(format!(
            "AI{ch} at {volts} V read as {value} ({:.6} V): must be the voltage truncated to a \
             step of {:.1} uV",
            f64::from(value) * PV_STEP_V,
            PV_STEP_V * 1e6
        ))
    }
}

/// Every value of `values` (a master's reads of the eight inputs, e.g. the lowest and the
/// highest it saw) checked with [`check_input`] against `levels`.
pub fn check_inputs(levels: &[f64; 8], values: &[i16]) -> Result<(), String> {
    if values.len() != levels.len() {
        return Err(format!(
            "{} input values, not {}",
            values.len(),
            levels.len()
        ));
    }
    for (ch, (v, value)) in levels.iter().zip(values).enumerate() {
        check_input(ch, *v, *value)?;
    }
    Ok(())
}

/// One output pair as the slave took it (a process-data exchange with the expected working
/// counter).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputsTaken {
    /// 0x6411:01 and 0x6411:02.
    pub values: [i16; 2],
    /// The slave may rightly never have put it out: the next frame may have replaced it
    /// before the module's output event (the master's late cycle beside it).
    pub may_be_replaced: bool,
}

/// What [`check_outputs`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputsOnTheDac {
    /// Pairs checked.
    pub pairs: usize,
    /// Values (of both channels) that were allowed to be missing and were.
    pub missing: usize,
}

/// Every pair of `taken` (in the order the master sent them, each once) reached the DAC
/// model's register of its channel (`updates`, every load in order) as the code whose voltage
/// is the value's to within half a code, in that order and with no other code between; only a
/// pair flagged [`OutputsTaken::may_be_replaced`] may be missing. The check starts at the
/// first pair found on the DAC and ends with the last pair; the leading pairs whose first
/// value is 0 are left out (code 0 is what the DAC holds before OP too, so it names no
/// exchange).
pub fn check_outputs(
    taken: &[OutputsTaken],
    updates: &[DacUpdate],
) -> Result<OutputsOnTheDac, String> {
    let taken: Vec<&OutputsTaken> = taken.iter().skip_while(|t| t.values[0] == 0).collect();
    if taken.is_empty() {
        return Err("no output pair to check".into());
    }
    let mut missing = 0;
    for ch in 0..2usize {
        let mut codes: Vec<u16> = updates
            .iter()
            .filter(|u| usize::from(u.channel) == ch)
            .map(|u| u.code)
            .collect();
        // A register loaded again with the same code (an output event without a new frame)
        // is one value on the output.
        codes.dedup();
        let is = |code: u16, value: i16| {
            let asked = f64::from(value.max(0)) * PV_STEP_V;
            (f64::from(code) * DAC_CODE_V - asked).abs() < DAC_CODE_V / 2.0
        };
        let Some(mut at) = taken
            .iter()
            .find_map(|t| codes.iter().position(|&c| is(c, t.values[ch])))
        else {
            return Err(format!("no output value of the master on DAC channel {ch}"));
        };
        for (i, t) in taken.iter().enumerate() {
            let value = t.values[ch];
            if codes.get(at).is_some_and(|&c| is(c, value)) {
                at += 1;
            } else if t.may_be_replaced {
                missing += 1;
            } else {
                return Err(format!(
                    "DAC channel {ch}: pair {i} of {} (value {value}, {:.5} V) is not next on the \
                     DAC, which shows codes {:x?} around there",
                    taken.len(),
                    f64::from(value) * PV_STEP_V,
                    codes.get(at.saturating_sub(2)..(at + 3).min(codes.len()))
                ));
            }
        }
    }
    Ok(OutputsOnTheDac {
        pairs: taken.len(),
        missing,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(channel: u8, code: u16) -> DacUpdate {
        DacUpdate {
            time_ns: 0,
            channel,
            code,
        }
    }

    fn pair(a: i16, b: i16, may_be_replaced: bool) -> OutputsTaken {
        OutputsTaken {
            values: [a, b],
            may_be_replaced,
        }
    }

    #[test]
    fn inputs_are_the_voltage_truncated_to_a_step() {
        // 5 V is 16 384 steps exactly; 5 V - 1 uV truncates to 16 383.
        check_input(0, 5.0, 16384).unwrap();
        check_input(0, 5.0 - 1e-6, 16383).unwrap();
        assert!(check_input(0, 5.0, 16383).is_err(), "a step low");
        assert!(
            check_input(0, 5.0 - 1e-6, 16384).is_err(),
            "rounded, not truncated"
        );
        assert!(check_inputs(&AI_LEVELS_V, &[0; 7]).is_err());
        let values = AI_LEVELS_V.map(|v| (v / PV_STEP_V).floor() as i16);
        check_inputs(&AI_LEVELS_V, &values).unwrap();
        let mut swapped = values;
        swapped.swap(2, 3);
        assert!(check_inputs(&AI_LEVELS_V, &swapped)
            .unwrap_err()
            .contains("AI2"));
    }

    #[test]
    fn outputs_must_all_reach_the_dac_in_order() {
        let taken = [
            pair(0, 0, false),
            pair(100, 30_000, false),
            pair(200, 29_000, true),
            pair(300, 28_000, false),
        ];
        // Power-up 0, a repeated load, then every pair.
        let all = [
            load(0, 0),
            load(1, 0),
            load(0, 200),
            load(1, 60_000),
            load(0, 200),
            load(1, 60_000),
            load(0, 400),
            load(1, 58_000),
            load(0, 600),
            load(1, 56_000),
        ];
        assert_eq!(
            check_outputs(&taken, &all),
            Ok(OutputsOnTheDac {
                pairs: 3,
                missing: 0
            })
        );
        // The flagged pair may be missing, no other.
        let without = |code_a: u16, code_b: u16| -> Vec<DacUpdate> {
            all.iter()
                .copied()
                .filter(|u| {
                    !(u.channel == 0 && u.code == code_a || u.channel == 1 && u.code == code_b)
                })
                .collect()
        };
        assert_eq!(
            check_outputs(&taken, &without(400, 58_000)).map(|o| o.missing),
            Ok(2)
        );
        assert!(check_outputs(&taken, &without(600, 56_000))
            .unwrap_err()
            .contains("pair 2"));
        // A code the master never sent, between two of its pairs.
        let mut extra = all.to_vec();
        extra.insert(6, load(0, 1234));
        assert!(check_outputs(&taken, &extra).is_err());
        // A code one off.
        let mut off = all.to_vec();
        off[8] = load(0, 601);
        assert!(check_outputs(&taken, &off).is_err());
        assert!(check_outputs(&taken, &[]).is_err());
    }
}
