//! The image on the co-simulator under ethercrab: the in-process sim run (ESM walk, SDO
//! identity and OD summary, the loop-back) as `cargo xtask sim --image` does it.

use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_target, load_image};
use virtual_board::tools::sim::{self, Line, SimConfig};

#[test]
fn sim_reaches_op_and_loops_back() {
    let image = load_image().unwrap();
    let (target, handle) = image_target(image, Options::default()).unwrap();
    let cfg = SimConfig {
        freqs_hz: vec![500.0],
        seconds: Some(0.01),
        ..Default::default()
    };
    let mut out = |l: Line| match l {
        Line::Result(s) => println!("{s}"),
        Line::Progress(s) => eprintln!("{s}"),
    };
    let report = sim::run_in_process(&cfg, target, &mut out);
    let facts = handle.with(|c| c.facts()).unwrap();
    println!("{}", facts.summary());
    let report = report.unwrap();
    assert!(
        report.states.contains(&"OP".to_string()),
        "{:?}",
        report.states
    );
    assert!(facts.fault.is_none() && facts.reports.is_empty());
}
