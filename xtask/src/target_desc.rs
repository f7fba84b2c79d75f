//! The probe-rs target description of the LPC1754 (a `ChipFamily` YAML, the format of
//! probe-rs' built-in targets and of `target-gen`'s output), with our own flash algorithm.
//!
//! probe-rs has no LPC17xx target. The description here gives it the memory map (128 KB flash
//! with the 4 KB / 32 KB sector table, the local SRAM, the AHB SRAM) and the algorithm built
//! from `xtask/flash-algo`: its code as base64, loaded at the address it is linked at, with the
//! entry points as offsets from there. `flash::prepare` checks every file it writes by loading
//! it with probe-rs' own `probe-rs-target` structs and `validate()`, as
//! `probe-rs --chip-description-path` does.

use crate::image::{self, AHBSRAM, FLASH, RAM};
use flash_algo::iap::IAP_RAM_START;
use flash_algo::sector::SECTOR_RUNS;
use jep106::JEP106Code;
use object::elf;
use object::read::elf::{FileHeader, Sym};
use object::LittleEndian as LE;
use probe_rs_target::{
    Chip, ChipFamily, CoreType, FlashProperties, GenericRegion, MemoryAccess, MemoryRegion,
    NvmRegion, RamRegion, RawFlashAlgorithm, SectorDescription, TargetDescriptionSource,
};
use std::collections::HashMap;

/// The chip (and family) name to pass as `--chip`.
pub const CHIP: &str = "LPC1754";
/// The name of the flash algorithm in the description.
pub const ALGORITHM: &str = "lpc1754-iap";
/// probe-rs programs the flash in pages of this size (a count the IAP copy accepts).
pub const PAGE_SIZE: u32 = 1024;
/// Stack probe-rs gives the algorithm. The IAP ROM runs on it too; its need on the LPC17xx is
/// UNCONFIRMED (NXP gives 148 bytes for a related part), 2 KB leaves ample room.
pub const STACK_SIZE: u32 = 2048;
/// ms probe-rs waits for ProgramPage (1 KB at 4 MHz CCLK takes a few ms).
pub const PROGRAM_PAGE_TIMEOUT_MS: u32 = 1000;
/// ms probe-rs waits for EraseSector (a 32 KB sector takes ~100 ms).
pub const ERASE_SECTOR_TIMEOUT_MS: u32 = 3000;
/// The JEP106 code of NXP (bank 0, id 0x15).
const NXP_JEP106: (u8, u8) = (0x15, 0x0);
/// Symbol the algorithm's link script defines at its load address.
const LOAD_SYMBOL: &str = "_algo_load";

/// The flash algorithm as the description carries it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AlgoBlob {
    /// Where the code is linked and loaded.
    pub load_address: u64,
    /// Code, constants and data from `load_address` on (zero-filled gaps, length a multiple
    /// of 4).
    pub instructions: Vec<u8>,
    /// Offsets of the entry points from `load_address` (with the Thumb bit, as linked).
    pub pc_init: u64,
    pub pc_uninit: u64,
    pub pc_program_page: u64,
    pub pc_erase_sector: u64,
    pub pc_erase_all: u64,
    pub pc_verify: u64,
    /// Offset of the data (static base) from `load_address`.
    pub data_section_offset: u64,
}

/// One loadable section of the algorithm ELF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AllocSection {
    /// Name.
    pub name: String,
    /// Address.
    pub addr: u64,
    /// Size.
    pub size: u64,
    /// Contents (`None` for NOBITS: zeros).
    pub data: Option<Vec<u8>>,
}

/// Builds the blob from the loadable sections and the symbols (name -> value).
pub fn assemble(
    sections: &[AllocSection],
    symbols: &HashMap<String, u64>,
) -> Result<AlgoBlob, String> {
    let load = *symbols
        .get(LOAD_SYMBOL)
        .ok_or_else(|| format!("the algorithm ELF has no `{LOAD_SYMBOL}` symbol (algo.x)"))?;
    let loaded: Vec<&AllocSection> = sections.iter().filter(|s| s.size > 0).collect();
    let Some(end) = loaded.iter().map(|s| s.addr + s.size).max() else {
        return Err("the algorithm ELF has no loadable sections".into());
    };
    if let Some(s) = loaded.iter().find(|s| s.addr < load) {
        return Err(format!(
            "section {} at {:#x} lies below the load address {load:#x}",
            s.name, s.addr
        ));
    }
    let mut blob = vec![0u8; (end - load).next_multiple_of(4) as usize];
    for s in &loaded {
        if let Some(data) = &s.data {
            let at = (s.addr - load) as usize;
            let bytes = data
                .get(..s.size as usize)
                .ok_or_else(|| format!("section {} is shorter than its size", s.name))?;
            blob[at..at + bytes.len()].copy_from_slice(bytes);
        }
    }
    let text_end = loaded
        .iter()
        .filter(|s| s.name == ".text")
        .map(|s| s.addr + s.size)
        .max()
        .ok_or("the algorithm ELF has no .text")?;
    let data_start = loaded
        .iter()
        .filter(|s| s.name != ".text")
        .map(|s| s.addr)
        .min()
        .unwrap_or(text_end);
    let entry = |name: &str| -> Result<u64, String> {
        let addr = *symbols
            .get(name)
            .ok_or_else(|| format!("the algorithm ELF has no entry point `{name}`"))?;
        if addr & 1 == 0 || addr < load || addr >= text_end {
            return Err(format!(
                "entry point `{name}` at {addr:#x} is not Thumb code inside .text"
            ));
        }
        Ok(addr - load)
    };
    Ok(AlgoBlob {
        load_address: load,
        pc_init: entry("Init")?,
        pc_uninit: entry("UnInit")?,
        pc_program_page: entry("ProgramPage")?,
        pc_erase_sector: entry("EraseSector")?,
        pc_erase_all: entry("EraseChip")?,
        pc_verify: entry("Verify")?,
        data_section_offset: data_start - load,
        instructions: blob,
    })
}

/// Reads the algorithm ELF into a blob.
pub fn from_elf(data: &[u8]) -> Result<AlgoBlob, String> {
    let sections = image::sections(data)
        .map_err(|e| e.to_string())?
        .into_iter()
        .map(|s| {
            let bytes = s
                .file_offset
                .filter(|_| s.load_addr.is_some())
                .and_then(|o| data.get(o as usize..(o + s.size) as usize))
                .map(<[u8]>::to_vec);
            AllocSection {
                name: s.name,
                addr: s.addr,
                size: s.size,
                data: bytes,
            }
        })
        .collect::<Vec<_>>();
    assemble(&sections, &symbols(data)?)
}

/// The global symbols of an ELF32 file.
fn symbols(data: &[u8]) -> Result<HashMap<String, u64>, String> {
    let e = |err: object::read::Error| format!("cannot read the algorithm ELF: {err}");
    let header = elf::FileHeader32::<LE>::parse(data).map_err(e)?;
    let endian = header.endian().map_err(e)?;
    let table = header.sections(endian, data).map_err(e)?;
    let symtab = table.symbols(endian, data, elf::SHT_SYMTAB).map_err(e)?;
    let mut out = HashMap::new();
    for sym in symtab.iter() {
        if sym.st_bind() != elf::STB_GLOBAL {
            continue;
        }
        let name = sym.name(endian, symtab.strings()).map_err(e)?;
        out.insert(
            String::from_utf8_lossy(name).into_owned(),
            u64::from(sym.st_value(endian)),
        );
    }
    Ok(out)
}

/// The local SRAM probe-rs may use: all of it but the IAP ROM's top 32 bytes.
fn algo_ram_end() -> u64 {
    u64::from(IAP_RAM_START)
}

/// The target description as probe-rs' own structs: the chip, its memory map and the flash
/// algorithm.
pub fn family(blob: &AlgoBlob, description: &str) -> ChipFamily {
    let flash = FLASH.start..FLASH.start + FLASH.len;
    let cores = vec!["main".to_string()];
    let mut chip = Chip::generic_arm(CHIP, CoreType::Armv7m);
    chip.memory_map = vec![
        MemoryRegion::Nvm(NvmRegion {
            name: Some("IROM1 (flash, sectors 0-15 4 KB, 16-17 32 KB)".into()),
            range: flash.clone(),
            cores: cores.clone(),
            is_alias: false,
            access: Some(MemoryAccess {
                boot: true,
                ..MemoryAccess::default()
            }),
        }),
        MemoryRegion::Ram(RamRegion {
            name: Some("IRAM1 (local SRAM below the IAP ROM's 32 bytes)".into()),
            range: RAM.start..algo_ram_end(),
            cores: cores.clone(),
            is_alias: false,
            access: None,
        }),
        MemoryRegion::Generic(GenericRegion {
            name: Some("IAP ROM scratch (top 32 bytes of the local SRAM)".into()),
            range: algo_ram_end()..RAM.start + RAM.len,
            cores: cores.clone(),
            access: None,
        }),
        MemoryRegion::Ram(RamRegion {
            name: Some("IRAM2 (AHB SRAM bank 0)".into()),
            range: AHBSRAM.start..AHBSRAM.start + AHBSRAM.len,
            cores: cores.clone(),
            is_alias: false,
            access: None,
        }),
    ];
    chip.flash_algorithms = vec![ALGORITHM.to_string()];
    let algorithm = RawFlashAlgorithm {
        name: ALGORITHM.into(),
        description: description.into(),
        default: true,
        instructions: blob.instructions.clone(),
        load_address: Some(blob.load_address),
        pc_init: Some(blob.pc_init),
        pc_uninit: Some(blob.pc_uninit),
        pc_program_page: blob.pc_program_page,
        pc_erase_sector: blob.pc_erase_sector,
        pc_erase_all: Some(blob.pc_erase_all),
        pc_verify: Some(blob.pc_verify),
        data_section_offset: blob.data_section_offset,
        stack_size: Some(STACK_SIZE),
        flash_properties: FlashProperties {
            address_range: flash,
            page_size: PAGE_SIZE,
            erased_byte_value: 0xFF,
            program_page_timeout: PROGRAM_PAGE_TIMEOUT_MS,
            erase_sector_timeout: ERASE_SECTOR_TIMEOUT_MS,
            sectors: SECTOR_RUNS
                .iter()
                .map(|run| SectorDescription {
                    size: u64::from(run.size),
                    address: u64::from(run.address),
                })
                .collect(),
        },
        cores,
        ..RawFlashAlgorithm::default()
    };
    ChipFamily {
        name: CHIP.into(),
        manufacturer: Some(JEP106Code::new(NXP_JEP106.1, NXP_JEP106.0)),
        chip_detection: Vec::new(),
        generated_from_pack: false,
        pack_file_release: None,
        variants: vec![chip],
        flash_algorithms: vec![algorithm],
        source: TargetDescriptionSource::External,
    }
}

/// The whole target description as YAML: probe-rs' own serialisation of [`family`] (the
/// flash algorithm's code as base64), with its hex numbers unquoted.
pub fn yaml(blob: &AlgoBlob, description: &str) -> Result<String, String> {
    let body = yaml_serde::to_string(&family(blob, description))
        .map_err(|e| format!("cannot write the target description: {e}"))?;
    Ok(format!(
        "# LPC1754 target description for probe-rs, generated by `cargo xtask flash` from the\n\
         # flash algorithm in xtask/flash-algo. Do not edit: rebuilt on every flash.\n{}",
        unquote_hex(&body)
    ))
}

/// probe-rs-target serialises its numbers as hex strings ('0x1000'), but reads them back
/// only as YAML integers (0x1000); its own generator (`target-gen`) unquotes them the same
/// way.
fn unquote_hex(yaml: &str) -> String {
    let mut out = String::with_capacity(yaml.len());
    for line in yaml.lines() {
        let quoted = line
            .rsplit_once(" '0x")
            .and_then(|(head, rest)| Some((head, rest.strip_suffix('\'')?)))
            .filter(|(_, digits)| digits.chars().all(|c| c.is_ascii_hexdigit()));
        match quoted {
            Some((head, digits)) => {
                out.push_str(head);
                out.push_str(" 0x");
                out.push_str(digits);
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// Loads `yaml` the way `probe-rs --chip-description-path` does (yaml_serde into
/// probe-rs-target's `ChipFamily`, then `validate()`), and checks that the flash algorithm
/// fits the RAM below the IAP ROM's area however probe-rs lays out its buffers and stack.
pub fn check(yaml: &str) -> Result<ChipFamily, String> {
    let family: ChipFamily =
        yaml_serde::from_str(yaml).map_err(|e| format!("probe-rs cannot parse it: {e}"))?;
    family
        .validate()
        .map_err(|e| format!("probe-rs rejects it: {e}"))?;
    let algo = family
        .flash_algorithms
        .iter()
        .find(|a| a.name == ALGORITHM)
        .ok_or("the flash algorithm is missing")?;
    // probe-rs: 4-byte header below load_address, code, then (double) page buffers and the
    // stack after them, each 8-byte aligned; all of it must stay below the IAP ROM's RAM.
    let load = algo.load_address.ok_or("no load_address")?;
    let code_end = (load + algo.instructions.len() as u64).next_multiple_of(8);
    let top = code_end
        + 2 * u64::from(algo.flash_properties.page_size)
        + u64::from(algo.stack_size.unwrap_or(STACK_SIZE))
        + 8;
    if load < RAM.start + 4 || top > algo_ram_end() {
        return Err(format!(
            "the algorithm with buffers and stack spans {load:#x}..{top:#x}, outside {:#x}..{:#x}",
            RAM.start + 4,
            algo_ram_end()
        ));
    }
    Ok(family)
}

#[cfg(test)]
mod tests {
    use super::*;
    use probe_rs_target::{MemoryRegion, SectorDescription};

    fn sections() -> Vec<AllocSection> {
        vec![
            AllocSection {
                name: ".text".into(),
                addr: 0x1000_0020,
                size: 0x102,
                data: Some((0..0x102).map(|i| i as u8).collect()),
            },
            AllocSection {
                name: ".data".into(),
                addr: 0x1000_0124,
                size: 4,
                data: Some(vec![0xAA; 4]),
            },
            AllocSection {
                name: ".bss".into(),
                addr: 0x1000_0128,
                size: 6,
                data: None,
            },
        ]
    }

    fn symbols() -> HashMap<String, u64> {
        [
            (LOAD_SYMBOL, 0x1000_0020),
            ("Init", 0x1000_0021),
            ("UnInit", 0x1000_0041),
            ("EraseSector", 0x1000_0061),
            ("EraseChip", 0x1000_0081),
            ("ProgramPage", 0x1000_00A1),
            ("Verify", 0x1000_00C1),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
    }

    #[test]
    fn assembles_code_data_and_zeroed_bss_at_the_load_address() {
        let blob = assemble(&sections(), &symbols()).unwrap();
        assert_eq!(blob.load_address, 0x1000_0020);
        assert_eq!(blob.instructions.len(), 0x110); // 0x10E rounded up to words
        assert_eq!(
            &blob.instructions[..0x102],
            &sections()[0].data.clone().unwrap()[..]
        );
        assert_eq!(&blob.instructions[0x102..0x104], &[0, 0]); // alignment gap
        assert_eq!(&blob.instructions[0x104..0x108], &[0xAA; 4]);
        assert!(blob.instructions[0x108..].iter().all(|&b| b == 0));
        assert_eq!(blob.pc_init, 0x1);
        assert_eq!(blob.pc_uninit, 0x21);
        assert_eq!(blob.pc_erase_sector, 0x41);
        assert_eq!(blob.pc_erase_all, 0x61);
        assert_eq!(blob.pc_program_page, 0x81);
        assert_eq!(blob.pc_verify, 0xA1);
        assert_eq!(blob.data_section_offset, 0x104);
    }

    #[test]
    fn refuses_broken_elves() {
        let mut s = symbols();
        s.remove("ProgramPage");
        let e = assemble(&sections(), &s).unwrap_err();
        assert!(e.contains("ProgramPage"), "{e}");
        let mut s = symbols();
        s.insert("Init".into(), 0x1000_0020); // even: not Thumb
        assert!(assemble(&sections(), &s).unwrap_err().contains("Thumb"));
        let mut s = symbols();
        s.insert("Verify".into(), 0x1000_0125); // in .data
        assert!(assemble(&sections(), &s).is_err());
        let mut s = symbols();
        s.remove(LOAD_SYMBOL);
        assert!(assemble(&sections(), &s).unwrap_err().contains(LOAD_SYMBOL));
        let mut s = symbols();
        s.insert(LOAD_SYMBOL.into(), 0x1000_0040);
        assert!(assemble(&sections(), &s).unwrap_err().contains("below"));
        assert!(assemble(&[], &symbols()).is_err());
    }

    #[test]
    fn hex_numbers_are_unquoted_and_nothing_else() {
        let y = "a: '0x15'\n  - size: '0x1000'\nname: '0xZZ'\nd: 'x 0x1'\n";
        assert_eq!(
            unquote_hex(y),
            "a: 0x15\n  - size: 0x1000\nname: '0xZZ'\nd: 'x 0x1'\n"
        );
    }

    #[test]
    fn probe_rs_loads_the_description() {
        let blob = assemble(&sections(), &symbols()).unwrap();
        let text = yaml(&blob, "LPC1754 IAP flash algorithm (test)").unwrap();
        let family = check(&text).unwrap();
        assert_eq!(family.name, "LPC1754");
        let m = family.manufacturer.unwrap();
        assert_eq!((m.id, m.cc), (0x15, 0));
        assert_eq!(family.variants.len(), 1);
        let chip = &family.variants[0];
        assert_eq!(chip.name, "LPC1754");
        assert_eq!(chip.flash_algorithms, ["lpc1754-iap"]);
        assert_eq!(chip.cores[0].core_type, probe_rs_target::CoreType::Armv7m);
        let ranges: Vec<(char, std::ops::Range<u64>)> = chip
            .memory_map
            .iter()
            .map(|r| match r {
                MemoryRegion::Nvm(n) => ('N', n.range.clone()),
                MemoryRegion::Ram(r) => ('R', r.range.clone()),
                MemoryRegion::Generic(g) => ('G', g.range.clone()),
            })
            .collect();
        assert_eq!(
            ranges,
            [
                ('N', 0..0x2_0000),
                ('R', 0x1000_0000..0x1000_3FE0),
                ('G', 0x1000_3FE0..0x1000_4000),
                ('R', 0x2007_C000..0x2008_0000),
            ]
        );
        let algo = &family.flash_algorithms[0];
        assert_eq!(algo.instructions, blob.instructions);
        assert_eq!(algo.load_address, Some(0x1000_0020));
        assert_eq!(algo.pc_init, Some(0x1));
        assert_eq!(algo.pc_uninit, Some(0x21));
        assert_eq!(algo.pc_erase_sector, 0x41);
        assert_eq!(algo.pc_erase_all, Some(0x61));
        assert_eq!(algo.pc_program_page, 0x81);
        assert_eq!(algo.pc_verify, Some(0xA1));
        assert_eq!(algo.data_section_offset, 0x104);
        assert_eq!(algo.stack_size, Some(STACK_SIZE));
        assert!(algo.default);
        let p = &algo.flash_properties;
        assert_eq!(p.address_range, 0..0x2_0000);
        assert_eq!(p.page_size, 1024);
        assert_eq!(p.erased_byte_value, 0xFF);
        assert_eq!(
            p.sectors,
            [
                SectorDescription {
                    size: 0x1000,
                    address: 0
                },
                SectorDescription {
                    size: 0x8000,
                    address: 0x1_0000
                }
            ]
        );
        assert_eq!(algo.cores, ["main"]);
    }

    #[test]
    fn check_refuses_what_probe_rs_would_refuse_or_misplace() {
        let blob = assemble(&sections(), &symbols()).unwrap();
        let good = yaml(&blob, "t").unwrap();
        // A field probe-rs does not know (deny_unknown_fields).
        let bad = good.replace("  default: true\n", "  default: true\n  colour: blue\n");
        assert!(check(&bad).unwrap_err().contains("parse"));
        // A variant naming an algorithm the family lacks.
        let bad = good.replace("  - lpc1754-iap", "  - other-algo");
        assert!(check(&bad).unwrap_err().contains("rejects"));
        // An algorithm so big that buffers and stack would reach the IAP ROM's RAM.
        let mut big = blob.clone();
        big.instructions = vec![0; 12 * 1024];
        assert!(check(&yaml(&big, "t").unwrap())
            .unwrap_err()
            .contains("outside"));
        assert_eq!(PAGE_SIZE, 1024);
        assert!(flash_algo::iap::COPY_SIZES.contains(&PAGE_SIZE));
    }
}
