//! The independent watchdog (RM0008 chapter 19): KR's keys (0xCCCC start, 0xAAAA reload,
//! 0x5555 unlocks PR and RLR), the 12-bit down-counter on the LSI divided by 4 << PR, and the
//! reset when it reaches 0. Once started it cannot be stopped (until a reset).

use super::unconfirmed::LSI_HZ;
use crate::periph::ticks_to_ns;

const KR: u32 = 0x00;
const PR: u32 = 0x04;
const RLR: u32 = 0x08;
const SR: u32 = 0x0C;

/// The IWDG.
#[derive(Clone, Debug)]
pub struct Iwdg {
    pr: u32,
    rlr: u32,
    unlocked: bool,
    /// When the counter reaches 0 (started).
    expires_at: Option<u64>,
    reset_request: bool,
    /// Writes to PR/RLR while locked (ignored by the chip).
    pub locked_writes: u64,
}

impl Default for Iwdg {
    fn default() -> Self {
        Self::new()
    }
}

impl Iwdg {
    /// Reset: stopped, PR 0 (/4), RLR 0xFFF.
    pub fn new() -> Self {
        Self {
            pr: 0,
            rlr: 0xFFF,
            unlocked: false,
            expires_at: None,
            reset_request: false,
            locked_writes: 0,
        }
    }

    fn timeout_ns(&self) -> u64 {
        let div = 4u64 << self.pr.min(6);
        ticks_to_ns((u64::from(self.rlr) + 1) * div, LSI_HZ)
    }

    /// Whether it runs.
    pub fn started(&self) -> bool {
        self.expires_at.is_some()
    }

    /// When it resets the chip.
    pub fn next_event(&self) -> Option<u64> {
        self.expires_at
    }

    /// Time passes to `now`.
    pub fn on_event(&mut self, now: u64) {
        if self.expires_at.is_some_and(|t| now >= t) {
            self.reset_request = true;
            self.expires_at = None;
        }
    }

    /// Whether it reset the chip (once).
    pub fn take_reset_request(&mut self) -> bool {
        std::mem::take(&mut self.reset_request)
    }

    /// A register read (SR: the updates take effect at once here: PVU/RVU 0).
    pub fn read(&self, offset: u32) -> u32 {
        match offset {
            PR => self.pr,
            RLR => self.rlr,
            KR | SR => 0,
            _ => 0,
        }
    }

    /// A register write at `now`; `true` when the key starts it (the LSI must run).
    pub fn write(&mut self, now: u64, offset: u32, value: u32) -> bool {
        match (offset, value & 0xFFFF) {
            (KR, 0xCCCC) => {
                self.expires_at = Some(now + self.timeout_ns());
                self.unlocked = false;
                return true;
            }
            (KR, 0xAAAA) => {
                self.unlocked = false;
                if self.expires_at.is_some() {
                    self.expires_at = Some(now + self.timeout_ns());
                }
            }
            (KR, 0x5555) => self.unlocked = true,
            (KR, _) => self.unlocked = false,
            (PR | RLR, v) if self.unlocked => {
                if offset == PR {
                    self.pr = v & 7;
                } else {
                    self.rlr = v & 0xFFF;
                }
            }
            (PR | RLR, _) => self.locked_writes += 1,
            _ => {}
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_boards_100_ms_and_feeding() {
        let mut w = Iwdg::new();
        w.write(0, KR, 0xCCCC);
        w.write(0, KR, 0x5555);
        w.write(0, PR, 3);
        w.write(0, RLR, 125);
        w.write(0, KR, 0xAAAA);
        // 126 x 32 / 40 kHz.
        assert_eq!(w.next_event(), Some(100_800_000));
        w.write(50_000_000, KR, 0xAAAA);
        w.on_event(100_800_000);
        assert!(!w.take_reset_request());
        w.on_event(150_800_000);
        assert!(w.take_reset_request());
        let mut locked = Iwdg::new();
        locked.write(0, PR, 3);
        assert_eq!((locked.read(PR), locked.locked_writes), (0, 1));
    }
}
