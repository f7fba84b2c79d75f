//! `cargo xtask bench --peer soes`: this project's release image and SOES built for the same
//! board (`cargo xtask peer soes`), both on the co-simulated LPC1754 under ethercrab,
//! measured the same way (`lpc1754-cosim peer-bench`, its own process: the GPL engine
//! stays out of xtask), printed side by side with the ratios, and the conformance table.

use crate::util::{cargo, exec, Result};
use crate::{build, peer, setup};
use std::fmt::Write as _;
use std::path::Path;
use virtual_board::tools::peer_figures::{
    conformance_table, PeerFigures, StackFigures, COMPARISON_CYCLE_NS,
};

/// Builds both images, runs the co-simulator's side-by-side bench, prints the tables;
/// `json`: a copy of the figures.
pub fn run(quick: bool, json: Option<&Path>) -> Result {
    let figures = measure(quick)?;
    print!("{}", report(&figures));
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&figures).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

fn measure(quick: bool) -> Result<PeerFigures> {
    let ours = build::build(&build::Args::default())?;
    let soes = peer::build_soes()?;
    setup::cosim()?;
    let json = build::target_dir().join("bench").join("peer-soes.json");
    if let Some(dir) = json.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let mut cmd = cargo();
    cmd.args([
        "run",
        "--quiet",
        "-p",
        "lpc1754-cosim",
        "--",
        "peer-bench",
        "--json",
    ])
    .arg(&json)
    .env("LPC1754_IMAGE", &ours.elf)
    .env(peer::SOES_IMAGE_ENV, &soes);
    if quick {
        cmd.arg("--quick");
    }
    exec(&mut cmd)?;
    let text = std::fs::read_to_string(&json)
        .map_err(|e| format!("cannot read {}: {e}", json.display()))?;
    serde_json::from_str(&text).map_err(|e| {
        format!(
            "{}: not the co-simulator's peer figures: {e}",
            json.display()
        )
    })
}

fn us(ns: f64) -> String {
    format!("{:.2} us", ns / 1e3)
}

/// `peer / ours`, the ratio column: above 1 the peer takes more (time, bytes).
fn ratio(ours: f64, peer: f64) -> String {
    if ours > 0.0 {
        format!("{:.2}", peer / ours)
    } else {
        "-".into()
    }
}

fn shortest(f: &StackFigures) -> Option<f64> {
    f.sweep.shortest_sustained().map(|c| c.cycle_ns as f64)
}

fn shortest_text(f: &StackFigures) -> String {
    match f.sweep.shortest_sustained() {
        Some(c) => format!(
            "{}{}",
            us(c.cycle_ns as f64),
            f.sweep.first_failing().map_or(String::new(), |b| format!(
                " ({} is not: {})",
                us(b.cycle_ns as f64),
                b.verdict()
            ))
        ),
        None => "none of the cycles tried".into(),
    }
}

/// The two tables as Markdown.
pub fn report(f: &PeerFigures) -> String {
    let (a, b) = (&f.ours, &f.peer);
    let peer = &f.peer_name;
    let ms = COMPARISON_CYCLE_NS / 1_000_000;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n| figure (co-simulated LPC1754, ethercrab) | this project | {peer} | {peer} / this project |"
    );
    let _ = writeln!(s, "|---|---|---|---|");
    let mut row = |name: String, x: String, y: String, r: String| {
        let _ = writeln!(s, "| {name} | {x} | {y} | {r} |");
    };
    row(
        "shortest sustained DC cycle, 2 AO + 8 AI".into(),
        shortest_text(a),
        shortest_text(b),
        match (shortest(a), shortest(b)) {
            (Some(x), Some(y)) => ratio(x, y),
            _ => "-".into(),
        },
    );
    let (la, lb) = (
        &a.at_comparison_cycle.sync0_to_ldac,
        &b.at_comparison_cycle.sync0_to_ldac,
    );
    row(
        format!("SYNC0 edge -> both DAC outputs (LDAC) at {ms} ms DC, mean (max)"),
        format!("{} ({})", us(la.mean_ns), us(la.max_ns as f64)),
        format!("{} ({})", us(lb.mean_ns), us(lb.max_ns as f64)),
        ratio(la.mean_ns, lb.mean_ns),
    );
    row(
        format!("CPU load at {ms} ms DC (cycles not in WFI)"),
        format!("{:.2} %", 100.0 * a.at_comparison_cycle.cpu_load),
        format!("{:.2} %", 100.0 * b.at_comparison_cycle.cpu_load),
        ratio(
            a.at_comparison_cycle.cpu_load,
            b.at_comparison_cycle.cpu_load,
        ),
    );
    row(
        "SDO upload service time, expedited (request in SM0 -> reply in SM1)".into(),
        us(a.sdo_upload_ns),
        us(b.sdo_upload_ns),
        ratio(a.sdo_upload_ns, b.sdo_upload_ns),
    );
    row(
        "SDO download service time, expedited 4 bytes".into(),
        us(a.sdo_download_ns),
        us(b.sdo_download_ns),
        ratio(a.sdo_download_ns, b.sdo_download_ns),
    );
    let esm = |f: &StackFigures| {
        format!(
            "{} (I->P {}, P->S {}, S->O {})",
            us(f.esm_total_ns() as f64),
            us(f.esm_ns[0] as f64),
            us(f.esm_ns[1] as f64),
            us(f.esm_ns[2] as f64)
        )
    };
    row(
        "ESM INIT -> OP, the slave's time (AL control -> AL status, DC)".into(),
        esm(a),
        esm(b),
        ratio(a.esm_total_ns() as f64, b.esm_total_ns() as f64),
    );
    row(
        format!("PDI bytes per process-data cycle (ET1100 SPI, {ms} ms DC)"),
        format!("{:.1} B", a.pdi_bytes_per_cycle),
        format!("{:.1} B", b.pdi_bytes_per_cycle),
        ratio(a.pdi_bytes_per_cycle, b.pdi_bytes_per_cycle),
    );
    row(
        "flash (the program: vectors, code, read-only data, .data)".into(),
        format!("{} B", a.flash_bytes),
        format!("{} B", b.flash_bytes),
        ratio(a.flash_bytes as f64, b.flash_bytes as f64),
    );
    row(
        "static RAM (.data + .bss)".into(),
        format!("{} B", a.static_ram_bytes),
        format!("{} B", b.static_ram_bytes),
        ratio(a.static_ram_bytes as f64, b.static_ram_bytes as f64),
    );
    row(
        format!("deepest stack ({ms} ms DC run)"),
        format!("{} B", a.stack_bytes),
        format!("{} B", b.stack_bytes),
        ratio(a.stack_bytes as f64, b.stack_bytes as f64),
    );
    let _ = writeln!(
        s,
        "\nSDO objects: this project {}; {peer} {}. Sweep: {}. {}",
        a.sdo_objects,
        b.sdo_objects,
        a.sweep.method,
        if f.quick { "Short form (--quick)." } else { "" }
    );
    let _ = writeln!(s);
    s.push_str(&conformance_table(&f.conformance, peer));
    s
}
