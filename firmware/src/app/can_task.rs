//! One activation of the CAN task: the frames the controller received go to the
//! application, its timers run, and its frames go into the controller's free transmit
//! buffers. The same logic runs behind the LPC1754's CAN1 (`crate::hw::can`) and the
//! virtual board's bus.

use super::outputs::OutputStage;
use super::SlaveApp;
use coe_core::canopen::CanFrame;

/// The CAN controller as the task needs it.
pub trait CanController {
    /// The next received frame, if any.
    fn receive(&mut self) -> Option<CanFrame>;
    /// Takes a frame for transmission; false if no transmit buffer is free.
    fn transmit(&mut self, frame: &CanFrame) -> bool;
}

/// What one activation leaves to the task body.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CanOutcome {
    /// Pend the DAC task with the apply request (an RPDO brought outputs, or fault values).
    pub apply_outputs: bool,
    /// A frame was taken: pend the CAN task again for the next one. The PDI task runs at
    /// the same priority and its vector (EINT3) comes before CAN's, so an SM2 event that
    /// arrives meanwhile is served before the next frame: it waits for at most one frame's
    /// work, never for a burst.
    pub run_again: bool,
}

/// Serves the controller at `now_ns`: one received frame, or the timers when none came,
/// then transmission as long as the controller takes frames.
pub fn run<C: CanController + ?Sized>(
    can: &mut C,
    app: &mut SlaveApp,
    stage: &OutputStage,
    now_ns: u64,
) -> CanOutcome {
    let mut out = CanOutcome::default();
    match can.receive() {
        Some(frame) => {
            out.apply_outputs = app.on_can_frame(&frame, stage, now_ns).apply_outputs;
            out.run_again = true;
        }
        None => out.apply_outputs = app.poll_can(stage, now_ns).apply_outputs,
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
    use crate::app::outputs::{DacPair, StageKind};
    use crate::app::process_data::ProcessData;
    use crate::app::AppConfig;
    use crate::product::can::{DEFAULT_NODE_ID as NODE, PROCESS_DATA_SOURCE_INDEX};
    use crate::product::od;
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
            for _ in 0..=frames.len() {
                let o = self.activation();
                out.apply_outputs |= o.apply_outputs;
                if !o.run_again {
                    break;
                }
            }
            (out, core::mem::take(&mut self.can.tx))
        }

        fn activation(&mut self) -> CanOutcome {
            run(&mut self.can, &mut self.app, &self.stage, self.now)
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
        // A burst: each activation takes one frame and asks to run again, so the PDI task
        // (same priority, served first when both are pending) waits for one frame's work.
        r.can.rx.extend(vec![nmt(0x80); 3]);
        for left in (0..3).rev() {
            assert!(r.activation().run_again);
            assert_eq!(r.can.rx.len(), left);
        }
        assert_eq!(
            r.activation(),
            CanOutcome::default(),
            "nothing left: the timers ran"
        );
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
}
