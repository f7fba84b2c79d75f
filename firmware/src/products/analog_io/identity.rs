//! Who the module is: identity (0x1018, SII words 8..15), names (0x1008..0x100A, SII
//! strings, ESI), and what its update files are built for.

use crate::platform::board::{Board, Options, THESIS, VENDOR_ID};
use crate::platform::boot::header::Target;
use coe_core::device::{Identity, Names};

/// The board the product is built for.
pub const BOARD: Board = THESIS;

/// Identity (0x1018 and SII words 8..15): the board's vendor (a placeholder,
/// [`VENDOR_ID`]), the project's own product code.
pub const IDENTITY: Identity = Identity {
    vendor_id: VENDOR_ID,
    product_code: 0x0000_1754,
    revision: 0x0001_0000,
    serial_number: 0,
};

/// What the product's update files are built for: its identity on its board, needing
/// nothing beyond the thesis board, so every assembly of the board takes them.
pub const UPDATE_TARGET: Target = Target::new(
    IDENTITY.vendor_id,
    IDENTITY.product_code,
    &BOARD,
    Options::NONE,
);

/// Names and versions (0x1008..0x100A, SII strings, ESI).
pub const NAMES: Names = Names {
    vendor_name: "Placeholder vendor (no ETG vendor ID)",
    device_name: "Analog IO 8AI 2AO",
    order_code: "AIO-8AI2AO",
    group_type: "AnalogIO",
    group_name: "Analog I/O",
    hardware_version: "LPC1754+ET1100 rev A",
    software_version: env!("CARGO_PKG_VERSION"),
};
