#![doc = include_str!("../README.md")]
#![no_std]
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

#[cfg(any(test, feature = "std"))]
extern crate std;

#[macro_use]
mod open_enum;

pub mod abort;
pub mod al_status;
pub mod canopen;
pub mod device;
pub mod eds;
pub mod emergency_queue;
pub mod error_history;
pub mod esi;
pub mod esm;
pub mod foe;
pub mod mailbox;
pub mod od;
pub mod pdo;
pub mod sdo_server;
pub mod sii;
pub mod wire;

pub use abort::SdoAbortCode;
pub use al_status::AlStatusCode;
pub use esm::AlState;
