//! Link setup of the flash algorithm binary: `algo.x` on the linker search path and passed to
//! the binary only (never as global rustflags), and only for the bare-metal target.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let script = dir.join("algo.x");
    println!("cargo:rerun-if-changed={}", script.display());
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_OS").unwrap_or_default() != "none" {
        return; // host build: the binary is a stub
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    fs::copy(&script, out.join("algo.x")).expect("copy algo.x to OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Talgo.x");
    println!("cargo:rustc-link-arg-bins=--nmagic");
}
