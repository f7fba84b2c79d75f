//! The FoE server (file access over EtherCAT, ETG.1000.6 5.8): the slave side of read and
//! write transfers, on the packets of [`crate::wire::foe`], with the files themselves behind
//! the caller's [`FileStore`] (the bootloader's flash writer, a test's memory).
//!
//! - Write: a write request (file name, password) goes to [`FileStore::open_write`]; the
//!   answer is ACK 0 or an error. DATA packets must come numbered 1, 2, ... (0x8005 otherwise);
//!   each goes to [`FileStore::write`] at its offset and is acknowledged with its number, or
//!   answered with BUSY (the master sends the same packet again later) or an error. A packet
//!   shorter than the mailbox allows ends the file: [`FileStore::finish_write`] checks it
//!   before the last ACK.
//! - Read: a read request goes to [`FileStore::open_read`]; DATA packets follow one per ACK
//!   of the previous one, from [`FileStore::read`], until a short (possibly empty) one.
//! - A transfer that sees no packet for [`FoeServer::set_timeout_ms`] (10 s by default) ends;
//!   a packet that continues it then gets an error. A new request ends the transfer in
//!   progress; an ERR from the master ends it without reply; leaving the state it ran in (an
//!   ESM transition) ends it. Every end but the good one calls [`FileStore::abort`].
//! - A packet that fits no transfer (DATA without a write, ACK without a read, BUSY) gets
//!   0x8004 "Illegal"; a packet too short for the FoE header or with an unknown op code gets a
//!   mailbox error reply (size too short, invalid header).
//!
//! The server never panics and answers every packet but an ERR.
//!
//! [`FoeMailbox`] is a mailbox that serves FoE only (the bootloader: counters, duplicate
//! drop and the repeat backup of [`crate::mailbox`]); a device with CoE and FoE serves both
//! through [`crate::sdo_server::SdoServer::process_with`] and [`FoeEndpoint`].

use crate::esm::AlState;
use crate::mailbox::{Incoming, MailboxErrorCode, MailboxProtocol, MailboxService, Reply};
use crate::wire::foe::{self, Foe, FoeErrorCode, FoeRepr};
use crate::wire::MailboxType;

/// Default time a transfer may wait for its next packet. Longer than the SDO server's: a
/// master may erase flash or read a file between two packets.
pub const DEFAULT_TIMEOUT_MS: u32 = 10_000;

/// An FoE error the server sends: the code and a text for the person reading the master's
/// log (ASCII; the code's standard text by default).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FoeError {
    /// Error code.
    pub code: FoeErrorCode,
    /// Error text.
    pub text: &'static str,
}

impl FoeError {
    /// The code with its standard text.
    pub const fn new(code: FoeErrorCode) -> Self {
        Self {
            code,
            text: code.text(),
        }
    }

    /// The code with a text of the caller's.
    pub const fn with_text(code: FoeErrorCode, text: &'static str) -> Self {
        Self { code, text }
    }

    /// The answer to a DATA packet outside a write (also what a slave that takes no file
    /// sends).
    pub const DATA_WITHOUT_WRITE: Self =
        Self::with_text(FoeErrorCode::Illegal, "DATA without a write in progress");
    /// The answer to an ACK packet outside a read.
    pub const ACK_WITHOUT_READ: Self =
        Self::with_text(FoeErrorCode::Illegal, "ACK without a read in progress");
    /// The answer to a BUSY packet: only a slave may be busy.
    pub const BUSY_FROM_MASTER: Self =
        Self::with_text(FoeErrorCode::Illegal, "BUSY from the master");
}

impl From<FoeErrorCode> for FoeError {
    fn from(code: FoeErrorCode) -> Self {
        Self::new(code)
    }
}

/// Why [`FileStore::write`] did not take a data packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WriteRefusal {
    /// Not now: the server answers BUSY with this progress and the master sends the same
    /// packet again.
    Busy {
        /// The part done.
        done: u16,
        /// The whole.
        entire: u16,
    },
    /// The transfer ends with this error.
    Error(FoeError),
}

impl From<FoeError> for WriteRefusal {
    fn from(e: FoeError) -> Self {
        Self::Error(e)
    }
}

/// The files an FoE server serves: the application's side of the transfers.
///
/// A store sees one transfer at a time: `open_*`, then `write`s or `read`s in order, then
/// `finish_write` (writes) or nothing (reads), or `abort` at any point after a successful
/// `open_*`.
pub trait FileStore {
    /// A master asks to write `name` (raw bytes, no NUL) with `password` in ESM state
    /// `state`. `Ok` accepts; data at offset 0 follows.
    fn open_write(&mut self, name: &[u8], password: u32, state: AlState) -> Result<(), FoeError>;

    /// The data of the next packet, at `offset` bytes into the file.
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), WriteRefusal>;

    /// The last packet has come: the file is `len` bytes. `Ok` makes the server send the
    /// last ACK; an error is sent instead of it.
    fn finish_write(&mut self, len: u32) -> Result<(), FoeError>;

    /// False for a store that only takes files: the server answers every read request
    /// "not found" itself and never reads (code that uses such a store has no read path).
    fn reads(&self) -> bool {
        true
    }

    /// A master asks to read `name` with `password` in `state`. The default: no file.
    fn open_read(&mut self, name: &[u8], password: u32, state: AlState) -> Result<(), FoeError> {
        let _ = (name, password, state);
        Err(FoeError::new(FoeErrorCode::NotFound))
    }

    /// Fills `out` from `offset` bytes into the file being read; returns the bytes written,
    /// fewer than `out.len()` at the end of the file.
    fn read(&mut self, offset: u32, out: &mut [u8]) -> Result<usize, FoeError> {
        let _ = (offset, out);
        Err(FoeError::new(FoeErrorCode::NotFound))
    }

    /// The transfer opened last ended without `finish_write` (error, timeout, a new
    /// request, the master's ERR, a state change, or the end of a read).
    fn abort(&mut self);
}

/// A transfer in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Transfer {
    Idle,
    Write {
        /// The packet number expected next.
        next: u32,
        /// Bytes received so far.
        offset: u32,
        last_ms: u32,
    },
    Read {
        /// The number of the last DATA packet sent.
        sent: u32,
        /// Offset of the next packet's data.
        offset: u32,
        /// The last packet sent was short: its ACK ends the transfer.
        last: bool,
        last_ms: u32,
    },
}

impl Transfer {
    const fn last_ms(&self) -> Option<u32> {
        match *self {
            Self::Idle => None,
            Self::Write { last_ms, .. } | Self::Read { last_ms, .. } => Some(last_ms),
        }
    }
}

/// The FoE server of one slave: the state of one transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FoeServer {
    transfer: Transfer,
    timeout_ms: u32,
}

impl Default for FoeServer {
    fn default() -> Self {
        Self::new()
    }
}

/// Bytes of the FoE packet's file data area in a whole mailbox buffer of `mailbox_len`.
pub const fn data_room(mailbox_len: usize) -> usize {
    mailbox_len.saturating_sub(foe::DATA_OVERHEAD)
}

impl FoeServer {
    /// No transfer, the default timeout.
    pub const fn new() -> Self {
        Self {
            transfer: Transfer::Idle,
            timeout_ms: DEFAULT_TIMEOUT_MS,
        }
    }

    /// Sets the time a transfer may wait for its next packet.
    pub fn set_timeout_ms(&mut self, timeout_ms: u32) {
        self.timeout_ms = timeout_ms;
    }

    /// True while a read or write is in progress.
    pub const fn busy(&self) -> bool {
        !matches!(self.transfer, Transfer::Idle)
    }

    /// An ESM transition ends any transfer (the state it was allowed in is gone).
    pub fn on_state_change<F: FileStore + ?Sized>(
        &mut self,
        from: AlState,
        to: AlState,
        files: &mut F,
    ) {
        if from != to {
            self.end(files);
        }
    }

    fn end<F: FileStore + ?Sized>(&mut self, files: &mut F) {
        if self.transfer != Transfer::Idle {
            self.transfer = Transfer::Idle;
            files.abort();
        }
    }

    /// Serves one FoE packet (`packet`: the mailbox payload of a type-4 frame) and writes the
    /// answer into `out` (the room after the mailbox header of the read mailbox).
    /// `request_mailbox_len` is the size of the write mailbox the packet came in: a DATA
    /// packet with fewer than `request_mailbox_len - 12` bytes is the last one.
    ///
    /// `Ok(Some(n))`: an FoE packet of `n` bytes to send; `Ok(None)`: nothing to send (the
    /// master's ERR, the ACK of a read's last packet); `Err(code)`: answer with a mailbox
    /// error (the packet is not FoE).
    pub fn process<F: FileStore + ?Sized>(
        &mut self,
        packet: &[u8],
        request_mailbox_len: usize,
        state: AlState,
        files: &mut F,
        now_ms: u32,
        out: &mut [u8],
    ) -> Result<Option<usize>, MailboxErrorCode> {
        let view = Foe::new_unchecked(packet);
        let repr = FoeRepr::parse(&view).map_err(|e| e.mailbox_error_code())?;
        let timed_out = self
            .transfer
            .last_ms()
            .is_some_and(|last| now_ms.wrapping_sub(last) > self.timeout_ms);
        if timed_out {
            self.end(files);
            if matches!(repr, FoeRepr::Data { .. } | FoeRepr::Ack { .. }) {
                return Ok(send(
                    out,
                    &FoeError::with_text(FoeErrorCode::NotDefined, "transfer timed out")
                        .into_repr(),
                ));
            }
        }
        let answer = match repr {
            FoeRepr::WriteRequest {
                password,
                file_name,
            } => {
                self.end(files);
                match files.open_write(file_name, password, state) {
                    Ok(()) => {
                        self.transfer = Transfer::Write {
                            next: 1,
                            offset: 0,
                            last_ms: now_ms,
                        };
                        FoeRepr::Ack { packet_number: 0 }
                    }
                    Err(e) => e.into_repr(),
                }
            }
            FoeRepr::ReadRequest {
                password,
                file_name,
            } => {
                self.end(files);
                if !files.reads() {
                    FoeError::new(FoeErrorCode::NotFound).into_repr()
                } else {
                    match files.open_read(file_name, password, state) {
                        Ok(()) => return Ok(self.read_packet(1, 0, files, now_ms, out)),
                        Err(e) => e.into_repr(),
                    }
                }
            }
            FoeRepr::Data {
                packet_number,
                data,
            } => {
                let room = data_room(request_mailbox_len);
                match self.data(packet_number, data, room, files, now_ms) {
                    Ok(answer) => answer,
                    Err(e) => {
                        self.end(files);
                        e.into_repr()
                    }
                }
            }
            FoeRepr::Ack { packet_number } => match self.transfer {
                Transfer::Read {
                    sent, offset, last, ..
                } if files.reads() && packet_number == sent => {
                    if last {
                        self.transfer = Transfer::Idle;
                        files.abort();
                        return Ok(None);
                    }
                    return Ok(self.read_packet(sent.wrapping_add(1), offset, files, now_ms, out));
                }
                Transfer::Read { .. } if files.reads() => {
                    self.end(files);
                    FoeError::new(FoeErrorCode::PacketNumberWrong).into_repr()
                }
                _ => {
                    self.end(files);
                    FoeError::ACK_WITHOUT_READ.into_repr()
                }
            },
            FoeRepr::Error { .. } => {
                // The master gives up: no answer.
                self.end(files);
                return Ok(None);
            }
            FoeRepr::Busy { .. } => {
                self.end(files);
                FoeError::BUSY_FROM_MASTER.into_repr()
            }
        };
        Ok(send(out, &answer))
    }

    /// A DATA packet of a write.
    fn data<F: FileStore + ?Sized>(
        &mut self,
        number: u32,
        data: &[u8],
        room: usize,
        files: &mut F,
        now_ms: u32,
    ) -> Result<FoeRepr<'static>, FoeError> {
        let Transfer::Write { next, offset, .. } = self.transfer else {
            return Err(FoeError::DATA_WITHOUT_WRITE);
        };
        if number != next {
            return Err(FoeError::new(FoeErrorCode::PacketNumberWrong));
        }
        if data.len() > room {
            return Err(FoeError::with_text(
                FoeErrorCode::Illegal,
                "DATA longer than the mailbox",
            ));
        }
        let end = u32::try_from(data.len())
            .ok()
            .and_then(|n| offset.checked_add(n))
            .ok_or(FoeError::new(FoeErrorCode::DiskFull))?;
        match files.write(offset, data) {
            Ok(()) => {}
            Err(WriteRefusal::Busy { done, entire }) => {
                // The same packet comes again.
                self.transfer = Transfer::Write {
                    next,
                    offset,
                    last_ms: now_ms,
                };
                return Ok(FoeRepr::Busy {
                    done,
                    entire,
                    text: &[],
                });
            }
            Err(WriteRefusal::Error(e)) => return Err(e),
        }
        if data.len() < room {
            files.finish_write(end)?;
            self.transfer = Transfer::Idle;
        } else {
            self.transfer = Transfer::Write {
                next: next.wrapping_add(1),
                offset: end,
                last_ms: now_ms,
            };
        }
        Ok(FoeRepr::Ack {
            packet_number: number,
        })
    }

    /// DATA packet `number` of a read, from `offset`.
    fn read_packet<F: FileStore + ?Sized>(
        &mut self,
        number: u32,
        offset: u32,
        files: &mut F,
        now_ms: u32,
        out: &mut [u8],
    ) -> Option<usize> {
        let room = out.len().saturating_sub(foe::HEADER_LEN);
        let Some(area) = out.get_mut(foe::HEADER_LEN..) else {
            self.end(files);
            return None;
        };
        let read = files.read(offset, area).and_then(|n| {
            let n = n.min(room);
            u32::try_from(n)
                .ok()
                .and_then(|len| offset.checked_add(len))
                .map(|next| (n, next))
                .ok_or(FoeError::new(FoeErrorCode::ProgramError))
        });
        let (n, next) = match read {
            Ok(r) => r,
            Err(e) => {
                self.end(files);
                return send(out, &e.into_repr());
            }
        };
        self.transfer = Transfer::Read {
            sent: number,
            offset: next,
            last: n < room,
            last_ms: now_ms,
        };
        // The data is in place already; only the header goes in front.
        let mut view = Foe::new_unchecked(&mut *out);
        view.set_op_code(foe::FoeOpCode::Data);
        view.set_reserved(0);
        view.set_word(number);
        Some(foe::HEADER_LEN + n)
    }
}

impl FoeError {
    /// The error packet.
    pub const fn into_repr(self) -> FoeRepr<'static> {
        FoeRepr::Error {
            code: self.code,
            text: self.text.as_bytes(),
        }
    }
}

/// Writes `answer` into `out`; an error text that does not fit is shortened.
fn send(out: &mut [u8], answer: &FoeRepr<'_>) -> Option<usize> {
    let room = out.len().saturating_sub(foe::HEADER_LEN);
    let answer = match *answer {
        FoeRepr::Error { code, text } => FoeRepr::Error {
            code,
            text: text.get(..room).unwrap_or(text),
        },
        other => other,
    };
    answer.emit(&mut Foe::new_unchecked(out)).ok()?;
    Some(answer.buffer_len())
}

/// An [`FoeServer`] with the [`FileStore`] it serves, as a protocol beside CoE
/// ([`crate::sdo_server::SdoServer::process_with`]).
pub struct FoeEndpoint<'a, F: FileStore + ?Sized> {
    /// The server.
    pub server: &'a mut FoeServer,
    /// Its files.
    pub files: &'a mut F,
}

impl<F: FileStore + ?Sized> MailboxProtocol for FoeEndpoint<'_, F> {
    fn serves(&self, mailbox_type: MailboxType) -> bool {
        mailbox_type == MailboxType::Foe
    }

    fn serve(
        &mut self,
        payload: &[u8],
        request_len: usize,
        state: AlState,
        now_ms: u32,
        out: &mut [u8],
    ) -> Result<Option<(MailboxType, usize)>, MailboxErrorCode> {
        self.server
            .process(payload, request_len, state, self.files, now_ms, out)
            .map(|n| n.map(|n| (MailboxType::Foe, n)))
    }
}

/// A mailbox that serves FoE only (a bootloader): the mailbox layer (header checks with
/// mailbox error replies, counters and duplicates, the repeat backup) around an
/// [`FoeServer`]. `MBX` is the largest frame kept for the repeat request.
#[derive(Debug, Clone)]
pub struct FoeMailbox<const MBX: usize> {
    mailbox: MailboxService<MBX, 0>,
    server: FoeServer,
}

impl<const MBX: usize> Default for FoeMailbox<MBX> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const MBX: usize> FoeMailbox<MBX> {
    /// Nothing in progress.
    pub const fn new() -> Self {
        Self {
            mailbox: MailboxService::new(),
            server: FoeServer::new(),
        }
    }

    /// The FoE server.
    pub fn server(&self) -> &FoeServer {
        &self.server
    }

    /// The FoE server, to set its timeout.
    pub fn server_mut(&mut self) -> &mut FoeServer {
        &mut self.server
    }

    /// The mailbox service.
    pub fn mailbox(&self) -> &MailboxService<MBX, 0> {
        &self.mailbox
    }

    /// Serves one received frame (the whole write-mailbox content) and writes the reply
    /// frame into `reply` (the read mailbox size). CoE and every other protocol get the
    /// mailbox error "unsupported protocol".
    pub fn process<F: FileStore + ?Sized>(
        &mut self,
        request: &[u8],
        state: AlState,
        files: &mut F,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        let limit = reply.len().min(MBX);
        let Some(reply) = reply.get_mut(..limit) else {
            return Reply::None;
        };
        let mut endpoint = FoeEndpoint {
            server: &mut self.server,
            files,
        };
        match self.mailbox.receive(request) {
            Incoming::Duplicate => Reply::None,
            Incoming::Error(code) => self.mailbox.send_error(reply, code),
            Incoming::Coe(..) => self
                .mailbox
                .send_error(reply, MailboxErrorCode::UnsupportedProtocol),
            Incoming::Other(mailbox_type, payload) => self.mailbox.serve_other(
                &mut endpoint,
                mailbox_type,
                payload,
                request.len(),
                state,
                now_ms,
                reply,
            ),
        }
    }

    /// Writes the last frame again (the repeat request of SM1).
    pub fn repeat(&self, reply: &mut [u8]) -> Reply {
        self.mailbox.repeat(reply)
    }

    /// Applies an ESM transition: INIT -> PREOP or INIT -> BOOT resets the counters; any
    /// change ends a transfer.
    pub fn on_state_change<F: FileStore + ?Sized>(
        &mut self,
        from: AlState,
        to: AlState,
        files: &mut F,
    ) {
        self.mailbox.on_state_change(from, to);
        self.server.on_state_change(from, to, files);
    }
}

#[cfg(test)]
mod tests;
