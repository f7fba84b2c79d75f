//! What the EtherCAT slave application needs from the device it serves: the product's
//! application (its objects, its process data, its outputs), behind one trait, so the stack
//! knows no product, no converter and no other fieldbus.
//!
//! A product with a second fieldbus gives the slave application an [`Application`] that
//! holds the other stack too (the CANopen node beside the analog I/O, `crate::products`),
//! and learns through the notifications ([`Application::on_output_event`],
//! [`Application::on_cycle_polled`], [`Application::on_emergency`]) what it must know of
//! the EtherCAT cycle.

use super::sync::{Figures, Sync0Counts, SyncMonitor};
use crate::stacks::diagnostics::Diagnostics;
use coe_core::device::SyncManagerDesc;
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::sdo_server::Emergency;
use coe_core::AlStatusCode;
use et1100::SyncManager;

/// The hand-over between the PDI task and the task that acts at the SYNC0 edge, as far as
/// the slave application uses it (lock-free: shared by reference between priorities).
pub trait CycleStage {
    /// What the SYNC0 task has recorded (edges, edges without fresh outputs, the last
    /// edge's time).
    fn sync0_counts(&self) -> Sync0Counts;
    /// SYNC0 edges latch the outputs (DC mode, set at PREOP -> SAFEOP) or not.
    fn set_dc_mode(&self, dc: bool);
    /// True in DC mode.
    fn dc_mode(&self) -> bool;
    /// A fault reaction is staged and waits for the output task.
    fn fault_waiting(&self) -> bool;
}

/// PREOP -> SAFEOP in DC SYNC0 mode: where the SYNC0 edges lie in DC time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DcStart {
    /// SYNC0 cycle (0x09A0), ns.
    pub cycle_ns: u32,
    /// The ESC's next SYNC0 time (0x0990), DC ns.
    pub next_sync0_dc: u64,
    /// The captured time (low 32 bits, MCU ns) of the SYNC0 edge right before
    /// `next_sync0_dc`, if SYNC0 was running; `None`: the next edge captured is the first.
    pub previous_edge_lo: Option<u32>,
}

/// What an application's call asks of the caller besides its answer.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Effects {
    /// The output task must apply the staged outputs now (free run, SM-synchronous, SDO
    /// writes, fault values).
    pub apply_outputs: bool,
    /// An Emergency of the application (an output out of range).
    pub emergency: Option<Emergency>,
}

/// The device the EtherCAT slave application serves.
///
/// Process data: at PREOP -> SAFEOP [`Application::prepare`] checks the PDO configuration
/// and SM2/SM3 and fixes the images; each cycle the slave application reads SM2 into
/// [`Application::output_image`] (read twice into [`Application::output_buffer`]s when
/// the outputs must be confirmed), hands it over with [`Application::take_outputs`] in OP,
/// and writes [`Application::input_image`] to SM3.
pub trait Application {
    /// The hand-over to the SYNC0 task.
    type Stage: CycleStage;
    /// The image's sync figures.
    type Figures: Figures;
    /// A buffer as long as the longest output image ([`Application::output_buffer`]).
    type OutputBuffer: AsMut<[u8]>;

    /// A zeroed [`Self::OutputBuffer`]: the slave application keeps two, for the
    /// confirming reads of the outputs.
    fn output_buffer() -> Self::OutputBuffer;

    /// The object dictionary the mailbox serves.
    fn od(&self) -> &'static ObjectDictionary;

    /// The device's error state: 0x1001, 0x1003, the Emergencies.
    fn diagnostics(&mut self) -> &mut Diagnostics;

    /// The slave application's sync mode and cycle monitor, which the application keeps:
    /// their objects (0x1C32, 0x1C33 with [`SyncMonitor::read`] and [`SyncMonitor::write`],
    /// 0x10F1:02 the sync error counter limit; 0x1C32/0x1C33 sub 1 and 2 written in PREOP
    /// only, 0x08000022) are in its dictionary, so its object access serves them to every
    /// fieldbus.
    fn sync(&self) -> &SyncMonitor<Self::Figures>;

    /// [`Self::sync`], to change.
    fn sync_mut(&mut self) -> &mut SyncMonitor<Self::Figures>;

    /// Runs `serve` on the objects as the mailbox's SDO server sees them at `now_ns` (a
    /// product with another fieldbus puts that fieldbus's objects around its own).
    fn with_objects<R>(
        &mut self,
        stage: &Self::Stage,
        now_ns: u64,
        serve: impl FnOnce(&mut dyn ObjectAccess) -> R,
    ) -> R;

    /// After a mailbox service: what the SDO writes of it mean for the outputs (`in_op`:
    /// the ESM is in OP).
    fn after_mailbox(&mut self, in_op: bool, stage: &Self::Stage) -> Effects;

    /// The ESM entered (`true`: SAFEOP or OP) or left the states with process data.
    fn set_running(&mut self, running: bool);

    /// The fault reaction: outputs to their fault values (watchdog, leaving OP, sync
    /// error); the caller asks the output task to apply them.
    fn enter_fault(&mut self, stage: &Self::Stage);

    /// Bytes of the output image the PDO assignment gives now (before [`Self::prepare`]).
    fn output_len(&self) -> usize;

    /// PREOP -> SAFEOP: the PDO configuration checked and the images built, SM2 and SM3
    /// checked against them and against the device description (`expect2`, `expect3`); the
    /// AL status code of a refusal.
    fn prepare(
        &mut self,
        sm2: &SyncManager,
        sm3: &SyncManager,
        expect2: &SyncManagerDesc,
        expect3: &SyncManagerDesc,
    ) -> Result<(), AlStatusCode>;

    /// Whether [`Self::start_sync`] wants the SYNC0 timing in DC mode (two ESC reads at
    /// PREOP -> SAFEOP; left out of the images of applications that do not).
    const WANTS_DC_START: bool = false;

    /// PREOP -> SAFEOP, after [`Self::prepare`]: the sync mode chosen, with the SYNC0
    /// timing in DC mode when [`Self::WANTS_DC_START`] (`None` otherwise); the AL status
    /// code of a configuration the application cannot serve in that mode.
    fn start_sync(&mut self, dc: Option<DcStart>) -> Result<(), AlStatusCode> {
        let _ = dc;
        Ok(())
    }

    /// SAFEOP -> OP: whether the device can run its outputs now, else the AL status code of
    /// the refusal (a gateway whose mandatory nodes do not all run yet: 0x0018, its inputs
    /// are not valid). The default: always.
    #[inline(always)]
    fn check_op(&mut self) -> Result<(), AlStatusCode> {
        Ok(())
    }

    /// In OP, at each background poll: a fault of the device that takes it to SAFEOP with
    /// the error flag and this code (a gateway's mandatory node lost). The default: none.
    #[inline(always)]
    fn op_fault(&mut self) -> Option<AlStatusCode> {
        None
    }

    /// The output image of the configuration in effect (SAFEOP, OP), to read SM2 into.
    fn output_image(&mut self) -> &mut [u8];

    /// The outputs of a cycle are in [`Self::output_image`] (OP): take them.
    fn take_outputs(&mut self, stage: &Self::Stage) -> Effects;

    /// The input image of the cycle for SM3 (the newest inputs published), `None` if none.
    fn input_image(&mut self) -> Option<&[u8]>;

    /// The outputs of an EtherCAT cycle were refused: no two of their reads agreed (the
    /// cycle's outputs are not taken). Not on the usual path.
    #[inline(always)]
    fn on_outputs_refused(&mut self) {}

    /// The outputs of an EtherCAT cycle (SM2 event) were served at `now_ns`. On the SM2
    /// path: keep it short.
    #[inline(always)]
    fn on_output_event(&mut self, now_ns: u64) {
        let _ = now_ns;
    }

    /// The background poll ran at `now_ns`, for the SYNC0 edge captured at `edge_lo` (the
    /// low 32 bits of its time) or, `None`, for no new edge; `stage` is the hand-over to the
    /// SYNC0 task, as it was at that edge.
    #[inline(always)]
    fn on_cycle_polled(&mut self, stage: &Self::Stage, now_ns: u64, edge_lo: Option<u32>) {
        let _ = (stage, now_ns, edge_lo);
    }

    /// An Emergency the slave application sends (already in the error history): for
    /// another fieldbus to send too.
    #[inline(always)]
    fn on_emergency(&mut self, emergency: &Emergency) {
        let _ = emergency;
    }
}
