//! Link setup of the bare-metal runner: its own complete linker script for QEMU's
//! lm3s6965evb (flash at 0, SRAM at 0x2000_0000), passed to the binary only. It does not use
//! the workspace's `memory.x` (the LPC1754's local SRAM at 0x1000_0000 does not exist on
//! that machine) nor cortex-m-rt.

use std::env;
use std::path::PathBuf;

fn main() {
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let script = dir.join("qemu-lm3s6965.ld");
    println!("cargo:rerun-if-changed={}", script.display());
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_OS").unwrap_or_default() != "none" {
        return;
    }
    println!("cargo:rustc-link-arg-bins=-T{}", script.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
}
