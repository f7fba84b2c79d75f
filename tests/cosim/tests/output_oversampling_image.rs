//! OUTPUT OVERSAMPLING ON THE IMAGE (docs/book/oversampling.md): ethercrab assigns the
//! update PDOs (0x1620..) in 0x1C12 over SDO in PRE-OP, with the whole input stream in
//! 0x1C13, and runs DC SYNC0; the AD5663 model sees every update of every block exactly
//! once and in order, both channels latched by LDAC falls that PWM1 puts on the grid
//! SYNC0 + k T/n. Refusals: a factor the cycle cannot serve, at PRE-OP -> SAFE-OP.

use firmware::io::analog::oversampling::STATUS_OUTPUTS_HELD;
use lpc1754_cosim::oversampling::{check_outputs, run, run_with, Block, ClimbingCodes, Config};
use lpc1754_cosim::run::load_image;

fn config(cycle_ns: u64, sample_pdos: u8, update_pdos: u8, cycles: u64) -> Config {
    Config {
        cycle_ns,
        cycles,
        sample_pdos,
        sine_hz: 1_234.5,
        update_pdos,
    }
}

/// 1 s at 1 ms, 20 updates per cycle (20 kHz per channel) beside the 250 kSPS input
/// stream: every update once, in order, on the grid.
#[test]
fn one_second_at_1_ms_20_khz_every_update_once_on_the_grid() {
    let image = load_image().expect("the release image");
    let r = run(&image, config(1_000_000, 8, 4, 1_000)).unwrap();
    let c = check_outputs(&r);
    eprintln!("{c:?}");
    assert_eq!(c.sequence_breaks, 0, "{c:?}");
    assert!((c.updates_per_s - 20_000.0).abs() < 100.0, "{c:?}");
    assert!(c.edge_error_max_ns <= 1_000, "{c:?}");
    // 20 updates per cycle, one load of channel A each.
    assert!(c.loads >= 19_900, "{c:?}");
    assert!(r.after.reports.is_empty(), "{}", r.after.summary());
    // Every block played: no input block says the outputs held.
    assert!(r.blocks.iter().all(|b| b.status == 0));
}

/// The master leaves out two frames: the SYNC0 edge the missing update block was for finds
/// none, the outputs hold for that cycle (the climbing codes stand still, then jump once),
/// and the input block cut at that edge (the one whose scans close 40 us before it) says so
/// in status bit 2; no other block does.
#[test]
fn a_missed_frame_holds_the_outputs_and_the_input_block_of_that_edge_says_so() {
    let image = load_image().expect("the release image");
    let mut master = ClimbingCodes {
        skipped: vec![120, 250],
    };
    let r = run_with(&image, config(1_000_000, 8, 4, 300), &mut master).unwrap();
    let c = check_outputs(&r);
    eprintln!("{c:?}");
    // Each LDAC fall of a held cycle latches the same code again: 20 repeats from the held
    // SYNC0 edge on, then one jump over the missed block's codes.
    let repeats: Vec<usize> = (1..r.dac_a.len())
        .filter(|&k| r.dac_a[k].1 == r.dac_a[k - 1].1)
        .collect();
    assert_eq!(repeats.len(), 2 * 20, "{c:?}");
    assert_eq!(c.sequence_breaks, 2 * 20 + 2, "{c:?}");
    let held_edges_dc: Vec<i64> = repeats
        .iter()
        .filter(|&&k| !repeats.contains(&(k - 1)))
        .map(|&k| r.dac_a[k].0 as i64 + r.dc_minus_virtual_ns)
        .collect();
    assert_eq!(held_edges_dc.len(), 2);
    let flagged: Vec<&Block> = r
        .blocks
        .iter()
        .filter(|b| b.status & STATUS_OUTPUTS_HELD != 0)
        .collect();
    assert!(r
        .blocks
        .iter()
        .all(|b| b.status & !STATUS_OUTPUTS_HELD == 0));
    assert_eq!(flagged.len(), 2, "{flagged:?}");
    for (b, edge) in flagged.iter().zip(&held_edges_dc) {
        // The block's scans end within one scan (32 us) after edge - 40 us.
        let end = (b.time_dc + u64::from(b.scans) * 32_000) as i64;
        let after_close = end - (edge - 40_000);
        assert!(
            (0..32_000).contains(&after_close),
            "{b:?} for the edge at {edge}"
        );
    }
}

/// 500 us with 10 updates (20 kHz) beside four sample PDOs: on the grid, every update
/// played once, in order.
#[test]
fn at_500_us_10_updates_per_cycle() {
    let image = load_image().expect("the release image");
    let r = run(&image, config(500_000, 4, 2, 1_000)).unwrap();
    let c = check_outputs(&r);
    eprintln!("{c:?}");
    assert_eq!(c.sequence_breaks, 0, "{c:?}");
    assert!(c.loads >= 9_990, "{c:?}");
    assert!((c.updates_per_s - 20_000.0).abs() < 100.0, "{c:?}");
    assert!(c.edge_error_max_ns <= 1_000, "{c:?}");
}

/// A factor whose interval is not whole (1 ms / 15) and those the bus and the CPU cannot
/// carry beside the inputs (40 and 50 updates at 1 ms) are refused at PRE-OP -> SAFE-OP
/// with their codes.
#[test]
fn factors_the_cycle_cannot_serve_are_refused() {
    let image = load_image().expect("the release image");
    let e = run(&image, config(1_000_000, 8, 3, 10)).unwrap_err();
    assert!(e.contains("AL status code 0x001d"), "{e}");
    let e = run(&image, config(1_000_000, 8, 10, 10)).unwrap_err();
    assert!(e.contains("AL status code 0x0035"), "{e}");
    // 40 updates (25 us each) would need more than 80 % of the cycle beside the input
    // stream: refused, where an estimate of 3 us per update had admitted it and starved the
    // watchdog.
    let e = run(&image, config(1_000_000, 8, 8, 10)).unwrap_err();
    assert!(e.contains("AL status code 0x0035"), "{e}");
}
