//! `cargo xtask build`: the release images for the LPC1754.
//!
//! Builds the two programs of `firmware` for thumbv7m-none-eabi (installing flip-link first
//! if needed): the application (bin `analog-io`, linked at 0x3100 in the application slot,
//! profile `release`) and the bootloader (bin `bootloader`, the first 12 KB, profile
//! `bootloader`). Then, under `target/thumbv7m-none-eabi/` (or `$CARGO_TARGET_DIR`):
//!
//! - `bootloader/bootloader.bin`: the vector checksum patched in (also into the ELF), read
//!   back from disk and verified (checksum rule, vectors, CRP word);
//!
//! and next to the application's ELF (`release/`):
//!
//! - `analog-io.bin`: the application image from 0x3100, its vectors checked;
//! - `analog-io.efw`: the update file, the header block (`firmware::platform::boot::header`: identity,
//!   hardware revision, version, length, CRC-32) and the application image;
//! - `flash-image.bin`: what `cargo xtask flash` writes from address 0 (bootloader, update
//!   file in the slot, the staging area's header erased).
//!
//! It prints the paths, the update file's version and CRC, and both programs' flash and RAM
//! against their budgets, and fails when either is over.

use crate::image::{self, Budget, Crp, Usage, BOOT_BUDGET, BUDGET};
use crate::setup;
use crate::util::{cargo, exec, root, Result};
use firmware::platform::boot::header::HeaderRepr;
use firmware::platform::boot::layout::APP_VECTORS;
use firmware::products::analog_io::identity::{NAMES, UPDATE_TARGET};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The firmware's target triple.
pub const TARGET: &str = "thumbv7m-none-eabi";
/// The application binary's name.
pub const BIN: &str = "analog-io";
/// The bootloader binary's name.
pub const BOOT_BIN: &str = "bootloader";
/// The cargo profile the bootloader is built with (the workspace's Cargo.toml says why).
pub const BOOT_PROFILE: &str = "bootloader";

#[derive(clap::Args, Debug, Clone, Default)]
pub struct Args {
    /// Accept a CRP word that enables Code Read Protection (CRP1/2/3, NO_ISP).
    /// CRP3 locks SWD and ISP out FOR EVER.
    #[arg(long)]
    pub allow_crp: bool,
}

/// One linked program.
#[derive(Debug, Clone)]
pub struct Program {
    /// The ELF.
    pub elf: PathBuf,
    /// Its flash image from its first address.
    pub bin: PathBuf,
    /// Memory use.
    pub usage: Usage,
}

/// What a build produced.
#[derive(Debug, Clone)]
pub struct Output {
    /// The application's ELF.
    pub elf: PathBuf,
    /// The application's image (from 0x3100).
    pub bin: PathBuf,
    /// The application's memory use.
    pub usage: Usage,
    /// The bootloader.
    pub boot: Program,
    /// The CRP level of the flash image (the bootloader's word at 0x2FC).
    pub crp: Crp,
    /// The update file.
    pub efw: PathBuf,
    /// Its header.
    pub header: HeaderRepr,
    /// The whole flash content for a probe, from address 0.
    pub image: PathBuf,
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

/// Where the ELF of the bootloader lands (its profile's directory beside `release`).
pub fn boot_elf_path() -> PathBuf {
    target_dir().join(TARGET).join(BOOT_PROFILE).join(BOOT_BIN)
}

pub fn run(args: &Args) -> Result {
    let out = build(args)?;
    print_report(&out);
    Ok(())
}

/// The paths, the update file and both programs against their budgets.
pub fn print_report(out: &Output) {
    println!("application:");
    print_usage(&out.usage, &BUDGET);
    println!("bootloader:");
    print_usage(&out.boot.usage, &BOOT_BUDGET);
    println!("ELF:        {}", out.elf.display());
    println!("ELF:        {}", out.boot.elf.display());
    println!(
        "BIN:        {} (the application alone, from {APP_VECTORS:#x})",
        out.bin.display()
    );
    println!(
        "BIN:        {} (the bootloader, from 0)",
        out.boot.bin.display()
    );
    println!(
        "update:     {} (version {}, image {} B, CRC-32 {:#010x}, for vendor {:#x} product {:#x} hardware revision {})",
        out.efw.display(),
        out.header.version_str().unwrap_or("?"),
        out.header.image_len,
        out.header.image_crc,
        out.header.vendor_id,
        out.header.product_code,
        out.header.hardware_revision
    );
    println!(
        "flash:      {} (bootloader + application, what `cargo xtask flash` writes)",
        out.image.display()
    );
    println!("CRP:        {}", out.crp);
}

/// Builds, converts, verifies; no printing of the report.
pub fn build(args: &Args) -> Result<Output> {
    let out = build_unchecked(args)?;
    check_budget(&out)?;
    Ok(out)
}

/// The budget verdict of both programs, printing the figures when over budget.
pub fn check_budget(out: &Output) -> Result {
    for (name, usage, budget) in [
        ("application", &out.usage, &BUDGET),
        ("bootloader", &out.boot.usage, &BOOT_BUDGET),
    ] {
        if let Err(e) = image::check_budget(usage, budget) {
            print_usage(usage, budget);
            return Err(format!("{name}: {e}"));
        }
    }
    Ok(())
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
    exec(release_log(
        profile
            .cargo()
            .args(["build", "--release", "-p", "firmware", "--bin", BIN])
            .args(["--target", TARGET])
            .args(profile.config_args()),
    ))?;
    Ok(profile.release_dir().join(BIN))
}

/// The release images log nothing (`DEFMT_LOG=off`: the defmt frames and their strings
/// cost about 0.8 KB of flash, the RTT transport another 0.7 KB and 1 KB of RAM, so the
/// firmware's default `rtt` feature is left out); a `DEFMT_LOG` of the caller's (e.g.
/// `error` or `info`, for an image read through a probe) is kept, with the transport.
fn release_log(cmd: &mut Command) -> &mut Command {
    if std::env::var_os("DEFMT_LOG").is_none() {
        cmd.env("DEFMT_LOG", "off").arg("--no-default-features");
    }
    cmd
}

/// Builds the bootloader with its own profile.
fn build_bootloader() -> Result {
    setup::targets()?;
    setup::flip_link()?;
    exec(release_log(cargo().args([
        "build",
        "--profile",
        BOOT_PROFILE,
        "-p",
        "firmware",
        "--bin",
        BOOT_BIN,
        "--target",
        TARGET,
    ])))
}

/// Like [`build`] but without the budget verdict (for `size`, which reports first).
pub fn build_unchecked(args: &Args) -> Result<Output> {
    let app = link(&Profile::default())?;
    build_bootloader()?;
    finish_unchecked(&app, args.allow_crp)
}

/// The post-link steps with `app_elf` as the application (the cargo runner passes one): the
/// bootloader is built, everything else as [`build`].
pub fn finish(app_elf: &Path, allow_crp: bool) -> Result<Output> {
    build_bootloader()?;
    let out = finish_unchecked(app_elf, allow_crp)?;
    check_budget(&out)?;
    Ok(out)
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

fn write(path: &Path, data: &[u8]) -> Result {
    std::fs::write(path, data).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// A program's sections, image from `base` and usage; the checksum patched first when
/// `checksum` (the bootloader, whose vectors the boot ROM checks).
fn program(elf: &Path, base: u64, checksum: bool) -> Result<(Program, Vec<u8>)> {
    let mut data = read(elf)?;
    let sections = image::sections(&data).map_err(|e| e.to_string())?;
    if checksum
        && image::patch_elf_checksum(&mut data, &sections)
            .map_err(|e| e.to_string())?
            .is_some()
    {
        write(elf, &data)?;
    }
    let mut bin = image::elf_to_bin(&data, &sections, base).map_err(|e| e.to_string())?;
    if checksum {
        image::patch_checksum(&mut bin).map_err(|e| e.to_string())?;
    }
    let bin_path = elf.with_extension("bin");
    write(&bin_path, &bin)?;
    let program = Program {
        elf: elf.to_path_buf(),
        bin: bin_path,
        usage: image::usage(&sections, base),
    };
    Ok((program, bin))
}

/// [`finish`] without the bootloader build and the budget verdict.
fn finish_unchecked(app_elf: &Path, allow_crp: bool) -> Result<Output> {
    let (boot, _) = program(&boot_elf_path(), image::FLASH.start, true)?;
    let (app, app_bin) = program(app_elf, u64::from(APP_VECTORS), false)?;

    // Verify what is on disk, not what is in memory.
    let boot_bin = read(&boot.bin)?;
    let crp = image::verify_bin(&boot_bin, allow_crp).map_err(|e| format!("bootloader: {e}"))?;
    if crp.protects() {
        eprintln!();
        eprintln!("!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!");
        eprintln!("!! WARNING: the image enables Code Read Protection: {crp}");
        eprintln!("!! Flashing it restricts or removes debug/ISP access (--allow-crp given).");
        eprintln!("!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!");
        eprintln!();
    }
    let (efw, header) = image::update_file(&app_bin, &UPDATE_TARGET, NAMES.software_version)
        .map_err(|e| format!("application: {e}"))?;
    let efw_path = app_elf.with_extension("efw");
    write(&efw_path, &efw)?;
    let flash = image::flash_image(&boot_bin, &read(&efw_path)?).map_err(|e| e.to_string())?;
    let image_path = app_elf.with_file_name("flash-image.bin");
    write(&image_path, &flash)?;
    eprintln!(
        "bootloader: {} bytes, vector checksum verified (words 0..7 sum to 0), CRP {crp}",
        boot_bin.len()
    );
    Ok(Output {
        elf: app.elf,
        bin: app.bin,
        usage: app.usage,
        boot,
        crp,
        efw: efw_path,
        header,
        image: image_path,
    })
}

fn pct(used: u64, of: u64) -> f64 {
    100.0 * used as f64 / of as f64
}

/// The flash/RAM figures of a program against its budget.
pub fn print_usage(u: &Usage, budget: &Budget) {
    println!(
        "  flash:      {:>6} B of {:>6} B budget ({:5.1} %)  [.vector_table to the end of .data, gaps included]",
        u.flash,
        budget.flash,
        pct(u.flash, budget.flash)
    );
    println!(
        "  static RAM: {:>6} B of {:>6} B budget ({:5.1} %)  [.data + .bss + .uninit; stack excluded]",
        u.ram,
        budget.ram,
        pct(u.ram, budget.ram)
    );
    println!(
        "  stack:      up to {} B (the rest of the local SRAM below the statics, flip-link; top 40 B reserved for IAP and the boot request)",
        image::RAM.len - 40 - u.ram
    );
    if u.ahbsram > 0 {
        println!(
            "  AHB SRAM:   {:>6} B of {:>6} B (.ahbsram buffers, outside the static RAM budget)",
            u.ahbsram,
            image::AHBSRAM.len
        );
    }
}
