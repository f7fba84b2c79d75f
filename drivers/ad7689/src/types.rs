//! Public types: errors, samples, channels.

use core::convert::Infallible;
use core::fmt;

/// All errors of this crate.
///
/// `CommE` is the error of the [`SpiDevice`](embedded_hal::spi::SpiDevice), `PinE` the error of
/// the CNV/SDO pins in busy-indicator mode ([`Infallible`] in read-after-conversion mode).
///
/// After `Comm`, `Pin` (from a frame) or `ReadbackMismatch` the driver no longer knows which
/// conversion is in flight: reads return `None` until a CFG written with
/// [`read_and_configure`](crate::Ad7689::read_and_configure) has come through the pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<CommE, PinE = Infallible> {
    /// The SPI device reported an error.
    Comm(CommE),
    /// The CNV or SDO pin reported an error.
    Pin(PinE),
    /// A [`Config`](crate::Config) with a channel above 7. Nothing was sent.
    InvalidChannel,
    /// The busy indicator (SDO low) did not come within the timeout. Nothing was sent.
    Timeout,
    /// The CFG read back after the result is not the one the driver wrote for that
    /// conversion (14-bit values).
    ReadbackMismatch {
        /// The CFG the driver expected.
        expected: u16,
        /// The CFG the ADC sent.
        read: u16,
    },
}

impl<CommE: fmt::Debug, PinE: fmt::Debug> fmt::Display for Error<CommE, PinE> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Comm(e) => write!(f, "SPI error: {e:?}"),
            Error::Pin(e) => write!(f, "pin error: {e:?}"),
            Error::InvalidChannel => f.write_str("channel above 7"),
            Error::Timeout => f.write_str("no end of conversion within the timeout"),
            Error::ReadbackMismatch { expected, read } => {
                write!(f, "CFG readback {read:#06x}, expected {expected:#06x}")
            }
        }
    }
}

impl<CommE: fmt::Debug, PinE: fmt::Debug> core::error::Error for Error<CommE, PinE> {}

/// What a conversion measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Channel {
    /// Input `n` (0..=7): single-ended, or the positive input of a pair.
    In(u8),
    /// The internal temperature sensor.
    Temperature,
}

impl Channel {
    /// The input number, `None` for the temperature sensor.
    pub const fn input(self) -> Option<u8> {
        match self {
            Channel::In(n) => Some(n),
            Channel::Temperature => None,
        }
    }
}

/// One conversion result, tagged with what it measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// The input (or the temperature sensor) the result belongs to.
    pub channel: Channel,
    /// The raw 16-bit result: straight binary in the unipolar modes, two's complement in the
    /// bipolar ones (see [`unipolar_volts`](crate::unipolar_volts),
    /// [`bipolar_volts`](crate::bipolar_volts)).
    pub code: u16,
}

/// Placeholder for "no SDO pin" in busy-indicator mode: the driver then waits the maximum
/// conversion time instead of watching the busy indicator (for example because the caller
/// already saw the SDO falling edge as an interrupt).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NoPin;
