//! Helpers shared by the integration tests.
#![allow(dead_code)]

use virtual_board::models::esc::{parse_frame, Esc, EscConfig, FrameBuilder, ParsedDatagram};
use virtual_board::rig::sii_builder::minimal_io_device;

/// An ESC loaded with the minimal test device image.
pub fn esc() -> Esc {
    Esc::new(EscConfig::new(minimal_io_device()))
}

/// Sends a frame through the ESC and returns the datagrams as they come back.
pub fn run(esc: &mut Esc, f: FrameBuilder) -> Vec<ParsedDatagram> {
    let mut frame = f.build();
    assert!(esc.process_frame(&mut frame));
    parse_frame(&frame).expect("valid frame")
}

/// One datagram through the ESC.
pub fn one(esc: &mut Esc, command: u8, adp: u16, ado: u16, data: &[u8]) -> ParsedDatagram {
    run(esc, FrameBuilder::new().datagram(command, adp, ado, data)).remove(0)
}

/// Configures SyncManager `n` from the EtherCAT side (as a master does with FPWR).
pub fn config_sm(esc: &mut Esc, n: usize, start: u16, len: u16, control: u8) {
    let mut b = Vec::new();
    b.extend_from_slice(&start.to_le_bytes());
    b.extend_from_slice(&len.to_le_bytes());
    b.extend_from_slice(&[control, 0, 0x01, 0]);
    esc.ecat_write(0x0800 + 8 * n as u16, &b);
}

/// Configures FMMU `n`.
#[allow(clippy::too_many_arguments)]
pub fn config_fmmu(
    esc: &mut Esc,
    n: usize,
    log: u32,
    len: u16,
    start_bit: u8,
    stop_bit: u8,
    phys: u16,
    phys_bit: u8,
    ty: u8,
) {
    let mut b = Vec::new();
    b.extend_from_slice(&log.to_le_bytes());
    b.extend_from_slice(&len.to_le_bytes());
    b.extend_from_slice(&[start_bit, stop_bit]);
    b.extend_from_slice(&phys.to_le_bytes());
    b.extend_from_slice(&[phys_bit, ty, 0x01, 0, 0, 0]);
    esc.ecat_write(0x0600 + 16 * n as u16, &b);
}
