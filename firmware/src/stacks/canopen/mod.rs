//! The CANopen node on CAN: coe-core's node ([`CanNode`]) on a device's dictionary, with
//! the window that keeps its work out of the way of the EtherCAT cycle ([`window`]) and the
//! CAN task that moves frames ([`task`]). It knows no product: the device is a
//! [`CanApplication`], which the product that runs the node gives it.
//!
//! A product with both fieldbuses composes them: the EtherCAT slave application's
//! application holds the node ([`CanSide`]), serves the node's communication objects on the
//! EtherCAT mailbox too ([`CanSide::access`]), passes the EtherCAT cycle on to the window
//! ([`CanSide::on_output_event`], [`CanSide::on_cycle_polled`]) and the slave application's
//! Emergencies to the node ([`CanSide::queue_emergency`]); the CAN task calls the node
//! through the product ([`task::CanHost`]).

pub mod task;
pub mod window;

use coe_core::canopen::node::{CanApplication, CanNode, NodeAccess};
use coe_core::canopen::params::CommDefaults;
use coe_core::canopen::CanFrame;
use coe_core::od::ObjectDictionary;
use coe_core::sdo_server::Emergency;
use window::{CallKind, CanWindow};

/// A CANopen node with `R` RPDOs, `T` TPDOs, `HB` heartbeat consumers, `Q` Emergencies
/// that can wait and an SDO transfer buffer of `BUF` bytes, and the window its calls must
/// fit.
pub struct CanSide<
    const R: usize,
    const T: usize,
    const HB: usize,
    const Q: usize,
    const BUF: usize,
> {
    node: CanNode<R, T, HB, Q, BUF>,
    /// When the CAN task may call the node (after the outputs of an EtherCAT cycle).
    window: CanWindow,
}

impl<const R: usize, const T: usize, const HB: usize, const Q: usize, const BUF: usize>
    CanSide<R, T, HB, Q, BUF>
{
    /// The node `node_id` on `od` with the communication defaults `defaults`; EtherCAT
    /// cycles are at least `min_cycle_ns` long.
    pub fn new(
        node_id: u8,
        od: &'static ObjectDictionary,
        defaults: &'static CommDefaults<R, T>,
        min_cycle_ns: u32,
    ) -> Self {
        Self {
            node: CanNode::new(node_id, od, defaults),
            window: CanWindow::new(min_cycle_ns),
        }
    }

    /// The node.
    pub fn node(&self) -> &CanNode<R, T, HB, Q, BUF> {
        &self.node
    }

    /// One bounded piece of the node's work on `app` at `now_ns`: a received `frame`, or
    /// without one its next PDO step, or its timers when none is left.
    pub fn call<A: CanApplication + ?Sized>(
        &mut self,
        frame: Option<&CanFrame>,
        app: &mut A,
        now_ns: u64,
    ) {
        let now_us = micros(now_ns);
        match frame {
            Some(frame) => self.node.receive(frame, app, now_us),
            None if self.node.has_steps() => _ = self.node.step(app, now_us),
            None => self.node.timers(app, now_us),
        }
    }

    /// The object access for another fieldbus's SDO server at `now_ns`: the node's
    /// communication objects, the rest `app`'s.
    pub fn access<'a, A: CanApplication + ?Sized>(
        &'a mut self,
        app: &'a mut A,
        now_ns: u64,
    ) -> NodeAccess<'a, A, R, T, HB, Q> {
        self.node.access(app, micros(now_ns))
    }

    /// An Emergency of the device (another fieldbus raised it): out on CAN too.
    pub fn queue_emergency(&mut self, emergency: Emergency) {
        self.node.queue_emergency(emergency);
    }

    /// The next frame for the CAN controller (highest priority first).
    pub fn pop_tx(&mut self) -> Option<CanFrame> {
        self.node.pop_tx()
    }

    /// The frame [`CanSide::pop_tx`] would give, left in place.
    pub fn peek_tx(&self) -> Option<CanFrame> {
        self.node.peek_tx()
    }

    /// True if the node has frames to send (cheap: the PDI task asks every activation).
    pub fn has_tx(&self) -> bool {
        self.node.has_tx()
    }

    /// The kind of the call that serves received `frame`, or without one the node's next
    /// PDO step or timers ([`CallKind`]).
    pub fn call_kind(&self, frame: Option<&CanFrame>) -> CallKind {
        let sync_id = self.node.params().sync.cob_id.can_id();
        match frame {
            Some(f) => CallKind::of_frame(f.id(), self.node.node_id(), sync_id),
            None if self.node.has_steps() => CallKind::PdoStep,
            None => CallKind::Timers,
        }
    }

    /// True if the node has PDO work left in steps (run before the next frame).
    pub fn has_steps(&self) -> bool {
        self.node.has_steps()
    }

    /// Whether a call of `kind` may start at `now_ns` ([`CanWindow`]); a refusal is
    /// remembered as CAN work that waits.
    pub fn admit(&mut self, kind: CallKind, now_ns: u64) -> bool {
        self.window.admit(kind, now_ns)
    }

    /// CAN work was refused and the window is open now: pend the CAN task.
    pub fn work_waiting(&self, now_ns: u64) -> bool {
        self.window.work_waiting(now_ns)
    }

    /// CAN work was refused and waits for the window (whoever opens it pends the CAN task).
    pub fn waiting(&self) -> bool {
        self.window.waiting()
    }

    /// When the node's timers must run next (ns).
    pub fn deadline_ns(&self) -> Option<u64> {
        self.node
            .next_deadline_us()
            .map(|us| us.saturating_mul(1000))
    }

    /// The outputs of an EtherCAT cycle were served at `now_ns` (the SM2 path: two stores).
    #[inline(always)]
    pub fn on_output_event(&mut self, now_ns: u64) {
        self.window.on_output_event(now_ns);
    }

    /// The PDI task's background poll ran at `now_ns`, for the SYNC0 edge captured at
    /// `edge_lo` or, `None`, for none (the tick's).
    pub fn on_cycle_polled(&mut self, now_ns: u64, edge_lo: Option<u32>) {
        match edge_lo {
            Some(edge_lo) => self.window.on_sync0_polled(now_ns, edge_lo),
            None => self.window.on_tick_polled(now_ns),
        }
    }
}

/// Nanoseconds to microseconds (32-bit divisions only).
pub(crate) fn micros(now_ns: u64) -> u64 {
    crate::platform::div::div_u64_u32(now_ns, 1000)
}
