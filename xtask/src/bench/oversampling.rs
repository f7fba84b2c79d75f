//! The oversampling group (docs/book/oversampling.md): the analog-io image on the
//! co-simulator with the input block PDOs at 1 ms, 250 us and 100 us, alone and with output
//! update PDOs (`lpc1754-cosim oversampling`), one line of figures each.

use crate::build;
use crate::util::Result;

/// Cycles per configuration (the short form: fewer).
const CYCLES: u64 = 1_000;
const CYCLES_QUICK: u64 = 200;

/// Runs the group and returns its lines.
pub fn lines(quick: bool) -> Result<Vec<String>> {
    let product = build::product("analog-io")?;
    let out = build::build(&build::Args::of(product))?;
    let cycles = if quick { CYCLES_QUICK } else { CYCLES };
    super::cosim_cmd::lines(&["oversampling", "--cycles", &cycles.to_string()], &out.elf)
}
