//! Public types: errors, channel and mode selectors, chip markers.

use core::convert::Infallible;
use core::fmt;
use embedded_hal::digital;

/// All errors of this crate.
///
/// `CommE` is the error of the [`SpiDevice`](embedded_hal::spi::SpiDevice), `PinE` the error
/// of the optional LDAC pin ([`Infallible`] when the driver has no pin, see [`NoLdac`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<CommE, PinE = Infallible> {
    /// The SPI device reported an error. The frame may or may not have reached the DAC.
    Comm(CommE),
    /// The LDAC pin reported an error.
    Pin(PinE),
    /// A channel index that names no DAC channel (only 0 = A and 1 = B exist).
    InvalidChannel,
    /// A voltage outside the output range of the [`OutputScale`](crate::OutputScale), or
    /// not a number. Nothing was sent.
    OutOfRange,
}

impl<CommE: fmt::Debug, PinE: fmt::Debug> fmt::Display for Error<CommE, PinE> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Comm(e) => write!(f, "SPI error: {e:?}"),
            Error::Pin(e) => write!(f, "LDAC pin error: {e:?}"),
            Error::InvalidChannel => f.write_str("no such DAC channel"),
            Error::OutOfRange => f.write_str("voltage outside the output range"),
        }
    }
}

impl<CommE: fmt::Debug, PinE: fmt::Debug> core::error::Error for Error<CommE, PinE> {}

impl<CommE, PinE> From<InvalidChannel> for Error<CommE, PinE> {
    fn from(_: InvalidChannel) -> Self {
        Error::InvalidChannel
    }
}

/// The index given to [`Channel::try_from`] names no channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InvalidChannel(pub u8);

/// DAC channel selector (address bits DB18..DB16, AD5663 datasheet Table 8 / AD5663R Table 9).
///
/// Every command of the AD5663 accepts [`Channel::Both`] (address 111, "all DACs"), so no
/// driver method rejects it; [`Channel::try_from`] maps the indices 0 and 1 (for example the
/// sub-indices 1 and 2 of a CiA 401 object minus one) and rejects every other index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Channel {
    /// DAC A (address 000).
    A,
    /// DAC B (address 001).
    B,
    /// Both DACs (address 111).
    Both,
}

impl Channel {
    /// The address field A2..A0.
    pub(crate) const fn address(self) -> u8 {
        match self {
            Channel::A => 0b000,
            Channel::B => 0b001,
            Channel::Both => 0b111,
        }
    }

    /// The channel-select bits DB1 (B) and DB0 (A) of the power-down and LDAC commands.
    pub(crate) const fn select_bits(self) -> u16 {
        match self {
            Channel::A => 0b01,
            Channel::B => 0b10,
            Channel::Both => 0b11,
        }
    }
}

impl TryFrom<u8> for Channel {
    type Error = InvalidChannel;

    /// 0 -> A, 1 -> B; any other index is an error.
    fn try_from(index: u8) -> Result<Self, Self::Error> {
        match index {
            0 => Ok(Channel::A),
            1 => Ok(Channel::B),
            n => Err(InvalidChannel(n)),
        }
    }
}

/// Power mode of a channel (command 100, bits DB5:DB4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PowerMode {
    /// Normal operation (00), the power-on mode.
    #[default]
    Normal,
    /// Powered down, output 1 kΩ to GND (01).
    PullDown1k,
    /// Powered down, output 100 kΩ to GND (10).
    PullDown100k,
    /// Powered down, output three-state (11).
    ThreeState,
}

impl PowerMode {
    pub(crate) const fn bits(self) -> u16 {
        match self {
            PowerMode::Normal => 0b00,
            PowerMode::PullDown1k => 0b01,
            PowerMode::PullDown100k => 0b10,
            PowerMode::ThreeState => 0b11,
        }
    }
}

/// What the software reset (command 101) clears, selected by DB0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetMode {
    /// DB0 = 0: the input and DAC registers go to zero scale.
    DacAndInputRegisters,
    /// DB0 = 1: also the LDAC and power-down registers (back to power-on state).
    ///
    /// **UNCONFIRMED** (see [`unconfirmed::FULL_RESET_DB0`](crate::unconfirmed::FULL_RESET_DB0)).
    All,
}

/// LDAC register (command 110, DB1 = B, DB0 = A): the channels whose bit is 1 are
/// *transparent*: their DAC register follows every input-register write at once and the LDAC
/// pin is ignored for them. Channels with bit 0 update only on the LDAC pin (active low), on
/// "update DAC n" or on "write input n, update all". Power-on value: [`LdacMask::None`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LdacMask {
    /// No channel transparent (both follow the LDAC pin): the power-on state.
    #[default]
    None,
    /// Channel A transparent.
    A,
    /// Channel B transparent.
    B,
    /// Both channels transparent (the thesis word 0x00300003).
    Both,
}

impl LdacMask {
    pub(crate) const fn bits(self) -> u16 {
        match self {
            LdacMask::None => 0b00,
            LdacMask::A => 0b01,
            LdacMask::B => 0b10,
            LdacMask::Both => 0b11,
        }
    }
}

/// Placeholder for "no LDAC pin" (the pin is tied or not used).
///
/// It implements only [`digital::ErrorType`] (error [`Infallible`]), not `OutputPin`, so
/// [`Ad5663::pulse_ldac`](crate::Ad5663::pulse_ldac) does not exist for a driver without a pin.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NoLdac;

impl digital::ErrorType for NoLdac {
    type Error = Infallible;
}

/// Chip variants (type markers for [`Ad5663`](crate::Ad5663)).
pub mod ic {
    /// AD5663: external reference only. Command 111 is reserved and cannot be sent.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    #[cfg_attr(feature = "defmt", derive(defmt::Format))]
    pub struct Ad5663;

    /// AD5663R: with internal reference, switched by command 111.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    #[cfg_attr(feature = "defmt", derive(defmt::Format))]
    pub struct Ad5663R;
}
