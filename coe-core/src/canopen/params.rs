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

fn put(buf: &mut [u8], bytes: &[u8]) -> Result<usize, SdoAbortCode> {
    buf.get_mut(..bytes.len())
        .ok_or(SdoAbortCode::OutOfMemory)?
        .copy_from_slice(bytes);
    Ok(bytes.len())
}

fn le<const N: usize>(data: &[u8]) -> Result<[u8; N], SdoAbortCode> {
    <[u8; N]>::try_from(data).map_err(|_| {
        if data.len() < N {
            SdoAbortCode::LengthTooLow
        } else {
            SdoAbortCode::LengthTooHigh
        }
    })
}

/// Only sub 0 exists (VAR).
fn var(sub: u8) -> Result<(), SdoAbortCode> {
    if sub == 0 {
        Ok(())
    } else {
        Err(SdoAbortCode::SubindexDoesNotExist)
    }
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

    /// SDO upload of `index:sub` (node `node` for 0x1200).
    pub fn read(
        &self,
        node: u8,
        index: u16,
        sub: u8,
        buf: &mut [u8],
    ) -> Result<usize, SdoAbortCode> {
        if let Some((kind, i)) = Self::pdo_of(index) {
            return self
                .pdo(kind, i)
                .ok_or(SdoAbortCode::ObjectDoesNotExist)?
                .read_sub(kind, sub, buf);
        }
        match index {
            COB_ID_SYNC => var(sub).and_then(|()| put(buf, &self.sync.cob_id.0.to_le_bytes())),
            COMMUNICATION_CYCLE_PERIOD => {
                var(sub).and_then(|()| put(buf, &self.sync.period_us.to_le_bytes()))
            }
            GUARD_TIME => var(sub).and_then(|()| put(buf, &self.guard_time_ms.to_le_bytes())),
            LIFE_TIME_FACTOR => var(sub).and_then(|()| put(buf, &[self.life_factor])),
            COB_ID_EMCY => var(sub).and_then(|()| put(buf, &self.emcy.cob_id.0.to_le_bytes())),
            INHIBIT_TIME_EMCY => {
                var(sub).and_then(|()| put(buf, &self.emcy.inhibit_100us.to_le_bytes()))
            }
            PRODUCER_HEARTBEAT_TIME => {
                var(sub).and_then(|()| put(buf, &self.heartbeat_ms.to_le_bytes()))
            }
            SYNC_COUNTER_OVERFLOW => var(sub).and_then(|()| put(buf, &[self.sync.overflow])),
            CONSUMER_HEARTBEAT_TIME => match sub {
                0 => put(buf, &[HB as u8]),
                _ => {
                    let e = self
                        .consumers
                        .get(usize::from(sub) - 1)
                        .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
                    put(buf, &e.to_u32().to_le_bytes())
                }
            },
            ERROR_BEHAVIOUR => match sub {
                0 => put(buf, &[1]),
                1 => put(buf, &[self.error_behaviour]),
                _ => Err(SdoAbortCode::SubindexDoesNotExist),
            },
            SDO_SERVER_PARAMETER => match sub {
                0 => put(buf, &[2]),
                1 => put(buf, &u32::from(cob::SDO_RX + u16::from(node)).to_le_bytes()),
                2 => put(buf, &u32::from(cob::SDO_TX + u16::from(node)).to_le_bytes()),
                _ => Err(SdoAbortCode::SubindexDoesNotExist),
            },
            _ => Err(SdoAbortCode::ObjectDoesNotExist),
        }
    }

    /// SDO download of `index:sub`; `mapping` gives the current mapping of a PDO (for the
    /// checks of making it valid). Returns what the runtime must know.
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
        let sub0_fixed = |sub: u8| {
            if sub == 0 {
                Err(SdoAbortCode::WriteOfReadOnly)
            } else {
                Ok(())
            }
        };
        match index {
            COB_ID_SYNC => {
                var(sub)?;
                self.sync.set_cob_id(u32::from_le_bytes(le(data)?))?;
                Ok(Changed::Sync)
            }
            COMMUNICATION_CYCLE_PERIOD => {
                var(sub)?;
                self.sync.period_us = u32::from_le_bytes(le(data)?);
                Ok(Changed::Sync)
            }
            GUARD_TIME => {
                var(sub)?;
                self.guard_time_ms = u16::from_le_bytes(le(data)?);
                Ok(Changed::Nothing)
            }
            LIFE_TIME_FACTOR => {
                var(sub)?;
                let [v] = le(data)?;
                self.life_factor = v;
                Ok(Changed::Nothing)
            }
            COB_ID_EMCY => {
                var(sub)?;
                self.emcy.set_cob_id(u32::from_le_bytes(le(data)?))?;
                Ok(Changed::Nothing)
            }
            INHIBIT_TIME_EMCY => {
                var(sub)?;
                self.emcy.inhibit_100us = u16::from_le_bytes(le(data)?);
                Ok(Changed::Nothing)
            }
            PRODUCER_HEARTBEAT_TIME => {
                var(sub)?;
                self.heartbeat_ms = u16::from_le_bytes(le(data)?);
                Ok(Changed::Heartbeat)
            }
            SYNC_COUNTER_OVERFLOW => {
                var(sub)?;
                let [v] = le(data)?;
                self.sync.set_overflow(v)?;
                Ok(Changed::Sync)
            }
            CONSUMER_HEARTBEAT_TIME => {
                sub0_fixed(sub)?;
                let i = usize::from(sub) - 1;
                if i >= HB {
                    return Err(SdoAbortCode::SubindexDoesNotExist);
                }
                let entry = ConsumerEntry::from_u32(u32::from_le_bytes(le(data)?));
                if entry.node > 127 {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                let clash = self.consumers.iter().enumerate().any(|(j, e)| {
                    j != i && e.is_active() && entry.is_active() && e.node == entry.node
                });
                if clash {
                    return Err(SdoAbortCode::ParameterIncompatible);
                }
                if let Some(slot) = self.consumers.get_mut(i) {
                    *slot = entry;
                }
                Ok(Changed::Consumer(i))
            }
            ERROR_BEHAVIOUR => {
                sub0_fixed(sub)?;
                if sub != 1 {
                    return Err(SdoAbortCode::SubindexDoesNotExist);
                }
                let [v] = le(data)?;
                if v > error_behaviour::STOPPED {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                self.error_behaviour = v;
                Ok(Changed::Nothing)
            }
            SDO_SERVER_PARAMETER => match sub {
                0..=2 => Err(SdoAbortCode::WriteOfReadOnly),
                _ => Err(SdoAbortCode::SubindexDoesNotExist),
            },
            _ => Err(SdoAbortCode::ObjectDoesNotExist),
        }
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
