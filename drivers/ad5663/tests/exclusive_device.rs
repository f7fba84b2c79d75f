//! Chip-select framing through `embedded_hal_bus::spi::ExclusiveDevice`: one command is SYNC
//! low, 24 bits, SYNC high; the two-frame simultaneous write toggles SYNC in between.

use ad5663::{Ad5663, Channel};
use embedded_hal_bus::spi::ExclusiveDevice;
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTransaction};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiTransaction};

#[test]
fn one_command_is_one_sync_low_frame() {
    let bus = SpiMock::new(&[
        SpiTransaction::write_vec(vec![0x18, 0x12, 0x34]),
        SpiTransaction::flush(),
    ]);
    let sync = PinMock::new(&[
        PinTransaction::set(State::High), // ExclusiveDevice::new
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
    ]);
    // The mocks share their expectations with their clones.
    let (mut bus_check, mut sync_check) = (bus.clone(), sync.clone());
    let dev = ExclusiveDevice::new_no_delay(bus, sync).unwrap();
    let mut dac = Ad5663::new_ad5663(dev);
    dac.write_and_update(Channel::A, 0x1234).unwrap();
    drop(dac.destroy());
    bus_check.done();
    sync_check.done();
}

#[test]
fn simultaneous_write_is_two_frames() {
    let bus = SpiMock::new(&[
        SpiTransaction::write_vec(vec![0x00, 0x00, 0x01]),
        SpiTransaction::flush(),
        SpiTransaction::write_vec(vec![0x11, 0x00, 0x02]),
        SpiTransaction::flush(),
    ]);
    let sync = PinMock::new(&[
        PinTransaction::set(State::High),
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
    ]);
    let (mut bus_check, mut sync_check) = (bus.clone(), sync.clone());
    let dev = ExclusiveDevice::new_no_delay(bus, sync).unwrap();
    let mut dac = Ad5663::new_ad5663(dev);
    dac.write_both_simultaneous(1, 2).unwrap();
    drop(dac.destroy());
    bus_check.done();
    sync_check.done();
}
