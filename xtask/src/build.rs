//! `cargo xtask build`: the release image for the LPC1754.
//!
//! Builds `firmware` (bin `analog-io`) for thumbv7m-none-eabi (installing flip-link first if
//! needed), patches the vector checksum into the ELF, writes the BIN next to it
//! (`target/thumbv7m-none-eabi/release/analog-io.bin`, or under `$CARGO_TARGET_DIR`), reads the
//! BIN back and verifies it (checksum rule, vectors, CRP word), and fails when the image is
//! over the flash/RAM budget.

use crate::image::{self, Crp, Usage, BUDGET};
use crate::setup;
use crate::util::{cargo, exec, root, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The firmware's target triple.
pub const TARGET: &str = "thumbv7m-none-eabi";
/// The binary's name.
pub const BIN: &str = "analog-io";

#[derive(clap::Args, Debug, Clone, Default)]
pub struct Args {
    /// Accept a CRP word that enables Code Read Protection (CRP1/2/3, NO_ISP).
    /// CRP3 locks SWD and ISP out FOR EVER.
    #[arg(long)]
    pub allow_crp: bool,
}

/// What a build produced.
#[derive(Debug, Clone)]
pub struct Output {
    /// The ELF (checksum patched).
    pub elf: PathBuf,
    /// The flash image.
    pub bin: PathBuf,
    /// Memory use.
    pub usage: Usage,
    /// The CRP level of the image.
    pub crp: Crp,
}

/// The cargo target directory (honours `CARGO_TARGET_DIR`, relative to the workspace root).
pub fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) if !d.is_empty() => {
            let d = PathBuf::from(d);
            if d.is_absolute() {
                d
            } else {
                root().join(d)
            }
        }
        _ => root().join("target"),
    }
}

pub fn run(args: &Args) -> Result {
    let out = build(args)?;
    print_usage(&out.usage);
    println!("ELF: {}", out.elf.display());
    println!("BIN: {}", out.bin.display());
    println!("CRP: {}", out.crp);
    Ok(())
}

/// Builds, converts, verifies; no printing of the usage.
pub fn build(args: &Args) -> Result<Output> {
    let out = build_unchecked(args)?;
    check_budget(&out.usage)?;
    Ok(out)
}

/// The budget verdict, printing the figures when over budget.
pub fn check_budget(usage: &Usage) -> Result {
    if let Err(e) = image::check_budget(usage, &BUDGET) {
        print_usage(usage);
        return Err(e.to_string());
    }
    Ok(())
}

/// Like [`build`] but without the budget verdict (for `size`, which reports first).
pub fn build_unchecked(args: &Args) -> Result<Output> {
    let elf = link(&Profile::default())?;
    finish_unchecked(&elf, args.allow_crp)
}

/// Overrides of the release profile for one build (`cargo --config` values) and the target
/// directory they build in: a build with other settings keeps its artifacts apart from the
/// normal ones (`bench --opt-levels`).
#[derive(Debug, Clone, Default)]
pub struct Profile {
    /// `--config` values, e.g. `profile.release.opt-level="s"`.
    pub config: Vec<String>,
    /// The target directory (`None`: [`target_dir`]).
    pub target_dir: Option<PathBuf>,
}

impl Profile {
    /// `cargo` with the overrides applied.
    pub fn cargo(&self) -> Command {
        let mut cmd = cargo();
        if let Some(dir) = &self.target_dir {
            cmd.env("CARGO_TARGET_DIR", dir);
        }
        cmd
    }

    /// The `--config` arguments.
    pub fn config_args(&self) -> Vec<String> {
        self.config
            .iter()
            .flat_map(|c| ["--config".to_string(), c.clone()])
            .collect()
    }

    /// Where the release artifacts of `TARGET` land.
    pub fn release_dir(&self) -> PathBuf {
        self.target_dir
            .clone()
            .unwrap_or_else(target_dir)
            .join(TARGET)
            .join("release")
    }
}

/// Compiles and links the firmware binary with `profile`; returns the ELF (not yet patched).
pub fn link(profile: &Profile) -> Result<PathBuf> {
    setup::targets()?;
    setup::flip_link()?;
    exec(
        profile
            .cargo()
            .args(["build", "--release", "-p", "firmware", "--bin", BIN])
            .args(["--target", TARGET])
            .args(profile.config_args()),
    )?;
    Ok(profile.release_dir().join(BIN))
}

/// The post-link steps on an existing ELF: checksum into the ELF and the BIN, BIN written
/// and verified from disk, budget.
pub fn finish(elf: &Path, allow_crp: bool) -> Result<Output> {
    let out = finish_unchecked(elf, allow_crp)?;
    check_budget(&out.usage)?;
    Ok(out)
}

/// [`finish`] without the budget verdict.
fn finish_unchecked(elf: &Path, allow_crp: bool) -> Result<Output> {
    let mut data = std::fs::read(elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
    let sections = image::sections(&data).map_err(|e| e.to_string())?;
    if image::patch_elf_checksum(&mut data, &sections)
        .map_err(|e| e.to_string())?
        .is_some()
    {
        std::fs::write(elf, &data).map_err(|e| format!("cannot write {}: {e}", elf.display()))?;
    }
    let mut bin = image::elf_to_bin(&data, &sections).map_err(|e| e.to_string())?;
    let checksum = image::patch_checksum(&mut bin).map_err(|e| e.to_string())?;
    let bin_path = elf.with_extension("bin");
    std::fs::write(&bin_path, &bin)
        .map_err(|e| format!("cannot write {}: {e}", bin_path.display()))?;

    // Verify what is on disk, not what is in memory.
    let written =
        std::fs::read(&bin_path).map_err(|e| format!("cannot read {}: {e}", bin_path.display()))?;
    let crp = image::verify_bin(&written, allow_crp).map_err(|e| e.to_string())?;
    if crp.protects() {
        eprintln!();
        eprintln!("!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!");
        eprintln!("!! WARNING: the image enables Code Read Protection: {crp}");
        eprintln!("!! Flashing it restricts or removes debug/ISP access (--allow-crp given).");
        eprintln!("!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!");
        eprintln!();
    }
    eprintln!(
        "image: {} bytes, vector checksum {checksum:#010x} (words 0..7 sum to 0), CRP {crp}",
        written.len()
    );
    let usage = image::usage(&sections);
    Ok(Output {
        elf: elf.to_path_buf(),
        bin: bin_path,
        usage,
        crp,
    })
}

fn pct(used: u64, of: u64) -> f64 {
    100.0 * used as f64 / of as f64
}

/// The flash/RAM figures against the budget.
pub fn print_usage(u: &Usage) {
    println!(
        "flash:      {:>6} B of {:>6} B budget ({:5.1} %)  [.vector_table + .crp + .text + .rodata + .data]",
        u.flash,
        BUDGET.flash,
        pct(u.flash, BUDGET.flash)
    );
    println!(
        "static RAM: {:>6} B of {:>6} B budget ({:5.1} %)  [.data + .bss + .uninit; stack excluded]",
        u.ram,
        BUDGET.ram,
        pct(u.ram, BUDGET.ram)
    );
    println!(
        "stack:      up to {} B (the rest of the local SRAM below the statics, flip-link; top 32 B reserved for IAP)",
        image::RAM.len - 32 - u.ram
    );
    println!(
        "AHB SRAM:   {:>6} B of {:>6} B (.ahbsram buffers, outside the static RAM budget)",
        u.ahbsram,
        image::AHBSRAM.len
    );
    println!(
        "BIN:        {:>6} B (image end, including the 0xFF gap before the CRP word at 0x2FC)",
        u.image_end
    );
}
