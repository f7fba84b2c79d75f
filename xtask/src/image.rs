//! The pure logic of the firmware images: ELF -> BIN, the LPC17xx vector checksum, the Code
//! Read Protection word, the flash/RAM accounting against the budgets, and the files made of
//! the two programs (`firmware::platform::boot::layout`): the update file (`.efw`: the application slot,
//! header block then the application) and the flash image (bootloader, application slot, the
//! staging area's header erased). No I/O here; the `build` and `size` commands feed it bytes.
//!
//! Facts (UM10360 32.3.1.1 and 32.6; hardware-facts section 7):
//! * The boot ROM starts the user code only if the 32-bit sum of the first eight vector
//!   table words (0x00..0x1F) is 0: word 7 (offset 0x1C, a reserved vector) holds the two's
//!   complement of the sum of words 0..6. Otherwise it stays in the ISP loader.
//! * The word at 0x2FC is the CRP: 0x12345678 CRP1, 0x87654321 CRP2, 0x43218765 CRP3
//!   (permanent: no SWD, no ISP), 0x4E697370 NO_ISP; any other value = no protection.

use firmware::platform::boot::header::{HeaderRepr, Target};
use firmware::platform::boot::layout::{
    self, APP_SLOT, APP_VECTORS, BOOTLOADER, HEADER_BLOCK, STAGING,
};
use flash_algo::crp;
use object::elf;
use object::read::elf::{FileHeader, ProgramHeader, SectionHeader};
use object::LittleEndian as LE;
use std::fmt;

/// Offset of the checksum word in the vector table.
pub const CHECKSUM_OFFSET: usize = 0x1C;
/// Offset of the CRP word.
pub const CRP_OFFSET: usize = flash_algo::crp::CRP_ADDRESS as usize;

/// LPC1754 memory map (UM10360 2.1).
pub const FLASH: Region = Region {
    start: 0x0000_0000,
    len: 128 * 1024,
};
/// Local SRAM (16 KB; the top 32 bytes belong to the IAP ROM).
pub const RAM: Region = Region {
    start: 0x1000_0000,
    len: 16 * 1024,
};
/// AHB SRAM bank 0.
pub const AHBSRAM: Region = Region {
    start: 0x2007_C000,
    len: 16 * 1024,
};

/// Where a chip's flash and static RAM are, as the image's sections are sorted into them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryMap {
    /// The flash.
    pub flash: Region,
    /// The SRAM the statics and the stack live in.
    pub ram: Region,
    /// A second SRAM for big buffers (the LPC1754's AHB SRAM), if any.
    pub ahbsram: Option<Region>,
}

/// The LPC1754's.
pub const LPC1754_MAP: MemoryMap = MemoryMap {
    flash: FLASH,
    ram: RAM,
    ahbsram: Some(AHBSRAM),
};

/// The STM32F103VC's (RM0008 §3.3): 256 KB flash at 0x0800_0000, 48 KB SRAM.
pub const STM32F103VC_MAP: MemoryMap = MemoryMap {
    flash: Region {
        start: 0x0800_0000,
        len: 256 * 1024,
    },
    ram: Region {
        start: 0x2000_0000,
        len: 48 * 1024,
    },
    ahbsram: None,
};

/// The budget of the bootloader: its region (`firmware::platform::boot::layout::BOOTLOADER`); static RAM as the application's (the two
/// never run at the same time).
pub const BOOT_BUDGET: Budget = Budget {
    flash: layout::BOOTLOADER_BUDGET as u64,
    ram: 6 * 1024,
};

/// An address range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// First address.
    pub start: u64,
    /// Length in bytes.
    pub len: u64,
}

impl Region {
    /// Whether `addr` lies inside.
    pub fn contains(&self, addr: u64) -> bool {
        addr >= self.start && addr < self.start + self.len
    }
}

/// Flash and static RAM limits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budget {
    /// Bytes of flash.
    pub flash: u64,
    /// Bytes of static RAM (.data + .bss + .uninit).
    pub ram: u64,
}

/// An error of the image logic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ImageError {
    /// The ELF could not be parsed.
    Elf(String),
    /// The image is shorter than the vector table / CRP word.
    TooShort { len: usize, need: usize },
    /// Sum of words 0..7 is not 0.
    BadChecksum { sum: u32 },
    /// The CRP word enables protection and `--allow-crp` was not given.
    CrpRefused(Crp),
    /// Initial stack pointer or reset vector outside the memory map.
    BadVectors(String),
    /// Loadable data outside the flash.
    OutsideFlash { section: String, addr: u64 },
    /// Over budget.
    OverBudget(String),
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Elf(e) => write!(f, "cannot read the ELF: {e}"),
            Self::TooShort { len, need } => {
                write!(f, "image is {len} bytes, needs at least {need}")
            }
            Self::BadChecksum { sum } => write!(
                f,
                "vector checksum wrong: words 0..7 sum to {sum:#010x}, the boot ROM would stay in ISP"
            ),
            Self::CrpRefused(c) => write!(
                f,
                "the CRP word at 0x2FC is {c}: refusing (pass --allow-crp if you really mean it)"
            ),
            Self::BadVectors(s) => write!(f, "vector table: {s}"),
            Self::OutsideFlash { section, addr } => {
                write!(f, "section {section} loads at {addr:#x}, outside the flash")
            }
            Self::OverBudget(s) => write!(f, "over budget: {s}"),
        }
    }
}

/// The Code Read Protection level a word selects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Crp {
    /// No protection (any other value); the word is kept.
    None(u32),
    /// 0x12345678: SWD off, limited ISP.
    Crp1,
    /// 0x87654321: SWD off, ISP only full erase.
    Crp2,
    /// 0x43218765: SWD and ISP off for ever.
    Crp3,
    /// 0x4E697370: P2.10 not sampled, no ISP entry.
    NoIsp,
}

impl Crp {
    /// The level of `word`.
    pub fn of(word: u32) -> Self {
        match word {
            crp::CRP1 => Self::Crp1,
            crp::CRP2 => Self::Crp2,
            crp::CRP3 => Self::Crp3,
            crp::NO_ISP => Self::NoIsp,
            w => Self::None(w),
        }
    }

    /// Whether the level restricts access.
    pub fn protects(&self) -> bool {
        !matches!(self, Self::None(_))
    }
}

impl fmt::Display for Crp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::None(w) => write!(f, "{w:#010x} (no protection)"),
            Self::Crp1 => f.write_str("0x12345678 CRP1 (SWD disabled, partial ISP)"),
            Self::Crp2 => f.write_str("0x87654321 CRP2 (SWD disabled, ISP full erase only)"),
            Self::Crp3 => {
                f.write_str("0x43218765 CRP3 (SWD and ISP disabled PERMANENTLY: no way back)")
            }
            Self::NoIsp => f.write_str("0x4E697370 NO_ISP (ISP entry via P2.10 disabled)"),
        }
    }
}

fn word(bin: &[u8], offset: usize) -> Result<u32, ImageError> {
    bin.get(offset..offset + 4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or(ImageError::TooShort {
            len: bin.len(),
            need: offset + 4,
        })
}

/// The checksum word for vector words 0..6: `-(w0 + ... + w6)` (wrapping).
pub fn vector_checksum(words: &[u32; 7]) -> u32 {
    words
        .iter()
        .fold(0u32, |a, w| a.wrapping_add(*w))
        .wrapping_neg()
}

/// Writes the checksum into word 7 of `vectors` (the first 32 bytes of the image, or of the
/// vector table section); returns it.
pub fn patch_checksum(vectors: &mut [u8]) -> Result<u32, ImageError> {
    let mut w = [0u32; 7];
    for (i, slot) in w.iter_mut().enumerate() {
        *slot = word(vectors, 4 * i)?;
    }
    let sum = vector_checksum(&w);
    word(vectors, CHECKSUM_OFFSET)?;
    vectors[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&sum.to_le_bytes());
    Ok(sum)
}

/// Checks the boot ROM's rule: words 0..7 sum to 0.
pub fn verify_checksum(bin: &[u8]) -> Result<(), ImageError> {
    let mut sum = 0u32;
    for i in 0..8 {
        sum = sum.wrapping_add(word(bin, 4 * i)?);
    }
    if sum == 0 {
        Ok(())
    } else {
        Err(ImageError::BadChecksum { sum })
    }
}

/// The CRP word of the image; an error for a protecting value unless `allow`.
pub fn check_crp(bin: &[u8], allow: bool) -> Result<Crp, ImageError> {
    let crp = Crp::of(word(bin, CRP_OFFSET)?);
    if crp.protects() && !allow {
        return Err(ImageError::CrpRefused(crp));
    }
    Ok(crp)
}

/// Plausibility of the first two vectors of a program whose vector table starts `bin` and
/// lies at `base`: initial SP inside the local SRAM the programs may use (8-byte aligned, at
/// most the boot request word), reset handler a Thumb address inside the image.
pub fn check_vectors_at(bin: &[u8], base: u64) -> Result<(), ImageError> {
    let sp = u64::from(word(bin, 0)?);
    let reset = u64::from(word(bin, 4)?);
    let ram_end = u64::from(layout::RAM_END);
    if !(sp > RAM.start && sp <= ram_end) || sp % 8 != 0 {
        return Err(ImageError::BadVectors(format!(
            "initial SP {sp:#x} is not an 8-byte aligned address in the local SRAM below {ram_end:#x}"
        )));
    }
    let handler = reset & !1;
    if reset & 1 == 0 || handler < base || handler >= base + bin.len() as u64 {
        return Err(ImageError::BadVectors(format!(
            "reset vector {reset:#x} is not a Thumb address inside the image"
        )));
    }
    Ok(())
}

/// [`check_vectors_at`] for the program at address 0 (the bootloader).
pub fn check_vectors(bin: &[u8]) -> Result<(), ImageError> {
    check_vectors_at(bin, FLASH.start)
}

/// Every check a written BIN must pass before it goes near a chip.
pub fn verify_bin(bin: &[u8], allow_crp: bool) -> Result<Crp, ImageError> {
    if bin.len() < CRP_OFFSET + 4 {
        return Err(ImageError::TooShort {
            len: bin.len(),
            need: CRP_OFFSET + 4,
        });
    }
    verify_checksum(bin)?;
    check_vectors(bin)?;
    check_crp(bin, allow_crp)
}

/// Where a section lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// Occupies flash only (code, constants, vector table, CRP).
    Flash,
    /// Initialised RAM: occupies flash (load image) and RAM.
    FlashAndRam,
    /// Zeroed or uninitialised RAM (.bss, .uninit).
    Ram,
    /// AHB SRAM (NOLOAD buffers).
    AhbSram,
    /// Not loaded (debug info, defmt strings).
    None,
}

/// One section of the ELF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SectionInfo {
    /// Name.
    pub name: String,
    /// Run address (VMA).
    pub addr: u64,
    /// Load address (LMA): where its bytes sit in flash, if it has any.
    pub load_addr: Option<u64>,
    /// Size in bytes.
    pub size: u64,
    /// Classification.
    pub place: Place,
    /// File offset of the contents (for patching), if the section has contents.
    pub file_offset: Option<u64>,
}

/// The image's use of memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Usage {
    /// Flash: what the program occupies of its region, from its first address to the end of
    /// the last loadable section (.vector_table, .crp, .text, .rodata, .data load image),
    /// the 0xFF gap before the CRP word included.
    pub flash: u64,
    /// Static RAM in the local SRAM: .data + .bss + .uninit (stack excluded).
    pub ram: u64,
    /// AHB SRAM buffers (.ahbsram).
    pub ahbsram: u64,
    /// End of the flash image (the BIN size, including the gap before the CRP word).
    pub image_end: u64,
}

/// The memory use of a program linked from `base`.
pub fn usage(sections: &[SectionInfo], base: u64) -> Usage {
    let mut u = Usage::default();
    for s in sections {
        match s.place {
            Place::FlashAndRam | Place::Ram => u.ram += s.size,
            Place::AhbSram => u.ahbsram += s.size,
            Place::Flash | Place::None => {}
        }
        if let Some(lma) = s.load_addr {
            u.image_end = u.image_end.max(lma + s.size);
        }
    }
    u.flash = u.image_end.saturating_sub(base);
    u
}

/// The budget verdict: `Err` naming every limit that is exceeded.
pub fn check_budget(u: &Usage, b: &Budget) -> Result<(), ImageError> {
    let mut over = Vec::new();
    if u.flash > b.flash {
        over.push(format!("flash {} B > {} B", u.flash, b.flash));
    }
    if u.ram > b.ram {
        over.push(format!("static RAM {} B > {} B", u.ram, b.ram));
    }
    if over.is_empty() {
        Ok(())
    } else {
        Err(ImageError::OverBudget(over.join(", ")))
    }
}

/// The sections of an ELF32 little-endian image, with load addresses from the program
/// headers and a place in the memory map.
pub fn sections(data: &[u8]) -> Result<Vec<SectionInfo>, ImageError> {
    sections_in(data, &LPC1754_MAP)
}

/// [`sections`] of an image for the chip with memory map `map`.
pub fn sections_in(data: &[u8], map: &MemoryMap) -> Result<Vec<SectionInfo>, ImageError> {
    let e = |err: object::read::Error| ImageError::Elf(err.to_string());
    let header = elf::FileHeader32::<LE>::parse(data).map_err(e)?;
    let endian = header.endian().map_err(e)?;
    let phdrs = header.program_headers(endian, data).map_err(e)?;
    let table = header.sections(endian, data).map_err(e)?;
    let mut out = Vec::new();
    for s in table.iter() {
        let flags = u64::from(s.sh_flags(endian));
        let size = u64::from(s.sh_size(endian));
        if flags & u64::from(elf::SHF_ALLOC) == 0 || size == 0 {
            continue;
        }
        let name = String::from_utf8_lossy(table.section_name(endian, s).map_err(e)?).into_owned();
        let addr = u64::from(s.sh_addr(endian));
        let nobits = s.sh_type(endian) == elf::SHT_NOBITS;
        let offset = u64::from(s.sh_offset(endian));
        let load_addr = if nobits {
            None
        } else {
            // The PT_LOAD segment holding the section's bytes gives the LMA.
            phdrs
                .iter()
                .filter(|p| p.p_type(endian) == elf::PT_LOAD)
                .find(|p| {
                    let o = u64::from(p.p_offset(endian));
                    offset >= o && offset + size <= o + u64::from(p.p_filesz(endian))
                })
                .map(|p| u64::from(p.p_paddr(endian)) + offset - u64::from(p.p_offset(endian)))
                .or(Some(addr))
        };
        let place = if map.ahbsram.is_some_and(|r| r.contains(addr)) {
            Place::AhbSram
        } else if map.ram.contains(addr) {
            if nobits {
                Place::Ram
            } else {
                Place::FlashAndRam
            }
        } else if map.flash.contains(addr) && !nobits {
            Place::Flash
        } else {
            Place::None
        };
        out.push(SectionInfo {
            name,
            addr,
            load_addr: if place == Place::Flash || place == Place::FlashAndRam {
                load_addr
            } else {
                None
            },
            size,
            place,
            file_offset: (!nobits).then_some(offset),
        });
    }
    Ok(out)
}

/// The flash image from `base` (what `objcopy -O binary` gives for a program linked there):
/// every section with a load address, at its load address, gaps filled with 0xFF (the erased
/// flash value).
pub fn elf_to_bin(data: &[u8], sections: &[SectionInfo], base: u64) -> Result<Vec<u8>, ImageError> {
    elf_to_bin_in(data, sections, base, &FLASH)
}

/// [`elf_to_bin`] for a chip whose flash is `flash`.
pub fn elf_to_bin_in(
    data: &[u8],
    sections: &[SectionInfo],
    base: u64,
    flash: &Region,
) -> Result<Vec<u8>, ImageError> {
    let mut bin: Vec<u8> = Vec::new();
    for s in sections {
        let (Some(lma), Some(off)) = (s.load_addr, s.file_offset) else {
            continue;
        };
        if !flash.contains(lma) || lma < base || lma + s.size > flash.start + flash.len {
            return Err(ImageError::OutsideFlash {
                section: s.name.clone(),
                addr: lma,
            });
        }
        let start = (lma - base) as usize;
        let end = start + s.size as usize;
        if bin.len() < end {
            bin.resize(end, 0xFF);
        }
        let src = data
            .get(off as usize..off as usize + s.size as usize)
            .ok_or_else(|| ImageError::Elf(format!("section {} beyond the file", s.name)))?;
        bin[start..end].copy_from_slice(src);
    }
    Ok(bin)
}

/// The update file of an application image (`app`, linked at the slot's vector table
/// address): the header block for `target` and `version`, then the image. Checks the
/// application's vectors and that it fits the slot.
pub fn update_file(
    app: &[u8],
    target: &Target,
    version: &str,
) -> Result<(Vec<u8>, HeaderRepr), ImageError> {
    check_vectors_at(app, u64::from(APP_VECTORS))?;
    if app.len() as u64 > u64::from(layout::MAX_IMAGE) {
        return Err(ImageError::OverBudget(format!(
            "application {} B does not fit the {} B slot",
            app.len(),
            layout::MAX_IMAGE
        )));
    }
    let header = HeaderRepr::for_image(app, target, version);
    let mut file = header.to_bytes().to_vec();
    file.extend_from_slice(app);
    Ok((file, header))
}

/// The whole flash content a debug probe writes: the bootloader (padded to its region), the
/// update file in the application slot, and 0xFF over the staging area's header block, so
/// the probe erases that sector and no staged update from before survives the flashing.
pub fn flash_image(boot: &[u8], update: &[u8]) -> Result<Vec<u8>, ImageError> {
    if boot.len() as u64 > u64::from(BOOTLOADER.len) {
        return Err(ImageError::OverBudget(format!(
            "bootloader {} B does not fit its {} B",
            boot.len(),
            BOOTLOADER.len
        )));
    }
    if update.len() as u64 > u64::from(APP_SLOT.len) {
        return Err(ImageError::OverBudget(format!(
            "update file {} B does not fit the {} B slot",
            update.len(),
            APP_SLOT.len
        )));
    }
    let mut image = vec![0xFF; (STAGING.start + HEADER_BLOCK) as usize];
    image[..boot.len()].copy_from_slice(boot);
    let slot = APP_SLOT.start as usize;
    image[slot..slot + update.len()].copy_from_slice(update);
    Ok(image)
}

/// Patches the vector checksum into the ELF's section that loads at address 0; returns the
/// checksum, `None` if no such section exists.
pub fn patch_elf_checksum(
    data: &mut [u8],
    sections: &[SectionInfo],
) -> Result<Option<u32>, ImageError> {
    let Some(s) = sections
        .iter()
        .find(|s| s.load_addr == Some(FLASH.start) && s.size >= 32)
    else {
        return Ok(None);
    };
    let off = s.file_offset.unwrap_or(0) as usize;
    let vectors = data
        .get_mut(off..off + 32)
        .ok_or_else(|| ImageError::Elf("vector table beyond the file".into()))?;
    patch_checksum(vectors).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic image: SP, reset and exception vectors, CRP word.
    fn image(crp: u32) -> Vec<u8> {
        let mut bin = vec![0xFF; 0x400];
        let words = [
            0x1000_3FD8u32,
            0x0000_0301,
            0x0000_0305,
            0x0000_0307,
            0x0000_0309,
            0x0000_030B,
            0x0000_030D,
            0,
        ];
        for (i, w) in words.iter().enumerate() {
            bin[4 * i..4 * i + 4].copy_from_slice(&w.to_le_bytes());
        }
        bin[CRP_OFFSET..CRP_OFFSET + 4].copy_from_slice(&crp.to_le_bytes());
        bin
    }

    #[test]
    fn checksum_is_twos_complement_of_words_0_to_6() {
        let w = [0x1000_3FE0, 0x301, 0x305, 0x307, 0x309, 0x30B, 0x30D];
        let sum: u64 = w.iter().map(|&x| u64::from(x)).sum();
        assert_eq!(vector_checksum(&w), (0u32).wrapping_sub(sum as u32));
        // By hand: 0x1000_3FE0 + 0x122E = 0x1000_520E, negated 0xEFFF_ADF2.
        assert_eq!(vector_checksum(&w), 0xEFFF_ADF2);
        // Wrapping case.
        assert_eq!(vector_checksum(&[0xFFFF_FFFF, 1, 0, 0, 0, 0, 0]), 0);
        assert_eq!(
            vector_checksum(&[0x8000_0000, 0x8000_0000, 2, 0, 0, 0, 0]),
            0xFFFF_FFFE
        );
    }

    #[test]
    fn patch_then_verify() {
        let mut bin = image(0xFFFF_FFFF);
        assert!(matches!(
            verify_checksum(&bin),
            Err(ImageError::BadChecksum { .. })
        ));
        let c = patch_checksum(&mut bin).unwrap();
        assert_eq!(&bin[0x1C..0x20], &c.to_le_bytes());
        verify_checksum(&bin).unwrap();
        assert_eq!(verify_bin(&bin, false).unwrap(), Crp::None(0xFFFF_FFFF));
        // Idempotent.
        assert_eq!(patch_checksum(&mut bin).unwrap(), c);
        // Any change of words 0..6 breaks it.
        bin[4] ^= 0x10;
        assert!(verify_checksum(&bin).is_err());
    }

    #[test]
    fn crp_values() {
        for (w, c) in [
            (0x1234_5678, Crp::Crp1),
            (0x8765_4321, Crp::Crp2),
            (0x4321_8765, Crp::Crp3),
            (0x4E69_7370, Crp::NoIsp),
        ] {
            let mut bin = image(w);
            patch_checksum(&mut bin).unwrap();
            assert_eq!(verify_bin(&bin, false), Err(ImageError::CrpRefused(c)));
            assert_eq!(verify_bin(&bin, true), Ok(c));
            assert!(c
                .to_string()
                .to_lowercase()
                .starts_with(&format!("{w:#010x}")));
        }
        for w in [0xFFFF_FFFF, 0, 0x1234_5679] {
            assert_eq!(check_crp(&image(w), false), Ok(Crp::None(w)));
        }
    }

    #[test]
    fn short_and_implausible_images() {
        assert!(matches!(
            verify_bin(&[0; 16], false),
            Err(ImageError::TooShort { .. })
        ));
        let mut bin = image(0xFFFF_FFFF);
        bin[0..4].copy_from_slice(&0x2000_0000u32.to_le_bytes()); // SP not in local SRAM
        patch_checksum(&mut bin).unwrap();
        assert!(matches!(
            verify_bin(&bin, false),
            Err(ImageError::BadVectors(_))
        ));
        let mut bin = image(0xFFFF_FFFF);
        bin[4..8].copy_from_slice(&0x300u32.to_le_bytes()); // even: not Thumb
        patch_checksum(&mut bin).unwrap();
        assert!(matches!(
            verify_bin(&bin, false),
            Err(ImageError::BadVectors(_))
        ));
    }

    #[test]
    fn update_file_and_flash_image() {
        // An application image at 0x3100: SP at the top of the usable RAM, reset at +0x101.
        let mut app = vec![0x5A; 0x300];
        app[0..4].copy_from_slice(&0x1000_3FD8u32.to_le_bytes());
        app[4..8].copy_from_slice(&0x0000_3201u32.to_le_bytes());
        let target = firmware::products::analog_io::identity::UPDATE_TARGET;
        let (efw, header) = update_file(&app, &target, "1.2.3").unwrap();
        assert_eq!(efw.len(), 256 + app.len());
        assert_eq!(&efw[256..], &app[..]);
        assert_eq!(&efw[..4], b"AEFW");
        assert_eq!(header.version_str(), Some("1.2.3"));
        assert_eq!(header.image_len, 0x300);
        assert_eq!(
            header.image_crc,
            firmware::platform::boot::crc32::crc32(&app)
        );
        assert_eq!(header.check(&firmware::products::analog_io::BOARD), Ok(()));
        // Vectors of an image linked elsewhere are refused.
        let mut elsewhere = app.clone();
        elsewhere[4..8].copy_from_slice(&0x0000_0301u32.to_le_bytes());
        assert!(matches!(
            update_file(&elsewhere, &target, "1"),
            Err(ImageError::BadVectors(_))
        ));
        // The flash image: bootloader at 0, the file at 0x3000, 0xFF up to the staging
        // area's header block inclusive.
        let mut boot = image(0xFFFF_FFFF);
        patch_checksum(&mut boot).unwrap();
        let flash = flash_image(&boot, &efw).unwrap();
        assert_eq!(flash.len(), 0x1_0100);
        assert_eq!(&flash[..boot.len()], &boot[..]);
        assert!(flash[boot.len()..0x3000].iter().all(|b| *b == 0xFF));
        assert_eq!(&flash[0x3000..0x3000 + efw.len()], &efw[..]);
        assert!(flash[0x3000 + efw.len()..].iter().all(|b| *b == 0xFF));
        assert!(flash_image(&[0; 0x3001], &efw).is_err());
        assert!(flash_image(&boot, &vec![0; 0xD001]).is_err());
    }

    fn sec(name: &str, addr: u64, lma: Option<u64>, size: u64, place: Place) -> SectionInfo {
        SectionInfo {
            name: name.into(),
            addr,
            load_addr: lma,
            size,
            place,
            file_offset: lma.map(|_| 0),
        }
    }

    #[test]
    fn accounting_and_budget() {
        let s = [
            sec(".vector_table", 0, Some(0), 0xCC, Place::Flash),
            sec(".crp", 0x2FC, Some(0x2FC), 4, Place::Flash),
            sec(".text", 0x300, Some(0x300), 10_000, Place::Flash),
            sec(".rodata", 0x2A10, Some(0x2A10), 1_000, Place::Flash),
            sec(".data", 0x1000_3000, Some(0x2DF8), 56, Place::FlashAndRam),
            sec(".bss", 0x1000_3038, None, 100, Place::Ram),
            sec(".uninit", 0x1000_309C, None, 1_200, Place::Ram),
            sec(".ahbsram", 0x2007_C000, None, 4_096, Place::AhbSram),
            sec(".defmt", 0, None, 12, Place::None),
        ];
        let u = usage(&s, 0);
        // The gap between the vector table and the CRP word is taken, too.
        assert_eq!(u.flash, 0x2DF8 + 56);
        assert_eq!(u.ram, 56 + 100 + 1_200);
        assert_eq!(u.ahbsram, 4_096);
        assert_eq!(u.image_end, 0x2DF8 + 56);
        check_budget(&u, &crate::build::budget_of(firmware::products::default())).unwrap();
        let small = Budget {
            flash: 1_000,
            ram: 100,
        };
        let err = check_budget(&u, &small).unwrap_err().to_string();
        assert!(err.contains("flash") && err.contains("static RAM"), "{err}");
    }
}
