//! The bootloader's FoE file store: an update file received over FoE goes into the staging
//! area ([`crate::platform::boot::layout::STAGING`]) and is checked there; the application slot is not
//! touched.
//!
//! - A write is accepted in BOOT only (0x8008 "bootstrap only" otherwise), for a file name
//!   ending in `.efw` (0x8001 "not found" otherwise) with password [`PASSWORD`] (0x800A "no
//!   rights" otherwise).
//! - The header block (the first 256 bytes) is checked as soon as it is in: a missing or
//!   damaged header is 0x8010 "no file header", an image for another vendor, product,
//!   hardware revision or address 0x800D "invalid firmware", one larger than the slot 0x8003
//!   "disk full". Only then is the staging area erased.
//! - The file is written in 1 KB chunks, each compared with the flash right after it is
//!   programmed (0x8011 "flash error" on any IAP failure); the first chunk, which holds the
//!   header, is kept in RAM until the end.
//! - At the last packet: a file shorter than its header says, or an image whose CRC-32 is
//!   not the header's, is 0x800C "invalid checksum" and the header is never written; else
//!   the first chunk goes in last and the staged file is read back and checked whole.
//!
//! The bootloader installs a staged file at its next reset ([`crate::platform::boot::install`]).

use super::crc32::Crc32;
use super::header::{Header, HeaderRepr, Mismatch};
use super::install::{check_image, Invalid};
use super::layout::{Chunk, CHUNK, HEADER_BLOCK, STAGING};
use crate::platform::board::Board;
use coe_core::foe::{FileStore, FoeError, WriteRefusal};
use coe_core::wire::FoeErrorCode;
use coe_core::AlState;
use lpc17xx_iap::{Iap, IapEntry};

/// The FoE password of a firmware file.
pub const PASSWORD: u32 = 0;

/// The file name ending of a firmware file (ASCII, any case).
pub const SUFFIX: &[u8] = b".efw";

fn error(code: FoeErrorCode, text: &'static str) -> FoeError {
    FoeError::with_text(code, text)
}

const FLASH_ERROR: FoeError = FoeError::with_text(FoeErrorCode::FlashError, "flash write failed");

/// The answer to a write of a firmware file outside BOOT (here and in the application).
pub const BOOT_ONLY: FoeError = FoeError::with_text(FoeErrorCode::BootstrapOnly, "in BOOT only");

/// Whether `name` ends in `.efw`, ignoring case.
pub fn is_firmware_name(name: &[u8]) -> bool {
    name.len() > SUFFIX.len()
        && name
            .get(name.len() - SUFFIX.len()..)
            .is_some_and(|end| end.eq_ignore_ascii_case(SUFFIX))
}

/// The staging writer: the bootloader's [`FileStore`], owning the IAP access.
pub struct StagingWriter<E: IapEntry> {
    iap: Iap<E>,
    board: Board,
    open: bool,
    header: Option<HeaderRepr>,
    received: u32,
    crc: Crc32,
    first: Chunk,
    work: Chunk,
    staged: Option<HeaderRepr>,
}

impl<E: IapEntry> StagingWriter<E> {
    /// A writer for the images `board` accepts.
    pub fn new(iap: Iap<E>, board: Board) -> Self {
        Self {
            iap,
            board,
            open: false,
            header: None,
            received: 0,
            crc: Crc32::new(),
            first: Chunk::erased(),
            work: Chunk::erased(),
            staged: None,
        }
    }

    /// The IAP access.
    pub fn iap_mut(&mut self) -> &mut Iap<E> {
        &mut self.iap
    }

    /// The IAP access, given back.
    pub fn into_iap(self) -> Iap<E> {
        self.iap
    }

    /// The header of the file staged by the last good write, if any.
    pub fn staged(&self) -> Option<&HeaderRepr> {
        self.staged.as_ref()
    }

    /// Programs `chunk` at `index` chunks into the staging area and compares it.
    fn program(&mut self, index: u32, chunk: &Chunk) -> Result<(), FoeError> {
        let dst = STAGING.start + index * CHUNK as u32;
        self.iap.program(dst, &chunk.0).map_err(|_| FLASH_ERROR)?;
        match self.iap.verify(dst, &chunk.0) {
            Ok(None) => Ok(()),
            _ => Err(FLASH_ERROR),
        }
    }

    /// The header block is complete: check it, then erase the staging area.
    fn accept_header(&mut self) -> Result<(), FoeError> {
        let header = HeaderRepr::parse(&Header::new_unchecked(&self.first.0[..]))
            .map_err(|e| error(FoeErrorCode::NoFileHeader, e.message()))?;
        header.check(&self.board).map_err(|m| match m {
            Mismatch::TooLarge => error(FoeErrorCode::DiskFull, m.message()),
            _ => error(FoeErrorCode::InvalidFirmware, m.message()),
        })?;
        self.staged = None;
        let (first, last) = STAGING.sectors();
        self.iap
            .erase_sectors(first, last)
            .map_err(|_| FLASH_ERROR)?;
        self.header = Some(header);
        Ok(())
    }

    fn take(&mut self, data: &[u8]) -> Result<(), FoeError> {
        for &byte in data {
            let at = self.received as usize;
            let index = at / CHUNK;
            let within = at % CHUNK;
            if let Some(header) = self.header {
                if self.received >= HEADER_BLOCK + header.image_len {
                    return Err(error(FoeErrorCode::DiskFull, "longer than the header says"));
                }
            }
            let buffer = if index == 0 {
                &mut self.first
            } else {
                &mut self.work
            };
            if let Some(slot) = buffer.0.get_mut(within) {
                *slot = byte;
            }
            if self.received >= HEADER_BLOCK {
                self.crc = self.crc.update(&[byte]);
            }
            self.received += 1;
            if self.received == HEADER_BLOCK {
                self.accept_header()?;
            }
            if index > 0 && within == CHUNK - 1 {
                let chunk = core::mem::replace(&mut self.work, Chunk::erased());
                self.program(index as u32, &chunk)?;
            }
        }
        Ok(())
    }

    fn finish(&mut self, len: u32) -> Result<HeaderRepr, FoeError> {
        let header = self
            .header
            .ok_or(error(FoeErrorCode::NoFileHeader, "shorter than the header"))?;
        if len != HEADER_BLOCK + header.image_len {
            return Err(error(FoeErrorCode::InvalidChecksum, "truncated"));
        }
        if self.crc.finish() != header.image_crc {
            return Err(error(FoeErrorCode::InvalidChecksum, "image CRC wrong"));
        }
        let index = len as usize / CHUNK;
        if index > 0 && len as usize % CHUNK != 0 {
            let chunk = core::mem::replace(&mut self.work, Chunk::erased());
            self.program(index as u32, &chunk)?;
        }
        // The header's chunk last: until it is in, the staging area holds no valid file.
        let first = core::mem::replace(&mut self.first, Chunk::erased());
        self.program(0, &first)?;
        match check_image(&self.iap, STAGING, &self.board) {
            Ok(staged) if staged == header => Ok(header),
            Ok(_) | Err(Invalid::Header(_) | Invalid::Mismatch(_) | Invalid::Crc) => {
                Err(FLASH_ERROR)
            }
        }
    }

    fn reset(&mut self) {
        self.open = false;
        self.header = None;
        self.received = 0;
        self.crc = Crc32::new();
        self.first = Chunk::erased();
        self.work = Chunk::erased();
    }
}

impl<E: IapEntry> FileStore for StagingWriter<E> {
    fn reads(&self) -> bool {
        false
    }

    fn open_write(&mut self, name: &[u8], password: u32, state: AlState) -> Result<(), FoeError> {
        if state != AlState::Bootstrap {
            return Err(BOOT_ONLY);
        }
        if !is_firmware_name(name) {
            return Err(error(FoeErrorCode::NotFound, "only *.efw files"));
        }
        if password != PASSWORD {
            return Err(error(FoeErrorCode::NoRights, "wrong password"));
        }
        self.reset();
        self.open = true;
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), WriteRefusal> {
        if !self.open || offset != self.received {
            return Err(error(FoeErrorCode::Illegal, "data out of order").into());
        }
        self.take(data).map_err(WriteRefusal::Error)
    }

    fn finish_write(&mut self, len: u32) -> Result<(), FoeError> {
        let result = self.finish(len);
        self.reset();
        let header = result?;
        self.staged = Some(header);
        Ok(())
    }

    fn abort(&mut self) {
        self.reset();
    }
}
