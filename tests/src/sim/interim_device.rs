//! A stand-in device description for the firmware's slave application, used until the
//! firmware's own one (`firmware::od` / `firmware::device`, with the generated SII) lands.
//!
//! It follows the brief (CiA 401 device type 0x000C0191, 8 AI as 0x6401:01..08 and 2 AO as
//! 0x6411:01..02 INTEGER16, RxPDO 0x1600 and TxPDO 0x1A00, fault configuration 0x6443/0x6444)
//! with a placeholder identity (vendor 0 is not an ETG vendor ID). The SII image is built to
//! match it with the test SII builder.

use crate::firmware_cpu::Device;
use crate::sii_builder::{SiiBuilder, SiiPdo, SiiPdoEntry, SiiSyncManager};
use coe_core::od::{Access, DataType, EntryDesc, Value};
use coe_core::od::{ObjectDesc, ObjectDictionary};
use coe_core::pdo::PdoEntry;
use firmware::app::esc::SmExpect;
use firmware::app::process_data::{Mapping, ProcessData};
use firmware::app::AppConfig;

const I16: DataType = DataType::Integer16;
const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const RWP: Access = Access::RW_PREOP;

/// Product code of the stand-in identity.
pub const PRODUCT_CODE: u32 = 0x0000_1754;
/// Device name (0x1008 and the SII).
pub const NAME: &str = "Analog IO 8AI 2AO";

macro_rules! ai {
    ($($n:literal),*) => {
        &[EntryDesc::count(8), $(EntryDesc::new($n, "AI", I16, Access::RO.tx_mappable())),*]
    };
}

macro_rules! map {
    ($($n:literal),*) => {
        &[EntryDesc::new(0, "SubIndex 000", U8, RWP), $(EntryDesc::new($n, "Entry", U32, RWP)),*]
    };
}

const SYNC_ENTRIES: &[EntryDesc] = &[
    EntryDesc::new(0, "SubIndex 000", U8, Access::RO),
    EntryDesc::new(1, "Sync mode", U16, RWP),
    EntryDesc::new(2, "Cycle time", U32, RWP),
    EntryDesc::new(4, "Sync modes supported", U16, Access::RO),
    EntryDesc::new(5, "Minimum cycle time", U32, Access::RO),
    EntryDesc::new(6, "Calc and copy time", U32, Access::RO),
    EntryDesc::new(9, "Delay time", U32, Access::RO),
    EntryDesc::new(0x0A, "Sync0 cycle time", U32, Access::RO),
    EntryDesc::new(0x0B, "SM event missed", U16, Access::RO),
    EntryDesc::new(0x0C, "Cycle time too small", U16, Access::RO),
    EntryDesc::new(0x20, "Sync error", DataType::Boolean, Access::RO),
];

/// The stand-in object dictionary.
pub static OD: ObjectDictionary =
    ObjectDictionary::new(&[
        ObjectDesc::var(
            0x1000,
            "Device type",
            &[EntryDesc::new(0, "Device type", U32, Access::RO)
                .with_default(Value::Uint(0x000C_0191))],
        ),
        ObjectDesc::var(
            0x1001,
            "Error register",
            &[EntryDesc::new(0, "Error register", U8, Access::RO)],
        ),
        ObjectDesc::var(
            0x1008,
            "Device name",
            &[EntryDesc::string(0, "Device name", NAME)],
        ),
        ObjectDesc::var(
            0x1009,
            "Hardware version",
            &[EntryDesc::string(
                0,
                "Hardware version",
                "LPC1754+ET1100 rev A",
            )],
        ),
        ObjectDesc::var(
            0x100A,
            "Software version",
            &[EntryDesc::string(
                0,
                "Software version",
                env!("CARGO_PKG_VERSION"),
            )],
        ),
        ObjectDesc::record(
            0x1018,
            "Identity",
            DataType::Unknown(0x0023),
            &[
                EntryDesc::count(4),
                EntryDesc::new(1, "Vendor ID", U32, Access::RO).with_default(Value::Uint(0)),
                EntryDesc::new(2, "Product code", U32, Access::RO)
                    .with_default(Value::Uint(PRODUCT_CODE as u64)),
                EntryDesc::new(3, "Revision", U32, Access::RO).with_default(Value::Uint(1)),
                EntryDesc::new(4, "Serial number", U32, Access::RO).with_default(Value::Uint(42)),
            ],
        ),
        ObjectDesc::record(0x1600, "RxPDO 1", DataType::PdoMapping, map!(1, 2)),
        ObjectDesc::record(0x1601, "RxPDO 2", DataType::PdoMapping, map!(1, 2)),
        ObjectDesc::record(
            0x1A00,
            "TxPDO 1",
            DataType::PdoMapping,
            map!(1, 2, 3, 4, 5, 6, 7, 8),
        ),
        ObjectDesc::record(
            0x1A01,
            "TxPDO 2",
            DataType::PdoMapping,
            map!(1, 2, 3, 4, 5, 6, 7, 8),
        ),
        ObjectDesc::array(
            0x1C12,
            "RxPDO assign",
            &[
                EntryDesc::new(0, "SubIndex 000", U8, RWP),
                EntryDesc::new(1, "Assign", U16, RWP),
                EntryDesc::new(2, "Assign", U16, RWP),
            ],
        ),
        ObjectDesc::array(
            0x1C13,
            "TxPDO assign",
            &[
                EntryDesc::new(0, "SubIndex 000", U8, RWP),
                EntryDesc::new(1, "Assign", U16, RWP),
                EntryDesc::new(2, "Assign", U16, RWP),
            ],
        ),
        ObjectDesc::record(
            0x1C32,
            "SM output parameter",
            DataType::Unknown(0x0042),
            SYNC_ENTRIES,
        ),
        ObjectDesc::record(
            0x1C33,
            "SM input parameter",
            DataType::Unknown(0x0042),
            SYNC_ENTRIES,
        ),
        ObjectDesc::array(
            0x6401,
            "Read analog input 16-bit",
            ai!(1, 2, 3, 4, 5, 6, 7, 8),
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

const MBX_OUT: u16 = 0x1000;
const MBX_IN: u16 = 0x1080;
const MBX_LEN: u16 = 128;
const PD_OUT: u16 = 0x1100;
const PD_IN: u16 = 0x1180;

fn ai_entries() -> Vec<SiiPdoEntry> {
    (1..=8)
        .map(|s| SiiPdoEntry {
            index: 0x6401,
            subindex: s,
            data_type: 0x03,
            bits: 16,
        })
        .collect()
}

/// The SII image matching [`OD`].
pub fn sii() -> Vec<u8> {
    let mut name = 0;
    SiiBuilder::new()
        .identity(0, PRODUCT_CODE, 1, 42)
        .mailbox((MBX_OUT, MBX_LEN), (MBX_IN, MBX_LEN), 0x0004)
        .string(NAME, &mut name)
        .general(name, 0x23)
        .fmmus(&[1, 2, 3])
        .sync_manager(SiiSyncManager {
            start: MBX_OUT,
            len: MBX_LEN,
            control: 0x26,
            enable: 0x01,
            usage: 1,
        })
        .sync_manager(SiiSyncManager {
            start: MBX_IN,
            len: MBX_LEN,
            control: 0x22,
            enable: 0x01,
            usage: 2,
        })
        .sync_manager(SiiSyncManager {
            start: PD_OUT,
            len: 0,
            control: 0x64,
            enable: 0x01,
            usage: 3,
        })
        .sync_manager(SiiSyncManager {
            start: PD_IN,
            len: 0,
            control: 0x20,
            enable: 0x01,
            usage: 4,
        })
        .rxpdo(SiiPdo {
            index: 0x1600,
            sm: 2,
            entries: (1..=2)
                .map(|s| SiiPdoEntry {
                    index: 0x6411,
                    subindex: s,
                    data_type: 0x03,
                    bits: 16,
                })
                .collect(),
        })
        .txpdo(SiiPdo {
            index: 0x1A00,
            sm: 3,
            entries: ai_entries(),
        })
        .build()
}

/// The stand-in device.
pub fn device() -> Device {
    let ai: Vec<PdoEntry> = (1..=8).map(|s| PdoEntry::new(0x6401, s, 16)).collect();
    Device {
        description: "the firmware's slave application (object dictionary: the virtual board's \
            stand-in until firmware::device lands)"
            .into(),
        od: &OD,
        config: AppConfig {
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
        },
        process_data: ProcessData::new(
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
        ),
        sii: sii(),
    }
}
