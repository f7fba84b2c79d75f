//! The ET1100 SPI PDI, byte-exact (hardware-facts 1.2; ESC datasheet Section III SPI
//! chapter as summarised there).
//!
//! One `SpiDevice::transaction` is one SPI_SEL-low period. The byte stream is processed
//! byte by byte across all `Operation`s of the transaction:
//!
//! | byte | MOSI                              | MISO        |
//! |------|-----------------------------------|-------------|
//! | 0    | A\[12:5\]                         | 0x0220      |
//! | 1    | A\[4:0\]<<3 \| CMD                | 0x0221      |
//! | (2)  | A\[15:13\]<<5 \| CMD<<2 (CMD 110) | 0x0222      |
//! | wait | 0xFF (CMD 3 only)                 | 0xFF        |
//! | data | 0x00 ... last byte 0xFF (reads)   | data        |
//!
//! CMD: 0 NOP, 2 read, 3 read with wait state, 4 write, 6 address extension.
//! A read whose last data byte is not 0xFF on MOSI counts as a PDI error (0x030D,
//! 0x030E b4); data bytes clocked after the termination byte set 0x030E b5.
//! Writes are committed as one access when SPI_SEL goes high.

use crate::models::esc::{regs, Esc};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use std::cell::RefCell;
use std::convert::Infallible;
use std::rc::Rc;

/// SPI command codes (CMD field).
pub mod spi_cmd {
    /// No operation (address phase only; events are still shifted out).
    pub const NOP: u8 = 0b000;
    /// Read without wait state.
    pub const READ: u8 = 0b010;
    /// Read with one wait-state byte.
    pub const READ_WAIT: u8 = 0b011;
    /// Write.
    pub const WRITE: u8 = 0b100;
    /// Address extension (3-byte addressing).
    pub const ADDR_EXT: u8 = 0b110;
}

/// Counters of the SPI front end (for the process-data benchmark).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SpiStats {
    /// Number of transactions (SPI_SEL low periods).
    pub transactions: u64,
    /// Total bytes clocked.
    pub bytes: u64,
    /// Address-phase bytes (2 or 3 per transaction).
    pub address_bytes: u64,
    /// Wait-state bytes.
    pub wait_bytes: u64,
    /// Data bytes read from the ESC.
    pub read_bytes: u64,
    /// Data bytes written to the ESC.
    pub write_bytes: u64,
    /// Transactions that ended with a PDI error.
    pub errors: u64,
    /// Sum of `Operation::DelayNs` requested inside transactions.
    pub delay_ns: u64,
}

/// One recorded transaction (when recording is on).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SpiRecord {
    /// Bytes on MOSI.
    pub mosi: Vec<u8>,
    /// Bytes on MISO.
    pub miso: Vec<u8>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Addr0,
    Addr1,
    Addr2,
    Wait,
    ReadData,
    WriteData,
    Idle,
}

/// State of one SPI_SEL-low period.
#[derive(Debug)]
pub struct SpiSession {
    phase: Phase,
    addr: u32,
    cmd: u8,
    events: [u8; 4],
    index: usize,
    read_count: u32,
    terminated: bool,
    after_termination: bool,
    write_buf: Vec<u8>,
    record: SpiRecord,
    active: bool,
}

impl Esc {
    /// SPI_SEL goes low: the AL event request is sampled for the address phase.
    pub fn spi_begin(&mut self) -> SpiSession {
        SpiSession {
            phase: Phase::Addr0,
            addr: 0,
            cmd: 0,
            events: self.al_event_request().to_le_bytes(),
            index: 0,
            read_count: 0,
            terminated: false,
            after_termination: false,
            write_buf: Vec::new(),
            record: SpiRecord::default(),
            // SPI works only with the PDI configured as SPI (0x0140 = 0x05) from a good SII.
            active: self.pdi_operational() && self.peek_u8(regs::PDI_CONTROL) == 0x05,
        }
    }

    /// One byte exchanged: returns the MISO byte for the MOSI byte.
    pub fn spi_byte(&mut self, s: &mut SpiSession, mosi: u8) -> u8 {
        let miso = if !s.active {
            0xFF
        } else {
            self.spi_byte_active(s, mosi)
        };
        s.index += 1;
        self.spi_stats.bytes += 1;
        s.record.mosi.push(mosi);
        s.record.miso.push(miso);
        miso
    }

    fn spi_byte_active(&mut self, s: &mut SpiSession, mosi: u8) -> u8 {
        match s.phase {
            Phase::Addr0 => {
                s.addr = (mosi as u32) << 5;
                s.phase = Phase::Addr1;
                self.spi_stats.address_bytes += 1;
                s.events[0]
            }
            Phase::Addr1 => {
                s.addr |= (mosi >> 3) as u32;
                s.cmd = mosi & 0x07;
                self.spi_stats.address_bytes += 1;
                if s.cmd == spi_cmd::ADDR_EXT {
                    s.phase = Phase::Addr2;
                } else {
                    Self::spi_start(s);
                }
                s.events[1]
            }
            Phase::Addr2 => {
                s.addr |= ((mosi >> 5) as u32) << 13;
                s.cmd = (mosi >> 2) & 0x07;
                self.spi_stats.address_bytes += 1;
                Self::spi_start(s);
                s.events[2]
            }
            Phase::Wait => {
                self.spi_stats.wait_bytes += 1;
                s.phase = Phase::ReadData;
                0xFF
            }
            Phase::ReadData => {
                if s.terminated {
                    s.after_termination = true;
                    return 0x00;
                }
                let mut b = [0u8];
                self.pdi_read((s.addr + s.read_count) as u16, &mut b);
                s.read_count += 1;
                self.spi_stats.read_bytes += 1;
                if mosi == 0xFF {
                    s.terminated = true;
                }
                b[0]
            }
            Phase::WriteData => {
                s.write_buf.push(mosi);
                self.spi_stats.write_bytes += 1;
                0x00
            }
            Phase::Idle => 0x00,
        }
    }

    fn spi_start(s: &mut SpiSession) {
        s.phase = match s.cmd {
            spi_cmd::READ => Phase::ReadData,
            spi_cmd::READ_WAIT => Phase::Wait,
            spi_cmd::WRITE => Phase::WriteData,
            _ => Phase::Idle,
        };
    }

    /// SPI_SEL goes high: writes are committed, protocol errors counted.
    pub fn spi_end(&mut self, s: SpiSession) -> SpiRecord {
        self.spi_stats.transactions += 1;
        if s.active {
            let mut code = 0u8;
            if s.phase == Phase::ReadData && s.read_count > 0 && !s.terminated {
                code |= 0x10;
            }
            if s.after_termination {
                code |= 0x20;
            }
            if matches!(s.phase, Phase::Addr0 | Phase::Addr1 | Phase::Addr2) && s.index > 0 {
                // SPI_SEL released inside the address phase.
                code |= 0x01;
            }
            if code != 0 {
                self.spi_stats.errors += 1;
                let a = regs::PDI_ERROR_COUNTER;
                let c = self.peek_u8(a).saturating_add(1);
                self.poke(a, &[c]);
                let e = self.peek_u8(regs::PDI_ERROR_CODE) | code;
                self.poke(regs::PDI_ERROR_CODE, &[e]);
            }
            if s.phase == Phase::WriteData && !s.write_buf.is_empty() {
                self.pdi_write(s.addr as u16, &s.write_buf);
            }
        }
        if self.spi_record {
            self.spi_log.push(s.record.clone());
        }
        s.record
    }

    /// Runs one whole transaction given as a MOSI byte string; returns MISO.
    pub fn spi_transfer(&mut self, mosi: &[u8]) -> Vec<u8> {
        let mut s = self.spi_begin();
        let out = mosi.iter().map(|m| self.spi_byte(&mut s, *m)).collect();
        self.spi_end(s);
        out
    }
}

/// A shared handle on the ESC model.
pub type SharedEsc = Rc<RefCell<Esc>>;

/// The ESC's SPI slave port as an `embedded_hal::spi::SpiDevice<u8>`.
///
/// Cloning gives another handle on the same ESC (as the board's single SPI bus).
/// `Operation::Read` clocks 0x00 on MOSI; `Transfer` pads a shorter write with 0x00.
#[derive(Clone)]
pub struct EscSpi {
    esc: SharedEsc,
}

impl EscSpi {
    /// A front end on `esc`.
    pub fn new(esc: SharedEsc) -> Self {
        Self { esc }
    }

    /// The ESC behind this port.
    pub fn esc(&self) -> &SharedEsc {
        &self.esc
    }

    /// The IRQ line (level, true = asserted).
    pub fn irq(&self) -> bool {
        self.esc.borrow().irq()
    }
}

impl ErrorType for EscSpi {
    type Error = Infallible;
}

impl SpiDevice<u8> for EscSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        let mut esc = self.esc.borrow_mut();
        let mut s = esc.spi_begin();
        for op in operations.iter_mut() {
            match op {
                Operation::Read(buf) => {
                    for b in buf.iter_mut() {
                        *b = esc.spi_byte(&mut s, 0x00);
                    }
                }
                Operation::Write(buf) => {
                    for b in buf.iter() {
                        esc.spi_byte(&mut s, *b);
                    }
                }
                Operation::Transfer(read, write) => {
                    for i in 0..read.len().max(write.len()) {
                        let m = write.get(i).copied().unwrap_or(0x00);
                        let o = esc.spi_byte(&mut s, m);
                        if let Some(r) = read.get_mut(i) {
                            *r = o;
                        }
                    }
                }
                Operation::TransferInPlace(buf) => {
                    for b in buf.iter_mut() {
                        *b = esc.spi_byte(&mut s, *b);
                    }
                }
                Operation::DelayNs(ns) => esc.spi_stats.delay_ns += *ns as u64,
            }
        }
        esc.spi_end(s);
        Ok(())
    }
}
