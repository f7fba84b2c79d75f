//! When the CAN task may call the CANopen node: the DC path's priority over CAN work.
//!
//! The CAN and PDI tasks share the slave application at one priority, so a node call
//! holds back any PDI activation that comes during it. While EtherCAT runs regular
//! cycles, a call therefore starts only if, by the bound of its kind ([`CallKind`]), it
//! ends early enough for the PDI work still to come before the next cycle's outputs must
//! be in place:
//!
//! - DC SYNC0: the next frame's outputs must be staged and preloaded before the SYNC0 edge
//!   after it. Before that edge come the frame's SM2 activation ([`SM2_ACTIVATION_NS`]),
//!   the poll after this cycle's SYNC0 edge if the PDI task has not run it yet
//!   ([`POLL_ACTIVATION_NS`]) and the millisecond tick's poll if it falls in between
//!   ([`TICK_POLL_NS`]): a call must end by the next edge minus those. The PDI task's
//!   polls record the edge they serve, or the tick's time.
//! - Output events without SYNC0 edges (SM-synchronous): a call must end before the next
//!   frame.
//!
//! The node cuts its long work into such calls (a frame, its PDO steps, its timers: see
//! `coe_core::canopen::node::CanNode::step`), so that with SYNC0 half a cycle after the
//! frame every kind fits right after the outputs of a cycle at the product's minimum
//! cycle without a tick in it ([`CanWindow::every_kind_fits_after_the_outputs`], which a
//! product with CAN holds its minimum cycle to);
//! with SYNC0 earlier in the cycle the longest kinds wait for longer cycles. Received
//! frames wait in the task's inbox meanwhile ([`super::task::CanInbox`]); the PDI
//! task pends the CAN task when the refused call fits. Without output events (no
//! EtherCAT cycles, or [`STOPPED_PERIODS`] periods without one) the window is always
//! open. The SM2 path only notes the time and
//! counts; the CAN side measures the period as the mean interval since it last looked and
//! uses the shorter of its last two measurements, so one lost frame does not widen it.

use coe_core::canopen::cob;

/// Periods without an output event after which EtherCAT cycles count as stopped.
pub const STOPPED_PERIODS: u32 = 4;

/// Longest PDI activation that serves a cycle's outputs, the DAC task's preload included
/// (ns). Measured on the image (can_image at 94 us with CAN traffic: 3 302 cycles at
/// 100 MHz), with margin.
pub const SM2_ACTIVATION_NS: u32 = 34_000;

/// Longest PDI activation after a SYNC0 edge: cycle monitor and the inputs to SM3 (ns).
/// Measured on the image as above (2 919 cycles), with margin.
pub const POLL_ACTIVATION_NS: u32 = 30_000;

/// Longest PDI activation of the millisecond tick's poll without a SYNC0 edge (ns),
/// reserved when the next tick comes before the deadline. Measured on the image as above
/// (1 142 cycles), with margin.
pub const TICK_POLL_NS: u32 = 13_000;

/// Period of the tick's poll (ns): `TICK_HZ` of the RTIC application.
pub const TICK_NS: u32 = 1_000_000;

/// What a node call does, for the bound of its duration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CallKind {
    /// The node's timers and queued work (a call without a frame).
    Timers,
    /// One PDO step of the node: an RPDO or TPDO layout read, or a TPDO packed.
    PdoStep,
    /// An NMT command (a start leaves the RPDO layouts to PDO steps).
    Nmt,
    /// A SYNC: the synchronous RPDOs applied, the synchronous TPDOs queued.
    Sync,
    /// An SDO request (one segment: the SDO machine on the dictionary).
    Sdo,
    /// Anything else: RPDOs, heartbeats and Emergencies of other nodes.
    Other,
}

impl CallKind {
    /// Every kind.
    pub const ALL: [Self; 6] = [
        Self::Timers,
        Self::PdoStep,
        Self::Nmt,
        Self::Sync,
        Self::Sdo,
        Self::Other,
    ];

    /// The kind of a call of received frame `id` for node `node_id` whose SYNC COB-ID is
    /// `sync_id`.
    pub fn of_frame(id: u16, node_id: u8, sync_id: u16) -> Self {
        if id == cob::NMT {
            Self::Nmt
        } else if id == sync_id {
            Self::Sync
        } else if id == cob::SDO_RX + u16::from(node_id) {
            Self::Sdo
        } else {
            Self::Other
        }
    }

    /// Longest call of this kind (ns), the CAN task's activation around it included.
    /// Measured on the image in can_image's tests (DC at 85, 94 and 100 us with SYNCs and
    /// SDO uploads; start-up with SDO downloads, NMT start), cycles at 100 MHz: timers
    /// 1 255, PDO steps 2 602 (TPDO packed and queued; its layout 2 421, an RPDO layout
    /// 1 466), NMT start 853, SYNC 1 162, SDO 2 367 (upload) and 3 394 (download of a PDO
    /// parameter); with margin. Not measured: NMT resets and RPDOs while EtherCAT cycles
    /// run (Other takes an SDO-like bound).
    pub const fn bound_ns(self) -> u32 {
        match self {
            Self::Timers => 14_000,
            Self::PdoStep => 28_000,
            Self::Nmt => 20_000,
            Self::Sync => 14_000,
            Self::Sdo => 36_000,
            Self::Other => 20_000,
        }
    }
}

/// The output events seen, the SYNC0 edges served and whether CAN work waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CanWindow {
    /// Time of the last output event (ns), 0 until seen.
    last_ns: u64,
    /// Output events seen (wrapping).
    events: u32,
    /// The last event and count the CAN side has taken into the period.
    seen: (u64, u32),
    /// The last two periods the CAN side measured (ns), oldest first; 0 until known.
    periods: [u32; 2],
    /// Capture time of the last SYNC0 edge the PDI task's poll served (ns), 0 until seen.
    edge_ns: u64,
    /// Time of the last poll without a SYNC0 edge (the tick's), 0 until seen.
    tick_ns: u64,
    /// The kind of a refused call: the PDI task pends the CAN task when it fits.
    waiting: Option<CallKind>,
    /// A mean interval below this (half the shortest DC cycle the module accepts) is no
    /// period: a second SM2 event of a cycle (the line still asserted, a repeated read).
    same_cycle_ns: u32,
}

impl CanWindow {
    /// No output event seen: always open. `min_cycle_ns`: the shortest EtherCAT cycle the
    /// module accepts.
    pub const fn new(min_cycle_ns: u32) -> Self {
        Self {
            last_ns: 0,
            events: 0,
            seen: (0, 0),
            periods: [0; 2],
            edge_ns: 0,
            tick_ns: 0,
            waiting: None,
            same_cycle_ns: min_cycle_ns / 2,
        }
    }

    /// The rule a product's minimum cycle must meet: with SYNC0 half a cycle after the
    /// frame, a call of every kind fits right after the outputs of a cycle of `cycle_ns`.
    pub fn every_kind_fits_after_the_outputs(cycle_ns: u32) -> bool {
        let t = u64::from(cycle_ns);
        let mut w = Self::new(cycle_ns);
        for k in 1..=3 {
            w.on_output_event(k * t);
            w.measure();
            if k < 3 {
                let edge = k * t + t / 2;
                w.on_sync0_polled(edge + 2_000, edge as u32);
            }
        }
        let after_outputs = 3 * t + u64::from(SM2_ACTIVATION_NS);
        CallKind::ALL
            .iter()
            .all(|kind| w.fits(*kind, after_outputs))
    }

    /// An EtherCAT cycle's outputs (SM2 event) were served at `now_ns`. On the SM2 path,
    /// so only the time and a count are kept: the CAN side works the period out.
    pub fn on_output_event(&mut self, now_ns: u64) {
        self.last_ns = now_ns;
        self.events = self.events.wrapping_add(1);
    }

    /// The PDI task's poll at `now_ns` served the SYNC0 edge captured at `edge_lo` (the
    /// low 32 bits of its time, at most 4.29 s ago).
    pub fn on_sync0_polled(&mut self, now_ns: u64, edge_lo: u32) {
        let ago = (now_ns as u32).wrapping_sub(edge_lo);
        self.edge_ns = now_ns.saturating_sub(u64::from(ago));
    }

    /// The PDI task's poll at `now_ns` found no new SYNC0 edge: the tick's.
    pub fn on_tick_polled(&mut self, now_ns: u64) {
        self.tick_ns = now_ns;
    }

    /// The cycle period the window follows: the shorter of the last two the CAN side
    /// measured (0: not known yet).
    pub fn period_ns(&self) -> u32 {
        self.periods[0].min(self.periods[1])
    }

    /// Takes the output events since the last look into the period: their mean interval.
    /// A second SM2 event of a cycle makes it shorter (a smaller window), a lost frame
    /// longer by its share, and the shorter of two measurements is used.
    fn measure(&mut self) {
        let (seen_ns, seen_events) = self.seen;
        let n = self.events.wrapping_sub(seen_events);
        if n == 0 {
            return;
        }
        let mean = span(seen_ns, self.last_ns) / n;
        // A tiny period would count as cycles stopped and open the window.
        if seen_ns != 0 && mean >= self.same_cycle_ns {
            self.periods = [self.periods[1], mean];
        }
        self.seen = (self.last_ns, self.events);
    }

    /// How long a node call that starts at `now_ns` may take (ns), or `None` while no
    /// cycles run. (32-bit spans: the image's cheapest form.)
    pub fn budget_ns(&self, now_ns: u64) -> Option<u32> {
        let period = self.period_ns();
        let since = span(self.last_ns, now_ns);
        if period == 0 || since / STOPPED_PERIODS >= period {
            return None;
        }
        let edge_ago = span(self.edge_ns, now_ns);
        // SYNC0 edges served within two periods of the last outputs: DC mode.
        if self.edge_ns == 0 || edge_ago.abs_diff(since) >= period.saturating_mul(2) {
            return Some(period.saturating_sub(since));
        }
        // The next frame's edge: one period after this cycle's if that was polled, else
        // two after the last polled one, with this cycle's poll before it.
        let (next_edge, poll) = match edge_ago < since {
            true => (period, 0),
            false => (period.saturating_mul(2), POLL_ACTIVATION_NS),
        };
        let end = next_edge
            .saturating_sub(edge_ago)
            .saturating_sub(SM2_ACTIVATION_NS + poll);
        // The tick's poll, if it comes before then.
        let next_tick = TICK_NS - span(self.tick_ns, now_ns) % TICK_NS;
        let tick = match self.tick_ns != 0 && next_tick < end {
            true => TICK_POLL_NS,
            false => 0,
        };
        Some(end.saturating_sub(tick))
    }

    /// Whether a call of `kind` may start at `now_ns`.
    #[inline(never)]
    pub fn fits(&self, kind: CallKind, now_ns: u64) -> bool {
        self.budget_ns(now_ns)
            .is_none_or(|budget| kind.bound_ns() <= budget)
    }

    /// [`CanWindow::fits`], remembering a refusal as work that waits.
    pub fn admit(&mut self, kind: CallKind, now_ns: u64) -> bool {
        self.measure();
        let open = self.fits(kind, now_ns);
        self.waiting = (!open).then_some(kind);
        open
    }

    /// A node call was refused and would fit now: the CAN task should run.
    pub fn work_waiting(&self, now_ns: u64) -> bool {
        self.waiting.is_some_and(|kind| self.fits(kind, now_ns))
    }

    /// A node call was refused and has not run since.
    pub const fn waiting(&self) -> bool {
        self.waiting.is_some()
    }
}

/// `to - from` in ns, saturated to 32 bits (4.29 s: longer counts as stopped).
fn span(from: u64, to: u64) -> u32 {
    u32::try_from(to.saturating_sub(from)).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    const US: u64 = 1_000;
    /// The minimum cycle of the tests (the analog products').
    const MIN_CYCLE_TIME_NS: u32 = 90_000;

    impl CanWindow {
        /// The latest end of a call that starts at `now_ns`.
        fn deadline_ns(&self, now_ns: u64) -> Option<u64> {
            self.budget_ns(now_ns).map(|b| now_ns + u64::from(b))
        }
    }

    /// A window after `n` DC cycles of `period`: outputs at `k * period` (k = 1..=n), the
    /// SYNC0 edge `phase` later and its poll 2 us after the edge; the CAN side looks once
    /// per cycle. The last cycle's edge is polled only if `polled`.
    fn dc_cycles(period: u64, phase: u64, n: u64, polled: bool) -> CanWindow {
        let mut w = CanWindow::new(MIN_CYCLE_TIME_NS);
        for k in 1..=n {
            let t = k * period;
            w.on_output_event(t);
            w.measure();
            if k < n || polled {
                let edge = t + phase;
                w.on_sync0_polled(edge + 2 * US, edge as u32);
            }
        }
        w
    }

    /// Output events every `period` without SYNC0 (SM-synchronous), `n` of them.
    fn sm_cycles(period: u64, n: u64) -> CanWindow {
        let mut w = CanWindow::new(MIN_CYCLE_TIME_NS);
        for k in 1..=n {
            w.on_output_event(k * period);
            w.measure();
        }
        w
    }

    const KINDS: [CallKind; 6] = CallKind::ALL;

    #[test]
    fn open_without_output_events() {
        let mut w = CanWindow::new(MIN_CYCLE_TIME_NS);
        assert!(w.admit(CallKind::Nmt, 0) && w.admit(CallKind::Sync, 123 * US));
        // One event gives no period yet.
        w.on_output_event(10 * US);
        assert!(w.fits(CallKind::Nmt, 10 * US));
        assert!(!w.waiting());
    }

    #[test]
    fn before_this_cycles_poll_a_call_leaves_room_for_it_and_the_next_outputs() {
        let t = 100 * US;
        let w = dc_cycles(t, t / 2, 3, false);
        let last = 3 * t;
        // This cycle's edge at +50 us and the next at +150 us: the call must end by
        // +150 - SM2 - poll - margin.
        let end = last + 150 * US - u64::from(SM2_ACTIVATION_NS + POLL_ACTIVATION_NS);
        assert_eq!(w.deadline_ns(last + 30 * US), Some(end));
        for kind in KINDS {
            let latest = end - u64::from(kind.bound_ns());
            assert_eq!(w.fits(kind, latest), latest >= last, "{kind:?}");
            assert!(!w.fits(kind, latest + 1), "{kind:?}");
        }
    }

    #[test]
    fn after_the_poll_only_the_next_outputs_are_reserved() {
        let t = 100 * US;
        let w = dc_cycles(t, t / 2, 3, true);
        let last = 3 * t;
        let end = last + 150 * US - u64::from(SM2_ACTIVATION_NS);
        assert_eq!(w.deadline_ns(last + 80 * US), Some(end));
        assert!(w.fits(CallKind::Sdo, end - u64::from(CallKind::Sdo.bound_ns())));
        assert!(!w.fits(CallKind::Sdo, end - u64::from(CallKind::Sdo.bound_ns()) + 1));
    }

    #[test]
    fn the_ticks_poll_is_reserved_when_it_comes_before_the_deadline() {
        let t = 100 * US;
        let mut w = dc_cycles(t, t / 2, 30, false);
        let last = 30 * t;
        let now = last + 30 * US;
        let plain = w.deadline_ns(now).unwrap();
        // A tick 1 ms before a point between now and the deadline: its next poll comes.
        w.on_tick_polled(now + 10 * US - u64::from(TICK_NS));
        assert_eq!(w.deadline_ns(now), Some(plain - u64::from(TICK_POLL_NS)));
        // The next tick after the deadline: nothing reserved.
        w.on_tick_polled(plain + US - u64::from(TICK_NS));
        assert_eq!(w.deadline_ns(now), Some(plain));
    }

    #[test]
    fn every_kind_fits_after_the_outputs_at_90_us_not_at_80() {
        let t = u64::from(MIN_CYCLE_TIME_NS);
        let w = dc_cycles(t, t / 2, 3, false);
        let after_outputs = 3 * t + u64::from(SM2_ACTIVATION_NS);
        for kind in KINDS {
            assert!(w.fits(kind, after_outputs), "{kind:?}");
        }
        assert!(CanWindow::every_kind_fits_after_the_outputs(
            MIN_CYCLE_TIME_NS
        ));
        assert!(!CanWindow::every_kind_fits_after_the_outputs(80_000));
    }

    #[test]
    fn the_deadline_follows_the_sync0_phase() {
        // SYNC0 a quarter cycle after the frame: less room before the next edge.
        let t = 200 * US;
        let early = dc_cycles(t, t / 4, 3, false);
        let late = dc_cycles(t, 3 * t / 4, 3, false);
        let now = 3 * t + 40 * US;
        assert_eq!(
            late.deadline_ns(now).unwrap() - early.deadline_ns(now).unwrap(),
            t / 2
        );
    }

    #[test]
    fn without_sync0_calls_end_before_the_next_frame() {
        let w = sm_cycles(500 * US, 3);
        let last = 1_500 * US;
        assert_eq!(w.deadline_ns(last + 10 * US), Some(last + 500 * US));
        let bound = u64::from(CallKind::Sync.bound_ns());
        assert!(w.fits(CallKind::Sync, last + 500 * US - bound));
        assert!(!w.fits(CallKind::Sync, last + 500 * US - bound + 1));
    }

    #[test]
    fn a_lost_frame_does_not_widen_the_window() {
        let mut w = sm_cycles(100 * US, 3);
        // The frame at 400 us is lost; the next comes at 500 us.
        w.on_output_event(500 * US);
        w.measure();
        assert_eq!(u64::from(w.period_ns()), 100 * US);
        // A cycle time changed for good is followed after two events.
        for t in [700, 900] {
            w.on_output_event(t * US);
            w.measure();
        }
        assert_eq!(u64::from(w.period_ns()), 200 * US);
    }

    #[test]
    fn a_second_event_in_the_same_cycle_is_not_a_cycle() {
        let mut w = sm_cycles(100 * US, 3);
        w.on_output_event(315 * US);
        w.measure();
        assert_eq!(u64::from(w.period_ns()), 100 * US);
        assert!(w.deadline_ns(315 * US + 60 * US).is_some(), "not stopped");
    }

    #[test]
    fn stopped_cycles_open_the_window() {
        let w = dc_cycles(100 * US, 50 * US, 3, true);
        let last = 300 * US;
        assert!(!w.fits(CallKind::Nmt, last + 399 * US));
        let stopped = last + u64::from(STOPPED_PERIODS) * 100 * US;
        assert_eq!(w.deadline_ns(stopped), None);
        assert!(w.fits(CallKind::Nmt, stopped));
    }

    #[test]
    fn a_refused_call_waits_until_its_kind_fits() {
        let t = 100 * US;
        let mut w = dc_cycles(t, t / 2, 3, true);
        let last = 3 * t;
        assert!(!w.admit(CallKind::Sdo, last + 95 * US));
        assert!(w.waiting());
        assert!(
            !w.work_waiting(last + 99 * US),
            "still too late in the cycle"
        );
        w.on_output_event(last + t);
        assert!(w.work_waiting(last + t + 33 * US), "after the next outputs");
        assert!(w.admit(CallKind::Sdo, last + t + 33 * US));
        assert!(!w.waiting() && !w.work_waiting(last + t + 34 * US));
    }

    #[test]
    fn frames_are_told_apart_by_identifier() {
        let node = 5;
        assert_eq!(CallKind::of_frame(0, node, 0x80), CallKind::Nmt);
        assert_eq!(CallKind::of_frame(0x80, node, 0x80), CallKind::Sync);
        assert_eq!(CallKind::of_frame(0x91, node, 0x91), CallKind::Sync);
        assert_eq!(CallKind::of_frame(0x80, node, 0x91), CallKind::Other);
        assert_eq!(CallKind::of_frame(0x605, node, 0x80), CallKind::Sdo);
        assert_eq!(CallKind::of_frame(0x606, node, 0x80), CallKind::Other);
        assert_eq!(CallKind::of_frame(0x305, node, 0x80), CallKind::Other);
    }
}
