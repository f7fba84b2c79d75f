//! The watchdog (UM10360 chapter 28, base 0x4000_0000): WDMOD (WDEN b0, WDRESET b1, WDTOF
//! b2, WDINT b3), WDTC (at least 0xFF), WDFEED (0xAA then 0x55), WDTV, WDCLKSEL (0 = IRC,
//! 1 = PCLK, 2 = RTC oscillator). The counter runs from WDCLK / 4 after the first feed
//! with WDEN set; at 0 it resets the chip (WDRESET) or interrupts. WDMOD's WDEN and WDRESET
//! only take effect with a feed, and cannot be cleared by software.

use super::{ticks_to_ns, Peripheral, Tick};

const WDEN: u32 = 1;
const WDRESET: u32 = 2;
const WDTOF: u32 = 4;
const WDINT: u32 = 8;

/// The watchdog.
#[derive(Clone, Debug)]
pub struct Wdt {
    wdmod: u32,
    wdmod_written: u32,
    tc: u32,
    clksel: u32,
    running: bool,
    feed_aa: bool,
    expires_at: Option<u64>,
    reset_request: bool,
    /// Feeds accepted.
    pub feeds: u64,
}

impl Wdt {
    /// Reset state; `timed_out`: WDTOF kept from a watchdog reset.
    pub fn new(timed_out: bool) -> Self {
        Self {
            wdmod: if timed_out { WDTOF } else { 0 },
            wdmod_written: 0,
            tc: 0xFF,
            clksel: 0,
            running: false,
            feed_aa: false,
            expires_at: None,
            reset_request: false,
            feeds: 0,
        }
    }

    fn clock_hz(&self, t: Tick) -> u64 {
        match self.clksel & 3 {
            1 => t.pclk_hz,
            2 => 32_768,
            _ => super::syscon::IRC_HZ,
        }
    }

    fn reload(&mut self, t: Tick) {
        // The counter decrements once per 4 WDCLK periods.
        let ns = ticks_to_ns(u64::from(self.tc) * 4, self.clock_hz(t));
        self.expires_at = Some(t.now_ns + ns);
    }

    /// True once when the watchdog resets the chip.
    pub fn take_reset_request(&mut self) -> bool {
        std::mem::take(&mut self.reset_request)
    }

    /// Whether the counter runs.
    pub fn running(&self) -> bool {
        self.running
    }
}

impl Peripheral for Wdt {
    fn read(&mut self, t: Tick, offset: u32) -> u32 {
        match offset {
            0x00 => self.wdmod,
            0x04 => self.tc,
            0x0C => match self.expires_at {
                Some(e) => {
                    let left = e.saturating_sub(t.now_ns);
                    (u128::from(left) * u128::from(self.clock_hz(t)) / 4_000_000_000) as u32
                }
                None => self.tc,
            },
            0x10 => self.clksel,
            _ => 0,
        }
    }

    fn write(&mut self, t: Tick, offset: u32, value: u32) {
        if offset != 0x08 && self.feed_aa {
            // UM10360 28.4.3: after 0xAA, any other WDT register access before 0x55
            // resets (or interrupts) at once when the watchdog is enabled.
            self.feed_aa = false;
            if self.running {
                self.reset_request = self.wdmod & WDRESET != 0;
            }
        }
        match offset {
            0x00 => {
                // WDEN/WDRESET are set-only; WDTOF and WDINT clear by writing 0.
                self.wdmod_written |= value & (WDEN | WDRESET);
                self.wdmod &= !(WDTOF | WDINT) | (value & (WDTOF | WDINT));
            }
            0x04 => self.tc = value.max(0xFF),
            0x08 => match value & 0xFF {
                0xAA => self.feed_aa = true,
                0x55 if self.feed_aa => {
                    self.feed_aa = false;
                    self.wdmod |= self.wdmod_written;
                    if self.wdmod & WDEN != 0 {
                        self.running = true;
                        self.feeds += 1;
                        self.reload(t);
                    }
                }
                _ => {
                    if self.feed_aa && self.running {
                        self.reset_request = self.wdmod & WDRESET != 0;
                    }
                    self.feed_aa = false;
                }
            },
            0x10 if !self.running => self.clksel = value & 3,
            _ => {}
        }
    }

    fn next_event(&self) -> Option<u64> {
        self.expires_at
    }

    fn on_event(&mut self, t: Tick) {
        if self.expires_at.is_some_and(|e| t.now_ns >= e) {
            self.wdmod |= WDTOF;
            if self.wdmod & WDRESET != 0 {
                self.reset_request = true;
                self.expires_at = None;
            } else {
                self.wdmod |= WDINT;
                self.reload(t);
            }
        }
    }

    fn irq(&self) -> bool {
        self.wdmod & WDINT != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periph::testing::t;

    /// The firmware's setup: IRC, 100 000 ticks of 1 us, WDEN | WDRESET, fed.
    #[test]
    fn times_out_without_feeds_and_keeps_wdtof() {
        let mut w = Wdt::new(false);
        w.write(t(0), 0x10, 0);
        w.write(t(0), 0x04, 100_000);
        w.write(t(0), 0x00, WDEN | WDRESET);
        assert_eq!(w.next_event(), None, "not running before the first feed");
        w.write(t(0), 0x08, 0xAA);
        w.write(t(0), 0x08, 0x55);
        assert_eq!(w.next_event(), Some(100_000_000));
        w.write(t(50_000_000), 0x08, 0xAA);
        w.write(t(50_000_000), 0x08, 0x55);
        assert_eq!(w.next_event(), Some(150_000_000));
        w.on_event(t(150_000_000));
        assert!(w.take_reset_request());
        assert_ne!(w.read(t(0), 0x00) & WDTOF, 0);
    }

    #[test]
    fn a_broken_feed_resets_a_running_watchdog() {
        let mut w = Wdt::new(false);
        w.write(t(0), 0x00, WDEN | WDRESET);
        w.write(t(0), 0x08, 0xAA);
        w.write(t(0), 0x08, 0x55);
        w.write(t(10), 0x08, 0xAA);
        w.write(t(10), 0x04, 0x1000);
        assert!(w.take_reset_request());
    }
}
