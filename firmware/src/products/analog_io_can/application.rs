//! The analog I/O on two fieldbuses: the application the EtherCAT slave application serves
//! ([`AnalogCan`]: the analog I/O, the CANopen node and which fieldbus drives the outputs),
//! and the view the node works on ([`CanView`]). The stacks stay apart: the slave
//! application learns nothing of CAN, the node nothing of EtherCAT; this module wires them.
//!
//! - The dictionary is one: the node serves its communication objects on the EtherCAT
//!   mailbox too, and CAN's SDO server sees the slave application's sync objects (which
//!   the analog I/O keeps).
//! - The slave application's Emergencies go out on CAN too; an application Emergency raised
//!   by a CAN call goes out on both (`AnalogCan::can_call`).
//! - [`PROCESS_DATA_SOURCE_INDEX`] decides which fieldbus drives the outputs
//!   (`super::can`): EtherCAT reaches SAFEOP with RxPDOs only while it is the source, SDO
//!   writes of 0x6411 drive the outputs only from the source, RPDOs only while CAN is; the
//!   PDO configuration, which both share, changes only while EtherCAT runs no process data.
//! - The EtherCAT cycle reaches the node's window ([`crate::stacks::canopen::window`]).

use super::can::{
    AI_INTERRUPT_ENABLE_INDEX, CAN_EMERGENCY_QUEUE, COMM_DEFAULTS, DEFAULT_NODE_ID,
    HEARTBEAT_CONSUMERS, PROCESS_DATA_SOURCE_INDEX, SOURCE_CAN, SOURCE_ETHERCAT,
};
use crate::io::analog::outputs::OutputStage;
use crate::io::analog::process_data::{MAX_IMAGE, RX_PDOS, TX_PDOS};
use crate::io::analog::{AnalogApplication, AnalogIo};
use crate::products::analog_io::sync::AnalogFigures;
use crate::stacks::canopen::task::CanHost;
use crate::stacks::canopen::window::CallKind;
use crate::stacks::canopen::CanSide;
use crate::stacks::diagnostics::Diagnostics;
use crate::stacks::ethercat::mailbox::TRANSFER_BUFFER;
use crate::stacks::ethercat::sync::SyncMonitor;
use crate::stacks::ethercat::{Application, Effects, SlaveApp};
use coe_core::canopen::node::CanApplication;
use coe_core::canopen::{CanFrame, NmtState};
use coe_core::device::SyncManagerDesc;
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::sdo_server::Emergency;
use coe_core::{AlState, AlStatusCode, SdoAbortCode};
use et1100::SyncManager;

/// The analog I/O with `analog-io`'s sync figures.
pub type Analog = AnalogIo<AnalogFigures>;

/// The module's CANopen node and its window.
pub type Node =
    CanSide<RX_PDOS, TX_PDOS, HEARTBEAT_CONSUMERS, CAN_EMERGENCY_QUEUE, TRANSFER_BUFFER>;

/// Which fieldbus drives the outputs ([`PROCESS_DATA_SOURCE_INDEX`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutputSource {
    /// EtherCAT (SM2), the default.
    #[default]
    EtherCat,
    /// CAN (RPDOs).
    Can,
}

impl OutputSource {
    /// The object's value.
    pub const fn value(self) -> u8 {
        match self {
            Self::EtherCat => SOURCE_ETHERCAT,
            Self::Can => SOURCE_CAN,
        }
    }

    /// The source a value names.
    pub const fn from_value(value: u8) -> Option<Self> {
        match value {
            SOURCE_ETHERCAT => Some(Self::EtherCat),
            SOURCE_CAN => Some(Self::Can),
            _ => None,
        }
    }
}

/// Which fieldbus runs process data now (set by the ESM and the node's NMT state).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Running {
    /// The ESM is in SAFEOP or OP.
    pub ethercat: bool,
    /// The CAN node is operational.
    pub can: bool,
}

/// What the two fieldbuses share beyond the analog I/O: who drives the outputs, who runs,
/// and 0x6423.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Arbitration {
    /// Which fieldbus drives the outputs.
    pub source: OutputSource,
    /// Which fieldbus runs process data.
    pub running: Running,
    /// CiA 401 0x6423: event-driven TPDOs go out on a change of the inputs.
    pub ai_events: bool,
}

/// The application of `analog-io-can`.
pub struct AnalogCan {
    /// The analog I/O.
    pub analog: Analog,
    /// The CANopen node.
    pub can: Node,
    /// Which fieldbus drives the outputs.
    pub arbitration: Arbitration,
    /// What calls of the node from the EtherCAT mailbox asked of the outputs, until the
    /// slave application collects it ([`Application::after_mailbox`]).
    pending: Effects,
}

impl AnalogCan {
    /// The analog I/O with the node `node_id` on it; EtherCAT cycles of at least
    /// `min_cycle_ns`.
    pub fn new(analog: Analog, node_id: u8, min_cycle_ns: u32) -> Self {
        let od = analog.od();
        Self {
            analog,
            can: Node::new(node_id, od, &COMM_DEFAULTS, min_cycle_ns),
            arbitration: Arbitration::default(),
            pending: Effects::default(),
        }
    }

    /// The node-ID unless configured.
    pub const DEFAULT_NODE_ID: u8 = DEFAULT_NODE_ID;

    /// One call of the node (a received `frame`, else a PDO step or the timers), and what
    /// it asks of the outputs into `effects`. (Out of line: the node's work inlined into
    /// the CAN task's handler made the image larger.)
    #[inline(never)]
    fn can_call(
        &mut self,
        frame: Option<&CanFrame>,
        stage: &OutputStage,
        now_ns: u64,
        effects: &mut Effects,
    ) {
        if !self.arbitration.running.ethercat {
            // Without EtherCAT cycles the CAN side ends the sampling cycle (TPDOs and SDO
            // reads see the newest inputs); with them it reads what their cycle published.
            self.analog.sampler.publish();
        }
        let mut view = CanView {
            analog: &mut self.analog,
            arbitration: &mut self.arbitration,
            stage,
            effects,
        };
        self.can.call(frame, &mut view, now_ns);
        let operational = self.can.node().state() == NmtState::Operational;
        self.arbitration.running.can = operational;
        // SDO-written outputs take effect if CAN drives the outputs and is operational.
        if let Some(values) = self.analog.take_ao_written() {
            let owner = self.arbitration.source == OutputSource::Can;
            self.analog
                .stage_outputs(values, owner && operational, stage, effects);
        }
    }
}

impl AnalogApplication for AnalogCan {
    type Figures = AnalogFigures;
    fn analog(&mut self) -> &mut Analog {
        &mut self.analog
    }
}

impl Application for AnalogCan {
    type Stage = OutputStage;
    type Figures = AnalogFigures;
    type OutputBuffer = [u8; MAX_IMAGE];

    fn output_buffer() -> [u8; MAX_IMAGE] {
        [0; MAX_IMAGE]
    }

    fn od(&self) -> &'static ObjectDictionary {
        self.analog.od()
    }

    fn diagnostics(&mut self) -> &mut Diagnostics {
        &mut self.analog.diag
    }

    fn sync(&self) -> &SyncMonitor<AnalogFigures> {
        &self.analog.sync
    }

    fn sync_mut(&mut self) -> &mut SyncMonitor<AnalogFigures> {
        &mut self.analog.sync
    }

    /// The node's communication objects around the application's.
    fn with_objects<R>(
        &mut self,
        stage: &OutputStage,
        now_ns: u64,
        serve: impl FnOnce(&mut dyn ObjectAccess) -> R,
    ) -> R {
        let mut view = CanView {
            analog: &mut self.analog,
            arbitration: &mut self.arbitration,
            stage,
            effects: &mut self.pending,
        };
        serve(&mut self.can.access(&mut view, now_ns))
    }

    /// SDO-written outputs take effect if EtherCAT drives the outputs and is in OP.
    fn after_mailbox(&mut self, in_op: bool, stage: &OutputStage) -> Effects {
        let mut effects = core::mem::take(&mut self.pending);
        if let Some(values) = self.analog.take_ao_written() {
            let owner = self.arbitration.source == OutputSource::EtherCat;
            self.analog
                .stage_outputs(values, owner && in_op, stage, &mut effects);
        }
        effects
    }

    fn set_running(&mut self, running: bool) {
        self.arbitration.running.ethercat = running;
    }

    fn enter_fault(&mut self, stage: &OutputStage) {
        self.analog.enter_fault(stage);
    }

    fn output_len(&self) -> usize {
        self.analog.output_len()
    }

    /// CAN driving the outputs leaves EtherCAT the inputs only (`super::can`).
    fn prepare(
        &mut self,
        sm2: &SyncManager,
        sm3: &SyncManager,
        expect2: &SyncManagerDesc,
        expect3: &SyncManagerDesc,
    ) -> Result<(), AlStatusCode> {
        if self.arbitration.source == OutputSource::Can && self.analog.output_len() > 0 {
            return Err(AlStatusCode::InvalidOutputConfiguration);
        }
        self.analog.prepare(sm2, sm3, expect2, expect3)
    }

    fn output_image(&mut self) -> &mut [u8] {
        self.analog.output_image()
    }

    /// Out of line: a smaller PDI handler is what lets this image fit its budget, for one
    /// call more on the outputs' path.
    #[inline(never)]
    fn take_outputs(&mut self, stage: &OutputStage) -> Effects {
        self.analog.take_outputs(stage)
    }

    fn input_image(&mut self) -> Option<&[u8]> {
        self.analog.input_image()
    }

    #[inline(always)]
    fn on_output_event(&mut self, now_ns: u64) {
        self.can.on_output_event(now_ns);
    }

    fn on_cycle_polled(&mut self, _: &Self::Stage, now_ns: u64, edge_lo: Option<u32>) {
        self.can.on_cycle_polled(now_ns, edge_lo);
    }

    fn on_emergency(&mut self, emergency: &Emergency) {
        self.can.queue_emergency(*emergency);
    }
}

/// The CAN task's host: the slave application with this application, so an application
/// Emergency a CAN call raises goes out on the EtherCAT mailbox too.
impl CanHost for SlaveApp<AnalogCan> {
    type Stage = OutputStage;

    fn call_kind(&self, frame: Option<&CanFrame>) -> CallKind {
        self.application().can.call_kind(frame)
    }

    fn has_steps(&self) -> bool {
        self.application().can.has_steps()
    }

    fn admit(&mut self, kind: CallKind, now_ns: u64) -> bool {
        self.application_mut().can.admit(kind, now_ns)
    }

    fn call(&mut self, frame: Option<&CanFrame>, stage: &OutputStage, now_ns: u64) -> bool {
        let mut effects = Effects::default();
        self.application_mut()
            .can_call(frame, stage, now_ns, &mut effects);
        if let Some(e) = effects.emergency {
            self.emergency(e);
        }
        effects.apply_outputs
    }

    fn peek_tx(&self) -> Option<CanFrame> {
        self.application().can.peek_tx()
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        self.application_mut().can.pop_tx()
    }
}

/// The application as the CANopen node sees it for one call: the analog I/O, the
/// arbitration, the output stage, and what the call asks of the outputs.
pub struct CanView<'a> {
    /// The analog I/O.
    pub analog: &'a mut Analog,
    /// Who drives the outputs.
    pub arbitration: &'a mut Arbitration,
    /// The DAC hand-over.
    pub stage: &'a OutputStage,
    /// The output task's work and an application Emergency raised during the call.
    pub effects: &'a mut Effects,
}

impl CanView<'_> {
    /// The PDO configuration back to its defaults, unless EtherCAT runs process data on it.
    fn reset_pdo_configuration(&mut self) {
        if !self.arbitration.running.ethercat {
            self.analog.pd.reset();
        }
    }
}

impl ObjectAccess for CanView<'_> {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        let value = match (index, sub) {
            (PROCESS_DATA_SOURCE_INDEX, 0) => self.arbitration.source.value(),
            (AI_INTERRUPT_ENABLE_INDEX, 0) => u8::from(self.arbitration.ai_events),
            _ => return self.analog.read(index, sub, buf),
        };
        let out = buf.first_mut().ok_or(SdoAbortCode::OutOfMemory)?;
        *out = value;
        Ok(1)
    }

    fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        let a = &mut *self.arbitration;
        match (index, sub) {
            (PROCESS_DATA_SOURCE_INDEX, 0) => {
                let source = match data {
                    [v] => OutputSource::from_value(*v).ok_or(SdoAbortCode::ValueRangeExceeded)?,
                    _ => return Err(SdoAbortCode::LengthMismatch),
                };
                if source != a.source && (a.running.ethercat || a.running.can) {
                    return Err(SdoAbortCode::DeviceState);
                }
                a.source = source;
                Ok(())
            }
            (AI_INTERRUPT_ENABLE_INDEX, 0) => {
                a.ai_events = match data {
                    [0] => false,
                    [1] => true,
                    [_] => return Err(SdoAbortCode::ValueRangeExceeded),
                    _ => return Err(SdoAbortCode::LengthMismatch),
                };
                Ok(())
            }
            // The other fieldbus may be in its configuration state while EtherCAT runs.
            (i, _) if self.analog.pd.owns(i) && a.running.ethercat => {
                Err(SdoAbortCode::DeviceState)
            }
            _ => self.analog.write(index, sub, data, state),
        }
    }

    fn is_rx_mapped(&self, index: u16, subindex: u8) -> bool {
        self.analog.is_rx_mapped(index, subindex)
    }
}

impl CanApplication for CanView<'_> {
    fn can_owns_outputs(&self) -> bool {
        self.arbitration.source == OutputSource::Can
    }

    fn apply_outputs(&mut self) {
        if let Some(values) = self.analog.take_ao_written() {
            self.analog
                .stage_outputs(values, true, self.stage, self.effects);
        }
    }

    fn outputs_fault(&mut self) {
        self.analog.enter_fault(self.stage);
        self.effects.apply_outputs = true;
    }

    fn change_of_state(&self) -> bool {
        self.arbitration.ai_events
    }

    // The node sends its own errors on CAN only; they enter the error history here.
    fn raise_error(&mut self, bits: u8, code: u16, data: [u8; 5]) -> Emergency {
        let e = self.analog.diag.raise(bits, code, data);
        self.analog.diag.history.record(&e);
        e
    }

    fn clear_error(&mut self, bits: u8) -> Option<Emergency> {
        self.analog.diag.clear(bits)
    }

    /// NMT reset node: the application parameters (AO fault configuration, AI filter,
    /// 0x6423, the output source) and the PDO configuration; reset communication while CAN
    /// drives the outputs: the PDO configuration. The PDO configuration stays while
    /// EtherCAT runs process data on it.
    fn reset(&mut self, application: bool) {
        if application {
            self.analog.reset_parameters();
            self.arbitration.ai_events = false;
            self.arbitration.source = OutputSource::EtherCat;
            self.reset_pdo_configuration();
        } else if self.can_owns_outputs() {
            self.reset_pdo_configuration();
        }
    }
}
