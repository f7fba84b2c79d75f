//! A subcommand of the co-simulator's binary (`lpc1754-cosim`, GPL-2.0, run as its own
//! process so its code stays out of xtask) on a release image, its stdout as lines.

use crate::util::{cargo, Result};
use std::path::Path;

/// Runs `lpc1754-cosim ARGS` with `elf` as the image (`LPC1754_IMAGE`; the other products'
/// images beside it) and returns its stdout's lines.
pub fn lines(args: &[&str], elf: &Path) -> Result<Vec<String>> {
    let what = format!(
        "lpc1754-cosim {}",
        args.first().copied().unwrap_or_default()
    );
    let output = cargo()
        .args(["run", "--quiet", "-p", "lpc1754-cosim", "--"])
        .args(args)
        .env("LPC1754_IMAGE", elf)
        .output()
        .map_err(|e| format!("{what}: {e}"))?;
    if !output.status.success() {
        return Err(format!(
            "{what} failed: {}",
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(str::to_string)
        .collect())
}
