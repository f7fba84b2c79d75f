//! The dictionary descriptions of the CAN communication objects ([`super::params`]), made
//! from the same [`CommDefaults`] the node resets to, so the firmware's dictionary, the EDS,
//! the ESI and the node cannot disagree.
//!
//! A firmware declares one `static` [`CommObjects`] and lists its objects in its dictionary
//! in index order (`CAN.sync_cob_id()`, `CAN.rpdo(0)`, ...). Names follow CiA 301; the
//! record types are CiA 301's PDO_COMM_PAR (0x0020) and SDO_PARAMETER (0x0022). COB-ID
//! defaults hold the base of the predefined connection set without the node-ID
//! ([`super::params`]).

use super::cob;
use super::params::{
    CommDefaults, PdoDefault, COB_ID_EMCY, COB_ID_SYNC, COMMUNICATION_CYCLE_PERIOD,
    CONSUMER_HEARTBEAT_TIME, ERROR_BEHAVIOUR, GUARD_TIME, INHIBIT_TIME_EMCY, LIFE_TIME_FACTOR,
    PRODUCER_HEARTBEAT_TIME, RPDO_COMMUNICATION, SDO_SERVER_PARAMETER, SYNC_COUNTER_OVERFLOW,
    TPDO_COMMUNICATION,
};
use super::pdo::{RPDO_HIGHEST_SUB, TPDO_HIGHEST_SUB};
use crate::od::{Access, DataType, EntryDefault, EntryDesc, ObjectDesc, Value};

const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;

/// CiA 301 record type PDO_COMM_PAR.
pub const PDO_COMM_PAR: DataType = DataType::Unknown(0x0020);
/// CiA 301 record type SDO_PARAMETER.
pub const SDO_PARAMETER: DataType = DataType::Unknown(0x0022);

/// The most heartbeat consumer entries a description names.
pub const MAX_CONSUMERS: usize = 8;

const CONSUMER_NAMES: [&str; MAX_CONSUMERS] = [
    "Consumer heartbeat time 1",
    "Consumer heartbeat time 2",
    "Consumer heartbeat time 3",
    "Consumer heartbeat time 4",
    "Consumer heartbeat time 5",
    "Consumer heartbeat time 6",
    "Consumer heartbeat time 7",
    "Consumer heartbeat time 8",
];

const RPDO_NAMES: [&str; 4] = [
    "RPDO 1 communication parameter",
    "RPDO 2 communication parameter",
    "RPDO 3 communication parameter",
    "RPDO 4 communication parameter",
];

const TPDO_NAMES: [&str; 4] = [
    "TPDO 1 communication parameter",
    "TPDO 2 communication parameter",
    "TPDO 3 communication parameter",
    "TPDO 4 communication parameter",
];

const fn uint(v: u64) -> Value {
    Value::Uint(v)
}

const fn var(
    name: &'static str,
    data_type: DataType,
    access: Access,
    default: u64,
) -> [EntryDesc; 1] {
    [EntryDesc::new(0, name, data_type, access).with_default(uint(default))]
}

const fn highest(sub: u8) -> EntryDesc {
    EntryDesc::new(0, "Highest sub-index supported", U8, Access::RO).with_default(uint(sub as u64))
}

/// The entries of every RPDO communication parameter; the PDO's own defaults are
/// [`rpdo_own_defaults`].
const RPDO_ENTRIES: [EntryDesc; 4] = [
    highest(RPDO_HIGHEST_SUB),
    EntryDesc::new(1, "COB-ID used by RPDO", U32, Access::RW),
    EntryDesc::new(2, "Transmission type", U8, Access::RW),
    EntryDesc::new(5, "Event timer", U16, Access::RW),
];

const fn rpdo_own_defaults(d: &PdoDefault) -> [EntryDefault; 3] {
    [
        EntryDefault::new(1, d.cob_id),
        EntryDefault::new(2, d.transmission_type as u32),
        EntryDefault::new(5, d.event_timer_ms as u32),
    ]
}

/// The entries of every TPDO communication parameter; the PDO's own defaults are
/// [`tpdo_own_defaults`].
const TPDO_ENTRIES: [EntryDesc; 6] = [
    highest(TPDO_HIGHEST_SUB),
    EntryDesc::new(1, "COB-ID used by TPDO", U32, Access::RW),
    EntryDesc::new(2, "Transmission type", U8, Access::RW),
    EntryDesc::new(3, "Inhibit time", U16, Access::RW),
    EntryDesc::new(5, "Event timer", U16, Access::RW),
    EntryDesc::new(6, "SYNC start value", U8, Access::RW).with_default(uint(0)),
];

const fn tpdo_own_defaults(d: &PdoDefault) -> [EntryDefault; 4] {
    [
        EntryDefault::new(1, d.cob_id),
        EntryDefault::new(2, d.transmission_type as u32),
        EntryDefault::new(3, d.inhibit_100us as u32),
        EntryDefault::new(5, d.event_timer_ms as u32),
    ]
}

/// The entries of every communication object: `R` RPDOs, `T` TPDOs, and `HB1` entries of
/// 0x1016 (sub 0 and `HB1 - 1` consumers, at most [`MAX_CONSUMERS`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommObjects<const R: usize, const T: usize, const HB1: usize> {
    sync_cob_id: [EntryDesc; 1],
    cycle_period: [EntryDesc; 1],
    guard_time: [EntryDesc; 1],
    life_factor: [EntryDesc; 1],
    emcy_cob_id: [EntryDesc; 1],
    emcy_inhibit: [EntryDesc; 1],
    consumers: [EntryDesc; HB1],
    producer: [EntryDesc; 1],
    sync_overflow: [EntryDesc; 1],
    error_behaviour: [EntryDesc; 2],
    sdo_server: [EntryDesc; 3],
    rpdo: [EntryDesc; 4],
    rpdo_defaults: [[EntryDefault; 3]; R],
    tpdo: [EntryDesc; 6],
    tpdo_defaults: [[EntryDefault; 4]; T],
}

impl<const R: usize, const T: usize, const HB1: usize> CommObjects<R, T, HB1> {
    /// The descriptions with the defaults of `d`.
    pub const fn new(d: &CommDefaults<R, T>) -> Self {
        let mut consumers = [EntryDesc::count((HB1 - 1) as u8); HB1];
        let mut i = 1;
        while i < HB1 {
            let name = CONSUMER_NAMES[if i - 1 < MAX_CONSUMERS {
                i - 1
            } else {
                MAX_CONSUMERS - 1
            }];
            consumers[i] = EntryDesc::new(i as u8, name, U32, Access::RW).with_default(uint(0));
            i += 1;
        }
        let mut rpdo_defaults = [[EntryDefault::new(0, 0); 3]; R];
        let mut i = 0;
        while i < R {
            rpdo_defaults[i] = rpdo_own_defaults(&d.rpdo[i]);
            i += 1;
        }
        let mut tpdo_defaults = [[EntryDefault::new(0, 0); 4]; T];
        let mut i = 0;
        while i < T {
            tpdo_defaults[i] = tpdo_own_defaults(&d.tpdo[i]);
            i += 1;
        }
        Self {
            sync_cob_id: var("COB-ID SYNC", U32, Access::RW, cob::SYNC as u64),
            cycle_period: var("Communication cycle period", U32, Access::RW, 0),
            guard_time: var("Guard time", U16, Access::RW, d.guard_time_ms as u64),
            life_factor: var("Life time factor", U8, Access::RW, d.life_factor as u64),
            emcy_cob_id: var("COB-ID EMCY", U32, Access::RW, cob::EMCY as u64),
            emcy_inhibit: var(
                "Inhibit time EMCY",
                U16,
                Access::RW,
                d.emcy_inhibit_100us as u64,
            ),
            consumers,
            producer: var(
                "Producer heartbeat time",
                U16,
                Access::RW,
                d.heartbeat_ms as u64,
            ),
            sync_overflow: var("Synchronous counter overflow value", U8, Access::RW, 0),
            error_behaviour: [
                EntryDesc::count(1),
                EntryDesc::new(1, "Communication error", U8, Access::RW)
                    .with_default(uint(d.error_behaviour as u64)),
            ],
            sdo_server: [
                highest(2),
                EntryDesc::new(1, "COB-ID client to server", U32, Access::RO)
                    .with_default(uint(cob::SDO_RX as u64)),
                EntryDesc::new(2, "COB-ID server to client", U32, Access::RO)
                    .with_default(uint(cob::SDO_TX as u64)),
            ],
            rpdo: RPDO_ENTRIES,
            rpdo_defaults,
            tpdo: TPDO_ENTRIES,
            tpdo_defaults,
        }
    }

    /// 0x1005.
    pub const fn sync_cob_id(&'static self) -> ObjectDesc {
        ObjectDesc::var(COB_ID_SYNC, "COB-ID SYNC", &self.sync_cob_id)
    }
    /// 0x1006.
    pub const fn cycle_period(&'static self) -> ObjectDesc {
        ObjectDesc::var(
            COMMUNICATION_CYCLE_PERIOD,
            "Communication cycle period",
            &self.cycle_period,
        )
    }
    /// 0x100C.
    pub const fn guard_time(&'static self) -> ObjectDesc {
        ObjectDesc::var(GUARD_TIME, "Guard time", &self.guard_time)
    }
    /// 0x100D.
    pub const fn life_factor(&'static self) -> ObjectDesc {
        ObjectDesc::var(LIFE_TIME_FACTOR, "Life time factor", &self.life_factor)
    }
    /// 0x1014.
    pub const fn emcy_cob_id(&'static self) -> ObjectDesc {
        ObjectDesc::var(COB_ID_EMCY, "COB-ID EMCY", &self.emcy_cob_id)
    }
    /// 0x1015.
    pub const fn emcy_inhibit(&'static self) -> ObjectDesc {
        ObjectDesc::var(INHIBIT_TIME_EMCY, "Inhibit time EMCY", &self.emcy_inhibit)
    }
    /// 0x1016.
    pub const fn consumers(&'static self) -> ObjectDesc {
        ObjectDesc::array(
            CONSUMER_HEARTBEAT_TIME,
            "Consumer heartbeat time",
            &self.consumers,
        )
    }
    /// 0x1017.
    pub const fn producer(&'static self) -> ObjectDesc {
        ObjectDesc::var(
            PRODUCER_HEARTBEAT_TIME,
            "Producer heartbeat time",
            &self.producer,
        )
    }
    /// 0x1019.
    pub const fn sync_overflow(&'static self) -> ObjectDesc {
        ObjectDesc::var(
            SYNC_COUNTER_OVERFLOW,
            "Synchronous counter overflow value",
            &self.sync_overflow,
        )
    }
    /// 0x1029.
    pub const fn error_behaviour(&'static self) -> ObjectDesc {
        ObjectDesc::array(ERROR_BEHAVIOUR, "Error behavior", &self.error_behaviour)
    }
    /// 0x1200.
    pub const fn sdo_server(&'static self) -> ObjectDesc {
        ObjectDesc::record(
            SDO_SERVER_PARAMETER,
            "SDO server parameter",
            SDO_PARAMETER,
            &self.sdo_server,
        )
    }
    /// 0x1400 + `i`.
    pub const fn rpdo(&'static self, i: usize) -> ObjectDesc {
        ObjectDesc::record(
            RPDO_COMMUNICATION + i as u16,
            RPDO_NAMES[i],
            PDO_COMM_PAR,
            &self.rpdo,
        )
        .with_defaults(&self.rpdo_defaults[i])
    }
    /// 0x1800 + `i`.
    pub const fn tpdo(&'static self, i: usize) -> ObjectDesc {
        ObjectDesc::record(
            TPDO_COMMUNICATION + i as u16,
            TPDO_NAMES[i],
            PDO_COMM_PAR,
            &self.tpdo,
        )
        .with_defaults(&self.tpdo_defaults[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::params::CommParameters;
    use crate::od::{ObjectAccess, ObjectDictionary, OdStore};

    const DEFAULTS: CommDefaults<2, 2> = CommDefaults {
        rpdo: [
            PdoDefault::new(0x200, false, 255),
            PdoDefault::new(0x300, true, 1),
        ],
        tpdo: [
            PdoDefault::new(0x180, false, 255),
            PdoDefault::new(0x280, true, 254),
        ],
        heartbeat_ms: 500,
        guard_time_ms: 0,
        life_factor: 0,
        emcy_inhibit_100us: 10,
        error_behaviour: 1,
    };

    static CAN: CommObjects<2, 2, 3> = CommObjects::new(&DEFAULTS);

    static OD: ObjectDictionary = ObjectDictionary::new(&[
        CAN.sync_cob_id(),
        CAN.cycle_period(),
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
        CAN.tpdo(0),
        CAN.tpdo(1),
    ]);

    const _: () = if let Err(e) = OD.validate() {
        panic!("{}", e.message())
    };

    /// The descriptions and the parameters agree: every entry the dictionary describes
    /// reads from the node's parameters (node-ID 0, so COB-ID defaults are the bases) with
    /// the description's length and default.
    #[test]
    fn descriptions_match_the_parameters() {
        let params = CommParameters::<2, 2, 2>::defaults(&DEFAULTS, 0);
        let mut defaults = OdStore::<512>::new(OD).unwrap();
        for object in OD.iter() {
            for entry in object.entries {
                let mut a = [0u8; 8];
                let mut b = [0u8; 8];
                let n = params
                    .read(0, object.index, entry.subindex, &mut a)
                    .unwrap();
                let m = defaults.read(object.index, entry.subindex, &mut b).unwrap();
                assert_eq!(
                    n,
                    entry.byte_len(),
                    "{:#x}:{}",
                    object.index,
                    entry.subindex
                );
                let value = |x: &[u8]| {
                    let mut w = [0u8; 4];
                    w[..x.len().min(4)].copy_from_slice(&x[..x.len().min(4)]);
                    u32::from_le_bytes(w)
                };
                assert_eq!(
                    value(&a[..n]),
                    value(&b[..m]),
                    "{:#x}:{} {}",
                    object.index,
                    entry.subindex,
                    entry.name
                );
            }
        }
        // Every object the parameters serve is described.
        for index in 0x1000..0x2000u16 {
            if CommParameters::<2, 2, 2>::serves(index) {
                assert!(OD.find(index).is_some(), "{index:#x} not described");
            }
        }
    }
}
