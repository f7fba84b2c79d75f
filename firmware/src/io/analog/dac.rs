//! The AD5663 as the DAC task sees it: the [`DacAction`]s of the [`DacLatch`](super::outputs::DacLatch) carried out
//! through the `ad5663` driver, generic over the SPI device and the LDAC pin (the board's
//! SSP0 + GPIO, a mock in the tests).
//!
//! | action / call                | frames (24 bit, datasheet command table)             | outputs change           |
//! |------------------------------|------------------------------------------------------|--------------------------|
//! | [`OutputDac::init`]          | `0x28_0000` reset, `0x20_0003` both powered, `0x30_0000` LDAC register 0 | to zero scale (0 V) |
//! | [`OutputDac::preload`]       | `0x00_aaaa` write input A, `0x01_bbbb` write input B | no (LDAC register 0, LDAC high) |
//! | [`DacAction::PulseLdac`]     | none: LDAC low, high                                 | both, at the falling edge |
//! | [`DacAction::WriteAndUpdate`]| `0x00_aaaa`, `0x11_bbbb` write input B + update all  | both, at the end of frame 2 |
//! | [`DacAction::Keep`]          | none                                                 | no                       |
//!
//! The board carries the plain AD5663 (external 2.5 V reference, hardware-facts 5): it has
//! no internal reference, so there is nothing to switch off, and the driver's chip type
//! ([`ic::Ad5663`]) makes the reserved command 111 impossible to send.

use super::outputs::{DacAction, DacPair};
use ad5663::{ic, Ad5663, Channel, LdacMask, PowerMode, ResetMode};
use embedded_hal::digital::{self, OutputPin};
use embedded_hal::spi::{self, SpiDevice};

/// The driver's error on `SPI` with the LDAC pin `LDAC`.
pub type DacError<SPI, LDAC> =
    ad5663::Error<<SPI as spi::ErrorType>::Error, <LDAC as digital::ErrorType>::Error>;

/// The output DAC (owner: the SYNC0/DAC task).
#[derive(Debug)]
pub struct OutputDac<SPI, LDAC> {
    dac: Ad5663<SPI, ic::Ad5663, LDAC>,
}

impl<SPI, LDAC> OutputDac<SPI, LDAC>
where
    SPI: SpiDevice,
    LDAC: OutputPin,
{
    /// The DAC on its SPI device (chip select = SYNC) with its LDAC pin, driven high
    /// (inactive). Sends nothing; call [`OutputDac::init`]. Fails only if the pin does.
    pub fn new(spi: SPI, ldac: LDAC) -> Result<Self, LDAC::Error> {
        let dac = Ad5663::new_ad5663(spi).with_ldac(ldac)?;
        Ok(Self { dac })
    }

    /// The state the SYNC0 scheme needs, whatever the DAC held before (after an MCU-only
    /// reset, e.g. by the watchdog, it still drives the old outputs): input and DAC
    /// registers reset to zero scale (0 V, what [`super::outputs::OutputStage::new`]
    /// assumes as applied), both channels powered, LDAC register 0 (no channel transparent:
    /// only the LDAC pin or an update command changes the outputs).
    pub fn init(&mut self) -> Result<(), DacError<SPI, LDAC>> {
        self.dac.reset(ResetMode::DacAndInputRegisters)?;
        self.dac.set_power_mode(Channel::Both, PowerMode::Normal)?;
        self.dac.set_ldac_mask(LdacMask::None)
    }

    /// DC fast path: writes both input registers without changing the outputs, so that the
    /// next SYNC0 only pulses LDAC.
    pub fn preload(&mut self, pair: DacPair) -> Result<(), DacError<SPI, LDAC>> {
        self.dac.stage_both(pair.a, pair.b)
    }

    /// Carries out the DAC task's action.
    // Inline: at a SYNC0 edge the LDAC pulse is the first thing the task does.
    #[inline(always)]
    pub fn execute(&mut self, action: DacAction) -> Result<(), DacError<SPI, LDAC>> {
        match action {
            DacAction::Keep => Ok(()),
            DacAction::PulseLdac(_) => self.dac.pulse_ldac(),
            DacAction::WriteAndUpdate(pair) => self.dac.write_both_simultaneous(pair.a, pair.b),
        }
    }

    /// Gives the SPI device and the LDAC pin back.
    pub fn destroy(self) -> (SPI, LDAC) {
        self.dac.destroy_with_ldac()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::analog::outputs::{DacLatch, OutputStage};
    use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as Pin};
    use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as Spi};
    use std::vec;
    use std::vec::Vec;

    /// One command: one transaction with one 3-byte write (the 24-bit word, MSB first).
    fn frame(word: u32) -> [Spi<u8>; 3] {
        [
            Spi::transaction_start(),
            Spi::write_vec(vec![(word >> 16) as u8, (word >> 8) as u8, word as u8]),
            Spi::transaction_end(),
        ]
    }

    fn frames(words: &[u32]) -> Vec<Spi<u8>> {
        words.iter().flat_map(|w| frame(*w)).collect()
    }

    /// A DAC expecting `words` on the bus and `ldac` on the pin after the initial high.
    fn dac(words: &[u32], ldac: &[State]) -> OutputDac<SpiMock<u8>, PinMock> {
        let mut pin = vec![Pin::set(State::High)];
        pin.extend(ldac.iter().map(|s| Pin::set(*s)));
        OutputDac::new(SpiMock::new(&frames(words)), PinMock::new(&pin)).unwrap()
    }

    fn done(dac: OutputDac<SpiMock<u8>, PinMock>) {
        let (mut spi, mut pin) = dac.destroy();
        spi.done();
        pin.done();
    }

    #[test]
    fn new_drives_ldac_high_and_sends_nothing() {
        done(dac(&[], &[]));
    }

    #[test]
    fn init_resets_powers_up_and_clears_the_ldac_register() {
        // Datasheet: 101 reset (DB0 = 0: input + DAC registers), 100 power mode normal for
        // DB1/DB0 = B/A, 110 LDAC register with both bits 0.
        let mut d = dac(&[0x28_0000, 0x20_0003, 0x30_0000], &[]);
        d.init().unwrap();
        done(d);
    }

    #[test]
    fn preload_writes_both_input_registers_only() {
        let mut d = dac(&[0x00_1234, 0x01_ABCD], &[]);
        d.preload(DacPair::new(0x1234, 0xABCD)).unwrap();
        done(d);
    }

    #[test]
    fn write_and_update_is_write_a_then_write_b_and_update_all() {
        let mut d = dac(&[0x00_8000, 0x11_FFFF], &[]);
        d.execute(DacAction::WriteAndUpdate(DacPair::new(0x8000, 0xFFFF)))
            .unwrap();
        done(d);
    }

    #[test]
    fn pulse_ldac_sends_no_frame() {
        let mut d = dac(&[], &[State::Low, State::High]);
        d.execute(DacAction::PulseLdac(DacPair::new(1, 2))).unwrap();
        done(d);
    }

    #[test]
    fn keep_touches_nothing() {
        let mut d = dac(&[], &[]);
        d.execute(DacAction::Keep).unwrap();
        done(d);
    }

    /// An SPI device whose every transaction fails.
    struct DeadBus;

    impl spi::ErrorType for DeadBus {
        type Error = spi::ErrorKind;
    }

    impl SpiDevice for DeadBus {
        fn transaction(&mut self, _: &mut [spi::Operation<'_, u8>]) -> Result<(), spi::ErrorKind> {
            Err(spi::ErrorKind::Other)
        }
    }

    #[test]
    fn bus_error_is_reported() {
        let pin = PinMock::new(&[Pin::set(State::High)]);
        let mut d = OutputDac::new(DeadBus, pin).unwrap();
        let r = d.execute(DacAction::WriteAndUpdate(DacPair::new(1, 2)));
        assert_eq!(r, Err(ad5663::Error::Comm(spi::ErrorKind::Other)));
        assert!(d.init().is_err());
        let (_, mut pin) = d.destroy();
        pin.done();
    }

    /// The DC cycle as the DAC task runs it: preload when pended, LDAC only at SYNC0; the
    /// next pair without a preload is written and updated at the edge.
    #[test]
    fn dc_cycle_through_the_latch() {
        let stage = OutputStage::new();
        stage.set_dc_mode(true);
        let mut latch = DacLatch::new();
        let mut d = dac(
            &[0x00_0100, 0x01_0200, 0x00_0300, 0x11_0400],
            &[State::Low, State::High],
        );
        stage.stage(DacPair::new(0x0100, 0x0200));
        let pair = latch.preload(&stage).unwrap();
        d.preload(pair).unwrap();
        d.execute(latch.on_sync0(&stage, 1_000)).unwrap();
        stage.stage(DacPair::new(0x0300, 0x0400));
        d.execute(latch.on_sync0(&stage, 2_000)).unwrap();
        d.execute(latch.on_sync0(&stage, 3_000)).unwrap(); // nothing fresh: Keep
        assert_eq!(stage.applied(), DacPair::new(0x0300, 0x0400));
        assert_eq!(stage.sync0_without_outputs(), 1);
        done(d);
    }
}
