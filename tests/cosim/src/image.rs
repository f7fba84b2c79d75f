//! The firmware as the microcontroller's flash holds it (the LPC1754's, or the STM32F103's,
//! told by where the ELF is linked, [`Chip::of_load_address`]): the ELFs' loadable segments at their load
//! addresses (`.data`'s initial values included), the symbols the co-simulator needs, and
//! the boot ROM's checks (UM10360 32.3 and 32.6): the vector checksum (words 0..7 sum to 0,
//! else the ROM stays in ISP and never starts the image) and the Code Read Protection word
//! at 0x2FC.
//!
//! The release flash holds two programs (`firmware::platform::boot::layout`): the bootloader from 0,
//! and the update file (`.efw`: header block, then the application linked at 0x3100) in the
//! application slot ([`Image::from_programs`]). A single ELF from 0 also loads
//! ([`Image::from_elf`], for tests of the boot ROM's checks).

use crate::chip::Chip;
use firmware::platform::boot::header::{Header, HeaderRepr, Target};
use firmware::platform::boot::layout::{APP_SLOT, APP_VECTORS, HEADER_BLOCK};
use object::elf::PT_LOAD;
use object::read::elf::{ElfFile32, ProgramHeader, SectionHeader};
use object::{Endianness, Object, ObjectSection, ObjectSymbol};
use std::fmt;
use std::path::Path;

/// Flash size of the LPC1754.
pub const FLASH_SIZE: usize = 128 * 1024;
/// The CRP word's address.
pub const CRP_ADDRESS: usize = 0x2FC;

/// Code Read Protection levels (UM10360 32.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Crp {
    /// No protection (any other word).
    None,
    /// CRP1 0x12345678.
    Crp1,
    /// CRP2 0x87654321.
    Crp2,
    /// CRP3 0x43218765: SWD and ISP disabled for ever.
    Crp3,
    /// NO_ISP 0x4E697370: P2.10 not sampled.
    NoIsp,
}

impl Crp {
    fn of(word: u32) -> Self {
        match word {
            0x1234_5678 => Crp::Crp1,
            0x8765_4321 => Crp::Crp2,
            0x4321_8765 => Crp::Crp3,
            0x4E69_7370 => Crp::NoIsp,
            _ => Crp::None,
        }
    }
}

/// Why an image does not start.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ImageError {
    /// Not an ELF the co-simulator can load.
    Elf(String),
    /// A segment outside the flash.
    OutsideFlash(u32, usize),
    /// The programs are linked for different chips.
    MixedChips,
    /// The boot ROM's vector checksum does not hold.
    Checksum {
        /// Sum of words 0..7 (must be 0).
        sum: u32,
        /// Word 7 as stored.
        stored: u32,
        /// Word 7 that would make the sum 0.
        expected: u32,
    },
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImageError::Elf(e) => write!(f, "cannot load the image: {e}"),
            ImageError::OutsideFlash(a, n) => write!(
                f,
                "a loadable segment of {n} bytes at {a:#010x} lies outside the chip's flash"
            ),
            ImageError::MixedChips => write!(f, "the programs are linked for different chips"),
            ImageError::Checksum {
                sum,
                stored,
                expected,
            } => write!(
                f,
                "boot ROM: the vector checksum is wrong (words 0..7 sum to {sum:#010x}, not 0: \
                 word 7 at 0x1C is {stored:#010x}, {expected:#010x} expected); the ROM stays in \
                 ISP and never starts the image (UM10360 32.3.1.1)"
            ),
        }
    }
}

impl std::error::Error for ImageError {}

/// A loaded image.
#[derive(Clone)]
pub struct Image {
    /// The chip the image is linked for.
    pub chip: Chip,
    /// The product the image is, when the loader knows it ([`Image::product`] otherwise
    /// reads the update file's header).
    pub known_product: Option<&'static firmware::products::Product>,
    /// Flash contents from the chip's flash base (erased bytes 0xFF).
    pub flash: Vec<u8>,
    /// Bytes of flash the segments occupy (highest end).
    pub flash_used: usize,
    /// Address of the defmt RTT control block (`_SEGGER_RTT`), if present.
    pub rtt: Option<u32>,
    /// The ELF itself (defmt's tables live in it).
    pub elf: Vec<u8>,
    /// Function symbols (address without the Thumb bit, size, name), sorted by address.
    pub functions: Vec<(u32, u32, String)>,
    /// Sizes of .data + .bss + .uninit in the local SRAM (static RAM).
    pub static_ram: u32,
    /// Bytes the flash holds: the allocated sections with contents (vector table, CRP
    /// word, code, read-only data, .data's initial values), gaps between them excluded.
    pub flash_bytes: u32,
    /// Where the vector table of the program that does the work lies (the application's
    /// after the bootloader, else 0): its stack is the one measured.
    pub app_vectors: u32,
    /// The lowest address the stack may reach: `__StackLimit` of a C image whose stack sits
    /// above its static RAM, else the local SRAM's start (flip-link puts the stack below).
    pub stack_floor: u32,
}

/// The chip an ELF is linked for: the flash its lowest loadable segment is in.
fn chip_of(data: &[u8]) -> Result<Chip, ImageError> {
    let elf = ElfFile32::<Endianness>::parse(data).map_err(|e| ImageError::Elf(e.to_string()))?;
    let e = elf.endian();
    let lowest = elf
        .elf_program_headers()
        .iter()
        .filter(|ph| ph.p_type(e) == PT_LOAD && ph.p_filesz(e) != 0)
        .map(|ph| ph.p_paddr(e))
        .min()
        .ok_or_else(|| ImageError::Elf("no loadable segment".into()))?;
    Chip::of_load_address(lowest).ok_or(ImageError::OutsideFlash(lowest, 0))
}

/// The loadable segments of an ELF into `flash` (the chip's flash from its base); the
/// highest end (offset from the base).
fn load_segments(data: &[u8], flash: &mut [u8]) -> Result<usize, ImageError> {
    let elf = ElfFile32::<Endianness>::parse(data).map_err(|e| ImageError::Elf(e.to_string()))?;
    let e = elf.endian();
    let base = chip_of(data)?.flash().start as usize;
    let mut used = 0;
    for ph in elf.elf_program_headers() {
        if ph.p_type(e) != PT_LOAD || ph.p_filesz(e) == 0 {
            continue;
        }
        let bytes = ph
            .data(e, data)
            .map_err(|_| ImageError::Elf("bad program header".into()))?;
        let addr = ph.p_paddr(e);
        let at = (addr as usize).wrapping_sub(base);
        let end = at.wrapping_add(bytes.len());
        if at > flash.len() || end > flash.len() {
            return Err(ImageError::OutsideFlash(addr, bytes.len()));
        }
        flash[at..end].copy_from_slice(bytes);
        used = used.max(end);
    }
    Ok(used)
}

/// The function symbols of an ELF (address without the Thumb bit, size, demangled name).
fn functions_of(data: &[u8]) -> Result<Vec<(u32, u32, String)>, ImageError> {
    let elf = ElfFile32::<Endianness>::parse(data).map_err(|e| ImageError::Elf(e.to_string()))?;
    Ok(elf
        .symbols()
        .filter(|s| s.kind() == object::SymbolKind::Text && s.size() > 0)
        .filter_map(|s| {
            let name = s.name().ok()?;
            Some((
                s.address() as u32 & !1,
                s.size() as u32,
                rustc_demangle::demangle(name).to_string(),
            ))
        })
        .collect())
}

impl Image {
    /// `flash` on `chip` with nothing else known (no ELF, no RTT, the stack floor at the
    /// SRAM's start): the unit tests' image.
    #[cfg(test)]
    pub(crate) fn bare(chip: Chip, flash: Vec<u8>) -> Image {
        Image {
            chip,
            known_product: None,
            flash,
            flash_used: 0,
            rtt: None,
            elf: Vec::new(),
            functions: Vec::new(),
            static_ram: 0,
            flash_bytes: 0,
            app_vectors: 0,
            stack_floor: chip.sram().start,
        }
    }

    /// Loads an ELF file.
    pub fn from_file(path: &Path) -> Result<Self, ImageError> {
        let data =
            std::fs::read(path).map_err(|e| ImageError::Elf(format!("{}: {e}", path.display())))?;
        Self::from_elf(data)
    }

    /// Loads an ELF image from bytes (a program linked at the start of its chip's flash).
    pub fn from_elf(data: Vec<u8>) -> Result<Self, ImageError> {
        let elf = ElfFile32::<Endianness>::parse(data.as_slice())
            .map_err(|e| ImageError::Elf(e.to_string()))?;
        let chip = chip_of(&data)?;
        let mut flash = vec![0xFF; chip.flash().len as usize];
        let used = load_segments(&data, &mut flash)?;
        let rtt = elf
            .symbols()
            .find(|s| s.name() == Ok("_SEGGER_RTT"))
            .map(|s| s.address() as u32);
        let mut functions = functions_of(&data)?;
        functions.sort();
        let static_ram = elf
            .sections()
            .filter(|s| matches!(s.name(), Ok(".data" | ".bss" | ".uninit")))
            .map(|s| s.size() as u32)
            .sum();
        let e = elf.endian();
        let flash_bytes = elf
            .elf_section_table()
            .iter()
            .filter(|h| {
                h.sh_type(e) == object::elf::SHT_PROGBITS
                    && h.sh_flags(e) & object::elf::SHF_ALLOC != 0
            })
            .map(|h| h.sh_size(e))
            .sum();
        let stack_floor = elf
            .symbols()
            .find(|s| s.name() == Ok("__StackLimit"))
            .map_or(chip.sram().start, |s| s.address() as u32);
        Ok(Self {
            chip,
            known_product: None,
            flash,
            flash_used: used,
            flash_bytes,
            rtt,
            elf: data,
            functions,
            static_ram,
            app_vectors: 0,
            stack_floor,
        })
    }

    /// The release flash: the bootloader's ELF from 0, the update file (header block and
    /// image) in the application slot. `app_elf` is the application the file carries: its
    /// symbols, RTT block and defmt tables are the image's (the bootloader's functions are
    /// added for reports); its loadable bytes must be the file's image.
    pub fn from_programs(
        bootloader_elf: &[u8],
        app_elf: Vec<u8>,
        update_file: &[u8],
    ) -> Result<Self, ImageError> {
        let mut image = Self::from_elf(app_elf)?;
        if chip_of(bootloader_elf)? != image.chip {
            return Err(ImageError::MixedChips);
        }
        let mut flash = vec![0xFF; FLASH_SIZE];
        load_segments(bootloader_elf, &mut flash)?;
        let slot = APP_SLOT.start as usize;
        if update_file.len() > APP_SLOT.len as usize {
            return Err(ImageError::OutsideFlash(APP_SLOT.start, update_file.len()));
        }
        let carried = update_file.get(HEADER_BLOCK as usize..).unwrap_or_default();
        let linked = image
            .flash
            .get(APP_VECTORS as usize..image.flash_used)
            .unwrap_or_default();
        if carried != linked {
            return Err(ImageError::Elf(
                "the update file does not carry the application ELF's image".into(),
            ));
        }
        flash[slot..slot + update_file.len()].copy_from_slice(update_file);
        image.flash = flash;
        image.flash_used = slot + update_file.len();
        image.functions.extend(functions_of(bootloader_elf)?);
        image.functions.sort();
        image.app_vectors = APP_VECTORS;
        Ok(image)
    }

    /// The product whose update file the application slot holds (by its header's product
    /// code), if any.
    pub fn product(&self) -> Option<&'static firmware::products::Product> {
        if self.known_product.is_some() {
            return self.known_product;
        }
        let slot = APP_SLOT.start as usize;
        let block = self.flash.get(slot..slot + HEADER_BLOCK as usize)?;
        let header = HeaderRepr::parse(&Header::new_unchecked(block)).ok()?;
        firmware::products::PRODUCTS.iter().copied().find(|p| {
            p.update
                .is_some_and(|u| u.product_code == header.product_code)
        })
    }

    /// Word `i` of the flash.
    pub fn word(&self, addr: usize) -> u32 {
        u32::from_le_bytes(self.flash[addr..addr + 4].try_into().expect("4 bytes"))
    }

    /// The boot ROM's checks: the vector checksum must hold; returns the CRP level. The
    /// STM32 boots from its flash without a checksum (its read protection is an option
    /// byte, not modelled: [`Crp::None`]).
    pub fn boot_rom_check(&self) -> Result<Crp, ImageError> {
        if self.chip != Chip::Lpc1754 {
            return Ok(Crp::None);
        }
        let sum = (0..8).fold(0u32, |a, i| a.wrapping_add(self.word(4 * i)));
        if sum != 0 {
            let stored = self.word(0x1C);
            return Err(ImageError::Checksum {
                sum,
                stored,
                expected: stored.wrapping_sub(sum),
            });
        }
        Ok(Crp::of(self.word(CRP_ADDRESS)))
    }

    /// The stack pointer of the reset vector table (vector 0 at address 0).
    pub fn reset_sp(&self) -> u32 {
        self.word(0)
    }

    /// The reset handler of the reset vector table (vector 1 at address 0).
    pub fn reset_vector(&self) -> u32 {
        self.word(4)
    }

    /// Initial stack pointer of the working program (the application after the
    /// bootloader): the top of the stack the run measures.
    pub fn initial_sp(&self) -> u32 {
        self.word(self.app_vectors as usize)
    }

    /// The working program's reset handler (the application after the bootloader).
    pub fn app_entry(&self) -> u32 {
        self.word(self.app_vectors as usize + 4) & !1
    }

    /// The function containing `addr` (name, offset), for reports.
    pub fn symbolize(&self, addr: u32) -> Option<(&str, u32)> {
        let a = addr & !1;
        let i = self.functions.partition_point(|f| f.0 <= a);
        let (start, size, name) = self.functions.get(i.checked_sub(1)?)?;
        (a < start + size).then(|| (name.as_str(), a - start))
    }

    /// Replaces `from` by `to` at the only place `from` occurs in the working program (the
    /// application after the bootloader, whose update header is then signed again, so the
    /// bootloader still starts it; else the whole flash), for tests that patch an image;
    /// errors when it occurs not exactly once.
    pub fn patch_unique(&mut self, from: &[u8], to: &[u8]) -> Result<usize, String> {
        assert_eq!(from.len(), to.len());
        let base = self.app_vectors as usize;
        let hits: Vec<usize> = self.flash[base..self.flash_used]
            .windows(from.len())
            .enumerate()
            .filter(|(_, w)| *w == from)
            .map(|(i, _)| base + i)
            .collect();
        match hits.as_slice() {
            [at] => {
                self.flash[*at..*at + to.len()].copy_from_slice(to);
                if base != 0 {
                    self.sign_application()?;
                }
                Ok(*at)
            }
            _ => Err(format!(
                "{from:02x?} occurs {} times in the image, not once",
                hits.len()
            )),
        }
    }

    /// Writes the application slot's header again for the image it holds now (length and
    /// CRC-32; identity, revision and version kept).
    fn sign_application(&mut self) -> Result<(), String> {
        let slot = APP_SLOT.start as usize;
        let block = &self.flash[slot..slot + HEADER_BLOCK as usize];
        let old = HeaderRepr::parse(&Header::new_unchecked(block))
            .map_err(|e| format!("the application slot's header: {e}"))?;
        let image = &self.flash[APP_VECTORS as usize..self.flash_used];
        let target = Target {
            vendor_id: old.vendor_id,
            product_code: old.product_code,
            hardware_revision: old.hardware_revision,
            board: old.board,
            needs: old.needs,
        };
        let mut new = HeaderRepr::for_image(image, &target, "");
        new.version = old.version;
        self.flash[slot..slot + HEADER_BLOCK as usize].copy_from_slice(&new.to_bytes());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksum_rule_and_crp() {
        let mut img = Image::bare(Chip::Lpc1754, vec![0xFF; FLASH_SIZE]);
        for i in 0..7 {
            img.flash[4 * i..4 * i + 4].copy_from_slice(&(0x1000_0000u32 + i as u32).to_le_bytes());
        }
        let sum = (0..7).fold(0u32, |a, i| a.wrapping_add(img.word(4 * i)));
        img.flash[0x1C..0x20].copy_from_slice(&sum.wrapping_neg().to_le_bytes());
        assert_eq!(img.boot_rom_check(), Ok(Crp::None));
        img.flash[CRP_ADDRESS..CRP_ADDRESS + 4].copy_from_slice(&0x4321_8765u32.to_le_bytes());
        assert_eq!(img.boot_rom_check(), Ok(Crp::Crp3));
        img.flash[0x1C] ^= 1;
        let err = img.boot_rom_check().unwrap_err().to_string();
        assert!(
            err.contains("vector checksum is wrong") && err.contains("ISP"),
            "{err}"
        );
    }
}
