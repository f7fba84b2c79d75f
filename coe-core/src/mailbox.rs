//! The mailbox service of the slave (ETG.1000.4 5.6 / ETG.1000.6 5.3): what happens to a
//! mailbox frame before and after the protocol handler sees it.
//!
//! - received header checks, answered with mailbox error replies (type 0, ETG.1000.4
//!   table 29): a length beyond the buffer (InvalidSize), data too short for the protocol
//!   header (SizeTooShort), an unsupported protocol type (UnsupportedProtocol), a CoE service
//!   the slave does not offer (ServiceNotSupported), an invalid CoE service number
//!   (InvalidHeader);
//! - the counter (header byte 5 bits 4..6): a received frame whose non-zero counter equals
//!   the previous one is a retry of a frame already served and is dropped without a reply;
//!   the slave numbers its own frames 1..7, 7 wrapping to 1;
//! - a backup of the last frame written to the read mailbox for the repeat request (SM1
//!   repeat, ESC datasheet section I 8.6): the same bytes, same counter;
//! - counters reset when the ESM goes INIT -> PREOP;
//! - a fixed-capacity queue of Emergencies (CoE service 1), sent when the read mailbox is free.
//!
//! [`crate::sdo_server::SdoServer`] owns one [`MailboxService`] and is the entry point the
//! firmware calls.

use crate::esm::AlState;
use crate::sdo_server::frame::{
    coe_service, emit_coe, MbxHeader, COE_HDR, MBX_HDR, SVC_EMERGENCY, SVC_SDO_INFO,
    SVC_SDO_REQUEST, TYPE_COE, TYPE_ERROR,
};

/// Length of the mailbox header.
pub const MAILBOX_HEADER_LEN: usize = MBX_HDR;

/// Mailbox error detail codes (ETG.1000.4 table 30; the u16 after the 0x0001 service word of
/// a mailbox error reply).
pub mod error_code {
    /// Syntax of the 6-byte header wrong.
    pub const SYNTAX: u16 = 0x0001;
    /// Mailbox protocol not supported.
    pub const UNSUPPORTED_PROTOCOL: u16 = 0x0002;
    /// Channel field invalid.
    pub const INVALID_CHANNEL: u16 = 0x0003;
    /// Service in the mailbox protocol not supported.
    pub const SERVICE_NOT_SUPPORTED: u16 = 0x0004;
    /// Mailbox protocol header invalid.
    pub const INVALID_HEADER: u16 = 0x0005;
    /// Length of received mailbox data too short.
    pub const SIZE_TOO_SHORT: u16 = 0x0006;
    /// Mailbox protocol cannot be processed: no memory.
    pub const NO_MORE_MEMORY: u16 = 0x0007;
    /// Length of data inconsistent.
    pub const INVALID_SIZE: u16 = 0x0008;
}

/// The outcome of a call into the server: nothing to send, or a frame of `n` bytes at the
/// start of the caller's reply buffer (to be written to the read mailbox, SM1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reply {
    /// No frame to send.
    None,
    /// A whole mailbox frame (header included) of this many bytes.
    Frame(usize),
}

impl Reply {
    /// The frame length, if any.
    pub const fn frame_len(self) -> Option<usize> {
        match self {
            Self::None => None,
            Self::Frame(n) => Some(n),
        }
    }
}

/// An Emergency message (CoE service 1; ETG.1000.6 5.6.4, CiA 301 7.2.7): error code
/// (CiA 301 table 21), error register (object 0x1001) and 5 manufacturer-specific bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Emergency {
    /// Error code (e.g. 0x8700 sync controller, 0x8211 PDO length, 0xFF00.. manufacturer).
    pub error_code: u16,
    /// Error register (the value of 0x1001).
    pub error_register: u8,
    /// Manufacturer-specific data.
    pub data: [u8; 5],
}

impl Emergency {
    /// Bytes after the CoE header.
    pub const LEN: usize = 8;

    fn emit(&self, out: &mut [u8]) -> Option<usize> {
        let out = out.get_mut(..Self::LEN)?;
        let (code, rest) = out.split_at_mut(2);
        code.copy_from_slice(&self.error_code.to_le_bytes());
        let (reg, data) = rest.split_at_mut(1);
        reg.copy_from_slice(&[self.error_register]);
        data.copy_from_slice(&self.data);
        Some(Self::LEN)
    }
}

/// Counter, backup and emergency queue of one mailbox; `MBX` is the largest frame kept for
/// the repeat request, `EMCY` the number of Emergencies that can wait.
#[derive(Debug, Clone)]
pub struct MailboxService<const MBX: usize, const EMCY: usize> {
    last_rx_counter: u8,
    tx_counter: u8,
    backup: [u8; MBX],
    backup_len: usize,
    emcy: [Option<Emergency>; EMCY],
    emcy_head: usize,
    emcy_len: usize,
    emcy_dropped: u32,
}

impl<const MBX: usize, const EMCY: usize> Default for MailboxService<MBX, EMCY> {
    fn default() -> Self {
        Self::new()
    }
}

/// What the header check found.
pub(crate) enum Incoming<'a> {
    /// A retry of the frame served last: no reply.
    Duplicate,
    /// Answer with this mailbox error (an [`error_code`]).
    Error(u16),
    /// A CoE frame for this service: the data after the CoE header.
    Coe(u8, &'a [u8]),
}

impl<const MBX: usize, const EMCY: usize> MailboxService<MBX, EMCY> {
    /// A fresh service: no counter seen, next own counter 1, nothing queued.
    pub const fn new() -> Self {
        Self {
            last_rx_counter: 0,
            tx_counter: 0,
            backup: [0; MBX],
            backup_len: 0,
            emcy: [None; EMCY],
            emcy_head: 0,
            emcy_len: 0,
            emcy_dropped: 0,
        }
    }

    /// Resets the counters and the backup (ESM INIT -> PREOP). Queued Emergencies stay.
    pub fn reset(&mut self) {
        self.last_rx_counter = 0;
        self.tx_counter = 0;
        self.backup_len = 0;
    }

    /// Applies an ESM transition: INIT -> PREOP resets the counters.
    pub fn on_state_change(&mut self, from: AlState, to: AlState) {
        if from == AlState::Init && to == AlState::PreOp {
            self.reset();
        }
    }

    /// The last frame written to the read mailbox (empty before the first one).
    pub fn last_frame(&self) -> &[u8] {
        self.backup.get(..self.backup_len).unwrap_or(&[])
    }

    /// Copies the last frame into `reply` for the repeat request. `Reply::None` if there is
    /// none or it does not fit.
    pub fn repeat(&self, reply: &mut [u8]) -> Reply {
        let last = self.last_frame();
        if last.is_empty() {
            return Reply::None;
        }
        match reply.get_mut(..last.len()) {
            Some(dst) => {
                dst.copy_from_slice(last);
                Reply::Frame(last.len())
            }
            None => Reply::None,
        }
    }

    /// Queues an Emergency; when the queue is full the oldest one is dropped (and counted).
    pub fn push_emergency(&mut self, emergency: Emergency) {
        if EMCY == 0 {
            self.emcy_dropped = self.emcy_dropped.saturating_add(1);
            return;
        }
        if self.emcy_len == EMCY {
            self.emcy_head = (self.emcy_head + 1) % EMCY;
            self.emcy_len -= 1;
            self.emcy_dropped = self.emcy_dropped.saturating_add(1);
        }
        let tail = (self.emcy_head + self.emcy_len) % EMCY;
        if let Some(slot) = self.emcy.get_mut(tail) {
            *slot = Some(emergency);
            self.emcy_len += 1;
        }
    }

    /// Number of queued Emergencies.
    pub fn pending_emergencies(&self) -> usize {
        self.emcy_len
    }

    /// Number of Emergencies dropped because the queue was full.
    pub fn dropped_emergencies(&self) -> u32 {
        self.emcy_dropped
    }

    fn pop_emergency(&mut self) -> Option<Emergency> {
        if self.emcy_len == 0 || EMCY == 0 {
            return None;
        }
        let item = self.emcy.get_mut(self.emcy_head).and_then(Option::take);
        self.emcy_head = (self.emcy_head + 1) % EMCY;
        self.emcy_len -= 1;
        item
    }

    /// Checks a received frame (the whole write-mailbox content).
    pub(crate) fn receive<'a>(&mut self, frame: &'a [u8]) -> Incoming<'a> {
        let Some(header) = MbxHeader::parse(frame) else {
            return Incoming::Error(error_code::SIZE_TOO_SHORT);
        };
        if header.counter != 0 && header.counter == self.last_rx_counter {
            return Incoming::Duplicate;
        }
        self.last_rx_counter = header.counter;
        let end = MBX_HDR + usize::from(header.length);
        let Some(data) = frame.get(MBX_HDR..end) else {
            return Incoming::Error(error_code::INVALID_SIZE);
        };
        if header.mailbox_type != TYPE_COE {
            return Incoming::Error(error_code::UNSUPPORTED_PROTOCOL);
        }
        let Some(service) = coe_service(data) else {
            return Incoming::Error(error_code::SIZE_TOO_SHORT);
        };
        let rest = data.get(COE_HDR..).unwrap_or(&[]);
        match service {
            SVC_SDO_REQUEST | SVC_SDO_INFO => Incoming::Coe(service, rest),
            1..=7 => Incoming::Error(error_code::SERVICE_NOT_SUPPORTED),
            _ => Incoming::Error(error_code::INVALID_HEADER),
        }
    }

    fn next_counter(&mut self) -> u8 {
        self.tx_counter = if self.tx_counter >= 7 {
            1
        } else {
            self.tx_counter + 1
        };
        self.tx_counter
    }

    /// Writes the mailbox header in front of `data_len` bytes already in
    /// `reply[6..]`, numbers the frame and keeps a copy for the repeat request.
    pub(crate) fn send(&mut self, reply: &mut [u8], mailbox_type: u8, data_len: usize) -> Reply {
        let total = MAILBOX_HEADER_LEN + data_len;
        let Ok(length) = u16::try_from(data_len) else {
            return Reply::None;
        };
        if total > reply.len() {
            return Reply::None;
        }
        let counter = self.next_counter();
        let header = MbxHeader {
            length,
            address: 0,
            channel: 0,
            priority: 0,
            mailbox_type,
            counter,
        };
        if header.emit(reply).is_none() {
            return Reply::None;
        }
        if let (Some(src), Some(dst)) = (reply.get(..total), self.backup.get_mut(..total)) {
            dst.copy_from_slice(src);
            self.backup_len = total;
        } else {
            self.backup_len = 0;
        }
        Reply::Frame(total)
    }

    /// Sends a mailbox error reply.
    pub(crate) fn send_error(&mut self, reply: &mut [u8], code: u16) -> Reply {
        let Some(body) = reply.get_mut(MBX_HDR..MBX_HDR + 4) else {
            return Reply::None;
        };
        body[..2].copy_from_slice(&0x0001u16.to_le_bytes());
        body[2..].copy_from_slice(&code.to_le_bytes());
        self.send(reply, TYPE_ERROR, 4)
    }

    /// Sends the oldest queued Emergency, if any.
    pub(crate) fn send_emergency(&mut self, reply: &mut [u8]) -> Reply {
        let needed = MBX_HDR + COE_HDR + Emergency::LEN;
        if reply.len() < needed {
            return Reply::None;
        }
        let Some(emergency) = self.pop_emergency() else {
            return Reply::None;
        };
        let Some(body) = reply.get_mut(MBX_HDR..needed) else {
            return Reply::None;
        };
        let (coe, data) = body.split_at_mut(COE_HDR);
        if emit_coe(coe, SVC_EMERGENCY).is_none() || emergency.emit(data).is_none() {
            return Reply::None;
        }
        self.send(reply, TYPE_COE, COE_HDR + Emergency::LEN)
    }
}
