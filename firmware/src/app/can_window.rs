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
//! always open. The SM2 path only notes the time and counts; the CAN side measures the
//! period as the mean interval since it last looked and uses the shorter of its last two
//! measurements, so one lost frame does not widen the window into the next cycle.

use crate::product::sync::MIN_CYCLE_TIME_NS;

/// Longest node call the window leaves room for (ns): the image's longest measured CAN
/// activation (NMT start, 8 466 cycles at 100 MHz) with margin.
pub const CALL_RESERVE_NS: u32 = 100_000;

/// A mean interval below this (half the shortest DC cycle the module accepts) is no
/// period: a second SM2 event of a cycle (the line still asserted, a repeated read).
pub const SAME_CYCLE_NS: u32 = MIN_CYCLE_TIME_NS / 2;

/// Periods without an output event after which EtherCAT cycles count as stopped.
pub const STOPPED_PERIODS: u32 = 4;

/// The output events seen and whether CAN work waits for the window.
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
    /// A node call was refused: the PDI task pends the CAN task when the window opens.
    waiting: bool,
}

impl CanWindow {
    /// No output event seen: always open.
    pub const fn new() -> Self {
        Self {
            last_ns: 0,
            events: 0,
            seen: (0, 0),
            periods: [0; 2],
            waiting: false,
        }
    }

    /// An EtherCAT cycle's outputs (SM2 event) were served at `now_ns`. On the SM2 path,
    /// so only the time and a count are kept: the CAN side works the period out.
    pub fn on_output_event(&mut self, now_ns: u64) {
        self.last_ns = now_ns;
        self.events = self.events.wrapping_add(1);
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
        if seen_ns != 0 && mean >= SAME_CYCLE_NS {
            self.periods = [self.periods[1], mean];
        }
        self.seen = (self.last_ns, self.events);
    }

    /// Whether a node call may start at `now_ns`. (Out of line: one copy for the PDI and
    /// the CAN task.)
    #[inline(never)]
    pub fn is_open(&self, now_ns: u64) -> bool {
        let period = self.period_ns();
        let since = span(self.last_ns, now_ns);
        period == 0
            || since / STOPPED_PERIODS >= period
            || since < (period / 2).max(period.saturating_sub(CALL_RESERVE_NS))
    }

    /// [`CanWindow::is_open`], remembering a refusal as work that waits.
    pub fn admit(&mut self, now_ns: u64) -> bool {
        self.measure();
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

    /// An output event the CAN side looks at before the next.
    fn event(w: &mut CanWindow, t: u64) {
        w.on_output_event(t);
        w.measure();
    }

    /// Output events every `period` from `period` on, `n` of them.
    fn cycles(period: u64, n: u64) -> CanWindow {
        let mut w = CanWindow::new();
        for k in 1..=n {
            event(&mut w, k * period);
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
        event(&mut w, 500 * US);
        assert_eq!(u64::from(w.period_ns()), 100 * US);
        assert!(!w.is_open(500 * US + 60 * US));
        // A cycle time changed for good is followed after two events.
        event(&mut w, 700 * US);
        event(&mut w, 900 * US);
        assert_eq!(u64::from(w.period_ns()), 200 * US);
    }

    #[test]
    fn a_second_event_in_the_same_cycle_is_not_a_cycle() {
        let mut w = cycles(100 * US, 3);
        event(&mut w, 300 * US + 15 * US);
        assert_eq!(u64::from(w.period_ns()), 100 * US);
        assert!(
            !w.is_open(315 * US + 60 * US),
            "not taken for stopped cycles"
        );
        // The CAN side looking once per several cycles measures their mean (from the
        // second event of the cycle: a little shorter, the safe side).
        for k in 4..=9 {
            w.on_output_event(k * 100 * US);
        }
        w.measure();
        assert_eq!(u64::from(w.period_ns()), (900 - 315) * US / 6);
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
