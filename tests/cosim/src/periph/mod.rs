//! Models of the LPC1754 peripherals the firmware touches (UM10360), each behind
//! [`Peripheral`]. What crosses between peripherals (interrupt lines, DMA requests, pins,
//! power and clocks) is routed by [`crate::machine`], not by the models themselves.

pub mod can;
pub mod gpdma;
pub mod gpio;
pub mod pincon;
pub mod pwm;
pub mod spi;
pub mod ssp;
pub mod syscon;
pub mod timer;
pub mod wdt;

/// What a peripheral sees of the chip at an access or event: the time and its clock.
#[derive(Clone, Copy, Debug)]
pub struct Tick {
    /// Virtual time (ns).
    pub now_ns: u64,
    /// The peripheral's PCLK (Hz), from SYSCON's PCLKSEL and CCLK.
    pub pclk_hz: u64,
}

/// One peripheral: registers plus timed behaviour.
pub trait Peripheral {
    /// A register read at `offset` from the peripheral's base (word access).
    fn read(&mut self, t: Tick, offset: u32) -> u32;
    /// A register write.
    fn write(&mut self, t: Tick, offset: u32, value: u32);
    /// The next instant (ns) something happens on its own, if anything is scheduled.
    fn next_event(&self) -> Option<u64> {
        None
    }
    /// What is due at `t.now_ns` happens.
    fn on_event(&mut self, _t: Tick) {}
    /// The level of its interrupt line.
    fn irq(&self) -> bool {
        false
    }
}

/// ns of `ticks` periods of a clock of `hz`, rounded up (the edge after).
pub fn ticks_to_ns(ticks: u64, hz: u64) -> u64 {
    match ticks.checked_mul(1_000_000_000) {
        Some(n) => n.div_ceil(hz.max(1)),
        None => (u128::from(ticks) * 1_000_000_000).div_ceil(u128::from(hz.max(1))) as u64,
    }
}

/// Whole periods of a clock of `hz` in `ns`.
pub fn ns_to_ticks(ns: u64, hz: u64) -> u64 {
    match ns.checked_mul(hz) {
        Some(n) => n / 1_000_000_000,
        None => (u128::from(ns) * u128::from(hz) / 1_000_000_000) as u64,
    }
}

/// What the peripherals' unit tests share: a tick at PCLK 100 MHz, and a peripheral run on
/// its own events.
#[cfg(test)]
pub(crate) mod testing {
    use super::{Peripheral, Tick};

    /// The time `now_ns` with PCLK at CCLK (100 MHz).
    pub fn t(now_ns: u64) -> Tick {
        Tick {
            now_ns,
            pclk_hz: 100_000_000,
        }
    }

    /// Everything `p` schedules up to `until` (ns) happens, in order.
    pub fn run_until(p: &mut impl Peripheral, until: u64) {
        while let Some(e) = p.next_event() {
            if e > until {
                break;
            }
            p.on_event(t(e));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_round_as_stated_and_do_not_overflow() {
        assert_eq!(ticks_to_ns(1, 100_000_000), 10);
        assert_eq!(ticks_to_ns(1, 12_000_000), 84, "rounded up");
        assert_eq!(ns_to_ticks(84, 12_000_000), 1, "whole periods");
        // Beyond u64 in the intermediate product: the wide path.
        assert_eq!(
            ticks_to_ns(u64::MAX / 1_000, 1_000_000_000),
            u64::MAX / 1_000
        );
        assert_eq!(ns_to_ticks(u64::MAX / 2, 4), (u64::MAX / 2) / 250_000_000);
    }
}
