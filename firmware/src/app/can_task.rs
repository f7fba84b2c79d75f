//! One activation of the CAN task: the frames the controller received go to the
//! application, its timers run, and its frames go into the controller's free transmit
//! buffers. The same logic runs behind the LPC1754's CAN1 (`crate::hw::can`) and the
//! virtual board's bus.

use super::outputs::OutputStage;
use super::{PdiOutcome, SlaveApp};
use coe_core::canopen::CanFrame;

/// The CAN controller as the task needs it.
pub trait CanController {
    /// The next received frame, if any.
    fn receive(&mut self) -> Option<CanFrame>;
    /// Takes a frame for transmission; false if no transmit buffer is free.
    fn transmit(&mut self, frame: &CanFrame) -> bool;
}

/// Most frames taken from the controller in one activation: a bound, so a flooded bus
/// cannot hold the task (the controller's receive interrupt comes again).
pub const MAX_RX_PER_RUN: usize = 16;

/// Serves the controller at `now_ns`: received frames, the timers, then transmission as
/// long as the controller takes frames. What the DAC task must do comes back.
pub fn run<C: CanController + ?Sized>(
    can: &mut C,
    app: &mut SlaveApp,
    stage: &OutputStage,
    now_ns: u64,
) -> PdiOutcome {
    let mut out = PdiOutcome::default();
    let mut received = false;
    for _ in 0..MAX_RX_PER_RUN {
        let Some(frame) = can.receive() else { break };
        received = true;
        let o = app.on_can_frame(&frame, stage, now_ns);
        out.apply_outputs |= o.apply_outputs;
    }
    if !received {
        out.apply_outputs |= app.poll_can(stage, now_ns).apply_outputs;
    }
    while let Some(frame) = app.peek_can_tx() {
        if !can.transmit(&frame) {
            break;
        }
        app.can_tx();
    }
    out
}
