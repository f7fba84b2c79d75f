//! The SYNC consumer (CiA 301 7.2.5, objects 0x1005 COB-ID SYNC, 0x1006 communication cycle
//! period, 0x1019 synchronous counter overflow value).
//!
//! A SYNC frame carries no data, or one byte, the counter (1..=0x1019 value), when 0x1019 is
//! 2..=240. A SYNC of the other length is reported (EMCY 0x8240) and not used. With a
//! communication cycle period (µs) configured, a gap of 1.5 periods without a
//! SYNC while operational is reported once (EMCY 0x8100), until SYNCs come again.
//!
//! This node consumes SYNC only: 0x1005 bit 30 (the node produces SYNC) and bit 29 (29-bit
//! identifier) are refused with 0x06090030, as is a restricted CAN-ID.

use super::cob;
use super::frame::{is_restricted_id, CobId};
use crate::abort::SdoAbortCode;

/// The SYNC parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncParams {
    /// 0x1005: COB-ID SYNC.
    pub cob_id: CobId,
    /// 0x1006: communication cycle period in µs (0: not monitored).
    pub period_us: u32,
    /// 0x1019: synchronous counter overflow value (0: SYNC without counter).
    pub overflow: u8,
}

impl Default for SyncParams {
    fn default() -> Self {
        Self {
            cob_id: CobId::new(cob::SYNC),
            period_us: 0,
            overflow: 0,
        }
    }
}

impl SyncParams {
    /// Checks and stores a new 0x1005 value.
    pub fn set_cob_id(&mut self, raw: u32) -> Result<(), SdoAbortCode> {
        let cob = CobId(raw);
        if raw & CobId::BIT30 != 0 || cob.is_extended() || is_restricted_id(cob.can_id()) {
            return Err(SdoAbortCode::ValueRangeExceeded);
        }
        self.cob_id = cob;
        Ok(())
    }

    /// Checks and stores a new 0x1019 value: 0 or 2..=240, and only while 0x1006 is 0
    /// (0x08000022 otherwise, as CiA 301 asks).
    pub fn set_overflow(&mut self, value: u8) -> Result<(), SdoAbortCode> {
        if self.period_us != 0 {
            return Err(SdoAbortCode::DeviceState);
        }
        if value == 1 || value > 240 {
            return Err(SdoAbortCode::ValueRangeExceeded);
        }
        self.overflow = value;
        Ok(())
    }
}

/// Why a SYNC frame was not used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SyncError {
    /// The length does not match 0x1019 (EMCY 0x8240).
    Length,
}

/// The consumer's runtime.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncConsumer {
    last_us: Option<u64>,
    timed_out: bool,
    /// SYNCs received (wrapping), for diagnostics.
    pub received: u32,
}

/// What the consumer saw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SyncEvent {
    /// A SYNC, with its counter if it carries one.
    Sync(Option<u8>),
    /// A SYNC after a timeout: SYNC is back (the timeout error clears).
    Resumed(Option<u8>),
}

impl SyncConsumer {
    /// Nothing received.
    pub const fn new() -> Self {
        Self {
            last_us: None,
            timed_out: false,
            received: 0,
        }
    }

    /// A SYNC frame with `data` at `now_us`.
    pub fn receive(
        &mut self,
        params: &SyncParams,
        data: &[u8],
        now_us: u64,
    ) -> Result<SyncEvent, SyncError> {
        let counter = match (params.overflow, data) {
            (0, []) => None,
            (2..=240, [c]) => Some(*c),
            _ => return Err(SyncError::Length),
        };
        self.received = self.received.wrapping_add(1);
        self.last_us = Some(now_us);
        if core::mem::take(&mut self.timed_out) {
            Ok(SyncEvent::Resumed(counter))
        } else {
            Ok(SyncEvent::Sync(counter))
        }
    }

    /// The monitoring deadline (1.5 periods after the last SYNC), if monitored.
    pub fn deadline_us(&self, params: &SyncParams) -> Option<u64> {
        if params.period_us == 0 || self.timed_out {
            return None;
        }
        Some(self.last_us? + u64::from(params.period_us) * 3 / 2)
    }

    /// True when the deadline has just passed at `now_us` (reported once).
    pub fn timed_out(&mut self, params: &SyncParams, now_us: u64) -> bool {
        match self.deadline_us(params) {
            Some(t) if now_us >= t => {
                self.timed_out = true;
                true
            }
            _ => false,
        }
    }

    /// Forgets the last SYNC (monitoring restarts with the next one).
    pub fn reset(&mut self) {
        *self = Self::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counter_follows_0x1019() {
        let mut p = SyncParams::default();
        let mut c = SyncConsumer::new();
        assert_eq!(c.receive(&p, &[], 0), Ok(SyncEvent::Sync(None)));
        assert_eq!(c.receive(&p, &[1], 0), Err(SyncError::Length));
        p.set_overflow(10).unwrap();
        assert_eq!(c.receive(&p, &[7], 0), Ok(SyncEvent::Sync(Some(7))));
        assert_eq!(c.receive(&p, &[], 0), Err(SyncError::Length));
        assert_eq!(c.received, 2);
    }

    #[test]
    fn parameter_rules() {
        let mut p = SyncParams::default();
        assert_eq!(p.cob_id, CobId::new(0x80));
        assert_eq!(p.set_overflow(1), Err(SdoAbortCode::ValueRangeExceeded));
        assert_eq!(p.set_overflow(241), Err(SdoAbortCode::ValueRangeExceeded));
        p.period_us = 1000;
        assert_eq!(p.set_overflow(2), Err(SdoAbortCode::DeviceState));
        assert_eq!(
            p.set_cob_id(0x4000_0080),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            p.set_cob_id(0x2000_0080),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(
            p.set_cob_id(0x0000_0701),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(p.set_cob_id(0x0000_0081), Ok(()));
    }

    #[test]
    fn timeout_after_one_and_a_half_periods() {
        let p = SyncParams {
            period_us: 10_000,
            ..SyncParams::default()
        };
        let mut c = SyncConsumer::new();
        assert!(!c.timed_out(&p, 1_000_000), "not started");
        c.receive(&p, &[], 0).unwrap();
        assert_eq!(c.deadline_us(&p), Some(15_000));
        assert!(!c.timed_out(&p, 14_999));
        assert!(c.timed_out(&p, 15_000));
        assert!(!c.timed_out(&p, 20_000), "once");
        assert_eq!(c.receive(&p, &[], 30_000), Ok(SyncEvent::Resumed(None)));
    }
}
