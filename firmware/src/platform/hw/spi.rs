//! The legacy SPI (0x4002_0000) for the ET1100 PDI: master, mode 3 (CPOL = CPHA = 1, as SII
//! word 1 = 0x0603 sets the ESC), 8-bit frames MSB first, SCK = PCLK / 8 = 12.5 MHz (the
//! block's limit, CCR even >= 8). No FIFO, no DMA: one byte at a time, SPIF polled with a
//! bound. The chip select is the GPIO P0.16 held by the `SpiDevice`
//! ([`crate::hw::esc::EscSpiDevice`]) for a whole ESC access.

use embedded_hal::spi::{ErrorKind, ErrorType, SpiBus};
use lpc17xx_pac as pac;

/// S0SPCR: BitEnable 0 (8 bits), CPHA b3, CPOL b4, MSTR b5, LSBF 0, SPIE 0.
const CR_MODE3_MASTER: u32 = (1 << 3) | (1 << 4) | (1 << 5);
/// S0SPCCR: PCLK 100 MHz / 8 = 12.5 MHz.
pub const CCR: u32 = 8;
/// S0SPSR bits.
const SR_ABRT: u32 = 1 << 3;
const SR_MODF: u32 = 1 << 4;
const SR_ROVR: u32 = 1 << 5;
const SR_WCOL: u32 = 1 << 6;
const SR_SPIF: u32 = 1 << 7;
/// The error bits (reading S0SPSR clears them, so every poll looks at them).
const SR_ERRORS: u32 = SR_ABRT | SR_MODF | SR_ROVR | SR_WCOL;
/// A byte takes 8 SCK = 64 CPU cycles; a poll loop iteration is >= 4 cycles, so 1000 polls
/// are several byte times.
const SPIF_POLLS: u32 = 1000;

/// A bus error of the legacy SPI.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum SpiError {
    /// SPIF did not rise within the poll budget (clock off, block stuck).
    Timeout,
    /// Mode fault: SSEL driven low while master (should not happen: SSEL is GPIO here).
    ModeFault,
    /// Read overrun.
    Overrun,
    /// Write collision.
    WriteCollision,
    /// Slave abort.
    Abort,
}

impl embedded_hal::spi::Error for SpiError {
    fn kind(&self) -> ErrorKind {
        match self {
            Self::ModeFault => ErrorKind::ModeFault,
            Self::Overrun => ErrorKind::Overrun,
            _ => ErrorKind::Other,
        }
    }
}

/// The legacy SPI as an `SpiBus<u8>` (owner: the PDI task, through the ESC device).
pub struct LegacySpi {
    spi: pac::SPI,
}

impl LegacySpi {
    /// Master mode 3, 12.5 MHz. Pins (P0.15/17/18 fn 3) and PCLK are set by the board.
    pub fn new(spi: pac::SPI) -> Self {
        // SAFETY: documented control values (UM10360 chapter 17).
        spi.ccr.write(|w| unsafe { w.bits(CCR) });
        spi.cr.write(|w| unsafe { w.bits(CR_MODE3_MASTER) });
        // Clear any stale status: read SR, then DR.
        let _ = spi.sr.read().bits();
        let _ = spi.dr.read().bits();
        Self { spi }
    }

    /// One byte out, one byte in.
    #[inline]
    fn exchange(&mut self, out: u8) -> Result<u8, SpiError> {
        // SAFETY: 8-bit data register.
        self.spi.dr.write(|w| unsafe { w.bits(u32::from(out)) });
        for _ in 0..SPIF_POLLS {
            let sr = self.spi.sr.read().bits();
            if sr & SR_ERRORS != 0 {
                return Err(self.fault(sr));
            }
            if sr & SR_SPIF != 0 {
                // Reading SR (done) then DR clears SPIF.
                return Ok(self.spi.dr.read().bits() as u8);
            }
        }
        Err(SpiError::Timeout)
    }

    /// The error an S0SPSR value `sr` with an error bit reports, the bit cleared. Out of
    /// line: the inlined byte loops share it.
    #[cold]
    #[inline(never)]
    fn fault(&mut self, sr: u32) -> SpiError {
        let _ = self.spi.dr.read().bits();
        if sr & SR_MODF != 0 {
            // MODF clears by writing CR again.
            // SAFETY: the same control value as in `new`.
            self.spi.cr.write(|w| unsafe { w.bits(CR_MODE3_MASTER) });
            SpiError::ModeFault
        } else if sr & SR_ROVR != 0 {
            SpiError::Overrun
        } else if sr & SR_WCOL != 0 {
            SpiError::WriteCollision
        } else {
            SpiError::Abort
        }
    }
}

impl ErrorType for LegacySpi {
    type Error = SpiError;
}

impl SpiBus<u8> for LegacySpi {
    fn read(&mut self, words: &mut [u8]) -> Result<(), SpiError> {
        for w in words {
            *w = self.exchange(0)?;
        }
        Ok(())
    }

    fn write(&mut self, words: &[u8]) -> Result<(), SpiError> {
        for &w in words {
            self.exchange(w)?;
        }
        Ok(())
    }

    fn transfer(&mut self, read: &mut [u8], write: &[u8]) -> Result<(), SpiError> {
        // The ESC's address phases send and receive as many bytes: that part is a loop
        // without a decision per byte. The longer side's rest is read (0x00 out) or
        // written, called only when there is one (the calls are not inlined here).
        let both = read.len().min(write.len());
        let (read_both, read_rest) = read.split_at_mut(both);
        let (write_both, write_rest) = write.split_at(both);
        for (r, &w) in read_both.iter_mut().zip(write_both) {
            *r = self.exchange(w)?;
        }
        if !read_rest.is_empty() {
            self.read(read_rest)?;
        }
        if !write_rest.is_empty() {
            self.write(write_rest)?;
        }
        Ok(())
    }

    fn transfer_in_place(&mut self, words: &mut [u8]) -> Result<(), SpiError> {
        for w in words {
            *w = self.exchange(*w)?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), SpiError> {
        Ok(()) // every exchange waits for SPIF
    }
}
