//! The boot of one node as CiA 302-2 ("boot slave", figures 5..11) does it, as far as this
//! master goes: the identity check, the configuration download with the remote PDO
//! configuration and its read-back, the start of error control, the start. The SDO steps
//! are a pure function of the node's configuration ([`next_op`]), so the sequence a node
//! sees is fixed and tested without a bus.
//!
//! | # | step | SDOs | error (CiA 302-2 letter) |
//! |---|---|---|---|
//! | 1 | device type | upload 0x1000 (always: it tells the node is there) | no answer or abort: B; not the expected value (if configured): C |
//! | 2 | identity | upload 0x1018:01..04, only those with an expected value | vendor D, product code M, revision N, serial number O |
//! | 3 | unused PDOs | 0x1400..3 / 0x1800..3 sub 1 := not valid, for the PDO numbers 1..=4 no place configures (if asked; an abort is accepted) | - |
//! | 4 | PDOs | per PDO: COB-ID not valid, transmission type, inhibit time and event timer (if set), mapping count 0, the entries, the count, COB-ID valid | J |
//! | 5 | error control | 0x1017 producer heartbeat time; with guarding 0x100C and 0x100D | J |
//! | 6 | start-up SDOs | the node's list | J |
//! | 7 | read-back | per PDO: COB-ID (valid bit and CAN-ID), transmission type, mapping count and entries | J |
//! | 8 | error control started | heartbeat: one within the consumer time; guarding: an answer within the guard time | K (heartbeat), F (guarding) |
//! | 9 | start | NMT start, individually or all at once | - |
//!
//! A node that reports itself operational when its boot begins gets L and an NMT reset of
//! its communication (it must not run on a configuration the master did not check). The
//! letters A, E, G, H and I belong to steps this master does not have (the network list is
//! the configuration itself, there is no "keep alive" state check and no software download);
//! they are in [`BootError`] so a report can name every letter the specification names.

use super::super::cob;
use super::super::frame::CobId;
use super::super::params::{
    GUARD_TIME, LIFE_TIME_FACTOR, PRODUCER_HEARTBEAT_TIME, RPDO_COMMUNICATION, RPDO_MAPPING,
    TPDO_COMMUNICATION, TPDO_MAPPING,
};
use super::super::pdo::PdoKind;
use super::config::{NodeConfig, PdoConfig, MAX_MAPPED, MAX_STARTUP_SDOS, PDOS_PER_NODE};

/// The boot errors of CiA 302-2 (its "error status" letters, as Lely's `co_nmt_es2str` and
/// CANopenNode's `CO_BOOTUP_ERROR_x` name them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootError {
    /// A: the node is not in the network list.
    NotInNetworkList,
    /// B: no answer to the upload of 0x1000.
    NoDeviceType,
    /// C: 0x1000 is not the expected device type (0x1F84).
    DeviceTypeMismatch,
    /// D: 0x1018:01 is not the expected vendor-ID (0x1F85).
    VendorIdMismatch,
    /// E: no state answer in "check node state" (heartbeat producer).
    HeartbeatStateCheck,
    /// F: no state answer in "check node state" / error control start (node guarding).
    GuardingStateCheck,
    /// G: software version check asked without expected date and time.
    SoftwareVersionNotConfigured,
    /// H: software version not the expected one, update not allowed.
    SoftwareVersionMismatch,
    /// I: software version not the expected one, update failed.
    SoftwareUpdateFailed,
    /// J: the configuration download failed.
    ConfigurationFailed,
    /// K: no heartbeat during the start of error control.
    HeartbeatMissing,
    /// L: the node was operational when its boot began.
    InitiallyOperational,
    /// M: 0x1018:02 is not the expected product code (0x1F86).
    ProductCodeMismatch,
    /// N: 0x1018:03 is not the expected revision number (0x1F87).
    RevisionMismatch,
    /// O: 0x1018:04 is not the expected serial number (0x1F88).
    SerialNumberMismatch,
}

impl BootError {
    /// The letter CiA 302-2 gives the error.
    pub const fn letter(self) -> char {
        match self {
            Self::NotInNetworkList => 'A',
            Self::NoDeviceType => 'B',
            Self::DeviceTypeMismatch => 'C',
            Self::VendorIdMismatch => 'D',
            Self::HeartbeatStateCheck => 'E',
            Self::GuardingStateCheck => 'F',
            Self::SoftwareVersionNotConfigured => 'G',
            Self::SoftwareVersionMismatch => 'H',
            Self::SoftwareUpdateFailed => 'I',
            Self::ConfigurationFailed => 'J',
            Self::HeartbeatMissing => 'K',
            Self::InitiallyOperational => 'L',
            Self::ProductCodeMismatch => 'M',
            Self::RevisionMismatch => 'N',
            Self::SerialNumberMismatch => 'O',
        }
    }

    /// A short text for a diagnosis message.
    pub const fn text(self) -> &'static str {
        match self {
            Self::NotInNetworkList => "node not in the network list",
            Self::NoDeviceType => "no answer to the device type (0x1000)",
            Self::DeviceTypeMismatch => "device type (0x1000) not the expected one",
            Self::VendorIdMismatch => "vendor-ID (0x1018:01) not the expected one",
            Self::HeartbeatStateCheck => "no heartbeat state in the node state check",
            Self::GuardingStateCheck => "no node guarding answer",
            Self::SoftwareVersionNotConfigured => "software version check not configured",
            Self::SoftwareVersionMismatch => "software version not the expected one",
            Self::SoftwareUpdateFailed => "software update failed",
            Self::ConfigurationFailed => "configuration download failed",
            Self::HeartbeatMissing => "no heartbeat at the start of error control",
            Self::InitiallyOperational => "node was operational before its boot",
            Self::ProductCodeMismatch => "product code (0x1018:02) not the expected one",
            Self::RevisionMismatch => "revision number (0x1018:03) not the expected one",
            Self::SerialNumberMismatch => "serial number (0x1018:04) not the expected one",
        }
    }
}

/// What an upload of the boot checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Check {
    /// An identity value: `expected` (0: only that the node answers); `silent` if it does
    /// not answer, `mismatch` if the value differs.
    Identity {
        /// The expected value (0: any).
        expected: u32,
        /// The error when there is no answer.
        silent: BootError,
        /// The error when the value differs.
        mismatch: BootError,
    },
    /// A value written before: `value & mask` must be `expected` (error J).
    ReadBack {
        /// The value written.
        expected: u32,
        /// The bits compared.
        mask: u32,
    },
}

impl Check {
    /// The error a value `actual` makes, if any.
    pub const fn verdict(self, actual: u32) -> Option<BootError> {
        match self {
            Self::Identity {
                expected, mismatch, ..
            } => {
                if expected != 0 && actual != expected {
                    Some(mismatch)
                } else {
                    None
                }
            }
            Self::ReadBack { expected, mask } => {
                if actual & mask != expected & mask {
                    Some(BootError::ConfigurationFailed)
                } else {
                    None
                }
            }
        }
    }

    /// The error when the upload fails.
    pub const fn failure(self) -> BootError {
        match self {
            Self::Identity { silent, .. } => silent,
            Self::ReadBack { .. } => BootError::ConfigurationFailed,
        }
    }

    /// The value expected.
    pub const fn expected(self) -> u32 {
        match self {
            Self::Identity { expected, .. } | Self::ReadBack { expected, .. } => expected,
        }
    }
}

/// One SDO of the boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootOp {
    /// Upload and check.
    Read {
        /// Index.
        index: u16,
        /// Subindex.
        sub: u8,
        /// What the value must be.
        check: Check,
    },
    /// Download (`size` bytes of `value`, little-endian); an abort fails the boot with J
    /// unless `may_fail`.
    Write {
        /// Index.
        index: u16,
        /// Subindex.
        sub: u8,
        /// The value.
        value: u32,
        /// Bytes, 1..=4.
        size: u8,
        /// An abort is accepted (a PDO the node does not have).
        may_fail: bool,
    },
}

impl BootOp {
    /// Index and subindex.
    pub const fn address(&self) -> (u16, u8) {
        match *self {
            Self::Read { index, sub, .. } | Self::Write { index, sub, .. } => (index, sub),
        }
    }
}

/// The identity uploads.
const IDENTITY: u16 = 5;
/// The "unused PDO" writes: PDO numbers 1..=4 in both directions.
const UNUSED: u16 = 8;
/// Steps per configured PDO: COB-ID off, type, inhibit, event timer, count 0, the entries,
/// count, COB-ID on.
const PDO_WRITES: u16 = 7 + MAX_MAPPED as u16;
const PDO_PLACES: u16 = 2 * PDOS_PER_NODE as u16;
/// 0x1017, 0x100C, 0x100D.
const ERROR_CONTROL: u16 = 3;
/// Read-backs per PDO: COB-ID, type, count, the entries.
const PDO_READS: u16 = 3 + MAX_MAPPED as u16;

/// Where each part of the sequence starts.
const AT_UNUSED: u16 = IDENTITY;
const AT_PDOS: u16 = AT_UNUSED + UNUSED;
const AT_ERROR_CONTROL: u16 = AT_PDOS + PDO_PLACES * PDO_WRITES;
const AT_STARTUP: u16 = AT_ERROR_CONTROL + ERROR_CONTROL;
const AT_READ_BACK: u16 = AT_STARTUP + MAX_STARTUP_SDOS as u16;
/// Steps of the sequence (most are skipped for a given node).
pub const STEPS: u16 = AT_READ_BACK + PDO_PLACES * PDO_READS;

/// The COB-ID bits the read-back compares: "not valid" and the 11-bit CAN-ID (bit 30, "no
/// RTR", is the node's business).
const COB_ID_MASK: u32 = CobId::INVALID | 0x7FF;

/// The PDO of place `place` (0..2 * PDOS_PER_NODE: the RPDOs, then the TPDOs).
fn place(cfg: &NodeConfig, place: u16) -> Option<(PdoKind, &PdoConfig)> {
    let p = usize::from(place);
    match p.checked_sub(PDOS_PER_NODE) {
        None => cfg.rpdo.get(p)?.as_ref().map(|c| (PdoKind::Rpdo, c)),
        Some(t) => cfg.tpdo.get(t)?.as_ref().map(|c| (PdoKind::Tpdo, c)),
    }
}

/// Communication and mapping parameter indices of PDO `number` (1..=512).
const fn indices(kind: PdoKind, number: u16) -> (u16, u16) {
    let i = number.saturating_sub(1);
    match kind {
        PdoKind::Rpdo => (RPDO_COMMUNICATION + i, RPDO_MAPPING + i),
        PdoKind::Tpdo => (TPDO_COMMUNICATION + i, TPDO_MAPPING + i),
    }
}

const fn write(index: u16, sub: u8, value: u32, size: u8) -> BootOp {
    BootOp::Write {
        index,
        sub,
        value,
        size,
        may_fail: false,
    }
}

const fn read_back(index: u16, sub: u8, expected: u32, mask: u32) -> BootOp {
    BootOp::Read {
        index,
        sub,
        check: Check::ReadBack { expected, mask },
    }
}

/// Step `k` of the boot of `cfg`, `None` if the node skips it.
pub fn op(cfg: &NodeConfig, k: u16) -> Option<BootOp> {
    if k < AT_UNUSED {
        return identity_op(cfg, k);
    }
    if k < AT_PDOS {
        return unused_pdo_op(cfg, k - AT_UNUSED);
    }
    if k < AT_ERROR_CONTROL {
        let j = k - AT_PDOS;
        return pdo_write_op(cfg, j / PDO_WRITES, j % PDO_WRITES);
    }
    if k < AT_STARTUP {
        let guarding = cfg.uses_guarding();
        return match k - AT_ERROR_CONTROL {
            0 if cfg.heartbeat_producer_ms != 0 || guarding => Some(write(
                PRODUCER_HEARTBEAT_TIME,
                0,
                cfg.heartbeat_producer_ms.into(),
                2,
            )),
            1 if guarding => Some(write(GUARD_TIME, 0, cfg.guard_time_ms.into(), 2)),
            2 if guarding => Some(write(LIFE_TIME_FACTOR, 0, cfg.life_time_factor.into(), 1)),
            _ => None,
        };
    }
    if k < AT_READ_BACK {
        let s = cfg.startup_sdos().get(usize::from(k - AT_STARTUP))?;
        return Some(write(s.index, s.sub, s.value, s.size));
    }
    let j = k.checked_sub(AT_READ_BACK)?;
    pdo_read_op(cfg, j / PDO_READS, j % PDO_READS)
}

/// The first step at or after `from` the node does, with its number.
pub fn next_op(cfg: &NodeConfig, from: u16) -> Option<(u16, BootOp)> {
    (from..STEPS).find_map(|k| op(cfg, k).map(|o| (k, o)))
}

fn identity_op(cfg: &NodeConfig, k: u16) -> Option<BootOp> {
    use BootError::*;
    let id = &cfg.identity;
    let (index, sub, expected, silent, mismatch) = match k {
        0 => (0x1000, 0, id.device_type, NoDeviceType, DeviceTypeMismatch),
        1 => (0x1018, 1, id.vendor_id, VendorIdMismatch, VendorIdMismatch),
        2 => (
            0x1018,
            2,
            id.product_code,
            ProductCodeMismatch,
            ProductCodeMismatch,
        ),
        3 => (0x1018, 3, id.revision, RevisionMismatch, RevisionMismatch),
        _ => (
            0x1018,
            4,
            id.serial,
            SerialNumberMismatch,
            SerialNumberMismatch,
        ),
    };
    (k == 0 || expected != 0).then_some(BootOp::Read {
        index,
        sub,
        check: Check::Identity {
            expected,
            silent,
            mismatch,
        },
    })
}

fn unused_pdo_op(cfg: &NodeConfig, j: u16) -> Option<BootOp> {
    if !cfg.disable_unused_pdos {
        return None;
    }
    let (kind, places, base) = if j < 4 {
        (PdoKind::Rpdo, &cfg.rpdo, 0x200)
    } else {
        (PdoKind::Tpdo, &cfg.tpdo, 0x180)
    };
    let number = j % 4 + 1;
    if places.iter().flatten().any(|p| p.number == number) {
        return None;
    }
    let default_id = base + 0x100 * (u32::from(number) - 1) + u32::from(cfg.node_id);
    let (comm, _) = indices(kind, number);
    Some(BootOp::Write {
        index: comm,
        sub: 1,
        value: CobId::INVALID | default_id,
        size: 4,
        may_fail: true,
    })
}

fn pdo_write_op(cfg: &NodeConfig, p: u16, j: u16) -> Option<BootOp> {
    let (kind, pdo) = place(cfg, p)?;
    let (comm, map) = indices(kind, pdo.number);
    let cob = u32::from(pdo.cob_id);
    let m = MAX_MAPPED as u16;
    let (event, third) = match kind {
        PdoKind::Rpdo => (pdo.deadline_ms, 0),
        PdoKind::Tpdo => (pdo.event_timer_ms, pdo.inhibit_100us),
    };
    match j {
        0 => Some(write(comm, 1, CobId::INVALID | cob, 4)),
        1 => Some(write(comm, 2, pdo.transmission_type.into(), 1)),
        2 => (third != 0).then_some(write(comm, 3, third.into(), 2)),
        3 => (event != 0).then_some(write(comm, 5, event.into(), 2)),
        4 => Some(write(map, 0, 0, 1)),
        _ if j < 5 + m => {
            let i = j - 5;
            let e = pdo.entries().get(usize::from(i))?;
            Some(write(map, (i + 1) as u8, *e, 4))
        }
        _ if j == 5 + m => Some(write(map, 0, pdo.mapped.into(), 1)),
        _ => Some(write(comm, 1, cob, 4)),
    }
}

fn pdo_read_op(cfg: &NodeConfig, p: u16, j: u16) -> Option<BootOp> {
    let (kind, pdo) = place(cfg, p)?;
    let (comm, map) = indices(kind, pdo.number);
    match j {
        0 => Some(read_back(comm, 1, pdo.cob_id.into(), COB_ID_MASK)),
        1 => Some(read_back(comm, 2, pdo.transmission_type.into(), 0xFF)),
        2 => Some(read_back(map, 0, pdo.mapped.into(), 0xFF)),
        _ => {
            let i = j - 3;
            let e = pdo.entries().get(usize::from(i))?;
            Some(read_back(map, (i + 1) as u8, *e, u32::MAX))
        }
    }
}

/// The node-ID of an error control frame's identifier, if it is one.
pub const fn error_control_node(id: u16) -> Option<u8> {
    match id.checked_sub(cob::NMT_ERROR_CONTROL) {
        Some(n @ 1..=127) => Some(n as u8),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::super::config::{Identity, StartupSdo};
    use super::*;
    use crate::pdo::PdoEntry;
    use std::vec::Vec;

    fn sequence(cfg: &NodeConfig) -> Vec<BootOp> {
        let mut out = Vec::new();
        let mut k = 0;
        while let Some((at, op)) = next_op(cfg, k) {
            out.push(op);
            k = at + 1;
        }
        out
    }

    fn w(index: u16, sub: u8, value: u32, size: u8) -> BootOp {
        write(index, sub, value, size)
    }

    /// The sequence of a servo axis (seed 001): identity with vendor and product, RPDO 1
    /// synchronous with controlword and target position, TPDO 1 with statusword and
    /// position, heartbeat.
    #[test]
    fn the_sequence_of_an_axis() {
        let mut cfg = NodeConfig::new(3);
        cfg.identity = Identity {
            device_type: 0x0002_0192,
            vendor_id: 0x1234,
            product_code: 0x640,
            ..Identity::default()
        };
        cfg.rpdo[0] = Some(PdoConfig::new(
            1,
            0x203,
            1,
            &[PdoEntry::new(0x6040, 0, 16), PdoEntry::new(0x607A, 0, 32)],
        ));
        let mut t = PdoConfig::new(
            1,
            0x183,
            1,
            &[PdoEntry::new(0x6041, 0, 16), PdoEntry::new(0x6064, 0, 32)],
        );
        t.inhibit_100us = 5;
        cfg.tpdo[0] = Some(t);
        cfg.heartbeat_producer_ms = 100;
        cfg.heartbeat_consumer_ms = 250;
        cfg.push_startup(StartupSdo {
            index: 0x6060,
            sub: 0,
            size: 1,
            value: 8,
        });
        let id = |index, sub, expected, silent, mismatch| BootOp::Read {
            index,
            sub,
            check: Check::Identity {
                expected,
                silent,
                mismatch,
            },
        };
        use BootError::*;
        let expected = [
            id(0x1000, 0, 0x0002_0192, NoDeviceType, DeviceTypeMismatch),
            id(0x1018, 1, 0x1234, VendorIdMismatch, VendorIdMismatch),
            id(0x1018, 2, 0x640, ProductCodeMismatch, ProductCodeMismatch),
            w(0x1400, 1, 0x8000_0203, 4),
            w(0x1400, 2, 1, 1),
            w(0x1600, 0, 0, 1),
            w(0x1600, 1, 0x6040_0010, 4),
            w(0x1600, 2, 0x607A_0020, 4),
            w(0x1600, 0, 2, 1),
            w(0x1400, 1, 0x203, 4),
            w(0x1800, 1, 0x8000_0183, 4),
            w(0x1800, 2, 1, 1),
            w(0x1800, 3, 5, 2),
            w(0x1A00, 0, 0, 1),
            w(0x1A00, 1, 0x6041_0010, 4),
            w(0x1A00, 2, 0x6064_0020, 4),
            w(0x1A00, 0, 2, 1),
            w(0x1800, 1, 0x183, 4),
            w(0x1017, 0, 100, 2),
            w(0x6060, 0, 8, 1),
            read_back(0x1400, 1, 0x203, 0x8000_07FF),
            read_back(0x1400, 2, 1, 0xFF),
            read_back(0x1600, 0, 2, 0xFF),
            read_back(0x1600, 1, 0x6040_0010, u32::MAX),
            read_back(0x1600, 2, 0x607A_0020, u32::MAX),
            read_back(0x1800, 1, 0x183, 0x8000_07FF),
            read_back(0x1800, 2, 1, 0xFF),
            read_back(0x1A00, 0, 2, 0xFF),
            read_back(0x1A00, 1, 0x6041_0010, u32::MAX),
            read_back(0x1A00, 2, 0x6064_0020, u32::MAX),
        ];
        assert_eq!(sequence(&cfg), expected);
    }

    #[test]
    fn guarding_unused_pdos_and_a_bare_node() {
        assert_eq!(
            sequence(&NodeConfig::new(9)),
            [BootOp::Read {
                index: 0x1000,
                sub: 0,
                check: Check::Identity {
                    expected: 0,
                    silent: BootError::NoDeviceType,
                    mismatch: BootError::DeviceTypeMismatch
                }
            }]
        );
        let mut cfg = NodeConfig::new(9);
        cfg.guard_time_ms = 50;
        cfg.life_time_factor = 3;
        cfg.disable_unused_pdos = true;
        cfg.tpdo[1] = Some(PdoConfig::new(
            2,
            0x289,
            255,
            &[PdoEntry::new(0x6000, 1, 8)],
        ));
        let s = sequence(&cfg);
        let unused: Vec<(u16, u32)> = s
            .iter()
            .filter_map(|o| match *o {
                BootOp::Write {
                    index,
                    value,
                    may_fail: true,
                    ..
                } => Some((index, value)),
                _ => None,
            })
            .collect();
        assert_eq!(
            unused,
            [
                (0x1400, 0x8000_0209),
                (0x1401, 0x8000_0309),
                (0x1402, 0x8000_0409),
                (0x1403, 0x8000_0509),
                (0x1800, 0x8000_0189),
                (0x1802, 0x8000_0389),
                (0x1803, 0x8000_0489),
            ]
        );
        assert!(s.contains(&w(0x1017, 0, 0, 2)));
        assert!(s.contains(&w(0x100C, 0, 50, 2)));
        assert!(s.contains(&w(0x100D, 0, 3, 1)));
        assert!(s.contains(&w(0x1801, 1, 0x289, 4)));
    }

    #[test]
    fn checks_and_letters() {
        let c = Check::Identity {
            expected: 7,
            silent: BootError::NoDeviceType,
            mismatch: BootError::DeviceTypeMismatch,
        };
        assert_eq!(c.verdict(7), None);
        assert_eq!(c.verdict(8), Some(BootError::DeviceTypeMismatch));
        assert_eq!(c.failure(), BootError::NoDeviceType);
        let any = Check::Identity {
            expected: 0,
            silent: BootError::NoDeviceType,
            mismatch: BootError::DeviceTypeMismatch,
        };
        assert_eq!(any.verdict(12345), None);
        let rb = Check::ReadBack {
            expected: 0x185,
            mask: 0x8000_07FF,
        };
        assert_eq!(rb.verdict(0x4000_0185), None, "bit 30 is the node's");
        assert_eq!(
            rb.verdict(0x8000_0185),
            Some(BootError::ConfigurationFailed)
        );
        let letters: std::string::String = [
            BootError::NotInNetworkList,
            BootError::NoDeviceType,
            BootError::DeviceTypeMismatch,
            BootError::VendorIdMismatch,
            BootError::HeartbeatStateCheck,
            BootError::GuardingStateCheck,
            BootError::SoftwareVersionNotConfigured,
            BootError::SoftwareVersionMismatch,
            BootError::SoftwareUpdateFailed,
            BootError::ConfigurationFailed,
            BootError::HeartbeatMissing,
            BootError::InitiallyOperational,
            BootError::ProductCodeMismatch,
            BootError::RevisionMismatch,
            BootError::SerialNumberMismatch,
        ]
        .iter()
        .map(|e| e.letter())
        .collect();
        assert_eq!(letters, "ABCDEFGHIJKLMNO");
        assert_eq!(error_control_node(0x705), Some(5));
        assert_eq!(error_control_node(0x700), None);
        assert_eq!(error_control_node(0x780), None);
    }
}
