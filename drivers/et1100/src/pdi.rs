//! The process data interface: raw byte access to the ESC address space.

use crate::{AlEvents, Error};

/// The result of an access through the PDI `P`, for code generic over the PDI.
pub type PdiResult<T, P> = Result<T, Error<<P as Pdi>::BusError>>;

/// Raw access to the ESC from the PDI side.
///
/// Every access returns the AL event bits (0x0220..) that belong to it; an implementation
/// keeps no hidden state between accesses.
pub trait Pdi {
    /// The error of the underlying bus.
    type BusError;

    /// Reads `buf.len()` bytes starting at `addr` in one access.
    ///
    /// Errors with [`Error::OutOfRange`] for an empty buffer or an access beyond 0xFFFF,
    /// without touching the bus.
    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvents, Error<Self::BusError>>;

    /// Writes `data` starting at `addr` in one access.
    ///
    /// Errors with [`Error::OutOfRange`] for empty data or an access beyond 0xFFFF,
    /// without touching the bus.
    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvents, Error<Self::BusError>>;

    /// Reads the AL event bits alone.
    fn events(&mut self) -> Result<AlEvents, Error<Self::BusError>>;

    /// Reads AL event bits 0..15 alone (0x0220/0x0221: AL control, DC, SYNC0/1, SM
    /// activation, EEPROM, watchdog, SM0..SM7, all the 8-SyncManager ET1100 has) in the
    /// cheapest access the PDI offers; bits 16.. read as 0 ([`AlEvents::LOW`]). The
    /// default masks [`Pdi::events`].
    fn low_events(&mut self) -> Result<AlEvents, Error<Self::BusError>> {
        self.events().map(|e| e & AlEvents::LOW)
    }
}

impl<P: Pdi + ?Sized> Pdi for &mut P {
    type BusError = P::BusError;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvents, Error<Self::BusError>> {
        P::read(self, addr, buf)
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvents, Error<Self::BusError>> {
        P::write(self, addr, data)
    }

    fn events(&mut self) -> Result<AlEvents, Error<Self::BusError>> {
        P::events(self)
    }

    fn low_events(&mut self) -> Result<AlEvents, Error<Self::BusError>> {
        P::low_events(self)
    }
}

/// Checks that `len` bytes at `addr` are a non-empty access inside 0x0000..=0xFFFF.
pub(crate) fn check_range<E>(addr: u16, len: usize) -> Result<(), Error<E>> {
    let end = u32::try_from(len)
        .ok()
        .and_then(|len| len.checked_add(u32::from(addr)));
    match end {
        Some(end) if len != 0 && end <= 0x1_0000 => Ok(()),
        _ => Err(Error::OutOfRange),
    }
}
