//! Link setup of the LPC1754 binary.
//!
//! Copies the workspace's `memory.x` into `OUT_DIR` (on the linker search path) and passes
//! cortex-m-rt's `link.x` and defmt's `defmt.x` to the binary only
//! (`cargo:rustc-link-arg-bins`), never as global rustflags: the library and the driver crates
//! cross-build for other targets without these scripts.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let memory_x = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"))
        .join("..")
        .join("memory.x");
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");

    let target_os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if target_os != "none" {
        return; // host build: the binary is a stub, nothing to link specially
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    fs::copy(&memory_x, out.join("memory.x")).expect("copy memory.x to OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // No page alignment between sections (the usual Cortex-M setting; smaller ELF).
    println!("cargo:rustc-link-arg-bins=--nmagic");
    // Identical code folding: monomorphised copies with the same machine code share one body.
    println!("cargo:rustc-link-arg-bins=--icf=all");
}
