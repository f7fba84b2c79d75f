//! The EtherCAT slave application: everything between the ESC registers and the CoE core
//! that does not depend on the MCU, for any device behind the [`Application`] trait: the
//! ESM with its checks, the mailbox (CoE SDO, SDO Information, Emergencies, FoE answered
//! "bootstrap only"), the process data over the PDI, the sync modes and the cycle
//! monitor, the SyncManager watchdog and the safety service. It knows no product, no
//! converter and no other fieldbus.
//!
//! # Entry points and priorities
//!
//! | Caller (priority)          | Call                                   | State touched                   |
//! |----------------------------|----------------------------------------|---------------------------------|
//! | PDI IRQ task (middle)      | [`SlaveApp::on_pdi_irq`] ([`pdi_task::PdiTask::run`]) | `SlaveApp`, the ESC, the stage |
//! | background                 | [`SlaveApp::poll`]                     | the same, from the same task    |
//! | mailbox task (below)       | [`SlaveApp::mailbox_step`], one step per lock, while [`PdiOutcome::serve_mailbox`] asked | the same, under the lock |
//!
//! The application's [`CycleStage`] is the one thing shared with the task that acts at the
//! SYNC0 edge (lock-free). When [`PdiOutcome::apply_outputs`] is set, the PDI task asks
//! that task to apply the staged outputs now (free run, SM-synchronous, faults). After
//! each SYNC0 edge the PDI task's [`SlaveApp::poll`] should run (pend it) so the inputs of
//! the cycle reach SM3 and the cycle monitor sees the edge.
//!
//! # A host harness (the virtual board) in a few lines
//!
//! ```text
//! let stage = OutputStage::new();
//! let mut app = SlaveApp::new(CONFIG, application);
//! app.start(&mut esc)?;
//! // IRQ line asserted:
//! if app.on_pdi_irq(&mut esc, &stage, now_ns)?.apply_outputs {
//!     // the output task applies the staged outputs
//! }
//! // SYNC0 edge: the output task latches, then
//! app.poll(&mut esc, &stage, now_ns)?;
//! ```

pub mod application;
pub mod boot_slave;
pub mod confirm;
pub mod mailbox;
pub mod op_modes;
pub mod pdi_task;
pub mod sync;
pub mod sync_objects;

pub use application::{Application, CycleStage, DcStart, Effects};

use crate::platform::div::div_u64_u32;
use crate::stacks::diagnostics::{
    EMCY_PDI_ERROR, EMCY_SYNC_ERROR, EMCY_WATCHDOG, ERR_COMMUNICATION,
};
use coe_core::device::{MemoryWindow, SyncManagerDesc};
use coe_core::esm::{Esm, Transition};
use coe_core::sdo_server::Emergency;
use coe_core::{AlState, AlStatusCode};
use confirm::Confirmed;
use et1100::{
    AlEvents, AlStatus, Et1100, Pdi, PdiResult, Register, SmMode, SyncManager, WatchdogStatus,
};
use mailbox::{mailbox_sm_ok, AppLink, Service, EVENT_SAMPLE_MS, SAFETY_SERVICE_MS};
use sync::{check_sync, SyncInputs, SyncMode, SyncMonitor, SyncVerdict};

/// What the device description fixes for the application.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AppConfig {
    /// SM0..SM3 as the device description (SII/ESI) gives them. The mailboxes are checked
    /// against start, length and control byte; the process-data SyncManagers against start
    /// and control byte, their length follows the PDO configuration.
    pub sm: [SyncManagerDesc; 4],
    /// Explicit device ID for the ID request (`None`: not supported).
    pub device_id: Option<u16>,
    /// The bootstrap mailbox (master -> slave, slave -> master) the master must configure
    /// for INIT -> BOOT, which resets the module into its bootloader; `None`: no BOOT state
    /// (refused with 0x0013).
    pub bootstrap: Option<(MemoryWindow, MemoryWindow)>,
}

/// What the PDI task must do after a call.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdiOutcome {
    /// Ask the output task to apply the staged outputs now: fresh outputs (free run,
    /// SM-synchronous) or fault values.
    pub apply_outputs: bool,
    /// An SM2 event (the master's outputs of a cycle) was served.
    pub sm2_event: bool,
    /// A master asked for BOOT on a well configured bootstrap mailbox: set the boot request
    /// ([`crate::platform::boot::request`]) and reset the CPU; the bootloader takes it from there.
    pub enter_bootloader: bool,
    /// The mailbox needs its service: run [`SlaveApp::mailbox_step`] from the mailbox task
    /// (below the PDI task) until it says there is no more.
    pub serve_mailbox: bool,
}

/// What one step of the mailbox job did ([`SlaveApp::mailbox_step`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MailboxStep {
    /// More steps are to come: call again (after letting higher priorities run).
    pub more: bool,
    /// What the step asks of the output task (SDO-written outputs in OP).
    pub outcome: PdiOutcome,
}

/// AL event bits always enabled.
const BASE_EVENTS: AlEvents = AlEvents::AL_CONTROL
    .union(AlEvents::SM_ACTIVATION)
    .union(AlEvents::WATCHDOG);

/// The slave application (ESM, mailbox, process data over the PDI) for the device `A`.
pub struct SlaveApp<A: Application> {
    esm: Esm,
    mailbox: AppLink,
    app: A,
    config: AppConfig,
    /// The AL event mask last written to the ESC.
    mask: Option<AlEvents>,
    /// What the mask is made of (ESM state, output layout, the mailbox's wanted events) may
    /// have changed since it was worked out: a cycle that changed none of it skips the work.
    mask_stale: bool,
    sync0_seen: u32,
    /// Time of the next unconditional mailbox service (ns); never while in INIT.
    mailbox_check_ns: u64,
    /// The safety service is due: the mailbox task reads the PDI error counter first.
    pdi_errors_due: bool,
    /// Time of the background poll's next own event sample (ns).
    event_sample_ns: u64,
    /// Read changed outputs twice before taking them (decided at PREOP -> SAFEOP).
    confirm_outputs: bool,
    /// Buffers of the confirming reads of the outputs.
    fresh: A::OutputBuffer,
    again: A::OutputBuffer,
    /// Output reads dropped because no two reads agreed.
    rejected_reads: u16,
    /// The ESC's PDI error counter and the dropped reads as last reported.
    pdi_reported: (u8, u16),
}

impl<A: Application> SlaveApp<A> {
    /// The slave application in INIT for the device `app`.
    pub fn new(config: AppConfig, app: A) -> Self {
        Self {
            esm: Esm::new()
                .with_device_id(config.device_id)
                .with_bootstrap(config.bootstrap.is_some()),
            mailbox: AppLink::for_dictionary(app.od()),
            app,
            config,
            mask: None,
            mask_stale: true,
            sync0_seen: 0,
            mailbox_check_ns: u64::MAX,
            pdi_errors_due: false,
            event_sample_ns: 0,
            confirm_outputs: true,
            fresh: A::output_buffer(),
            again: A::output_buffer(),
            rejected_reads: 0,
            pdi_reported: (0, 0),
        }
    }

    /// The ESM state.
    pub fn state(&self) -> AlState {
        self.esm.state()
    }

    /// The ESM (status word, error, code).
    pub fn esm(&self) -> &Esm {
        &self.esm
    }

    /// The device.
    pub fn application(&self) -> &A {
        &self.app
    }

    /// The device, to change (samples in, a second fieldbus's calls).
    pub fn application_mut(&mut self) -> &mut A {
        &mut self.app
    }

    /// The sync mode, 0x1C32/0x1C33 and the cycle monitor (the application keeps it).
    pub fn sync(&self) -> &SyncMonitor<A::Figures> {
        self.app.sync()
    }

    /// The mailbox link.
    pub fn mailbox(&self) -> &AppLink {
        &self.mailbox
    }

    /// Power-up: AL status INIT without error, event mask.
    pub fn start<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<(), P> {
        self.write_status(esc)?;
        self.update_mask(esc)
    }

    /// The ESC IRQ: reads the AL event bits once and serves AL control, watchdog, outputs
    /// (SM2), and asks for the mailbox service (SM0/SM1, the SyncManager activation with
    /// the repeat request) when its event bits say it has work
    /// ([`mailbox::MailboxLink::needs_service`]): the mailbox task runs it
    /// ([`Self::mailbox_step`]), below this one, so no mailbox exchange holds the outputs.
    ///
    /// The event bits come from [`Pdi::low_events`]: on the SPI PDI a NOP with 2 address
    /// bytes, which shifts out 0x0220/0x0221 (AL control .. SM7). The 3-byte NOP would add
    /// 0x0222 (SyncManagers 8..15), which the ET1100 does not have, for one more byte on the
    /// bus in every cycle.
    // Out of line: inlined, the PDI task's image is larger (one call per activation).
    #[inline(never)]
    pub fn on_pdi_irq<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
    ) -> PdiResult<PdiOutcome, P> {
        let events = esc.low_events()?;
        let mut out = PdiOutcome::default();
        if events.contains(AlEvents::AL_CONTROL) {
            let from = self.esm.state();
            self.al_control(esc, stage, &mut out)?;
            if from == AlState::Init && self.esm.state() == AlState::PreOp {
                // INIT -> PREOP has just read the mailbox registers.
                self.arm_mailbox_check(now_ns);
            }
        }
        if events.contains(AlEvents::WATCHDOG) {
            self.watchdog(esc, stage, &mut out)?;
        }
        if events.contains(AlEvents::SM2) {
            self.outputs(esc, stage, now_ns, &mut out)?;
            out.sm2_event = true;
            self.app.on_output_event(now_ns);
            if self.safety_service_due(now_ns) {
                self.want_safety_service(now_ns, &mut out);
            }
        }
        let activation = events.contains(AlEvents::SM_ACTIVATION);
        if activation {
            // Reading the activate registers (SM0..SM3 in one access) clears the event.
            let mut all = [0u8; 4 * SyncManager::SIZE];
            esc.read(Register::SyncManager0.addr(), &mut all)?;
        }
        let mailbox_work = self.esm.state() != AlState::Init && self.mailbox_has_work(events);
        if activation {
            let how = Service::Registers { check_repeat: true };
            self.want_mailbox(now_ns, how, &mut out);
        } else if mailbox_work {
            self.want_mailbox(now_ns, Service::Events(events), &mut out);
        }
        self.update_mask(esc)?;
        Ok(out)
    }

    /// Background work: the cycle monitor (missed SM events at the SYNC0 edges), the
    /// inputs outside SM-synchronous cycles, and the mailbox (waiting reply, SDO
    /// Information fragments, Emergencies) when the event bits of the inputs write or the
    /// waiting work call for it, else every [`SAFETY_SERVICE_MS`].
    // Out of line: inlined, the PDI task's image is larger (one call per activation).
    #[inline(never)]
    pub fn poll<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
    ) -> PdiResult<PdiOutcome, P> {
        let mut out = PdiOutcome::default();
        let state = self.esm.state();
        let counts = stage.sync0_counts();
        let new_edge = counts.edges != self.sync0_seen;
        self.sync0_seen = counts.edges;
        self.app
            .on_cycle_polled(stage, now_ns, new_edge.then_some(counts.last_edge_lo));
        if self.app.sync_mut().on_sync0_counts(counts) == SyncVerdict::SyncError {
            self.sync_error(esc, stage, AlStatusCode::SynchronizationError, &mut out)?;
        }
        let in_op = self.esm.state() == AlState::Op;
        let sync0 = self
            .app
            .sync_mut()
            .on_sync0_time(now_ns, counts.edges, in_op);
        if sync0 == SyncVerdict::FatalSyncError {
            self.sync_error(esc, stage, AlStatusCode::FatalSyncError, &mut out)?;
        }
        if self.esm.state() == AlState::Op {
            if let Some(code) = self.app.op_fault() {
                self.local_error(esc, stage, code, &mut out)?;
            }
        }
        let mut events = None;
        if matches!(self.esm.state(), AlState::SafeOp | AlState::Op) {
            let mode = self.app.sync().mode();
            let free = mode == SyncMode::FreeRun || !self.app.sync().armed();
            if free || (mode == SyncMode::DcSync0 && new_edge) {
                events = self.write_inputs(esc)?;
            }
        }
        if state != AlState::Init {
            // The event bits of the inputs write, else (every EVENT_SAMPLE_MS) a sample of
            // its own; the IRQ serves the mailbox events as they come.
            let events = match events {
                Some(e) => e,
                None if now_ns >= self.event_sample_ns => {
                    self.event_sample_ns =
                        now_ns.saturating_add(u64::from(EVENT_SAMPLE_MS) * 1_000_000);
                    esc.low_events()?
                }
                None => AlEvents::empty(),
            };
            let work = self.mailbox_has_work(events);
            // In DC cycles the output event asks for the periodic register reads, so that
            // their steps start after the outputs are preloaded and cannot hold a frame's
            // outputs back past SYNC0; here only if no output event came for a period.
            let dc_cycles = matches!(self.esm.state(), AlState::SafeOp | AlState::Op)
                && self.app.sync().mode() == SyncMode::DcSync0
                && self.app.sync().armed();
            let overdue = now_ns
                >= self
                    .mailbox_check_ns
                    .saturating_add(u64::from(SAFETY_SERVICE_MS) * 1_000_000);
            if self.safety_service_due(now_ns) && (!dc_cycles || overdue) {
                self.want_safety_service(now_ns, &mut out);
            } else if work {
                self.want_mailbox(now_ns, Service::Events(events), &mut out);
            }
        }
        self.update_mask(esc)?;
        Ok(out)
    }

    // ------------------------------------------------------------------ ESM

    /// Writes AL status code and AL status and reads them back, writing again what did not
    /// arrive: the master must see the state the slave is in, and the SPI has no checksum.
    fn write_status<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<(), P> {
        self.mask_stale = true;
        self.app
            .set_running(matches!(self.esm.state(), AlState::SafeOp | AlState::Op));
        let (status, code) = (self.esm.status(), self.esm.status_code_word());
        for _ in 0..confirm::MAX_READS {
            esc.write_al_status(AlStatus(status), code)?;
            // 0x0130..0x0135: status, reserved, code.
            let mut back = [0u8; 6];
            esc.read(Register::AlStatus.addr(), &mut back)?;
            let got = (
                u16::from_le_bytes([back[0], back[1]]),
                u16::from_le_bytes([back[4], back[5]]),
            );
            if got == (status, code) {
                break;
            }
        }
        Ok(())
    }

    /// An Emergency of the device (also one another fieldbus's call raised): into the
    /// error history (0x1003), out on the mailbox and to the application (for another
    /// fieldbus). (Out of line: many callers, none on the process-data path's usual way.)
    #[inline(never)]
    pub fn emergency(&mut self, e: Emergency) {
        self.mailbox.queue_emergency(e);
        self.app.diagnostics().history.record(&e);
        self.app.on_emergency(&e);
    }

    /// [`MailboxLink::needs_service`](mailbox::MailboxLink::needs_service). Outside the
    /// mailbox service, what the mailbox waits for changes only while SM1 is busy: then
    /// the event bits (SM1 read, a request that waits) and a queued Emergency count.
    fn mailbox_has_work(&mut self, events: AlEvents) -> bool {
        if self.mailbox.sm1_busy() {
            self.mask_stale = true;
        }
        self.mailbox.needs_service(events)
    }

    /// The AL event mask, worked out again only if what it is made of may have changed.
    #[inline(always)]
    fn update_mask<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<(), P> {
        match self.mask_stale {
            true => self.write_mask(esc),
            false => Ok(()),
        }
    }

    fn write_mask<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<(), P> {
        let mut mask = BASE_EVENTS;
        let state = self.esm.state();
        if state != AlState::Init {
            mask |= self.mailbox.event_mask();
        }
        if matches!(state, AlState::SafeOp | AlState::Op) && !self.app.output_image().is_empty() {
            mask |= AlEvents::SM2;
        }
        if self.mask != Some(mask) {
            esc.set_event_mask(mask)?;
            self.mask = Some(mask);
        }
        self.mask_stale = false;
        Ok(())
    }

    fn al_control<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        out: &mut PdiOutcome,
    ) -> PdiResult<(), P> {
        // Read until two reads agree (a flipped bit would request a state the master never
        // asked for); if none do, the last read stands and the master sees the outcome.
        let (mut control, mut again) = ([0u8; 2], [0u8; 2]);
        confirm::read_confirmed(&mut control, None, &mut again, |b| {
            esc.read(Register::AlControl.addr(), b).map(drop)
        })?;
        let control = u16::from_le_bytes(control);
        let had_error = self.esm.error();
        let decision = self.esm.request(control);
        if had_error && !self.esm.error() {
            if let Some(e) = self.app.diagnostics().clear(ERR_COMMUNICATION) {
                self.emergency(e);
            }
        }
        match decision {
            Transition::Allowed {
                from: AlState::Init,
                to: AlState::Bootstrap,
            } => {
                // The state stays INIT: the bootloader reports BOOT once it serves the
                // bootstrap mailbox, so no FoE request reaches an MCU that is resetting.
                if self.bootstrap_mailbox_ok(esc)? {
                    out.enter_bootloader = true;
                } else {
                    self.esm
                        .fail(AlState::Init, AlStatusCode::InvalidMailboxConfigurationBoot);
                }
            }
            Transition::Allowed { from, to } => {
                match self.transition(esc, stage, from, to, out)? {
                    Ok(()) => self.esm.complete(to),
                    Err((state, code)) => self.esm.fail(state, code),
                }
                let to = self.esm.state();
                let mailbox = &mut self.mailbox;
                self.app
                    .with_objects(stage, 0, |o| mailbox.on_state_change(o, from, to));
                if self.esm.state() == AlState::Init {
                    self.mailbox_check_ns = u64::MAX;
                }
            }
            _ => {}
        }
        self.write_status(esc)
    }

    /// SM0/SM1 as the master configured them for BOOT, against the bootstrap mailbox.
    fn bootstrap_mailbox_ok<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<bool, P> {
        let Some((out, inp)) = self.config.bootstrap else {
            return Ok(false);
        };
        let [sm0, sm1, ..] = self.config.sm;
        let ok0 = mailbox_sm_ok(&esc.read_sm(0)?, out.start, out.len, sm0.control);
        let ok1 = mailbox_sm_ok(&esc.read_sm(1)?, inp.start, inp.len, sm1.control);
        Ok(ok0 && ok1)
    }

    /// Checks and actions of `from -> to`; `Err((state, code))` refuses it.
    fn transition<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        from: AlState,
        to: AlState,
        out: &mut PdiOutcome,
    ) -> PdiResult<Result<(), (AlState, AlStatusCode)>, P> {
        if from == AlState::Op {
            // Leaving OP: safe outputs at once, stale outputs never come back.
            self.app.enter_fault(stage);
            self.app.sync_mut().disarm();
            out.apply_outputs = true;
        }
        match (from, to) {
            (AlState::Init, AlState::PreOp) => {
                let mut regs = [SyncManager::default(); 2];
                for (n, slot) in (0..2u8).zip(regs.iter_mut()) {
                    let sm = esc.read_sm(n)?;
                    let expect = self.config.sm.get(usize::from(n)).copied();
                    if !expect.is_some_and(|e| mailbox_sm_ok(&sm, e.start, e.len, e.control)) {
                        return Ok(Err((
                            AlState::Init,
                            AlStatusCode::InvalidMailboxConfiguration,
                        )));
                    }
                    *slot = sm;
                }
                self.mailbox.start(esc, regs[0], regs[1])?;
                self.app.sync_mut().reset();
            }
            (AlState::PreOp, AlState::SafeOp) => {
                if let Err(code) = self.prepare_safeop(esc, stage)? {
                    return Ok(Err((AlState::PreOp, code)));
                }
            }
            (AlState::SafeOp, AlState::Op) => {
                if let Err(code) = self.app.check_op() {
                    return Ok(Err((AlState::SafeOp, code)));
                }
                // Accepted before the first outputs arrive; the outputs stay safe until
                // fresh process data come in OP.
                self.app.sync_mut().enter_op();
            }
            _ => {}
        }
        if matches!(to, AlState::Init | AlState::PreOp) {
            stage.set_dc_mode(false);
        }
        Ok(Ok(()))
    }

    fn prepare_safeop<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
    ) -> PdiResult<Result<(), AlStatusCode>, P> {
        let sm2 = esc.read_sm(2)?;
        let sm3 = esc.read_sm(3)?;
        let dc_activation = esc.sync_activation()?;
        let sync0_cycle_ns = esc.sync0_cycle_ns()?;
        let (requested, requested_inputs) = self.app.sync().requests();
        let inputs = SyncInputs {
            requested,
            requested_inputs,
            dc_activation,
            sync0_cycle_ns,
            has_outputs: self.app.output_len() > 0,
            sm2_three_buffer: sm2.mode() == SmMode::Buffered,
            min_cycle_ns: self.app.sync().figures().min_cycle_ns,
        };
        let mode = match check_sync(&inputs) {
            Ok(mode) => mode,
            Err(e) => return Ok(Err(e.al_status_code())),
        };
        let [_, _, expect2, expect3] = self.config.sm;
        if let Err(code) = self.app.prepare(&sm2, &sm3, &expect2, &expect3) {
            return Ok(Err(code));
        }
        let dc = match mode {
            SyncMode::DcSync0 if A::WANTS_DC_START => {
                Some(self.dc_start(esc, stage, sync0_cycle_ns)?)
            }
            _ => None,
        };
        if let Err(code) = self.app.start_sync(dc) {
            return Ok(Err(code));
        }
        self.app.sync_mut().start(mode, sync0_cycle_ns);
        self.confirm_outputs = mode != SyncMode::DcSync0
            || sync0_cycle_ns >= self.app.sync().figures().confirm_outputs_min_cycle_ns;
        stage.set_dc_mode(mode == SyncMode::DcSync0);
        // Inputs are valid in SAFEOP.
        self.write_inputs(esc)?;
        Ok(Ok(()))
    }

    /// Where the SYNC0 edges lie in DC time: the system time and the next SYNC0 time read
    /// back to back, and the last edge captured before them if SYNC0 runs (the edge that
    /// came `cycle - (next - now)` before); read again if an edge came during the reads.
    fn dc_start<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        cycle_ns: u32,
    ) -> PdiResult<DcStart, P> {
        let mut tries = 2;
        loop {
            let before = stage.sync0_counts();
            let now = esc.system_time()?;
            let next = esc.read_u64(Register::DcStartTime)?;
            let after = stage.sync0_counts();
            tries -= 1;
            if before.edges == after.edges || tries == 0 {
                let running = next.wrapping_sub(now) <= u64::from(cycle_ns) && after.edges > 0;
                return Ok(DcStart {
                    cycle_ns,
                    next_sync0_dc: next,
                    previous_edge_lo: running.then_some(after.last_edge_lo),
                });
            }
        }
    }

    // ------------------------------------------------------------ faults

    fn watchdog<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        out: &mut PdiOutcome,
    ) -> PdiResult<(), P> {
        let status = esc.watchdog_status()?;
        if status == WatchdogStatus::Expired && self.esm.state() == AlState::Op {
            self.local_error(esc, stage, AlStatusCode::SyncManagerWatchdog, out)?;
            let e = self
                .app
                .diagnostics()
                .raise(ERR_COMMUNICATION, EMCY_WATCHDOG, [0; 5]);
            self.emergency(e);
        }
        Ok(())
    }

    /// A sync error (0x001A) or, SYNC0 gone, the fatal sync error (0x002C): Emergency, and
    /// in OP SAFEOP with the fault values.
    fn sync_error<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        code: AlStatusCode,
        out: &mut PdiOutcome,
    ) -> PdiResult<(), P> {
        let counter = self.app.sync().error_counter().to_le_bytes();
        let e = self.app.diagnostics().raise(
            ERR_COMMUNICATION,
            EMCY_SYNC_ERROR,
            [counter[0], counter[1], 0, 0, 0],
        );
        self.emergency(e);
        if self.esm.state() == AlState::Op {
            self.local_error(esc, stage, code, out)?;
        }
        Ok(())
    }

    /// OP -> SAFEOP with `code`, fault outputs.
    fn local_error<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        code: AlStatusCode,
        out: &mut PdiOutcome,
    ) -> PdiResult<(), P> {
        let from = self.esm.state();
        self.app.enter_fault(stage);
        self.app.sync_mut().disarm();
        out.apply_outputs = true;
        self.esm.local_error(AlState::SafeOp, code);
        let to = self.esm.state();
        let mailbox = &mut self.mailbox;
        self.app
            .with_objects(stage, 0, |o| mailbox.on_state_change(o, from, to));
        self.write_status(esc)
    }

    /// Reports a rise of the ESC's PDI error counter (0x030D, with its code 0x030E) or of the
    /// dropped output reads with an Emergency, once per rise (the master may clear
    /// 0x030D). Called with the periodic safety service.
    fn report_pdi_errors<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<(), P> {
        let mut b = [0u8; 2];
        esc.read(Register::PdiErrorCounter.addr(), &mut b)?;
        let (counter, rejected) = self.pdi_reported;
        let rose = b[0] > counter || self.rejected_reads != rejected;
        self.pdi_reported = (b[0], self.rejected_reads);
        if rose {
            let [lo, hi] = self.rejected_reads.to_le_bytes();
            let e = self
                .app
                .diagnostics()
                .report(EMCY_PDI_ERROR, [b[0], b[1], lo, hi, 0]);
            self.emergency(e);
        }
        Ok(())
    }

    // ------------------------------------------------------------ process data

    fn outputs<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
        out: &mut PdiOutcome,
    ) -> PdiResult<(), P> {
        let state = self.esm.state();
        if !matches!(state, AlState::SafeOp | AlState::Op) {
            return Ok(());
        }
        let start = self.config.sm[2].start;
        let image = self.app.output_image();
        if image.is_empty() {
            return Ok(());
        }
        if self.confirm_outputs {
            // Taken only when two reads agree (or equal to what is staged already): a
            // value the ESC never held must not reach the DAC.
            let n = image.len();
            let (Some(fresh), Some(again)) = (
                self.fresh.as_mut().get_mut(..n),
                self.again.as_mut().get_mut(..n),
            ) else {
                return Ok(());
            };
            let read = confirm::read_confirmed(fresh, Some(image), again, |b| {
                esc.read_process_data(start, b).map(drop)
            })?;
            match read {
                Confirmed::Same => {}
                Confirmed::New => {
                    // A few bytes: a loop costs less than the call into memcpy.
                    for (to, from) in image.iter_mut().zip(fresh.iter()) {
                        *to = *from;
                    }
                }
                Confirmed::Unstable => {
                    // Dropped: in DC mode the SYNC0 edge counts a missed SM event.
                    self.rejected_reads = self.rejected_reads.wrapping_add(1);
                    self.app.on_outputs_refused();
                    return Ok(());
                }
            }
        } else {
            esc.read_process_data(start, image)?;
        }
        let in_op = state == AlState::Op;
        self.app
            .sync_mut()
            .on_sm2_event(now_ns, in_op, stage.sync0_counts());
        if in_op {
            let taken = self.app.take_outputs(stage);
            if let Some(e) = taken.emergency {
                self.emergency(e);
            }
            if taken.apply_outputs && self.app.sync().mode() != SyncMode::DcSync0 {
                out.apply_outputs = true;
            }
        }
        if self.app.sync().mode() != SyncMode::DcSync0 {
            self.write_inputs(esc)?;
        }
        Ok(())
    }

    /// Publishes the samples of the cycle and writes them to SM3; returns the AL event bits
    /// of the write (`None` if nothing was written).
    fn write_inputs<P: Pdi>(&mut self, esc: &mut Et1100<P>) -> PdiResult<Option<AlEvents>, P> {
        let start = self.config.sm[3].start;
        match self.app.input_image() {
            Some(image) if !image.is_empty() => esc.write_process_data(start, image).map(Some),
            _ => Ok(None),
        }
    }

    // ------------------------------------------------------------ mailbox

    /// Whether the periodic safety service (the mailbox and PDI error registers read by the
    /// mailbox task, every [`SAFETY_SERVICE_MS`] from PREOP) is due.
    pub fn safety_service_due(&self, now_ns: u64) -> bool {
        now_ns >= self.mailbox_check_ns
    }

    /// The next safety service of the mailbox: [`SAFETY_SERVICE_MS`] after the registers were
    /// read at `now_ns`. (Out of line: two callers, neither on the process-data path.)
    #[inline(never)]
    fn arm_mailbox_check(&mut self, now_ns: u64) {
        self.mailbox_check_ns = match self.esm.state() {
            AlState::Init => u64::MAX,
            _ => now_ns.saturating_add(u64::from(SAFETY_SERVICE_MS) * 1_000_000),
        };
    }

    /// Asks for the periodic safety service: the PDI error counter, then the mailbox
    /// registers, in the mailbox task. The register reads are the mailbox task's, below
    /// this one, so they hold no SM2 event wherever in the cycle they fall.
    fn want_safety_service(&mut self, now_ns: u64, out: &mut PdiOutcome) {
        self.pdi_errors_due = true;
        let how = Service::Registers {
            check_repeat: false,
        };
        self.want_mailbox(now_ns, how, out);
    }

    /// Asks for the mailbox service `how` (run by [`Self::mailbox_step`]). Reading the
    /// registers re-arms the periodic safety service.
    fn want_mailbox(&mut self, now_ns: u64, how: Service, out: &mut PdiOutcome) {
        if matches!(how, Service::Registers { .. }) {
            self.arm_mailbox_check(now_ns);
        }
        self.mailbox.want(how);
        // No mailbox events while the job waits or runs (the line would stay asserted).
        self.mask_stale = true;
        out.serve_mailbox = true;
    }

    /// One bounded step of the mailbox job ([`mailbox::MailboxLink::step`]: at most one
    /// access of [`mailbox::CHUNK`] bytes to a mailbox buffer, a few to registers, or one
    /// request through the SDO server). The mailbox task calls it, one step per lock of
    /// the application and the ESC, while [`MailboxStep::more`] says so; the PDI and SYNC0
    /// tasks run between two steps. The last step enables the mailbox events again.
    // Out of line: the mailbox task's, not on the process-data path.
    #[inline(never)]
    pub fn mailbox_step<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
    ) -> PdiResult<MailboxStep, P> {
        if core::mem::take(&mut self.pdi_errors_due) {
            // The safety service's first access, a step of its own.
            self.report_pdi_errors(esc)?;
            return Ok(MailboxStep {
                more: true,
                ..Default::default()
            });
        }
        let state = self.esm.state();
        // ns -> ms as (ns / 64) / 15625: a divisor below 2^16 keeps it to 32-bit divisions.
        let now_ms = div_u64_u32(now_ns >> 6, 15_625) as u32;
        let mailbox = &mut self.mailbox;
        let stepped = self.app.with_objects(stage, now_ns, |objects| {
            mailbox.step(esc, state, objects, now_ms)
        });
        let mut step = MailboxStep::default();
        // SDO-written outputs take effect in OP.
        let after = self.app.after_mailbox(state == AlState::Op, stage);
        step.outcome.apply_outputs = after.apply_outputs;
        if let Some(e) = after.emergency {
            self.emergency(e);
        }
        step.more = match stepped {
            Ok(more) => more,
            Err(e) => {
                self.mask_stale = true;
                return Err(e);
            }
        };
        if !step.more {
            self.mask_stale = true;
            self.update_mask(esc)?;
        }
        Ok(step)
    }

    /// Runs the mailbox job to its end at once (host harnesses and tests that do not model
    /// the mailbox task's priority).
    pub fn serve_mailbox<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
    ) -> PdiResult<PdiOutcome, P> {
        let mut out = PdiOutcome::default();
        loop {
            let step = self.mailbox_step(esc, stage, now_ns)?;
            out.apply_outputs |= step.outcome.apply_outputs;
            if !step.more {
                return Ok(out);
            }
        }
    }
}
