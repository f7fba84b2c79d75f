//! THE 1 KHZ LOOP-BACK WITH OVERSAMPLING ON THE IMAGE (docs/book/oversampling-loopback.md):
//! a 1 kHz sine on AI1; ethercrab assigns every conversion (8 sample PDOs at 1 ms, 4 at
//! 500 us) and 20 kHz of updates (4 and 2 update PDOs) at a 1 ms and a 500 us DC cycle,
//! resamples AI1's 31.25 kSPS onto the 20 kHz
//! update grid with a quintic interpolator and writes AO1; the AD5663 model's output,
//! latched at the LDAC edges, has THD (harmonics 2..10) under -60 dB (the must-show;
//! -19 dB at 100 us without oversampling) and the amplitude of the input, but for the
//! zero-order hold's own droop.

use lpc1754_cosim::oversampling::loopback::{self, CONFIGS};
use lpc1754_cosim::run::load_image;

#[test]
fn the_1_khz_loop_back_at_1_ms_and_500_us_with_oversampling_has_thd_under_minus_60_db() {
    let image = load_image().expect("the release image");
    for (cycle_ns, sample_pdos, update_pdos) in CONFIGS {
        let cycles = 300_000_000 / cycle_ns;
        check(&loopback::run(&image, cycle_ns, sample_pdos, update_pdos, cycles).unwrap());
    }
}

/// 0.3 s: the loop fills in 5 ms, then at least 72 whole patterns are analysed.
fn check(l: &loopback::Loopback) {
    eprintln!("{}", l.line());
    let a = &l.analysis;
    // 20 kHz out.
    assert_eq!(
        l.run.config.updates() as u64,
        l.run.config.cycle_ns / 50_000
    );
    assert!(a.thd_db() < -60.0, "{}", l.line());
    // The input's amplitude: the hold's sinc droop (-0.41 % at 1 kHz and 20 kHz) and
    // nothing else of note (the interpolator and the converters' codes).
    assert!(
        (a.amplitude_error - l.hold_droop()).abs() < 0.000_5,
        "{}",
        l.line()
    );
    assert!(a.amplitude_error.abs() < 0.005, "{}", l.line());
    // Every update came from samples: no block missed on the way.
    assert_eq!(l.starved, 0, "{}", l.line());
    assert!(l.written >= 20 * 290, "{}", l.line());
    // The delay the master chose, plus the hold's half update (and the sample times'
    // sub-microsecond offset): the loop is what it was built to be.
    let expected = l.delay_ns as f64 + 25_000.0;
    assert!(
        (a.latency_ns - expected).abs() < 2_000.0,
        "{}, expected {expected} ns",
        l.line()
    );
    assert!(l.run.after.reports.is_empty(), "{}", l.run.after.summary());
}
