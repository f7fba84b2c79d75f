//! `cargo xtask peer soes`: SOES, the C stack most open-source slaves use, built for the
//! thesis board (`tests/soes`) into an ELF the co-simulator runs beside the release image.
//!
//! SOES's own sources are compiled from `../shared/peers/soes` (GPL-2.0 with a linking
//! exception), beside the checkout as in CI; nothing of them is copied into the
//! repository. The port (hardware layer, main loop, object dictionary, start-up) is
//! `tests/soes/port`. gcc-arm-none-eabi with newlib (Debian packages, which `cargo xtask
//! setup` installs) builds it at -O2; the boot ROM's vector checksum is patched into the
//! ELF as `cargo xtask build` does for the bootloader.

use crate::image;
use crate::setup;
use crate::util::{exec, root, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The environment variable that names the SOES ELF for the co-simulator's tests.
pub const SOES_IMAGE_ENV: &str = "SOES_IMAGE";

/// SOES's sources the port compiles (relative to the SOES tree): the slave loop, the ESM
/// and mailbox, CoE. FoE and EoE are off in `ecat_options.h`, as the module has neither.
pub const SOES_SOURCES: [&str; 3] = ["soes/ecat_slv.c", "soes/esc.c", "soes/esc_coe.c"];

/// The port's own sources (in `tests/soes/port`).
const PORT_SOURCES: [&str; 6] = [
    "startup.c",
    "board.c",
    "esc_hw.c",
    "analog.c",
    "objectlist.c",
    "main.c",
];

/// The optimisation a SOES user ships on this board: -O2, since the 128 KB flash holds
/// SOES many times over and the process-data cycle is what is measured (see
/// docs/book/soes.md).
pub const OPT_LEVEL: &str = "-O2";

#[derive(clap::Args)]
pub struct Args {
    /// The peer to build (only `soes`).
    #[arg(value_parser = ["soes"])]
    pub peer: String,
}

pub fn run(args: &Args) -> Result {
    debug_assert_eq!(args.peer, "soes");
    let elf = build_soes()?;
    eprintln!("SOES image: {}", elf.display());
    Ok(())
}

/// Where SOES's sources are: `../shared/peers/soes` beside the checkout.
pub fn soes_tree() -> Result<PathBuf> {
    let tree = root().join("../shared/peers/soes");
    if tree.join("soes/ecat_slv.c").is_file() {
        Ok(tree)
    } else {
        Err(format!(
            "SOES's sources are not at {}: the SOES peer is built from ../shared/peers/soes \
             beside the checkout (unmodified upstream SOES, GPL-2.0 with a linking exception), \
             as CI lays it out",
            tree.display()
        ))
    }
}

/// Builds the SOES image; returns its ELF (`target/soes/soes-analog-io.elf`).
pub fn build_soes() -> Result<PathBuf> {
    let tree = soes_tree()?;
    if !setup::debian(&setup::PEER_PACKAGES) {
        return Err(format!(
            "the SOES peer needs the Debian packages {:?} (`cargo xtask setup` installs \
             them, as root)",
            setup::PEER_PACKAGES
        ));
    }
    let port = root().join("tests/soes/port");
    let out = crate::build::target_dir().join("soes");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let elf = out.join("soes-analog-io.elf");
    let mut objects = Vec::new();
    // SOES's sources as they are (their warnings are not the port's), the port's with
    // warnings as errors.
    let sources = SOES_SOURCES
        .iter()
        .map(|s| (tree.join(s), false))
        .chain(PORT_SOURCES.iter().map(|s| (port.join(s), true)));
    for (source, own) in sources {
        let stem = source.file_stem().unwrap_or_default().to_string_lossy();
        let object = out.join(format!("{stem}.o"));
        let mut cc = compiler();
        cc.args(["-c", "-std=gnu11", "-ffunction-sections", "-fdata-sections"])
            .args(["-DNDEBUG", "-Wall", "-Wextra"])
            .args(if own { &["-Werror"][..] } else { &[][..] })
            .arg(include(&port))
            .arg(include(&tree.join("soes")))
            .arg(include(&tree.join("soes/include/sys/gcc")))
            .arg(&source)
            .arg("-o")
            .arg(&object);
        exec(&mut cc)?;
        objects.push(object);
    }
    let mut link = compiler();
    link.args(["-nostartfiles", "--specs=nano.specs"])
        .arg(format!("-T{}", port.join("lpc1754.ld").display()))
        .arg("-Wl,--gc-sections")
        .arg(format!(
            "-Wl,-Map={}",
            out.join("soes-analog-io.map").display()
        ))
        .args(&objects)
        .arg("-o")
        .arg(&elf);
    exec(&mut link)?;
    patch_checksum(&elf)?;
    Ok(elf)
}

/// arm-none-eabi-gcc for the LPC1754's Cortex-M3 at [`OPT_LEVEL`], with debug information
/// (the co-simulator's profile names functions from it).
fn compiler() -> Command {
    let mut cmd = Command::new("arm-none-eabi-gcc");
    cmd.args(["-mcpu=cortex-m3", "-mthumb", OPT_LEVEL, "-g"]);
    cmd
}

fn include(dir: &Path) -> String {
    format!("-I{}", dir.display())
}

/// The boot ROM's vector checksum (word 7) written into the ELF.
fn patch_checksum(elf: &Path) -> Result {
    let mut data = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let sections = image::sections(&data).map_err(|e| e.to_string())?;
    image::patch_elf_checksum(&mut data, &sections).map_err(|e| e.to_string())?;
    std::fs::write(elf, &data).map_err(|e| format!("{}: {e}", elf.display()))?;
    let bin = image::elf_to_bin(&data, &sections, 0).map_err(|e| e.to_string())?;
    image::verify_checksum(&bin).map_err(|e| format!("SOES image: {e}"))
}
