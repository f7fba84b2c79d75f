//! The SDO state machine (CiA 301 7.2.4.3, ETG.1000.6 5.6.2), independent of the transport:
//! one SDO request frame in, one SDO frame out.
//!
//! This is the only implementation of the SDO server protocol in the project. Both
//! transports are thin framings around it:
//! - CoE ([`super::SdoServer`]): the SDO frame sits after the mailbox and CoE headers and may
//!   be as long as the read mailbox allows (normal transfers carry data in the initiate
//!   frame, segments are as long as the mailbox);
//! - CAN ([`crate::canopen::sdo::CanSdoServer`]): the SDO frame is the 8 data bytes of a CAN
//!   frame (0x600 + node-ID in, 0x580 + node-ID out), so a normal transfer carries only its
//!   size in the initiate frame and every segment holds at most 7 bytes.
//!
//! The transport says how much room a reply has by the length of the output buffer it
//! hands in; everything else is the same: expedited transfers with the exact size of the
//! entry, segmented transfers with the toggle bit from 0 (0x05030000 on a toggle error),
//! the last bit and the unused-byte count, complete access where the transport has it,
//! access checks against the object dictionary per state, length and range checks, the
//! application's veto, and the timeout: a transfer that sees no request for
//! [`SdoMachine::set_timeout_ms`] is aborted with 0x05040000 on its next segment request. A
//! new initiate request drops a transfer in progress; an abort from the client ends it
//! without a reply.

use super::complete;
use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::od::{EntryDesc, ObjectAccess, ObjectDictionary};
use crate::wire::{self, Direction, InitData, Sdo, SdoRepr};

/// Default time a segmented transfer may wait for its next request.
pub const DEFAULT_TIMEOUT_MS: u32 = 1000;

/// A reply the machine wrote: `len` bytes at the start of the output buffer, travelling
/// in `direction` (an abort is a [`Direction::Request`] frame, which CoE sends with the
/// service "SDO request").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SdoAnswer {
    /// Length of the SDO frame.
    pub len: usize,
    /// Direction of the frame (response, or request for an abort).
    pub direction: Direction,
}

/// What a request is served against: the state the access rights are checked in, the
/// object dictionary, the application that holds the values, and the time (ms, wrapping)
/// for the transfer timeout.
pub struct SdoContext<'a, A: ObjectAccess + ?Sized> {
    /// ESM state (CoE), or the NMT state's equivalent (CAN).
    pub state: AlState,
    /// The object dictionary.
    pub od: &'a ObjectDictionary,
    /// The application.
    pub app: &'a mut A,
    /// Now, in ms.
    pub now_ms: u32,
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

/// The object a request names and whether it is a complete access.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Target {
    index: u16,
    subindex: u8,
    complete: bool,
}

/// The SDO server protocol of one SDO channel; `BUF` is the transfer buffer, the largest
/// object (or complete-access image) that can be uploaded or downloaded in several frames.
#[derive(Debug, Clone)]
pub struct SdoMachine<const BUF: usize> {
    transfer: Transfer,
    timeout_ms: u32,
    complete_access: bool,
    buf: [u8; BUF],
}

/// Checks a value for one entry before it is written: length, range, and the unused high
/// bits of BOOLEAN/BITn.
fn check_value(entry: &EntryDesc, data: &[u8]) -> Result<(), SdoAbortCode> {
    let cap = entry.byte_len();
    if entry.data_type().is_variable_length() {
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

/// Writes `frame` into `out`; `None` if it does not fit.
fn emit(out: &mut [u8], frame: &SdoRepr<'_>) -> Option<SdoAnswer> {
    frame.emit(&mut Sdo::new_unchecked(&mut *out)).ok()?;
    Some(SdoAnswer {
        len: frame.buffer_len(),
        direction: frame.direction(),
    })
}

/// An abort to answer a request with: the object it names and why. Every abort ends the
/// transfer in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Abort {
    index: u16,
    subindex: u8,
    code: SdoAbortCode,
}

impl Abort {
    const fn new(index: u16, subindex: u8, code: SdoAbortCode) -> Self {
        Self {
            index,
            subindex,
            code,
        }
    }
}

impl Target {
    const fn abort(self, code: SdoAbortCode) -> Abort {
        Abort::new(self.index, self.subindex, code)
    }
}

impl<const BUF: usize> SdoMachine<BUF> {
    /// A machine with nothing in progress and the default timeout. `complete_access`:
    /// whether the transport has complete access (CoE); without it (CAN, where the bit is
    /// reserved) an initiate request with the bit set is answered with 0x05040001.
    pub const fn new(complete_access: bool) -> Self {
        Self {
            transfer: Transfer::Idle,
            timeout_ms: DEFAULT_TIMEOUT_MS,
            complete_access,
            buf: [0; BUF],
        }
    }

    /// Sets the time a segmented transfer may wait for its next request.
    pub fn set_timeout_ms(&mut self, timeout_ms: u32) {
        self.timeout_ms = timeout_ms;
    }

    /// True while a segmented transfer is open.
    pub fn busy(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Drops a transfer in progress (no reply).
    pub fn reset(&mut self) {
        self.transfer = Transfer::Idle;
    }

    /// Serves one SDO request frame (`view`: checked, so at least the 8 bytes every SDO
    /// frame has) and writes the reply frame into `out`, whose length bounds the reply (at
    /// least 8 bytes, else nothing is answered). Never panics; returns `None` when there is
    /// nothing to send (an abort from the client, or no room).
    pub fn serve<A: ObjectAccess + ?Sized>(
        &mut self,
        view: &Sdo<&[u8]>,
        ctx: SdoContext<'_, A>,
        out: &mut [u8],
    ) -> Option<SdoAnswer> {
        if out.len() < wire::sdo::HEADER_LEN {
            return None;
        }
        // One place turns an abort into its frame: the replies below only name it.
        let reply = match self.reply(view, ctx, out.len()) {
            Ok(reply) => reply?,
            Err(Abort {
                index,
                subindex,
                code,
            }) => {
                self.transfer = Transfer::Idle;
                SdoRepr::Abort {
                    index,
                    sub_index: subindex,
                    code,
                }
            }
        };
        emit(out, &reply)
    }

    /// The reply to one request in a frame of at most `room` bytes: a frame, nothing (an
    /// abort from the client) or an abort.
    fn reply<A: ObjectAccess + ?Sized>(
        &mut self,
        view: &Sdo<&[u8]>,
        ctx: SdoContext<'_, A>,
        room: usize,
    ) -> Result<Option<SdoRepr<'_>>, Abort> {
        // Segment requests (specifier 0 download, 3 upload) continue a transfer.
        let segment = matches!(view.command_specifier(), 0 | 3);
        if let Some((t_index, t_sub, last_ms)) = self.transfer.target() {
            if ctx.now_ms.wrapping_sub(last_ms) > self.timeout_ms {
                self.transfer = Transfer::Idle;
                if segment {
                    return Err(Abort::new(t_index, t_sub, SdoAbortCode::SdoProtocolTimeout));
                }
            }
        }
        let request = SdoRepr::parse(view, Direction::Request).map_err(|e| {
            // A segment frame has no index: name the transfer's object.
            let (index, subindex) = self
                .transfer
                .target()
                .filter(|_| segment)
                .map_or((view.index(), view.sub_index()), |(i, s, _)| (i, s));
            Abort::new(index, subindex, e.sdo_abort_code())
        })?;
        let reply = match request {
            SdoRepr::InitiateDownloadRequest {
                index,
                sub_index,
                complete_access,
                data,
            } => {
                self.transfer = Transfer::Idle;
                let target = self.target(index, sub_index, complete_access)?;
                self.init_download(target, data, ctx)?
            }
            SdoRepr::DownloadSegmentRequest { toggle, last, data } => {
                self.download_segment(toggle, last, data, ctx)?
            }
            SdoRepr::InitiateUploadRequest {
                index,
                sub_index,
                complete_access,
            } => {
                self.transfer = Transfer::Idle;
                let target = self.target(index, sub_index, complete_access)?;
                self.init_upload(target, ctx, room)?
            }
            SdoRepr::UploadSegmentRequest { toggle } => {
                self.upload_segment(toggle, ctx.now_ms, room)?
            }
            SdoRepr::Abort { .. } => {
                // Abort transfer from the client: no response.
                self.transfer = Transfer::Idle;
                return Ok(None);
            }
            // Responses are never parsed from the request direction.
            SdoRepr::InitiateDownloadResponse { .. }
            | SdoRepr::InitiateUploadResponse { .. }
            | SdoRepr::DownloadSegmentResponse { .. }
            | SdoRepr::UploadSegmentResponse { .. } => {
                return Err(Abort::new(
                    view.index(),
                    view.sub_index(),
                    SdoAbortCode::InvalidCommandSpecifier,
                ));
            }
        };
        Ok(Some(reply))
    }

    /// The target of an initiate request; a complete access on a transport without it is
    /// aborted.
    fn target(&self, index: u16, subindex: u8, complete: bool) -> Result<Target, Abort> {
        let target = Target {
            index,
            subindex,
            complete,
        };
        if complete && !self.complete_access {
            return Err(target.abort(SdoAbortCode::InvalidCommandSpecifier));
        }
        Ok(target)
    }

    /// A segment request that does not belong to the transfer in progress: the old transfer
    /// ends and the request is answered with 0x05040001.
    fn unexpected_segment(&self) -> Abort {
        let (index, subindex) = self
            .transfer
            .target()
            .map_or((0, 0), |(index, subindex, _)| (index, subindex));
        Abort::new(index, subindex, SdoAbortCode::InvalidCommandSpecifier)
    }

    fn init_download<A: ObjectAccess + ?Sized>(
        &mut self,
        target: Target,
        data: InitData<'_>,
        ctx: SdoContext<'_, A>,
    ) -> Result<SdoRepr<'static>, Abort> {
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
        let size = if complete {
            check_complete_download(ctx.od, index, subindex, declared)
        } else {
            check_download(&ctx, index, subindex, declared)
        }
        .map_err(|code| target.abort(code))?;
        if size <= payload.len() {
            let value = payload.get(..size).unwrap_or(&[]);
            store(ctx, target, value).map_err(|code| target.abort(code))?;
            return Ok(download_ack(target));
        }
        // Segmented: keep what came and wait for segments.
        let dst = self
            .buf
            .get_mut(..payload.len())
            .filter(|_| size <= BUF)
            .ok_or(target.abort(SdoAbortCode::OutOfMemory))?;
        dst.copy_from_slice(payload);
        self.transfer = Transfer::Download {
            index,
            subindex,
            complete,
            total: size,
            received: payload.len(),
            toggle: false,
            last_ms: ctx.now_ms,
        };
        Ok(download_ack(target))
    }

    fn download_segment<A: ObjectAccess + ?Sized>(
        &mut self,
        seg_toggle: bool,
        last: bool,
        segment: &[u8],
        ctx: SdoContext<'_, A>,
    ) -> Result<SdoRepr<'static>, Abort> {
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
            return Err(self.unexpected_segment());
        };
        let target = Target {
            index,
            subindex,
            complete,
        };
        if seg_toggle != toggle {
            return Err(target.abort(SdoAbortCode::ToggleBitNotAlternated));
        }
        let end = received + segment.len();
        if end > total {
            return Err(target.abort(SdoAbortCode::LengthTooHigh));
        }
        self.buf
            .get_mut(received..end)
            .ok_or(target.abort(SdoAbortCode::OutOfMemory))?
            .copy_from_slice(segment);
        let response = SdoRepr::DownloadSegmentResponse { toggle };
        if !last {
            self.transfer = Transfer::Download {
                index,
                subindex,
                complete,
                total,
                received: end,
                toggle: !toggle,
                last_ms: ctx.now_ms,
            };
            return Ok(response);
        }
        self.transfer = Transfer::Idle;
        if end < total {
            return Err(target.abort(SdoAbortCode::LengthTooLow));
        }
        let value = self.buf.get(..total).unwrap_or(&[]);
        store(ctx, target, value).map_err(|code| target.abort(code))?;
        Ok(response)
    }

    /// The initiate upload response in a frame of `room` bytes; a value that does not fit
    /// opens a segmented transfer.
    fn init_upload<A: ObjectAccess + ?Sized>(
        &mut self,
        target: Target,
        ctx: SdoContext<'_, A>,
        room: usize,
    ) -> Result<SdoRepr<'_>, Abort> {
        let now_ms = ctx.now_ms;
        let Target {
            index,
            subindex,
            complete,
        } = target;
        let read = if complete {
            match ctx.od.find(index) {
                Some(object) => {
                    complete::upload(object, subindex, ctx.app, ctx.state, &mut self.buf)
                }
                None => Err(SdoAbortCode::ObjectDoesNotExist),
            }
        } else {
            self.read_entry(ctx, index, subindex)
        };
        let n = read.map_err(|code| target.abort(code))?.min(BUF);
        let value = self.buf.get(..n).unwrap_or_default();
        // Room for data after the initiate header: none on CAN, the mailbox's on CoE.
        let room = room.saturating_sub(wire::sdo::HEADER_LEN);
        // Expedited with the exact size for 1..4 bytes; else normal, segmented if the
        // value does not fit the reply.
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
        Ok(SdoRepr::InitiateUploadResponse {
            index,
            sub_index: subindex,
            complete_access: complete,
            data,
        })
    }

    /// Access checks and read of a single entry into the transfer buffer.
    fn read_entry<A: ObjectAccess + ?Sized>(
        &mut self,
        ctx: SdoContext<'_, A>,
        index: u16,
        subindex: u8,
    ) -> Result<usize, SdoAbortCode> {
        let (_, entry) = ctx.od.entry(index, subindex)?;
        if !entry.access.is_readable() {
            return Err(SdoAbortCode::ReadOfWriteOnly);
        }
        if !entry.access.readable_in(ctx.state) {
            return Err(SdoAbortCode::DeviceState);
        }
        let cap = if entry.bit_len == 0 {
            BUF
        } else {
            entry.byte_len()
        };
        let buf = self.buf.get_mut(..cap).ok_or(SdoAbortCode::OutOfMemory)?;
        let n = ctx.app.read(index, subindex, buf)?;
        Ok(n.min(cap))
    }

    /// The next upload segment in a frame of `room` bytes.
    fn upload_segment(
        &mut self,
        seg_toggle: bool,
        now_ms: u32,
        room: usize,
    ) -> Result<SdoRepr<'_>, Abort> {
        let Transfer::Upload {
            index,
            subindex,
            total,
            sent,
            toggle,
            ..
        } = self.transfer
        else {
            return Err(self.unexpected_segment());
        };
        if seg_toggle != toggle {
            return Err(Abort::new(
                index,
                subindex,
                SdoAbortCode::ToggleBitNotAlternated,
            ));
        }
        // Room for segment data: 7 bytes on CAN, the mailbox's on CoE.
        let room = room.saturating_sub(wire::sdo::SEGMENT_HEADER_LEN);
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
        let data = self.buf.get(sent..sent + chunk).unwrap_or_default();
        Ok(SdoRepr::UploadSegmentResponse { toggle, last, data })
    }
}

fn download_ack(target: Target) -> SdoRepr<'static> {
    SdoRepr::InitiateDownloadResponse {
        index: target.index,
        sub_index: target.subindex,
        complete_access: target.complete,
    }
}

/// Access and size checks of a single-entry download; returns the value size.
fn check_download<A: ObjectAccess + ?Sized>(
    ctx: &SdoContext<'_, A>,
    index: u16,
    subindex: u8,
    declared: Option<usize>,
) -> Result<usize, SdoAbortCode> {
    let (_, entry) = ctx.od.entry(index, subindex)?;
    check_write_access(entry, ctx, index, subindex)?;
    let cap = entry.byte_len();
    let size = match declared {
        Some(size) => size,
        None if entry.data_type().is_variable_length() => 4.min(cap.max(1)),
        None if cap <= 4 => cap,
        None => return Err(SdoAbortCode::LengthMismatch),
    };
    if entry.data_type().is_variable_length() {
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
    ctx: &SdoContext<'_, A>,
    index: u16,
    subindex: u8,
) -> Result<(), SdoAbortCode> {
    let state = ctx.state;
    if !entry.access.is_writable() {
        return Err(SdoAbortCode::WriteOfReadOnly);
    }
    if !entry.access.writable_in(state) {
        return Err(SdoAbortCode::DeviceState);
    }
    if state == AlState::Op
        && entry.access.is_rx_mappable()
        && ctx.app.is_rx_mapped(index, subindex)
    {
        return Err(SdoAbortCode::MappedToRxPdo);
    }
    Ok(())
}

fn check_complete_download(
    od: &ObjectDictionary,
    index: u16,
    subindex: u8,
    declared: Option<usize>,
) -> Result<usize, SdoAbortCode> {
    let object = od.find(index).ok_or(SdoAbortCode::ObjectDoesNotExist)?;
    complete::check_start(object, subindex)?;
    Ok(declared.unwrap_or(4))
}

/// Writes a downloaded value: a single entry after the value checks, or a complete-access
/// image.
fn store<A: ObjectAccess + ?Sized>(
    ctx: SdoContext<'_, A>,
    target: Target,
    value: &[u8],
) -> Result<(), SdoAbortCode> {
    let SdoContext { state, od, app, .. } = ctx;
    let Target {
        index,
        subindex,
        complete,
    } = target;
    if complete {
        let object = od.find(index).ok_or(SdoAbortCode::ObjectDoesNotExist)?;
        return complete::download(object, subindex, value, app, state);
    }
    let (_, entry) = od.entry(index, subindex)?;
    check_value(entry, value)?;
    app.write(index, subindex, value, state)
}
