//! `analog-io-can`: `analog-io` plus a CANopen device (CiA 301/401) on CAN1, for the thesis
//! board with a CAN transceiver. The same dictionary on both fieldbuses; which one drives
//! the outputs is an object of its own ([`can`]).
//!
//! - board: [`crate::platform::board::THESIS_CAN`];
//! - stacks: the EtherCAT slave application ([`crate::stacks::ethercat`]) and the CANopen
//!   node ([`crate::stacks::canopen`]) around the analog I/O, composed in [`application`];
//! - image: within 48 KB of flash ([`PRODUCT`]'s budget); the cargo feature
//!   `analog-io-can` turns on the image's CAN task (feature `canopen-node`).
//!
//! | module          | what                                                           |
//! |-----------------|----------------------------------------------------------------|
//! | [`identity`]    | product code, names, the update files' target                  |
//! | [`can`]         | node-ID, bit rate, the CiA 401 PDO set, the output source, EDS facts |
//! | [`od`]          | `analog-io`'s objects plus the node's and the output source    |
//! | [`device`]      | the device description (SII, ESI, EDS)                          |
//! | [`application`] | the analog I/O on two fieldbuses: the composition of the stacks |
//!
//! The SyncManager layout, the PDO defaults and the sync figures are `analog-io`'s.
//!
//! [`PRODUCT`]: crate::products::analog_io_can::PRODUCT
//! [`identity`]: crate::products::analog_io_can::identity
//! [`can`]: crate::products::analog_io_can::can
//! [`od`]: crate::products::analog_io_can::od
//! [`device`]: crate::products::analog_io_can::device
//! [`application`]: mod@crate::products::analog_io_can::application

pub mod application;
pub mod can;
pub mod device;
pub mod identity;
pub mod od;

#[cfg(test)]
mod tests;

use super::{analog_io, Budget, CanFacts, ImageBuild, Product};
use crate::io::analog::AnalogIo;
use crate::stacks::ethercat::AppConfig;
pub use application::AnalogCan;
use coe_core::device::oversampling::Oversampling;

pub use identity::BOARD;

/// The product for the tools.
pub static PRODUCT: Product = Product {
    name: "analog-io-can",
    summary: "analog-io plus CANopen (CiA 301/401) on CAN1, the board with a CAN transceiver",
    board: &BOARD,
    update: Some(identity::UPDATE_TARGET),
    device: &device::DEVICE,
    oversampling: &Oversampling::NONE,
    can: Some(CanFacts {
        eds: can::EDS_INFO,
        node_id: can::DEFAULT_NODE_ID,
    }),
    budget: Budget {
        flash: 48 * 1024,
        ram: 6 * 1024,
    },
    // The fastest setting that fits (`cargo xtask bench --opt-levels`, docs/book/
    // products.md): without the outliner the image is over its budget.
    build: ImageBuild {
        opt_level: "s",
        machine_outliner: true,
    },
};

/// What the slave application takes from the device description: `analog-io`'s.
pub const CONFIG: AppConfig = analog_io::CONFIG;

/// The application the slave application serves.
pub type Application = AnalogCan;

/// The application at power-up, the node at its default node-ID.
pub fn application() -> Application {
    application_with_node_id(can::DEFAULT_NODE_ID)
}

/// The application at power-up, with the CANopen node `node_id`.
pub fn application_with_node_id(node_id: u8) -> Application {
    AnalogCan::new(
        AnalogIo::new(&od::OD, analog_io::process_data()),
        node_id,
        analog_io::sync::FIGURES.min_cycle_ns,
    )
}
