//! The process data the master exchanges with one node, and their supervision.
//!
//! An [`Input`] is a TPDO of the node: its last data, how often it came, and what went
//! wrong: a synchronous TPDO (transmission type 1..=240) that did not come within its
//! number of SYNC periods is missing (the check runs when the master sends the next SYNC,
//! from the second SYNC after the node started); a TPDO of another length than its
//! mapping is refused; an event-driven TPDO with a deadline that did not come within it
//! timed out. Each problem is reported when it starts and counted every time.
//!
//! An [`Output`] is an RPDO of the node: the data the application set, sent after every
//! SYNC (synchronous types) or when they change and every event timer period (event-driven
//! types).

use super::super::pdo::{PdoData, Transmission};
use super::config::PdoConfig;

/// Counters of an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InputStats {
    /// Frames taken.
    pub received: u32,
    /// SYNC periods it was missing in.
    pub missing: u32,
    /// Frames refused for their length.
    pub length_errors: u32,
    /// Deadlines passed.
    pub timeouts: u32,
}

/// A problem an input reports (once, when it starts).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InputProblem {
    /// Missing at a SYNC.
    Missing,
    /// Wrong length (the length received).
    Length(u8),
    /// Deadline passed.
    Timeout,
}

/// A TPDO of a node as the master receives it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Input {
    data: Option<PdoData>,
    running: bool,
    armed: bool,
    since_sync: bool,
    syncs_without: u8,
    last_us: u64,
    missing_reported: bool,
    length_reported: bool,
    timeout_reported: bool,
    /// Counters.
    pub stats: InputStats,
}

impl Input {
    /// The node became operational at `now_us`: supervision starts.
    pub fn start(&mut self, now_us: u64) {
        self.running = true;
        self.armed = false;
        self.since_sync = false;
        self.syncs_without = 0;
        self.last_us = now_us;
        self.missing_reported = false;
        self.timeout_reported = false;
    }

    /// The node stopped: no supervision (the last data stay).
    pub fn stop(&mut self) {
        self.running = false;
    }

    /// The last data taken.
    pub fn data(&self) -> Option<&[u8]> {
        self.data
            .as_ref()
            .map(|d| d.bytes.get(..usize::from(d.len)).unwrap_or(&[]))
    }

    /// A frame of this PDO; a problem if it starts one.
    pub fn receive(&mut self, cfg: &PdoConfig, data: &[u8], now_us: u64) -> Option<InputProblem> {
        if data.len() != cfg.len() {
            self.stats.length_errors = self.stats.length_errors.wrapping_add(1);
            let first = !core::mem::replace(&mut self.length_reported, true);
            return first.then_some(InputProblem::Length(data.len() as u8));
        }
        self.length_reported = false;
        self.data = Some(PdoData::new(data));
        self.stats.received = self.stats.received.wrapping_add(1);
        self.since_sync = true;
        self.last_us = now_us;
        self.timeout_reported = false;
        None
    }

    /// The master sends a SYNC: the check of a synchronous TPDO.
    pub fn sync(&mut self, cfg: &PdoConfig) -> Option<InputProblem> {
        let Some(Transmission::SyncCyclic(n)) = cfg.transmission() else {
            return None;
        };
        if !self.running {
            return None;
        }
        if !core::mem::replace(&mut self.armed, true) {
            self.since_sync = false;
            return None;
        }
        if core::mem::take(&mut self.since_sync) {
            self.syncs_without = 0;
            self.missing_reported = false;
            return None;
        }
        self.syncs_without = self.syncs_without.saturating_add(1);
        if self.syncs_without < n {
            return None;
        }
        self.syncs_without = 0;
        self.stats.missing = self.stats.missing.wrapping_add(1);
        let first = !core::mem::replace(&mut self.missing_reported, true);
        first.then_some(InputProblem::Missing)
    }

    /// When the deadline of an event-driven TPDO passes.
    pub fn deadline_us(&self, cfg: &PdoConfig) -> Option<u64> {
        let event = matches!(cfg.transmission(), Some(Transmission::Event));
        (self.running && event && cfg.deadline_ms != 0 && !self.timeout_reported)
            .then(|| self.last_us + u64::from(cfg.deadline_ms) * 1000)
    }

    /// The deadline check at `now_us`.
    pub fn check_deadline(&mut self, cfg: &PdoConfig, now_us: u64) -> Option<InputProblem> {
        match self.deadline_us(cfg) {
            Some(t) if now_us >= t => {
                self.timeout_reported = true;
                self.stats.timeouts = self.stats.timeouts.wrapping_add(1);
                Some(InputProblem::Timeout)
            }
            _ => None,
        }
    }
}

/// An RPDO of a node as the master sends it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Output {
    data: Option<PdoData>,
    changed: bool,
    next_us: Option<u64>,
    /// Frames sent.
    pub sent: u32,
}

impl Output {
    /// New data; false (nothing taken) if the length is not the mapping's.
    pub fn set(&mut self, cfg: &PdoConfig, data: &[u8]) -> bool {
        if data.len() != cfg.len() {
            return false;
        }
        let new = PdoData::new(data);
        if self.data != Some(new) {
            self.changed = true;
            self.data = Some(new);
        }
        true
    }

    /// The data set, if any.
    pub fn data(&self) -> Option<&[u8]> {
        self.data
            .as_ref()
            .map(|d| d.bytes.get(..usize::from(d.len)).unwrap_or(&[]))
    }

    /// True if the SYNC makes this output go out.
    pub fn due_at_sync(&self, cfg: &PdoConfig) -> bool {
        self.data.is_some() && cfg.transmission().is_some_and(|t| t.is_synchronous())
    }

    /// True if an event-driven output goes out at `now_us` (changed, or its period).
    pub fn due_by_event(&self, cfg: &PdoConfig, now_us: u64) -> bool {
        self.data.is_some()
            && matches!(cfg.transmission(), Some(Transmission::Event))
            && (self.changed || self.next_us.is_some_and(|t| now_us >= t))
    }

    /// When the event timer repeats the output.
    pub fn next_us(&self, cfg: &PdoConfig) -> Option<u64> {
        let event = matches!(cfg.transmission(), Some(Transmission::Event));
        if !event || self.data.is_none() {
            return None;
        }
        if self.changed {
            return Some(0);
        }
        self.next_us
    }

    /// The output went out at `now_us`.
    pub fn sent(&mut self, cfg: &PdoConfig, now_us: u64) {
        self.changed = false;
        self.sent = self.sent.wrapping_add(1);
        self.next_us =
            (cfg.event_timer_ms != 0).then(|| now_us + u64::from(cfg.event_timer_ms) * 1000);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdo::PdoEntry;

    fn cfg(t: u8) -> PdoConfig {
        PdoConfig::new(1, 0x185, t, &[PdoEntry::new(0x6000, 1, 16)])
    }

    #[test]
    fn a_missing_sync_tpdo_from_the_second_sync() {
        let c = cfg(1);
        let mut i = Input::default();
        assert_eq!(i.sync(&c), None, "not running");
        i.start(0);
        assert_eq!(i.sync(&c), None, "arms");
        assert_eq!(i.receive(&c, &[1, 2], 10), None);
        assert_eq!(i.sync(&c), None, "came");
        assert_eq!(i.sync(&c), Some(InputProblem::Missing));
        assert_eq!(i.sync(&c), None, "reported once");
        assert_eq!(i.stats.missing, 2, "counted twice");
        i.receive(&c, &[3, 4], 20);
        assert_eq!(i.sync(&c), None);
        assert_eq!(i.sync(&c), Some(InputProblem::Missing), "reported again");
        assert_eq!(i.data(), Some(&[3u8, 4][..]));
        // Every 3rd SYNC: missing after 3 SYNCs without it.
        let c3 = cfg(3);
        let mut i = Input::default();
        i.start(0);
        i.sync(&c3);
        assert_eq!((i.sync(&c3), i.sync(&c3)), (None, None));
        assert_eq!(i.sync(&c3), Some(InputProblem::Missing));
    }

    #[test]
    fn length_and_deadline() {
        let mut c = cfg(255);
        c.deadline_ms = 100;
        let mut i = Input::default();
        i.start(1_000);
        assert_eq!(i.receive(&c, &[1], 0), Some(InputProblem::Length(1)));
        assert_eq!(i.receive(&c, &[1, 2, 3], 0), None, "once");
        assert_eq!(i.data(), None);
        assert_eq!(i.stats.length_errors, 2);
        assert_eq!(i.deadline_us(&c), Some(101_000));
        assert_eq!(i.check_deadline(&c, 100_999), None);
        assert_eq!(i.check_deadline(&c, 101_000), Some(InputProblem::Timeout));
        assert_eq!(i.check_deadline(&c, 500_000), None, "once");
        i.receive(&c, &[1, 2], 600_000);
        assert_eq!(i.deadline_us(&c), Some(700_000));
        assert_eq!(i.sync(&c), None, "event-driven: no SYNC check");
    }

    #[test]
    fn outputs() {
        let s = cfg(1);
        let mut o = Output::default();
        assert!(!o.due_at_sync(&s), "nothing set");
        assert!(!o.set(&s, &[1]));
        assert!(o.set(&s, &[1, 2]));
        assert!(o.due_at_sync(&s));
        let mut e = cfg(255);
        e.event_timer_ms = 50;
        let mut o = Output::default();
        o.set(&e, &[1, 2]);
        assert!(o.due_by_event(&e, 0));
        assert_eq!(o.next_us(&e), Some(0));
        o.sent(&e, 1_000);
        assert!(!o.due_by_event(&e, 50_999));
        assert!(o.due_by_event(&e, 51_000), "period");
        o.sent(&e, 51_000);
        o.set(&e, &[1, 2]);
        assert!(!o.due_by_event(&e, 60_000), "same data");
        o.set(&e, &[1, 3]);
        assert!(o.due_by_event(&e, 60_000));
        assert_eq!(o.data(), Some(&[1u8, 3][..]));
    }
}
