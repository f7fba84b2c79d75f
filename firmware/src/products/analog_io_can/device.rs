//! The module's device description: `analog-io`'s ([`analog_io::device::description`])
//! with this product's identity, names and dictionary, and the SyncManagers' room for its
//! plain PDOs (it has no oversampling PDOs); the EDS (CAN) is generated from it too, with
//! the facts of [`super::can::EDS_INFO`].

use super::identity::{IDENTITY, NAMES};
use super::od::OD;
use crate::products::analog_io;
use coe_core::device::DeviceDescription;

/// The module.
pub static DEVICE: DeviceDescription = analog_io::device::description(
    IDENTITY,
    NAMES,
    &OD,
    &analog_io::layout::PLAIN_SYNC_MANAGERS,
);

const _: () = if let Err(e) = DEVICE.validate() {
    panic!("{}", e.message())
};
