//! The figures of the side-by-side bench (issue 29): this project's release image and a peer
//! stack (SOES) measured the same way on the co-simulated board, and the conformance checks
//! of both. The co-simulator writes them as JSON (`lpc1754-cosim peer-bench`), `cargo xtask
//! bench --peer soes` reads them without linking the GPL co-simulator.

use crate::tools::image_figures::{DcCheck, Sweep};
use serde::{Deserialize, Serialize};

/// One stack's figures.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct StackFigures {
    /// What it is.
    pub name: String,
    /// The ELF measured.
    pub elf: String,
    /// The sweep for the shortest sustained DC cycle (criteria of [`DcCheck`]).
    pub sweep: Sweep,
    /// The run at the comparison cycle ([`COMPARISON_CYCLE_NS`]): CPU load, SYNC0 -> LDAC.
    pub at_comparison_cycle: DcCheck,
    /// ET1100 SPI bytes per process-data cycle in OP at the comparison cycle.
    pub pdi_bytes_per_cycle: f64,
    /// Service time of an expedited SDO upload (ns): the request complete in SM0 -> the
    /// reply complete in SM1, mean of the repetitions.
    pub sdo_upload_ns: f64,
    /// The same for an expedited download of 4 bytes.
    pub sdo_download_ns: f64,
    /// The objects of the two SDO rows.
    pub sdo_objects: String,
    /// The slave's time per transition (AL control written -> AL status showing the state),
    /// ns: INIT -> PRE-OP, PRE-OP -> SAFE-OP, SAFE-OP -> OP.
    pub esm_ns: [u64; 3],
    /// Flash bytes of the program (vector table, code, read-only data, .data's initial
    /// values).
    pub flash_bytes: u64,
    /// Static RAM (.data + .bss).
    pub static_ram_bytes: u64,
    /// Deepest stack seen (the painted stack) in the run at the comparison cycle.
    pub stack_bytes: u64,
}

impl StackFigures {
    /// INIT -> OP: the three transitions' times added.
    pub fn esm_total_ns(&self) -> u64 {
        self.esm_ns.iter().sum()
    }
}

/// The DC cycle of the CPU-load and latency rows: 1 ms.
pub const COMPARISON_CYCLE_NS: u64 = 1_000_000;

/// A check's outcome for one stack.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Verdict {
    /// The check passed.
    pub pass: bool,
    /// What was seen (why it failed, or the value that passed).
    pub detail: String,
}

/// One conformance check, run against both stacks.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct ConformanceRow {
    /// The area (mailbox, SDO, complete access, SDO Information, ESM, watchdog, DC).
    pub area: String,
    /// What the check requires (and of which specification).
    pub check: String,
    /// This project's release image.
    pub ours: Verdict,
    /// The peer.
    pub peer: Verdict,
}

/// Everything the side-by-side bench measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct PeerFigures {
    /// The short form (fewer cycles, coarser sweep).
    pub quick: bool,
    /// The peer's name (`soes`).
    pub peer_name: String,
    /// This project's release image.
    pub ours: StackFigures,
    /// The peer.
    pub peer: StackFigures,
    /// The conformance checks.
    pub conformance: Vec<ConformanceRow>,
}

/// The conformance rows as a Markdown table (area, check, each stack's verdict with what was
/// seen) and a count of the checks each stack passes.
pub fn conformance_table(rows: &[ConformanceRow], peer: &str) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "| area | check | this project | {peer} |");
    let _ = writeln!(s, "|---|---|---|---|");
    let cell = |v: &Verdict| {
        format!(
            "{} ({})",
            if v.pass { "pass" } else { "**fail**" },
            v.detail
        )
    };
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            r.area,
            r.check,
            cell(&r.ours),
            cell(&r.peer)
        );
    }
    let passed = |f: &dyn Fn(&ConformanceRow) -> bool| rows.iter().filter(|r| f(r)).count();
    let _ = writeln!(
        s,
        "\n{} checks: this project passes {}, {peer} passes {}.",
        rows.len(),
        passed(&|r| r.ours.pass),
        passed(&|r| r.peer.pass)
    );
    s
}
