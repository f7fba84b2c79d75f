//! Chip-select framing through `embedded_hal_bus::spi::ExclusiveDevice` in read-after-conversion
//! mode: the chip select is CNV, so one frame is CNV low, 16 SCK with DIN/SDO, CNV high (which
//! starts the next conversion).

use ad7689::{Ad7689, Config, Reference, Sequencer};
use embedded_hal_bus::spi::ExclusiveDevice;
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTransaction};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiTransaction};

#[test]
fn one_frame_is_one_cnv_low_period() {
    let cfg = Config::new()
        .channel(7)
        .reference(Reference::External)
        .sequencer(Sequencer::Scan);
    let bus = SpiMock::new(&[
        SpiTransaction::transfer_in_place(vec![0xFF, 0xDC], vec![0x00, 0x00]),
        SpiTransaction::flush(),
        SpiTransaction::transfer_in_place(vec![0x00, 0x00], vec![0x00, 0x00]),
        SpiTransaction::flush(),
    ]);
    let cnv = PinMock::new(&[
        PinTransaction::set(State::High), // ExclusiveDevice::new: idle high (converting)
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
        PinTransaction::set(State::Low),
        PinTransaction::set(State::High),
    ]);
    // The mocks share their expectations with their clones.
    let (mut bus_check, mut cnv_check) = (bus.clone(), cnv.clone());
    let dev = ExclusiveDevice::new_no_delay(bus, cnv).unwrap();
    let mut adc = Ad7689::new(dev);
    assert_eq!(adc.read_and_configure(cfg), Ok(None));
    assert_eq!(adc.read(), Ok(None));
    drop(adc.destroy());
    bus_check.done();
    cnv_check.done();
}
