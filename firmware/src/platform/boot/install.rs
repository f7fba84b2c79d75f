//! What the bootloader does at reset, on the flash through the IAP ROM:
//!
//! 1. check the staging area and the application slot: header (magic, format, its CRC),
//!    fit for this board ([`Board`], the rule of [`super::header`]), image CRC-32
//!    ([`check_image`]);
//! 2. a valid staged image that is not the application's: install it ([`install`]: erase the
//!    slot, copy from the back, the header's chunk last, compare every chunk);
//! 3. a valid staged image equal to the application: erase the staging area (the update is
//!    done; a probe-flashed application is never overwritten by an old staged file);
//! 4. start the application if it is valid and no boot request came, else stay in the
//!    bootloader ([`startup`], [`Startup`]).
//!
//! Every step can be cut by a power loss; the next reset goes through the same steps from
//! what the flash holds (the power-cut test in `crate::platform::boot::power_cut` cuts every erase and
//! program step).

use super::crc32::Crc32;
use super::header::{Header, HeaderError, HeaderRepr, Mismatch};
use super::layout::{Chunk, Region, APP_SLOT, CHUNK, HEADER_BLOCK, STAGING};
use crate::platform::board::Board;
use lpc17xx_iap::{Command, Iap, IapEntry, IapError, Status};

/// Why a region holds no image this module can run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Invalid {
    /// No valid header (erased, partly written, damaged).
    Header(HeaderError),
    /// A valid header for another module or too large.
    Mismatch(Mismatch),
    /// The image's CRC-32 is not the header's (partly written or damaged image).
    Crc,
}

/// The image in `region` (header block first), checked whole: header, fit for `board`,
/// image CRC-32.
pub fn check_image<E: IapEntry>(
    iap: &Iap<E>,
    region: Region,
    board: &Board,
) -> Result<HeaderRepr, Invalid> {
    let mut block = [0u8; HEADER_BLOCK as usize];
    iap.read_flash(region.start, &mut block);
    let header = HeaderRepr::parse(&Header::new_unchecked(&block[..])).map_err(Invalid::Header)?;
    header.check(board).map_err(Invalid::Mismatch)?;
    if HEADER_BLOCK + header.image_len > region.len {
        return Err(Invalid::Mismatch(Mismatch::TooLarge));
    }
    let mut crc = Crc32::new();
    let mut at = region.start + HEADER_BLOCK;
    let end = at + header.image_len;
    let mut buf = [0u8; 256];
    while at < end {
        let n = (end - at).min(buf.len() as u32) as usize;
        let part = buf.get_mut(..n).unwrap_or_default();
        iap.read_flash(at, part);
        crc = crc.update(part);
        at += n as u32;
    }
    if crc.finish() == header.image_crc {
        Ok(header)
    } else {
        Err(Invalid::Crc)
    }
}

/// Copies the staged image of `staged` into the application slot: erase the slot (its
/// first sector, the header's, first), then every chunk from the second on, then the first,
/// each compared after programming.
pub fn install<E: IapEntry>(iap: &mut Iap<E>, staged: &HeaderRepr) -> Result<(), IapError> {
    let (first, last) = APP_SLOT.sectors();
    iap.erase_sectors(first, last)?;
    let chunks = (HEADER_BLOCK + staged.image_len).div_ceil(CHUNK as u32);
    let mut buf = Chunk::erased();
    for index in (1..chunks).chain(core::iter::once(0)) {
        let offset = index * CHUNK as u32;
        iap.read_flash(STAGING.start + offset, &mut buf.0);
        let dst = APP_SLOT.start + offset;
        iap.program(dst, &buf.0)?;
        if iap.verify(dst, &buf.0)?.is_some() {
            return Err(IapError {
                command: Command::Compare,
                status: Status::CompareError,
            });
        }
    }
    Ok(())
}

/// Why the bootloader stays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stay {
    /// The application asked for it (a master's BOOT request).
    Requested,
    /// No valid application in the slot.
    NoApplication(Invalid),
}

/// The outcome of the reset sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Startup {
    /// The application slot after the sequence.
    pub application: Result<HeaderRepr, Invalid>,
    /// A staged image was installed now.
    pub installed: bool,
    /// The installation failed at this IAP command (the staged image stays for the next
    /// reset).
    pub install_error: Option<IapError>,
    /// `None`: start the application; else why the bootloader stays.
    pub stay: Option<Stay>,
}

/// The reset sequence (see the module documentation): installs a pending staged image and
/// decides between starting the application and staying in the bootloader.
pub fn startup<E: IapEntry>(iap: &mut Iap<E>, board: &Board, boot_requested: bool) -> Startup {
    let staged = check_image(iap, STAGING, board).ok();
    let mut application = check_image(iap, APP_SLOT, board);
    let mut installed = false;
    let mut install_error = None;
    if let Some(staged) = staged {
        if application != Ok(staged) {
            match install(iap, &staged) {
                Ok(()) => installed = true,
                Err(e) => install_error = Some(e),
            }
            application = check_image(iap, APP_SLOT, board);
        }
        if application == Ok(staged) {
            let (first, last) = STAGING.sectors();
            // A failed erase leaves a staged image equal to the application: harmless,
            // erased again at the next reset.
            let _ = iap.erase_sectors(first, last);
        }
    }
    let stay = match application {
        _ if boot_requested => Some(Stay::Requested),
        Ok(_) => None,
        Err(e) => Some(Stay::NoApplication(e)),
    };
    Startup {
        application,
        installed,
        install_error,
        stay,
    }
}
