//! The 64-bit time base on the core's cycle counter
//! (`firmware::platform::stm32f1::time`): extended under a short critical section, so any
//! priority may read it.

use core::cell::Cell;
use cortex_m::interrupt::{self, Mutex};
use cortex_m::peripheral::{DCB, DWT};
use firmware::platform::stm32f1::time::{cycles_to_ns, CycleClock};

static CLOCK: Mutex<Cell<CycleClock>> = Mutex::new(Cell::new(CycleClock::new()));

/// Starts the cycle counter.
pub fn init(dcb: &mut DCB, dwt: &mut DWT) {
    dcb.enable_trace();
    dwt.enable_cycle_counter();
}

/// Cycles since [`init`].
pub fn now_cycles() -> u64 {
    interrupt::free(|cs| {
        let cell = CLOCK.borrow(cs);
        let mut clock = cell.get();
        let now = clock.observe(DWT::cycle_count());
        cell.set(clock);
        now
    })
}

/// Nanoseconds since [`init`].
pub fn now_ns() -> u64 {
    cycles_to_ns(now_cycles())
}
