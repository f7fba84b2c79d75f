//! The ET1100 on the board: the `et1100` driver over the legacy-SPI device, and the slave
//! application's [`EscPort`] on top of it (the seam between `firmware::app` and the driver).

use super::board::EscSpiDevice;
use et1100::{Et1100, Pdi, SpiPdi};
use firmware::app::esc::EscPort;

/// The driver type on this board.
pub type Esc = Et1100<SpiPdi<EscSpiDevice>>;

/// The driver's error on this board.
pub type EscError = et1100::Error<<SpiPdi<EscSpiDevice> as Pdi>::BusError>;

/// The ET1100 (owner: the PDI task).
pub struct EscPdi {
    esc: Esc,
}

impl EscPdi {
    /// The ESC on its SPI device.
    pub fn new(spi: EscSpiDevice) -> Self {
        Self {
            esc: Et1100::new(SpiPdi::new(spi)),
        }
    }

    /// The driver, for register helpers beyond [`EscPort`].
    pub fn driver(&mut self) -> &mut Esc {
        &mut self.esc
    }
}

impl EscPort for EscPdi {
    type Error = EscError;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<u32, EscError> {
        if buf.is_empty() {
            return self.events();
        }
        self.esc.read(addr, buf).map(|e| e.bits())
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<u32, EscError> {
        if data.is_empty() {
            return self.events();
        }
        self.esc.write(addr, data).map(|e| e.bits())
    }

    /// The NOP access (2 address bytes): AL event bits 0..15 (AL control, DC, SM0..SM7).
    fn events(&mut self) -> Result<u32, EscError> {
        self.esc.events().map(|e| e.bits())
    }
}
