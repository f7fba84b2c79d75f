//! PDOs on CAN (CiA 301 7.2.2, 7.5.2.35..38): the communication parameters (RPDO 0x1400..,
//! TPDO 0x1800..) with their SDO rules, and the per-PDO runtime: transmission types,
//! inhibit time, event timer, SYNC counting, RPDO deadline monitoring.
//!
//! The mapping parameters (0x1600.., 0x1A00..) are the same objects the EtherCAT side
//! assigns ([`crate::pdo::PdoMapping`], validated there); the CAN node reads them through
//! the application and adds the CAN rules: a PDO carries at most 64 bits, and a valid PDO
//! has at least one mapped object.
//!
//! Communication parameter rules (as CiA 301 and the common stacks apply them; every
//! violation is 0x06090030 "value range exceeded" unless said otherwise):
//! - sub 1 COB-ID: bits 28..11 and bit 29 (29-bit frames are not supported) must be 0; the
//!   CAN-ID of a valid PDO cannot change (make it not valid first); a valid PDO needs a
//!   CAN-ID outside the restricted ones, at least one mapped object and at most 64 mapped
//!   bits (0x06040042); bit 30 reads 1 (no RTR: remote-requested PDOs are not served);
//! - sub 2 transmission type: 0 (synchronous, acyclic), 1..=240 (every n-th SYNC), 254,
//!   255 (event-driven); 241..=253 (reserved and the RTR-only types) are refused;
//! - sub 3 inhibit time (TPDO, 100 µs units) and sub 6 SYNC start value (TPDO, 0..=240)
//!   only while the PDO is not valid; sub 5 event timer (ms) any time (RPDO: deadline).

use super::frame::{is_restricted_id, CobId};
use super::param_bytes::{put_le, take_le};
use crate::abort::SdoAbortCode;

/// The most bits a CAN PDO carries (8 data bytes).
pub const MAX_PDO_BITS: u32 = 64;

/// Highest subindex of an RPDO communication parameter (sub 5, event timer).
pub const RPDO_HIGHEST_SUB: u8 = 5;
/// Highest subindex of a TPDO communication parameter (sub 6, SYNC start value).
pub const TPDO_HIGHEST_SUB: u8 = 6;

/// Which way a PDO goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PdoKind {
    /// Received (0x1400 + i, mapping 0x1600 + i).
    Rpdo,
    /// Transmitted (0x1800 + i, mapping 0x1A00 + i).
    Tpdo,
}

/// The meaning of a transmission type (CiA 301 table 71).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Transmission {
    /// 0: synchronous, acyclic (TPDO: at a SYNC after an event; RPDO: applied at the SYNC).
    SyncAcyclic,
    /// 1..=240: synchronous, every n-th SYNC (RPDO: applied at the next SYNC).
    SyncCyclic(u8),
    /// 254 (manufacturer) and 255 (device profile): event-driven (RPDO: applied at once).
    Event,
}

impl Transmission {
    /// The meaning of a transmission type; `None` for the ones this node refuses
    /// (241..=251 reserved, 252/253 RTR-only).
    pub const fn of(value: u8) -> Option<Self> {
        match value {
            0 => Some(Self::SyncAcyclic),
            1..=240 => Some(Self::SyncCyclic(value)),
            254 | 255 => Some(Self::Event),
            _ => None,
        }
    }

    /// True for the SYNC-driven types (0..=240).
    pub const fn is_synchronous(self) -> bool {
        !matches!(self, Self::Event)
    }
}

/// The mapping of a PDO as the communication parameter rules need it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MappingInfo {
    /// Mapped objects (sub 0 of the mapping parameter).
    pub count: u8,
    /// Mapped bits.
    pub bits: u32,
}

impl MappingInfo {
    /// Bytes the PDO carries.
    pub const fn bytes(self) -> usize {
        self.bits.div_ceil(8) as usize
    }

    /// Checks that a PDO with this mapping may be valid on CAN.
    pub const fn check_can(self) -> Result<(), SdoAbortCode> {
        if self.count == 0 {
            return Err(SdoAbortCode::ValueRangeExceeded);
        }
        if self.bits > MAX_PDO_BITS {
            return Err(SdoAbortCode::PdoLengthExceeded);
        }
        Ok(())
    }
}

/// A PDO communication parameter (RECORD PDO_COMM_PAR, CiA 301 0x0020).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoComm {
    /// Sub 1: COB-ID (bit 31 not valid, bit 30 no RTR).
    pub cob_id: CobId,
    /// Sub 2: transmission type.
    pub transmission_type: u8,
    /// Sub 3: inhibit time in 100 µs (TPDO).
    pub inhibit_100us: u16,
    /// Sub 5: event timer in ms (TPDO: period of event-driven PDOs; RPDO: deadline).
    pub event_timer_ms: u16,
    /// Sub 6: SYNC start value (TPDO; 0 = not used).
    pub sync_start: u8,
}

impl PdoComm {
    /// A PDO with this COB-ID and transmission type, no inhibit time, no event timer.
    pub const fn new(cob_id: CobId, transmission_type: u8) -> Self {
        Self {
            cob_id,
            transmission_type,
            inhibit_100us: 0,
            event_timer_ms: 0,
            sync_start: 0,
        }
    }

    /// True if the PDO exists (COB-ID bit 31 clear).
    pub const fn is_valid(&self) -> bool {
        self.cob_id.is_valid()
    }

    /// The meaning of the transmission type (event-driven for a stored value this node
    /// would refuse, which only a wrong default can hold).
    // Out of line: the SYNC, timer, RPDO and parameter paths share one copy.
    #[inline(never)]
    pub const fn transmission(&self) -> Transmission {
        match Transmission::of(self.transmission_type) {
            Some(t) => t,
            None => Transmission::Event,
        }
    }

    /// True if `sub` exists for `kind`.
    pub const fn has_sub(kind: PdoKind, sub: u8) -> bool {
        match kind {
            PdoKind::Rpdo => matches!(sub, 0 | 1 | 2 | 5),
            PdoKind::Tpdo => matches!(sub, 0 | 1 | 2 | 3 | 5 | 6),
        }
    }

    /// The value of `sub` for `kind` and its length in bytes.
    pub fn value(&self, kind: PdoKind, sub: u8) -> Result<(u32, usize), SdoAbortCode> {
        if !Self::has_sub(kind, sub) {
            return Err(SdoAbortCode::SubindexDoesNotExist);
        }
        Ok(match sub {
            0 => (
                match kind {
                    PdoKind::Rpdo => RPDO_HIGHEST_SUB,
                    PdoKind::Tpdo => TPDO_HIGHEST_SUB,
                }
                .into(),
                1,
            ),
            // Remote-requested PDOs are not served: bit 30 always reads 1.
            1 => (self.cob_id.0 | CobId::BIT30, 4),
            2 => (self.transmission_type.into(), 1),
            3 => (self.inhibit_100us.into(), 2),
            5 => (self.event_timer_ms.into(), 2),
            _ => (self.sync_start.into(), 1),
        })
    }

    /// SDO upload of `sub` into `buf`; returns the length.
    pub fn read_sub(&self, kind: PdoKind, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        let (value, len) = self.value(kind, sub)?;
        put_le(buf, value, len)
    }

    /// SDO download of `sub` with the rules of the module documentation; `mapping` is the
    /// PDO's current mapping (for making it valid).
    pub fn write_sub(
        &mut self,
        kind: PdoKind,
        sub: u8,
        data: &[u8],
        mapping: MappingInfo,
    ) -> Result<(), SdoAbortCode> {
        let (_, len) = self.value(kind, sub)?;
        if sub == 0 {
            return Err(SdoAbortCode::WriteOfReadOnly);
        }
        // `value` has `len` bytes: the narrowing casts below keep all of it.
        let value = take_le(data, len)?;
        match sub {
            1 => {
                let new = CobId(value & !CobId::BIT30);
                if new.is_extended() {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                if new.is_valid() {
                    if self.is_valid() && new.can_id() != self.cob_id.can_id() {
                        return Err(SdoAbortCode::ValueRangeExceeded);
                    }
                    if is_restricted_id(new.can_id()) {
                        return Err(SdoAbortCode::ValueRangeExceeded);
                    }
                    mapping.check_can()?;
                }
                self.cob_id = new;
            }
            2 => {
                let t = value as u8;
                Transmission::of(t).ok_or(SdoAbortCode::ValueRangeExceeded)?;
                self.transmission_type = t;
            }
            3 => {
                if self.is_valid() {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                self.inhibit_100us = value as u16;
            }
            5 => self.event_timer_ms = value as u16,
            _ => {
                if self.is_valid() || value > 240 {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                self.sync_start = value as u8;
            }
        }
        Ok(())
    }
}

/// A received PDO's data, kept for the next SYNC (synchronous RPDOs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoData {
    /// Bytes (the first `len` are valid).
    pub bytes: [u8; 8],
    /// Length.
    pub len: u8,
}

impl PdoData {
    /// A copy of `data` (at most 8 bytes).
    pub fn new(data: &[u8]) -> Self {
        let mut bytes = [0u8; 8];
        let len = data.len().min(8);
        if let (Some(dst), Some(src)) = (bytes.get_mut(..len), data.get(..len)) {
            dst.copy_from_slice(src);
        }
        Self {
            bytes,
            len: len as u8,
        }
    }

    /// The valid bytes.
    pub fn as_slice(&self) -> &[u8] {
        self.bytes.get(..usize::from(self.len)).unwrap_or(&[])
    }
}

/// What an RPDO of the wrong length means (CiA 301 7.2.2.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LengthCheck {
    /// As mapped.
    Exact,
    /// Longer than mapped: used, reported once (EMCY 0x8220).
    TooLong,
    /// Shorter than mapped: not used, reported (EMCY 0x8210).
    TooShort,
}

impl LengthCheck {
    /// The check of `len` received bytes against `mapping`.
    pub const fn of(len: usize, mapping: MappingInfo) -> Self {
        let need = mapping.bytes();
        if len < need {
            Self::TooShort
        } else if len > need {
            Self::TooLong
        } else {
            Self::Exact
        }
    }
}

/// The runtime of one RPDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RpdoRuntime {
    /// Data waiting for the next SYNC (synchronous types).
    pub pending: Option<PdoData>,
    /// When the last RPDO came (deadline monitoring starts with the first).
    pub last_us: Option<u64>,
    /// The deadline passed and was reported.
    pub timed_out: bool,
    /// A length error is being reported (cleared by a PDO of the right length).
    pub length_error: bool,
}

impl RpdoRuntime {
    /// Checks the deadline (event timer) at `now_us`: true when it has just passed.
    pub fn deadline_passed(&mut self, event_timer_ms: u16, now_us: u64) -> bool {
        if event_timer_ms == 0 || self.timed_out {
            return false;
        }
        match self.last_us {
            Some(last) if now_us >= last + u64::from(event_timer_ms) * 1000 => {
                self.timed_out = true;
                true
            }
            _ => false,
        }
    }

    /// The deadline, if monitored.
    pub fn deadline_us(&self, event_timer_ms: u16) -> Option<u64> {
        if event_timer_ms == 0 || self.timed_out {
            return None;
        }
        Some(self.last_us? + u64::from(event_timer_ms) * 1000)
    }
}

/// The runtime of one TPDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TpdoRuntime {
    /// SYNCs counted towards the next transmission (cyclic types).
    pub syncs: u8,
    /// The SYNC start value was met (or is not used).
    pub started: bool,
    /// An event asks for a transmission (event-driven types; type 0 at the next SYNC).
    pub requested: bool,
    /// The inhibit time ends here.
    pub inhibit_until_us: u64,
    /// The event timer fires here.
    pub event_at_us: Option<u64>,
    /// The data last sent (change detection).
    pub last: Option<PdoData>,
}

impl TpdoRuntime {
    /// Entering operational: event-driven PDOs are sent once, SYNC counting starts over.
    // Out of line (cold): NMT start and parameter writes share one copy.
    #[inline(never)]
    pub fn start(&mut self, comm: &PdoComm, now_us: u64) {
        *self = Self {
            requested: true,
            started: comm.sync_start == 0,
            event_at_us: (comm.event_timer_ms != 0)
                .then(|| now_us + u64::from(comm.event_timer_ms) * 1000),
            ..Self::default()
        };
    }

    /// A SYNC with `counter` (None: the SYNC carries no counter): true if the PDO is sent
    /// at this SYNC.
    pub fn on_sync(&mut self, comm: &PdoComm, counter: Option<u8>) -> bool {
        match comm.transmission() {
            Transmission::SyncAcyclic => core::mem::take(&mut self.requested),
            Transmission::SyncCyclic(n) => {
                if !self.started {
                    if counter.is_some_and(|c| c == comm.sync_start) || counter.is_none() {
                        self.started = true;
                        self.syncs = 0;
                        return true;
                    }
                    return false;
                }
                self.syncs = self.syncs.saturating_add(1);
                if self.syncs >= n {
                    self.syncs = 0;
                    true
                } else {
                    false
                }
            }
            Transmission::Event => false,
        }
    }

    /// Event-driven: true if the PDO is to be sent at `now_us` (requested or the event timer
    /// fired, and the inhibit time is over).
    pub fn event_due(&mut self, comm: &PdoComm, now_us: u64) -> bool {
        if comm.transmission() != Transmission::Event {
            return false;
        }
        if self.event_at_us.is_some_and(|t| now_us >= t) {
            self.requested = true;
        }
        self.requested && now_us >= self.inhibit_until_us
    }

    /// The PDO was sent at `now_us` with `data`.
    pub fn sent(&mut self, comm: &PdoComm, data: PdoData, now_us: u64) {
        self.requested = false;
        self.last = Some(data);
        self.inhibit_until_us = now_us + u64::from(comm.inhibit_100us) * 100;
        if comm.transmission() == Transmission::Event {
            self.event_at_us =
                (comm.event_timer_ms != 0).then(|| now_us + u64::from(comm.event_timer_ms) * 1000);
        }
    }

    /// The next time [`TpdoRuntime::event_due`] may become true.
    pub fn next_us(&self, comm: &PdoComm) -> Option<u64> {
        if comm.transmission() != Transmission::Event {
            return None;
        }
        if self.requested {
            return Some(self.inhibit_until_us);
        }
        self.event_at_us.map(|t| t.max(self.inhibit_until_us))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAPPED: MappingInfo = MappingInfo { count: 2, bits: 32 };

    fn tpdo() -> PdoComm {
        PdoComm::new(CobId::new(0x285), 255)
    }

    #[test]
    fn transmission_types() {
        assert_eq!(Transmission::of(0), Some(Transmission::SyncAcyclic));
        assert_eq!(Transmission::of(1), Some(Transmission::SyncCyclic(1)));
        assert_eq!(Transmission::of(240), Some(Transmission::SyncCyclic(240)));
        for t in 241..=253 {
            assert_eq!(Transmission::of(t), None, "{t}");
        }
        assert_eq!(Transmission::of(254), Some(Transmission::Event));
        assert_eq!(Transmission::of(255), Some(Transmission::Event));
    }

    #[test]
    fn subindices_per_kind() {
        let c = tpdo();
        let mut buf = [0u8; 4];
        assert_eq!(c.read_sub(PdoKind::Tpdo, 0, &mut buf), Ok(1));
        assert_eq!(buf[0], 6);
        assert_eq!(c.read_sub(PdoKind::Rpdo, 0, &mut buf), Ok(1));
        assert_eq!(buf[0], 5);
        assert_eq!(c.read_sub(PdoKind::Tpdo, 1, &mut buf), Ok(4));
        assert_eq!(u32::from_le_bytes(buf), 0x4000_0285, "bit 30: no RTR");
        assert_eq!(
            c.read_sub(PdoKind::Tpdo, 4, &mut buf),
            Err(SdoAbortCode::SubindexDoesNotExist),
            "sub 4 is reserved"
        );
        assert_eq!(
            c.read_sub(PdoKind::Rpdo, 3, &mut buf),
            Err(SdoAbortCode::SubindexDoesNotExist)
        );
        assert_eq!(
            c.read_sub(PdoKind::Rpdo, 6, &mut buf),
            Err(SdoAbortCode::SubindexDoesNotExist)
        );
    }

    #[test]
    fn cob_id_rules() {
        let mut c = tpdo();
        let w = |c: &mut PdoComm, v: u32, m| c.write_sub(PdoKind::Tpdo, 1, &v.to_le_bytes(), m);
        // Valid PDO: the CAN-ID cannot change, the same one (bit 30 either way) is fine.
        assert_eq!(
            w(&mut c, 0x286, MAPPED),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(w(&mut c, 0x4000_0285, MAPPED), Ok(()));
        // Invalidate, change, validate.
        assert_eq!(w(&mut c, 0x8000_0285, MAPPED), Ok(()));
        assert!(!c.is_valid());
        assert_eq!(w(&mut c, 0x8000_0286, MAPPED), Ok(()));
        assert_eq!(w(&mut c, 0x286, MAPPED), Ok(()));
        assert_eq!(c.cob_id, CobId::new(0x286));
        // Extended, restricted, empty or too long mappings.
        c.cob_id = c.cob_id.invalid();
        assert_eq!(
            w(&mut c, 0x2000_0286, MAPPED),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            w(&mut c, 0x0000_0901, MAPPED),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            w(&mut c, 0x605, MAPPED),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            w(&mut c, 0x286, MappingInfo { count: 0, bits: 0 }),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            w(&mut c, 0x286, MappingInfo { count: 5, bits: 80 }),
            Err(SdoAbortCode::PdoLengthExceeded)
        );
        // A too-long mapping may stay on a PDO that is not valid.
        assert_eq!(
            w(&mut c, 0x8000_0286, MappingInfo { count: 5, bits: 80 }),
            Ok(())
        );
        assert_eq!(
            c.write_sub(PdoKind::Tpdo, 1, &[1, 2], MAPPED),
            Err(SdoAbortCode::LengthTooLow)
        );
    }

    #[test]
    fn other_sub_rules() {
        let mut c = tpdo();
        assert_eq!(c.write_sub(PdoKind::Tpdo, 2, &[1], MAPPED), Ok(()));
        assert_eq!(c.transmission(), Transmission::SyncCyclic(1));
        assert_eq!(
            c.write_sub(PdoKind::Tpdo, 2, &[252], MAPPED),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            c.write_sub(PdoKind::Tpdo, 3, &[10, 0], MAPPED),
            Err(SdoAbortCode::ValueRangeExceeded),
            "inhibit time of a valid PDO"
        );
        assert_eq!(c.write_sub(PdoKind::Tpdo, 5, &[100, 0], MAPPED), Ok(()));
        assert_eq!(c.event_timer_ms, 100);
        assert_eq!(
            c.write_sub(PdoKind::Tpdo, 0, &[6], MAPPED),
            Err(SdoAbortCode::WriteOfReadOnly)
        );
        c.cob_id = c.cob_id.invalid();
        assert_eq!(c.write_sub(PdoKind::Tpdo, 3, &[10, 0], MAPPED), Ok(()));
        assert_eq!(c.inhibit_100us, 10);
        assert_eq!(c.write_sub(PdoKind::Tpdo, 6, &[240], MAPPED), Ok(()));
        assert_eq!(
            c.write_sub(PdoKind::Tpdo, 6, &[241], MAPPED),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
    }

    #[test]
    fn cyclic_tpdo_counts_syncs() {
        let comm = PdoComm::new(CobId::new(0x285), 3);
        let mut rt = TpdoRuntime::default();
        rt.start(&comm, 0);
        let sent: std::vec::Vec<bool> = (0..7).map(|_| rt.on_sync(&comm, None)).collect();
        assert_eq!(sent, [false, false, true, false, false, true, false]);
    }

    #[test]
    fn sync_start_value_waits_for_the_counter() {
        let mut comm = PdoComm::new(CobId::new(0x285), 2);
        comm.sync_start = 3;
        let mut rt = TpdoRuntime::default();
        rt.start(&comm, 0);
        let sent: std::vec::Vec<bool> = (1..=7).map(|c| rt.on_sync(&comm, Some(c))).collect();
        assert_eq!(sent, [false, false, true, false, true, false, true]);
    }

    #[test]
    fn acyclic_sync_tpdo_needs_an_event() {
        let comm = PdoComm::new(CobId::new(0x285), 0);
        let mut rt = TpdoRuntime::default();
        rt.start(&comm, 0);
        assert!(rt.on_sync(&comm, None), "first SYNC after start");
        assert!(!rt.on_sync(&comm, None));
        rt.requested = true;
        assert!(rt.on_sync(&comm, None));
    }

    #[test]
    fn event_tpdo_with_timer_and_inhibit() {
        let mut comm = PdoComm::new(CobId::new(0x285), 255);
        comm.event_timer_ms = 10;
        comm.inhibit_100us = 50; // 5 ms
        let mut rt = TpdoRuntime::default();
        rt.start(&comm, 0);
        assert!(rt.event_due(&comm, 0), "sent once when operational");
        rt.sent(&comm, PdoData::new(&[1]), 0);
        assert!(!rt.event_due(&comm, 9_999));
        assert_eq!(rt.next_us(&comm), Some(10_000));
        assert!(rt.event_due(&comm, 10_000));
        rt.sent(&comm, PdoData::new(&[1]), 10_000);
        // A requested transmission waits for the inhibit time.
        rt.requested = true;
        assert!(!rt.event_due(&comm, 14_999));
        assert_eq!(rt.next_us(&comm), Some(15_000));
        assert!(rt.event_due(&comm, 15_000));
        assert!(!rt.on_sync(&comm, None), "SYNC does not send event PDOs");
    }

    #[test]
    fn rpdo_deadline() {
        let mut rt = RpdoRuntime::default();
        assert!(!rt.deadline_passed(100, 1_000_000), "not received yet");
        rt.last_us = Some(0);
        assert_eq!(rt.deadline_us(100), Some(100_000));
        assert!(!rt.deadline_passed(100, 99_999));
        assert!(rt.deadline_passed(100, 100_000));
        assert!(!rt.deadline_passed(100, 200_000), "reported once");
        assert!(!RpdoRuntime::default().deadline_passed(0, u64::MAX));
    }

    #[test]
    fn length_checks() {
        let m = MappingInfo { count: 2, bits: 32 };
        assert_eq!(LengthCheck::of(4, m), LengthCheck::Exact);
        assert_eq!(LengthCheck::of(3, m), LengthCheck::TooShort);
        assert_eq!(LengthCheck::of(8, m), LengthCheck::TooLong);
        assert_eq!(MappingInfo { count: 1, bits: 1 }.bytes(), 1);
        assert_eq!(PdoData::new(&[1, 2, 3]).as_slice(), &[1, 2, 3]);
        assert_eq!(PdoData::new(&[0; 12]).len, 8);
    }
}
