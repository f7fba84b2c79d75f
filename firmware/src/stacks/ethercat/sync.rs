//! Synchronisation: free run, SM-synchronous (SM2 event) and DC SYNC0; the values of the
//! sync manager parameter objects 0x1C32 (outputs) and 0x1C33 (inputs) (ETG.1020 "Sync
//! modes", hardware-facts section 4), their check at PREOP -> SAFEOP, and the cycle
//! monitoring (missed events, sync error after 0x10F1:02).
//!
//! # Choosing the mode at PREOP -> SAFEOP ([`check_sync`])
//!
//! - The master wrote 0x1C32:01 in this PREOP session (TwinCAT start-up SDOs): the request is
//!   enforced against the ESC: DC SYNC0 needs 0x0981 with cyclic operation and SYNC0 active,
//!   any other mode needs SYNC0 inactive, else 0x0030 InvalidDcSyncConfiguration; in DC
//!   mode the SYNC0 cycle (0x09A0) must be at least the minimum cycle time
//!   ([`SyncFigures::min_cycle_ns`]), else 0x0035 DcInvalidSyncCycleTime; free run needs SM2 in
//!   3-buffer mode, else 0x0029 FreeRunNeeds3BufferMode; SYNC1 is not offered, 0x0028.
//! - The master did not write it (ethercrab, SOEM): the mode follows the ESC, as SOES does:
//!   SYNC0 active -> DC SYNC0 (same cycle-time check), else SM-synchronous when SM2 carries
//!   outputs, else free run.
//!
//! # Cycle monitoring ([`SyncMonitor`])
//!
//! Armed by the first SM2 event in OP (SAFEOP -> OP is accepted before the first outputs).
//! DC mode: a SYNC0 edge without fresh outputs since the previous edge is a missed SM event
//! (0x1C32:0B); two SM2 events between edges count "cycle time too small" (0x0C); an SM2
//! event later than the next SYNC0 minus the calc+copy time counts "shift too short" (0x0D).
//! The sync error counter (ETG.1020) goes up by 3 per missed event and down by 1 per good
//! cycle; above 0x10F1:02 it raises the sync error (0x1C32:20 = TRUE), which the application
//! answers with an Emergency, the error register and SAFEOP + 0x001A. So in DC mode a
//! master that stops sending gives 0x001A a few cycles later, before the SM watchdog.
//!
//! SM-synchronous mode counts no missed events: there is no local time base to miss an
//! event against, and 0x1C32:0B is "number of missed SM events in OPERATIONAL (DC mode
//! only)" (Beckhoff's 0x1C32 object description after ETG.1020); the Beckhoff SSC likewise
//! counts missed SM events only in its SYNC0 interrupt (ecatappl.c `Sync0_Isr`). A master
//! that stops is caught by the ESC's SM watchdog: SAFEOP + 0x001B (ecatslv.c
//! `CheckIfEcatError`, which also checks the watchdog before the sync error). SM2 events
//! closer than the minimum cycle time count "cycle time too small".

use coe_core::{AlStatusCode, SdoAbortCode};
use core::marker::PhantomData;
use et1100::SyncActivation;

/// Sync mode code (0x1C32:01, 0x1C33:01): free run.
pub const SYNC_MODE_FREE_RUN: u16 = 0;
/// Sync mode code: synchronous with the SM event (0x1C32:01: SM2; 0x1C33:01: SM3).
pub const SYNC_MODE_SM: u16 = 1;
/// Sync mode code: DC SYNC0.
pub const SYNC_MODE_DC_SYNC0: u16 = 2;
/// Sync mode code of 0x1C33:01: inputs latched on the SM2 event (Beckhoff SSC
/// `SYNCTYPE_SM2INT`).
pub const SYNC_MODE_SM2_INPUTS: u16 = 0x22;

/// Sync modes supported (0x1C32:04/0x1C33:04): b0 free run, b1 SM-synchronous, bits 4:2 =
/// 001 DC SYNC0.
pub const SUPPORTED_MODES: u16 = 0x0007;

/// The figures of one image that the slave application advertises (0x1C32/0x1C33, the
/// device description) and enforces: measured on the image of the product they belong to
/// (`cargo xtask bench`), so each product gives its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncFigures {
    /// Shortest cycle the image handles (0x1C32:05/0x1C33:05, ns): the limit on the SYNC0
    /// cycle (AL status 0x0035) and on 0x1C32:02.
    pub min_cycle_ns: u32,
    /// Outputs: SM2 event to outputs copied and staged (0x1C32:06, ns).
    pub output_calc_copy_ns: u32,
    /// Outputs: SYNC0 edge to outputs updated (0x1C32:09, ns).
    pub output_delay_ns: u32,
    /// Inputs: latch to SM3 written (0x1C33:06, ns), for an input image of up to
    /// `input_calc_copy_bytes`.
    pub input_calc_copy_ns: u32,
    /// The SM3 bytes `input_calc_copy_ns` covers.
    pub input_calc_copy_bytes: u16,
    /// The PDI write of each SM3 byte beyond those (ns): what a larger image (the
    /// oversampling blocks) adds to 0x1C33:06 ([`SyncFigures::input_calc_copy_for`]).
    pub input_copy_ns_per_byte: u32,
    /// Shortest DC cycle at which changed outputs are read twice before they are taken
    /// (`super::confirm`); in SM-synchronous and free-run mode they always are.
    pub confirm_outputs_min_cycle_ns: u32,
    /// Default Sync Error Counter Limit (0x10F1:02).
    pub default_error_limit: u16,
}

impl SyncFigures {
    /// 0x1C33:06 for an input image of `bytes` (the assigned TxPDOs' SM3 length).
    pub const fn input_calc_copy_for(&self, bytes: usize) -> u32 {
        let extra = bytes.saturating_sub(self.input_calc_copy_bytes as usize);
        let extra = if extra > u32::MAX as usize {
            u32::MAX
        } else {
            extra as u32
        };
        self.input_calc_copy_ns
            .saturating_add(extra.saturating_mul(self.input_copy_ns_per_byte))
    }
}

/// Which sync manager parameter object an SDO upload reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SyncObject {
    /// 0x1C32, the outputs'.
    Outputs,
    /// 0x1C33, the inputs', with the assigned input image's length in bytes (its calc and
    /// copy time grows with it: [`SyncFigures::input_calc_copy_for`]).
    Inputs {
        /// SM3 bytes of the assigned TxPDOs.
        image_bytes: usize,
    },
}

/// SYNC0 bookkeeping the DAC task leaves for the PDI task (cycle monitoring).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sync0Counts {
    /// SYNC0 edges seen (wrapping).
    pub edges: u32,
    /// Edges in DC mode that found no fresh outputs (wrapping).
    pub without_outputs: u32,
    /// Low 32 bits of the captured time of the last edge (ns).
    pub last_edge_lo: u32,
}

/// A product's [`SyncFigures`] as a type: the monitor is generic over it, so the figures are
/// constants in the image (as immediate operands on the process-data path).
pub trait Figures {
    /// The figures.
    const SYNC: SyncFigures;
}

/// Shortest SYNC0 watchdog time: the SSC's tick (1 ms), its Sync0WdValue at least 1.
pub const SYNC0_WATCHDOG_MIN_NS: u64 = 1_000_000;

/// A sync mode as 0x1C32:01 / 0x1C33:01 give it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SyncMode {
    /// 0: free run (outputs applied and inputs latched when the application gets to them).
    FreeRun,
    /// 1 (0x1C33: 0x22): synchronous with the SM2 event.
    #[default]
    SmSync,
    /// 2: DC SYNC0.
    DcSync0,
}

impl SyncMode {
    /// The 0x1C32:01 value.
    pub const fn output_value(self) -> u16 {
        match self {
            Self::FreeRun => SYNC_MODE_FREE_RUN,
            Self::SmSync => SYNC_MODE_SM,
            Self::DcSync0 => SYNC_MODE_DC_SYNC0,
        }
    }

    /// The 0x1C33:01 value (0x22: inputs latched on the SM2 event).
    pub const fn input_value(self) -> u16 {
        match self {
            Self::FreeRun => SYNC_MODE_FREE_RUN,
            Self::SmSync => SYNC_MODE_SM2_INPUTS,
            Self::DcSync0 => SYNC_MODE_DC_SYNC0,
        }
    }

    /// Decodes a 0x1C32:01 value (`Err(SyncModeNotSupported)` for 3 = SYNC1 and others).
    pub const fn from_output_value(value: u16) -> Result<Self, SyncConfigError> {
        match value {
            SYNC_MODE_FREE_RUN => Ok(Self::FreeRun),
            SYNC_MODE_SM => Ok(Self::SmSync),
            SYNC_MODE_DC_SYNC0 => Ok(Self::DcSync0),
            _ => Err(SyncConfigError::SyncModeNotSupported),
        }
    }

    /// Decodes a 0x1C33:01 value (1 = SM3 event and 0x22 = SM2 event both mean SM-sync).
    pub const fn from_input_value(value: u16) -> Result<Self, SyncConfigError> {
        match value {
            SYNC_MODE_FREE_RUN => Ok(Self::FreeRun),
            SYNC_MODE_SM | SYNC_MODE_SM2_INPUTS => Ok(Self::SmSync),
            SYNC_MODE_DC_SYNC0 => Ok(Self::DcSync0),
            _ => Err(SyncConfigError::SyncModeNotSupported),
        }
    }
}

/// Why the sync configuration is refused at PREOP -> SAFEOP.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SyncConfigError {
    /// Requested mode and 0x0981 disagree (AL status 0x0030).
    InvalidDcSyncConfiguration,
    /// SYNC0 cycle below the minimum cycle time (AL status 0x0035).
    DcInvalidSyncCycleTime,
    /// Free run with SM2 not in 3-buffer mode (AL status 0x0029).
    FreeRunNeeds3BufferMode,
    /// The requested mode is not offered (AL status 0x0028).
    SyncModeNotSupported,
}

impl SyncConfigError {
    /// The AL status code (0x0134) of the refusal.
    pub const fn al_status_code(self) -> AlStatusCode {
        match self {
            Self::InvalidDcSyncConfiguration => AlStatusCode::InvalidDcSyncConfiguration,
            Self::DcInvalidSyncCycleTime => AlStatusCode::DcInvalidSyncCycleTime,
            Self::FreeRunNeeds3BufferMode => AlStatusCode::FreeRunNeeds3BufferMode,
            Self::SyncModeNotSupported => AlStatusCode::SyncModeNotSupported,
        }
    }
}

/// What [`check_sync`] looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SyncInputs {
    /// 0x1C32:01 if the master wrote it in this PREOP session.
    pub requested: Option<SyncMode>,
    /// 0x1C33:01 if the master wrote it in this PREOP session.
    pub requested_inputs: Option<SyncMode>,
    /// ESC 0x0981 (DC activation).
    pub dc_activation: SyncActivation,
    /// ESC 0x09A0 (SYNC0 cycle time, ns).
    pub sync0_cycle_ns: u32,
    /// SM2 carries outputs (RxPDO length > 0).
    pub has_outputs: bool,
    /// SM2 is in 3-buffer mode (control bits 1:0 = 00).
    pub sm2_three_buffer: bool,
    /// The shortest SYNC0 cycle accepted ([`SyncFigures::min_cycle_ns`]).
    pub min_cycle_ns: u32,
}

/// The PREOP -> SAFEOP sync check: the mode to run in, or the refusal.
pub fn check_sync(inputs: &SyncInputs) -> Result<SyncMode, SyncConfigError> {
    let sync0_active = inputs
        .dc_activation
        .contains(SyncActivation::CYCLIC_UNIT | SyncActivation::SYNC0);
    let sync0_bits = inputs
        .dc_activation
        .intersects(SyncActivation::SYNC0 | SyncActivation::SYNC1);
    let mode = match inputs.requested {
        Some(mode) => {
            if (mode == SyncMode::DcSync0) != sync0_active
                || (mode != SyncMode::DcSync0 && sync0_bits)
            {
                return Err(SyncConfigError::InvalidDcSyncConfiguration);
            }
            mode
        }
        None if sync0_active => SyncMode::DcSync0,
        None if sync0_bits => return Err(SyncConfigError::InvalidDcSyncConfiguration),
        None if inputs.has_outputs => SyncMode::SmSync,
        None => SyncMode::FreeRun,
    };
    if inputs.dc_activation.contains(SyncActivation::SYNC1) {
        return Err(SyncConfigError::SyncModeNotSupported);
    }
    if let Some(input_mode) = inputs.requested_inputs {
        if (input_mode == SyncMode::DcSync0) != (mode == SyncMode::DcSync0) {
            return Err(SyncConfigError::InvalidDcSyncConfiguration);
        }
    }
    match mode {
        SyncMode::DcSync0 if inputs.sync0_cycle_ns < inputs.min_cycle_ns => {
            Err(SyncConfigError::DcInvalidSyncCycleTime)
        }
        SyncMode::FreeRun if inputs.has_outputs && !inputs.sm2_three_buffer => {
            Err(SyncConfigError::FreeRunNeeds3BufferMode)
        }
        _ => Ok(mode),
    }
}

/// What a monitor update found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SyncVerdict {
    /// Nothing new.
    Ok,
    /// The sync error counter just exceeded the limit.
    SyncError,
    /// No SYNC0 edge for longer than the SYNC0 watchdog allows.
    FatalSyncError,
}

/// The 0x1C32/0x1C33 values and the cycle monitor.
#[derive(Debug, Clone)]
pub struct SyncMonitor<F> {
    mode: SyncMode,
    requested: Option<SyncMode>,
    requested_inputs: Option<SyncMode>,
    cycle_time_ns: u32,
    sync0_cycle_ns: u32,
    sm_event_missed: u16,
    cycle_too_small: u16,
    shift_too_short: u16,
    error_counter: u16,
    error_limit: u16,
    sync_error: bool,
    armed: bool,
    last_sm2_ns: Option<u64>,
    edges_at_sm2: Option<u32>,
    baseline: Sync0Counts,
    arm_edges: u32,
    /// SYNC0 watchdog (DC mode, OP): the edge count and when it last changed.
    sync0_seen: Option<(u32, u64)>,
    figures: PhantomData<F>,
}

impl<F: Figures> Default for SyncMonitor<F> {
    fn default() -> Self {
        Self::new()
    }
}

impl<F: Figures> SyncMonitor<F> {
    /// SM-synchronous by default, nothing requested, counters 0, for an image with the
    /// figures `F`.
    pub const fn new() -> Self {
        Self {
            mode: SyncMode::SmSync,
            requested: None,
            requested_inputs: None,
            cycle_time_ns: 0,
            sync0_cycle_ns: 0,
            sm_event_missed: 0,
            cycle_too_small: 0,
            shift_too_short: 0,
            error_counter: 0,
            error_limit: F::SYNC.default_error_limit,
            sync_error: false,
            armed: false,
            last_sm2_ns: None,
            edges_at_sm2: None,
            baseline: Sync0Counts {
                edges: 0,
                without_outputs: 0,
                last_edge_lo: 0,
            },
            arm_edges: 0,
            sync0_seen: None,
            figures: PhantomData,
        }
    }

    /// The image's figures.
    pub const fn figures(&self) -> &'static SyncFigures {
        &F::SYNC
    }

    /// The mode in effect (decided at PREOP -> SAFEOP).
    pub const fn mode(&self) -> SyncMode {
        self.mode
    }

    /// The 0x1C32:01 value: the requested mode in PREOP, the mode in effect after.
    pub fn output_mode_value(&self) -> u16 {
        self.requested.unwrap_or(self.mode).output_value()
    }

    /// The 0x1C33:01 value.
    pub fn input_mode_value(&self) -> u16 {
        self.requested_inputs
            .unwrap_or(self.requested.unwrap_or(self.mode))
            .input_value()
    }

    /// SDO write of 0x1C32:01 / 0x1C33:01 (`inputs` for 0x1C33); 0x06090030 for an
    /// unsupported mode.
    pub fn request_mode(&mut self, inputs: bool, value: u16) -> Result<(), SdoAbortCode> {
        let parse = if inputs {
            SyncMode::from_input_value(value)
        } else {
            SyncMode::from_output_value(value)
        };
        let mode = parse.map_err(|_| SdoAbortCode::ValueRangeExceeded)?;
        if inputs {
            self.requested_inputs = Some(mode);
        } else {
            self.requested = Some(mode);
        }
        Ok(())
    }

    /// The mode requests of this PREOP session (for [`SyncInputs`]).
    pub const fn requests(&self) -> (Option<SyncMode>, Option<SyncMode>) {
        (self.requested, self.requested_inputs)
    }

    /// Entering PREOP from INIT: forget the requests of the previous session and reset the
    /// counters.
    pub fn reset(&mut self) {
        let limit = self.error_limit;
        let cycle = self.cycle_time_ns;
        *self = Self::new();
        self.error_limit = limit;
        self.cycle_time_ns = cycle;
    }

    /// PREOP -> SAFEOP accepted with `mode` and the ESC's SYNC0 cycle: counters reset.
    pub fn start(&mut self, mode: SyncMode, sync0_cycle_ns: u32) {
        self.mode = mode;
        self.sync0_cycle_ns = sync0_cycle_ns;
        if mode == SyncMode::DcSync0 {
            self.cycle_time_ns = sync0_cycle_ns;
        }
        self.clear_counters();
        self.armed = false;
    }

    /// Clears the counters and the sync error (0x1C32:08 = 2, a new session).
    pub fn clear_counters(&mut self) {
        self.sm_event_missed = 0;
        self.cycle_too_small = 0;
        self.shift_too_short = 0;
        self.error_counter = 0;
        self.sync_error = false;
        self.last_sm2_ns = None;
        self.edges_at_sm2 = None;
    }

    /// Leaving OP: the monitor waits for the first SM2 event in OP again.
    pub fn disarm(&mut self) {
        self.armed = false;
    }

    /// SAFEOP -> OP: the monitor waits for the first SM2 event in OP, and the sync error
    /// starts over, as the SSC clears its SM event missed counter and sync error when it
    /// starts the outputs (StartOutputHandler): an error acknowledged before must not keep
    /// the next one from being raised. The diagnostic counters (0x1C32:0B..0D) go on.
    pub fn enter_op(&mut self) {
        self.armed = false;
        self.error_counter = 0;
        self.sync_error = false;
        self.sync0_seen = None;
    }

    /// The SYNC0 watchdog time: twice the SYNC0 cycle, at least 1 ms (the SSC's
    /// Sync0WdValue in its 1 ms ticks).
    pub fn sync0_watchdog_ns(&self) -> u64 {
        (2 * u64::from(self.sync0_cycle_ns)).max(SYNC0_WATCHDOG_MIN_NS)
    }

    /// The SYNC0 watchdog, with the SYNC0 edge count at `now_ns` (the PDI task's
    /// background work, which runs at least every millisecond): in DC mode in OP, no new
    /// edge for longer than [`Self::sync0_watchdog_ns`] is the fatal sync error (AL status
    /// 0x002C, as the SSC's CheckIfEcatError gives it when its Sync0 watchdog expires);
    /// reported once, it sets 0x1C32:20.
    pub fn on_sync0_time(&mut self, now_ns: u64, edges: u32, in_op: bool) -> SyncVerdict {
        if self.mode != SyncMode::DcSync0 || !in_op {
            self.sync0_seen = None;
            return SyncVerdict::Ok;
        }
        match self.sync0_seen {
            Some((seen, since)) if seen == edges => {
                let quiet = now_ns.saturating_sub(since);
                if quiet > self.sync0_watchdog_ns() && !self.sync_error {
                    self.sync_error = true;
                    return SyncVerdict::FatalSyncError;
                }
            }
            _ => self.sync0_seen = Some((edges, now_ns)),
        }
        SyncVerdict::Ok
    }

    /// True once the first SM2 event in OP arrived.
    pub const fn armed(&self) -> bool {
        self.armed
    }

    /// The cycle time (0x1C32:02, ns).
    pub const fn cycle_time_ns(&self) -> u32 {
        self.cycle_time_ns
    }

    /// SDO write of 0x1C32:02 (0 = unknown; otherwise at least the minimum cycle time,
    /// 0x06090032 ValueTooLow).
    pub fn set_cycle_time_ns(&mut self, ns: u32) -> Result<(), SdoAbortCode> {
        if ns != 0 && ns < F::SYNC.min_cycle_ns {
            return Err(SdoAbortCode::ValueTooLow);
        }
        self.cycle_time_ns = ns;
        Ok(())
    }

    /// The SYNC0 cycle read at PREOP -> SAFEOP (0x1C32:0A).
    pub const fn sync0_cycle_ns(&self) -> u32 {
        self.sync0_cycle_ns
    }

    /// 0x1C32:0B SM event missed counter.
    pub const fn sm_event_missed(&self) -> u16 {
        self.sm_event_missed
    }

    /// 0x1C32:0C cycle time too small counter.
    pub const fn cycle_too_small(&self) -> u16 {
        self.cycle_too_small
    }

    /// 0x1C32:0D shift time too short counter.
    pub const fn shift_too_short(&self) -> u16 {
        self.shift_too_short
    }

    /// 0x1C32:20 sync error.
    pub const fn sync_error(&self) -> bool {
        self.sync_error
    }

    /// The internal sync error counter.
    pub const fn error_counter(&self) -> u16 {
        self.error_counter
    }

    /// 0x10F1:02 Sync Error Counter Limit.
    pub const fn error_limit(&self) -> u16 {
        self.error_limit
    }

    /// Sets 0x10F1:02.
    pub fn set_error_limit(&mut self, limit: u16) {
        self.error_limit = limit;
    }

    fn missed(&mut self, n: u32) -> SyncVerdict {
        if n == 0 {
            return SyncVerdict::Ok;
        }
        let n16 = u16::try_from(n).unwrap_or(u16::MAX);
        self.sm_event_missed = self.sm_event_missed.saturating_add(n16);
        self.error_counter = self.error_counter.saturating_add(n16.saturating_mul(3));
        if self.error_counter > self.error_limit && !self.sync_error {
            self.sync_error = true;
            return SyncVerdict::SyncError;
        }
        SyncVerdict::Ok
    }

    fn good(&mut self, n: u32) {
        let n16 = u16::try_from(n).unwrap_or(u16::MAX);
        self.error_counter = self.error_counter.saturating_sub(n16);
    }

    /// An SM2 event (fresh outputs) at `now_ns`, `in_op` while the ESM is in OP; `sync0`
    /// is the DAC task's SYNC0 bookkeeping at this moment. It only counts: the sync error
    /// counter moves at the SYNC0 edges ([`Self::on_sync0_counts`]) and, in SM-synchronous
    /// mode, only down here.
    // One caller, on the SM2 path of every cycle; at opt-level "s" the image had it out of line.
    #[inline(always)]
    pub fn on_sm2_event(&mut self, now_ns: u64, in_op: bool, sync0: Sync0Counts) {
        let previous = self.last_sm2_ns.replace(now_ns);
        let edges_before = self.edges_at_sm2.replace(sync0.edges);
        if !in_op {
            return;
        }
        if !self.armed {
            self.armed = true;
            self.baseline = sync0;
            self.arm_edges = sync0.edges;
            return;
        }
        match self.mode {
            SyncMode::DcSync0 => {
                if edges_before == Some(sync0.edges) {
                    self.cycle_too_small = self.cycle_too_small.saturating_add(1);
                }
                if self.sync0_cycle_ns != 0 && sync0.edges != self.arm_edges {
                    let next = sync0.last_edge_lo.wrapping_add(self.sync0_cycle_ns);
                    let remaining = next.wrapping_sub(now_ns as u32);
                    if remaining < F::SYNC.output_calc_copy_ns {
                        self.shift_too_short = self.shift_too_short.saturating_add(1);
                    }
                }
            }
            SyncMode::SmSync => {
                if let Some(prev) = previous {
                    if now_ns.saturating_sub(prev) < u64::from(F::SYNC.min_cycle_ns) {
                        self.cycle_too_small = self.cycle_too_small.saturating_add(1);
                    }
                }
                self.good(1);
            }
            SyncMode::FreeRun => {}
        }
    }

    /// The DAC task's SYNC0 bookkeeping (read from the output stage): in DC mode, once
    /// armed, every edge without fresh outputs is a missed SM event, every other edge a good
    /// cycle.
    pub fn on_sync0_counts(&mut self, sync0: Sync0Counts) -> SyncVerdict {
        let edges = sync0.edges.wrapping_sub(self.baseline.edges);
        let without = sync0
            .without_outputs
            .wrapping_sub(self.baseline.without_outputs)
            .min(edges);
        self.baseline = sync0;
        if self.mode != SyncMode::DcSync0 || !self.armed {
            return SyncVerdict::Ok;
        }
        self.good(edges - without);
        self.missed(without)
    }

    /// SDO upload of 0x1C32 or 0x1C33 (`object`) subindex `sub`.
    pub fn read(&self, object: SyncObject, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        let f = &F::SYNC;
        let inputs = matches!(object, SyncObject::Inputs { .. });
        let (calc_copy, delay) = match object {
            SyncObject::Inputs { image_bytes } => (f.input_calc_copy_for(image_bytes), 0),
            SyncObject::Outputs => (f.output_calc_copy_ns, f.output_delay_ns),
        };
        let mut tmp = [0u8; 4];
        let bytes: &[u8] = match sub {
            0 => {
                tmp[0] = 0x20;
                &tmp[..1]
            }
            1 => {
                let v = if inputs {
                    self.input_mode_value()
                } else {
                    self.output_mode_value()
                };
                tmp[..2].copy_from_slice(&v.to_le_bytes());
                &tmp[..2]
            }
            2 => put_u32(&mut tmp, self.cycle_time_ns),
            3 => put_u32(&mut tmp, 0),
            4 => {
                tmp[..2].copy_from_slice(&SUPPORTED_MODES.to_le_bytes());
                &tmp[..2]
            }
            5 => put_u32(&mut tmp, f.min_cycle_ns),
            6 => put_u32(&mut tmp, calc_copy),
            7 => put_u32(&mut tmp, 0),
            8 => {
                tmp[..2].copy_from_slice(&0u16.to_le_bytes());
                &tmp[..2]
            }
            9 => put_u32(&mut tmp, delay),
            0x0A => put_u32(&mut tmp, self.sync0_cycle_ns),
            0x0B => put_u16(&mut tmp, self.sm_event_missed),
            0x0C => put_u16(&mut tmp, self.cycle_too_small),
            0x0D => put_u16(&mut tmp, self.shift_too_short),
            0x20 => {
                tmp[0] = u8::from(self.sync_error);
                &tmp[..1]
            }
            _ => return Err(SdoAbortCode::SubindexDoesNotExist),
        };
        let out = buf
            .get_mut(..bytes.len())
            .ok_or(SdoAbortCode::OutOfMemory)?;
        out.copy_from_slice(bytes);
        Ok(bytes.len())
    }

    /// SDO download to 0x1C32/0x1C33: sub 1 (sync mode), sub 2 (cycle time), sub 8 (get
    /// cycle time: 0 = nothing, 1 = measure, 2 = reset the counters); anything else is
    /// read-only (0x06010002). State rules come from the entry access bits.
    pub fn write(&mut self, inputs: bool, sub: u8, data: &[u8]) -> Result<(), SdoAbortCode> {
        match sub {
            1 => self.request_mode(inputs, le_u16(data)?),
            2 => self.set_cycle_time_ns(le_u32(data)?),
            8 => match le_u16(data)? {
                0 | 1 => Ok(()),
                2 => {
                    self.clear_counters();
                    Ok(())
                }
                _ => Err(SdoAbortCode::ValueRangeExceeded),
            },
            _ => Err(SdoAbortCode::WriteOfReadOnly),
        }
    }
}

fn put_u32(tmp: &mut [u8; 4], v: u32) -> &[u8] {
    *tmp = v.to_le_bytes();
    &tmp[..]
}

fn put_u16(tmp: &mut [u8; 4], v: u16) -> &[u8] {
    tmp[..2].copy_from_slice(&v.to_le_bytes());
    &tmp[..2]
}

/// A little-endian u16 of exactly two bytes (0x06070012/13 otherwise).
pub(crate) fn le_u16(data: &[u8]) -> Result<u16, SdoAbortCode> {
    match data {
        [a, b] => Ok(u16::from_le_bytes([*a, *b])),
        _ if data.len() < 2 => Err(SdoAbortCode::LengthTooLow),
        _ => Err(SdoAbortCode::LengthTooHigh),
    }
}

/// A little-endian u32 of exactly four bytes (0x06070012/13 otherwise).
pub(crate) fn le_u32(data: &[u8]) -> Result<u32, SdoAbortCode> {
    match data {
        [a, b, c, d] => Ok(u32::from_le_bytes([*a, *b, *c, *d])),
        _ if data.len() < 4 => Err(SdoAbortCode::LengthTooLow),
        _ => Err(SdoAbortCode::LengthTooHigh),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The figures of the tests: the analog products' (`crate::products`).
    const MIN_CYCLE_TIME_NS: u32 = crate::products::analog_io::sync::MIN_CYCLE_TIME_NS;
    struct TestFigures;
    impl Figures for TestFigures {
        const SYNC: SyncFigures = FIGURES;
    }
    type Monitor = SyncMonitor<TestFigures>;
    const FIGURES: SyncFigures = SyncFigures {
        min_cycle_ns: MIN_CYCLE_TIME_NS,
        output_calc_copy_ns: 8_000,
        output_delay_ns: 3_000,
        input_calc_copy_ns: 15_000,
        input_calc_copy_bytes: 16,
        input_copy_ns_per_byte: 770,
        confirm_outputs_min_cycle_ns: 62_000,
        default_error_limit: 4,
    };

    fn dc(cycle: u32) -> SyncInputs {
        SyncInputs {
            dc_activation: SyncActivation::CYCLIC_UNIT | SyncActivation::SYNC0,
            sync0_cycle_ns: cycle,
            has_outputs: true,
            sm2_three_buffer: true,
            min_cycle_ns: MIN_CYCLE_TIME_NS,
            ..SyncInputs::default()
        }
    }

    #[test]
    fn input_calc_copy_grows_with_the_bytes_beyond_those_it_covers() {
        assert_eq!(FIGURES.input_calc_copy_for(0), 15_000);
        assert_eq!(FIGURES.input_calc_copy_for(16), 15_000);
        assert_eq!(FIGURES.input_calc_copy_for(17), 15_770);
        assert_eq!(FIGURES.input_calc_copy_for(526), 15_000 + 510 * 770);
        assert_eq!(
            FIGURES.input_calc_copy_for(usize::MAX),
            u32::MAX,
            "saturates"
        );
    }

    #[test]
    fn requested_dc_needs_sync0_active() {
        let mut i = dc(MIN_CYCLE_TIME_NS);
        i.requested = Some(SyncMode::DcSync0);
        assert_eq!(check_sync(&i), Ok(SyncMode::DcSync0));
        i.dc_activation = SyncActivation::empty();
        assert_eq!(
            check_sync(&i),
            Err(SyncConfigError::InvalidDcSyncConfiguration)
        );
        i.dc_activation = SyncActivation::SYNC0; // SYNC0 bit without cyclic operation
        assert_eq!(
            check_sync(&i),
            Err(SyncConfigError::InvalidDcSyncConfiguration)
        );
        assert_eq!(
            u16::from(SyncConfigError::InvalidDcSyncConfiguration.al_status_code()),
            0x0030
        );
    }

    #[test]
    fn requested_sm_sync_with_sync0_active_is_refused() {
        let mut i = dc(100_000);
        i.requested = Some(SyncMode::SmSync);
        assert_eq!(
            check_sync(&i),
            Err(SyncConfigError::InvalidDcSyncConfiguration)
        );
        i.dc_activation = SyncActivation::empty();
        assert_eq!(check_sync(&i), Ok(SyncMode::SmSync));
    }

    #[test]
    fn sync0_cycle_below_minimum_is_refused() {
        let mut i = dc(MIN_CYCLE_TIME_NS - 1);
        assert_eq!(check_sync(&i), Err(SyncConfigError::DcInvalidSyncCycleTime));
        assert_eq!(
            u16::from(SyncConfigError::DcInvalidSyncCycleTime.al_status_code()),
            0x0035
        );
        i.sync0_cycle_ns = 0; // single shot
        assert_eq!(check_sync(&i), Err(SyncConfigError::DcInvalidSyncCycleTime));
        i.sync0_cycle_ns = MIN_CYCLE_TIME_NS;
        assert_eq!(check_sync(&i), Ok(SyncMode::DcSync0));
    }

    #[test]
    fn unrequested_mode_follows_the_esc() {
        assert_eq!(check_sync(&dc(1_000_000)), Ok(SyncMode::DcSync0));
        let mut i = dc(0);
        i.dc_activation = SyncActivation::empty();
        assert_eq!(check_sync(&i), Ok(SyncMode::SmSync));
        i.has_outputs = false;
        assert_eq!(check_sync(&i), Ok(SyncMode::FreeRun));
        i.dc_activation = SyncActivation::SYNC0;
        assert_eq!(
            check_sync(&i),
            Err(SyncConfigError::InvalidDcSyncConfiguration)
        );
    }

    #[test]
    fn free_run_needs_three_buffers_and_sync1_is_not_offered() {
        let mut i = dc(0);
        i.dc_activation = SyncActivation::empty();
        i.requested = Some(SyncMode::FreeRun);
        i.sm2_three_buffer = false;
        assert_eq!(
            check_sync(&i),
            Err(SyncConfigError::FreeRunNeeds3BufferMode)
        );
        assert_eq!(
            u16::from(SyncConfigError::FreeRunNeeds3BufferMode.al_status_code()),
            0x0029
        );
        i.sm2_three_buffer = true;
        assert_eq!(check_sync(&i), Ok(SyncMode::FreeRun));
        let mut j = dc(100_000);
        j.dc_activation |= SyncActivation::SYNC1;
        assert_eq!(check_sync(&j), Err(SyncConfigError::SyncModeNotSupported));
        assert_eq!(
            SyncMode::from_output_value(3),
            Err(SyncConfigError::SyncModeNotSupported)
        );
    }

    #[test]
    fn input_mode_must_agree_on_dc() {
        let mut i = dc(MIN_CYCLE_TIME_NS);
        i.requested_inputs = Some(SyncMode::SmSync);
        assert_eq!(
            check_sync(&i),
            Err(SyncConfigError::InvalidDcSyncConfiguration)
        );
        i.requested_inputs = Some(SyncMode::DcSync0);
        assert_eq!(check_sync(&i), Ok(SyncMode::DcSync0));
    }

    /// A fake DAC task: SYNC0 edges with or without fresh outputs.
    #[derive(Default)]
    struct Edges(Sync0Counts);

    impl Edges {
        fn edge(&mut self, t: u64, fresh: bool) -> Sync0Counts {
            self.0.edges += 1;
            self.0.without_outputs += u32::from(!fresh);
            self.0.last_edge_lo = t as u32;
            self.0
        }
    }

    #[test]
    fn dc_missed_events_raise_sync_error_after_the_limit() {
        let mut m = Monitor::new();
        let mut e = Edges::default();
        m.start(SyncMode::DcSync0, 100_000);
        // Before the first SM2 event in OP nothing counts.
        assert_eq!(m.on_sync0_counts(e.edge(0, false)), SyncVerdict::Ok);
        assert_eq!(m.sm_event_missed(), 0);
        m.on_sm2_event(10_000, true, e.0);
        assert_eq!(m.on_sync0_counts(e.edge(100_000, true)), SyncVerdict::Ok);
        // Limit 4: first miss -> 3, second -> 6 > 4.
        assert_eq!(m.on_sync0_counts(e.edge(200_000, false)), SyncVerdict::Ok);
        assert_eq!(m.error_counter(), 3);
        assert_eq!(
            m.on_sync0_counts(e.edge(300_000, false)),
            SyncVerdict::SyncError
        );
        assert!(m.sync_error());
        assert_eq!(m.sm_event_missed(), 2);
        // Reported once; several edges at once count each.
        e.edge(400_000, false);
        assert_eq!(m.on_sync0_counts(e.edge(500_000, false)), SyncVerdict::Ok);
        assert_eq!(m.sm_event_missed(), 4);
        let mut b = [0u8; 4];
        assert_eq!(m.read(SyncObject::Outputs, 0x20, &mut b), Ok(1));
        assert_eq!(b[0], 1);
        assert_eq!(m.read(SyncObject::Outputs, 0x0B, &mut b), Ok(2));
        assert_eq!(u16::from_le_bytes([b[0], b[1]]), 4);
    }

    /// After a sync error and its acknowledge, SAFEOP -> OP starts the error over: the
    /// next two misses in a row raise it again (it stayed latched before).
    #[test]
    fn the_sync_error_starts_over_at_safeop_to_op() {
        let mut m = Monitor::new();
        let mut e = Edges::default();
        m.start(SyncMode::DcSync0, 100_000);
        for round in 0..3u64 {
            let t = round * 1_000_000;
            m.enter_op();
            assert!(!m.sync_error());
            m.on_sm2_event(t, true, e.0);
            assert_eq!(
                m.on_sync0_counts(e.edge(t + 100_000, false)),
                SyncVerdict::Ok
            );
            assert_eq!(
                m.on_sync0_counts(e.edge(t + 200_000, false)),
                SyncVerdict::SyncError,
                "round {round}"
            );
            m.disarm();
        }
        assert_eq!(m.sm_event_missed(), 6, "the diagnostic counter goes on");
    }

    /// SYNC0 watchdog: in DC mode in OP, edges keep it quiet; none for more than twice
    /// the cycle (at least 1 ms) is the fatal sync error, once; outside OP or DC it is off.
    #[test]
    fn sync0_watchdog_gives_the_fatal_sync_error() {
        let mut m = Monitor::new();
        m.start(SyncMode::DcSync0, 100_000);
        assert_eq!(m.sync0_watchdog_ns(), 1_000_000);
        let mut edges = 0;
        for k in 0..50u64 {
            edges += 1;
            assert_eq!(m.on_sync0_time(k * 100_000, edges, true), SyncVerdict::Ok);
        }
        // No edge from 4.9 ms on.
        assert_eq!(m.on_sync0_time(5_800_000, edges, true), SyncVerdict::Ok);
        assert_eq!(
            m.on_sync0_time(5_900_001, edges, true),
            SyncVerdict::FatalSyncError
        );
        assert!(m.sync_error());
        assert_eq!(
            m.on_sync0_time(9_000_000, edges, true),
            SyncVerdict::Ok,
            "once"
        );
        // Outside OP it does not count; back in OP it starts from the first look.
        m.enter_op();
        assert_eq!(m.on_sync0_time(20_000_000, edges, false), SyncVerdict::Ok);
        assert_eq!(m.on_sync0_time(21_000_000, edges, true), SyncVerdict::Ok);
        assert_eq!(m.on_sync0_time(21_900_000, edges, true), SyncVerdict::Ok);
        assert_eq!(
            m.on_sync0_time(22_000_001, edges, true),
            SyncVerdict::FatalSyncError
        );
        // Long cycles: twice the cycle.
        m.start(SyncMode::DcSync0, 4_000_000);
        assert_eq!(m.sync0_watchdog_ns(), 8_000_000);
        // Not in DC mode: off.
        m.start(SyncMode::SmSync, 0);
        m.enter_op();
        assert_eq!(m.on_sync0_time(0, 0, true), SyncVerdict::Ok);
        assert_eq!(m.on_sync0_time(u64::MAX / 2, 0, true), SyncVerdict::Ok);
    }

    #[test]
    fn good_cycles_decrement_the_error_counter() {
        let mut m = Monitor::new();
        let mut e = Edges::default();
        m.start(SyncMode::DcSync0, 100_000);
        m.on_sm2_event(0, true, e.0);
        m.on_sync0_counts(e.edge(100_000, false)); // 3
        for t in 2..5u64 {
            m.on_sm2_event(t * 100_000 - 50_000, true, e.0);
            m.on_sync0_counts(e.edge(t * 100_000, true));
        }
        assert_eq!(m.error_counter(), 0);
        assert!(!m.sync_error());
    }

    #[test]
    fn dc_cycle_too_small_and_shift_too_short() {
        let mut m = Monitor::new();
        let mut e = Edges::default();
        m.start(SyncMode::DcSync0, 100_000);
        m.on_sm2_event(0, true, e.0);
        m.on_sync0_counts(e.edge(50_000, true));
        m.on_sm2_event(60_000, true, e.0);
        m.on_sm2_event(70_000, true, e.0); // second SM2 event in one cycle
        assert_eq!(m.cycle_too_small(), 1);
        m.on_sync0_counts(e.edge(150_000, true));
        m.on_sm2_event(249_000, true, e.0); // 1 us before the next edge < calc+copy
        assert_eq!(m.shift_too_short(), 1);
        assert_eq!(m.cycle_too_small(), 1);
    }

    #[test]
    fn sm_sync_counts_no_missed_events() {
        let mut m = Monitor::new();
        m.set_cycle_time_ns(1_000_000).unwrap();
        m.start(SyncMode::SmSync, 0);
        let c = Sync0Counts::default();
        m.on_sm2_event(0, true, c);
        m.on_sm2_event(1_000_000, true, c);
        // A long gap (the master stopped for a while) is no missed event and no sync error:
        // the SM watchdog reports a stopped master in this mode.
        m.on_sm2_event(900_000_000, true, c);
        assert_eq!(m.on_sync0_counts(c), SyncVerdict::Ok);
        assert_eq!((m.sm_event_missed(), m.error_counter()), (0, 0));
        assert!(!m.sync_error());
        // Events too close together.
        m.on_sm2_event(900_010_000, true, c);
        m.on_sm2_event(900_020_000, true, c);
        assert_eq!(m.cycle_too_small(), 2);
    }

    #[test]
    fn object_values_and_writes() {
        let mut m = Monitor::new();
        let mut b = [0u8; 8];
        assert_eq!(m.read(SyncObject::Outputs, 4, &mut b), Ok(2));
        assert_eq!(b[..2], [0x07, 0x00]);
        assert_eq!(m.read(SyncObject::Outputs, 5, &mut b), Ok(4));
        assert_eq!(
            u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            MIN_CYCLE_TIME_NS
        );
        assert_eq!(
            m.read(SyncObject::Inputs { image_bytes: 0 }, 1, &mut b),
            Ok(2)
        );
        assert_eq!(b[..2], [0x22, 0x00]);
        // 0x1C33:06 follows the assigned input image; 0x1C32:06 does not.
        for (image_bytes, want) in [(16, 15_000), (526, FIGURES.input_calc_copy_for(526))] {
            let inputs = SyncObject::Inputs { image_bytes };
            assert_eq!(m.read(inputs, 6, &mut b), Ok(4));
            assert_eq!(u32::from_le_bytes([b[0], b[1], b[2], b[3]]), want);
        }
        assert!(FIGURES.input_calc_copy_for(526) > 15_000);
        assert_eq!(m.read(SyncObject::Outputs, 6, &mut b), Ok(4));
        assert_eq!(u32::from_le_bytes([b[0], b[1], b[2], b[3]]), 8_000);
        assert_eq!(m.write(false, 1, &[2, 0]), Ok(()));
        assert_eq!(m.output_mode_value(), 2);
        assert_eq!(m.input_mode_value(), 2);
        assert_eq!(
            m.write(false, 1, &[3, 0]),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(m.write(false, 1, &[2]), Err(SdoAbortCode::LengthTooLow));
        assert_eq!(
            m.write(false, 2, &1000u32.to_le_bytes()),
            Err(SdoAbortCode::ValueTooLow)
        );
        assert_eq!(
            m.write(false, 5, &[0; 4]),
            Err(SdoAbortCode::WriteOfReadOnly)
        );
        assert_eq!(
            m.read(SyncObject::Outputs, 0x13, &mut b),
            Err(SdoAbortCode::SubindexDoesNotExist)
        );
        assert_eq!(
            m.read(SyncObject::Outputs, 2, &mut b[..3]),
            Err(SdoAbortCode::OutOfMemory)
        );
        m.reset();
        assert_eq!(m.requests(), (None, None));
    }

    /// 0x1C32/0x1C33 of the product's dictionary describe exactly what the monitor serves:
    /// every entry is read with its length, sub 0 stays 0x20, and the unmeasured 0x0E..=0x12
    /// are absent from both.
    #[test]
    fn the_dictionary_describes_what_the_monitor_serves() {
        let monitor = Monitor::new();
        // The default assignment's input image is within the bytes the static figure covers.
        let inputs = SyncObject::Inputs { image_bytes: 0 };
        for (index, inputs) in [(0x1C32, SyncObject::Outputs), (0x1C33, inputs)] {
            let object = crate::products::analog_io::od::OD.find(index).unwrap();
            assert_eq!(object.max_subindex(), 0x20);
            let mut buf = [0u8; 8];
            for e in object.entries.iter().skip(1) {
                let n = monitor.read(inputs, e.subindex, &mut buf);
                assert_eq!(
                    n,
                    Ok(usize::from(e.bit_len.div_ceil(8))),
                    "{index:#x}:{:#x}",
                    e.subindex
                );
                // The defaults are the values the monitor starts with.
                let mut default = [0u8; 8];
                let len =
                    object
                        .resolve(e)
                        .default()
                        .encode(e.data_type(), e.bit_len, &mut default);
                if let Some(len) = len.filter(|n| *n > 0) {
                    assert_eq!(default[..len], buf[..len], "{index:#x}:{:#x}", e.subindex);
                }
            }
            for sub in 0x0E..=0x12 {
                assert!(object.entry(sub).is_none(), "{index:#x}:{sub:#x}");
                assert_eq!(
                    monitor.read(inputs, sub, &mut buf),
                    Err(SdoAbortCode::SubindexDoesNotExist)
                );
            }
        }
    }
}
