//! The driver.

use crate::command::Command;
use crate::scale::OutputScale;
use crate::types::{ic, Channel, Error, LdacMask, NoLdac, PowerMode, ResetMode};
use core::marker::PhantomData;
use embedded_hal::digital::{self, OutputPin};
use embedded_hal::spi::{Operation, SpiDevice};

/// AD5663 / AD5663R driver.
///
/// - `SPI`: the [`SpiDevice`]; its chip select is the DAC's SYNC pin (active low, one
///   transaction = one 24-bit frame). SPI mode [`MODE`](crate::MODE).
/// - `IC`: the chip variant, [`ic::Ad5663`] or [`ic::Ad5663R`]; only the latter has
///   [`set_internal_reference`](Ad5663::set_internal_reference).
/// - `LDAC`: the LDAC pin ([`OutputPin`]) or [`NoLdac`]; only with a pin is there
///   [`pulse_ldac`](Ad5663::pulse_ldac).
///
/// The constructors send nothing: the DAC keeps its power-on state (outputs at zero scale,
/// LDAC register 0 = both channels wait for the LDAC pin, normal power mode).
#[derive(Debug)]
pub struct Ad5663<SPI, IC = ic::Ad5663, LDAC = NoLdac> {
    spi: SPI,
    ldac: LDAC,
    _ic: PhantomData<IC>,
}

impl<SPI> Ad5663<SPI, ic::Ad5663, NoLdac> {
    /// A driver for the AD5663 (external reference only) on `spi`. Sends nothing.
    pub const fn new_ad5663(spi: SPI) -> Self {
        Self {
            spi,
            ldac: NoLdac,
            _ic: PhantomData,
        }
    }
}

impl<SPI> Ad5663<SPI, ic::Ad5663R, NoLdac> {
    /// A driver for the AD5663R (with internal reference) on `spi`. Sends nothing.
    pub const fn new_ad5663r(spi: SPI) -> Self {
        Self {
            spi,
            ldac: NoLdac,
            _ic: PhantomData,
        }
    }
}

impl<SPI, IC> Ad5663<SPI, IC, NoLdac> {
    /// Gives the driver the LDAC pin and drives it high (inactive), so nothing latches by
    /// accident. On a pin error the driver is dropped; the error is returned.
    pub fn with_ldac<P>(self, mut ldac: P) -> Result<Ad5663<SPI, IC, P>, P::Error>
    where
        P: OutputPin,
    {
        ldac.set_high()?;
        Ok(Ad5663 {
            spi: self.spi,
            ldac,
            _ic: PhantomData,
        })
    }

    /// Destroys the driver and gives the SPI device back.
    pub fn destroy(self) -> SPI {
        self.spi
    }
}

impl<SPI, IC, P: OutputPin> Ad5663<SPI, IC, P> {
    /// Destroys the driver and gives the SPI device and the LDAC pin back.
    pub fn destroy_with_ldac(self) -> (SPI, P) {
        (self.spi, self.ldac)
    }
}

impl<SPI, IC, LDAC> Ad5663<SPI, IC, LDAC>
where
    SPI: SpiDevice,
    LDAC: digital::ErrorType,
{
    /// Sends one command as one 24-bit frame (one SPI transaction).
    fn send(&mut self, command: Command) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        let frame = command.bytes();
        self.spi
            .transaction(&mut [Operation::Write(&frame)])
            .map_err(Error::Comm)
    }

    /// Command 000: writes the input register(s) of `channel`. The output changes only for a
    /// channel that is transparent in the LDAC register, or later on LDAC / an update command.
    pub fn write_input(
        &mut self,
        channel: Channel,
        code: u16,
    ) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::WriteInput(channel, code))
    }

    /// Command 001: copies the input register(s) of `channel` to the DAC register(s).
    pub fn update_dac(&mut self, channel: Channel) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::UpdateDac(channel))
    }

    /// Command 010: writes the input register(s) of `channel`, then updates *both* DAC
    /// registers from their input registers (software LDAC).
    pub fn write_input_update_all(
        &mut self,
        channel: Channel,
        code: u16,
    ) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::WriteInputUpdateAll(channel, code))
    }

    /// Command 011: writes and updates `channel` at once (the output changes at the 24th
    /// falling SCLK edge).
    pub fn write_and_update(
        &mut self,
        channel: Channel,
        code: u16,
    ) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::WriteAndUpdate(channel, code))
    }

    /// Command 011 for a voltage: converts `volts` with `scale` (see [`OutputScale`]) and writes
    /// and updates `channel`. [`Error::OutOfRange`] (nothing sent) if the voltage is not
    /// reachable.
    pub fn write_and_update_volts(
        &mut self,
        channel: Channel,
        volts: f32,
        scale: OutputScale,
    ) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        let code = scale.code(volts).ok_or(Error::OutOfRange)?;
        self.write_and_update(channel, code)
    }

    /// Command 100: sets the power mode of `channel` (both channels with [`Channel::Both`]).
    /// The other channel is not affected.
    pub fn set_power_mode(
        &mut self,
        channel: Channel,
        mode: PowerMode,
    ) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::PowerMode(channel, mode))
    }

    /// Command 101: software reset (see [`ResetMode`]; the extent of [`ResetMode::All`] is
    /// **UNCONFIRMED**).
    pub fn reset(&mut self, mode: ResetMode) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::Reset(mode))
    }

    /// Command 110: LDAC register setup (see [`LdacMask`]).
    ///
    /// [`LdacMask::Both`] is the thesis configuration word `0x00300003`: both channels
    /// transparent, so every "write input n" updates its output at once and the LDAC pin is
    /// ignored; two channels written one after the other then change about one frame (about
    /// 1 µs at 25 MHz) apart. It is *not* the power-on state and this driver never sends it
    /// on its own. For simultaneous updates keep [`LdacMask::None`].
    pub fn set_ldac_mask(&mut self, mask: LdacMask) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::LdacSetup(mask))
    }

    /// Both outputs change together, without an LDAC pin: "write input A" (000), then "write
    /// input B and update all" (010). Two frames (two SPI transactions).
    ///
    /// Timing: both outputs change at the 24th falling SCLK edge of the *second* frame, so
    /// about two frames after the call starts: 2 × 0.96 µs + the chip-select gap at 25 MHz
    /// (≈2.1 µs), 2 × 1.92 µs at 12.5 MHz (≈4 µs).
    ///
    /// Preconditions: LDAC register [`LdacMask::None`] (the power-on state; a transparent
    /// channel A would change after the first frame) and the LDAC pin high (a pin held low
    /// makes every write update at once).
    pub fn write_both_simultaneous(
        &mut self,
        a: u16,
        b: u16,
    ) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.write_input(Channel::A, a)?;
        self.write_input_update_all(Channel::B, b)
    }

    /// Stages both input registers ("write input A", then "write input B"; two frames) without
    /// changing the outputs, for a later [`pulse_ldac`](Ad5663::pulse_ldac) (or
    /// [`update_dac`](Ad5663::update_dac) with [`Channel::Both`]).
    ///
    /// Precondition: LDAC register [`LdacMask::None`] (the power-on state) and the LDAC pin
    /// high; otherwise the outputs follow each write.
    pub fn stage_both(&mut self, a: u16, b: u16) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.write_input(Channel::A, a)?;
        self.write_input(Channel::B, b)
    }
}

impl<SPI, LDAC> Ad5663<SPI, ic::Ad5663R, LDAC>
where
    SPI: SpiDevice,
    LDAC: digital::ErrorType,
{
    /// Command 111 (AD5663R only): switches the internal reference on (DB0 = 1) or off.
    ///
    /// ```
    /// # use embedded_hal_mock::eh1::spi::{Mock, Transaction};
    /// let mut dac = ad5663::Ad5663::new_ad5663r(Mock::<u8>::new(&[
    ///     Transaction::transaction_start(),
    ///     Transaction::write_vec(vec![0x38, 0x00, 0x01]),
    ///     Transaction::transaction_end(),
    /// ]));
    /// dac.set_internal_reference(true).unwrap();
    /// dac.destroy().done();
    /// ```
    ///
    /// It does not exist for the plain AD5663, on which 111 is reserved:
    ///
    /// ```compile_fail
    /// # use embedded_hal_mock::eh1::spi::Mock;
    /// let mut dac = ad5663::Ad5663::new_ad5663(Mock::<u8>::new(&[]));
    /// dac.set_internal_reference(true); // no such method for ic::Ad5663
    /// ```
    pub fn set_internal_reference(
        &mut self,
        on: bool,
    ) -> Result<(), Error<SPI::Error, LDAC::Error>> {
        self.send(Command::InternalReference(on))
    }
}

impl<SPI, IC, P> Ad5663<SPI, IC, P>
where
    SPI: SpiDevice,
    P: OutputPin,
{
    /// Pulses the LDAC pin (low, then high): every channel that is not transparent in the
    /// LDAC register copies its input register to its DAC register on the falling edge.
    ///
    /// Timing: the outputs change at the falling edge, so the SYNC0-to-output delay is the
    /// time to the first GPIO write (a few hundred ns from an interrupt on a Cortex-M3); both
    /// channels change together. The pulse is two back-to-back pin writes; see
    /// [`unconfirmed::LDAC_LOW_MIN_NS`](crate::unconfirmed::LDAC_LOW_MIN_NS) for the minimum
    /// width. Stage the values first ([`stage_both`](Ad5663::stage_both)), completely: a pulse
    /// between the two staging frames would latch a half-written pair; guarding that is the
    /// caller's job (the firmware's SYNC0 task only pulses when a whole pair is staged).
    pub fn pulse_ldac(&mut self) -> Result<(), Error<SPI::Error, P::Error>> {
        self.ldac.set_low().map_err(Error::Pin)?;
        self.ldac.set_high().map_err(Error::Pin)
    }
}
