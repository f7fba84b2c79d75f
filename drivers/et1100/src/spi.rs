//! The SPI PDI (ESC-I 10.2 "SPI slave interface"; hardware-facts 1.2).
//!
//! Frame, MSB first:
//!
//! | Byte | 2-byte addressing (A < 0x2000) | 3-byte addressing          | MISO   |
//! |------|--------------------------------|----------------------------|--------|
//! | 0    | A\[12:5\]                      | A\[12:5\]                  | 0x0220 |
//! | 1    | A\[4:0\] << 3 \| CMD           | A\[4:0\] << 3 \| 0b110     | 0x0221 |
//! | 2    | -                              | A\[15:13\] << 5 \| CMD << 2 | 0x0222 |
//!
//! Reads use command 3: one 0xFF wait-state byte follows the address, then the data phase
//! clocks 0x00 per byte and 0xFF on the last byte (read termination). Writes send the data
//! right after the address.

use embedded_hal::spi::{Operation, SpiDevice};

use crate::pdi::check_range;
use crate::unconfirmed::READ_COMMAND;
use crate::{AlEvents, Error, Pdi};

/// SPI commands (ESC-I 10.2; SSC ET9300 header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Command {
    /// 000: no operation; the address phase still shifts out the events.
    Nop,
    /// Read; the concrete command (2 or 3) is [`READ_COMMAND`].
    Read,
    /// 100: write.
    Write,
}

impl Command {
    const fn bits(self) -> u8 {
        match self {
            Command::Nop => 0b000,
            Command::Read => READ_COMMAND,
            Command::Write => 0b100,
        }
    }
}

/// 110: address extension (3-byte addressing) in byte 1.
const ADDRESS_EXTENSION: u8 = 0b110;
/// Wait-state byte after the address of a command-3 read; also the read termination byte.
const WAIT: u8 = 0xFF;
/// Largest address reachable with 2-byte addressing.
const TWO_BYTE_LIMIT: u16 = 0x2000;

/// The address phase of one access: the bytes and how many are used (2 or 3).
fn address_phase(addr: u16, cmd: Command) -> ([u8; 3], usize) {
    let a0 = ((addr >> 5) & 0xFF) as u8;
    let low = ((addr & 0x1F) as u8) << 3;
    if addr < TWO_BYTE_LIMIT {
        ([a0, low | cmd.bits(), 0], 2)
    } else {
        let a2 = (((addr >> 13) & 0x07) as u8) << 5 | cmd.bits() << 2;
        ([a0, low | ADDRESS_EXTENSION, a2], 3)
    }
}

/// Events from the MISO bytes of an address phase (0x0220, 0x0221 and, after a third
/// address byte, 0x0222; what was not clocked out reads as 0).
fn events_from(miso: [u8; 3]) -> AlEvents {
    AlEvents::from_le_bytes([miso[0], miso[1], miso[2], 0])
}

/// The ET1100 SPI PDI on an [`SpiDevice`] (SPI mode 3; the device owns SPI_SEL).
///
/// Each access is exactly one [`SpiDevice::transaction`], so SPI_SEL frames it.
#[derive(Debug)]
pub struct SpiPdi<SPI> {
    spi: SPI,
}

impl<SPI: SpiDevice> SpiPdi<SPI> {
    /// Wraps the SPI device.
    pub fn new(spi: SPI) -> Self {
        Self { spi }
    }

    /// Gives the SPI device back.
    pub fn destroy(self) -> SPI {
        self.spi
    }

    /// The SPI device, e.g. to change its configuration.
    pub fn spi_mut(&mut self) -> &mut SPI {
        &mut self.spi
    }
}

impl<SPI: SpiDevice> Pdi for SpiPdi<SPI> {
    type BusError = SPI::Error;

    /// One transaction: `Transfer(address + 0xFF wait byte)`, then `TransferInPlace(buf)` with
    /// `buf` pre-filled 0x00 ... 0xFF (termination).
    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<AlEvents, Error<SPI::Error>> {
        check_range(addr, buf.len())?;
        let (a, n) = address_phase(addr, Command::Read);
        // The wait byte follows the address: at index 2 after a 2-byte address phase (the
        // third address byte is not sent then), at index 3 after a 3-byte one.
        let tx = [a[0], a[1], if n == 2 { WAIT } else { a[2] }, WAIT];
        let mut rx = [0u8; 4];
        if let Some((last, data)) = buf.split_last_mut() {
            data.fill(0x00);
            *last = WAIT;
        }
        self.spi
            .transaction(&mut [
                Operation::Transfer(&mut rx[..=n], &tx[..=n]),
                Operation::TransferInPlace(buf),
            ])
            .map_err(Error::Bus)?;
        Ok(events_from(if n == 2 {
            [rx[0], rx[1], 0]
        } else {
            [rx[0], rx[1], rx[2]]
        }))
    }

    /// One transaction: `Transfer(address)`, then `Write(data)`.
    fn write(&mut self, addr: u16, data: &[u8]) -> Result<AlEvents, Error<SPI::Error>> {
        check_range(addr, data.len())?;
        let (tx, n) = address_phase(addr, Command::Write);
        let mut rx = [0u8; 3];
        self.spi
            .transaction(&mut [
                Operation::Transfer(&mut rx[..n], &tx[..n]),
                Operation::Write(data),
            ])
            .map_err(Error::Bus)?;
        Ok(events_from(rx))
    }

    /// One transaction: a 3-byte NOP (`00 06 00`), so all of 0x0220..0x0222 are returned.
    fn events(&mut self) -> Result<AlEvents, Error<SPI::Error>> {
        let tx = [0x00, ADDRESS_EXTENSION, Command::Nop.bits() << 2];
        let mut rx = [0u8; 3];
        self.spi
            .transaction(&mut [Operation::Transfer(&mut rx, &tx)])
            .map_err(Error::Bus)?;
        Ok(events_from(rx))
    }

    /// A 2-byte NOP (address 0, command 000): two bytes on the bus instead of three.
    fn low_events(&mut self) -> Result<AlEvents, Error<SPI::Error>> {
        let tx = [0x00, Command::Nop.bits()];
        let mut rx = [0u8; 2];
        self.spi
            .transaction(&mut [Operation::Transfer(&mut rx, &tx)])
            .map_err(Error::Bus)?;
        Ok(events_from([rx[0], rx[1], 0]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_bits() {
        assert_eq!(Command::Nop.bits(), 0);
        assert_eq!(Command::Read.bits(), 3);
        assert_eq!(Command::Write.bits(), 4);
    }

    #[test]
    fn addressing() {
        assert_eq!(address_phase(0x0120, Command::Read), ([0x09, 0x03, 0], 2));
        assert_eq!(address_phase(0x1FFF, Command::Write), ([0xFF, 0xFC, 0], 2));
        assert_eq!(
            address_phase(0x3400, Command::Read),
            ([0xA0, 0x06, 0x2C], 3)
        );
        assert_eq!(
            address_phase(0x4200, Command::Write),
            ([0x10, 0x06, 0x50], 3)
        );
        assert_eq!(
            address_phase(0xFFFF, Command::Read),
            ([0xFF, 0xFE, 0xEC], 3)
        );
    }
}
