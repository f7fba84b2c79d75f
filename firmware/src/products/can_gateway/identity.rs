//! Who the gateway is: its product code and names, and what its update files are built for.

use crate::platform::board::{Board, Options, THESIS_CAN, VENDOR_ID};
use crate::platform::boot::header::Target;
use crate::products::analog_io;
use coe_core::device::{Identity, Names};

/// The board the product is built for: the thesis board with the CAN transceiver on CAN1
/// (the DAC and the ADC stay unused).
pub const BOARD: Board = THESIS_CAN;

/// Identity (0x1018 and SII words 8..15): the board's vendor, a product code of its own.
pub const IDENTITY: Identity = Identity {
    vendor_id: VENDOR_ID,
    product_code: 0x0002_1754,
    revision: 0x0001_0000,
    serial_number: 0,
};

/// What the update files are built for: needs the CAN transceiver.
pub const UPDATE_TARGET: Target = Target::new(
    IDENTITY.vendor_id,
    IDENTITY.product_code,
    &BOARD,
    Options::CAN_TRANSCEIVER,
);

/// Names and versions (0x1008..0x100A, SII strings, ESI).
pub const NAMES: Names = Names {
    device_name: "EtherCAT CANopen master gateway",
    order_code: "CANGW-8",
    group_type: "Gateway",
    group_name: "Gateways",
    hardware_version: "LPC1754+ET1100+CAN rev A",
    ..analog_io::identity::NAMES
};
