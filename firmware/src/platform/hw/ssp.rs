//! The SSP ports (ARM PL022): SSP0 (0x4008_8000) for the AD5663 and SSP1 (0x4003_0000) for
//! the AD7689 (UM10360 chapter 18, hardware-facts section 7). 8-entry FIFOs in both
//! directions; SCK = PCLK / (CPSDVSR * (SCR + 1)).
//!
//! [`Ssp`] is an `SpiBus<u8>` that keeps the TX FIFO filled ahead of the RX side (up to
//! [`FIFO_DEPTH`] frames in flight); with the GPIO SYNC pin of [`crate::hw::dac::DacSpiDevice`]
//! it is the AD5663's `SpiDevice`. SSP1 runs 16-bit frames for the timer-driven AD7689 path
//! ([`crate::hw::timers::AdcSampler`]), which uses the raw FIFO helpers below.

use core::ops::Deref;
use embedded_hal::spi::{ErrorKind, ErrorType, SpiBus};
use lpc17xx_pac as pac;

/// PL022 FIFO depth.
pub const FIFO_DEPTH: usize = 8;

const SR_TFE: u32 = 1 << 0;
const SR_TNF: u32 = 1 << 1;
const SR_RNE: u32 = 1 << 2;
const SR_BSY: u32 = 1 << 4;
const CR1_SSE: u32 = 1 << 1;
/// Poll budget per frame: a 16-bit frame at the slowest clock used (16.7 MHz) is 96 CPU
/// cycles; 2000 polls are many frame times.
const POLLS: u32 = 2000;

/// The register block shared by SSP0 and SSP1.
pub trait SspInstance: Deref<Target = pac::ssp1::RegisterBlock> {}
impl SspInstance for pac::SSP0 {}
impl SspInstance for pac::SSP1 {}

/// Frame format and clock of one port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SspConfig {
    /// CR0: DSS [3:0] = bits - 1, FRF [5:4] = 0 (SPI), CPOL b6, CPHA b7, SCR [15:8].
    pub cr0: u32,
    /// CPSR: even prescaler 2..=254.
    pub cpsr: u32,
}

impl SspConfig {
    /// AD5663: 8-bit frames, mode 1 (CPOL 0, CPHA 1: data sampled on the falling edge),
    /// 100 MHz / (4 * 1) = 25 MHz (the LPC's SSP master limit is ~33 MHz).
    pub const AD5663: Self = Self {
        cr0: 0x07 | (1 << 7),
        cpsr: 4,
    };
    /// AD7689 without busy indicator: 16-bit frames, mode 0 (CPOL 0, CPHA 0),
    /// 100 MHz / (2 * (2 + 1)) = 16.7 MHz (safe for the ADC's SDO timing, hardware-facts 6).
    pub const AD7689: Self = Self {
        cr0: 0x0F | (2 << 8),
        cpsr: 2,
    };

    /// SCK in Hz at `pclk_hz`.
    pub const fn sck_hz(&self, pclk_hz: u32) -> u32 {
        pclk_hz / (self.cpsr * (((self.cr0 >> 8) & 0xFF) + 1))
    }
}

// 12.5 MHz / 25 MHz limits checked at compile time.
const _: () = assert!(SspConfig::AD5663.sck_hz(super::PCLK_HZ) == 25_000_000);
const _: () = assert!(SspConfig::AD7689.sck_hz(super::PCLK_HZ) <= 16_700_000);

/// A bus error of an SSP port.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum SspError {
    /// The FIFO did not move within the poll budget.
    Timeout,
}

impl embedded_hal::spi::Error for SspError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// An SSP port as master.
pub struct Ssp<S: SspInstance> {
    ssp: S,
}

impl<S: SspInstance> Ssp<S> {
    /// Configures and enables the port (pins and PCLK are set by the board).
    pub fn new(ssp: S, config: SspConfig) -> Self {
        // SAFETY: documented register values (UM10360 18.6).
        ssp.cr1.write(|w| unsafe { w.bits(0) });
        ssp.cr0.write(|w| unsafe { w.bits(config.cr0) });
        ssp.cpsr.write(|w| unsafe { w.bits(config.cpsr) });
        ssp.imsc.write(|w| unsafe { w.bits(0) });
        ssp.cr1.write(|w| unsafe { w.bits(CR1_SSE) });
        let mut s = Self { ssp };
        s.drain_rx();
        s
    }

    /// Discards whatever the RX FIFO holds (bounded by the FIFO depth).
    pub fn drain_rx(&mut self) {
        for _ in 0..FIFO_DEPTH * 2 {
            if self.ssp.sr.read().bits() & SR_RNE == 0 {
                break;
            }
            let _ = self.ssp.dr.read().bits();
        }
    }

    /// Queues one frame if the TX FIFO has room; `false` if full.
    #[inline(always)]
    pub fn try_push(&mut self, frame: u16) -> bool {
        if self.ssp.sr.read().bits() & SR_TNF == 0 {
            return false;
        }
        // SAFETY: DR takes one frame of the configured size.
        self.ssp.dr.write(|w| unsafe { w.bits(u32::from(frame)) });
        true
    }

    /// Lets the GPDMA empty the RX FIFO (DMACR RXDMAE, b0; TX stays CPU/timer driven).
    pub fn enable_rx_dma(&mut self) {
        self.drain_rx();
        // SAFETY: DMACR bit 0 = RX DMA request enable (UM10360 18.6.9, hardware-facts 7).
        self.ssp.dmacr.write(|w| unsafe { w.bits(1) });
    }

    /// Address of the data register (the GPDMA's source/destination).
    pub fn dr_address(&self) -> u32 {
        core::ptr::addr_of!(self.ssp.dr) as u32
    }

    /// Takes one received frame if there is one.
    #[inline(always)]
    pub fn try_pop(&mut self) -> Option<u16> {
        if self.ssp.sr.read().bits() & SR_RNE == 0 {
            return None;
        }
        Some(self.ssp.dr.read().bits() as u16)
    }

    /// Runs one bus operation, FIFO kept full. Two copies: one for the writes of the DAC
    /// preload in every DC cycle ([`WriteOnly`]: no decision per frame), one for the other
    /// three operations ([`Frames`]); the DAC's SPI transaction inlines every operation, so
    /// a loop per operation would all land in the flash image.
    #[inline(never)]
    fn run(&mut self, mut frames: impl Buffers) -> Result<(), SspError> {
        let n = frames.len();
        let (mut sent, mut got, mut idle) = (0, 0, 0u32);
        while got < n {
            let mut progress = false;
            while sent < n && sent - got < FIFO_DEPTH && self.try_push(u16::from(frames.tx(sent))) {
                sent += 1;
                progress = true;
            }
            if let Some(b) = self.try_pop() {
                frames.rx(got, b as u8);
                got += 1;
                progress = true;
            }
            if progress {
                idle = 0;
            } else {
                idle += 1;
                if idle > POLLS {
                    return Err(SspError::Timeout);
                }
            }
        }
        Ok(())
    }

    fn wait_idle(&mut self) -> Result<(), SspError> {
        for _ in 0..POLLS {
            let sr = self.ssp.sr.read().bits();
            if sr & SR_TFE != 0 && sr & SR_BSY == 0 {
                return Ok(());
            }
        }
        Err(SspError::Timeout)
    }
}

impl<S: SspInstance> ErrorType for Ssp<S> {
    type Error = SspError;
}

/// The buffers of one bus operation: what frame `i` sends and where its reply goes.
trait Buffers {
    /// Frames of the operation.
    fn len(&self) -> usize;
    /// The byte frame `i` sends.
    fn tx(&self, i: usize) -> u8;
    /// Takes the reply to frame `i`.
    fn rx(&mut self, i: usize, b: u8);
}

/// Bytes out, replies dropped (the common operation: the AD5663's frames).
struct WriteOnly<'a>(&'a [u8]);

impl Buffers for WriteOnly<'_> {
    fn len(&self) -> usize {
        self.0.len()
    }

    fn tx(&self, i: usize) -> u8 {
        self.0.get(i).copied().unwrap_or(0)
    }

    fn rx(&mut self, _: usize, _: u8) {}
}

/// The other operations' buffers.
enum Frames<'a> {
    /// Zeros out, replies kept.
    Read(&'a mut [u8]),
    /// `max(len)` frames: `write` (then zeros) out, replies into `read` (the rest dropped).
    Transfer(&'a mut [u8], &'a [u8]),
    /// Bytes out, each replaced by its reply. Frames in flight are at most FIFO_DEPTH
    /// behind, and byte i is sent before it is overwritten by its own reply (reply i arrives
    /// after send i).
    InPlace(&'a mut [u8]),
}

impl Buffers for Frames<'_> {
    fn len(&self) -> usize {
        match self {
            Frames::Read(r) | Frames::InPlace(r) => r.len(),
            Frames::Transfer(r, w) => r.len().max(w.len()),
        }
    }

    fn tx(&self, i: usize) -> u8 {
        match self {
            Frames::Read(_) => 0,
            Frames::Transfer(_, w) => w.get(i).copied().unwrap_or(0),
            Frames::InPlace(w) => w.get(i).copied().unwrap_or(0),
        }
    }

    fn rx(&mut self, i: usize, b: u8) {
        match self {
            Frames::Read(r) | Frames::Transfer(r, _) | Frames::InPlace(r) => {
                if let Some(slot) = r.get_mut(i) {
                    *slot = b;
                }
            }
        }
    }
}

impl<S: SspInstance> SpiBus<u8> for Ssp<S> {
    fn read(&mut self, words: &mut [u8]) -> Result<(), SspError> {
        self.run(Frames::Read(words))
    }

    fn write(&mut self, words: &[u8]) -> Result<(), SspError> {
        self.run(WriteOnly(words))
    }

    fn transfer(&mut self, read: &mut [u8], write: &[u8]) -> Result<(), SspError> {
        self.run(Frames::Transfer(read, write))
    }

    fn transfer_in_place(&mut self, words: &mut [u8]) -> Result<(), SspError> {
        self.run(Frames::InPlace(words))
    }

    fn flush(&mut self) -> Result<(), SspError> {
        self.wait_idle()
    }
}
