//! The node guarding master (CiA 301 7.2.8.3.2.1): every guard time a remote frame to the
//! node, which answers its state with a toggle bit that alternates from answer to answer.
//! An answer that does not come before the next request, or comes with the toggle bit not
//! alternated, is a miss; `life time factor` misses in a row (the node's life time) make
//! the node lost, reported once. The next good answer brings it back.

/// What an answer or a request showed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GuardEvent {
    /// The life time passed without a good answer.
    Lost,
    /// A lost node answered well again.
    Resumed,
}

/// The guarding of one node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GuardMaster {
    next_us: Option<u64>,
    awaiting: bool,
    last_toggle: Option<bool>,
    misses: u8,
    lost: bool,
    /// Answers whose toggle bit did not alternate.
    pub toggle_errors: u32,
}

impl GuardMaster {
    /// Not guarding.
    pub const fn new() -> Self {
        Self {
            next_us: None,
            awaiting: false,
            last_toggle: None,
            misses: 0,
            lost: false,
            toggle_errors: 0,
        }
    }

    /// Starts guarding at `now_us`: the first request is due at once, the toggle bit is
    /// taken from the first answer (a node starts with 0 after a reset of communication,
    /// but a node guarded before may be at 1).
    pub fn start(&mut self, now_us: u64) {
        *self = Self {
            next_us: Some(now_us),
            toggle_errors: self.toggle_errors,
            ..Self::new()
        };
    }

    /// Stops guarding.
    pub fn stop(&mut self) {
        self.next_us = None;
        self.awaiting = false;
    }

    /// When the next request is due.
    pub const fn next_us(&self) -> Option<u64> {
        self.next_us
    }

    /// True while the node is lost.
    pub const fn is_lost(&self) -> bool {
        self.lost
    }

    /// A request goes out at `now_us` if one is due: the unanswered previous one counts as
    /// a miss; returns whether to send and the loss if this miss completes the life time.
    pub fn request(
        &mut self,
        now_us: u64,
        guard_ms: u16,
        life_factor: u8,
    ) -> (bool, Option<GuardEvent>) {
        match self.next_us {
            Some(t) if now_us >= t => {}
            _ => return (false, None),
        }
        let mut event = None;
        if self.awaiting {
            event = self.miss(life_factor);
        }
        self.awaiting = true;
        self.next_us = Some(now_us + u64::from(guard_ms) * 1000);
        (true, event)
    }

    fn miss(&mut self, life_factor: u8) -> Option<GuardEvent> {
        self.misses = self.misses.saturating_add(1);
        if !self.lost && self.misses >= life_factor.max(1) {
            self.lost = true;
            return Some(GuardEvent::Lost);
        }
        None
    }

    /// An answer byte (toggle in bit 7, the state code below) arrived; a loss or return it
    /// completes. An answer nobody asked for is ignored.
    pub fn answer(&mut self, byte: u8, life_factor: u8) -> Option<GuardEvent> {
        if !self.awaiting {
            return None;
        }
        self.awaiting = false;
        let toggle = byte & 0x80 != 0;
        let expected = self.last_toggle.map(|t| !t);
        self.last_toggle = Some(toggle);
        if expected.is_some_and(|e| e != toggle) {
            self.toggle_errors = self.toggle_errors.wrapping_add(1);
            return self.miss(life_factor);
        }
        self.misses = 0;
        core::mem::take(&mut self.lost).then_some(GuardEvent::Resumed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_answers_and_life_time() {
        let mut g = GuardMaster::new();
        assert_eq!(g.request(0, 100, 3), (false, None), "not started");
        g.start(1_000);
        assert_eq!(g.request(1_000, 100, 3), (true, None));
        assert_eq!(g.answer(0x7F, 3), None);
        assert_eq!(g.answer(0xFF, 3), None, "not asked");
        assert_eq!(g.request(100_999, 100, 3), (false, None));
        assert_eq!(g.request(101_000, 100, 3), (true, None));
        assert_eq!(g.answer(0x85, 3), None);
        // Silence: misses at the 2nd, 3rd and 4th request; lost at the third.
        assert_eq!(g.request(201_000, 100, 3), (true, None));
        assert_eq!(g.request(301_000, 100, 3), (true, None));
        assert_eq!(g.request(401_000, 100, 3), (true, None));
        assert_eq!(g.request(501_000, 100, 3), (true, Some(GuardEvent::Lost)));
        assert!(g.is_lost());
        assert_eq!(g.request(601_000, 100, 3), (true, None), "reported once");
        // The node answers again (toggle continues from its own count).
        assert_eq!(g.answer(0x05, 3), Some(GuardEvent::Resumed));
        assert!(!g.is_lost());
    }

    #[test]
    fn toggle_not_alternated_is_a_miss() {
        let mut g = GuardMaster::new();
        g.start(0);
        g.request(0, 10, 2);
        g.answer(0x05, 2);
        g.request(10_000, 10, 2);
        assert_eq!(g.answer(0x05, 2), None, "first miss");
        // The next answer is judged from the last one.
        g.request(20_000, 10, 2);
        assert_eq!(g.answer(0x05, 2), Some(GuardEvent::Lost), "second miss");
        assert_eq!(g.toggle_errors, 2);
        g.request(30_000, 10, 2);
        assert_eq!(g.answer(0x85, 2), Some(GuardEvent::Resumed));
    }
}
