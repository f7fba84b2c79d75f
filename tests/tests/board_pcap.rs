//! The board's frame path and the pcap writer.

use virtual_board::models::esc::{cmd, parse_frame, regs, FrameBuilder};
use virtual_board::rig::board::{BoardConfig, BoardIo, PdiCpu, VirtualBoard};
use virtual_board::rig::sii_builder::minimal_io_device;
use virtual_board::tools::pcap::{read_records, PcapWriter, LINKTYPE_ETHERNET, MAGIC_NS};

#[test]
fn pcap_header_and_records() {
    let mut p = PcapWriter::new();
    p.record(1_500_000_123, &[1, 2, 3]);
    let b = p.bytes();
    assert_eq!(u32::from_le_bytes(b[0..4].try_into().unwrap()), MAGIC_NS);
    assert_eq!(u16::from_le_bytes(b[4..6].try_into().unwrap()), 2);
    assert_eq!(u16::from_le_bytes(b[6..8].try_into().unwrap()), 4);
    assert_eq!(
        u32::from_le_bytes(b[20..24].try_into().unwrap()),
        LINKTYPE_ETHERNET
    );
    assert_eq!(&b[24..28], &1u32.to_le_bytes(), "seconds");
    assert_eq!(&b[28..32], &500_000_123u32.to_le_bytes(), "nanoseconds");
    assert_eq!(
        read_records(b).unwrap(),
        vec![(1_500_000_123, vec![1, 2, 3])]
    );
}

/// The whole file, byte for byte: classic pcap, the nanosecond magic, little-endian, version
/// 2.4, snap length 65535, Ethernet; each record seconds, nanoseconds, captured and original
/// length, data.
#[test]
fn pcap_file_bytes() {
    let mut p = PcapWriter::new();
    p.record(1_500_000_123, &[1, 2, 3]);
    p.record(2_000_000_000, &[]);
    #[rustfmt::skip]
    let golden = [
        0x4D, 0x3C, 0xB2, 0xA1, 2, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF, 0, 0, 1, 0, 0, 0,
        1, 0, 0, 0, 0x7B, 0x65, 0xCD, 0x1D, 3, 0, 0, 0, 3, 0, 0, 0, 1, 2, 3,
        2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    ];
    assert_eq!(p.bytes(), golden);
    assert_eq!(p.frames(), 2);
}

/// Counts IRQ calls and acknowledges AL control by reading it (direct PDI access).
struct AckCpu {
    irqs: std::rc::Rc<std::cell::Cell<u32>>,
}

impl PdiCpu for AckCpu {
    fn on_irq(&mut self, io: &mut BoardIo) {
        self.irqs.set(self.irqs.get() + 1);
        let mut b = [0; 2];
        io.esc.esc().borrow_mut().pdi_read(regs::AL_CONTROL, &mut b);
    }
}

#[test]
fn exchange_records_both_directions_and_advances_time() {
    let mut board = VirtualBoard::new(BoardConfig::new(minimal_io_device()));
    let irqs = std::rc::Rc::new(std::cell::Cell::new(0));
    board.set_cpu(Box::new(AckCpu { irqs: irqs.clone() }));
    let frame = FrameBuilder::new()
        .datagram(cmd::BWR, 0, regs::AL_CONTROL, &[0x02, 0])
        .build();
    let reply = board.exchange(&frame);
    assert_eq!(parse_frame(&reply).unwrap()[0].wkc, 1);
    assert_eq!(
        irqs.get(),
        1,
        "IRQ handler ran once and cleared the level IRQ"
    );
    assert!(!board.esc().borrow().irq());
    let t = board.now_ns();
    assert!(t >= 10_000, "wire time + gap: {t}");
    let recs = read_records(board.pcap().unwrap().bytes()).unwrap();
    assert_eq!(recs.len(), 2);
    assert_eq!(recs[0].1, frame);
    assert_eq!(recs[1].1, reply);
    assert!(recs[1].0 > recs[0].0);
    assert_eq!(recs[1].1[6], 0x12);
}

/// Never clears the IRQ: the board gives up after `max_irq_calls`.
struct DeafCpu;
impl PdiCpu for DeafCpu {}

#[test]
fn a_stuck_irq_is_bounded() {
    let mut cfg = BoardConfig::new(minimal_io_device());
    cfg.max_irq_calls = 5;
    cfg.capture = false;
    let mut board = VirtualBoard::new(cfg);
    board.set_cpu(Box::new(DeafCpu));
    board.exchange(
        &FrameBuilder::new()
            .datagram(cmd::BWR, 0, regs::AL_CONTROL, &[2, 0])
            .build(),
    );
    assert_eq!(board.stats.irq_calls, 5);
    assert_eq!(board.stats.irq_stuck, 1);
    assert!(board.pcap().is_none());
}
