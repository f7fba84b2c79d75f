//! The figures the LPC1754 co-simulator (`tests/cosim`, GPL-2.0) measures on the release
//! image for `cargo xtask bench` (issue 12, section 3), as its `bench` command writes them
//! (JSON) and xtask reads them. The format lives here, in the MIT/Apache virtual board, so
//! xtask reads it without linking the co-simulator.
//!
//! The criteria of a sustained DC cycle are defined here, once ([`DcCheck::sustained`]).

use serde::{Deserialize, Serialize};

/// Everything `lpc1754-cosim bench` measured.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ImageFigures {
    /// The short form (CI) rather than the full one.
    pub quick: bool,
    /// The ELF that ran.
    pub elf: String,
    /// Flash the ELF occupies (bytes: its allocated sections with contents, as
    /// `cargo xtask size` counts them).
    pub flash_bytes: u64,
    /// Static RAM of the ELF (.data + .bss + .uninit, bytes).
    pub static_ram_bytes: u64,
    /// Stack the ELF leaves (the local SRAM below its initial SP, bytes).
    pub stack_bytes: u64,
    /// The time model: cycles per instruction as numerator and denominator.
    pub cpi: (u64, u64),
    /// CPU clock the image set up (Hz).
    pub cclk_hz: u64,
    /// The profile run: per task, the sampler, SYNC0 -> LDAC.
    pub profile: ProfileRun,
    /// The shortest DC cycle.
    pub sweep: Sweep,
    /// The shortest DC cycle searched again with the time model's CPI 20 % below and above
    /// [`ImageFigures::cpi`] (the margin the advertised minimum needs).
    #[serde(default)]
    pub cpi_sensitivity: Vec<CpiSweep>,
}

/// The sweep's search at another CPI of the time model.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct CpiSweep {
    /// Cycles per instruction, numerator and denominator.
    pub cpi: (u64, u64),
    /// The cycle times tried.
    pub sweep: Sweep,
}

/// One run from reset: INIT -> PRE-OP, mailbox traffic (SDO uploads and downloads, SDO
/// Information, a segmented upload), then INIT -> OP with DC SYNC0 and process data.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ProfileRun {
    /// The OP part of the run.
    pub dc: DcCheck,
    /// Per exception (RTIC task) and thread mode, over the whole run.
    pub vectors: Vec<Vector>,
    /// Deepest stack seen over the whole run (the stack painted at power-on, bytes).
    pub deepest_stack: u64,
    /// The most the stack can need: init's (which runs with interrupts off), or idle's plus,
    /// per priority level, the deepest stack of a task of that level (tasks of one level
    /// never nest), whichever is more.
    pub stack_bound: u64,
    /// The AD7689 sampler's share of the CPU in the OP part.
    pub sampler: SamplerShare,
    /// The PDI task in the OP part: where its cycles go.
    pub pdi_task: Vec<(String, f64)>,
    /// The longest activation of the PDI task: when (phase of the run) and where its cycles
    /// went.
    pub pdi_longest: Longest,
    /// Per task in the OP part, the functions its cycles went to, most first.
    #[serde(default)]
    pub hot_code: Vec<HotCode>,
}

/// One function's own cycles in a task, per judged DC cycle: the code of library functions
/// inlined into it (register access, iterators, `read_volatile`) counts to it, so what
/// speeds up a cycle can be read off by name.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct HotCode {
    /// The task (RTIC task name, else the vector's).
    pub task: String,
    /// The innermost function of the project's crates the cycles were spent in.
    pub function: String,
    /// Its cycles per judged DC cycle.
    pub cycles_per_cycle: f64,
}

/// One exception (an RTIC task's vector) or thread mode (number 0: init and idle).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Vector {
    /// Exception number (16 + IRQ), 0 for thread mode.
    pub number: u32,
    /// Its name (LPC17xx vector table).
    pub name: String,
    /// The RTIC task bound to it, as the image's debug information names it.
    pub task: Option<String>,
    /// NVIC priority byte (lower preempts); None for thread mode.
    pub priority: Option<u8>,
    /// Completed activations.
    pub activations: u64,
    /// Mean entry-to-exit cycles (exception entry and return included, nested preemptions
    /// included).
    pub mean_cycles: f64,
    /// Longest entry-to-exit cycles.
    pub max_cycles: u64,
    /// Share of all cycles spent in its own code (nested preemptions excluded).
    pub own_share: f64,
    /// Deepest stack one activation used itself (bytes, its 32-byte exception frame and
    /// alignment pad included).
    pub max_stack: u64,
}

/// The AD7689 sampler's work on the CPU.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SamplerShare {
    /// AD7689 conversions per second in the OP part.
    pub conversions_per_s: f64,
    /// Cycles per second of the GPDMA interrupt (entry to exit).
    pub dma_irq_cycles_per_s: f64,
    /// Cycles per second of the PDI task's drain of the ring (`AdcSource::drain_into`, with
    /// what it inlines and calls).
    pub drain_cycles_per_s: f64,
    /// Both, as a share of the CPU's cycles.
    pub share: f64,
}

/// The longest activation of a task.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Longest {
    /// Its entry-to-exit cycles.
    pub cycles: u64,
    /// The phase of the run it fell in.
    pub phase: String,
    /// Where its own cycles went (label, share).
    pub work: Vec<(String, f64)>,
}

/// SYNC0 edge -> LDAC falling edge (both DAC channels loaded together), per SYNC0 edge.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Latency {
    /// Edges measured.
    pub count: u64,
    /// Shortest (ns).
    pub min_ns: u64,
    /// Mean (ns).
    pub mean_ns: f64,
    /// Longest (ns).
    pub max_ns: u64,
    /// How often each latency occurred: (ns, edges), shortest first (the latencies are
    /// whole CPU cycles, so a few distinct values cover a run).
    #[serde(default)]
    pub histogram: Vec<(u64, u64)>,
}

/// A DC cycle run with 2 AO + 8 AI, and the criteria it is judged by.
///
/// The master (ethercrab, in process) sends one frame per cycle with a new output pair (both
/// channels change every cycle), SYNC0 lies half a cycle after the frame
/// (`sync0_shift` = cycle / 2), and the ADC inputs are constants. Judged over the
/// `cycles` SYNC0 edges after the first ones in OP:
/// - **missed SYNC0**: an edge the SYNC0 task never served: its capture (CAP1.0 -> T1CR0)
///   was overwritten by the next edge's before the CPU read it or acknowledged its
///   interrupt;
/// - **stale output**: an edge after which both DAC channels were not loaded together, before
///   the next edge, with the pair the last frame before the edge carried (the pair came too
///   late for its edge, or never: the firmware had no fresh pair to latch, or latched another);
/// - **lost sample**: an AD7689 result the GPDMA wrote into the ring and overwrote before the
///   CPU read it, a frame lost to a full SSP1 RX FIFO, or two conversions closer than the
///   ADC's tCYC;
/// - **unsampled inputs**: fewer AD7689 conversions than one per channel per cycle (8 per
///   cycle), so some cycle's inputs could not be new (a firmware that samples once per
///   cycle in the background falls behind when the CPU is saturated);
/// - and the slave stays in OP with the working counters right.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct DcCheck {
    /// DC cycle (ns).
    pub cycle_ns: u64,
    /// Cycles the run was to judge.
    pub planned: u64,
    /// SYNC0 edges judged.
    pub edges: u64,
    /// See the type's documentation.
    pub missed_sync0: u64,
    /// See the type's documentation.
    pub stale_outputs: u64,
    /// See the type's documentation.
    pub lost_samples: u64,
    /// Cycles whose inputs were off the ADC model's constant inputs by more than 1 LSB (a
    /// figure, not a criterion: inputs are read a cycle later than they are sampled).
    pub stale_inputs: u64,
    /// Why the run stopped early (the slave left OP, a frame failed, the image faulted, the
    /// firmware refused the cycle), if it did.
    pub failure: Option<String>,
    /// CPU load over the judged cycles (cycles not asleep).
    pub cpu_load: f64,
    /// SYNC0 edge -> LDAC edge over the judged cycles.
    pub sync0_to_ldac: Latency,
    /// AD7689 conversions over the judged cycles (see the type's documentation).
    #[serde(default)]
    pub conversions: u64,
    /// Cycles whose input image (moving inputs) was the previous cycle's on every channel:
    /// an SM3 update that came late (a criterion).
    #[serde(default)]
    pub late_inputs: u64,
    /// SDO exchanges completed in OP during the run (the mailbox traffic).
    #[serde(default)]
    pub sdo_exchanges: u64,
    /// The traffic the run was judged under (the co-simulator's `Traffic::describe`).
    #[serde(default)]
    pub traffic: String,
    /// SYNC0 -> LDAC is judged ([`DcCheck::ldac_met`], in the verdict): the runs under a
    /// real master's traffic (the image's sweep); a figure only for the others (the peer).
    #[serde(default)]
    pub judge_ldac: bool,
}

/// The longest SYNC0 -> LDAC a sustained cycle time may show (BRIEF section 6: both DAC
/// outputs updated within 1 us of the SYNC0 edge).
pub const SYNC0_TO_LDAC_MAX_NS: u64 = 1_000;

/// Conversions per judged cycle a sustained cycle needs: one per AD7689 channel.
pub const CONVERSIONS_PER_CYCLE: u64 = 8;

impl DcCheck {
    /// No missed SYNC0, no stale output, no lost sample, no failure, over all planned cycles.
    pub fn sustained(&self) -> bool {
        self.failure.is_none()
            && self.edges >= self.planned
            && self.missed_sync0 == 0
            && self.stale_outputs == 0
            && self.late_inputs == 0
            && self.lost_samples == 0
            && self.conversions >= CONVERSIONS_PER_CYCLE * self.edges
    }

    /// SYNC0 -> LDAC within [`SYNC0_TO_LDAC_MAX_NS`] at every judged edge (judged apart from
    /// [`Self::sustained`]: a late latch is a timing figure of the DAC path, not lost
    /// process data; the sweep reports it per cycle time).
    pub fn ldac_met(&self) -> bool {
        self.sync0_to_ldac.count > 0 && self.sync0_to_ldac.max_ns <= SYNC0_TO_LDAC_MAX_NS
    }

    /// What broke, for a report ("sustained" when nothing did).
    pub fn verdict(&self) -> String {
        if let Some(f) = &self.failure {
            return f.clone();
        }
        let mut why = Vec::new();
        if self.edges < self.planned {
            why.push(format!("{} of {} edges judged", self.edges, self.planned));
        }
        for (n, what) in [
            (self.missed_sync0, "missed SYNC0"),
            (self.stale_outputs, "stale outputs"),
            (self.late_inputs, "late inputs"),
            (self.lost_samples, "lost samples"),
        ] {
            if n > 0 {
                why.push(format!("{n} {what}"));
            }
        }
        if self.conversions < CONVERSIONS_PER_CYCLE * self.edges {
            why.push(format!(
                "unsampled inputs: {} conversions in {} cycles",
                self.conversions, self.edges
            ));
        }
        let mut verdict = if why.is_empty() {
            "sustained".to_string()
        } else {
            why.join(", ")
        };
        if self.judge_ldac && !self.ldac_met() {
            verdict.push_str(&format!(
                "; SYNC0 -> LDAC {:.2} us max: over the {:.1} us target",
                self.sync0_to_ldac.max_ns as f64 / 1e3,
                SYNC0_TO_LDAC_MAX_NS as f64 / 1e3
            ));
        }
        verdict
    }
}

/// (label, share) pairs as text, shares of at least 0.5 %: "label 58 %; other 10 %".
pub fn shares_text(work: &[(String, f64)]) -> String {
    work.iter()
        .filter(|(_, x)| *x >= 0.005)
        .map(|(l, x)| format!("{l} {:.0} %", 100.0 * x))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The cycle times tried, longest first, and what the shortest sustained one is.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Sweep {
    /// Every cycle time tried, in the order tried.
    pub points: Vec<DcCheck>,
    /// What the sweep covered (the short form checks one cycle time only).
    pub method: String,
}

impl Sweep {
    /// The shortest cycle time that was sustained, if any.
    pub fn shortest_sustained(&self) -> Option<&DcCheck> {
        self.points
            .iter()
            .filter(|p| p.sustained())
            .min_by_key(|p| p.cycle_ns)
    }

    /// The longest cycle time that was not sustained and is shorter than every sustained
    /// one (the bound from below), if any.
    pub fn first_failing(&self) -> Option<&DcCheck> {
        let best = self.shortest_sustained().map_or(u64::MAX, |p| p.cycle_ns);
        self.points
            .iter()
            .filter(|p| !p.sustained() && p.cycle_ns < best)
            .max_by_key(|p| p.cycle_ns)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(cycle_us: u64, missed: u64) -> DcCheck {
        DcCheck {
            cycle_ns: cycle_us * 1000,
            planned: 100,
            edges: 100,
            missed_sync0: missed,
            conversions: 8 * 100,
            ..Default::default()
        }
    }

    #[test]
    fn every_criterion_breaks_a_cycle() {
        assert!(point(50, 0).sustained());
        assert_eq!(point(50, 0).verdict(), "sustained");
        assert!(!point(50, 1).sustained());
        let mut p = point(50, 0);
        p.stale_outputs = 2;
        assert!(!p.sustained());
        assert_eq!(p.verdict(), "2 stale outputs");
        let mut p = point(50, 0);
        p.lost_samples = 1;
        assert!(!p.sustained());
        let mut p = point(50, 0);
        p.edges = 99;
        assert!(!p.sustained());
        assert_eq!(p.verdict(), "99 of 100 edges judged");
        let mut p = point(50, 0);
        p.failure = Some("left OP".into());
        assert!(!p.sustained());
        // Inputs a cycle old are a figure, not a criterion.
        let mut p = point(50, 0);
        p.stale_inputs = 5;
        assert!(p.sustained());
        // Fewer than 8 conversions per cycle: some cycle's inputs are not new.
        let mut p = point(50, 0);
        p.conversions = 8 * 100 - 1;
        assert!(!p.sustained());
        assert_eq!(
            p.verdict(),
            "unsampled inputs: 799 conversions in 100 cycles"
        );
    }

    #[test]
    fn the_sweep_reports_the_shortest_sustained_and_the_bound_below() {
        let s = Sweep {
            points: vec![
                point(100, 0),
                point(60, 0),
                point(40, 3),
                point(50, 0),
                point(45, 1),
            ],
            method: String::new(),
        };
        assert_eq!(s.shortest_sustained().unwrap().cycle_ns, 50_000);
        assert_eq!(s.first_failing().unwrap().cycle_ns, 45_000);
        let work = [("SPI".to_string(), 0.581), ("tiny".to_string(), 0.004)];
        assert_eq!(shares_text(&work), "SPI 58 %");
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<Sweep>(&json).unwrap(), s);
    }
}
