//! The SSP ports (ARM PL022; UM10360 chapter 18): SSP0 at 0x4008_8000, SSP1 at
//! 0x4003_0000. 8-frame TX and RX FIFOs, frames of 4..16 bits, SCK = PCLK / (CPSDVSR x
//! (SCR + 1)), DMA requests (RX: FIFO not empty; TX: FIFO not full) when DMACR enables them.
//!
//! Master only. A frame starts when the TX FIFO holds one and the port is enabled; at its
//! end [`crate::machine`] exchanges it with the device on the pins
//! ([`Ssp::take_finished`] / [`Ssp::receive`]). A frame that arrives to a full RX FIFO is
//! lost (RORRIS).

use super::{ticks_to_ns, Peripheral, Tick};
use std::collections::VecDeque;

/// PL022 FIFO depth.
pub const FIFO: usize = 8;

const CR1_SSE: u32 = 1 << 1;
const CR1_MS: u32 = 1 << 2;

/// One SSP port.
#[derive(Clone, Debug, Default)]
pub struct Ssp {
    cr0: u32,
    cr1: u32,
    cpsr: u32,
    imsc: u32,
    ris: u32,
    dmacr: u32,
    tx: VecDeque<u16>,
    rx: VecDeque<u16>,
    shifting: Option<(u16, u64)>,
    finished: Option<u16>,
    /// Frames sent.
    pub frames: u64,
    /// Frames lost to a full RX FIFO.
    pub overruns: u64,
    /// Rule violations (once each).
    pub violations: Vec<String>,
}

impl Ssp {
    /// Reset state.
    pub fn new() -> Self {
        Self::default()
    }

    fn violation(&mut self, msg: String) {
        if !self.violations.contains(&msg) {
            self.violations.push(msg);
        }
    }

    /// Bits per frame (DSS + 1).
    pub fn frame_bits(&self) -> u32 {
        (self.cr0 & 0xF) + 1
    }

    /// SPI mode (CPOL b6, CPHA b7) as 0..=3.
    pub fn mode(&self) -> u8 {
        (u8::from(self.cr0 & (1 << 6) != 0) << 1) | u8::from(self.cr0 & (1 << 7) != 0)
    }

    /// SCK at `pclk_hz`.
    pub fn sck_hz(&self, pclk_hz: u64) -> u64 {
        let scr = u64::from((self.cr0 >> 8) & 0xFF);
        pclk_hz / (u64::from(self.cpsr.max(2)) * (scr + 1))
    }

    fn enabled(&self) -> bool {
        self.cr1 & CR1_SSE != 0
    }

    /// RX DMA request (RX FIFO not empty, DMACR.RXDMAE).
    pub fn rx_dma_request(&self) -> bool {
        self.dmacr & 1 != 0 && !self.rx.is_empty()
    }

    /// TX DMA request (TX FIFO not full, DMACR.TXDMAE).
    pub fn tx_dma_request(&self) -> bool {
        self.dmacr & 2 != 0 && self.tx.len() < FIFO
    }

    /// The frame whose last bit just went out (for the machine to exchange).
    pub fn take_finished(&mut self) -> Option<u16> {
        self.finished.take()
    }

    /// What the device sent during the finished frame.
    pub fn receive(&mut self, word: u16) {
        if self.rx.len() >= FIFO {
            self.overruns += 1;
            self.ris |= 1; // RORRIS
        } else {
            self.rx
                .push_back(word & ((1u32 << self.frame_bits()) - 1) as u16);
        }
    }

    /// Starts the next frame if one waits (after [`Ssp::receive`] or a DR write).
    pub fn kick(&mut self, t: Tick) {
        if self.shifting.is_some() || !self.enabled() {
            return;
        }
        if let Some(w) = self.tx.pop_front() {
            let scr = u64::from((self.cr0 >> 8) & 0xFF);
            let pclk_per_bit = u64::from(self.cpsr.max(2)) * (scr + 1);
            let ns = ticks_to_ns(u64::from(self.frame_bits()) * pclk_per_bit, t.pclk_hz);
            self.shifting = Some((w, t.now_ns + ns.max(1)));
        }
    }

    fn sr(&self) -> u32 {
        let busy = self.shifting.is_some() || !self.tx.is_empty();
        u32::from(self.tx.is_empty())
            | u32::from(self.tx.len() < FIFO) << 1
            | u32::from(!self.rx.is_empty()) << 2
            | u32::from(self.rx.len() >= FIFO) << 3
            | u32::from(busy) << 4
    }
}

impl Peripheral for Ssp {
    fn read(&mut self, _t: Tick, offset: u32) -> u32 {
        match offset {
            0x00 => self.cr0,
            0x04 => self.cr1,
            0x08 => u32::from(self.rx.pop_front().unwrap_or(0)),
            0x0C => self.sr(),
            0x10 => self.cpsr,
            0x14 => self.imsc,
            0x18 => self.ris,
            0x1C => self.ris & self.imsc,
            0x24 => self.dmacr,
            _ => 0,
        }
    }

    fn write(&mut self, t: Tick, offset: u32, value: u32) {
        match offset {
            0x00 => self.cr0 = value & 0xFFFF,
            0x04 => {
                self.cr1 = value & 0xF;
                if self.cr1 & CR1_MS != 0 {
                    self.violation("SSP slave mode (CR1.MS) is not modelled".into());
                }
                self.kick(t);
            }
            0x08 if self.tx.len() < FIFO => {
                self.tx.push_back(value as u16);
                self.kick(t);
            }
            0x10 => {
                if value & 1 != 0 || value < 2 {
                    self.violation(format!("CPSR = {value} (UM10360 18.6.5: even, 2..=254)"));
                }
                self.cpsr = value & 0xFF;
            }
            0x14 => self.imsc = value & 0xF,
            0x20 => self.ris &= !(value & 3),
            0x24 => self.dmacr = value & 3,
            _ => {}
        }
    }

    fn next_event(&self) -> Option<u64> {
        self.shifting.map(|(_, end)| end)
    }

    fn on_event(&mut self, t: Tick) {
        if let Some((w, end)) = self.shifting {
            if t.now_ns >= end {
                self.shifting = None;
                self.frames += 1;
                self.finished = Some(w);
            }
        }
    }

    fn irq(&self) -> bool {
        self.ris & self.imsc != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periph::testing::t;

    #[test]
    fn frames_take_bits_times_the_sck_period_and_fill_the_rx_fifo() {
        let mut s = Ssp::new();
        s.write(t(0), 0x00, 0x07 | (1 << 7)); // 8 bits, mode 1, SCR 0
        s.write(t(0), 0x10, 4); // 25 MHz
        s.write(t(0), 0x04, CR1_SSE);
        assert_eq!((s.mode(), s.sck_hz(100_000_000)), (1, 25_000_000));
        for b in [1, 2, 3] {
            s.write(t(0), 0x08, b);
        }
        assert_eq!(
            s.read(t(0), 0x0C) & 0b10011,
            0b10010,
            "busy, not empty, not full"
        );
        assert_eq!(s.next_event(), Some(320));
        s.on_event(t(320));
        assert_eq!(s.take_finished(), Some(1));
        s.receive(0xAB);
        s.kick(t(320));
        assert_eq!(s.next_event(), Some(640));
        assert_eq!(s.read(t(320), 0x08), 0xAB);
    }

    #[test]
    fn dma_requests_follow_the_fifos() {
        let mut s = Ssp::new();
        s.write(t(0), 0x00, 0x0F);
        s.write(t(0), 0x10, 2);
        s.write(t(0), 0x24, 1);
        assert!(!s.rx_dma_request());
        s.receive(0x1234);
        assert!(s.rx_dma_request());
        for _ in 0..FIFO {
            s.receive(0);
        }
        assert_eq!(s.overruns, 1);
    }
}
