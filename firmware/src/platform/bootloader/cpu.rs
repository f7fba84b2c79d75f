//! What the bootloader does to the Cortex-M3 and the LPC1754 itself: with its `memcpy` and
//! `memclr` (`aeabi_mem`), the only `unsafe` code of the bootloader besides the shared
//! hardware layer and the IAP ROM call.

use crate::hw::gpio::InPin;
use cortex_m::peripheral::NVIC;
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

/// TIMER0 MCR: interrupt flag on MR0.
const MCR_MR0I: u32 = 1;
/// TIMER0 IR: the MR0 flag (write 1 to clear).
const IR_MR0: u32 = 1;
/// P0.22 (SPI_IRQ) in the port-0 GPIO interrupt registers.
const ESC_IRQ_BIT: u32 = 1 << 22;
/// NVIC bits of TIMER0 (IRQ 1) and EINT3 (IRQ 21, the GPIO interrupts), in ISER0/ICPR0.
const WAKE_IRQS: u32 = 1 << 1 | 1 << 21;

/// The bootloader's idle wait (WFI): until the ESC asserts its IRQ line (the falling edge of
/// P0.22, EINT3) or TIMER0 counts on (MR0: FoE timeouts, the watchdog), the only things the
/// polled slave waits for. Both interrupts are enabled in the NVIC with PRIMASK set: a
/// pending one ends WFI without being taken (ARMv7-M B1.5.19), so the bootloader still has
/// no interrupt handler, and a reset (its only way out) clears them.
pub struct Idle {
    int: pac::GPIOINT,
    irq: InPin,
}

impl Idle {
    /// Masks interrupts for good and enables the two wake-ups.
    pub fn new(int: pac::GPIOINT, irq: InPin, clock: &Clock) -> Self {
        cortex_m::interrupt::disable();
        // SAFETY: documented register values (UM10360 9.5.6.3, 21.6.8); PRIMASK is set, so
        // the NVIC's enable bits run no handler.
        unsafe {
            int.enf0.write(|w| w.bits(ESC_IRQ_BIT));
            clock.timer.mcr.write(|w| w.bits(MCR_MR0I));
            (*NVIC::PTR).iser[0].write(WAKE_IRQS);
        }
        Self { int, irq }
    }

    /// Sleeps until the ESC asserts its IRQ line or the millisecond after next; returns at
    /// once while the line is asserted (events are waiting).
    pub fn wait(&mut self, clock: &Clock) {
        // SAFETY: write-1-to-clear flags and a match value (UM10360 9.5.6.11, 21.6.1, 21.6.9):
        // two ticks on, as one may pass before it lands.
        unsafe {
            self.int.clr0.write(|w| w.bits(ESC_IRQ_BIT));
            clock.timer.ir.write(|w| w.bits(IR_MR0));
            clock.timer.mr[0].write(|w| w.bits(clock.now_ms().wrapping_add(2)));
            (*NVIC::PTR).icpr[0].write(WAKE_IRQS);
        }
        if self.irq.is_high() {
            cortex_m::asm::wfi();
        }
    }
}
