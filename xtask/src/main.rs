//! Project automation: `cargo xtask <command>` (alias in `.cargo/config.toml`).
//!
//! Each command lives in its own module; `main` only parses arguments and dispatches.

mod bench;
mod build;
mod docs;
mod esi;
mod flash;
mod fuzz;
mod image;
mod mcu;
mod peer;
mod setup;
mod sim;
mod size;
mod target_desc;
mod test;
mod util;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "cargo xtask",
    about = "Build, test, flash and simulate the EtherCAT analog I/O module"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Everything CI checks: rustfmt, clippy, host tests, cross-builds.
    Test(test::Args),
    /// Install what the project needs on this machine (idempotent).
    Setup,
    /// Build the manual (docs/, an mdBook) into target/book, with the tables generated from
    /// the code; fails on a broken link or anchor and on a `cargo xtask` command it shows
    /// that does not exist.
    Docs,
    /// Run the virtual board with a real EtherCAT master (in process, or on a network
    /// interface with --iface): ESM walk, SDO identity, AI -> AO loop-back figures.
    Sim(sim::Args),
    /// Release image for the LPC1754: ELF + BIN with the vector checksum, CRP check, budget.
    Build(build::Args),
    /// Device description files from the firmware's description: the ESI XML, validated
    /// against the ETG.2000 schema (../shared/vectors/esi-schema) when it and xmllint exist.
    Esi(esi::Args),
    /// Flash/RAM figures of the release image, per crate and per symbol.
    Size(size::Args),
    /// Performance figures against the targets (PDI bytes, Cortex-M3 instructions under
    /// QEMU, cycle time, footprint, ADC, thesis loop-back) as one table.
    Bench(bench::Args),
    /// Flash and verify the release image on an LPC1754 (probe-rs with our own flash
    /// algorithm, or OpenOCD); refuses CRP lock values; --dry-run prints the commands.
    Flash(flash::Args),
    /// Flash with probe-rs and show the firmware's defmt log over RTT.
    Run(flash::RunArgs),
    /// Build a peer stack for the same board (`soes`: SOES from ../shared/peers/soes with
    /// the port in tests/soes) into an ELF the co-simulator runs.
    Peer(peer::Args),
    /// Run the cargo-fuzz targets of tests/fuzz (seeded from the real-world captures) for a
    /// while each; fails on a crash.
    Fuzz(fuzz::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Test(args) => test::run(&args),
        Command::Setup => setup::all(),
        Command::Docs => docs::run(),
        Command::Sim(args) => sim::run(&args),
        Command::Build(args) => build::run(&args),
        Command::Size(args) => size::run(&args),
        Command::Esi(args) => esi::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Flash(args) => flash::run(&args),
        Command::Run(args) => flash::run_and_monitor(&args),
        Command::Fuzz(args) => fuzz::run(&args),
        Command::Peer(args) => peer::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
