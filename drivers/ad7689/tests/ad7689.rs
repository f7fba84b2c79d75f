//! SPI-level tests with exact frames (AD7682/AD7689 Rev. D pp. 25-30): CFG `<< 2` on DIN in
//! the first 14 SCK, result MSB first on SDO, CFG readback after it.

use ad7689::{
    unconfirmed, Ad7689, Busy, Channel, Config, Error, InputConfig, NoPin, Rac, Reference, Sample,
    Sequencer, BUSY_POLL_NS, MODE_BUSY, MODE_RAC,
};
use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice, MODE_0, MODE_3};
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as DelayTransaction};
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTransaction};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiTransaction};
use embedded_hal_mock::eh1::MockError;
use std::io::ErrorKind as IoErrorKind;

type T = SpiTransaction<u8>;

/// One frame = one transaction with one in-place transfer: `din` out, `sdo` in.
fn frame(din: &[u8], sdo: &[u8]) -> Vec<T> {
    vec![
        T::transaction_start(),
        T::transfer_in_place(din.to_vec(), sdo.to_vec()),
        T::transaction_end(),
    ]
}

/// A 16-bit read-after-conversion frame that keeps the CFG (DIN low) and returns `code`.
fn keep(code: u16) -> Vec<T> {
    frame(&[0, 0], &code.to_be_bytes())
}

/// A 16-bit frame that writes `cfg` and returns `code`.
fn write(cfg: Config, code: u16) -> Vec<T> {
    frame(&cfg.word().to_be_bytes(), &code.to_be_bytes())
}

fn concat(parts: Vec<Vec<T>>) -> Vec<T> {
    parts.into_iter().flatten().collect()
}

/// Unipolar to GND, external reference, scan IN0..INlast, no readback.
fn scan(last: u8) -> Config {
    Config::new()
        .input(InputConfig::UnipolarGnd)
        .channel(last)
        .reference(Reference::External)
        .sequencer(Sequencer::Scan)
}

fn sample(n: u8, code: u16) -> Option<Sample> {
    Some(Sample {
        channel: Channel::In(n),
        code,
    })
}

#[test]
fn spi_modes() {
    assert_eq!(MODE_RAC, MODE_0);
    assert_eq!(MODE_BUSY, MODE_3);
}

#[test]
fn new_sends_nothing() {
    Ad7689::new(SpiMock::<u8>::new(&[])).destroy().done();
}

#[test]
fn golden_cfg_words_on_the_bus() {
    // hardware-facts: 0x3FCF -> 0xFF3C (internal 4.096 V), 0x3FF7 -> 0xFFDC (external).
    let int = scan(7).reference(Reference::Internal4V096);
    let ext = scan(7);
    assert_eq!((int.bits(), ext.bits()), (0x3FCF, 0x3FF7));
    let spi = SpiMock::new(&concat(vec![
        frame(&[0xFF, 0x3C], &[0, 0]),
        frame(&[0xFF, 0xDC], &[0, 0]),
    ]));
    let mut adc = Ad7689::new(spi);
    assert_eq!(adc.read_and_configure(int), Ok(None));
    assert_eq!(adc.read_and_configure(ext), Ok(None));
    adc.destroy().done();
}

#[test]
fn scan_results_carry_their_channel() {
    // Frame 0 writes the CFG; frame 1 reads a dummy; frame k + 2 holds IN(k).
    let mut parts = vec![write(scan(7), 0xDEAD), keep(0xBEEF)];
    for k in 0..10u16 {
        parts.push(keep(0x1000 * k + k));
    }
    let mut adc = Ad7689::new(SpiMock::new(&concat(parts)));
    assert_eq!(adc.read_and_configure(scan(7)), Ok(None));
    assert!(!adc.is_synchronized());
    assert_eq!(adc.read(), Ok(None));
    assert_eq!(adc.next_channel(), Some(Channel::In(0)));
    for k in 0..10u16 {
        let n = (k % 8) as u8;
        assert_eq!(adc.read(), Ok(sample(n, 0x1000 * k + k)), "frame {}", k + 2);
    }
    adc.destroy().done();
}

#[test]
fn start_runs_the_power_up_sequence() {
    // Two CFG writes, one read, each after tCYC; then the first result is IN0.
    let cfg = scan(3);
    let spi = SpiMock::new(&concat(vec![
        frame(&[0xF7, 0xDC], &[0x11, 0x11]),
        frame(&[0xF7, 0xDC], &[0x22, 0x22]),
        keep(0x3333),
        keep(0x4000),
        keep(0x4001),
    ]));
    assert_eq!(cfg.word(), 0xF7DC);
    let mut delay = CheckedDelay::new(&[
        DelayTransaction::delay_ns(4_000),
        DelayTransaction::delay_ns(4_000),
        DelayTransaction::delay_ns(4_000),
        DelayTransaction::delay_ns(4_000),
    ]);
    let mut adc = Ad7689::new(spi);
    adc.start(cfg, &mut delay).unwrap();
    assert_eq!(adc.next_channel(), Some(Channel::In(0)));
    assert_eq!(adc.next_config(), Some(cfg));
    assert_eq!(adc.read_when_ready(&mut delay), Ok(sample(0, 0x4000)));
    assert_eq!(adc.read(), Ok(sample(1, 0x4001)));
    adc.destroy().done();
    delay.done();
}

#[test]
fn wait_ready_without_busy_waits_tcyc() {
    assert_eq!(
        unconfirmed::T_CYC_MIN_NS,
        unconfirmed::T_CONV_MAX_NS + unconfirmed::T_ACQ_MIN_NS
    );
    let mut delay = CheckedDelay::new(&[DelayTransaction::delay_ns(unconfirmed::T_CYC_MIN_NS)]);
    let mut adc = Ad7689::new(SpiMock::<u8>::new(&[]));
    adc.wait_ready(&mut delay).unwrap();
    adc.destroy().done();
    delay.done();
}

#[test]
fn scan_with_temperature() {
    let cfg = scan(1)
        .sequencer(Sequencer::ScanWithTemperature)
        .reference(Reference::ExternalTemperature);
    let spi = SpiMock::new(&concat(vec![
        write(cfg, 0),
        keep(0),
        keep(100),
        keep(101),
        keep(4528),
        keep(102),
    ]));
    let mut adc = Ad7689::new(spi);
    adc.read_and_configure(cfg).unwrap();
    adc.read().unwrap();
    assert_eq!(adc.read(), Ok(sample(0, 100)));
    assert_eq!(adc.read(), Ok(sample(1, 101)));
    assert_eq!(
        adc.read(),
        Ok(Some(Sample {
            channel: Channel::Temperature,
            code: 4528
        }))
    );
    assert_eq!(adc.read(), Ok(sample(0, 102)));
    adc.destroy().done();
}

#[test]
fn single_channel_and_temperature_mode() {
    let ch5 = Config::new().channel(5);
    let temp = Config::new()
        .input(InputConfig::Temperature)
        .reference(Reference::Internal4V096);
    let spi = SpiMock::new(&concat(vec![
        write(ch5, 0),
        write(temp, 0),
        keep(0x0555),
        keep(0x1234),
    ]));
    let mut adc = Ad7689::new(spi);
    assert_eq!(adc.read_and_configure(ch5), Ok(None));
    assert_eq!(adc.read_and_configure(temp), Ok(None));
    assert_eq!(adc.read(), Ok(sample(5, 0x0555)));
    assert_eq!(
        adc.read(),
        Ok(Some(Sample {
            channel: Channel::Temperature,
            code: 0x1234
        }))
    );
    adc.destroy().done();
}

#[test]
fn rewriting_the_cfg_restarts_the_scan_two_frames_later() {
    let spi = SpiMock::new(&concat(vec![
        write(scan(7), 0),
        keep(0),
        keep(0xA0),
        keep(0xA1),
        write(scan(2), 0xA2),
        keep(0xA3),
        keep(0xB0),
        keep(0xB1),
        keep(0xB2),
        keep(0xB0),
    ]));
    let mut adc = Ad7689::new(spi);
    adc.read_and_configure(scan(7)).unwrap();
    adc.read().unwrap();
    assert_eq!(adc.read(), Ok(sample(0, 0xA0)));
    assert_eq!(adc.read(), Ok(sample(1, 0xA1)));
    assert_eq!(adc.read_and_configure(scan(2)), Ok(sample(2, 0xA2)));
    assert_eq!(adc.read(), Ok(sample(3, 0xA3)));
    assert_eq!(adc.read(), Ok(sample(0, 0xB0)));
    assert_eq!(adc.read(), Ok(sample(1, 0xB1)));
    assert_eq!(adc.read(), Ok(sample(2, 0xB2)));
    assert_eq!(adc.read(), Ok(sample(0, 0xB0)));
    adc.destroy().done();
}

#[test]
fn readback_frames_are_32_bits_and_checked() {
    // 0x3FF6: scan IN0..IN7, external, readback on (RB = 0) -> read back as 0xFFD8.
    let cfg = scan(7).readback(true);
    assert_eq!(cfg.bits(), 0x3FF6);
    let spi = SpiMock::new(&concat(vec![
        // Nothing known yet: 16-bit frames.
        frame(&[0xFF, 0xD8], &[0, 0]),
        frame(&[0, 0], &[0, 0]),
        // The result of a conversion governed by `cfg`: data, then CFG << 2.
        frame(&[0, 0, 0, 0], &[0x12, 0x34, 0xFF, 0xD8]),
        frame(&[0, 0, 0, 0], &[0x56, 0x78, 0xFF, 0xD8]),
    ]));
    let mut adc = Ad7689::new(spi);
    adc.read_and_configure(cfg).unwrap();
    adc.read().unwrap();
    assert_eq!(adc.read(), Ok(sample(0, 0x1234)));
    assert_eq!(adc.read(), Ok(sample(1, 0x5678)));
    adc.destroy().done();
}

#[test]
fn readback_mismatch_is_an_error_and_loses_sync() {
    let cfg = scan(7).readback(true);
    let spi = SpiMock::new(&concat(vec![
        frame(&[0xFF, 0xD8], &[0, 0]),
        frame(&[0, 0], &[0, 0]),
        // The ADC reports 0x3FF7 (no readback): not what the driver wrote.
        frame(&[0, 0, 0, 0], &[0x12, 0x34, 0xFF, 0xDC]),
        keep(0x9999),
    ]));
    let mut adc = Ad7689::new(spi);
    adc.read_and_configure(cfg).unwrap();
    adc.read().unwrap();
    assert_eq!(
        adc.read(),
        Err(Error::ReadbackMismatch {
            expected: 0x3FF6,
            read: 0x3FF7
        })
    );
    assert!(!adc.is_synchronized());
    assert_eq!(adc.read(), Ok(None));
    adc.destroy().done();
}

#[test]
fn switching_readback_off_shortens_the_frame_when_its_result_comes() {
    let on = scan(7).readback(true);
    let off = scan(7);
    let spi = SpiMock::new(&concat(vec![
        frame(&[0xFF, 0xD8], &[0, 0]),
        frame(&[0, 0], &[0, 0]),
        frame(&[0xFF, 0xDC, 0, 0], &[0x00, 0x10, 0xFF, 0xD8]), // IN0 (on); writes `off`
        frame(&[0, 0, 0, 0], &[0x00, 0x11, 0xFF, 0xD8]),       // IN1 (on)
        keep(0x0020),                                          // IN0 (off), restarted
    ]));
    let mut adc = Ad7689::new(spi);
    adc.read_and_configure(on).unwrap();
    adc.read().unwrap();
    assert_eq!(adc.read_and_configure(off), Ok(sample(0, 0x10)));
    assert_eq!(adc.read(), Ok(sample(1, 0x11)));
    assert_eq!(adc.read(), Ok(sample(0, 0x20)));
    adc.destroy().done();
}

#[test]
fn invalid_channel_sends_nothing() {
    let bad = Config::new().channel(8);
    let mut adc = Ad7689::new(SpiMock::<u8>::new(&[]));
    let mut delay = NoopDelay::new();
    assert_eq!(adc.read_and_configure(bad), Err(Error::InvalidChannel));
    assert_eq!(adc.start(bad, &mut delay), Err(Error::InvalidChannel));
    assert_eq!(
        adc.configure_when_ready(bad, &mut delay),
        Err(Error::InvalidChannel)
    );
    adc.destroy().done();
}

/// A SpiDevice that fails transaction number `fail_at` without touching the mock. (The eh1
/// SPI mock of embedded-hal-mock 0.11 has no `with_error`; the pin mock has.)
struct FailingSpi {
    inner: SpiMock<u8>,
    fail_at: usize,
    count: usize,
}

impl ErrorType for FailingSpi {
    type Error = ErrorKind;
}

impl SpiDevice for FailingSpi {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        let n = self.count;
        self.count += 1;
        if n == self.fail_at {
            Err(ErrorKind::Other)
        } else {
            self.inner.transaction(ops)
        }
    }
}

#[test]
fn bus_error_is_reported_and_loses_sync() {
    let spi = FailingSpi {
        inner: SpiMock::new(&concat(vec![
            write(scan(7), 0),
            keep(0),
            keep(0x10),
            keep(0x77),
        ])),
        fail_at: 3,
        count: 0,
    };
    let mut adc = Ad7689::new(spi);
    adc.read_and_configure(scan(7)).unwrap();
    adc.read().unwrap();
    assert_eq!(adc.read(), Ok(sample(0, 0x10)));
    assert_eq!(adc.read(), Err(Error::Comm(ErrorKind::Other)));
    // The frame count may be off: nothing is tagged until a new CFG comes through.
    assert_eq!(adc.read(), Ok(None));
    adc.destroy().inner.done();
}

#[test]
fn resynchronize_forgets_the_pipeline() {
    let spi = SpiMock::new(&concat(vec![write(scan(7), 0), keep(0), keep(5)]));
    let mut adc = Ad7689::new(spi);
    adc.read_and_configure(scan(7)).unwrap();
    adc.read().unwrap();
    assert!(adc.is_synchronized());
    adc.resynchronize();
    assert_eq!(adc.next_channel(), None);
    assert_eq!(adc.read(), Ok(None));
    adc.destroy().done();
}

// ---- Busy indicator ------------------------------------------------------------------------

/// A 24-bit busy-mode frame: DIN = `din16` then zeros; SDO = result in bits 23..8, then the
/// pulled-up high-impedance line.
fn busy_frame(din16: u16, code: u16) -> Vec<T> {
    let d = din16.to_be_bytes();
    let c = code.to_be_bytes();
    frame(&[d[0], d[1], 0], &[c[0], c[1], 0xFF])
}

/// The CNV pulse the driver gives after each frame (and once in `start`).
fn cnv_pulses(n: usize) -> Vec<PinTransaction> {
    (0..n)
        .flat_map(|_| {
            [
                PinTransaction::set(State::High),
                PinTransaction::set(State::Low),
            ]
        })
        .collect()
}

#[test]
fn busy_mode_waits_for_sdo_low_then_clocks_24_bits() {
    let cfg = scan(7);
    let spi = SpiMock::new(&concat(vec![
        busy_frame(cfg.word(), 0x1111),
        busy_frame(0, 0x2222),
        busy_frame(0, 0x8001),
    ]));
    let cnv = PinMock::new(&cnv_pulses(3));
    // Conversion still running (SDO pulled up), then the busy indicator (SDO low).
    let sdo = PinMock::new(&[
        PinTransaction::get(State::Low),
        PinTransaction::get(State::High),
        PinTransaction::get(State::Low),
        PinTransaction::get(State::High),
        PinTransaction::get(State::High),
        PinTransaction::get(State::Low),
    ]);
    let mut delay = CheckedDelay::new(&[
        DelayTransaction::delay_ns(BUSY_POLL_NS),
        DelayTransaction::delay_ns(BUSY_POLL_NS),
        DelayTransaction::delay_ns(BUSY_POLL_NS),
    ]);
    let mut adc = Ad7689::new_busy(spi, cnv, sdo);
    adc.wait_ready(&mut delay).unwrap();
    assert_eq!(adc.read_and_configure(cfg), Ok(None));
    assert_eq!(adc.read_when_ready(&mut delay), Ok(None));
    assert_eq!(adc.read_when_ready(&mut delay), Ok(sample(0, 0x8001)));
    let (mut spi, mut cnv, mut sdo) = adc.destroy();
    spi.done();
    cnv.done();
    sdo.done();
    delay.done();
}

#[test]
fn busy_mode_start() {
    let cfg = scan(7);
    let spi = SpiMock::new(&concat(vec![
        busy_frame(cfg.word(), 0),
        busy_frame(cfg.word(), 0),
        busy_frame(0, 0),
        busy_frame(0, 0xFFFF),
    ]));
    // One pulse to start the first conversion, one after each frame.
    let cnv = PinMock::new(&cnv_pulses(5));
    let sdo = PinMock::new(&vec![PinTransaction::get(State::Low); 4]);
    let mut adc = Ad7689::new_busy(spi, cnv, sdo);
    let mut delay = NoopDelay::new();
    adc.start(cfg, &mut delay).unwrap();
    assert_eq!(adc.read_when_ready(&mut delay), Ok(sample(0, 0xFFFF)));
    let (mut spi, mut cnv, mut sdo) = adc.destroy();
    spi.done();
    cnv.done();
    sdo.done();
}

#[test]
fn busy_timeout_sends_nothing_and_keeps_sync() {
    let cfg = scan(7);
    let spi = SpiMock::new(&concat(vec![
        busy_frame(cfg.word(), 0),
        busy_frame(0, 0),
        busy_frame(0, 0x0042),
    ]));
    let cnv = PinMock::new(&cnv_pulses(3));
    // Polls at 0, 100, 200, 300 ns: still high -> timeout. Then low.
    let mut gets = vec![PinTransaction::get(State::High); 4];
    gets.push(PinTransaction::get(State::Low));
    let sdo = PinMock::new(&gets);
    let mut delay = CheckedDelay::new(&vec![DelayTransaction::delay_ns(BUSY_POLL_NS); 3]);
    let mut adc = Ad7689::new_busy(spi, cnv, sdo);
    adc.set_busy_timeout_ns(300);
    adc.read_and_configure(cfg).unwrap();
    adc.read().unwrap();
    let before = adc.next_channel();
    assert_eq!(adc.read_when_ready(&mut delay), Err(Error::Timeout));
    assert_eq!(adc.next_channel(), before);
    assert_eq!(adc.read_when_ready(&mut delay), Ok(sample(0, 0x0042)));
    let (mut spi, mut cnv, mut sdo) = adc.destroy();
    spi.done();
    cnv.done();
    sdo.done();
    delay.done();
}

#[test]
fn busy_without_sdo_pin_waits_tconv() {
    let spi = SpiMock::new(&busy_frame(0, 0x1234));
    let cnv = PinMock::new(&cnv_pulses(1));
    let mut delay = CheckedDelay::new(&[DelayTransaction::delay_ns(unconfirmed::T_CONV_MAX_NS)]);
    let mut adc: Ad7689<_, Busy<_, NoPin>> = Ad7689::new_busy(spi, cnv, NoPin);
    assert_eq!(adc.read_when_ready(&mut delay), Ok(None));
    let (mut spi, mut cnv, NoPin) = adc.destroy();
    spi.done();
    cnv.done();
    delay.done();
}

#[test]
fn busy_readback_frames_are_32_bits() {
    let cfg = scan(7).readback(true);
    let spi = SpiMock::new(&concat(vec![
        busy_frame(cfg.word(), 0),
        busy_frame(0, 0),
        frame(&[0, 0, 0, 0], &[0xAB, 0xCD, 0xFF, 0xD8]),
    ]));
    let cnv = PinMock::new(&cnv_pulses(3));
    let mut adc = Ad7689::new_busy(spi, cnv, NoPin);
    adc.read_and_configure(cfg).unwrap();
    adc.read().unwrap();
    assert_eq!(adc.read(), Ok(sample(0, 0xABCD)));
    let (mut spi, mut cnv, _) = adc.destroy();
    spi.done();
    cnv.done();
}

#[test]
fn cnv_pin_error() {
    let err = MockError::Io(IoErrorKind::NotConnected);
    let spi = SpiMock::new(&busy_frame(0, 0));
    let cnv = PinMock::new(&[PinTransaction::set(State::High).with_error(err.clone())]);
    let mut adc = Ad7689::new_busy(spi, cnv, NoPin);
    assert_eq!(adc.read(), Err(Error::Pin(err)));
    assert!(!adc.is_synchronized());
    let (mut spi, mut cnv, _) = adc.destroy();
    spi.done();
    cnv.done();
}

#[test]
fn sdo_pin_error() {
    let err = MockError::Io(IoErrorKind::NotConnected);
    let cnv = PinMock::new(&[]);
    let sdo = PinMock::new(&[PinTransaction::get(State::Low).with_error(err.clone())]);
    let mut adc = Ad7689::new_busy(SpiMock::<u8>::new(&[]), cnv, sdo);
    assert_eq!(adc.wait_ready(&mut NoopDelay::new()), Err(Error::Pin(err)));
    let (mut spi, mut cnv, mut sdo) = adc.destroy();
    spi.done();
    cnv.done();
    sdo.done();
}

#[test]
fn rac_is_the_default_interface() {
    let adc: Ad7689<SpiMock<u8>, Rac> = Ad7689::new(SpiMock::new(&[]));
    adc.destroy().done();
}

#[test]
fn error_display() {
    let e: Error<ErrorKind> = Error::ReadbackMismatch {
        expected: 0x3FF6,
        read: 0x3FF7,
    };
    assert_eq!(e.to_string(), "CFG readback 0x3ff7, expected 0x3ff6");
    assert_eq!(
        Error::<ErrorKind>::Timeout.to_string(),
        "no end of conversion within the timeout"
    );
}
