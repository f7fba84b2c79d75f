//! Who the module is: identity (0x1018, SII words 8..15) and names (0x1008..0x100A, SII
//! strings, ESI).

use crate::platform::boot::header::Target;
use coe_core::device::{Identity, Names};

/// Vendor ID.
///
/// PLACEHOLDER: 0 is not an ETG-assigned vendor ID. A product must replace it with the
/// manufacturer's own ID from the EtherCAT Technology Group before it ships (the thesis
/// board borrowed Beckhoff's ID 2; this project must not). This is the only place it is set.
pub const VENDOR_ID: u32 = 0x0000_0000;

/// Identity (0x1018 and SII words 8..15): placeholder vendor, the project's own product code.
pub const IDENTITY: Identity = Identity {
    vendor_id: VENDOR_ID,
    product_code: 0x0000_1754,
    revision: 0x0001_0000,
    serial_number: 0,
};

/// The board revision an image is built for (the update file header,
/// [`crate::platform::boot::header`]): revision A, as 0x1009 names it.
pub const HARDWARE_REVISION: u32 = 1;

/// What an update file must be built for to be accepted and started on this module.
pub const UPDATE_TARGET: Target = Target {
    vendor_id: IDENTITY.vendor_id,
    product_code: IDENTITY.product_code,
    hardware_revision: HARDWARE_REVISION,
};

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
