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
//!
//! On the wall clock the board's CPU may run behind ([`crate::tools::iface`]): it then reads SM2 after
//! the next frame has arrived and an output value never reaches the DAC, as on a CPU that
//! slow. [`check_outputs`] reports each value missing with where it was due, and
//! [`unexplained`] keeps those the board's lag there does not explain.

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

/// One output pair the master sent in OP, in the order sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputsTaken {
    /// 0x6411:01 and 0x6411:02.
    pub values: [i16; 2],
    /// The slave may rightly never have put it out: the next frame may have replaced it
    /// before the module's output event (the master's late cycle beside it), or its frame
    /// never passed the module (no answer with the expected working counter).
    pub may_be_replaced: bool,
}

/// An output value the master sent that never reached the DAC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MissingOutput {
    /// Index of the pair in the checked pairs.
    pub pair: usize,
    /// DAC channel.
    pub channel: usize,
    /// The board's virtual time between the DAC loads before and after it (ns): where the
    /// module had to take it.
    pub between_ns: (u64, u64),
}

/// What [`check_outputs`] found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutputsOnTheDac {
    /// Pairs checked.
    pub pairs: usize,
    /// Values (of both channels) flagged [`OutputsTaken::may_be_replaced`] that were missing.
    pub replaced: usize,
    /// Values not flagged that were missing: for the caller to explain (a board whose CPU
    /// ran behind the wall clock reads SM2 after the next frame arrived) or to fail.
    pub missing: Vec<MissingOutput>,
}

/// Checks that the DAC model's registers (`updates`, every load in order) took the pairs of
/// `taken` (in the order the master sent them, each once, the values of a channel all
/// different): every code loaded from the first of the master's values to the last is the
/// code whose voltage is one of them to within half a code, in the order sent, never an older
/// one after a newer. A value that never arrived is reported ([`OutputsOnTheDac`]), not an
/// error. The leading pairs whose first value is 0 are left out (code 0 is what the DAC holds
/// before OP too, so it names no exchange).
pub fn check_outputs(
    taken: &[OutputsTaken],
    updates: &[DacUpdate],
) -> Result<OutputsOnTheDac, String> {
    let taken: Vec<&OutputsTaken> = taken.iter().skip_while(|t| t.values[0] == 0).collect();
    if taken.is_empty() {
        return Err("no output pair to check".into());
    }
    let mut found = OutputsOnTheDac {
        pairs: taken.len(),
        replaced: 0,
        missing: Vec::new(),
    };
    for ch in 0..2usize {
        // The code of each value (the one whose voltage is within half a code of it).
        let mut index = std::collections::HashMap::new();
        for (i, t) in taken.iter().enumerate() {
            let code = (f64::from(t.values[ch].max(0)) * PV_STEP_V / DAC_CODE_V).round() as u16;
            if index.insert(code, i).is_some() {
                return Err(format!(
                    "DAC channel {ch}: value {} sent twice",
                    t.values[ch]
                ));
            }
        }
        let mut loads: Vec<(u64, u16)> = updates
            .iter()
            .filter(|u| usize::from(u.channel) == ch)
            .map(|u| (u.time_ns, u.code))
            .collect();
        // A register loaded again with the same code (an output event without a new frame)
        // is one value on the output.
        loads.dedup_by_key(|l| l.1);
        let ours = |l: &(u64, u16)| index.contains_key(&l.1);
        let (Some(first), Some(last)) = (loads.iter().position(ours), loads.iter().rposition(ours))
        else {
            return Err(format!("no output value of the master on DAC channel {ch}"));
        };
        let mut next = 0;
        let mut before_ns = loads[first].0;
        let mut miss = |from: usize, to: usize, between_ns: (u64, u64)| {
            for (pair, t) in taken.iter().enumerate().take(to).skip(from) {
                if t.may_be_replaced {
                    found.replaced += 1;
                } else {
                    found.missing.push(MissingOutput {
                        pair,
                        channel: ch,
                        between_ns,
                    });
                }
            }
        };
        for &(at_ns, code) in &loads[first..=last] {
            match index.get(&code) {
                Some(&k) if k >= next => {
                    miss(next, k, (before_ns, at_ns));
                    next = k + 1;
                }
                Some(&k) => {
                    return Err(format!(
                        "DAC channel {ch}: pair {k} of {} (code {code:#06x}) came back at {at_ns} \
                         ns, after pair {}",
                        taken.len(),
                        next - 1
                    ))
                }
                None => {
                    return Err(format!(
                        "DAC channel {ch}: code {code:#06x} at {at_ns} ns, between the master's \
                         pairs {} and {}, is none of the master's values",
                        next.saturating_sub(1),
                        next
                    ))
                }
            }
            before_ns = at_ns;
        }
        let after_ns = loads.get(last + 1).map_or(before_ns, |l| l.0);
        miss(next, taken.len(), (before_ns, after_ns));
    }
    Ok(found)
}

/// The values of `missing` that the board's lag behind the wall clock does not explain: where
/// the CPU was less than `lag_that_skips_ns` behind (the time from a pair's first frame to
/// the next pair's, less the time from a frame to the output event), per `lag_between(from,
/// to)`, the largest lag while the board's virtual time was in `[from, to]`
/// ([`crate::tools::iface::Lag::max_between`]).
pub fn unexplained(
    missing: &[MissingOutput],
    lag_that_skips_ns: u64,
    lag_between: impl Fn(u64, u64) -> u64,
) -> Vec<MissingOutput> {
    missing
        .iter()
        .filter(|m| lag_between(m.between_ns.0, m.between_ns.1) < lag_that_skips_ns)
        .copied()
        .collect()
}

/// Of the values the master sent, the share that must reach the DAC however far the board's
/// CPU ran behind: below it, the run checked too little to be a test.
pub const MIN_SHARE_ON_THE_DAC: f64 = 0.9;

/// [`check_outputs`] for a board served on the wall clock ([`crate::tools::iface`]): every
/// value missing must be flagged or explained by the board's `lag` where it was due (at least
/// `lag_that_skips_ns`, [`unexplained`]), and at least [`MIN_SHARE_ON_THE_DAC`] of the values
/// must have reached the DAC. A line that says what was found, or what failed.
pub fn check_outputs_on_the_wall_clock(
    taken: &[OutputsTaken],
    updates: &[DacUpdate],
    lag: &crate::tools::iface::Lag,
    lag_that_skips_ns: u64,
) -> Result<String, String> {
    let found = check_outputs(taken, updates)?;
    let values = 2 * found.pairs;
    let reached = values - found.replaced - found.missing.len();
    let summary = format!(
        "{reached} of {values} output values on the DAC in order ({} beside a late master \
         cycle and {} where the board's CPU was {:.1} ms or more behind the wall clock missing)",
        found.replaced,
        found.missing.len(),
        lag_that_skips_ns as f64 * 1e-6
    );
    let wrong = unexplained(&found.missing, lag_that_skips_ns, |a, b| {
        lag.max_between(a, b)
    });
    if let Some(m) = wrong.first() {
        return Err(format!(
            "{summary}; {} not explained, the first: pair {} on channel {}, due between {} and \
             {} ns, where the CPU was {:.2} ms behind",
            wrong.len(),
            m.pair,
            m.channel,
            m.between_ns.0,
            m.between_ns.1,
            lag.max_between(m.between_ns.0, m.between_ns.1) as f64 * 1e-6
        ));
    }
    if (reached as f64) < MIN_SHARE_ON_THE_DAC * values as f64 {
        return Err(format!("{summary}: too few to check"));
    }
    Ok(summary)
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
    fn outputs_reach_the_dac_in_order_or_are_reported_missing() {
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
        // A pair's two loads at the same time, 1 us after the pair before.
        let all: Vec<DacUpdate> = all
            .iter()
            .enumerate()
            .map(|(i, u)| DacUpdate {
                time_ns: i as u64 / 2 * 1000,
                ..*u
            })
            .collect();
        assert_eq!(
            check_outputs(&taken, &all),
            Ok(OutputsOnTheDac {
                pairs: 3,
                replaced: 0,
                missing: vec![]
            })
        );
        // A flagged pair missing is counted; any other is reported with where it was due.
        let without = |code_a: u16, code_b: u16| -> Vec<DacUpdate> {
            all.iter()
                .copied()
                .filter(|u| {
                    !(u.channel == 0 && u.code == code_a || u.channel == 1 && u.code == code_b)
                })
                .collect()
        };
        let o = check_outputs(&taken, &without(400, 58_000)).unwrap();
        assert_eq!((o.replaced, o.missing.len()), (2, 0));
        let o = check_outputs(&taken, &without(200, 60_000)).unwrap();
        assert_eq!(o.missing.len(), 2);
        assert_eq!(o.missing[0].pair, 0);
        let o = check_outputs(&taken, &without(600, 56_000)).unwrap();
        assert_eq!(o.missing.len(), 2);
        assert_eq!((o.missing[0].pair, o.missing[0].channel), (2, 0));
        // Due after the load at 3 us: explained by a lag of 3 ms there, or not.
        assert_eq!(o.missing[0].between_ns, (3000, 3000));
        assert!(unexplained(&o.missing, 2_000_000, |_, _| 3_000_000).is_empty());
        assert_eq!(
            unexplained(&o.missing, 2_000_000, |_, _| 1_000_000),
            o.missing
        );
        // An older value after a newer one.
        let mut back = all.to_vec();
        back.push(load(0, 400));
        back.push(load(0, 600));
        assert!(check_outputs(&taken, &back)
            .unwrap_err()
            .contains("came back"));
        // A code the master never sent, between two of its pairs.
        let mut extra = all.to_vec();
        extra.insert(6, load(0, 1234));
        assert!(check_outputs(&taken, &extra)
            .unwrap_err()
            .contains("none of the master's"));
        // A code one off.
        let mut off = all.to_vec();
        off[6] = load(0, 401);
        assert!(check_outputs(&taken, &off).is_err());
        assert!(check_outputs(&taken, &[]).is_err());
    }
}
