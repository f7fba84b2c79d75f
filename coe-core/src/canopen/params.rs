//! The communication parameters of the CAN side (CiA 301 7.5.2) as the node holds them, with
//! their SDO access rules, and the defaults they return to at a reset of communication.
//!
//! | Index | Object | Rules |
//! |---|---|---|
//! | 0x1005 | COB-ID SYNC | [`SyncParams::set_cob_id`] |
//! | 0x1006 | communication cycle period (µs) | any value; 0 = not monitored |
//! | 0x100C / 0x100D | guard time (ms) / life time factor | any value |
//! | 0x1014 | COB-ID EMCY | [`EmcyParams::set_cob_id`] |
//! | 0x1015 | inhibit time EMCY (100 µs) | any value |
//! | 0x1016 | consumer heartbeat time, sub 1..N `node << 16 \| ms` | a node-ID above 127 is 0x06090030; two active entries for one node are 0x06040043 |
//! | 0x1017 | producer heartbeat time (ms) | any value; 0 = node guarding instead |
//! | 0x1019 | synchronous counter overflow value | [`SyncParams::set_overflow`] |
//! | 0x1029 | error behaviour, sub 1 communication error | 0 pre-operational, 1 no change, 2 stopped; else 0x06090030 |
//! | 0x1200 | SDO server parameter | read-only: 0x600 / 0x580 + node-ID |
//! | 0x1400 + i / 0x1800 + i | RPDO / TPDO communication parameter | [`PdoComm::write_sub`] |
//!
//! COB-ID defaults are relative to the node-ID, as in the predefined connection set: the
//! dictionary's default holds the base (e.g. 0x180 for TPDO 1), the EDS writes it as
//! `$NODEID+0x180`, and the node adds its node-ID when it (re)sets the parameters.

use super::cob;
use super::emcy::EmcyParams;
use super::error_control::ConsumerEntry;
use super::frame::CobId;
use super::param_bytes::{put_le, take_le};
use super::pdo::{MappingInfo, PdoComm, PdoKind};
use super::sync::SyncParams;
use crate::abort::SdoAbortCode;

/// 0x1005 COB-ID SYNC.
pub const COB_ID_SYNC: u16 = 0x1005;
/// 0x1006 communication cycle period.
pub const COMMUNICATION_CYCLE_PERIOD: u16 = 0x1006;
/// 0x100C guard time.
pub const GUARD_TIME: u16 = 0x100C;
/// 0x100D life time factor.
pub const LIFE_TIME_FACTOR: u16 = 0x100D;
/// 0x1014 COB-ID EMCY.
pub const COB_ID_EMCY: u16 = 0x1014;
/// 0x1015 inhibit time EMCY.
pub const INHIBIT_TIME_EMCY: u16 = 0x1015;
/// 0x1016 consumer heartbeat time.
pub const CONSUMER_HEARTBEAT_TIME: u16 = 0x1016;
/// 0x1017 producer heartbeat time.
pub const PRODUCER_HEARTBEAT_TIME: u16 = 0x1017;
/// 0x1019 synchronous counter overflow value.
pub const SYNC_COUNTER_OVERFLOW: u16 = 0x1019;
/// 0x1029 error behaviour.
pub const ERROR_BEHAVIOUR: u16 = 0x1029;
/// 0x1200 SDO server parameter.
pub const SDO_SERVER_PARAMETER: u16 = 0x1200;
/// 0x1400 RPDO 1 communication parameter (0x1400 + i for RPDO i + 1).
pub const RPDO_COMMUNICATION: u16 = 0x1400;
/// 0x1600 RPDO 1 mapping parameter.
pub const RPDO_MAPPING: u16 = 0x1600;
/// 0x1800 TPDO 1 communication parameter.
pub const TPDO_COMMUNICATION: u16 = 0x1800;
/// 0x1A00 TPDO 1 mapping parameter.
pub const TPDO_MAPPING: u16 = 0x1A00;

/// True for the entries whose default is relative to the node-ID (the COB-IDs of the
/// predefined connection set: 0x1014, 0x1200:01/02, the PDOs' sub 1); the EDS writes their
/// default as `$NODEID+base`.
pub const fn is_node_relative(index: u16, sub: u8) -> bool {
    match index {
        COB_ID_EMCY => sub == 0,
        SDO_SERVER_PARAMETER => sub == 1 || sub == 2,
        RPDO_COMMUNICATION..=0x15FF | TPDO_COMMUNICATION..=0x19FF => sub == 1,
        _ => false,
    }
}

/// 0x1029:01 values.
pub mod error_behaviour {
    /// Change to pre-operational (only from operational).
    pub const PRE_OPERATIONAL: u8 = 0;
    /// No change of the NMT state.
    pub const NO_CHANGE: u8 = 1;
    /// Change to stopped.
    pub const STOPPED: u8 = 2;
}

/// The default of one PDO's communication parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoDefault {
    /// COB-ID without the node-ID (e.g. 0x180 for TPDO 1); bit 31 for a PDO that is not
    /// valid by default.
    pub cob_id: u32,
    /// Transmission type.
    pub transmission_type: u8,
    /// Inhibit time (100 µs, TPDO).
    pub inhibit_100us: u16,
    /// Event timer (ms).
    pub event_timer_ms: u16,
}

impl PdoDefault {
    /// A PDO on `base + node-ID`, valid or not, with this transmission type (bit 30 set:
    /// remote requests are not served, as the COB-ID reads).
    pub const fn new(base: u16, valid: bool, transmission_type: u8) -> Self {
        Self {
            cob_id: base as u32 | CobId::BIT30 | if valid { 0 } else { CobId::INVALID },
            transmission_type,
            inhibit_100us: 0,
            event_timer_ms: 0,
        }
    }

    /// The parameter of node `node`.
    pub const fn resolve(&self, node: u8) -> PdoComm {
        PdoComm {
            cob_id: CobId(self.cob_id + node as u32),
            transmission_type: self.transmission_type,
            inhibit_100us: self.inhibit_100us,
            event_timer_ms: self.event_timer_ms,
            sync_start: 0,
        }
    }
}

/// The defaults of the communication parameters: `R` RPDOs, `T` TPDOs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CommDefaults<const R: usize, const T: usize> {
    /// RPDO 1.. (0x1400..).
    pub rpdo: [PdoDefault; R],
    /// TPDO 1.. (0x1800..).
    pub tpdo: [PdoDefault; T],
    /// 0x1017 (ms).
    pub heartbeat_ms: u16,
    /// 0x100C (ms).
    pub guard_time_ms: u16,
    /// 0x100D.
    pub life_factor: u8,
    /// 0x1015 (100 µs).
    pub emcy_inhibit_100us: u16,
    /// 0x1029:01.
    pub error_behaviour: u8,
}

/// What a parameter write changed, for the node's runtime.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Changed {
    /// Nothing the runtime needs to know.
    Nothing,
    /// 0x1017: the heartbeat cycle restarts.
    Heartbeat,
    /// 0x1016 entry `i` (0-based).
    Consumer(usize),
    /// SYNC parameters (monitoring restarts).
    Sync,
    /// RPDO `i` communication parameter (0-based).
    Rpdo(usize),
    /// TPDO `i` communication parameter.
    Tpdo(usize),
}

/// The communication parameters: `R` RPDOs, `T` TPDOs, `HB` heartbeat consumer entries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CommParameters<const R: usize, const T: usize, const HB: usize> {
    /// 0x1005, 0x1006, 0x1019.
    pub sync: SyncParams,
    /// 0x100C.
    pub guard_time_ms: u16,
    /// 0x100D.
    pub life_factor: u8,
    /// 0x1014, 0x1015.
    pub emcy: EmcyParams,
    /// 0x1016.
    pub consumers: [ConsumerEntry; HB],
    /// 0x1017.
    pub heartbeat_ms: u16,
    /// 0x1029:01.
    pub error_behaviour: u8,
    /// 0x1400..
    pub rpdo: [PdoComm; R],
    /// 0x1800..
    pub tpdo: [PdoComm; T],
}

impl<const R: usize, const T: usize, const HB: usize> CommParameters<R, T, HB> {
    /// The defaults for node `node`.
    pub fn defaults(d: &CommDefaults<R, T>, node: u8) -> Self {
        Self {
            sync: SyncParams::default(),
            guard_time_ms: d.guard_time_ms,
            life_factor: d.life_factor,
            emcy: EmcyParams {
                cob_id: CobId::new(cob::EMCY + u16::from(node)),
                inhibit_100us: d.emcy_inhibit_100us,
            },
            consumers: [ConsumerEntry {
                node: 0,
                time_ms: 0,
            }; HB],
            heartbeat_ms: d.heartbeat_ms,
            error_behaviour: d.error_behaviour,
            rpdo: core::array::from_fn(|i| {
                d.rpdo
                    .get(i)
                    .map_or(PdoComm::new(CobId::new(0).invalid(), 255), |p| {
                        p.resolve(node)
                    })
            }),
            tpdo: core::array::from_fn(|i| {
                d.tpdo
                    .get(i)
                    .map_or(PdoComm::new(CobId::new(0).invalid(), 255), |p| {
                        p.resolve(node)
                    })
            }),
        }
    }

    /// True if `index` is one of the objects these parameters serve.
    pub const fn serves(index: u16) -> bool {
        match index {
            COB_ID_SYNC
            | COMMUNICATION_CYCLE_PERIOD
            | GUARD_TIME
            | LIFE_TIME_FACTOR
            | COB_ID_EMCY
            | INHIBIT_TIME_EMCY
            | CONSUMER_HEARTBEAT_TIME
            | PRODUCER_HEARTBEAT_TIME
            | SYNC_COUNTER_OVERFLOW
            | ERROR_BEHAVIOUR
            | SDO_SERVER_PARAMETER => true,
            _ => Self::pdo_of(index).is_some(),
        }
    }

    /// The PDO whose communication parameter `index` is: kind and 0-based number.
    pub const fn pdo_of(index: u16) -> Option<(PdoKind, usize)> {
        let (kind, i) = match index {
            RPDO_COMMUNICATION..=0x15FF => (PdoKind::Rpdo, (index - RPDO_COMMUNICATION) as usize),
            TPDO_COMMUNICATION..=0x19FF => (PdoKind::Tpdo, (index - TPDO_COMMUNICATION) as usize),
            _ => return None,
        };
        let n = match kind {
            PdoKind::Rpdo => R,
            PdoKind::Tpdo => T,
        };
        if i < n {
            Some((kind, i))
        } else {
            None
        }
    }

    /// The PDO whose mapping parameter `index` is.
    pub const fn mapping_of(index: u16) -> Option<(PdoKind, usize)> {
        match index {
            RPDO_MAPPING..=0x17FF => Self::pdo_of(index - RPDO_MAPPING + RPDO_COMMUNICATION),
            TPDO_MAPPING..=0x1BFF => Self::pdo_of(index - TPDO_MAPPING + TPDO_COMMUNICATION),
            _ => None,
        }
    }

    /// The communication parameter of a PDO.
    pub fn pdo(&self, kind: PdoKind, i: usize) -> Option<&PdoComm> {
        match kind {
            PdoKind::Rpdo => self.rpdo.get(i),
            PdoKind::Tpdo => self.tpdo.get(i),
        }
    }

    /// The value of `index:sub` (node `node` for 0x1200) and its length in bytes: one place
    /// that knows which entries exist and how long they are, for uploads and downloads.
    fn value(&self, node: u8, index: u16, sub: u8) -> Result<(u32, usize), SdoAbortCode> {
        if let Some((kind, i)) = Self::pdo_of(index) {
            return self
                .pdo(kind, i)
                .ok_or(SdoAbortCode::ObjectDoesNotExist)?
                .value(kind, sub);
        }
        // The objects of one value hold it in sub 0; the others answer by subindex.
        let (value, len) = match index {
            COB_ID_SYNC => (self.sync.cob_id.0, 4),
            COMMUNICATION_CYCLE_PERIOD => (self.sync.period_us, 4),
            GUARD_TIME => (self.guard_time_ms.into(), 2),
            LIFE_TIME_FACTOR => (self.life_factor.into(), 1),
            COB_ID_EMCY => (self.emcy.cob_id.0, 4),
            INHIBIT_TIME_EMCY => (self.emcy.inhibit_100us.into(), 2),
            PRODUCER_HEARTBEAT_TIME => (self.heartbeat_ms.into(), 2),
            SYNC_COUNTER_OVERFLOW => (self.sync.overflow.into(), 1),
            CONSUMER_HEARTBEAT_TIME => {
                return match usize::from(sub).checked_sub(1) {
                    None => Ok((HB as u32, 1)),
                    Some(i) => self
                        .consumers
                        .get(i)
                        .map(|e| (e.to_u32(), 4))
                        .ok_or(SdoAbortCode::SubindexDoesNotExist),
                }
            }
            ERROR_BEHAVIOUR => {
                return match sub {
                    0 => Ok((1, 1)),
                    1 => Ok((self.error_behaviour.into(), 1)),
                    _ => Err(SdoAbortCode::SubindexDoesNotExist),
                }
            }
            SDO_SERVER_PARAMETER => {
                return match sub {
                    0 => Ok((2, 1)),
                    1 => Ok(((cob::SDO_RX + u16::from(node)).into(), 4)),
                    2 => Ok(((cob::SDO_TX + u16::from(node)).into(), 4)),
                    _ => Err(SdoAbortCode::SubindexDoesNotExist),
                }
            }
            _ => return Err(SdoAbortCode::ObjectDoesNotExist),
        };
        if sub != 0 {
            return Err(SdoAbortCode::SubindexDoesNotExist);
        }
        Ok((value, len))
    }

    /// SDO upload of `index:sub` (node `node` for 0x1200); 0x06020000 (object does not
    /// exist) exactly for the objects these parameters do not serve.
    pub fn read(
        &self,
        node: u8,
        index: u16,
        sub: u8,
        buf: &mut [u8],
    ) -> Result<usize, SdoAbortCode> {
        let (value, len) = self.value(node, index, sub)?;
        put_le(buf, value, len)
    }

    /// SDO download of `index:sub`; `mapping` gives the current mapping of a PDO (for the
    /// checks of making it valid). Returns what the runtime must know; 0x06020000 (object
    /// does not exist) exactly for the objects these parameters do not serve.
    pub fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        mapping: impl FnOnce(PdoKind, usize) -> MappingInfo,
    ) -> Result<Changed, SdoAbortCode> {
        if let Some((kind, i)) = Self::pdo_of(index) {
            let info = mapping(kind, i);
            let comm = match kind {
                PdoKind::Rpdo => self.rpdo.get_mut(i),
                PdoKind::Tpdo => self.tpdo.get_mut(i),
            }
            .ok_or(SdoAbortCode::ObjectDoesNotExist)?;
            comm.write_sub(kind, sub, data, info)?;
            return Ok(match kind {
                PdoKind::Rpdo => Changed::Rpdo(i),
                PdoKind::Tpdo => Changed::Tpdo(i),
            });
        }
        let (_, len) = self.value(0, index, sub)?;
        let read_only = match index {
            CONSUMER_HEARTBEAT_TIME | ERROR_BEHAVIOUR => sub == 0,
            SDO_SERVER_PARAMETER => true,
            _ => false,
        };
        if read_only {
            return Err(SdoAbortCode::WriteOfReadOnly);
        }
        // `value` has `len` bytes: the narrowing casts below keep all of it.
        let value = take_le(data, len)?;
        match index {
            COB_ID_SYNC => {
                self.sync.set_cob_id(value)?;
                Ok(Changed::Sync)
            }
            COMMUNICATION_CYCLE_PERIOD => {
                self.sync.period_us = value;
                Ok(Changed::Sync)
            }
            GUARD_TIME => {
                self.guard_time_ms = value as u16;
                Ok(Changed::Nothing)
            }
            LIFE_TIME_FACTOR => {
                self.life_factor = value as u8;
                Ok(Changed::Nothing)
            }
            COB_ID_EMCY => {
                self.emcy.set_cob_id(value)?;
                Ok(Changed::Nothing)
            }
            INHIBIT_TIME_EMCY => {
                self.emcy.inhibit_100us = value as u16;
                Ok(Changed::Nothing)
            }
            PRODUCER_HEARTBEAT_TIME => {
                self.heartbeat_ms = value as u16;
                Ok(Changed::Heartbeat)
            }
            SYNC_COUNTER_OVERFLOW => {
                self.sync.set_overflow(value as u8)?;
                Ok(Changed::Sync)
            }
            CONSUMER_HEARTBEAT_TIME => self.set_consumer(usize::from(sub) - 1, value),
            ERROR_BEHAVIOUR => {
                if value > u32::from(error_behaviour::STOPPED) {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                self.error_behaviour = value as u8;
                Ok(Changed::Nothing)
            }
            _ => Err(SdoAbortCode::ObjectDoesNotExist),
        }
    }

    /// 0x1016 entry `i` (0-based, known to exist): a node-ID above 127 is 0x06090030, a
    /// second active entry for one node 0x06040043.
    fn set_consumer(&mut self, i: usize, raw: u32) -> Result<Changed, SdoAbortCode> {
        let entry = ConsumerEntry::from_u32(raw);
        if entry.node > 127 {
            return Err(SdoAbortCode::ValueRangeExceeded);
        }
        let clash = self
            .consumers
            .iter()
            .enumerate()
            .any(|(j, e)| j != i && e.is_active() && entry.is_active() && e.node == entry.node);
        if clash {
            return Err(SdoAbortCode::ParameterIncompatible);
        }
        if let Some(slot) = self.consumers.get_mut(i) {
            *slot = entry;
        }
        Ok(Changed::Consumer(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEFAULTS: CommDefaults<2, 3> = CommDefaults {
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

    type Params = CommParameters<2, 3, 4>;

    fn read(p: &Params, index: u16, sub: u8) -> Result<std::vec::Vec<u8>, SdoAbortCode> {
        let mut buf = [0u8; 8];
        p.read(5, index, sub, &mut buf).map(|n| buf[..n].to_vec())
    }

    const MAPPED: MappingInfo = MappingInfo { count: 2, bits: 32 };

    #[test]
    fn defaults_add_the_node_id() {
        let p = Params::defaults(&DEFAULTS, 5);
        assert_eq!(
            read(&p, 0x1400, 1),
            Ok(0xC000_0205u32.to_le_bytes().to_vec())
        );
        assert_eq!(
            read(&p, 0x1401, 1),
            Ok(0x4000_0305u32.to_le_bytes().to_vec())
        );
        assert_eq!(
            read(&p, 0x1801, 1),
            Ok(0x4000_0285u32.to_le_bytes().to_vec())
        );
        assert_eq!(read(&p, 0x1014, 0), Ok(0x85u32.to_le_bytes().to_vec()));
        assert_eq!(read(&p, 0x1005, 0), Ok(0x80u32.to_le_bytes().to_vec()));
        assert_eq!(read(&p, 0x1200, 1), Ok(0x605u32.to_le_bytes().to_vec()));
        assert_eq!(read(&p, 0x1200, 2), Ok(0x585u32.to_le_bytes().to_vec()));
        assert_eq!(read(&p, 0x1016, 0), Ok(std::vec![4]));
        assert_eq!(read(&p, 0x1029, 0), Ok(std::vec![1]));
        assert_eq!(read(&p, 0x1402, 1), Err(SdoAbortCode::ObjectDoesNotExist));
        assert_eq!(read(&p, 0x1005, 1), Err(SdoAbortCode::SubindexDoesNotExist));
        assert_eq!(read(&p, 0x1016, 5), Err(SdoAbortCode::SubindexDoesNotExist));
    }

    #[test]
    fn subindexes_beyond_each_object() {
        let p = Params::defaults(&DEFAULTS, 5);
        for (index, sub) in [
            (0x1006, 1),
            (0x100C, 1),
            (0x1017, 1),
            (0x1019, 1),
            (0x1016, 5),
            (0x1029, 2),
            (0x1200, 3),
        ] {
            assert_eq!(
                read(&p, index, sub),
                Err(SdoAbortCode::SubindexDoesNotExist),
                "{index:#x}:{sub}"
            );
        }
        assert_eq!(read(&p, 0x1016, 4), Ok(std::vec![0; 4]));
        assert_eq!(read(&p, 0x1029, 1), Ok(std::vec![0]));
        assert_eq!(read(&p, 0x1200, 0), Ok(std::vec![2]));
        assert_eq!(read(&p, 0x1030, 0), Err(SdoAbortCode::ObjectDoesNotExist));
    }

    #[test]
    fn object_does_not_exist_exactly_for_the_objects_not_served() {
        let mut p = Params::defaults(&DEFAULTS, 5);
        for index in 0x1000..=0x1FFF {
            for sub in 0..=7 {
                let missing = SdoAbortCode::ObjectDoesNotExist;
                let served = Params::serves(index);
                let answer = read(&p, index, sub);
                assert_eq!(answer != Err(missing), served, "{index:#x}:{sub}");
                for data in [&[0u8][..], &[0; 2], &[0x80, 0, 0, 0]] {
                    let written = p.write(index, sub, data, |_, _| MAPPED);
                    assert_eq!(written != Err(missing), served, "{index:#x}:{sub} {data:?}");
                }
            }
        }
    }

    #[test]
    fn which_objects() {
        for i in [
            0x1005, 0x1006, 0x100C, 0x100D, 0x1014, 0x1015, 0x1016, 0x1017, 0x1019, 0x1029, 0x1200,
            0x1400, 0x1401, 0x1800, 0x1802,
        ] {
            assert!(Params::serves(i), "{i:#x}");
        }
        for i in [0x1000, 0x1402, 0x1803, 0x1600, 0x1A00] {
            assert!(!Params::serves(i), "{i:#x}");
        }
        assert_eq!(Params::mapping_of(0x1601), Some((PdoKind::Rpdo, 1)));
        assert_eq!(Params::mapping_of(0x1A02), Some((PdoKind::Tpdo, 2)));
        assert_eq!(Params::mapping_of(0x1A03), None);
    }

    #[test]
    fn heartbeat_consumer_rules() {
        let mut p = Params::defaults(&DEFAULTS, 5);
        let w =
            |p: &mut Params, sub: u8, v: u32| p.write(0x1016, sub, &v.to_le_bytes(), |_, _| MAPPED);
        assert_eq!(w(&mut p, 1, 0x0003_0064), Ok(Changed::Consumer(0)));
        assert_eq!(
            w(&mut p, 2, 0x0003_00C8),
            Err(SdoAbortCode::ParameterIncompatible)
        );
        assert_eq!(
            w(&mut p, 2, 0x0003_0000),
            Ok(Changed::Consumer(1)),
            "inactive entry may repeat"
        );
        assert_eq!(
            w(&mut p, 3, 0x0080_0064),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            w(&mut p, 5, 0x0004_0064),
            Err(SdoAbortCode::SubindexDoesNotExist)
        );
        assert_eq!(
            p.write(0x1016, 0, &[4], |_, _| MAPPED),
            Err(SdoAbortCode::WriteOfReadOnly)
        );
        assert_eq!(
            read(&p, 0x1016, 1),
            Ok(0x0003_0064u32.to_le_bytes().to_vec())
        );
    }

    #[test]
    fn other_writes() {
        let mut p = Params::defaults(&DEFAULTS, 5);
        let none = |_, _| MAPPED;
        assert_eq!(
            p.write(0x1017, 0, &[0xE8, 0x03], none),
            Ok(Changed::Heartbeat)
        );
        assert_eq!(p.heartbeat_ms, 1000);
        assert_eq!(
            p.write(0x1017, 0, &[0xE8], none),
            Err(SdoAbortCode::LengthTooLow)
        );
        assert_eq!(p.write(0x1029, 1, &[2], none), Ok(Changed::Nothing));
        assert_eq!(
            p.write(0x1029, 1, &[3], none),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            p.write(0x1200, 1, &[0; 4], none),
            Err(SdoAbortCode::WriteOfReadOnly)
        );
        assert_eq!(
            p.write(0x1006, 0, &10_000u32.to_le_bytes(), none),
            Ok(Changed::Sync)
        );
        assert_eq!(
            p.write(0x1019, 0, &[4], none),
            Err(SdoAbortCode::DeviceState)
        );
        assert_eq!(p.write(0x1801, 2, &[1], none), Ok(Changed::Tpdo(1)));
        assert_eq!(p.tpdo[1].transmission_type, 1);
        // Making TPDO 1 valid with a mapping of 128 bits is refused (CAN: 64 bits).
        let long = |_, _| MappingInfo {
            count: 8,
            bits: 128,
        };
        assert_eq!(
            p.write(0x1800, 1, &0x185u32.to_le_bytes(), long),
            Err(SdoAbortCode::PdoLengthExceeded)
        );
    }
}
