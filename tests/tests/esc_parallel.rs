//! The ET1100's 16-bit asynchronous µC PDI front end: byte lanes, SyncManager buffers
//! through 16-bit accesses, BUSY timing, and seed 004's multiplexed address latch.

mod common;
use common::config_sm;
use virtual_board::models::esc::parallel::{
    AddressLatch, BusTiming, Lanes, ParallelPort, UNDRIVEN_DATA,
};
use virtual_board::models::esc::{regs, Esc, EscConfig};
use virtual_board::rig::sii_builder::SiiBuilder;

/// Time the µC holds RD/WR low in these tests when BUSY does not stretch it.
const STROBE: u64 = 100;
const T: BusTiming = BusTiming {
    read_ns: 80,
    write_ns: 120,
};

/// An ESC whose SII selects the 16-bit asynchronous µC PDI (0x0E08, w1 0x0600).
fn esc_ucontroller() -> Esc {
    let sii = SiiBuilder::new()
        .config_word(0, 0x0E08)
        .config_word(1, 0x0600)
        .build();
    Esc::new(EscConfig::new(sii))
}

/// Reads at `adr` at a time far from any write.
fn read(port: &mut ParallelPort, esc: &mut Esc, adr: u16, bhe: bool) -> u16 {
    port.read(esc, 1_000_000, STROBE, adr, bhe).data
}

fn write(port: &mut ParallelPort, esc: &mut Esc, adr: u16, bhe: bool, data: u16) {
    port.write(esc, 1_000_000, STROBE, adr, bhe, data);
}

#[test]
fn lanes_follow_table_70() {
    assert_eq!(Lanes::decode(0x1000, true), Some(Lanes::Word));
    assert_eq!(Lanes::decode(0x1000, false), Some(Lanes::Low));
    assert_eq!(Lanes::decode(0x1001, true), Some(Lanes::High));
    assert_eq!(Lanes::decode(0x1001, false), None);
}

#[test]
fn word_and_byte_accesses_move_their_lanes_only() {
    let mut esc = esc_ucontroller();
    let mut port = ParallelPort::new(T);
    write(&mut port, &mut esc, 0x1000, true, 0xBBAA);
    assert_eq!(esc.peek_u16(0x1000), 0xBBAA);
    // The low lane at the even address, the high lane at the odd one.
    write(&mut port, &mut esc, 0x1000, false, 0x1122);
    assert_eq!(esc.peek_u16(0x1000), 0xBB22);
    write(&mut port, &mut esc, 0x1001, true, 0x3344);
    assert_eq!(esc.peek_u16(0x1000), 0x3322);
    // Reads: the selected lane carries the byte, the other is not driven.
    assert_eq!(read(&mut port, &mut esc, 0x1000, true), 0x3322);
    assert_eq!(read(&mut port, &mut esc, 0x1000, false), 0xFF22);
    assert_eq!(read(&mut port, &mut esc, 0x1001, true), 0x33FF);
    // An odd address without BHE is invalid: nothing moves.
    write(&mut port, &mut esc, 0x1001, false, 0x5566);
    assert_eq!(esc.peek_u16(0x1000), 0x3322);
    assert_eq!(read(&mut port, &mut esc, 0x1001, false), UNDRIVEN_DATA);
    let s = &port.stats;
    assert_eq!((s.word_writes, s.byte_writes, s.invalid), (1, 2, 2));
    assert_eq!((s.word_reads, s.byte_reads), (1, 2));
}

#[test]
fn registers_keep_their_side_effects_and_write_masks() {
    let mut esc = esc_ucontroller();
    let mut port = ParallelPort::new(T);
    assert_eq!(esc.peek_u8(regs::PDI_CONTROL), 0x08);
    esc.ecat_write(regs::AL_CONTROL, &[0x02, 0x00]);
    assert_eq!(read(&mut port, &mut esc, 0x0220, true) & 0x0001, 0x0001);
    // Reading the high byte of AL control alone acknowledges the event too (0x0121).
    assert_eq!(read(&mut port, &mut esc, 0x0121, true), 0x00FF);
    assert_eq!(read(&mut port, &mut esc, 0x0220, true) & 0x0001, 0);
    // AL status is the PDI's; AL control is not.
    write(&mut port, &mut esc, regs::AL_STATUS, true, 0x0002);
    write(&mut port, &mut esc, regs::AL_CONTROL, true, 0x0008);
    assert_eq!(esc.peek_u16(regs::AL_STATUS), 0x0002);
    assert_eq!(esc.peek_u16(regs::AL_CONTROL), 0x0002);
    // The event mask written as two words (a 32-bit register).
    write(&mut port, &mut esc, regs::AL_EVENT_MASK, true, 0x0F11);
    write(&mut port, &mut esc, regs::AL_EVENT_MASK + 2, true, 0x0000);
    assert_eq!(esc.peek_u32(regs::AL_EVENT_MASK), 0x0000_0F11);
}

#[test]
fn a_pdi_other_than_the_ucontroller_one_is_not_served() {
    // The board's SPI SII (0x0E05): the µC pins do nothing.
    let mut esc = Esc::new(EscConfig::new(SiiBuilder::new().build()));
    let mut port = ParallelPort::new(T);
    write(&mut port, &mut esc, 0x1000, true, 0x1234);
    assert_eq!(esc.peek_u16(0x1000), 0);
    let a = port.read(&mut esc, 0, STROBE, 0x0000, true);
    assert_eq!((a.data, a.busy_ns, a.end_ns), (UNDRIVEN_DATA, 0, STROBE));
    assert_eq!(port.stats.refused, 2);
}

/// SM2: 3-buffer, master writes, PDI reads, 6 bytes at 0x1100. SM3: 3-buffer, PDI writes,
/// master reads, 5 bytes at 0x1180 (odd: the last 16-bit access reaches past the buffer).
fn process_data_sms(esc: &mut Esc) {
    config_sm(esc, 2, 0x1100, 6, 0x64);
    config_sm(esc, 3, 0x1180, 5, 0x20);
}

#[test]
fn three_buffer_outputs_are_taken_by_the_word_that_covers_the_last_byte() {
    let mut esc = esc_ucontroller();
    let mut port = ParallelPort::new(T);
    process_data_sms(&mut esc);
    esc.ecat_write(0x1100, &[1, 2, 3, 4, 5, 6]);
    assert!(esc.al_event_request() & (1 << 10) != 0, "SM2 event");
    let w0 = read(&mut port, &mut esc, 0x1100, true);
    // The first byte acknowledged the SM2 event; the buffer is open for reading.
    assert_eq!(esc.al_event_request() & (1 << 10), 0);
    assert_eq!(w0, 0x0201);
    // The master writes again while the PDI is in the middle of the buffer: the PDI keeps
    // reading its buffer.
    esc.ecat_write(0x1100, &[11, 12, 13, 14, 15, 16]);
    assert_eq!(read(&mut port, &mut esc, 0x1102, true), 0x0403);
    assert_eq!(read(&mut port, &mut esc, 0x1104, true), 0x0605);
    // The word at 0x1104 covered the last byte: the next read gets the newest buffer.
    assert_eq!(read(&mut port, &mut esc, 0x1100, true), 0x0C0B);
    assert_eq!(read(&mut port, &mut esc, 0x1102, true), 0x0E0D);
    // The last byte read alone on its high lane completes the buffer as well.
    assert_eq!(read(&mut port, &mut esc, 0x1105, true), 0x10FF);
    esc.ecat_write(0x1100, &[21, 22, 23, 24, 25, 26]);
    assert_eq!(read(&mut port, &mut esc, 0x1100, true), 0x1615);
}

#[test]
fn three_buffer_inputs_are_published_by_the_access_with_the_last_byte() {
    let mut esc = esc_ucontroller();
    let mut port = ParallelPort::new(T);
    process_data_sms(&mut esc);
    let mut got = [0u8; 5];
    // Two words, then the last byte on the low lane (even address) publishes the buffer.
    write(&mut port, &mut esc, 0x1180, true, 0x0201);
    write(&mut port, &mut esc, 0x1182, true, 0x0403);
    write(&mut port, &mut esc, 0x1184, false, 0xEE05);
    esc.ecat_read(0x1180, &mut got);
    assert_eq!(got, [1, 2, 3, 4, 5]);
    // Two words of the next buffer: still open, the master reads the published one.
    write(&mut port, &mut esc, 0x1180, true, 0x0807);
    write(&mut port, &mut esc, 0x1182, true, 0x0A09);
    esc.ecat_read(0x1180, &mut got);
    assert_eq!(got, [1, 2, 3, 4, 5]);
    // A word at 0x1184 covers the last byte and one byte past the buffer: it publishes. The
    // byte past the buffer is no free memory: 3-buffer mode takes 3 x 5 bytes, and 0x1185
    // is the first byte of the second buffer, the one just written and published. So a
    // 16-bit write must never reach past a buffer's last byte (the driver writes a trailing
    // odd byte alone: `drivers/et1100/tests/memory.rs`).
    write(&mut port, &mut esc, 0x1184, true, 0x770B);
    esc.ecat_read(0x1180, &mut got);
    assert_eq!(got, [0x77, 8, 9, 10, 11]);
}

#[test]
fn mailbox_is_freed_by_the_last_byte_on_either_lane() {
    let mut esc = esc_ucontroller();
    let mut port = ParallelPort::new(T);
    // SM0: mailbox, master writes, 8 bytes at 0x1000. SM1: mailbox, PDI writes, 7 bytes at
    // 0x1080 (odd: its last byte is on the low lane).
    config_sm(&mut esc, 0, 0x1000, 8, 0x26);
    config_sm(&mut esc, 1, 0x1080, 7, 0x22);
    esc.ecat_write(0x1000, &[1, 2, 3, 4, 5, 6, 7, 8]);
    assert!(esc.sm_mailbox_full(0));
    read(&mut port, &mut esc, 0x1000, true);
    // Skipping to the last byte on the high lane frees the mailbox.
    assert_eq!(read(&mut port, &mut esc, 0x1007, true), 0x08FF);
    assert!(!esc.sm_mailbox_full(0));
    // A reply: three words, then the last byte on the low lane marks SM1 full.
    for (i, w) in [0x0201u16, 0x0403, 0x0605].iter().enumerate() {
        write(&mut port, &mut esc, 0x1080 + 2 * i as u16, true, *w);
        assert!(!esc.sm_mailbox_full(1));
    }
    write(&mut port, &mut esc, 0x1086, false, 0x0007);
    assert!(esc.sm_mailbox_full(1));
    let mut got = [0u8; 7];
    esc.ecat_read(0x1080, &mut got);
    assert_eq!(got, [1, 2, 3, 4, 5, 6, 7]);
}

#[test]
fn busy_holds_a_read_and_the_access_after_a_write() {
    let mut esc = esc_ucontroller();
    let mut port = ParallelPort::new(T);
    // A read alone: BUSY for the read time; RD stays low for the longer of strobe and BUSY.
    let r = port.read(&mut esc, 1_000, 50, 0x1000, true);
    assert_eq!((r.busy_ns, r.end_ns), (80, 1_080));
    // A write is not held; it is stored during the 120 ns after WR rises.
    let w = port.write(&mut esc, 2_000, 50, 0x1000, true, 0x1234);
    assert_eq!((w.busy_ns, w.end_ns), (0, 2_050));
    // A read 30 ns later waits for the store (90 ns left), then reads (80 ns).
    let r = port.read(&mut esc, 2_080, 50, 0x1000, true);
    assert_eq!((r.data, r.busy_ns, r.end_ns), (0x1234, 170, 2_250));
    // Two writes back to back: the second waits for the first to be stored.
    port.write(&mut esc, 3_000, 50, 0x1000, true, 1);
    let w = port.write(&mut esc, 3_060, 50, 0x1002, true, 2);
    assert_eq!((w.busy_ns, w.end_ns), (110, 3_170));
    // Long after: no wait.
    let r = port.read(&mut esc, 10_000, 100, 0x1002, true);
    assert_eq!((r.busy_ns, r.end_ns), (80, 10_100));
    assert_eq!(port.stats.busy_ns, 80 + 170 + 110 + 80);
}

#[test]
fn the_unconfirmed_busy_range_is_the_research_notes() {
    // research/stm32-fsmc.md §2: 80 ns without a frame, 260 ns clashing with one.
    assert_eq!(BusTiming::NO_CLASH.read_ns, 80);
    assert_eq!(BusTiming::FRAME_CLASH.read_ns, 260);
    let mut esc = esc_ucontroller();
    let mut port = ParallelPort::new(BusTiming::FRAME_CLASH);
    assert_eq!(port.read(&mut esc, 0, 100, 0x1000, true).end_ns, 260);
}

#[test]
fn seed_004_latch_maps_the_fsmc_halfword_address_and_byte_lanes() {
    let mut latch = AddressLatch::default();
    // SM0's start register at 0x6000_0800: halfword address 0x0400 on AD[15:0].
    latch.address_phase(0x0800 >> 1);
    // A halfword access drives NBL0 and NBL1 low.
    assert_eq!(latch.esc_pins(false, false), (0x0800, true));
    // A byte write to the even byte: NBL0 low, NBL1 high -> low lane.
    assert_eq!(latch.esc_pins(false, true), (0x0800, false));
    // A byte write to the odd byte: NBL0 high (ADR[0] = 1), NBL1 low -> high lane.
    let (adr, bhe) = latch.esc_pins(true, false);
    assert_eq!((adr, bhe), (0x0801, true));
    assert_eq!(Lanes::decode(adr, bhe), Some(Lanes::High));
    // The top of the ESC's 64 KB: AD = 0x7FFF -> ADR[15:1] all ones.
    latch.address_phase(0x7FFF);
    assert_eq!(latch.esc_pins(true, false).0, 0xFFFF);
}
