//! RTIC 2 application for the LPC1754.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("analog-io runs on the LPC1754: build it with `cargo xtask build`");
}
