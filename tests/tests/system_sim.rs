//! SYSTEM TEST: the `cargo xtask sim` runner ([`virtual_board::tools::sim`]) end to end, with
//! ethercrab in process.
//!
//! Each scenario saves its capture; the tests named `*_decodes_in_tshark` run it again and
//! decode the capture with tshark (ignored unless run explicitly, as `cargo xtask test`
//! does: they need tshark).

use std::path::{Path, PathBuf};
use virtual_board::capture_tests;
use virtual_board::tools::sim::{self, Line, SimConfig, Target};

fn collect(lines: &mut Vec<Line>) -> impl FnMut(Line) + '_ {
    move |l| {
        match &l {
            Line::Result(s) => println!("{s}"),
            Line::Progress(s) => eprintln!("{s}"),
        }
        lines.push(l)
    }
}

capture_tests!(
    runner_walks_the_esm_with_the_echo_responder,
    runner_echo_capture_decodes_in_tshark,
    walk_with_the_echo_responder,
    "system-sim-echo"
);

/// The runner walks the ESM with the transport test responder (no CoE): the SDO part
/// reports what it could not read instead of failing, and the loop-back is skipped with
/// a reason. Returns the pcap it writes (as `name`).
fn walk_with_the_echo_responder(name: &str) -> PathBuf {
    let pcap = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let cfg = SimConfig {
        seconds: Some(0.02),
        freqs_hz: vec![100.0],
        pcap: Some(pcap.clone()),
        ..Default::default()
    };
    let mut lines = Vec::new();
    let report = sim::run_in_process(&cfg, Target::echo(), &mut collect(&mut lines)).unwrap();
    assert_eq!(
        report.states,
        ["INIT", "PRE-OP", "SAFE-OP", "OP", "INIT"],
        "{report:?}"
    );
    assert_eq!(report.name, "Virtual analog IO");
    assert_eq!(report.identity.1, 0x1234);
    assert!(report.sdo.iter().all(|v| v.value.is_err()));
    assert!(report.loopback.is_empty());
    assert!(report.cycles >= 100);
    let text: Vec<String> = lines
        .iter()
        .filter_map(|l| match l {
            Line::Result(s) => Some(s.clone()),
            _ => None,
        })
        .collect();
    assert!(text.iter().any(|l| l.contains("loop-back: skipped")));
    assert!(text.iter().any(|l| l == "ESM: SAFE-OP -> OP"));
    let (path, frames) = report.pcap.clone().unwrap();
    assert_eq!(path, pcap);
    assert!(frames > 200);
    pcap
}

capture_tests!(
    runner_loops_back_through_the_firmware,
    runner_firmware_capture_decodes_in_tshark,
    loop_back_through_the_firmware,
    "system-sim-firmware"
);

/// `cargo xtask sim` with the firmware: the ESM walk, SDO values and the loop-back
/// figures (a short run: 10 periods of 500 Hz at the default cycle, the advertised
/// minimum). Returns the pcap it
/// writes (as `name`).
fn loop_back_through_the_firmware(name: &str) -> PathBuf {
    let pcap = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let cfg = SimConfig {
        seconds: Some(0.02),
        freqs_hz: vec![500.0],
        pcap: Some(pcap.clone()),
        ..Default::default()
    };
    let mut lines = Vec::new();
    let target = sim::firmware_target().unwrap();
    let report = sim::run_in_process(&cfg, target, &mut collect(&mut lines)).unwrap();
    assert_eq!(
        report.states,
        ["INIT", "PRE-OP", "SAFE-OP", "OP", "INIT"],
        "{report:?}"
    );
    let device_type = report.sdo.iter().find(|v| v.index == 0x1000).unwrap();
    assert_eq!(device_type.value.as_deref(), Ok("0x000c0191"));
    assert!(matches!(&report.od, Some(Ok(od)) if od.all.contains(&0x6401)));
    // Amplitude (the hold's sinc, -2.96 % at 500 Hz and 270 us), offset, latency, THD and
    // THD+N against the zero-order hold's.
    let figures = report.check_loopback(&cfg).unwrap();
    assert_eq!(figures.len(), 1);
    assert_eq!(figures[0].freq_hz, 500.0);
    pcap
}
