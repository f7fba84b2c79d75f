//! What the master reports to its application (the gateway turns these into diagnosis
//! entries and Emergencies), and the fixed queue that holds them until it asks.

use super::super::nmt::NmtState;
use super::boot::BootError;
use super::sdo_client::{SdoFailure, SdoResult};
use crate::wire::EmergencyRepr;

/// Why a node counts as lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LossCause {
    /// Its heartbeat did not come within the consumer time.
    Heartbeat,
    /// Node guarding: no (good) answer within the life time.
    Guarding,
    /// It sent a boot-up message while it was running: it was reset.
    BootUp,
    /// It reported another state than operational while it should be operational.
    State(NmtState),
}

/// Why a boot step failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootCause {
    /// The SDO failed.
    Sdo(SdoFailure),
    /// The value read was not the expected one.
    Mismatch {
        /// The value configured or written.
        expected: u32,
        /// The value the node has.
        actual: u32,
    },
    /// No heartbeat or guarding answer came.
    Silent,
    /// The node was operational.
    WasOperational,
}

/// An event of the master; `slot` is the place in the configuration, `node` its node-ID.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MasterEvent {
    /// The node is configured and started (or, with the all-at-once start, waits for it).
    NodeBooted {
        /// Place.
        slot: u8,
        /// Node-ID.
        node: u8,
    },
    /// The boot of the node failed.
    BootError {
        /// Place.
        slot: u8,
        /// Node-ID.
        node: u8,
        /// The CiA 302-2 error (its letter: [`BootError::letter`]).
        error: BootError,
        /// The object of the step that failed (0 for the error control steps).
        index: u16,
        /// Its subindex.
        sub: u8,
        /// Why.
        cause: BootCause,
    },
    /// A node that was operational is lost.
    NodeLost {
        /// Place.
        slot: u8,
        /// Node-ID.
        node: u8,
        /// How the master noticed.
        cause: LossCause,
    },
    /// A lost node is operational again.
    NodeReturned {
        /// Place.
        slot: u8,
        /// Node-ID.
        node: u8,
    },
    /// The node sent an Emergency.
    Emergency {
        /// Place.
        slot: u8,
        /// Node-ID.
        node: u8,
        /// The Emergency.
        emergency: EmergencyRepr,
    },
    /// A synchronous TPDO of the node did not come between two SYNCs (reported when it
    /// starts missing; every missed cycle is counted).
    PdoMissing {
        /// Place of the node.
        slot: u8,
        /// Node-ID.
        node: u8,
        /// Place of the PDO among the node's TPDOs.
        pdo: u8,
    },
    /// A TPDO of the node came with another length than its mapping (its data are not
    /// taken; reported once until a good one comes).
    PdoLength {
        /// Place of the node.
        slot: u8,
        /// Node-ID.
        node: u8,
        /// Place of the PDO.
        pdo: u8,
        /// The length received.
        len: u8,
    },
    /// An event-driven TPDO of the node did not come within its deadline.
    PdoTimeout {
        /// Place of the node.
        slot: u8,
        /// Node-ID.
        node: u8,
        /// Place of the PDO.
        pdo: u8,
    },
    /// An SDO transfer the application asked for ended.
    SdoDone {
        /// Place of the node.
        slot: u8,
        /// Node-ID.
        node: u8,
        /// Bytes uploaded (0 for a download), or why it failed.
        result: SdoResult,
    },
}

/// Up to `N` events, oldest first; when full the oldest goes (and is counted), so the
/// newest state of the network always gets through.
#[derive(Debug, Clone)]
pub struct EventQueue<const N: usize> {
    items: [Option<MasterEvent>; N],
    head: usize,
    len: usize,
    /// Events dropped because the queue was full.
    pub dropped: u32,
}

impl<const N: usize> EventQueue<N> {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            items: [None; N],
            head: 0,
            len: 0,
            dropped: 0,
        }
    }

    /// Queues an event.
    pub fn push(&mut self, event: MasterEvent) {
        if N == 0 {
            self.dropped = self.dropped.wrapping_add(1);
            return;
        }
        if self.len == N {
            self.head = (self.head + 1) % N;
            self.len -= 1;
            self.dropped = self.dropped.wrapping_add(1);
        }
        if let Some(slot) = self.items.get_mut((self.head + self.len) % N) {
            *slot = Some(event);
            self.len += 1;
        }
    }

    /// The oldest event.
    pub fn pop(&mut self) -> Option<MasterEvent> {
        if self.len == 0 {
            return None;
        }
        let item = self.items.get_mut(self.head).and_then(Option::take);
        self.head = (self.head + 1) % N.max(1);
        self.len -= 1;
        item
    }

    /// Events waiting.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// True if none waits.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl<const N: usize> Default for EventQueue<N> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(slot: u8) -> MasterEvent {
        MasterEvent::NodeBooted { slot, node: slot }
    }

    #[test]
    fn oldest_first_and_oldest_dropped() {
        let mut q = EventQueue::<3>::new();
        assert_eq!(q.pop(), None);
        for i in 0..5 {
            q.push(e(i));
        }
        assert_eq!(q.dropped, 2);
        assert_eq!(q.len(), 3);
        assert_eq!(q.pop(), Some(e(2)));
        assert_eq!(q.pop(), Some(e(3)));
        q.push(e(9));
        assert_eq!(q.pop(), Some(e(4)));
        assert_eq!(q.pop(), Some(e(9)));
        assert!(q.is_empty());
    }
}
