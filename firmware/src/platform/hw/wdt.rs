//! The MCU watchdog (UM10360 chapter 28): clocked from the 4 MHz IRC (WDCLKSEL = 0, fixed
//! /4 prescaler -> 1 MHz), resets the chip when not fed within [`TIMEOUT_US`]. Fed by the
//! lowest-priority task, so a task that locks up the CPU (or an interrupt storm) resets the
//! module; the ET1100's own SM watchdog then sets the outputs safe on the master's side.

use lpc17xx_pac as pac;

/// Watchdog period in microseconds (1 MHz watchdog tick).
pub const TIMEOUT_US: u32 = 100_000;
/// The feeder's period; well inside the timeout.
pub const FEED_PERIOD_MS: u32 = 10;

const WDMOD_WDEN: u32 = 1 << 0;
const WDMOD_WDRESET: u32 = 1 << 1;
const WDMOD_WDTOF: u32 = 1 << 2;

/// The watchdog (owner: the feeder task).
pub struct Watchdog {
    wdt: pac::WDT,
}

impl Watchdog {
    /// Configured, not yet running.
    pub fn new(wdt: pac::WDT) -> Self {
        // SAFETY: documented register values: IRC clock, timeout, enable + reset.
        wdt.clksel.write(|w| unsafe { w.bits(0) });
        wdt.tc.write(|w| unsafe { w.bits(TIMEOUT_US) });
        Self { wdt }
    }

    /// Whether the last reset came from the watchdog (WDTOF).
    pub fn caused_reset(&self) -> bool {
        self.wdt.mod_.read().bits() & WDMOD_WDTOF != 0
    }

    /// Starts it (cannot be stopped again until reset) with a first feed.
    pub fn start(&mut self) {
        // SAFETY: WDEN | WDRESET; clears WDTOF.
        self.wdt
            .mod_
            .write(|w| unsafe { w.bits(WDMOD_WDEN | WDMOD_WDRESET) });
        self.feed();
    }

    /// The feed sequence 0xAA, 0x55, uninterrupted (another WDT access in between would
    /// reset the chip).
    pub fn feed(&mut self) {
        cortex_m::interrupt::free(|_| {
            // SAFETY: the feed register accepts 0xAA then 0x55.
            self.wdt.feed.write(|w| unsafe { w.bits(0xAA) });
            self.wdt.feed.write(|w| unsafe { w.bits(0x55) });
        });
    }
}
