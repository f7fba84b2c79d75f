//! An instruction-level co-simulator of the LPC1754 that runs the unmodified release image
//! of the firmware on the virtual board, so real EtherCAT masters drive the binary a user
//! flashes (issue 12).
//!
//! **Licence: GPL-2.0-only**, because it links the unicorn engine (GPL-2.0). It is a
//! test-only crate: nothing else in the workspace depends on it; `cargo xtask sim --image`
//! and `cargo xtask bench` run its binary.
//!
//! | module       | what                                                                  |
//! |--------------|-----------------------------------------------------------------------|
//! | [`image`]    | the programs as the flash holds them; the boot ROM's checksum and CRP checks |
//! | [`iap`]      | the IAP ROM at 0x1FFF_1FF1 on lpc17xx-iap's flash model               |
//! | [`cpu`]      | the Cortex-M3 on unicorn with the ARMv7-M exception model             |
//! | [`nvic`]     | NVIC, SCB, SysTick: pending, active, priorities, masks                |
//! | [`periph`]   | SYSCON, PINSEL, GPIO, SPI, SSP, timers, GPDMA, WDT from UM10360        |
//! | [`ahb_sram`] | the GPDMA's SRAM, watched for samples lost before the CPU read them    |
//! | [`chip`]     | which microcontroller: memory map, NVIC, time model                   |
//! | [`stm32`]    | the STM32F103's peripherals after RM0008 (the second board)            |
//! | [`machine`]  | time, events, NVIC, profile shared; each chip's bus and pin wiring     |
//! | [`rtt`]      | the firmware's defmt log over RTT                                      |
//! | [`code`]     | functions and inlined functions per instruction (DWARF), decoded blocks |
//! | [`profile`]  | cycles and stack per exception, instructions per function             |
//! | [`thumb`]    | Thumb instruction length and how each moves SP                        |
//! | [`bench`]    | the image's figures for `cargo xtask bench` (profile run, cycle sweep) |
//! | [`boards`]   | both boards' images swept the same way, side by side                   |
//! | [`cosim`]    | all of it as the virtual board's CPU ([`cosim::Cosim`])                |
//! | [`peer`]     | other stacks on the same board (SOES): image, SII, figures, conformance |
//! | [`traffic`]  | a real master's traffic in the DC runs: mailbox in OP, jitter, moving inputs |

pub mod ahb_sram;
pub mod bench;
pub mod boards;
pub mod chip;
pub mod code;
pub mod cosim;
pub mod cpu;
pub mod iap;
pub mod image;
pub mod machine;
pub mod nvic;
pub mod oversampling;
pub mod peer;
pub mod periph;
pub mod profile;
pub mod rtt;
pub mod run;
pub mod stm32;
pub mod thumb;
pub mod traffic;
