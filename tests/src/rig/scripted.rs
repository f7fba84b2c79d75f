//! A synchronous, scripted EtherCAT master for fault tests: it does what real masters do,
//! one datagram at a time, on the board's virtual time, and lets a test break the network
//! on purpose.
//!
//! What it does, as ethercrab and SOEM do it (`shared/masters.md`):
//! - bring-up ([`ScriptedMaster::init`]): BRD of the type register (working counter = slave
//!   count), INIT with acknowledge, FMMUs, SyncManagers and the DC cyclic unit cleared
//!   (BWR), the station address by position (APWR), the SII read through the ESC's EEPROM
//!   interface (0x0502..0x050F: identity, mailbox words 0x18..0x1B, the SyncM category);
//! - the ESM walk ([`ScriptedMaster::request_state`], [`ScriptedMaster::to_op`]): AL
//!   control written with the acknowledge bit when the error flag is set, AL status polled;
//!   the mailbox SyncManagers from the SII before INIT -> PREOP, SM2/SM3 sized from the PDO
//!   assignment read over SDO, FMMUs and (optionally) DC SYNC0 before PREOP -> SAFEOP;
//! - the mailbox through [`MailboxClient`]/[`SdoClient`] on this master's datagrams
//!   ([`RegisterPort`]): counters, a write that is not taken (working counter 0) is resent
//!   as SOEM does, a lost read is recovered with the repeat request;
//! - process data ([`ScriptedMaster::cycle`]): one LRW per cycle over the FMMUs, working
//!   counter checked (3: read + write); in DC mode the frames leave half a cycle before the
//!   SYNC0 edge ([`ScriptedMaster::wait_cycle_slot`]), as ethercrab's `sync0_shift` does.
//!
//! Faults of the network are explicit, named operations ([`ScriptedMaster::pull_cable`],
//! [`ScriptedMaster::lose_frames`], [`ScriptedMaster::lose_replies`],
//! [`ScriptedMaster::duplicate_frames`]); faults inside the board are switches of the
//! models ([`crate::models`]).
//!
//! Time: every frame takes its wire time on the board ([`VirtualBoard::exchange`]); a frame
//! that is lost costs the master the same time (it waits for it), and
//! [`ScriptedMaster::wait`] lets virtual time pass with the board running.

use crate::models::esc::{cmd, parse_frame, regs, FrameBuilder, ParsedDatagram};
use crate::rig::board::BoardConfig;
use crate::rig::master::SharedBoard;
use crate::rig::sdo_client::{
    Emergency, RegisterPort, SdoClient, SdoError, Upload, MAILBOX_TYPE_COE,
};
use crate::tools::sim::{self, PdoLayout};
use coe_core::sii::reader::{Sii, SyncManagers};
use coe_core::sii::{category, word};
use std::cell::{Cell, RefCell, RefMut};
use std::fmt;
use std::future::Future;
use std::rc::Rc;

/// Mailbox size the master's SDO client is built for (the module's; checked against the
/// SII at [`ScriptedMaster::init`]).
pub const MBX: usize = firmware::stacks::ethercat::mailbox::MAILBOX_SIZE;

/// The station address the master gives the (only) slave.
pub const STATION: u16 = 0x1001;

/// AL control / status state values (ETG.1000.6 table 9; coe-core's numbering).
pub mod state {
    use coe_core::esm::{AlState, ERROR_FLAG};
    /// INIT.
    pub const INIT: u8 = AlState::Init.nibble();
    /// PRE-OPERATIONAL.
    pub const PREOP: u8 = AlState::PreOp.nibble();
    /// BOOTSTRAP.
    pub const BOOT: u8 = AlState::Bootstrap.nibble();
    /// SAFE-OPERATIONAL.
    pub const SAFEOP: u8 = AlState::SafeOp.nibble();
    /// OPERATIONAL.
    pub const OP: u8 = AlState::Op.nibble();
    /// AL control b4: error acknowledge; AL status b4: error indication.
    pub const ERROR: u8 = ERROR_FLAG as u8;
}

/// Polls of AL status after an AL control write (one frame each).
pub const STATE_POLLS: usize = 200;
/// Polls of the EEPROM interface's busy bit (one frame each).
pub const EEPROM_POLLS: usize = 2000;
/// Attempts of a register access whose frame got no answer.
pub const RETRIES: usize = 4;
/// Attempts of a mailbox write whose first answer was lost, while the mailbox is full.
pub const MAILBOX_RESENDS: usize = 2000;
/// Logical address of the process image (outputs first, then inputs).
pub const LOGICAL_START: u32 = 0x0001_0000;

/// What went wrong on the master side.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MasterError {
    /// A frame got no answer (cable pulled, frame lost).
    NoReply(String),
    /// A datagram came back with an unexpected working counter.
    WorkingCounter {
        /// What the datagram did.
        what: String,
        /// The working counter expected.
        expected: u16,
        /// The working counter received.
        got: u16,
    },
    /// The slave did not do what was asked (state not reached, EEPROM error, SDO error).
    Slave(String),
}

impl fmt::Display for MasterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoReply(what) => write!(f, "{what}: no reply"),
            Self::WorkingCounter {
                what,
                expected,
                got,
            } => write!(f, "{what}: working counter {got}, expected {expected}"),
            Self::Slave(s) => f.write_str(s),
        }
    }
}

impl From<SdoError> for MasterError {
    fn from(e: SdoError) -> Self {
        Self::Slave(e.to_string())
    }
}

/// AL status (0x0130) and AL status code (0x0134) as the master reads them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AlStatus {
    /// The state nibble.
    pub state: u8,
    /// The error indication (b4).
    pub error: bool,
    /// AL status code.
    pub code: u16,
}

impl AlStatus {
    /// `(AL status word, AL status code)`, as tests compare them: e.g. `(0x14, 0x1B)`.
    pub fn pair(&self) -> (u8, u16) {
        (
            self.state | if self.error { state::ERROR } else { 0 },
            self.code,
        )
    }
}

/// Counters of the network between master and slave.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NetStats {
    /// Frames the master sent.
    pub frames: u64,
    /// Frames lost on the way to the slave (not processed).
    pub lost_to_slave: u64,
    /// Frames the slave processed whose answer was lost.
    pub lost_from_slave: u64,
    /// Frames delivered twice.
    pub duplicated: u64,
    /// Frames sent while the cable was pulled.
    pub unplugged: u64,
    /// Register accesses repeated after a lost frame.
    pub retries: u64,
}

#[derive(Debug)]
struct Network {
    plugged: bool,
    lose_to_slave: u32,
    lose_from_slave: u32,
    duplicate: u32,
    stats: NetStats,
}

/// A SyncManager as the SII's SyncM category (41) gives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SiiSm {
    /// Start address.
    pub start: u16,
    /// Default length.
    pub len: u16,
    /// Control byte.
    pub control: u8,
    /// Enable byte (b0: enable).
    pub enable: u8,
    /// Type: 1 mailbox out, 2 mailbox in, 3 outputs, 4 inputs.
    pub kind: u8,
}

impl SiiSm {
    /// The 8 register bytes for this SyncManager with `len` and `activate`.
    pub fn registers(&self, len: u16, activate: u8) -> [u8; 8] {
        let s = self.start.to_le_bytes();
        let l = len.to_le_bytes();
        [s[0], s[1], l[0], l[1], self.control, 0, activate, 0]
    }
}

/// What the master learnt from the SII.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlaveInfo {
    /// Vendor ID, product code, revision, serial (words 8..15).
    pub identity: [u32; 4],
    /// Standard mailbox: out (master -> slave) start and size, in start and size (words
    /// 0x18..0x1B).
    pub mailbox: [u16; 4],
    /// Bootstrap mailbox, the same (words 0x14..0x17; zero without BOOT support).
    pub bootstrap_mailbox: [u16; 4],
    /// The SyncM category, SM0 first.
    pub sync_managers: Vec<SiiSm>,
}

/// The process image the master set up at PREOP -> SAFEOP.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProcessImage {
    /// The PDO layout read over SDO.
    pub layout: PdoLayout,
    /// Output bytes (SM2 length).
    pub outputs: usize,
    /// Input bytes (SM3 length).
    pub inputs: usize,
}

/// How the process data are synchronised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sync {
    /// SM-synchronous: a frame every `cycle_ns`, SYNC0 off.
    SmSync {
        /// The master's cycle.
        cycle_ns: u64,
    },
    /// DC SYNC0 every `cycle_ns`; frames half a cycle before each edge.
    Dc {
        /// SYNC0 cycle (0x09A0).
        cycle_ns: u32,
    },
}

impl Sync {
    /// The cycle time.
    pub fn cycle_ns(&self) -> u64 {
        match *self {
            Self::SmSync { cycle_ns } => cycle_ns,
            Self::Dc { cycle_ns } => u64::from(cycle_ns),
        }
    }
}

/// Virtual time of the first SYNC0 edge after the start of cyclic operation: the start time
/// the master writes to 0x0990 lies this far after the system time it read.
pub const DC_START_DELAY_NS: u64 = 500_000;

/// A scripted master driving one slave on a [`VirtualBoard`].
pub struct ScriptedMaster {
    board: SharedBoard,
    net: RefCell<Network>,
    info: RefCell<Option<SlaveInfo>>,
    image: RefCell<Option<ProcessImage>>,
    sdo: RefCell<SdoClient<MBX>>,
    emergencies: RefCell<Vec<Emergency>>,
    unexpected: RefCell<Vec<[u8; MBX]>>,
    sync: Cell<Option<Sync>>,
    pace: Cell<Pace>,
    cyclic: RefCell<Cyclic>,
}

/// The cyclic process data the master keeps sending in the background.
#[derive(Debug, Default)]
struct Cyclic {
    running: bool,
    outputs: Vec<u8>,
    next_slot: u64,
    stats: CyclicStats,
}

/// Counters of the background cyclic frames.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CyclicStats {
    /// Cyclic frames sent in the background.
    pub frames: u64,
    /// Of them, frames without an answer or with a wrong working counter.
    pub errors: u64,
}

/// When the master sends its cyclic frames: slots `origin + k * cycle - lead`.
#[derive(Debug, Clone, Copy, Default)]
struct Pace {
    /// Virtual time of SYNC0 edge 0 (DC), or of the first slot (SM-sync).
    origin: u64,
    /// The master's cycle.
    cycle: u64,
    /// How long before the SYNC0 edge the frame leaves (DC; 0 in SM-sync).
    lead: u64,
}

/// Runs a future of the SDO client to completion (the scripted master answers at once).
pub fn block<F: Future>(f: F) -> F::Output {
    futures_lite::future::block_on(f)
}

impl ScriptedMaster {
    /// A master on `board`.
    pub fn new(board: SharedBoard) -> Self {
        Self {
            board,
            net: RefCell::new(Network {
                plugged: true,
                lose_to_slave: 0,
                lose_from_slave: 0,
                duplicate: 0,
                stats: NetStats::default(),
            }),
            info: RefCell::new(None),
            image: RefCell::new(None),
            sdo: RefCell::new(SdoClient::new(0, 0, 1)),
            emergencies: RefCell::new(Vec::new()),
            unexpected: RefCell::new(Vec::new()),
            sync: Cell::new(None),
            pace: Cell::new(Pace::default()),
            cyclic: RefCell::new(Cyclic::default()),
        }
    }

    /// The firmware's slave application on a fresh board (`edit` adjusts the board's
    /// configuration first: ESC fault switches, capture).
    pub fn firmware(edit: impl FnOnce(&mut BoardConfig)) -> Self {
        let target = sim::firmware_target().expect("the firmware target builds");
        Self::new(Rc::new(RefCell::new(target.into_board(edit))))
    }

    /// The board.
    pub fn board(&self) -> &SharedBoard {
        &self.board
    }

    /// Current virtual time (ns).
    pub fn now_ns(&self) -> u64 {
        self.board.borrow().now_ns()
    }

    /// Lets `ns` of virtual time pass (the board keeps running; the cyclic frames too while
    /// [`Self::start_cyclic`] runs them).
    pub fn wait(&self, ns: u64) {
        self.wait_until(self.now_ns() + ns);
    }

    /// Lets virtual time pass until `t` (nothing if it has passed).
    pub fn wait_until(&self, t: u64) {
        self.serve_slots_before(t);
        self.wait_until_raw(t);
    }

    fn wait_until_raw(&self, t: u64) {
        let now = self.now_ns();
        if t > now {
            self.board.borrow_mut().step(t - now);
        }
    }

    // ------------------------------------------------------------------ cyclic frames

    /// The master sends its process data every cycle slot from now on, in the background
    /// of whatever else it does (mailbox, waits), with `outputs` (changed by
    /// [`Self::set_outputs`] and by every [`Self::cycle`]).
    pub fn start_cyclic(&self, outputs: &[u8]) {
        let next = self.slot_after(self.now_ns());
        let mut c = self.cyclic.borrow_mut();
        c.running = true;
        c.outputs = outputs.to_vec();
        c.next_slot = next.unwrap_or(u64::MAX);
    }

    /// The master stops sending process data.
    pub fn stop_cyclic(&self) {
        self.cyclic.borrow_mut().running = false;
    }

    /// The outputs of the background cyclic frames.
    pub fn set_outputs(&self, outputs: &[u8]) {
        self.cyclic.borrow_mut().outputs = outputs.to_vec();
    }

    /// Counters of the background cyclic frames.
    pub fn cyclic_stats(&self) -> CyclicStats {
        self.cyclic.borrow().stats.clone()
    }

    /// Sends the cyclic frames of the slots before `t` (each at its slot time, or at once if
    /// the master is late).
    fn serve_slots_before(&self, t: u64) {
        loop {
            let (slot, outputs) = {
                let c = self.cyclic.borrow();
                if !c.running || c.next_slot >= t {
                    return;
                }
                (c.next_slot, c.outputs.clone())
            };
            self.wait_until_raw(slot);
            let ok = self.lrw(&outputs).is_ok();
            let next = self.slot_after(self.now_ns().max(slot));
            let mut c = self.cyclic.borrow_mut();
            c.stats.frames += 1;
            c.stats.errors += u64::from(!ok);
            c.next_slot = next.unwrap_or(u64::MAX);
        }
    }

    /// The first cycle slot after `t`: `origin - lead + k * cycle`.
    fn slot_after(&self, t: u64) -> Option<u64> {
        let p = self.pace.get();
        if p.cycle == 0 {
            return None;
        }
        let first = p.origin.saturating_sub(p.lead);
        Some(if t < first {
            first
        } else {
            first + (t - first) / p.cycle * p.cycle + p.cycle
        })
    }

    // ------------------------------------------------------------------ network faults

    /// Pulls the cable: no frame reaches the slave until [`Self::plug_cable`].
    pub fn pull_cable(&self) {
        self.net.borrow_mut().plugged = false;
    }

    /// Plugs the cable back in.
    pub fn plug_cable(&self) {
        self.net.borrow_mut().plugged = true;
    }

    /// The next `n` frames are lost on the way to the slave (never processed).
    pub fn lose_frames(&self, n: u32) {
        self.net.borrow_mut().lose_to_slave += n;
    }

    /// The next `n` frames reach the slave, and their answers are lost on the way back.
    pub fn lose_replies(&self, n: u32) {
        self.net.borrow_mut().lose_from_slave += n;
    }

    /// The next `n` frames reach the slave twice (a network stack resending them).
    pub fn duplicate_frames(&self, n: u32) {
        self.net.borrow_mut().duplicate += n;
    }

    /// The network counters.
    pub fn net_stats(&self) -> NetStats {
        self.net.borrow().stats.clone()
    }

    // ------------------------------------------------------------------ frames

    /// Sends one frame; the datagrams as they came back, `None` if no answer arrived. A
    /// cyclic frame due before this one would be through goes first.
    pub fn transmit(&self, frame: &FrameBuilder) -> Option<Vec<ParsedDatagram>> {
        let bytes = frame.build();
        let t = self.board.borrow().frame_time_ns(bytes.len());
        self.serve_slots_before(self.now_ns() + t);
        self.transmit_now(&bytes)
    }

    /// Sends one frame at once (the network faults apply).
    fn transmit_now(&self, bytes: &[u8]) -> Option<Vec<ParsedDatagram>> {
        let (deliver, twice, answer) = {
            let mut net = self.net.borrow_mut();
            net.stats.frames += 1;
            if !net.plugged {
                net.stats.unplugged += 1;
                (false, false, false)
            } else if net.lose_to_slave > 0 {
                net.lose_to_slave -= 1;
                net.stats.lost_to_slave += 1;
                (false, false, false)
            } else {
                let twice = net.duplicate > 0;
                if twice {
                    net.duplicate -= 1;
                    net.stats.duplicated += 1;
                }
                let lost = net.lose_from_slave > 0;
                if lost {
                    net.lose_from_slave -= 1;
                    net.stats.lost_from_slave += 1;
                }
                (true, twice, !lost)
            }
        };
        if !deliver {
            // The master waits for the frame as long as it would have taken.
            let mut board = self.board.borrow_mut();
            let t = board.frame_time_ns(bytes.len());
            board.step(t);
            return None;
        }
        let reply = self.board.borrow_mut().exchange(bytes);
        if twice {
            self.board.borrow_mut().exchange(bytes);
        }
        if !answer {
            return None;
        }
        parse_frame(&reply)
    }

    /// One datagram, once: its data and working counter, `None` without an answer.
    pub fn datagram(&self, command: u8, adp: u16, ado: u16, data: &[u8]) -> Option<(Vec<u8>, u16)> {
        let frame = FrameBuilder::new().datagram(command, adp, ado, data);
        self.transmit(&frame)
            .and_then(|mut d| (!d.is_empty()).then(|| d.remove(0)))
            .map(|d| (d.data, d.wkc))
    }

    /// One datagram, resent (up to [`RETRIES`] times) while no answer arrives: safe for
    /// reads and for writes that may be repeated.
    fn datagram_retried(
        &self,
        command: u8,
        adp: u16,
        ado: u16,
        data: &[u8],
        what: &str,
    ) -> Result<(Vec<u8>, u16), MasterError> {
        for attempt in 0..RETRIES {
            if attempt > 0 {
                self.net.borrow_mut().stats.retries += 1;
            }
            if let Some(r) = self.datagram(command, adp, ado, data) {
                return Ok(r);
            }
        }
        Err(MasterError::NoReply(what.into()))
    }

    /// FPRD of `len` bytes at `addr`; working counter 1 expected.
    pub fn read(&self, addr: u16, len: usize) -> Result<Vec<u8>, MasterError> {
        let what = format!("FPRD {addr:#06x}");
        let (data, wkc) = self.datagram_retried(cmd::FPRD, STATION, addr, &vec![0; len], &what)?;
        expect_wkc(&what, 1, wkc)?;
        Ok(data)
    }

    /// FPRD of a u16.
    pub fn read_u16(&self, addr: u16) -> Result<u16, MasterError> {
        let d = self.read(addr, 2)?;
        Ok(u16::from_le_bytes([d[0], d[1]]))
    }

    /// FPWR of `data` at `addr`; working counter 1 expected.
    pub fn write(&self, addr: u16, data: &[u8]) -> Result<(), MasterError> {
        let what = format!("FPWR {addr:#06x}");
        let (_, wkc) = self.datagram_retried(cmd::FPWR, STATION, addr, data, &what)?;
        expect_wkc(&what, 1, wkc)
    }

    /// FPWR, once, returning the working counter (`None`: no answer).
    pub fn write_once(&self, addr: u16, data: &[u8]) -> Option<u16> {
        self.datagram(cmd::FPWR, STATION, addr, data)
            .map(|(_, w)| w)
    }

    // ------------------------------------------------------------------ bring-up

    /// Finds the slave, resets it as masters do and reads its SII.
    pub fn init(&self) -> Result<SlaveInfo, MasterError> {
        let (_, count) = self.datagram_retried(cmd::BRD, 0, regs::TYPE, &[0; 2], "BRD 0x0000")?;
        expect_wkc("BRD 0x0000 (slave count)", 1, count)?;
        // Reset: INIT with acknowledge, FMMUs, SyncManagers and the cyclic unit off.
        let bwr = |addr: u16, data: &[u8]| {
            self.datagram_retried(cmd::BWR, 0, addr, data, "BWR")
                .map(drop)
        };
        bwr(regs::AL_CONTROL, &[state::INIT | state::ERROR, 0])?;
        bwr(regs::FMMU_BASE, &[0; 256])?;
        bwr(regs::SM_BASE, &[0; 128])?;
        bwr(regs::DC_ACTIVATION, &[0])?;
        let (_, wkc) = self.datagram_retried(
            cmd::APWR,
            0,
            regs::STATION_ADDRESS,
            &STATION.to_le_bytes(),
            "APWR 0x0010",
        )?;
        expect_wkc("APWR station address", 1, wkc)?;
        self.write(regs::EEPROM_CONFIG, &[0, 0])?;
        let info = self.read_sii()?;
        if usize::from(info.mailbox[1]) != MBX || usize::from(info.mailbox[3]) != MBX {
            return Err(MasterError::Slave(format!(
                "mailbox sizes {:?} in the SII, the master is built for {MBX}",
                info.mailbox
            )));
        }
        *self.sdo.borrow_mut() = SdoClient::new(info.mailbox[0], info.mailbox[2], 1);
        *self.info.borrow_mut() = Some(info.clone());
        Ok(info)
    }

    /// The SII as read at [`Self::init`].
    pub fn slave_info(&self) -> Option<SlaveInfo> {
        self.info.borrow().clone()
    }

    /// Waits while the EEPROM interface is busy (0x0502 b15); the last control word.
    fn eeprom_idle(&self) -> Result<u16, MasterError> {
        for _ in 0..EEPROM_POLLS {
            let ctl = self.read_u16(regs::EEPROM_CONTROL)?;
            if ctl & 0x8000 == 0 {
                return Ok(ctl);
            }
        }
        Err(MasterError::Slave("EEPROM interface busy".into()))
    }

    /// Reads SII words from `first` on through the EEPROM interface (read command, busy
    /// poll, data register: 4 or 2 words per read as 0x0502 b6 says).
    pub fn sii_words(&self, first: u16, count: usize) -> Result<Vec<u16>, MasterError> {
        let mut words = Vec::with_capacity(count);
        while words.len() < count {
            let ctl = self.eeprom_idle()?;
            let per_read = if ctl & 0x0040 != 0 { 4 } else { 2 };
            let addr = u32::from(first) + words.len() as u32;
            let mut cmd = vec![0x00, 0x01];
            cmd.extend_from_slice(&addr.to_le_bytes());
            self.write(regs::EEPROM_CONTROL, &cmd)?;
            let ctl = self.eeprom_idle()?;
            if ctl & 0x6000 != 0 {
                return Err(MasterError::Slave(format!(
                    "EEPROM read of word {addr:#x}: error bits {ctl:#06x}"
                )));
            }
            let data = self.read(regs::EEPROM_DATA, per_read * 2)?;
            for w in data.chunks(2) {
                words.push(u16::from_le_bytes([w[0], w[1]]));
            }
        }
        words.truncate(count);
        Ok(words)
    }

    /// Writes one SII word (write enable, write command, busy poll).
    pub fn sii_write_word(&self, addr: u16, value: u16) -> Result<(), MasterError> {
        self.eeprom_idle()?;
        // Data first (0x0508), then control (write enable, write command) and address,
        // whose write starts the command.
        self.write(regs::EEPROM_DATA, &value.to_le_bytes())?;
        let mut cmd = vec![0x01, 0x02];
        cmd.extend_from_slice(&u32::from(addr).to_le_bytes());
        self.write(regs::EEPROM_CONTROL, &cmd)?;
        let ctl = self.eeprom_idle()?;
        if ctl & 0x6000 != 0 {
            return Err(MasterError::Slave(format!(
                "EEPROM write of word {addr:#x}: error bits {ctl:#06x}"
            )));
        }
        Ok(())
    }

    /// The ESC reloads its configuration from the EEPROM (command 4).
    pub fn sii_reload(&self) -> Result<u16, MasterError> {
        self.eeprom_idle()?;
        self.write(regs::EEPROM_CONTROL, &[0x00, 0x04])?;
        self.eeprom_idle()
    }

    /// Identity, mailbox layout and SyncManagers from the SII: the fixed area, then the
    /// categories a block at a time until the SyncM category is in (read with coe-core's
    /// SII reader).
    pub fn read_sii(&self) -> Result<SlaveInfo, MasterError> {
        let mut words = self.sii_words(0, word::FIRST_CATEGORY)?;
        let size_words = (usize::from(words[word::SIZE]) + 1) * 1024 / 16;
        loop {
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            let sii = Sii::new_unchecked(&bytes[..]);
            if let Some(Ok(body)) = sii.category(category::SYNC_MANAGER) {
                let ident = sii.identity();
                let mbx = sii.standard_mailbox();
                let boot = sii.bootstrap_mailbox();
                return Ok(SlaveInfo {
                    identity: [
                        ident.vendor_id,
                        ident.product_code,
                        ident.revision,
                        ident.serial_number,
                    ],
                    mailbox: [
                        mbx.receive_offset,
                        mbx.receive_size,
                        mbx.send_offset,
                        mbx.send_size,
                    ],
                    bootstrap_mailbox: [
                        boot.receive_offset,
                        boot.receive_size,
                        boot.send_offset,
                        boot.send_size,
                    ],
                    sync_managers: SyncManagers::new(body)
                        .map(|e| SiiSm {
                            start: e.start,
                            len: e.len,
                            control: e.control,
                            enable: e.enable,
                            kind: e.sm_type,
                        })
                        .collect(),
                });
            }
            if words.len() >= size_words {
                return Err(MasterError::Slave("no SyncM category in the SII".into()));
            }
            let more = self.sii_words(words.len() as u16, 32)?;
            words.extend(more);
        }
    }

    /// SyncManager `n` as the SII gives it.
    pub fn sm(&self, n: usize) -> Result<SiiSm, MasterError> {
        self.info
            .borrow()
            .as_ref()
            .and_then(|i| i.sync_managers.get(n).copied())
            .ok_or_else(|| MasterError::Slave(format!("SM{n}: no SII entry (init first)")))
    }

    // ------------------------------------------------------------------ ESM

    /// AL status and code.
    pub fn al_status(&self) -> Result<AlStatus, MasterError> {
        let d = self.read(regs::AL_STATUS, 6)?;
        Ok(AlStatus {
            state: d[0] & 0x0F,
            error: d[0] & state::ERROR != 0,
            code: u16::from_le_bytes([d[4], d[5]]),
        })
    }

    /// Writes AL control = `control` as it is and polls AL status until it shows
    /// `control`'s state without error, or the error flag, or [`STATE_POLLS`] polls pass.
    pub fn write_al_control(&self, control: u16) -> Result<AlStatus, MasterError> {
        self.write(regs::AL_CONTROL, &control.to_le_bytes())?;
        let want = (control & 0x0F) as u8;
        let mut last = self.al_status()?;
        for _ in 0..STATE_POLLS {
            if last.state == want || last.error {
                break;
            }
            last = self.al_status()?;
        }
        Ok(last)
    }

    /// Requests `state` as masters do: with the error acknowledge if AL status shows the
    /// error flag. Returns AL status as it settled.
    pub fn request_state(&self, target: u8) -> Result<AlStatus, MasterError> {
        let now = self.al_status()?;
        let ack = if now.error { state::ERROR } else { 0 };
        self.write_al_control(u16::from(target | ack))
    }

    /// Writes SyncManager `n`'s 8 register bytes, disabling it first (the ESC takes start,
    /// length and control only while the SyncManager is disabled).
    pub fn write_sm(&self, n: usize, registers: [u8; 8]) -> Result<(), MasterError> {
        self.write(regs::sm(n) + 6, &[0])?;
        self.write(regs::sm(n), &registers)
    }

    /// Writes SM0/SM1 as the SII gives them (before INIT -> PREOP), enable bit as the SII
    /// says, without disabling them first (what is in the mailboxes stays for the slave
    /// to deal with).
    pub fn configure_mailbox(&self) -> Result<(), MasterError> {
        for n in 0..2 {
            let sm = self.sm(n)?;
            self.write(regs::sm(n), &sm.registers(sm.len, sm.enable & 0x01))?;
        }
        self.sdo.borrow_mut().mailbox().reset_counter();
        Ok(())
    }

    /// Reads the PDO layout over SDO (as ethercrab does: 0x1C12/0x1C13 and each PDO,
    /// expedited uploads), writes SM2/SM3 with their lengths and the FMMUs (outputs at
    /// [`LOGICAL_START`], the inputs right after), and, for DC, starts SYNC0.
    pub fn configure_process_data(&self, sync: Sync) -> Result<ProcessImage, MasterError> {
        let layout = block(sim::read_pdo_layout_with(|index, sub| async move {
            self.sdo_upload(index, sub)
                .map(|d| d.iter().rev().fold(0u32, |v, b| v << 8 | u32::from(*b)))
                .map_err(|e| e.to_string())
        }))
        .map_err(MasterError::Slave)?;
        let bits = |e: &[sim::MappedEntry]| e.iter().map(|e| usize::from(e.bits)).sum::<usize>();
        let image = ProcessImage {
            outputs: bits(&layout.outputs).div_ceil(8),
            inputs: bits(&layout.inputs).div_ceil(8),
            layout,
        };
        *self.image.borrow_mut() = Some(image.clone());
        self.rewrite_process_data(sync)?;
        Ok(image)
    }

    /// Writes SM2/SM3 and the FMMUs for the process image read last (a master going from
    /// PREOP to SAFEOP again), and sets `sync`.
    pub fn rewrite_process_data(&self, sync: Sync) -> Result<(), MasterError> {
        let (outputs, inputs) = self
            .image
            .borrow()
            .as_ref()
            .map(|i| (i.outputs, i.inputs))
            .ok_or_else(|| MasterError::Slave("no process image read yet".into()))?;
        let (sm2, sm3) = (self.sm(2)?, self.sm(3)?);
        self.write_sm(2, sm2.registers(outputs as u16, 0x01))?;
        self.write_sm(3, sm3.registers(inputs as u16, 0x01))?;
        self.write(
            regs::fmmu(0),
            &fmmu(LOGICAL_START, outputs, sm2.start, 0x02),
        )?;
        let log_in = LOGICAL_START + outputs as u32;
        self.write(regs::fmmu(1), &fmmu(log_in, inputs, sm3.start, 0x01))?;
        self.set_sync(sync)
    }

    /// Sets the synchronisation: DC starts the SYNC0 unit (0x0981 = 0, read the system
    /// time, 0x09A0 cycle, 0x0990 start = time + [`DC_START_DELAY_NS`], 0x0981 = 3), SM-sync
    /// stops it.
    pub fn set_sync(&self, sync: Sync) -> Result<(), MasterError> {
        self.write(regs::DC_ACTIVATION, &[0])?;
        if let Sync::Dc { cycle_ns } = sync {
            // The time stamp and the frame that reads it go out together (no cyclic frame
            // in between).
            let t0 = self.now_ns();
            let read =
                FrameBuilder::new().datagram(cmd::FPRD, STATION, regs::DC_SYSTEM_TIME, &[0; 8]);
            let st = self
                .transmit_now(&read.build())
                .and_then(|d| d.into_iter().next())
                .filter(|d| d.wkc == 1)
                .ok_or_else(|| MasterError::NoReply("FPRD 0x0910".into()))?
                .data;
            let system = u64::from_le_bytes(st.try_into().unwrap_or([0; 8]));
            let start = system + DC_START_DELAY_NS;
            self.write(regs::DC_SYNC0_CYCLE, &cycle_ns.to_le_bytes())?;
            self.write(regs::DC_START_TIME, &start.to_le_bytes())?;
            self.write(regs::DC_ACTIVATION, &[0x03])?;
            self.pace.set(Pace {
                origin: t0 + DC_START_DELAY_NS,
                cycle: u64::from(cycle_ns),
                lead: u64::from(cycle_ns) / 2,
            });
        } else {
            self.pace.set(Pace {
                origin: self.now_ns(),
                cycle: sync.cycle_ns(),
                lead: 0,
            });
        }
        self.sync.set(Some(sync));
        self.repace();
        Ok(())
    }

    /// The pace changed: the next background slot follows it.
    fn repace(&self) {
        let next = self.slot_after(self.now_ns()).unwrap_or(u64::MAX);
        self.cyclic.borrow_mut().next_slot = next;
    }

    /// The master's own cycle from now on (its frames keep this cycle whatever SYNC0 does).
    pub fn set_slot_cycle(&self, cycle_ns: u64) {
        let p = self.pace.get();
        self.pace.set(Pace {
            cycle: cycle_ns.max(1),
            ..p
        });
        self.repace();
    }

    /// How long before a SYNC0 edge the cyclic frame leaves (DC; half a cycle by default).
    pub fn set_slot_lead(&self, lead_ns: u64) {
        let p = self.pace.get();
        self.pace.set(Pace { lead: lead_ns, ..p });
        self.repace();
    }

    /// The synchronisation set last.
    pub fn sync(&self) -> Option<Sync> {
        self.sync.get()
    }

    /// The process image set up last.
    pub fn image(&self) -> Option<ProcessImage> {
        self.image.borrow().clone()
    }

    /// INIT -> PREOP -> SAFEOP -> OP with the mailbox and process data set up on the way;
    /// `before_safeop` runs in PREOP (start-up SDOs). Fails at the first state not reached.
    pub fn to_op(
        &self,
        sync: Sync,
        before_safeop: impl FnOnce(&Self) -> Result<(), MasterError>,
    ) -> Result<ProcessImage, MasterError> {
        self.configure_mailbox()?;
        self.expect_state(state::PREOP)?;
        before_safeop(self)?;
        let image = self.configure_process_data(sync)?;
        self.expect_state(state::SAFEOP)?;
        self.expect_state(state::OP)?;
        Ok(image)
    }

    /// Requests `target` and fails unless AL status shows it without error.
    pub fn expect_state(&self, target: u8) -> Result<AlStatus, MasterError> {
        let s = self.request_state(target)?;
        if s.state == target && !s.error {
            Ok(s)
        } else {
            Err(MasterError::Slave(format!(
                "state {target:#x} requested: AL status {:#04x}, code {:#06x}",
                s.pair().0,
                s.code
            )))
        }
    }

    // ------------------------------------------------------------------ mailbox

    /// The SDO client (with its mailbox client) for step-by-step use:
    /// `block(master.sdo().upload(&master, 0x1000, 0))`.
    pub fn sdo(&self) -> RefMut<'_, SdoClient<MBX>> {
        self.sdo.borrow_mut()
    }

    /// The mailbox client for raw use: `block(master.sdo().mailbox().send(...))`.
    pub fn send_mailbox(&self, payload: &[u8]) -> Result<bool, MasterError> {
        block(self.sdo().mailbox().send(self, MAILBOX_TYPE_COE, payload))
            .map_err(MasterError::Slave)
    }

    /// An SDO upload (any size); Emergencies read on the way are kept
    /// ([`Self::take_emergencies`]).
    pub fn sdo_upload(&self, index: u16, sub: u8) -> Result<Vec<u8>, SdoError> {
        self.sdo_upload_full(index, sub, false).map(|u| u.data)
    }

    /// An SDO upload, `complete` access or not, with how it travelled.
    pub fn sdo_upload_full(&self, index: u16, sub: u8, complete: bool) -> Result<Upload, SdoError> {
        let mut emcy = Vec::new();
        let r = block(
            self.sdo()
                .upload_with(self, index, sub, complete, &mut |f| emcy.push(f)),
        );
        self.keep_frames(emcy);
        r
    }

    /// An SDO download (expedited, normal or segmented as the size asks).
    pub fn sdo_download(&self, index: u16, sub: u8, data: &[u8]) -> Result<usize, SdoError> {
        block(self.sdo().download(self, index, sub, data))
    }

    fn keep_frames(&self, frames: Vec<[u8; MBX]>) {
        for f in frames {
            match Emergency::parse(&f) {
                Some(e) => self.emergencies.borrow_mut().push(e),
                None => self.unexpected.borrow_mut().push(f),
            }
        }
    }

    /// Reads the read mailbox while it holds frames (at most `max`): Emergencies are kept
    /// ([`Self::take_emergencies`]), anything else too ([`Self::take_unexpected`]).
    pub fn drain_mailbox(&self, max: usize) -> Result<usize, MasterError> {
        let mut n = 0;
        while n < max {
            let frame = block(self.sdo().mailbox().try_read(self)).map_err(MasterError::Slave)?;
            let Some(frame) = frame else { break };
            self.keep_frames(vec![frame]);
            n += 1;
            // The slave writes the next frame on the SM1 event: give it a moment.
            self.wait(20_000);
        }
        Ok(n)
    }

    /// The Emergencies received so far (and forgets them).
    pub fn take_emergencies(&self) -> Vec<Emergency> {
        std::mem::take(&mut self.emergencies.borrow_mut())
    }

    /// Frames received that were neither an answer nor an Emergency (and forgets them).
    pub fn take_unexpected(&self) -> Vec<[u8; MBX]> {
        std::mem::take(&mut self.unexpected.borrow_mut())
    }

    // ------------------------------------------------------------------ process data

    /// One LRW over the process image now: writes `outputs`, returns the inputs. Working
    /// counter 3 expected (inputs read + outputs written). With the background frames
    /// running, `outputs` become theirs and this frame takes the slot it is in.
    pub fn cycle(&self, outputs: &[u8]) -> Result<Vec<u8>, MasterError> {
        let r = self.lrw(outputs);
        let next = self.slot_after(self.now_ns());
        let mut c = self.cyclic.borrow_mut();
        if c.running {
            c.outputs = outputs.to_vec();
            if c.next_slot <= self.now_ns() {
                c.next_slot = next.unwrap_or(u64::MAX);
            }
        }
        r
    }

    fn lrw(&self, outputs: &[u8]) -> Result<Vec<u8>, MasterError> {
        let (out_len, in_len) = self
            .image
            .borrow()
            .as_ref()
            .map(|i| (i.outputs, i.inputs))
            .ok_or_else(|| MasterError::Slave("no process image".into()))?;
        let mut data = vec![0u8; out_len + in_len];
        let n = outputs.len().min(out_len);
        data[..n].copy_from_slice(&outputs[..n]);
        let frame = FrameBuilder::new().logical(cmd::LRW, LOGICAL_START, &data);
        let mut d = self
            .transmit_now(&frame.build())
            .filter(|d| !d.is_empty())
            .ok_or_else(|| MasterError::NoReply("LRW".into()))?;
        let d = d.remove(0);
        expect_wkc("LRW", 3, d.wkc)?;
        Ok(d.data[out_len..].to_vec())
    }

    /// Waits for the next cycle slot: in DC mode (by default) half a cycle before the next
    /// SYNC0 edge, in SM-synchronous mode the next multiple of the cycle.
    pub fn wait_cycle_slot(&self) {
        if let Some(slot) = self.slot_after(self.now_ns()) {
            self.wait_until(slot);
        }
    }

    /// The AO values as process data (0x6411:01/02 are the image's first two INTEGER16).
    pub fn ao_image(a: i16, b: i16) -> [u8; 4] {
        let (a, b) = (a.to_le_bytes(), b.to_le_bytes());
        [a[0], a[1], b[0], b[1]]
    }

    /// The DAC model's output registers (what the outputs show).
    pub fn dac(&self) -> [u16; 2] {
        self.board.borrow().dac().borrow().dac
    }
}

fn expect_wkc(what: &str, expected: u16, got: u16) -> Result<(), MasterError> {
    if got == expected {
        Ok(())
    } else {
        Err(MasterError::WorkingCounter {
            what: what.into(),
            expected,
            got,
        })
    }
}

/// The 16 bytes of an FMMU mapping `len` bytes at logical `log` onto `phys` (`kind`: 1
/// read, 2 write), activated.
pub fn fmmu(log: u32, len: usize, phys: u16, kind: u8) -> [u8; 16] {
    let mut b = [0u8; 16];
    b[0..4].copy_from_slice(&log.to_le_bytes());
    b[4..6].copy_from_slice(&(len as u16).to_le_bytes());
    b[6] = 0;
    b[7] = 7;
    b[8..10].copy_from_slice(&phys.to_le_bytes());
    b[0x0B] = kind;
    b[0x0C] = 0x01;
    b
}

impl RegisterPort for ScriptedMaster {
    async fn read_u8(&self, addr: u16) -> Result<u8, String> {
        self.read(addr, 1).map(|d| d[0]).map_err(|e| e.to_string())
    }

    async fn write_u8(&self, addr: u16, value: u8) -> Result<(), String> {
        self.write(addr, &[value]).map_err(|e| e.to_string())
    }

    /// A write whose answer is lost is sent again, unchanged (same counter), until the
    /// slave takes it, as SOEM's mailbox send does: if the first copy was taken the slave
    /// drops the second as a repeated counter.
    async fn write_buffer<const N: usize>(
        &self,
        addr: u16,
        data: &[u8; N],
    ) -> Result<bool, String> {
        if let Some(wkc) = self.write_once(addr, data) {
            return Ok(wkc == 1);
        }
        for _ in 0..MAILBOX_RESENDS {
            self.net.borrow_mut().stats.retries += 1;
            if self.write_once(addr, data) == Some(1) {
                return Ok(true);
            }
            self.wait(10_000);
        }
        Err(format!("mailbox write at {addr:#06x}: never taken"))
    }

    async fn read_buffer<const N: usize>(&self, addr: u16) -> Result<Option<[u8; N]>, String> {
        let what = format!("FPRD {addr:#06x}");
        match self.datagram(cmd::FPRD, STATION, addr, &[0; N]) {
            Some((d, 1)) => Ok(d.try_into().ok()),
            Some(_) => Ok(None),
            None => Err(MasterError::NoReply(what).to_string()),
        }
    }
}
