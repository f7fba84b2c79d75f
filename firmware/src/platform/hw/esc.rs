//! The ET1100 on the board: the `et1100` driver over the legacy-SPI device. The slave
//! application takes this `Et1100` as it is (generic over the driver's `Pdi`), so the board
//! runs the same ESC access code as the virtual board and the benchmarks.

use super::cs_device::CsDevice;
use super::spi::LegacySpi;
use et1100::{Et1100, SpiPdi};

/// The ET1100's SPI device: the legacy SPI with the GPIO SPI_SEL held low for a whole
/// transaction (one `SpiDevice::transaction` per ESC access).
pub type EscSpiDevice = CsDevice<LegacySpi>;

/// The ET1100 on its SPI device (owner: the PDI task).
pub type Esc = Et1100<SpiPdi<EscSpiDevice>>;

/// The ESC on its SPI device.
pub fn new(spi: EscSpiDevice) -> Esc {
    Et1100::new(SpiPdi::new(spi))
}
