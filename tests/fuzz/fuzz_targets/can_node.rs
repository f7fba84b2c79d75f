//! Fuzz target: any frames from the bus into coe-core's CANopen node (the one the firmware
//! runs), on a small device with mappable inputs and outputs, never panic; every frame it
//! sends is its own (boot-up/heartbeat/guarding answer, SDO answer, EMCY, a TPDO) and an SDO
//! answer is 8 bytes.
//!
//! Input: see `can_stream.rs`. Run: `cargo xtask fuzz --target can_node`.
#![no_main]

#[path = "can_stream.rs"]
mod can_stream;

use coe_core::canopen::node::{CanApplication, CanNode};
use coe_core::canopen::objects::CommObjects;
use coe_core::canopen::params::{CommDefaults, PdoDefault};
use coe_core::esm::AlState;
use coe_core::od::{
    Access, DataType, EntryDesc, ObjectAccess, ObjectDesc, ObjectDictionary, OdStore, Value,
};
use coe_core::pdo::{PdoEntry, PdoMapping};
use coe_core::wire::EmergencyRepr;
use coe_core::SdoAbortCode;
use libfuzzer_sys::fuzz_target;

const NODE: u8 = 5;

static DEFAULTS: CommDefaults<2, 2> = CommDefaults {
    rpdo: [
        PdoDefault::new(0x200, true, 1),
        PdoDefault::new(0x300, false, 255),
    ],
    tpdo: [
        PdoDefault::new(0x180, true, 1),
        PdoDefault::new(0x280, true, 255),
    ],
    heartbeat_ms: 20,
    guard_time_ms: 0,
    life_factor: 0,
    emcy_inhibit_100us: 10,
    error_behaviour: 0,
};

static CAN: CommObjects<2, 2, 3> = CommObjects::new(&DEFAULTS);

const fn mapping_entries() -> [EntryDesc; 5] {
    let names = ["Entry 1", "Entry 2", "Entry 3", "Entry 4"];
    let mut e = [EntryDesc::count(0).with_access(Access::RW_PREOP); 5];
    let mut i = 1;
    while i < 5 {
        e[i] = EntryDesc::new(
            i as u8,
            names[i - 1],
            DataType::Unsigned32,
            Access::RW_PREOP,
        );
        i += 1;
    }
    e
}
static MAP: [EntryDesc; 5] = mapping_entries();

static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[
            EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x000F_0191)),
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
        &[EntryDesc::string(
            0,
            "Device name",
            "A node name long enough to be segmented",
        )],
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
    ObjectDesc::record(0x1A00, "TPDO 1 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1A01, "TPDO 2 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::array(
        0x6000,
        "Inputs",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "In 1", DataType::Unsigned16, Access::RO.tx_mappable()),
            EntryDesc::new(2, "In 2", DataType::Unsigned16, Access::RO.tx_mappable()),
        ],
    ),
    ObjectDesc::array(
        0x6200,
        "Outputs",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Out 1", DataType::Unsigned16, Access::RW.rx_mappable()),
            EntryDesc::new(2, "Out 2", DataType::Unsigned16, Access::RW.rx_mappable()),
        ],
    ),
]);

const MAPPINGS: [u16; 4] = [0x1600, 0x1601, 0x1A00, 0x1A01];

fn mappings() -> [PdoMapping<4>; 4] {
    let out = [PdoEntry::new(0x6200, 1, 16), PdoEntry::new(0x6200, 2, 16)];
    let inp = [PdoEntry::new(0x6000, 1, 16), PdoEntry::new(0x6000, 2, 16)];
    [
        PdoMapping::with_entries(0x1600, &out),
        PdoMapping::with_entries(0x1601, &out[..1]),
        PdoMapping::with_entries(0x1A00, &inp),
        PdoMapping::with_entries(0x1A01, &inp[..1]),
    ]
}

struct Device {
    store: OdStore<512>,
    maps: [PdoMapping<4>; 4],
    register: u8,
}

impl ObjectAccess for Device {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        match MAPPINGS.iter().position(|i| *i == index) {
            Some(i) => self.maps[i].read_sub(sub, buf),
            None => self.store.read(index, sub, buf),
        }
    }

    fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        match MAPPINGS.iter().position(|i| *i == index) {
            Some(i) => self.maps[i].write_sub(sub, data, &OD, 64),
            None => self.store.write(index, sub, data, state),
        }
    }
}

impl CanApplication for Device {
    fn can_owns_outputs(&self) -> bool {
        true
    }
    fn apply_outputs(&mut self) {}
    fn outputs_fault(&mut self) {}
    fn change_of_state(&self) -> bool {
        true
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
        (self.register & !1 == 0).then(|| {
            self.register = 0;
            EmergencyRepr::default()
        })
    }
    fn reset(&mut self, _application: bool) {
        self.maps = mappings();
    }
}

fuzz_target!(|data: &[u8]| {
    let Ok(store) = OdStore::new(OD) else {
        panic!("the dictionary fits");
    };
    let mut dev = Device {
        store,
        maps: mappings(),
        register: 0,
    };
    let mut node = CanNode::<2, 2, 2, 4, 64>::new(NODE, &OD, &DEFAULTS);
    node.poll(&mut dev, 0);
    let own = |id: u16| {
        [0x085, 0x185, 0x285, 0x585, 0x705].contains(&id)
            || !coe_core::canopen::frame::is_restricted_id(id)
    };
    for (now, frame) in can_stream::frames(data) {
        node.receive(&frame, &mut dev, now);
        node.poll(&mut dev, now);
        if let Some(t) = node.next_deadline_us() {
            node.poll(&mut dev, t.max(now));
        }
        while let Some(f) = node.pop_tx() {
            assert!(own(f.id()), "the node sent {f:?}");
            if f.id() == 0x585 {
                assert_eq!(f.data().len(), 8, "SDO answers are 8 bytes");
            }
        }
    }
});
