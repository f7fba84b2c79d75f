//! The two analog outputs: values staged by the PDI task, latched by the SYNC0 (DAC) task,
//! and the fault reaction (CiA 401 0x6443 "AO error mode", 0x6444 "AO error value").
//!
//! # Staging without locks and without `unsafe`
//!
//! The DAC codes of both channels travel as ONE 32-bit word ([`DacPair::pack`]) in an
//! [`AtomicU32`], so the DAC side can only ever read a complete pair: a half-written pair
//! does not exist. A second word, the control word, carries a sequence number and what the
//! pair is for ([`StageKind`]); the single writer (PDI task) stores the pair first and the
//! control word second, the reader (DAC task, higher priority) reads the control word first.
//! [`OutputStage`] is shared by reference (a `&'static OutputStage`, made in RTIC's `init`
//! and handed to the PDI and DAC tasks as local resources), its [`DacLatch`] reader is
//! local to the DAC task.
//!
//! # What the DAC task does ([`DacAction`])
//!
//! - SYNC0 edge ([`DacLatch::on_sync0`]): fresh pair -> latch it; if the pair was already
//!   written to the input registers ([`DacLatch::preload`], LDAC register 0 so nothing
//!   changed yet) only the LDAC pin is pulsed ([`DacAction::PulseLdac`]; `cargo xtask
//!   bench` prints the time from the edge, F2), else both registers are written with "write input A" + "write input B and
//!   update all" ([`DacAction::WriteAndUpdate`]). Preload and latch belong to the same
//!   sequence number, so LDAC never latches registers that hold anything but a complete,
//!   current pair. No fresh pair -> [`DacAction::Keep`]: the outputs keep their values and
//!   [`OutputStage::sync0_without_outputs`] counts it.
//! - Apply request ([`DacLatch::apply_now`]): free run and SM-synchronous mode apply a fresh
//!   pair at once, and a fault pair is always applied at once (the PDI task pends the DAC
//!   task).
//!
//! # Fault reaction ([`OutputStage::enter_fault`])
//!
//! On a process-data watchdog expiry and on every transition out of OP the PDI task calls
//! `enter_fault`: it first cancels whatever is staged (so a stale pair can never be latched
//! afterwards), then computes the fault pair from the pair actually applied and the fault
//! configuration (per channel: 0x6443 = 1 -> the 0x6444 value, 0x6443 = 0 -> keep the
//! present output), and stages it for immediate application. [`AnalogOutputs`] then refuses
//! to stage anything until fresh process data arrive in OP.

pub use super::dac_pair::DacPair;
use super::output_blocks::Grid;
#[cfg(any(feature = "analog-io", not(target_os = "none")))]
use super::output_blocks::UpdateRing;
use super::scaling::{ao_in_range, dac_code_to_ao, fault_value_to_dac_code};
use crate::platform::board::AO_CHANNELS as CHANNELS;
use crate::stacks::ethercat::application::CycleStage;
use crate::stacks::ethercat::sync::Sync0Counts;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

// A DAC pair is the AD5663's two channels.
const _: () = assert!(CHANNELS == 2, "the outputs are the AD5663's two channels");

/// CiA 401 AO error mode (0x6443) per channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ErrorMode {
    /// 0: a fault leaves the output unchanged.
    Keep,
    /// 1: a fault switches the output to the 0x6444 value (the default).
    #[default]
    ErrorValue,
}

impl ErrorMode {
    /// Decodes the 0x6443 value; `None` for other values (0x06090030).
    pub const fn from_u8(value: u8) -> Option<Self> {
        match value {
            0 => Some(Self::Keep),
            1 => Some(Self::ErrorValue),
            _ => None,
        }
    }

    /// The 0x6443 value.
    pub const fn to_u8(self) -> u8 {
        match self {
            Self::Keep => 0,
            Self::ErrorValue => 1,
        }
    }
}

/// The fault configuration of both channels (0x6443, 0x6444).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FaultConfig {
    /// 0x6443:01..02.
    pub mode: [ErrorMode; CHANNELS],
    /// 0x6444:01..02 in 0x6411 units (clamped to 0..=0x7FFF when applied).
    pub value: [i32; CHANNELS],
}

impl FaultConfig {
    /// The pair a fault produces when `current` is on the outputs.
    pub fn fault_pair(&self, current: DacPair) -> DacPair {
        let pick = |i: usize, now: u16| match self.mode.get(i) {
            Some(ErrorMode::ErrorValue) => {
                fault_value_to_dac_code(self.value.get(i).copied().unwrap_or(0))
            }
            _ => now,
        };
        DacPair::new(pick(0, current.a), pick(1, current.b))
    }
}

/// What a staged pair is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StageKind {
    /// Nothing valid: a previously staged pair was withdrawn.
    Cancelled,
    /// Fresh outputs from the process data (or an SDO write in OP).
    Outputs,
    /// The fault pair (applied at once).
    Fault,
}

impl StageKind {
    const fn bits(self) -> u32 {
        match self {
            Self::Cancelled => 0,
            Self::Outputs => 1,
            Self::Fault => 2,
        }
    }

    const fn from_bits(bits: u32) -> Self {
        match bits & 3 {
            1 => Self::Outputs,
            2 => Self::Fault,
            _ => Self::Cancelled,
        }
    }
}

/// The hand-over between the PDI task (single writer) and the DAC task (single reader).
#[derive(Debug, Default)]
pub struct OutputStage {
    pair: AtomicU32,
    control: AtomicU32,
    applied: AtomicU32,
    without_outputs: AtomicU32,
    sync0_edges: AtomicU32,
    sync0_time_lo: AtomicU32,
    dc_mode: AtomicBool,
    /// Output oversampling: the LDAC grid ([`Grid::pack`]; [`Grid::OFF`]: one pair per
    /// cycle). Only in a build with it, so the others keep their layout.
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    block_grid: AtomicU32,
    /// Output oversampling: the blocks for the update interrupt.
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    pub blocks: UpdateRing,
}

impl OutputStage {
    /// Nothing staged, 0 V applied (the AD5663 power-on state).
    pub const fn new() -> Self {
        Self {
            pair: AtomicU32::new(0),
            control: AtomicU32::new(0),
            applied: AtomicU32::new(0),
            without_outputs: AtomicU32::new(0),
            sync0_edges: AtomicU32::new(0),
            sync0_time_lo: AtomicU32::new(0),
            dc_mode: AtomicBool::new(false),
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            block_grid: AtomicU32::new(0),
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            blocks: UpdateRing::new(),
        }
    }

    /// PDI side: output oversampling on `grid` ([`Grid::OFF`]: one pair per cycle as
    /// before). The SYNC0 task starts or stops the grid at its next edge.
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    pub fn set_block_grid(&self, grid: Grid) {
        self.blocks.stop();
        self.block_grid.store(grid.pack(), Ordering::Release);
    }

    /// The LDAC grid asked for.
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    pub fn block_grid(&self) -> Grid {
        Grid::unpack(self.block_grid.load(Ordering::Acquire))
    }

    /// The LDAC grid asked for: none in a build without output oversampling.
    #[cfg(not(any(feature = "analog-io", not(target_os = "none"))))]
    pub fn block_grid(&self) -> Grid {
        Grid::OFF
    }

    /// Update interrupt: `pair` was written for the next LDAC edge (the pair a fault with
    /// "keep" holds).
    pub fn record_applied(&self, pair: DacPair) {
        self.applied.store(pair.pack(), Ordering::Release);
    }

    fn publish(&self, kind: StageKind) {
        let seq = (self.control.load(Ordering::Acquire) >> 2).wrapping_add(1);
        self.control
            .store(seq << 2 | kind.bits(), Ordering::Release);
    }

    /// PDI side: stages a complete pair of fresh outputs.
    pub fn stage(&self, pair: DacPair) {
        self.pair.store(pair.pack(), Ordering::Release);
        self.publish(StageKind::Outputs);
    }

    /// PDI side: withdraws a staged pair that was not latched yet.
    pub fn cancel(&self) {
        self.publish(StageKind::Cancelled);
    }

    /// PDI side: the fault reaction. Cancels anything staged, then stages the fault pair
    /// computed from the applied pair and `config`, and returns it. The DAC task must be
    /// asked to apply it at once ([`DacLatch::apply_now`]).
    pub fn enter_fault(&self, config: &FaultConfig) -> DacPair {
        // No block update may follow the fault pair.
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        self.blocks.stop();
        self.cancel();
        let pair = config.fault_pair(self.applied());
        self.pair.store(pair.pack(), Ordering::Release);
        self.publish(StageKind::Fault);
        pair
    }

    /// The pair last handed to the DAC.
    pub fn applied(&self) -> DacPair {
        DacPair::unpack(self.applied.load(Ordering::Acquire))
    }

    /// SYNC0 edges that found no fresh outputs (the outputs kept their values).
    pub fn sync0_without_outputs(&self) -> u32 {
        self.without_outputs.load(Ordering::Relaxed)
    }

    /// Output oversampling: the cycles whose outputs held because their update block came
    /// late or never ([`UpdateRing::underruns`]; 0 in a build without it).
    pub fn output_holds(&self) -> u32 {
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        return self.blocks.underruns();
        #[cfg(not(any(feature = "analog-io", not(target_os = "none"))))]
        0
    }

    /// PDI side: SYNC0 edges latch the outputs only in DC mode (set at PREOP -> SAFEOP).
    pub fn set_dc_mode(&self, dc: bool) {
        // Leaving SAFEOP for PREOP/INIT: the LDAC grid stops with the blocks.
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        if !dc {
            self.set_block_grid(Grid::OFF);
        }
        self.dc_mode.store(dc, Ordering::Release);
    }

    /// True if SYNC0 edges latch the outputs.
    pub fn dc_mode(&self) -> bool {
        self.dc_mode.load(Ordering::Acquire)
    }

    /// The SYNC0 bookkeeping of the DAC task.
    pub fn sync0_counts(&self) -> Sync0Counts {
        Sync0Counts {
            edges: self.sync0_edges.load(Ordering::Acquire),
            without_outputs: self.without_outputs.load(Ordering::Acquire),
            last_edge_lo: self.sync0_time_lo.load(Ordering::Acquire),
        }
    }

    /// What is staged now: kind and pair (for tests and diagnostics).
    pub fn staged(&self) -> (StageKind, DacPair) {
        let control = self.control.load(Ordering::Acquire);
        (
            StageKind::from_bits(control),
            DacPair::unpack(self.pair.load(Ordering::Acquire)),
        )
    }
}

impl CycleStage for OutputStage {
    fn sync0_counts(&self) -> Sync0Counts {
        OutputStage::sync0_counts(self)
    }

    fn set_dc_mode(&self, dc: bool) {
        OutputStage::set_dc_mode(self, dc)
    }

    fn dc_mode(&self) -> bool {
        OutputStage::dc_mode(self)
    }

    fn fault_waiting(&self) -> bool {
        self.staged().0 == StageKind::Fault
    }
}

/// What the DAC task writes to the AD5663.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DacAction {
    /// Nothing: the outputs keep their values.
    Keep,
    /// The input registers already hold this pair: pulse LDAC only.
    PulseLdac(DacPair),
    /// Write input A, then write input B and update all (both change together).
    WriteAndUpdate(DacPair),
}

impl DacAction {
    /// The pair that is on the outputs after the action, if it changes them.
    pub const fn pair(&self) -> Option<DacPair> {
        match *self {
            Self::Keep => None,
            Self::PulseLdac(p) | Self::WriteAndUpdate(p) => Some(p),
        }
    }
}

/// The DAC task's reader of an [`OutputStage`] (task-local state).
#[derive(Debug, Default, Clone)]
pub struct DacLatch {
    seen: u32,
    preloaded: Option<u32>,
}

impl DacLatch {
    /// A latch that has seen nothing.
    pub const fn new() -> Self {
        Self {
            seen: 0,
            preloaded: None,
        }
    }

    /// Takes a fresh staged pair: `Some((control, kind, pair))` if the control word changed.
    fn fresh(&mut self, stage: &OutputStage) -> Option<(u32, StageKind, DacPair)> {
        let control = stage.control.load(Ordering::Acquire);
        if control == self.seen {
            return None;
        }
        self.seen = control;
        let pair = DacPair::unpack(stage.pair.load(Ordering::Acquire));
        Some((control, StageKind::from_bits(control), pair))
    }

    fn latch(&mut self, stage: &OutputStage, control: u32, pair: DacPair) -> DacAction {
        let action = if self.preloaded == Some(control) {
            DacAction::PulseLdac(pair)
        } else {
            DacAction::WriteAndUpdate(pair)
        };
        self.preloaded = None;
        stage.applied.store(pair.pack(), Ordering::Release);
        action
    }

    /// A SYNC0 edge captured at `captured_ns`: in DC mode latch a fresh pair, or keep the
    /// outputs and count the edge; outside DC mode only the edge is recorded. The SYNC0 task
    /// calls the two halves ([`Self::latch_at_sync0`], [`Self::record_sync0`]) with the
    /// DAC action between them, so that the LDAC edge does not wait for the capture's time.
    pub fn on_sync0(&mut self, stage: &OutputStage, captured_ns: u64) -> DacAction {
        let action = self.latch_at_sync0(stage);
        Self::record_sync0(stage, captured_ns);
        action
    }

    /// What a SYNC0 edge does to the outputs: in DC mode latch a fresh pair (the edges
    /// that find none are counted), else nothing. Needs no time, so it comes first.
    pub fn latch_at_sync0(&mut self, stage: &OutputStage) -> DacAction {
        if !stage.dc_mode() {
            return DacAction::Keep;
        }
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        if stage.block_grid() != Grid::OFF {
            // The update interrupt plays the blocks; a fault pair is applied at once.
            let next = stage.sync0_edges.load(Ordering::Relaxed).wrapping_add(1);
            if !stage.blocks.has_block_for(next) {
                let n = stage.without_outputs.load(Ordering::Relaxed);
                stage
                    .without_outputs
                    .store(n.wrapping_add(1), Ordering::Relaxed);
            }
            return DacAction::Keep;
        }
        match self.fresh(stage) {
            Some((control, StageKind::Outputs | StageKind::Fault, pair)) => {
                self.latch(stage, control, pair)
            }
            Some((_, StageKind::Cancelled, _)) | None => {
                self.preloaded = None;
                let n = stage.without_outputs.load(Ordering::Relaxed);
                stage
                    .without_outputs
                    .store(n.wrapping_add(1), Ordering::Relaxed);
                DacAction::Keep
            }
        }
    }

    /// Records a SYNC0 edge captured at `captured_ns` for the PDI side
    /// ([`OutputStage::sync0_counts`]), after [`Self::latch_at_sync0`] of the same edge.
    pub fn record_sync0(stage: &OutputStage, captured_ns: u64) {
        stage
            .sync0_time_lo
            .store(captured_ns as u32, Ordering::Release);
        let edges = stage.sync0_edges.load(Ordering::Relaxed);
        stage
            .sync0_edges
            .store(edges.wrapping_add(1), Ordering::Release);
    }

    /// An apply request from the PDI task (free run, SM-synchronous, fault): latch a fresh
    /// pair at once; nothing fresh -> [`DacAction::Keep`] (not counted).
    pub fn apply_now(&mut self, stage: &OutputStage) -> DacAction {
        match self.fresh(stage) {
            Some((control, StageKind::Outputs | StageKind::Fault, pair)) => {
                self.latch(stage, control, pair)
            }
            _ => {
                self.preloaded = None;
                DacAction::Keep
            }
        }
    }

    /// DC mode, fast path: the pair to write into the input registers now (LDAC register 0:
    /// the outputs do not change) so the next SYNC0 only pulses LDAC. `None` if there is no
    /// fresh, not yet preloaded pair of outputs.
    pub fn preload(&mut self, stage: &OutputStage) -> Option<DacPair> {
        let control = stage.control.load(Ordering::Acquire);
        if control == self.seen
            || self.preloaded == Some(control)
            || StageKind::from_bits(control) != StageKind::Outputs
        {
            return None;
        }
        self.preloaded = Some(control);
        Some(DacPair::unpack(stage.pair.load(Ordering::Acquire)))
    }
}

/// The PDI-side view of the outputs: the 0x6411 values, the fault configuration and the
/// rule "outputs only in OP, and only fresh ones after a fault".
#[derive(Debug, Clone, Default)]
pub struct AnalogOutputs {
    values: [i16; CHANNELS],
    fault: FaultConfig,
    enabled: bool,
    out_of_range: bool,
}

/// What [`AnalogOutputs::set_values`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SetOutcome {
    /// A pair was staged for the DAC.
    pub staged: bool,
    /// A value became out of range (negative) with this update: report it once.
    pub newly_out_of_range: bool,
    /// A value is out of range.
    pub out_of_range: bool,
}

impl AnalogOutputs {
    /// Outputs disabled, values 0, default fault configuration (0x6443 = 1, 0x6444 = 0).
    pub const fn new() -> Self {
        Self {
            values: [0; CHANNELS],
            fault: FaultConfig {
                mode: [ErrorMode::ErrorValue; CHANNELS],
                value: [0; CHANNELS],
            },
            enabled: false,
            out_of_range: false,
        }
    }

    /// The 0x6411 values last received.
    pub const fn values(&self) -> [i16; CHANNELS] {
        self.values
    }

    /// The fault configuration.
    pub const fn fault_config(&self) -> &FaultConfig {
        &self.fault
    }

    /// Changes the fault configuration (0x6443/0x6444 writes).
    pub fn fault_config_mut(&mut self) -> &mut FaultConfig {
        &mut self.fault
    }

    /// True while outputs received in OP drive the DAC.
    pub const fn enabled(&self) -> bool {
        self.enabled
    }

    /// New 0x6411 values (from SM2 or an SDO write). In OP they are staged for the DAC and
    /// the outputs are enabled; in any other state they are only stored.
    pub fn set_values(
        &mut self,
        values: [i16; CHANNELS],
        in_op: bool,
        stage: &OutputStage,
    ) -> SetOutcome {
        self.values = values;
        // The pair by name: an iterator over two values is a loop at opt-level "s".
        let [a, b] = values;
        let bad = !(ao_in_range(a) && ao_in_range(b));
        let newly_out_of_range = bad && !self.out_of_range;
        self.out_of_range = bad;
        if in_op {
            self.enabled = true;
            stage.stage(DacPair::from_ao(values));
        }
        SetOutcome {
            staged: in_op,
            newly_out_of_range,
            out_of_range: bad,
        }
    }

    /// Output oversampling: the last update of a block published in OP (0x6411 reads it;
    /// the update interrupt applies the block).
    pub fn set_block_values(&mut self, pair: DacPair) {
        self.values = [dac_code_to_ao(pair.a), dac_code_to_ao(pair.b)];
        self.enabled = true;
    }

    /// The fault reaction (watchdog, leaving OP): disables the outputs until fresh data
    /// arrive in OP and stages the fault pair. Returns the fault pair. (Out of line: several
    /// callers, at faults only.)
    #[inline(never)]
    pub fn enter_fault(&mut self, stage: &OutputStage) -> DacPair {
        self.enabled = false;
        stage.enter_fault(&self.fault)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dc_stage() -> OutputStage {
        let stage = OutputStage::new();
        stage.set_dc_mode(true);
        stage
    }

    #[test]
    fn sync0_outside_dc_mode_only_records_the_edge() {
        let stage = OutputStage::new();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(1, 2));
        assert_eq!(latch.on_sync0(&stage, 0x1_0000_0010), DacAction::Keep);
        assert_eq!(
            stage.sync0_counts(),
            Sync0Counts {
                edges: 1,
                without_outputs: 0,
                last_edge_lo: 0x10
            }
        );
        assert_eq!(
            latch.apply_now(&stage),
            DacAction::WriteAndUpdate(DacPair::new(1, 2))
        );
    }

    #[test]
    fn the_latch_at_sync0_needs_no_time_and_the_record_no_decision() {
        // The SYNC0 task pulses LDAC between the two halves: the decision reads only the
        // stage, the record only counts the edge.
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(3, 4));
        assert_eq!(latch.preload(&stage), Some(DacPair::new(3, 4)));
        assert_eq!(
            latch.latch_at_sync0(&stage),
            DacAction::PulseLdac(DacPair::new(3, 4))
        );
        assert_eq!(stage.sync0_counts(), Sync0Counts::default());
        assert_eq!(stage.applied(), DacPair::new(3, 4));
        DacLatch::record_sync0(&stage, 0x2_0000_0020);
        assert_eq!(
            stage.sync0_counts(),
            Sync0Counts {
                edges: 1,
                without_outputs: 0,
                last_edge_lo: 0x20
            }
        );
        // An edge without fresh outputs: counted by the decision, recorded by the record.
        assert_eq!(latch.latch_at_sync0(&stage), DacAction::Keep);
        assert_eq!(stage.sync0_counts().without_outputs, 1);
        assert_eq!(stage.sync0_counts().edges, 1);
        DacLatch::record_sync0(&stage, 0x30);
        assert_eq!(stage.sync0_counts().edges, 2);
    }

    #[test]
    fn pair_packs_into_one_word() {
        let p = DacPair::new(0x1234, 0xABCD);
        assert_eq!(p.pack(), 0xABCD_1234);
        assert_eq!(DacPair::unpack(p.pack()), p);
        assert_eq!(DacPair::from_ao([0x4000, -3]), DacPair::new(0x8000, 0));
        assert_eq!(p.channel(1), Some(0xABCD));
        assert_eq!(p.channel(2), None);
    }

    #[test]
    fn sync0_latches_a_fresh_pair_once() {
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(1, 2));
        assert_eq!(
            latch.on_sync0(&stage, 0),
            DacAction::WriteAndUpdate(DacPair::new(1, 2))
        );
        assert_eq!(stage.applied(), DacPair::new(1, 2));
        // No fresh outputs: keep and count.
        assert_eq!(latch.on_sync0(&stage, 0), DacAction::Keep);
        assert_eq!(latch.on_sync0(&stage, 0), DacAction::Keep);
        assert_eq!(stage.sync0_without_outputs(), 2);
        assert_eq!(stage.applied(), DacPair::new(1, 2));
    }

    #[test]
    fn only_the_newest_complete_pair_is_latched() {
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(1, 1));
        stage.stage(DacPair::new(2, 2));
        assert_eq!(latch.on_sync0(&stage, 0).pair(), Some(DacPair::new(2, 2)));
    }

    #[test]
    fn preload_then_ldac_pulse() {
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(7, 8));
        assert_eq!(latch.preload(&stage), Some(DacPair::new(7, 8)));
        assert_eq!(latch.preload(&stage), None, "preloaded once");
        assert_eq!(
            latch.on_sync0(&stage, 0),
            DacAction::PulseLdac(DacPair::new(7, 8))
        );
    }

    #[test]
    fn pair_staged_after_preload_is_written_not_pulsed() {
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(7, 8));
        assert!(latch.preload(&stage).is_some());
        stage.stage(DacPair::new(9, 10));
        assert_eq!(
            latch.on_sync0(&stage, 0),
            DacAction::WriteAndUpdate(DacPair::new(9, 10))
        );
    }

    #[test]
    fn fault_cancels_staged_pair_and_applies_fault_values() {
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(100, 200));
        assert!(latch.apply_now(&stage).pair().is_some());
        // A new pair arrives but is not latched yet when the fault hits.
        stage.stage(DacPair::new(300, 400));
        assert!(latch.preload(&stage).is_some());
        let config = FaultConfig {
            mode: [ErrorMode::ErrorValue, ErrorMode::Keep],
            value: [0x1000, 0x2000],
        };
        let fault = stage.enter_fault(&config);
        // Channel A to the fault value, channel B keeps the APPLIED value (not the stale 400).
        assert_eq!(fault, DacPair::new(0x2000, 200));
        assert_eq!(latch.apply_now(&stage), DacAction::WriteAndUpdate(fault));
        // The stale pair never comes back.
        assert_eq!(latch.on_sync0(&stage, 0), DacAction::Keep);
        assert_eq!(stage.applied(), fault);
    }

    #[test]
    fn cancelled_stage_is_never_latched() {
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        stage.stage(DacPair::new(5, 5));
        stage.cancel();
        assert_eq!(latch.on_sync0(&stage, 0), DacAction::Keep);
        assert_eq!(latch.apply_now(&stage), DacAction::Keep);
        assert_eq!(stage.applied(), DacPair::default());
        assert_eq!(stage.staged().0, StageKind::Cancelled);
    }

    #[test]
    fn outputs_only_in_op_and_fresh_after_fault() {
        let stage = dc_stage();
        let mut latch = DacLatch::new();
        let mut ao = AnalogOutputs::new();
        // SAFEOP: stored, not staged.
        let out = ao.set_values([0x100, 0x200], false, &stage);
        assert!(!out.staged);
        assert_eq!(ao.values(), [0x100, 0x200]);
        assert_eq!(latch.apply_now(&stage), DacAction::Keep);
        // OP: staged.
        assert!(ao.set_values([0x100, 0x200], true, &stage).staged);
        assert!(ao.enabled());
        assert_eq!(
            latch.on_sync0(&stage, 0),
            DacAction::WriteAndUpdate(DacPair::new(0x200, 0x400))
        );
        // Fault with the defaults: both to 0.
        ao.fault_config_mut().value = [0, 0x10];
        let fault = ao.enter_fault(&stage);
        assert_eq!(fault, DacPair::new(0, 0x20));
        assert!(!ao.enabled());
        assert_eq!(latch.apply_now(&stage), DacAction::WriteAndUpdate(fault));
    }

    #[test]
    fn out_of_range_is_reported_once_per_episode() {
        let stage = dc_stage();
        let mut ao = AnalogOutputs::new();
        let set = ao.set_values([-1, 0], true, &stage);
        assert!(set.newly_out_of_range && set.out_of_range);
        let set = ao.set_values([-5, 0], true, &stage);
        assert!(!set.newly_out_of_range && set.out_of_range);
        let set = ao.set_values([5, 0], true, &stage);
        assert!(!set.newly_out_of_range && !set.out_of_range);
        assert!(ao.set_values([5, -2], true, &stage).newly_out_of_range);
        assert_eq!(stage.staged().1, DacPair::new(10, 0));
    }

    #[test]
    fn error_mode_codes() {
        assert_eq!(ErrorMode::from_u8(0), Some(ErrorMode::Keep));
        assert_eq!(ErrorMode::from_u8(1), Some(ErrorMode::ErrorValue));
        assert_eq!(ErrorMode::from_u8(2), None);
        assert_eq!(ErrorMode::Keep.to_u8(), 0);
    }
}
