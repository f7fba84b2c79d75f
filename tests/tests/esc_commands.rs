//! Datagram commands, working counters and addressing of the ESC model.

mod common;
use common::*;
use virtual_board::models::esc::{cmd, parse_frame, regs, FrameBuilder};

#[test]
fn brd_reads_type_increments_adp_and_marks_source_mac() {
    let mut esc = esc();
    let mut frame = FrameBuilder::new()
        .datagram(cmd::BRD, 0, regs::TYPE, &[0, 0x80])
        .build();
    assert!(esc.process_frame(&mut frame));
    assert_eq!(frame[6], 0x12, "source MAC bit 1 set on the way back");
    let d = &parse_frame(&frame).unwrap()[0];
    assert_eq!(
        d.data,
        vec![0x11, 0x80],
        "BRD ORs the ESC data into the datagram"
    );
    assert_eq!(d.wkc, 1);
    assert_eq!(d.adp, 1, "ADP incremented by the slave");
}

#[test]
fn non_ethercat_frames_pass_untouched() {
    let mut esc = esc();
    let mut frame = FrameBuilder::new().datagram(cmd::BRD, 0, 0, &[0]).build();
    frame[12] = 0x08;
    frame[13] = 0x00;
    let copy = frame.clone();
    assert!(!esc.process_frame(&mut frame));
    assert_eq!(frame, copy);
}

#[test]
fn esc_information_registers() {
    let mut esc = esc();
    let d = one(&mut esc, cmd::BRD, 0, 0, &[0; 10]);
    assert_eq!(d.data[0], 0x11, "ET1100 type");
    assert_eq!(d.data[4], 8, "8 FMMUs");
    assert_eq!(d.data[5], 8, "8 SyncManagers");
    assert_eq!(d.data[6], 8, "8 KB process RAM");
    let features = u16::from_le_bytes([d.data[8], d.data[9]]);
    assert_ne!(features & 0x0004, 0, "DC supported");
    assert_ne!(features & 0x0008, 0, "64-bit DC");
}

#[test]
fn position_addressing() {
    let mut esc = esc();
    let d = one(&mut esc, cmd::APWR, 0, regs::STATION_ADDRESS, &[0x00, 0x10]);
    assert_eq!((d.wkc, d.adp), (1, 1));
    assert_eq!(esc.peek_u16(regs::STATION_ADDRESS), 0x1000);
    // ADP != 0: not addressed, but still incremented.
    let d = one(&mut esc, cmd::APRD, 0xFFFF, regs::STATION_ADDRESS, &[0, 0]);
    assert_eq!((d.wkc, d.adp, d.data.clone()), (0, 0, vec![0, 0]));
    let d = one(&mut esc, cmd::APRD, 0, regs::STATION_ADDRESS, &[0, 0]);
    assert_eq!((d.wkc, d.data.clone()), (1, vec![0x00, 0x10]));
    // APRW: +1 read, +2 write.
    let d = one(&mut esc, cmd::APRW, 0, regs::STATION_ADDRESS, &[0x01, 0x10]);
    assert_eq!((d.wkc, d.data.clone()), (3, vec![0x00, 0x10]));
    assert_eq!(esc.peek_u16(regs::STATION_ADDRESS), 0x1001);
}

#[test]
fn configured_addressing_and_alias() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    assert_eq!(one(&mut esc, cmd::FPRD, 0x1000, 0x0130, &[0, 0]).wkc, 1);
    assert_eq!(one(&mut esc, cmd::FPRD, 0x1001, 0x0130, &[0, 0]).wkc, 0);
    assert_eq!(one(&mut esc, cmd::FPWR, 0x1000, 0x0120, &[2, 0]).wkc, 1);
    assert_eq!(one(&mut esc, cmd::FPWR, 0x1001, 0x0120, &[4, 0]).wkc, 0);
    assert_eq!(esc.peek_u16(regs::AL_CONTROL), 2);
    let d = one(&mut esc, cmd::FPRW, 0x1000, 0x0120, &[8, 0]);
    assert_eq!((d.wkc, d.data.clone()), (3, vec![2, 0]));
    assert_eq!(d.adp, 0x1000, "FP commands do not change ADP");
    // Alias (0x0012 from the PDI / SII word 4) answers once DL control b24 enables it.
    esc.pdi_write(regs::STATION_ALIAS, &[0x34, 0x12]);
    assert_eq!(one(&mut esc, cmd::FPRD, 0x1234, 0x0130, &[0, 0]).wkc, 0);
    esc.ecat_write(0x0103, &[0x01]);
    assert_eq!(one(&mut esc, cmd::FPRD, 0x1234, 0x0130, &[0, 0]).wkc, 1);
}

#[test]
fn broadcast_write_and_read_write() {
    let mut esc = esc();
    let d = one(&mut esc, cmd::BWR, 0, regs::AL_CONTROL, &[0x11, 0]);
    assert_eq!((d.wkc, d.adp), (1, 1));
    assert_eq!(esc.peek_u16(regs::AL_CONTROL), 0x11);
    let d = one(&mut esc, cmd::BRW, 0, regs::AL_CONTROL, &[0x02, 0]);
    assert_eq!(d.wkc, 3);
    assert_eq!(
        d.data,
        vec![0x13, 0],
        "old value ORed into the incoming data"
    );
    assert_eq!(esc.peek_u16(regs::AL_CONTROL), 0x02);
}

#[test]
fn nop_does_nothing() {
    let mut esc = esc();
    let d = one(&mut esc, cmd::NOP, 0, regs::AL_CONTROL, &[0x08, 0]);
    assert_eq!((d.wkc, d.data.clone()), (0, vec![0x08, 0]));
    assert_eq!(esc.peek_u16(regs::AL_CONTROL), 1);
}

#[test]
fn armw_and_frmw_read_on_addressed_write_elsewhere() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    esc.advance(1_000);
    let t = esc.dc_system_time();
    let d = one(&mut esc, cmd::ARMW, 0, regs::DC_SYSTEM_TIME, &[0; 8]);
    assert_eq!(d.wkc, 1);
    assert_eq!(u64::from_le_bytes(d.data.clone().try_into().unwrap()), t);
    let d = one(&mut esc, cmd::FRMW, 0x1000, regs::DC_SYSTEM_TIME, &[0; 8]);
    assert_eq!(d.wkc, 1);
    assert_eq!(u64::from_le_bytes(d.data.clone().try_into().unwrap()), t);
    // Not the addressed station: the ESC writes (drift control), data unchanged.
    let written = (t - 500).to_le_bytes();
    let d = one(&mut esc, cmd::FRMW, 0x2000, regs::DC_SYSTEM_TIME, &written);
    assert_eq!((d.wkc, d.data.clone()), (1, written.to_vec()));
    let diff = esc.peek_u32(regs::DC_SYSTEM_TIME_DIFF);
    assert_eq!(diff, 500, "local copy 500 ns ahead of the received time");
    let d = one(
        &mut esc,
        cmd::ARMW,
        5,
        regs::DC_SYSTEM_TIME,
        &(t + 700).to_le_bytes(),
    );
    assert_eq!((d.wkc, d.adp), (1, 6));
    // The first write nudged the local clock by a few ns (drift control).
    let diff = esc.peek_u32(regs::DC_SYSTEM_TIME_DIFF);
    assert_eq!(
        diff & 0x8000_0000,
        0x8000_0000,
        "local copy behind: sign bit"
    );
    assert!((700..=704).contains(&(diff & 0x7FFF_FFFF)), "{diff:#x}");
}

#[test]
fn several_datagrams_follow_the_more_bit() {
    let mut esc = esc();
    let f = FrameBuilder::new()
        .datagram(cmd::APWR, 0, regs::STATION_ADDRESS, &[0x00, 0x10])
        .datagram(cmd::FPRD, 0x1000, regs::TYPE, &[0])
        .datagram(cmd::BRD, 0, regs::AL_STATUS, &[0, 0]);
    let ds = run(&mut esc, f);
    assert_eq!(ds.len(), 3);
    assert_eq!(ds.iter().map(|d| d.wkc).collect::<Vec<_>>(), vec![1, 1, 1]);
    assert_eq!(ds[1].data, vec![0x11]);
    // Datagrams after one without the more bit are not processed.
    let mut frame = FrameBuilder::new()
        .datagram(cmd::BRD, 0, 0, &[0])
        .datagram(cmd::BRD, 0, 0, &[0])
        .build();
    frame[16 + 7] &= 0x7F; // clear "more" of the first datagram
    esc.process_frame(&mut frame);
    let second_wkc_at = frame.len() - 2;
    assert_eq!(&frame[second_wkc_at..], &[0, 0]);
}

#[test]
fn read_only_registers_ignore_ecat_writes() {
    let mut esc = esc();
    let d = one(&mut esc, cmd::BWR, 0, regs::AL_STATUS, &[0x08, 0]);
    assert_eq!(
        d.wkc, 1,
        "register writes count even where bits are read-only"
    );
    assert_eq!(esc.peek_u16(regs::AL_STATUS), 1);
    esc.pdi_write(regs::AL_STATUS, &[0x02, 0]);
    assert_eq!(esc.peek_u16(regs::AL_STATUS), 2);
    esc.ecat_write(regs::AL_STATUS_CODE, &[0x11, 0]);
    assert_eq!(esc.peek_u16(regs::AL_STATUS_CODE), 0);
    esc.ecat_write(regs::TYPE, &[0x55]);
    assert_eq!(esc.peek_u8(regs::TYPE), 0x11);
    // The AL event mask belongs to the PDI.
    esc.ecat_write(regs::AL_EVENT_MASK, &[0, 0, 0, 0]);
    assert_eq!(esc.peek_u32(regs::AL_EVENT_MASK), 0x00FF_FF0F);
}

#[test]
fn al_control_write_raises_the_pdi_event_and_irq() {
    let mut esc = esc();
    assert!(!esc.irq());
    one(&mut esc, cmd::BWR, 0, regs::AL_CONTROL, &[0x02, 0]);
    assert_eq!(esc.al_event_request() & 1, 1);
    assert!(esc.irq());
    // Masked: event stays, IRQ goes.
    esc.pdi_write(regs::AL_EVENT_MASK, &[0, 0, 0, 0]);
    assert!(!esc.irq());
    esc.pdi_write(regs::AL_EVENT_MASK, &[0x0F, 0xFF, 0xFF, 0x00]);
    assert!(esc.irq());
    // Reading AL control from the PDI clears it.
    let mut b = [0; 2];
    esc.pdi_read(regs::AL_CONTROL, &mut b);
    assert_eq!(b, [0x02, 0]);
    assert_eq!(esc.al_event_request() & 1, 0);
    assert!(!esc.irq());
}

#[test]
fn al_status_change_shows_in_the_datagram_irq_field() {
    let mut esc = esc();
    esc.ecat_write(regs::ECAT_EVENT_MASK, &[0x08, 0]);
    esc.pdi_write(regs::AL_STATUS, &[0x02, 0]);
    let d = one(&mut esc, cmd::BRD, 0, regs::TYPE, &[0]);
    assert_eq!(d.irq & 0x0008, 0x0008);
    // Reading AL status acknowledges it.
    one(&mut esc, cmd::BRD, 0, regs::AL_STATUS, &[0, 0]);
    let d = one(&mut esc, cmd::BRD, 0, regs::TYPE, &[0]);
    assert_eq!(d.irq & 0x0008, 0);
}

#[test]
fn dl_status_reports_pdi_operational_and_port0() {
    let mut esc = esc();
    let d = one(&mut esc, cmd::BRD, 0, regs::DL_STATUS, &[0, 0]);
    let v = u16::from_le_bytes([d.data[0], d.data[1]]);
    assert_eq!(v & 0x0001, 1, "PDI operational");
    assert_eq!(v & 0x0010, 0x0010, "link on port 0");
    assert_eq!(v & 0x0200, 0x0200, "communication on port 0");
}

#[test]
fn accesses_beyond_the_memory_read_zero() {
    let mut esc = esc();
    let d = one(&mut esc, cmd::BRD, 0, 0x3400, &[0; 4]);
    assert_eq!((d.wkc, d.data.clone()), (1, vec![0; 4]));
}
