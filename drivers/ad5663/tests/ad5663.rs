//! SPI-level tests: every operation against the exact datasheet frame (AD5663R DS p. 21,
//! Table 8/9: DB21..19 command, DB18..16 address, DB15..0 data, MSB first).

use ad5663::{
    ic, Ad5663, Channel, Error, InvalidChannel, LdacMask, NoLdac, OutputScale, PowerMode,
    ResetMode, MODE,
};
use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice, MODE_1};
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTransaction};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiTransaction};
use embedded_hal_mock::eh1::MockError;
use std::io::ErrorKind as IoErrorKind;

/// One 24-bit frame = one SPI transaction with one 3-byte write.
fn frame(bytes: [u8; 3]) -> Vec<SpiTransaction<u8>> {
    vec![
        SpiTransaction::transaction_start(),
        SpiTransaction::write_vec(bytes.to_vec()),
        SpiTransaction::transaction_end(),
    ]
}

fn frames(list: &[[u8; 3]]) -> Vec<SpiTransaction<u8>> {
    list.iter().flat_map(|b| frame(*b)).collect()
}

fn new_ad5663(expected: &[[u8; 3]]) -> Ad5663<SpiMock<u8>, ic::Ad5663, NoLdac> {
    Ad5663::new_ad5663(SpiMock::new(&frames(expected)))
}

fn new_ad5663r(expected: &[[u8; 3]]) -> Ad5663<SpiMock<u8>, ic::Ad5663R, NoLdac> {
    Ad5663::new_ad5663r(SpiMock::new(&frames(expected)))
}

macro_rules! frame_test {
    ($name:ident, [$($byte:expr),+], $method:ident $(, $arg:expr)*) => {
        #[test]
        fn $name() {
            let mut dac = new_ad5663(&[[$($byte),+]]);
            dac.$method($($arg),*).unwrap();
            dac.destroy().done();
        }
    };
}

// Command 000: write input register n.
frame_test!(
    write_input_a,
    [0x00, 0x12, 0x34],
    write_input,
    Channel::A,
    0x1234
);
frame_test!(
    write_input_b,
    [0x01, 0xFF, 0xFF],
    write_input,
    Channel::B,
    0xFFFF
);
frame_test!(
    write_input_both,
    [0x07, 0x80, 0x00],
    write_input,
    Channel::Both,
    0x8000
);
// Command 001: update DAC register n.
frame_test!(update_dac_a, [0x08, 0x00, 0x00], update_dac, Channel::A);
frame_test!(update_dac_b, [0x09, 0x00, 0x00], update_dac, Channel::B);
frame_test!(
    update_dac_both,
    [0x0F, 0x00, 0x00],
    update_dac,
    Channel::Both
);
// Command 010: write input register n, update all.
frame_test!(
    write_input_update_all_a,
    [0x10, 0x00, 0x01],
    write_input_update_all,
    Channel::A,
    0x0001
);
frame_test!(
    write_input_update_all_b,
    [0x11, 0xAB, 0xCD],
    write_input_update_all,
    Channel::B,
    0xABCD
);
// Command 011: write to and update channel n.
frame_test!(
    write_and_update_a,
    [0x18, 0x40, 0x00],
    write_and_update,
    Channel::A,
    0x4000
);
frame_test!(
    write_and_update_b,
    [0x19, 0x00, 0x00],
    write_and_update,
    Channel::B,
    0x0000
);
frame_test!(
    write_and_update_both,
    [0x1F, 0xFF, 0xFF],
    write_and_update,
    Channel::Both,
    0xFFFF
);
// Command 100: power modes, DB5:4 mode, DB1 = B, DB0 = A.
frame_test!(
    power_up_both,
    [0x20, 0x00, 0x03],
    set_power_mode,
    Channel::Both,
    PowerMode::Normal
);
frame_test!(
    power_down_1k_a,
    [0x20, 0x00, 0x11],
    set_power_mode,
    Channel::A,
    PowerMode::PullDown1k
);
frame_test!(
    power_down_100k_b,
    [0x20, 0x00, 0x22],
    set_power_mode,
    Channel::B,
    PowerMode::PullDown100k
);
frame_test!(
    power_down_three_state_both,
    [0x20, 0x00, 0x33],
    set_power_mode,
    Channel::Both,
    PowerMode::ThreeState
);
// Command 101: reset, DB0 selects the extent.
frame_test!(
    reset_registers,
    [0x28, 0x00, 0x00],
    reset,
    ResetMode::DacAndInputRegisters
);
frame_test!(reset_all, [0x28, 0x00, 0x01], reset, ResetMode::All);
// Command 110: LDAC register, DB1 = B, DB0 = A.
frame_test!(ldac_none, [0x30, 0x00, 0x00], set_ldac_mask, LdacMask::None);
frame_test!(ldac_a, [0x30, 0x00, 0x01], set_ldac_mask, LdacMask::A);
frame_test!(ldac_b, [0x30, 0x00, 0x02], set_ldac_mask, LdacMask::B);

#[test]
fn thesis_configuration_word_is_ldac_both_transparent() {
    // 0x00300003: command 110, DB1 = DB0 = 1.
    let mut dac = new_ad5663(&[[0x30, 0x00, 0x03]]);
    dac.set_ldac_mask(LdacMask::Both).unwrap();
    dac.destroy().done();
}

#[test]
fn constructors_send_nothing() {
    new_ad5663(&[]).destroy().done();
    new_ad5663r(&[]).destroy().done();
}

#[test]
fn internal_reference_ad5663r() {
    // Command 111, DB0 = 1 on / 0 off.
    let mut dac = new_ad5663r(&[[0x38, 0x00, 0x01], [0x38, 0x00, 0x00]]);
    dac.set_internal_reference(true).unwrap();
    dac.set_internal_reference(false).unwrap();
    dac.destroy().done();
}

#[test]
fn ad5663r_has_the_common_commands_too() {
    let mut dac = new_ad5663r(&[[0x1F, 0x12, 0x34]]);
    dac.write_and_update(Channel::Both, 0x1234).unwrap();
    dac.destroy().done();
}

#[test]
fn write_both_simultaneous_is_write_a_then_write_b_update_all() {
    let mut dac = new_ad5663(&[[0x00, 0x11, 0x22], [0x11, 0x33, 0x44]]);
    dac.write_both_simultaneous(0x1122, 0x3344).unwrap();
    dac.destroy().done();
}

#[test]
fn stage_both_writes_both_input_registers_only() {
    let mut dac = new_ad5663(&[[0x00, 0xAA, 0xBB], [0x01, 0xCC, 0xDD]]);
    dac.stage_both(0xAABB, 0xCCDD).unwrap();
    dac.destroy().done();
}

#[test]
fn stage_then_pulse_ldac() {
    let spi = SpiMock::new(&frames(&[[0x00, 0x40, 0x00], [0x01, 0xC0, 0x00]]));
    let ldac = PinMock::new(&[
        PinTransaction::set(State::High),
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
    ]);
    let mut dac = Ad5663::new_ad5663(spi).with_ldac(ldac).unwrap();
    dac.stage_both(0x4000, 0xC000).unwrap();
    dac.pulse_ldac().unwrap();
    let (mut spi, mut ldac) = dac.destroy_with_ldac();
    spi.done();
    ldac.done();
}

#[test]
fn pulse_ldac_alone_sends_no_frame() {
    let ldac = PinMock::new(&[
        PinTransaction::set(State::High),
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
    ]);
    let mut dac = Ad5663::new_ad5663r(SpiMock::new(&[]))
        .with_ldac(ldac)
        .unwrap();
    dac.pulse_ldac().unwrap();
    dac.pulse_ldac().unwrap();
    let (mut spi, mut ldac) = dac.destroy_with_ldac();
    spi.done();
    ldac.done();
}

#[test]
fn write_volts_with_board_scale() {
    // 0..10 V board: 2.5 V reference, x4. 5 V = 0x8000, 2.5 V = 0x4000.
    let board = OutputScale::new(2.5, 4.0);
    let mut dac = new_ad5663(&[[0x18, 0x80, 0x00], [0x1F, 0x40, 0x00]]);
    dac.write_and_update_volts(Channel::A, 5.0, board).unwrap();
    dac.write_and_update_volts(Channel::Both, 2.5, board)
        .unwrap();
    dac.destroy().done();
}

#[test]
fn write_volts_out_of_range_sends_nothing() {
    let board = OutputScale::new(2.5, 4.0);
    let mut dac = new_ad5663(&[]);
    for v in [10.0, -0.1, f32::NAN, f32::INFINITY] {
        assert_eq!(
            dac.write_and_update_volts(Channel::A, v, board),
            Err(Error::OutOfRange)
        );
    }
    // A broken scale is out of range too, never a panic.
    assert_eq!(
        dac.write_and_update_volts(Channel::B, 1.0, OutputScale::new(0.0, 4.0)),
        Err(Error::OutOfRange)
    );
    dac.destroy().done();
}

#[test]
fn channel_from_index() {
    assert_eq!(Channel::try_from(0), Ok(Channel::A));
    assert_eq!(Channel::try_from(1), Ok(Channel::B));
    assert_eq!(Channel::try_from(2), Err(InvalidChannel(2)));
    assert_eq!(Channel::try_from(255), Err(InvalidChannel(255)));
    let e: Error<ErrorKind> = InvalidChannel(2).into();
    assert_eq!(e, Error::InvalidChannel);
}

#[test]
fn bad_channel_index_is_an_error_before_any_frame() {
    let mut dac = new_ad5663(&[]);
    let r = Channel::try_from(7)
        .map_err(Error::from)
        .and_then(|c| dac.write_and_update(c, 0x1234));
    assert_eq!(r, Err(Error::InvalidChannel));
    dac.destroy().done();
}

/// A SpiDevice that fails transaction number `fail_at` (0-based) without touching the mock,
/// and passes every other one to it. (The eh1 SPI mock of embedded-hal-mock 0.11 has no
/// `with_error`; the pin mock has, see the pin tests.)
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
fn bus_error_is_reported() {
    let spi = FailingSpi {
        inner: SpiMock::new(&[]),
        fail_at: 0,
        count: 0,
    };
    let mut dac = Ad5663::new_ad5663(spi);
    assert_eq!(
        dac.write_and_update(Channel::A, 1),
        Err(Error::Comm(ErrorKind::Other))
    );
    dac.destroy().inner.done();
}

#[test]
fn bus_error_in_first_frame_stops_simultaneous_write() {
    let spi = FailingSpi {
        inner: SpiMock::new(&[]),
        fail_at: 0,
        count: 0,
    };
    let mut dac = Ad5663::new_ad5663(spi);
    assert_eq!(
        dac.write_both_simultaneous(1, 2),
        Err(Error::Comm(ErrorKind::Other))
    );
    let spi = dac.destroy();
    assert_eq!(spi.count, 1, "the second frame must not be sent");
    let mut inner = spi.inner;
    inner.done();
}

#[test]
fn bus_error_in_second_frame_of_staging() {
    let spi = FailingSpi {
        inner: SpiMock::new(&frame([0x00, 0x00, 0x05])),
        fail_at: 1,
        count: 0,
    };
    let mut dac = Ad5663::new_ad5663(spi);
    assert_eq!(dac.stage_both(5, 6), Err(Error::Comm(ErrorKind::Other)));
    dac.destroy().inner.done();
}

#[test]
fn ldac_pin_error_on_pulse() {
    let err = MockError::Io(IoErrorKind::NotConnected);
    let ldac = PinMock::new(&[
        PinTransaction::set(State::High),
        PinTransaction::set(State::Low).with_error(err.clone()),
    ]);
    let mut dac = Ad5663::new_ad5663(SpiMock::new(&[]))
        .with_ldac(ldac)
        .unwrap();
    assert_eq!(dac.pulse_ldac(), Err(Error::Pin(err)));
    let (mut spi, mut ldac) = dac.destroy_with_ldac();
    spi.done();
    ldac.done();
}

#[test]
fn ldac_pin_error_when_attaching() {
    let err = MockError::Io(IoErrorKind::NotConnected);
    let mut ldac = PinMock::new(&[PinTransaction::set(State::High).with_error(err.clone())]);
    let mut spi = SpiMock::<u8>::new(&[]);
    // The driver (and with it the moved clones) is dropped on the error.
    let r = Ad5663::new_ad5663(spi.clone()).with_ldac(ldac.clone());
    assert_eq!(r.err(), Some(err));
    spi.done();
    ldac.done();
}

#[test]
fn spi_mode_is_mode_1() {
    assert_eq!(MODE, MODE_1);
}

#[test]
fn error_display() {
    extern crate std;
    use std::string::ToString;
    let e: Error<ErrorKind> = Error::OutOfRange;
    assert_eq!(e.to_string(), "voltage outside the output range");
    let e: Error<ErrorKind, MockError> = Error::Comm(ErrorKind::Other);
    assert!(e.to_string().starts_with("SPI error"));
}
