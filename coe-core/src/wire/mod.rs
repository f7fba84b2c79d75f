//! The wire layer: zero-copy views and owned representations of every mailbox frame the slave
//! reads or writes, after smoltcp's `wire` module.
//!
//! Each format has one file:
//!
//! | File | Format | Specification |
//! |---|---|---|
//! | [`mailbox`] | mailbox header, mailbox error reply | ETG.1000.4 5.6 (mailbox header and error reply tables); ESC datasheet section I 8 |
//! | [`coe`] | CoE header | ETG.1000.6 5.6.1 |
//! | [`sdo`] | SDO initiate/segment/abort frames | ETG.1000.6 5.6.2 |
//! | [`sdo_info`] | SDO Information service | ETG.1000.6 5.6.3 |
//! | [`emergency`] | CoE Emergency | ETG.1000.6 5.6.4 |
//! | [`foe`] | FoE packets (read/write request, data, ack, error, busy) | ETG.1000.6 5.8 |
//!
//! (Section numbers are cited rather than table numbers, which differ between editions.)
//!
//! Every format has two layers:
//!
//! - a view `Xxx<T: AsRef<[u8]>>` over a byte buffer with one getter per field (setters where
//!   `T: AsMut<[u8]>`). `new_checked` validates the length once; afterwards no accessor reads
//!   outside the buffer. `new_unchecked` is for emitting into a fresh buffer. Accessors never
//!   panic even on an unchecked view: a field outside the buffer reads as zero and a write to it
//!   is dropped.
//! - an owned `XxxRepr` with `parse` (which validates again, so it is safe on any view),
//!   `emit` (which first checks that the buffer holds [`buffer_len`](mailbox::MailboxRepr::buffer_len)
//!   bytes and fails with [`Error::Truncated`] otherwise) and `buffer_len`.
//!
//! The layers nest the way the frames do: a [`Mailbox`] payload holds a [`Coe`] frame whose
//! payload is an [`Sdo`], [`SdoInfo`] or [`Emergency`] frame, or a [`Foe`] packet. EtherCAT
//! is little-endian.

use core::fmt;
use core::ops::Range;

use crate::abort::SdoAbortCode;

pub mod coe;
pub mod emergency;
pub mod foe;
pub mod mailbox;
pub mod sdo;
pub mod sdo_info;

pub use coe::{Coe, CoeRepr, CoeService};
pub use emergency::{Emergency, EmergencyRepr};
pub use foe::{Foe, FoeErrorCode, FoeOpCode, FoeRepr};
pub use mailbox::{
    next_counter, Mailbox, MailboxErrorCode, MailboxErrorReply, MailboxErrorReplyRepr, MailboxRepr,
    MailboxType,
};
pub use sdo::{Direction, InitData, Sdo, SdoRepr};
pub use sdo_info::{
    write_od_list, EntryDescriptionHead, EntryValue, OdListType, SdoInfo, SdoInfoHeaderRepr,
    SdoInfoOpCode, SdoInfoRepr, ServiceDataSink, ValueInfo,
};

/// Why a buffer is not a valid frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The buffer is shorter than the frame needs (or than a length field says), or an
    /// emit buffer is shorter than [`buffer_len`](mailbox::MailboxRepr::buffer_len).
    Truncated,
    /// A field holds a value the format does not allow (e.g. an unknown SDO command
    /// specifier, a wrong mailbox error service type, an inconsistent size).
    Malformed,
}

impl Error {
    /// The mailbox error reply detail a slave answers this error with when it occurs in a
    /// protocol header after the mailbox header (ETG.1000.4 mailbox error reply codes).
    /// A mailbox header whose length field exceeds the buffer is also `Truncated`
    /// ([`Mailbox::check_len`]); a slave answers that one with
    /// [`MailboxErrorCode::InvalidSize`].
    pub const fn mailbox_error_code(self) -> MailboxErrorCode {
        match self {
            Error::Truncated => MailboxErrorCode::SizeTooShort,
            Error::Malformed => MailboxErrorCode::InvalidHeader,
        }
    }

    /// The SDO abort code a slave answers this error with when it occurs in an SDO frame
    /// (ETG.1000.6 table 41).
    pub const fn sdo_abort_code(self) -> SdoAbortCode {
        match self {
            Error::Truncated => SdoAbortCode::LengthTooLow,
            Error::Malformed => SdoAbortCode::InvalidCommandSpecifier,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Truncated => f.write_str("truncated frame"),
            Error::Malformed => f.write_str("malformed frame"),
        }
    }
}

/// The result type of the wire layer.
pub type Result<T> = core::result::Result<T, Error>;

/// Reads one byte; zero outside the buffer.
#[inline]
pub(crate) fn get_u8(data: &[u8], offset: usize) -> u8 {
    data.get(offset).copied().unwrap_or(0)
}

/// Writes one byte; dropped outside the buffer.
#[inline]
pub(crate) fn set_u8(data: &mut [u8], offset: usize, value: u8) {
    if let Some(b) = data.get_mut(offset) {
        *b = value;
    }
}

/// Reads a little-endian u16; zero if the range is not inside the buffer.
#[inline]
pub(crate) fn get_u16(data: &[u8], range: Range<usize>) -> u16 {
    data.get(range)
        .and_then(|s| <[u8; 2]>::try_from(s).ok())
        .map_or(0, u16::from_le_bytes)
}

/// Reads a little-endian u32; zero if the range is not inside the buffer.
#[inline]
pub(crate) fn get_u32(data: &[u8], range: Range<usize>) -> u32 {
    data.get(range)
        .and_then(|s| <[u8; 4]>::try_from(s).ok())
        .map_or(0, u32::from_le_bytes)
}

/// Copies `src` into `data` at `offset`, as far as both reach.
#[inline]
pub(crate) fn set_bytes(data: &mut [u8], offset: usize, src: &[u8]) {
    if let Some(dst) = data.get_mut(offset..) {
        for (d, s) in dst.iter_mut().zip(src) {
            *d = *s;
        }
    }
}

/// Writes a little-endian u16; dropped if the range is not inside the buffer.
#[inline]
pub(crate) fn set_u16(data: &mut [u8], range: Range<usize>, value: u16) {
    if let Some(dst) = data.get_mut(range) {
        if dst.len() == 2 {
            set_bytes(dst, 0, &value.to_le_bytes());
        }
    }
}

/// Writes a little-endian u32; dropped if the range is not inside the buffer.
#[inline]
pub(crate) fn set_u32(data: &mut [u8], range: Range<usize>, value: u32) {
    if let Some(dst) = data.get_mut(range) {
        if dst.len() == 4 {
            set_bytes(dst, 0, &value.to_le_bytes());
        }
    }
}

/// The bytes from `offset` to the end; empty if `offset` is past the end.
#[inline]
pub(crate) fn tail(data: &[u8], offset: usize) -> &[u8] {
    data.get(offset..).unwrap_or_default()
}

/// The mutable bytes from `offset` to the end; empty if `offset` is past the end.
#[inline]
pub(crate) fn tail_mut(data: &mut [u8], offset: usize) -> &mut [u8] {
    data.get_mut(offset..).unwrap_or_default()
}

/// `Err(Truncated)` unless `len >= need`.
#[inline]
pub(crate) const fn need(len: usize, need: usize) -> Result<()> {
    if len >= need {
        Ok(())
    } else {
        Err(Error::Truncated)
    }
}
