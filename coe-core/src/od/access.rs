//! The application side of the object dictionary.

use crate::abort::SdoAbortCode;
use crate::esm::AlState;

/// How the application supplies entry values and accepts or vetoes writes.
///
/// Values are the little-endian byte images of the entries (BOOLEAN and BITn as one byte,
/// strings as their bytes without terminator). The SDO server has already checked that the
/// entry exists, that the access rights allow the access in the current state, the length
/// and the `min`/`max` range before it calls [`ObjectAccess::write`]; the application only
/// adds its own rules and answers them with an abort code (e.g. 0x08000022 DeviceState,
/// 0x06090030 ValueRangeExceeded, 0x06040041 CannotBeMapped).
pub trait ObjectAccess {
    /// Writes the current value of `index:subindex` into `buf` and returns its length in
    /// bytes. For fixed-size entries that is the entry's byte length; for strings, OCTET_STRING
    /// and DOMAIN the actual length (at most `buf.len()`, else
    /// `Err(SdoAbortCode::OutOfMemory)`).
    fn read(&mut self, index: u16, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode>;

    /// Stores a new value for `index:subindex`, or vetoes it with an abort code.
    fn write(
        &mut self,
        index: u16,
        subindex: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode>;

    /// True if `index:subindex` is currently mapped into an assigned RxPDO. The SDO server
    /// refuses SDO downloads to such an entry in OP (0x06010006 MappedToRxPdo), since the
    /// process data would overwrite the value every cycle. The default says "never".
    fn is_rx_mapped(&self, index: u16, subindex: u8) -> bool {
        let _ = (index, subindex);
        false
    }
}

/// A borrowed access is an access: an application can hand out `&mut self` where a view of
/// its objects is asked for.
impl<T: ObjectAccess + ?Sized> ObjectAccess for &mut T {
    fn read(&mut self, index: u16, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        (**self).read(index, subindex, buf)
    }

    fn write(
        &mut self,
        index: u16,
        subindex: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        (**self).write(index, subindex, data, state)
    }

    fn is_rx_mapped(&self, index: u16, subindex: u8) -> bool {
        (**self).is_rx_mapped(index, subindex)
    }
}
