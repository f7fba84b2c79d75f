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
pub(crate) mod frame;
mod info;

use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::mailbox::{error_code, Incoming, MailboxService};
pub use crate::mailbox::{Emergency, Reply};
use crate::od::{EntryDesc, ObjectAccess, ObjectDictionary};
use frame::{
    emit_info_header, emit_sdo, emit_segment, COE_HDR, MBX_HDR, SVC_SDO_REQUEST, SVC_SDO_RESPONSE,
    TYPE_COE,
};
use info::InfoQuery;

/// Default time a segmented transfer may wait for its next request.
pub const DEFAULT_TIMEOUT_MS: u32 = 1000;

/// Smallest read mailbox the server can answer SDO requests through (mailbox header, CoE
/// header, SDO header).
pub const MIN_MAILBOX: usize = MBX_HDR + COE_HDR + 8;

/// SDO command bits (ETG.1000.6 5.6.2).
mod cmd {
    pub const SIZE_INDICATED: u8 = 0x01;
    pub const EXPEDITED: u8 = 0x02;
    pub const COMPLETE_ACCESS: u8 = 0x10;
    pub const TOGGLE: u8 = 0x10;
    pub const LAST_SEGMENT: u8 = 0x01;
    pub const DOWNLOAD_RESPONSE: u8 = 0x60;
    pub const UPLOAD_RESPONSE: u8 = 0x40;
    pub const DOWNLOAD_SEGMENT_RESPONSE: u8 = 0x20;
    pub const UPLOAD_SEGMENT_RESPONSE: u8 = 0x00;
    pub const ABORT: u8 = 0x80;
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

fn u16_at(data: &[u8], at: usize) -> u16 {
    match data.get(at..at + 2) {
        Some(&[a, b]) => u16::from_le_bytes([a, b]),
        _ => 0,
    }
}

fn byte_at(data: &[u8], at: usize) -> u8 {
    data.get(at).copied().unwrap_or(0)
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
    /// bytes give no reply, a mailbox error reply or a well-formed CoE reply.
    pub fn process<A: ObjectAccess + ?Sized>(
        &mut self,
        request: &[u8],
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let limit = reply.len().min(MBX);
        let Some(reply) = reply.get_mut(..limit) else {
            return Reply::None;
        };
        match self.mailbox.receive(request) {
            Incoming::Duplicate => Reply::None,
            Incoming::Error(code) => self.mailbox.send_error(reply, code),
            Incoming::Coe(SVC_SDO_REQUEST, data) => {
                self.info = None;
                self.sdo_request(data, state, od, app, now_ms, reply)
            }
            Incoming::Coe(_, data) => self.sdo_info(data, od, reply),
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
            Some(n) => self.mailbox.send(reply, TYPE_COE, n),
            None => Reply::None,
        }
    }

    fn abort(&mut self, reply: &mut [u8], index: u16, subindex: u8, code: SdoAbortCode) -> Reply {
        let code = u32::from(code).to_le_bytes();
        let len = reply
            .get_mut(MBX_HDR..)
            .and_then(|out| emit_sdo(out, SVC_SDO_REQUEST, cmd::ABORT, index, subindex, code, &[]));
        self.send_coe(reply, len)
    }

    fn respond(
        &mut self,
        reply: &mut [u8],
        command: u8,
        index: u16,
        subindex: u8,
        head: [u8; 4],
        payload: Payload,
    ) -> Reply {
        let len = match reply.get_mut(MBX_HDR..) {
            Some(out) => {
                let data = match payload {
                    Payload::None => &[][..],
                    Payload::Buf(n) => self.buf.get(..n).unwrap_or(&[]),
                };
                emit_sdo(out, SVC_SDO_RESPONSE, command, index, subindex, head, data)
            }
            None => None,
        };
        self.send_coe(reply, len)
    }

    fn segment(&mut self, reply: &mut [u8], command: u8, range: (usize, usize)) -> Reply {
        let len = match (reply.get_mut(MBX_HDR..), self.buf.get(range.0..range.1)) {
            (Some(out), Some(data)) => emit_segment(out, command, data),
            (Some(out), None) => emit_segment(out, command, &[]),
            _ => None,
        };
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
        if data.len() < 8 {
            return self.mailbox.send_error(reply, error_code::SIZE_TOO_SHORT);
        }
        if reply.len() < MIN_MAILBOX {
            return Reply::None;
        }
        let command = byte_at(data, 0);
        let index = u16_at(data, 1);
        let subindex = byte_at(data, 3);
        let ccs = command >> 5;
        if let Some((t_index, t_sub, last_ms)) = self.transfer.target() {
            if now_ms.wrapping_sub(last_ms) > self.timeout_ms {
                self.transfer = Transfer::Idle;
                if ccs == 0 || ccs == 3 {
                    return self.abort(reply, t_index, t_sub, SdoAbortCode::SdoProtocolTimeout);
                }
            }
        }
        match ccs {
            1 => {
                self.transfer = Transfer::Idle;
                self.init_download(data, state, od, app, now_ms, reply)
            }
            0 => self.download_segment(data, state, od, app, now_ms, reply),
            2 => {
                self.transfer = Transfer::Idle;
                self.init_upload(data, state, od, app, now_ms, reply)
            }
            3 => self.upload_segment(data, now_ms, reply),
            4 => {
                // Abort transfer from the master: no response.
                self.transfer = Transfer::Idle;
                Reply::None
            }
            _ => {
                self.transfer = Transfer::Idle;
                self.abort(
                    reply,
                    index,
                    subindex,
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

    fn init_download<A: ObjectAccess + ?Sized>(
        &mut self,
        data: &[u8],
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let command = byte_at(data, 0);
        let index = u16_at(data, 1);
        let subindex = byte_at(data, 3);
        let complete = command & cmd::COMPLETE_ACCESS != 0;
        let expedited = command & cmd::EXPEDITED != 0;
        let (declared, payload): (Option<usize>, &[u8]) = if expedited {
            let size = (command & cmd::SIZE_INDICATED != 0)
                .then(|| 4 - usize::from((command >> 2) & 0x03));
            (size, data.get(4..8).unwrap_or(&[]))
        } else {
            let size = u32::from_le_bytes([
                byte_at(data, 4),
                byte_at(data, 5),
                byte_at(data, 6),
                byte_at(data, 7),
            ]);
            (
                Some(usize::try_from(size).unwrap_or(usize::MAX)),
                data.get(8..).unwrap_or(&[]),
            )
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
                Ok(()) => self.download_ack(reply, index, subindex, complete),
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
        self.download_ack(reply, index, subindex, complete)
    }

    fn download_ack(
        &mut self,
        reply: &mut [u8],
        index: u16,
        subindex: u8,
        complete: bool,
    ) -> Reply {
        let command = cmd::DOWNLOAD_RESPONSE | if complete { cmd::COMPLETE_ACCESS } else { 0 };
        self.respond(reply, command, index, subindex, [0; 4], Payload::None)
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

    fn download_segment<A: ObjectAccess + ?Sized>(
        &mut self,
        data: &[u8],
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
        let command = byte_at(data, 0);
        let seg_toggle = command & cmd::TOGGLE != 0;
        if seg_toggle != toggle {
            self.transfer = Transfer::Idle;
            return self.abort(reply, index, subindex, SdoAbortCode::ToggleBitNotAlternated);
        }
        let last = command & cmd::LAST_SEGMENT != 0;
        let segment = data.get(1..).unwrap_or(&[]);
        let valid = if data.len() == 8 {
            7 - usize::from((command >> 1) & 0x07)
        } else {
            segment.len()
        };
        let segment = segment.get(..valid).unwrap_or(segment);
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
        let response = cmd::DOWNLOAD_SEGMENT_RESPONSE | if toggle { cmd::TOGGLE } else { 0 };
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
            return self.segment(reply, response, (0, 0));
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
            Ok(()) => self.segment(reply, response, (0, 0)),
            Err(code) => self.abort(reply, index, subindex, code),
        }
    }

    fn init_upload<A: ObjectAccess + ?Sized>(
        &mut self,
        data: &[u8],
        state: AlState,
        od: &ObjectDictionary,
        app: &mut A,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let command = byte_at(data, 0);
        let index = u16_at(data, 1);
        let subindex = byte_at(data, 3);
        let complete = command & cmd::COMPLETE_ACCESS != 0;
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
        let ca = if complete { cmd::COMPLETE_ACCESS } else { 0 };
        if (1..=4).contains(&n) {
            // Expedited with the exact size: 4 - n unused bytes in bits 2..3.
            let mut head = [0u8; 4];
            if let (Some(dst), Some(src)) = (head.get_mut(..n), self.buf.get(..n)) {
                dst.copy_from_slice(src);
            }
            let command = cmd::UPLOAD_RESPONSE
                | cmd::EXPEDITED
                | cmd::SIZE_INDICATED
                | (((4 - n) as u8) << 2)
                | ca;
            return self.respond(reply, command, index, subindex, head, Payload::None);
        }
        let command = cmd::UPLOAD_RESPONSE | cmd::SIZE_INDICATED | ca;
        let size = u32::try_from(n).unwrap_or(u32::MAX).to_le_bytes();
        let room = reply.len().saturating_sub(MIN_MAILBOX);
        if n <= room {
            return self.respond(reply, command, index, subindex, size, Payload::Buf(n));
        }
        self.transfer = Transfer::Upload {
            index,
            subindex,
            total: n,
            sent: room,
            toggle: false,
            last_ms: now_ms,
        };
        self.respond(reply, command, index, subindex, size, Payload::Buf(room))
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

    fn upload_segment(&mut self, data: &[u8], now_ms: u32, reply: &mut [u8]) -> Reply {
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
        let command = byte_at(data, 0);
        if (command & cmd::TOGGLE != 0) != toggle {
            self.transfer = Transfer::Idle;
            return self.abort(reply, index, subindex, SdoAbortCode::ToggleBitNotAlternated);
        }
        let room = reply.len().saturating_sub(MBX_HDR + COE_HDR + 1);
        let remaining = total.saturating_sub(sent);
        let chunk = remaining.min(room);
        let last = chunk == remaining;
        let mut response = cmd::UPLOAD_SEGMENT_RESPONSE | if toggle { cmd::TOGGLE } else { 0 };
        if last {
            response |= cmd::LAST_SEGMENT;
            self.transfer = Transfer::Idle;
        } else {
            self.transfer = Transfer::Upload {
                index,
                subindex,
                total,
                sent: sent + chunk,
                toggle: !toggle,
                last_ms: now_ms,
            };
        }
        if chunk < 7 {
            response |= ((7 - chunk) as u8) << 1;
        }
        self.segment(reply, response, (sent, sent + chunk))
    }

    // ---------------------------------------------------------------- SDO Information

    fn sdo_info(&mut self, data: &[u8], od: &ObjectDictionary, reply: &mut [u8]) -> Reply {
        let opcode = byte_at(data, 0) & 0x7F;
        let needed = match opcode {
            0x01 | 0x03 => 6,
            0x05 => 8,
            _ => 4,
        };
        if data.len() < needed {
            return self.mailbox.send_error(reply, error_code::SIZE_TOO_SHORT);
        }
        self.info = None;
        let query = match opcode {
            0x01 => InfoQuery::OdList(u16_at(data, 4)),
            0x03 => InfoQuery::Object(u16_at(data, 4)),
            0x05 => InfoQuery::Entry {
                index: u16_at(data, 4),
                subindex: byte_at(data, 6),
                value_info: byte_at(data, 7),
            },
            _ => return self.info_error(reply, SdoAbortCode::InvalidCommandSpecifier),
        };
        let total = match info::stream_len(&query, od) {
            Ok(total) => total,
            Err(code) => return self.info_error(reply, code),
        };
        // Even fragment sizes keep the u16 indices of an OD list whole.
        let chunk = reply.len().saturating_sub(MBX_HDR + COE_HDR + 4) & !1;
        if chunk == 0 {
            return Reply::None;
        }
        let fragments = total.div_ceil(chunk).max(1);
        let pending = InfoPending {
            query,
            total,
            sent: 0,
            chunk,
            fragments_left: u16::try_from(fragments - 1).unwrap_or(u16::MAX),
        };
        self.info_fragment(pending, od, reply)
    }

    fn info_fragment(
        &mut self,
        pending: InfoPending,
        od: &ObjectDictionary,
        reply: &mut [u8],
    ) -> Reply {
        let body_at = MBX_HDR + COE_HDR + 4;
        let len = pending
            .chunk
            .min(pending.total.saturating_sub(pending.sent));
        let written = match reply.get_mut(body_at..body_at + len) {
            Some(out) => info::stream_chunk(&pending.query, od, pending.sent, out),
            None => {
                self.info = None;
                return Reply::None;
            }
        };
        let incomplete = pending.fragments_left > 0;
        let header = reply.get_mut(MBX_HDR..).and_then(|out| {
            emit_info_header(
                out,
                pending.query.response_opcode(),
                incomplete,
                pending.fragments_left,
                written,
            )
        });
        self.info = incomplete.then(|| InfoPending {
            sent: pending.sent + written,
            fragments_left: pending.fragments_left - 1,
            ..pending
        });
        self.send_coe(reply, header)
    }

    fn info_error(&mut self, reply: &mut [u8], code: SdoAbortCode) -> Reply {
        let body_at = MBX_HDR + COE_HDR + 4;
        let Some(out) = reply.get_mut(body_at..body_at + 4) else {
            return Reply::None;
        };
        out.copy_from_slice(&u32::from(code).to_le_bytes());
        let len = reply
            .get_mut(MBX_HDR..)
            .and_then(|out| emit_info_header(out, 0x07, false, 0, 4));
        self.send_coe(reply, len)
    }
}

/// What follows the SDO header of a response.
#[derive(Debug, Clone, Copy)]
enum Payload {
    None,
    /// The first `n` bytes of the transfer buffer.
    Buf(usize),
}
