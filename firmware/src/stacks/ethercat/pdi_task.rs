//! One activation of the PDI task: the slave application behind the ESC's level IRQ as an
//! edge interrupt sees it, plus the background work pended after SYNC0 or by a timer tick.
//!
//! The ET1100's SPI_IRQ is a level (AL event & mask != 0); the MCU's GPIO interrupt only
//! sees its falling edge. So after serving, the task looks at the line again and pends
//! itself while it stays asserted, at most [`MAX_REPENDS`] times in a row: a line stuck low
//! (an event the application never clears, a broken pin) must not starve the lower
//! priorities. After that the line is still served once per activation (SYNC0, tick), and
//! the budget comes back with the next edge or when the line is seen released.
//!
//! The application is started only once the ESC's PDI is operational (EEPROM loaded), and
//! retried on every activation until then, so a slow or late EEPROM load does not leave the
//! module silent.

use super::{Application, CycleStage, SlaveApp};
use et1100::{Et1100, Pdi};

/// Self-pends in a row while the IRQ line stays asserted after serving.
pub const MAX_REPENDS: u8 = 16;

/// How long `init` waits for the ESC's EEPROM_LOADED before it goes on without it (the PDI
/// task then starts the application when the pin rises): the ET1100 reads its configuration
/// area (16 words over I2C) within a few ms of its reset; 100 ms covers a slow EEPROM and a
/// late ESC reset release.
pub const EEPROM_WAIT_MS: u32 = 100;

/// What woke the PDI task, as the hardware layer saw it at entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Wake {
    /// A falling edge of the IRQ line (acknowledged).
    pub edge: bool,
    /// The IRQ line is asserted now.
    pub line_asserted: bool,
    /// Background work was requested (pended after SYNC0, or the periodic tick).
    pub poll: bool,
    /// The ESC's PDI is operational (EEPROM_LOADED high).
    pub pdi_ready: bool,
}

/// What the hardware layer must do after an activation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Done {
    /// Pend the DAC task to apply the staged outputs now.
    pub apply_outputs: bool,
    /// DC mode: pend the DAC task without the apply request, so it writes freshly staged
    /// outputs into the input registers and the next SYNC0 only pulses LDAC (it does nothing
    /// when nothing fresh is staged).
    pub preload_outputs: bool,
    /// Pend the PDI task again: the line is still asserted, or background work was put off
    /// behind the DAC task.
    pub pend_again: bool,
    /// Set the boot request and reset the CPU into the bootloader (a master's INIT -> BOOT,
    /// [`super::PdiOutcome::enter_bootloader`]).
    pub enter_bootloader: bool,
    /// Pend the mailbox task ([`PdiTask::mailbox_step`]).
    pub serve_mailbox: bool,
}

impl Done {
    /// Takes what one call of the application asks for.
    fn take(&mut self, o: super::PdiOutcome) {
        self.apply_outputs |= o.apply_outputs;
        self.enter_bootloader |= o.enter_bootloader;
        self.serve_mailbox |= o.serve_mailbox;
    }
}

/// Steps of the mailbox job in one activation of the mailbox task before it pends itself
/// again (a bound: a job takes about 20 with 128-byte mailboxes).
pub const MAILBOX_STEPS: u32 = 64;

/// What one step of the mailbox task asks the hardware layer for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MailboxDone {
    /// Step again (after releasing the lock, so higher priorities run first).
    pub more: bool,
    /// Pend the DAC task to apply the staged outputs now (SDO-written outputs in OP).
    pub apply_outputs: bool,
}

/// Bounds the self-pends of a level IRQ seen through an edge interrupt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LevelIrq {
    repends: u8,
    exhausted: u32,
}

impl LevelIrq {
    /// A line with its full budget.
    pub const fn new() -> Self {
        Self {
            repends: 0,
            exhausted: 0,
        }
    }

    /// After serving: whether to pend again. `edge`: this activation came from an edge;
    /// `asserted`: the line is still asserted now.
    pub fn after_serve(&mut self, edge: bool, asserted: bool) -> bool {
        if edge || !asserted {
            self.repends = 0;
        }
        if !asserted {
            return false;
        }
        if self.repends < MAX_REPENDS {
            self.repends += 1;
            return true;
        }
        if self.repends == MAX_REPENDS {
            // Count each exhaustion once; stay above the budget until it comes back.
            self.repends = MAX_REPENDS + 1;
            self.exhausted = self.exhausted.wrapping_add(1);
        }
        false
    }

    /// How often the line stayed asserted through a whole budget.
    pub const fn exhausted(&self) -> u32 {
        self.exhausted
    }
}

/// The PDI task's state: the application, the IRQ line bookkeeping and the error counters.
pub struct PdiTask<A: Application> {
    app: SlaveApp<A>,
    line: LevelIrq,
    started: bool,
    bus_errors: u32,
    /// Background work put off to the next activation (the DAC task first).
    poll_deferred: bool,
}

impl<A: Application> PdiTask<A> {
    /// The task around `app` (not started: see [`PdiTask::run`]).
    pub fn new(app: SlaveApp<A>) -> Self {
        Self {
            app,
            line: LevelIrq::new(),
            started: false,
            bus_errors: 0,
            poll_deferred: false,
        }
    }

    /// The application.
    pub fn app(&self) -> &SlaveApp<A> {
        &self.app
    }

    /// The application, e.g. for another fieldbus's task at the same priority.
    pub fn app_mut(&mut self) -> &mut SlaveApp<A> {
        &mut self.app
    }

    /// Whether [`SlaveApp::start`] has succeeded.
    pub const fn started(&self) -> bool {
        self.started
    }

    /// ESC accesses that failed (the activation's work was cut short).
    pub const fn bus_errors(&self) -> u32 {
        self.bus_errors
    }

    /// The IRQ line bookkeeping.
    pub const fn line(&self) -> &LevelIrq {
        &self.line
    }

    /// Starts the application if the PDI is ready and it has not started yet; `true` once
    /// started.
    pub fn start<P: Pdi>(&mut self, esc: &mut Et1100<P>, pdi_ready: bool) -> bool {
        if !self.started && pdi_ready {
            match self.app.start(esc) {
                Ok(()) => self.started = true,
                Err(_) => self.bus_errors = self.bus_errors.wrapping_add(1),
            }
        }
        self.started
    }

    /// One activation. `still_asserted` reads the line after the work is done. `drain` moves
    /// the new samples into the sampler, at most once: right before the background work,
    /// whose inputs need the newest samples, or at the end of an activation that leaves
    /// nothing to the DAC task. An activation with outputs does not drain: the DAC task runs
    /// when it returns, and the preload must not wait (the next poll, at the latest the
    /// tick's every millisecond, drains; the ring holds several).
    pub fn run<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
        wake: Wake,
        still_asserted: impl FnOnce() -> bool,
        mut drain: impl FnMut(&mut A),
    ) -> Done {
        // Started once; every later activation skips the call.
        if !(self.started || self.start(esc, wake.pdi_ready)) {
            drain(self.app.application_mut());
            // Nothing can be served; the periodic tick retries. No self-pend: a line that
            // an unready ESC holds low must not keep the task busy.
            return Done::default();
        }
        let mut done = Done::default();
        let deferred = core::mem::take(&mut self.poll_deferred);
        let mut poll = wake.poll || deferred;
        if wake.edge || wake.line_asserted {
            let r = self.app.on_pdi_irq(esc, stage, now_ns);
            done.take(self.outcome(r, stage));
            done.preload_outputs = stage.dc_mode() && !done.apply_outputs;
            if !deferred && poll && (done.apply_outputs || done.preload_outputs) {
                // The DAC task is pended only when this activation returns: the outputs
                // go first, the background work in the next activation, or a long one
                // would push the DC preload past the SYNC0 edge. Put off once only, so a
                // stuck line cannot keep the task pending itself.
                self.poll_deferred = true;
                poll = false;
            }
        }
        if poll {
            drain(self.app.application_mut());
            let r = self.app.poll(esc, stage, now_ns);
            done.take(self.outcome(r, stage));
        } else if !(done.apply_outputs || done.preload_outputs) {
            drain(self.app.application_mut());
        }
        done.pend_again = self.line.after_serve(wake.edge, still_asserted()) || self.poll_deferred;
        done
    }

    /// One step of the mailbox task, which runs below this task and calls this under the
    /// lock of the task's state and the ESC, one step per lock
    /// ([`SlaveApp::mailbox_step`]). A failed access ends the job (counted).
    pub fn mailbox_step<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
    ) -> MailboxDone {
        if !self.started {
            return MailboxDone::default();
        }
        let r = self.app.mailbox_step(esc, stage, now_ns);
        let more = r.as_ref().is_ok_and(|s| s.more);
        let outcome = self.outcome(r.map(|s| s.outcome), stage);
        MailboxDone {
            more,
            apply_outputs: outcome.apply_outputs,
        }
    }

    /// Runs the mailbox task's steps at once, at most [`MAILBOX_STEPS`] of them as one
    /// activation of the task does (host harnesses that do not model its priority). True
    /// when a step asked for the staged outputs to be applied.
    pub fn serve_mailbox<P: Pdi>(
        &mut self,
        esc: &mut Et1100<P>,
        stage: &A::Stage,
        now_ns: u64,
    ) -> bool {
        let mut apply_outputs = false;
        for _ in 0..MAILBOX_STEPS {
            let step = self.mailbox_step(esc, stage, now_ns);
            apply_outputs |= step.apply_outputs;
            if !step.more {
                break;
            }
        }
        apply_outputs
    }

    /// What to do after a call. A failed ESC access may have cut off an outcome that a
    /// fault already staged: then the DAC task is asked anyway (outside DC mode, or when a
    /// fault pair waits). It applies only a pair it has not applied yet.
    fn outcome<E>(
        &mut self,
        r: Result<super::PdiOutcome, E>,
        stage: &A::Stage,
    ) -> super::PdiOutcome {
        match r {
            Ok(o) => o,
            Err(_) => {
                self.bus_errors = self.bus_errors.wrapping_add(1);
                super::PdiOutcome {
                    apply_outputs: !stage.dc_mode() || stage.fault_waiting(),
                    ..Default::default()
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fake_esc::FakeEsc;
    use crate::io::analog::outputs::{DacLatch, DacPair, OutputStage};
    use crate::products::analog_io::{application, Application as AnalogIo, CONFIG};
    use coe_core::AlState;
    use et1100::AlEvents;

    /// The analog-io product's task: the tests need an application, and that one is real.
    fn task() -> (PdiTask<AnalogIo>, FakeEsc, OutputStage) {
        let app = SlaveApp::new(CONFIG, application());
        (PdiTask::new(app), FakeEsc::new(), OutputStage::new())
    }

    const EDGE: Wake = Wake {
        edge: true,
        line_asserted: true,
        poll: false,
        pdi_ready: true,
    };

    const POLL: Wake = Wake {
        edge: false,
        line_asserted: false,
        poll: true,
        pdi_ready: true,
    };

    /// The master configures the mailbox SyncManagers as the device description says.
    fn mailbox_sms(esc: &mut FakeEsc) {
        for (n, sm) in CONFIG.sm.iter().take(2).enumerate() {
            esc.master_sm(n as u8, sm.start, sm.len, sm.control, true);
        }
    }

    #[test]
    fn repends_are_bounded_while_the_line_stays_asserted() {
        let mut line = LevelIrq::new();
        assert!(line.after_serve(true, true));
        for _ in 1..MAX_REPENDS {
            assert!(line.after_serve(false, true));
        }
        assert!(!line.after_serve(false, true));
        assert_eq!(line.exhausted(), 1);
        // Later activations (SYNC0, tick) do not pend again and do not count again.
        assert!(!line.after_serve(false, true));
        assert_eq!(line.exhausted(), 1);
        // An edge brings the budget back.
        assert!(line.after_serve(true, true));
    }

    #[test]
    fn a_released_line_restores_the_budget() {
        let mut line = LevelIrq::new();
        for _ in 0..=MAX_REPENDS {
            line.after_serve(false, true);
        }
        assert!(!line.after_serve(false, true));
        assert!(!line.after_serve(false, false));
        assert!(line.after_serve(false, true));
        assert_eq!(line.exhausted(), 1);
    }

    #[test]
    fn nothing_happens_before_the_pdi_is_ready() {
        let (mut t, mut esc, stage) = task();
        let wake = Wake {
            pdi_ready: false,
            ..EDGE
        };
        let done = t.run(&mut esc.driver(), &stage, 0, wake, || true, |_| {});
        assert_eq!(done, Done::default());
        assert!(!t.started());
        assert_eq!(esc.writes, 0);
        assert!(esc.event_mask().is_empty());
    }

    #[test]
    fn starts_when_ready_and_retries_after_a_bus_error() {
        let (mut t, mut esc, stage) = task();
        esc.fail_next = true;
        assert_eq!(
            t.run(&mut esc.driver(), &stage, 0, POLL, || false, |_| {}),
            Done::default()
        );
        assert!(!t.started());
        assert_eq!(t.bus_errors(), 1);
        t.run(&mut esc.driver(), &stage, 0, POLL, || false, |_| {});
        assert!(t.started());
        assert_eq!(esc.al_status(), (0x01, 0));
        assert!(esc.event_mask().contains(AlEvents::AL_CONTROL));
    }

    #[test]
    fn an_edge_serves_the_al_events() {
        let (mut t, mut esc, stage) = task();
        mailbox_sms(&mut esc);
        esc.master_al_control(0x02);
        let done = t.run(&mut esc.driver(), &stage, 0, EDGE, || false, |_| {});
        assert_eq!(t.app().state(), AlState::PreOp);
        assert_eq!(esc.al_status(), (0x02, 0));
        assert!(!done.pend_again);
    }

    #[test]
    fn a_pended_activation_polls_and_leaves_the_events_alone() {
        let (mut t, mut esc, stage) = task();
        mailbox_sms(&mut esc);
        esc.master_al_control(0x02);
        t.run(&mut esc.driver(), &stage, 0, EDGE, || false, |_| {});
        // An SDO upload of 0x1000 arrives; only the background poll runs.
        let upload = [
            10, 0, 0, 0, 0x00, 0x13, 0x00, 0x20, 0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0,
        ];
        assert!(esc.master_write_mailbox(&upload));
        esc.master_al_control(0x01);
        let done = t.run(&mut esc.driver(), &stage, 1_000, POLL, || true, |_| {});
        assert!(done.serve_mailbox, "the poll asks for the mailbox task");
        assert!(
            esc.master_read_mailbox().is_none(),
            "not served by the PDI task"
        );
        while t.mailbox_step(&mut esc.driver(), &stage, 1_000).more {}
        let reply = esc
            .master_read_mailbox()
            .expect("the mailbox task served the mailbox");
        assert_eq!(reply[8], 0x43);
        assert_eq!(reply[12..16], 0x000C_0191u32.to_le_bytes());
        // The pending AL control request was not touched.
        assert_eq!(t.app().state(), AlState::PreOp);
    }

    #[test]
    fn dc_mode_asks_for_a_preload_after_serving_events() {
        let (mut t, mut esc, stage) = task();
        let done = t.run(&mut esc.driver(), &stage, 0, EDGE, || false, |_| {});
        assert!(!done.preload_outputs, "not in DC mode");
        stage.set_dc_mode(true);
        let done = t.run(&mut esc.driver(), &stage, 0, EDGE, || false, |_| {});
        assert!(done.preload_outputs);
        assert!(!done.apply_outputs);
        // A pure poll serves no SM2 event: nothing new to preload.
        let done = t.run(&mut esc.driver(), &stage, 0, POLL, || false, |_| {});
        assert!(!done.preload_outputs);
    }

    /// The samples are drained once per activation: before the background work (its inputs
    /// take the newest samples), never in an activation that leaves outputs to the DAC task
    /// (the preload must not wait), else at the end.
    #[test]
    fn samples_are_drained_before_the_background_work_and_never_before_a_preload() {
        let (mut t, mut esc, stage) = task();
        mailbox_sms(&mut esc);
        esc.master_al_control(0x02);
        let drains = core::cell::Cell::new(0);
        let count = |_: &mut AnalogIo| drains.set(drains.get() + 1);
        t.run(&mut esc.driver(), &stage, 0, EDGE, || false, count);
        assert_eq!(
            drains.get(),
            1,
            "an activation without outputs drains at its end"
        );
        assert_eq!(t.app().state(), AlState::PreOp);
        t.run(&mut esc.driver(), &stage, 1_000, POLL, || false, count);
        assert_eq!(drains.get(), 2, "a poll drains (once)");
        stage.set_dc_mode(true);
        let both = Wake { poll: true, ..EDGE };
        let done = t.run(&mut esc.driver(), &stage, 2_000, both, || false, count);
        assert!(done.preload_outputs && done.pend_again);
        assert_eq!(drains.get(), 2, "no drain before the DAC task's preload");
        let next = Wake {
            edge: false,
            line_asserted: false,
            poll: false,
            pdi_ready: true,
        };
        t.run(&mut esc.driver(), &stage, 3_000, next, || false, count);
        assert_eq!(drains.get(), 3, "the deferred poll drained");
    }

    /// An IRQ and the background work in one activation, in DC mode: the activation
    /// returns with the preload for the DAC task and puts the background work off to the
    /// next one (a long poll must not push the preload past the SYNC0 edge).
    #[test]
    fn the_outputs_go_before_the_background_work() {
        let (mut t, mut esc, stage) = task();
        mailbox_sms(&mut esc);
        esc.master_al_control(0x02);
        t.run(&mut esc.driver(), &stage, 0, EDGE, || false, |_| {});
        assert_eq!(t.app().state(), AlState::PreOp);
        stage.set_dc_mode(true);
        let both = Wake { poll: true, ..EDGE };
        let done = t.run(&mut esc.driver(), &stage, 1_000, both, || false, |_| {});
        assert!(done.preload_outputs && done.pend_again);
        // The next activation (no edge, no new request) runs the background work: in PREOP
        // it samples the event bits, an access of its own.
        let next = Wake {
            edge: false,
            line_asserted: false,
            poll: false,
            pdi_ready: true,
        };
        let reads = esc.reads;
        let done = t.run(&mut esc.driver(), &stage, 5_000_000, next, || false, |_| {});
        assert!(!done.pend_again);
        assert!(esc.reads > reads, "the deferred poll ran");
        // Nothing deferred any more.
        let reads = esc.reads;
        t.run(&mut esc.driver(), &stage, 5_000_000, next, || false, |_| {});
        assert_eq!(esc.reads, reads);
        // Outside DC mode and without outputs to apply, both run in one activation.
        stage.set_dc_mode(false);
        let done = t.run(&mut esc.driver(), &stage, 9_000_000, both, || false, |_| {});
        assert!(!done.pend_again);
    }

    #[test]
    fn a_stuck_line_is_served_a_bounded_number_of_times() {
        let (mut t, mut esc, stage) = task();
        let mut activations = 1;
        let mut done = t.run(&mut esc.driver(), &stage, 0, EDGE, || true, |_| {});
        while done.pend_again {
            let wake = Wake {
                edge: false,
                ..EDGE
            };
            done = t.run(&mut esc.driver(), &stage, 0, wake, || true, |_| {});
            activations += 1;
            assert!(activations <= 1 + usize::from(MAX_REPENDS));
        }
        assert_eq!(activations, 1 + usize::from(MAX_REPENDS));
        assert_eq!(t.line().exhausted(), 1);
    }

    /// In DC mode with background work requested at every activation, a stuck line still
    /// ends: the work is put off once, not again and again.
    #[test]
    fn a_stuck_line_in_dc_mode_does_not_put_the_background_work_off_for_ever() {
        let (mut t, mut esc, stage) = task();
        t.run(&mut esc.driver(), &stage, 0, POLL, || false, |_| {});
        stage.set_dc_mode(true);
        let both = Wake { poll: true, ..EDGE };
        let mut activations = 1;
        let mut done = t.run(&mut esc.driver(), &stage, 0, both, || true, |_| {});
        while done.pend_again {
            let wake = Wake {
                edge: false,
                ..both
            };
            done = t.run(&mut esc.driver(), &stage, 0, wake, || true, |_| {});
            activations += 1;
            assert!(activations <= 2 + usize::from(MAX_REPENDS));
        }
    }

    #[test]
    fn a_failed_access_still_applies_a_staged_fault() {
        let (mut t, mut esc, stage) = task();
        t.run(&mut esc.driver(), &stage, 0, POLL, || false, |_| {});
        stage.set_dc_mode(true);
        stage.stage(DacPair::new(1, 2));
        esc.fail_next = true;
        let done = t.run(&mut esc.driver(), &stage, 0, EDGE, || false, |_| {});
        // DC mode, outputs waiting for SYNC0: not applied early.
        assert!(!done.apply_outputs);
        assert_eq!(t.bus_errors(), 1);
        let mut latch = DacLatch::new();
        stage.enter_fault(&Default::default());
        esc.fail_next = true;
        let done = t.run(&mut esc.driver(), &stage, 0, EDGE, || false, |_| {});
        assert!(done.apply_outputs);
        assert!(latch.apply_now(&stage).pair().is_some());
    }
}
