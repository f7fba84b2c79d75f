//! The platform: what every product on the LPC1754 boards stands on, and nothing that
//! belongs to one product.
//!
//! | module        | what                                                                  |
//! |---------------|-----------------------------------------------------------------------|
//! | [`chip`]      | the LPC17xx as data: register formats and plans (DMA lists, CAN timing) |
//! | [`board`]     | the boards: converters, front end, the ESC's wiring, assembly options   |
//! | [`boot`]      | the bootloader's logic: flash map, update file, install, staging        |
//! | [`adc_scan`]  | the board's AD7689 scan: CFG word and frame pipeline                    |
//! | [`div`]       | 64-by-32-bit division with the Cortex-M3's `UDIV`                      |
//! | [`timebase`]  | a 64-bit time base from a 32-bit timer                                 |
//! | [`stm32f1`]   | the second board (STM32F103VC + ET1100 on the FSMC) as data            |
//!
//! The binaries add the hardware layer (`platform/hw`, register access, the only `unsafe`)
//! and the bootloader program (`platform/bootloader`).

pub mod adc_scan;
pub mod board;
pub mod boot;
pub mod chip;
pub mod div;
pub mod stm32f1;
pub mod timebase;
