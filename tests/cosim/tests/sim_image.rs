//! The image on the co-simulator under ethercrab: the in-process sim run (ESM walk, SDO
//! identity and OD summary, the loop-back and its figures) as `cargo xtask sim --image
//! [--product NAME]` does it, on both boards.

mod common;

use firmware::products::Product;
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_target, load_image_of};
use virtual_board::tools::sim::{self, Line, SimConfig};

#[test]
fn sim_reaches_op_and_loops_back() {
    sim_run(firmware::products::default());
}

#[test]
fn sim_reaches_op_and_loops_back_on_the_stm32() {
    sim_run(common::stm32_product());
}

fn sim_run(product: &Product) {
    let image = load_image_of(product.name).unwrap();
    let (target, handle) = image_target(image, Options::default()).unwrap();
    let cfg = SimConfig {
        freqs_hz: vec![500.0],
        seconds: Some(0.02),
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
    // 10 periods of 500 Hz at the default cycle (the advertised minimum, 270 us): amplitude
    // (the hold's sinc), offset, latency, THD and THD+N against the zero-order hold's, as
    // the host-compiled firmware's loop-back is judged (system_sim).
    let figures = report.check_loopback(&cfg).unwrap();
    assert_eq!(figures.len(), 1);
}
