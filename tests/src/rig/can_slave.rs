//! A CANopen slave in process: coe-core's [`CanNode`] (the project's own CAN node, the one
//! the firmware runs) on a small device with two faces, on its own port of a [`CanBus`]:
//! - a generic I/O module (seed 002): 16 input bytes at 0x2000 and 16 output bytes at
//!   0x2100, mappable;
//! - a CiA 402-like servo axis (seed 001): controlword 0x6040 and target position 0x607A in,
//!   statusword 0x6041 and position actual 0x6064 out. The drive is ideal: the position
//!   follows the target applied at each SYNC, the statusword follows the controlword
//!   through the CiA 402 states shutdown -> switched on -> operation enabled.
//!
//! Every PDO parameter starts not valid: the master configures what runs. The slave's
//! identity (0x1000, 0x1018) is per instance, so the master's identity check can fail.
//! Its clock is the bus's; it handles a frame at the time the frame ends on the bus.

use crate::models::can::{CanBus, PortId};
use coe_core::canopen::node::{CanApplication, CanNode};
use coe_core::canopen::objects::CommObjects;
use coe_core::canopen::params::{CommDefaults, PdoDefault};
use coe_core::canopen::{CanFrame, NmtState};
use coe_core::esm::AlState;
use coe_core::od::{
    Access, DataType, EntryDesc, ObjectAccess, ObjectDesc, ObjectDictionary, OdStore, Value,
};
use coe_core::pdo::PdoMapping;
use coe_core::wire::EmergencyRepr;
use coe_core::SdoAbortCode;

/// The node type: 4 RPDOs, 4 TPDOs, one heartbeat consumer, 4 queued Emergencies, 64-byte
/// SDO transfers.
pub type SlaveNode = CanNode<4, 4, 2, 4, 64>;

static DEFAULTS: CommDefaults<4, 4> = CommDefaults {
    rpdo: [
        PdoDefault::new(0x200, false, 255),
        PdoDefault::new(0x300, false, 255),
        PdoDefault::new(0x400, false, 255),
        PdoDefault::new(0x500, false, 255),
    ],
    tpdo: [
        PdoDefault::new(0x180, false, 255),
        PdoDefault::new(0x280, false, 255),
        PdoDefault::new(0x380, false, 255),
        PdoDefault::new(0x480, false, 255),
    ],
    heartbeat_ms: 0,
    guard_time_ms: 0,
    life_factor: 0,
    emcy_inhibit_100us: 0,
    error_behaviour: 1,
};

static CAN: CommObjects<4, 4, 2> = CommObjects::new(&DEFAULTS);

const RWP: Access = Access::RW_PREOP;

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

const fn bytes(access: Access) -> [EntryDesc; 17] {
    let names = [
        "Byte 1", "Byte 2", "Byte 3", "Byte 4", "Byte 5", "Byte 6", "Byte 7", "Byte 8", "Byte 9",
        "Byte 10", "Byte 11", "Byte 12", "Byte 13", "Byte 14", "Byte 15", "Byte 16",
    ];
    let mut e = [EntryDesc::count(16); 17];
    let mut i = 1;
    while i < 17 {
        e[i] = EntryDesc::new(i as u8, names[i - 1], DataType::Unsigned8, access);
        i += 1;
    }
    e
}
static INPUTS: [EntryDesc; 17] = bytes(Access::RO.tx_mappable());
static OUTPUTS: [EntryDesc; 17] = bytes(Access::RW.rx_mappable());

static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[EntryDesc::new(
            0,
            "Device type",
            DataType::Unsigned32,
            Access::RO,
        )],
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
    CAN.guard_time(),
    CAN.life_factor(),
    CAN.emcy_cob_id(),
    CAN.emcy_inhibit(),
    CAN.consumers(),
    CAN.producer(),
    ObjectDesc::record(
        0x1018,
        "Identity",
        DataType::Identity,
        &[
            EntryDesc::count(4),
            EntryDesc::new(1, "Vendor-ID", DataType::Unsigned32, Access::RO),
            EntryDesc::new(2, "Product code", DataType::Unsigned32, Access::RO),
            EntryDesc::new(3, "Revision number", DataType::Unsigned32, Access::RO),
            EntryDesc::new(4, "Serial number", DataType::Unsigned32, Access::RO),
        ],
    ),
    CAN.sync_overflow(),
    CAN.error_behaviour(),
    CAN.sdo_server(),
    CAN.rpdo(0),
    CAN.rpdo(1),
    CAN.rpdo(2),
    CAN.rpdo(3),
    ObjectDesc::record(0x1600, "RPDO 1 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1601, "RPDO 2 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1602, "RPDO 3 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1603, "RPDO 4 mapping", DataType::PdoMapping, &MAP),
    CAN.tpdo(0),
    CAN.tpdo(1),
    CAN.tpdo(2),
    CAN.tpdo(3),
    ObjectDesc::record(0x1A00, "TPDO 1 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1A01, "TPDO 2 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1A02, "TPDO 3 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::record(0x1A03, "TPDO 4 mapping", DataType::PdoMapping, &MAP),
    ObjectDesc::array(0x2000, "Inputs", &INPUTS),
    ObjectDesc::array(0x2100, "Outputs", &OUTPUTS),
    ObjectDesc::var(
        0x6040,
        "Controlword",
        &[EntryDesc::new(
            0,
            "Controlword",
            DataType::Unsigned16,
            Access::RW.rx_mappable(),
        )],
    ),
    ObjectDesc::var(
        0x6041,
        "Statusword",
        &[EntryDesc::new(
            0,
            "Statusword",
            DataType::Unsigned16,
            Access::RO.tx_mappable(),
        )],
    ),
    ObjectDesc::var(
        0x6064,
        "Position actual value",
        &[EntryDesc::new(
            0,
            "Position actual value",
            DataType::Integer32,
            Access::RO.tx_mappable(),
        )],
    ),
    ObjectDesc::var(
        0x607A,
        "Target position",
        &[EntryDesc::new(
            0,
            "Target position",
            DataType::Integer32,
            Access::RW.rx_mappable(),
        )
        .with_default(Value::Int(0))],
    ),
]);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};

const MAPPINGS: [u16; 8] = [
    0x1600, 0x1601, 0x1602, 0x1603, 0x1A00, 0x1A01, 0x1A02, 0x1A03,
];

/// The identity a slave shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlaveIdentity {
    /// 0x1000.
    pub device_type: u32,
    /// 0x1018:01..04.
    pub vendor_id: u32,
    /// 0x1018:02.
    pub product_code: u32,
    /// 0x1018:03.
    pub revision: u32,
    /// 0x1018:04.
    pub serial: u32,
}

/// CiA 402 statusword of "operation enabled" (bits 0, 1, 2, 5).
pub const STATUS_OPERATION_ENABLED: u16 = 0x0027;

/// The device behind the node.
pub struct SlaveDevice {
    identity: SlaveIdentity,
    store: OdStore<512>,
    maps: [PdoMapping<8>; 8],
    /// 0x2000: what the TPDOs carry.
    pub inputs: [u8; 16],
    /// 0x2100 as the last RPDOs applied it.
    pub outputs: [u8; 16],
    /// 0x6040.
    pub controlword: u16,
    /// 0x6041.
    pub statusword: u16,
    /// 0x607A as the RPDO wrote it (applied at the SYNC).
    target: i32,
    /// 0x6064.
    pub position: i32,
    /// Every target position applied, in order (seed 001's setpoints).
    pub setpoints: Vec<i32>,
    /// Times the outputs were applied.
    pub applied: u64,
    register: u8,
}

impl SlaveDevice {
    fn new(identity: SlaveIdentity) -> Self {
        Self {
            identity,
            store: OdStore::new(OD).unwrap_or_else(|e| panic!("slave dictionary: {e:?}")),
            maps: MAPPINGS.map(|i| PdoMapping::with_entries(i, &[])),
            inputs: [0; 16],
            outputs: [0; 16],
            controlword: 0,
            statusword: 0x0040,
            target: 0,
            position: 0,
            setpoints: Vec::new(),
            applied: 0,
            register: 0,
        }
    }

    fn map(&mut self, index: u16) -> Option<&mut PdoMapping<8>> {
        MAPPINGS
            .iter()
            .position(|i| *i == index)
            .and_then(|i| self.maps.get_mut(i))
    }
}

fn put(buf: &mut [u8], bytes: &[u8]) -> Result<usize, SdoAbortCode> {
    buf.get_mut(..bytes.len())
        .ok_or(SdoAbortCode::OutOfMemory)?
        .copy_from_slice(bytes);
    Ok(bytes.len())
}

impl ObjectAccess for SlaveDevice {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        if let Some(m) = self.map(index) {
            return m.read_sub(sub, buf);
        }
        let id = self.identity;
        match (index, sub) {
            (0x1000, 0) => put(buf, &id.device_type.to_le_bytes()),
            (0x1001, 0) => put(buf, &[self.register]),
            (0x1018, 1) => put(buf, &id.vendor_id.to_le_bytes()),
            (0x1018, 2) => put(buf, &id.product_code.to_le_bytes()),
            (0x1018, 3) => put(buf, &id.revision.to_le_bytes()),
            (0x1018, 4) => put(buf, &id.serial.to_le_bytes()),
            (0x2000, 1..=16) => put(buf, &[self.inputs[usize::from(sub) - 1]]),
            (0x2100, 1..=16) => put(buf, &[self.outputs[usize::from(sub) - 1]]),
            (0x6040, 0) => put(buf, &self.controlword.to_le_bytes()),
            (0x6041, 0) => put(buf, &self.statusword.to_le_bytes()),
            (0x6064, 0) => put(buf, &self.position.to_le_bytes()),
            (0x607A, 0) => put(buf, &self.target.to_le_bytes()),
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
            return m.write_sub(sub, data, &OD, 64);
        }
        match (index, sub, data) {
            (0x2100, 1..=16, [b]) => {
                self.outputs[usize::from(sub) - 1] = *b;
                Ok(())
            }
            (0x6040, 0, [a, b]) => {
                self.controlword = u16::from_le_bytes([*a, *b]);
                Ok(())
            }
            (0x607A, 0, [a, b, c, d]) => {
                self.target = i32::from_le_bytes([*a, *b, *c, *d]);
                Ok(())
            }
            _ => self.store.write(index, sub, data, state),
        }
    }
}

impl CanApplication for SlaveDevice {
    fn can_owns_outputs(&self) -> bool {
        true
    }

    fn apply_outputs(&mut self) {
        self.applied += 1;
        // CiA 402 (simplified): shutdown -> ready to switch on, switch on -> switched on,
        // enable operation -> operation enabled; anything else -> switch on disabled.
        self.statusword = match self.controlword & 0x000F {
            0x0006 => 0x0021,
            0x0007 => 0x0023,
            0x000F => STATUS_OPERATION_ENABLED,
            _ => 0x0040,
        };
        if self.statusword == STATUS_OPERATION_ENABLED {
            self.position = self.target;
            self.setpoints.push(self.target);
        }
    }

    fn outputs_fault(&mut self) {}

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

    fn reset(&mut self, _application: bool) {
        self.maps = MAPPINGS.map(|i| PdoMapping::with_entries(i, &[]));
    }
}

/// A slave on a port of the bus.
pub struct InProcessSlave {
    /// The node.
    pub node: SlaveNode,
    /// Its device.
    pub dev: SlaveDevice,
    /// Its port.
    pub port: PortId,
    /// Powered: a slave that is off neither hears nor sends; powering it on boots it.
    pub powered: bool,
}

/// Frames a controller holds for the bus (the LPC1754's CAN1 has three).
pub const TX_BUFFERS: usize = 3;

impl InProcessSlave {
    /// A slave with `node_id` and `identity`, attached to `bus`.
    pub fn attach(bus: &mut CanBus, node_id: u8, identity: SlaveIdentity) -> Self {
        let port = bus.attach(&format!("slave {node_id}"));
        Self {
            node: SlaveNode::new(node_id, &OD, &DEFAULTS),
            dev: SlaveDevice::new(identity),
            port,
            powered: true,
        }
    }

    /// The NMT state.
    pub fn state(&self) -> NmtState {
        self.node.state()
    }

    /// Power off (`false`) or on (`true`: a new node that boots up).
    pub fn power(&mut self, bus: &mut CanBus, on: bool) {
        if on && !self.powered {
            self.node = SlaveNode::new(self.node.node_id(), &OD, &DEFAULTS);
            self.dev.reset(true);
        }
        if !on {
            // What was received or queued is lost with the power.
            while bus.receive(self.port).is_some() {}
        }
        self.powered = on;
    }

    /// Takes the frames the bus delivered and serves the node's timers at `now_ns`; moves
    /// frames to the controller's buffers.
    pub fn service(&mut self, bus: &mut CanBus, now_ns: u64) {
        if !self.powered {
            while bus.receive(self.port).is_some() {}
            return;
        }
        while let Some((t, f)) = bus.receive(self.port) {
            self.node.receive(&f, &mut self.dev, t / 1000);
            self.node.poll(&mut self.dev, t / 1000);
        }
        if self
            .node
            .next_deadline_us()
            .is_some_and(|t| t <= now_ns / 1000)
        {
            self.node.poll(&mut self.dev, now_ns / 1000);
        }
        while bus.pending(self.port) < TX_BUFFERS {
            let Some(f) = self.node.pop_tx() else { break };
            bus.send(self.port, f);
        }
    }

    /// When the node's timers want it next (ns), if later than `now_ns`.
    pub fn next_ns(&self, now_ns: u64) -> Option<u64> {
        if !self.powered {
            return None;
        }
        self.node
            .next_deadline_us()
            .map(|t| t * 1000)
            .filter(|t| *t > now_ns)
    }

    /// Frames queued by the node, not yet on the bus.
    pub fn frame_waiting(&self) -> Option<CanFrame> {
        self.node.peek_tx()
    }
}
