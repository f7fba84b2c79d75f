//! Who the module is: its own product code and names beside `analog-io`'s, and what its
//! update files are built for.

use crate::platform::board::{Board, Options, THESIS_CAN, VENDOR_ID};
use crate::platform::boot::header::Target;
use crate::products::analog_io;
use coe_core::device::{Identity, Names};

/// The board the product is built for.
pub const BOARD: Board = THESIS_CAN;

/// Identity (0x1018 and SII words 8..15): the board's vendor, a product code of its own.
pub const IDENTITY: Identity = Identity {
    vendor_id: VENDOR_ID,
    product_code: 0x0001_1754,
    revision: 0x0001_0000,
    serial_number: 0,
};

/// What the product's update files are built for: its identity on its board, needing the
/// CAN transceiver, so only a board that has one takes them.
pub const UPDATE_TARGET: Target = Target::new(
    IDENTITY.vendor_id,
    IDENTITY.product_code,
    &BOARD,
    Options::CAN_TRANSCEIVER,
);

/// Names and versions (0x1008..0x100A, SII strings, ESI).
pub const NAMES: Names = Names {
    device_name: "Analog IO 8AI 2AO CANopen",
    order_code: "AIO-8AI2AO-CAN",
    hardware_version: "LPC1754+ET1100+CAN rev A",
    ..analog_io::identity::NAMES
};
