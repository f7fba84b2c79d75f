//! FMMU mapping, SyncManager mailbox and 3-buffer rules, the PD watchdog.

mod common;
use common::*;
use virtual_board::models::esc::{cmd, regs, FrameBuilder};

#[test]
fn logical_commands_need_an_fmmu() {
    let mut esc = esc();
    let d = run(&mut esc, FrameBuilder::new().logical(cmd::LRD, 0, &[0; 4])).remove(0);
    assert_eq!(d.wkc, 0);
}

#[test]
fn fmmu_byte_mapping_lrd_lwr_lrw() {
    let mut esc = esc();
    // FMMU0: logical 0x10000..0x10003 -> 0x1200 write; FMMU1: 0x10004..0x10007 <- 0x1300 read.
    config_fmmu(&mut esc, 0, 0x1_0000, 4, 0, 7, 0x1200, 0, 0x02);
    config_fmmu(&mut esc, 1, 0x1_0004, 4, 0, 7, 0x1300, 0, 0x01);
    esc.poke(0x1300, &[1, 2, 3, 4]);
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LWR, 0x1_0000, &[9, 8, 7, 6]),
    )
    .remove(0);
    assert_eq!(d.wkc, 1);
    let mut m = [0; 4];
    esc.peek(0x1200, &mut m);
    assert_eq!(m, [9, 8, 7, 6]);
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRD, 0x1_0000, &[0xEE; 8]),
    )
    .remove(0);
    assert_eq!(d.wkc, 1);
    assert_eq!(
        d.data,
        vec![0xEE, 0xEE, 0xEE, 0xEE, 1, 2, 3, 4],
        "write-only part untouched"
    );
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRW, 0x1_0000, &[5, 5, 5, 5, 0, 0, 0, 0]),
    )
    .remove(0);
    assert_eq!(d.wkc, 3, "LRW: +1 read, +2 write");
    assert_eq!(d.data, vec![5, 5, 5, 5, 1, 2, 3, 4]);
    // A datagram that overlaps only part of an FMMU.
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRD, 0x1_0006, &[0; 4]),
    )
    .remove(0);
    assert_eq!((d.wkc, d.data.clone()), (1, vec![3, 4, 0, 0]));
    // Inactive FMMU.
    esc.ecat_write(0x0600 + 16 + 0x0C, &[0]);
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRD, 0x1_0004, &[0; 4]),
    )
    .remove(0);
    assert_eq!(d.wkc, 0);
}

#[test]
fn fmmu_bit_granular_mapping() {
    let mut esc = esc();
    // Logical bits 4..7 of byte 0x20000 <-> physical bits 2..5 of 0x1400.
    config_fmmu(&mut esc, 0, 0x2_0000, 1, 4, 7, 0x1400, 2, 0x03);
    esc.poke(0x1400, &[0b1100_0011]);
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LWR, 0x2_0000, &[0b1010_1111]),
    )
    .remove(0);
    assert_eq!(d.wkc, 1);
    assert_eq!(
        esc.peek_u8(0x1400),
        0b1110_1011,
        "only bits 2..5 replaced by 1010"
    );
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRD, 0x2_0000, &[0b0000_0101]),
    )
    .remove(0);
    assert_eq!(
        d.data,
        vec![0b1010_0101],
        "bits 0..3 keep the incoming data"
    );
    // Bit mapping across a byte boundary: 6 logical bits starting at bit 6.
    config_fmmu(&mut esc, 1, 0x3_0000, 2, 6, 3, 0x1500, 0, 0x02);
    run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LWR, 0x3_0000, &[0b1100_0000, 0b0000_1111]),
    );
    assert_eq!(esc.peek_u8(0x1500), 0b0011_1111);
}

#[test]
fn fmmu_can_map_registers() {
    let mut esc = esc();
    config_sm(&mut esc, 0, 0x1000, 8, 0x26);
    // FMMU2 maps SM0's status register 0x0805 into the image (as some masters do).
    config_fmmu(&mut esc, 2, 0x4_0000, 1, 0, 7, 0x0805, 0, 0x01);
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRD, 0x4_0000, &[0]),
    )
    .remove(0);
    assert_eq!((d.wkc, d.data[0] & 0x08), (1, 0));
    esc.ecat_write(0x1000, &[1; 8]);
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRD, 0x4_0000, &[0]),
    )
    .remove(0);
    assert_eq!(d.data[0] & 0x08, 0x08, "mailbox full seen through the FMMU");
}

#[test]
fn write_mailbox_full_and_empty_rules() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    config_sm(&mut esc, 0, 0x1000, 16, 0x26);
    let d = one(&mut esc, cmd::FPWR, 0x1000, 0x1000, &[0xA1; 16]);
    assert_eq!(d.wkc, 1);
    assert_eq!(esc.peek_u8(0x0805) & 0x08, 0x08, "status: mailbox full");
    assert_ne!(
        esc.al_event_request() & (1 << 8),
        0,
        "SM0 event for the PDI"
    );
    assert!(esc.irq());
    // A write to a full mailbox is not performed and not counted.
    let d = one(&mut esc, cmd::FPWR, 0x1000, 0x1000, &[0xB2; 16]);
    assert_eq!(d.wkc, 0);
    // The PDI reads it; reading the last byte frees it.
    let mut b = [0; 16];
    esc.pdi_read(0x1000, &mut b[..8]);
    assert_eq!(
        esc.al_event_request() & (1 << 8),
        0,
        "first byte read clears the event"
    );
    assert!(esc.sm_mailbox_full(0));
    esc.pdi_read(0x1008, &mut b[8..]);
    assert_eq!(b, [0xA1; 16]);
    assert!(!esc.sm_mailbox_full(0));
    // Reading the empty mailbox again via ECAT: wrong direction, not counted.
    assert_eq!(one(&mut esc, cmd::FPRD, 0x1000, 0x1000, &[0; 16]).wkc, 0);
    // Accesses that do not start at the start address are refused.
    assert_eq!(one(&mut esc, cmd::FPWR, 0x1000, 0x1004, &[0; 12]).wkc, 0);
    // A partial write starting at the start leaves the buffer open but not full.
    assert_eq!(one(&mut esc, cmd::FPWR, 0x1000, 0x1000, &[3; 8]).wkc, 1);
    assert!(!esc.sm_mailbox_full(0));
    assert_eq!(esc.peek_u8(0x0805) & 0x80, 0x80, "write buffer open");
    assert_eq!(one(&mut esc, cmd::FPWR, 0x1000, 0x1008, &[4; 8]).wkc, 1);
    assert!(esc.sm_mailbox_full(0));
    // A datagram covering registers and the full mailbox still counts (register bytes).
    assert_eq!(one(&mut esc, cmd::FPWR, 0x1000, 0x0FF0, &[0; 32]).wkc, 1);
}

#[test]
fn read_mailbox_rules() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    config_sm(&mut esc, 1, 0x1080, 16, 0x22);
    assert_eq!(
        one(&mut esc, cmd::FPRD, 0x1000, 0x1080, &[0; 16]).wkc,
        0,
        "empty"
    );
    esc.pdi_write(0x1080, &[0x5A; 16]);
    assert_eq!(esc.peek_u8(0x080D) & 0x08, 0x08);
    // The PDI cannot overwrite a full read mailbox.
    esc.pdi_write(0x1080, &[0x00; 16]);
    let d = one(&mut esc, cmd::FPRD, 0x1000, 0x1080, &[0; 16]);
    assert_eq!((d.wkc, d.data.clone()), (1, vec![0x5A; 16]));
    assert_eq!(esc.peek_u8(0x080D) & 0x08, 0);
    assert_ne!(
        esc.al_event_request() & (1 << 9),
        0,
        "PDI told the mailbox was read"
    );
    assert_eq!(
        one(&mut esc, cmd::FPRD, 0x1000, 0x1080, &[0; 16]).wkc,
        0,
        "read once"
    );
    // The next PDI write (first byte) acknowledges the event.
    esc.pdi_write(0x1080, &[1; 16]);
    assert_eq!(esc.al_event_request() & (1 << 9), 0);
}

#[test]
fn mailbox_repeat_request_and_ack() {
    let mut esc = esc();
    config_sm(&mut esc, 1, 0x1080, 16, 0x22);
    let mut act = [0u8];
    esc.pdi_read(0x080E, &mut act);
    assert_eq!(esc.al_event_request() & 0x10, 0);
    // The master toggles the repeat bit.
    esc.ecat_write(0x080E, &[0x03]);
    assert_ne!(
        esc.al_event_request() & 0x10,
        0,
        "SM activation change event"
    );
    esc.pdi_read(0x080E, &mut act);
    assert_eq!(act[0] & 0x02, 0x02);
    assert_eq!(
        esc.al_event_request() & 0x10,
        0,
        "read of 0x080E acknowledges"
    );
    // The PDI rewrites the last reply and acknowledges in 0x080F b1.
    esc.pdi_write(0x1080, &[7; 16]);
    esc.pdi_write(0x080F, &[0x02]);
    let d = one(&mut esc, cmd::BRD, 0, 0x080E, &[0, 0]);
    assert_eq!(d.data, vec![0x03, 0x02]);
    assert!(esc.sm_mailbox_full(1));
    // The master cannot write 0x080F; the PDI cannot write 0x080E.
    esc.ecat_write(0x080F, &[0]);
    esc.pdi_write(0x080E, &[0]);
    assert_eq!(esc.peek_u16(0x080E), 0x0203);
}

#[test]
fn sm_config_is_locked_while_enabled_and_disable_resets() {
    let mut esc = esc();
    config_sm(&mut esc, 0, 0x1000, 16, 0x26);
    esc.ecat_write(0x0800, &[0x00, 0x14]);
    assert_eq!(
        esc.peek_u16(0x0800),
        0x1000,
        "start address locked while enabled"
    );
    esc.ecat_write(0x1000, &[1; 16]);
    assert!(esc.sm_mailbox_full(0));
    esc.ecat_write(0x0806, &[0x00]);
    assert!(!esc.sm_mailbox_full(0));
    esc.ecat_write(0x0800, &[0x00, 0x14]);
    assert_eq!(esc.peek_u16(0x0800), 0x1400);
    // PDI deactivation (0x0807 b0) turns the area into plain memory.
    config_sm(&mut esc, 0, 0x1000, 16, 0x26);
    esc.pdi_write(0x0807, &[0x01]);
    assert!(esc.ecat_write(0x1004, &[9; 4]).written);
    assert_eq!(esc.peek_u8(0x1004), 9);
}

#[test]
fn three_buffer_mode_is_consistent() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    config_sm(&mut esc, 2, 0x1100, 4, 0x64);
    assert_eq!(esc.peek_u8(0x0815) & 0x30, 0x30, "no buffer written yet");
    assert_eq!(
        one(&mut esc, cmd::FPWR, 0x1000, 0x1100, &[1, 1, 1, 1]).wkc,
        1
    );
    assert_ne!(esc.al_event_request() & (1 << 10), 0);
    let mut b = [0; 4];
    esc.pdi_read(0x1100, &mut b);
    assert_eq!(b, [1; 4]);
    // Two writes without a read: the reader gets the newest.
    one(&mut esc, cmd::FPWR, 0x1000, 0x1100, &[2; 4]);
    one(&mut esc, cmd::FPWR, 0x1000, 0x1100, &[3; 4]);
    esc.pdi_read(0x1100, &mut b);
    assert_eq!(b, [3; 4]);
    // The reader is in the middle of a buffer while a new one completes.
    one(&mut esc, cmd::FPWR, 0x1000, 0x1100, &[4; 4]);
    esc.pdi_read(0x1100, &mut b[..2]);
    assert_eq!(esc.peek_u8(0x0815) & 0x40, 0x40, "read buffer open");
    one(&mut esc, cmd::FPWR, 0x1000, 0x1100, &[5; 4]);
    one(&mut esc, cmd::FPWR, 0x1000, 0x1100, &[6; 4]);
    esc.pdi_read(0x1102, &mut b[2..]);
    assert_eq!(b, [4; 4], "consistent: no mix of old and new data");
    esc.pdi_read(0x1100, &mut b);
    assert_eq!(b, [6; 4]);
    // The three buffers use 3 x length of RAM behind the first buffer's range.
    let mut raw = [0; 12];
    esc.peek(0x1100, &mut raw);
    let mut seen: Vec<u8> = raw.chunks(4).map(|c| c[0]).collect();
    seen.sort();
    assert!(seen.contains(&6) && seen.contains(&5), "{raw:?}");
    let last = (esc.peek_u8(0x0815) >> 4) & 3;
    assert_eq!(
        raw[last as usize * 4],
        6,
        "status bits point at the last written buffer"
    );
}

#[test]
fn three_buffer_inputs_are_always_readable() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    config_sm(&mut esc, 3, 0x1180, 2, 0x20);
    assert_eq!(one(&mut esc, cmd::FPRD, 0x1000, 0x1180, &[0; 2]).wkc, 1);
    esc.pdi_write(0x1180, &[0x34, 0x12]);
    let d = one(&mut esc, cmd::FPRD, 0x1000, 0x1180, &[0; 2]);
    assert_eq!(d.data, vec![0x34, 0x12]);
    assert_eq!(
        one(&mut esc, cmd::FPRD, 0x1000, 0x1180, &[0; 2]).data,
        vec![0x34, 0x12]
    );
    // The master cannot write the inputs buffer.
    assert_eq!(one(&mut esc, cmd::FPWR, 0x1000, 0x1180, &[0; 2]).wkc, 0);
    // Through an FMMU with LRW: inputs read, +1.
    config_fmmu(&mut esc, 3, 0x100, 2, 0, 7, 0x1180, 0, 0x01);
    let d = run(
        &mut esc,
        FrameBuilder::new().logical(cmd::LRW, 0x100, &[0; 2]),
    )
    .remove(0);
    assert_eq!((d.wkc, d.data.clone()), (1, vec![0x34, 0x12]));
}

/// The oversampling design writes an input image in two accesses: the header and the valid
/// samples from the start, then the last byte alone, which completes the buffer; the bytes in
/// between keep what that buffer held (docs/book/oversampling.md, PDI budget). Other PDI
/// accesses may come between the two.
#[test]
fn three_buffer_write_completes_on_its_last_byte_with_bytes_skipped() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    config_sm(&mut esc, 3, 0x1180, 8, 0x20);
    esc.record_pdi_buffer_writes = true;
    esc.pdi_write(0x1180, &[0xEE; 8]);
    let read = |esc: &mut virtual_board::models::esc::Esc| {
        one(esc, cmd::FPRD, 0x1000, 0x1180, &[0; 8]).data
    };
    assert_eq!(read(&mut esc), vec![0xEE; 8]);
    esc.pdi_write(0x1180, &[1, 2, 3]);
    assert_eq!(
        read(&mut esc),
        vec![0xEE; 8],
        "not complete: the master reads the last one"
    );
    let mut events = [0; 2];
    esc.pdi_read(0x0220, &mut events);
    esc.advance(1_000);
    esc.pdi_write(0x1187, &[8]);
    // Each completed buffer recorded with the time of its last byte (the first at the
    // model's start time, the second 1 us later), the unfinished write not.
    let t = esc.pdi_buffer_writes[0].1;
    assert_eq!(esc.pdi_buffer_writes, [(3, t), (3, t + 1_000)]);
    let image = read(&mut esc);
    assert_eq!(image[..3], [1, 2, 3]);
    assert_eq!(image[7], 8);
    // The skipped bytes are what that physical buffer held before: never written here.
    assert_eq!(image[3..7], [0; 4]);
}

#[test]
fn pd_watchdog_expires_without_sm2_writes() {
    let mut esc = esc();
    config_sm(&mut esc, 2, 0x1100, 2, 0x64);
    // 100 us ticks (default divider) x 10 = 1 ms.
    esc.ecat_write(regs::WD_TIME_PD, &10u16.to_le_bytes());
    assert_eq!(esc.pd_watchdog_period_ns(), 1_000_000);
    esc.ecat_write(0x1100, &[1, 2]);
    esc.advance(900_000);
    assert_eq!(esc.peek_u8(regs::WD_STATUS_PD) & 1, 1);
    esc.ecat_write(0x1100, &[1, 2]);
    esc.advance(900_000);
    assert_eq!(esc.peek_u8(regs::WD_STATUS_PD) & 1, 1, "retriggered");
    esc.advance(200_000);
    assert_eq!(esc.peek_u8(regs::WD_STATUS_PD) & 1, 0, "expired");
    assert_eq!(esc.peek_u8(regs::WD_COUNTER_PD), 1);
    assert_ne!(esc.al_event_request() & 0x40, 0);
    let mut s = [0];
    esc.pdi_read(regs::WD_STATUS_PD, &mut s);
    assert_eq!(
        esc.al_event_request() & 0x40,
        0,
        "read of 0x0440 acknowledges"
    );
    esc.advance(5_000_000);
    assert_eq!(
        esc.peek_u8(regs::WD_COUNTER_PD),
        1,
        "counts once per expiry"
    );
    esc.ecat_write(0x1100, &[1, 2]);
    assert_eq!(esc.peek_u8(regs::WD_STATUS_PD) & 1, 1);
    // The master clears the counter by writing it.
    esc.ecat_write(regs::WD_COUNTER_PD, &[0]);
    assert_eq!(esc.peek_u8(regs::WD_COUNTER_PD), 0);
}

#[test]
fn watchdog_time_zero_disables() {
    let mut esc = esc();
    config_sm(&mut esc, 2, 0x1100, 2, 0x64);
    esc.ecat_write(regs::WD_TIME_PD, &[0, 0]);
    esc.ecat_write(0x1100, &[1, 2]);
    esc.advance(1_000_000_000);
    assert_eq!(esc.peek_u8(regs::WD_STATUS_PD) & 1, 1);
}
