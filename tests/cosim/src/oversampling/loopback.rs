//! The 1 kHz loop-back with oversampling on the image (docs/book/oversampling-loopback.md):
//! a sine on AI1, the master (ethercrab in process) takes AI1's samples from the input
//! blocks (31.25 kSPS, every conversion), resamples them onto the output update grid
//! (SYNC0 + k T/n) with a quintic (6-tap Lagrange) interpolator, and writes them into the update PDOs
//! for AO1 (and AO2); the AD5663 model's output, latched at the LDAC edges, is compared with
//! the input by the loop-back analysis of the virtual board
//! ([`virtual_board::tools::loopback`]: amplitude error, latency, THD over harmonics 2..10).
//! Shared by the system test, `lpc1754-cosim oversampling` (`cargo xtask bench`) and
//! `lpc1754-cosim sim --oversampling` (`cargo xtask sim --image --oversampling`).

use super::{
    run_with, Block, Config, OsRun, OutputMaster, CHANNELS, PERIOD_NS, SINE_AMPLITUDE_V,
    SINE_OFFSET_V, SINE_PHASE,
};
use crate::image::Image;
use std::collections::VecDeque;
use std::f64::consts::PI;
use virtual_board::models::adc::Signal;
use virtual_board::tools::loopback::{
    analyze, dac_code_to_volts, signal_points, Analysis, AnalysisOptions, Staircase,
};

/// The loop-back's sine (Hz): the thesis' 1 kHz.
pub const SINE_HZ: f64 = 1_000.0;
/// Input samples each side of the interpolation point (the interpolator has `2 A` taps).
pub const TAPS_PER_SIDE: usize = 3;
/// How long before the SYNC0 edge an input block closes (0x8000:06).
const INPUT_LEAD_NS: u64 = 40_000;
/// AI1's sample period: one scan of the eight channels.
pub const SCAN_NS: u64 = PERIOD_NS * CHANNELS as u64;

/// The configurations the bench and the test run (cycle, sample PDOs, update PDOs): every
/// conversion in (8 sample PDOs at 1 ms, 4 at 500 us) and 20 kHz out (20 and 10 updates
/// per cycle), the factors the output test runs without a break.
pub const CONFIGS: [(u64, u8, u8); 2] = [(1_000_000, 8, 4), (500_000, 4, 2)];

/// Sample slots per sample PDO.
const SLOTS_PER_PDO: u64 = 32;

/// The fewest sample PDOs that hold every conversion of a cycle: its largest block
/// (`ceil(T / scan)` scans of 8 channels), 32 slots each.
pub fn sample_pdos_for(cycle_ns: u64) -> u8 {
    let slots = cycle_ns.div_ceil(SCAN_NS) * CHANNELS as u64;
    u8::try_from(slots.div_ceil(SLOTS_PER_PDO)).unwrap_or(u8::MAX)
}

/// The fixed delay from an input sample's time to the output update that plays it (ns).
/// The frames of [`super::run_with`] pass the module at the SYNC0 edges: the block the
/// frame at edge c carries plays over `[SYNC0(c+1), SYNC0(c+2))`, and the newest input the
/// master has when it fills it is the block the frame before brought, which the module cut
/// `INPUT_LEAD` before edge c-2 (measured: a block reaches the master in the second frame
/// after its edge). The interpolator needs `A` samples after the point, plus one scan for
/// the last scan's place in its block and one of margin.
pub fn delay_ns(cycle_ns: u64, updates: usize) -> u64 {
    let step = cycle_ns / updates.max(1) as u64;
    4 * cycle_ns - step + INPUT_LEAD_NS + (TAPS_PER_SIDE as u64 + 2) * SCAN_NS
}

/// Interpolation of the uniform samples `s` at the fractional index `x`: the polynomial
/// through the [`TAPS_PER_SIDE`] samples each side of `x` (Lagrange, quintic with 3 a
/// side); `None` when a tap falls outside `s` or on a missing sample (NaN).
///
/// Why not linear interpolation: it is a triangle filter, `sinc^2(f / fs)` in frequency.
/// At 1 kHz from AI1's 31.25 kSPS it takes 0.34 % off the amplitude and passes the images
/// at `fs +- f` (30.25 and 32.25 kHz) at about -59 dB, which the 20 kHz output grid folds
/// back to 9.75 and 10.25 kHz, beside the 10th harmonic; between the samples it is off by
/// up to 0.5 % of the amplitude (-46 dB). The droop alone is more than the loop-back's
/// amplitude budget, and the error is the -60 dB the THD must beat. A sine of 1 kHz is
/// 31 samples a period, far below the Nyquist frequency, where a polynomial through a few
/// neighbours is flat: the cubic through 4 samples is within -88 dB of the sine, the quintic
/// through 6 within -130 dB (the unit tests measure them), with a latency of 3 samples
/// (96 us). A Lanczos-windowed sinc, tried first, reached only -61 dB with 8 taps a side
/// and -82 dB with 16 (its ripple at 1 kHz).
pub fn interpolate(s: &[f64], x: f64) -> Option<f64> {
    let a = TAPS_PER_SIDE as i64;
    let first = x.floor() as i64 - a + 1;
    let taps = first..first + 2 * a;
    let mut sum = 0.0;
    for j in taps.clone() {
        let v = *s.get(usize::try_from(j).ok()?)?;
        if v.is_nan() {
            return None;
        }
        let weight: f64 = taps
            .clone()
            .filter(|m| *m != j)
            .map(|m| (x - m as f64) / (j - m) as f64)
            .product();
        sum += weight * v;
    }
    Some(sum)
}

/// The master of the loop-back: AI1's samples by scan counter, played `delay` later on the
/// output grid.
#[derive(Debug)]
pub struct LoopbackMaster {
    cycle_ns: u64,
    delay_ns: u64,
    /// DC time and scan counter of the first block's first scan (AI1): the place of every
    /// other scan, by the counter's distance from it (a master may join a running stream,
    /// and the counter wraps after 2^32 scans).
    t0_dc: Option<(u64, u32)>,
    /// Scan counter of `history[0]`.
    base: u32,
    /// AI1's codes (NaN: not received).
    history: VecDeque<f64>,
    /// The last code written (held when the samples are not there).
    last: u16,
    /// Updates written from samples.
    pub written: u64,
    /// Updates that held because a sample they needed had not come (or was lost), once
    /// the loop ran.
    pub starved: u64,
}

impl LoopbackMaster {
    /// A master for `cycle_ns` with `updates` updates per cycle.
    pub fn new(cycle_ns: u64, updates: usize) -> Self {
        Self {
            cycle_ns,
            delay_ns: delay_ns(cycle_ns, updates),
            t0_dc: None,
            base: 0,
            history: VecDeque::new(),
            last: 0x8000,
            written: 0,
            starved: 0,
        }
    }

    /// Scans kept: four cycles' worth, more than the delay reaches back.
    fn keep(&self) -> usize {
        (5 * self.cycle_ns / SCAN_NS) as usize + 2 * TAPS_PER_SIDE
    }

    /// AI1's code at DC time `t`, interpolated.
    fn at(&mut self, t: u64) -> Option<f64> {
        let (t0, c0) = self.t0_dc?;
        let since_t0 = t.wrapping_sub(t0) as i64 as f64 / SCAN_NS as f64;
        let x = since_t0 + f64::from(c0.wrapping_sub(self.base) as i32);
        interpolate(self.history.make_contiguous(), x)
    }
}

impl OutputMaster for LoopbackMaster {
    fn received(&mut self, block: &Block) {
        // The blocks of the first edges in OP are empty (no scan, no time yet).
        if block.scans == 0 {
            return;
        }
        if self.t0_dc.is_none() {
            self.t0_dc = Some((block.time_dc, block.counter));
        }
        // A first block, or one so far ahead that the history is all gaps: start from it.
        let ahead = block.counter.wrapping_sub(self.base) as i32;
        if self.history.is_empty() || ahead > 2 * self.keep() as i32 {
            self.history.clear();
            self.base = block.counter;
        }
        for (j, code) in block.samples.iter().step_by(CHANNELS).enumerate() {
            // Scans before `base` (older than the history) are dropped.
            let Ok(at) = usize::try_from(
                block.counter.wrapping_add(j as u32).wrapping_sub(self.base) as i32,
            ) else {
                continue;
            };
            while self.history.len() <= at {
                self.history.push_back(f64::NAN);
            }
            self.history[at] = f64::from(*code);
        }
        while self.history.len() > self.keep() {
            self.history.pop_front();
            self.base = self.base.wrapping_add(1);
        }
    }

    fn fill(&mut self, _: u64, plays_from_dc: Option<u64>, out: &mut [u8]) {
        let n = out.len() / 4;
        let step = self.cycle_ns / n.max(1) as u64;
        for (k, pair) in out.chunks_exact_mut(4).enumerate() {
            let code = match plays_from_dc {
                Some(edge) => {
                    let t = (edge + k as u64 * step).saturating_sub(self.delay_ns);
                    match self.at(t) {
                        Some(v) => {
                            self.written += 1;
                            v.round().clamp(0.0, 65_535.0) as u16
                        }
                        None => {
                            // Before the first samples reach back this far, holding is the
                            // start of the loop; after, it is a starved update.
                            self.starved += u64::from(self.written > 0);
                            self.last
                        }
                    }
                }
                None => self.last,
            };
            self.last = code;
            pair[..2].copy_from_slice(&code.to_le_bytes());
            pair[2..].copy_from_slice(&code.to_le_bytes());
        }
    }
}

/// Points of a plotted line: (ms, V).
pub type Points = Vec<(f64, f64)>;

/// A loop-back run and its figures.
#[derive(Debug)]
pub struct Loopback {
    /// The run (stream, LDAC edges, AO1's loads).
    pub run: OsRun,
    /// AO1 against AI1's input.
    pub analysis: Analysis,
    /// The master's delay from sample to update (ns).
    pub delay_ns: u64,
    /// Updates written from samples, and those that held for want of a sample.
    pub written: u64,
    /// See [`LoopbackMaster::starved`].
    pub starved: u64,
}

impl Loopback {
    /// Updates per cycle.
    pub fn updates(&self) -> usize {
        self.run.config.updates()
    }

    /// The amplitude error the DAC's zero-order hold alone gives: `sinc(f T / n) - 1`.
    pub fn hold_droop(&self) -> f64 {
        let x = PI * SINE_HZ * self.run.config.cycle_ns as f64 * 1e-9 / self.updates() as f64;
        x.sin() / x - 1.0
    }

    /// One line of figures.
    pub fn line(&self) -> String {
        let a = &self.analysis;
        let c = self.run.config;
        format!(
            "loop-back {:.0} Hz AI1 -> master -> AO1, cycle {:>5} us, {} sample PDOs ({:.2} kSPS \
             on AI1), {} updates/cycle ({:.0} kHz): amplitude error {:+.3} % (the hold's own \
             {:+.3} %), latency {:.1} us (the master's delay {:.0} us + half an update), THD \
             (2..10) {:.1} dB ({:.4} %), THD+N {:.1} dB, {} periods, {} of {} updates held for \
             want of a sample",
            a.freq_hz,
            c.cycle_ns / 1_000,
            c.sample_pdos,
            1e6 / SCAN_NS as f64,
            self.updates(),
            1e6 / (c.cycle_ns as f64 / self.updates() as f64),
            100.0 * a.amplitude_error,
            100.0 * self.hold_droop(),
            a.latency_ns / 1e3,
            self.delay_ns as f64 / 1e3,
            a.thd_db(),
            100.0 * a.thd,
            20.0 * a.thd_n.log10(),
            a.periods,
            self.starved,
            self.written + self.starved
        )
    }

    /// The input and AO1's steps over the last `periods` periods of the window, for a plot:
    /// `(time in ms from the shown start, volts)`, the output as two points per load.
    pub fn traces(&self, periods: f64) -> (Points, Points) {
        let (w0, w1) = self.analysis.window_ns;
        let start = (w1 as f64 - periods * 1e9 / SINE_HZ).max(w0 as f64) as u64;
        let input = signal_points(&input_signal(), start, w1);
        let output = output_staircase(&self.run).plot_points(start, w1);
        (input, output)
    }
}

/// AI1's input as the ADC model sees it (virtual time).
fn input_signal() -> Signal {
    Signal::Sine {
        amplitude: SINE_AMPLITUDE_V,
        offset: SINE_OFFSET_V,
        freq_hz: SINE_HZ,
        phase: SINE_PHASE,
    }
}

/// AO1 as the DAC model latched it, in volts.
fn output_staircase(run: &OsRun) -> Staircase {
    Staircase::new(
        run.dac_a
            .iter()
            .map(|&(t, code)| (t, dac_code_to_volts(code)))
            .collect(),
    )
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Runs the loop-back on the image: `cycles` cycles in OP at `cycle_ns`, the sample PDOs
/// and update PDOs given.
pub fn run(
    image: &Image,
    cycle_ns: u64,
    sample_pdos: u8,
    update_pdos: u8,
    cycles: u64,
) -> Result<Loopback, String> {
    let config = Config {
        cycle_ns,
        cycles,
        sample_pdos,
        sine_hz: SINE_HZ,
        update_pdos,
    };
    if update_pdos == 0 {
        return Err("the loop-back needs output update PDOs".into());
    }
    let mut master = LoopbackMaster::new(cycle_ns, config.updates());
    let run = run_with(image, config, &mut master)?;
    let delay = master.delay_ns;
    // The window: whole periods of the pattern the sine, the sample grid and the update
    // grid make together (4 ms at 1 kHz, 32 us and 50 us), so that no component between
    // the harmonics leaks into them; after the loop filled (the delay and two cycles).
    let step = cycle_ns / config.updates() as u64;
    let period = (1e9 / SINE_HZ).round() as u64;
    let pattern = [SCAN_NS, step]
        .iter()
        .fold(period, |l, &x| l / gcd(l, x) * x);
    let end = run.start_ns + run.span_ns;
    let first = run.start_ns + delay + 2 * cycle_ns;
    let whole = end.saturating_sub(first) / pattern * pattern;
    if whole == 0 {
        return Err(format!(
            "{cycles} cycles leave no whole {} us of loop-back to analyse",
            pattern / 1_000
        ));
    }
    let opts = AnalysisOptions {
        latency_hint_ns: Some(delay as f64 + step as f64 / 2.0),
        ..Default::default()
    };
    let analysis = analyze(
        &input_signal(),
        &output_staircase(&run),
        SINE_HZ,
        end - whole,
        end,
        &opts,
    )
    .map_err(|e| {
        format!(
            "loop-back analysis: {e} ({} updates written from samples, {} held, {} loads of AO1)",
            master.written,
            master.starved,
            run.dac_a.len()
        )
    })?;
    Ok(Loopback {
        run,
        analysis,
        delay_ns: delay,
        written: master.written,
        starved: master.starved,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest error of `interp` on a full-scale-relative 1 kHz sine sampled every
    /// scan, over many fractional positions (relative to the amplitude).
    fn worst_error(interp: impl Fn(&[f64], f64) -> Option<f64>) -> f64 {
        let w = 2.0 * PI * SINE_HZ * SCAN_NS as f64 * 1e-9;
        let s: Vec<f64> = (0..200).map(|j| (w * j as f64).sin()).collect();
        (0..1000)
            .map(|i| 50.0 + i as f64 * 0.0997)
            .map(|x| (interp(&s, x).unwrap() - (w * x).sin()).abs())
            .fold(0.0, f64::max)
    }

    fn linear(s: &[f64], x: f64) -> Option<f64> {
        let i = x.floor() as usize;
        let f = x - i as f64;
        Some(s.get(i)? * (1.0 - f) + s.get(i + 1)? * f)
    }

    /// The cubic through 4 samples (2 a side), for comparison.
    fn cubic(s: &[f64], x: f64) -> Option<f64> {
        let first = x.floor() as i64 - 1;
        let taps = first..first + 4;
        Some(
            taps.clone()
                .map(|j| {
                    let w: f64 = taps
                        .clone()
                        .filter(|m| *m != j)
                        .map(|m| (x - m as f64) / (j - m) as f64)
                        .product();
                    w * s[j as usize]
                })
                .sum(),
        )
    }

    #[test]
    fn the_quintic_rebuilds_a_1_khz_sine_below_minus_120_db_where_linear_does_not() {
        let db = |e: f64| 20.0 * e.log10();
        let quintic = db(worst_error(interpolate));
        let cubic = db(worst_error(cubic));
        let lin = db(worst_error(linear));
        eprintln!("linear {lin:.1} dB, cubic {cubic:.1} dB, quintic {quintic:.1} dB");
        assert!(quintic < -120.0, "quintic: {quintic} dB");
        assert!(cubic < -85.0, "cubic: {cubic} dB");
        // Linear interpolation: about 5e-3 of the amplitude between the samples (-46 dB).
        assert!(lin > -50.0, "linear: {lin} dB");
    }

    #[test]
    fn the_sample_pdos_hold_every_conversion_of_a_cycle() {
        assert_eq!(sample_pdos_for(1_000_000), 8);
        assert_eq!(sample_pdos_for(500_000), 4);
        assert_eq!(sample_pdos_for(250_000), 2);
        assert_eq!(sample_pdos_for(100_000), 1);
        assert!(CONFIGS.iter().all(|c| c.1 == sample_pdos_for(c.0)));
    }

    #[test]
    fn the_interpolator_passes_a_constant_and_refuses_missing_samples() {
        let s = vec![7.0; 40];
        assert!((interpolate(&s, 20.3).unwrap() - 7.0).abs() < 1e-12);
        assert_eq!(interpolate(&s, 1.5), None, "taps before the first sample");
        assert_eq!(interpolate(&s, 37.0), None, "taps after the last sample");
        let mut gap = s.clone();
        gap[21] = f64::NAN;
        assert_eq!(interpolate(&gap, 20.3), None);
        assert!((interpolate(&s, 8.0).unwrap() - 7.0).abs() < 1e-12);
    }

    fn block(counter: u32, scans: u8) -> Block {
        Block {
            counter,
            scans,
            status: 0,
            time_dc: 1_000_000 + u64::from(counter) * SCAN_NS,
            samples: (0..u32::from(scans) * CHANNELS as u32)
                .map(|s| (counter + s / CHANNELS as u32) as u16)
                .collect(),
        }
    }

    #[test]
    fn the_master_plays_the_samples_after_its_delay_and_counts_what_it_lacks() {
        let mut m = LoopbackMaster::new(1_000_000, 20);
        let mut out = [0u8; 80];
        // Before any timing: the hold value.
        m.fill(0, None, &mut out);
        assert_eq!(u16::from_le_bytes([out[0], out[1]]), 0x8000);
        for c in 0..8u32 {
            m.received(&block(c * 31, 31));
        }
        // AI1's code of scan s is s: a ramp, which the interpolator passes exactly.
        let delay = delay_ns(1_000_000, 20);
        let edge = 1_000_000 + 200 * SCAN_NS + delay;
        m.fill(1, Some(edge), &mut out);
        let codes: Vec<u16> = out
            .chunks_exact(4)
            .map(|p| u16::from_le_bytes([p[0], p[1]]))
            .collect();
        assert_eq!(codes[0], 200);
        // 50 us per update is 1.5625 scans.
        assert_eq!(codes[4], (200.0 + 4.0 * 1.5625f64).round() as u16);
        assert_eq!((m.written, m.starved), (20, 0));
        // Samples not there yet: held and counted.
        m.fill(2, Some(edge + 10_000_000), &mut out);
        assert_eq!((m.written, m.starved), (20, 20));
    }

    #[test]
    fn the_master_places_samples_by_the_counters_distance_wherever_it_starts_and_wraps() {
        let mut m = LoopbackMaster::new(1_000_000, 20);
        let mut out = [0u8; 80];
        // The module's counter starts near the end of its range and wraps (a stream whose
        // first block was cut late); the DC times go on as before.
        let first = u32::MAX - 100;
        for k in 0..8u32 {
            let counter = first.wrapping_add(k * 31);
            let mut b = block(k * 31, 31);
            b.counter = counter;
            m.received(&b);
        }
        let edge = 1_000_000 + 200 * SCAN_NS + delay_ns(1_000_000, 20);
        m.fill(1, Some(edge), &mut out);
        assert_eq!(
            u16::from_le_bytes([out[0], out[1]]),
            200,
            "scan 200 after the first"
        );
        assert_eq!((m.written, m.starved), (20, 0));
    }
}
