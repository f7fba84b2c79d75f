//! `cargo xtask test`: everything CI checks.

use crate::util::{cargo, exec, have, Result};
use crate::{bench, build, docs, esi, flash, fuzz, peer, setup};
use std::path::Path;
use std::process::Command;

/// Seconds each fuzz target runs in CI (long campaigns: `cargo xtask fuzz --seconds N`).
const CI_FUZZ_SECONDS: u32 = 30;

/// The tests ignored by default because they need python3 with python-canopen, python-can
/// and durand (the setup installs them; without them they fail, naming what is missing):
/// python-canopen driving the board, and coe-core's master driving durand, python-canopen's
/// LocalNode and the firmware's node.
const PYTHON_CAN_TESTS: [&str; 2] = [
    "python_canopen_drives_the_board_over_socketcand",
    "the_master_runs_durand_python_canopen_and_the_firmware_node",
];

/// The tests ignored by default because they need tshark: their names end so.
const TSHARK_TESTS: &str = "_decodes_in_tshark";
/// The tests ignored by default because they need root (a network namespace, raw sockets):
/// ethercrab and the firmware on the virtual board (and the echo responder), SOEM (pysoem) and the image (and SOES) on the
/// co-simulator (the LPC1754 and the STM32 images), SOEM assigning the input oversampling PDOs
/// on the image, SOEM updating the module's firmware on the virtual board and on the image, and
/// the CAN product's image after refused files, each on a veth pair.
const ROOT_TESTS: [&str; 10] = [
    "ethercrab_drives_the_firmware_over_a_veth_pair",
    "ethercrab_gets_its_words_echoed_over_a_veth_pair",
    "pysoem_drives_the_image_over_a_veth_pair",
    "pysoem_drives_the_stm32_image_over_a_veth_pair",
    "pysoem_assigns_the_oversampling_pdos_and_reaches_op_over_a_veth_pair",
    "pysoem_plays_every_update_through_the_oversampling_pdos_over_a_veth_pair",
    "pysoem_drives_soes_over_a_veth_pair",
    "pysoem_updates_the_module_over_a_veth_pair",
    "pysoem_updates_the_image_over_a_veth_pair",
    "pysoem_updates_the_can_image_after_refused_files",
];

/// The `no_std` crates others reuse: they must build for every embedded target, and they
/// are ready to publish (`cargo publish --dry-run`).
const PORTABLE_CRATES: [&str; 5] = ["coe-core", "et1100", "ad5663", "ad7689", "lpc17xx-iap"];

#[derive(clap::Args)]
pub struct Args {
    /// Skip rustfmt and clippy (faster local iterations).
    #[arg(long)]
    pub no_lint: bool,
}

/// The `mod.rs` of every product (firmware/src/products/NAME/mod.rs).
fn product_modules() -> Result<Vec<std::path::PathBuf>> {
    let dir = crate::util::root().join("firmware/src/products");
    let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut mods: Vec<_> = entries
        .filter_map(|e| Some(e.ok()?.path().join("mod.rs")))
        .filter(|p| p.is_file())
        .collect();
    mods.sort();
    Ok(mods)
}

pub fn run(args: &Args) -> Result {
    setup::all()?;
    if !args.no_lint {
        exec(cargo().args(["fmt", "--all", "--check"]))?;
        // The fuzz crate is a workspace of its own, out of reach of `--all`.
        exec(cargo().args([
            "fmt",
            "--manifest-path",
            "tests/fuzz/Cargo.toml",
            "--all",
            "--check",
        ]))?;
        // The product modules are declared inside the `products!` macro, where cargo fmt
        // does not look: rustfmt takes them by path (and the modules they declare).
        exec(
            Command::new("rustfmt")
                .args(["--edition", "2021", "--check"])
                .args(product_modules()?),
        )?;
        exec(cargo().args([
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ]))?;
        // The API documentation of the crates others reuse, and the firmware's: a broken
        // link is a warning rustdoc alone sees.
        let mut doc = cargo();
        doc.args(["doc", "--no-deps", "--lib", "-p", "firmware"]);
        for c in PORTABLE_CRATES {
            doc.args(["-p", c]);
        }
        exec(doc.env("RUSTDOCFLAGS", "-D warnings"))?;
    }
    publish_dry_run()?;
    // The LPC1754 images of every product first: release builds, checksum, CRP word and
    // budgets verified on the BINs; the co-simulator's system tests (tests/cosim) run these
    // very programs (each product's bootloader and update file are found beside its
    // application's ELF, the products' ELFs beside the default one's).
    let mut images = Vec::new();
    for product in firmware::products::PRODUCTS {
        images.push(build::build(&build::Args::of(product))?);
    }
    images.iter().for_each(build::print_report);
    build::print_budgets(&images);
    let image = &images[0];
    // SOES for the same board (tests/soes), which the co-simulator's peer tests run.
    let soes = peer::build_soes()?;
    exec(
        cargo()
            .args(["test", "--workspace"])
            .env("LPC1754_IMAGE", &image.elf)
            .env(peer::SOES_IMAGE_ENV, &soes),
    )?;
    ignored_tests(&image.elf, &soes)?;
    // coe-core as the firmware builds it (without the `real` feature, which the workspace
    // test run unifies back on), so the no-REAL paths are tested too.
    exec(cargo().args(["test", "-p", "coe-core", "--no-default-features"]))?;
    // The device description files, the ESI validated against the ETG.2000 schema.
    esi::run(&esi::Args::default())?;
    // The manual: its generated tables, its links and the commands it shows.
    docs::run()?;
    for target in setup::TARGETS {
        let mut cmd = cargo();
        cmd.args(["build", "--release", "--target", target]);
        for c in PORTABLE_CRATES {
            cmd.args(["-p", c]);
        }
        cmd.env("RUSTFLAGS", "-D warnings");
        exec(&mut cmd)?;
    }
    // The images' own code, which only this target compiles, per product (its tasks), the
    // bootloader's hardware code, and the fallback ADC path (one interrupt per sample
    // instead of the GPDMA) with the last LPC1754 product, so none can rot.
    let last_lpc = firmware::products::PRODUCTS
        .iter()
        .rposition(|p| p.board.mcu().has_bootloader());
    for (i, product) in firmware::products::PRODUCTS.iter().enumerate() {
        let features = match Some(i) == last_lpc {
            true => format!("{},adc-irq", product.name),
            false => product.name.to_string(),
        };
        let mut clippy = cargo();
        clippy
            .args(["clippy", "--release", "-p", "firmware"])
            .args(["--bin", crate::mcu::of(product.board.mcu()).bin]);
        if product.board.mcu().has_bootloader() {
            clippy.args(["--bin", build::BOOT_BIN]);
        }
        exec(
            clippy
                .args(["--target", build::TARGET, "--no-default-features"])
                .args(["--features", &features])
                .args(["--", "-D", "warnings"]),
        )?;
    }
    // The benchmark in its short form, so the command cannot rot (needs qemu-system-arm,
    // which setup installs; it fails, not skips, without it).
    bench::run(&bench::Args {
        quick: true,
        ..Default::default()
    })?;
    // The flash algorithm for thumbv7m-none-eabi, its target description loaded the way
    // probe-rs loads it, and the exact flashing commands, without a probe.
    flash::run(&flash::Args::dry_run())?;
    // Every fuzz target for a short while, seeded from the real captures: a crash fails CI.
    fuzz::run(&fuzz::Args {
        seconds: CI_FUZZ_SECONDS,
        ..Default::default()
    })?;
    Ok(())
}

/// `cargo publish --dry-run` of the reusable crates: each is packaged (manifest, README,
/// licence files) and the package alone is built, as crates.io would take it. The crates go
/// in one command so that et1100's dependency on coe-core resolves to the coe-core packaged
/// beside it, which the registry does not have yet. `--allow-dirty`: a developer runs this
/// with changes not yet committed; CI's clone is clean anyway.
fn publish_dry_run() -> Result {
    let mut cmd = cargo();
    cmd.args(["publish", "--dry-run", "--allow-dirty"]);
    for c in PORTABLE_CRATES {
        cmd.args(["-p", c]);
    }
    exec(&mut cmd)
}

/// The tests ignored by default because they need what a developer's machine may lack:
/// the capture checks (tshark, which the setup installs, so its absence is an error) and
/// the network-interface tests (root: run when this is root, else said loudly). The tests
/// that read the shared vectors beside the checkout show as ignored where they are absent
/// and run with the others where they are present (`has_shared_vectors`).
fn ignored_tests(image: &Path, soes: &Path) -> Result {
    if !have("tshark") {
        return Err(
            "tshark is not installed, so the capture checks (tests named \
             *_decodes_in_tshark) cannot run: install the Debian package tshark \
             (`cargo xtask setup` does, as root)"
                .into(),
        );
    }
    let ignored = |names: &[&str]| {
        let mut cmd = cargo();
        cmd.args(["test", "--workspace", "--tests", "--", "--ignored"])
            .args(names)
            .env("LPC1754_IMAGE", image)
            .env(peer::SOES_IMAGE_ENV, soes);
        cmd
    };
    exec(&mut ignored(&[TSHARK_TESTS]))?;
    // A master against a program on the wall clock: one at a time, so that each virtual
    // board has a core, as each real one has its own CPU. (Two co-simulated boards and
    // their masters busy-polling at real-time priority on two cores starved each other,
    // and SOEM's 2 ms datagram timeout then failed runs that had nothing wrong.)
    let mut wall_clock: Vec<&str> = PYTHON_CAN_TESTS.to_vec();
    if setup::is_root() {
        wall_clock.extend(ROOT_TESTS);
    } else if in_ci() {
        // CI promises every test ran: a test that cannot run fails the run.
        return Err(format!(
            "not root, so these tests cannot run: {} (CI=true: run as root)",
            ROOT_TESTS.join(", ")
        ));
    } else {
        eprintln!("NOT RUN (needs root): {}", ROOT_TESTS.join(", "));
    }
    exec(ignored(&wall_clock).arg("--test-threads=1"))
}

/// Running under CI (`CI=true`, as GitHub Actions, GitLab and most CI services set it).
fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v.eq_ignore_ascii_case("true") || v == "1")
}
