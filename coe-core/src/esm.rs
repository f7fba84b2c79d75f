//! EtherCAT State Machine (ETG.1000.6 section 6.4; ESC datasheet section I, figure "ESM").
//!
//! [`AlState`] is the state nibble of AL control (0x0120) and AL status (0x0130);
//! [`transition_allowed`] is the transition matrix, [`decide`] the pure decision for an AL
//! control write (matrix, error flag and acknowledge), and [`Esm`] keeps the state, the error
//! flag, the AL status code ([`AlStatusCode`], register 0x0134) and the ID indication.
//!
//! These are the one definition of the ESM state and flags: ESC drivers (the `et1100` crate's
//! `AlControl`/`AlStatus`) read them from here, since an ESC only stores what the
//! application layer writes.

use crate::al_status::AlStatusCode;

/// An ESM state as written to AL control (0x0120 bits 3:0) and AL status (0x0130 bits 3:0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AlState {
    /// INIT (1): no mailbox, no process data.
    Init = 1,
    /// PRE-OPERATIONAL (2): mailbox active.
    PreOp = 2,
    /// BOOTSTRAP (3): firmware update over FoE.
    Bootstrap = 3,
    /// SAFE-OPERATIONAL (4): inputs valid, outputs in safe state.
    SafeOp = 4,
    /// OPERATIONAL (8): inputs and outputs valid.
    Op = 8,
}

impl AlState {
    /// Decodes the state nibble; `None` for a value that names no state (AL status code 0x0012).
    pub const fn from_nibble(value: u8) -> Option<Self> {
        match value & 0x0F {
            1 => Some(Self::Init),
            2 => Some(Self::PreOp),
            3 => Some(Self::Bootstrap),
            4 => Some(Self::SafeOp),
            8 => Some(Self::Op),
            _ => None,
        }
    }

    /// The state nibble.
    pub const fn nibble(self) -> u8 {
        self as u8
    }
}

/// AL control (0x0120) bit 4: error acknowledge; AL status (0x0130) bit 4: error indication.
pub const ERROR_FLAG: u16 = 0x0010;
/// AL control bit 5: device identification request; AL status bit 5: ID loaded.
pub const ID_FLAG: u16 = 0x0020;
/// AL control / AL status bits 3:0: the state.
pub const STATE_MASK: u16 = 0x000F;

/// The ESM transition matrix (ETG.1000.6 6.4.1, figure "ESM" and table "state transitions";
/// ESC datasheet section I, AL control; hardware-facts 1.7): true if `from -> to` is a
/// transition a master may request (same-state requests included).
///
/// Allowed: I->P, P->S, S->O, O->S, P->I, S->I, O->I, S->P, O->P, I->B, B->I and every
/// state to itself. Forbidden: I->S, I->O, P->O, P->B, B->P, B->S, B->O, S->B, O->B.
pub const fn transition_allowed(from: AlState, to: AlState) -> bool {
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

/// What an AL control write asks the slave to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Transition {
    /// Nothing to do: the same state was requested, or the request is ignored while an
    /// error waits for its acknowledge.
    Stay,
    /// The matrix allows `from -> to`. The caller runs the checks of the transition (I->P
    /// mailbox SyncManagers, P->S process-data SyncManagers, mapping and sync mode, S->O
    /// valid outputs) and reports [`Esm::complete`] or [`Esm::fail`].
    Allowed {
        /// The present state.
        from: AlState,
        /// The requested state.
        to: AlState,
    },
    /// Refused at once: the state stays and the error flag is set with this code
    /// (0x0011 InvalidRequestedStateChange, 0x0012 UnknownRequestedState or 0x0013
    /// BootstrapNotSupported).
    Refused(AlStatusCode),
}

/// The name [`Esm::request`] returns under.
pub type Decision = Transition;

/// Decides an AL control write as a pure function of the present state, the error flag
/// and the control word (state nibble, b4 error acknowledge; b5 is not looked at here).
///
/// Error flag rules (ETG.1000.6 6.4 "ESM", error indication; ESC datasheet section I,
/// "AL status"; as Beckhoff SSC 4.x `AL_ControlInd` implements them, which ignores only
/// requests for a higher state while the flag is unacknowledged):
/// - an acknowledge (b4) clears the flag and the request is then decided as usual;
/// - without acknowledge, while the flag is set, a request for the same or a higher state
///   is ignored ([`Transition::Stay`]), as is an unknown or forbidden request (the first
///   error stays visible); a request for a lower state is carried out and the flag stays.
///
/// (SOES and SSC 5.x are stricter and only carry out INIT without acknowledge.)
pub fn decide(state: AlState, error: bool, control: u16, bootstrap_supported: bool) -> Transition {
    let error = error && control & ERROR_FLAG == 0;
    let Some(to) = AlState::from_nibble((control & STATE_MASK) as u8) else {
        return if error {
            Transition::Stay
        } else {
            Transition::Refused(AlStatusCode::UnknownRequestedState)
        };
    };
    if error && to >= state {
        return Transition::Stay;
    }
    if !transition_allowed(state, to) {
        return if error {
            Transition::Stay
        } else {
            Transition::Refused(AlStatusCode::InvalidRequestedStateChange)
        };
    }
    if to == state {
        return Transition::Stay;
    }
    if to == AlState::Bootstrap && !bootstrap_supported {
        return Transition::Refused(AlStatusCode::BootstrapNotSupported);
    }
    Transition::Allowed { from: state, to }
}

/// The slave's ESM: state, error flag and AL status code, ID indication.
///
/// The firmware calls [`request`](Self::request) with every AL control value it reads,
/// runs the transition it gets, reports [`complete`](Self::complete) or
/// [`fail`](Self::fail), and writes [`status`](Self::status) to 0x0130 and
/// [`status_code_word`](Self::status_code_word) to 0x0134.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Esm {
    state: AlState,
    error: bool,
    code: AlStatusCode,
    id_loaded: bool,
    device_id: Option<u16>,
    bootstrap: bool,
}

impl Default for Esm {
    fn default() -> Self {
        Self::new()
    }
}

impl Esm {
    /// INIT without error; BOOT not supported; no device ID.
    pub const fn new() -> Esm {
        Esm {
            state: AlState::Init,
            error: false,
            code: AlStatusCode::NoError,
            id_loaded: false,
            device_id: None,
            bootstrap: false,
        }
    }

    /// Accepts I->B (a firmware update path exists); otherwise it is refused with 0x0013.
    pub const fn with_bootstrap(mut self, supported: bool) -> Esm {
        self.bootstrap = supported;
        self
    }

    /// The explicit device ID shown in 0x0134 on an ID request (AL control b5); `None`
    /// ignores ID requests.
    pub const fn with_device_id(mut self, id: Option<u16>) -> Esm {
        self.device_id = id;
        self
    }

    /// The present state.
    pub const fn state(&self) -> AlState {
        self.state
    }

    /// True while the error flag is set.
    pub const fn error(&self) -> bool {
        self.error
    }

    /// The code of the pending error ([`AlStatusCode::NoError`] without one).
    pub const fn status_code(&self) -> AlStatusCode {
        self.code
    }

    /// True while the device ID is shown (AL status b5).
    pub const fn id_loaded(&self) -> bool {
        self.id_loaded
    }

    /// The AL status register value (0x0130): state | error b4 | ID loaded b5.
    pub const fn status(&self) -> u16 {
        let mut v = self.state.nibble() as u16;
        if self.error {
            v |= ERROR_FLAG;
        }
        if self.id_loaded {
            v |= ID_FLAG;
        }
        v
    }

    /// The AL status code register value (0x0134): the error code, else the device ID while
    /// it is loaded, else 0.
    pub fn status_code_word(&self) -> u16 {
        match (self.error, self.id_loaded, self.device_id) {
            (true, _, _) => self.code.into(),
            (false, true, Some(id)) => id,
            _ => 0,
        }
    }

    fn set_error(&mut self, code: AlStatusCode) {
        self.error = true;
        self.code = code;
        self.id_loaded = false;
    }

    /// Handles an AL control value: acknowledge (b4), ID request (b5) and the requested
    /// state. A refusal is recorded (error flag and code) before it is returned.
    pub fn request(&mut self, control: u16) -> Decision {
        if control & ERROR_FLAG != 0 {
            self.error_ack();
        }
        self.id_loaded = control & ID_FLAG != 0 && !self.error && self.device_id.is_some();
        let decision = decide(self.state, self.error, control, self.bootstrap);
        if let Transition::Refused(code) = decision {
            self.set_error(code);
        }
        decision
    }

    /// Clears the error flag and code (what AL control b4 does).
    pub fn error_ack(&mut self) {
        self.error = false;
        self.code = AlStatusCode::NoError;
    }

    /// The checks of an allowed transition passed: the slave is in `to` (a pending error
    /// flag stays).
    pub fn complete(&mut self, to: AlState) {
        self.state = to;
    }

    /// The checks of a transition failed: the slave goes to (or stays in) `to_state` with
    /// the error flag and `code`.
    pub fn fail(&mut self, to_state: AlState, code: AlStatusCode) {
        self.state = to_state;
        self.set_error(code);
    }

    /// A local error (watchdog, sync error, ...): down to `state` (never up) with the error
    /// flag and `code`.
    pub fn local_error(&mut self, state: AlState, code: AlStatusCode) {
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

    /// hardware-facts 1.7, written out: the allowed (from, to) pairs besides same-state.
    const ALLOWED: [(AlState, AlState); 11] = [
        (Init, PreOp),
        (PreOp, SafeOp),
        (SafeOp, Op),
        (Op, SafeOp),
        (PreOp, Init),
        (SafeOp, Init),
        (Op, Init),
        (SafeOp, PreOp),
        (Op, PreOp),
        (Init, Bootstrap),
        (Bootstrap, Init),
    ];

    /// The forbidden pairs, refused with 0x0011.
    const FORBIDDEN: [(AlState, AlState); 9] = [
        (Init, SafeOp),
        (Init, Op),
        (PreOp, Op),
        (PreOp, Bootstrap),
        (Bootstrap, PreOp),
        (Bootstrap, SafeOp),
        (Bootstrap, Op),
        (SafeOp, Bootstrap),
        (Op, Bootstrap),
    ];

    fn esm_in(state: AlState) -> Esm {
        let mut e = Esm::new().with_bootstrap(true);
        e.complete(state);
        e
    }

    #[test]
    fn matrix_covers_all_25_pairs() {
        for from in ALL {
            for to in ALL {
                let allowed = ALLOWED.contains(&(from, to));
                let forbidden = FORBIDDEN.contains(&(from, to));
                let same = from == to;
                assert_eq!(
                    u8::from(allowed) + u8::from(forbidden) + u8::from(same),
                    1,
                    "{from:?}->{to:?}"
                );
                assert_eq!(transition_allowed(from, to), allowed || same);
            }
        }
    }

    #[test]
    fn every_pair_without_error() {
        for from in ALL {
            for to in ALL {
                let mut e = esm_in(from);
                let d = e.request(u16::from(to.nibble()));
                if from == to {
                    assert_eq!(d, Transition::Stay, "{from:?}->{to:?}");
                    assert!(!e.error());
                } else if ALLOWED.contains(&(from, to)) {
                    assert_eq!(d, Transition::Allowed { from, to }, "{from:?}->{to:?}");
                    assert!(!e.error());
                    e.complete(to);
                    assert_eq!(e.status(), u16::from(to.nibble()));
                } else {
                    assert_eq!(
                        d,
                        Transition::Refused(AlStatusCode::InvalidRequestedStateChange),
                        "{from:?}->{to:?}"
                    );
                    assert_eq!(e.state(), from);
                    assert_eq!(e.status(), u16::from(from.nibble()) | 0x10);
                    assert_eq!(e.status_code_word(), 0x0011);
                }
            }
        }
    }

    #[test]
    fn unknown_nibbles() {
        for from in ALL {
            for nibble in [0u16, 5, 6, 7, 9, 10, 11, 12, 13, 14, 15] {
                let mut e = esm_in(from);
                assert_eq!(
                    e.request(nibble),
                    Transition::Refused(AlStatusCode::UnknownRequestedState),
                    "{from:?} <- {nibble}"
                );
                assert_eq!(e.state(), from);
                assert_eq!(e.status(), u16::from(from.nibble()) | 0x10);
                assert_eq!(e.status_code(), AlStatusCode::UnknownRequestedState);
                assert_eq!(e.status_code_word(), 0x0012);
            }
        }
    }

    #[test]
    fn bootstrap_unsupported() {
        let mut e = Esm::new();
        assert_eq!(
            e.request(0x0003),
            Transition::Refused(AlStatusCode::BootstrapNotSupported)
        );
        assert_eq!(e.status(), 0x0011);
        assert_eq!(e.status_code_word(), 0x0013);
        // Forbidden pairs into BOOT stay 0x0011 even when BOOT is not supported.
        let mut e = Esm::new();
        e.complete(PreOp);
        assert_eq!(
            e.request(0x0003),
            Transition::Refused(AlStatusCode::InvalidRequestedStateChange)
        );
    }

    #[test]
    fn every_pair_with_error_and_no_ack() {
        for from in ALL {
            for to in ALL {
                let mut e = esm_in(from);
                e.fail(from, AlStatusCode::SyncManagerWatchdog);
                let d = e.request(u16::from(to.nibble()));
                let lower = to < from;
                if lower && ALLOWED.contains(&(from, to)) {
                    assert_eq!(d, Transition::Allowed { from, to }, "{from:?}->{to:?}");
                    e.complete(to);
                    assert_eq!(e.state(), to);
                } else {
                    assert_eq!(d, Transition::Stay, "{from:?}->{to:?}");
                    assert_eq!(e.state(), from);
                }
                // The error and its code stay until acknowledged.
                assert!(e.error());
                assert_eq!(e.status_code(), AlStatusCode::SyncManagerWatchdog);
                assert_eq!(e.status() & 0x10, 0x10);
            }
        }
    }

    #[test]
    fn unknown_nibble_with_error_is_ignored() {
        let mut e = esm_in(SafeOp);
        e.fail(SafeOp, AlStatusCode::SyncManagerWatchdog);
        assert_eq!(e.request(0x0007), Transition::Stay);
        assert_eq!(e.status_code(), AlStatusCode::SyncManagerWatchdog);
    }

    #[test]
    fn every_pair_with_error_and_ack() {
        for from in ALL {
            for to in ALL {
                let mut e = esm_in(from);
                e.fail(from, AlStatusCode::SyncManagerWatchdog);
                let d = e.request(u16::from(to.nibble()) | 0x10);
                if from == to {
                    assert_eq!(d, Transition::Stay);
                    assert!(!e.error());
                } else if ALLOWED.contains(&(from, to)) {
                    assert_eq!(d, Transition::Allowed { from, to });
                    assert!(!e.error());
                } else {
                    assert_eq!(
                        d,
                        Transition::Refused(AlStatusCode::InvalidRequestedStateChange)
                    );
                    assert!(e.error());
                    assert_eq!(e.status_code(), AlStatusCode::InvalidRequestedStateChange);
                }
            }
        }
    }

    #[test]
    fn failed_check_lowers_state_with_code() {
        // P->S fails its SyncManager check: back to PREOP with 0x001D.
        let mut e = esm_in(PreOp);
        assert_eq!(
            e.request(0x0004),
            Transition::Allowed {
                from: PreOp,
                to: SafeOp
            }
        );
        e.fail(PreOp, AlStatusCode::InvalidOutputConfiguration);
        assert_eq!(e.status(), 0x0012);
        assert_eq!(e.status_code_word(), 0x001D);
        // Retry without ack is ignored; with ack it goes through.
        assert_eq!(e.request(0x0004), Transition::Stay);
        assert_eq!(
            e.request(0x0014),
            Transition::Allowed {
                from: PreOp,
                to: SafeOp
            }
        );
        e.complete(SafeOp);
        assert_eq!(e.status(), 0x0004);
        assert_eq!(e.status_code_word(), 0);
    }

    #[test]
    fn watchdog_in_op() {
        let mut e = esm_in(Op);
        e.local_error(SafeOp, AlStatusCode::SyncManagerWatchdog);
        assert_eq!(e.status(), 0x0014);
        assert_eq!(e.status_code_word(), 0x001B);
        // Local errors never raise the state.
        let mut e = esm_in(PreOp);
        e.local_error(SafeOp, AlStatusCode::SynchronizationError);
        assert_eq!(e.state(), PreOp);
        // Ack alone (same state) clears it.
        let mut e = esm_in(Op);
        e.local_error(SafeOp, AlStatusCode::SyncManagerWatchdog);
        assert_eq!(e.request(0x0014), Transition::Stay);
        assert_eq!(e.status(), 0x0004);
        e.local_error(SafeOp, AlStatusCode::SyncManagerWatchdog);
        e.error_ack();
        assert_eq!(e.status(), 0x0004);
        assert_eq!(e.status_code(), AlStatusCode::NoError);
    }

    #[test]
    fn id_request() {
        let mut e = Esm::new().with_device_id(Some(0x1234));
        assert_eq!(e.request(0x0021), Transition::Stay);
        assert!(e.id_loaded());
        assert_eq!(e.status(), 0x0021);
        assert_eq!(e.status_code_word(), 0x1234);
        assert_eq!(
            e.request(0x0022),
            Transition::Allowed {
                from: Init,
                to: PreOp
            }
        );
        e.complete(PreOp);
        assert_eq!(e.status(), 0x0022);
        // The next write without b5 clears it.
        assert_eq!(e.request(0x0002), Transition::Stay);
        assert_eq!(e.status(), 0x0002);
        assert_eq!(e.status_code_word(), 0);
        // No ID while an error is pending; an error replaces the ID.
        e.request(0x0022);
        e.fail(PreOp, AlStatusCode::InvalidMailboxConfiguration);
        assert_eq!(e.status(), 0x0012);
        assert_eq!(e.status_code_word(), 0x0016);
        e.request(0x0022);
        assert_eq!(e.status(), 0x0012);
        // Without a device ID the request is ignored.
        let mut e = Esm::new();
        e.request(0x0021);
        assert_eq!(e.status(), 0x0001);
        assert_eq!(e.status_code_word(), 0);
    }

    #[test]
    fn upper_control_bits_are_ignored() {
        let mut e = Esm::new();
        assert_eq!(
            e.request(0xFFC2),
            Transition::Allowed {
                from: Init,
                to: PreOp
            }
        );
    }

    #[test]
    fn decide_is_pure() {
        assert_eq!(
            decide(Op, false, 0x0002, false),
            Transition::Allowed {
                from: Op,
                to: PreOp
            }
        );
        assert_eq!(decide(Op, true, 0x0008, false), Transition::Stay);
        assert_eq!(
            decide(Init, false, 0x0003, true),
            Transition::Allowed {
                from: Init,
                to: Bootstrap
            }
        );
        assert_eq!(Esm::default(), Esm::new());
        assert_eq!(Esm::new().status(), 0x0001);
    }
}
