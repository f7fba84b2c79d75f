//! Shared test fixture for the server tests: a test object dictionary, an application that
//! stores values and can veto, and a bench that frames requests and unframes replies.
#![allow(dead_code)]

use coe_core::esm::AlState;
use coe_core::od::{
    Access, DataType, EntryDesc, ObjectAccess, ObjectDesc, ObjectDictionary, OdStore, Value,
    ValueRange,
};
use coe_core::pdo::{PdoAssignment, PdoEntry, PdoMapping};
use coe_core::sdo_server::{Reply, SdoServer};
use coe_core::SdoAbortCode;

/// The device name: longer than the 64-byte test mailbox, so its upload is segmented.
pub const LONG_NAME: &str =
    "Analog I/O slave: 8 x AI 16 bit 0..10 V, 2 x AO 16 bit 0..10 V, LPC1754 + ET1100 (test)";

pub const RW_PD: Access = Access::RW.rx_mappable();
pub const RO_PD: Access = Access::RO.tx_mappable();

pub static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[
            EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x000C_0191)),
        ],
    ),
    ObjectDesc::var(
        0x1008,
        "Device name",
        &[EntryDesc::string(0, "Device name", LONG_NAME)],
    ),
    ObjectDesc::var(
        0x1009,
        "HW version",
        &[EntryDesc::string(0, "HW version", "1.0")],
    ),
    ObjectDesc::record(
        0x1018,
        "Identity",
        DataType::Identity,
        &[
            EntryDesc::count(4),
            EntryDesc::new(1, "Vendor ID", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x1234_5678)),
            EntryDesc::new(2, "Product code", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x0000_1754)),
            EntryDesc::new(3, "Revision", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x0001_0000)),
            EntryDesc::new(4, "Serial number", DataType::Unsigned32, Access::RO),
        ],
    ),
    ObjectDesc::record(
        0x1A00,
        "TxPDO map 1",
        DataType::PdoMapping,
        &[
            EntryDesc::count(1).with_access(Access::RW_PREOP),
            EntryDesc::new(1, "SubIndex 001", DataType::Unsigned32, Access::RW_PREOP),
            EntryDesc::new(2, "SubIndex 002", DataType::Unsigned32, Access::RW_PREOP),
            EntryDesc::new(3, "SubIndex 003", DataType::Unsigned32, Access::RW_PREOP),
        ],
    ),
    ObjectDesc::array(
        0x1C13,
        "Sync manager 3 PDO assignment",
        &[
            EntryDesc::count(1).with_access(Access::RW_PREOP),
            EntryDesc::new(1, "SubIndex 001", DataType::Unsigned16, Access::RW_PREOP),
            EntryDesc::new(2, "SubIndex 002", DataType::Unsigned16, Access::RW_PREOP),
        ],
    ),
    ObjectDesc::var(
        0x2000,
        "U8 rw",
        &[EntryDesc::new(0, "U8 rw", DataType::Unsigned8, Access::RW)],
    ),
    ObjectDesc::var(
        0x2001,
        "U16 ranged",
        &[
            EntryDesc::new(0, "U16 ranged", DataType::Unsigned16, Access::RW.backup())
                .with_range(&ValueRange {
                    min: Value::Int(10),
                    max: Value::Int(1000),
                })
                .with_default(Value::Int(100))
                .with_unit(0x0026),
        ],
    ),
    ObjectDesc::var(
        0x2002,
        "U32 rw",
        &[EntryDesc::new(
            0,
            "U32 rw",
            DataType::Unsigned32,
            Access::RW.settings(),
        )],
    ),
    ObjectDesc::var(
        0x2003,
        "I16 ranged",
        &[
            EntryDesc::new(0, "I16 ranged", DataType::Integer16, Access::RW).with_range(
                &ValueRange {
                    min: Value::Int(-100),
                    max: Value::Int(100),
                },
            ),
        ],
    ),
    ObjectDesc::var(
        0x2004,
        "U32 wo",
        &[EntryDesc::new(
            0,
            "U32 wo",
            DataType::Unsigned32,
            Access::WO,
        )],
    ),
    ObjectDesc::var(
        0x2005,
        "U16 preop",
        &[EntryDesc::new(
            0,
            "U16 preop",
            DataType::Unsigned16,
            Access::RW_PREOP,
        )],
    ),
    ObjectDesc::var(
        0x2006,
        "Octets",
        &[EntryDesc::new(0, "Octets", DataType::OctetString, Access::RW).with_bits(200 * 8)],
    ),
    ObjectDesc::var(
        0x2007,
        "Domain",
        &[EntryDesc::new(0, "Domain", DataType::Domain, Access::RW).with_bits(300 * 8)],
    ),
    ObjectDesc::var(
        0x2008,
        "Writable string",
        &[
            EntryDesc::new(0, "Writable string", DataType::VisibleString, Access::RW)
                .with_bits(16 * 8),
        ],
    ),
    ObjectDesc::record(
        0x3000,
        "Mixed record",
        DataType::Unknown(0x0040),
        &[
            EntryDesc::count(6),
            EntryDesc::new(1, "Flag", DataType::Boolean, Access::RW),
            EntryDesc::new(2, "Code", DataType::Bit3, Access::RW),
            EntryDesc::new(3, "Byte", DataType::Unsigned8, Access::RW),
            EntryDesc::new(4, "Word", DataType::Integer16, Access::RW),
            EntryDesc::new(5, "Status", DataType::Unsigned16, Access::RO)
                .with_default(Value::Int(0xBEEF)),
            EntryDesc::new(6, "Dword", DataType::Unsigned32, Access::RW),
        ],
    ),
    ObjectDesc::array(
        0x3001,
        "Dynamic list",
        &[
            EntryDesc::count(2).with_access(Access::RW_PREOP),
            EntryDesc::new(1, "Item 1", DataType::Unsigned16, Access::RW_PREOP),
            EntryDesc::new(2, "Item 2", DataType::Unsigned16, Access::RW_PREOP),
            EntryDesc::new(3, "Item 3", DataType::Unsigned16, Access::RW_PREOP),
        ],
    ),
    ObjectDesc::array(
        0x6401,
        "Read analog input 16-bit",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AI 1", DataType::Integer16, RO_PD),
            EntryDesc::new(2, "AI 2", DataType::Integer16, RO_PD),
        ],
    ),
    ObjectDesc::array(
        0x6411,
        "Write analog output 16-bit",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AO 1", DataType::Integer16, RW_PD),
            EntryDesc::new(2, "AO 2", DataType::Integer16, RW_PD),
        ],
    ),
]);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};

/// Values in an `OdStore`, plus a veto and the RxPDO-mapped flag of 0x6411.
pub struct App {
    pub store: OdStore<1024>,
    pub veto: Option<(u16, u8, SdoAbortCode)>,
    pub ao_mapped: bool,
    pub writes: Vec<(u16, u8, Vec<u8>)>,
    /// 0x1A00, backed by the PDO module (default: 0x6401:01, 16 bit).
    pub txpdo: [PdoMapping<3>; 1],
    /// 0x1C13 (default: 0x1A00).
    pub sm3: PdoAssignment<2>,
}

/// Room in the SM3 process image of the test device: 32 bits.
pub const SM3_BITS: u32 = 32;

impl App {
    pub fn new() -> Self {
        let mut store = OdStore::new(OD).unwrap();
        store.set(0x1018, 4, &0xCAFE_F00Du32.to_le_bytes()).unwrap();
        store.set(0x2007, 0, &[]).unwrap();
        Self {
            store,
            veto: None,
            ao_mapped: false,
            writes: Vec::new(),
            txpdo: [PdoMapping::with_entries(
                0x1A00,
                &[PdoEntry::new(0x6401, 1, 16)],
            )],
            sm3: PdoAssignment::with_pdos(0x1C13, &[0x1A00]),
        }
    }
}

impl ObjectAccess for App {
    fn read(&mut self, index: u16, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        match index {
            0x1A00 => self.txpdo[0].read_sub(subindex, buf),
            0x1C13 => self.sm3.read_sub(subindex, buf),
            _ => self.store.read(index, subindex, buf),
        }
    }

    fn write(
        &mut self,
        index: u16,
        subindex: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        if let Some((i, s, code)) = self.veto {
            if i == index && s == subindex {
                return Err(code);
            }
        }
        self.writes.push((index, subindex, data.to_vec()));
        match index {
            0x1A00 => self.txpdo[0].write_sub(subindex, data, &OD, SM3_BITS),
            0x1C13 => self.sm3.write_sub(subindex, data, &self.txpdo, SM3_BITS),
            _ => self.store.write(index, subindex, data, state),
        }
    }

    fn is_rx_mapped(&self, index: u16, _subindex: u8) -> bool {
        self.ao_mapped && index == 0x6411
    }
}

/// Mailbox size of the bench (SM0 = SM1 = 64 bytes).
pub const MBX: usize = 64;

pub struct Bench {
    pub server: SdoServer<128, 512, 4>,
    pub app: App,
    pub state: AlState,
    pub now: u32,
    pub counter: u8,
    /// Read mailbox size (SM1) the replies must fit.
    pub mbx: usize,
}

/// A mailbox frame: header (length, address 0, channel 0, priority 0, type 3 CoE, counter)
/// followed by `coe`, padded to the mailbox size like a master writing the whole SM0.
pub fn frame(counter: u8, coe: &[u8]) -> Vec<u8> {
    let mut f = Vec::new();
    f.extend_from_slice(&(coe.len() as u16).to_le_bytes());
    f.extend_from_slice(&[0x00, 0x00, 0x00, 0x03 | (counter << 4)]);
    f.extend_from_slice(coe);
    if f.len() < MBX {
        f.resize(MBX, 0);
    }
    f
}

impl Bench {
    pub fn new() -> Self {
        Self {
            server: SdoServer::new(),
            app: App::new(),
            state: AlState::PreOp,
            now: 0,
            counter: 0,
            mbx: MBX,
        }
    }

    pub fn with_mailbox(mbx: usize) -> Self {
        Self { mbx, ..Self::new() }
    }

    fn next_counter(&mut self) -> u8 {
        self.counter = if self.counter >= 7 {
            1
        } else {
            self.counter + 1
        };
        self.counter
    }

    /// Sends a raw mailbox frame; returns the reply frame.
    pub fn raw(&mut self, request: &[u8]) -> Option<Vec<u8>> {
        let mut reply = vec![0xEEu8; self.mbx];
        match self.server.process(
            request,
            self.state,
            &OD,
            &mut self.app,
            self.now,
            &mut reply,
        ) {
            Reply::None => None,
            Reply::Frame(n) => {
                assert!(n <= self.mbx);
                Some(reply[..n].to_vec())
            }
        }
    }

    /// Sends CoE bytes (CoE header onwards) with the next counter; returns the CoE bytes of
    /// the reply after checking its mailbox header (length, type CoE).
    pub fn coe(&mut self, coe: &[u8]) -> Option<Vec<u8>> {
        let c = self.next_counter();
        let reply = self.raw(&frame(c, coe))?;
        Some(check_coe_frame(&reply))
    }

    /// Like `coe` but the reply must exist.
    pub fn ask(&mut self, coe: &[u8]) -> Vec<u8> {
        self.coe(coe).expect("a reply")
    }

    /// Pending fragment or emergency.
    pub fn poll(&mut self) -> Option<Vec<u8>> {
        let mut reply = vec![0xEEu8; self.mbx];
        match self.server.poll(&OD, &mut reply) {
            Reply::None => None,
            Reply::Frame(n) => Some(reply[..n].to_vec()),
        }
    }
}

/// Checks a reply frame's mailbox header and returns its data.
pub fn check_coe_frame(reply: &[u8]) -> Vec<u8> {
    assert!(reply.len() >= 8, "{reply:02X?}");
    let len = u16::from_le_bytes([reply[0], reply[1]]) as usize;
    assert_eq!(len, reply.len() - 6, "length field {reply:02X?}");
    assert_eq!(reply[5] & 0x0F, 0x03, "mailbox type CoE {reply:02X?}");
    reply[6..].to_vec()
}

/// An SDO abort as the server must send it: CoE service 2 (SDO request), command 0x80.
pub fn abort(index: u16, sub: u8, code: SdoAbortCode) -> Vec<u8> {
    let mut v = vec![0x00, 0x20, 0x80];
    v.extend_from_slice(&index.to_le_bytes());
    v.push(sub);
    v.extend_from_slice(&u32::from(code).to_le_bytes());
    v
}

/// An SDO request (CoE service 2) with command, index, subindex and 4 data bytes.
pub fn sdo(command: u8, index: u16, sub: u8, data: [u8; 4]) -> Vec<u8> {
    let mut v = vec![0x00, 0x20, command];
    v.extend_from_slice(&index.to_le_bytes());
    v.push(sub);
    v.extend_from_slice(&data);
    v
}

/// An SDO response (CoE service 3).
pub fn resp(command: u8, index: u16, sub: u8, data: [u8; 4]) -> Vec<u8> {
    let mut v = vec![0x00, 0x30, command];
    v.extend_from_slice(&index.to_le_bytes());
    v.push(sub);
    v.extend_from_slice(&data);
    v
}
