//! NMT (CiA 301 7.2.8.2 and 7.3.2): the slave state machine, the module control commands
//! (COB-ID 0x000, two bytes: command specifier, node-ID or 0 for all nodes) and the state
//! codes that boot-up, heartbeat and node guarding report.
//!
//! ```text
//!  power on / reset -> Initialising --(boot-up sent)--> Pre-operational
//!  Pre-operational <-> Operational <-> Stopped <-> Pre-operational   (start 0x01, stop 0x02,
//!                                                                       enter pre-op 0x80)
//!  any state --(reset node 0x81 / reset communication 0x82)--> Initialising
//! ```
//!
//! Which services run in each state ([`NmtState::allows`]): SDO, SYNC and EMCY in
//! pre-operational and operational, PDO only in operational, NMT and error control always.

use crate::esm::AlState;

crate::open_enum! {
    /// NMT module control command specifier (CiA 301 table 42).
    pub enum NmtCommand(u8) {
        /// Start remote node: enter operational.
        StartRemoteNode = 0x01,
        /// Stop remote node: enter stopped.
        StopRemoteNode = 0x02,
        /// Enter pre-operational.
        EnterPreOperational = 0x80,
        /// Reset node: application and communication parameters to their defaults.
        ResetNode = 0x81,
        /// Reset communication: communication parameters to their defaults.
        ResetCommunication = 0x82,
    }
}

/// Length of an NMT module control frame.
pub const COMMAND_LEN: usize = 2;

/// An NMT module control frame as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NmtCommandRepr {
    /// The command.
    pub command: NmtCommand,
    /// The addressed node, 0 for all nodes.
    pub node: u8,
}

impl NmtCommandRepr {
    /// Parses the data of an NMT frame: exactly two bytes (CiA 301 7.2.8.3.1.1).
    pub fn parse(data: &[u8]) -> Option<Self> {
        match *data {
            [command, node] => Some(Self {
                command: NmtCommand::from(command),
                node,
            }),
            _ => None,
        }
    }

    /// The two data bytes.
    pub fn emit(&self) -> [u8; COMMAND_LEN] {
        [u8::from(self.command), self.node]
    }

    /// True if the command is for `node` (its own ID or 0, all nodes).
    pub const fn addresses(&self, node: u8) -> bool {
        self.node == 0 || self.node == node
    }
}

/// The NMT state of a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NmtState {
    /// Initialising: after power-on or a reset, until the boot-up message is sent.
    Initialising,
    /// Pre-operational: SDO configuration, no PDOs.
    PreOperational,
    /// Operational: everything, PDOs included.
    Operational,
    /// Stopped: only NMT and error control.
    Stopped,
}

/// A service whose availability depends on the NMT state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Service {
    /// SDO (server).
    Sdo,
    /// PDO (both directions).
    Pdo,
    /// SYNC consumer.
    Sync,
    /// EMCY producer.
    Emcy,
    /// Heartbeat producer/consumer and node guarding.
    ErrorControl,
}

impl NmtState {
    /// The state code of heartbeat and node guarding messages (CiA 301 table 52): 0 boot-up,
    /// 4 stopped, 5 operational, 127 pre-operational.
    pub const fn code(self) -> u8 {
        match self {
            Self::Initialising => 0,
            Self::Stopped => 4,
            Self::Operational => 5,
            Self::PreOperational => 127,
        }
    }

    /// The state of a state code (bit 7, the node guarding toggle, ignored).
    pub const fn from_code(code: u8) -> Option<Self> {
        match code & 0x7F {
            0 => Some(Self::Initialising),
            4 => Some(Self::Stopped),
            5 => Some(Self::Operational),
            127 => Some(Self::PreOperational),
            _ => None,
        }
    }

    /// True if `service` runs in this state (CiA 301 table 45).
    pub const fn allows(self, service: Service) -> bool {
        match (self, service) {
            (_, Service::ErrorControl) => !matches!(self, Self::Initialising),
            (Self::Operational, _) => true,
            (Self::PreOperational, Service::Pdo) => false,
            (Self::PreOperational, _) => true,
            (Self::Stopped | Self::Initialising, _) => false,
        }
    }

    /// The state the object dictionary's access rights are checked against for an SDO in
    /// this state: the access words name EtherCAT states, and CANopen's pre-operational and
    /// operational have the same meaning (configuration allowed / process data running).
    /// `None` where no SDO is served.
    pub const fn access_state(self) -> Option<AlState> {
        match self {
            Self::PreOperational => Some(AlState::PreOp),
            Self::Operational => Some(AlState::Op),
            Self::Stopped | Self::Initialising => None,
        }
    }
}

/// What a node must do after an NMT command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NmtTransition {
    /// The state changes from `from` to `to`.
    Enter {
        /// The state before.
        from: NmtState,
        /// The new state.
        to: NmtState,
    },
    /// Reset communication (or, with `application`, the whole node), then boot up.
    Reset {
        /// Reset node (application parameters too), not only communication.
        application: bool,
    },
}

/// The NMT slave: the state and the command rules.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NmtSlave {
    state: NmtState,
}

impl Default for NmtSlave {
    fn default() -> Self {
        Self::new()
    }
}

impl NmtSlave {
    /// A node in Initialising (power-on).
    pub const fn new() -> Self {
        Self {
            state: NmtState::Initialising,
        }
    }

    /// The state.
    pub const fn state(&self) -> NmtState {
        self.state
    }

    /// Initialisation is done and the boot-up message sent: pre-operational.
    pub fn booted(&mut self) {
        self.state = NmtState::PreOperational;
    }

    /// Sets the state directly (the node's own reactions, e.g. CiA 301 0x1029 on a
    /// communication error). Returns the transition if the state changes.
    pub fn enter(&mut self, to: NmtState) -> Option<NmtTransition> {
        let from = self.state;
        if from == to || from == NmtState::Initialising {
            return None;
        }
        self.state = to;
        Some(NmtTransition::Enter { from, to })
    }

    /// Applies an NMT command addressed to this node; `None` if it changes nothing (the
    /// state it asks for is the current one, an unknown command, or the node is still
    /// initialising).
    pub fn command(&mut self, command: NmtCommand) -> Option<NmtTransition> {
        if self.state == NmtState::Initialising {
            return None;
        }
        let to = match command {
            NmtCommand::StartRemoteNode => NmtState::Operational,
            NmtCommand::StopRemoteNode => NmtState::Stopped,
            NmtCommand::EnterPreOperational => NmtState::PreOperational,
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                self.state = NmtState::Initialising;
                return Some(NmtTransition::Reset {
                    application: command == NmtCommand::ResetNode,
                });
            }
            NmtCommand::Unknown(_) => return None,
        };
        self.enter(to)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_frames() {
        let c = NmtCommandRepr::parse(&[0x01, 0x05]).unwrap();
        assert_eq!(c.command, NmtCommand::StartRemoteNode);
        assert!(c.addresses(5));
        assert!(!c.addresses(6));
        assert_eq!(c.emit(), [0x01, 0x05]);
        let all = NmtCommandRepr::parse(&[0x81, 0x00]).unwrap();
        assert_eq!(all.command, NmtCommand::ResetNode);
        assert!(all.addresses(1) && all.addresses(127));
        assert_eq!(NmtCommandRepr::parse(&[0x01]), None);
        assert_eq!(NmtCommandRepr::parse(&[0x01, 0x05, 0x00]), None);
        let odd = NmtCommandRepr::parse(&[0x7E, 0x05]).unwrap();
        assert_eq!(odd.command, NmtCommand::Unknown(0x7E));
        assert_eq!(odd.emit(), [0x7E, 0x05]);
    }

    #[test]
    fn state_codes_round_trip() {
        for s in [
            NmtState::Initialising,
            NmtState::PreOperational,
            NmtState::Operational,
            NmtState::Stopped,
        ] {
            assert_eq!(NmtState::from_code(s.code()), Some(s));
            assert_eq!(NmtState::from_code(s.code() | 0x80), Some(s));
        }
        assert_eq!(NmtState::from_code(1), None);
        assert_eq!(NmtState::PreOperational.code(), 0x7F);
    }

    #[test]
    fn services_per_state() {
        use NmtState::*;
        use Service::*;
        assert!(PreOperational.allows(Sdo) && !PreOperational.allows(Pdo));
        assert!(Operational.allows(Pdo) && Operational.allows(Sdo));
        assert!(!Stopped.allows(Sdo) && !Stopped.allows(Emcy) && Stopped.allows(ErrorControl));
        assert!(!Initialising.allows(ErrorControl));
        assert_eq!(PreOperational.access_state(), Some(AlState::PreOp));
        assert_eq!(Operational.access_state(), Some(AlState::Op));
        assert_eq!(Stopped.access_state(), None);
    }

    #[test]
    fn transitions() {
        let mut n = NmtSlave::new();
        assert_eq!(n.command(NmtCommand::StartRemoteNode), None, "not booted");
        n.booted();
        assert_eq!(n.state(), NmtState::PreOperational);
        assert_eq!(
            n.command(NmtCommand::StartRemoteNode),
            Some(NmtTransition::Enter {
                from: NmtState::PreOperational,
                to: NmtState::Operational
            })
        );
        assert_eq!(n.command(NmtCommand::StartRemoteNode), None, "same state");
        assert!(n.command(NmtCommand::StopRemoteNode).is_some());
        assert_eq!(n.state(), NmtState::Stopped);
        assert!(n.command(NmtCommand::EnterPreOperational).is_some());
        assert_eq!(n.command(NmtCommand::Unknown(3)), None);
        assert_eq!(
            n.command(NmtCommand::ResetCommunication),
            Some(NmtTransition::Reset { application: false })
        );
        assert_eq!(n.state(), NmtState::Initialising);
        n.booted();
        assert_eq!(
            n.command(NmtCommand::ResetNode),
            Some(NmtTransition::Reset { application: true })
        );
    }
}
