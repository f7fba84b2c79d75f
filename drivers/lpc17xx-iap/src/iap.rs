//! The LPC17xx In-Application Programming ROM (UM10360 32.8; hardware-facts section 9).
//!
//! The ROM is a Thumb function at [`IAP_ENTRY`] taking two pointers: five command words in
//! (code, then up to four parameters) and five result words out (status, then results).
//! Erase and copy need a "prepare sectors" of the same sectors right before them, and the CPU
//! clock in kHz, from which the ROM times the flash pulses. While it works the ROM uses the
//! top 32 bytes of the local SRAM ([`IAP_RAM_START`]..) and the flash cannot be read, so the
//! caller runs from RAM with interrupts off.

use crate::sector::sectors_spanning;
use core::fmt;

/// The ROM entry point (Thumb bit set).
pub const IAP_ENTRY: u32 = 0x1FFF_1FF1;
/// The ROM's scratch area: the top 32 bytes of the 16 KB local SRAM of the LPC1754.
pub const IAP_RAM_START: u32 = 0x1000_3FE0;
/// End of the local SRAM (exclusive).
pub const IAP_RAM_END: u32 = 0x1000_4000;
/// Byte counts "Copy RAM to flash" accepts.
pub const COPY_SIZES: [u32; 4] = [256, 512, 1024, 4096];
/// Alignment of a copy's flash destination.
pub const COPY_DST_ALIGN: u32 = 256;
/// Alignment of a copy's RAM source (and of everything "compare" takes).
pub const WORD: u32 = 4;
/// The part ID "Read part ID" returns on an LPC1754 (hardware-facts section 9; ISP tools'
/// part tables agree).
pub const LPC1754_PART_ID: u32 = 0x2501_1722;

/// An IAP command code (open: unknown codes survive a round trip).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// 50: prepare sectors (start, end) for a write or an erase.
    PrepareSectors,
    /// 51: copy RAM to flash (dst, src, bytes, CCLK kHz).
    CopyRamToFlash,
    /// 52: erase sectors (start, end, CCLK kHz).
    EraseSectors,
    /// 53: blank check sectors (start, end); results: offset and contents of the first
    /// non-blank word.
    BlankCheckSectors,
    /// 54: read part ID.
    ReadPartId,
    /// 55: read boot code version.
    ReadBootCodeVersion,
    /// 56: compare (dst, src, bytes); result: offset of the first mismatch.
    Compare,
    /// 57: reinvoke ISP.
    ReinvokeIsp,
    /// 58: read device serial number.
    ReadSerialNumber,
    /// Any other code.
    Unknown(u32),
}

impl From<u32> for Command {
    fn from(code: u32) -> Self {
        match code {
            50 => Self::PrepareSectors,
            51 => Self::CopyRamToFlash,
            52 => Self::EraseSectors,
            53 => Self::BlankCheckSectors,
            54 => Self::ReadPartId,
            55 => Self::ReadBootCodeVersion,
            56 => Self::Compare,
            57 => Self::ReinvokeIsp,
            58 => Self::ReadSerialNumber,
            c => Self::Unknown(c),
        }
    }
}

impl From<Command> for u32 {
    fn from(c: Command) -> u32 {
        match c {
            Command::PrepareSectors => 50,
            Command::CopyRamToFlash => 51,
            Command::EraseSectors => 52,
            Command::BlankCheckSectors => 53,
            Command::ReadPartId => 54,
            Command::ReadBootCodeVersion => 55,
            Command::Compare => 56,
            Command::ReinvokeIsp => 57,
            Command::ReadSerialNumber => 58,
            Command::Unknown(c) => c,
        }
    }
}

impl Command {
    /// The RAM bytes the ROM reads for `command` (code and four parameter words): address
    /// and length of a copy's source (51) or of a compare's second operand (56), `None` for
    /// the other commands. A simulator reads them from its memory for [`IapEntry::call`].
    pub fn source(command: &[u32; 5]) -> Option<(u32, u32)> {
        match Command::from(command[0]) {
            Command::CopyRamToFlash | Command::Compare => Some((command[2], command[3])),
            _ => None,
        }
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Self::PrepareSectors => "prepare sectors",
            Self::CopyRamToFlash => "copy RAM to flash",
            Self::EraseSectors => "erase sectors",
            Self::BlankCheckSectors => "blank check sectors",
            Self::ReadPartId => "read part ID",
            Self::ReadBootCodeVersion => "read boot code version",
            Self::Compare => "compare",
            Self::ReinvokeIsp => "reinvoke ISP",
            Self::ReadSerialNumber => "read device serial number",
            Self::Unknown(c) => return write!(f, "unknown command {c}"),
        };
        write!(f, "{name} ({})", u32::from(*self))
    }
}

/// An IAP status code (result word 0; open).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// 0 CMD_SUCCESS.
    Success,
    /// 1 INVALID_COMMAND.
    InvalidCommand,
    /// 2 SRC_ADDR_ERROR: source not on a word boundary.
    SrcAddrError,
    /// 3 DST_ADDR_ERROR: destination not on the required boundary.
    DstAddrError,
    /// 4 SRC_ADDR_NOT_MAPPED.
    SrcAddrNotMapped,
    /// 5 DST_ADDR_NOT_MAPPED.
    DstAddrNotMapped,
    /// 6 COUNT_ERROR: byte count not allowed.
    CountError,
    /// 7 INVALID_SECTOR: sector number wrong or end < start.
    InvalidSector,
    /// 8 SECTOR_NOT_BLANK.
    SectorNotBlank,
    /// 9 SECTOR_NOT_PREPARED_FOR_WRITE_OPERATION.
    SectorNotPrepared,
    /// 10 COMPARE_ERROR.
    CompareError,
    /// 11 BUSY: the flash programming interface is busy.
    Busy,
    /// Any other value.
    Unknown(u32),
}

impl From<u32> for Status {
    fn from(code: u32) -> Self {
        match code {
            0 => Self::Success,
            1 => Self::InvalidCommand,
            2 => Self::SrcAddrError,
            3 => Self::DstAddrError,
            4 => Self::SrcAddrNotMapped,
            5 => Self::DstAddrNotMapped,
            6 => Self::CountError,
            7 => Self::InvalidSector,
            8 => Self::SectorNotBlank,
            9 => Self::SectorNotPrepared,
            10 => Self::CompareError,
            11 => Self::Busy,
            c => Self::Unknown(c),
        }
    }
}

impl From<Status> for u32 {
    fn from(s: Status) -> u32 {
        match s {
            Status::Success => 0,
            Status::InvalidCommand => 1,
            Status::SrcAddrError => 2,
            Status::DstAddrError => 3,
            Status::SrcAddrNotMapped => 4,
            Status::DstAddrNotMapped => 5,
            Status::CountError => 6,
            Status::InvalidSector => 7,
            Status::SectorNotBlank => 8,
            Status::SectorNotPrepared => 9,
            Status::CompareError => 10,
            Status::Busy => 11,
            Status::Unknown(c) => c,
        }
    }
}

impl Status {
    /// What the code means, for a person.
    pub fn message(&self) -> &'static str {
        match self {
            Self::Success => "success",
            Self::InvalidCommand => "invalid command",
            Self::SrcAddrError => "source address not on a word boundary",
            Self::DstAddrError => "destination address not on a 256-byte boundary",
            Self::SrcAddrNotMapped => "source address not mapped in the memory map",
            Self::DstAddrNotMapped => "destination address not mapped in the memory map",
            Self::CountError => "byte count not 256, 512, 1024 or 4096 (or not a multiple of 4)",
            Self::InvalidSector => "invalid sector number, or end sector before start sector",
            Self::SectorNotBlank => "sector not blank",
            Self::SectorNotPrepared => "sector not prepared for a write operation",
            Self::CompareError => "source and destination differ",
            Self::Busy => "flash programming interface busy",
            Self::Unknown(_) => "unknown IAP status code",
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (status {})", self.message(), u32::from(*self))
    }
}

/// A call into the IAP ROM, and reads of the flash it programs.
///
/// `source` holds the RAM bytes a "copy RAM to flash" or "compare" command reads at
/// `command[2]` (`command[3]` of them, see [`Command::source`]), and is empty for the other
/// commands. The ROM reads RAM by itself, so the chip's implementation ignores it; a model
/// programs from it.
pub trait IapEntry {
    /// Runs `command` (code and four parameter words) and returns the five result words.
    fn call(&mut self, command: &[u32; 5], source: &[u8]) -> [u32; 5];

    /// Fills `buf` with the flash bytes from `addr` (user flash mapped at 0); bytes outside
    /// the flash read as erased (0xFF).
    fn read_flash(&self, addr: u32, buf: &mut [u8]);

    /// The address at which the ROM finds `buf` (the RAM operand of a copy or compare).
    fn ram_address(&self, buf: &[u8]) -> u32;

    /// The word user flash holds at `addr` now. Programming only clears bits, so a CRP
    /// guard checks what a write leaves in flash: the written word ANDed with this one.
    fn read_flash_word(&self, addr: u32) -> u32 {
        let mut word = [0u8; 4];
        self.read_flash(addr, &mut word);
        u32::from_le_bytes(word)
    }
}

/// A failed IAP command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IapError {
    /// The command.
    pub command: Command,
    /// Its status.
    pub status: Status,
}

impl fmt::Display for IapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "IAP {} failed: {}", self.command, self.status)
    }
}

/// The outcome of a blank check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlankCheck {
    /// Every word of the sectors reads 0xFFFF_FFFF.
    Blank,
    /// The first word that is not blank.
    NotBlank {
        /// Byte offset from the start sector's first address.
        offset: u32,
        /// Its contents.
        contents: u32,
    },
}

/// The IAP commands with their parameter words, on top of an entry point.
#[derive(Debug)]
pub struct Iap<E> {
    entry: E,
    cclk_khz: u32,
}

impl<E: IapEntry> Iap<E> {
    /// `cclk_khz`: the CPU clock the ROM times erase and write pulses from.
    pub fn new(entry: E, cclk_khz: u32) -> Self {
        Self { entry, cclk_khz }
    }

    /// The CPU clock passed to erase and copy.
    pub fn cclk_khz(&self) -> u32 {
        self.cclk_khz
    }

    /// The entry point (the model's state, in tests).
    pub fn entry(&self) -> &E {
        &self.entry
    }

    /// The entry point, mutable.
    pub fn entry_mut(&mut self) -> &mut E {
        &mut self.entry
    }

    /// Gives the entry point back.
    pub fn into_entry(self) -> E {
        self.entry
    }

    /// Fills `buf` with the flash bytes from `addr`.
    pub fn read_flash(&self, addr: u32, buf: &mut [u8]) {
        self.entry.read_flash(addr, buf)
    }

    /// Calls the ROM; the raw result words.
    fn raw(&mut self, command: Command, params: [u32; 4], source: &[u8]) -> [u32; 5] {
        let words = [
            u32::from(command),
            params[0],
            params[1],
            params[2],
            params[3],
        ];
        self.entry.call(&words, source)
    }

    /// Calls the ROM; the result words on success, the status otherwise.
    fn run(
        &mut self,
        command: Command,
        params: [u32; 4],
        source: &[u8],
    ) -> Result<[u32; 5], IapError> {
        let result = self.raw(command, params, source);
        match Status::from(result[0]) {
            Status::Success => Ok(result),
            status => Err(IapError { command, status }),
        }
    }

    /// 50: prepare sectors `start..=end` for the next erase or copy.
    pub fn prepare(&mut self, start: u32, end: u32) -> Result<(), IapError> {
        self.run(Command::PrepareSectors, [start, end, 0, 0], &[])
            .map(drop)
    }

    /// 52: erase sectors `start..=end` (prepare them first).
    pub fn erase(&mut self, start: u32, end: u32) -> Result<(), IapError> {
        let cclk = self.cclk_khz;
        self.run(Command::EraseSectors, [start, end, cclk, 0], &[])
            .map(drop)
    }

    /// 51: copy `source` (which sits in RAM at `src_addr`) to flash at `dst` (prepare the
    /// sector first).
    pub fn copy_ram_to_flash(
        &mut self,
        dst: u32,
        src_addr: u32,
        source: &[u8],
    ) -> Result<(), IapError> {
        let cclk = self.cclk_khz;
        let len = u32::try_from(source.len()).unwrap_or(u32::MAX);
        self.run(Command::CopyRamToFlash, [dst, src_addr, len, cclk], source)
            .map(drop)
    }

    /// 50 + 51: prepares the sectors `buf` covers at `dst` and copies `buf` (in RAM, word
    /// aligned, 256/512/1024/4096 bytes) there.
    pub fn program(&mut self, dst: u32, buf: &[u8]) -> Result<(), IapError> {
        let len = u32::try_from(buf.len()).unwrap_or(u32::MAX);
        let (first, last) = sectors_spanning(dst, len).ok_or(IapError {
            command: Command::CopyRamToFlash,
            status: Status::DstAddrNotMapped,
        })?;
        self.prepare(first, last)?;
        let src = self.entry.ram_address(buf);
        self.copy_ram_to_flash(dst, src, buf)
    }

    /// 50 + 52: prepares and erases sectors `first..=last`.
    pub fn erase_sectors(&mut self, first: u32, last: u32) -> Result<(), IapError> {
        self.prepare(first, last)?;
        self.erase(first, last)
    }

    /// 56: whether the flash at `dst` holds `buf` (in RAM); `Ok(Some(offset))` of the first
    /// word that differs.
    pub fn verify(&mut self, dst: u32, buf: &[u8]) -> Result<Option<u32>, IapError> {
        let src = self.entry.ram_address(buf);
        self.compare(dst, src, buf)
    }

    /// 53: blank check sectors `start..=end`.
    pub fn blank_check(&mut self, start: u32, end: u32) -> Result<BlankCheck, IapError> {
        let result = self.raw(Command::BlankCheckSectors, [start, end, 0, 0], &[]);
        match Status::from(result[0]) {
            Status::Success => Ok(BlankCheck::Blank),
            Status::SectorNotBlank => Ok(BlankCheck::NotBlank {
                offset: result[1],
                contents: result[2],
            }),
            status => Err(IapError {
                command: Command::BlankCheckSectors,
                status,
            }),
        }
    }

    /// 54: the part ID.
    pub fn read_part_id(&mut self) -> Result<u32, IapError> {
        self.run(Command::ReadPartId, [0; 4], &[]).map(|r| r[1])
    }

    /// 56: compare `source` (in RAM at `src_addr`) with the memory at `dst`; `Ok(None)` when
    /// equal, `Ok(Some(offset))` of the first differing word.
    pub fn compare(
        &mut self,
        dst: u32,
        src_addr: u32,
        source: &[u8],
    ) -> Result<Option<u32>, IapError> {
        let len = u32::try_from(source.len()).unwrap_or(u32::MAX);
        let result = self.raw(Command::Compare, [dst, src_addr, len, 0], source);
        match Status::from(result[0]) {
            Status::Success => Ok(None),
            Status::CompareError => Ok(Some(result[1])),
            status => Err(IapError {
                command: Command::Compare,
                status,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::FlashModel;

    #[test]
    fn codes_round_trip() {
        for code in 0..=80u32 {
            assert_eq!(u32::from(Command::from(code)), code);
            assert_eq!(u32::from(Status::from(code)), code);
        }
        assert_eq!(Command::from(50), Command::PrepareSectors);
        assert_eq!(Command::from(51), Command::CopyRamToFlash);
        assert_eq!(Command::from(52), Command::EraseSectors);
        assert_eq!(Command::from(53), Command::BlankCheckSectors);
        assert_eq!(Command::from(54), Command::ReadPartId);
        assert_eq!(Command::from(49), Command::Unknown(49));
        assert_eq!(Status::from(12), Status::Unknown(12));
        assert_eq!(
            Command::source(&[51, 0x3000, 0x1000_0400, 256, 4000]),
            Some((0x1000_0400, 256))
        );
        assert_eq!(
            Command::source(&[56, 0x3000, 0x2007_C000, 64, 0]),
            Some((0x2007_C000, 64))
        );
        assert_eq!(Command::source(&[52, 3, 5, 4000, 0]), None);
    }

    #[test]
    fn every_status_has_its_own_message() {
        let mut seen = std::vec::Vec::new();
        for code in 0..=11 {
            let m = Status::from(code).message();
            assert!(!seen.contains(&m), "{code}: {m}");
            seen.push(m);
        }
        assert_eq!(Status::from(12).message(), "unknown IAP status code");
        assert_eq!(
            std::format!("{}", Status::SectorNotPrepared),
            "sector not prepared for a write operation (status 9)"
        );
        let e = IapError {
            command: Command::EraseSectors,
            status: Status::Busy,
        };
        assert_eq!(
            std::format!("{e}"),
            "IAP erase sectors (52) failed: flash programming interface busy (status 11)"
        );
    }

    #[test]
    fn parameter_words() {
        let mut iap = Iap::new(FlashModel::new(), 4_000);
        iap.prepare(3, 5).unwrap();
        iap.erase(3, 5).unwrap();
        assert_eq!(iap.read_part_id().unwrap(), LPC1754_PART_ID);
        iap.prepare(3, 3).unwrap();
        let data = [0x5Au8; 256];
        iap.copy_ram_to_flash(0x3000, 0x1000_0400, &data).unwrap();
        assert_eq!(
            iap.compare(0x3000, 0x1000_0400, &data).unwrap(),
            None,
            "programmed bytes compare equal"
        );
        assert_eq!(iap.blank_check(4, 5).unwrap(), BlankCheck::Blank);
        assert_eq!(
            iap.blank_check(3, 3).unwrap(),
            BlankCheck::NotBlank {
                offset: 0,
                contents: 0x5A5A_5A5A
            }
        );
        assert_eq!(
            iap.entry().log(),
            &[
                [50, 3, 5, 0, 0],
                [52, 3, 5, 4_000, 0],
                [54, 0, 0, 0, 0],
                [50, 3, 3, 0, 0],
                [51, 0x3000, 0x1000_0400, 256, 4_000],
                [56, 0x3000, 0x1000_0400, 256, 0],
                [53, 4, 5, 0, 0],
                [53, 3, 3, 0, 0],
            ]
        );
    }

    #[test]
    fn failures_carry_command_and_status() {
        let mut iap = Iap::new(FlashModel::new(), 4_000);
        // Erase without prepare.
        assert_eq!(
            iap.erase(0, 0),
            Err(IapError {
                command: Command::EraseSectors,
                status: Status::SectorNotPrepared
            })
        );
        // End before start, sector 18 does not exist.
        assert_eq!(iap.prepare(2, 1).unwrap_err().status, Status::InvalidSector);
        assert_eq!(
            iap.prepare(0, 18).unwrap_err().status,
            Status::InvalidSector
        );
        // Compare reports the offset of the first difference.
        iap.prepare(1, 1).unwrap();
        iap.copy_ram_to_flash(0x1000, 0x1000_0000, &[0u8; 256])
            .unwrap();
        let mut other = [0u8; 256];
        other[0x44] = 1;
        assert_eq!(
            iap.compare(0x1000, 0x1000_0000, &other).unwrap(),
            Some(0x44)
        );
        assert_eq!(
            iap.compare(0x1001, 0x1000_0000, &other).unwrap_err().status,
            Status::DstAddrError
        );
    }
}
