//! A model of the LPC1754's 128 KB flash and its IAP ROM on the host (feature `model`), for
//! tests of code that programs flash and for simulators of the chip, whose IAP entry hook
//! hands the command words (and the RAM bytes [`Command::source`] names) to
//! [`FlashModel::call`].
//!
//! It keeps the flash bytes and which sectors are prepared, enforces the ROM's rules
//! (prepare before erase and copy, 256-byte aligned destinations, word-aligned RAM sources,
//! the four copy sizes, sector numbers, sources in RAM), programs like flash does (bits only
//! go from 1 to 0), and logs every command. Misuse that the real ROM would not report but
//! that breaks on a chip (a CPU clock of 0 or other than the one set, a copy source in the
//! 32 bytes of RAM the ROM uses) is recorded in [`FlashModel::violations`].
//!
//! Power cuts: [`FlashModel::cut_power_at`] interrupts the n-th erase or program step (one
//! erase or copy command each) with a [`CutEffect`]; after it the flash is frozen (every
//! command answers [`Status::Busy`] and changes nothing) until [`FlashModel::power_on`], the
//! reboot.

use crate::iap::{
    Command, IapEntry, Status, COPY_DST_ALIGN, COPY_SIZES, IAP_RAM_END, IAP_RAM_START,
    LPC1754_PART_ID, WORD,
};
use crate::sector::{sector_of, sector_size, sector_start, FLASH_SIZE, LAST_SECTOR};
use std::format;
use std::string::String;
use std::vec::Vec;

/// RAM the ROM accepts as a copy source: the local SRAM and the AHB SRAM of the LPC1754.
pub const RAM: [(u32, u32); 2] = [(0x1000_0000, 0x1000_4000), (0x2007_C000, 0x2008_4000)];

/// Where the model says a host buffer lies for the ROM ([`IapEntry::ram_address`]): in the
/// local SRAM, clear of the ROM's 32 bytes for any copy size.
pub const RAM_OPERAND: u32 = 0x1000_1000;

/// What an erase or program step did when the power failed during it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CutEffect {
    /// Nothing: the flash is as before the step.
    Nothing,
    /// The first half: an erase cleared the first half of its range, a program wrote the
    /// first half of its bytes.
    Half,
    /// All of it: the step finished, the power failed before the ROM returned.
    All,
}

impl CutEffect {
    /// Every effect, for tests that try them all.
    pub const ALL: [CutEffect; 3] = [CutEffect::Nothing, CutEffect::Half, CutEffect::All];
}

/// A failed command: its status and result words 1 and 2.
struct Fail(Status, [u32; 2]);

impl From<Status> for Fail {
    fn from(s: Status) -> Self {
        Self(s, [0, 0])
    }
}

/// The flash and the ROM.
#[derive(Debug, Clone)]
pub struct FlashModel {
    flash: Vec<u8>,
    prepared: u32,
    log: Vec<[u32; 5]>,
    part_id: u32,
    fail: Option<(u32, Status)>,
    cclk_khz: Option<u32>,
    violations: Vec<String>,
    steps: u64,
    cut: Option<(u64, CutEffect)>,
    powered: bool,
}

impl Default for FlashModel {
    fn default() -> Self {
        Self::new()
    }
}

impl FlashModel {
    /// A blank LPC1754 (every byte 0xFF).
    pub fn new() -> Self {
        Self {
            flash: std::vec![0xFF; FLASH_SIZE as usize],
            prepared: 0,
            log: Vec::new(),
            part_id: LPC1754_PART_ID,
            fail: None,
            cclk_khz: None,
            violations: Vec::new(),
            steps: 0,
            cut: None,
            powered: true,
        }
    }

    /// Another part.
    pub fn with_part_id(mut self, id: u32) -> Self {
        self.part_id = id;
        self
    }

    /// Every later `command` answers `status` (and does nothing).
    pub fn failing(mut self, command: u32, status: Status) -> Self {
        self.fail = Some((command, status));
        self
    }

    /// The CPU clock the chip runs at: an erase or copy told another one is a violation
    /// (the ROM would time its pulses wrong).
    pub fn with_cclk_khz(mut self, khz: u32) -> Self {
        self.cclk_khz = Some(khz);
        self
    }

    /// The flash bytes.
    pub fn flash(&self) -> &[u8] {
        &self.flash
    }

    /// Writes `bytes` at `addr` as a programmer would before the test (no ROM rules; the
    /// bytes replace what is there). Bytes outside the flash are dropped.
    pub fn load(&mut self, addr: u32, bytes: &[u8]) {
        let start = (addr as usize).min(self.flash.len());
        let end = start.saturating_add(bytes.len()).min(self.flash.len());
        self.flash[start..end].copy_from_slice(&bytes[..end - start]);
    }

    /// The commands so far.
    pub fn log(&self) -> &[[u32; 5]] {
        &self.log
    }

    /// Misuse seen so far (empty when the caller followed the rules).
    pub fn violations(&self) -> &[String] {
        &self.violations
    }

    /// Erase and program steps started so far (cut or not).
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Cuts the power during erase/program step `step` (0 = the next one started after the
    /// model's creation or last [`power_on`](Self::power_on)), with `effect`.
    pub fn cut_power_at(&mut self, step: u64, effect: CutEffect) {
        self.cut = Some((self.steps + step, effect));
    }

    /// False from a power cut until [`power_on`](Self::power_on).
    pub fn powered(&self) -> bool {
        self.powered
    }

    /// Power back (a reboot): nothing is prepared, no cut is pending.
    pub fn power_on(&mut self) {
        self.powered = true;
        self.prepared = 0;
        self.cut = None;
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

    fn check_clock(&mut self, command: &[u32; 5], khz: u32) {
        if khz == 0 {
            self.violations.push(format!(
                "{command:?}: CPU clock 0 kHz (the ROM cannot time the flash pulses)"
            ));
        } else if let Some(real) = self.cclk_khz.filter(|real| *real != khz) {
            self.violations.push(format!(
                "{command:?}: told the ROM {khz} kHz, the CPU runs at {real} kHz"
            ));
        }
    }

    /// The byte range of sectors `first..=last`.
    fn span(first: u32, last: u32) -> (usize, usize) {
        let start = sector_start(first).unwrap_or(0) as usize;
        let end = sector_start(last)
            .zip(sector_size(last))
            .map_or(start, |(s, n)| (s + n) as usize);
        (start, end)
    }

    /// Counts a flash-changing step; the part of it to carry out (`None`: all of it).
    fn step(&mut self) -> Option<CutEffect> {
        let n = self.steps;
        self.steps += 1;
        match self.cut {
            Some((at, effect)) if at == n => {
                self.powered = false;
                Some(effect)
            }
            _ => None,
        }
    }

    fn run(&mut self, c: &[u32; 5], source: &[u8]) -> Result<[u32; 2], Fail> {
        if !self.powered {
            return Err(Status::Busy.into());
        }
        if let Some((code, status)) = self.fail {
            if code == c[0] {
                return Err(status.into());
            }
        }
        match Command::from(c[0]) {
            Command::PrepareSectors => {
                self.prepared |= Self::sectors(c[1], c[2]).ok_or(Status::InvalidSector)?;
                Ok([0, 0])
            }
            Command::EraseSectors => {
                let mask = Self::sectors(c[1], c[2]).ok_or(Status::InvalidSector)?;
                self.check_clock(c, c[3]);
                if self.prepared & mask != mask {
                    return Err(Status::SectorNotPrepared.into());
                }
                let (start, end) = Self::span(c[1], c[2]);
                let end = match self.step() {
                    None | Some(CutEffect::All) => end,
                    Some(CutEffect::Half) => start + (end - start) / 2,
                    Some(CutEffect::Nothing) => start,
                };
                self.flash[start..end].fill(0xFF);
                self.prepared &= !mask;
                if self.powered {
                    Ok([0, 0])
                } else {
                    Err(Status::Busy.into())
                }
            }
            Command::CopyRamToFlash => {
                let (dst, src, len) = (c[1], c[2], c[3]);
                self.check_clock(c, c[4]);
                if dst % COPY_DST_ALIGN != 0 {
                    return Err(Status::DstAddrError.into());
                }
                if src % WORD != 0 {
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
                if src < IAP_RAM_END && src + len > IAP_RAM_START {
                    self.violations.push(format!(
                        "{c:?}: copy source overlaps 0x1000_3FE0..0x1000_3FFF, which the ROM uses"
                    ));
                }
                if source.len() != len as usize {
                    self.violations.push(format!(
                        "{c:?}: {} source bytes given for a count of {len}",
                        source.len()
                    ));
                    return Err(Status::CountError.into());
                }
                let first = sector_of(dst).ok_or(Status::DstAddrNotMapped)?;
                let last = sector_of(dst + len - 1).ok_or(Status::DstAddrNotMapped)?;
                let mask = Self::sectors(first, last).ok_or(Status::InvalidSector)?;
                if self.prepared & mask != mask {
                    return Err(Status::SectorNotPrepared.into());
                }
                let n = match self.step() {
                    None | Some(CutEffect::All) => source.len(),
                    Some(CutEffect::Half) => source.len() / 2,
                    Some(CutEffect::Nothing) => 0,
                };
                let at = dst as usize;
                for (f, s) in self.flash[at..at + n].iter_mut().zip(source) {
                    *f &= *s;
                }
                self.prepared &= !mask;
                if self.powered {
                    Ok([0, 0])
                } else {
                    Err(Status::Busy.into())
                }
            }
            Command::BlankCheckSectors => {
                Self::sectors(c[1], c[2]).ok_or(Status::InvalidSector)?;
                let (start, end) = Self::span(c[1], c[2]);
                for a in (start..end).step_by(4) {
                    let w = &self.flash[a..a + 4];
                    let word = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
                    if word != u32::MAX {
                        return Err(Fail(Status::SectorNotBlank, [(a - start) as u32, word]));
                    }
                }
                Ok([0, 0])
            }
            Command::ReadPartId => Ok([self.part_id, 0]),
            Command::Compare => {
                let (dst, src, len) = (c[1], c[2], c[3]);
                if dst % WORD != 0 {
                    return Err(Status::DstAddrError.into());
                }
                if src % WORD != 0 {
                    return Err(Status::SrcAddrError.into());
                }
                if len % WORD != 0 {
                    return Err(Status::CountError.into());
                }
                if dst.checked_add(len).is_none_or(|e| e > FLASH_SIZE) {
                    return Err(Status::DstAddrNotMapped.into());
                }
                if !Self::in_ram(src, len) {
                    return Err(Status::SrcAddrNotMapped.into());
                }
                if source.len() != len as usize {
                    self.violations.push(format!(
                        "{c:?}: {} source bytes given for a count of {len}",
                        source.len()
                    ));
                    return Err(Status::CountError.into());
                }
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

impl IapEntry for FlashModel {
    fn call(&mut self, command: &[u32; 5], source: &[u8]) -> [u32; 5] {
        self.log.push(*command);
        match self.run(command, source) {
            Ok([r1, r2]) => [0, r1, r2, 0, 0],
            Err(Fail(status, [r1, r2])) => [u32::from(status), r1, r2, 0, 0],
        }
    }

    fn ram_address(&self, _buf: &[u8]) -> u32 {
        RAM_OPERAND
    }

    fn read_flash(&self, addr: u32, buf: &mut [u8]) {
        for (i, b) in buf.iter_mut().enumerate() {
            *b = (addr as usize)
                .checked_add(i)
                .and_then(|a| self.flash.get(a))
                .copied()
                .unwrap_or(0xFF);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::iap::Iap;

    const SRC: u32 = 0x1000_0400;

    #[test]
    fn rules_of_the_rom() {
        let mut iap = Iap::new(FlashModel::new(), 4_000);
        // Copy without prepare, to an unaligned or unmapped destination, from outside RAM.
        let data = [0u8; 256];
        assert_eq!(
            iap.copy_ram_to_flash(0x3000, SRC, &data)
                .unwrap_err()
                .status,
            Status::SectorNotPrepared
        );
        iap.prepare(3, 3).unwrap();
        assert_eq!(
            iap.copy_ram_to_flash(0x3004, SRC, &data)
                .unwrap_err()
                .status,
            Status::DstAddrError
        );
        assert_eq!(
            iap.copy_ram_to_flash(0x3000, SRC + 2, &data)
                .unwrap_err()
                .status,
            Status::SrcAddrError
        );
        assert_eq!(
            iap.copy_ram_to_flash(0x3000, 0x0000_1000, &data)
                .unwrap_err()
                .status,
            Status::SrcAddrNotMapped
        );
        assert_eq!(
            iap.copy_ram_to_flash(0x3000, SRC, &data[..128])
                .unwrap_err()
                .status,
            Status::CountError
        );
        assert_eq!(
            iap.copy_ram_to_flash(0x2_0000, SRC, &data)
                .unwrap_err()
                .status,
            Status::DstAddrNotMapped
        );
        // A prepare lasts for one erase or copy.
        iap.copy_ram_to_flash(0x3000, SRC, &data).unwrap();
        assert_eq!(
            iap.copy_ram_to_flash(0x3100, SRC, &data)
                .unwrap_err()
                .status,
            Status::SectorNotPrepared
        );
        assert!(iap.entry().violations().is_empty());
    }

    #[test]
    fn program_erase_and_verify_name_their_sectors() {
        let mut iap = Iap::new(FlashModel::new(), 4_000);
        let page = [0x11u8; 1024];
        // 0x2F00..0x3300 spans sectors 2 and 3: both are prepared.
        iap.program(0x2F00, &page).unwrap();
        assert_eq!(iap.verify(0x2F00, &page).unwrap(), None);
        assert_eq!(iap.verify(0x2F00, &[0x12; 1024]).unwrap(), Some(0));
        iap.erase_sectors(2, 3).unwrap();
        assert_eq!(
            iap.entry().log(),
            &[
                [50, 2, 3, 0, 0],
                [51, 0x2F00, RAM_OPERAND, 1024, 4_000],
                [56, 0x2F00, RAM_OPERAND, 1024, 0],
                [56, 0x2F00, RAM_OPERAND, 1024, 0],
                [50, 2, 3, 0, 0],
                [52, 2, 3, 4_000, 0],
            ]
        );
        assert_eq!(
            iap.program(0x1_FF00, &page).unwrap_err().status,
            Status::DstAddrNotMapped
        );
    }

    #[test]
    fn programming_only_clears_bits() {
        let mut iap = Iap::new(FlashModel::new(), 4_000);
        iap.prepare(2, 2).unwrap();
        iap.copy_ram_to_flash(0x2000, SRC, &[0xF0; 256]).unwrap();
        iap.prepare(2, 2).unwrap();
        iap.copy_ram_to_flash(0x2000, SRC, &[0x3C; 256]).unwrap();
        assert!(iap.entry().flash()[0x2000..0x2100]
            .iter()
            .all(|b| *b == 0x30));
        let mut word = [0u8; 4];
        iap.read_flash(0x20FE, &mut word);
        assert_eq!(word, [0x30, 0x30, 0xFF, 0xFF]);
        iap.read_flash(0x1_FFFE, &mut word);
        assert_eq!(word, [0xFF; 4], "outside the flash reads erased");
    }

    #[test]
    fn clock_and_iap_ram_violations_are_recorded() {
        let mut iap = Iap::new(FlashModel::new().with_cclk_khz(100_000), 4_000);
        iap.prepare(2, 2).unwrap();
        iap.erase(2, 2).unwrap();
        iap.prepare(2, 2).unwrap();
        iap.copy_ram_to_flash(0x2000, 0x1000_3F00, &[0; 256])
            .unwrap();
        let v = iap.entry().violations();
        assert_eq!(v.len(), 3, "{v:?}");
        assert!(v[0].contains("4000 kHz") && v[0].contains("100000 kHz"));
        assert!(v[2].contains("which the ROM uses"));
        let mut zero = Iap::new(FlashModel::new(), 0);
        zero.prepare(1, 1).unwrap();
        zero.erase(1, 1).unwrap();
        assert!(zero.entry().violations()[0].contains("clock 0"));
    }

    #[test]
    fn power_cuts_freeze_the_flash_until_power_on() {
        for (effect, erased, programmed) in [
            (CutEffect::Nothing, 0usize, 0usize),
            (CutEffect::Half, 0x800, 128),
            (CutEffect::All, 0x1000, 256),
        ] {
            let mut model = FlashModel::new();
            model.load(0x4000, &[0u8; 0x1000]);
            let mut iap = Iap::new(model, 4_000);
            iap.entry_mut().cut_power_at(0, effect);
            iap.prepare(4, 4).unwrap();
            assert_eq!(iap.erase(4, 4).unwrap_err().status, Status::Busy);
            let f = iap.entry().flash();
            assert!(f[0x4000..0x4000 + erased].iter().all(|b| *b == 0xFF));
            assert!(f[0x4000 + erased..0x5000].iter().all(|b| *b == 0));
            // Frozen: nothing works, nothing changes.
            assert_eq!(iap.prepare(4, 4).unwrap_err().status, Status::Busy);
            assert!(!iap.entry().powered());
            iap.entry_mut().power_on();
            assert_eq!(iap.entry().steps(), 1);

            let mut iap = Iap::new(FlashModel::new(), 4_000);
            iap.entry_mut().cut_power_at(1, effect);
            iap.prepare(5, 5).unwrap();
            iap.copy_ram_to_flash(0x5000, SRC, &[0; 256]).unwrap();
            iap.prepare(5, 5).unwrap();
            assert!(iap.copy_ram_to_flash(0x5100, SRC, &[0; 256]).is_err());
            let f = iap.entry().flash();
            assert!(f[0x5100..0x5100 + programmed].iter().all(|b| *b == 0));
            assert!(f[0x5100 + programmed..0x5200].iter().all(|b| *b == 0xFF));
            assert_eq!(iap.entry().steps(), 2);
        }
    }
}
