//! SPI1/SPI2 in master mode (RM0008 section 25.3): CR1's clock (BR: PCLK / 2^(BR+1)),
//! CPOL/CPHA, DFF (8 or 16 bits), SPE; one TX buffer in front of the shift register (TXE),
//! one RX buffer (RXNE, OVR when a frame arrives on an unread one), BSY while shifting, and
//! CR2's DMA requests. A frame moves when the shift ends: the machine exchanges it with the
//! device the pins select.

use crate::periph::{ticks_to_ns, Tick};

const CR1: u32 = 0x00;
const CR2: u32 = 0x04;
const SR: u32 = 0x08;
const DR: u32 = 0x0C;

const RXNE: u32 = 1 << 0;
const TXE: u32 = 1 << 1;
const OVR: u32 = 1 << 6;
const BSY: u32 = 1 << 7;
const MSTR: u32 = 1 << 2;
const SPE: u32 = 1 << 6;
const DFF: u32 = 1 << 11;
const RXDMAEN: u32 = 1 << 0;
const TXDMAEN: u32 = 1 << 1;

/// An SPI port.
#[derive(Clone, Debug, Default)]
pub struct Spi {
    cr1: u32,
    cr2: u32,
    tx: Option<u16>,
    /// The frame shifting and when it ends.
    shifting: Option<(u16, u64)>,
    finished: Option<u16>,
    rx: u16,
    rxne: bool,
    ovr: bool,
    /// Frames lost to OVR.
    pub overruns: u64,
}

impl Spi {
    /// Reset.
    pub fn new() -> Self {
        Self::default()
    }

    /// Frame length.
    pub fn frame_bits(&self) -> u32 {
        if self.cr1 & DFF != 0 {
            16
        } else {
            8
        }
    }

    /// SPI mode (CPOL << 1 | CPHA).
    pub fn mode(&self) -> u32 {
        self.cr1 & 3
    }

    /// Whether it runs as the master.
    pub fn master(&self) -> bool {
        self.cr1 & (MSTR | SPE) == MSTR | SPE
    }

    fn start_next(&mut self, t: Tick) {
        if self.shifting.is_some() || !self.master() {
            return;
        }
        if let Some(w) = self.tx.take() {
            let div = 2u64 << ((self.cr1 >> 3) & 7);
            let end = t.now_ns + ticks_to_ns(u64::from(self.frame_bits()) * div, t.pclk_hz);
            self.shifting = Some((w, end));
        }
    }

    /// When the shifting frame ends.
    pub fn next_event(&self) -> Option<u64> {
        if self.finished.is_some() {
            return None;
        }
        self.shifting.map(|(_, end)| end)
    }

    /// The frame ends if due: [`Spi::take_finished`] gives its MOSI word.
    pub fn on_event(&mut self, t: Tick) {
        if let Some((w, end)) = self.shifting {
            if end <= t.now_ns && self.finished.is_none() {
                self.finished = Some(w);
            }
        }
    }

    /// The MOSI word of a frame that ended (the machine answers with [`Spi::complete`]).
    pub fn take_finished(&mut self) -> Option<u16> {
        self.finished.take()
    }

    /// The frame's MISO word arrives; the next frame starts.
    pub fn complete(&mut self, t: Tick, miso: u16) {
        self.shifting = None;
        if self.rxne {
            self.ovr = true;
            self.overruns += 1;
        } else {
            self.rx = miso;
            self.rxne = true;
        }
        self.start_next(t);
    }

    /// RX DMA request.
    pub fn rx_dma_request(&self) -> bool {
        self.rxne && self.cr2 & RXDMAEN != 0
    }

    /// TX DMA request.
    pub fn tx_dma_request(&self) -> bool {
        self.tx.is_none() && self.master() && self.cr2 & TXDMAEN != 0
    }

    /// The interrupt (TXEIE, RXNEIE, ERRIE).
    pub fn irq(&self) -> bool {
        (self.cr2 & 1 << 7 != 0 && self.tx.is_none())
            || (self.cr2 & 1 << 6 != 0 && self.rxne)
            || (self.cr2 & 1 << 5 != 0 && self.ovr)
    }

    /// A register read (DR clears RXNE).
    pub fn read(&mut self, _t: Tick, offset: u32) -> u32 {
        match offset {
            CR1 => self.cr1,
            CR2 => self.cr2,
            SR => {
                let mut v = 0;
                if self.rxne {
                    v |= RXNE;
                }
                if self.tx.is_none() {
                    v |= TXE;
                }
                if self.ovr {
                    v |= OVR;
                }
                if self.shifting.is_some() || self.tx.is_some() {
                    v |= BSY;
                }
                v
            }
            DR => {
                self.rxne = false;
                let v = u32::from(self.rx);
                if self.frame_bits() == 8 {
                    v & 0xFF
                } else {
                    v
                }
            }
            _ => 0,
        }
    }

    /// A register write (DR fills the TX buffer).
    pub fn write(&mut self, t: Tick, offset: u32, value: u32) {
        match offset {
            CR1 => self.cr1 = value & 0xFFFF,
            CR2 => self.cr2 = value & 0xE7,
            // OVR is cleared by reading DR then SR; a write to SR does nothing.
            SR => {}
            DR => {
                let w = if self.frame_bits() == 8 {
                    value & 0xFF
                } else {
                    value & 0xFFFF
                };
                self.tx = Some(w as u16);
                self.start_next(t);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(now_ns: u64) -> Tick {
        Tick {
            now_ns,
            pclk_hz: 36_000_000,
        }
    }

    #[test]
    fn a_byte_at_18_mhz_and_the_flags() {
        let mut s = Spi::new();
        // Mode 1, master, BR = 0 (PCLK/2), SPE.
        s.write(t(0), CR1, 1 | MSTR | SPE);
        s.write(t(0), DR, 0xA5);
        assert_eq!(s.read(t(0), SR) & (TXE | BSY), TXE | BSY);
        assert_eq!(s.next_event(), Some(445), "8 bits at 18 MHz");
        s.on_event(t(445));
        assert_eq!(s.take_finished(), Some(0xA5));
        s.complete(t(445), 0x3C);
        assert_eq!(s.read(t(445), SR) & (RXNE | BSY), RXNE);
        assert_eq!(s.read(t(445), DR), 0x3C);
        assert_eq!(s.read(t(445), SR) & RXNE, 0);
    }
}
