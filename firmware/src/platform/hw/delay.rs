//! A busy-wait `DelayNs` from the CPU clock, for the `SpiDevice`s' `Operation::DelayNs`
//! (chip-select gaps). Bounded by construction: it counts cycles.

use super::CCLK_HZ;

/// Cycle-counting delay at [`CCLK_HZ`].
#[derive(Debug, Clone, Copy, Default)]
pub struct CycleDelay;

/// Nanoseconds per CPU cycle (10 at 100 MHz); a whole number, so the cycle count needs
/// only a 32-bit division (a 64-bit one would link `__aeabi_uldivmod`).
const NS_PER_CYCLE: u32 = 1_000_000_000 / CCLK_HZ;
const _: () = assert!(1_000_000_000 % CCLK_HZ == 0, "CCLK must divide 1 GHz");

impl embedded_hal::delay::DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        // cycles = ns * CCLK / 1e9 = ns / NS_PER_CYCLE, rounded up.
        cortex_m::asm::delay(ns.div_ceil(NS_PER_CYCLE).max(1));
    }
}
