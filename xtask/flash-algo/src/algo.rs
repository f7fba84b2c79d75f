//! The sequences behind the CMSIS flash algorithm entry points, on any [`IapEntry`].
//!
//! * `Init`: read part ID (54) as a sanity check: the algorithm only runs on an LPC1754.
//! * `EraseSector(addr)`: prepare (50) + erase (52) + blank check (53) of that one sector.
//! * `EraseChip`: the same over sectors 0..=17.
//! * `ProgramPage(addr, len, buf)`: refuse a write that would leave a CRP lock value at 0x2FC (programming only clears bits: the written word AND the word flash holds), then prepare (50) +
//!   copy RAM to flash (51) straight from probe-rs' buffer when the ROM accepts it as is
//!   (256/512/1024/4096 bytes at a destination aligned to the size, word-aligned buffer), else
//!   in 256-byte pieces through a staging buffer padded with 0xFF.
//! * `Verify(addr, len, buf)`: compare (56); returns `addr + len` or the first bad address.
//!
//! Every entry point returns 0 or an [`ErrorCode`]; [`ErrorCode`]'s `Display` tells a person
//! what a code means (`cargo xtask flash --explain CODE`).

use crate::crp;
use crate::iap::{
    BlankCheck, Iap, IapEntry, IapError, COPY_DST_ALIGN, COPY_SIZES, IAP_RAM_END, IAP_RAM_START,
    LPC1754_PART_ID, WORD,
};
use crate::iap::{Command, Status};
use crate::sector::{in_flash, sector_of, sector_start, LAST_SECTOR};
use core::fmt;

/// Bytes per staged copy: the smallest count the ROM takes.
pub const STAGING_SIZE: usize = 256;

/// A word-aligned RAM buffer for copies the ROM cannot take straight from probe-rs' buffer.
#[derive(Debug, Clone)]
#[repr(C, align(4))]
pub struct Staging {
    /// The bytes (0xFF where the page has none).
    pub bytes: [u8; STAGING_SIZE],
}

impl Default for Staging {
    fn default() -> Self {
        Self {
            bytes: [0xFF; STAGING_SIZE],
        }
    }
}

/// Why an entry point failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// An IAP command failed.
    Iap(IapError),
    /// The range is not inside the 128 KB flash.
    OutOfFlash {
        /// First address.
        addr: u32,
        /// Length.
        len: u32,
    },
    /// EraseSector got an address that is not the first of a sector.
    NotSectorStart(u32),
    /// ProgramPage got a destination that is not on a 256-byte boundary.
    Unaligned(u32),
    /// The RAM buffer overlaps the top 32 bytes of the local SRAM, which the ROM uses.
    BufferInIapRam(u32),
    /// A sector was not blank after its erase.
    NotBlank {
        /// Address of the first word that is not 0xFFFF_FFFF.
        addr: u32,
        /// Its contents.
        contents: u32,
    },
    /// Read part ID returned another part.
    WrongPart(u32),
    /// ProgramPage would write a CRP lock value to 0x2FC (refused unless built with the
    /// `allow-crp-lock` feature).
    CrpLock(u32),
}

impl From<IapError> for Error {
    fn from(e: IapError) -> Self {
        Self::Iap(e)
    }
}

/// Base of the algorithm's own codes; IAP failures are `command * 0x100 + status`
/// (0x3200..=0x3AFF for commands 50..=58).
const OWN_CODES: u32 = 0xA100;

impl Error {
    /// The non-zero code the entry point returns to probe-rs.
    pub fn code(&self) -> u32 {
        match self {
            Self::Iap(e) => (u32::from(e.command) << 8) | (u32::from(e.status) & 0xFF),
            Self::OutOfFlash { .. } => OWN_CODES + 1,
            Self::NotSectorStart(_) => OWN_CODES + 2,
            Self::Unaligned(_) => OWN_CODES + 3,
            Self::BufferInIapRam(_) => OWN_CODES + 4,
            Self::NotBlank { .. } => OWN_CODES + 5,
            Self::WrongPart(_) => OWN_CODES + 6,
            Self::CrpLock(_) => OWN_CODES + 7,
        }
    }
}

/// A code returned by an entry point, explained by its `Display`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ErrorCode(pub u32);

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let code = self.0;
        let (command, status) = (code >> 8, code & 0xFF);
        match code {
            0 => f.write_str("success"),
            c if (50..=58).contains(&command) && c >> 16 == 0 => write!(
                f,
                "IAP {} failed: {}",
                Command::from(command),
                Status::from(status)
            ),
            c if c == OWN_CODES + 1 => f.write_str("address range outside the 128 KB flash"),
            c if c == OWN_CODES + 2 => {
                f.write_str("erase address is not the first address of a sector")
            }
            c if c == OWN_CODES + 3 => f.write_str("program address is not on a 256-byte boundary"),
            c if c == OWN_CODES + 4 => {
                f.write_str("RAM buffer overlaps 0x1000_3FE0..0x1000_3FFF, which the IAP ROM uses")
            }
            c if c == OWN_CODES + 5 => f.write_str("sector not blank after erase"),
            c if c == OWN_CODES + 6 => {
                f.write_str("read part ID did not return 0x25011722: this is not an LPC1754")
            }
            c if c == OWN_CODES + 7 => f.write_str(
                "refused to write a Code Read Protection lock value (CRP1/CRP2/CRP3/NO_ISP) \
                 to 0x2FC (the algorithm was built without allow-crp-lock)",
            ),
            c => write!(f, "unknown flash algorithm code {c:#x}"),
        }
    }
}

/// Checks that `[addr, addr + len)` is flash.
pub fn check_range(addr: u32, len: u32) -> Result<(), Error> {
    if in_flash(addr, len) {
        Ok(())
    } else {
        Err(Error::OutOfFlash { addr, len })
    }
}

fn check_buffer(ram_addr: u32, len: u32) -> Result<(), Error> {
    let end = u64::from(ram_addr) + u64::from(len);
    if u64::from(ram_addr) < u64::from(IAP_RAM_END) && end > u64::from(IAP_RAM_START) {
        Err(Error::BufferInIapRam(ram_addr))
    } else {
        Ok(())
    }
}

/// The flash algorithm: the entry points' logic over an IAP entry point.
#[derive(Debug)]
pub struct FlashAlgo<E> {
    iap: Iap<E>,
    allow_crp_lock: bool,
}

impl<E: IapEntry> FlashAlgo<E> {
    /// `cclk_khz`: the CPU clock while the algorithm runs; `allow_crp_lock`: whether
    /// ProgramPage may write a CRP lock value.
    pub fn new(entry: E, cclk_khz: u32, allow_crp_lock: bool) -> Self {
        Self {
            iap: Iap::new(entry, cclk_khz),
            allow_crp_lock,
        }
    }

    /// The IAP layer (the mock, in tests).
    pub fn iap(&self) -> &Iap<E> {
        &self.iap
    }

    /// `Init`: the part must be an LPC1754.
    pub fn init(&mut self) -> Result<(), Error> {
        match self.iap.read_part_id()? {
            LPC1754_PART_ID => Ok(()),
            other => Err(Error::WrongPart(other)),
        }
    }

    fn erase_sectors(&mut self, first: u32, last: u32) -> Result<(), Error> {
        self.iap.prepare(first, last)?;
        self.iap.erase(first, last)?;
        match self.iap.blank_check(first, last)? {
            BlankCheck::Blank => Ok(()),
            BlankCheck::NotBlank { offset, contents } => Err(Error::NotBlank {
                addr: sector_start(first).unwrap_or(0).wrapping_add(offset),
                contents,
            }),
        }
    }

    /// `EraseSector`: `addr` must be the first address of a sector.
    pub fn erase_sector(&mut self, addr: u32) -> Result<(), Error> {
        check_range(addr, 1)?;
        let sector = sector_of(addr).ok_or(Error::OutOfFlash { addr, len: 1 })?;
        if sector_start(sector) != Some(addr) {
            return Err(Error::NotSectorStart(addr));
        }
        self.erase_sectors(sector, sector)
    }

    /// `EraseChip`: every sector.
    pub fn erase_chip(&mut self) -> Result<(), Error> {
        self.erase_sectors(0, LAST_SECTOR)
    }

    /// `ProgramPage`: `data` sits in RAM at `data_addr`; `staging` (at `staging_addr`) is
    /// used when the ROM cannot copy from there directly.
    pub fn program_page(
        &mut self,
        addr: u32,
        data: &[u8],
        data_addr: u32,
        staging: &mut Staging,
        staging_addr: u32,
    ) -> Result<(), Error> {
        let len = u32::try_from(data.len()).map_err(|_| Error::OutOfFlash {
            addr,
            len: u32::MAX,
        })?;
        check_range(addr, len)?;
        if addr % COPY_DST_ALIGN != 0 {
            return Err(Error::Unaligned(addr));
        }
        let current = self.iap.entry().read_flash_word(crp::CRP_ADDRESS);
        if let Some(word) = crp::lock_value_resulting(addr, data, current) {
            if !self.allow_crp_lock {
                return Err(Error::CrpLock(word));
            }
        }
        if len == 0 {
            return Ok(());
        }
        if COPY_SIZES.contains(&len) && addr % len == 0 && data_addr % WORD == 0 {
            // One copy; an aligned power-of-two piece never crosses a sector boundary.
            check_buffer(data_addr, len)?;
            let sector = sector_of(addr).ok_or(Error::OutOfFlash { addr, len })?;
            self.iap.prepare(sector, sector)?;
            self.iap.copy_ram_to_flash(addr, data_addr, data)?;
            return Ok(());
        }
        check_buffer(staging_addr, STAGING_SIZE as u32)?;
        let mut dst = addr;
        for piece in data.chunks(STAGING_SIZE) {
            staging.bytes.fill(0xFF);
            staging.bytes[..piece.len()].copy_from_slice(piece);
            let sector = sector_of(dst).ok_or(Error::OutOfFlash { addr: dst, len })?;
            self.iap.prepare(sector, sector)?;
            self.iap
                .copy_ram_to_flash(dst, staging_addr, &staging.bytes)?;
            dst += STAGING_SIZE as u32;
        }
        Ok(())
    }

    /// `Verify`: `addr + len` when the flash holds `data` (in RAM at `data_addr`), otherwise
    /// the address of the first word that differs (`addr` when the check itself failed).
    pub fn verify(&mut self, addr: u32, data: &[u8], data_addr: u32) -> u32 {
        let Ok(len) = u32::try_from(data.len()) else {
            return addr;
        };
        if len == 0 {
            return addr;
        }
        if check_range(addr, len).is_err()
            || addr % WORD != 0
            || len % WORD != 0
            || data_addr % WORD != 0
        {
            return addr;
        }
        match self.iap.compare(addr, data_addr, data) {
            Ok(None) => addr + len,
            Ok(Some(offset)) => addr + offset.min(len - WORD),
            Err(_) => addr,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::crp::{CRP1, CRP3, NO_ISP};
    use crate::sector::FLASH_SIZE;
    use lpc17xx_iap::model::FlashModel as MockIap;
    use std::string::ToString;

    const BUF: u32 = 0x1000_1000;
    const STAGE: u32 = 0x1000_0800;
    const CCLK: u32 = 4_000;

    fn algo() -> FlashAlgo<MockIap> {
        FlashAlgo::new(MockIap::new(), CCLK, false)
    }

    fn log(a: &FlashAlgo<MockIap>) -> std::vec::Vec<[u32; 5]> {
        a.iap().entry().log().to_vec()
    }

    fn flash(a: &FlashAlgo<MockIap>) -> &[u8] {
        a.iap().entry().flash()
    }

    fn pattern(len: usize, seed: u8) -> std::vec::Vec<u8> {
        (0..len)
            .map(|i| (i as u8).wrapping_mul(7).wrapping_add(seed))
            .collect()
    }

    #[test]
    fn init_reads_the_part_id() {
        let mut a = algo();
        a.init().unwrap();
        assert_eq!(log(&a), [[54, 0, 0, 0, 0]]);
        let mut other = FlashAlgo::new(MockIap::new().with_part_id(0x2601_3F37), CCLK, false);
        assert_eq!(other.init(), Err(Error::WrongPart(0x2601_3F37)));
        let mut broken = FlashAlgo::new(MockIap::new().failing(54, Status::Busy), CCLK, false);
        assert_eq!(broken.init().unwrap_err().code(), 54 * 0x100 + 11);
    }

    #[test]
    fn erase_sector_sequence_for_small_and_large_sectors() {
        let mut m = MockIap::new();
        m.load(0, &[0u8; 0x2_0000]);
        let mut a = FlashAlgo::new(m, CCLK, false);
        a.erase_sector(0x0000_3000).unwrap();
        a.erase_sector(0x0001_8000).unwrap();
        assert_eq!(
            log(&a),
            [
                [50, 3, 3, 0, 0],
                [52, 3, 3, CCLK, 0],
                [53, 3, 3, 0, 0],
                [50, 17, 17, 0, 0],
                [52, 17, 17, CCLK, 0],
                [53, 17, 17, 0, 0],
            ]
        );
        let f = flash(&a);
        assert!(f[0x3000..0x4000].iter().all(|&b| b == 0xFF));
        assert!(f[0x1_8000..0x2_0000].iter().all(|&b| b == 0xFF));
        assert!(f[0x2000..0x3000].iter().all(|&b| b == 0));
        assert!(f[0x4000..0x1_8000].iter().all(|&b| b == 0));
    }

    #[test]
    fn erase_sector_refuses_bad_addresses_without_touching_the_rom() {
        let mut a = algo();
        assert_eq!(a.erase_sector(0x3004), Err(Error::NotSectorStart(0x3004)));
        assert_eq!(
            a.erase_sector(0x1_1000),
            Err(Error::NotSectorStart(0x1_1000))
        );
        assert!(matches!(
            a.erase_sector(FLASH_SIZE),
            Err(Error::OutOfFlash { .. })
        ));
        assert!(log(&a).is_empty());
    }

    #[test]
    fn erase_chip_covers_every_sector() {
        let mut m = MockIap::new();
        m.load(0, &[0u8; 0x2_0000]);
        let mut a = FlashAlgo::new(m, CCLK, false);
        a.erase_chip().unwrap();
        assert_eq!(
            log(&a),
            [[50, 0, 17, 0, 0], [52, 0, 17, CCLK, 0], [53, 0, 17, 0, 0]]
        );
        assert!(flash(&a).iter().all(|&b| b == 0xFF));
    }

    #[test]
    fn erase_reports_iap_failures_and_leftovers() {
        let mut a = FlashAlgo::new(MockIap::new().failing(52, Status::Busy), CCLK, false);
        let e = a.erase_sector(0).unwrap_err();
        assert_eq!(
            e,
            Error::Iap(IapError {
                command: Command::EraseSectors,
                status: Status::Busy
            })
        );
        assert_eq!(e.code(), 0x340B);
        // Erase "succeeds" but the ROM's blank check still finds a word.
        let mut m = MockIap::new().failing(52, Status::Success);
        m.load(0x5008, &[1, 2, 3, 4]);
        let mut a = FlashAlgo::new(m, CCLK, false);
        assert_eq!(
            a.erase_sector(0x5000),
            Err(Error::NotBlank {
                addr: 0x5008,
                contents: 0x0403_0201
            })
        );
    }

    #[test]
    fn program_page_copies_straight_from_the_buffer() {
        let mut a = algo();
        let data = pattern(1024, 3);
        a.program_page(0x1_0400, &data, BUF, &mut Staging::default(), STAGE)
            .unwrap();
        assert_eq!(
            log(&a),
            [[50, 16, 16, 0, 0], [51, 0x1_0400, BUF, 1024, CCLK]]
        );
        assert_eq!(&flash(&a)[0x1_0400..0x1_0800], &data[..]);
        for size in [256u32, 512, 4096] {
            let mut a = algo();
            let data = pattern(size as usize, 9);
            a.program_page(0x8000, &data, BUF, &mut Staging::default(), STAGE)
                .unwrap();
            assert_eq!(log(&a), [[50, 8, 8, 0, 0], [51, 0x8000, BUF, size, CCLK]]);
            assert_eq!(&flash(&a)[0x8000..0x8000 + size as usize], &data[..]);
        }
    }

    #[test]
    fn program_page_stages_what_the_rom_cannot_take() {
        // 1000 bytes (not a copy size): four 256-byte pieces, the last padded with 0xFF.
        let mut a = algo();
        let data = pattern(1000, 1);
        a.program_page(0x2000, &data, BUF, &mut Staging::default(), STAGE)
            .unwrap();
        let expected: std::vec::Vec<[u32; 5]> = (0..4)
            .flat_map(|i| [[50, 2, 2, 0, 0], [51, 0x2000 + 256 * i, STAGE, 256, CCLK]])
            .collect();
        assert_eq!(log(&a), expected);
        assert_eq!(&flash(&a)[0x2000..0x2000 + 1000], &data[..]);
        assert!(flash(&a)[0x2000 + 1000..0x2400].iter().all(|&b| b == 0xFF));

        // A buffer off a word boundary, and a 1024-byte page at a 256-byte boundary.
        for (addr, buf) in [(0x2000u32, BUF + 2), (0x2100, BUF)] {
            let mut a = algo();
            let data = pattern(1024, 5);
            a.program_page(addr, &data, buf, &mut Staging::default(), STAGE)
                .unwrap();
            assert_eq!(log(&a).len(), 8, "{addr:#x}");
            assert!(log(&a).iter().all(|c| c[0] != 51 || c[2] == STAGE));
            assert_eq!(&flash(&a)[addr as usize..addr as usize + 1024], &data[..]);
        }

        // Pieces that cross from sector 15 into 16 are prepared one sector at a time.
        let mut a = algo();
        let data = pattern(768, 2);
        a.program_page(0xFF00, &data, BUF, &mut Staging::default(), STAGE)
            .unwrap();
        let sectors: std::vec::Vec<u32> = log(&a)
            .iter()
            .filter(|c| c[0] == 50)
            .map(|c| c[1])
            .collect();
        assert_eq!(sectors, [15, 16, 16]);
    }

    #[test]
    fn program_page_refuses_bad_requests_before_any_iap_call() {
        let mut a = algo();
        let mut st = Staging::default();
        let page = [0u8; 256];
        assert_eq!(
            a.program_page(0x80, &page, BUF, &mut st, STAGE),
            Err(Error::Unaligned(0x80))
        );
        assert!(matches!(
            a.program_page(FLASH_SIZE - 128, &page, BUF, &mut st, STAGE),
            Err(Error::OutOfFlash { .. })
        ));
        assert_eq!(
            a.program_page(0, &page, 0x1000_3F00, &mut st, STAGE),
            Err(Error::BufferInIapRam(0x1000_3F00))
        );
        assert_eq!(
            a.program_page(0, &page[..100], BUF, &mut st, 0x1000_3FE0),
            Err(Error::BufferInIapRam(0x1000_3FE0))
        );
        assert!(log(&a).is_empty());
        a.program_page(0, &[], BUF, &mut st, STAGE).unwrap();
        assert!(log(&a).is_empty());
    }

    #[test]
    fn crp_lock_values_are_refused_unless_allowed() {
        for lock in [CRP1, crate::crp::CRP2, CRP3, NO_ISP] {
            let mut page = [0xFFu8; 1024];
            page[0x2FC..0x300].copy_from_slice(&lock.to_le_bytes());
            let mut a = algo();
            let e = a
                .program_page(0, &page, BUF, &mut Staging::default(), STAGE)
                .unwrap_err();
            assert_eq!(e, Error::CrpLock(lock));
            assert!(log(&a).is_empty(), "nothing written");
            assert!(ErrorCode(e.code())
                .to_string()
                .contains("Code Read Protection"));

            let mut allowed = FlashAlgo::new(MockIap::new(), CCLK, true);
            allowed
                .program_page(0, &page, BUF, &mut Staging::default(), STAGE)
                .unwrap();
            assert_eq!(
                &allowed.iap().entry().flash()[0x2FC..0x300],
                &lock.to_le_bytes()
            );
        }
        // The word the firmware writes (0xFFFF_FFFF) and a page without 0x2FC pass.
        let mut a = algo();
        let mut page = [0u8; 1024];
        page[0x2FC..0x300].copy_from_slice(&u32::MAX.to_le_bytes());
        a.program_page(0, &page, BUF, &mut Staging::default(), STAGE)
            .unwrap();
        let mut page = [0u8; 1024];
        page[0x2FC..0x300].copy_from_slice(&CRP3.to_le_bytes());
        a.program_page(0x400, &page, BUF, &mut Staging::default(), STAGE)
            .unwrap();
    }

    #[test]
    fn two_writes_that_combine_into_a_lock_value_are_refused() {
        // Each word alone is harmless, but flash keeps only the bits both leave set.
        let first = CRP3 | 0x0000_00FF;
        let second = CRP3 | 0x0000_FF00;
        assert!(!crate::crp::LOCK_VALUES.contains(&first));
        assert!(!crate::crp::LOCK_VALUES.contains(&second));
        let mut a = algo();
        let mut page = [0xFFu8; 1024];
        page[0x2FC..0x300].copy_from_slice(&first.to_le_bytes());
        a.program_page(0, &page, BUF, &mut Staging::default(), STAGE)
            .unwrap();
        let writes = log(&a).len();
        page[0x2FC..0x300].copy_from_slice(&second.to_le_bytes());
        let e = a
            .program_page(0, &page, BUF, &mut Staging::default(), STAGE)
            .unwrap_err();
        assert_eq!(e, Error::CrpLock(CRP3));
        assert_eq!(log(&a).len(), writes, "nothing written the second time");
        assert_eq!(&a.iap().entry().flash()[0x2FC..0x300], &first.to_le_bytes());
    }

    #[test]
    fn program_reports_the_rom_status() {
        let mut a = FlashAlgo::new(
            MockIap::new().failing(51, Status::SectorNotPrepared),
            CCLK,
            false,
        );
        let e = a
            .program_page(0, &[0u8; 256], BUF, &mut Staging::default(), STAGE)
            .unwrap_err();
        assert_eq!(e.code(), 0x3309);
        assert_eq!(
            ErrorCode(e.code()).to_string(),
            "IAP copy RAM to flash (51) failed: sector not prepared for a write operation (status 9)"
        );
    }

    #[test]
    fn verify_returns_end_or_first_bad_address() {
        let mut a = algo();
        let data = pattern(1024, 4);
        a.program_page(0x400, &data, BUF, &mut Staging::default(), STAGE)
            .unwrap();
        assert_eq!(a.verify(0x400, &data, BUF), 0x800);
        assert_eq!(log(&a).last(), Some(&[56, 0x400, BUF, 1024, 0]));
        let mut bad = data.clone();
        bad[0x123] ^= 0x40;
        assert_eq!(a.verify(0x400, &bad, BUF), 0x400 + 0x120);
        // Unaligned or outside: the first address, never `addr + len`.
        assert_eq!(a.verify(0x402, &data[..8], BUF), 0x402);
        assert_eq!(a.verify(0x400, &data[..6], BUF), 0x400);
        assert_eq!(a.verify(0x400, &data, BUF + 1), 0x400);
        assert_eq!(a.verify(FLASH_SIZE - 4, &data[..8], BUF), FLASH_SIZE - 4);
        assert_eq!(a.verify(0x400, &[], BUF), 0x400);
    }

    #[test]
    fn erase_program_verify_round_trip_over_the_whole_flash() {
        let mut a = algo();
        a.init().unwrap();
        a.erase_chip().unwrap();
        let image = pattern(FLASH_SIZE as usize, 11);
        for (i, page) in image.chunks(1024).enumerate() {
            let addr = (i * 1024) as u32;
            if addr == 0 {
                continue; // holds 0x2FC: a pattern byte sequence is no lock value, checked below
            }
            a.program_page(addr, page, BUF, &mut Staging::default(), STAGE)
                .unwrap();
            assert_eq!(a.verify(addr, page, BUF), addr + 1024);
        }
        assert_eq!(&flash(&a)[1024..], &image[1024..]);
        assert_eq!(crate::crp::lock_value_written(0, &image[..1024]), None);
        a.program_page(0, &image[..1024], BUF, &mut Staging::default(), STAGE)
            .unwrap();
        assert_eq!(flash(&a), &image[..]);
    }

    #[test]
    fn every_code_is_explained() {
        let errors = [
            Error::OutOfFlash { addr: 0, len: 0 },
            Error::NotSectorStart(0),
            Error::Unaligned(0),
            Error::BufferInIapRam(0),
            Error::NotBlank {
                addr: 0,
                contents: 0,
            },
            Error::WrongPart(0),
            Error::CrpLock(0),
        ];
        let mut texts = std::vec::Vec::new();
        for e in errors {
            assert_ne!(e.code(), 0);
            let t = ErrorCode(e.code()).to_string();
            assert!(!t.starts_with("unknown"), "{e:?}");
            assert!(!texts.contains(&t));
            texts.push(t);
        }
        for command in 50..=58u32 {
            for status in 1..=11u32 {
                let e = Error::Iap(IapError {
                    command: Command::from(command),
                    status: Status::from(status),
                });
                assert_eq!(e.code(), command * 256 + status);
                assert!(ErrorCode(e.code()).to_string().starts_with("IAP "));
            }
        }
        assert_eq!(ErrorCode(0).to_string(), "success");
        assert_eq!(
            ErrorCode(0x1234).to_string(),
            "unknown flash algorithm code 0x1234"
        );
        assert_eq!(
            ErrorCode(0x1_3301).to_string(),
            "unknown flash algorithm code 0x13301"
        );
    }
}
