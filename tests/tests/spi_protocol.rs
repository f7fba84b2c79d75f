//! The ET1100 SPI PDI, byte-exact golden streams (hardware-facts 1.2).

mod common;
use common::*;
use embedded_hal::spi::{Operation, SpiDevice};
use virtual_board::models::esc::regs;
use virtual_board::models::spi::{EscSpi, SharedEsc};

fn with_al_control_event() -> virtual_board::models::esc::Esc {
    let mut esc = esc();
    // The master requests PREOP: AL event bit 0 set, AL control = 0x0002.
    esc.ecat_write(regs::AL_CONTROL, &[0x02, 0x00]);
    esc
}

#[test]
fn read_with_wait_state_golden_stream() {
    let mut esc = with_al_control_event();
    // Read 2 bytes at 0x0120 with cmd 3: address, wait byte, data with 0xFF termination.
    let miso = esc.spi_transfer(&[0x09, 0x03, 0xFF, 0x00, 0xFF]);
    assert_eq!(miso, vec![0x01, 0x00, 0xFF, 0x02, 0x00]);
    // The read of 0x0120 acknowledged the event: the next address phase shows it clear.
    let miso = esc.spi_transfer(&[0x09, 0x03, 0xFF, 0x00, 0xFF]);
    assert_eq!(&miso[..2], &[0x00, 0x00]);
    assert_eq!(esc.spi_stats.errors, 0);
}

#[test]
fn read_without_wait_state_golden_stream() {
    let mut esc = with_al_control_event();
    // `09 02 00 FF`: read 2 bytes at 0x0120 with cmd 2.
    let miso = esc.spi_transfer(&[0x09, 0x02, 0x00, 0xFF]);
    assert_eq!(miso, vec![0x01, 0x00, 0x02, 0x00]);
}

#[test]
fn three_byte_addressing_golden_stream() {
    let mut esc = esc();
    // `A0 06 2C FF 00 00 00 FF`: read 4 bytes at 0x3400 (beyond the 8 KB RAM: zeros).
    let miso = esc.spi_transfer(&[0xA0, 0x06, 0x2C, 0xFF, 0x00, 0x00, 0x00, 0xFF]);
    assert_eq!(miso, vec![0x00, 0x00, 0x00, 0xFF, 0, 0, 0, 0]);
    // The same form reaches process RAM at 0x2F00: A[12:5] = 0x78, A[15:13] = 1.
    esc.pdi_write(0x2F00, &[0xDE, 0xAD]);
    let miso = esc.spi_transfer(&[0x78, 0x06, 0x2C, 0xFF, 0x00, 0xFF]);
    assert_eq!(&miso[4..], &[0xDE, 0xAD]);
    // The third address byte shifts out 0x0222 (SM8.. events, none here).
    esc.ecat_write(regs::AL_CONTROL, &[0x04, 0x00]);
    let miso = esc.spi_transfer(&[0x09, 0x06, 0x0C, 0xFF, 0xFF]);
    assert_eq!(miso, vec![0x01, 0x00, 0x00, 0xFF, 0x04]);
}

#[test]
fn write_golden_stream() {
    let mut esc = esc();
    // Write AL status = 0x0002 at 0x0130: `09 84 02 00`.
    let miso = esc.spi_transfer(&[0x09, 0x84, 0x02, 0x00]);
    assert_eq!(&miso[..2], &[0x00, 0x00]);
    assert_eq!(esc.peek_u16(regs::AL_STATUS), 0x0002);
    // 3-byte addressing write at 0x1200: `90 06 10 data` (A[15:13] = 0, CMD 4).
    esc.spi_transfer(&[0x90, 0x06, 0x10, 0x11, 0x22]);
    assert_eq!(esc.peek_u16(0x1200), 0x2211);
}

#[test]
fn nop_shifts_out_events_only() {
    let mut esc = with_al_control_event();
    let miso = esc.spi_transfer(&[0x00, 0x00, 0x00, 0x00]);
    assert_eq!(miso, vec![0x01, 0x00, 0x00, 0x00]);
    assert_eq!(
        esc.al_event_request() & 1,
        1,
        "NOP does not acknowledge anything"
    );
    assert_eq!(esc.spi_stats.errors, 0);
}

#[test]
fn missing_termination_is_a_pdi_error() {
    let mut esc = esc();
    esc.spi_transfer(&[0x09, 0x03, 0xFF, 0x00, 0x00]);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_COUNTER), 1);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_CODE) & 0x10, 0x10);
    // Clocking data after the termination byte.
    esc.spi_transfer(&[0x09, 0x03, 0xFF, 0xFF, 0x00]);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_COUNTER), 2);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_CODE) & 0x20, 0x20);
    // The master clears the counter by writing it.
    esc.ecat_write(regs::PDI_ERROR_COUNTER, &[0]);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_COUNTER), 0);
    assert_eq!(esc.spi_stats.errors, 2);
}

#[test]
fn spi_device_splits_the_stream_across_operations() {
    let esc = SharedEsc::new(with_al_control_event());
    let mut spi = EscSpi::new(esc.clone());
    assert!(spi.irq());
    let mut ev = [0u8; 2];
    let mut wait = [0u8; 1];
    let mut data = [0u8; 2];
    spi.transaction(&mut [
        Operation::Transfer(&mut ev, &[0x09, 0x03]),
        Operation::TransferInPlace(&mut wait),
        Operation::Transfer(&mut data, &[0x00, 0xFF]),
    ])
    .unwrap();
    assert_eq!((ev, data), ([0x01, 0x00], [0x02, 0x00]));
    assert_eq!(wait, [0xFF], "MISO during the wait byte");
    assert!(!spi.irq());
    // Write split into address and data operations.
    spi.transaction(&mut [
        Operation::Write(&[0x09, 0x84]),
        Operation::Write(&[0x02, 0x00]),
    ])
    .unwrap();
    assert_eq!(esc.borrow().peek_u16(regs::AL_STATUS), 2);
    let s = esc.borrow().spi_stats.clone();
    assert_eq!(s.transactions, 2);
    assert_eq!(s.bytes, 9);
    assert_eq!(s.address_bytes, 4);
    assert_eq!(s.wait_bytes, 1);
    assert_eq!(s.read_bytes, 2);
    assert_eq!(s.write_bytes, 2);
}

#[test]
fn read_operation_without_termination_is_flagged() {
    let esc = SharedEsc::new(esc());
    let mut spi = EscSpi::new(esc.clone());
    let mut data = [0u8; 2];
    spi.transaction(&mut [
        Operation::Write(&[0x09, 0x03, 0xFF]),
        Operation::Read(&mut data),
    ])
    .unwrap();
    assert_eq!(data, [0x01, 0x00], "AL control reset value");
    assert_eq!(esc.borrow().peek_u8(regs::PDI_ERROR_CODE) & 0x10, 0x10);
}

#[test]
fn mailbox_through_spi_reads_frees_on_last_byte() {
    let mut esc = esc();
    config_sm(&mut esc, 0, 0x1000, 4, 0x26);
    esc.ecat_write(0x1000, &[1, 2, 3, 4]);
    // SM0 event (bit 8) appears in the second event byte; bit 4 is the SM activation
    // change from enabling SM0.
    let miso = esc.spi_transfer(&[0x80, 0x03, 0xFF, 0x00, 0x00, 0x00, 0xFF]);
    assert_eq!(miso, vec![0x10, 0x01, 0xFF, 1, 2, 3, 4]);
    assert!(!esc.sm_mailbox_full(0));
    assert_eq!(esc.al_event_request() & 0x100, 0);
}

#[test]
fn recording_transactions() {
    let mut esc = esc();
    esc.spi_record = true;
    esc.spi_transfer(&[0x09, 0x84, 0x04, 0x00]);
    assert_eq!(esc.spi_log.len(), 1);
    assert_eq!(esc.spi_log[0].mosi, vec![0x09, 0x84, 0x04, 0x00]);
    assert_eq!(esc.spi_log[0].miso.len(), 4);
}

/// Fault switch: a MISO bit flipped in a read's data reaches only the MCU; the ESC's state
/// and error counters know nothing of it. Only the targeted transaction is hit.
#[test]
fn fault_miso_bit_flip_reaches_the_mcu_only() {
    use virtual_board::models::spi::{SpiFault, SpiTarget};
    let mut esc = esc();
    esc.pdi_write(0x1200, &[0x34, 0x12]);
    esc.spi_faults.inject(
        SpiTarget::Read(0x1200),
        SpiFault::FlipMiso { byte: 4, bit: 0 },
    );
    // A read of another address first (0x1180): not hit.
    let miso = esc.spi_transfer(&[0x8C, 0x03, 0xFF, 0x00, 0xFF]);
    assert_eq!(&miso[3..], &[0x00, 0x00]);
    assert_eq!(esc.spi_faults.pending(), 1);
    // Read 2 bytes at 0x1200 (cmd 3): data bytes at index 3 and 4; index 4 arrives flipped.
    let miso = esc.spi_transfer(&[0x90, 0x03, 0xFF, 0x00, 0xFF]);
    assert_eq!(&miso[3..], &[0x34, 0x13]);
    assert_eq!(esc.spi_faults.pending(), 0);
    assert_eq!(esc.spi_faults.injected.len(), 1);
    assert_eq!(esc.spi_stats.errors, 0);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_COUNTER), 0);
    // The next read is clean again.
    let miso = esc.spi_transfer(&[0x90, 0x03, 0xFF, 0x00, 0xFF]);
    assert_eq!(&miso[3..], &[0x34, 0x12]);
}

/// Fault switch: a MOSI bit flipped in a write's data is written by the ESC; one flipped in
/// a read's termination byte leaves the read without termination (a PDI error).
#[test]
fn fault_mosi_bit_flip_reaches_the_esc() {
    use virtual_board::models::spi::{SpiFault, SpiTarget};
    let mut esc = esc();
    esc.spi_faults
        .inject(SpiTarget::Next, SpiFault::FlipMosi { byte: 3, bit: 7 });
    esc.spi_transfer(&[0x90, 0x04, 0x11, 0x22]);
    assert_eq!(esc.peek_u16(0x1200), 0xA211);
    esc.spi_faults
        .inject(SpiTarget::Next, SpiFault::FlipMosi { byte: 4, bit: 0 });
    esc.spi_transfer(&[0x90, 0x03, 0xFF, 0x00, 0xFF]);
    assert_eq!(esc.spi_stats.errors, 1);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_COUNTER), 1);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_CODE) & 0x10, 0x10);
}

/// Fault switch: SPI_SEL released in the middle of a read ends the ESC's access there (no
/// termination: a PDI error, 0x030E b4) and the MCU reads the idle bus; released in the
/// middle of a write, the bytes before are written, the rest are not.
#[test]
fn fault_sel_released_mid_transaction() {
    use virtual_board::models::spi::{SpiFault, SpiTarget, SEL_HIGH_MISO};
    let mut esc = esc();
    esc.pdi_write(0x1200, &[1, 2, 3, 4]);
    esc.spi_faults
        .inject(SpiTarget::Read(0x1200), SpiFault::DropSel { byte: 5 });
    let miso = esc.spi_transfer(&[0x90, 0x03, 0xFF, 0x00, 0x00, 0x00, 0xFF]);
    assert_eq!(&miso[3..], &[1, 2, SEL_HIGH_MISO, SEL_HIGH_MISO]);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_COUNTER), 1);
    assert_eq!(esc.peek_u8(regs::PDI_ERROR_CODE) & 0x10, 0x10);
    esc.spi_faults
        .inject(SpiTarget::Write(0x1200), SpiFault::DropSel { byte: 4 });
    esc.spi_transfer(&[0x90, 0x04, 0xAA, 0xBB, 0xCC, 0xDD]);
    let mut got = [0u8; 4];
    esc.peek(0x1200, &mut got);
    assert_eq!(got, [0xAA, 0xBB, 3, 4]);
}
