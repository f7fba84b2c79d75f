//! The AD5663 on SSP0 (hardware-facts 5): the application's [`OutputDac`] (the `ad5663`
//! driver carrying out the DAC task's actions) on the board's SPI device (SSP0, mode 1,
//! 25 MHz, GPIO SYNC held low for each 24-bit frame) and LDAC pin.

use super::cs_device::CsDevice;
use super::gpio::OutPin;
use super::ssp::Ssp;
use super::CCLK_HZ;
use core::convert::Infallible;
use firmware::io::analog::dac::OutputDac;

/// The AD5663's SPI device: SSP0 with the GPIO SYNC held low for a whole 24-bit frame.
pub type DacSpiDevice = CsDevice<Ssp<lpc17xx_pac::SSP0>>;

/// The AD5663 with its LDAC pin (owner: the SYNC0/DAC task).
pub type Dac = OutputDac<DacSpiDevice, LdacPin>;

/// The DAC's error on this board.
/// CPU cycles LDAC stays low: twice the (UNCONFIRMED) minimum pulse width of the driver's
/// `unconfirmed` module, 4 cycles = 40 ns at 100 MHz. Two back-to-back writes to the fast
/// GPIO block can be as short as two cycles, too close to that minimum.
const LDAC_LOW_CYCLES: u32 =
    (2 * ad5663::unconfirmed::LDAC_LOW_MIN_NS * (CCLK_HZ / 1_000_000)).div_ceil(1000);

/// The LDAC pin (P2.3, active low) with a guaranteed low time before it rises again.
#[derive(Debug)]
pub struct LdacPin(OutPin);

impl LdacPin {
    /// The pin from the board's pin map.
    pub fn new(pin: OutPin) -> Self {
        Self(pin)
    }
}

impl embedded_hal::digital::ErrorType for LdacPin {
    type Error = Infallible;
}

impl embedded_hal::digital::OutputPin for LdacPin {
    #[inline(always)]
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.set(false);
        Ok(())
    }

    /// Waits out the minimum low time first (also when the pin was already high: the
    /// driver only raises it at construction and at the end of a pulse).
    #[inline(always)]
    fn set_high(&mut self) -> Result<(), Infallible> {
        cortex_m::asm::delay(LDAC_LOW_CYCLES);
        self.0.set(true);
        Ok(())
    }
}
