//! SYSTEM TEST: the `cargo xtask sim` runner ([`virtual_board::sim`]) end to end, with
//! ethercrab in process.

use virtual_board::sim::{self, Line, SimConfig, Target};

fn collect(lines: &mut Vec<Line>) -> impl FnMut(Line) + '_ {
    move |l| {
        match &l {
            Line::Result(s) => println!("{s}"),
            Line::Progress(s) => eprintln!("{s}"),
        }
        lines.push(l)
    }
}

/// The runner walks the ESM with the transport test responder (no CoE): the SDO part
/// reports what it could not read instead of failing, and the loop-back is skipped with
/// a reason. The pcap it writes decodes in tshark.
#[test]
fn runner_walks_the_esm_with_the_echo_responder() {
    let pcap = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("system-sim-echo.pcap");
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
    virtual_board::sim::tshark::assert_clean(&pcap);
}
