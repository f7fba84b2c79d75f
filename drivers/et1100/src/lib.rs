//! Driver for the Beckhoff ET1100 EtherCAT slave controller (ESC), seen from the
//! application controller through its process data interface (PDI).
//!
//! - [`SpiPdi`]: the SPI slave PDI on any [`embedded_hal::spi::SpiDevice`] (SPI mode 3;
//!   2-byte addressing below 0x2000, 3-byte addressing above; reads with the wait-state
//!   command and 0xFF read termination). One `SpiDevice::transaction` per access.
//! - [`MemoryPdi`]: an 8/16-bit memory-mapped parallel PDI over a user-supplied
//!   [`MemoryBus`] (e.g. an STM32 FSMC bank).
//! - [`Et1100`]: raw accesses plus typed helpers for the AL state machine registers,
//!   SyncManagers and mailboxes, process data, watchdog, distributed clocks and PDI EEPROM
//!   access.
//!
//! Every access returns the AL event request bits ([`AlEvents`], 0x0220..) that belong to it;
//! the driver keeps no state besides the bus. Register reads with a side effect in the ESC
//! (AL control, SM activate, watchdog status, SYNC status, mailbox buffers) say so.
//!
//! `#![no_std]`, no allocation, no `unsafe`, no panics. Every wait is bounded by the caller.
//!
//! References: Beckhoff "EtherCAT Slave Controller" datasheet, Section I (technology) and
//! Section II (register description), <https://www.beckhoff.com/>; ET1100 hardware description
//! (Section III).
//!
//! # Features
//!
//! - `defmt`: derives `defmt::Format` for the public types.
//!
//! # Dependencies
//!
//! `coe-core` (no_std, no allocation, no ESC chip in it) for what the ESC only stores on
//! behalf of the EtherCAT application layer: the ESM state of AL control/status
//! ([`AlState`]) and the SyncManager control byte fields that the SII and ESI describe too
//! (`coe_core::device::sm_control`). The ESC's own register map, event bits and register
//! block layouts are defined here.
//!
//! # Minimum supported Rust version
//!
//! 1.85.
//!
//! # Example
//!
//! Read the AL control register after the master wrote it, then report the new state.
//!
//! ```
//! use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
//! use et1100::{AlState, AlStatus, Et1100, SpiPdi};
//!
//! let expectations = [
//!     // Read 2 bytes at 0x0120: address 09 03, wait byte FF, data 00 FF.
//!     // MISO during the address phase: AL event bits 0x0220/0x0221 (bit 0 = AL control).
//!     T::transaction_start(),
//!     T::transfer(vec![0x09, 0x03, 0xFF], vec![0x01, 0x00, 0xFF]),
//!     T::transfer_in_place(vec![0x00, 0xFF], vec![0x02, 0x00]),
//!     T::transaction_end(),
//!     // Write the AL status code (0x0134), then the AL status (0x0130).
//!     T::transaction_start(),
//!     T::transfer(vec![0x09, 0xA4], vec![0x00, 0x00]),
//!     T::write_vec(vec![0x00, 0x00]),
//!     T::transaction_end(),
//!     T::transaction_start(),
//!     T::transfer(vec![0x09, 0x84], vec![0x00, 0x00]),
//!     T::write_vec(vec![0x02, 0x00]),
//!     T::transaction_end(),
//! ];
//! let spi = Mock::new(&expectations);
//! let mut esc = Et1100::new(SpiPdi::new(spi));
//!
//! let control = esc.read_al_control()?;
//! assert_eq!(control.state(), Some(AlState::PreOp));
//! esc.write_al_status(AlStatus::new(AlState::PreOp, false, false), 0x0000)?;
//!
//! let mut spi = esc.destroy().destroy();
//! spi.done();
//! # Ok::<(), et1100::Error<embedded_hal::spi::ErrorKind>>(())
//! ```
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

mod al;
mod dc;
mod device;
mod eeprom;
mod error;
mod memory;
mod pdi;
mod register;
mod spi;
mod sync_manager;
pub mod unconfirmed;
mod watchdog;

pub use al::{AlControl, AlEvents, AlStatus};
/// The ESM state of AL control and AL status, defined by the application-layer core.
pub use coe_core::esm::AlState;
pub use dc::SyncActivation;
pub use device::{DlStatus, EscInfo, Et1100};
pub use eeprom::{EepromChunk, EepromStatus};
pub use error::Error;
pub use memory::{BusWidth, MemoryBus, MemoryPdi};
pub use pdi::{Pdi, PdiResult};
pub use register::Register;
pub use spi::SpiPdi;
pub use sync_manager::{SmDirection, SmMode, SyncManager};
pub use watchdog::{WatchdogCounters, WatchdogStatus};

/// The README's example, compiled as a doctest so that it cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctest;
