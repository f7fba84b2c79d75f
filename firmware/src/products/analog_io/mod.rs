//! `analog-io`, the thesis board's module (the default product): 8 analog inputs and 2
//! analog outputs on EtherCAT, CoE and FoE, on the board without a CAN transceiver.
//!
//! - board: [`crate::platform::board::THESIS`];
//! - stacks: the EtherCAT slave application ([`crate::stacks::ethercat`]) around the analog
//!   I/O ([`crate::io::analog::AnalogIo`]), nothing on CAN;
//! - image: at most 44 KB of flash ([`PRODUCT`]'s budget).
//!
//! | module       | what                                                              |
//! |--------------|-------------------------------------------------------------------|
//! | [`identity`] | vendor ID, product code, revision, names, the update files' target |
//! | [`sync`]     | the figures of 0x1C32/0x1C33 (minimum cycle)                      |
//! | [`layout`]   | the SyncManagers in the ESC's process RAM                         |
//! | [`od`]       | the object dictionary                                             |
//! | [`oversampling`] | the input oversampling objects and PDOs (0x6010, 0x6020.., 0x1A10.., 0x8000) |
//! | [`output_oversampling`] | the output oversampling objects and PDOs (0x7010, 0x7020.., 0x1610, 0x1620..) |
//! | [`op_modes`] | the DC op modes that choose oversampling, one per bus cycle, with their PDO assignments |
//! | [`device`]   | the device description (SII, ESI) built from all of the above     |
//!
//! `analog-io-can` is this product plus CANopen on CAN1: it takes its dictionary's
//! analog objects, its layout and its figures from here.
//!
//! [`PRODUCT`]: crate::products::analog_io::PRODUCT
//! [`identity`]: crate::products::analog_io::identity
//! [`sync`]: crate::products::analog_io::sync
//! [`layout`]: crate::products::analog_io::layout
//! [`od`]: crate::products::analog_io::od
//! [`oversampling`]: crate::products::analog_io::oversampling
//! [`output_oversampling`]: crate::products::analog_io::output_oversampling
//! [`op_modes`]: crate::products::analog_io::op_modes
//! [`device`]: crate::products::analog_io::device

pub mod device;
pub mod identity;
pub mod layout;
pub mod od;
pub mod op_modes;
pub mod output_oversampling;
pub mod oversampling;
pub mod sync;

#[cfg(test)]
mod tests;

use super::{Budget, ImageBuild, Product};
use crate::io::analog::process_data::{mappings, Mapping, ProcessData, RX_PDOS, TX_PDOS};
use crate::io::analog::AnalogIo;
use crate::platform::boot::layout::BOOTSTRAP_MAILBOX;
use crate::stacks::ethercat::AppConfig;
use coe_core::device::oversampling::Oversampling;

pub use identity::BOARD;

/// The product for the tools.
pub static PRODUCT: Product = Product {
    name: "analog-io",
    summary: "8 AI + 2 AO on EtherCAT (CoE, FoE), the thesis board",
    board: &BOARD,
    update: Some(identity::UPDATE_TARGET),
    device: &device::DEVICE,
    oversampling: &OVERSAMPLING,
    can: None,
    // 48 KB, the most the rules allow an application: input oversampling (its 20 objects
    // with two 33-entry tables and the block cutter, about 7 KB) and output oversampling
    // (22 objects, the update path and the LDAC grid, about 4.7 KB).
    budget: Budget {
        flash: 48 * 1024,
        ram: 6 * 1024,
    },
    // Speed first within the budget (`cargo xtask bench --opt-levels`, docs/book/
    // products.md): "s" without the outliner has the shortest process-data cycle of all
    // settings; 2 and 3 do not fit.
    build: ImageBuild {
        opt_level: "s",
        machine_outliner: false,
    },
};

/// The sample and update PDOs as replicated PDOs (ETG.2000 `OSFac`..): the ESI and the SII
/// list 0x1A20 (factors 1..8) and 0x1620 (1..10) once; the dictionary holds them all. The
/// oversampling op modes ([`op_modes`]) follow the plain ones of the description.
pub static OVERSAMPLING: Oversampling = Oversampling {
    replicas: &[output_oversampling::REPLICAS, oversampling::REPLICAS],
    op_modes: &op_modes::OP_MODES,
};

// Checked where the oversampling images exist (the analog-io image, the host): other
// images leave them out, so this description's op modes do not fit their SyncManagers.
const _: () = if crate::io::analog::oversampling::BUILT {
    if let Err(e) = OVERSAMPLING.validate(&device::DEVICE) {
        panic!("{}", e.message())
    }
};

/// What the slave application takes from the device description: its SyncManager layout,
/// the bootstrap mailbox; no explicit device ID.
pub const CONFIG: AppConfig = AppConfig {
    sm: layout::SYNC_MANAGERS,
    device_id: None,
    bootstrap: Some(BOOTSTRAP_MAILBOX),
};

/// The default mapping objects, built when compiling (copied, not built, at start-up).
const RX_DEFAULT: [Mapping; RX_PDOS] = mappings(od::RX_MAPPINGS, od::RX_DEFAULTS);
const TX_DEFAULT: [Mapping; TX_PDOS] = mappings(od::TX_MAPPINGS, od::TX_DEFAULTS);

/// The default PDO configuration: the mapping objects with their default entries and the
/// assignments, from the constants the dictionary's defaults of 0x1600../0x1A00../0x1C12/
/// 0x1C13 are made of ([`od::RX_DEFAULTS`] and friends); a host test reads it back against
/// the dictionary.
pub fn process_data() -> ProcessData {
    ProcessData::new(
        RX_DEFAULT,
        TX_DEFAULT,
        &od::RX_ASSIGN_DEFAULT,
        &od::TX_ASSIGN_DEFAULT,
    )
    .with_input_blocks()
    .with_output_blocks()
}

/// The application the slave application serves: the analog I/O on the dictionary.
pub type Application = AnalogIo<sync::AnalogFigures>;

/// The application at power-up.
pub fn application() -> Application {
    AnalogIo::new(&od::OD, process_data())
}
