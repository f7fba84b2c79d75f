//! The EMCY producer (CiA 301 7.2.7, objects 0x1014 COB-ID EMCY and 0x1015 inhibit time
//! EMCY, 100 µs units): Emergencies queued by the application or the node go out one at a
//! time, at least the inhibit time apart, in pre-operational and operational, while 0x1014
//! is valid. The frame is the 8 bytes of [`EmergencyRepr`] (error code, 0x1001, 5 bytes),
//! the same layout CoE carries after its header.
//!
//! 0x1014 rules: bit 29 and bits 28..11 must be 0; the CAN-ID of a valid EMCY cannot change
//! (clear the valid bit first), and a valid one must not be restricted (0x06090030).

use super::frame::{is_restricted_id, CanFrame, CobId};
use crate::abort::SdoAbortCode;
use crate::emergency_queue::EmergencyQueue;
use crate::wire::{self, EmergencyRepr};

/// The EMCY parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EmcyParams {
    /// 0x1014: COB-ID EMCY.
    pub cob_id: CobId,
    /// 0x1015: inhibit time in 100 µs.
    pub inhibit_100us: u16,
}

impl EmcyParams {
    /// Checks and stores a new 0x1014 value.
    pub fn set_cob_id(&mut self, raw: u32) -> Result<(), SdoAbortCode> {
        let new = CobId(raw & !CobId::BIT30);
        if new.is_extended() {
            return Err(SdoAbortCode::ValueRangeExceeded);
        }
        if new.is_valid() {
            if self.cob_id.is_valid() && new.can_id() != self.cob_id.can_id() {
                return Err(SdoAbortCode::ValueRangeExceeded);
            }
            if is_restricted_id(new.can_id()) {
                return Err(SdoAbortCode::ValueRangeExceeded);
            }
        }
        self.cob_id = new;
        Ok(())
    }
}

/// The producer: a queue of `N` Emergencies and the inhibit timer.
#[derive(Debug, Clone)]
pub struct EmcyProducer<const N: usize> {
    queue: EmergencyQueue<N>,
    next_us: u64,
    /// Emergencies sent.
    pub sent: u32,
}

impl<const N: usize> Default for EmcyProducer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> EmcyProducer<N> {
    /// Nothing queued.
    pub const fn new() -> Self {
        Self {
            queue: EmergencyQueue::new(),
            next_us: 0,
            sent: 0,
        }
    }

    /// Queues an Emergency (the oldest is dropped when the queue is full).
    pub fn push(&mut self, emergency: EmergencyRepr) {
        self.queue.push(emergency);
    }

    /// The queue.
    pub fn queue(&self) -> &EmergencyQueue<N> {
        &self.queue
    }

    /// Drops the queue (reset of communication).
    pub fn reset(&mut self) {
        self.queue.clear();
        self.next_us = 0;
    }

    /// The next EMCY frame if one may go out at `now_us`.
    pub fn next_frame(&mut self, params: &EmcyParams, now_us: u64) -> Option<CanFrame> {
        if !params.cob_id.is_valid() || now_us < self.next_us {
            return None;
        }
        let emergency = self.queue.pop()?;
        let mut data = [0u8; wire::emergency::LEN];
        emergency
            .emit(&mut wire::Emergency::new_unchecked(&mut data[..]))
            .ok()?;
        self.next_us = now_us + u64::from(params.inhibit_100us) * 100;
        self.sent = self.sent.wrapping_add(1);
        CanFrame::new(params.cob_id.can_id(), &data).ok()
    }

    /// When the next queued Emergency may go out.
    pub fn next_us(&self) -> Option<u64> {
        (!self.queue.is_empty()).then_some(self.next_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PARAMS: EmcyParams = EmcyParams {
        cob_id: CobId::new(0x85),
        inhibit_100us: 10,
    };

    #[test]
    fn frames_and_inhibit_time() {
        let mut p = EmcyProducer::<4>::new();
        assert_eq!(p.next_frame(&PARAMS, 0), None);
        p.push(EmergencyRepr {
            error_code: 0x8130,
            error_register: 0x11,
            data: [1, 2, 3, 4, 5],
        });
        p.push(EmergencyRepr::default());
        let f = p.next_frame(&PARAMS, 0).unwrap();
        assert_eq!(f.id(), 0x85);
        assert_eq!(f.data(), &[0x30, 0x81, 0x11, 1, 2, 3, 4, 5]);
        assert_eq!(p.next_frame(&PARAMS, 999), None, "inhibit time 1 ms");
        assert_eq!(p.next_us(), Some(1000));
        let f = p.next_frame(&PARAMS, 1000).unwrap();
        assert_eq!(f.data(), &[0; 8]);
        assert_eq!(p.sent, 2);
        p.push(EmergencyRepr::default());
        let off = EmcyParams {
            cob_id: PARAMS.cob_id.invalid(),
            ..PARAMS
        };
        assert_eq!(p.next_frame(&off, 10_000), None, "not valid: nothing sent");
        assert_eq!(p.queue().len(), 1);
    }

    #[test]
    fn cob_id_rules() {
        let mut p = PARAMS;
        assert_eq!(p.set_cob_id(0x86), Err(SdoAbortCode::ValueRangeExceeded));
        assert_eq!(p.set_cob_id(0x8000_0085), Ok(()));
        assert_eq!(p.set_cob_id(0x8000_0086), Ok(()));
        assert_eq!(p.set_cob_id(0x7F), Err(SdoAbortCode::ValueRangeExceeded));
        assert_eq!(
            p.set_cob_id(0x2000_0086),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(p.set_cob_id(0x86), Ok(()));
        assert_eq!(p.cob_id, CobId::new(0x86));
    }
}
