//! The oversampling group (docs/book/oversampling.md): the analog-io image on the
//! co-simulator with the input block PDOs at 1 ms, 500 us and the advertised minimum, alone
//! and with output update PDOs, and the 1 kHz loop-back with oversampling at 1 ms
//! (docs/book/oversampling-loopback.md) (`lpc1754-cosim oversampling`), one line of figures
//! each, and the loop-back's plot.

use super::plot;
use crate::build;
use crate::util::Result;
use std::path::{Path, PathBuf};

/// Cycles per configuration (the short form: fewer).
const CYCLES: u64 = 1_000;
const CYCLES_QUICK: u64 = 200;
/// The loop-back plot's file name in the plot directory.
pub const PLOT: &str = "loopback-oversampling.png";

/// Runs the group: its lines, and the loop-back plot written into `plot_dir`.
pub fn lines(quick: bool, plot_dir: &Path) -> Result<(Vec<String>, PathBuf)> {
    let product = build::product("analog-io")?;
    let out = build::build(&build::Args::of(product))?;
    let cycles = if quick { CYCLES_QUICK } else { CYCLES };
    // The traces go through the target directory, the plot into `plot_dir` (which may be
    // the book's figures).
    let scratch = build::target_dir().join("bench");
    for dir in [plot_dir, scratch.as_path()] {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let json = scratch.join("loopback-oversampling.json");
    let json_arg = json.to_string_lossy();
    let lines = super::cosim_cmd::lines(
        &[
            "oversampling",
            "--cycles",
            &cycles.to_string(),
            "--loopback-json",
            &json_arg,
        ],
        &out.elf,
    )?;
    let png = plot_dir.join(PLOT);
    plot::loopback(
        &png,
        "Loop-back AI1 -> master -> AO1 on the image with oversampling (every conversion in, 20 kHz out)",
        &traces(&json)?,
    )?;
    Ok((lines, png))
}

/// The traces `lpc1754-cosim oversampling --loopback-json` wrote.
fn traces(json: &Path) -> Result<Vec<plot::Trace>> {
    let text = std::fs::read_to_string(json)
        .map_err(|e| format!("cannot read {}: {e}", json.display()))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", json.display()))?;
    let bad = || format!("{}: not the loop-back traces", json.display());
    let points = |v: &serde_json::Value| -> Result<Vec<(f64, f64)>> {
        v.as_array()
            .ok_or_else(bad)?
            .iter()
            .map(|p| match (p[0].as_f64(), p[1].as_f64()) {
                (Some(t), Some(v)) => Ok((t, v)),
                _ => Err(bad()),
            })
            .collect()
    };
    value
        .as_array()
        .ok_or_else(bad)?
        .iter()
        .map(|t| {
            Ok(plot::Trace {
                freq_hz: t["freq_hz"].as_f64().ok_or_else(bad)?,
                input: points(&t["input"])?,
                output: points(&t["output"])?,
                figures: t["figures"].as_str().ok_or_else(bad)?.to_string(),
            })
        })
        .collect()
}
