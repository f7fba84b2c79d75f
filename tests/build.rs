//! Tells the tests whether the real-world test vectors (`../shared/vectors`, next to a
//! checkout in CI) are present, so the tests that read them show as ignored, not passed,
//! where they are not.

use std::path::Path;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(has_shared_vectors)");
    println!("cargo::rerun-if-changed=build.rs");
    let manifest = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default();
    if Path::new(&manifest)
        .ancestors()
        .any(|a| a.join("shared/vectors").is_dir())
    {
        println!("cargo::rustc-cfg=has_shared_vectors");
    }
}
