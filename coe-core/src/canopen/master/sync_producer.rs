//! The SYNC producer (CiA 301 7.2.5, 0x1005 bit 30, 0x1006, 0x1019): a SYNC every
//! `period` µs on its own clock, or one per `multiplier` cycle events of another clock
//! (the gateway's EtherCAT SM2 or SYNC0 event, so CAN cycles follow the EtherCAT cycle as
//! the EL6751 does it). With a counter overflow value of 2..=240 the SYNC carries a
//! counter that runs 1..=overflow; else it has no data.

use super::super::frame::CanFrame;

/// The producer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncProducer {
    cob_id: u16,
    period_us: u32,
    multiplier: u8,
    overflow: u8,
    counter: u8,
    events: u8,
    next_us: Option<u64>,
    /// SYNCs produced.
    pub produced: u32,
}

impl SyncProducer {
    /// A producer on `cob_id`; `period_us` 0: no own clock; `multiplier` 0: no SYNC from
    /// cycle events; `overflow` outside 2..=240: no counter.
    pub const fn new(cob_id: u16, period_us: u32, multiplier: u8, overflow: u8) -> Self {
        Self {
            cob_id,
            period_us,
            multiplier,
            overflow: if overflow >= 2 && overflow <= 240 {
                overflow
            } else {
                0
            },
            counter: 0,
            events: 0,
            next_us: None,
            produced: 0,
        }
    }

    /// Starts the own clock at `now_us` (the first SYNC one period later).
    pub fn start(&mut self, now_us: u64) {
        self.next_us = (self.period_us != 0).then(|| now_us + u64::from(self.period_us));
        self.events = 0;
        self.counter = 0;
    }

    /// When the own clock's next SYNC is due.
    pub const fn next_us(&self) -> Option<u64> {
        self.next_us
    }

    /// True if the own clock has a SYNC due at `now_us`; the next one is then one period
    /// after the due time (no drift from late calls).
    pub fn due(&mut self, now_us: u64) -> bool {
        match self.next_us {
            Some(t) if now_us >= t => {
                let period = self.period_us.max(1);
                // A call more than a period late skips the SYNCs it missed (32-bit
                // arithmetic: no 64-bit division on the MCU); more than 71 minutes late,
                // the schedule starts again from now.
                self.next_us = Some(match u32::try_from(now_us - t) {
                    Ok(late) => t + u64::from(late - late % period) + u64::from(period),
                    Err(_) => now_us + u64::from(period),
                });
                true
            }
            _ => false,
        }
    }

    /// A cycle event of the other clock: true if this one makes a SYNC.
    pub fn cycle_event(&mut self) -> bool {
        if self.multiplier == 0 {
            return false;
        }
        self.events += 1;
        if self.events >= self.multiplier {
            self.events = 0;
            true
        } else {
            false
        }
    }

    /// The next SYNC frame (advances the counter).
    pub fn frame(&mut self) -> Option<CanFrame> {
        self.produced = self.produced.wrapping_add(1);
        if self.overflow == 0 {
            return CanFrame::new(self.cob_id, &[]).ok();
        }
        self.counter = if self.counter >= self.overflow {
            1
        } else {
            self.counter + 1
        };
        CanFrame::new(self.cob_id, &[self.counter]).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn own_clock_without_drift() {
        let mut s = SyncProducer::new(0x80, 1000, 0, 0);
        assert!(!s.due(u64::MAX), "not started");
        s.start(500);
        assert!(!s.due(1_499));
        assert!(s.due(1_700), "late");
        assert_eq!(s.next_us(), Some(2_500), "the period is kept");
        assert!(s.due(5_600), "three periods late");
        assert_eq!(s.next_us(), Some(6_500));
        let hours_late = 6_500 + 2 * 3_600_000_000;
        assert!(s.due(hours_late), "past the 32-bit lateness");
        assert_eq!(
            s.next_us(),
            Some(hours_late + 1000),
            "the schedule starts again"
        );
        assert!(!s.cycle_event(), "multiplier 0");
        let f = s.frame().unwrap();
        assert_eq!((f.id(), f.data()), (0x80, &[][..]));
    }

    #[test]
    fn cycle_events_with_multiplier_and_counter() {
        let mut s = SyncProducer::new(0x81, 0, 3, 3);
        s.start(0);
        assert_eq!(s.next_us(), None);
        let made: std::vec::Vec<bool> = (0..7).map(|_| s.cycle_event()).collect();
        assert_eq!(made, [false, false, true, false, false, true, false]);
        let counters: std::vec::Vec<u8> = (0..4).map(|_| s.frame().unwrap().data()[0]).collect();
        assert_eq!(counters, [1, 2, 3, 1]);
        assert_eq!(SyncProducer::new(0x80, 0, 1, 1).frame().unwrap().dlc(), 0);
    }
}
