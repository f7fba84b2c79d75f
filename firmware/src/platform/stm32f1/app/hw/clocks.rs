//! The clock tree (`firmware::platform::stm32f1::clocks`): HSE 8 MHz, PLL x9 = 72 MHz
//! SYSCLK/HCLK/APB2, APB1 36 MHz, flash 2 wait states with prefetch; and the clocks of the
//! peripherals the board uses.

use super::{pac, read, set_bits, wait, write};
use firmware::platform::stm32f1::clocks::CLOCKS;

/// Polls of a ready flag: HSE start-up is at most a few ms (about 2 us per poll at the
/// 8 MHz HSI the loop runs on before the switch).
const READY_POLLS: u32 = 50_000;

/// RCC_CR bits.
const HSEON: u32 = 1 << 16;
const HSERDY: u32 = 1 << 17;
const PLLON: u32 = 1 << 24;
const PLLRDY: u32 = 1 << 25;
/// RCC_CFGR SWS (system clock switch status): PLL.
const SWS_MASK: u32 = 0b11 << 2;
const SWS_PLL: u32 = 0b10 << 2;

/// RCC_AHBENR: DMA1, FSMC.
const AHBENR: u32 = 1 << 0 | 1 << 8;
/// RCC_APB2ENR: AFIO, GPIOA..E, SPI1, TIM8.
const APB2ENR: u32 = 1 << 0 | 0b1_1111 << 2 | 1 << 12 | 1 << 13;
/// RCC_APB1ENR: TIM3, SPI2.
const APB1ENR: u32 = 1 << 1 | 1 << 14;

/// Why the 72 MHz clock did not start (the core then runs on the 8 MHz HSI).
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ClockError {
    /// The crystal oscillator did not start.
    Hse,
    /// The PLL did not lock.
    Pll,
    /// The switch to the PLL did not happen.
    Switch,
}

/// Starts HSE and the PLL and switches SYSCLK to it; the flash wait states first.
pub fn init(
    rcc: &pac::rcc::RegisterBlock,
    flash: &pac::flash::RegisterBlock,
) -> Result<(), ClockError> {
    set_bits(rcc.cr(), HSEON);
    if !wait(READY_POLLS, || read(rcc.cr()) & HSERDY != 0) {
        return Err(ClockError::Hse);
    }
    write(flash.acr(), CLOCKS.flash_acr());
    write(rcc.cfgr(), CLOCKS.cfgr_before_switch());
    set_bits(rcc.cr(), PLLON);
    if !wait(READY_POLLS, || read(rcc.cr()) & PLLRDY != 0) {
        return Err(ClockError::Pll);
    }
    write(rcc.cfgr(), CLOCKS.cfgr());
    if !wait(READY_POLLS, || read(rcc.cfgr()) & SWS_MASK == SWS_PLL) {
        return Err(ClockError::Switch);
    }
    Ok(())
}

/// Clocks the peripherals the board uses.
pub fn enable_peripherals(rcc: &pac::rcc::RegisterBlock) {
    set_bits(rcc.ahbenr(), AHBENR);
    set_bits(rcc.apb2enr(), APB2ENR);
    set_bits(rcc.apb1enr(), APB1ENR);
}
