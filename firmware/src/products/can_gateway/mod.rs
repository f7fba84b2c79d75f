//! `can-gateway`: an EtherCAT slave that is a CANopen master (seeds 002 and 001, as
//! Beckhoff's EL6751): up to [`od::MAX_NODES`] CANopen nodes on CAN1, each a module of the
//! modular device profile with its configuration, its process data and its diagnosis.
//!
//! - board: [`crate::platform::board::THESIS_CAN`] (CAN1 with its transceiver; the DAC and
//!   the ADC stay idle);
//! - stacks: the EtherCAT slave application ([`crate::stacks::ethercat`]) around the
//!   gateway ([`application::Gateway`]), which holds coe-core's CANopen master; the CAN
//!   task is the CANopen node's (`crate::stacks::canopen::task`) with the master behind it;
//! - image: not built yet. Linked with a temporarily larger slot it takes 59.4 KB of flash
//!   (opt-level "z" with the outliner, the smallest setting), over the 48 KB budget and the
//!   52 KB application slot: it is not in the products list until it fits
//!   (docs/book/gateway.md, "Image size").
//!
//! | module             | what                                                        |
//! |--------------------|-------------------------------------------------------------|
//! | [`identity`]       | product code, names, the update files' target               |
//! | [`sync`]           | the figures of 0x1C32/0x1C33                                |
//! | [`modules`]        | the node places: count, index distance, bytes               |
//! | [`layout`]         | the SyncManagers                                            |
//! | [`od`]             | the object dictionary (modules per node, 0xF000.., 0x10F3)   |
//! | [`network`]        | the 0x8000 family and 0xF800 in the master's places          |
//! | [`process_image`]  | the PDO assignment and the images                           |
//! | [`diagnosis`]      | node states and the diagnosis history 0x10F3                |
//! | [`stage`]          | the SYNC0 task's hand-over                                  |
//! | [`application`]    | the gateway: ESM coupling, objects, process data, CAN host   |
//! | [`device`]         | the device description (SII, ESI)                            |
//!
//! [`PRODUCT`]: crate::products::can_gateway::PRODUCT
//! [`od::MAX_NODES`]: crate::products::can_gateway::od::MAX_NODES
//! [`application::Gateway`]: crate::products::can_gateway::application::Gateway
//! [`identity`]: crate::products::can_gateway::identity
//! [`sync`]: crate::products::can_gateway::sync
//! [`modules`]: crate::products::can_gateway::modules
//! [`layout`]: crate::products::can_gateway::layout
//! [`od`]: crate::products::can_gateway::od
//! [`network`]: crate::products::can_gateway::network
//! [`process_image`]: crate::products::can_gateway::process_image
//! [`diagnosis`]: crate::products::can_gateway::diagnosis
//! [`stage`]: crate::products::can_gateway::stage
//! [`application`]: mod@crate::products::can_gateway::application
//! [`device`]: crate::products::can_gateway::device

pub mod application;
pub mod device;
pub mod diagnosis;
pub mod identity;
pub mod layout;
pub mod modules;
pub mod network;
pub mod od;
pub mod process_image;
pub mod stage;
pub mod sync;

#[cfg(test)]
mod tests;

use super::{Budget, ImageBuild, Product};
use crate::platform::boot::layout::BOOTSTRAP_MAILBOX;
use crate::stacks::ethercat::AppConfig;
pub use application::Gateway;
use coe_core::device::oversampling::Oversampling;

pub use identity::BOARD;

/// The product for the tools.
pub static PRODUCT: Product = Product {
    name: "can-gateway",
    summary: "EtherCAT slave and CANopen master on CAN1: CAN nodes as modules (EL6751-like)",
    board: &BOARD,
    update: Some(identity::UPDATE_TARGET),
    device: &device::DEVICE,
    // No CANopen device of its own on CAN (no EDS): it is the bus's master.
    can: None,
    oversampling: &Oversampling::NONE,
    budget: Budget {
        flash: 48 * 1024,
        // The master's node places (about 1 KB each) live in RAM.
        ram: 14 * 1024,
    },
    // The smallest setting measured (59.4 KB; "s": 62.2 KB before the 64-bit divisions went).
    build: ImageBuild {
        opt_level: "z",
        machine_outliner: true,
    },
};

/// What the slave application takes from the device description.
pub const CONFIG: AppConfig = AppConfig {
    sm: layout::SYNC_MANAGERS,
    device_id: None,
    bootstrap: Some(BOOTSTRAP_MAILBOX),
};

/// The application the slave application serves.
pub type Application = Gateway;

/// The application at power-up.
pub fn application() -> Application {
    Gateway::new()
}
