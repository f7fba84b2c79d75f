//! Device errors: the error register (0x1001, CiA 301 7.5.2.2), the history of the
//! Emergencies sent (0x1003, CiA 301 7.5.2.3), the Emergency codes the module sends (CiA 301
//! table 21, CiA 402 0x8700) and the error settings (0x10F1).

use coe_core::error_history::ErrorHistory;
use coe_core::sdo_server::Emergency;

/// Errors the pre-defined error field (0x1003) keeps. Each costs 4 B of RAM and a 28 B
/// entry description in flash, and the flash budget sets the limit: four hold a fault and
/// what followed it (e.g. the watchdog, the sync error, an output clamped), which the
/// Emergency queue of the same depth could have had waiting at once.
pub const ERROR_HISTORY: usize = 4;

/// 0x1001 bit 0: generic error (set whenever any other bit is).
pub const ERR_GENERIC: u8 = 0x01;
/// 0x1001 bit 4: communication error (watchdog, sync error).
pub const ERR_COMMUNICATION: u8 = 0x10;
/// 0x1001 bit 7: manufacturer-specific (analog output out of range).
pub const ERR_MANUFACTURER: u8 = 0x80;

/// Emergency: RPDO timeout (CiA 301 0x8250): the process-data watchdog expired.
pub const EMCY_WATCHDOG: u16 = 0x8250;
/// Emergency: sync controller error (0x8700, as EtherCAT drives use it): the sync error
/// counter exceeded 0x10F1:02.
pub const EMCY_SYNC_ERROR: u16 = 0x8700;
/// Emergency: manufacturer-specific 0xFF01: an 0x6411 value outside 0..=0x7FFF was clamped
/// (data byte 0: channel bit mask).
pub const EMCY_AO_OUT_OF_RANGE: u16 = 0xFF01;
/// Emergency: device hardware (CiA 301 0x5000): the MCU's SPI link to the ESC saw errors.
/// Data: the ESC's PDI error counter (0x030D) and code (0x030E), the output reads dropped
/// because no two reads agreed (u16).
pub const EMCY_PDI_ERROR: u16 = 0x5000;
/// Emergency: error reset / no error (0x0000), sent when the error register clears.
pub const EMCY_NO_ERROR: u16 = 0x0000;

/// Error register, error history and 0x10F1:01.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Diagnostics {
    register: u8,
    /// 0x1003: the Emergencies sent, newest first; recorded where they are queued
    /// (`SlaveApp::emergency` for both fieldbuses, the CAN node's own through
    /// `CanView::raise_error`).
    pub history: ErrorHistory<ERROR_HISTORY>,
    /// 0x10F1:01 Local Error Reaction (stored; the reaction is fixed: SAFEOP + safe outputs).
    pub local_error_reaction: u32,
}

impl Diagnostics {
    /// No error.
    pub const fn new() -> Self {
        Self {
            register: 0,
            history: ErrorHistory::new(),
            local_error_reaction: 0,
        }
    }

    /// The 0x1001 value.
    pub const fn register(&self) -> u8 {
        self.register
    }

    /// Sets `bits` and returns the Emergency that reports `code` with `data`. (Out of line:
    /// several callers in both stacks, none on the process-data path.)
    #[inline(never)]
    pub fn raise(&mut self, bits: u8, code: u16, data: [u8; 5]) -> Emergency {
        self.register |= bits | ERR_GENERIC;
        self.report(code, data)
    }

    /// The Emergency that reports `code` with `data` without setting an error bit (an
    /// event that is over when it is reported).
    pub fn report(&self, code: u16, data: [u8; 5]) -> Emergency {
        Emergency {
            error_code: code,
            error_register: self.register,
            data,
        }
    }

    /// Clears `bits`; returns the "no error" Emergency if the register became 0. (The test
    /// in line: the process-data path clears every cycle, a bit that is rarely set.)
    #[inline]
    pub fn clear(&mut self, bits: u8) -> Option<Emergency> {
        if self.register & bits == 0 {
            return None;
        }
        self.clear_set(bits)
    }

    #[inline(never)]
    fn clear_set(&mut self, bits: u8) -> Option<Emergency> {
        self.register &= !bits;
        if self.register & !ERR_GENERIC == 0 {
            self.register = 0;
            return Some(Emergency {
                error_code: EMCY_NO_ERROR,
                error_register: 0,
                data: [0; 5],
            });
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raise_and_clear() {
        let mut d = Diagnostics::new();
        let e = d.raise(ERR_COMMUNICATION, EMCY_WATCHDOG, [0; 5]);
        assert_eq!(e.error_register, 0x11);
        assert_eq!(d.register(), 0x11);
        d.raise(ERR_MANUFACTURER, EMCY_AO_OUT_OF_RANGE, [1, 0, 0, 0, 0]);
        assert_eq!(d.clear(ERR_COMMUNICATION), None);
        assert_eq!(d.register(), 0x81);
        let reset = d.clear(ERR_MANUFACTURER).unwrap();
        assert_eq!(reset.error_code, 0);
        assert_eq!(d.register(), 0);
        assert_eq!(d.clear(ERR_MANUFACTURER), None);
    }
}
