//! The STM32 board's time base: the Cortex-M3's 32-bit cycle counter (DWT_CYCCNT, at HCLK,
//! wrapping every 59.6 s at 72 MHz) extended to 64 bits by looking at it at least once per
//! wrap (the 1 ms tick does), and the SYNC0 capture of a 16-bit timer on the same clock
//! placed on that time base.

use super::clocks::CLOCKS;

/// The cycle counter's clock (Hz).
pub const CYCLE_HZ: u32 = CLOCKS.hclk_hz();

/// The 64-bit cycle count, extended from the 32-bit counter at each look.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CycleClock {
    high: u32,
    last: u32,
}

impl CycleClock {
    /// At cycle 0.
    pub const fn new() -> Self {
        Self { high: 0, last: 0 }
    }

    /// The 64-bit count of the counter reading `now`: a reading below the last one is past
    /// a wrap (the counter is looked at more often than it wraps).
    pub fn observe(&mut self, now: u32) -> u64 {
        if now < self.last {
            self.high = self.high.wrapping_add(1);
        }
        self.last = now;
        (self.high as u64) << 32 | now as u64
    }
}

/// Nanoseconds of `cycles` at [`CYCLE_HZ`].
pub const fn cycles_to_ns(cycles: u64) -> u64 {
    // 72 MHz: 125 / 9 ns per cycle, exact in integers.
    cycles * 1_000 / (CYCLE_HZ as u64 / 1_000_000)
}

/// The cycle count at which a 16-bit timer on the same clock captured `captured`, given
/// the cycle count `now` at which its counter read `counter` (less than one timer wrap,
/// 910 us, after the capture).
pub const fn capture_cycles(now: u64, counter: u16, captured: u16) -> u64 {
    now.wrapping_sub(counter.wrapping_sub(captured) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extends_across_wraps() {
        let mut c = CycleClock::new();
        assert_eq!(c.observe(10), 10);
        assert_eq!(c.observe(0xFFFF_FFF0), 0xFFFF_FFF0);
        assert_eq!(c.observe(5), 0x1_0000_0005);
        assert_eq!(c.observe(5), 0x1_0000_0005);
        assert_eq!(c.observe(0x8000_0000), 0x1_8000_0000);
        assert_eq!(c.observe(1), 0x2_0000_0001);
    }

    #[test]
    fn nanoseconds_at_72_mhz() {
        assert_eq!(CYCLE_HZ, 72_000_000);
        assert_eq!(cycles_to_ns(72), 1_000);
        assert_eq!(cycles_to_ns(72_000_000), 1_000_000_000);
        assert_eq!(cycles_to_ns(9), 125);
    }

    #[test]
    fn captures_before_now_also_across_the_timer_wrap() {
        assert_eq!(capture_cycles(1_000, 500, 400), 900);
        assert_eq!(capture_cycles(1_000, 10, 0xFFF0), 1_000 - 26);
        assert_eq!(capture_cycles(1_000, 7, 7), 1_000);
    }
}
