//! The AD5663 on SSP0 (hardware-facts 5): 24-bit frames `x x C2 C1 C0 A2 A1 A0 | D15..D0`,
//! MSB first, SYNC (GPIO) low for the whole frame, data taken on the falling SCLK edge.
//!
//! Stand-in for the `ad5663` driver crate (still a stub at the time of writing): the four
//! commands the DAC task needs, byte-exact as the virtual board's AD5663 model expects. When
//! the driver lands, [`Dac`] keeps its API and delegates.

use super::board::DacSpiDevice;
use super::gpio::OutPin;
use embedded_hal::spi::SpiDevice;
use firmware::app::outputs::{DacAction, DacPair};

/// Commands (C2..C0).
mod cmd {
    pub const WRITE_INPUT: u8 = 0b000;
    pub const WRITE_INPUT_UPDATE_ALL: u8 = 0b010;
    pub const POWER: u8 = 0b100;
    pub const LDAC_REGISTER: u8 = 0b110;
}

/// Addresses (A2..A0).
mod addr {
    pub const A: u8 = 0b000;
    pub const B: u8 = 0b001;
    pub const BOTH: u8 = 0b111;
}

/// The frame bytes of one command.
pub const fn frame(command: u8, address: u8, data: u16) -> [u8; 3] {
    [command << 3 | address, (data >> 8) as u8, data as u8]
}

/// The DAC's bus error.
pub type DacError = <DacSpiDevice as embedded_hal::spi::ErrorType>::Error;

/// The AD5663 with its LDAC pin (owner: the SYNC0/DAC task).
pub struct Dac {
    spi: DacSpiDevice,
    ldac: OutPin,
}

impl Dac {
    /// The DAC on its device; LDAC idles high.
    pub fn new(spi: DacSpiDevice, ldac: OutPin) -> Self {
        Self { spi, ldac }
    }

    fn send(&mut self, command: u8, address: u8, data: u16) -> Result<(), DacError> {
        self.spi.write(&frame(command, address, data))
    }

    /// Power-up state for the SYNC0 scheme: both channels powered (normal operation), LDAC
    /// register 0 (the LDAC pin updates both channels together).
    pub fn init(&mut self) -> Result<(), DacError> {
        self.send(cmd::POWER, addr::BOTH, 0x0003)?; // DB5:4 = 00 normal, DB1:0 = both
        self.send(cmd::LDAC_REGISTER, addr::BOTH, 0x0000)
    }

    /// Writes both input registers without changing the outputs (DC fast path).
    pub fn preload(&mut self, pair: DacPair) -> Result<(), DacError> {
        self.send(cmd::WRITE_INPUT, addr::A, pair.a)?;
        self.send(cmd::WRITE_INPUT, addr::B, pair.b)
    }

    /// Pulses LDAC (>= 20 ns low): both outputs take their input registers together.
    pub fn pulse_ldac(&mut self) {
        self.ldac.set(false);
        cortex_m::asm::delay(4); // 40 ns at 100 MHz
        self.ldac.set(true);
    }

    /// Carries out the DAC task's action.
    pub fn execute(&mut self, action: DacAction) -> Result<(), DacError> {
        match action {
            DacAction::Keep => Ok(()),
            DacAction::PulseLdac(_) => {
                self.pulse_ldac();
                Ok(())
            }
            DacAction::WriteAndUpdate(pair) => {
                self.send(cmd::WRITE_INPUT, addr::A, pair.a)?;
                self.send(cmd::WRITE_INPUT_UPDATE_ALL, addr::B, pair.b)
            }
        }
    }
}
