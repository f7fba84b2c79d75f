//! The hardware layer of the LPC1754 board: the only place (besides the flash algorithm) with
//! `unsafe`. Every module owns one peripheral (or one pin set) and offers a safe API to the
//! RTIC tasks in `main.rs`; every wait on hardware is bounded and returns an error.
//!
//! | module       | what                                                                  |
//! |--------------|-----------------------------------------------------------------------|
//! | [`board`]    | THE pin map (hardware-facts 10.A) with its LQFP80 check, PINSEL setup |
//! | [`boot_request`] | the RAM word that carries a BOOT request into the bootloader       |
//! | [`clocks`]   | 12 MHz crystal -> PLL0 -> 100 MHz CCLK, flash wait states, PCLKs      |
//! | [`gpio`]     | GPIO output/input pins (chip selects, LDAC)                           |
//! | [`spi`]      | legacy SPI (ET1100 PDI) as `SpiBus`, the ESC's `SpiDevice`            |
//! | [`ssp`]      | SSP0 (AD5663) and SSP1 (AD7689) as `SpiBus` with FIFO use             |
//! | [`timers`]   | Timer1 SYNC0 capture (timestamp), Timer2 CNV + ADC frames (`adc-irq`) |
//! | [`adc_dma`]  | Timer2 CNV + SSP1 frames + ring moved by the GPDMA (default)          |
//! | [`adc`]      | the ADC path chosen at build time (GPDMA or `adc-irq`)                |
//! | [`gpio_irq`] | ESC IRQ on P0.22 (falling edge, EINT3 vector)                         |
//! | [`wdt`]      | the MCU watchdog                                                      |
//! | [`can`]      | CAN1 (P0.0/P0.1) for the CANopen node: bit timing, bypass filter, 3 TX buffers |
//! | [`esc`]      | the ET1100: the `et1100` driver on the legacy-SPI device              |
//! | [`dac`]      | the AD5663 (`ad5663` driver via `firmware::io::analog::dac`) and its LDAC pin |
//! | [`ldac_grid`] | output oversampling: LDAC from PWM1.4, the update interrupts on Timer1 MR1 |
//! | [`cs_device`] | bus + GPIO chip select as `SpiDevice` (ET1100, AD5663)              |
//! | [`mem`]      | buffers in the AHB SRAM (`.ahbsram`)                                  |

pub mod adc;
#[cfg(not(feature = "adc-irq"))]
pub mod adc_dma;
pub mod board;
pub mod boot_request;
#[cfg_attr(not(feature = "canopen-node"), allow(dead_code))]
pub mod can;
pub mod clocks;
pub mod cs_device;
pub mod dac;
pub mod delay;
pub mod esc;
pub mod gpio;
pub mod gpio_irq;
#[cfg(feature = "analog-io")]
pub mod ldac_grid;
#[cfg(feature = "adc-irq")]
pub mod mem;
pub mod spi;
pub mod ssp;
pub mod timers;
pub mod wdt;

/// The CPU clock after [`clocks::init`] (Hz); PCLK of every peripheral used is CCLK/1.
pub const CCLK_HZ: u32 = clocks::CCLK_HZ;

/// Peripheral clock of SPI, SSP0/1, Timer1/2, CAN1 (PCLKSEL = 01: CCLK/1).
pub const PCLK_HZ: u32 = clocks::CCLK_HZ;

/// `r`, its address hidden from the optimiser in a register (no memory touched, no
/// instruction emitted): the fields behind it are then reached by offsets from that
/// register, not each by an address of its own (two instructions apiece), as the SYNC0
/// task's way to the LDAC edge wants.
#[inline(always)]
pub fn in_register<T>(r: &'static T) -> &'static T {
    let mut p: *const T = r;
    // SAFETY: the empty template leaves the register, and so the pointer, unchanged.
    // It reads and writes no memory: the pointer is passed only to be hidden (`nomem`).
    #[allow(clippy::pointers_in_nomem_asm_block)]
    unsafe {
        core::arch::asm!("/* {0} */", inout(reg) p, options(pure, nomem, nostack, preserves_flags));
    }
    // SAFETY: `p` is still `r`, a valid `&'static T`.
    unsafe { &*p }
}
