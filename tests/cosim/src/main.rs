//! `lpc1754-cosim`: the release image on the co-simulated LPC1754, driven by a real master.
//!
//! ```text
//! lpc1754-cosim sim [the options of `cargo xtask sim`]   # what `cargo xtask sim --image` runs
//! lpc1754-cosim bench [--quick] [--json FILE]             # the image rows of `cargo xtask bench`
//! ```
//!
//! The image is `$LPC1754_IMAGE` (set by xtask after it built the image), else the release
//! ELF in the workspace's target directory.

use clap::{Parser, Subcommand};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_path, image_target, load_image, load_image_of, CosimHandle};
use std::process::ExitCode;
use virtual_board::tools::sim;
use virtual_board::tools::sim::cli::{self, SimArgs};

#[derive(Parser)]
#[command(
    name = "lpc1754-cosim",
    about = "The release image on the co-simulated LPC1754"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The virtual board with the image as its MCU, driven by a real master (the options
    /// of `cargo xtask sim`), plus the image facts.
    #[command(after_long_help = cli::AFTER_HELP)]
    Sim {
        #[command(flatten)]
        args: SimArgs,
        /// Print the firmware's defmt log (RTT) as it comes.
        #[arg(long)]
        log: bool,
    },
    /// The image's figures for `cargo xtask bench`: a profile run (per task cycles and
    /// stack, the sampler's share, SYNC0 -> LDAC) and the sweep for the shortest DC cycle.
    Bench {
        /// The short form (CI): fewer cycles per run, a coarser sweep.
        #[arg(long)]
        quick: bool,
        /// Write the figures as JSON to FILE (the format of
        /// `virtual_board::tools::image_figures`) instead of printing them as text.
        #[arg(long, value_name = "FILE")]
        json: Option<std::path::PathBuf>,
        /// Only judge this DC cycle (us), with the plan's cycles under a real master's traffic
        /// (as the sweep judges), and print the verdict.
        #[arg(long, value_name = "US")]
        cycle_us: Option<u64>,
        /// Let the sweep try this DC cycle (us) too (the cycle a rule on its figure turns
        /// on).
        #[arg(long, value_name = "US")]
        also_cycle_us: Option<u64>,
        /// With --cycle-us: the time model's cycles per instruction instead of the chip's
        /// (NUM/DEN, e.g. 3/2: 20 % above the LPC1754's 5/4).
        #[arg(long, value_name = "NUM/DEN", value_parser = parse_cpi, requires = "cycle_us")]
        cpi: Option<lpc1754_cosim::chip::Cpi>,
    },
    /// Oversampling on the image (docs/book/oversampling.md): the block PDOs at 1 ms,
    /// 500 us and the advertised minimum, then the 1 kHz loop-back with oversampling at 1 ms
    /// (docs/book/oversampling-loopback.md), one line of figures each.
    Oversampling {
        /// Cycles per configuration.
        #[arg(long, default_value_t = 1_000)]
        cycles: u64,
        /// Write the loop-back's input and output traces (the last periods of each run)
        /// as JSON to FILE, for `cargo xtask bench`'s plot.
        #[arg(long, value_name = "FILE")]
        loopback_json: Option<std::path::PathBuf>,
    },
    /// Both boards' release images (the default product on the LPC1754, the STM32F103's
    /// product) swept for the shortest sustained DC cycle, side by side (Markdown).
    Boards {
        /// The short form: fewer cycles per run, a coarser sweep.
        #[arg(long)]
        quick: bool,
        /// The LPC1754 row from `bench --json`'s figures (its sweep) instead of a new sweep.
        #[arg(long, value_name = "FILE")]
        lpc_figures: Option<std::path::PathBuf>,
    },
    /// This project's image and a peer stack (SOES, `$SOES_IMAGE` or `cargo xtask peer
    /// soes`'s output) measured the same way, and the conformance checks of both.
    PeerBench {
        /// The short form (CI): fewer cycles per run, a coarser sweep.
        #[arg(long)]
        quick: bool,
        /// Write the figures as JSON to FILE (`virtual_board::tools::peer_figures`).
        #[arg(long, value_name = "FILE")]
        json: Option<std::path::PathBuf>,
        /// Only the conformance table (Markdown) on stdout.
        #[arg(long)]
        conformance: bool,
    },
}

fn oversampling(cycles: u64, loopback_json: Option<&std::path::Path>) -> Result<(), String> {
    use lpc1754_cosim::oversampling::{figures, loopback, run, Config, BENCH_CONFIGS};
    let image = load_image()?;
    for (cycle_ns, sample_pdos, update_pdos) in BENCH_CONFIGS {
        let config = Config {
            cycle_ns,
            cycles,
            sample_pdos,
            sine_hz: 1_234.5,
            update_pdos,
        };
        match run(&image, config) {
            Ok(r) => println!("{}", figures(&r)),
            Err(e) => println!(
                "cycle {:>5} us, {sample_pdos} sample PDOs, {update_pdos} update PDOs: not run: {}",
                cycle_ns / 1_000,
                e.lines().next().unwrap_or("")
            ),
        }
    }
    let mut traces = Vec::new();
    for (cycle_ns, sample_pdos, update_pdos) in loopback::CONFIGS {
        let l = loopback::run(&image, cycle_ns, sample_pdos, update_pdos, cycles)?;
        println!("{}", l.line());
        let (input, output) = l.traces(LOOPBACK_PLOT_PERIODS);
        traces.push(serde_json::json!({
            "freq_hz": l.analysis.freq_hz,
            "figures": format!(
                "{} us cycle, {} updates/cycle: amplitude error {:+.2} %, THD {:.1} dB, latency {:.0} us",
                cycle_ns / 1_000,
                l.updates(),
                100.0 * l.analysis.amplitude_error,
                l.analysis.thd_db(),
                l.analysis.latency_ns / 1e3
            ),
            "input": input,
            "output": output,
        }));
    }
    if let Some(path) = loopback_json {
        let text = serde_json::to_string(&traces).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

/// Periods of the sine in each panel of the loop-back plot.
const LOOPBACK_PLOT_PERIODS: f64 = 3.0;

/// "3/2" -> CPI 3/2.
fn parse_cpi(s: &str) -> Result<lpc1754_cosim::chip::Cpi, String> {
    let bad = || format!("{s:?} is not a CPI as NUM/DEN with both > 0 (e.g. 3/2)");
    let (num, den) = s.split_once('/').ok_or_else(bad)?;
    let (num, den) = (
        num.trim().parse::<u64>().map_err(|_| bad())?,
        den.trim().parse::<u64>().map_err(|_| bad())?,
    );
    if num == 0 || den == 0 {
        return Err(bad());
    }
    Ok(lpc1754_cosim::chip::Cpi { num, den })
}

fn bench(
    quick: bool,
    json: Option<&std::path::Path>,
    cycle_us: Option<u64>,
    also_cycle_us: Option<u64>,
    cpi: Option<lpc1754_cosim::chip::Cpi>,
) -> Result<(), String> {
    let image = load_image()?;
    if let Some(us) = cycle_us {
        let plan = lpc1754_cosim::bench::Plan::new(quick);
        // Judged as the sweep judges: under a real master's traffic.
        let program = lpc1754_cosim::bench::Program {
            cpi,
            ..lpc1754_cosim::bench::Program::release(&image)
        };
        let run = lpc1754_cosim::bench::dc_run_traffic(
            &program,
            us * 1000,
            plan.sweep_cycles(us * 1000),
            false,
            None,
            &lpc1754_cosim::traffic::Traffic::REAL_MASTER,
        )?;
        println!("{us} us: {} ({:?})", run.check.verdict(), run.check);
        print!("{}", run.after.summary());
        return Ok(());
    }
    let elf = image_path().display().to_string();
    let also_ns = also_cycle_us.map(|us| us * 1000);
    let figures = lpc1754_cosim::bench::measure(&image, &elf, quick, also_ns, &mut |line| {
        eprintln!("[image bench] {line}")
    })?;
    match json {
        Some(path) => {
            let text = serde_json::to_string_pretty(&figures).map_err(|e| e.to_string())?;
            std::fs::write(path, text)
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        }
        None => print!("{}", lpc1754_cosim::bench::summary(&figures)),
    }
    Ok(())
}

fn boards(quick: bool, lpc_figures: Option<&std::path::Path>) -> Result<(), String> {
    use firmware::platform::board::Mcu;
    use firmware::products::{default, PRODUCTS};
    use lpc1754_cosim::boards::{measure, table, BoardFigures};
    let stm32 = PRODUCTS
        .iter()
        .find(|p| p.board.mcu() == Mcu::Stm32f103vc)
        .ok_or("no STM32F103 product")?;
    let mut progress = |line: &str| eprintln!("[boards] {line}");
    const LPC: &str = "LPC1754, ET1100 on SPI";
    let lpc = match lpc_figures {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            let f: virtual_board::tools::image_figures::ImageFigures = serde_json::from_str(&text)
                .map_err(|e| format!("{}: not `bench --json`'s figures: {e}", path.display()))?;
            BoardFigures {
                board: LPC.into(),
                product: default().name.into(),
                cclk_hz: f.cclk_hz,
                sweep: f.sweep,
            }
        }
        None => measure(
            LPC,
            default().name,
            &load_image()?,
            quick,
            false,
            &mut progress,
        ),
    };
    let image = load_image_of(stm32.name)?;
    let mut rows = vec![lpc];
    for (board, clash) in [
        ("STM32F103VC, ET1100 on FSMC, BUSY 80 ns", false),
        (
            "STM32F103VC, ET1100 on FSMC, BUSY 260 ns (every access clashing)",
            true,
        ),
    ] {
        rows.push(measure(
            board,
            stm32.name,
            &image,
            quick,
            clash,
            &mut progress,
        ));
    }
    print!("{}", table(&rows));
    Ok(())
}

fn peer_bench(
    quick: bool,
    json: Option<&std::path::Path>,
    conformance: bool,
) -> Result<(), String> {
    use lpc1754_cosim::peer;
    let ours = load_image()?;
    let soes = peer::soes::load()?;
    if conformance {
        let rows = peer::conformance_rows(&ours, &soes)?;
        print!(
            "{}",
            virtual_board::tools::peer_figures::conformance_table(&rows, "SOES")
        );
        return Ok(());
    }
    let figures = peer::measure(
        &ours,
        &image_path().display().to_string(),
        &soes,
        &peer::soes::image_path().display().to_string(),
        quick,
        &mut |line| eprintln!("[peer bench] {line}"),
    )?;
    let text = serde_json::to_string_pretty(&figures).map_err(|e| e.to_string())?;
    match json {
        Some(path) => std::fs::write(path, text)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?,
        None => println!("{text}"),
    }
    Ok(())
}

/// `sim --oversampling N`: the 1 kHz loop-back with N updates per cycle and every
/// conversion in, at `--cycle-us`, for `--seconds` (default 0.3) of virtual time.
fn sim_oversampling(args: &SimArgs, updates: u16) -> Result<(), String> {
    use lpc1754_cosim::oversampling::{figures_without_sequence, loopback, UPDATES_PER_PDO};
    if args.iface.is_some() || args.can_port.is_some() || args.pcap.is_some() {
        return Err(
            "--oversampling runs the in-process master only (no --iface, --can-port or --pcap)"
                .into(),
        );
    }
    let per_pdo = UPDATES_PER_PDO as u16;
    if updates == 0 || !updates.is_multiple_of(per_pdo) {
        return Err(format!(
            "--oversampling {updates}: the update PDOs carry {per_pdo} updates each, so N is a \
             multiple of {per_pdo} (5..=50)"
        ));
    }
    let cycle_ns = u64::from(args.cycle_us) * 1_000;
    let sample_pdos = loopback::sample_pdos_for(cycle_ns);
    let seconds = args.seconds.unwrap_or(0.3);
    let cycles = (seconds * 1e9 / cycle_ns as f64).ceil() as u64;
    println!(
        "loop-back with oversampling on the image: {} us cycle, {sample_pdos} sample PDOs, \
         {updates} updates/cycle, {cycles} cycles; a {:.0} Hz sine on AI1 (ignores --freq, \
         --amplitude, --offset, --ai, --ao)",
        args.cycle_us,
        loopback::SINE_HZ
    );
    let image = load_image()?;
    let update_pdos = u8::try_from(updates / per_pdo).map_err(|e| e.to_string())?;
    let l = loopback::run(&image, cycle_ns, sample_pdos, update_pdos, cycles)?;
    println!("{}", l.line());
    println!("{}", figures_without_sequence(&l.run));
    print!("{}", l.run.after.summary());
    if l.run.after.fault.is_some() || !l.run.after.reports.is_empty() {
        return Err("the image faulted or a model reported a problem (see above)".into());
    }
    Ok(())
}

fn sim(args: &SimArgs, log: bool) -> Result<(), String> {
    if let Some(updates) = args.oversampling {
        return sim_oversampling(args, updates);
    }
    let handle: std::cell::RefCell<Option<CosimHandle>> = std::cell::RefCell::new(None);
    cli::run(
        args,
        |echo| {
            if echo {
                return Err(
                    "--echo runs the test responder, not the image: use `cargo xtask sim --echo`"
                        .into(),
                );
            }
            if args.node_id != sim::DEFAULT_NODE_ID {
                return Err(format!(
                    "the image's CANopen node-ID is {} (firmware::products::analog_io::can): --node-id \
                     applies to the host-compiled application",
                    sim::DEFAULT_NODE_ID
                ));
            }
            let image = load_image_of(args.product()?.name)?;
            let options = Options {
                echo_log: log,
                ..Default::default()
            };
            let (target, h) = image_target(image, options)?;
            *handle.borrow_mut() = Some(h);
            Ok(Some(target))
        },
        &mut || {
            if let Some(facts) = handle.borrow().as_ref().and_then(|h| h.with(|c| c.facts())) {
                print!("{}", facts.summary());
            }
        },
    )?;
    let h = handle.borrow();
    let facts = h.as_ref().and_then(|h| h.with(|c| c.facts()));
    match facts {
        Some(f) if f.fault.is_some() || !f.reports.is_empty() => {
            Err("the image faulted or a model reported a problem (see above)".into())
        }
        _ => Ok(()),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Sim { args, log } => sim(&args, log),
        Command::Oversampling {
            cycles,
            loopback_json,
        } => oversampling(cycles, loopback_json.as_deref()),
        Command::Bench {
            quick,
            json,
            cycle_us,
            also_cycle_us,
            cpi,
        } => bench(quick, json.as_deref(), cycle_us, also_cycle_us, cpi),
        Command::Boards { quick, lpc_figures } => boards(quick, lpc_figures.as_deref()),
        Command::PeerBench {
            quick,
            json,
            conformance,
        } => peer_bench(quick, json.as_deref(), conformance),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
