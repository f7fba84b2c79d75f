//! The SDO server: the SDO state machine ([`machine`], one copy for every transport) and its
//! CoE framing ([`SdoServer`], ETG.1000.6 5.6.2 SDO, 5.6.3 SDO Information). The CAN framing
//! of the same machine is [`crate::canopen::sdo::CanSdoServer`].
//!
//! [`SdoServer::process`], the CoE entry point, takes the whole content of the write
//! mailbox (SM0) and writes the whole reply frame for the read mailbox (SM1).
//!
//! Served:
//! - SDO download and upload through [`machine::SdoMachine`]: expedited (exact sizes: a u8
//!   answers with one byte, 0x4F), normal (the whole value in one frame, as far as the read
//!   mailbox reaches) and segmented (toggle bit from 0, last bit, unused-byte count;
//!   0x05030000 on a toggle error), complete access (see [`complete`](self) rules), with
//!   access checks per ESM state, length and range checks and the application's veto; a
//!   transfer that sees no request for [`SdoServer::set_timeout_ms`] (1000 ms by default)
//!   is aborted with 0x05040000 on the next segment request; a new initiate request drops a
//!   transfer in progress;
//! - SDO Information: OD list (list types 0..5), object description, entry description
//!   with unit/default/min/max, SDO Information errors; long responses go out in fragments,
//!   the rest of them one per [`SdoServer::poll`] call;
//! - Emergencies queued by the application ([`SdoServer::queue_emergency`]), sent by
//!   [`SdoServer::poll`] when nothing else is pending;
//! - the mailbox layer of [`crate::mailbox`]: header checks with mailbox error replies,
//!   counter/duplicate handling, the repeat backup ([`SdoServer::repeat`]).
//!
//! Aborts go out as CoE service "SDO request" (2) with command 0x80, as masters expect.
//!
//! Call [`SdoServer::process`] only when the read mailbox is free (the request can wait in
//! SM0 until then), and [`SdoServer::poll`] whenever the read mailbox has become free.

mod complete;
pub(crate) use complete::Layout;
pub mod info;
pub mod machine;

use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::mailbox::{
    emit_coe, payload_area, Incoming, MailboxProtocol, MailboxService, NoOtherProtocol,
    MAILBOX_HEADER_LEN,
};
pub use crate::mailbox::{Emergency, Reply};
use crate::od::{ObjectAccess, ObjectDictionary};
use crate::wire::{self, CoeService, MailboxType, Sdo, SdoInfo, SdoInfoHeaderRepr, SdoInfoRepr};
use info::InfoQuery;
pub use machine::DEFAULT_TIMEOUT_MS;
use machine::{SdoContext, SdoMachine};

/// Smallest read mailbox the server can answer SDO requests through (mailbox header, CoE
/// header, SDO header).
pub const MIN_MAILBOX: usize = MAILBOX_HEADER_LEN + wire::coe::HEADER_LEN + wire::sdo::HEADER_LEN;

/// Bytes of a read mailbox frame in front of the SDO frame.
const SDO_OVERHEAD: usize = MAILBOX_HEADER_LEN + wire::coe::HEADER_LEN;

/// Bytes of a read mailbox frame in front of SDO Information service data.
const INFO_OVERHEAD: usize =
    MAILBOX_HEADER_LEN + wire::coe::HEADER_LEN + wire::sdo_info::HEADER_LEN;

/// A fragmented SDO Information response still being sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct InfoPending {
    query: InfoQuery,
    total: usize,
    sent: usize,
    chunk: usize,
    fragments_left: u16,
}

/// The CoE mailbox server of one slave.
///
/// - `MBX`: largest frame the server writes (and keeps for the repeat request); replies are
///   also bounded by the reply buffer the caller gives, i.e. the read mailbox size.
/// - `BUF`: transfer buffer; the largest object (or complete-access image) that can be
///   uploaded or downloaded in several frames.
/// - `EMCY`: Emergencies that can wait.
#[derive(Debug, Clone)]
pub struct SdoServer<const MBX: usize = 128, const BUF: usize = 512, const EMCY: usize = 4> {
    mailbox: MailboxService<MBX, EMCY>,
    machine: SdoMachine<BUF>,
    info: Option<InfoPending>,
}

impl<const MBX: usize, const BUF: usize, const EMCY: usize> Default for SdoServer<MBX, BUF, EMCY> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const MBX: usize, const BUF: usize, const EMCY: usize> SdoServer<MBX, BUF, EMCY> {
    /// A server with nothing in progress and the default timeout.
    pub const fn new() -> Self {
        Self {
            mailbox: MailboxService::new(),
            machine: SdoMachine::new(true),
            info: None,
        }
    }

    /// Sets the time a segmented transfer may wait for its next request.
    pub fn set_timeout_ms(&mut self, timeout_ms: u32) {
        self.machine.set_timeout_ms(timeout_ms);
    }

    /// The mailbox service (counters, backup, Emergency queue).
    pub fn mailbox(&self) -> &MailboxService<MBX, EMCY> {
        &self.mailbox
    }

    /// True while a segmented transfer or a fragmented SDO Information response is open.
    pub fn busy(&self) -> bool {
        self.machine.busy() || self.info.is_some()
    }

    /// True if [`SdoServer::poll`] has a frame to send: an SDO Information fragment, or a
    /// queued Emergency outside a segmented transfer.
    pub fn has_outgoing(&self) -> bool {
        self.info.is_some() || (!self.machine.busy() && self.mailbox.pending_emergencies() > 0)
    }

    /// Applies an ESM transition: INIT -> PREOP resets the mailbox counters; entering INIT
    /// or BOOT drops everything in progress.
    pub fn on_state_change(&mut self, from: AlState, to: AlState) {
        self.mailbox.on_state_change(from, to);
        if matches!(to, AlState::Init | AlState::Bootstrap) {
            self.machine.reset();
            self.info = None;
        }
    }

    /// Queues an Emergency for [`SdoServer::poll`] (the oldest is dropped when full).
    pub fn queue_emergency(&mut self, emergency: Emergency) {
        self.mailbox.push_emergency(emergency);
    }

    /// Writes the last frame again (the repeat request of SM1).
    pub fn repeat(&self, reply: &mut [u8]) -> Reply {
        self.mailbox.repeat(reply)
    }

    /// Serves one received mailbox frame (`request`, the whole SM0 content) and writes the
    /// reply frame into `reply`, whose length is the read mailbox size. Never panics; any
    /// bytes give no reply, a mailbox error reply or a well-formed CoE reply. Frames of
    /// other protocols get the mailbox error "unsupported protocol".
    pub fn process<A: ObjectAccess + ?Sized>(
        &mut self,
        request: &[u8],
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        self.process_with(request, state, od, app, now_ms, reply, &mut NoOtherProtocol)
    }

    /// [`SdoServer::process`] with a protocol served beside CoE on the same mailbox
    /// (`other`, e.g. FoE through [`crate::foe::FoeEndpoint`]): its frames share the
    /// counters and the repeat backup.
    #[allow(clippy::too_many_arguments)]
    pub fn process_with<A: ObjectAccess + ?Sized, P: MailboxProtocol + ?Sized>(
        &mut self,
        request: &[u8],
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
        other: &mut P,
    ) -> Reply {
        let limit = reply.len().min(MBX);
        let Some(reply) = reply.get_mut(..limit) else {
            return Reply::None;
        };
        match self.mailbox.receive(request) {
            Incoming::Duplicate => Reply::None,
            Incoming::Error(code) => self.mailbox.send_error(reply, code),
            Incoming::Coe(CoeService::SdoRequest, data) => {
                self.info = None;
                self.sdo_request(data, state, od, app, now_ms, reply)
            }
            Incoming::Coe(_, data) => self.sdo_info(data, od, reply),
            Incoming::Other(mailbox_type, payload) => self.mailbox.serve_other(
                other,
                mailbox_type,
                payload,
                request.len(),
                state,
                now_ms,
                reply,
            ),
        }
    }

    /// Sends what is pending once the read mailbox is free: the next fragment of an SDO
    /// Information response, else a queued Emergency (never in the middle of a segmented
    /// transfer). `Reply::None` if there is nothing.
    pub fn poll(&mut self, od: &ObjectDictionary, reply: &mut [u8]) -> Reply {
        let limit = reply.len().min(MBX);
        let Some(reply) = reply.get_mut(..limit) else {
            return Reply::None;
        };
        if let Some(pending) = self.info {
            return self.info_fragment(pending, od, reply);
        }
        if self.machine.busy() {
            return Reply::None;
        }
        self.mailbox.send_emergency(reply)
    }

    // ---------------------------------------------------------------- frames

    fn send_coe(&mut self, reply: &mut [u8], len: Option<usize>) -> Reply {
        match len {
            Some(n) => self.mailbox.send(reply, MailboxType::Coe, n),
            None => Reply::None,
        }
    }

    /// An SDO request: the machine writes its answer after the mailbox and CoE headers,
    /// then the CoE header (service from the answer's direction) and the mailbox header go
    /// in front of it.
    fn sdo_request<A: ObjectAccess + ?Sized>(
        &mut self,
        data: &[u8],
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let view = match Sdo::new_checked(data) {
            Ok(view) => view,
            Err(e) => return self.mailbox.send_error(reply, e.mailbox_error_code()),
        };
        if reply.len() < MIN_MAILBOX {
            return Reply::None;
        }
        let out = wire::tail_mut(reply, SDO_OVERHEAD);
        let ctx = SdoContext {
            state,
            od,
            app,
            now_ms,
        };
        let Some(answer) = self.machine.serve(&view, ctx, out) else {
            return Reply::None;
        };
        let service = answer.direction.coe_service();
        let len = emit_coe(payload_area(reply), service, |_| Ok(answer.len));
        self.send_coe(reply, len)
    }

    // ---------------------------------------------------------------- SDO Information

    fn sdo_info(&mut self, data: &[u8], od: &ObjectDictionary, reply: &mut [u8]) -> Reply {
        let view = match SdoInfo::new_checked(data) {
            Ok(view) => view,
            Err(e) => return self.mailbox.send_error(reply, e.mailbox_error_code()),
        };
        let query = match SdoInfoRepr::parse_request(view.opcode(), view.payload()) {
            Some(Ok(request)) => InfoQuery::from_request(&request),
            Some(Err(e)) => return self.mailbox.send_error(reply, e.mailbox_error_code()),
            None => None,
        };
        self.info = None;
        let Some(query) = query else {
            return self.info_error(reply, SdoAbortCode::InvalidCommandSpecifier);
        };
        let total = match info::stream_len(&query, od) {
            Ok(total) => total,
            Err(code) => return self.info_error(reply, code),
        };
        // Even fragment sizes keep the u16 indices of an OD list whole.
        let chunk = reply.len().saturating_sub(INFO_OVERHEAD) & !1;
        let Some(fragments) = info::fragment_count(total, chunk) else {
            return Reply::None;
        };
        let pending = InfoPending {
            query,
            total,
            sent: 0,
            chunk,
            fragments_left: fragments - 1,
        };
        self.info_fragment(pending, od, reply)
    }

    fn info_fragment(
        &mut self,
        pending: InfoPending,
        od: &ObjectDictionary,
        reply: &mut [u8],
    ) -> Reply {
        let len = pending
            .chunk
            .min(pending.total.saturating_sub(pending.sent));
        let written = match reply.get_mut(INFO_OVERHEAD..INFO_OVERHEAD + len) {
            Some(out) => info::stream_chunk(&pending.query, od, pending.sent, out),
            None => {
                self.info = None;
                return Reply::None;
            }
        };
        let incomplete = pending.fragments_left > 0;
        let header = SdoInfoHeaderRepr {
            opcode: pending.query.response_opcode(),
            incomplete,
            fragments_left: pending.fragments_left,
        };
        // The service data is already in place; only the headers go in front of it.
        let len = emit_coe(payload_area(reply), CoeService::SdoInformation, |out| {
            header.emit(&mut SdoInfo::new_unchecked(out))?;
            Ok(header.buffer_len() + written)
        });
        self.info = incomplete.then(|| InfoPending {
            sent: pending.sent + written,
            fragments_left: pending.fragments_left - 1,
            ..pending
        });
        self.send_coe(reply, len)
    }

    fn info_error(&mut self, reply: &mut [u8], code: SdoAbortCode) -> Reply {
        let error = SdoInfoRepr::Error { code };
        let len = emit_coe(payload_area(reply), CoeService::SdoInformation, |out| {
            error.emit(&mut SdoInfo::new_unchecked(out))?;
            Ok(error.buffer_len())
        });
        self.send_coe(reply, len)
    }
}
