//! `analog-io-can` as a whole: the CAN task on the composition of both stacks, the node's
//! objects and Emergencies, its minimum cycle against the CAN window's rule.

use super::can::{DEFAULT_NODE_ID as NODE, PROCESS_DATA_SOURCE_INDEX};
use super::{application_with_node_id, AnalogCan, CONFIG};
use crate::fake_esc::FakeEsc;
use crate::io::analog::outputs::{DacPair, OutputStage, StageKind};
use crate::stacks::canopen::task::{
    run, CanController, CanHost, CanInbox, CanOutcome, INBOX_FRAMES,
};
use crate::stacks::canopen::window::CanWindow;
use crate::stacks::ethercat::SlaveApp;
use coe_core::canopen::CanFrame;
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
    app: Box<SlaveApp<AnalogCan>>,
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
            app: Box::new(SlaveApp::new(CONFIG, application_with_node_id(NODE))),
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
            &mut *self.app,
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
    assert_eq!(r.app.peek_tx(), Some(boot_up), "kept for the next run");
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
fn output_events(app: &mut SlaveApp<AnalogCan>, times: &[u64]) {
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
/// The advertised minimum cycle (ns), the shortest DC cycle the module accepts.
const CYCLE: u64 = crate::products::analog_io::sync::MIN_CYCLE_TIME_NS as u64;

impl Rig {
    /// A rig after the boot-up whose application served outputs at `base`, 100 us and
    /// 200 us later (EtherCAT cycles of 100 us); `base`.
    /// Three cycles of the advertised minimum ([`CYCLE`]); the next output event is due at
    /// `base + 3 * CYCLE`.
    fn in_minimum_cycles() -> (Self, u64) {
        let mut r = Self::new(usize::MAX);
        r.run(&[]);
        let base = r.now;
        for k in 0..3 {
            // The CAN task looks between the cycles (its tick at the latest).
            r.now = base + k * CYCLE;
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
    let (mut r, base) = Rig::in_minimum_cycles();
    r.now = base + 3 * CYCLE - 20 * US;
    r.can.rx.extend(vec![upload_0x1000(); 3]);
    assert_eq!(r.activation(), CanOutcome::default());
    assert_eq!(r.inbox.len(), 3, "taken from the controller, not served");
    assert!(r.can.tx.is_empty());
    assert!(r.app.application().can.waiting() && !r.app.application().can.work_waiting(r.now));
    output_events(&mut r.app, &[base + 3 * CYCLE]);
    r.now = base + 3 * CYCLE + 10 * US;
    assert!(
        r.app.application().can.work_waiting(r.now),
        "the PDI task pends the CAN task"
    );
    let mut activations = 1;
    while r.activation().run_again {
        activations += 1;
    }
    assert_eq!(activations, 6, "one frame, then the timers, per activation");
    assert_eq!(r.can.tx.len(), 3, "every request answered");
    assert!(r.can.tx.iter().all(|f| f.id() == 0x580 + u16::from(NODE)));
    assert!(!r.app.application().can.waiting());
    assert_eq!(r.inbox.overruns(), 0);
}

#[test]
fn a_full_inbox_counts_the_frames_it_loses() {
    let (mut r, base) = Rig::in_minimum_cycles();
    r.now = base + 3 * CYCLE - 10 * US;
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

#[test]
fn the_minimum_cycle_leaves_room_for_every_node_call() {
    assert!(CanWindow::every_kind_fits_after_the_outputs(
        crate::products::analog_io::sync::FIGURES.min_cycle_ns
    ));
}

mod view {
    use super::super::application::{Arbitration, CanView};
    use crate::io::analog::outputs::OutputStage;
    use crate::io::analog::AnalogIo;
    use crate::products::analog_io;
    use crate::products::analog_io_can::od::OD;
    use crate::stacks::diagnostics::ERR_COMMUNICATION;
    use crate::stacks::ethercat::Effects;
    use coe_core::canopen::node::CanApplication;
    use coe_core::od::ObjectAccess;
    use coe_core::{AlState, SdoAbortCode};
    use std::vec;

    fn read(view: &mut CanView, sub: u8) -> Result<vec::Vec<u8>, SdoAbortCode> {
        let mut buf = [0u8; 8];
        let n = view.read(0x1003, sub, &mut buf)?;
        Ok(buf[..n].to_vec())
    }

    /// The node's own Emergencies (heartbeat loss here) enter 0x1003, which both
    /// fieldbuses read and clear through the application.
    #[test]
    fn node_emergencies_enter_the_error_history() {
        let mut analog = AnalogIo::new(&OD, analog_io::process_data());
        let mut arbitration = Arbitration::default();
        let stage = OutputStage::new();
        let mut effects = Effects::default();
        let mut view = CanView {
            analog: &mut analog,
            arbitration: &mut arbitration,
            stage: &stage,
            effects: &mut effects,
        };
        assert_eq!(read(&mut view, 0), Ok(vec![0]));
        assert_eq!(read(&mut view, 1), Err(SdoAbortCode::NoDataAvailable));
        view.raise_error(ERR_COMMUNICATION, 0x8130, [0x7F, 0, 0, 0, 0]);
        view.raise_error(ERR_COMMUNICATION, 0x8100, [0; 5]);
        assert_eq!(read(&mut view, 0), Ok(vec![2]));
        assert_eq!(
            read(&mut view, 1),
            Ok(0x0011_8100u32.to_le_bytes().to_vec())
        );
        assert_eq!(
            read(&mut view, 2),
            Ok(0x7F11_8130u32.to_le_bytes().to_vec())
        );
        assert_eq!(read(&mut view, 3), Err(SdoAbortCode::NoDataAvailable));
        assert_eq!(
            view.clear_error(ERR_COMMUNICATION).map(|e| e.error_code),
            Some(0)
        );
        assert_eq!(
            read(&mut view, 0),
            Ok(vec![2]),
            "the error reset is not recorded"
        );
        let write =
            |view: &mut CanView, sub, data: &[u8]| view.write(0x1003, sub, data, AlState::Op);
        assert_eq!(
            write(&mut view, 0, &[1]),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(read(&mut view, 0), Ok(vec![2]));
        assert_eq!(write(&mut view, 0, &[0]), Ok(()));
        assert_eq!(read(&mut view, 0), Ok(vec![0]));
        assert_eq!(read(&mut view, 1), Err(SdoAbortCode::NoDataAvailable));
    }
}
