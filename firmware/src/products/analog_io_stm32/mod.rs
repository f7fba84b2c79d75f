//! `analog-io-stm32`, the analog module on the second board (issue 30, seed 004): the same
//! 8 analog inputs and 2 analog outputs on EtherCAT with CoE, on an STM32F103VC with the
//! ET1100 on the FSMC ([`crate::platform::stm32f1`]).
//!
//! - board: [`crate::platform::board::STM32_FSMC`];
//! - stacks: the EtherCAT slave application around the analog I/O, as `analog-io`, with
//!   `analog-io`'s object dictionary objects, SyncManager layout and figures;
//! - **no firmware update**: the board has no bootloader (the STM32's flash controller is
//!   not driven yet), so the mailbox offers CoE only, the ESI and the SII have no FoE and no
//!   bootstrap mailbox, and a master's request for BOOT is refused;
//! - no input oversampling (its objects and code are `analog-io`'s alone);
//! - image: the application alone from 0x0800_0000 (`memory-stm32f103.x`).
//!
//! | module       | what                                                              |
//! |--------------|-------------------------------------------------------------------|
//! | [`identity`] | vendor ID, product code, revision, names                          |
//! | [`od`]       | the object dictionary (`analog-io`'s analog objects, this identity) |
//! | [`device`]   | the device description (SII, ESI): µC PDI, CoE only               |
//!
//! The figures of 0x1C32/0x1C33 (minimum cycle) are `analog-io`'s, measured on the
//! LPC1754's co-simulated image; this board's are not measured yet (no STM32 co-simulator).
//!
//! [`identity`]: crate::products::analog_io_stm32::identity
//! [`od`]: crate::products::analog_io_stm32::od
//! [`device`]: crate::products::analog_io_stm32::device

pub mod device;
pub mod identity;
pub mod od;

#[cfg(test)]
mod tests;

use super::{analog_io, Budget, ImageBuild, Product};
use crate::io::analog::AnalogIo;
use crate::stacks::ethercat::AppConfig;
use coe_core::device::oversampling::Oversampling;

pub use identity::BOARD;

/// The product for the tools.
pub static PRODUCT: Product = Product {
    name: "analog-io-stm32",
    summary: "8 AI + 2 AO on EtherCAT (CoE, no FoE), the STM32F103 + ET1100 FSMC board",
    board: &BOARD,
    update: None,
    device: &device::DEVICE,
    oversampling: &Oversampling::NONE,
    can: None,
    // The STM32F103VC has 256 KB of flash and 48 KB of SRAM; the budget keeps the image
    // near the LPC1754 products' so that both boards stay comparable.
    budget: Budget {
        flash: 48 * 1024,
        ram: 8 * 1024,
    },
    build: ImageBuild {
        opt_level: "s",
        machine_outliner: false,
    },
};

/// `analog-io`'s configuration without the bootstrap mailbox: no bootloader to enter.
pub const CONFIG: AppConfig = AppConfig {
    bootstrap: None,
    ..analog_io::CONFIG
};

/// The application the slave application serves: the analog I/O on this dictionary.
pub type Application = analog_io::Application;

/// The application at power-up.
pub fn application() -> Application {
    AnalogIo::new(&od::OD, analog_io::process_data())
}
