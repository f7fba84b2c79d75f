//! The synchronisation modes the firmware's products offer a master, as the device
//! description lists them (ESI `Dc/OpMode`, SII DC category): SM-synchronous, DC with
//! SYNC0 = the bus cycle, free run. Each product names them for what its cycle does.

use super::sync::{SYNC_MODE_DC_SYNC0, SYNC_MODE_FREE_RUN, SYNC_MODE_SM};
use coe_core::device::DcOpMode;

/// An op mode without DC: `sync_mode` is [`SYNC_MODE_SM`] or [`SYNC_MODE_FREE_RUN`].
const fn without_dc(name: &'static str, description: &'static str, sync_mode: u16) -> DcOpMode {
    DcOpMode {
        name,
        description,
        assign_activate: 0,
        sync_mode,
        cycle_time_sync0: 0,
        sync0_factor: 0,
        shift_time_sync0: 0,
        sync1_factor: 0,
        shift_time_sync1: 0,
    }
}

/// "SM-Synchron": the cycle runs at the SM2 event.
pub const fn sm_synchron(description: &'static str) -> DcOpMode {
    without_dc("SM-Synchron", description, SYNC_MODE_SM)
}

/// "FreeRun": the module's own cycle.
pub const FREE_RUN: DcOpMode = without_dc("FreeRun", "Free Run", SYNC_MODE_FREE_RUN);

/// A DC op mode with SYNC0 = the bus cycle (AssignActivate 0x0300, `CycleTimeSync0
/// Factor="1"`) and no SYNC1: the plain "DC" mode, and modes that add a PDO assignment
/// (the oversampling ones of `analog-io`).
pub const fn dc_sync0(name: &'static str, description: &'static str) -> DcOpMode {
    DcOpMode {
        name,
        description,
        assign_activate: 0x0300,
        sync_mode: SYNC_MODE_DC_SYNC0,
        cycle_time_sync0: 0,
        sync0_factor: 1,
        shift_time_sync0: 0,
        sync1_factor: 0,
        shift_time_sync1: 0,
    }
}
