//! What the bootloader does to the Cortex-M3 and the LPC1754 itself: the only `unsafe` code
//! of the bootloader besides the shared hardware layer and the IAP ROM call.

use firmware::boot::layout::BOOT_REQUEST_ADDR;
use firmware::boot::request::{is_request, CLEARED};
use lpc17xx_pac as pac;

/// Reads the boot request word and clears it (a request counts for one reset).
pub fn take_boot_request() -> bool {
    let at = BOOT_REQUEST_ADDR as *mut [u32; 2];
    // SAFETY: two words of the local SRAM that both linker scripts keep outside their RAM
    // region (firmware::boot::layout); nothing else refers to them.
    let words = unsafe { core::ptr::read_volatile(at) };
    // SAFETY: as above.
    unsafe { core::ptr::write_volatile(at, CLEARED) };
    is_request(words)
}

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
