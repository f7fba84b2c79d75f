//! A minimal PDI-side responder for the test SII ([`crate::rig::sii_builder::minimal_io_device`]):
//! it acknowledges every AL control request, copies the SM2 output word to the SM3 input
//! word (an echo), and has no mailbox.
//!
//! It is **not** the firmware: it exists to test the transports (in-process, raw socket)
//! without depending on the slave application. It talks to the ESC model through the
//! byte-exact SPI front end, like a real PDI CPU would.

use crate::models::esc::regs;
use crate::models::spi::EscSpi;
use crate::rig::board::{BoardIo, PdiCpu};
use embedded_hal::spi::{Operation, SpiDevice};

/// Reads `n` bytes with command 3 (wait byte, 0xFF termination), 2-byte addressing;
/// returns the AL event bits of the address phase and the data.
pub fn spi_read(spi: &mut EscSpi, addr: u16, n: usize) -> (u16, Vec<u8>) {
    let hdr = [(addr >> 5) as u8, ((addr & 0x1F) << 3) as u8 | 0x03, 0xFF];
    let mut ev = [0u8; 3];
    let mut mosi = vec![0u8; n];
    mosi[n - 1] = 0xFF;
    let mut data = vec![0u8; n];
    let _ = spi.transaction(&mut [
        Operation::Transfer(&mut ev, &hdr),
        Operation::Transfer(&mut data, &mosi),
    ]);
    (u16::from_le_bytes([ev[0], ev[1]]), data)
}

/// Writes `data` with command 4, 2-byte addressing.
pub fn spi_write(spi: &mut EscSpi, addr: u16, data: &[u8]) {
    let hdr = [(addr >> 5) as u8, ((addr & 0x1F) << 3) as u8 | 0x04];
    let _ = spi.transaction(&mut [Operation::Write(&hdr), Operation::Write(data)]);
}

/// The echo responder (see the module docs).
#[derive(Debug, Default)]
pub struct EchoResponder {
    /// AL states acknowledged, in order.
    pub states: Vec<u8>,
    echo: [u8; 2],
}

impl EchoResponder {
    /// A responder in INIT.
    pub fn new() -> Self {
        Self::default()
    }
}

impl PdiCpu for EchoResponder {
    fn on_irq(&mut self, io: &mut BoardIo) {
        let spi = &mut io.esc;
        let (events, _) = spi_read(spi, regs::AL_EVENT_REQUEST, 4);
        if events & 0x0001 != 0 {
            let (_, ctl) = spi_read(spi, regs::AL_CONTROL, 2);
            let state = ctl[0] & 0x0F;
            spi_write(spi, regs::AL_STATUS_CODE, &[0, 0]);
            spi_write(spi, regs::AL_STATUS, &[state, 0]);
            self.states.push(state);
        }
        if events & (1 << (8 + 2)) != 0 {
            let (_, out) = spi_read(spi, 0x1100, 2);
            self.echo = [out[0], out[1]];
            spi_write(spi, 0x1180, &self.echo);
        }
        if events & (1 << (8 + 3)) != 0 {
            spi_write(spi, 0x1180, &self.echo);
        }
        if events & !0x0D01 != 0 {
            // Other events (SM activation changes ...): masked so the level IRQ drops.
            let (_, mask) = spi_read(spi, regs::AL_EVENT_MASK, 4);
            let m = u32::from_le_bytes([mask[0], mask[1], mask[2], mask[3]])
                & !(events as u32 & !0x0D01);
            spi_write(spi, regs::AL_EVENT_MASK, &m.to_le_bytes());
        }
    }

    fn poll(&mut self, io: &mut BoardIo) {
        // Keep SM3 filled once in SAFEOP/OP, before the master's first read.
        let sm3_enabled = io.esc.esc().borrow().peek_u8(regs::sm(3) + 6) & 1 != 0;
        if sm3_enabled && matches!(self.states.last(), Some(4) | Some(8)) {
            spi_write(&mut io.esc, 0x1180, &self.echo);
        }
    }
}
