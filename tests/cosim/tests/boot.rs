//! First light: the image boots on the co-simulator and the ESC reaches PREOP.

use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_target, load_image};
use std::cell::RefCell;
use std::rc::Rc;
use virtual_board::rig::board::{BoardConfig, VirtualBoard};

#[test]
fn boots() {
    let image = load_image().unwrap();
    let (target, handle) = image_target(
        image,
        Options {
            echo_log: true,
            ..Default::default()
        },
    )
    .unwrap();
    let board = Rc::new(RefCell::new(VirtualBoard::new(BoardConfig::new(
        target.sii,
    ))));
    let cpu = (target.make_cpu)(board.borrow().io());
    board.borrow_mut().set_cpu(cpu);
    board.borrow_mut().step(20_000_000);
    let facts = handle.with(|c| c.facts()).unwrap();
    eprintln!("{}", facts.summary());
    let b = board.borrow();
    let esc = b.esc().borrow();
    eprintln!(
        "AL status {:#x} code {:#x} spi {:?}",
        esc.peek_u16(0x130),
        esc.peek_u16(0x134),
        esc.spi_stats
    );
    assert!(facts.fault.is_none());
}

#[test]
fn rtt_table() {
    let image = load_image().unwrap();
    eprintln!("rtt at {:x?}", image.rtt);
    let t = defmt_decoder::Table::parse(&image.elf);
    eprintln!("table: {:?}", t.as_ref().map(|t| t.is_some()));
}
