//! A model of the LPC17xx IAP ROM on a 128 KB flash, for the host tests: it keeps the flash
//! bytes and which sectors are prepared, enforces the ROM's rules (prepare before erase and
//! copy, 256-byte destinations, word-aligned RAM sources, the four copy sizes, sector
//! numbers), programs like flash does (bits only go from 1 to 0) and logs every command.

use crate::iap::{IapEntry, Status, COPY_DST_ALIGN, COPY_SIZES, IAP_RAM_START, LPC1754_PART_ID};
use crate::sector::{sector_of, sector_size, sector_start, FLASH_SIZE, LAST_SECTOR};
use std::vec::Vec;

/// RAM the ROM accepts as a copy source: local SRAM and the AHB SRAM.
const RAM: [(u32, u32); 2] = [(0x1000_0000, 0x1000_4000), (0x2007_C000, 0x2008_4000)];

/// A failed command: its status and result words 1 and 2.
struct Fail(Status, [u32; 2]);

impl From<Status> for Fail {
    fn from(s: Status) -> Self {
        Self(s, [0, 0])
    }
}

pub struct MockIap {
    pub flash: Vec<u8>,
    prepared: u32,
    log: Vec<[u32; 5]>,
    part_id: u32,
    fail: Option<(u32, Status)>,
}

impl MockIap {
    /// A blank LPC1754.
    pub fn new() -> Self {
        Self {
            flash: std::vec![0xFF; FLASH_SIZE as usize],
            prepared: 0,
            log: Vec::new(),
            part_id: LPC1754_PART_ID,
            fail: None,
        }
    }

    /// Another part.
    pub fn with_part_id(mut self, id: u32) -> Self {
        self.part_id = id;
        self
    }

    /// Every later `command` answers `status`.
    pub fn failing(mut self, command: u32, status: Status) -> Self {
        self.fail = Some((command, status));
        self
    }

    /// The commands so far.
    pub fn log(&self) -> &[[u32; 5]] {
        &self.log
    }

    fn sectors(start: u32, end: u32) -> Option<u32> {
        if start > end || end > LAST_SECTOR {
            return None;
        }
        Some((start..=end).fold(0, |m, s| m | 1 << s))
    }

    fn in_ram(addr: u32, len: u32) -> bool {
        RAM.iter()
            .any(|&(s, e)| addr >= s && addr.checked_add(len).is_some_and(|end| end <= e))
    }

    fn run(&mut self, c: &[u32; 5], source: &[u8]) -> Result<[u32; 2], Fail> {
        if let Some((code, status)) = self.fail {
            if code == c[0] {
                return Err(status.into());
            }
        }
        match c[0] {
            50 => {
                self.prepared |= Self::sectors(c[1], c[2]).ok_or(Status::InvalidSector)?;
                Ok([0, 0])
            }
            52 => {
                let mask = Self::sectors(c[1], c[2]).ok_or(Status::InvalidSector)?;
                assert!(c[3] > 0, "erase without a CPU clock");
                if self.prepared & mask != mask {
                    return Err(Status::SectorNotPrepared.into());
                }
                let start = sector_start(c[1]).unwrap() as usize;
                let end = (sector_start(c[2]).unwrap() + sector_size(c[2]).unwrap()) as usize;
                self.flash[start..end].fill(0xFF);
                self.prepared &= !mask;
                Ok([0, 0])
            }
            51 => {
                let (dst, src, len) = (c[1], c[2], c[3]);
                assert!(c[4] > 0, "copy without a CPU clock");
                if dst % COPY_DST_ALIGN != 0 {
                    return Err(Status::DstAddrError.into());
                }
                if src % 4 != 0 {
                    return Err(Status::SrcAddrError.into());
                }
                if !COPY_SIZES.contains(&len) {
                    return Err(Status::CountError.into());
                }
                if dst.checked_add(len).is_none_or(|e| e > FLASH_SIZE) {
                    return Err(Status::DstAddrNotMapped.into());
                }
                if !Self::in_ram(src, len) {
                    return Err(Status::SrcAddrNotMapped.into());
                }
                assert!(
                    src + len <= IAP_RAM_START || src >= IAP_RAM_START + 32,
                    "copy source overlaps the RAM the IAP ROM uses"
                );
                assert_eq!(source.len() as u32, len, "source bytes and count differ");
                let first = sector_of(dst).unwrap();
                let last = sector_of(dst + len - 1).unwrap();
                let mask = Self::sectors(first, last).unwrap();
                if self.prepared & mask != mask {
                    return Err(Status::SectorNotPrepared.into());
                }
                for (f, s) in self.flash[dst as usize..(dst + len) as usize]
                    .iter_mut()
                    .zip(source)
                {
                    *f &= *s;
                }
                self.prepared &= !mask;
                Ok([0, 0])
            }
            53 => {
                Self::sectors(c[1], c[2]).ok_or(Status::InvalidSector)?;
                let start = sector_start(c[1]).unwrap();
                let end = sector_start(c[2]).unwrap() + sector_size(c[2]).unwrap();
                for a in (start..end).step_by(4) {
                    let w = &self.flash[a as usize..a as usize + 4];
                    let word = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
                    if word != u32::MAX {
                        return Err(Fail(Status::SectorNotBlank, [a - start, word]));
                    }
                }
                Ok([0, 0])
            }
            54 => Ok([self.part_id, 0]),
            56 => {
                let (dst, src, len) = (c[1], c[2], c[3]);
                if dst % 4 != 0 {
                    return Err(Status::DstAddrError.into());
                }
                if src % 4 != 0 {
                    return Err(Status::SrcAddrError.into());
                }
                if len % 4 != 0 {
                    return Err(Status::CountError.into());
                }
                if dst.checked_add(len).is_none_or(|e| e > FLASH_SIZE) {
                    return Err(Status::DstAddrNotMapped.into());
                }
                if !Self::in_ram(src, len) {
                    return Err(Status::SrcAddrNotMapped.into());
                }
                assert_eq!(source.len() as u32, len, "source bytes and count differ");
                let flash = &self.flash[dst as usize..(dst + len) as usize];
                for (i, (f, s)) in flash.chunks(4).zip(source.chunks(4)).enumerate() {
                    if f != s {
                        return Err(Fail(Status::CompareError, [4 * i as u32, 0]));
                    }
                }
                Ok([0, 0])
            }
            _ => Err(Status::InvalidCommand.into()),
        }
    }
}

impl IapEntry for MockIap {
    fn call(&mut self, command: &[u32; 5], source: &[u8]) -> [u32; 5] {
        self.log.push(*command);
        match self.run(command, source) {
            Ok([r1, r2]) => [0, r1, r2, 0, 0],
            Err(Fail(status, [r1, r2])) => [u32::from(status), r1, r2, 0, 0],
        }
    }

    fn read_flash_word(&self, addr: u32) -> u32 {
        let at = addr as usize;
        match self.flash.get(at..at + 4) {
            Some(b) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            None => u32::MAX,
        }
    }
}
