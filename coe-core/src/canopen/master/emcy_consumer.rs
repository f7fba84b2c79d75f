//! The EMCY consumer (CiA 301 7.2.7): the Emergencies of the configured nodes, on
//! 0x080 + node-ID, decoded with the same [`EmergencyRepr`] the node's producer and the
//! CoE mailbox use; per node the last one and a count.

use crate::wire::{Emergency, EmergencyRepr};

/// What the master keeps of a node's Emergencies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EmcyLog {
    /// The last Emergency.
    pub last: Option<EmergencyRepr>,
    /// Emergencies received.
    pub count: u32,
    /// EMCY frames of the wrong length.
    pub malformed: u32,
}

impl EmcyLog {
    /// An EMCY frame's data: the Emergency, or `None` (counted) if it is not 8 bytes.
    pub fn receive(&mut self, data: &[u8]) -> Option<EmergencyRepr> {
        let repr = (data.len() == 8)
            .then(|| EmergencyRepr::parse(&Emergency::new_unchecked(data)).ok())
            .flatten();
        match repr {
            Some(e) => {
                self.last = Some(e);
                self.count = self.count.wrapping_add(1);
            }
            None => self.malformed = self.malformed.wrapping_add(1),
        }
        repr
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn golden_emergency() {
        let mut log = EmcyLog::default();
        let e = log.receive(&[0x30, 0x81, 0x11, 0x05, 0, 0, 0, 0]).unwrap();
        assert_eq!(e.error_code, 0x8130);
        assert_eq!(e.error_register, 0x11);
        assert_eq!(e.data, [5, 0, 0, 0, 0]);
        assert_eq!(log.receive(&[0x30, 0x81]), None);
        assert_eq!((log.count, log.malformed), (1, 1));
        assert_eq!(log.last, Some(e));
    }
}
