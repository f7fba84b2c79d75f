//! What the bootloader does to the Cortex-M3 and the LPC1754 itself: with its `memcpy` and
//! `memclr` (`aeabi_mem`), the only `unsafe` code of the bootloader besides the shared
//! hardware layer and the IAP ROM call.

use lpc17xx_pac as pac;

/// Starts the image whose vector table is at `vectors`: VTOR, main stack pointer and reset
/// handler from the table. The caller has checked the image (header, CRC, vectors).
pub fn start_application(vectors: u32) -> ! {
    // SAFETY: `vectors` is the 256-byte aligned vector table of a checked image; nothing of
    // the bootloader runs after the jump, so its stack and statics may be overwritten. No
    // interrupt is enabled (the bootloader polls), so none fires between VTOR and the jump.
    unsafe {
        (*cortex_m::peripheral::SCB::PTR).vtor.write(vectors);
        cortex_m::asm::bootload(vectors as *const u32)
    }
}

/// Resets the CPU and the peripherals (SYSRESETREQ); the local SRAM keeps its content.
pub fn reset() -> ! {
    cortex_m::peripheral::SCB::sys_reset()
}

/// WDMOD WDEN: the watchdog runs (an application started it; only a reset stops it).
const WDMOD_WDEN: u32 = 1 << 0;
/// A watchdog period for the bootloader: longer than any IAP erase of the slot (UNCONFIRMED
/// timing: 14 sectors of about 100 ms each at most) at the watchdog's 1 MHz tick.
const WATCHDOG_US: u32 = 5_000_000;

/// If an application left the watchdog running (UNCONFIRMED whether SYSRESETREQ stops it on
/// the LPC1754), lengthens its period so erasing flash cannot trip it, and feeds it.
pub fn slow_watchdog(wdt: &pac::WDT) {
    if wdt.mod_.read().bits() & WDMOD_WDEN != 0 {
        // SAFETY: documented value of the timer constant register (UM10360 28.4.2).
        wdt.tc.write(|w| unsafe { w.bits(WATCHDOG_US) });
        feed_watchdog(wdt);
    }
}

/// Feeds the watchdog if it runs (a no-op otherwise: a feed would start it).
pub fn feed_watchdog(wdt: &pac::WDT) {
    if wdt.mod_.read().bits() & WDMOD_WDEN != 0 {
        cortex_m::interrupt::free(|_| {
            // SAFETY: the feed sequence 0xAA, 0x55 (UM10360 28.4.3), with interrupts masked
            // so nothing touches the watchdog in between.
            wdt.feed.write(|w| unsafe { w.bits(0xAA) });
            wdt.feed.write(|w| unsafe { w.bits(0x55) });
        });
    }
}

/// TIMER0 TCR: counter enable.
const TCR_ENABLE: u32 = 1;

/// The bootloader's time: TIMER0 (unused by the application, powered at reset) counting
/// milliseconds; it wraps after 49 days, and every use of it compares by wrapping
/// differences.
pub struct Clock {
    timer: pac::TIMER0,
}

impl Clock {
    /// Starts TIMER0 at 1 kHz from its peripheral clock `pclk_hz` (PCLKSEL0 leaves it at
    /// CCLK / 4).
    pub fn start(timer: pac::TIMER0, pclk_hz: u32) -> Self {
        let prescale = (pclk_hz / 1_000).saturating_sub(1);
        // SAFETY: documented register values (UM10360 21.6): prescaler, then run.
        timer.pr.write(|w| unsafe { w.bits(prescale) });
        timer.tcr.write(|w| unsafe { w.bits(TCR_ENABLE) });
        Self { timer }
    }

    /// Milliseconds since [`Clock::start`] (wrapping).
    pub fn now_ms(&self) -> u32 {
        self.timer.tc.read().bits()
    }
}
