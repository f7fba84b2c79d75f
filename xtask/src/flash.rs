//! `cargo xtask flash` and `cargo xtask run`: the bootloader and the application onto an
//! LPC1754 through a CMSIS-DAP, J-Link or ST-Link probe.
//!
//! Steps: build the images (`xtask build`: the bootloader with its vector checksum, CRP word
//! refused when it locks the part unless `--allow-crp-lock`; the application in its slot with
//! the update header; both in one flash image from address 0, which also erases the header
//! of the staging area so no older staged update is installed over the new application),
//! build our flash algorithm (`xtask/flash-algo`, for
//! thumbv7m-none-eabi, linked by rust-lld at its RAM address) and turn it into the probe-rs
//! target description `target/probe-rs/LPC1754.yaml` (checked with probe-rs' own structs),
//! then flash and verify with the `probe-rs` CLI (installed with cargo if missing) or with
//! OpenOCD (Debian package; its `lpc2000` driver also drives the IAP ROM). With `--dry-run`
//! everything but the probe runs and the exact commands are printed.

use crate::build::{self, TARGET};
use crate::target_desc::{self, CHIP};
use crate::util::{cargo, exec, have, root, Result};
use crate::{mcu, setup};
use flash_algo::ErrorCode;
use std::fmt;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The probe-rs CLI release the target description is written for (probe-rs-target in
/// xtask/Cargo.toml has the same version).
pub const PROBE_RS_VERSION: &str = "0.32.0";
/// The flash algorithm's package and binary.
const ALGO_PACKAGE: &str = "flash-algo";
const ALGO_BIN: &str = "lpc1754-flash-algo";
/// What to say when no probe answers.
const NO_PROBE: &str = "no debug probe found: connect a CMSIS-DAP, J-Link or ST-Link probe to \
     the board's SWD header (SWDIO, SWCLK, GND, VTref) and power the board; nothing was written";

/// Which tool talks to the probe.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    /// probe-rs with our target description and flash algorithm (default).
    #[default]
    ProbeRs,
    /// OpenOCD with its lpc17xx target and lpc2000 flash driver.
    Openocd,
}

/// A probe given as `VID:PID[:SERIAL]` (hexadecimal VID and PID, as `probe-rs list` shows).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProbeSelector {
    pub vid: u16,
    pub pid: u16,
    pub serial: Option<String>,
}

impl fmt::Display for ProbeSelector {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04x}:{:04x}", self.vid, self.pid)?;
        if let Some(s) = &self.serial {
            write!(f, ":{s}")?;
        }
        Ok(())
    }
}

/// Parses `--probe`.
pub fn parse_probe(s: &str) -> std::result::Result<ProbeSelector, String> {
    let bad = || {
        format!(
            "--probe expects VID:PID or VID:PID:SERIAL with a 4-digit hexadecimal VID and PID \
             (see `probe-rs list`), e.g. 0d28:0204 or 1366:0101:000801234567; got `{s}`"
        )
    };
    let mut parts = s.splitn(3, ':');
    let hex = |p: Option<&str>| {
        p.filter(|p| !p.is_empty() && p.len() <= 4)
            .and_then(|p| u16::from_str_radix(p, 16).ok())
    };
    let vid = hex(parts.next()).ok_or_else(bad)?;
    let pid = hex(parts.next()).ok_or_else(bad)?;
    let serial = match parts.next() {
        Some("") => return Err(bad()),
        Some(s) => Some(s.to_string()),
        None => None,
    };
    Ok(ProbeSelector { vid, pid, serial })
}

/// Parses a flash algorithm code (decimal or 0x-hexadecimal).
fn parse_code(s: &str) -> std::result::Result<u32, String> {
    let parsed = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u32::from_str_radix(h, 16),
        None => s.parse(),
    };
    parsed.map_err(|_| format!("--explain expects a number like 13321 or 0x3409; got `{s}`"))
}

#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// The probe to use, as VID:PID[:SERIAL] (hexadecimal, see `probe-rs list`). With
    /// --backend openocd only the SERIAL is used (`adapter serial`).
    #[arg(long, value_name = "SELECTOR", value_parser = parse_probe)]
    pub probe: Option<ProbeSelector>,
    /// The tool that drives the probe.
    #[arg(long, value_enum, default_value_t = Backend::ProbeRs)]
    pub backend: Backend,
    /// OpenOCD interface script (--backend openocd): interface/cmsis-dap.cfg,
    /// interface/jlink.cfg, interface/stlink.cfg, ...
    #[arg(long, value_name = "CFG", default_value = "interface/cmsis-dap.cfg")]
    pub openocd_interface: String,
    /// Erase the whole flash first instead of only the sectors the image touches (probe-rs).
    #[arg(long)]
    pub chip_erase: bool,
    /// Flash an image whose CRP word at 0x2FC locks the part (CRP1/CRP2/CRP3/NO_ISP).
    /// CRP3 disables SWD and ISP FOR EVER.
    #[arg(long)]
    pub allow_crp_lock: bool,
    /// Build, check and generate everything, print the exact commands, touch no probe.
    #[arg(long)]
    pub dry_run: bool,
    /// Explain a code the flash algorithm returned ("... failed with code N") and exit.
    #[arg(long, value_name = "CODE", value_parser = parse_code)]
    pub explain: Option<u32>,
    /// The product to flash (its bootloader and application; default: the default product).
    #[arg(long, value_name = "NAME")]
    pub product: Option<String>,
}

impl Args {
    /// `cargo xtask flash --dry-run` (the CI step).
    pub fn dry_run() -> Self {
        Self {
            probe: None,
            backend: Backend::ProbeRs,
            openocd_interface: "interface/cmsis-dap.cfg".into(),
            chip_erase: false,
            allow_crp_lock: false,
            dry_run: true,
            explain: None,
            product: None,
        }
    }
}

#[derive(clap::Args, Debug, Clone)]
pub struct RunArgs {
    /// The probe to use, as VID:PID[:SERIAL] (hexadecimal, see `probe-rs list`).
    #[arg(long, value_name = "SELECTOR", value_parser = parse_probe)]
    pub probe: Option<ProbeSelector>,
    /// Flash this ELF instead of building the release image (the cargo runner passes it);
    /// its vector checksum is patched and its CRP word checked all the same.
    #[arg(long, value_name = "PATH")]
    pub elf: Option<PathBuf>,
    /// Accept a CRP word that locks the part (see `cargo xtask flash --help`).
    #[arg(long)]
    pub allow_crp_lock: bool,
    /// Build, check and generate everything, print the exact command, touch no probe.
    #[arg(long)]
    pub dry_run: bool,
    /// The product the image is (its bootloader goes with it; with --elf, the product
    /// whose feature built it; default: the default product).
    #[arg(long, value_name = "NAME")]
    pub product: Option<String>,
}

/// What both commands prepare before touching a probe.
struct Prepared {
    image: build::Output,
    /// Our target description (the LPC1754); `None` where probe-rs knows the chip itself.
    description: Option<PathBuf>,
}

impl Prepared {
    /// The chip's tool facts.
    fn mcu(&self) -> mcu::McuTools {
        mcu::of(self.image.product.board.mcu())
    }
}

pub fn run(args: &Args) -> Result {
    if let Some(code) = args.explain {
        println!("{code:#x}: {}", ErrorCode(code));
        return Ok(());
    }
    if args.backend == Backend::Openocd && args.chip_erase {
        return Err(
            "--chip-erase works with --backend probe-rs only (OpenOCD's `program` erases the \
             sectors it writes)"
                .into(),
        );
    }
    let p = prepare(args.product.as_deref(), None, args.allow_crp_lock)?;
    match args.backend {
        Backend::ProbeRs => {
            let cmds = probe_rs_flash_commands(&p, args.probe.as_ref(), args.chip_erase);
            if args.dry_run {
                return print_dry_run(&cmds, args.probe.as_ref());
            }
            ensure_probe_rs()?;
            check_probe_attached(args.probe.as_ref())?;
            let [download, verify, reset] = cmds;
            exec_explained(download)?;
            verify_output(verify)?;
            exec_explained(reset)?;
            println!("flashed and verified {}", p.image.image.display());
            Ok(())
        }
        Backend::Openocd => {
            let cmd = openocd_command(&p, args.probe.as_ref(), &args.openocd_interface);
            if args.dry_run {
                println!("dry run: no probe touched; a real run executes:");
                println!("  {}", quoted(&cmd));
                return Ok(());
            }
            if !setup::debian(&["openocd"]) {
                return Err("OpenOCD is not installed and cannot be installed here (Debian package `openocd`)".into());
            }
            run_openocd(cmd)?;
            println!("flashed and verified {}", p.image.image.display());
            Ok(())
        }
    }
}

/// `cargo xtask run`: flash with probe-rs (the bootloader and the given or built
/// application), reset, and show the application's defmt log over RTT.
pub fn run_and_monitor(args: &RunArgs) -> Result {
    let p = prepare(
        args.product.as_deref(),
        args.elf.as_deref(),
        args.allow_crp_lock,
    )?;
    let [download, _, reset] = probe_rs_flash_commands(&p, args.probe.as_ref(), false);
    let mut attach = probe_rs("attach", &p, args.probe.as_ref());
    attach.arg(&p.image.elf);
    if args.dry_run {
        return print_dry_run(&[download, reset, attach], args.probe.as_ref());
    }
    ensure_probe_rs()?;
    check_probe_attached(args.probe.as_ref())?;
    exec_explained(download)?;
    exec_explained(reset)?;
    exec_explained(attach)
}

/// Image, algorithm and description, all checked.
fn prepare(product: Option<&str>, elf: Option<&Path>, allow_crp_lock: bool) -> Result<Prepared> {
    let args = build::Args {
        allow_crp: allow_crp_lock,
        product: product.map(String::from),
    };
    let image = match elf {
        Some(elf) => build::finish(args.product()?, elf, allow_crp_lock)?,
        None => build::build(&args)?,
    };
    // The algorithm that may write a lock value only for an image that carries one (and was
    // allowed to by xtask build); every other image gets the refusing one.
    let description = if mcu::of(image.product.board.mcu()).probe_rs_builtin {
        None
    } else {
        Some(write_description(image.crp_protects())?)
    };
    Ok(Prepared { image, description })
}

/// Builds the flash algorithm and writes the checked target description; returns its path.
pub fn write_description(allow_crp_lock: bool) -> Result<PathBuf> {
    let elf = build_algorithm(allow_crp_lock)?;
    let data = std::fs::read(&elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
    let blob = target_desc::from_elf(&data)?;
    let description = if allow_crp_lock {
        "LPC1754 flash via the IAP ROM (xtask/flash-algo, CCLK 4 MHz IRC; CRP lock values ALLOWED)"
    } else {
        "LPC1754 flash via the IAP ROM (xtask/flash-algo, CCLK 4 MHz IRC; refuses CRP lock values at 0x2FC)"
    };
    let yaml = target_desc::yaml(&blob, description)?;
    target_desc::check(&yaml).map_err(|e| format!("generated target description: {e}"))?;
    let dir = build::target_dir().join("probe-rs");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let path = dir.join(if allow_crp_lock {
        format!("{CHIP}-allow-crp-lock.yaml")
    } else {
        format!("{CHIP}.yaml")
    });
    std::fs::write(&path, yaml).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    eprintln!(
        "target description: {} (flash algorithm {} bytes at {:#x}, checked with probe-rs-target {PROBE_RS_VERSION})",
        path.display(),
        blob.instructions.len(),
        blob.load_address
    );
    Ok(path)
}

/// Builds `xtask/flash-algo` for the LPC1754; returns the ELF.
fn build_algorithm(allow_crp_lock: bool) -> Result<PathBuf> {
    setup::targets()?;
    let mut cmd = cargo();
    cmd.args([
        "build",
        "--release",
        "-p",
        ALGO_PACKAGE,
        "--bin",
        ALGO_BIN,
        "--target",
        TARGET,
    ]);
    if allow_crp_lock {
        cmd.args(["--features", "allow-crp-lock"]);
    }
    // The firmware links through flip-link (.cargo/config.toml); the algorithm has no stack
    // of its own to flip, so it links with plain rust-lld and its own algo.x.
    cmd.env("CARGO_TARGET_THUMBV7M_NONE_EABI_LINKER", "rust-lld");
    exec(&mut cmd)?;
    Ok(build::target_dir()
        .join(TARGET)
        .join("release")
        .join(ALGO_BIN))
}

/// `probe-rs <sub> [--chip-description-path D] --chip C [--probe S]`.
fn probe_rs(sub: &str, p: &Prepared, probe: Option<&ProbeSelector>) -> Command {
    let mut cmd = Command::new("probe-rs");
    cmd.current_dir(root());
    cmd.arg(sub);
    if let Some(description) = &p.description {
        cmd.arg("--chip-description-path").arg(description);
    }
    cmd.args(["--chip", p.mcu().probe_rs_chip]);
    if let Some(p) = probe {
        cmd.arg("--probe").arg(p.to_string());
    }
    cmd
}

/// Download with verify, an independent verify (the algorithm's Verify, IAP compare), reset.
fn probe_rs_flash_commands(
    p: &Prepared,
    probe: Option<&ProbeSelector>,
    chip_erase: bool,
) -> [Command; 3] {
    let base = match p.mcu().map.flash.start {
        0 => "0".to_string(),
        start => format!("{start:#x}"),
    };
    let bin_args = |cmd: &mut Command| {
        cmd.args(["--binary-format", "bin", "--base-address", &base])
            .arg(&p.image.image);
    };
    let mut download = probe_rs("download", p, probe);
    if chip_erase {
        download.arg("--chip-erase");
    }
    download.arg("--verify");
    bin_args(&mut download);
    let mut verify = probe_rs("verify", p, probe);
    bin_args(&mut verify);
    let reset = probe_rs("reset", p, probe);
    [download, verify, reset]
}

/// OpenOCD: program, verify, reset, exit.
fn openocd_command(p: &Prepared, probe: Option<&ProbeSelector>, interface: &str) -> Command {
    let mut cmd = Command::new("openocd");
    cmd.current_dir(root());
    cmd.args(["-f", interface]);
    if let Some(serial) = probe.and_then(|p| p.serial.as_deref()) {
        cmd.args(["-c", &format!("adapter serial {serial}")]);
    }
    let mcu = p.mcu();
    cmd.args(["-f", mcu.openocd_target]);
    cmd.args([
        "-c",
        &format!(
            "program {{{}}} {:#010x} verify reset exit",
            p.image.image.display(),
            mcu.map.flash.start
        ),
    ]);
    cmd
}

fn print_dry_run(cmds: &[Command], probe: Option<&ProbeSelector>) -> Result {
    println!("dry run: no probe touched; a real run executes:");
    println!("  {}", quoted(&probe_list_command()));
    match probe {
        Some(p) => println!("    (and stops unless a probe {p} is listed)"),
        None => println!("    (and stops unless a probe is listed)"),
    }
    for c in cmds {
        println!("  {}", quoted(c));
    }
    if !have("probe-rs") {
        println!(
            "  (probe-rs is not installed: a real run first runs `cargo install probe-rs-tools --version ={PROBE_RS_VERSION} --locked`)"
        );
    }
    Ok(())
}

/// The command line with shell quoting where needed, ready to paste.
pub fn quoted(cmd: &Command) -> String {
    let word = |s: &str| {
        if !s.is_empty()
            && s.chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c))
        {
            s.to_string()
        } else {
            format!("'{}'", s.replace('\'', r"'\''"))
        }
    };
    std::iter::once(cmd.get_program())
        .chain(cmd.get_args())
        .map(|a| word(&a.to_string_lossy()))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Installs the probe-rs CLI when missing (a long cargo build, once).
fn ensure_probe_rs() -> Result {
    if have("probe-rs") {
        let version = Command::new("probe-rs")
            .arg("--version")
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default();
        if !version.contains(PROBE_RS_VERSION) {
            eprintln!(
                "note: {} found; the target description is written for probe-rs {PROBE_RS_VERSION} \
                 (`cargo install probe-rs-tools --version ={PROBE_RS_VERSION} --locked`)",
                version.trim()
            );
        }
        return Ok(());
    }
    eprintln!(
        "probe-rs is missing: installing probe-rs-tools {PROBE_RS_VERSION} with cargo (once; this builds for several minutes)"
    );
    exec(Command::new("cargo").args([
        "install",
        "probe-rs-tools",
        "--version",
        &format!("={PROBE_RS_VERSION}"),
        "--locked",
    ]))
}

fn probe_list_command() -> Command {
    let mut cmd = Command::new("probe-rs");
    cmd.arg("list");
    cmd
}

/// The probes `probe-rs list` printed (`[n]: name -- vid:pid:serial (kind)` lines).
pub fn listed_probes(list_output: &str) -> Vec<String> {
    list_output
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with('[') && l.contains("]:"))
        .map(str::to_string)
        .collect()
}

/// Whether a `probe-rs list` line names the selected probe (the serial must match whole).
pub fn matches_probe(line: &str, probe: &ProbeSelector) -> bool {
    let line = line.to_ascii_lowercase();
    let id = format!("{:04x}:{:04x}", probe.vid, probe.pid);
    let Some(at) = line.find(&id) else {
        return false;
    };
    match &probe.serial {
        None => true,
        Some(serial) => {
            let rest = &line[at + id.len()..];
            let listed = rest
                .strip_prefix(':')
                .and_then(|r| r.split_whitespace().next())
                .unwrap_or("");
            listed == serial.to_ascii_lowercase()
        }
    }
}

/// Fails with a clear message unless a (the selected) probe is attached.
fn check_probe_attached(probe: Option<&ProbeSelector>) -> Result {
    let mut cmd = probe_list_command();
    eprintln!("$ {}", quoted(&cmd));
    let out = cmd
        .output()
        .map_err(|e| format!("cannot start `probe-rs list`: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let probes = listed_probes(&text);
    for p in &probes {
        eprintln!("  {p}");
    }
    if probes.is_empty() {
        return Err(NO_PROBE.into());
    }
    if let Some(sel) = probe {
        if !probes.iter().any(|l| matches_probe(l, sel)) {
            return Err(format!(
                "probe {sel} is not attached (see the list above); nothing was written"
            ));
        }
    }
    Ok(())
}

/// Runs a probe-rs command; on failure, explains flash algorithm codes.
fn exec_explained(mut cmd: Command) -> Result {
    exec(&mut cmd).map_err(|e| {
        format!(
            "{e}\nif probe-rs reported a flash algorithm code, `cargo xtask flash --explain CODE` \
             says what it means (e.g. {:#x}: {})",
            0x3409,
            ErrorCode(0x3409)
        )
    })
}

/// `probe-rs verify` prints its verdict and exits 0 either way: read the verdict.
fn verify_output(mut cmd: Command) -> Result {
    eprintln!("$ {}", quoted(&cmd));
    let out = cmd
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot start `probe-rs verify`: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    print!("{text}");
    if out.status.success() && text.contains("Verification successful") {
        Ok(())
    } else {
        Err(format!(
            "verification of the flash against the image failed ({})",
            out.status
        ))
    }
}

/// What OpenOCD prints when it finds no adapter.
pub fn openocd_found_no_probe(log: &str) -> bool {
    let log = log.to_ascii_lowercase();
    [
        "unable to find a matching cmsis-dap device",
        "no j-link device found",
        "unable to open",
        "open failed",
        "no device found",
    ]
    .iter()
    .any(|p| log.contains(p))
}

/// Runs OpenOCD, echoing its log, and turns "no adapter" into the clear message.
fn run_openocd(mut cmd: Command) -> Result {
    eprintln!("$ {}", quoted(&cmd));
    let mut child = cmd
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start openocd: {e}"))?;
    let mut log = String::new();
    if let Some(err) = child.stderr.take() {
        for line in BufReader::new(err)
            .lines()
            .map_while(std::result::Result::ok)
        {
            eprintln!("{line}");
            log.push_str(&line);
            log.push('\n');
        }
    }
    let status = child
        .wait()
        .map_err(|e| format!("openocd did not finish: {e}"))?;
    if status.success() {
        Ok(())
    } else if openocd_found_no_probe(&log) {
        Err(NO_PROBE.into())
    } else {
        Err(format!("openocd failed ({status})"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::{Crp, Usage};

    fn prepared() -> Prepared {
        Prepared {
            image: build::Output {
                product: firmware::products::default(),
                elf: PathBuf::from("/w/target/thumbv7m-none-eabi/release/analog-io"),
                bin: PathBuf::from("/w/target/thumbv7m-none-eabi/release/analog-io.bin"),
                usage: Usage::default(),
                boot: Some(build::BootParts {
                    program: build::Program {
                        elf: PathBuf::from("/w/target/thumbv7m-none-eabi/bootloader/analog-io"),
                        bin: PathBuf::from("/w/target/thumbv7m-none-eabi/bootloader/analog-io.bin"),
                        usage: Usage::default(),
                    },
                    crp: Crp::None(u32::MAX),
                    efw: PathBuf::from("/w/target/thumbv7m-none-eabi/release/analog-io.efw"),
                    header: firmware::platform::boot::header::HeaderRepr::for_image(
                        &[],
                        &firmware::products::analog_io::identity::UPDATE_TARGET,
                        "0.1.0",
                    ),
                }),
                image: PathBuf::from(
                    "/w/target/thumbv7m-none-eabi/release/analog-io-flash-image.bin",
                ),
            },
            description: Some(PathBuf::from("/w/target/probe-rs/LPC1754.yaml")),
        }
    }

    #[test]
    fn probe_selectors() {
        assert_eq!(
            parse_probe("0d28:0204").unwrap(),
            ProbeSelector {
                vid: 0x0D28,
                pid: 0x0204,
                serial: None
            }
        );
        let p = parse_probe("1366:0101:000801234567").unwrap();
        assert_eq!(p.serial.as_deref(), Some("000801234567"));
        assert_eq!(p.to_string(), "1366:0101:000801234567");
        // A serial may itself contain colons.
        assert_eq!(
            parse_probe("0483:3748:a:b").unwrap().serial.as_deref(),
            Some("a:b")
        );
        for bad in [
            "",
            "0d28",
            "0d28:",
            "xyz:0204",
            "12345:0204",
            "0d28:0204:",
            "stlink",
        ] {
            let e = parse_probe(bad).unwrap_err();
            assert!(e.contains("VID:PID") && e.contains(bad), "{bad}: {e}");
        }
    }

    #[test]
    fn explain_codes() {
        assert_eq!(parse_code("0x3409"), Ok(0x3409));
        assert_eq!(parse_code("13321"), Ok(13321));
        assert!(parse_code("0xZZ").unwrap_err().contains("0xZZ"));
        assert!(ErrorCode(0x3409).to_string().contains("not prepared"));
    }

    #[test]
    fn probe_rs_commands_are_exact() {
        let sel = parse_probe("0d28:0204:ABC").unwrap();
        let [d, v, r] = probe_rs_flash_commands(&prepared(), Some(&sel), true);
        let common = "--chip-description-path /w/target/probe-rs/LPC1754.yaml --chip LPC1754 --probe 0d28:0204:ABC";
        assert_eq!(
            quoted(&d),
            format!("probe-rs download {common} --chip-erase --verify --binary-format bin --base-address 0 /w/target/thumbv7m-none-eabi/release/analog-io-flash-image.bin")
        );
        assert_eq!(
            quoted(&v),
            format!("probe-rs verify {common} --binary-format bin --base-address 0 /w/target/thumbv7m-none-eabi/release/analog-io-flash-image.bin")
        );
        assert_eq!(quoted(&r), format!("probe-rs reset {common}"));
        let [d, ..] = probe_rs_flash_commands(&prepared(), None, false);
        assert_eq!(
            quoted(&d),
            "probe-rs download --chip-description-path /w/target/probe-rs/LPC1754.yaml --chip LPC1754 --verify --binary-format bin --base-address 0 /w/target/thumbv7m-none-eabi/release/analog-io-flash-image.bin"
        );
    }

    /// A board probe-rs knows (the STM32F103): no description of ours, the image at the
    /// start of its flash.
    #[test]
    fn probe_rs_commands_for_a_built_in_chip() {
        let product = firmware::products::find("analog-io-stm32").unwrap();
        let image =
            PathBuf::from("/w/target/thumbv7m-none-eabi/release/analog-io-stm32-flash-image.bin");
        let p = Prepared {
            image: build::Output {
                product,
                elf: PathBuf::from("/w/target/thumbv7m-none-eabi/release/analog-io-stm32"),
                bin: PathBuf::from("/w/target/thumbv7m-none-eabi/release/analog-io-stm32.bin"),
                usage: Usage::default(),
                boot: None,
                image: image.clone(),
            },
            description: None,
        };
        let [d, v, r] = probe_rs_flash_commands(&p, None, false);
        let bin = format!(
            "--binary-format bin --base-address 0x8000000 {}",
            image.display()
        );
        assert_eq!(
            quoted(&d),
            format!("probe-rs download --chip STM32F103VC --verify {bin}")
        );
        assert_eq!(
            quoted(&v),
            format!("probe-rs verify --chip STM32F103VC {bin}")
        );
        assert_eq!(quoted(&r), "probe-rs reset --chip STM32F103VC");
        let c = openocd_command(&p, None, "interface/stlink.cfg");
        assert!(quoted(&c).contains("-f target/stm32f1x.cfg"));
        assert!(quoted(&c).contains(" 0x08000000 verify reset exit"));
    }

    #[test]
    fn openocd_command_is_exact() {
        let sel = parse_probe("0d28:0204:ABC").unwrap();
        let c = openocd_command(&prepared(), Some(&sel), "interface/jlink.cfg");
        assert_eq!(
            quoted(&c),
            "openocd -f interface/jlink.cfg -c 'adapter serial ABC' -f target/lpc17xx.cfg -c 'program {/w/target/thumbv7m-none-eabi/release/analog-io-flash-image.bin} 0x00000000 verify reset exit'"
        );
    }

    #[test]
    fn probe_list_parsing() {
        let none = "No debug probes were found.\n";
        assert!(listed_probes(none).is_empty());
        let two = "The following debug probes were found:\n\
                   [0]: CMSIS-DAP -- 0d28:0204:0240000034544e45 (CMSIS-DAP)\n\
                   [1]: J-Link -- 1366:0101:000801234567 (J-Link)\n";
        let probes = listed_probes(two);
        assert_eq!(probes.len(), 2);
        let sel = |s| parse_probe(s).unwrap();
        assert!(matches_probe(&probes[0], &sel("0D28:0204")));
        assert!(matches_probe(
            &probes[0],
            &sel("0d28:0204:0240000034544E45")
        ));
        assert!(!matches_probe(&probes[0], &sel("0d28:0204:0240")));
        assert!(matches_probe(&probes[1], &sel("1366:0101")));
        assert!(!matches_probe(&probes[1], &sel("0483:3748")));
    }

    #[test]
    fn openocd_no_probe_messages() {
        assert!(openocd_found_no_probe(
            "Error: unable to find a matching CMSIS-DAP device\n"
        ));
        assert!(openocd_found_no_probe("Error: No J-Link device found.\n"));
        assert!(!openocd_found_no_probe(
            "Error: checksum mismatch - attempting binary compare\n"
        ));
    }

    #[test]
    fn quoting() {
        let mut c = Command::new("openocd");
        c.args(["-c", "a b", "it's", ""]);
        assert_eq!(quoted(&c), r#"openocd -c 'a b' 'it'\''s' ''"#);
    }
}
