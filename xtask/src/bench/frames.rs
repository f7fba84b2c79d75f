//! Group 8 of the bench, frames on a network interface: how fast `cargo xtask sim --image --iface` answers an
//! outside master. SOEM (pysoem, `tests/cosim/scripts/pysoem_master.py`: DC at 4 ms,
//! process data, the SM watchdog, SDO Information) drives the co-simulated image on a veth
//! pair in a private network namespace (`unshare --net`), and the board's own summary gives
//! the frame answer latency (arrival on the interface to the reply's send) and how far the
//! CPU's virtual time was behind the wall clock. Needs root (raw sockets, namespaces),
//! iproute2 and pysoem; without them the rows say why.

use super::report::{Group, Row, Verdict};
use crate::build;
use crate::util::{cargo, exec, root, Result};
use std::path::Path;
use std::process::Command;

/// The issue's bound on the answer latency's 99th percentile (issue 32).
const P99_LIMIT_US: f64 = 500.0;

/// The figures the board printed.
#[derive(Debug, Clone, PartialEq)]
struct Served {
    mean_us: f64,
    p99_us: f64,
    max_us: f64,
    frames: u64,
    lag: String,
}

/// Parses the summary lines of a wall-clock run
/// (`virtual_board::tools::sim::serving_summary`).
fn parse(out: &str) -> Option<Served> {
    let latency = out
        .lines()
        .find(|l| l.starts_with("frame answer latency"))?;
    let after = |key: &str| -> Option<f64> {
        let rest = &latency[latency.find(key)? + key.len()..];
        rest.split_whitespace().next()?.parse().ok()
    };
    let lag = out
        .lines()
        .find_map(|l| l.strip_prefix("virtual time behind the wall clock: "))?;
    Some(Served {
        mean_us: after("mean ")?,
        p99_us: after("p99 ")?,
        max_us: after("max ")?,
        frames: after("over ")? as u64,
        lag: lag.to_string(),
    })
}

fn row(figure: &str, value: String, target: &str, verdict: Verdict) -> Row {
    Row::new(
        Group::Frames,
        figure.into(),
        value,
        target.into(),
        "issue 32: a module answers every frame in microseconds".into(),
        verdict,
    )
}

/// The rows of group 8: SOEM against the release image for 2 000 DC cycles (500 quick).
pub fn rows(quick: bool) -> Vec<Row> {
    let cycles = if quick { 500 } else { 2000 };
    match measure(cycles) {
        Ok(s) => {
            let verdict = if s.p99_us < P99_LIMIT_US {
                Verdict::Met(String::new())
            } else {
                Verdict::Missed(format!("p99 {} us", s.p99_us))
            };
            vec![
                row(
                    &format!("Frame answer latency, image on a veth pair, SOEM ({cycles} cycles of 4 ms DC)"),
                    format!(
                        "mean {} us, p99 {} us, max {} us over {} frames",
                        s.mean_us, s.p99_us, s.max_us, s.frames
                    ),
                    "p99 < 500 us",
                    verdict,
                )
                .with_number(s.p99_us, "us"),
                row(
                    "Virtual time behind the wall clock, same run",
                    s.lag,
                    "-",
                    Verdict::Info(String::new()),
                ),
            ]
        }
        Err(why) => vec![row(
            "Frame answer latency, image on a veth pair, SOEM",
            "-".into(),
            "p99 < 500 us",
            Verdict::NotMeasured(why),
        )],
    }
}

fn measure(cycles: u32) -> Result<Served> {
    if let Some(why) = virtual_board::tools::iface::pysoem_missing() {
        return Err(why);
    }
    let elf = build::build(&build::Args::default())?.elf;
    exec(cargo().args(["build", "--quiet", "-p", "lpc1754-cosim"]))?;
    let bin = build::target_dir().join("debug").join("lpc1754-cosim");
    let dir = build::target_dir().join("bench");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let board = dir.join("frames-board.txt");
    let master = dir.join("frames-master.txt");
    // The board in the background until the master is done (SIGINT ends it like Ctrl-C).
    let script = r#"
        ip link add vb0 type veth peer name vb1 && ip link set vb0 up && ip link set vb1 up || exit 2
        "$BIN" sim --iface vb1 --seconds 300 > "$BOARD" 2>&1 &
        board=$!
        for _ in $(seq 600); do grep -q "waiting for frames" "$BOARD" && break; sleep 0.1; done
        python3 "$SCRIPT" vb0 "$CYCLES" > "$MASTER" 2>&1
        status=$?
        kill -INT $board
        wait $board
        exit $status
    "#;
    let status = Command::new("unshare")
        .args(["--net", "--", "sh", "-c", script])
        .env("BIN", &bin)
        .env("BOARD", &board)
        .env("MASTER", &master)
        .env("CYCLES", cycles.to_string())
        .env(
            "SCRIPT",
            root().join("tests/cosim/scripts/pysoem_master.py"),
        )
        .env("LPC1754_IMAGE", &elf)
        .status()
        .map_err(|e| format!("unshare: {e}"))?;
    let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
    if !status.success() {
        return Err(format!(
            "SOEM did not pass ({status}): {}",
            read(&master).lines().last().unwrap_or("no output")
        ));
    }
    parse(&read(&board)).ok_or_else(|| format!("no latency in {}", board.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_lines_parse() {
        let out = "served 3.5 s: 10 EtherCAT frames\n\
            frame answer latency (arrival on the interface to the reply's send): mean 44 us, \
            p99 102 us, max 1861 us over 4737 frames; answered at real-time priority\n\
            virtual time behind the wall clock: 0.12 ms at the end, 85.15 ms at most\n";
        assert_eq!(
            parse(out),
            Some(Served {
                mean_us: 44.0,
                p99_us: 102.0,
                max_us: 1861.0,
                frames: 4737,
                lag: "0.12 ms at the end, 85.15 ms at most".into()
            })
        );
        assert_eq!(parse("nothing"), None);
    }
}
