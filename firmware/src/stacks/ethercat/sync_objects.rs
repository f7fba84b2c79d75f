//! The entries of 0x1C32 (outputs) / 0x1C33 (inputs), ETG.1020 "SM synchronisation", as the
//! slave application's sync monitor ([`super::sync::SyncMonitor`]) serves them: one
//! description for every product's dictionary, with the product's [`SyncFigures`] as
//! defaults.
//!
//! 0x0E..=0x12 (RxPDO toggle failed, cycle and SM sync distances) are optional in ETG.1020 and
//! not measured, so they are absent (a gap before 0x20; sub 0 stays 0x20).

use super::sync::{SyncFigures, SUPPORTED_MODES, SYNC_MODE_SM, SYNC_MODE_SM2_INPUTS};
use coe_core::od::{Access, DataType, EntryDefault, EntryDesc, Value, ValueRange};

const BOOL: DataType = DataType::Boolean;
const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const RO: Access = Access::RO;
const RW: Access = Access::RW;
const RWP: Access = Access::RW_PREOP;

/// 0x1C32:08 / 0x1C33:08 "Get cycle time": 0 stop, 1 start, 2 reset the figures.
const GET_CYCLE_TIME: &ValueRange = &ValueRange {
    min: Value::Uint(0),
    max: Value::Uint(2),
};

const fn ns(value: u32) -> Value {
    Value::Uint(value as u64)
}

/// The entries both objects share; the sync mode, calc and copy time and delay time are each
/// object's own ([`output_defaults`], [`input_defaults`]).
pub const fn sync_parameters(figures: &SyncFigures) -> [EntryDesc; 15] {
    [
        EntryDesc::new(0, "SubIndex 000", U8, RO).with_default(Value::Uint(0x20)),
        EntryDesc::new(1, "Sync mode", U16, RWP),
        EntryDesc::new(2, "Cycle time", U32, RWP).with_default(Value::Uint(0)),
        EntryDesc::new(3, "Shift time", U32, RO).with_default(Value::Uint(0)),
        EntryDesc::new(4, "Sync modes supported", U16, RO)
            .with_default(Value::Uint(SUPPORTED_MODES as u64)),
        EntryDesc::new(5, "Minimum cycle time", U32, RO).with_default(ns(figures.min_cycle_ns)),
        EntryDesc::new(6, "Calc and copy time", U32, RO),
        EntryDesc::new(7, "Minimum delay time", U32, RO).with_default(Value::Uint(0)),
        EntryDesc::new(8, "Get cycle time", U16, RW).with_range(GET_CYCLE_TIME),
        EntryDesc::new(9, "Delay time", U32, RO),
        EntryDesc::new(0x0A, "Sync0 cycle time", U32, RO),
        EntryDesc::new(0x0B, "SM event missed", U16, RO),
        EntryDesc::new(0x0C, "Cycle time too small", U16, RO),
        EntryDesc::new(0x0D, "Shift time too short", U16, RO),
        EntryDesc::new(0x20, "Sync error", BOOL, RO),
    ]
}

/// 0x1C32's own defaults: SM-synchronous, the output path's calc and copy and delay times.
pub const fn output_defaults(figures: &SyncFigures) -> [EntryDefault; 3] {
    [
        EntryDefault::new(1, SYNC_MODE_SM as u32),
        EntryDefault::new(6, figures.output_calc_copy_ns),
        EntryDefault::new(9, figures.output_delay_ns),
    ]
}

/// 0x1C33's own defaults: synchronous with SM2, the input path's calc and copy time.
pub const fn input_defaults(figures: &SyncFigures) -> [EntryDefault; 3] {
    [
        EntryDefault::new(1, SYNC_MODE_SM2_INPUTS as u32),
        EntryDefault::new(6, figures.input_calc_copy_ns),
        EntryDefault::new(9, 0),
    ]
}
