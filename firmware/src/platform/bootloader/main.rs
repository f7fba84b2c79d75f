//! The bootloader of an LPC1754 board (a stub on the host; `cargo xtask build` builds it for
//! the board of each product, `firmware::products::selected::BOARD`): the
//! first 12 KB of the flash. It owns the vector table the boot ROM checks (checksum at 0x1C)
//! and the CRP word at 0x2FC; nothing ever writes its sectors but a debug probe.
//!
//! At reset ([`firmware::platform::boot::install::startup`], host-tested with power cuts at every
//! step): take the application's boot request from RAM, run the CPU at 100 MHz, install a
//! staged update if one is pending (any product's the board accepts,
//! `firmware::platform::boot::header`), then start the application (VTOR, stack pointer, reset
//! handler of the image at 0x3100) if it is valid and no boot request came. Otherwise it
//! stays: the EtherCAT slave of the bootloader serves INIT and BOOT, and in BOOT writes an
//! update file received over FoE into the staging area; BOOT -> INIT after a good file resets
//! into the new application.
//!
//! No interrupts: everything is polled, and between two rounds the CPU sleeps (WFI) until the
//! ESC raises its IRQ line or the next millisecond ([`cpu::Idle`]). A panic resets the CPU
//! (the libraries do not panic; should one, the next reset is the safe way back).
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod aeabi_mem;
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
    use firmware::platform::boot::install::startup;
    use firmware::platform::boot::layout::{APP_VECTORS, BOOTSTRAP_MAILBOX, MAILBOX_CONTROL};
    use firmware::products::selected::BOARD;
    use firmware::stacks::ethercat::boot_slave::{BootSlave, Bootstrap};
    use lpc17xx_iap::rom::Rom;
    use lpc17xx_iap::Iap;
    use lpc17xx_pac as pac;

    #[entry]
    fn main() -> ! {
        let requested = hw::boot_request::take();
        let Some(dp) = pac::Peripherals::take() else {
            cpu::reset()
        };
        cpu::slow_watchdog(&dp.WDT);
        // 100 MHz for the image checks; the ROM is told the clock actually reached.
        let _ = hw::clocks::init(&dp.SYSCON);
        let cclk_hz = hw::clocks::current(&dp.SYSCON).cclk_hz;
        let mut iap = Iap::new(Rom, cclk_hz / 1000);
        let reset = startup(&mut iap, &BOARD, requested);
        if reset.stay.is_none() {
            cpu::start_application(APP_VECTORS);
        }

        // The bootloader stays: the EtherCAT slave of INIT and BOOT, polled.
        let clock = cpu::Clock::start(dp.TIMER0, cclk_hz / 4);
        let mut board = hw::board::init_bootloader(&dp.PINCONNECT, dp.SPI);
        let bootstrap = Bootstrap {
            out: BOOTSTRAP_MAILBOX.0,
            inp: BOOTSTRAP_MAILBOX.1,
            out_control: MAILBOX_CONTROL.0,
            in_control: MAILBOX_CONTROL.1,
        };
        let mut slave = BootSlave::new(iap, BOARD, bootstrap, reset.application.is_ok());
        let mut idle = cpu::Idle::new(dp.GPIOINT, board.esc_irq, &clock);
        let mut started = false;
        loop {
            cpu::feed_watchdog(&dp.WDT);
            // The ESC's PDI works once it has loaded its EEPROM; a failed access is retried
            // in the next round.
            let outcome = if started {
                slave.poll(&mut board.esc, clock.now_ms())
            } else if board.esc_eeprom_loaded.is_high() {
                let outcome = slave.start(&mut board.esc);
                started = outcome.is_ok();
                outcome
            } else {
                continue;
            };
            if outcome.is_ok_and(|o| o.reset) {
                cpu::reset();
            }
            idle.wait(&clock);
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
