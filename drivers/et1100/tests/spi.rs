//! The SPI PDI and the register helpers against `embedded_hal_mock` with exact bytes
//! (hardware-facts 1.2).

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
use et1100::{
    AlEvents, AlState, AlStatus, EepromStatus, Error, Et1100, Pdi, SmDirection, SmMode, SpiPdi,
    SyncActivation, SyncManager, WatchdogStatus,
};

/// One read access: `addr` (address bytes with the command), wait byte 0xFF, data phase
/// `00 .. 00 FF`; MISO: `events` during the address, then `data`.
fn rd(addr: &[u8], events: &[u8], data: &[u8]) -> Vec<T<u8>> {
    assert_eq!(addr.len(), events.len());
    let mut mosi = addr.to_vec();
    mosi.push(0xFF);
    let mut miso = events.to_vec();
    miso.push(0xFF);
    let mut term = vec![0x00; data.len()];
    *term.last_mut().unwrap() = 0xFF;
    vec![
        T::transaction_start(),
        T::transfer(mosi, miso),
        T::transfer_in_place(term, data.to_vec()),
        T::transaction_end(),
    ]
}

/// One write access: `addr`, then `data`.
fn wr(addr: &[u8], events: &[u8], data: &[u8]) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::transfer(addr.to_vec(), events.to_vec()),
        T::write_vec(data.to_vec()),
        T::transaction_end(),
    ]
}

fn esc(expectations: &[Vec<T<u8>>]) -> Et1100<SpiPdi<Mock<u8>>> {
    let all: Vec<T<u8>> = expectations.concat();
    Et1100::new(SpiPdi::new(Mock::new(&all)))
}

fn done(esc: Et1100<SpiPdi<Mock<u8>>>) {
    esc.destroy().destroy().done();
}

#[test]
fn read_two_bytes_at_0x0120_with_wait_state() {
    let mut e = esc(&[rd(&[0x09, 0x03], &[0x11, 0x02], &[0x04, 0x00])]);
    let mut buf = [0xAA; 2];
    let ev = e.read(0x0120, &mut buf).unwrap();
    assert_eq!(buf, [0x04, 0x00]);
    assert_eq!(ev.bits(), 0x0211);
    assert!(ev.contains(AlEvents::AL_CONTROL | AlEvents::SM_ACTIVATION | AlEvents::SM1));
    assert!(!ev.contains(AlEvents::SM0));
    done(e);
}

#[test]
fn read_four_bytes_at_0x3400_three_byte_addressing() {
    // hardware-facts 1.2: A0 06 2C FF 00 00 00 FF.
    let mut e = esc(&[rd(&[0xA0, 0x06, 0x2C], &[0x00, 0x01, 0x80], &[1, 2, 3, 4])]);
    let mut buf = [0u8; 4];
    let ev = e.read(0x3400, &mut buf).unwrap();
    assert_eq!(buf, [1, 2, 3, 4]);
    // The third address byte shifts out 0x0222.
    assert_eq!(ev.bits(), 0x0080_0100);
    assert!(ev.intersects(AlEvents::sm(0)) && ev.intersects(AlEvents::sm(15)));
    done(e);
}

#[test]
fn read_single_byte_is_terminated() {
    let mut e = esc(&[rd(&[0x00, 0x03], &[0, 0], &[0x11])]);
    let mut buf = [0u8; 1];
    e.read(0x0000, &mut buf).unwrap();
    assert_eq!(buf, [0x11]);
    done(e);
}

#[test]
fn write_at_0x4200_three_byte_addressing() {
    let mut e = esc(&[wr(&[0x10, 0x06, 0x50], &[0x40, 0, 0], &[0xDE, 0xAD])]);
    let ev = e.write(0x4200, &[0xDE, 0xAD]).unwrap();
    assert!(ev.contains(AlEvents::WATCHDOG));
    done(e);
}

#[test]
fn write_two_byte_addressing() {
    // 0x1FFF is the last address with 2-byte addressing: FF, 1F<<3 | 4.
    let mut e = esc(&[
        wr(&[0xFF, 0xFC], &[0, 0], &[0x55]),
        wr(&[0x00, 0x06, 0x30], &[0, 0, 0], &[0x66]),
    ]);
    e.write(0x1FFF, &[0x55]).unwrap();
    e.write(0x2000, &[0x66]).unwrap();
    done(e);
}

#[test]
fn events_come_from_the_address_bytes_only() {
    // A 2-byte read clocks the wait byte at the third position: its MISO (0xFF here) is
    // not 0x0222. A 2-byte write has no third byte: 0x0222 reads as 0. A 3-byte write
    // returns 0x0222 in its third address byte.
    let mut e = esc(&[
        rd(&[0x88, 0x03], &[0x01, 0x02], &[7, 8, 9]),
        wr(&[0x8C, 0x04], &[0x03, 0x04], &[5, 6]),
        wr(&[0x10, 0x06, 0x50], &[0x05, 0x06, 0x07], &[1]),
    ]);
    let mut three = [0u8; 3];
    assert_eq!(e.read(0x1100, &mut three).unwrap().bits(), 0x0201);
    assert_eq!(three, [7, 8, 9]);
    assert_eq!(e.write(0x1180, &[5, 6]).unwrap().bits(), 0x0403);
    assert_eq!(e.write(0x4200, &[1]).unwrap().bits(), 0x0007_0605);
    done(e);
}

#[test]
fn nop_returns_all_event_bytes() {
    let mut e = esc(&[vec![
        T::transaction_start(),
        T::transfer(vec![0x00, 0x06, 0x00], vec![0x05, 0x01, 0x00]),
        T::transaction_end(),
    ]]);
    let ev = e.events().unwrap();
    assert_eq!(ev, AlEvents::from_bits_retain(0x0105));
    assert!(ev.contains(AlEvents::AL_CONTROL | AlEvents::SYNC0 | AlEvents::SM0));
    done(e);
}

#[test]
fn low_events_is_a_two_byte_nop() {
    let mut e = esc(&[vec![
        T::transaction_start(),
        T::transfer(vec![0x00, 0x00], vec![0x05, 0x01]),
        T::transaction_end(),
    ]]);
    let ev = e.low_events().unwrap();
    assert_eq!(ev, AlEvents::from_bits_retain(0x0105));
    assert!(ev.contains(AlEvents::AL_CONTROL | AlEvents::SYNC0 | AlEvents::SM0));
    done(e);
}

#[test]
fn out_of_range_touches_no_bus() {
    let mut e = esc(&[rd(&[0xFF, 0xFE, 0xEC], &[0, 0, 0], &[0x99])]);
    let mut empty: [u8; 0] = [];
    assert_eq!(e.read(0x0120, &mut empty), Err(Error::OutOfRange));
    assert_eq!(e.write(0x0120, &[]), Err(Error::OutOfRange));
    let mut two = [0u8; 2];
    assert_eq!(e.read(0xFFFF, &mut two), Err(Error::OutOfRange));
    assert_eq!(e.write(0xFFFE, &[1, 2, 3]), Err(Error::OutOfRange));
    assert_eq!(e.read_sm(16), Err(Error::InvalidIndex));
    assert_eq!(e.sm_pdi_control(200, 1), Err(Error::InvalidIndex));
    // The last byte of the address space is fine.
    let mut one = [0u8; 1];
    e.read(0xFFFF, &mut one).unwrap();
    assert_eq!(one, [0x99]);
    done(e);
}

#[test]
fn sm_decode_in_one_access() {
    // SM2 at 0x0810: 40 83.
    let bytes = [0x00, 0x11, 0x04, 0x00, 0x64, 0x31, 0x01, 0x00];
    let mut e = esc(&[rd(&[0x40, 0x83], &[0x10, 0x00], &bytes)]);
    let sm = e.read_sm(2).unwrap();
    assert_eq!(sm.start, 0x1100);
    assert_eq!(sm.length, 4);
    assert_eq!(sm.mode(), SmMode::Buffered);
    assert_eq!(sm.direction(), SmDirection::EcatWrite);
    assert!(sm.pdi_irq() && sm.watchdog_trigger() && !sm.ecat_irq());
    assert!(sm.write_event() && !sm.read_event());
    assert_eq!(sm.last_buffer(), 3);
    assert!(sm.enabled() && !sm.repeat_requested() && !sm.deactivated());
    assert_eq!(sm.to_bytes(), bytes);
    done(e);
}

#[test]
fn sm_pair_in_one_access() {
    // SM0 at 0x0800 (40 03) and SM1 after it: 16 bytes in one read.
    let sm0 = [0x00, 0x10, 0x80, 0x00, 0x26, 0x08, 0x01, 0x00];
    let sm1 = [0x80, 0x10, 0x80, 0x00, 0x22, 0x00, 0x01, 0x00];
    let mut both = [0u8; 16];
    both[..8].copy_from_slice(&sm0);
    both[8..].copy_from_slice(&sm1);
    let mut e = esc(&[rd(&[0x40, 0x03], &[0x00, 0x00], &both)]);
    let (first, second) = e.read_sm_pair(0).unwrap();
    assert_eq!(first.to_bytes(), sm0);
    assert_eq!(second.to_bytes(), sm1);
    assert_eq!((first.start, second.start), (0x1000, 0x1080));
    assert!(first.mailbox_full() && !second.mailbox_full());
    // The pair must lie inside the 16 SyncManagers; no access otherwise.
    assert_eq!(e.read_sm_pair(15), Err(Error::InvalidIndex));
    assert_eq!(e.read_sm_pair(255), Err(Error::InvalidIndex));
    done(e);
}

#[test]
fn sm_pdi_control_and_repeat_ack() {
    let sm1 = SyncManager {
        start: 0x1080,
        length: 0x80,
        control: 0x22,
        status: 0x00,
        activate: 0x03,
        pdi_control: 0x00,
    };
    // SM1 PDI control at 0x080F: 40 7C.
    let mut e = esc(&[
        wr(&[0x40, 0x7C], &[0, 0], &[0x02]),
        wr(&[0x40, 0x3C], &[0, 0], &[SyncManager::PDI_DEACTIVATE]),
    ]);
    assert!(e.repeat_requested(&sm1));
    e.ack_repeat(1, &sm1).unwrap();
    e.sm_pdi_control(0, SyncManager::PDI_DEACTIVATE).unwrap();
    let acked = SyncManager {
        pdi_control: 0x02,
        ..sm1
    };
    assert!(!e.repeat_requested(&acked));
    done(e);
}

#[test]
fn read_mailbox_whole_buffer() {
    let sm0 = SyncManager {
        start: 0x1000,
        length: 8,
        control: 0x26,
        status: 0x08,
        activate: 0x01,
        pdi_control: 0,
    };
    let msg = [2, 0, 0, 0, 0, 0x13, 0xAB, 0xCD];
    let mut e = esc(&[rd(&[0x80, 0x03], &[0x00, 0x01], &msg)]);
    let mut small = [0u8; 7];
    assert_eq!(e.read_mailbox(&sm0, &mut small), Err(Error::BufferTooSmall));
    let mut buf = [0u8; 16];
    assert_eq!(e.read_mailbox(&sm0, &mut buf).unwrap(), 8);
    assert_eq!(buf[..8], msg);
    assert_eq!(buf[8..], [0u8; 8]);
    done(e);
}

#[test]
fn write_mailbox_pads_to_last_byte() {
    let sm1 = SyncManager {
        start: 0x1080,
        length: 40,
        control: 0x22,
        ..Default::default()
    };
    let data = [1, 2, 3, 4, 5];
    let mut e = esc(&[
        // 0x1080: 84 04.
        wr(&[0x84, 0x04], &[0, 0], &data),
        // 0x1085: 84 2C, 32 zeros.
        wr(&[0x84, 0x2C], &[0, 0], &[0u8; 32]),
        // 0x10A5: 85 2C, the last 3 zeros up to 0x10A7.
        wr(&[0x85, 0x2C], &[0, 0], &[0u8; 3]),
    ]);
    assert_eq!(e.write_mailbox(&sm1, &[0u8; 41]), Err(Error::DataTooLong));
    e.write_mailbox(&sm1, &data).unwrap();
    done(e);
}

#[test]
fn write_mailbox_full_length_is_one_access() {
    let sm1 = SyncManager {
        start: 0x1080,
        length: 4,
        ..Default::default()
    };
    let mut e = esc(&[wr(&[0x84, 0x04], &[0, 0], &[9, 8, 7, 6])]);
    e.write_mailbox(&sm1, &[9, 8, 7, 6]).unwrap();
    let empty = SyncManager::default();
    assert_eq!(e.write_mailbox(&empty, &[]), Err(Error::OutOfRange));
    done(e);
}

#[test]
fn process_data() {
    let mut e = esc(&[
        rd(&[0x88, 0x03], &[0x00, 0x04], &[1, 2, 3, 4]),
        wr(&[0x8C, 0x04], &[0, 0], &[5, 6]),
    ]);
    let mut out = [0u8; 4];
    let ev = e.read_process_data(0x1100, &mut out).unwrap();
    assert!(ev.intersects(AlEvents::sm(2)));
    assert_eq!(out, [1, 2, 3, 4]);
    e.write_process_data(0x1180, &[5, 6]).unwrap();
    done(e);
}

#[test]
fn al_status_write_code_first() {
    // 0x0134: 09 A4; 0x0130: 09 84.
    let mut e = esc(&[
        wr(&[0x09, 0xA4], &[0, 0], &[0x11, 0x00]),
        wr(&[0x09, 0x84], &[0, 0], &[0x12, 0x00]),
    ]);
    let status = AlStatus::new(AlState::PreOp, true, false);
    e.write_al_status(status, 0x0011).unwrap();
    done(e);
}

#[test]
fn al_control_and_event_mask() {
    let mut e = esc(&[
        rd(&[0x09, 0x03], &[0x01, 0x00], &[0x14, 0x00]),
        // 0x0204: 10 24.
        wr(&[0x10, 0x24], &[0, 0], &[0x01, 0x0F, 0x00, 0x00]),
    ]);
    let c = e.read_al_control().unwrap();
    assert_eq!(c.state(), Some(AlState::SafeOp));
    assert!(c.error_ack() && !c.id_request());
    e.set_event_mask(
        AlEvents::AL_CONTROL | AlEvents::SM0 | AlEvents::SM1 | AlEvents::SM2 | AlEvents::SM3,
    )
    .unwrap();
    done(e);
}

#[test]
fn watchdog_and_dc() {
    let mut e = esc(&[
        // 0x0440: 22 03.
        rd(&[0x22, 0x03], &[0x40, 0x00], &[0x00, 0x00]),
        // 0x0981: 4C 0B.
        rd(&[0x4C, 0x0B], &[0, 0], &[0x07]),
        // 0x09A0: 4D 03.
        rd(&[0x4D, 0x03], &[0, 0], &[0x40, 0x42, 0x0F, 0x00]),
        // 0x098E: 4C 73.
        rd(&[0x4C, 0x73], &[0x04, 0x00], &[0x01]),
        // 0x0910: 48 83.
        rd(&[0x48, 0x83], &[0, 0], &[1, 2, 3, 4, 5, 6, 7, 8]),
    ]);
    assert_eq!(e.watchdog_status().unwrap(), WatchdogStatus::Expired);
    let act = e.sync_activation().unwrap();
    assert!(
        act.contains(SyncActivation::CYCLIC_UNIT | SyncActivation::SYNC0 | SyncActivation::SYNC1)
    );
    assert!(!act.contains(SyncActivation::AUTO_ACTIVATION));
    assert_eq!(e.sync0_cycle_ns().unwrap(), 1_000_000);
    assert!(e.sync0_status().unwrap());
    assert_eq!(e.system_time().unwrap(), 0x0807_0605_0403_0201);
    done(e);
}

// EEPROM: 0x0500 = 28 0x, 0x0501 = 28 0C, 0x0502 = 28 1x, 0x0504 = 28 24, 0x0508 = 28 43.

#[test]
fn eeprom_take_and_read_8_bytes() {
    let mut e = esc(&[
        rd(&[0x28, 0x03], &[0, 0], &[0x01]),
        wr(&[0x28, 0x0C], &[0, 0], &[0x01]),
        // Idle, 8-byte reads (b6).
        rd(&[0x28, 0x13], &[0, 0], &[0x40, 0x00]),
        wr(&[0x28, 0x24], &[0, 0], &[0x08, 0x00, 0x00, 0x00]),
        wr(&[0x28, 0x14], &[0, 0], &[0x00, 0x01]),
        // Busy, then done.
        rd(&[0x28, 0x13], &[0, 0], &[0x40, 0x81]),
        rd(&[0x28, 0x13], &[0, 0], &[0x40, 0x01]),
        rd(
            &[0x28, 0x43],
            &[0, 0],
            &[0xA0, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6, 0xA7],
        ),
        wr(&[0x28, 0x0C], &[0, 0], &[0x00]),
    ]);
    e.eeprom_take().unwrap();
    let chunk = e.eeprom_read_chunk(8, 5).unwrap();
    assert_eq!(
        chunk.as_bytes(),
        &[0xA0, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6, 0xA7]
    );
    e.eeprom_release().unwrap();
    done(e);
}

#[test]
fn eeprom_read_4_byte_chunks() {
    let mut e = esc(&[
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x00]),
        wr(&[0x28, 0x24], &[0, 0], &[0x0A, 0x00, 0x00, 0x00]),
        wr(&[0x28, 0x14], &[0, 0], &[0x00, 0x01]),
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x01]),
        rd(&[0x28, 0x43], &[0, 0], &[1, 2, 3, 4]),
        // Next chunk at word 0x0C.
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x01]),
        wr(&[0x28, 0x24], &[0, 0], &[0x0C, 0x00, 0x00, 0x00]),
        wr(&[0x28, 0x14], &[0, 0], &[0x00, 0x01]),
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x01]),
        rd(&[0x28, 0x43], &[0, 0], &[5, 6, 7, 8]),
    ]);
    let mut buf = [0u8; 6];
    e.eeprom_read(0x0A, &mut buf, 1).unwrap();
    assert_eq!(buf, [1, 2, 3, 4, 5, 6]);
    done(e);
}

#[test]
fn eeprom_timeout() {
    let mut e = esc(&[
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x00]),
        wr(&[0x28, 0x24], &[0, 0], &[0x00, 0x00, 0x00, 0x00]),
        wr(&[0x28, 0x14], &[0, 0], &[0x00, 0x01]),
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x81]),
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x81]),
    ]);
    assert_eq!(e.eeprom_read_chunk(0, 2), Err(Error::Timeout));
    // Zero polls: a timeout without any access.
    assert_eq!(e.eeprom_read_chunk(0, 0), Err(Error::Timeout));
    done(e);
}

#[test]
fn eeprom_errors() {
    let mut e = esc(&[
        // Not offered.
        rd(&[0x28, 0x03], &[0, 0], &[0x00]),
        // Offered but forced to ECAT.
        rd(&[0x28, 0x03], &[0, 0], &[0x03]),
        // Acknowledge error after the command.
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x00]),
        wr(&[0x28, 0x24], &[0, 0], &[0x00, 0x00, 0x00, 0x00]),
        wr(&[0x28, 0x14], &[0, 0], &[0x00, 0x01]),
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x21]),
        // Checksum error already before the command.
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x08]),
        // Write enable error.
        rd(&[0x28, 0x13], &[0, 0], &[0x00, 0x40]),
    ]);
    assert_eq!(e.eeprom_take(), Err(Error::EepromNotOffered));
    assert_eq!(e.eeprom_take(), Err(Error::EepromNotOffered));
    let err = e.eeprom_read_chunk(0, 3).unwrap_err();
    assert_eq!(err, Error::Eeprom(EepromStatus(0x2100)));
    if let Error::Eeprom(s) = err {
        assert!(s.ack_error() && !s.checksum_error() && s.command() == 1);
    }
    assert_eq!(
        e.eeprom_read_chunk(0, 3),
        Err(Error::Eeprom(EepromStatus(0x0800)))
    );
    assert_eq!(
        e.eeprom_read_chunk(0, 3),
        Err(Error::Eeprom(EepromStatus(0x4000)))
    );
    done(e);
}

/// An SPI device whose every transaction fails.
struct FailingSpi;

impl ErrorType for FailingSpi {
    type Error = ErrorKind;
}

impl SpiDevice for FailingSpi {
    fn transaction(&mut self, _: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        Err(ErrorKind::ModeFault)
    }
}

#[test]
fn bus_errors_are_passed_through() {
    // embedded-hal-mock 0.11's eh1 SPI mock cannot inject errors, hence FailingSpi.
    let mut e = Et1100::new(SpiPdi::new(FailingSpi));
    let bus = Err(Error::Bus(ErrorKind::ModeFault));
    let mut buf = [0u8; 2];
    assert_eq!(e.read(0x0120, &mut buf), bus);
    assert_eq!(e.write(0x0120, &buf), bus);
    assert_eq!(e.events(), bus);
    assert_eq!(e.low_events(), bus);
    assert_eq!(e.read_sm(0), Err(Error::Bus(ErrorKind::ModeFault)));
    assert_eq!(
        e.eeprom_read_chunk(0, 10),
        Err(Error::Bus(ErrorKind::ModeFault))
    );
    // Range errors still win over the bus.
    assert_eq!(e.write(0x0120, &[]), Err(Error::OutOfRange));
}

#[test]
fn pdi_through_mut_reference() {
    fn nop<P: Pdi>(mut p: P) -> AlEvents {
        p.events().ok().unwrap_or_default()
    }
    fn low<P: Pdi>(mut p: P) -> AlEvents {
        p.low_events().ok().unwrap_or_default()
    }
    let mut pdi = SpiPdi::new(Mock::new(&[
        T::transaction_start(),
        T::transfer(vec![0x00, 0x06, 0x00], vec![0x00, 0x00, 0x01]),
        T::transaction_end(),
        T::transaction_start(),
        T::transfer(vec![0x00, 0x00], vec![0x00, 0x02]),
        T::transaction_end(),
    ]));
    assert!(nop(&mut pdi).intersects(AlEvents::sm(8)));
    assert!(low(&mut pdi).intersects(AlEvents::sm(1)));
    pdi.destroy().done();
}
