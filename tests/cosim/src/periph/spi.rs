//! The legacy SPI (UM10360 chapter 17, base 0x4002_0000): master only here, one byte at a
//! time, no FIFO and no DMA. A byte written to S0SPDR takes 8 x S0SPCCR PCLK periods; SPIF
//! (S0SPSR b7) rises at its end and is cleared by reading S0SPSR and then accessing S0SPDR.
//! A write to S0SPDR during a transfer is a write collision (WCOL) and is dropped.
//!
//! The byte's partner (the ET1100 behind its SEL pin) is served by [`crate::machine`]: it
//! takes the byte with [`Spi::take_started`] and hands back what came in with
//! [`Spi::complete_with`].

use super::{ticks_to_ns, Peripheral, Tick};

const CR_BIT_ENABLE: u32 = 1 << 2;
const CR_CPHA: u32 = 1 << 3;
const CR_CPOL: u32 = 1 << 4;
const CR_MSTR: u32 = 1 << 5;
const CR_SPIE: u32 = 1 << 7;
const SR_WCOL: u32 = 1 << 6;
const SR_SPIF: u32 = 1 << 7;

/// The legacy SPI.
#[derive(Clone, Debug, Default)]
pub struct Spi {
    cr: u32,
    ccr: u32,
    sr: u32,
    rx: u8,
    /// The byte just written, waiting for the machine to exchange it.
    started: Option<u8>,
    /// End of the byte in flight.
    done_at: Option<u64>,
    /// SPIF was seen in a read of S0SPSR (the first half of its clearing).
    spif_read: bool,
    int_flag: bool,
    /// Bytes transferred.
    pub bytes: u64,
    /// Rule violations (once each).
    pub violations: Vec<String>,
}

impl Spi {
    /// Reset state.
    pub fn new() -> Self {
        Self::default()
    }

    fn violation(&mut self, msg: String) {
        if !self.violations.contains(&msg) {
            self.violations.push(msg);
        }
    }

    /// Clock polarity and phase as an SPI mode number (0..=3).
    pub fn mode(&self) -> u8 {
        (u8::from(self.cr & CR_CPOL != 0) << 1) | u8::from(self.cr & CR_CPHA != 0)
    }

    /// Bits per transfer.
    pub fn bits(&self) -> u32 {
        if self.cr & CR_BIT_ENABLE == 0 {
            8
        } else {
            match (self.cr >> 8) & 0xF {
                0 => 16,
                n => n.max(8),
            }
        }
    }

    /// A byte written to the data register, for the machine to exchange with the device.
    pub fn take_started(&mut self) -> Option<u8> {
        self.started.take()
    }

    /// The byte that came in during the transfer.
    pub fn complete_with(&mut self, miso: u8) {
        self.rx = miso;
    }
}

impl Peripheral for Spi {
    fn read(&mut self, t: Tick, offset: u32) -> u32 {
        self.on_event(t);
        match offset {
            0x00 => self.cr,
            0x04 => {
                self.spif_read = self.sr & SR_SPIF != 0;
                self.sr
            }
            0x08 => {
                if self.spif_read {
                    self.sr &= !(SR_SPIF | SR_WCOL);
                    self.spif_read = false;
                }
                u32::from(self.rx)
            }
            0x0C => self.ccr,
            0x1C => u32::from(self.int_flag),
            _ => 0,
        }
    }

    fn write(&mut self, t: Tick, offset: u32, value: u32) {
        self.on_event(t);
        match offset {
            0x00 => self.cr = value & 0xFFC,
            0x08 => {
                if self.spif_read {
                    self.sr &= !(SR_SPIF | SR_WCOL);
                    self.spif_read = false;
                }
                if self.done_at.is_some() {
                    self.sr |= SR_WCOL;
                    return;
                }
                if self.cr & CR_MSTR == 0 {
                    self.violation(
                        "S0SPDR written with S0SPCR.MSTR = 0: the SPI is a slave and no clock runs"
                            .into(),
                    );
                    return;
                }
                if self.ccr < 8 || !self.ccr.is_multiple_of(2) {
                    self.violation(format!(
                        "S0SPCCR = {} (UM10360 17.7.4: even and at least 8)",
                        self.ccr
                    ));
                }
                let bits = u64::from(self.bits());
                let ns = ticks_to_ns(bits * u64::from(self.ccr.max(8)), t.pclk_hz);
                self.done_at = Some(t.now_ns + ns.max(1));
                self.started = Some(value as u8);
                self.bytes += 1;
            }
            0x0C => self.ccr = value & 0xFF,
            0x1C if value & 1 != 0 => self.int_flag = false,
            _ => {}
        }
    }

    fn next_event(&self) -> Option<u64> {
        self.done_at
    }

    fn on_event(&mut self, t: Tick) {
        if self.done_at.is_some_and(|d| t.now_ns >= d) {
            self.done_at = None;
            self.sr |= SR_SPIF;
            if self.cr & CR_SPIE != 0 {
                self.int_flag = true;
            }
        }
    }

    fn irq(&self) -> bool {
        self.int_flag
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periph::testing::t;

    #[test]
    fn a_byte_takes_eight_ccr_periods_and_spif_clears_by_sr_then_dr() {
        let mut s = Spi::new();
        s.write(t(0), 0x0C, 8);
        s.write(t(0), 0x00, CR_MSTR | CR_CPOL | CR_CPHA);
        assert_eq!(s.mode(), 3);
        s.write(t(0), 0x08, 0x5A);
        assert_eq!(s.take_started(), Some(0x5A));
        s.complete_with(0xA5);
        assert_eq!(s.read(t(630), 0x04) & SR_SPIF, 0, "64 PCLK = 640 ns");
        s.write(t(630), 0x08, 0x11);
        assert_ne!(s.read(t(640), 0x04) & SR_WCOL, 0, "write collision");
        assert_ne!(s.read(t(640), 0x04) & SR_SPIF, 0);
        assert_eq!(s.read(t(640), 0x08), 0xA5);
        assert_eq!(s.read(t(640), 0x04), 0, "SPIF and WCOL cleared");
    }
}
