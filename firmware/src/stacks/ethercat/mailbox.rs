//! The mailbox link: SM0 (master -> slave) -> a mailbox server -> SM1 (slave -> master),
//! with the ESC's mailbox handshakes (ESC datasheet section I 8.5/8.6). The server is the
//! application's ([`AppServer`]: coe-core's SDO server, with FoE beside it answering
//! "bootstrap only") or the bootloader's (coe-core's FoE mailbox on the bootstrap mailbox,
//! `crate::stacks::ethercat::boot_slave`): one link, one set of handshakes, for both ([`MailboxServer`]).
//!
//! - A request is read when SM0 is full (AL event bit 8, or SM0 status b3 when polled) and
//!   no reply is waiting. The ESC opens a mailbox buffer on the access to its first byte and
//!   frees it on the access to its last byte, whatever lies between (hardware-facts 1.3/1.5,
//!   ESC-I 8), so only what carries data crosses the PDI: the header and an expedited SDO
//!   in one read from the start, the rest of the header's length if longer, then the last
//!   byte ([`read_request`]). While a reply waits, SM0 stays full (the master cannot send
//!   another request) and its event is masked ([`MailboxLink::event_mask`]).
//! - A reply is written the same way: the frame from the start, then the last byte, which
//!   marks SM1 full ([`write_frame`]); the master reads the length from the header. If SM1
//!   is still full (the master has not read the last one), the reply waits and goes out on
//!   the SM1 event (bit 9: the master read SM1) or the next poll.
//! - With nothing waiting, the server's pending work goes out: SDO Information fragments,
//!   then queued Emergencies.
//! - Repeat request: when SM1 activate b1 differs from PDI control b1, the last frame (the
//!   server's backup) is written again (SM1 emptied first through PDI control b0 if it is
//!   full) and PDI control b1 is set to the request's value. If SM1 was read and a new
//!   request waits in SM0, that request's reply answers the repeat instead: SOEM asks for a
//!   repeat after an Emergency it has read and dropped.
//! - INIT -> PREOP starts the mailbox ([`MailboxLink::start`]): a frame left in SM0 or SM1
//!   from before INIT answers nothing and is dropped, the repeat acknowledge takes SM1's
//!   repeat request bit (so a toggle state left by the master is not taken for a repeat
//!   request), and the server's counters and backup are reset. Any state change to INIT
//!   drops a waiting reply.
//! - The mailbox is served when the AL event bits (which every PDI access returns) say it
//!   changed, or work waits ([`MailboxLink::needs_service`]); the SM1 event (IntR: the
//!   master read the last byte) is the only way SM1 empties, and it stays set until the next
//!   write, so seeing it means SM1 is free; the SM0 event (IntW) means a request is in.
//!   Served that way ([`Service::Events`]) the SyncManager registers are not read: start,
//!   length and enable come from their last reading, which happens at INIT -> PREOP, on the
//!   SM activation event (the master changed a SyncManager; also the repeat request) and in
//!   the periodic safety service ([`SAFETY_SERVICE_MS`], [`Service::Registers`]), which
//!   catches anything the events missed.

use crate::platform::boot::staging::{is_firmware_name, BOOT_ONLY};
use coe_core::device::sm_control;
use coe_core::foe::FoeError;
use coe_core::mailbox::{MailboxErrorCode, MailboxProtocol, MAILBOX_HEADER_LEN};
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::sdo_server::{Emergency, Reply, SdoServer};
use coe_core::wire::foe::{self, Foe, FoeErrorCode, FoeRepr};
use coe_core::wire::MailboxType;
use coe_core::AlState;
use et1100::{AlEvents, Et1100, Pdi, PdiResult, SyncManager};

/// Mailbox size (SM0 and SM1 length).
pub const MAILBOX_SIZE: usize = 128;
/// Largest object transferred in several frames (segmented SDO, complete access).
pub const TRANSFER_BUFFER: usize = 512;
/// Emergencies that can wait for the mailbox.
pub const EMERGENCY_QUEUE: usize = 4;

/// Bytes of a request read in the first access: the mailbox header and an expedited SDO
/// (CoE header, command, index, subindex, 4 data bytes).
pub const FIRST_READ: usize = MAILBOX_HEADER_LEN + 10;

/// Interval of the unconditional mailbox service from the background poll: a backstop that
/// re-reads the SyncManager registers (a master that re-enables a mailbox SyncManager
/// raises the SM activation event, which the IRQ serves at once; this catches anything else).
pub const SAFETY_SERVICE_MS: u32 = 100;

/// Interval of the background poll's own AL event sample (a NOP access) when no inputs
/// write brought the event bits: a mailbox event whose IRQ the PDI task did not see is
/// served within this time.
pub const EVENT_SAMPLE_MS: u32 = 1;

/// The SDO server of the module.
pub type Server = SdoServer<MAILBOX_SIZE, TRANSFER_BUFFER, EMERGENCY_QUEUE>;

/// What a [`MailboxLink`] serves: every request it reads, and the frames that wait for a
/// free SM1.
pub trait MailboxServer {
    /// What the server works on besides the frames (the application's objects, the
    /// bootloader's file store), borrowed for one call.
    type Context<'a>: ?Sized;

    /// Serves one request (the whole SM0 content) into `reply` (the read mailbox size).
    fn process(
        &mut self,
        ctx: &mut Self::Context<'_>,
        request: &[u8],
        state: AlState,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply;

    /// A frame that waits for SM1 (fragments, Emergencies), if any.
    fn poll(&mut self, ctx: &mut Self::Context<'_>, reply: &mut [u8]) -> Reply;

    /// The last frame again (the repeat request).
    fn repeat(&self, reply: &mut [u8]) -> Reply;

    /// True if [`MailboxServer::poll`] has a frame.
    fn has_outgoing(&self) -> bool;

    /// An ESM transition.
    fn on_state_change(&mut self, ctx: &mut Self::Context<'_>, from: AlState, to: AlState);
}

/// FoE in the application: a firmware file (`*.efw`) is written in BOOT, where the
/// bootloader serves it; here every FoE packet is refused, so no transfer ever starts and
/// nothing is kept between packets (a stateless answer instead of coe-core's `FoeServer`
/// with a file store that refuses everything, whose answers a host test compares with
/// these): a write of a firmware file is "bootstrap only" (0x8008), any other write and
/// every read "not found", DATA, ACK and BUSY without a transfer "illegal", an ERR from the
/// master has no answer.
pub struct BootOnlyFoe;

impl BootOnlyFoe {
    /// The error a packet gets, `None` for the master's ERR.
    fn refusal(packet: &FoeRepr<'_>) -> Option<FoeError> {
        Some(match packet {
            FoeRepr::WriteRequest { file_name, .. } if is_firmware_name(file_name) => BOOT_ONLY,
            FoeRepr::WriteRequest { .. } | FoeRepr::ReadRequest { .. } => NOT_FOUND,
            FoeRepr::Data { .. } => FoeError::DATA_WITHOUT_WRITE,
            FoeRepr::Ack { .. } => FoeError::ACK_WITHOUT_READ,
            FoeRepr::Busy { .. } => FoeError::BUSY_FROM_MASTER,
            FoeRepr::Error { .. } => return None,
        })
    }
}

/// "Not found" with its standard text (a constant: only this code's text is kept).
const NOT_FOUND: FoeError = FoeError::new(FoeErrorCode::NotFound);

impl MailboxProtocol for BootOnlyFoe {
    fn serves(&self, mailbox_type: MailboxType) -> bool {
        mailbox_type == MailboxType::Foe
    }

    fn serve(
        &mut self,
        payload: &[u8],
        _: usize,
        _: AlState,
        _: u32,
        out: &mut [u8],
    ) -> Result<Option<(MailboxType, usize)>, MailboxErrorCode> {
        let packet =
            FoeRepr::parse(&Foe::new_unchecked(payload)).map_err(|e| e.mailbox_error_code())?;
        let Some(FoeError { code, text }) = Self::refusal(&packet) else {
            return Ok(None);
        };
        // A text that does not fit is shortened.
        let room = out.len().saturating_sub(foe::HEADER_LEN);
        let text = text.as_bytes();
        let answer = FoeRepr::Error {
            code,
            text: text.get(..room).unwrap_or(text),
        };
        if answer.emit(&mut Foe::new_unchecked(&mut *out)).is_err() {
            return Ok(None);
        }
        Ok(Some((MailboxType::Foe, answer.buffer_len())))
    }
}

/// The application's server: the SDO server on the dictionary `od`, FoE on the same
/// mailbox beside it ([`BootOnlyFoe`]).
pub struct AppServer {
    od: &'static ObjectDictionary,
    sdo: Server,
}

impl AppServer {
    /// Nothing in progress.
    pub const fn new(od: &'static ObjectDictionary) -> Self {
        Self {
            od,
            sdo: SdoServer::new(),
        }
    }

    /// The SDO server.
    pub fn sdo(&self) -> &Server {
        &self.sdo
    }
}

impl MailboxServer for AppServer {
    /// The dictionary's objects, as `dyn`: the SDO machine exists once in the image, for
    /// this mailbox and the CAN node's SDO server alike.
    type Context<'a> = dyn ObjectAccess + 'a;

    fn process(
        &mut self,
        objects: &mut (dyn ObjectAccess + '_),
        request: &[u8],
        state: AlState,
        now_ms: u32,
        reply: &mut [u8],
    ) -> Reply {
        self.sdo.process_with(
            request,
            state,
            self.od,
            objects,
            now_ms,
            reply,
            &mut BootOnlyFoe,
        )
    }

    fn poll(&mut self, _: &mut (dyn ObjectAccess + '_), reply: &mut [u8]) -> Reply {
        self.sdo.poll(self.od, reply)
    }

    fn repeat(&self, reply: &mut [u8]) -> Reply {
        self.sdo.repeat(reply)
    }

    fn has_outgoing(&self) -> bool {
        self.sdo.has_outgoing()
    }

    // Cold: one copy for the AL control and the local error paths.
    #[inline(never)]
    fn on_state_change(&mut self, _: &mut (dyn ObjectAccess + '_), from: AlState, to: AlState) {
        self.sdo.on_state_change(from, to);
    }
}

/// A mailbox SyncManager as a master configured it, against the window and control byte
/// the device description gives it: enabled, same start and length, same control byte apart
/// from the ECAT IRQ bit (b4), which masters set as they like.
pub fn mailbox_sm_ok(sm: &SyncManager, start: u16, len: u16, control: u8) -> bool {
    sm.enabled()
        && sm.start == start
        && sm.length == len
        && (sm.control & !sm_control::ECAT_IRQ) == (control & !sm_control::ECAT_IRQ)
}

/// How [`MailboxLink::service`] learns the mailbox state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Service {
    /// From the SyncManager registers (SM activation event, safety service), with the
    /// repeat-request check if `check_repeat`.
    Registers {
        /// Compare SM1's repeat request with its acknowledge.
        check_repeat: bool,
    },
    /// From these AL event bits, just seen, and the registers as last read (falls back to
    /// [`Service::Registers`] if they were never read).
    Events(AlEvents),
}

/// Mailbox service state: the link of a mailbox of `MBX` bytes (each direction) to the
/// server `S`.
pub struct MailboxLink<S, const MBX: usize> {
    server: S,
    buf: [u8; MBX],
    pending: usize,
    blocked: bool,
    sm1_busy: bool,
    registers: Option<(SyncManager, SyncManager)>,
    replies: u32,
    repeats: u32,
}

/// The application's link.
pub type AppLink = MailboxLink<AppServer, MAILBOX_SIZE>;

impl AppLink {
    /// The application's link on the dictionary `od`, nothing pending.
    pub const fn for_dictionary(od: &'static ObjectDictionary) -> Self {
        Self::new(AppServer::new(od))
    }

    /// Queues an Emergency (sent when SM1 is free).
    pub fn queue_emergency(&mut self, emergency: Emergency) {
        self.server.sdo.queue_emergency(emergency);
    }
}

impl<S: MailboxServer, const MBX: usize> MailboxLink<S, MBX> {
    /// Nothing pending.
    pub const fn new(server: S) -> Self {
        Self {
            server,
            buf: [0; MBX],
            pending: 0,
            blocked: false,
            sm1_busy: false,
            registers: None,
            replies: 0,
            repeats: 0,
        }
    }

    /// The server.
    pub fn server(&self) -> &S {
        &self.server
    }

    /// True while a reply waits for SM1.
    pub const fn reply_pending(&self) -> bool {
        self.pending != 0
    }

    /// Frames written to SM1 (replies, fragments, Emergencies, repeats).
    pub const fn frames_sent(&self) -> u32 {
        self.replies
    }

    /// Repeat requests served.
    pub const fn repeats(&self) -> u32 {
        self.repeats
    }

    /// The mailbox AL event bits to enable: SM0 while no reply waits, SM1 while one does
    /// or while a request waits in SM0 for SM1 to be read, or other frames wait for SM1.
    pub fn event_mask(&self) -> AlEvents {
        if self.pending != 0 || self.blocked || (self.sm1_busy && self.has_outgoing()) {
            AlEvents::SM1
        } else {
            AlEvents::SM0
        }
    }

    /// True while the last frame written to SM1 has not been seen read by the master.
    pub const fn sm1_busy(&self) -> bool {
        self.sm1_busy
    }

    /// Frames the server would send once SM1 is free (SDO Information fragments,
    /// Emergencies).
    fn has_outgoing(&self) -> bool {
        self.server.has_outgoing()
    }

    /// Takes note of the AL event bits of an access and tells whether [`Self::service`]
    /// has work: a request in SM0 (bit 8) or a frame to send, with SM1 free (bit 9 seen
    /// since the last write, or never written). A request that must wait for SM1 sets the
    /// SM1 event mask ([`Self::event_mask`]).
    pub fn needs_service(&mut self, events: AlEvents) -> bool {
        if events.contains(AlEvents::SM1) {
            self.sm1_busy = false;
        }
        let request = events.contains(AlEvents::SM0);
        if self.sm1_busy {
            if request && self.pending == 0 {
                self.blocked = true;
            }
            return false;
        }
        request || self.pending != 0 || self.blocked || self.has_outgoing()
    }

    /// ESM transition.
    pub fn on_state_change(&mut self, ctx: &mut S::Context<'_>, from: AlState, to: AlState) {
        self.server.on_state_change(ctx, from, to);
        if to == AlState::Init {
            self.pending = 0;
            self.blocked = false;
            self.sm1_busy = false;
            self.registers = None;
        }
    }

    /// Starts the mailbox on the SM0 and SM1 registers as just read and checked
    /// (INIT -> PREOP; SOES does the same in `ESC_startmbx`). A frame in either buffer is
    /// from before INIT and answers nothing: the PDI side deactivates that SyncManager for a
    /// moment, which empties its buffer. The repeat acknowledge (SM1 PDI control b1) is set
    /// to SM1's repeat request bit: the master may have rewritten the SyncManager with
    /// another toggle state, and the difference is not a repeat request.
    pub fn start<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        sm0: SyncManager,
        sm1: SyncManager,
    ) -> PdiResult<(), P> {
        if sm0.mailbox_full() {
            esc.sm_pdi_control(0, SyncManager::PDI_DEACTIVATE)?;
            esc.sm_pdi_control(0, 0)?;
        }
        let ack = sm1.requested_repeat_ack();
        if sm1.mailbox_full() {
            esc.sm_pdi_control(1, ack | SyncManager::PDI_DEACTIVATE)?;
        }
        if sm1.mailbox_full() || sm1.pdi_control & SyncManager::PDI_REPEAT_ACK != ack {
            esc.sm_pdi_control(1, ack)?;
        }
        let empty = |sm: SyncManager| SyncManager {
            status: sm.status & !SyncManager::STATUS_MAILBOX_FULL,
            pdi_control: sm.pdi_control & !SyncManager::PDI_REPEAT_ACK | ack,
            ..sm
        };
        self.registers = Some((empty(sm0), empty(sm1)));
        self.pending = 0;
        self.blocked = false;
        self.sm1_busy = false;
        Ok(())
    }

    /// Serves the mailbox: repeat request (if asked), waiting reply, a new request if SM0 is
    /// full, then the server's pending work. At most one request per call.
    pub fn service<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        state: AlState,
        ctx: &mut S::Context<'_>,
        now_ms: u32,
        how: Service,
    ) -> PdiResult<(), P> {
        if state == AlState::Init {
            return Ok(());
        }
        let (sm0, sm1, mut sm1_full, sm0_full) = match (how, self.registers) {
            (Service::Events(events), Some((sm0, sm1))) => {
                let request = events.contains(AlEvents::SM0) || self.blocked;
                (sm0, sm1, self.sm1_busy, request)
            }
            (how, _) => {
                let (sm0, sm1) = esc.read_sm_pair(0)?;
                let check_repeat = how == Service::Registers { check_repeat: true };
                if check_repeat && sm1.repeat_requested() {
                    if sm1.mailbox_full() || !sm0.mailbox_full() {
                        self.repeat(esc, &sm1)?;
                        return Ok(());
                    }
                    // SM1 was read and a new request waits: the master has moved on, and
                    // the frame it asks for again was one it did not ask for. SOEM drops an
                    // Emergency it reads, reads SM1 again at once and takes the empty
                    // mailbox for a lost frame; repeating that frame would start the same
                    // race again. The new request's reply answers the repeat.
                    esc.sm_pdi_control(1, sm1.requested_repeat_ack())?;
                    self.repeats = self.repeats.wrapping_add(1);
                }
                self.registers = Some((sm0, sm1));
                (sm0, sm1, sm1.mailbox_full(), sm0.mailbox_full())
            }
        };
        self.sm1_busy = sm1_full;
        self.blocked = false;
        if self.pending != 0 {
            if sm1_full {
                return Ok(());
            }
            self.flush(esc, &sm1)?;
            sm1_full = true;
        }
        if !sm1_full {
            if sm0_full && sm0.enabled() {
                let len = usize::from(sm0.length).min(MBX);
                let mut request = [0u8; MBX];
                let req = request.get_mut(..len).unwrap_or(&mut []);
                read_request(esc, sm0.start, req)?;
                let reply_len = usize::from(sm1.length).min(MBX);
                self.buf = [0; MBX];
                let out = self.buf.get_mut(..reply_len).unwrap_or(&mut []);
                if let Reply::Frame(n) = self.server.process(ctx, req, state, now_ms, out) {
                    self.pending = n.max(1);
                    self.flush(esc, &sm1)?;
                    return Ok(());
                }
            }
            self.send_background(esc, ctx, &sm1)?;
        } else if self.pending == 0 {
            // A request may wait in SM0 until the master has read SM1.
            self.blocked = sm0_full;
        }
        Ok(())
    }

    fn send_background<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        ctx: &mut S::Context<'_>,
        sm1: &SyncManager,
    ) -> PdiResult<(), P> {
        let reply_len = usize::from(sm1.length).min(MBX);
        self.buf = [0; MBX];
        let out = self.buf.get_mut(..reply_len).unwrap_or(&mut []);
        if let Reply::Frame(n) = self.server.poll(ctx, out) {
            self.pending = n.max(1);
            self.flush(esc, sm1)?;
        }
        Ok(())
    }

    /// Writes the waiting reply as the whole SM1 buffer.
    fn flush<P: Pdi>(&mut self, esc: &mut Et1100<P>, sm1: &SyncManager) -> PdiResult<(), P> {
        let len = usize::from(sm1.length).min(MBX);
        let frame = self.buf.get(..len).unwrap_or(&[]);
        write_frame(esc, sm1.start, frame, self.pending)?;
        self.pending = 0;
        self.sm1_busy = true;
        self.replies = self.replies.wrapping_add(1);
        Ok(())
    }

    fn repeat<P: Pdi>(&mut self, esc: &mut Et1100<P>, sm1: &SyncManager) -> PdiResult<(), P> {
        let ack = sm1.pdi_control & SyncManager::PDI_REPEAT_ACK;
        // Empty now, or emptied below.
        self.sm1_busy = false;
        if sm1.mailbox_full() {
            // Empty SM1 by deactivating it from the PDI side, then activate it again.
            esc.sm_pdi_control(1, ack | SyncManager::PDI_DEACTIVATE)?;
            esc.sm_pdi_control(1, ack)?;
        }
        let len = usize::from(sm1.length).min(MBX);
        let mut frame = [0u8; MBX];
        let out = frame.get_mut(..len).unwrap_or(&mut []);
        if let Some(n) = self.server.repeat(out).frame_len() {
            write_frame(esc, sm1.start, out, n)?;
            self.sm1_busy = true;
            self.replies = self.replies.wrapping_add(1);
        }
        esc.sm_pdi_control(1, sm1.requested_repeat_ack())?;
        self.repeats = self.repeats.wrapping_add(1);
        Ok(())
    }
}

/// Reads a request from the SM0 buffer `req.len()` long at `start`: [`FIRST_READ`] bytes,
/// then the rest of the header's length if it is longer, then the last byte, which frees the
/// buffer. Bytes beyond the header's length (not read) are left as they are in `req`;
/// whole-buffer reads when the frame fills it anyway.
pub fn read_request<P: Pdi>(esc: &mut Et1100<P>, start: u16, req: &mut [u8]) -> PdiResult<(), P> {
    let len = req.len();
    if len <= FIRST_READ + 1 {
        return esc.read(start, req).map(drop);
    }
    let (head, rest) = req.split_at_mut(FIRST_READ);
    esc.read(start, head)?;
    let declared = MAILBOX_HEADER_LEN + usize::from(u16::from_le_bytes([head[0], head[1]]));
    // `rest` is non-empty: len > FIRST_READ + 1.
    let last = rest.len() - 1;
    let more = declared.saturating_sub(FIRST_READ);
    let at = |o: usize| start.wrapping_add((FIRST_READ + o) as u16);
    if more >= last {
        return esc.read(at(0), rest).map(drop);
    }
    if let Some(middle) = rest.get_mut(..more).filter(|m| !m.is_empty()) {
        esc.read(at(0), middle)?;
    }
    esc.read(at(last), rest.get_mut(last..).unwrap_or(&mut []))
        .map(drop)
}

/// Writes the first `n` bytes of `frame` (a whole SM1 buffer) at `start`, then its last
/// byte, which marks the mailbox full; one access when the frame fills the buffer anyway.
pub fn write_frame<P: Pdi>(
    esc: &mut Et1100<P>,
    start: u16,
    frame: &[u8],
    n: usize,
) -> PdiResult<(), P> {
    let len = frame.len();
    let n = n.max(1);
    if n + 1 >= len {
        return esc.write(start, frame).map(drop);
    }
    esc.write(start, frame.get(..n).unwrap_or(&[]))?;
    esc.write(
        start.wrapping_add((len - 1) as u16),
        frame.get(len - 1..).unwrap_or(&[]),
    )
    .map(drop)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fake_esc::FakeEsc;
    use coe_core::foe::{FileStore, FoeEndpoint, FoeServer, WriteRefusal};
    use std::vec::Vec;

    /// The file store of an application that takes no file: a firmware file is "bootstrap
    /// only", any other name "not found" (what [`BootOnlyFoe`] answers without a server).
    struct RefuseAll;

    impl FileStore for RefuseAll {
        fn open_write(&mut self, name: &[u8], _: u32, _: AlState) -> Result<(), FoeError> {
            Err(if is_firmware_name(name) {
                BOOT_ONLY
            } else {
                FoeError::new(FoeErrorCode::NotFound)
            })
        }

        fn write(&mut self, _: u32, _: &[u8]) -> Result<(), WriteRefusal> {
            Err(FoeError::new(FoeErrorCode::Illegal).into())
        }

        fn finish_write(&mut self, _: u32) -> Result<(), FoeError> {
            Err(FoeError::new(FoeErrorCode::Illegal))
        }

        fn abort(&mut self) {}
    }

    fn packet(repr: FoeRepr<'_>) -> Vec<u8> {
        let mut buf = std::vec![0u8; repr.buffer_len()];
        repr.emit(&mut Foe::new_unchecked(&mut buf[..])).unwrap();
        buf
    }

    #[test]
    fn foe_answers_are_the_servers_with_a_store_that_refuses_everything() {
        let packets = [
            packet(FoeRepr::WriteRequest {
                password: 0,
                file_name: b"analog-io.efw",
            }),
            packet(FoeRepr::WriteRequest {
                password: 7,
                file_name: b"notes.txt",
            }),
            packet(FoeRepr::ReadRequest {
                password: 0,
                file_name: b"analog-io.efw",
            }),
            packet(FoeRepr::Data {
                packet_number: 1,
                data: &[1, 2, 3],
            }),
            packet(FoeRepr::Ack { packet_number: 1 }),
            packet(FoeRepr::Busy {
                done: 1,
                entire: 2,
                text: b"",
            }),
            packet(FoeRepr::Error {
                code: FoeErrorCode::NotDefined,
                text: b"stop",
            }),
            std::vec![2, 0, 0],
            std::vec![9, 0, 0, 0, 0, 0],
            Vec::new(),
        ];
        let mut server = FoeServer::new();
        let mut checked = 0;
        // Room for every text, for a shortened one, for the header only, for less.
        for room in [122, 16, foe::HEADER_LEN, 3] {
            for (n, p) in packets.iter().enumerate() {
                let (mut want, mut got) = ([0xAAu8; 122], [0xAAu8; 122]);
                let now_ms = 1_000 * n as u32;
                let expected = FoeEndpoint {
                    server: &mut server,
                    files: &mut RefuseAll,
                }
                .serve(p, 128, AlState::PreOp, now_ms, &mut want[..room]);
                let answer = BootOnlyFoe.serve(p, 128, AlState::PreOp, now_ms, &mut got[..room]);
                assert_eq!(answer, expected, "packet {n}, room {room}");
                assert_eq!(got, want, "packet {n}, room {room}");
                assert!(!server.busy(), "no transfer starts");
                checked += usize::from(matches!(answer, Ok(Some(_))));
            }
        }
        assert!(checked >= 12, "most packets have an answer");
    }

    const OUT: u16 = 0x1000;
    const IN: u16 = 0x1080;

    fn esc() -> FakeEsc {
        let mut esc = FakeEsc::new();
        esc.master_sm(0, OUT, 128, 0x26, true);
        esc.master_sm(1, IN, 128, 0x22, true);
        esc
    }

    /// A frame with `payload` bytes 1, 2, 3, ... after the header; the rest of the buffer 0xEE.
    fn frame(declared: u16, payload: usize) -> [u8; MAILBOX_SIZE] {
        let mut f = [0xEE; MAILBOX_SIZE];
        f[..2].copy_from_slice(&declared.to_le_bytes());
        f[2..6].fill(0);
        for (i, b) in f[6..6 + payload].iter_mut().enumerate() {
            *b = i as u8 + 1;
        }
        f
    }

    fn read(esc: &mut FakeEsc, f: &[u8; MAILBOX_SIZE]) -> ([u8; MAILBOX_SIZE], usize) {
        assert!(esc.master_write_mailbox(f));
        let reads = esc.reads;
        let mut req = [0u8; MAILBOX_SIZE];
        read_request(&mut esc.driver(), OUT, &mut req).unwrap();
        assert!(
            !FakeEsc::sm(esc, 0).mailbox_full(),
            "the last byte frees SM0"
        );
        (req, esc.reads - reads)
    }

    #[test]
    fn requests_read_header_length_and_last_byte_only() {
        let mut esc = esc();
        // Expedited SDO: the first read and the last byte.
        let f = frame(10, 10);
        let (req, reads) = read(&mut esc, &f);
        assert_eq!(reads, 2);
        assert_eq!(req[..16], f[..16]);
        assert_eq!(req[16..127], [0; 111]);
        assert_eq!(req[127], 0xEE);
        // Longer: the rest of the declared length in between.
        let f = frame(40, 40);
        let (req, reads) = read(&mut esc, &f);
        assert_eq!(reads, 3);
        assert_eq!(req[..46], f[..46]);
        assert_eq!(req[46..127], [0; 81]);
        // Filling the buffer (or claiming more): the rest in one access.
        for declared in [121, 122, 0xFFFF] {
            let f = frame(declared, 122);
            let (req, reads) = read(&mut esc, &f);
            assert_eq!(reads, 2);
            assert_eq!(req, f);
        }
        // Shorter than the header: still header, then last byte.
        let f = frame(0, 0);
        let (req, reads) = read(&mut esc, &f);
        assert_eq!(reads, 2);
        assert_eq!(req[..16], f[..16]);
    }

    #[test]
    fn start_drops_frames_from_before_init_and_takes_the_repeat_state_from_sm1() {
        let mut esc = esc();
        // SM1 holds an unread reply and its repeat acknowledge is 1 from an earlier repeat;
        // the master has rewritten SM1 with repeat request 0; SM0 holds an unread request.
        write_frame(&mut esc.driver(), IN, &frame(10, 10), 16).unwrap();
        assert!(esc.master_write_mailbox(&frame(10, 10)));
        esc.driver()
            .sm_pdi_control(1, SyncManager::PDI_REPEAT_ACK)
            .unwrap();
        let (sm0, sm1) = (esc.sm(0), esc.sm(1));
        assert!(sm0.mailbox_full() && sm1.mailbox_full());
        assert_eq!((sm1.repeat_request(), sm1.repeat_ack()), (false, true));

        let mut link = AppLink::for_dictionary(&crate::products::analog_io::od::OD);
        link.start(&mut esc.driver(), sm0, sm1).unwrap();
        let (sm0, sm1) = (esc.sm(0), esc.sm(1));
        assert!(
            !sm0.mailbox_full(),
            "the request from before INIT is dropped"
        );
        assert!(!sm1.mailbox_full(), "the reply from before INIT is dropped");
        assert!(
            !sm1.repeat_ack(),
            "the acknowledge follows SM1's repeat request"
        );
        assert_eq!(
            sm0.pdi_control & SyncManager::PDI_DEACTIVATE,
            0,
            "SM0 active again"
        );
        assert_eq!(
            sm1.pdi_control & SyncManager::PDI_DEACTIVATE,
            0,
            "SM1 active again"
        );
        assert!(!link.sm1_busy() && !link.reply_pending());

        // Nothing to do when both are empty and the toggle states agree.
        let writes = esc.writes;
        link.start(&mut esc.driver(), sm0, sm1).unwrap();
        assert_eq!(esc.writes, writes);
    }

    #[test]
    fn small_mailboxes_are_read_whole() {
        let mut esc = esc();
        esc.master_sm(0, OUT, 17, 0x26, true);
        assert!(esc.master_write_mailbox(&frame(10, 10)[..17]));
        let mut req = [0u8; 17];
        read_request(&mut esc.driver(), OUT, &mut req).unwrap();
        assert_eq!(esc.reads, 1);
        assert!(!esc.sm(0).mailbox_full());
        assert_eq!(req[..], frame(10, 10)[..17]);
    }

    #[test]
    fn frames_are_written_with_their_length_then_the_last_byte() {
        let mut esc = esc();
        let f = frame(10, 10);
        write_frame(&mut esc.driver(), IN, &f, 16).unwrap();
        assert_eq!(esc.writes, 2);
        assert!(esc.sm(1).mailbox_full(), "the last byte marks SM1 full");
        let got = esc.master_read_mailbox().unwrap();
        assert_eq!(got[..16], f[..16]);
        assert_eq!(got[127], f[127]);
        // A frame that fills the buffer: one access.
        write_frame(&mut esc.driver(), IN, &f, 127).unwrap();
        assert_eq!(esc.writes, 3);
        assert_eq!(esc.master_read_mailbox().unwrap(), f);
        // A zero length still marks the buffer full.
        write_frame(&mut esc.driver(), IN, &f, 0).unwrap();
        assert!(esc.sm(1).mailbox_full());
    }
}
