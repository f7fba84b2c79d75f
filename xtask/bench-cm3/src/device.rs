//! The module's objects as far as the measured paths touch them: identity, PDO mapping and
//! assignment (2 AO in SM2, 8 AI in SM3), sync parameters, AI/AO and the AO fault
//! configuration. The SyncManager layout is the SII's (mailboxes 128 bytes at 0x1000/0x1080,
//! process data at 0x1100/0x1180).
//!
//! (The firmware's own device description, `firmware::device`, replaces this table once it
//! exists; the measured code paths do not depend on which objects are present beyond these.)

use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, Value};
use coe_core::pdo::PdoEntry;
use firmware::app::esc::SmExpect;
use firmware::app::process_data::{Mapping, ProcessData};
use firmware::app::AppConfig;

const I16: DataType = DataType::Integer16;
const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const RWP: Access = Access::RW_PREOP;

/// Write mailbox (SM0) start.
pub const MBX_OUT: u16 = 0x1000;
/// Read mailbox (SM1) start.
pub const MBX_IN: u16 = 0x1080;
/// Mailbox length.
pub const MBX_LEN: u16 = 128;
/// Outputs (SM2) start.
pub const PD_OUT: u16 = 0x1100;
/// Inputs (SM3) start.
pub const PD_IN: u16 = 0x1180;
/// SM2 length: 2 AO x 16 bit.
pub const OUTPUT_BYTES: u16 = 4;
/// SM3 length: 8 AI x 16 bit.
pub const INPUT_BYTES: u16 = 16;

const MAP: &[EntryDesc] = &[
    EntryDesc::new(0, "SubIndex 000", U8, RWP),
    EntryDesc::new(1, "Entry", U32, RWP),
    EntryDesc::new(2, "Entry", U32, RWP),
    EntryDesc::new(3, "Entry", U32, RWP),
    EntryDesc::new(4, "Entry", U32, RWP),
    EntryDesc::new(5, "Entry", U32, RWP),
    EntryDesc::new(6, "Entry", U32, RWP),
    EntryDesc::new(7, "Entry", U32, RWP),
    EntryDesc::new(8, "Entry", U32, RWP),
];

const SYNC: &[EntryDesc] = &[
    EntryDesc::new(0, "SubIndex 000", U8, Access::RO),
    EntryDesc::new(1, "Sync mode", U16, RWP),
    EntryDesc::new(2, "Cycle time", U32, RWP),
    EntryDesc::new(0x0B, "SM event missed", U16, Access::RO),
    EntryDesc::new(0x20, "Sync error", DataType::Boolean, Access::RO),
];

const ASSIGN: &[EntryDesc] = &[
    EntryDesc::new(0, "SubIndex 000", U8, RWP),
    EntryDesc::new(1, "Assign", U16, RWP),
];

const AI: DataType = I16;

/// The objects of the benchmark.
pub static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[
            EntryDesc::new(0, "Device type", U32, Access::RO)
                .with_default(Value::Uint(0x000C_0191)),
        ],
    ),
    ObjectDesc::var(
        0x1001,
        "Error register",
        &[EntryDesc::new(0, "Error register", U8, Access::RO)],
    ),
    ObjectDesc::record(
        0x1018,
        "Identity",
        DataType::Unknown(0x0023),
        &[
            EntryDesc::count(4),
            EntryDesc::new(1, "Vendor ID", U32, Access::RO).with_default(Value::Uint(0)),
            EntryDesc::new(2, "Product code", U32, Access::RO).with_default(Value::Uint(0x1754)),
            EntryDesc::new(3, "Revision", U32, Access::RO).with_default(Value::Uint(1)),
            EntryDesc::new(4, "Serial number", U32, Access::RO).with_default(Value::Uint(42)),
        ],
    ),
    ObjectDesc::record(0x1600, "RxPDO 1", DataType::PdoMapping, MAP),
    ObjectDesc::record(0x1A00, "TxPDO 1", DataType::PdoMapping, MAP),
    ObjectDesc::array(0x1C12, "RxPDO assign", ASSIGN),
    ObjectDesc::array(0x1C13, "TxPDO assign", ASSIGN),
    ObjectDesc::record(
        0x1C32,
        "SM output parameter",
        DataType::Unknown(0x0042),
        SYNC,
    ),
    ObjectDesc::record(
        0x1C33,
        "SM input parameter",
        DataType::Unknown(0x0042),
        SYNC,
    ),
    ObjectDesc::array(
        0x6401,
        "Read analog input 16-bit",
        &[
            EntryDesc::count(8),
            EntryDesc::new(1, "AI 1", AI, Access::RO.tx_mappable()),
            EntryDesc::new(2, "AI 2", AI, Access::RO.tx_mappable()),
            EntryDesc::new(3, "AI 3", AI, Access::RO.tx_mappable()),
            EntryDesc::new(4, "AI 4", AI, Access::RO.tx_mappable()),
            EntryDesc::new(5, "AI 5", AI, Access::RO.tx_mappable()),
            EntryDesc::new(6, "AI 6", AI, Access::RO.tx_mappable()),
            EntryDesc::new(7, "AI 7", AI, Access::RO.tx_mappable()),
            EntryDesc::new(8, "AI 8", AI, Access::RO.tx_mappable()),
        ],
    ),
    ObjectDesc::array(
        0x6411,
        "Write analog output 16-bit",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AO 1", I16, Access::RW.rx_mappable()),
            EntryDesc::new(2, "AO 2", I16, Access::RW.rx_mappable()),
        ],
    ),
    ObjectDesc::array(
        0x6443,
        "Analog output error mode",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Mode 1", U8, Access::RW),
            EntryDesc::new(2, "Mode 2", U8, Access::RW),
        ],
    ),
    ObjectDesc::array(
        0x6444,
        "Analog output error value",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Value 1", DataType::Integer32, Access::RW),
            EntryDesc::new(2, "Value 2", DataType::Integer32, Access::RW),
        ],
    ),
]);

/// SyncManager expectations (as in the SII).
pub const fn config() -> AppConfig {
    AppConfig {
        sm: [
            SmExpect {
                start: MBX_OUT,
                len: MBX_LEN,
                control: 0x26,
            },
            SmExpect {
                start: MBX_IN,
                len: MBX_LEN,
                control: 0x22,
            },
            SmExpect {
                start: PD_OUT,
                len: 0,
                control: 0x64,
            },
            SmExpect {
                start: PD_IN,
                len: 0,
                control: 0x20,
            },
        ],
        device_id: None,
    }
}

/// The default PDO configuration: 0x1600 = AO 1..2, 0x1A00 = AI 1..8.
pub fn process_data() -> ProcessData {
    let ai = [
        PdoEntry::new(0x6401, 1, 16),
        PdoEntry::new(0x6401, 2, 16),
        PdoEntry::new(0x6401, 3, 16),
        PdoEntry::new(0x6401, 4, 16),
        PdoEntry::new(0x6401, 5, 16),
        PdoEntry::new(0x6401, 6, 16),
        PdoEntry::new(0x6401, 7, 16),
        PdoEntry::new(0x6401, 8, 16),
    ];
    ProcessData::new(
        [
            Mapping::with_entries(
                0x1600,
                &[PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)],
            ),
            Mapping::new(0x1601),
        ],
        [Mapping::with_entries(0x1A00, &ai), Mapping::new(0x1A01)],
        &[0x1600],
        &[0x1A00],
    )
}
