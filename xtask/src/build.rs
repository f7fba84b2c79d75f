//! `cargo xtask build [--product NAME]`: the release images of the products
//! (`firmware::products`), every product or the one named.
//!
//! Each product's image is the firmware's application binary built with the product's cargo
//! feature and its release settings (`firmware::products::ImageBuild`: opt-level, machine
//! outliner), and the bootloader of the product's board, built with the same feature
//! (installing flip-link first if needed). Then, under `target/thumbv7m-none-eabi/` (or
//! `$CARGO_TARGET_DIR`), named after the product:
//!
//! - `bootloader/NAME` and `bootloader/NAME.bin`: the bootloader of the product's board, the
//!   vector checksum patched in (also into the ELF), read back from disk and verified
//!   (checksum rule, vectors, CRP word);
//! - `release/NAME` (the ELF) and `release/NAME.bin`: the application image from 0x3100, its
//!   vectors checked;
//! - `release/NAME.efw`: the update file, the header block
//!   (`firmware::platform::boot::header`: identity, board, the board options it needs,
//!   version, length, CRC-32) and the application image;
//! - `release/NAME-flash-image.bin`: what `cargo xtask flash --product NAME` writes from
//!   address 0 (bootloader, update file in the slot, the staging area's header erased).
//!
//! A product whose board has no bootloader (`analog-io-stm32`: its MCU's own binary,
//! `crate::mcu`) has only `release/NAME`, `release/NAME.bin` (from the start of its flash)
//! and `release/NAME-flash-image.bin` (the same bytes): no update file.
//!
//! It prints the paths, the update file's version and CRC, each product's flash and RAM
//! against its budget and the bootloader's against its region, and fails when one is over.

use crate::image::{self, Budget, Crp, Usage, BOOT_BUDGET};
use crate::util::{cargo, exec, root, Result};
use crate::{mcu, setup};
use firmware::platform::boot::header::HeaderRepr;
use firmware::platform::boot::layout::APP_VECTORS;
use firmware::products::{Product, PRODUCTS};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The firmware's target triple.
pub const TARGET: &str = "thumbv7m-none-eabi";
/// The application binary (the image of the product whose feature is on).
pub const BIN: &str = "application";
/// The bootloader binary's name.
pub const BOOT_BIN: &str = "bootloader";
/// The cargo profile the bootloader is built with (the workspace's Cargo.toml says why).
pub const BOOT_PROFILE: &str = "bootloader";
/// The environment variable that gives the target's rustflags, per product (cargo joins it
/// with `.cargo/config.toml`'s, which therefore sets none).
const RUSTFLAGS_ENV: &str = "CARGO_TARGET_THUMBV7M_NONE_EABI_RUSTFLAGS";
/// The machine outliner on every function (not only the "z" ones).
const OUTLINER: &str = "-C llvm-args=-enable-machine-outliner=always";

#[derive(clap::Args, Debug, Clone, Default)]
pub struct Args {
    /// Accept a CRP word that enables Code Read Protection (CRP1/2/3, NO_ISP).
    /// CRP3 locks SWD and ISP out FOR EVER.
    #[arg(long)]
    pub allow_crp: bool,
    /// Only this product (default: `build` all, the other commands the default product).
    #[arg(long, value_name = "NAME")]
    pub product: Option<String>,
}

impl Args {
    /// `product` with the other options default.
    pub fn of(product: &'static Product) -> Self {
        Self {
            allow_crp: false,
            product: Some(product.name.into()),
        }
    }

    /// The product named, else the default one.
    pub fn product(&self) -> Result<&'static Product> {
        match &self.product {
            Some(name) => product(name),
            None => Ok(firmware::products::default()),
        }
    }
}

/// The product called `name`, or an error that lists them.
pub fn product(name: &str) -> Result<&'static Product> {
    firmware::products::find(name).ok_or_else(|| {
        format!(
            "no product {name:?}: the products are {}",
            firmware::products::NAMES.join(", ")
        )
    })
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

/// What a build of one product produced.
#[derive(Debug, Clone)]
pub struct Output {
    /// The product.
    pub product: &'static Product,
    /// The application's ELF.
    pub elf: PathBuf,
    /// The application's image (from 0x3100).
    pub bin: PathBuf,
    /// The application's memory use.
    pub usage: Usage,
    /// The bootloader and the update file (boards with a bootloader).
    pub boot: Option<BootParts>,
    /// The whole flash content for a probe, from the flash's first address.
    pub image: PathBuf,
}

/// The bootloader of a product's board and the product's update file.
#[derive(Debug, Clone)]
pub struct BootParts {
    /// The bootloader.
    pub program: Program,
    /// The CRP level of the flash image (the bootloader's word at 0x2FC).
    pub crp: Crp,
    /// The update file.
    pub efw: PathBuf,
    /// Its header.
    pub header: HeaderRepr,
}

impl Output {
    /// The application's budget (the product's).
    pub fn budget(&self) -> Budget {
        budget_of(self.product)
    }

    /// Whether the flash image locks the part (CRP; only LPC1754 bootloaders carry a word).
    pub fn crp_protects(&self) -> bool {
        self.boot.as_ref().is_some_and(|b| b.crp.protects())
    }
}

/// A product's application budget.
pub fn budget_of(product: &Product) -> Budget {
    Budget {
        flash: u64::from(product.budget.flash),
        ram: u64::from(product.budget.ram),
    }
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

/// Where the bootloader of `product`'s board lands (its profile's directory beside
/// `release`, named after the product).
pub fn boot_elf_path(product: &Product) -> PathBuf {
    target_dir()
        .join(TARGET)
        .join(BOOT_PROFILE)
        .join(product.name)
}

/// `cargo xtask build`: every product (or the one named), then the report and the budgets.
pub fn run(args: &Args) -> Result {
    let products: Vec<&'static Product> = match &args.product {
        Some(name) => vec![product(name)?],
        None => PRODUCTS.to_vec(),
    };
    let mut outs = Vec::new();
    for p in products {
        outs.push(build_unchecked(&Args {
            product: Some(p.name.into()),
            ..args.clone()
        })?);
    }
    for out in &outs {
        print_report(out);
    }
    print_budgets(&outs);
    outs.iter().try_for_each(check_budget)
}

/// Each product's flash and RAM against its budget, one line each.
pub fn print_budgets(outs: &[Output]) {
    println!("budgets:");
    for out in outs {
        let (u, b) = (&out.usage, out.budget());
        let boot = match &out.boot {
            Some(boot) => format!(
                "bootloader {:>5} B of {:>5} B",
                boot.program.usage.flash, BOOT_BUDGET.flash
            ),
            None => "no bootloader".into(),
        };
        println!(
            "  {:<15} flash {:>6} B of {:>6} B ({:5.1} %, {:>5} B free)   static RAM {:>5} B of {:>5} B ({:5.1} %)   {boot}",
            out.product.name,
            u.flash,
            b.flash,
            pct(u.flash, b.flash),
            b.flash.saturating_sub(u.flash),
            u.ram,
            b.ram,
            pct(u.ram, b.ram),
        );
    }
}

/// The paths, the update file and both programs against their budgets.
pub fn print_report(out: &Output) {
    println!("{} ({}):", out.product.name, out.product.summary);
    println!("application:");
    print_usage(&out.usage, &out.budget(), out.product);
    let Some(boot) = &out.boot else {
        println!("ELF:        {}", out.elf.display());
        println!(
            "BIN:        {} (the whole image, from {:#x}; no bootloader, no update file)",
            out.bin.display(),
            mcu::of(out.product.board.mcu()).map.flash.start
        );
        println!(
            "flash:      {} (what `cargo xtask flash --product {}` writes)",
            out.image.display(),
            out.product.name
        );
        return;
    };
    println!("bootloader ({}):", out.product.board.name);
    print_usage(&boot.program.usage, &BOOT_BUDGET, out.product);
    println!("ELF:        {}", out.elf.display());
    println!("ELF:        {}", boot.program.elf.display());
    println!(
        "BIN:        {} (the application alone, from {APP_VECTORS:#x})",
        out.bin.display()
    );
    println!(
        "BIN:        {} (the bootloader, from 0)",
        boot.program.bin.display()
    );
    let header = &boot.header;
    println!(
        "update:     {} (version {}, image {} B, CRC-32 {:#010x}, vendor {:#x} product {:#x}, board {:#x} rev {} needing {:#x})",
        boot.efw.display(),
        header.version_str().unwrap_or("?"),
        header.image_len,
        header.image_crc,
        header.vendor_id,
        header.product_code,
        header.board,
        header.hardware_revision,
        header.needs.0,
    );
    println!(
        "flash:      {} (bootloader + application, what `cargo xtask flash --product {}` writes)",
        out.image.display(),
        out.product.name
    );
    println!("CRP:        {}", boot.crp);
}

/// Builds, converts, verifies one product (`args.product`, else the default); no printing
/// of the report.
pub fn build(args: &Args) -> Result<Output> {
    let out = build_unchecked(args)?;
    check_budget(&out)?;
    Ok(out)
}

/// The budget verdict of both programs of a product, printing the figures when over.
pub fn check_budget(out: &Output) -> Result {
    let mut programs = vec![("application", &out.usage, out.budget())];
    if let Some(boot) = &out.boot {
        programs.push(("bootloader", &boot.program.usage, BOOT_BUDGET));
    }
    for (name, usage, budget) in programs {
        if let Err(e) = image::check_budget(usage, &budget) {
            print_usage(usage, &budget, out.product);
            return Err(format!("{} {name}: {e}", out.product.name));
        }
    }
    Ok(())
}

/// Overrides of the release profile for one build (`cargo --config` values, the target's
/// rustflags) and the target directory they build in.
#[derive(Debug, Clone, Default)]
pub struct Profile {
    /// `--config` values, e.g. `profile.release.opt-level="s"`.
    pub config: Vec<String>,
    /// The target's rustflags (`None`: `.cargo/config.toml`'s).
    pub rustflags: Option<String>,
    /// The target directory (`None`: [`target_dir`]).
    pub target_dir: Option<PathBuf>,
}

impl Profile {
    /// The release settings of `product`'s image.
    pub fn of(product: &Product) -> Self {
        Self::with(product.build.opt_level, product.build.machine_outliner)
    }

    /// The release profile at `opt_level`, the machine outliner on or off.
    pub fn with(opt_level: &str, outliner: bool) -> Self {
        let level = match opt_level.parse::<u8>() {
            Ok(n) => n.to_string(),
            Err(_) => format!("\"{opt_level}\""),
        };
        Self {
            config: vec![format!("profile.release.opt-level={level}")],
            rustflags: Some(if outliner {
                OUTLINER.into()
            } else {
                String::new()
            }),
            target_dir: None,
        }
    }

    /// `cargo` with the overrides applied.
    pub fn cargo(&self) -> Command {
        let mut cmd = cargo();
        if let Some(dir) = &self.target_dir {
            cmd.env("CARGO_TARGET_DIR", dir);
        }
        if let Some(flags) = &self.rustflags {
            cmd.env(RUSTFLAGS_ENV, flags);
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

/// Compiles and links `product`'s application with `profile`; returns its ELF, copied to
/// the product's name beside cargo's (not yet checked).
pub fn link(product: &Product, profile: &Profile) -> Result<PathBuf> {
    setup::targets()?;
    setup::flip_link()?;
    let bin = mcu::of(product.board.mcu()).bin;
    exec(features(
        profile
            .cargo()
            .args(["build", "--release", "-p", "firmware", "--bin", bin])
            .args(["--target", TARGET])
            .args(profile.config_args()),
        product,
    ))?;
    let dir = profile.release_dir();
    copy(&dir.join(bin), &dir.join(product.name))
}

/// The product's feature alone; the images log nothing (`DEFMT_LOG=off`: the defmt frames
/// and their strings cost about 0.8 KB of flash, the RTT transport another 0.7 KB and 1 KB of
/// RAM, so the firmware's default `rtt` feature is left out); a `DEFMT_LOG` of the caller's
/// (e.g. `error` or `info`, for an image read through a probe) is kept, with the transport.
fn features<'a>(cmd: &'a mut Command, product: &Product) -> &'a mut Command {
    cmd.arg("--no-default-features");
    if std::env::var_os("DEFMT_LOG").is_none() {
        cmd.env("DEFMT_LOG", "off")
            .args(["--features", product.name])
    } else {
        cmd.args(["--features", &format!("{},rtt", product.name)])
    }
}

/// Copies `from` to `to`; returns `to`.
fn copy(from: &Path, to: &Path) -> Result<PathBuf> {
    std::fs::copy(from, to)
        .map_err(|e| format!("cannot copy {} to {}: {e}", from.display(), to.display()))?;
    Ok(to.to_path_buf())
}

/// Builds the bootloader of `product`'s board with its own profile; returns its ELF, named
/// after the product.
fn build_bootloader(product: &Product) -> Result<PathBuf> {
    setup::targets()?;
    setup::flip_link()?;
    exec(features(
        cargo().args([
            "build",
            "--profile",
            BOOT_PROFILE,
            "-p",
            "firmware",
            "--bin",
            BOOT_BIN,
            "--target",
            TARGET,
        ]),
        product,
    ))?;
    let dir = target_dir().join(TARGET).join(BOOT_PROFILE);
    copy(&dir.join(BOOT_BIN), &boot_elf_path(product))
}

/// Like [`build`] but without the budget verdict (for `size`, which reports first).
pub fn build_unchecked(args: &Args) -> Result<Output> {
    let product = args.product()?;
    let app = link(product, &Profile::of(product))?;
    if product.board.mcu().has_bootloader() {
        build_bootloader(product)?;
    }
    finish_unchecked(product, &app, args.allow_crp)
}

/// The post-link steps with `app_elf` as `product`'s application (the cargo runner passes
/// one): the bootloader is built, everything else as [`build`].
pub fn finish(product: &'static Product, app_elf: &Path, allow_crp: bool) -> Result<Output> {
    if product.board.mcu().has_bootloader() {
        build_bootloader(product)?;
    }
    let out = finish_unchecked(product, app_elf, allow_crp)?;
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

/// The image of a board without a bootloader: the application from the flash's start,
/// vectors first; the flash image is its BIN.
fn finish_alone(product: &'static Product, app_elf: &Path) -> Result<Output> {
    let map = mcu::of(product.board.mcu()).map;
    let data = read(app_elf)?;
    let sections = image::sections_in(&data, &map).map_err(|e| e.to_string())?;
    let bin = image::elf_to_bin_in(&data, &sections, map.flash.start, &map.flash)
        .map_err(|e| e.to_string())?;
    if bin.len() < 8 {
        return Err(format!(
            "{}: no vector table in {}",
            product.name,
            app_elf.display()
        ));
    }
    let bin_path = app_elf.with_extension("bin");
    write(&bin_path, &bin)?;
    let image_path = app_elf.with_file_name(format!("{}-flash-image.bin", product.name));
    write(&image_path, &bin)?;
    Ok(Output {
        product,
        elf: app_elf.to_path_buf(),
        bin: bin_path,
        usage: image::usage(&sections, map.flash.start),
        boot: None,
        image: image_path,
    })
}

/// [`finish`] without the bootloader build and the budget verdict.
fn finish_unchecked(product: &'static Product, app_elf: &Path, allow_crp: bool) -> Result<Output> {
    let Some(target) = &product.update else {
        return finish_alone(product, app_elf);
    };
    let (boot, _) = program(&boot_elf_path(product), image::FLASH.start, true)?;
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
    let version = product.device.names.software_version;
    let (efw, header) = image::update_file(&app_bin, target, version)
        .map_err(|e| format!("{} application: {e}", product.name))?;
    let efw_path = app_elf.with_extension("efw");
    write(&efw_path, &efw)?;
    let flash = image::flash_image(&boot_bin, &read(&efw_path)?).map_err(|e| e.to_string())?;
    let image_path = app_elf.with_file_name(format!("{}-flash-image.bin", product.name));
    write(&image_path, &flash)?;
    eprintln!(
        "{}: bootloader {} bytes, vector checksum verified (words 0..7 sum to 0), CRP {crp}",
        product.name,
        boot_bin.len()
    );
    Ok(Output {
        product,
        elf: app.elf,
        bin: app.bin,
        usage: app.usage,
        boot: Some(BootParts {
            program: boot,
            crp,
            efw: efw_path,
            header,
        }),
        image: image_path,
    })
}

fn pct(used: u64, of: u64) -> f64 {
    100.0 * used as f64 / of as f64
}

/// The flash/RAM figures of a program of `product` against its budget.
pub fn print_usage(u: &Usage, budget: &Budget, product: &Product) {
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
    if product.board.mcu().has_bootloader() {
        println!(
            "  stack:      up to {} B (the rest of the local SRAM below the statics, flip-link; top 40 B reserved for IAP and the boot request)",
            image::RAM.len - 40 - u.ram
        );
    } else {
        println!(
            "  stack:      up to {} B (the rest of the SRAM below the statics, flip-link)",
            mcu::of(product.board.mcu()).map.ram.len - u.ram
        );
    }
    if u.ahbsram > 0 {
        println!(
            "  AHB SRAM:   {:>6} B of {:>6} B (.ahbsram buffers, outside the static RAM budget)",
            u.ahbsram,
            image::AHBSRAM.len
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_of_products() {
        let p = Profile::with("s", true);
        assert_eq!(p.config, ["profile.release.opt-level=\"s\""]);
        assert_eq!(p.rustflags.as_deref(), Some(OUTLINER));
        let p = Profile::with("3", false);
        assert_eq!(p.config, ["profile.release.opt-level=3"]);
        assert_eq!(p.rustflags.as_deref(), Some(""));
        for product in PRODUCTS {
            assert!(
                ["s", "z", "1", "2", "3"].contains(&product.build.opt_level),
                "{}",
                product.name
            );
        }
    }

    #[test]
    fn unknown_products_are_named_in_the_error() {
        let e = product("analog-io-pro").unwrap_err();
        assert!(e.contains("analog-io, analog-io-can"), "{e}");
        assert_eq!(Args::default().product().unwrap().name, "analog-io");
    }
}
