//! The SDO server (ETG.1000.6 5.6.2 SDO, 5.6.3 SDO Information): one entry point,
//! [`SdoServer::process`], takes the whole content of the write mailbox (SM0) and writes the
//! whole reply frame for the read mailbox (SM1).
//!
//! Served:
//! - SDO download and upload: expedited (exact sizes: a u8 answers with one byte, 0x4F),
//!   normal (the whole value in one frame) and segmented (toggle bit from 0, last bit,
//!   unused-byte count; 0x05030000 on a toggle error), complete access (see
//!   [`complete`](self) rules), with access checks per ESM state, length and range checks
//!   and the application's veto; a transfer that sees no request for
//!   [`SdoServer::set_timeout_ms`] (1000 ms by default) is aborted with 0x05040000 on the
//!   next segment request; a new initiate request drops a transfer in progress;
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

use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::mailbox::{
    emit_coe, payload_area, Incoming, MailboxProtocol, MailboxService, NoOtherProtocol,
    MAILBOX_HEADER_LEN,
};
pub use crate::mailbox::{Emergency, Reply};
use crate::od::{EntryDesc, ObjectAccess, ObjectDictionary};
use crate::wire::{
    self, CoeService, Direction, InitData, MailboxType, Sdo, SdoInfo, SdoInfoHeaderRepr,
    SdoInfoRepr, SdoRepr,
};
use info::InfoQuery;

/// Default time a segmented transfer may wait for its next request.
pub const DEFAULT_TIMEOUT_MS: u32 = 1000;

/// Smallest read mailbox the server can answer SDO requests through (mailbox header, CoE
/// header, SDO header).
pub const MIN_MAILBOX: usize = MAILBOX_HEADER_LEN + wire::coe::HEADER_LEN + wire::sdo::HEADER_LEN;

/// Bytes of a read mailbox frame in front of upload segment data.
const SEGMENT_OVERHEAD: usize =
    MAILBOX_HEADER_LEN + wire::coe::HEADER_LEN + wire::sdo::SEGMENT_HEADER_LEN;

/// Bytes of a read mailbox frame in front of SDO Information service data.
const INFO_OVERHEAD: usize =
    MAILBOX_HEADER_LEN + wire::coe::HEADER_LEN + wire::sdo_info::HEADER_LEN;

/// Writes an SDO frame (CoE header with the frame's service, then the frame) after the
/// mailbox header; returns the CoE frame length.
fn emit_sdo(reply: &mut [u8], frame: &SdoRepr<'_>) -> Option<usize> {
    emit_coe(payload_area(reply), frame.coe_service(), |out| {
        frame.emit(&mut Sdo::new_unchecked(out))?;
        Ok(frame.buffer_len())
    })
}

/// A segmented transfer in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Transfer {
    Idle,
    Download {
        index: u16,
        subindex: u8,
        complete: bool,
        total: usize,
        received: usize,
        toggle: bool,
        last_ms: u32,
    },
    Upload {
        index: u16,
        subindex: u8,
        total: usize,
        sent: usize,
        toggle: bool,
        last_ms: u32,
    },
}

impl Transfer {
    fn target(&self) -> Option<(u16, u8, u32)> {
        match *self {
            Self::Idle => None,
            Self::Download {
                index,
                subindex,
                last_ms,
                ..
            }
            | Self::Upload {
                index,
                subindex,
                last_ms,
                ..
            } => Some((index, subindex, last_ms)),
        }
    }
}

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
    transfer: Transfer,
    info: Option<InfoPending>,
    timeout_ms: u32,
    buf: [u8; BUF],
}

impl<const MBX: usize, const BUF: usize, const EMCY: usize> Default for SdoServer<MBX, BUF, EMCY> {
    fn default() -> Self {
        Self::new()
    }
}

/// Checks a value for one entry before it is written: length, range, and the unused high
/// bits of BOOLEAN/BITn.
fn check_value(entry: &EntryDesc, data: &[u8]) -> Result<(), SdoAbortCode> {
    let cap = entry.byte_len();
    if entry.data_type.is_variable_length() {
        if entry.bit_len != 0 && data.len() > cap {
            return Err(SdoAbortCode::LengthTooHigh);
        }
        return Ok(());
    }
    if data.len() > cap {
        return Err(SdoAbortCode::LengthTooHigh);
    }
    if data.len() < cap {
        return Err(SdoAbortCode::LengthTooLow);
    }
    let spare = entry.bit_len % 8;
    if spare != 0 {
        if let Some(top) = data.last() {
            if top >> spare != 0 {
                return Err(SdoAbortCode::ValueRangeExceeded);
            }
        }
    }
    entry.check_range(data)
}

impl<const MBX: usize, const BUF: usize, const EMCY: usize> SdoServer<MBX, BUF, EMCY> {
    /// A server with nothing in progress and the default timeout.
    pub const fn new() -> Self {
        Self {
            mailbox: MailboxService::new(),
            transfer: Transfer::Idle,
            info: None,
            timeout_ms: DEFAULT_TIMEOUT_MS,
            buf: [0; BUF],
        }
    }

    /// Sets the time a segmented transfer may wait for its next request.
    pub fn set_timeout_ms(&mut self, timeout_ms: u32) {
        self.timeout_ms = timeout_ms;
    }

    /// The mailbox service (counters, backup, Emergency queue).
    pub fn mailbox(&self) -> &MailboxService<MBX, EMCY> {
        &self.mailbox
    }

    /// True while a segmented transfer or a fragmented SDO Information response is open.
    pub fn busy(&self) -> bool {
        self.transfer != Transfer::Idle || self.info.is_some()
    }

    /// True if [`SdoServer::poll`] has a frame to send: an SDO Information fragment, or a
    /// queued Emergency outside a segmented transfer.
    pub fn has_outgoing(&self) -> bool {
        self.info.is_some()
            || (self.transfer == Transfer::Idle && self.mailbox.pending_emergencies() > 0)
    }

    /// Applies an ESM transition: INIT -> PREOP resets the mailbox counters; entering INIT
    /// or BOOT drops everything in progress.
    pub fn on_state_change(&mut self, from: AlState, to: AlState) {
        self.mailbox.on_state_change(from, to);
        if matches!(to, AlState::Init | AlState::Bootstrap) {
            self.transfer = Transfer::Idle;
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
        if self.transfer != Transfer::Idle {
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

    fn abort(&mut self, reply: &mut [u8], index: u16, subindex: u8, code: SdoAbortCode) -> Reply {
        let len = emit_sdo(
            reply,
            &SdoRepr::Abort {
                index,
                sub_index: subindex,
                code,
            },
        );
        self.send_coe(reply, len)
    }

    // ---------------------------------------------------------------- SDO

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
        // Segment requests (specifier 0 download, 3 upload) continue a transfer.
        let segment = matches!(view.command_specifier(), 0 | 3);
        if let Some((t_index, t_sub, last_ms)) = self.transfer.target() {
            if now_ms.wrapping_sub(last_ms) > self.timeout_ms {
                self.transfer = Transfer::Idle;
                if segment {
                    return self.abort(reply, t_index, t_sub, SdoAbortCode::SdoProtocolTimeout);
                }
            }
        }
        let request = match SdoRepr::parse(&view, Direction::Request) {
            Ok(request) => request,
            Err(e) => {
                // A segment frame has no index: name the transfer's object.
                let (index, subindex) = self
                    .transfer
                    .target()
                    .filter(|_| segment)
                    .map_or((view.index(), view.sub_index()), |(i, s, _)| (i, s));
                self.transfer = Transfer::Idle;
                return self.abort(reply, index, subindex, e.sdo_abort_code());
            }
        };
        match request {
            SdoRepr::InitiateDownloadRequest {
                index,
                sub_index,
                complete_access,
                data,
            } => {
                self.transfer = Transfer::Idle;
                let target = Target::new(index, sub_index, complete_access);
                self.init_download(target, data, state, od, app, now_ms, reply)
            }
            SdoRepr::DownloadSegmentRequest { toggle, last, data } => {
                self.download_segment(toggle, last, data, state, od, app, now_ms, reply)
            }
            SdoRepr::InitiateUploadRequest {
                index,
                sub_index,
                complete_access,
            } => {
                self.transfer = Transfer::Idle;
                let target = Target::new(index, sub_index, complete_access);
                self.init_upload(target, state, od, app, now_ms, reply)
            }
            SdoRepr::UploadSegmentRequest { toggle } => self.upload_segment(toggle, now_ms, reply),
            SdoRepr::Abort { .. } => {
                // Abort transfer from the master: no response.
                self.transfer = Transfer::Idle;
                Reply::None
            }
            // Responses are never parsed from the request direction.
            SdoRepr::InitiateDownloadResponse { .. }
            | SdoRepr::InitiateUploadResponse { .. }
            | SdoRepr::DownloadSegmentResponse { .. }
            | SdoRepr::UploadSegmentResponse { .. } => {
                self.transfer = Transfer::Idle;
                self.abort(
                    reply,
                    view.index(),
                    view.sub_index(),
                    SdoAbortCode::InvalidCommandSpecifier,
                )
            }
        }
    }

    /// A segment request that does not belong to the transfer in progress: the old transfer
    /// ends and the request is answered with 0x05040001.
    fn unexpected_segment(&mut self, reply: &mut [u8]) -> Reply {
        let (index, subindex) = self
            .transfer
            .target()
            .map_or((0, 0), |(index, subindex, _)| (index, subindex));
        self.transfer = Transfer::Idle;
        self.abort(
            reply,
            index,
            subindex,
            SdoAbortCode::InvalidCommandSpecifier,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn init_download<A: ObjectAccess + ?Sized>(
        &mut self,
        target: Target,
        data: InitData<'_>,
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let Target {
            index,
            subindex,
            complete,
        } = target;
        let expedited_bytes;
        let (declared, payload): (Option<usize>, &[u8]) = match data {
            // All four bytes: without a size indicated, the entry's size picks from them.
            InitData::Expedited { size, data } => {
                expedited_bytes = data;
                (size.map(usize::from), &expedited_bytes[..])
            }
            InitData::Normal {
                complete_size,
                data,
            } => (
                Some(usize::try_from(complete_size).unwrap_or(usize::MAX)),
                data,
            ),
        };
        let result = if complete {
            self.check_complete_download(od, index, subindex, declared)
        } else {
            Self::check_download(od, app, state, index, subindex, declared)
        };
        let size = match result {
            Ok(size) => size,
            Err(code) => return self.abort(reply, index, subindex, code),
        };
        if size <= payload.len() {
            let value = payload.get(..size).unwrap_or(&[]);
            let result = if complete {
                match od.find(index) {
                    Some(object) => complete::download(object, subindex, value, app, state),
                    None => Err(SdoAbortCode::ObjectDoesNotExist),
                }
            } else {
                Self::commit(od, app, state, index, subindex, value)
            };
            return match result {
                Ok(()) => self.download_ack(reply, target),
                Err(code) => self.abort(reply, index, subindex, code),
            };
        }
        // Segmented: keep what came and wait for segments.
        if size > BUF {
            return self.abort(reply, index, subindex, SdoAbortCode::OutOfMemory);
        }
        let Some(dst) = self.buf.get_mut(..payload.len()) else {
            return self.abort(reply, index, subindex, SdoAbortCode::OutOfMemory);
        };
        dst.copy_from_slice(payload);
        self.transfer = Transfer::Download {
            index,
            subindex,
            complete,
            total: size,
            received: payload.len(),
            toggle: false,
            last_ms: now_ms,
        };
        self.download_ack(reply, target)
    }

    fn download_ack(&mut self, reply: &mut [u8], target: Target) -> Reply {
        let len = emit_sdo(
            reply,
            &SdoRepr::InitiateDownloadResponse {
                index: target.index,
                sub_index: target.subindex,
                complete_access: target.complete,
            },
        );
        self.send_coe(reply, len)
    }

    /// Access and size checks of a single-entry download; returns the value size.
    fn check_download<A: ObjectAccess + ?Sized>(
        od: &ObjectDictionary,
        app: &mut A,
        state: AlState,
        index: u16,
        subindex: u8,
        declared: Option<usize>,
    ) -> Result<usize, SdoAbortCode> {
        let (_, entry) = od.entry(index, subindex)?;
        Self::check_write_access(entry, app, state, index, subindex)?;
        let cap = entry.byte_len();
        let size = match declared {
            Some(size) => size,
            None if entry.data_type.is_variable_length() => 4.min(cap.max(1)),
            None if cap <= 4 => cap,
            None => return Err(SdoAbortCode::LengthMismatch),
        };
        if entry.data_type.is_variable_length() {
            if entry.bit_len != 0 && size > cap {
                return Err(SdoAbortCode::LengthTooHigh);
            }
        } else if size > cap {
            return Err(SdoAbortCode::LengthTooHigh);
        } else if size < cap {
            return Err(SdoAbortCode::LengthTooLow);
        }
        Ok(size)
    }

    fn check_write_access<A: ObjectAccess + ?Sized>(
        entry: &EntryDesc,
        app: &mut A,
        state: AlState,
        index: u16,
        subindex: u8,
    ) -> Result<(), SdoAbortCode> {
        if !entry.access.is_writable() {
            return Err(SdoAbortCode::WriteOfReadOnly);
        }
        if !entry.access.writable_in(state) {
            return Err(SdoAbortCode::DeviceState);
        }
        if state == AlState::Op
            && entry.access.is_rx_mappable()
            && app.is_rx_mapped(index, subindex)
        {
            return Err(SdoAbortCode::MappedToRxPdo);
        }
        Ok(())
    }

    fn check_complete_download(
        &self,
        od: &ObjectDictionary,
        index: u16,
        subindex: u8,
        declared: Option<usize>,
    ) -> Result<usize, SdoAbortCode> {
        let object = od.find(index).ok_or(SdoAbortCode::ObjectDoesNotExist)?;
        complete::check_start(object, subindex)?;
        Ok(declared.unwrap_or(4))
    }

    /// Writes a single entry after the value checks.
    fn commit<A: ObjectAccess + ?Sized>(
        od: &ObjectDictionary,
        app: &mut A,
        state: AlState,
        index: u16,
        subindex: u8,
        value: &[u8],
    ) -> Result<(), SdoAbortCode> {
        let (_, entry) = od.entry(index, subindex)?;
        check_value(entry, value)?;
        app.write(index, subindex, value, state)
    }

    #[allow(clippy::too_many_arguments)]
    fn download_segment<A: ObjectAccess + ?Sized>(
        &mut self,
        seg_toggle: bool,
        last: bool,
        segment: &[u8],
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let Transfer::Download {
            index,
            subindex,
            complete,
            total,
            received,
            toggle,
            ..
        } = self.transfer
        else {
            return self.unexpected_segment(reply);
        };
        if seg_toggle != toggle {
            self.transfer = Transfer::Idle;
            return self.abort(reply, index, subindex, SdoAbortCode::ToggleBitNotAlternated);
        }
        let end = received + segment.len();
        if end > total {
            self.transfer = Transfer::Idle;
            return self.abort(reply, index, subindex, SdoAbortCode::LengthTooHigh);
        }
        match self.buf.get_mut(received..end) {
            Some(dst) => dst.copy_from_slice(segment),
            None => {
                self.transfer = Transfer::Idle;
                return self.abort(reply, index, subindex, SdoAbortCode::OutOfMemory);
            }
        }
        let response = SdoRepr::DownloadSegmentResponse { toggle };
        if !last {
            self.transfer = Transfer::Download {
                index,
                subindex,
                complete,
                total,
                received: end,
                toggle: !toggle,
                last_ms: now_ms,
            };
            let len = emit_sdo(reply, &response);
            return self.send_coe(reply, len);
        }
        self.transfer = Transfer::Idle;
        if end < total {
            return self.abort(reply, index, subindex, SdoAbortCode::LengthTooLow);
        }
        let value = self.buf.get(..total).unwrap_or(&[]);
        let result = if complete {
            match od.find(index) {
                Some(object) => complete::download(object, subindex, value, app, state),
                None => Err(SdoAbortCode::ObjectDoesNotExist),
            }
        } else {
            Self::commit(od, app, state, index, subindex, value)
        };
        match result {
            Ok(()) => {
                let len = emit_sdo(reply, &response);
                self.send_coe(reply, len)
            }
            Err(code) => self.abort(reply, index, subindex, code),
        }
    }

    fn init_upload<A: ObjectAccess + ?Sized>(
        &mut self,
        target: Target,
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let Target {
            index,
            subindex,
            complete,
        } = target;
        let read = if complete {
            match od.find(index) {
                Some(object) => complete::upload(object, subindex, app, state, &mut self.buf),
                None => Err(SdoAbortCode::ObjectDoesNotExist),
            }
        } else {
            self.read_entry(od, app, state, index, subindex)
        };
        let n = match read {
            Ok(n) => n.min(BUF),
            Err(code) => return self.abort(reply, index, subindex, code),
        };
        let value = self.buf.get(..n).unwrap_or_default();
        let room = reply.len().saturating_sub(MIN_MAILBOX);
        // Expedited with the exact size for 1..4 bytes; else normal, segmented if the
        // value does not fit the read mailbox.
        let data = match InitData::expedited(value) {
            Some(expedited) => expedited,
            None => InitData::Normal {
                complete_size: u32::try_from(n).unwrap_or(u32::MAX),
                data: value.get(..room).unwrap_or(value),
            },
        };
        if n > 4 && n > room {
            self.transfer = Transfer::Upload {
                index,
                subindex,
                total: n,
                sent: room,
                toggle: false,
                last_ms: now_ms,
            };
        }
        let len = emit_sdo(
            reply,
            &SdoRepr::InitiateUploadResponse {
                index,
                sub_index: subindex,
                complete_access: complete,
                data,
            },
        );
        self.send_coe(reply, len)
    }

    /// Access checks and read of a single entry into the transfer buffer.
    fn read_entry<A: ObjectAccess + ?Sized>(
        &mut self,
        od: &ObjectDictionary,
        app: &mut A,
        state: AlState,
        index: u16,
        subindex: u8,
    ) -> Result<usize, SdoAbortCode> {
        let (_, entry) = od.entry(index, subindex)?;
        if !entry.access.is_readable() {
            return Err(SdoAbortCode::ReadOfWriteOnly);
        }
        if !entry.access.readable_in(state) {
            return Err(SdoAbortCode::DeviceState);
        }
        let cap = if entry.bit_len == 0 {
            BUF
        } else {
            entry.byte_len()
        };
        let buf = self.buf.get_mut(..cap).ok_or(SdoAbortCode::OutOfMemory)?;
        let n = app.read(index, subindex, buf)?;
        Ok(n.min(cap))
    }

    fn upload_segment(&mut self, seg_toggle: bool, now_ms: u32, reply: &mut [u8]) -> Reply {
        let Transfer::Upload {
            index,
            subindex,
            total,
            sent,
            toggle,
            ..
        } = self.transfer
        else {
            return self.unexpected_segment(reply);
        };
        if seg_toggle != toggle {
            self.transfer = Transfer::Idle;
            return self.abort(reply, index, subindex, SdoAbortCode::ToggleBitNotAlternated);
        }
        let room = reply.len().saturating_sub(SEGMENT_OVERHEAD);
        let remaining = total.saturating_sub(sent);
        let chunk = remaining.min(room);
        let last = chunk == remaining;
        self.transfer = if last {
            Transfer::Idle
        } else {
            Transfer::Upload {
                index,
                subindex,
                total,
                sent: sent + chunk,
                toggle: !toggle,
                last_ms: now_ms,
            }
        };
        let len = emit_sdo(
            reply,
            &SdoRepr::UploadSegmentResponse {
                toggle,
                last,
                data: self.buf.get(sent..sent + chunk).unwrap_or_default(),
            },
        );
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

/// The object a request names and whether it is a complete access.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Target {
    index: u16,
    subindex: u8,
    complete: bool,
}

impl Target {
    const fn new(index: u16, subindex: u8, complete: bool) -> Self {
        Self {
            index,
            subindex,
            complete,
        }
    }
}
