//! One activation of the CAN task: the frames the controller received go into the
//! task's inbox, one call of the node (a frame, a PDO step or its timers) if the CAN
//! window admits its kind ([`super::window`]), and the node's frames into the
//! controller's free transmit buffers. The same logic runs behind the LPC1754's CAN1
//! (`platform/hw/can.rs`) and the virtual board's bus.

use super::window::CallKind;
use coe_core::canopen::CanFrame;
use heapless::Deque;

/// Received frames the inbox holds while the window is closed: at 1 Mbit/s about 0.8 ms
/// of back-to-back frames, several EtherCAT cycles at the advertised minimum.
pub const INBOX_FRAMES: usize = 16;

/// Frames one activation takes from the controller: its receive buffer holds two; more
/// arriving meanwhile raise the receive interrupt again.
pub const RX_PER_ACTIVATION: usize = 4;

/// The node as the CAN task drives it: a product's composition of its [`super::CanSide`]
/// with the application (and whatever else the node's calls reach).
pub trait CanHost {
    /// The hand-over to the output task.
    type Stage: ?Sized;
    /// The kind of the call that serves `frame`, or without one the next PDO step or the
    /// timers ([`super::CanSide::call_kind`]).
    fn call_kind(&self, frame: Option<&CanFrame>) -> CallKind;
    /// True if the node has PDO work left in steps.
    fn has_steps(&self) -> bool;
    /// Whether a call of `kind` may start at `now_ns` (the window).
    fn admit(&mut self, kind: CallKind, now_ns: u64) -> bool;
    /// One call of the node (a received `frame`, else a PDO step or the timers) and what
    /// follows from it; `true`: the output task must apply the staged outputs now.
    fn call(&mut self, frame: Option<&CanFrame>, stage: &Self::Stage, now_ns: u64) -> bool;
    /// The next frame to send, left in place.
    fn peek_tx(&self) -> Option<CanFrame>;
    /// The next frame to send.
    fn pop_tx(&mut self) -> Option<CanFrame>;
}

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
pub fn run<C: CanController + ?Sized, H: CanHost + ?Sized>(
    can: &mut C,
    inbox: &mut CanInbox,
    host: &mut H,
    stage: &H::Stage,
    now_ns: u64,
) -> CanOutcome {
    let mut out = CanOutcome::default();
    inbox.fill(can);
    // The node's PDO steps before the next frame (an RPDO needs the layout an NMT start
    // left to them), its timers after each frame.
    let frame = match inbox.timers_due || host.has_steps() {
        true => None,
        false => inbox.frames.front().copied(),
    };
    let kind = host.call_kind(frame.as_ref());
    if host.admit(kind, now_ns) {
        if frame.is_some() {
            inbox.frames.pop_front();
        }
        out.apply_outputs = host.call(frame.as_ref(), stage, now_ns);
        inbox.timers_due = match kind {
            CallKind::Timers => false,
            CallKind::PdoStep => inbox.timers_due,
            _ => true,
        };
        out.run_again = inbox.timers_due || host.has_steps() || !inbox.is_empty();
    }
    while let Some(frame) = host.peek_tx() {
        if !can.transmit(&frame) {
            break;
        }
        host.pop_tx();
    }
    out
}
