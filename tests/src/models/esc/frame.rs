//! EtherCAT frame processing (ETG.1000.4: Ethernet frame, EtherCAT header, datagrams)
//! and small frame builder/parser helpers for tests.

use super::{regs, AccessResult, Esc, Op, Side};

/// EtherType of EtherCAT frames.
pub const ETHERTYPE_ECAT: u16 = 0x88A4;

/// Datagram command codes (ETG.1000.4 Table 11).
pub mod cmd {
    pub const NOP: u8 = 0;
    pub const APRD: u8 = 1;
    pub const APWR: u8 = 2;
    pub const APRW: u8 = 3;
    pub const FPRD: u8 = 4;
    pub const FPWR: u8 = 5;
    pub const FPRW: u8 = 6;
    pub const BRD: u8 = 7;
    pub const BWR: u8 = 8;
    pub const BRW: u8 = 9;
    pub const LRD: u8 = 10;
    pub const LWR: u8 = 11;
    pub const LRW: u8 = 12;
    pub const ARMW: u8 = 13;
    pub const FRMW: u8 = 14;
}

impl Esc {
    /// Processes one Ethernet frame in place as the frame passes this ESC.
    ///
    /// Returns `false` (frame untouched) when it is not an EtherCAT frame with a type-1
    /// header. Otherwise every datagram is executed in order (following the "more" bit),
    /// the working counters and IRQ fields are updated, position addresses are
    /// incremented and bit 1 of the first source-MAC byte is set (as a real ESC does on
    /// the way back through port 0).
    pub fn process_frame(&mut self, frame: &mut [u8]) -> bool {
        if frame.len() < 14 + 2 || u16::from_be_bytes([frame[12], frame[13]]) != ETHERTYPE_ECAT {
            return false;
        }
        let hdr = u16::from_le_bytes([frame[14], frame[15]]);
        if hdr >> 12 != 1 {
            return false;
        }
        self.frames += 1;
        let ecat_len = (hdr & 0x07FF) as usize;
        let end = (16 + ecat_len).min(frame.len());
        let mut pos = 16;
        loop {
            if pos + 10 > end {
                break;
            }
            let len_field = u16::from_le_bytes([frame[pos + 6], frame[pos + 7]]);
            let dlen = (len_field & 0x07FF) as usize;
            let more = len_field & 0x8000 != 0;
            if pos + 10 + dlen + 2 > end {
                break;
            }
            let (head, rest) = frame[pos..].split_at_mut(10);
            let (data, tail) = rest.split_at_mut(dlen);
            self.process_datagram(head, data, &mut tail[..2]);
            pos += 10 + dlen + 2;
            if !more {
                break;
            }
        }
        frame[6] |= 0x02;
        true
    }

    fn process_datagram(&mut self, head: &mut [u8], data: &mut [u8], wkc: &mut [u8]) {
        let command = head[0];
        let adp = u16::from_le_bytes([head[2], head[3]]);
        let ado = u16::from_le_bytes([head[4], head[5]]);
        let logical = u32::from_le_bytes([head[2], head[3], head[4], head[5]]);
        let station = self.peek_u16(regs::STATION_ADDRESS);
        // DL control b24 (0x0103 b0) enables the station alias.
        let alias_enabled = self.peek_u8(0x0103) & 0x01 != 0;
        let alias = self.peek_u16(regs::STATION_ALIAS);
        let fp_match = adp == station || (alias_enabled && adp == alias);
        let ap_match = adp == 0;
        let mut inc = 0u16;
        let mut count = |r: AccessResult, read_w: u16, write_w: u16| {
            if r.read {
                inc += read_w;
            }
            if r.written {
                inc += write_w;
            }
        };
        use cmd::*;
        match command {
            APRD | FPRD if (command == APRD && ap_match) || (command == FPRD && fp_match) => {
                count(self.access(Side::Ecat, ado as u32, data, Op::Read), 1, 0)
            }
            APWR | FPWR if (command == APWR && ap_match) || (command == FPWR && fp_match) => {
                count(self.access(Side::Ecat, ado as u32, data, Op::Write), 0, 1)
            }
            APRW | FPRW if (command == APRW && ap_match) || (command == FPRW && fp_match) => count(
                self.access(Side::Ecat, ado as u32, data, Op::ReadWrite),
                1,
                2,
            ),
            BRD => count(self.access(Side::Ecat, ado as u32, data, Op::ReadOr), 1, 0),
            BWR => count(self.access(Side::Ecat, ado as u32, data, Op::Write), 0, 1),
            BRW => count(
                self.access(Side::Ecat, ado as u32, data, Op::ReadOrWrite),
                1,
                2,
            ),
            LRD => count(self.logical_access(logical, data, Op::Read), 1, 0),
            LWR => count(self.logical_access(logical, data, Op::Write), 0, 1),
            LRW => count(self.logical_access(logical, data, Op::ReadWrite), 1, 2),
            ARMW | FRMW => {
                let reads = if command == ARMW { ap_match } else { fp_match };
                let op = if reads { Op::Read } else { Op::Write };
                count(self.access(Side::Ecat, ado as u32, data, op), 1, 1)
            }
            _ => {}
        }
        // Position addressing: every ESC increments ADP (auto-increment and broadcast).
        if matches!(command, APRD | APWR | APRW | ARMW | BRD | BWR | BRW) {
            head[2..4].copy_from_slice(&adp.wrapping_add(1).to_le_bytes());
        }
        let irq = u16::from_le_bytes([head[8], head[9]]) | self.ecat_irq_field();
        head[8..10].copy_from_slice(&irq.to_le_bytes());
        let w = u16::from_le_bytes([wkc[0], wkc[1]]).wrapping_add(inc);
        wkc.copy_from_slice(&w.to_le_bytes());
    }
}

/// Builds EtherCAT frames (for tests and tools).
#[derive(Clone, Debug)]
pub struct FrameBuilder {
    src: [u8; 6],
    datagrams: Vec<(u8, u8, u32, Vec<u8>, u16)>,
}

impl Default for FrameBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameBuilder {
    /// A frame from the ethercrab default MAC 10:10:10:10:10:10.
    pub fn new() -> Self {
        Self {
            src: [0x10; 6],
            datagrams: Vec::new(),
        }
    }

    /// Adds a datagram with an address as ADP/ADO.
    pub fn datagram(self, command: u8, adp: u16, ado: u16, data: &[u8]) -> Self {
        let addr = adp as u32 | (ado as u32) << 16;
        self.datagram_raw(command, addr, data, 0)
    }

    /// Adds a datagram with a 32-bit (logical) address.
    pub fn logical(self, command: u8, address: u32, data: &[u8]) -> Self {
        self.datagram_raw(command, address, data, 0)
    }

    /// Adds a datagram with every field given (index = position in the frame).
    pub fn datagram_raw(mut self, command: u8, addr: u32, data: &[u8], wkc: u16) -> Self {
        let idx = self.datagrams.len() as u8;
        self.datagrams
            .push((command, idx, addr, data.to_vec(), wkc));
        self
    }

    /// The frame bytes.
    pub fn build(&self) -> Vec<u8> {
        let mut f = Vec::new();
        f.extend_from_slice(&[0xFF; 6]);
        f.extend_from_slice(&self.src);
        f.extend_from_slice(&ETHERTYPE_ECAT.to_be_bytes());
        let len: usize = self.datagrams.iter().map(|d| 12 + d.3.len()).sum();
        f.extend_from_slice(&((len as u16 & 0x07FF) | 0x1000).to_le_bytes());
        let n = self.datagrams.len();
        for (i, (c, idx, addr, data, wkc)) in self.datagrams.iter().enumerate() {
            f.push(*c);
            f.push(*idx);
            f.extend_from_slice(&addr.to_le_bytes());
            let more = if i + 1 < n { 0x8000 } else { 0 };
            f.extend_from_slice(&((data.len() as u16 & 0x07FF) | more).to_le_bytes());
            f.extend_from_slice(&[0, 0]);
            f.extend_from_slice(data);
            f.extend_from_slice(&wkc.to_le_bytes());
        }
        f
    }
}

/// One datagram of a parsed frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParsedDatagram {
    /// Command code.
    pub command: u8,
    /// Index.
    pub index: u8,
    /// ADP (low half of the address).
    pub adp: u16,
    /// ADO (high half of the address).
    pub ado: u16,
    /// Whole 32-bit address (logical commands).
    pub address: u32,
    /// IRQ field.
    pub irq: u16,
    /// Data.
    pub data: Vec<u8>,
    /// Working counter.
    pub wkc: u16,
}

/// Parses the datagrams of an EtherCAT frame (None when it is not one).
pub fn parse_frame(frame: &[u8]) -> Option<Vec<ParsedDatagram>> {
    if frame.len() < 16 || u16::from_be_bytes([frame[12], frame[13]]) != ETHERTYPE_ECAT {
        return None;
    }
    let hdr = u16::from_le_bytes([frame[14], frame[15]]);
    let end = (16 + (hdr & 0x07FF) as usize).min(frame.len());
    let mut pos = 16;
    let mut out = Vec::new();
    while pos + 12 <= end {
        let lf = u16::from_le_bytes([frame[pos + 6], frame[pos + 7]]);
        let dlen = (lf & 0x07FF) as usize;
        if pos + 12 + dlen > end {
            return None;
        }
        let address = u32::from_le_bytes(frame[pos + 2..pos + 6].try_into().ok()?);
        out.push(ParsedDatagram {
            command: frame[pos],
            index: frame[pos + 1],
            adp: address as u16,
            ado: (address >> 16) as u16,
            address,
            irq: u16::from_le_bytes([frame[pos + 8], frame[pos + 9]]),
            data: frame[pos + 10..pos + 10 + dlen].to_vec(),
            wkc: u16::from_le_bytes([frame[pos + 10 + dlen], frame[pos + 11 + dlen]]),
        });
        pos += 12 + dlen;
        if lf & 0x8000 == 0 {
            break;
        }
    }
    Some(out)
}
