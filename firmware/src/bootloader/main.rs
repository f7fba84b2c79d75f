//! The bootloader of the LPC1754 (a stub on the host; built by `cargo xtask build`): the
//! first 8 KB of the flash. It owns the vector table the boot ROM checks (checksum at 0x1C)
//! and the CRP word at 0x2FC; nothing ever writes its sectors but a debug probe.
//!
//! At reset ([`firmware::boot::install::startup`], host-tested with power cuts at every
//! step): take the application's boot request from RAM, run the CPU at 100 MHz, install a
//! staged update if one is pending, then start the application (VTOR, stack pointer, reset
//! handler of the image at 0x2100) if it is valid and no boot request came. Otherwise it
//! stays: the EtherCAT slave of the bootloader serves INIT and BOOT, and in BOOT writes an
//! update file received over FoE into the staging area; BOOT -> INIT after a good file resets
//! into the new application.
//!
//! No interrupts: everything is polled. A panic resets the CPU (the libraries do not panic;
//! should one, the next reset is the safe way back).
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod cpu;
#[cfg(target_os = "none")]
mod crp;

/// The board's hardware layer, shared with the application (the bootloader uses the clocks,
/// the pin map and the ESC on the legacy SPI of it).
#[cfg(target_os = "none")]
#[path = "../hw/mod.rs"]
#[allow(dead_code, unused_imports)]
mod hw;

#[cfg(target_os = "none")]
mod chip {
    use crate::{cpu, hw};
    use cortex_m_rt::entry;
    use firmware::boot::install::startup;
    use firmware::boot::layout::APP_VECTORS;
    use firmware::product::identity::UPDATE_TARGET;
    use lpc17xx_iap::rom::Rom;
    use lpc17xx_iap::Iap;
    use lpc17xx_pac as pac;

    #[entry]
    fn main() -> ! {
        let requested = cpu::take_boot_request();
        let Some(dp) = pac::Peripherals::take() else {
            cpu::reset()
        };
        cpu::slow_watchdog(&dp.WDT);
        // 100 MHz for the image checks; the ROM is told the clock actually reached.
        let _ = hw::clocks::init(&dp.SYSCON);
        let cclk_khz = hw::clocks::current(&dp.SYSCON).cclk_hz / 1000;
        let mut iap = Iap::new(Rom, cclk_khz);
        let reset = startup(&mut iap, &UPDATE_TARGET, requested);
        if reset.stay.is_none() {
            cpu::start_application(APP_VECTORS);
        }
        loop {
            cpu::feed_watchdog(&dp.WDT);
            cortex_m::asm::wfi();
        }
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        cpu::reset()
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("the bootloader runs on the LPC1754: build it with `cargo xtask build`");
}
