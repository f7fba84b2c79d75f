//! When the CAN task may call the CANopen node: the DC path's priority over CAN work.
//!
//! The CAN and PDI tasks share the slave application at one priority, so a node call
//! (a received frame, or the node's timers: up to about 85 us on the image for an NMT
//! start) holds back an SM2 event that comes during it. While EtherCAT delivers outputs
//! in regular cycles, a call therefore starts only in the part of the cycle after an
//! output event (SM2) where it cannot reach the next cycle's outputs:
//!
//! - before `period - CALL_RESERVE_NS`: it ends before the next frame;
//! - or in the first half of the cycle: it ends before the next SYNC0 edge as long as
//!   SYNC0 comes at least `CALL_RESERVE_NS - period / 2` after the frame plus its SM2
//!   handling (with the SYNC0 edge half a cycle after the frame, for any cycle above
//!   about 75 us).
//!
//! Received frames wait in the task's inbox meanwhile ([`super::can_task::CanInbox`]);
//! the PDI task pends the CAN task when the window opens and work waits. Without output
//! events (no EtherCAT cycles, or [`STOPPED_PERIODS`] periods without one) the window is
//! always open. The period is the shorter of the last two output intervals, so one lost
//! frame does not widen the window into the next cycle.

use crate::product::sync::MIN_CYCLE_TIME_NS;

/// Longest node call the window leaves room for (ns): the image's longest measured CAN
/// activation (NMT start, 8 466 cycles at 100 MHz) with margin.
pub const CALL_RESERVE_NS: u32 = 100_000;

/// Output events closer than this to the last one belong to its cycle: half the shortest
/// DC cycle the module accepts.
pub const SAME_CYCLE_NS: u32 = MIN_CYCLE_TIME_NS / 2;

/// Periods without an output event after which EtherCAT cycles count as stopped.
pub const STOPPED_PERIODS: u32 = 4;

/// The output events seen and whether CAN work waits for the window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CanWindow {
    /// Times of the last three output events (ns), oldest first; 0 until seen.
    times: [u64; 3],
    /// A node call was refused: the PDI task pends the CAN task when the window opens.
    waiting: bool,
}

impl CanWindow {
    /// No output event seen: always open.
    pub const fn new() -> Self {
        Self {
            times: [0; 3],
            waiting: false,
        }
    }

    /// An EtherCAT cycle's outputs (SM2 event) were served at `now_ns`. (On the SM2 path:
    /// only the time is kept, the window is worked out when the CAN side asks.)
    pub fn on_output_event(&mut self, now_ns: u64) {
        // A second SM2 event of the same cycle (the line still asserted, a repeated
        // read) is no new cycle: a tiny period would count as cycles stopped and open
        // the window.
        if now_ns.saturating_sub(self.times[2]) >= u64::from(SAME_CYCLE_NS) {
            self.times = [self.times[1], self.times[2], now_ns];
        }
    }

    /// The cycle period the window follows: the shorter of the last two intervals (0: not
    /// known yet).
    pub fn period_ns(&self) -> u32 {
        let [t0, t1, t2] = self.times;
        if t0 == 0 {
            return 0;
        }
        span(t0, t1).min(span(t1, t2))
    }

    /// Whether a node call may start at `now_ns`. (Out of line: one copy for the PDI and
    /// the CAN task.)
    #[inline(never)]
    pub fn is_open(&self, now_ns: u64) -> bool {
        let period = self.period_ns();
        let since = span(self.times[2], now_ns);
        period == 0
            || since / STOPPED_PERIODS >= period
            || since < (period / 2).max(period.saturating_sub(CALL_RESERVE_NS))
    }

    /// [`CanWindow::is_open`], remembering a refusal as work that waits.
    pub fn admit(&mut self, now_ns: u64) -> bool {
        let open = self.is_open(now_ns);
        self.waiting = !open;
        open
    }

    /// A node call was refused and the window is open now: the CAN task should run.
    pub fn work_waiting(&self, now_ns: u64) -> bool {
        self.waiting && self.is_open(now_ns)
    }

    /// A node call was refused and has not run since.
    pub const fn waiting(&self) -> bool {
        self.waiting
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

    /// Output events every `period` from `period` on, `n` of them.
    fn cycles(period: u64, n: u64) -> CanWindow {
        let mut w = CanWindow::new();
        for k in 1..=n {
            w.on_output_event(k * period);
        }
        w
    }

    #[test]
    fn open_without_output_events() {
        let mut w = CanWindow::new();
        assert!(w.admit(0) && w.admit(123 * US));
        // One event gives no period yet.
        w.on_output_event(10 * US);
        assert!(w.is_open(10 * US) && w.is_open(60 * US));
        assert!(!w.waiting());
    }

    #[test]
    fn at_100_us_calls_start_in_the_first_half_of_the_cycle_only() {
        let w = cycles(100 * US, 3);
        let last = 300 * US;
        assert_eq!(u64::from(w.period_ns()), 100 * US);
        assert!(w.is_open(last + 15 * US), "right after the outputs");
        assert!(w.is_open(last + 49 * US));
        assert!(!w.is_open(last + 50 * US), "would reach the next SYNC0");
        assert!(!w.is_open(last + 99 * US));
        assert!(
            !w.is_open(last + 150 * US),
            "the next frame is late, not gone"
        );
    }

    #[test]
    fn at_1_ms_calls_start_until_the_reserve_before_the_next_frame() {
        let w = cycles(1_000 * US, 3);
        let last = 3_000 * US;
        assert!(w.is_open(last + 899 * US));
        assert!(!w.is_open(last + 900 * US));
        // A call admitted last ends before the next output event.
        assert!(899 * US + u64::from(CALL_RESERVE_NS) < u64::from(w.period_ns()));
    }

    #[test]
    fn a_lost_frame_does_not_widen_the_window() {
        let mut w = cycles(100 * US, 3);
        // The frame at 400 us is lost; the next comes at 500 us.
        w.on_output_event(500 * US);
        assert_eq!(u64::from(w.period_ns()), 100 * US);
        assert!(!w.is_open(500 * US + 60 * US));
        // A cycle time changed for good is followed after two events.
        w.on_output_event(700 * US);
        w.on_output_event(900 * US);
        assert_eq!(u64::from(w.period_ns()), 200 * US);
    }

    #[test]
    fn a_second_event_in_the_same_cycle_is_not_a_cycle() {
        let mut w = cycles(100 * US, 3);
        w.on_output_event(300 * US + 15 * US);
        assert_eq!(u64::from(w.period_ns()), 100 * US);
        assert!(
            !w.is_open(300 * US + 60 * US),
            "not taken for stopped cycles"
        );
    }

    #[test]
    fn stopped_cycles_open_the_window() {
        let w = cycles(100 * US, 3);
        let last = 300 * US;
        assert!(!w.is_open(last + 399 * US));
        assert!(w.is_open(last + u64::from(STOPPED_PERIODS) * 100 * US));
    }

    #[test]
    fn a_refused_call_waits_for_the_window() {
        let mut w = cycles(100 * US, 3);
        let last = 300 * US;
        assert!(!w.admit(last + 70 * US));
        assert!(w.waiting());
        assert!(!w.work_waiting(last + 80 * US), "still closed");
        w.on_output_event(last + 100 * US);
        assert!(
            w.work_waiting(last + 110 * US),
            "opened by the next outputs"
        );
        assert!(w.admit(last + 110 * US));
        assert!(!w.waiting() && !w.work_waiting(last + 111 * US));
    }
}
