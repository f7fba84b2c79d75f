//! The EtherCAT analog I/O firmware as a library: everything but register access, tested on
//! the host. The tree reads from the bottom up; each layer imports only from the layers
//! below it (`tests/module_graph.rs` checks it):
//!
//! | layer        | what                                                                 |
//! |--------------|----------------------------------------------------------------------|
//! | [`platform`] | the chip, the boards and the bootloader: no product in it             |
//! | [`stacks`]   | the fieldbus stacks: the EtherCAT slave application, the CANopen node |
//! | [`io`]       | what the products do with the board's converters (the analog I/O)    |
//! | [`products`] | each product: identity, objects, which stacks, which board            |
//!
//! The images (the application of a product and the bootloader) are the crate's binaries;
//! their hardware layer (`platform/hw`, the only `unsafe`) is not part of the library.
#![no_std]
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

#[cfg(test)]
extern crate std;

#[cfg(any(test, feature = "fake-esc"))]
pub mod fake_esc;
pub mod io;
pub mod platform;
pub mod products;
pub mod stacks;
