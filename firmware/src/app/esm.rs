//! The EtherCAT state machine of the slave (ETG.1000.6 6.4; ESC datasheet section I,
//! "ESM"; hardware-facts 1.7): what a write of AL control (0x0120) asks for, and the AL
//! status (0x0130) and AL status code (0x0134) that answer it.
//!
//! This module decides; [`crate::app::SlaveApp`] runs the checks and actions of a
//! transition against the ESC and reports the outcome back ([`Esm::complete`],
//! [`Esm::fail`]).
//!
//! Rules:
//! - A request for a state that does not exist is refused with 0x0012 UnknownRequestedState;
//!   a transition the matrix forbids (I->S, I->O, P->O, P->B, B->P/S/O, S->B, O->B) with
//!   0x0011 InvalidRequestedStateChange; BOOT (I->B) with 0x0013 BootstrapNotSupported.
//!   The state stays, the error flag (0x0130 b4) is set.
//! - The error flag stays until the master acknowledges it (0x0120 b4). While it is set and
//!   not acknowledged, requests for a higher state are ignored; requests for the same or a
//!   lower state are carried out and the flag stays.
//! - Acknowledge clears the flag and the code; the request in the same write is then
//!   handled normally.
//! - ID request (0x0120 b5): with an explicit device ID configured and no error pending, the
//!   ID goes into 0x0134 and 0x0130 b5 is set; the next write without b5 clears both.
//! - Local errors (watchdog, sync error) take the slave down with [`Esm::local_error`].

use coe_core::AlState;

/// AL control / AL status bit 4: error (indication / acknowledge).
pub const ERROR_FLAG: u16 = 0x0010;
/// AL control bit 5: ID request; AL status bit 5: ID loaded.
pub const ID_FLAG: u16 = 0x0020;

/// AL status codes (0x0134) the application uses (ETG.1000.6 table 11; hardware-facts 1.6).
pub mod code {
    /// No error.
    pub const NO_ERROR: u16 = 0x0000;
    /// Invalid requested state change.
    pub const INVALID_STATE_CHANGE: u16 = 0x0011;
    /// Unknown requested state.
    pub const UNKNOWN_STATE: u16 = 0x0012;
    /// Bootstrap not supported.
    pub const BOOTSTRAP_NOT_SUPPORTED: u16 = 0x0013;
    /// Invalid mailbox configuration.
    pub const INVALID_MAILBOX_CONFIGURATION: u16 = 0x0016;
    /// Synchronization error.
    pub const SYNC_ERROR: u16 = 0x001A;
    /// Sync manager watchdog.
    pub const SM_WATCHDOG: u16 = 0x001B;
    /// Invalid output configuration.
    pub const INVALID_OUTPUT_CONFIGURATION: u16 = 0x001D;
    /// Invalid input configuration.
    pub const INVALID_INPUT_CONFIGURATION: u16 = 0x001E;
    /// Invalid input mapping.
    pub const INVALID_INPUT_MAPPING: u16 = 0x0024;
    /// Invalid output mapping.
    pub const INVALID_OUTPUT_MAPPING: u16 = 0x0025;
}

/// The transition matrix of hardware-facts 1.7.
// TODO(coe-core esm): replace with coe-core's transition matrix once `coe_core::esm`
// exports it; this is the same table.
const fn transition_allowed(from: AlState, to: AlState) -> bool {
    use AlState::*;
    matches!(
        (from, to),
        (Init, Init | PreOp | Bootstrap)
            | (PreOp, Init | PreOp | SafeOp)
            | (SafeOp, Init | PreOp | SafeOp | Op)
            | (Op, Init | PreOp | SafeOp | Op)
            | (Bootstrap, Init | Bootstrap)
    )
}

/// What an AL control write asks the application to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Decision {
    /// Nothing to run (same state, or ignored while an error waits for acknowledge).
    Stay,
    /// Run the checks and actions of `from -> to`, then [`Esm::complete`] or [`Esm::fail`].
    Change {
        /// Present state.
        from: AlState,
        /// Requested state.
        to: AlState,
    },
    /// Refused at once with this AL status code (already recorded).
    Refused(u16),
}

/// The ESM state, error flag, status code and ID indication.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Esm {
    state: AlState,
    error: bool,
    code: u16,
    id_loaded: bool,
    device_id: Option<u16>,
}

impl Default for Esm {
    fn default() -> Self {
        Self::new(None)
    }
}

impl Esm {
    /// INIT, no error; `device_id` is the explicit device ID for ID requests (`None`: not
    /// supported, requests are ignored).
    pub const fn new(device_id: Option<u16>) -> Self {
        Self {
            state: AlState::Init,
            error: false,
            code: code::NO_ERROR,
            id_loaded: false,
            device_id,
        }
    }

    /// The present state.
    pub const fn state(&self) -> AlState {
        self.state
    }

    /// True while the error flag is set.
    pub const fn error(&self) -> bool {
        self.error
    }

    /// The AL status code of the error (0 without error).
    pub const fn code(&self) -> u16 {
        self.code
    }

    /// The AL status word (0x0130).
    pub const fn status_word(&self) -> u16 {
        let mut v = self.state.nibble() as u16;
        if self.error {
            v |= ERROR_FLAG;
        }
        if self.id_loaded {
            v |= ID_FLAG;
        }
        v
    }

    /// The AL status code register value (0x0134): the error code, else the device ID
    /// while it is loaded, else 0.
    pub const fn status_code_word(&self) -> u16 {
        if self.error {
            self.code
        } else if self.id_loaded {
            match self.device_id {
                Some(id) => id,
                None => 0,
            }
        } else {
            0
        }
    }

    fn set_error(&mut self, code: u16) {
        self.error = true;
        self.code = code;
        self.id_loaded = false;
    }

    /// Handles an AL control value.
    pub fn on_control(&mut self, control: u16) -> Decision {
        if control & ERROR_FLAG != 0 {
            self.error = false;
            self.code = code::NO_ERROR;
        }
        self.id_loaded = control & ID_FLAG != 0 && !self.error && self.device_id.is_some();
        let Some(to) = AlState::from_nibble((control & 0x0F) as u8) else {
            if self.error {
                return Decision::Stay;
            }
            self.set_error(code::UNKNOWN_STATE);
            return Decision::Refused(code::UNKNOWN_STATE);
        };
        let from = self.state;
        if self.error && to > from {
            return Decision::Stay;
        }
        if !transition_allowed(from, to) {
            if self.error {
                return Decision::Stay;
            }
            self.set_error(code::INVALID_STATE_CHANGE);
            return Decision::Refused(code::INVALID_STATE_CHANGE);
        }
        if to == from {
            return Decision::Stay;
        }
        if to == AlState::Bootstrap {
            self.set_error(code::BOOTSTRAP_NOT_SUPPORTED);
            return Decision::Refused(code::BOOTSTRAP_NOT_SUPPORTED);
        }
        Decision::Change { from, to }
    }

    /// The checks of a transition passed: the slave is in `to`.
    pub fn complete(&mut self, to: AlState) {
        self.state = to;
    }

    /// The checks of a transition failed: the slave goes to (or stays in) `state` with the
    /// error flag and `code`.
    pub fn fail(&mut self, state: AlState, code: u16) {
        self.state = state;
        self.set_error(code);
    }

    /// A local error (watchdog, sync error): go down to `state` (never up) with `code`.
    pub fn local_error(&mut self, state: AlState, code: u16) {
        if state < self.state {
            self.state = state;
        }
        self.set_error(code);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use AlState::*;

    const ALL: [AlState; 5] = [Init, PreOp, Bootstrap, SafeOp, Op];

    fn esm_in(state: AlState) -> Esm {
        let mut e = Esm::new(None);
        e.complete(state);
        e
    }

    #[test]
    fn every_transition_of_the_matrix() {
        let allowed = [
            (Init, PreOp),
            (PreOp, SafeOp),
            (SafeOp, Op),
            (Op, SafeOp),
            (PreOp, Init),
            (SafeOp, Init),
            (Op, Init),
            (SafeOp, PreOp),
            (Op, PreOp),
        ];
        for from in ALL {
            for to in ALL {
                let mut e = esm_in(from);
                let d = e.on_control(u16::from(to.nibble()));
                let expected = if from == to {
                    Decision::Stay
                } else if allowed.contains(&(from, to)) {
                    Decision::Change { from, to }
                } else if from == Init && to == Bootstrap {
                    Decision::Refused(code::BOOTSTRAP_NOT_SUPPORTED)
                } else if from == Bootstrap && to == Init {
                    Decision::Change { from, to }
                } else {
                    Decision::Refused(code::INVALID_STATE_CHANGE)
                };
                assert_eq!(d, expected, "{from:?} -> {to:?}");
                if let Decision::Refused(c) = d {
                    assert_eq!(e.state(), from);
                    assert_eq!(e.status_word(), u16::from(from.nibble()) | ERROR_FLAG);
                    assert_eq!(e.status_code_word(), c);
                }
            }
        }
    }

    #[test]
    fn unknown_state_is_0x0012() {
        for nibble in [0u16, 5, 6, 7, 9, 0xF] {
            let mut e = esm_in(PreOp);
            assert_eq!(e.on_control(nibble), Decision::Refused(code::UNKNOWN_STATE));
            assert_eq!(e.status_word(), 0x12);
            assert_eq!(e.status_code_word(), 0x0012);
        }
    }

    #[test]
    fn error_flag_stays_until_acknowledged() {
        let mut e = esm_in(PreOp);
        e.fail(PreOp, code::INVALID_OUTPUT_CONFIGURATION);
        // Higher state without acknowledge: ignored.
        assert_eq!(e.on_control(0x04), Decision::Stay);
        assert_eq!(e.status_word(), 0x12);
        // Lower state without acknowledge: carried out, flag stays.
        assert_eq!(
            e.on_control(0x01),
            Decision::Change {
                from: PreOp,
                to: Init
            }
        );
        e.complete(Init);
        assert_eq!(e.status_word(), 0x11);
        assert_eq!(e.status_code_word(), 0x001D);
        // Acknowledge with the same state: flag and code cleared.
        assert_eq!(e.on_control(0x11), Decision::Stay);
        assert_eq!(e.status_word(), 0x01);
        assert_eq!(e.status_code_word(), 0);
        // Acknowledge together with a request.
        e.fail(Init, code::INVALID_MAILBOX_CONFIGURATION);
        assert_eq!(
            e.on_control(0x12),
            Decision::Change {
                from: Init,
                to: PreOp
            }
        );
    }

    #[test]
    fn local_error_only_goes_down() {
        let mut e = esm_in(Op);
        e.local_error(SafeOp, code::SM_WATCHDOG);
        assert_eq!(e.status_word(), 0x14);
        assert_eq!(e.status_code_word(), 0x001B);
        let mut e = esm_in(PreOp);
        e.local_error(SafeOp, code::SYNC_ERROR);
        assert_eq!(e.state(), PreOp);
    }

    #[test]
    fn id_request() {
        let mut e = Esm::new(Some(0x1234));
        e.complete(PreOp);
        assert_eq!(e.on_control(0x22), Decision::Stay);
        assert_eq!(e.status_word(), 0x22);
        assert_eq!(e.status_code_word(), 0x1234);
        e.on_control(0x02);
        assert_eq!(e.status_word(), 0x02);
        assert_eq!(e.status_code_word(), 0);
        // Not supported: ignored.
        let mut e = esm_in(PreOp);
        e.on_control(0x22);
        assert_eq!(e.status_word(), 0x02);
        // An error takes precedence over the ID.
        let mut e = Esm::new(Some(7));
        e.complete(PreOp);
        e.fail(PreOp, code::SYNC_ERROR);
        e.on_control(0x22);
        assert_eq!(e.status_code_word(), 0x001A);
        assert_eq!(e.status_word() & ID_FLAG, 0);
    }
}
