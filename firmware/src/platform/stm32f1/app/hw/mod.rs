//! The hardware layer of the STM32F103 board: the only place of the STM32 image with
//! `unsafe`. The values it writes come from the host-tested board plan
//! (`firmware::platform::stm32f1`: pins, clocks, FSMC, analog timing); every module owns one
//! peripheral (or pin set) and offers a safe API to the RTIC tasks; every wait on hardware is
//! bounded.
//!
//! | module     | what                                                                  |
//! |------------|-----------------------------------------------------------------------|
//! | [`board`]  | bring-up in order: clocks, bus clocks, the pin table, the parts below |
//! | [`clocks`] | HSE 8 MHz x 9 = 72 MHz, flash wait states, the bus clock enables      |
//! | [`gpio`]   | the pin table written to GPIOx_CRL/CRH; input and output pins         |
//! | [`esc`]    | the ET1100 on FSMC bank 1 (`MemoryPdi`), its IRQ on EXTI0             |
//! | [`sync0`]  | TIM8: SYNC0's capture (CH1) and the AD5663's LDAC (CH2, forced levels) |
//! | [`dac`]    | the AD5663 on SPI2 with its SYNC pin and LDAC                         |
//! | [`adc`]    | the AD7689: TIM3 CNV + frame requests, SPI1, DMA1 into the sample ring |
//! | [`time`]   | the 64-bit time base on the cycle counter                             |
//! | [`wdt`]    | the independent watchdog                                              |

pub mod adc;
pub mod board;
pub mod clocks;
pub mod dac;
pub mod esc;
pub mod gpio;
pub mod sync0;
pub mod time;
pub mod wdt;

pub use stm32f1::stm32f103 as pac;
use stm32f1::{Reg, RegisterSpec};

/// Reads a register.
#[inline(always)]
pub fn read<R: RegisterSpec>(reg: &Reg<R>) -> R::Ux {
    // SAFETY: a register of the PAC's peripheral, read as the width it has.
    unsafe { reg.as_ptr().read_volatile() }
}

/// Writes a whole register (values from the board plan, whose fields the datasheet defines).
#[inline(always)]
pub fn write<R: RegisterSpec>(reg: &Reg<R>, value: R::Ux) {
    // SAFETY: a register of the PAC's peripheral, written as the width it has; the callers'
    // values are the reference manual's (RM0008) for this peripheral.
    unsafe { reg.as_ptr().write_volatile(value) }
}

/// Sets `bits` in a 32-bit register (read-modify-write; only at bring-up, before any task).
#[inline(always)]
pub fn set_bits<R: RegisterSpec<Ux = u32>>(reg: &Reg<R>, bits: u32) {
    write(reg, read(reg) | bits);
}

/// Polls `done` at most `polls` times; `true` if it became true.
#[inline(always)]
pub fn wait(polls: u32, mut done: impl FnMut() -> bool) -> bool {
    for _ in 0..polls {
        if done() {
            return true;
        }
    }
    done()
}
