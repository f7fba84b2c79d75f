//! NMT error control (CiA 301 7.2.8.3.2): heartbeat producer (0x1017), heartbeat consumer
//! (0x1016) and node guarding with life guarding (0x100C guard time, 0x100D life time
//! factor), all on COB-ID 0x700 + node-ID.
//!
//! - Heartbeat producer: every 0x1017 ms one byte, the NMT state code; the boot-up message
//!   (state 0) is the first heartbeat. A state change is reported at once as well.
//! - Heartbeat consumer: each 0x1016 entry (`node << 16 | time_ms`) watches one node;
//!   monitoring starts with that node's first heartbeat, and a gap of the time or longer
//!   is a heartbeat event (reported once, until the node is heard again).
//! - Node guarding: the master sends a remote frame to 0x700 + node-ID; the node answers one
//!   byte, bit 7 a toggle (0 in the first answer after a reset of communication) and the
//!   state code. Life guarding: once guarded, a node that hears no guard request for
//!   `guard time x life time factor` reports a life guarding event. CiA 301 lets a node
//!   use one of the two protocols: node guarding answers only while the heartbeat producer
//!   time is 0.

use super::nmt::NmtState;

/// Microseconds per millisecond.
const US_PER_MS: u64 = 1000;

/// The heartbeat producer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HeartbeatProducer {
    next_us: Option<u64>,
}

impl HeartbeatProducer {
    /// Not running.
    pub const fn new() -> Self {
        Self { next_us: None }
    }

    /// A heartbeat (or the boot-up message) was sent at `now_us`: the next one is due
    /// `period_ms` later (never with period 0).
    // Out of line: the timers, boot-up, NMT transitions and 0x1017 writes share one copy.
    #[inline(never)]
    pub fn sent(&mut self, now_us: u64, period_ms: u16) {
        self.next_us = (period_ms != 0).then(|| now_us + u64::from(period_ms) * US_PER_MS);
    }

    /// The period changed (0x1017 written): restart the cycle at `now_us`.
    pub fn restart(&mut self, now_us: u64, period_ms: u16) {
        self.sent(now_us, period_ms);
    }

    /// True if a heartbeat is due at `now_us`.
    pub fn due(&self, now_us: u64) -> bool {
        self.next_us.is_some_and(|t| now_us >= t)
    }

    /// When the next heartbeat is due.
    pub const fn next_us(&self) -> Option<u64> {
        self.next_us
    }
}

/// One 0x1016 entry: the monitored node and its heartbeat time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConsumerEntry {
    /// Monitored node-ID (0: entry not used).
    pub node: u8,
    /// Heartbeat consumer time in ms (0: entry not used).
    pub time_ms: u16,
}

impl ConsumerEntry {
    /// Decodes the 0x1016 value `node << 16 | time`; bits 31..24 are reserved.
    pub const fn from_u32(raw: u32) -> Self {
        Self {
            node: (raw >> 16) as u8,
            time_ms: raw as u16,
        }
    }

    /// The 0x1016 value.
    pub const fn to_u32(self) -> u32 {
        (self.node as u32) << 16 | self.time_ms as u32
    }

    /// True if the entry watches a node.
    pub const fn is_active(self) -> bool {
        self.node != 0 && self.node <= 127 && self.time_ms != 0
    }
}

/// What the consumer saw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConsumerEvent {
    /// The node's heartbeat did not come in time.
    Lost {
        /// The node.
        node: u8,
    },
    /// A node that was lost is heard again.
    Resumed {
        /// The node.
        node: u8,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct Watch {
    last_us: Option<u64>,
    lost: bool,
    state: Option<NmtState>,
}

/// The heartbeat consumer for up to `N` nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HeartbeatConsumer<const N: usize> {
    watch: [Watch; N],
}

impl<const N: usize> Default for HeartbeatConsumer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> HeartbeatConsumer<N> {
    /// Nothing heard yet.
    pub const fn new() -> Self {
        Self {
            watch: [Watch {
                last_us: None,
                lost: false,
                state: None,
            }; N],
        }
    }

    /// Forgets everything (reset of communication, or an entry changed).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Forgets entry `i` (its 0x1016 value changed).
    pub fn reset_entry(&mut self, i: usize) {
        if let Some(w) = self.watch.get_mut(i) {
            *w = Watch::default();
        }
    }

    /// A heartbeat of `node` with state code `code` at `now_us`. Returns the event if a
    /// lost node is heard again.
    pub fn heard(
        &mut self,
        entries: &[ConsumerEntry; N],
        node: u8,
        code: u8,
        now_us: u64,
    ) -> Option<ConsumerEvent> {
        let mut event = None;
        for (entry, w) in entries.iter().zip(self.watch.iter_mut()) {
            if entry.is_active() && entry.node == node {
                if w.lost {
                    event = Some(ConsumerEvent::Resumed { node });
                }
                *w = Watch {
                    last_us: Some(now_us),
                    lost: false,
                    state: NmtState::from_code(code),
                };
            }
        }
        event
    }

    /// Checks the deadlines at `now_us`; returns the first newly lost node.
    pub fn check(&mut self, entries: &[ConsumerEntry; N], now_us: u64) -> Option<ConsumerEvent> {
        for (entry, w) in entries.iter().zip(self.watch.iter_mut()) {
            let Some(last) = w.last_us else { continue };
            if !entry.is_active() || w.lost {
                continue;
            }
            if now_us >= last + u64::from(entry.time_ms) * US_PER_MS {
                w.lost = true;
                return Some(ConsumerEvent::Lost { node: entry.node });
            }
        }
        None
    }

    /// The earliest deadline still being watched.
    pub fn next_deadline_us(&self, entries: &[ConsumerEntry; N]) -> Option<u64> {
        entries
            .iter()
            .zip(self.watch.iter())
            .filter(|(e, w)| e.is_active() && !w.lost)
            .filter_map(|(e, w)| Some(w.last_us? + u64::from(e.time_ms) * US_PER_MS))
            .min()
    }

    /// The last state `node` reported, if it is watched and was heard.
    pub fn state_of(&self, entries: &[ConsumerEntry; N], node: u8) -> Option<NmtState> {
        entries
            .iter()
            .zip(self.watch.iter())
            .find(|(e, _)| e.is_active() && e.node == node)
            .and_then(|(_, w)| w.state)
    }

    /// True while any watched node is lost.
    pub fn any_lost(&self) -> bool {
        self.watch.iter().any(|w| w.lost)
    }
}

/// Node guarding and life guarding.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NodeGuarding {
    toggle: bool,
    last_request_us: Option<u64>,
    lost: bool,
}

/// What life guarding saw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LifeGuardEvent {
    /// No guard request within the life time.
    Lost,
    /// Guard requests came again after a loss.
    Resumed,
}

impl NodeGuarding {
    /// Toggle 0, not guarded yet.
    pub const fn new() -> Self {
        Self {
            toggle: false,
            last_request_us: None,
            lost: false,
        }
    }

    /// A guard request (remote frame) at `now_us`: the answer byte (toggle and state code),
    /// and a life guarding event if guarding resumes after a loss.
    pub fn request(&mut self, state: NmtState, now_us: u64) -> (u8, Option<LifeGuardEvent>) {
        let answer = state.code() | if self.toggle { 0x80 } else { 0 };
        self.toggle = !self.toggle;
        self.last_request_us = Some(now_us);
        let event = core::mem::take(&mut self.lost).then_some(LifeGuardEvent::Resumed);
        (answer, event)
    }

    /// The life time in µs, `None` when life guarding is off (either value 0).
    pub fn life_time_us(guard_time_ms: u16, life_factor: u8) -> Option<u64> {
        let t = u64::from(guard_time_ms) * u64::from(life_factor) * US_PER_MS;
        (t != 0).then_some(t)
    }

    /// Checks the life time at `now_us`.
    pub fn check(
        &mut self,
        guard_time_ms: u16,
        life_factor: u8,
        now_us: u64,
    ) -> Option<LifeGuardEvent> {
        let life = Self::life_time_us(guard_time_ms, life_factor)?;
        let last = self.last_request_us?;
        if !self.lost && now_us >= last + life {
            self.lost = true;
            return Some(LifeGuardEvent::Lost);
        }
        None
    }

    /// When life guarding expires next, if it is running.
    pub fn deadline_us(&self, guard_time_ms: u16, life_factor: u8) -> Option<u64> {
        if self.lost {
            return None;
        }
        Some(self.last_request_us? + Self::life_time_us(guard_time_ms, life_factor)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn producer_period() {
        let mut p = HeartbeatProducer::new();
        assert!(!p.due(0));
        p.sent(1_000, 100);
        assert!(!p.due(100_999));
        assert!(p.due(101_000));
        p.sent(101_000, 0);
        assert!(!p.due(u64::MAX), "period 0: off");
    }

    #[test]
    fn consumer_entry_encoding() {
        let e = ConsumerEntry::from_u32(0x0020_03E8);
        assert_eq!(
            e,
            ConsumerEntry {
                node: 0x20,
                time_ms: 1000
            }
        );
        assert_eq!(e.to_u32(), 0x0020_03E8);
        assert!(e.is_active());
        assert!(!ConsumerEntry::from_u32(0x0020_0000).is_active());
        assert!(!ConsumerEntry::from_u32(0x0000_03E8).is_active());
        assert!(
            !ConsumerEntry::from_u32(0x0080_03E8).is_active(),
            "node 128"
        );
    }

    #[test]
    fn consumer_starts_with_the_first_heartbeat_and_reports_once() {
        let entries = [
            ConsumerEntry {
                node: 3,
                time_ms: 100,
            },
            ConsumerEntry {
                node: 0,
                time_ms: 0,
            },
        ];
        let mut c = HeartbeatConsumer::<2>::new();
        assert_eq!(
            c.check(&entries, 10_000_000),
            None,
            "not heard yet: no monitoring"
        );
        assert_eq!(c.heard(&entries, 3, 5, 0), None);
        assert_eq!(c.state_of(&entries, 3), Some(NmtState::Operational));
        assert_eq!(c.next_deadline_us(&entries), Some(100_000));
        assert_eq!(c.check(&entries, 99_999), None, "in time");
        assert_eq!(
            c.check(&entries, 100_000),
            Some(ConsumerEvent::Lost { node: 3 })
        );
        assert_eq!(c.check(&entries, 200_000), None, "reported once");
        assert!(c.any_lost());
        assert_eq!(
            c.heard(&entries, 3, 127, 300_000),
            Some(ConsumerEvent::Resumed { node: 3 })
        );
        assert!(!c.any_lost());
        assert_eq!(c.heard(&entries, 4, 5, 300_000), None, "not watched");
    }

    #[test]
    fn guarding_toggles_and_life_time() {
        let mut g = NodeGuarding::new();
        assert_eq!(g.check(100, 3, 1_000_000_000), None, "not guarded yet");
        assert_eq!(g.request(NmtState::PreOperational, 0), (0x7F, None));
        assert_eq!(g.request(NmtState::PreOperational, 100_000), (0xFF, None));
        assert_eq!(g.request(NmtState::Operational, 200_000), (0x05, None));
        assert_eq!(g.deadline_us(100, 3), Some(500_000));
        assert_eq!(g.check(100, 3, 499_999), None);
        assert_eq!(g.check(100, 3, 500_000), Some(LifeGuardEvent::Lost));
        assert_eq!(g.check(100, 3, 900_000), None, "reported once");
        assert_eq!(
            g.request(NmtState::Operational, 900_000),
            (0x85, Some(LifeGuardEvent::Resumed))
        );
        assert_eq!(
            g.check(0, 3, u64::MAX),
            None,
            "guard time 0: no life guarding"
        );
        assert_eq!(NodeGuarding::life_time_us(100, 0), None);
    }
}
