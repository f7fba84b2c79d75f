//! The mailbox service of the slave (ETG.1000.4 5.6 / ETG.1000.6 5.3): what happens to a
//! mailbox frame before and after the protocol handler sees it.
//!
//! - received header checks, answered with mailbox error replies (type 0,
//!   [`crate::wire::mailbox`]): a length beyond the buffer (InvalidSize), data too short for the protocol
//!   header (SizeTooShort), an unsupported protocol type (UnsupportedProtocol), a CoE service
//!   the slave does not offer (ServiceNotSupported), an invalid CoE service number
//!   (InvalidHeader);
//! - the counter (header byte 5 bits 4..6): a received frame whose non-zero counter equals
//!   the previous one is a retry of a frame already served and is dropped without a reply;
//!   the slave numbers its own frames 1..7, 7 wrapping to 1;
//! - a backup of the last frame written to the read mailbox for the repeat request (SM1
//!   repeat, ESC datasheet section I 8.6): the same bytes, same counter;
//! - counters reset when the ESM goes INIT -> PREOP or INIT -> BOOT;
//! - dispatch by mailbox type: CoE to the SDO server, other types (FoE) to a
//!   [`MailboxProtocol`] beside it, on the same counters and backup;
//! - a fixed-capacity queue of Emergencies (CoE service 1), sent when the read mailbox is free.
//!
//! [`crate::sdo_server::SdoServer`] owns one [`MailboxService`] and is the entry point the
//! firmware calls. Every frame is read and written through the [`crate::wire`] layer.

use crate::emergency_queue::EmergencyQueue;
use crate::esm::AlState;
use crate::wire::{
    self, Coe, CoeRepr, CoeService, EmergencyRepr, Mailbox, MailboxErrorReply,
    MailboxErrorReplyRepr, MailboxRepr, MailboxType,
};

pub use crate::wire::MailboxErrorCode;

/// Length of the mailbox header.
pub const MAILBOX_HEADER_LEN: usize = wire::mailbox::HEADER_LEN;

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
/// The wire layer's [`EmergencyRepr`] is what the queue holds and sends.
pub type Emergency = EmergencyRepr;

/// The part of a mailbox frame after the mailbox header, where a reply's payload goes
/// before [`MailboxService::send`] writes the header in front of it.
pub(crate) fn payload_area(reply: &mut [u8]) -> &mut [u8] {
    reply.get_mut(MAILBOX_HEADER_LEN..).unwrap_or_default()
}

/// Writes a CoE header for `service` into `out`, then the service data through `body`
/// (which gets the bytes after the CoE header and returns how many it wrote). Returns
/// the CoE frame length.
pub(crate) fn emit_coe(
    out: &mut [u8],
    service: CoeService,
    body: impl FnOnce(&mut [u8]) -> wire::Result<usize>,
) -> Option<usize> {
    let n = body(coe_header(out, service)?).ok()?;
    Some(wire::coe::HEADER_LEN + n)
}

/// The CoE header part of [`emit_coe`], one copy for all its callers (flash): writes the
/// header and returns the bytes after it.
#[inline(never)]
fn coe_header(out: &mut [u8], service: CoeService) -> Option<&mut [u8]> {
    CoeRepr::new(service)
        .emit(&mut Coe::new_unchecked(&mut *out))
        .ok()?;
    Some(wire::tail_mut(out, wire::coe::HEADER_LEN))
}

/// Counter, backup and emergency queue of one mailbox; `MBX` is the largest frame kept for
/// the repeat request, `EMCY` the number of Emergencies that can wait.
#[derive(Debug, Clone)]
pub struct MailboxService<const MBX: usize, const EMCY: usize> {
    last_rx_counter: u8,
    tx_counter: u8,
    backup: [u8; MBX],
    backup_len: usize,
    emcy: EmergencyQueue<EMCY>,
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
    /// Answer with this mailbox error.
    Error(MailboxErrorCode),
    /// A CoE frame for this service: the data after the CoE header.
    Coe(CoeService, &'a [u8]),
    /// A frame of another protocol: its type and payload.
    Other(MailboxType, &'a [u8]),
}

/// A mailbox protocol served beside CoE on the same mailbox (FoE): the mailbox layer hands
/// it the payload of the frames of its type and sends its answer with the shared counter and
/// repeat backup.
pub trait MailboxProtocol {
    /// True for the mailbox types it serves.
    fn serves(&self, mailbox_type: MailboxType) -> bool;

    /// Serves the payload of one frame that came in a write mailbox of `request_len` bytes
    /// and writes the answer's payload into `out`. `Ok(Some((type, n)))`: send a frame of
    /// that type with `n` payload bytes; `Ok(None)`: no answer; `Err(code)`: answer with
    /// that mailbox error.
    fn serve(
        &mut self,
        payload: &[u8],
        request_len: usize,
        state: AlState,
        now_ms: u32,
        out: &mut [u8],
    ) -> Result<Option<(MailboxType, usize)>, MailboxErrorCode>;
}

/// The protocol of a mailbox that serves CoE only: none.
pub struct NoOtherProtocol;

impl MailboxProtocol for NoOtherProtocol {
    fn serves(&self, _: MailboxType) -> bool {
        false
    }

    fn serve(
        &mut self,
        _: &[u8],
        _: usize,
        _: AlState,
        _: u32,
        _: &mut [u8],
    ) -> Result<Option<(MailboxType, usize)>, MailboxErrorCode> {
        Err(MailboxErrorCode::UnsupportedProtocol)
    }
}

impl<const MBX: usize, const EMCY: usize> MailboxService<MBX, EMCY> {
    /// A fresh service: no counter seen, next own counter 1, nothing queued.
    pub const fn new() -> Self {
        Self {
            last_rx_counter: 0,
            tx_counter: 0,
            backup: [0; MBX],
            backup_len: 0,
            emcy: EmergencyQueue::new(),
        }
    }

    /// Resets the counters and the backup (ESM INIT -> PREOP). Queued Emergencies stay.
    pub fn reset(&mut self) {
        self.last_rx_counter = 0;
        self.tx_counter = 0;
        self.backup_len = 0;
    }

    /// Applies an ESM transition: INIT -> PREOP and INIT -> BOOT (the mailbox starts)
    /// reset the counters.
    pub fn on_state_change(&mut self, from: AlState, to: AlState) {
        if from == AlState::Init && matches!(to, AlState::PreOp | AlState::Bootstrap) {
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
        self.emcy.push(emergency);
    }

    /// Number of queued Emergencies.
    pub fn pending_emergencies(&self) -> usize {
        self.emcy.len()
    }

    /// Number of Emergencies dropped because the queue was full.
    pub fn dropped_emergencies(&self) -> u32 {
        self.emcy.dropped()
    }

    /// Checks a received frame (the whole write-mailbox content).
    pub(crate) fn receive<'a>(&mut self, frame: &'a [u8]) -> Incoming<'a> {
        if frame.len() < MAILBOX_HEADER_LEN {
            return Incoming::Error(MailboxErrorCode::SizeTooShort);
        }
        // Unchecked until the counter is read: a header whose length field overruns the
        // buffer still counts (and is answered with InvalidSize by `parse` below).
        let view = Mailbox::new_unchecked(frame);
        let counter = view.counter();
        if counter != 0 && counter == self.last_rx_counter {
            return Incoming::Duplicate;
        }
        self.last_rx_counter = counter;
        let Ok(header) = MailboxRepr::parse(&view) else {
            return Incoming::Error(MailboxErrorCode::InvalidSize);
        };
        if header.mailbox_type != MailboxType::Coe {
            return Incoming::Other(header.mailbox_type, view.payload());
        }
        let coe = Coe::new_unchecked(view.payload());
        let Ok(coe_header) = CoeRepr::parse(&coe) else {
            return Incoming::Error(MailboxErrorCode::SizeTooShort);
        };
        match coe_header.service {
            CoeService::SdoRequest | CoeService::SdoInformation => {
                Incoming::Coe(coe_header.service, coe.payload())
            }
            CoeService::Unknown(_) => Incoming::Error(MailboxErrorCode::InvalidHeader),
            _ => Incoming::Error(MailboxErrorCode::ServiceNotSupported),
        }
    }

    /// Writes the mailbox header in front of `data_len` bytes already in
    /// [`payload_area`], numbers the frame and keeps a copy for the repeat request.
    pub(crate) fn send(
        &mut self,
        reply: &mut [u8],
        mailbox_type: MailboxType,
        data_len: usize,
    ) -> Reply {
        let counter = wire::next_counter(self.tx_counter);
        let header = MailboxRepr {
            address: 0,
            channel: 0,
            priority: 0,
            mailbox_type,
            counter,
            payload_len: data_len,
        };
        if header
            .emit(&mut Mailbox::new_unchecked(&mut *reply))
            .is_err()
        {
            return Reply::None;
        }
        self.tx_counter = counter;
        let total = header.buffer_len();
        if let (Some(src), Some(dst)) = (reply.get(..total), self.backup.get_mut(..total)) {
            dst.copy_from_slice(src);
            self.backup_len = total;
        } else {
            self.backup_len = 0;
        }
        Reply::Frame(total)
    }

    /// Serves a frame of another protocol through `protocol` (the mailbox error
    /// "unsupported protocol" if it does not serve `mailbox_type`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn serve_other<P: MailboxProtocol + ?Sized>(
        &mut self,
        protocol: &mut P,
        mailbox_type: MailboxType,
        payload: &[u8],
        request_len: usize,
        state: AlState,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        if !protocol.serves(mailbox_type) {
            return self.send_error(reply, MailboxErrorCode::UnsupportedProtocol);
        }
        match protocol.serve(payload, request_len, state, now_ms, payload_area(reply)) {
            Ok(Some((answer_type, n))) => self.send(reply, answer_type, n),
            Ok(None) => Reply::None,
            Err(code) => self.send_error(reply, code),
        }
    }

    /// Sends a mailbox error reply.
    pub(crate) fn send_error(&mut self, reply: &mut [u8], code: MailboxErrorCode) -> Reply {
        let error = MailboxErrorReplyRepr { code };
        let mut body = MailboxErrorReply::new_unchecked(payload_area(reply));
        if error.emit(&mut body).is_err() {
            return Reply::None;
        }
        self.send(reply, MailboxType::Error, error.buffer_len())
    }

    /// Sends the oldest queued Emergency, if any.
    pub(crate) fn send_emergency(&mut self, reply: &mut [u8]) -> Reply {
        if reply.len() < MAILBOX_HEADER_LEN + wire::emergency::MAILBOX_LEN {
            return Reply::None;
        }
        let Some(emergency) = self.emcy.pop() else {
            return Reply::None;
        };
        let len = emit_coe(payload_area(reply), CoeService::Emergency, |out| {
            emergency.emit(&mut wire::Emergency::new_unchecked(out))?;
            Ok(emergency.buffer_len())
        });
        match len {
            Some(n) => self.send(reply, MailboxType::Coe, n),
            None => Reply::None,
        }
    }
}
