//! The analog I/O module, independent of the MCU: the product (what the module is and
//! offers, [`product`]) and the slave application built for it ([`app`]).
#![no_std]
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

#[cfg(test)]
extern crate std;

pub mod app;
pub mod boot;
pub mod chip;
#[cfg(any(test, feature = "fake-esc"))]
pub mod fake_esc;
pub mod product;
