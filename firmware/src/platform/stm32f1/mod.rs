//! The second board, as data: an STM32F103VC (LQFP100, Cortex-M3 at 72 MHz) with the ET1100
//! on the FSMC's 16-bit bank, address and data multiplexed and the address held by an
//! external latch (seed 004), and the thesis board's analog front end (AD5663 on SPI2,
//! AD7689 on SPI1 sampled by a timer and DMA). Sources: `shared/research/stm32-fsmc.md`, RM0008, the
//! STM32F103xC/D/E datasheet, ET1100 Section III.
//!
//! Host-tested and free of register access: the RTIC image (`app/`, the binary
//! `application-stm32f103` of the product `analog-io-stm32`, on the stm32f1 PAC) writes
//! these values.
//!
//! | module       | what                                                                |
//! |--------------|---------------------------------------------------------------------|
//! | [`pins`]     | the one pin table: every pin's signal and configuration, EXTI, DMA, IRQs |
//! | [`clocks`]   | the clock tree (HSE 8 MHz, PLL x9) and the flash wait states        |
//! | [`fsmc`]     | bank 1's BCR1/BTR1 from the ET1100's bus timing and HCLK            |
//! | [`esc_pdi`]  | the ESC's PDI configuration (SII words 0/1) for the µC PDI         |
//! | [`analog`]   | the AD7689's TIM3 + DMA timing, the converters' SPI and DMA registers |
//! | [`time`]     | the 64-bit time base from the cycle counter, the SYNC0 capture on it |

pub mod analog;
pub mod clocks;
pub mod esc_pdi;
pub mod fsmc;
pub mod pins;
pub mod time;
