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
//!
//! Fault switches ([`SpiFaults`], off unless a test injects one): a bit of one byte flipped
//! on MISO (the MCU reads it wrong, the ESC cannot know) or on MOSI (the ESC takes a wrong
//! address, command or data bit), or SPI_SEL released in the middle of a transaction (the
//! ESC ends the access there with the errors the protocol gives; the MCU clocks on and
//! reads the idle bus, [`SEL_HIGH_MISO`]). Without an injected fault the front end is the
//! datasheet's.

use crate::models::esc::{regs, Esc};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use std::convert::Infallible;

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

/// What the MCU reads on MISO while SPI_SEL is high: the ESC releases MISO (high
/// impedance); the model reads the line as pulled up. The board's pull resistor is not
/// confirmed (no schematic): only the fault tests see this value.
pub const SEL_HIGH_MISO: u8 = 0xFF;

/// A fault on the SPI PDI wires during one transaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpiFault {
    /// Bit `bit` of byte `byte` (counted from the first address byte) arrives inverted at
    /// the MCU.
    FlipMiso {
        /// Byte index in the transaction.
        byte: usize,
        /// Bit 0..=7.
        bit: u8,
    },
    /// Bit `bit` of byte `byte` arrives inverted at the ESC.
    FlipMosi {
        /// Byte index in the transaction.
        byte: usize,
        /// Bit 0..=7.
        bit: u8,
    },
    /// SPI_SEL goes high before byte `byte` and stays high for the rest of the transaction.
    DropSel {
        /// Bytes the ESC sees.
        byte: usize,
    },
}

/// Which transaction a fault hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpiTarget {
    /// The next transaction.
    Next,
    /// The next read access starting at this address (chosen once the address phase is
    /// through, so only later bytes can be hit).
    Read(u16),
    /// The next write access starting at this address.
    Write(u16),
}

/// The faults waiting for their transaction, and those injected.
#[derive(Clone, Debug, Default)]
pub struct SpiFaults {
    pending: Vec<(SpiTarget, SpiFault)>,
    /// Faults that hit a transaction, in order: (transaction number, target, fault).
    pub injected: Vec<(u64, SpiTarget, SpiFault)>,
}

impl SpiFaults {
    /// Arms `fault` for the transaction `target` names.
    pub fn inject(&mut self, target: SpiTarget, fault: SpiFault) {
        self.pending.push((target, fault));
    }

    /// Faults armed and not yet injected.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Forgets the armed faults.
    pub fn clear(&mut self) {
        self.pending.clear();
    }

    fn take(&mut self, pick: impl Fn(&SpiTarget) -> bool) -> Option<(SpiTarget, SpiFault)> {
        let i = self.pending.iter().position(|(t, _)| pick(t))?;
        Some(self.pending.remove(i))
    }
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
    fault: Option<SpiFault>,
    fault_chosen: bool,
    sel_released: bool,
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
            fault: None,
            fault_chosen: false,
            sel_released: false,
        }
    }

    /// One byte exchanged: returns the MISO byte for the MOSI byte.
    pub fn spi_byte(&mut self, s: &mut SpiSession, mosi: u8) -> u8 {
        let i = s.index;
        if i == 0 {
            self.choose_fault(s, |t| *t == SpiTarget::Next);
        }
        if matches!(s.fault, Some(SpiFault::DropSel { byte }) if i >= byte) && !s.sel_released {
            self.spi_finish(s);
            s.sel_released = true;
        }
        let miso = if s.sel_released {
            SEL_HIGH_MISO
        } else {
            let seen = match s.fault {
                Some(SpiFault::FlipMosi { byte, bit }) if byte == i => mosi ^ (1 << (bit & 7)),
                _ => mosi,
            };
            let miso = if !s.active {
                0xFF
            } else {
                self.spi_byte_active(s, seen)
            };
            if !s.fault_chosen && !matches!(s.phase, Phase::Addr0 | Phase::Addr1 | Phase::Addr2) {
                let (addr, write) = (s.addr as u16, s.cmd == spi_cmd::WRITE);
                self.choose_fault(s, |t| match *t {
                    SpiTarget::Read(a) => !write && a == addr,
                    SpiTarget::Write(a) => write && a == addr,
                    SpiTarget::Next => false,
                });
            }
            miso
        };
        let miso = match s.fault {
            Some(SpiFault::FlipMiso { byte, bit }) if byte == i => miso ^ (1 << (bit & 7)),
            _ => miso,
        };
        s.index += 1;
        self.spi_stats.bytes += 1;
        s.record.mosi.push(mosi);
        s.record.miso.push(miso);
        miso
    }

    /// Takes the first armed fault whose target `pick` accepts for this transaction.
    fn choose_fault(&mut self, s: &mut SpiSession, pick: impl Fn(&SpiTarget) -> bool) {
        if s.fault.is_some() {
            return;
        }
        if let Some((target, fault)) = self.spi_faults.take(pick) {
            s.fault = Some(fault);
            s.fault_chosen = true;
            self.spi_faults
                .injected
                .push((self.spi_stats.transactions, target, fault));
        }
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
        if !s.sel_released {
            self.spi_finish(&s);
        }
        if self.spi_record {
            self.spi_log.push(s.record.clone());
        }
        s.record
    }

    /// The ESC's side of SPI_SEL going high: protocol errors counted, a write committed.
    fn spi_finish(&mut self, s: &SpiSession) {
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
    }

    /// Runs one whole transaction given as a MOSI byte string; returns MISO.
    pub fn spi_transfer(&mut self, mosi: &[u8]) -> Vec<u8> {
        let mut s = self.spi_begin();
        let out = mosi.iter().map(|m| self.spi_byte(&mut s, *m)).collect();
        self.spi_end(s);
        out
    }
}

pub use crate::models::shared_esc::SharedEsc;

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
