//! CANopen on CAN (CiA 301 application layer, CiA 401 behaviour of the device): the same
//! object dictionary and the same SDO state machine as the CoE side, on a CAN bus.
//!
//! A module of coe-core rather than a crate of its own: CoE is CANopen's application layer
//! carried over EtherCAT, and this layer reuses the parts that are not EtherCAT-specific:
//! the object dictionary model ([`crate::od`]), the SDO state machine
//! ([`crate::sdo_server::machine`], which this module frames for CAN in [`sdo`]), PDO mapping
//! validation and bit-exact packing ([`crate::pdo`]) and the Emergency format and queue.
//! It does not depend on the mailbox, the ESM, the SII or the ESI. Like the rest of the
//! crate it is `no_std`, allocation-free and panic-free.
//!
//! | Module | What | CiA 301 |
//! |---|---|---|
//! | [`frame`] | CAN frame (11-bit identifier, RTR, DLC), COB-ID bits, restricted identifiers, frame length on the wire | 7.2.1, 7.3.5 |
//! | [`cob`] | predefined connection set | 7.3.3 |
//! | [`nmt`] | NMT slave state machine and commands | 7.2.8.2, 7.3.2 |
//! | [`error_control`] | heartbeat producer/consumer, node guarding and life guarding | 7.2.8.3.2 |
//! | [`sdo`] | SDO server framing on 0x600/0x580 + node-ID | 7.2.4 |
//! | [`pdo`] | PDO communication parameters, transmission types, inhibit time, event timer | 7.2.2, 7.5.2.35..38 |
//! | [`sync`] | SYNC consumer with counter and cycle monitoring | 7.2.5 |
//! | [`emcy`] | EMCY producer with inhibit time | 7.2.7 |

pub mod cob;
pub mod emcy;
pub mod error_control;
pub mod frame;
pub mod master;
pub mod nmt;
pub mod node;
pub mod objects;
mod outbox;
mod param_bytes;
pub mod params;
pub mod pdo;
pub mod sdo;
pub mod sync;

pub use frame::{CanFrame, CobId};
pub use nmt::{NmtCommand, NmtState};
