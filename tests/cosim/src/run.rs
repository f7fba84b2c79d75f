//! Running the image on the virtual board: where the image is, the sim's [`Target`] for it,
//! and a handle to the co-simulator for its facts while the board owns it.

use crate::chip::Chip;
use crate::cosim::{Cosim, Options};
use crate::image::Image;
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use virtual_board::models::esc::SyncEdge;
use virtual_board::rig::board::{BoardIo, PdiCpu};
use virtual_board::tools::sim::{firmware_device, Target};

/// The environment variable that names the release ELF of the default product's application
/// (`cargo xtask test` sets it after building the images); the update file (`analog-io.efw`)
/// is beside it, the other products' ELFs and update files too ([`image_path_of`]), and the
/// bootloader's ELF at [`bootloader_path`], as `cargo xtask build` writes them.
pub const IMAGE_ENV: &str = "LPC1754_IMAGE";

/// The release ELF of the application: `$LPC1754_IMAGE`, else `cargo xtask build`'s output
/// in the workspace's target directory. The image is never built here (a cargo build inside
/// a running cargo would wait on its lock): run `cargo xtask build` first.
pub fn image_path() -> PathBuf {
    if let Some(p) = std::env::var_os(IMAGE_ENV) {
        return PathBuf::from(p);
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|d| if d.is_absolute() { d } else { root.join(d) })
        .unwrap_or_else(|| root.join("target"));
    target
        .join("thumbv7m-none-eabi/release")
        .join(firmware::products::default().name)
}

/// The release ELF of the product `name`: beside [`image_path`]'s.
pub fn image_path_of(name: &str) -> PathBuf {
    image_path().with_file_name(name)
}

fn read(path: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| {
        format!(
            "{}: {e}: run `cargo xtask build` first (or set {IMAGE_ENV})",
            path.display()
        )
    })
}

/// Loads the release flash of the default product: the bootloader, and the update file
/// with the application ELF it carries, with a clear message when one is missing.
pub fn load_image() -> Result<Image, String> {
    let app = image_path();
    load_programs(&app, &app.with_extension("efw"))
}

/// [`load_image`] of the product `name`; a board without a bootloader (the STM32F103's)
/// flashes the application's ELF alone.
pub fn load_image_of(name: &str) -> Result<Image, String> {
    let app = image_path_of(name);
    let product = firmware::products::PRODUCTS
        .iter()
        .copied()
        .find(|p| p.name == name);
    match product {
        Some(p) if !p.board.mcu().has_bootloader() => {
            let mut image = Image::from_elf(read(&app)?).map_err(|e| e.to_string())?;
            image.known_product = Some(p);
            Ok(image)
        }
        _ => load_programs(&app, &app.with_extension("efw")),
    }
}

/// The bootloader's ELF that goes with the application's `app_elf` (the bootloader of the
/// product's board): `cargo xtask build` builds it with its own cargo profile,
/// `bootloader`, and names it after the product in that profile's directory beside the
/// application's (`release/analog-io`, `bootloader/analog-io`).
pub fn bootloader_path(app_elf: &Path) -> PathBuf {
    let profiles = app_elf.parent().and_then(Path::parent);
    let name = app_elf.file_name().unwrap_or_default();
    profiles
        .unwrap_or(Path::new(""))
        .join("bootloader")
        .join(name)
}

/// Loads the bootloader that goes with `app_elf` ([`bootloader_path`]) and the update file
/// `efw` (which must carry `app_elf`'s image).
pub fn load_programs(app_elf: &Path, efw: &Path) -> Result<Image, String> {
    let boot = read(&bootloader_path(app_elf))?;
    Image::from_programs(&boot, read(app_elf)?, &read(efw)?).map_err(|e| e.to_string())
}

/// The co-simulator shared between the board (as its CPU) and the caller (for facts).
#[derive(Clone)]
pub struct CosimHandle(pub Rc<RefCell<Option<Cosim>>>);

impl CosimHandle {
    /// Runs `f` on the co-simulator (None before the board built it).
    pub fn with<R>(&self, f: impl FnOnce(&Cosim) -> R) -> Option<R> {
        self.0.borrow().as_ref().map(f)
    }
}

struct BoardCpu(CosimHandle);

impl PdiCpu for BoardCpu {
    fn runs_continuously(&self) -> bool {
        true
    }
    fn run_until(&mut self, io: &mut BoardIo, t_ns: u64) {
        if let Some(c) = self.0 .0.borrow_mut().as_mut() {
            c.run_until(io, t_ns);
        }
    }
    fn on_sync0(&mut self, io: &mut BoardIo, edge: &SyncEdge) {
        if let Some(c) = self.0 .0.borrow_mut().as_mut() {
            c.on_sync0(io, edge);
        }
    }
    fn next_timer_ns(&self) -> Option<u64> {
        self.0 .0.borrow().as_ref().and_then(|c| c.next_timer_ns())
    }
    fn next_wake_ns(&self, io: &BoardIo) -> u64 {
        self.0
             .0
            .borrow()
            .as_ref()
            .map_or(u64::MAX, |c| c.next_wake_ns(io))
    }
    fn idle_until(&mut self, io: &mut BoardIo, t_ns: u64) -> u64 {
        match self.0 .0.borrow_mut().as_mut() {
            Some(c) => c.idle_until(io, t_ns),
            None => io.now_ns(),
        }
    }
}

/// The image on the co-simulator as the sim's PDI side, with the SII image generated from
/// the description of the product it is (the same as the host-compiled target's). Fails as
/// the boot ROM would (wrong vector checksum) before any board exists.
pub fn image_target(image: Image, options: Options) -> Result<(Target, CosimHandle), String> {
    let product = image.product().unwrap_or(firmware::products::default());
    if image.chip != Chip::Lpc1754 {
        // The host-compiled harness runs the LPC1754's products only; the image needs the
        // product's SII alone.
        let sii = firmware_device::sii_image_with(product.device, product.oversampling)
            .map_err(|e| e.to_string())?;
        let description = format!(
            "the firmware's {} ({}, generated SII image)",
            product.name, product.device.names.device_name
        );
        return cosim_target(image, options, sii, "the release image", &description);
    }
    let device = firmware_device::device_of(product, virtual_board::tools::sim::DEFAULT_NODE_ID)?;
    cosim_target(
        image,
        options,
        device.sii.clone(),
        "the release image",
        &device.description,
    )
}

/// `program` on the co-simulator as the sim's PDI side, with the SII image `sii` (of the
/// device `device` describes). Fails as the boot ROM would before any board exists.
pub fn cosim_target(
    image: Image,
    options: Options,
    sii: Vec<u8>,
    program: &str,
    device: &str,
) -> Result<(Target, CosimHandle), String> {
    let crp = image.boot_rom_check().map_err(|e| e.to_string())?;
    let handle = CosimHandle(Rc::new(RefCell::new(None)));
    let h = handle.clone();
    let image = Rc::new(image);
    let target = Target {
        description: format!(
            "{program} on the {} co-simulator ({} B flash, CRP {crp:?}), {device}",
            image.chip.name(),
            image.flash_used
        ),
        sii,
        make_cpu: Box::new(move |io| {
            match Cosim::new(image, io, options) {
                Ok(c) => *h.0.borrow_mut() = Some(c),
                Err(e) => eprintln!("co-simulator: {e}"),
            }
            Box::new(BoardCpu(h))
        }),
    };
    Ok((target, handle))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bootloader_is_in_its_profile_directory_beside_the_application() {
        assert_eq!(
            bootloader_path(Path::new("/t/thumbv7m-none-eabi/release/analog-io-can")),
            Path::new("/t/thumbv7m-none-eabi/bootloader/analog-io-can")
        );
    }
}
