//! Who the module is: identity (0x1018, SII words 8..15) and names (0x1008..0x100A, SII
//! strings, ESI).

use crate::platform::board::{Board, STM32_FSMC, VENDOR_ID};
use crate::products::analog_io;
use coe_core::device::{Identity, Names};

/// The board the product is built for.
pub const BOARD: Board = STM32_FSMC;

/// Identity (0x1018 and SII words 8..15): the board's vendor (a placeholder,
/// [`VENDOR_ID`]), the project's own product code.
pub const IDENTITY: Identity = Identity {
    vendor_id: VENDOR_ID,
    product_code: 0x0000_F103,
    revision: 0x0001_0000,
    serial_number: 0,
};

/// Names and versions (0x1008..0x100A, SII strings, ESI).
pub const NAMES: Names = Names {
    device_name: "Analog IO 8AI 2AO (STM32)",
    order_code: "AIO-8AI2AO-F103",
    hardware_version: "STM32F103VC+ET1100 FSMC rev A",
    ..analog_io::identity::NAMES
};
