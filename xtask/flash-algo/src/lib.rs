//! Flash algorithm for the LPC1754 on top of the LPC17xx IAP ROM (UM10360 chapter 32), as
//! probe-rs runs it: `Init`, `UnInit`, `EraseSector`, `EraseChip`, `ProgramPage`, `Verify`.
//!
//! This library is the whole logic, tested on the host against a mock of the IAP entry
//! point: the sector table ([`sector`]), the IAP commands with their parameter words and
//! status codes ([`iap`]), the Code Read Protection guard ([`crp`]) and the entry points'
//! sequences ([`algo`]). The binary (`src/main.rs`, thumbv7m-none-eabi only) adds what needs
//! the chip: the call into the ROM at 0x1FFF_1FF1, the clock and memory-map registers, and
//! the `extern "C"` entry points.
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
pub mod iap;
pub mod sector;

#[cfg(test)]
mod mock;

pub use algo::{Error, ErrorCode, FlashAlgo, Staging};
pub use iap::{Command, IapEntry, Status};
