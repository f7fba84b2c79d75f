//! Idempotent installation of what the project needs: rustup targets, cargo tools, Debian
//! packages, Python packages.

use crate::util::{exec, have, Result};
use std::process::Command;

/// Cross-compilation targets of the library crates (also in `rust-toolchain.toml`).
pub const TARGETS: [&str; 3] = [
    "thumbv7m-none-eabi",
    "thumbv7em-none-eabihf",
    "riscv32imac-unknown-none-elf",
];

/// Debian packages the tests use: `tshark` decodes the virtual board's pcaps (the tests
/// named `*_decodes_in_tshark`), `xmllint` (libxml2-utils) validates the generated ESI
/// against the ETG.2000 schema, `ip` (iproute2) makes the veth pair of the network
/// interface test; `qemu-system-arm` runs the Cortex-M3 benchmark (`bench`, which fails
/// without it).
pub const DEBIAN_PACKAGES: [&str; 4] = ["tshark", "libxml2-utils", "iproute2", "qemu-system-arm"];

/// Debian packages the image co-simulator (`tests/cosim`, part of the workspace) needs to
/// build: unicorn-engine-sys builds unicorn's C sources with CMake and runs bindgen
/// (libclang) at every build.
pub const COSIM_PACKAGES: [&str; 2] = ["cmake", "libclang-dev"];

/// Debian packages of the SOES peer (`cargo xtask peer soes`, tests/soes): the C compiler for
/// the Cortex-M3 and the C library (newlib) it links.
pub const PEER_PACKAGES: [&str; 2] = ["gcc-arm-none-eabi", "libnewlib-arm-none-eabi"];

/// Python packages (PyPI name, version) the system tests use, pinned so each test drives the
/// software it was written against: pysoem (SOEM's Python binding, a wheel with SOEM inside),
/// the second EtherCAT master on a veth pair and of the firmware update test; python-canopen,
/// the CANopen master of the CAN system test (`tests/python/canopen_master.py`) and, with its
/// LocalNode, one of the slaves of coe-core's master (`tests/python/can_slaves.py`); python-can,
/// whose `socketcand` interface reaches the board's CAN bus; durand, a pure-Python CANopen
/// slave nobody here wrote, the master's other third-party slave.
pub const PYTHON_PACKAGES: [(&str, &str); 4] = [
    ("pysoem", "1.1.13"),
    ("canopen", "2.4.1"),
    ("python-can", "4.6.1"),
    ("durand", "0.5.0"),
];

/// Everything: targets, cargo tools, Debian and Python packages.
pub fn all() -> Result {
    targets()?;
    flip_link()?;
    mdbook()?;
    debian(&DEBIAN_PACKAGES);
    debian(&PEER_PACKAGES);
    python(&PYTHON_PACKAGES);
    cosim()
}

/// What the co-simulator's build needs; an error naming the packages when they cannot be
/// installed (the workspace does not build without them).
pub fn cosim() -> Result {
    if debian(&COSIM_PACKAGES) {
        Ok(())
    } else {
        Err(format!(
            "the image co-simulator (tests/cosim) needs the Debian packages {COSIM_PACKAGES:?} to build"
        ))
    }
}

/// Installs Python packages (`name`, `version`) with pip when that version is not installed.
/// Returns whether all of them are there afterwards; failing to install is not an error, the
/// tests that need them say so.
pub fn python(packages: &[(&str, &str)]) -> bool {
    let installed = |name: &str, version: &str| {
        Command::new("python3")
            .args(["-m", "pip", "show", name])
            .output()
            .map(|o| {
                o.status.success()
                    && String::from_utf8_lossy(&o.stdout)
                        .lines()
                        .any(|l| l.trim() == format!("Version: {version}"))
            })
            .unwrap_or(false)
    };
    let missing: Vec<String> = packages
        .iter()
        .filter(|(n, v)| !installed(n, v))
        .map(|(n, v)| format!("{n}=={v}"))
        .collect();
    if missing.is_empty() {
        return true;
    }
    if !have("python3") {
        eprintln!("note: Python packages {missing:?} are missing and python3 is not installed");
        return false;
    }
    let pip_install = |extra: &[&str]| {
        exec(
            Command::new("python3")
                .args([
                    "-m",
                    "pip",
                    "install",
                    "--quiet",
                    "--disable-pip-version-check",
                ])
                .args(extra)
                .args(&missing),
        )
        .is_ok()
    };
    // A distribution's own python3 (Debian 12 on, PEP 668) refuses pip installs into it; the
    // test masters are pinned versions only these tests use, so they go there all the same.
    pip_install(&[]) || pip_install(&["--break-system-packages"])
}

/// Adds the rustup targets (a no-op when present).
pub fn targets() -> Result {
    if !have("rustup") {
        return Ok(()); // toolchain not managed by rustup: assume targets are provided
    }
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    let missing: Vec<&str> = TARGETS
        .iter()
        .copied()
        .filter(|t| !installed.lines().any(|l| l.trim() == *t))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    exec(
        Command::new("rustup")
            .args(["target", "add"])
            .args(&missing),
    )
}

/// flip-link, the linker wrapper the firmware links with.
pub fn flip_link() -> Result {
    if have("flip-link") {
        return Ok(());
    }
    eprintln!("flip-link is missing: installing it with cargo (once)");
    exec(Command::new("cargo").args(["install", "--locked", "flip-link"]))
}

/// The mdBook version the manual is built with (`cargo xtask docs`; pinned: the book's
/// configuration and the HTML whose links the command checks are this version's).
pub const MDBOOK_VERSION: &str = "0.5.4";

/// mdBook, for `cargo xtask docs`. Built without its `serve` and `watch` features (no web
/// server, no file watcher: the command builds the book once), which leaves out about half
/// of its dependencies; about 3 minutes on two cores, once per machine.
pub fn mdbook() -> Result {
    let installed = Command::new("mdbook")
        .arg("--version")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == format!("mdbook v{MDBOOK_VERSION}"))
        .unwrap_or(false);
    if installed {
        return Ok(());
    }
    eprintln!("mdbook {MDBOOK_VERSION} is missing: installing it with cargo (once)");
    exec(Command::new("cargo").args([
        "install",
        "--locked",
        "mdbook",
        "--version",
        MDBOOK_VERSION,
        "--no-default-features",
        "--features",
        "search",
    ]))
}

/// The cargo-fuzz version `cargo xtask fuzz` installs (pinned: its flags and output format
/// are what the command parses).
pub const CARGO_FUZZ_VERSION: &str = "0.13.2";

/// cargo-fuzz, for `cargo xtask fuzz` (not part of [`all`]: only the fuzz command needs it).
pub fn cargo_fuzz() -> Result {
    let installed = Command::new("cargo")
        .args(["fuzz", "--version"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).contains(CARGO_FUZZ_VERSION))
        .unwrap_or(false);
    if installed {
        return Ok(());
    }
    eprintln!("cargo-fuzz {CARGO_FUZZ_VERSION} is missing: installing it with cargo (once)");
    exec(Command::new("cargo").args([
        "install",
        "--locked",
        "cargo-fuzz",
        "--version",
        CARGO_FUZZ_VERSION,
    ]))
}

/// Installs Debian packages when they are missing and we are allowed to (root, apt-get present).
/// Returns whether all of them are available afterwards; failing to install is not an error,
/// the callers skip what needs the package and say so.
pub fn debian(packages: &[&str]) -> bool {
    let missing: Vec<&str> = packages
        .iter()
        .copied()
        .filter(|p| {
            !Command::new("dpkg")
                .args(["-s", p])
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .status()
                .map(|s| s.success())
                .unwrap_or(false)
        })
        .collect();
    if missing.is_empty() {
        return true;
    }
    if !have("apt-get") || !is_root() {
        eprintln!(
            "note: Debian packages {missing:?} are missing and cannot be installed here (need root and apt-get)"
        );
        return false;
    }
    let _ = exec(Command::new("apt-get").arg("update").arg("-qq"));
    exec(
        Command::new("apt-get")
            .env("DEBIAN_FRONTEND", "noninteractive")
            .args(["install", "-y", "-qq", "--no-install-recommends"])
            .args(&missing),
    )
    .is_ok()
}

/// Whether this process runs as root.
pub fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| o.stdout.starts_with(b"0"))
        .unwrap_or(false)
}
