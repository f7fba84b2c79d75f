//! The driver's error type.

use core::fmt;

use crate::eeprom::EepromStatus;

/// All errors of this crate, generic over the bus error `E`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The bus (SPI device or memory bus) reported an error.
    Bus(E),
    /// The access is empty or reaches beyond address 0xFFFF; nothing was sent to the bus.
    OutOfRange,
    /// A SyncManager or FMMU index beyond the register space (16 each).
    InvalidIndex,
    /// The caller's buffer is smaller than the SyncManager (mailbox reads).
    BufferTooSmall,
    /// The data is longer than the SyncManager (mailbox writes).
    DataTooLong,
    /// A bounded busy poll ran out of polls (EEPROM busy, 0x0502 b15).
    Timeout,
    /// The EEPROM is not offered to the PDI (0x0500 b0 = 0) or is forced to ECAT (b1).
    EepromNotOffered,
    /// The EEPROM interface reported an error (0x0502 b11 checksum, b13 acknowledge/command,
    /// b14 write enable); the whole control/status word is attached.
    Eeprom(EepromStatus),
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "bus error: {e:?}"),
            Error::OutOfRange => f.write_str("access empty or beyond 0xFFFF"),
            Error::InvalidIndex => f.write_str("SyncManager/FMMU index out of range"),
            Error::BufferTooSmall => f.write_str("buffer smaller than the SyncManager"),
            Error::DataTooLong => f.write_str("data longer than the SyncManager"),
            Error::Timeout => f.write_str("timeout"),
            Error::EepromNotOffered => f.write_str("EEPROM not offered to the PDI"),
            Error::Eeprom(s) => write!(f, "EEPROM error, status {:#06x}", s.bits()),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
