//! The firmware image as the LPC1754's flash holds it: the ELF's loadable segments at their
//! load addresses (`.data`'s initial values included), the symbols the co-simulator needs,
//! and the boot ROM's checks (UM10360 32.3 and 32.6): the vector checksum (words 0..7 sum to
//! 0, else the ROM stays in ISP and never starts the image) and the Code Read Protection
//! word at 0x2FC.

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
                "a loadable segment of {n} bytes at {a:#010x} lies outside the 128 KB flash"
            ),
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
    /// Flash contents (erased bytes 0xFF).
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
}

impl Image {
    /// Loads an ELF file.
    pub fn from_file(path: &Path) -> Result<Self, ImageError> {
        let data =
            std::fs::read(path).map_err(|e| ImageError::Elf(format!("{}: {e}", path.display())))?;
        Self::from_elf(data)
    }

    /// Loads an ELF image from bytes.
    pub fn from_elf(data: Vec<u8>) -> Result<Self, ImageError> {
        let elf = ElfFile32::<Endianness>::parse(data.as_slice())
            .map_err(|e| ImageError::Elf(e.to_string()))?;
        let e = elf.endian();
        let mut flash = vec![0xFF; FLASH_SIZE];
        let mut used = 0;
        for ph in elf.elf_program_headers() {
            if ph.p_type(e) != PT_LOAD || ph.p_filesz(e) == 0 {
                continue;
            }
            let bytes = ph
                .data(e, data.as_slice())
                .map_err(|_| ImageError::Elf("bad program header".into()))?;
            let at = ph.p_paddr(e) as usize;
            let end = at + bytes.len();
            if end > FLASH_SIZE {
                return Err(ImageError::OutsideFlash(at as u32, bytes.len()));
            }
            flash[at..end].copy_from_slice(bytes);
            used = used.max(end);
        }
        let rtt = elf
            .symbols()
            .find(|s| s.name() == Ok("_SEGGER_RTT"))
            .map(|s| s.address() as u32);
        let mut functions: Vec<(u32, u32, String)> = elf
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
            .collect();
        functions.sort();
        let static_ram = elf
            .sections()
            .filter(|s| matches!(s.name(), Ok(".data" | ".bss" | ".uninit")))
            .map(|s| s.size() as u32)
            .sum();
        let flash_bytes = elf
            .elf_section_table()
            .iter()
            .filter(|h| {
                h.sh_type(e) == object::elf::SHT_PROGBITS
                    && h.sh_flags(e) & object::elf::SHF_ALLOC != 0
            })
            .map(|h| h.sh_size(e))
            .sum();
        Ok(Self {
            flash,
            flash_used: used,
            flash_bytes,
            rtt,
            elf: data,
            functions,
            static_ram,
        })
    }

    /// Word `i` of the flash.
    pub fn word(&self, addr: usize) -> u32 {
        u32::from_le_bytes(self.flash[addr..addr + 4].try_into().expect("4 bytes"))
    }

    /// The boot ROM's checks: the vector checksum must hold; returns the CRP level.
    pub fn boot_rom_check(&self) -> Result<Crp, ImageError> {
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

    /// Initial stack pointer (vector 0).
    pub fn initial_sp(&self) -> u32 {
        self.word(0)
    }

    /// The function containing `addr` (name, offset), for reports.
    pub fn symbolize(&self, addr: u32) -> Option<(&str, u32)> {
        let a = addr & !1;
        let i = self.functions.partition_point(|f| f.0 <= a);
        let (start, size, name) = self.functions.get(i.checked_sub(1)?)?;
        (a < start + size).then(|| (name.as_str(), a - start))
    }

    /// Replaces `from` by `to` at the only place `from` occurs in the flash (for tests that
    /// patch an image); errors when it occurs not exactly once.
    pub fn patch_unique(&mut self, from: &[u8], to: &[u8]) -> Result<usize, String> {
        assert_eq!(from.len(), to.len());
        let hits: Vec<usize> = self
            .flash
            .windows(from.len())
            .enumerate()
            .filter(|(_, w)| *w == from)
            .map(|(i, _)| i)
            .collect();
        match hits.as_slice() {
            [at] => {
                self.flash[*at..*at + to.len()].copy_from_slice(to);
                Ok(*at)
            }
            _ => Err(format!(
                "{from:02x?} occurs {} times in the image, not once",
                hits.len()
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksum_rule_and_crp() {
        let mut img = Image {
            flash: vec![0xFF; FLASH_SIZE],
            flash_used: 0,
            rtt: None,
            elf: Vec::new(),
            functions: Vec::new(),
            static_ram: 0,
            flash_bytes: 0,
        };
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
