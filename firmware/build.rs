//! Link setup of the two LPC1754 binaries and the STM32F103 one.
//!
//! Each binary gets its own memory map (`firmware::platform::boot::layout`): the application
//! (`application`) `memory-app.x` (the application slot after the update header), the
//! bootloader `memory-boot.x` (the first 12 KB, vectors with the checksum and the CRP word),
//! the STM32F103 application (`application-stm32f103`) `memory-stm32f103.x` (the whole flash).
//! cortex-m-rt's `link.x` includes `memory.x`, which the linker finds in the workspace root
//! (the directory it runs in, searched before any search path); that file includes
//! `memory-map.x`, which no directory but the binary's own has: each map is copied under that
//! name into a directory of its own in `OUT_DIR`, passed to its binary only
//! (`cargo:rustc-link-arg-bin`, `-L` and the path as two arguments, the form flip-link reads),
//! as are `link.x` and defmt's `defmt.x` (the application logs over RTT; the bootloader does
//! not log, but the shared hardware layer's types derive defmt's formatting, whose sections
//! defmt.x keeps out of the flash). Never global rustflags: the library and the driver crates
//! cross-build for other targets without these scripts.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

/// Copies `script` to `dir/memory-map.x` and gives `bin` that directory and its scripts.
fn link(bin: &str, script: &Path, dir: &Path, scripts: &[&str]) {
    fs::create_dir_all(dir).expect("create the linker script directory");
    fs::copy(script, dir.join("memory-map.x")).expect("copy the memory map to OUT_DIR");
    println!("cargo:rustc-link-arg-bin={bin}=-L");
    println!("cargo:rustc-link-arg-bin={bin}={}", dir.display());
    for s in scripts {
        println!("cargo:rustc-link-arg-bin={bin}=-T{s}");
    }
    // No page alignment between sections (the usual Cortex-M setting; smaller ELF).
    println!("cargo:rustc-link-arg-bin={bin}=--nmagic");
    // Identical code folding: monomorphised copies with the same machine code share one body.
    println!("cargo:rustc-link-arg-bin={bin}=--icf=all");
}

fn main() {
    let root = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo")).join("..");
    let app = root.join("memory-app.x");
    let boot = root.join("memory-boot.x");
    let stm32 = root.join("memory-stm32f103.x");
    for script in [&root.join("memory.x"), &app, &boot, &stm32] {
        println!("cargo:rerun-if-changed={}", script.display());
    }
    println!("cargo:rerun-if-changed=build.rs");

    let target_os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if target_os != "none" {
        return; // host build: the binaries are stubs, nothing to link specially
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    link(
        "application",
        &app,
        &out.join("application"),
        &["link.x", "defmt.x"],
    );
    link(
        "bootloader",
        &boot,
        &out.join("bootloader"),
        &["link.x", "defmt.x"],
    );
    link(
        "application-stm32f103",
        &stm32,
        &out.join("application-stm32f103"),
        &["link.x", "defmt.x"],
    );
}
