//! What the master is told: its own parameters ([`MasterConfig`], the CiA 302 0x1F80 /
//! 0x1006 / 0x1017 family, the gateway's 0xF800) and, per configured node, what to expect
//! and what to download ([`NodeConfig`], the CiA 302 network list 0x1F81 / 0x1F84..0x1F88
//! plus the PDO layout, the gateway's 0x8000 + 16n records).
//!
//! Every value is plain data with a fixed size, so the gateway fills a slot from its object
//! dictionary entry by entry; [`NodeConfig::check`] says what is wrong with a slot before
//! the master boots it.

use super::super::cob;
use super::super::frame::is_restricted_id;
use super::super::pdo::{Transmission, MAX_PDO_BITS};
use crate::pdo::PdoEntry;

/// PDOs per direction per node the master configures and exchanges (the four of the
/// predefined connection set; any PDO number of the node can take a place).
pub const PDOS_PER_NODE: usize = 4;

/// Mapped objects per PDO (8 bytes carry at most 8 byte-sized objects).
pub const MAX_MAPPED: usize = 8;

/// Start-up SDOs per node besides the PDO and error control parameters.
pub const MAX_STARTUP_SDOS: usize = 8;

/// The identity a node must show (CiA 302 0x1F84..0x1F88); 0 means "not checked" (the
/// device type is read in any case: it tells whether the node is there).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identity {
    /// 0x1000 device type (0x1F84).
    pub device_type: u32,
    /// 0x1018:01 vendor-ID (0x1F85).
    pub vendor_id: u32,
    /// 0x1018:02 product code (0x1F86).
    pub product_code: u32,
    /// 0x1018:03 revision number (0x1F87).
    pub revision: u32,
    /// 0x1018:04 serial number (0x1F88).
    pub serial: u32,
}

/// One PDO of a node as the master configures it there and exchanges it.
///
/// For an RPDO of the node (the master's output) `deadline_ms` is written to the node's
/// 0x1400+k:05 (its deadline monitoring) and `event_timer_ms` is how often the master
/// repeats an event-driven RPDO whose data did not change. For a TPDO of the node (the
/// master's input) `event_timer_ms` is written to 0x1800+k:05 and `deadline_ms` is the
/// master's own supervision of an event-driven TPDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoConfig {
    /// The node's PDO number, 1..=512 (communication parameter 0x1400/0x1800 + number - 1).
    pub number: u16,
    /// The 11-bit CAN-ID.
    pub cob_id: u16,
    /// Transmission type (0..=240 synchronous, 254/255 event-driven).
    pub transmission_type: u8,
    /// Inhibit time in 100 µs (TPDO sub 3; 0 = not written).
    pub inhibit_100us: u16,
    /// See the type's documentation (0 = not written / no repetition).
    pub event_timer_ms: u16,
    /// See the type's documentation (0 = not written / not supervised).
    pub deadline_ms: u16,
    /// Mapping entries (`index << 16 | sub << 8 | bits`), the first `mapped` are used.
    pub mapping: [u32; MAX_MAPPED],
    /// Mapped objects.
    pub mapped: u8,
}

impl PdoConfig {
    /// A PDO on `cob_id` with transmission type `transmission_type` carrying `entries`
    /// (at most [`MAX_MAPPED`]; the rest is dropped).
    pub fn new(number: u16, cob_id: u16, transmission_type: u8, entries: &[PdoEntry]) -> Self {
        let mut mapping = [0u32; MAX_MAPPED];
        let mut mapped = 0u8;
        for (slot, e) in mapping.iter_mut().zip(entries) {
            *slot = e.to_u32();
            mapped += 1;
        }
        Self {
            number,
            cob_id,
            transmission_type,
            inhibit_100us: 0,
            event_timer_ms: 0,
            deadline_ms: 0,
            mapping,
            mapped,
        }
    }

    /// The mapping entries in use.
    pub fn entries(&self) -> &[u32] {
        self.mapping
            .get(..usize::from(self.mapped))
            .unwrap_or(&self.mapping)
    }

    /// Mapped bits.
    pub fn bits(&self) -> u32 {
        self.entries().iter().map(|e| e & 0xFF).sum()
    }

    /// Bytes the PDO carries on the bus.
    pub fn len(&self) -> usize {
        self.bits().div_ceil(8) as usize
    }

    /// True if nothing is mapped.
    pub fn is_empty(&self) -> bool {
        self.mapped == 0
    }

    /// The meaning of the transmission type (`None`: one the master does not use).
    pub const fn transmission(&self) -> Option<Transmission> {
        Transmission::of(self.transmission_type)
    }
}

/// A start-up SDO: a value of 1..=4 bytes written after the PDO configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StartupSdo {
    /// Index.
    pub index: u16,
    /// Subindex.
    pub sub: u8,
    /// Size in bytes, 1..=4.
    pub size: u8,
    /// The value (little-endian on the wire).
    pub value: u32,
}

/// One configured node (a place of the network list).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NodeConfig {
    /// Node-ID 1..=127; 0 leaves the place empty.
    pub node_id: u8,
    /// What the node must show.
    pub identity: Identity,
    /// A mandatory node (0x1F81 bit 3): its boot error keeps the network from starting and
    /// it is not retried on a timer (only when it boots up or the application restarts it).
    pub mandatory: bool,
    /// Make the node's PDOs 1..=4 that no place here configures not valid, so they stay off
    /// the bus (a node without them is fine).
    pub disable_unused_pdos: bool,
    /// The node's RPDOs (the master's outputs), by place.
    pub rpdo: [Option<PdoConfig>; PDOS_PER_NODE],
    /// The node's TPDOs (the master's inputs), by place.
    pub tpdo: [Option<PdoConfig>; PDOS_PER_NODE],
    /// Written to the node's 0x1017 (0 with node guarding: not written without).
    pub heartbeat_producer_ms: u16,
    /// The master's heartbeat consumer time for the node (0: heartbeat not monitored).
    pub heartbeat_consumer_ms: u16,
    /// Node guarding: guard time (0x100C, ms; 0 = no guarding). Used when the heartbeat is
    /// not monitored.
    pub guard_time_ms: u16,
    /// Node guarding: life time factor (0x100D).
    pub life_time_factor: u8,
    /// Start-up SDOs, the first `startup_count` are used.
    pub startup: [StartupSdo; MAX_STARTUP_SDOS],
    /// Start-up SDOs in use.
    pub startup_count: u8,
}

/// What is wrong with a [`NodeConfig`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// The node-ID is above 127.
    NodeId,
    /// A PDO number is 0 or above 512.
    PdoNumber,
    /// A PDO's CAN-ID is above 0x7FF or restricted (CiA 301 7.3.5).
    CobId,
    /// A transmission type the master does not use (241..=253).
    TransmissionType,
    /// A PDO maps nothing or more than 64 bits.
    Mapping,
    /// Two PDOs (or a PDO and the SYNC) on one CAN-ID.
    DuplicateCobId,
    /// A start-up SDO of 0 or more than 4 bytes.
    StartupSize,
    /// Node guarding with a life time factor of 0.
    LifeTimeFactor,
    /// The master is running: a place changes only while it is stopped.
    Running,
    /// No such place.
    NoPlace,
}

impl NodeConfig {
    /// An empty place.
    pub const EMPTY: Self = Self {
        node_id: 0,
        identity: Identity {
            device_type: 0,
            vendor_id: 0,
            product_code: 0,
            revision: 0,
            serial: 0,
        },
        mandatory: false,
        disable_unused_pdos: false,
        rpdo: [None; PDOS_PER_NODE],
        tpdo: [None; PDOS_PER_NODE],
        heartbeat_producer_ms: 0,
        heartbeat_consumer_ms: 0,
        guard_time_ms: 0,
        life_time_factor: 0,
        startup: [StartupSdo {
            index: 0,
            sub: 0,
            size: 0,
            value: 0,
        }; MAX_STARTUP_SDOS],
        startup_count: 0,
    };

    /// A node `node_id` with nothing else configured.
    pub const fn new(node_id: u8) -> Self {
        Self {
            node_id,
            ..Self::EMPTY
        }
    }

    /// True if the place holds a node.
    pub const fn is_used(&self) -> bool {
        self.node_id != 0
    }

    /// The start-up SDOs in use.
    pub fn startup_sdos(&self) -> &[StartupSdo] {
        self.startup
            .get(..usize::from(self.startup_count))
            .unwrap_or(&self.startup)
    }

    /// Adds a start-up SDO; false when the list is full.
    pub fn push_startup(&mut self, sdo: StartupSdo) -> bool {
        match self.startup.get_mut(usize::from(self.startup_count)) {
            Some(slot) => {
                *slot = sdo;
                self.startup_count += 1;
                true
            }
            None => false,
        }
    }

    /// True if the master watches the node's heartbeat.
    pub const fn uses_heartbeat(&self) -> bool {
        self.heartbeat_consumer_ms != 0
    }

    /// True if the master guards the node (no heartbeat watched, a guard time set).
    pub const fn uses_guarding(&self) -> bool {
        !self.uses_heartbeat() && self.guard_time_ms != 0
    }

    /// Checks the place (an empty place is fine); `sync_cob_id` is the master's SYNC.
    pub fn check(&self, sync_cob_id: u16) -> Result<(), ConfigError> {
        if !self.is_used() {
            return Ok(());
        }
        if !cob::is_node_id(self.node_id) {
            return Err(ConfigError::NodeId);
        }
        let pdos = || self.rpdo.iter().chain(self.tpdo.iter()).flatten();
        for p in pdos() {
            if !(1..=512).contains(&p.number) {
                return Err(ConfigError::PdoNumber);
            }
            if p.cob_id > super::super::frame::MAX_ID || is_restricted_id(p.cob_id) {
                return Err(ConfigError::CobId);
            }
            if p.cob_id == sync_cob_id || pdos().filter(|q| q.cob_id == p.cob_id).count() > 1 {
                return Err(ConfigError::DuplicateCobId);
            }
            if p.transmission().is_none() {
                return Err(ConfigError::TransmissionType);
            }
            if p.is_empty() || p.bits() > MAX_PDO_BITS {
                return Err(ConfigError::Mapping);
            }
        }
        if self
            .startup_sdos()
            .iter()
            .any(|s| !(1..=4).contains(&s.size))
        {
            return Err(ConfigError::StartupSize);
        }
        if self.uses_guarding() && self.life_time_factor == 0 {
            return Err(ConfigError::LifeTimeFactor);
        }
        Ok(())
    }
}

/// The master's own parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MasterConfig {
    /// The master's node-ID (its heartbeat's CAN-ID).
    pub node_id: u8,
    /// The master's heartbeat period in ms (0: none).
    pub heartbeat_ms: u16,
    /// SYNC CAN-ID (0x1005; default 0x080).
    pub sync_cob_id: u16,
    /// Free-running SYNC period in µs (0x1006; 0 = only from the cycle events).
    pub sync_period_us: u32,
    /// One SYNC per this many external cycle events ([`super::Master::cycle_event`]; the
    /// EL6751's sync multiplier; 0 = cycle events do not make SYNCs).
    pub sync_multiplier: u8,
    /// Synchronous counter overflow (0x1019; 0 = SYNC without counter, else 2..=240).
    pub sync_overflow: u8,
    /// How long an SDO answer may take (ms).
    pub sdo_timeout_ms: u16,
    /// Reset the communication of all nodes (NMT broadcast) when the master starts.
    pub reset_on_start: bool,
    /// How long the master waits for a node's boot-up message after that reset before it
    /// boots the node anyway (ms).
    pub boot_wait_ms: u16,
    /// When an optional node that failed is booted again (ms).
    pub retry_ms: u16,
    /// Start every node with one broadcast once all mandatory nodes are configured (0x1F80
    /// bit 3 cleared, bit 1 set), instead of each node when its own boot ends.
    pub start_all_at_once: bool,
}

impl Default for MasterConfig {
    fn default() -> Self {
        Self {
            node_id: 0x7F,
            heartbeat_ms: 0,
            sync_cob_id: cob::SYNC,
            sync_period_us: 0,
            sync_multiplier: 1,
            sync_overflow: 0,
            sdo_timeout_ms: 100,
            reset_on_start: true,
            boot_wait_ms: 500,
            retry_ms: 1000,
            start_all_at_once: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pdo(cob: u16) -> PdoConfig {
        PdoConfig::new(1, cob, 1, &[PdoEntry::new(0x6000, 1, 16)])
    }

    #[test]
    fn pdo_length_from_the_mapping() {
        let p = PdoConfig::new(
            1,
            0x185,
            1,
            &[PdoEntry::new(0x6041, 0, 16), PdoEntry::new(0x6064, 0, 32)],
        );
        assert_eq!(p.entries(), &[0x6041_0010, 0x6064_0020]);
        assert_eq!(p.bits(), 48);
        assert_eq!(p.len(), 6);
    }

    #[test]
    fn checks() {
        let mut n = NodeConfig::new(5);
        n.tpdo[0] = Some(pdo(0x185));
        n.rpdo[0] = Some(pdo(0x205));
        assert_eq!(n.check(0x80), Ok(()));
        assert_eq!(NodeConfig::EMPTY.check(0x80), Ok(()));
        assert_eq!(NodeConfig::new(128).check(0x80), Err(ConfigError::NodeId));
        let mut bad = n;
        bad.rpdo[0] = Some(pdo(0x185));
        assert_eq!(bad.check(0x80), Err(ConfigError::DuplicateCobId));
        bad.rpdo[0] = Some(pdo(0x705));
        assert_eq!(bad.check(0x80), Err(ConfigError::CobId));
        bad.rpdo[0] = Some(PdoConfig::new(1, 0x205, 1, &[]));
        assert_eq!(bad.check(0x80), Err(ConfigError::Mapping));
        bad.rpdo[0] = Some(PdoConfig::new(1, 0x205, 1, &[PdoEntry::new(1, 1, 64); 2]));
        assert_eq!(bad.check(0x80), Err(ConfigError::Mapping));
        let mut t = pdo(0x205);
        t.transmission_type = 250;
        bad.rpdo[0] = Some(t);
        assert_eq!(bad.check(0x80), Err(ConfigError::TransmissionType));
        t.transmission_type = 1;
        t.number = 0;
        bad.rpdo[0] = Some(t);
        assert_eq!(bad.check(0x80), Err(ConfigError::PdoNumber));
        let mut g = n;
        g.guard_time_ms = 100;
        assert_eq!(g.check(0x80), Err(ConfigError::LifeTimeFactor));
        g.life_time_factor = 3;
        assert!(g.uses_guarding());
        g.heartbeat_consumer_ms = 300;
        assert!(!g.uses_guarding() && g.uses_heartbeat());
        let mut s = n;
        assert!(s.push_startup(StartupSdo {
            index: 0x2000,
            sub: 0,
            size: 5,
            value: 0
        }));
        assert_eq!(s.check(0x80), Err(ConfigError::StartupSize));
    }
}
