//! The AD5663 on SPI2 (18 MHz, mode 1, 8-bit frames; `firmware::platform::stm32f1::analog`):
//! the application's [`OutputDac`] on the SPI device with the GPIO SYNC (PB12) held low for
//! each 24-bit command, and LDAC from TIM8_CH2 ([`super::sync0::LdacPin`]). A command is three
//! bytes: written by the CPU (1.3 us), no DMA.

use super::gpio::{pin_of, OutPin};
use super::sync0::LdacPin;
use super::{pac, read, wait, write};
use embedded_hal::spi::{ErrorKind, ErrorType, SpiBus};
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
use firmware::io::analog::dac::OutputDac;
use firmware::platform::stm32f1::analog::DAC_SPI_CR1;
use firmware::platform::stm32f1::pins::Signal;

/// SPI_SR flags.
const RXNE: u16 = 1 << 0;
const TXE: u16 = 1 << 1;
const BSY: u16 = 1 << 7;
/// Polls of a flag: a byte takes 0.44 us (32 CPU cycles), a poll a few cycles.
const POLLS: u32 = 1_000;

/// The SPI port timed out (no clock, or the port disabled).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SpiTimeout;

impl embedded_hal::spi::Error for SpiTimeout {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// SPI2 as an 8-bit `SpiBus`, polled.
pub struct Spi2(pac::SPI2);

impl Spi2 {
    /// The port for the AD5663.
    pub fn new(spi: pac::SPI2) -> Self {
        write(spi.cr1(), DAC_SPI_CR1 as u16);
        Self(spi)
    }

    fn exchange(&mut self, out: u8) -> Result<u8, SpiTimeout> {
        let spi = &self.0;
        if !wait(POLLS, || read(spi.sr()) & TXE != 0) {
            return Err(SpiTimeout);
        }
        write(spi.dr(), u16::from(out));
        if !wait(POLLS, || read(spi.sr()) & RXNE != 0) {
            return Err(SpiTimeout);
        }
        Ok(read(spi.dr()) as u8)
    }
}

impl ErrorType for Spi2 {
    type Error = SpiTimeout;
}

impl SpiBus<u8> for Spi2 {
    fn read(&mut self, words: &mut [u8]) -> Result<(), SpiTimeout> {
        for w in words {
            *w = self.exchange(0)?;
        }
        Ok(())
    }

    fn write(&mut self, words: &[u8]) -> Result<(), SpiTimeout> {
        for &w in words {
            self.exchange(w)?;
        }
        Ok(())
    }

    fn transfer(&mut self, read: &mut [u8], write: &[u8]) -> Result<(), SpiTimeout> {
        for i in 0..read.len().max(write.len()) {
            let r = self.exchange(write.get(i).copied().unwrap_or(0))?;
            if let Some(slot) = read.get_mut(i) {
                *slot = r;
            }
        }
        Ok(())
    }

    fn transfer_in_place(&mut self, words: &mut [u8]) -> Result<(), SpiTimeout> {
        for w in words {
            *w = self.exchange(*w)?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), SpiTimeout> {
        let spi = &self.0;
        if wait(POLLS, || read(spi.sr()) & BSY == 0) {
            Ok(())
        } else {
            Err(SpiTimeout)
        }
    }
}

/// The AD5663's SPI device: SPI2 with the GPIO SYNC.
pub type DacSpiDevice = ExclusiveDevice<Spi2, OutPin, NoDelay>;

/// The AD5663 with its LDAC (owner: the SYNC0/DAC task).
pub type Dac = OutputDac<DacSpiDevice, LdacPin>;

/// The DAC on SPI2 with SYNC high until a command.
pub fn new(spi: pac::SPI2, ldac: LdacPin) -> Dac {
    let sync = OutPin::new(pin_of(Signal::DacSync), true);
    let device = match ExclusiveDevice::new_no_delay(Spi2::new(spi), sync) {
        Ok(d) => d,
        Err(never) => match never {},
    };
    match OutputDac::new(device, ldac) {
        Ok(d) => d,
        Err(never) => match never {},
    }
}
