//! The image rows: the release image measured on the LPC1754 co-simulator (`tests/cosim`,
//! GPL-2.0, run as its own binary so its code stays out of xtask): the shortest DC cycle it
//! sustains, SYNC0 edge -> LDAC edge, the sampler's CPU share, and per RTIC task its
//! entry-to-exit cycles, CPU share and stack, with flash and RAM of the same ELF. The
//! figures come as JSON in the format of [`virtual_board::tools::image_figures`].
//!
//! Where an image figure and a formula row (F1, F2, F3) differ, the image figure is the
//! measurement; the formula rows stay as the model that explains it.

use super::report::{Group, Row, Verdict};
use crate::util::{cargo, exec, Result};
use crate::{build, setup};
use virtual_board::tools::image_figures::{
    shares_text, DcCheck, ImageFigures, Latency, SYNC0_TO_LDAC_MAX_NS,
};

/// The BRIEF's targets these rows are judged by (section 6).
const CYCLE_TARGET_US: f64 = 25.0;
/// SYNC0 edge -> both DAC outputs updated: target and aim (us).
const LATENCY_TARGET_US: f64 = 1.0;
/// See [`LATENCY_TARGET_US`].
const LATENCY_AIM_US: f64 = 0.5;
/// The sampler's CPU share at 250 kSPS.
const SAMPLER_TARGET: f64 = 0.10;

/// Builds `product`'s release image and runs the co-simulator's bench on it; the sweep also
/// tries `also_us` (the cycle the advertised-minimum rule turns on).
pub fn measure(
    quick: bool,
    also_us: u64,
    product: &'static firmware::products::Product,
) -> Result<ImageFigures> {
    let out = build::build(&build::Args::of(product))?;
    setup::cosim()?;
    let json = json_path();
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
        "bench",
        "--json",
    ])
    .arg(&json)
    .arg("--also-cycle-us")
    .arg(also_us.to_string())
    .env("LPC1754_IMAGE", &out.elf);
    if quick {
        cmd.arg("--quick");
    }
    exec(&mut cmd)?;
    let text = std::fs::read_to_string(&json)
        .map_err(|e| format!("cannot read {}: {e}", json.display()))?;
    serde_json::from_str(&text)
        .map_err(|e| format!("{}: not the co-simulator's figures: {e}", json.display()))
}

/// Where [`measure`] leaves the image's figures (JSON).
pub fn json_path() -> std::path::PathBuf {
    build::target_dir().join("bench").join("image.json")
}

fn us(ns: f64) -> f64 {
    ns / 1e3
}

/// Cycles of `ns` at the image's CPU clock.
fn cycles(f: &ImageFigures, ns: f64) -> f64 {
    ns * f.cclk_hz as f64 / 1e9
}

fn latency_text(f: &ImageFigures, l: &Latency) -> String {
    format!(
        "{:.2} us = {:.0} cycles mean, {:.2} us = {:.0} cycles max",
        us(l.mean_ns),
        cycles(f, l.mean_ns),
        us(l.max_ns as f64),
        cycles(f, l.max_ns as f64)
    )
}

/// The shortest DC cycle the image sustained, in us (None: none of the cycle times tried).
pub fn min_cycle_us(f: &ImageFigures) -> Option<f64> {
    f.sweep.shortest_sustained().map(|c| us(c.cycle_ns as f64))
}

/// The share of the PDI task's cycles its ET1100 accesses take (the first work item).
fn pdi_share(f: &ImageFigures, label_start: &str) -> f64 {
    f.profile
        .pdi_task
        .iter()
        .find(|(l, _)| l.starts_with(label_start))
        .map_or(0.0, |w| w.1)
}

/// The sensitivity run with the highest CPI of the time model.
pub fn dearer_cpi(f: &ImageFigures) -> Option<super::advertised::DearerCpi> {
    let ratio = |c: &(u64, u64)| c.0 as f64 / c.1 as f64;
    let dearest = f
        .cpi_sensitivity
        .iter()
        .max_by(|a, b| ratio(&a.cpi).total_cmp(&ratio(&b.cpi)))?;
    (ratio(&dearest.cpi) > ratio(&f.cpi)).then(|| super::advertised::DearerCpi {
        cpi: dearest.cpi,
        measured_us: dearest
            .sweep
            .shortest_sustained()
            .map(|c| us(c.cycle_ns as f64)),
    })
}

fn cycle_row(f: &ImageFigures) -> Row {
    let best = f.sweep.shortest_sustained();
    let below = f.sweep.first_failing();
    let figure = format!(
        "minimum DC cycle, 2 AO + 8 AI, on the image (co-simulator, {})",
        f.sweep.method
    );
    let Some(best) = best else {
        return Row::new(
            Group::Derived,
            figure,
            "none of the cycle times tried".into(),
            format!("<= {CYCLE_TARGET_US} us (40 kHz)"),
            "BRIEF 6: measured on the image".into(),
            Verdict::Missed(
                f.sweep
                    .points
                    .first()
                    .map_or("no cycle time tried".into(), DcCheck::verdict),
            ),
        );
    };
    let value = format!(
        "{:.0} us ({:.1} kHz){}",
        us(best.cycle_ns as f64),
        1e6 / best.cycle_ns as f64,
        below.map_or(String::new(), |b| format!(
            "; {:.0} us is not: {}",
            us(b.cycle_ns as f64),
            b.verdict()
        ))
    );
    let cause = format!(
        "at {:.0} us the CPU is {:.0} % busy; the PDI task (the ESC IRQ) spends {:.0} % of its \
         cycles in ET1100 accesses over the FIFO-less legacy SPI, polling SPIF for every byte",
        us(best.cycle_ns as f64),
        100.0 * best.cpu_load,
        100.0 * pdi_share(f, "ET1100 accesses")
    );
    let verdict = if us(best.cycle_ns as f64) <= CYCLE_TARGET_US {
        Verdict::Met(String::new())
    } else {
        Verdict::Missed(cause)
    };
    Row::new(
        Group::Derived,
        figure,
        value,
        format!("<= {CYCLE_TARGET_US} us (40 kHz)"),
        "BRIEF 6: measured on the image; thesis requires 20 kHz".into(),
        verdict,
    )
    .with_number(us(best.cycle_ns as f64), "us")
}

fn latency_row(f: &ImageFigures) -> Row {
    let l = &f.profile.dc.sync0_to_ldac;
    let worst = f
        .sweep
        .shortest_sustained()
        .map(|c| (c.cycle_ns, c.sync0_to_ldac.max_ns));
    let mean = us(l.mean_ns);
    let verdict = if us(l.max_ns as f64) <= LATENCY_AIM_US {
        Verdict::Met(format!("also the {LATENCY_AIM_US} us aim"))
    } else if us(l.max_ns as f64) <= LATENCY_TARGET_US {
        Verdict::Met(format!("above the {LATENCY_AIM_US} us aim"))
    } else {
        Verdict::Missed(
            "the SYNC0 task pulses LDAC after the capture interrupt's entry, the capture and \
             time-base reads and the latch decision; at short cycles the edge also waits for a \
             DAC preload running in the same task"
                .into(),
        )
    };
    Row::new(
        Group::Derived,
        format!(
            "SYNC0 edge -> LDAC edge (both DAC channels) on the image, at {:.0} us DC",
            us(f.profile.dc.cycle_ns as f64)
        ),
        format!(
            "{}{}",
            latency_text(f, l),
            worst.map_or(String::new(), |(c, max)| format!(
                "; at {:.0} us DC {:.2} us max",
                us(c as f64),
                us(max as f64)
            ))
        ),
        format!("<= {LATENCY_TARGET_US} us ({LATENCY_AIM_US} us the aim: LDAC only)"),
        "BRIEF 6: measured on the image".into(),
        verdict,
    )
    .with_number(mean, "us")
}

fn sampler_row(f: &ImageFigures) -> Row {
    let s = &f.profile.sampler;
    let cps = f.cclk_hz as f64;
    Row::new(
        Group::Adc,
        format!(
            "sampler CPU share at {:.0} kSPS on the image (GPDMA interrupt + ring drain)",
            s.conversions_per_s / 1e3
        ),
        format!(
            "{:.1} % (GPDMA interrupt {:.2} %, ring drain {:.1} %)",
            100.0 * s.share,
            100.0 * s.dma_irq_cycles_per_s / cps,
            100.0 * s.drain_cycles_per_s / cps
        ),
        format!("<= {:.0} %", 100.0 * SAMPLER_TARGET),
        "BRIEF 6: measured on the image".into(),
        if s.share <= SAMPLER_TARGET {
            Verdict::Met(String::new())
        } else {
            Verdict::Missed("the PDI task's drain of the ring".into())
        },
    )
    .with_number(100.0 * s.share, "%")
}

fn footprint_rows(f: &ImageFigures) -> Vec<Row> {
    let p = &f.profile;
    vec![
        Row::new(
            Group::Footprint,
            "the ELF the co-simulator ran".into(),
            format!(
                "{} B flash, {} B static RAM, {} B stack",
                f.flash_bytes, f.static_ram_bytes, f.stack_bytes
            ),
            "-".into(),
            "the image rows come from this ELF".into(),
            Verdict::Info(String::new()),
        )
        .with_number(f.flash_bytes as f64, "B"),
        Row::new(
            Group::Footprint,
            "stack on the image: deepest seen; bound (init, or idle + the deepest task of each \
             priority level)"
                .into(),
            format!("{} B; {} B", p.deepest_stack, p.stack_bound),
            format!("<= {} B (the stack the ELF leaves)", f.stack_bytes),
            "flip-link: an overflow faults".into(),
            if p.stack_bound <= f.stack_bytes {
                Verdict::Met(String::new())
            } else {
                Verdict::Missed(format!("{} B over", p.stack_bound - f.stack_bytes))
            },
        )
        .with_number(p.stack_bound as f64, "B"),
    ]
}

fn task_rows(f: &ImageFigures) -> Vec<Row> {
    let p = &f.profile;
    let mut rows = vec![Row::new(
        Group::Image,
        format!(
            "CPU load at {:.0} us DC (2 AO + 8 AI, 250 kSPS)",
            us(p.dc.cycle_ns as f64)
        ),
        format!("{:.1} %", 100.0 * p.dc.cpu_load),
        "-".into(),
        "cycles not asleep in WFI".into(),
        Verdict::Info(String::new()),
    )
    .with_number(100.0 * p.dc.cpu_load, "%")];
    for v in &p.vectors {
        let task = v.task.as_deref().unwrap_or("(no RTIC task)");
        let figure = match v.priority {
            Some(prio) => format!(
                "task {task}: {} (exception {}, priority {prio:#04x})",
                v.name, v.number
            ),
            None => format!("{task}: {}", v.name),
        };
        let value = if v.activations > 0 {
            format!(
                "{} activations, entry..exit {:.0} cycles = {:.2} us mean, {} cycles = {:.2} us \
                 max; {:.1} % of the CPU; stack {} B",
                v.activations,
                v.mean_cycles,
                us(v.mean_cycles * 1e9 / f.cclk_hz as f64),
                v.max_cycles,
                us(v.max_cycles as f64 * 1e9 / f.cclk_hz as f64),
                100.0 * v.own_share,
                v.max_stack
            )
        } else {
            format!(
                "{:.1} % of the CPU; stack {} B",
                100.0 * v.own_share,
                v.max_stack
            )
        };
        rows.push(
            Row::new(
                Group::Image,
                figure,
                value,
                "-".into(),
                "profile run: mailbox traffic, then DC OP".into(),
                Verdict::Info(String::new()),
            )
            .with_number(v.max_stack as f64, "B"),
        );
    }
    rows.push(Row::new(
        Group::Image,
        "where the PDI task's cycles go in OP".into(),
        shares_text(&p.pdi_task),
        "-".into(),
        "by function, inlined code included (DWARF)".into(),
        Verdict::Info(String::new()),
    ));
    rows.push(
        Row::new(
            Group::Image,
            format!(
                "the PDI task's longest activation ({})",
                p.pdi_longest.phase
            ),
            format!(
                "{} cycles = {:.0} us: {}",
                p.pdi_longest.cycles,
                us(p.pdi_longest.cycles as f64 * 1e9 / f.cclk_hz as f64),
                shares_text(&p.pdi_longest.work)
            ),
            "-".into(),
            "by function, inlined code included (DWARF)".into(),
            Verdict::Info(String::new()),
        )
        .with_number(p.pdi_longest.cycles as f64, "cycles"),
    );
    for c in &f.sweep.points {
        rows.push(
            Row::new(
                Group::Image,
                format!("DC cycle {:.0} us, 2 AO + 8 AI", us(c.cycle_ns as f64)),
                format!(
                    "{}; {} edges judged, CPU load {:.1} %, SYNC0 -> LDAC {:.2} us max",
                    c.verdict(),
                    c.edges,
                    100.0 * c.cpu_load,
                    us(c.sync0_to_ldac.max_ns as f64)
                ),
                format!(
                    "no stale output, no late input; SYNC0 -> LDAC <= {} us",
                    SYNC0_TO_LDAC_MAX_NS / 1000
                ),
                "the sweep of the minimum DC cycle, under a real master's traffic".into(),
                match (c.sustained(), c.ldac_met()) {
                    (true, true) => Verdict::Met(String::new()),
                    (true, false) => Verdict::Missed("SYNC0 -> LDAC over 1 us".into()),
                    _ => Verdict::Missed("not sustained".into()),
                },
            )
            .with_number(100.0 * c.cpu_load, "%"),
        );
    }
    rows
}

/// The image rows by group: (cycle time and latency, footprint, ADC, per task).
pub struct ImageRows {
    /// Group 3.
    pub derived: Vec<Row>,
    /// Group 4.
    pub footprint: Vec<Row>,
    /// Group 5.
    pub adc: Vec<Row>,
    /// Group 7.
    pub tasks: Vec<Row>,
}

/// The rows of `f`.
pub fn rows(f: &ImageFigures) -> ImageRows {
    ImageRows {
        derived: vec![cycle_row(f), latency_row(f)],
        footprint: footprint_rows(f),
        adc: vec![sampler_row(f)],
        tasks: task_rows(f),
    }
}

/// The note under the table: how the image rows were measured.
pub fn note(f: &ImageFigures) -> String {
    // Relative to the workspace, so the book's copy names no checkout of one machine.
    let elf = std::path::Path::new(&f.elf);
    let elf = elf.strip_prefix(crate::util::root()).unwrap_or(elf);
    format!(
        "Image rows: the release ELF ({}) on the LPC1754 co-simulator (`lpc1754-cosim bench{}`: \
         unicorn 2.1.5, instructions x CPI {}/{} at {} MHz, 12/10/6 cycles per exception \
         entry/return/tail-chain, the SPI and SSP byte times of their clock settings) with \
         ethercrab in process. Profile run: mailbox traffic in PRE-OP (SDO, SDO Information, a \
         segmented upload), then {} judged DC cycles of {:.0} us. A DC cycle time is sustained \
         when every SYNC0 edge loads both DAC channels together with the pair the frame before \
         it carried (no missed SYNC0, no stale output), every cycle's input image is new (no \
         late input, with a moving signal on every ADC channel), no AD7689 result is lost \
         (overwritten unread in the GPDMA ring, an SSP1 overrun, tCYC) and the slave stays in \
         OP; SYNC0 lies half a cycle after the frame, give or take the master's jitter \
         (docs/book/traffic.md). Sweep: {}.{}",
        elf.display(),
        if f.quick { " --quick" } else { "" },
        f.cpi.0,
        f.cpi.1,
        f.cclk_hz / 1_000_000,
        f.profile.dc.planned,
        us(f.profile.dc.cycle_ns as f64),
        f.sweep.method,
        sensitivity_text(f)
    )
}

/// " Time model sensitivity: at CPI 1/1 the shortest sustained DC cycle is ..., at CPI 3/2
/// ...".
fn sensitivity_text(f: &ImageFigures) -> String {
    if f.cpi_sensitivity.is_empty() {
        return String::new();
    }
    let each: Vec<String> = f
        .cpi_sensitivity
        .iter()
        .map(|c| {
            format!(
                "at CPI {}/{} {}",
                c.cpi.0,
                c.cpi.1,
                c.sweep.shortest_sustained().map_or(
                    "none of the cycle times tried".into(),
                    |p| format!("{:.0} us", us(p.cycle_ns as f64))
                )
            )
        })
        .collect();
    format!(
        " Time model sensitivity (the same search with every instruction's cycles 20 % below \
         and above CPI {}/{}), shortest sustained DC cycle: {}.",
        f.cpi.0,
        f.cpi.1,
        each.join(", ")
    )
}
