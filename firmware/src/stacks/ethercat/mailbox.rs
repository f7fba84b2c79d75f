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

use crate::platform::boot::layout::MAILBOX_CONTROL;
use crate::platform::boot::staging::{is_firmware_name, BOOT_ONLY};
use coe_core::device::{sm_control, SmRole, SyncManagerDesc};
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

/// SM0 and SM1, the standard mailbox of every product: master -> slave at 0x1000, slave ->
/// master at 0x1080, [`MAILBOX_SIZE`] bytes each, with the bootstrap mailbox's control
/// bytes (`platform::boot::layout::MAILBOX_CONTROL`).
pub const MAILBOX_SYNC_MANAGERS: [SyncManagerDesc; 2] = [
    SyncManagerDesc::new(
        SmRole::MailboxOut,
        0x1000,
        MAILBOX_SIZE as u16,
        MAILBOX_CONTROL.0,
    ),
    SyncManagerDesc::new(
        SmRole::MailboxIn,
        0x1080,
        MAILBOX_SIZE as u16,
        MAILBOX_CONTROL.1,
    ),
];

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

/// Bytes of one access to a mailbox buffer by the application's mailbox task: the task runs
/// below the PDI task and takes the ESC for one access at a time, so the process data wait
/// for at most one such access (16 B on the 12.5 MHz legacy SPI: about 13 us with the
/// address phase) instead of a whole 128-byte frame (about 85 us).
pub const CHUNK: usize = 16;

/// Where the mailbox job is between two of its steps ([`MailboxLink::step`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Job {
    /// Nothing under way.
    Idle,
    /// Reading the request from SM0.
    Read(Transfer),
    /// The request is read: the server's reply next.
    Process,
    /// SM1 is free and no request came: the server's waiting frames next.
    Background,
    /// Writing a frame to SM1, then what `AfterWrite` says.
    Write(Transfer, AfterWrite),
    /// The repeated frame is out: the repeat acknowledge (SM1 PDI control) to write.
    RepeatAck(u8),
}

/// What follows the write of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AfterWrite {
    /// A reply or server frame (in the reply buffer); `blocked`: a request waits in SM0
    /// until the master has read it.
    Reply { blocked: bool },
    /// The repeated frame (in the request buffer); then this acknowledge.
    Repeat(u8),
}

/// One transfer of a mailbox buffer `len` bytes long, in accesses of at most a chunk: the
/// middle part `at..end`, then (unless the middle reached it) the last byte, which frees
/// (read) or fills (write) the mailbox. The ESC opens the buffer on its first byte and
/// closes it on its last, whatever lies between (hardware-facts 1.3/1.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Transfer {
    at: u16,
    end: u16,
    len: u16,
}

impl Transfer {
    /// A request in a buffer of `len` bytes: [`FIRST_READ`] bytes first (the header gives
    /// the rest, [`Transfer::after_header`]); a small buffer whole.
    fn request(len: usize) -> Self {
        let end = if len <= FIRST_READ + 1 {
            len
        } else {
            FIRST_READ
        };
        Self::new(end, len)
    }

    /// A frame of `n` bytes in a buffer of `len`: the frame, then the last byte; a frame
    /// that fills the buffer anyway whole.
    fn frame(n: usize, len: usize) -> Self {
        let n = n.max(1);
        Self::new(if n + 1 >= len { len } else { n }, len)
    }

    const fn new(end: usize, len: usize) -> Self {
        Self {
            at: 0,
            end: end as u16,
            len: len as u16,
        }
    }

    /// After the first read of a request: the rest of the header's length (`head`: the
    /// bytes read), all of the buffer if it claims that much or more.
    fn after_header(&mut self, head: &[u8]) {
        if usize::from(self.at) != FIRST_READ || usize::from(self.end) != FIRST_READ {
            return;
        }
        let declared = match head {
            [lo, hi, ..] => MAILBOX_HEADER_LEN + usize::from(u16::from_le_bytes([*lo, *hi])),
            _ => 0,
        };
        let len = usize::from(self.len);
        self.end = if declared + 1 >= len {
            self.len
        } else {
            declared.max(FIRST_READ) as u16
        };
    }

    /// One access: reads (`Dir::Read`) or writes the next piece of `buf` at `start`, at
    /// most `chunk` bytes; `true` when the transfer is done.
    fn step<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        start: u16,
        buf: &mut [u8],
        dir: Dir,
        chunk: usize,
    ) -> PdiResult<bool, P> {
        let (at, end, len) = (
            usize::from(self.at),
            usize::from(self.end),
            usize::from(self.len),
        );
        let range = if at < end {
            at..end.min(at + chunk)
        } else {
            len.saturating_sub(1)..len
        };
        self.at = range.end as u16;
        let addr = start.wrapping_add(range.start as u16);
        let part = buf.get_mut(range).unwrap_or(&mut []);
        match dir {
            Dir::Read => {
                esc.read(addr, part)?;
                self.after_header(buf);
            }
            Dir::Write => {
                esc.write(addr, part)?;
            }
        }
        Ok(self.at >= self.len)
    }
}

/// The direction of a [`Transfer`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Dir {
    Read,
    Write,
}

/// The state of a link's stepped job ([`Steps`]), or `()` for a link served in whole
/// exchanges only ([`MailboxLink::service`]).
pub trait JobState {
    /// A job was asked for or is under way.
    fn busy(&self) -> bool;
    /// Drops the job (state change to INIT, mailbox start).
    fn reset(&mut self);
}

impl JobState for () {
    fn busy(&self) -> bool {
        false
    }

    fn reset(&mut self) {}
}

/// The stepped job of a link of `MBX`-byte mailboxes, accessed at most `CHUNK` bytes at a
/// time ([`MailboxLink::step`]).
pub struct Steps<const MBX: usize, const CHUNK: usize> {
    /// The request being read; the repeated frame being written.
    req: [u8; MBX],
    /// SM0 and SM1 as the job under way found them.
    sm: (SyncManager, SyncManager),
    job: Job,
    wanted: Option<Service>,
}

impl<const MBX: usize, const CHUNK: usize> JobState for Steps<MBX, CHUNK> {
    fn busy(&self) -> bool {
        self.wanted.is_some() || self.job != Job::Idle
    }

    fn reset(&mut self) {
        self.job = Job::Idle;
        self.wanted = None;
    }
}

/// Mailbox service state: the link of a mailbox of `MBX` bytes (each direction) to the
/// server `S`.
///
/// With [`Steps`] the service is a job of bounded steps ([`Self::step`]): each makes at
/// most one access to a mailbox buffer (of at most a chunk) or a few to registers, or one
/// call of the server. A caller that must not be held for a whole exchange (the
/// application's PDI task) asks for the service ([`Self::want`]) and lets a task below it
/// run the steps, each under the lock of the ESC. [`Self::service`] serves a whole exchange
/// at once (the bootloader, whose link has no job state).
pub struct MailboxLink<S, const MBX: usize, J = ()> {
    server: S,
    buf: [u8; MBX],
    pending: usize,
    blocked: bool,
    sm1_busy: bool,
    registers: Option<(SyncManager, SyncManager)>,
    steps: J,
    replies: u32,
    repeats: u32,
}

/// The application's link.
pub type AppLink = MailboxLink<AppServer, MAILBOX_SIZE, Steps<MAILBOX_SIZE, CHUNK>>;

impl AppLink {
    /// The application's link on the dictionary `od`, nothing pending.
    pub const fn for_dictionary(od: &'static ObjectDictionary) -> Self {
        Self::stepped(AppServer::new(od))
    }

    /// Queues an Emergency (sent when SM1 is free).
    pub fn queue_emergency(&mut self, emergency: Emergency) {
        self.server.sdo.queue_emergency(emergency);
    }
}

impl<S, const MBX: usize> MailboxLink<S, MBX> {
    /// Nothing pending; served in whole exchanges.
    pub const fn new(server: S) -> Self {
        Self::with_steps(server, ())
    }
}

impl<S, const MBX: usize, const CHUNK: usize> MailboxLink<S, MBX, Steps<MBX, CHUNK>> {
    /// Nothing pending; served in steps.
    pub const fn stepped(server: S) -> Self {
        // A step must move at least one byte.
        const { assert!(CHUNK > 0) };
        const NONE: SyncManager = SyncManager {
            start: 0,
            length: 0,
            control: 0,
            status: 0,
            activate: 0,
            pdi_control: 0,
        };
        let steps = Steps {
            req: [0; MBX],
            sm: (NONE, NONE),
            job: Job::Idle,
            wanted: None,
        };
        Self::with_steps(server, steps)
    }
}

impl<S, const MBX: usize, J> MailboxLink<S, MBX, J> {
    const fn with_steps(server: S, steps: J) -> Self {
        Self {
            server,
            buf: [0; MBX],
            pending: 0,
            blocked: false,
            sm1_busy: false,
            registers: None,
            steps,
            replies: 0,
            repeats: 0,
        }
    }
}

impl<S: MailboxServer, const MBX: usize, J: JobState> MailboxLink<S, MBX, J> {
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

    /// True while a service was asked for or a job is under way ([`Self::step`] has work).
    pub fn busy(&self) -> bool {
        self.steps.busy()
    }

    /// The mailbox AL event bits to enable: none while the service is asked for or under
    /// way (the line would stay asserted for the PDI task until the job reads SM0 or
    /// writes SM1; the job's end enables them again); SM0 while no reply waits, SM1 while
    /// one does or while a request waits in SM0 for SM1 to be read, or other frames wait
    /// for SM1.
    pub fn event_mask(&self) -> AlEvents {
        if self.busy() {
            AlEvents::empty()
        } else if self.pending != 0 || self.blocked || (self.sm1_busy && self.has_outgoing()) {
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

    /// Takes note of the AL event bits of an access and tells whether the mailbox needs
    /// the service: a request in SM0 (bit 8) or a frame to send, with SM1 free (bit 9 seen
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

    /// ESM transition. To INIT: the job under way is dropped (a reply half written is
    /// never marked full; a request half read is dropped at INIT -> PREOP).
    pub fn on_state_change(&mut self, ctx: &mut S::Context<'_>, from: AlState, to: AlState) {
        self.server.on_state_change(ctx, from, to);
        if to == AlState::Init {
            self.pending = 0;
            self.blocked = false;
            self.sm1_busy = false;
            self.registers = None;
            self.steps.reset();
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
        self.steps.reset();
        Ok(())
    }

    /// Serves the mailbox as one whole exchange, its accesses as long as the frames: repeat
    /// request (if asked), waiting reply, a new request if SM0 is full, then the server's
    /// pending work. At most one request per call. For the bootloader, which has no process
    /// data to protect and no room for the stepped job ([`Self::step`] does the same in
    /// bounded steps; a host test runs both on one script and compares every frame).
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
                    if !new_request_answers_repeat(&sm0, &sm1) {
                        self.repeat(esc, &sm1)?;
                        return Ok(());
                    }
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

impl<S: MailboxServer, const MBX: usize, const CHUNK: usize>
    MailboxLink<S, MBX, Steps<MBX, CHUNK>>
{
    /// Asks for the service `how`, merged with one asked for before and not begun: the
    /// registers read covers the event bits (which the job reads again anyway), the repeat
    /// check is kept.
    pub fn want(&mut self, how: Service) {
        use Service::Registers;
        self.steps.wanted = Some(match (self.steps.wanted, how) {
            (Some(Registers { check_repeat: a }), Registers { check_repeat: b }) => Registers {
                check_repeat: a || b,
            },
            (Some(r @ Registers { .. }), _) => r,
            (_, how) => how,
        });
    }

    /// One step of the mailbox job; `true` while there is more to do. A job serves the
    /// repeat request (if asked), a waiting reply, a new request if SM0 is full, else the
    /// server's pending work: at most one request per job. A job begins with what was
    /// asked ([`Self::want`]): the SyncManager registers read, or the AL event bits read
    /// again (an access of its own), since the ones that asked may be old by then. A
    /// failed access ends the job (the safety service looks again).
    pub fn step<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        state: AlState,
        ctx: &mut S::Context<'_>,
        now_ms: u32,
    ) -> PdiResult<bool, P> {
        if state == AlState::Init {
            self.steps.reset();
            return Ok(false);
        }
        if let Err(e) = self.advance(esc, state, ctx, now_ms) {
            self.steps.job = Job::Idle;
            return Err(e);
        }
        Ok(self.busy())
    }

    fn advance<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        state: AlState,
        ctx: &mut S::Context<'_>,
        now_ms: u32,
    ) -> PdiResult<(), P> {
        let (sm0, sm1) = self.steps.sm;
        self.steps.job = match self.steps.job {
            Job::Idle => match self.steps.wanted.take() {
                Some(how) => self.begin(esc, how)?,
                None => Job::Idle,
            },
            Job::Read(mut t) => {
                let len = usize::from(sm0.length).min(MBX);
                let req = self.steps.req.get_mut(..len).unwrap_or(&mut []);
                match t.step(esc, sm0.start, req, Dir::Read, CHUNK)? {
                    true => Job::Process,
                    false => Job::Read(t),
                }
            }
            Job::Process => {
                let len = usize::from(sm0.length).min(MBX);
                let req = self.steps.req.get(..len).unwrap_or(&[]);
                let reply_len = usize::from(sm1.length).min(MBX);
                self.buf = [0; MBX];
                let out = self.buf.get_mut(..reply_len).unwrap_or(&mut []);
                match self.server.process(ctx, req, state, now_ms, out) {
                    Reply::Frame(n) => self.reply(n, reply_len, false),
                    _ => Job::Background,
                }
            }
            Job::Background => {
                let reply_len = usize::from(sm1.length).min(MBX);
                self.buf = [0; MBX];
                let out = self.buf.get_mut(..reply_len).unwrap_or(&mut []);
                match self.server.poll(ctx, out) {
                    Reply::Frame(n) => self.reply(n, reply_len, false),
                    _ => Job::Idle,
                }
            }
            Job::Write(mut t, then) => {
                let len = usize::from(sm1.length).min(MBX);
                let frame = match then {
                    AfterWrite::Reply { .. } => &mut self.buf,
                    AfterWrite::Repeat(_) => &mut self.steps.req,
                };
                let frame = frame.get_mut(..len).unwrap_or(&mut []);
                if t.step(esc, sm1.start, frame, Dir::Write, CHUNK)? {
                    self.sm1_busy = true;
                    self.replies = self.replies.wrapping_add(1);
                    match then {
                        AfterWrite::Reply { blocked } => {
                            self.pending = 0;
                            self.blocked = blocked;
                            Job::Idle
                        }
                        AfterWrite::Repeat(ack) => Job::RepeatAck(ack),
                    }
                } else {
                    Job::Write(t, then)
                }
            }
            Job::RepeatAck(ack) => {
                esc.sm_pdi_control(1, ack)?;
                self.repeats = self.repeats.wrapping_add(1);
                Job::Idle
            }
        };
        Ok(())
    }

    /// The waiting reply of `n` bytes in a buffer of `len` to write.
    fn reply(&mut self, n: usize, len: usize, blocked: bool) -> Job {
        self.pending = n.max(1);
        Job::Write(
            Transfer::frame(self.pending, len),
            AfterWrite::Reply { blocked },
        )
    }

    /// The first step of a job: what the mailbox holds, and what to do about it.
    fn begin<P: Pdi>(&mut self, esc: &mut Et1100<P>, how: Service) -> PdiResult<Job, P> {
        let (sm0, sm1, sm1_full, sm0_full) = match (how, self.registers) {
            (Service::Events(_), Some((sm0, sm1))) => {
                // The event bits again: the ones that asked may be old by now.
                let events = esc.low_events()?;
                if events.contains(AlEvents::SM1) {
                    self.sm1_busy = false;
                }
                let request = events.contains(AlEvents::SM0) || self.blocked;
                (sm0, sm1, self.sm1_busy, request)
            }
            (how, _) => {
                let (sm0, sm1) = esc.read_sm_pair(0)?;
                let check_repeat = how == Service::Registers { check_repeat: true };
                if check_repeat && sm1.repeat_requested() {
                    if !new_request_answers_repeat(&sm0, &sm1) {
                        self.steps.sm = (sm0, sm1);
                        return self.begin_repeat(esc, &sm1);
                    }
                    esc.sm_pdi_control(1, sm1.requested_repeat_ack())?;
                    self.repeats = self.repeats.wrapping_add(1);
                }
                self.registers = Some((sm0, sm1));
                (sm0, sm1, sm1.mailbox_full(), sm0.mailbox_full())
            }
        };
        self.steps.sm = (sm0, sm1);
        self.sm1_busy = sm1_full;
        self.blocked = false;
        let len = usize::from(sm1.length).min(MBX);
        Ok(if self.pending != 0 {
            match sm1_full {
                true => Job::Idle,
                // A request may wait in SM0 until the master has read SM1.
                false => self.reply(self.pending, len, sm0_full),
            }
        } else if sm1_full {
            self.blocked = sm0_full;
            Job::Idle
        } else if sm0_full && sm0.enabled() {
            self.steps.req = [0; MBX];
            Job::Read(Transfer::request(usize::from(sm0.length).min(MBX)))
        } else {
            Job::Background
        })
    }

    /// The repeat request: SM1 emptied if full, the last frame to write again, then the
    /// acknowledge.
    fn begin_repeat<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        sm1: &SyncManager,
    ) -> PdiResult<Job, P> {
        let ack = sm1.pdi_control & SyncManager::PDI_REPEAT_ACK;
        // Empty now, or emptied below.
        self.sm1_busy = false;
        if sm1.mailbox_full() {
            // Empty SM1 by deactivating it from the PDI side, then activate it again.
            esc.sm_pdi_control(1, ack | SyncManager::PDI_DEACTIVATE)?;
            esc.sm_pdi_control(1, ack)?;
        }
        let len = usize::from(sm1.length).min(MBX);
        self.steps.req = [0; MBX];
        let out = self.steps.req.get_mut(..len).unwrap_or(&mut []);
        let then = sm1.requested_repeat_ack();
        Ok(match self.server.repeat(out).frame_len() {
            Some(n) => Job::Write(Transfer::frame(n, len), AfterWrite::Repeat(then)),
            None => Job::RepeatAck(then),
        })
    }
}

/// Whether a repeat request is answered by the reply to the request waiting in SM0 instead
/// of the last frame again: SM1 was read and a new request waits, so the master has moved
/// on, and the frame it asks for again was one it did not ask for. SOEM drops an Emergency
/// it reads, reads SM1 again at once and takes the empty mailbox for a lost frame;
/// repeating that frame would start the same race again.
// Inlined: the bootloader links `service` too and has no room for one more call.
#[inline(always)]
fn new_request_answers_repeat(sm0: &SyncManager, sm1: &SyncManager) -> bool {
    !sm1.mailbox_full() && sm0.mailbox_full()
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

    /// The analog-io product's application as the objects of the SDO server.
    fn with_app<R>(f: impl FnOnce(&mut dyn ObjectAccess) -> R) -> R {
        use crate::stacks::ethercat::Application as _;
        let mut app = crate::products::analog_io::application();
        let stage = crate::io::analog::outputs::OutputStage::new();
        app.with_objects(&stage, 0, f)
    }

    /// What a master's script of SDO exchanges saw through a link with `CH`-byte chunks.
    struct Script {
        stepped: bool,
        frames: Vec<Vec<u8>>,
        longest: usize,
        steps: usize,
        /// Process-data reads the PDI task made between two steps.
        pd_reads: usize,
        segments: usize,
    }

    /// Runs the job asked for with `how`, one step at a time, the PDI task reading the
    /// outputs between two steps (as the mailbox task's lock allows); or, `stepped` false,
    /// the whole exchange at once ([`MailboxLink::service`], the bootloader's).
    fn serve_steps<const CH: usize>(
        link: &mut MailboxLink<AppServer, MAILBOX_SIZE, Steps<MAILBOX_SIZE, CH>>,
        esc: &mut FakeEsc,
        objects: &mut dyn ObjectAccess,
        how: Service,
        script: &mut Script,
    ) {
        // As the slave application asks: the event bits first.
        if let Service::Events(events) = how {
            if !link.needs_service(events) {
                return;
            }
        }
        if !script.stepped {
            script.steps += 1;
            link.service(&mut esc.driver(), AlState::PreOp, objects, 0, how)
                .unwrap();
            return;
        }
        link.want(how);
        for _ in 0..64 {
            let more = link
                .step(&mut esc.driver(), AlState::PreOp, objects, 0)
                .unwrap();
            script.steps += 1;
            esc.driver().read(0x1200, &mut [0u8; 4]).unwrap();
            script.pd_reads += 1;
            if !more {
                return;
            }
        }
        panic!("the job never ended");
    }

    /// The script: expedited uploads, a complete-access upload (segmented when it does not
    /// fit), SDO Information (the OD list in fragments, an object description), a repeat
    /// request; the master reads every frame as soon as SM1 is full.
    fn script<const CH: usize>(stepped: bool) -> Script {
        let mut esc = esc();
        let od = &crate::products::analog_io::od::OD;
        let mut link =
            MailboxLink::<_, MAILBOX_SIZE, Steps<MAILBOX_SIZE, CH>>::stepped(AppServer::new(od));
        let mut s = Script {
            stepped,
            frames: Vec::new(),
            longest: 0,
            steps: 0,
            pd_reads: 0,
            segments: 0,
        };
        let mut counter = 0u8;
        with_app(|objects| {
            let mut exchange = |esc: &mut FakeEsc, coe: &[u8], s: &mut Script| {
                counter = counter % 7 + 1;
                let mut f = (coe.len() as u16).to_le_bytes().to_vec();
                f.extend_from_slice(&[0, 0, 0, 0x03 | counter << 4]);
                f.extend_from_slice(coe);
                assert!(esc.master_write_mailbox(&f));
                let how = Service::Events(esc.event_request());
                serve_steps(&mut link, esc, objects, how, s);
                let mut last = Vec::new();
                while let Some(reply) = esc.master_read_mailbox() {
                    s.frames.push(reply.clone());
                    last = reply;
                    let how = Service::Events(esc.event_request());
                    serve_steps(&mut link, esc, objects, how, s);
                }
                last
            };
            let upload = |cmd: u8, index: u16, sub: u8| {
                let [lo, hi] = index.to_le_bytes();
                std::vec![0x00, 0x20, cmd, lo, hi, sub, 0, 0, 0, 0]
            };
            for (index, sub) in [(0x1018, 1), (0x1000, 0), (0x1C32, 5)] {
                let r = exchange(&mut esc, &upload(0x40, index, sub), &mut s);
                assert_eq!(r[8], 0x43, "expedited upload of {index:04X}");
            }
            // Complete access from subindex 0, the module description (the largest
            // object); segments while the object does not fit.
            let description = crate::products::analog_io::od::MODULE_DESCRIPTION_INDEX;
            for (cmd, index) in [(0x50, 0x1C32u16), (0x50, 0x1C33), (0x40, description)] {
                let mut r = exchange(&mut esc, &upload(cmd, index, 0), &mut s);
                assert_eq!(r[8] & 0xE3, 0x41, "normal upload of {index:04X}");
                let size = u32::from_le_bytes([r[12], r[13], r[14], r[15]]) as usize;
                let mut got = usize::from(u16::from_le_bytes([r[0], r[1]])) - 10;
                let mut toggle = 0u8;
                while got < size {
                    r = exchange(
                        &mut esc,
                        &[0x00, 0x20, 0x60 | toggle, 0, 0, 0, 0, 0, 0, 0],
                        &mut s,
                    );
                    assert_eq!(r[8] & 0xF0, toggle, "segment of {index:04X}");
                    got += usize::from(u16::from_le_bytes([r[0], r[1]])) - 3;
                    s.segments += 1;
                    toggle ^= 0x10;
                }
            }
            // SDO Information: the OD list (all objects), in fragments.
            let list = exchange(&mut esc, &[0x00, 0x80, 0x01, 0, 0, 0, 0x01, 0], &mut s);
            assert_eq!(list[8] & 0x7F, 0x02, "OD list response");
            let desc = exchange(&mut esc, &[0x00, 0x80, 0x03, 0, 0, 0, 0x32, 0x1C], &mut s);
            assert_eq!(desc[8] & 0x7F, 0x04, "object description response");
            // The repeat request: the last frame again.
            esc.master_repeat_request();
            let how = Service::Registers { check_repeat: true };
            serve_steps(&mut link, &mut esc, objects, how, &mut s);
            let again = esc.master_read_mailbox().expect("repeated");
            assert_eq!(again, desc);
            s.frames.push(again);
            let sm1 = esc.sm(1);
            assert_eq!(sm1.repeat_ack(), sm1.repeat_request(), "acknowledged");
        });
        assert_eq!(link.repeats(), 1);
        assert!(!link.busy());
        s.longest = esc.longest_ram_access;
        s
    }

    #[test]
    fn chunked_jobs_carry_the_same_frames_in_bounded_accesses() {
        let whole = script::<MAILBOX_SIZE>(false);
        let chunked = script::<CHUNK>(true);
        let stepped_whole = script::<MAILBOX_SIZE>(true);
        assert_eq!(stepped_whole.frames, whole.frames);
        assert_eq!(chunked.frames, whole.frames, "same frames, same order");
        assert!(whole.frames.len() >= 12, "{} frames", whole.frames.len());
        assert!(chunked.segments >= 1, "a segmented upload");
        assert!(whole.longest > CHUNK, "whole frames in one access");
        assert!(
            chunked.longest <= CHUNK,
            "every access at most one chunk: {}",
            chunked.longest
        );
        // The process data get the bus between every two steps.
        assert_eq!(chunked.pd_reads, chunked.steps);
        assert!(chunked.steps > whole.steps);
    }

    #[test]
    fn a_request_half_read_at_init_is_dropped_with_the_job() {
        let mut esc = esc();
        let mut link = AppLink::for_dictionary(&crate::products::analog_io::od::OD);
        let f = frame(40, 40);
        assert!(esc.master_write_mailbox(&f));
        with_app(|objects| {
            link.want(Service::Registers {
                check_repeat: false,
            });
            // The registers, then the first chunk of the request.
            for _ in 0..2 {
                assert!(link
                    .step(&mut esc.driver(), AlState::PreOp, objects, 0)
                    .unwrap());
            }
            link.on_state_change(objects, AlState::PreOp, AlState::Init);
            assert!(!link.busy());
            assert!(!link
                .step(&mut esc.driver(), AlState::Init, objects, 0)
                .unwrap());
        });
        assert!(esc.master_read_mailbox().is_none(), "nothing answered");
        // INIT -> PREOP drops what is left of it in SM0.
        let (sm0, sm1) = (esc.sm(0), esc.sm(1));
        link.start(&mut esc.driver(), sm0, sm1).unwrap();
        assert!(!esc.sm(0).mailbox_full());
    }

    #[test]
    fn a_failed_access_ends_the_job_and_the_next_one_serves_the_request() {
        let mut esc = esc();
        let mut link = AppLink::for_dictionary(&crate::products::analog_io::od::OD);
        let coe = [0x00u8, 0x20, 0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0];
        let mut f = std::vec![10u8, 0, 0, 0, 0, 0x13];
        f.extend_from_slice(&coe);
        assert!(esc.master_write_mailbox(&f));
        with_app(|objects| {
            let how = Service::Registers {
                check_repeat: false,
            };
            link.want(how);
            assert!(link
                .step(&mut esc.driver(), AlState::PreOp, objects, 0)
                .unwrap());
            esc.fail_next = true;
            assert!(link
                .step(&mut esc.driver(), AlState::PreOp, objects, 0)
                .is_err());
            assert!(!link.busy(), "the job ended");
            link.want(how);
            while link
                .step(&mut esc.driver(), AlState::PreOp, objects, 0)
                .unwrap()
            {}
        });
        let reply = esc.master_read_mailbox().expect("served");
        assert_eq!(reply[8], 0x43);
    }

    #[test]
    fn mailbox_events_are_masked_while_the_job_waits_or_runs() {
        let mut link = AppLink::for_dictionary(&crate::products::analog_io::od::OD);
        assert_eq!(link.event_mask(), AlEvents::SM0);
        link.want(Service::Events(AlEvents::SM0));
        assert_eq!(link.event_mask(), AlEvents::empty());
        link.want(Service::Registers { check_repeat: true });
        link.want(Service::Events(AlEvents::SM1));
        assert_eq!(
            link.steps.wanted,
            Some(Service::Registers { check_repeat: true }),
            "the registers read covers the events, the repeat check is kept"
        );
    }
}
