//! `SpiPdi` composed with `embedded_hal_bus::spi::ExclusiveDevice`: SPI_SEL frames each access
//! (low before the address phase, high after the last data byte).

use embedded_hal_bus::spi::ExclusiveDevice;
use embedded_hal_mock::eh1::digital::{Mock as Pin, State, Transaction as PinT};
use embedded_hal_mock::eh1::spi::{Mock as Bus, Transaction as T};
use et1100::{Et1100, SpiPdi};

#[test]
fn chip_select_frames_each_access() {
    let bus = Bus::new(&[
        // Read 2 bytes at 0x0120.
        T::transfer(vec![0x09, 0x03, 0xFF], vec![0x01, 0x00, 0xFF]),
        T::transfer_in_place(vec![0x00, 0xFF], vec![0x02, 0x00]),
        T::flush(),
        // Write 1 byte at 0x0807 (SM0 PDI control): 40 3C.
        T::transfer(vec![0x40, 0x3C], vec![0x00, 0x00]),
        T::write_vec(vec![0x01]),
        T::flush(),
    ]);
    let cs = Pin::new(&[
        // ExclusiveDevice deselects on construction.
        PinT::set(State::High),
        PinT::set(State::Low),
        PinT::set(State::High),
        PinT::set(State::Low),
        PinT::set(State::High),
    ]);
    // The mocks share their expectations between clones.
    let (mut bus_done, mut cs_done) = (bus.clone(), cs.clone());
    let dev = ExclusiveDevice::new_no_delay(bus, cs).unwrap();
    let mut esc = Et1100::new(SpiPdi::new(dev));
    let c = esc.read_al_control().unwrap();
    assert_eq!(c.0, 0x0002);
    esc.sm_pdi_control(0, 0x01).unwrap();
    drop(esc);
    bus_done.done();
    cs_done.done();
}
