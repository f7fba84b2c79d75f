//! The CANopen node against a CiA 401-like test device: boot-up, NMT, heartbeat, node
//! guarding, SDO over CAN, PDO configuration and exchange, SYNC, EMCY, the shared-mapping
//! rules and the object access another transport uses.

use coe_core::canopen::cob;
use coe_core::canopen::node::{emcy_code, CanApplication, CanNode, ERR_COMMUNICATION};
use coe_core::canopen::objects::CommObjects;
use coe_core::canopen::params::{CommDefaults, PdoDefault};
use coe_core::canopen::{CanFrame, NmtState};
use coe_core::esm::AlState;
use coe_core::od::{
    Access, DataType, EntryDesc, ObjectAccess, ObjectDesc, ObjectDictionary, OdStore, Value,
};
use coe_core::pdo::{PdoEntry, PdoMapping};
use coe_core::wire::EmergencyRepr;
use coe_core::SdoAbortCode;

const NODE: u8 = 5;
const MS: u64 = 1000;

static DEFAULTS: CommDefaults<2, 3> = CommDefaults {
    rpdo: [
        PdoDefault::new(0x200, false, 255),
        PdoDefault::new(0x300, true, 255),
    ],
    tpdo: [
        PdoDefault::new(0x180, false, 255),
        PdoDefault::new(0x280, true, 255),
        PdoDefault::new(0x380, true, 255),
    ],
    heartbeat_ms: 0,
    guard_time_ms: 0,
    life_factor: 0,
    emcy_inhibit_100us: 0,
    error_behaviour: 0,
};

static CAN: CommObjects<2, 3, 3> = CommObjects::new(&DEFAULTS);

const RWP: Access = Access::RW_PREOP;
const AI: [EntryDesc; 9] = {
    let mut e = [EntryDesc::count(8); 9];
    let names = [
        "AI 1", "AI 2", "AI 3", "AI 4", "AI 5", "AI 6", "AI 7", "AI 8",
    ];
    let mut i = 1;
    while i < 9 {
        e[i] = EntryDesc::new(
            i as u8,
            names[i - 1],
            DataType::Integer16,
            Access::RO.tx_mappable(),
        );
        i += 1;
    }
    e
};
const fn mapping_entries() -> [EntryDesc; 9] {
    let names = [
        "Entry 1", "Entry 2", "Entry 3", "Entry 4", "Entry 5", "Entry 6", "Entry 7", "Entry 8",
    ];
    let mut e = [EntryDesc::count(0).with_access(RWP); 9];
    let mut i = 1;
    while i < 9 {
        e[i] = EntryDesc::new(i as u8, names[i - 1], DataType::Unsigned32, RWP);
        i += 1;
    }
    e
}
static MAP: [EntryDesc; 9] = mapping_entries();

static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[
            EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x000C_0191)),
        ],
    ),
    ObjectDesc::var(
        0x1001,
        "Error register",
        &[EntryDesc::new(
            0,
            "Error register",
            DataType::Unsigned8,
            Access::RO,
        )],
    ),
    CAN.sync_cob_id(),
    CAN.cycle_period(),
    ObjectDesc::var(
        0x1008,
        "Device name",
        &[EntryDesc::string(0, "Device name", "Analog IO 8AI 2AO")],
    ),
    CAN.guard_time(),
    CAN.life_factor(),
    CAN.emcy_cob_id(),
    CAN.emcy_inhibit(),
    CAN.consumers(),
    CAN.producer(),
    CAN.sync_overflow(),
    CAN.error_behaviour(),
    CAN.sdo_server(),
    CAN.rpdo(0),
    CAN.rpdo(1),
    ObjectDesc::record(0x1600, "RPDO 1 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1601, "RPDO 2 mapping", DataType::PdoMapping, &MAP),
    CAN.tpdo(0),
    CAN.tpdo(1),
    CAN.tpdo(2),
    ObjectDesc::record(0x1A00, "TPDO 1 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1A01, "TPDO 2 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1A02, "TPDO 3 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::array(0x6401, "Read analog input 16-bit", &AI),
    ObjectDesc::array(
        0x6411,
        "Write analog output 16-bit",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AO 1", DataType::Integer16, Access::RW.rx_mappable()),
            EntryDesc::new(2, "AO 2", DataType::Integer16, Access::RW.rx_mappable()),
        ],
    ),
]);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};

const MAPPINGS: [u16; 5] = [0x1600, 0x1601, 0x1A00, 0x1A01, 0x1A02];

fn default_mappings() -> [PdoMapping<8>; 5] {
    let ai = |range: std::ops::RangeInclusive<u8>| -> Vec<PdoEntry> {
        range.map(|s| PdoEntry::new(0x6401, s, 16)).collect()
    };
    [
        PdoMapping::with_entries(
            0x1600,
            &[PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)],
        ),
        PdoMapping::with_entries(
            0x1601,
            &[PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)],
        ),
        PdoMapping::with_entries(0x1A00, &ai(1..=8)),
        PdoMapping::with_entries(0x1A01, &ai(1..=4)),
        PdoMapping::with_entries(0x1A02, &ai(5..=8)),
    ]
}

/// The test device: values in a store, mappings with the ETG rules, and a log of what the
/// node asked for.
struct Device {
    store: OdStore<512>,
    maps: [PdoMapping<8>; 5],
    ai: [i16; 8],
    ao: [i16; 2],
    ao_written: Option<[i16; 2]>,
    owner: bool,
    change_of_state: bool,
    register: u8,
    applied: Vec<[i16; 2]>,
    faults: u32,
    resets: Vec<bool>,
}

impl Device {
    fn new() -> Self {
        Self {
            store: OdStore::new(OD).unwrap(),
            maps: default_mappings(),
            ai: [100, 200, 300, 400, 500, 600, 700, 800],
            ao: [0; 2],
            ao_written: None,
            owner: true,
            change_of_state: false,
            register: 0,
            applied: Vec::new(),
            faults: 0,
            resets: Vec::new(),
        }
    }

    fn map(&mut self, index: u16) -> Option<&mut PdoMapping<8>> {
        MAPPINGS
            .iter()
            .position(|i| *i == index)
            .map(|i| &mut self.maps[i])
    }
}

impl ObjectAccess for Device {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        if let Some(m) = self.map(index) {
            return m.read_sub(sub, buf);
        }
        match (index, sub) {
            (0x1001, 0) => {
                buf[0] = self.register;
                Ok(1)
            }
            (0x6401, 1..=8) => {
                buf[..2].copy_from_slice(&self.ai[usize::from(sub) - 1].to_le_bytes());
                Ok(2)
            }
            (0x6411, 1..=2) => {
                let v = self.ao_written.unwrap_or(self.ao)[usize::from(sub) - 1];
                buf[..2].copy_from_slice(&v.to_le_bytes());
                Ok(2)
            }
            _ => self.store.read(index, sub, buf),
        }
    }

    fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        if let Some(m) = self.map(index) {
            return m.write_sub(sub, data, &OD, 256);
        }
        match (index, sub) {
            (0x6411, 1..=2) => {
                let mut v = self.ao_written.unwrap_or(self.ao);
                v[usize::from(sub) - 1] = i16::from_le_bytes([data[0], data[1]]);
                self.ao_written = Some(v);
                Ok(())
            }
            _ => self.store.write(index, sub, data, state),
        }
    }
}

impl CanApplication for Device {
    fn can_owns_outputs(&self) -> bool {
        self.owner
    }
    fn apply_outputs(&mut self) {
        if let Some(v) = self.ao_written.take() {
            self.ao = v;
            self.applied.push(v);
        }
    }
    fn outputs_fault(&mut self) {
        self.faults += 1;
    }
    fn change_of_state(&self) -> bool {
        self.change_of_state
    }
    fn raise_error(&mut self, bits: u8, code: u16, data: [u8; 5]) -> EmergencyRepr {
        self.register |= bits | 1;
        EmergencyRepr {
            error_code: code,
            error_register: self.register,
            data,
        }
    }
    fn clear_error(&mut self, bits: u8) -> Option<EmergencyRepr> {
        self.register &= !bits;
        if self.register & !1 == 0 {
            self.register = 0;
            return Some(EmergencyRepr::default());
        }
        None
    }
    fn reset(&mut self, application: bool) {
        self.resets.push(application);
        self.maps = default_mappings();
    }
}

type Node = CanNode<2, 3, 2, 4, 64>;

/// A node, its device and the virtual time.
struct Bench {
    node: Node,
    dev: Device,
    now: u64,
}

impl Bench {
    /// Powered up and booted; the boot-up message taken.
    fn new() -> Self {
        let mut b = Self {
            node: Node::new(NODE, &OD, &DEFAULTS),
            dev: Device::new(),
            now: 0,
        };
        b.node.poll(&mut b.dev, 0);
        assert_eq!(b.take(), vec![frame(0x705, &[0x00])], "boot-up");
        b
    }

    fn rx(&mut self, f: CanFrame) -> Vec<CanFrame> {
        self.node.receive(&f, &mut self.dev, self.now);
        self.node.poll(&mut self.dev, self.now);
        self.take()
    }

    /// The frames to send, taken while `has_tx` says there are (checked against `pop_tx`).
    fn take(&mut self) -> Vec<CanFrame> {
        let mut out = Vec::new();
        while self.node.has_tx() {
            out.push(self.node.pop_tx().expect("has_tx: a frame waits"));
        }
        assert_eq!(self.node.pop_tx(), None, "has_tx false: nothing waits");
        out
    }

    /// Advances the time to `t`, polling at every deadline on the way; the frames sent.
    fn run_until(&mut self, t: u64) -> Vec<(u64, CanFrame)> {
        let mut out = Vec::new();
        loop {
            let next = self.node.next_deadline_us().filter(|d| *d <= t);
            self.now = next.unwrap_or(t).max(self.now);
            self.node.poll(&mut self.dev, self.now);
            out.extend(self.take().into_iter().map(|f| (self.now, f)));
            if next.is_none() {
                return out;
            }
            let after = self.node.next_deadline_us();
            assert!(
                after.is_none_or(|d| d > self.now),
                "a poll at {} left the deadline at {after:?}",
                self.now
            );
        }
    }

    fn nmt(&mut self, cs: u8, node: u8) -> Vec<CanFrame> {
        self.rx(frame(0x000, &[cs, node]))
    }

    fn sdo(&mut self, req: [u8; 8]) -> [u8; 8] {
        let out = self.rx(frame(0x605, &req));
        assert_eq!(out.len(), 1, "one SDO answer: {out:?}");
        assert_eq!(out[0].id(), 0x585);
        out[0].data().try_into().unwrap()
    }

    fn download(&mut self, index: u16, sub: u8, value: &[u8]) -> Result<(), u32> {
        let n = value.len() as u8;
        let mut req = [
            0x23 | ((4 - n) << 2),
            index as u8,
            (index >> 8) as u8,
            sub,
            0,
            0,
            0,
            0,
        ];
        req[4..4 + value.len()].copy_from_slice(value);
        let a = self.sdo(req);
        match a[0] {
            0x60 => Ok(()),
            0x80 => Err(u32::from_le_bytes(a[4..].try_into().unwrap())),
            other => panic!("unexpected SDO answer {other:#x}"),
        }
    }

    fn upload(&mut self, index: u16, sub: u8) -> Result<u32, u32> {
        let a = self.sdo([0x40, index as u8, (index >> 8) as u8, sub, 0, 0, 0, 0]);
        match a[0] {
            0x80 => Err(u32::from_le_bytes(a[4..].try_into().unwrap())),
            c if c & 0xE3 == 0x43 => Ok(u32::from_le_bytes(a[4..].try_into().unwrap())),
            other => panic!("unexpected SDO answer {other:#x}"),
        }
    }
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::new(id, data).unwrap()
}

fn code(c: SdoAbortCode) -> u32 {
    u32::from(c)
}

fn emcy_of(f: &CanFrame) -> (u16, u8, u8) {
    let d = f.data();
    (u16::from_le_bytes([d[0], d[1]]), d[2], d[3])
}

#[test]
fn nmt_commands_for_this_node_and_for_all() {
    let mut b = Bench::new();
    assert_eq!(b.node.state(), NmtState::PreOperational);
    b.nmt(0x01, 6);
    assert_eq!(
        b.node.state(),
        NmtState::PreOperational,
        "another node's command"
    );
    b.nmt(0x01, NODE);
    assert_eq!(b.node.state(), NmtState::Operational);
    b.nmt(0x02, 0);
    assert_eq!(b.node.state(), NmtState::Stopped);
    b.nmt(0x80, 0);
    assert_eq!(b.node.state(), NmtState::PreOperational);
    // A malformed NMT frame changes nothing.
    b.rx(frame(0x000, &[0x01]));
    assert_eq!(b.node.state(), NmtState::PreOperational);
}

#[test]
fn resets_restore_the_parameters_and_boot_again() {
    let mut b = Bench::new();
    b.download(0x1017, 0, &500u16.to_le_bytes()).unwrap();
    b.download(0x1A00, 0, &[0]).unwrap();
    assert_eq!(b.upload(0x1017, 0), Ok(500));
    b.nmt(0x01, NODE);
    let out = b.nmt(0x82, NODE);
    assert_eq!(
        out,
        vec![frame(0x705, &[0])],
        "boot-up after reset communication"
    );
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(b.upload(0x1017, 0), Ok(0));
    assert_eq!(
        b.upload(0x1A00, 0),
        Ok(8),
        "the application restored its mappings"
    );
    assert_eq!(b.dev.resets, vec![false]);
    assert_eq!(
        b.dev.faults, 1,
        "left operational: outputs to their fault values"
    );
    b.nmt(0x81, 0);
    assert_eq!(b.dev.resets, vec![false, true]);
}

#[test]
fn heartbeat_producer_timing_and_state_changes() {
    let mut b = Bench::new();
    b.download(0x1017, 0, &100u16.to_le_bytes()).unwrap();
    let beats = b.run_until(350 * MS);
    let times: Vec<u64> = beats.iter().map(|(t, _)| *t).collect();
    assert_eq!(times, vec![100 * MS, 200 * MS, 300 * MS]);
    assert!(beats
        .iter()
        .all(|(_, f)| f.id() == 0x705 && f.data() == [0x7F]));
    // A state change is reported at once and restarts the cycle (the event-driven TPDOs
    // also go out once on entering operational).
    let out = b.nmt(0x01, NODE);
    let beats: Vec<_> = out.iter().filter(|f| f.id() == 0x705).collect();
    assert_eq!(beats, vec![&frame(0x705, &[0x05])]);
    let beats = b.run_until(b.now + 100 * MS);
    assert_eq!(beats, vec![(b.now, frame(0x705, &[0x05]))]);
}

#[test]
fn node_guarding_and_life_guarding() {
    let mut b = Bench::new();
    b.download(0x100C, 0, &100u16.to_le_bytes()).unwrap();
    b.download(0x100D, 0, &[3]).unwrap();
    let guard = CanFrame::remote(0x705, 1).unwrap();
    assert_eq!(b.rx(guard), vec![frame(0x705, &[0x7F])]);
    assert_eq!(b.rx(guard), vec![frame(0x705, &[0xFF])], "toggle");
    b.nmt(0x01, NODE);
    b.now = 50 * MS;
    assert_eq!(b.rx(guard), vec![frame(0x705, &[0x05])]);
    // No guard request for 300 ms: life guarding event, 0x1029 = 0 -> pre-operational.
    let out = b.run_until(400 * MS);
    let emcy: Vec<_> = out.iter().filter(|(_, f)| f.id() == 0x85).collect();
    assert_eq!(emcy.len(), 1, "{out:?}");
    assert_eq!(emcy[0].0, 350 * MS);
    assert_eq!(emcy_of(&emcy[0].1), (emcy_code::HEARTBEAT, 0x11, 0));
    assert_eq!(b.node.state(), NmtState::PreOperational);
    assert_eq!(
        b.dev.faults, 2,
        "fault on the loss and on leaving operational"
    );
    // Guarding again clears the error (the EMCY has the higher priority).
    let out = b.rx(guard);
    assert_eq!(out[0].id(), 0x85);
    assert_eq!(emcy_of(&out[0]), (0x0000, 0x00, 0), "error reset");
    assert_eq!(out[1], frame(0x705, &[0xFF]));
    // With a heartbeat producer time, node guarding is off.
    b.download(0x1017, 0, &1000u16.to_le_bytes()).unwrap();
    assert_eq!(b.rx(guard), vec![]);
}

#[test]
fn heartbeat_consumer_loss_applies_error_behaviour() {
    let mut b = Bench::new();
    b.download(0x1016, 1, &0x0003_0064u32.to_le_bytes())
        .unwrap();
    assert_eq!(
        b.download(0x1016, 2, &0x0003_00C8u32.to_le_bytes()),
        Err(code(SdoAbortCode::ParameterIncompatible))
    );
    b.nmt(0x01, NODE);
    assert!(
        b.run_until(500 * MS).is_empty(),
        "not monitored before the first heartbeat"
    );
    b.rx(frame(0x703, &[0x05]));
    // 0x1029:01 = 0: the loss takes the node to pre-operational.
    let out = b.run_until(b.now + 101 * MS);
    assert_eq!(out.len(), 1, "{out:?}");
    assert_eq!(out[0].0, 600 * MS);
    assert_eq!(emcy_of(&out[0].1), (emcy_code::HEARTBEAT, 0x11, 3));
    assert_eq!(b.node.state(), NmtState::PreOperational);
    let out = b.rx(frame(0x703, &[0x05]));
    assert_eq!(emcy_of(&out[0]), (0, 0, 0), "heard again: error reset");
    // 0x1029:01 = 2: stopped, where no SDO is served and EMCY waits.
    b.download(0x1029, 1, &[2]).unwrap();
    b.nmt(0x01, NODE);
    let faults = b.dev.faults;
    assert!(b.run_until(b.now + 101 * MS).is_empty());
    assert_eq!(b.node.state(), NmtState::Stopped);
    assert_eq!(
        b.dev.faults,
        faults + 2,
        "on the loss and on leaving operational"
    );
    assert!(b
        .rx(frame(0x605, &[0x40, 0, 0x10, 0, 0, 0, 0, 0]))
        .is_empty());
    b.rx(frame(0x703, &[0x05]));
    let mut out = b.nmt(0x80, NODE);
    out.extend(b.run_until(b.now).into_iter().map(|(_, f)| f));
    let emcy: Vec<_> = out.iter().map(emcy_of).collect();
    assert_eq!(
        emcy,
        vec![(emcy_code::HEARTBEAT, 0x11, 3), (0, 0, 0)],
        "sent in pre-operational"
    );
}

#[test]
fn sdo_over_can_shares_the_dictionary_and_access_rules() {
    let mut b = Bench::new();
    assert_eq!(b.upload(0x1000, 0), Ok(0x000C_0191));
    assert_eq!(b.upload(0x1200, 1), Ok(0x605));
    assert_eq!(b.upload(0x1801, 1), Ok(0x4000_0285));
    assert_eq!(b.upload(0x6401, 3), Ok(300));
    assert_eq!(
        b.upload(0x1234, 0),
        Err(code(SdoAbortCode::ObjectDoesNotExist))
    );
    assert_eq!(
        b.upload(0x6401, 9),
        Err(code(SdoAbortCode::SubindexDoesNotExist))
    );
    assert_eq!(
        b.download(0x1000, 0, &[1, 2, 3, 4]),
        Err(code(SdoAbortCode::WriteOfReadOnly))
    );
    assert_eq!(
        b.download(0x1017, 0, &[1]),
        Err(code(SdoAbortCode::LengthTooLow))
    );
    // Segmented upload of the device name: size, then 7-byte segments.
    let a = b.sdo([0x40, 0x08, 0x10, 0, 0, 0, 0, 0]);
    assert_eq!(a, [0x41, 0x08, 0x10, 0, 17, 0, 0, 0]);
    assert_eq!(&b.sdo([0x60, 0, 0, 0, 0, 0, 0, 0])[1..], b"Analog ");
    // Block transfer (ccs 5 upload, 6 download) is not served: abort 0x05040001.
    let [a0, a1, a2, a3] = 0x0504_0001u32.to_le_bytes();
    for request in [
        [0xA4, 0x08, 0x10, 0, 7, 0, 0, 0],
        [0xC6, 0x17, 0x10, 0, 2, 0, 0, 0],
    ] {
        assert_eq!(
            b.sdo(request),
            [0x80, request[1], request[2], 0, a0, a1, a2, a3]
        );
    }
    // Mappings are writable in pre-operational only.
    b.nmt(0x01, NODE);
    assert_eq!(
        b.download(0x1A01, 0, &[0]),
        Err(code(SdoAbortCode::DeviceState))
    );
    // In operational an RPDO-mapped output cannot be written by SDO.
    assert_eq!(
        b.download(0x6411, 1, &5i16.to_le_bytes()),
        Err(code(SdoAbortCode::MappedToRxPdo))
    );
}

#[test]
fn remapping_in_pre_operational_and_the_mapping_lock() {
    let mut b = Bench::new();
    // TPDO 2 is valid and CAN owns the outputs: its mapping is locked.
    assert_eq!(
        b.download(0x1A01, 0, &[0]),
        Err(code(SdoAbortCode::UnsupportedAccess))
    );
    // The CiA 301 sequence.
    b.download(0x1801, 1, &0x8000_0285u32.to_le_bytes())
        .unwrap();
    b.download(0x1A01, 0, &[0]).unwrap();
    b.download(0x1A01, 1, &0x6401_0810u32.to_le_bytes())
        .unwrap();
    b.download(0x1A01, 2, &0x6401_0110u32.to_le_bytes())
        .unwrap();
    assert_eq!(
        b.download(0x1A01, 3, &0x6411_0110u32.to_le_bytes()),
        Err(code(SdoAbortCode::CannotBeMapped)),
        "an output cannot go into a TPDO"
    );
    b.download(0x1A01, 0, &[2]).unwrap();
    b.download(0x1801, 2, &[1]).unwrap();
    b.download(0x1801, 1, &0x285u32.to_le_bytes()).unwrap();
    b.nmt(0x01, NODE);
    let out = b.rx(frame(0x080, &[]));
    assert_eq!(
        out,
        vec![frame(0x285, &[0x20, 0x03, 0x64, 0x00])],
        "AI 8, AI 1"
    );
    // Not the owner: the mapping follows the other fieldbus's rules only.
    b.nmt(0x80, NODE);
    b.dev.owner = false;
    assert_eq!(b.download(0x1A01, 0, &[0]), Ok(()));
    // A valid TPDO of more than 64 bits is refused.
    b.download(0x1800, 2, &[1]).unwrap();
    assert_eq!(
        b.download(0x1800, 1, &0x185u32.to_le_bytes()),
        Err(code(SdoAbortCode::PdoLengthExceeded))
    );
}

#[test]
fn synchronous_tpdos_carry_the_inputs() {
    let mut b = Bench::new();
    b.download(0x1801, 2, &[1]).unwrap();
    b.download(0x1802, 2, &[2]).unwrap();
    assert!(
        b.rx(frame(0x080, &[])).is_empty(),
        "no PDOs in pre-operational"
    );
    b.nmt(0x01, NODE);
    let ai = |v: &[i16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let out = b.rx(frame(0x080, &[]));
    assert_eq!(out, vec![frame(0x285, &ai(&[100, 200, 300, 400]))]);
    b.dev.ai[0] = -5;
    let out = b.rx(frame(0x080, &[]));
    assert_eq!(
        out,
        vec![
            frame(0x285, &ai(&[-5, 200, 300, 400])),
            frame(0x385, &ai(&[500, 600, 700, 800]))
        ],
        "type 2 every second SYNC, lowest identifier first"
    );
    assert_eq!(b.node.stats().syncs, 2);
    // A SYNC with a counter while 0x1019 is 0 is refused and reported.
    let out = b.rx(frame(0x080, &[1]));
    assert_eq!(out.len(), 1);
    assert_eq!(emcy_of(&out[0]).0, emcy_code::SYNC_LENGTH);
}

/// A caller with a deadline runs the PDO work in steps of one layout or one TPDO each:
/// an NMT start reads one RPDO layout per step, a SYNC queues its TPDOs, each sent in two
/// steps (its layout, then its data), lowest first; a stop drops what is left.
#[test]
fn pdo_work_runs_in_bounded_steps() {
    let mut b = Bench::new();
    b.download(0x1801, 2, &[1]).unwrap();
    b.download(0x1802, 2, &[1]).unwrap();
    let now = b.now;
    let step = |b: &mut Bench| b.node.step(&mut b.dev, now);
    b.node
        .receive(&frame(0x000, &[0x01, NODE]), &mut b.dev, now);
    assert_eq!(b.node.state(), NmtState::Operational);
    // One RPDO layout read per step (two RPDOs).
    assert!(b.node.has_steps());
    assert!(step(&mut b) && step(&mut b));
    assert!(!b.node.has_steps() && !step(&mut b));
    b.take();
    b.node.receive(&frame(0x080, &[]), &mut b.dev, now);
    assert!(b.take().is_empty(), "the SYNC only queues the TPDOs");
    let ai = |v: &[i16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    assert!(step(&mut b) && b.take().is_empty(), "TPDO 2's layout");
    assert!(step(&mut b));
    assert_eq!(b.take(), vec![frame(0x285, &ai(&[100, 200, 300, 400]))]);
    assert!(step(&mut b) && step(&mut b));
    assert_eq!(b.take(), vec![frame(0x385, &ai(&[500, 600, 700, 800]))]);
    assert!(!b.node.has_steps());
    // Stopped between the steps: nothing goes out.
    b.node.receive(&frame(0x080, &[]), &mut b.dev, now);
    assert!(step(&mut b));
    b.node
        .receive(&frame(0x000, &[0x02, NODE]), &mut b.dev, now);
    assert!(!step(&mut b) && !b.node.has_steps());
    assert!(b.take().iter().all(|f| f.id() != 0x285 && f.id() != 0x385));
}

#[test]
fn event_driven_tpdos_with_timer_inhibit_and_change_of_state() {
    let mut b = Bench::new();
    b.download(0x1801, 5, &10u16.to_le_bytes()).unwrap();
    b.download(0x1802, 1, &0x8000_0385u32.to_le_bytes())
        .unwrap();
    b.download(0x1802, 3, &50u16.to_le_bytes()).unwrap();
    b.download(0x1802, 1, &0x385u32.to_le_bytes()).unwrap();
    // Both go out once when the node becomes operational, then TPDO 2 every 10 ms.
    let t0 = b.now;
    let ids: Vec<u16> = b.nmt(0x01, NODE).iter().map(|f| f.id()).collect();
    assert_eq!(ids, vec![0x285, 0x385]);
    let out = b.run_until(t0 + 35 * MS);
    let ids: Vec<(u64, u16)> = out.iter().map(|(t, f)| (*t, f.id())).collect();
    assert_eq!(
        ids,
        vec![
            (t0 + 10 * MS, 0x285),
            (t0 + 20 * MS, 0x285),
            (t0 + 30 * MS, 0x285)
        ]
    );
    // Change of state (CiA 401 0x6423): TPDO 3 goes out on change, 5 ms apart at most.
    b.dev.change_of_state = true;
    b.dev.ai[4] = 1;
    let out = b.run_until(b.now + 1);
    assert!(out.iter().any(|(_, f)| f.id() == 0x385), "{out:?}");
    let sent_at = out.iter().find(|(_, f)| f.id() == 0x385).unwrap().0;
    b.dev.ai[4] = 2;
    let out = b.run_until(sent_at + 6 * MS);
    let t3: Vec<u64> = out
        .iter()
        .filter(|(_, f)| f.id() == 0x385)
        .map(|(t, _)| *t)
        .collect();
    assert_eq!(t3, vec![sent_at + 5 * MS], "inhibit time");
}

#[test]
fn rpdos_drive_the_outputs_only_when_can_owns_them() {
    let mut b = Bench::new();
    b.nmt(0x01, NODE);
    b.rx(frame(0x305, &[0x00, 0x10, 0x00, 0x20]));
    assert_eq!(b.dev.applied, vec![[0x1000, 0x2000]]);
    // Too short: not used, reported; too long: used, reported.
    let out = b.rx(frame(0x305, &[1, 2, 3]));
    assert_eq!(emcy_of(&out[0]).0, emcy_code::PDO_LENGTH);
    assert_eq!(b.dev.applied.len(), 1);
    b.rx(frame(0x305, &[1, 0, 2, 0, 9]));
    assert_eq!(b.dev.applied.last(), Some(&[1, 2]));
    // RPDO 1 is not valid by default: nothing.
    b.rx(frame(0x205, &[9, 9, 9, 9]));
    assert_eq!(b.dev.applied.len(), 2);
    // Not the owner: dropped and counted.
    b.dev.owner = false;
    b.rx(frame(0x305, &[7, 0, 7, 0]));
    assert_eq!(b.dev.applied.len(), 2);
    assert_eq!(b.node.stats().rpdo_not_owner, 1);
}

#[test]
fn synchronous_rpdo_waits_for_the_sync_and_deadline_monitoring() {
    let mut b = Bench::new();
    b.download(0x1401, 2, &[1]).unwrap();
    b.download(0x1401, 5, &[50, 0]).unwrap();
    b.nmt(0x01, NODE);
    b.rx(frame(0x305, &[5, 0, 6, 0]));
    assert!(b.dev.applied.is_empty(), "waits for the SYNC");
    b.rx(frame(0x080, &[]));
    assert_eq!(b.dev.applied, vec![[5, 6]]);
    let faults = b.dev.faults;
    let out = b.run_until(b.now + 51 * MS);
    assert_eq!(out.len(), 1, "{out:?}");
    assert_eq!(emcy_of(&out[0].1), (emcy_code::RPDO_TIMEOUT, 0x11, 2));
    assert_eq!(b.dev.faults, faults + 1, "deadline: fault values");
}

#[test]
fn sync_timeout_is_reported_once() {
    let mut b = Bench::new();
    b.download(0x1006, 0, &10_000u32.to_le_bytes()).unwrap();
    assert_eq!(
        b.download(0x1019, 0, &[4]),
        Err(code(SdoAbortCode::DeviceState))
    );
    b.nmt(0x01, NODE);
    b.rx(frame(0x080, &[]));
    let out = b.run_until(b.now + 100 * MS);
    assert_eq!(out.len(), 1);
    assert_eq!(emcy_of(&out[0].1).0, emcy_code::SYNC_TIMEOUT);
    let out = b.rx(frame(0x080, &[]));
    assert_eq!(emcy_of(&out[0]), (0, 0, 0), "SYNC back: error reset");
}

#[test]
fn application_emergencies_go_out_with_the_inhibit_time() {
    let mut b = Bench::new();
    b.download(0x1015, 0, &100u16.to_le_bytes()).unwrap(); // 10 ms
    let e = |c| EmergencyRepr {
        error_code: c,
        error_register: 0x11,
        data: [0; 5],
    };
    b.node.queue_emergency(e(0x8250));
    b.node.queue_emergency(e(0xFF01));
    let out = b.run_until(b.now + 20 * MS);
    let t: Vec<u64> = out.iter().map(|(t, _)| *t - out[0].0).collect();
    assert_eq!(t, vec![0, 10 * MS]);
    assert_eq!(emcy_of(&out[1].1).0, 0xFF01);
    // Disabled EMCY (bit 31): nothing goes out.
    b.download(0x1014, 0, &0x8000_0085u32.to_le_bytes())
        .unwrap();
    b.node.queue_emergency(e(1));
    assert!(b.run_until(b.now + 100 * MS).is_empty());
}

#[test]
fn outbox_sends_lowest_identifier_first_and_equal_ones_in_order() {
    let mut b = Bench::new();
    let upload = |index: u16| {
        let [lo, hi] = index.to_le_bytes();
        frame(0x605, &[0x40, lo, hi, 0, 0, 0, 0, 0])
    };
    // Several rounds, so the queueing numbers pass slots freed in between.
    for _ in 0..5 {
        for index in [0x1000u16, 0x1017, 0x1014, 0x1001] {
            b.node.receive(&upload(index), &mut b.dev, b.now);
        }
        b.node.queue_emergency(EmergencyRepr {
            error_code: 0xFF01,
            error_register: 0x81,
            data: [0; 5],
        });
        b.node.poll(&mut b.dev, b.now);
        let out = b.take();
        let ids: Vec<u16> = out.iter().map(|f| f.id()).collect();
        assert_eq!(ids, vec![0x85, 0x585, 0x585, 0x585, 0x585]);
        let indices: Vec<u16> = out[1..]
            .iter()
            .map(|f| u16::from_le_bytes([f.data()[1], f.data()[2]]))
            .collect();
        assert_eq!(indices, vec![0x1000, 0x1017, 0x1014, 0x1001]);
        b.now += 20 * MS;
    }
}

#[test]
fn another_transport_sees_the_can_objects() {
    let mut b = Bench::new();
    let mut access = b.node.access(&mut b.dev, 0);
    let mut buf = [0u8; 8];
    assert_eq!(access.read(0x1014, 0, &mut buf), Ok(4));
    assert_eq!(u32::from_le_bytes(buf[..4].try_into().unwrap()), 0x85);
    assert_eq!(
        access.write(0x1017, 0, &250u16.to_le_bytes(), AlState::PreOp),
        Ok(())
    );
    // The EtherCAT side's RxPDO rule, not CAN's, for is_rx_mapped.
    assert!(!access.is_rx_mapped(0x6411, 1));
    assert_eq!(access.read(0x1000, 0, &mut buf), Ok(4));
    assert_eq!(b.node.params().heartbeat_ms, 250);
    assert_eq!(ERR_COMMUNICATION, 0x10);
    assert_eq!(cob::SDO_RX, 0x600);
}

mod random {
    use super::*;
    use proptest::prelude::*;

    fn any_frame() -> impl Strategy<Value = CanFrame> {
        // Identifiers around this node's COB-IDs, plus any identifier.
        let id = prop_oneof![
            Just(0x000u16),
            Just(0x080),
            Just(0x305),
            Just(0x605),
            Just(0x705),
            Just(0x703),
            0u16..0x800,
        ];
        (
            id,
            any::<bool>(),
            proptest::collection::vec(any::<u8>(), 0..=8),
        )
            .prop_map(|(id, rtr, data)| {
                if rtr {
                    CanFrame::remote(id, data.len() as u8).unwrap()
                } else {
                    CanFrame::new(id, &data).unwrap()
                }
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Any frames at any times: no panic, the outbox never grows past its size, and a
        /// poll always moves the next deadline past the time it ran at.
        #[test]
        fn random_traffic_never_panics(
            steps in proptest::collection::vec((any_frame(), 0u64..50_000), 1..200),
            owner in any::<bool>(),
        ) {
            let mut b = Bench::new();
            b.dev.owner = owner;
            for (f, dt) in steps {
                b.now += dt;
                b.node.receive(&f, &mut b.dev, b.now);
                b.node.poll(&mut b.dev, b.now);
                prop_assert!(b.node.pending_tx() <= coe_core::canopen::node::OUTBOX);
                prop_assert!(b.node.next_deadline_us().is_none_or(|d| d > b.now));
                b.take();
            }
        }

        /// The SDO server's millisecond clock from 32-bit divisions is the 64-bit one's.
        #[test]
        fn wrapping_ms_is_the_division(us in any::<u64>()) {
            prop_assert_eq!(coe_core::canopen::node::wrapping_ms(us), (us / 1000) as u32);
        }
    }
}
