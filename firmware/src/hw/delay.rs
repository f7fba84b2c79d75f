//! A busy-wait `DelayNs` from the CPU clock, for the `SpiDevice`s' `Operation::DelayNs`
//! (chip-select gaps). Bounded by construction: it counts cycles.

use super::CCLK_HZ;

/// Cycle-counting delay at [`CCLK_HZ`].
#[derive(Debug, Clone, Copy, Default)]
pub struct CycleDelay;

impl embedded_hal::delay::DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        // cycles = ns * CCLK / 1e9, rounded up; at 100 MHz 10 ns per cycle.
        let cycles = (u64::from(ns) * u64::from(CCLK_HZ)).div_ceil(1_000_000_000);
        cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX).max(1));
    }
}
