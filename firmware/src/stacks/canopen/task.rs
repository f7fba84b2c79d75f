//! One activation of the CAN task: the frames the controller received go into the
//! task's inbox, one call of the node (a frame, a PDO step or its timers) if the CAN
//! window admits its kind ([`super::can_window`]), and the node's frames into the
//! controller's free transmit buffers. The same logic runs behind the LPC1754's CAN1
//! (`crate::hw::can`) and the virtual board's bus.

use super::window::CallKind;
use crate::io::analog::outputs::OutputStage;
use crate::stacks::ethercat::SlaveApp;
use coe_core::canopen::CanFrame;
use heapless::Deque;

/// Received frames the inbox holds while the window is closed: at 1 Mbit/s about 0.8 ms
/// of back-to-back frames, several EtherCAT cycles at the advertised minimum.
pub const INBOX_FRAMES: usize = 16;

/// Frames one activation takes from the controller: its receive buffer holds two; more
/// arriving meanwhile raise the receive interrupt again.
pub const RX_PER_ACTIVATION: usize = 4;

/// The CAN controller as the task needs it.
pub trait CanController {
    /// The next received frame, if any.
    fn receive(&mut self) -> Option<CanFrame>;
    /// Takes a frame for transmission; false if no transmit buffer is free.
    fn transmit(&mut self, frame: &CanFrame) -> bool;
}

/// Received frames waiting for the node, and those lost because it was full; whether the
/// node's timers are due after a frame.
#[derive(Debug, Default)]
pub struct CanInbox {
    frames: Deque<CanFrame, INBOX_FRAMES>,
    overruns: u32,
    timers_due: bool,
}

impl CanInbox {
    /// An empty inbox.
    pub const fn new() -> Self {
        Self {
            frames: Deque::new(),
            overruns: 0,
            timers_due: false,
        }
    }

    /// Moves what the controller received in (at most [`RX_PER_ACTIVATION`] frames),
    /// counting the frames that find it full.
    pub fn fill<C: CanController + ?Sized>(&mut self, can: &mut C) {
        for _ in 0..RX_PER_ACTIVATION {
            let Some(frame) = can.receive() else {
                return;
            };
            if self.frames.push_back(frame).is_err() {
                self.overruns = self.overruns.wrapping_add(1);
            }
        }
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// True if no frame waits.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frames lost because the inbox was full.
    pub const fn overruns(&self) -> u32 {
        self.overruns
    }
}

/// What one activation leaves to the task body.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CanOutcome {
    /// Pend the DAC task with the apply request (an RPDO brought outputs, or fault values).
    pub apply_outputs: bool,
    /// A frame went to the node and more wait: pend the CAN task again for the next one.
    /// The PDI task runs at the same priority and its vector (EINT3) comes before CAN's,
    /// so an SM2 event that arrives meanwhile is served before the next frame.
    pub run_again: bool,
}

/// Serves the controller at `now_ns`: its frames into the inbox; one node call if the
/// window admits its kind: a PDO step while the node has them, the timers after a frame
/// or when none waits, else the next frame; then transmission as long as the controller
/// takes frames (short: it holds no SM2 event for long).
pub fn run<C: CanController + ?Sized>(
    can: &mut C,
    inbox: &mut CanInbox,
    app: &mut SlaveApp,
    stage: &OutputStage,
    now_ns: u64,
) -> CanOutcome {
    let mut out = CanOutcome::default();
    inbox.fill(can);
    // The node's PDO steps before the next frame (an RPDO needs the layout an NMT start
    // left to them), its timers after each frame.
    let frame = match inbox.timers_due || app.can_has_steps() {
        true => None,
        false => inbox.frames.front().copied(),
    };
    let kind = app.can_call_kind(frame.as_ref());
    if app.admit_can_call(kind, now_ns) {
        let done = match frame {
            Some(f) => {
                inbox.frames.pop_front();
                app.on_can_frame(&f, stage, now_ns)
            }
            None => app.poll_can(stage, now_ns),
        };
        inbox.timers_due = match kind {
            CallKind::Timers => false,
            CallKind::PdoStep => inbox.timers_due,
            _ => true,
        };
        out.apply_outputs = done.apply_outputs;
        out.run_again = inbox.timers_due || app.can_has_steps() || !inbox.is_empty();
    }
    while let Some(frame) = app.peek_can_tx() {
        if !can.transmit(&frame) {
            break;
        }
        app.can_tx();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fake_esc::FakeEsc;
    use crate::io::analog::outputs::{DacPair, StageKind};
    use crate::io::analog::process_data::ProcessData;
    use crate::products::analog_io::can::{DEFAULT_NODE_ID as NODE, PROCESS_DATA_SOURCE_INDEX};
    use crate::products::analog_io::od;
    use crate::stacks::ethercat::AppConfig;
    use et1100::AlEvents;
    use std::boxed::Box;
    use std::collections::VecDeque;
    use std::vec;
    use std::vec::Vec;

    const MS: u64 = 1_000_000;

    /// A controller with a receive queue and `free` transmit buffers.
    struct FakeController {
        rx: VecDeque<CanFrame>,
        tx: Vec<CanFrame>,
        free: usize,
    }

    impl CanController for FakeController {
        fn receive(&mut self) -> Option<CanFrame> {
            self.rx.pop_front()
        }

        fn transmit(&mut self, frame: &CanFrame) -> bool {
            if self.free == 0 {
                return false;
            }
            self.free -= 1;
            self.tx.push(*frame);
            true
        }
    }

    struct Rig {
        can: FakeController,
        inbox: CanInbox,
        app: Box<SlaveApp>,
        stage: OutputStage,
        now: u64,
    }

    impl Rig {
        fn new(free: usize) -> Self {
            Self {
                can: FakeController {
                    rx: VecDeque::new(),
                    tx: Vec::new(),
                    free,
                },
                inbox: CanInbox::new(),
                app: Box::new(SlaveApp::new(
                    &od::OD,
                    AppConfig::product(),
                    ProcessData::product_default(),
                )),
                stage: OutputStage::new(),
                now: 0,
            }
        }

        /// Activations 1 ms after the last, with `frames` received, until the task stops
        /// asking to run again (as its body pends itself); the outcome of all, what they
        /// sent.
        fn run(&mut self, frames: &[CanFrame]) -> (CanOutcome, Vec<CanFrame>) {
            self.now += MS;
            self.can.rx.extend(frames.iter().copied());
            let mut out = CanOutcome::default();
            for _ in 0..64 {
                let o = self.activation();
                out.apply_outputs |= o.apply_outputs;
                if !o.run_again {
                    break;
                }
            }
            (out, core::mem::take(&mut self.can.tx))
        }

        fn activation(&mut self) -> CanOutcome {
            run(
                &mut self.can,
                &mut self.inbox,
                &mut self.app,
                &self.stage,
                self.now,
            )
        }
    }

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(id, data).unwrap()
    }

    fn nmt(command: u8) -> CanFrame {
        frame(0, &[command, NODE])
    }

    #[test]
    fn frames_wait_for_a_free_buffer() {
        let mut r = Rig::new(0);
        let (_, sent) = r.run(&[]);
        assert!(sent.is_empty());
        let boot_up = frame(0x700 + u16::from(NODE), &[0]);
        assert_eq!(r.app.peek_can_tx(), Some(boot_up), "kept for the next run");
        r.can.free = 3;
        assert_eq!(r.run(&[]).1, vec![boot_up]);
    }

    #[test]
    fn one_received_frame_per_activation() {
        let mut r = Rig::new(usize::MAX);
        r.run(&[]);
        // A burst: the first activation moves it into the inbox, each gives the node one
        // frame, the next its timers, and asks to run again while work waits, so the PDI
        // task (same priority, served first when both are pending) waits for one piece.
        r.can.rx.extend(vec![nmt(0x80); 3]);
        for left in (0..3).rev() {
            assert!(r.activation().run_again, "the timers follow the frame");
            assert!(r.can.rx.is_empty());
            assert_eq!(r.inbox.len(), left);
            assert_eq!(r.activation().run_again, left > 0, "the timers ran");
        }
        assert_eq!(r.activation(), CanOutcome::default(), "nothing left");
        // The node still answers within the same run.
        let (_, sent) = r.run(&[frame(
            0x600 + u16::from(NODE),
            &[0x40, 0, 0x10, 0, 0, 0, 0, 0],
        )]);
        assert_eq!(sent.len(), 1);
        assert_eq!(sent[0].id(), 0x580 + u16::from(NODE));
    }

    #[test]
    fn rpdos_reach_the_dac_only_when_can_owns_the_outputs() {
        let mut r = Rig::new(usize::MAX);
        r.run(&[]);
        let rpdo = frame(0x300 + u16::from(NODE), &[0, 0x30, 0, 0x10]);
        // EtherCAT owns the outputs (the default): the RPDO is dropped.
        r.run(&[nmt(0x01)]);
        let (out, _) = r.run(&[rpdo]);
        assert!(!out.apply_outputs);
        assert_ne!(r.stage.staged().0, StageKind::Outputs);
        // CAN takes them (SDO in pre-operational), then drives them in operational.
        r.run(&[nmt(0x80)]);
        let [lo, hi] = PROCESS_DATA_SOURCE_INDEX.to_le_bytes();
        let (_, sent) = r.run(&[frame(
            0x600 + u16::from(NODE),
            &[0x2F, lo, hi, 0, 1, 0, 0, 0],
        )]);
        assert_eq!(
            sent,
            vec![frame(
                0x580 + u16::from(NODE),
                &[0x60, lo, hi, 0, 0, 0, 0, 0]
            )]
        );
        r.run(&[nmt(0x01)]);
        let (out, _) = r.run(&[rpdo]);
        assert!(out.apply_outputs, "the DAC task applies them now");
        assert_eq!(
            r.stage.staged(),
            (StageKind::Outputs, DacPair::from_ao([0x3000, 0x1000]))
        );
        // Stopped: the outputs go to their fault values at once.
        let (out, _) = r.run(&[nmt(0x02)]);
        assert!(out.apply_outputs);
        assert_eq!(r.stage.staged().0, StageKind::Fault);
    }

    /// The PDI task's SM2 events at `times` (ns), as in a cycle's outputs.
    fn output_events(app: &mut SlaveApp, times: &[u64]) {
        let mut esc = FakeEsc::new();
        for &t in times {
            esc.raise(AlEvents::SM2);
            assert!(
                app.on_pdi_irq(&mut esc.driver(), &OutputStage::new(), t)
                    .unwrap()
                    .sm2_event
            );
        }
    }

    const US: u64 = 1_000;

    impl Rig {
        /// A rig after the boot-up whose application served outputs at `base`, 100 us and
        /// 200 us later (EtherCAT cycles of 100 us); `base`.
        fn in_100_us_cycles() -> (Self, u64) {
            let mut r = Self::new(usize::MAX);
            r.run(&[]);
            let base = r.now;
            for k in 0..3 {
                // The CAN task looks between the cycles (its tick at the latest).
                r.now = base + k * 100 * US;
                output_events(&mut r.app, &[r.now]);
                r.activation();
            }
            (r, base)
        }
    }

    fn upload_0x1000() -> CanFrame {
        frame(0x600 + u16::from(NODE), &[0x40, 0, 0x10, 0, 0, 0, 0, 0])
    }

    /// While EtherCAT cycles run, frames that arrive too late in a cycle for their kind
    /// (an SDO call could reach the next frame) wait in the inbox and all are served once
    /// the next cycle's outputs open the window.
    #[test]
    fn frames_wait_for_the_window_and_none_is_lost() {
        let (mut r, base) = Rig::in_100_us_cycles();
        r.now = base + 280 * US;
        r.can.rx.extend(vec![upload_0x1000(); 3]);
        assert_eq!(r.activation(), CanOutcome::default());
        assert_eq!(r.inbox.len(), 3, "taken from the controller, not served");
        assert!(r.can.tx.is_empty());
        assert!(r.app.can_waiting() && !r.app.can_work_waiting(r.now));
        output_events(&mut r.app, &[base + 300 * US]);
        r.now = base + 310 * US;
        assert!(
            r.app.can_work_waiting(r.now),
            "the PDI task pends the CAN task"
        );
        let mut activations = 1;
        while r.activation().run_again {
            activations += 1;
        }
        assert_eq!(activations, 6, "one frame, then the timers, per activation");
        assert_eq!(r.can.tx.len(), 3, "every request answered");
        assert!(r.can.tx.iter().all(|f| f.id() == 0x580 + u16::from(NODE)));
        assert!(!r.app.can_waiting());
        assert_eq!(r.inbox.overruns(), 0);
    }

    #[test]
    fn a_full_inbox_counts_the_frames_it_loses() {
        let (mut r, base) = Rig::in_100_us_cycles();
        r.now = base + 290 * US;
        let extra = 5;
        r.can.rx.extend(vec![nmt(0x80); INBOX_FRAMES + extra]);
        let mut activations = 0;
        while !r.can.rx.is_empty() {
            r.activation();
            activations += 1;
            assert!(activations <= INBOX_FRAMES, "the controller is drained");
        }
        assert_eq!(r.inbox.len(), INBOX_FRAMES);
        assert_eq!(r.inbox.overruns(), extra as u32);
    }
}
