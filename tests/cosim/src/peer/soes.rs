//! The SOES port (`tests/soes`, built by `cargo xtask peer soes`) on the co-simulator: where
//! its ELF is, its SII image (from its ESI), and the target the board runs.

use crate::cosim::Options;
use crate::image::Image;
use crate::run::{cosim_target, CosimHandle};
use std::path::PathBuf;
use virtual_board::tools::sim::Target;

/// The environment variable that names the SOES ELF (`cargo xtask test` and `cargo xtask
/// bench --peer soes` set it after building it).
pub const SOES_IMAGE_ENV: &str = "SOES_IMAGE";

/// The ESI of the port, whose SII image the board's ESC loads.
pub const ESI: &str = include_str!("../../../soes/esi/soes-analog-io.xml");

/// The SOES ELF: `$SOES_IMAGE`, else `cargo xtask peer soes`'s output in the workspace's
/// target directory.
pub fn image_path() -> PathBuf {
    if let Some(p) = std::env::var_os(SOES_IMAGE_ENV) {
        return PathBuf::from(p);
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|d| if d.is_absolute() { d } else { root.join(d) })
        .unwrap_or_else(|| root.join("target"));
    target.join("soes/soes-analog-io.elf")
}

/// Loads the SOES ELF (a program linked at 0, as the boot ROM starts it), with a clear
/// message when it is missing.
pub fn load() -> Result<Image, String> {
    let path = image_path();
    let data = std::fs::read(&path).map_err(|e| {
        format!(
            "{}: {e}: run `cargo xtask peer soes` first (or set {SOES_IMAGE_ENV})",
            path.display()
        )
    })?;
    Image::from_elf(data).map_err(|e| e.to_string())
}

/// The SII image of the port, from its ESI.
pub fn sii() -> Result<Vec<u8>, String> {
    super::esi::sii_from_esi(ESI)
}

/// The SOES image on the co-simulator as the sim's PDI side.
pub fn target(image: Image, options: Options) -> Result<(Target, CosimHandle), String> {
    cosim_target(
        image,
        options,
        sii()?,
        "SOES (tests/soes)",
        "SII from tests/soes/esi/soes-analog-io.xml",
    )
}

/// The port's object dictionary source (its 0x1C32:05 is the shortest cycle it accepts).
const OBJECT_LIST: &str = include_str!("../../../soes/port/objectlist.c");

/// The shortest SYNC0 cycle the port accepts (`MIN_CYCLE_TIME_NS` of its object list,
/// 0x1C32:05, which its DC check enforces).
pub fn min_cycle_ns() -> Result<u64, String> {
    OBJECT_LIST
        .lines()
        .find_map(|l| l.strip_prefix("#define MIN_CYCLE_TIME_NS"))
        .and_then(|v| v.trim().parse().ok())
        .ok_or_else(|| "tests/soes/port/objectlist.c defines no MIN_CYCLE_TIME_NS".into())
}

/// The SOES image as a program of the bench's DC runs.
pub fn program(image: &Image) -> Result<crate::bench::Program<'_>, String> {
    Ok(crate::bench::Program {
        image,
        target,
        min_cycle_ns: min_cycle_ns()?,
        boot_ns: 0,
        cpi: None,
    })
}
