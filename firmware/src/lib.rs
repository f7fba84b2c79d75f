//! The slave application of the analog I/O module, independent of the MCU.
#![no_std]
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

#[cfg(test)]
extern crate std;

pub mod app;
pub mod device;
#[cfg(any(test, feature = "fake-esc"))]
pub mod fake_esc;
pub mod od;
