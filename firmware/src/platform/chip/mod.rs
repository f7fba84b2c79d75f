//! The LPC17xx as data: register formats and the plans the firmware writes into the
//! peripherals, host-tested and free of register access (the firmware binary's hardware
//! layer, `hw`, performs the writes). The application (`crate::stacks::ethercat`) stays MCU-independent:
//! nothing there knows an LPC17xx register.

pub mod adc_dma;
pub mod can;
pub mod gpdma;
