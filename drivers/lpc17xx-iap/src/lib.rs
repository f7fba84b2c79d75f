//! LPC17xx in-application programming (UM10360 chapter 32): what a flash algorithm, a
//! bootloader or a simulator needs to erase and program the on-chip flash through the ROM.
//!
//! - [`iap`]: the command words, status codes and [`Iap`], the commands on any
//!   [`IapEntry`] (the ROM, or a model).
//! - [`sector`]: the LPC1754 sector table.
//! - `rom` (Arm bare-metal targets only): [`IapEntry`] of the chip, the call into the ROM at
//!   0x1FFF_1FF1 with interrupts masked: the only `unsafe` code of this crate.
//! - `model` (feature `model`, std): the flash and the ROM on the host, with their rules,
//!   a command log, misuse reports and power cuts at any erase or program step.
//!
//! `no_std`, no allocation (outside the model), no panic on any input.
#![no_std]
#![deny(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

#[cfg(any(test, feature = "model"))]
extern crate std;

pub mod iap;
pub mod sector;

#[cfg(any(test, feature = "model"))]
pub mod model;

#[cfg(all(target_arch = "arm", target_os = "none"))]
pub mod rom;

pub use iap::{BlankCheck, Command, Iap, IapEntry, IapError, Status};

/// The README's example, compiled as a doctest so that it cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctest;
