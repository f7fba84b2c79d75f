//! A PDI for a memory-mapped 8- or 16-bit asynchronous parallel interface (e.g. an STM32
//! FSMC/FMC bank wired to the ESC's µC PDI).
//!
//! Unlike SPI, a parallel access does not shift out the AL events, so every
//! [`Pdi::read`]/[`Pdi::write`] of a [`MemoryPdi`] first reads the event bits explicitly and
//! then performs the data access. It reads 0x0220..0x0221, the bits the ET1100 has (AL
//! control .. SM7; bits 16.. belong to SyncManagers 8..15), as the SPI PDI's 2-byte address
//! phase does: **one extra 16-bit access per call** (two on an 8-bit bus). The events are
//! sampled before the data access, as on SPI.

use crate::pdi::check_range;
use crate::{AlEvents, Error, Pdi, Register};

/// Byte-offset access to the ESC's address window, implemented by the user (volatile reads
/// and writes into the FSMC bank, a test fake, ...).
///
/// On a 16-bit bus a byte write must drive only its byte lane (the FSMC's NBL0/NBL1 wired to
/// the ESC's ADR\[0\]/BHE do). A byte read may read the whole halfword, as the FSMC does (it
/// drives both NBL low on reads): the ESC then sees a 16-bit read and the read side effects
/// of both bytes. [`MemoryPdi`] reads nothing whose neighbour in the halfword has an effect
/// it does not want, with two exceptions named where they are
/// ([`crate::Et1100::sync0_status`], [`crate::Et1100::sync1_status`]).
pub trait MemoryBus {
    /// The bus error (use [`core::convert::Infallible`] for plain memory-mapped I/O).
    type Error;

    /// Reads the byte at `offset`.
    fn read_u8(&mut self, offset: u16) -> Result<u8, Self::Error>;

    /// Writes the byte at `offset`.
    fn write_u8(&mut self, offset: u16, value: u8) -> Result<(), Self::Error>;

    /// Reads the little-endian 16-bit word at the even `offset`.
    fn read_u16(&mut self, offset: u16) -> Result<u16, Self::Error>;

    /// Writes the little-endian 16-bit word at the even `offset`.
    fn write_u16(&mut self, offset: u16, value: u16) -> Result<(), Self::Error>;
}

/// Data bus width of the parallel interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BusWidth {
    /// Byte accesses only.
    Bits8,
    /// Aligned word accesses; a leading odd byte and a trailing single byte use byte
    /// accesses, so no byte outside the requested range is written. (A word write past the
    /// last byte of an odd-length 3-buffer SyncManager would land in its next buffer.)
    Bits16,
}

/// The ESC on a memory-mapped parallel bus. Accesses go in ascending address order, so a
/// buffer access ends with its last byte.
#[derive(Debug)]
pub struct MemoryPdi<B> {
    bus: B,
    width: BusWidth,
}

impl<B: MemoryBus> MemoryPdi<B> {
    /// Wraps the bus.
    pub fn new(bus: B, width: BusWidth) -> Self {
        Self { bus, width }
    }

    /// Gives the bus back.
    pub fn destroy(self) -> B {
        self.bus
    }

    /// The bus.
    pub fn bus_mut(&mut self) -> &mut B {
        &mut self.bus
    }

    fn read_raw(&mut self, addr: u16, buf: &mut [u8]) -> Result<(), Error<B::Error>> {
        check_range(addr, buf.len())?;
        let mut i = 0usize;
        while i < buf.len() {
            // In range: check_range guarantees addr + len <= 0x1_0000.
            let a = (usize::from(addr) + i) as u16;
            let rest = buf.len() - i;
            if self.width == BusWidth::Bits16 && a % 2 == 0 && rest >= 2 {
                let w = self.bus.read_u16(a).map_err(Error::Bus)?.to_le_bytes();
                if let Some(dst) = buf.get_mut(i..i + 2) {
                    dst.copy_from_slice(&w);
                }
                i += 2;
            } else {
                let v = self.bus.read_u8(a).map_err(Error::Bus)?;
                if let Some(dst) = buf.get_mut(i) {
                    *dst = v;
                }
                i += 1;
            }
        }
        Ok(())
    }

    fn write_raw(&mut self, addr: u16, data: &[u8]) -> Result<(), Error<B::Error>> {
        check_range(addr, data.len())?;
        let mut i = 0usize;
        while i < data.len() {
            let a = (usize::from(addr) + i) as u16;
            match (self.width, data.get(i..i + 2)) {
                (BusWidth::Bits16, Some(&[lo, hi])) if a % 2 == 0 => {
                    self.bus
                        .write_u16(a, u16::from_le_bytes([lo, hi]))
                        .map_err(Error::Bus)?;
                    i += 2;
                }
                _ => {
                    let v = data.get(i).copied().unwrap_or(0);
                    self.bus.write_u8(a, v).map_err(Error::Bus)?;
                    i += 1;
                }
            }
        }
        Ok(())
    }
}

impl<B: MemoryBus> MemoryPdi<B> {
    /// The ET1100's AL event bits, 0x0220..0x0221: one 16-bit access (two byte accesses on
    /// an 8-bit bus).
    fn event_bits(&mut self) -> Result<AlEvents, Error<B::Error>> {
        let mut b = [0u8; 2];
        self.read_raw(Register::AlEventRequest.addr(), &mut b)?;
        Ok(AlEvents::from_bits_retain(u32::from(u16::from_le_bytes(b))))
    }
}

impl<B: MemoryBus> Pdi for MemoryPdi<B> {
    type BusError = B::Error;

    /// Reads the event bits (0x0220..0x0221), then `buf`.
    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvents, Error<B::Error>> {
        check_range(addr, buf.len())?;
        let events = self.event_bits()?;
        self.read_raw(addr, buf)?;
        Ok(events)
    }

    /// Reads the event bits (0x0220..0x0221), then writes `data`.
    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvents, Error<B::Error>> {
        check_range(addr, data.len())?;
        let events = self.event_bits()?;
        self.write_raw(addr, data)?;
        Ok(events)
    }

    /// Reads 0x0220..0x0223 (two 16-bit accesses, four on an 8-bit bus).
    fn events(&mut self) -> Result<AlEvents, Error<B::Error>> {
        let mut b = [0u8; 4];
        self.read_raw(Register::AlEventRequest.addr(), &mut b)?;
        Ok(AlEvents::from_le_bytes(b))
    }

    /// Reads 0x0220..0x0221 (one 16-bit access).
    fn low_events(&mut self) -> Result<AlEvents, Error<B::Error>> {
        self.event_bits()
    }
}
