//! Flash algorithm for the LPC1754 on top of the LPC17xx IAP ROM (UM10360 chapter 32), as
//! probe-rs runs it: `Init`, `UnInit`, `EraseSector`, `EraseChip`, `ProgramPage`, `Verify`.
//!
//! This library is the whole logic, tested on the host against the model of the flash and
//! the IAP ROM of the `lpc17xx-iap` crate, which also holds the sector table and the IAP
//! commands with their parameter words and status codes (re-exported as [`sector`] and
//! [`iap`]): the Code Read Protection guard ([`crp`]) and the entry points' sequences
//! ([`algo`]). The binary (`src/main.rs`, thumbv7m-none-eabi only) adds what needs the chip:
//! the clock and memory-map registers and the `extern "C"` entry points; the call into the
//! ROM is the crate's `rom::Rom`.
//!
//! `no_std`, no allocation, no `unsafe`, no panic on any input.
#![no_std]
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

#[cfg(test)]
extern crate std;

pub mod algo;
pub mod crp;

pub use lpc17xx_iap::{iap, sector};

pub use algo::{Error, ErrorCode, FlashAlgo, Staging};
pub use iap::{Command, IapEntry, Status};
