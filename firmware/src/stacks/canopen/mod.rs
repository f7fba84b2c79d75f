//! The CAN side of the application: coe-core's CANopen node ([`Node`]) on the module's
//! dictionary, and how the application answers it ([`CanView`]).
//!
//! [`super::SlaveApp`] owns the node: the EtherCAT mailbox serves the CAN communication
//! objects through it (one dictionary for both fieldbuses), EtherCAT-side Emergencies go
//! out on CAN too, and the process-data source decides which fieldbus drives the outputs
//! ([`crate::products::analog_io::can`]). The CAN task only moves frames between the controller and
//! [`super::SlaveApp::on_can_frame`] / [`super::SlaveApp::poll_can`] /
//! [`super::SlaveApp::can_tx`] ([`super::can_task`]).

pub mod task;
pub mod window;

use crate::io::analog::objects::{AppData, OutputSource};
use crate::io::analog::outputs::OutputStage;
use crate::products::analog_io::can::{CAN_EMERGENCY_QUEUE, HEARTBEAT_CONSUMERS};
use crate::products::analog_io::capacity::{AO_CHANNELS, RX_PDOS, TRANSFER_BUFFER, TX_PDOS};
use coe_core::canopen::node::{CanApplication, CanNode};
use coe_core::od::ObjectAccess;
use coe_core::sdo_server::Emergency;
use coe_core::{AlState, SdoAbortCode};

/// The module's CANopen node.
pub type Node =
    CanNode<RX_PDOS, TX_PDOS, HEARTBEAT_CONSUMERS, CAN_EMERGENCY_QUEUE, TRANSFER_BUFFER>;

/// The application as the CAN node (and, through the node, the mailbox) sees it for one
/// call: the data, the output stage, whether the DAC task must apply the staged outputs,
/// and an Emergency of the application to send on both fieldbuses afterwards.
pub struct CanView<'a> {
    /// The application data.
    pub data: &'a mut AppData,
    /// The DAC hand-over.
    pub stage: &'a OutputStage,
    /// Set when the DAC task must apply the staged outputs now.
    pub apply_outputs: &'a mut bool,
    /// An application Emergency raised during the call (an output out of range).
    pub emergency: Option<Emergency>,
}

impl<'a> CanView<'a> {
    /// A view for one call.
    pub fn new(data: &'a mut AppData, stage: &'a OutputStage, apply_outputs: &'a mut bool) -> Self {
        Self {
            data,
            stage,
            apply_outputs,
            emergency: None,
        }
    }

    /// Stages new output values (`in_op`: the fieldbus that sent them runs process data);
    /// the DAC task applies them at once.
    pub fn stage_outputs(&mut self, values: [i16; AO_CHANNELS], in_op: bool) {
        let (set, emergency) = self.data.set_outputs(values, in_op, self.stage);
        *self.apply_outputs |= set.staged;
        if emergency.is_some() {
            self.emergency = emergency;
        }
    }
}

impl ObjectAccess for CanView<'_> {
    fn read(&mut self, index: u16, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        self.data.read(index, subindex, buf)
    }

    fn write(
        &mut self,
        index: u16,
        subindex: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        self.data.write(index, subindex, data, state)
    }

    fn is_rx_mapped(&self, index: u16, subindex: u8) -> bool {
        self.data.is_rx_mapped(index, subindex)
    }
}

impl CanApplication for CanView<'_> {
    fn can_owns_outputs(&self) -> bool {
        self.data.source == OutputSource::Can
    }

    fn apply_outputs(&mut self) {
        if let Some(values) = self.data.take_ao_written() {
            self.stage_outputs(values, true);
        }
    }

    fn outputs_fault(&mut self) {
        self.data.outputs.enter_fault(self.stage);
        *self.apply_outputs = true;
    }

    fn change_of_state(&self) -> bool {
        self.data.ai_events
    }

    // The node sends its own errors on CAN only; they enter the error history here.
    fn raise_error(&mut self, bits: u8, code: u16, data: [u8; 5]) -> Emergency {
        let e = self.data.diag.raise(bits, code, data);
        self.data.diag.history.record(&e);
        e
    }

    fn clear_error(&mut self, bits: u8) -> Option<Emergency> {
        self.data.diag.clear(bits)
    }

    fn reset(&mut self, application: bool) {
        if application {
            self.data.reset_parameters();
        } else if self.can_owns_outputs() {
            self.data.reset_pdo_configuration();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::analog::process_data::ProcessData;
    use crate::products::analog_io::od::OD;
    use crate::stacks::diagnostics::ERR_COMMUNICATION;
    use std::vec;

    fn read(view: &mut CanView, sub: u8) -> Result<vec::Vec<u8>, SdoAbortCode> {
        let mut buf = [0u8; 8];
        let n = view.read(0x1003, sub, &mut buf)?;
        Ok(buf[..n].to_vec())
    }

    /// The node's own Emergencies (heartbeat loss here) enter 0x1003, which both
    /// fieldbuses read and clear through the application data.
    #[test]
    fn node_emergencies_enter_the_error_history() {
        let mut data = AppData::new(&OD, ProcessData::product_default());
        let stage = OutputStage::new();
        let mut apply = false;
        let mut view = CanView::new(&mut data, &stage, &mut apply);
        assert_eq!(read(&mut view, 0), Ok(vec![0]));
        assert_eq!(read(&mut view, 1), Err(SdoAbortCode::NoDataAvailable));
        view.raise_error(ERR_COMMUNICATION, 0x8130, [0x7F, 0, 0, 0, 0]);
        view.raise_error(ERR_COMMUNICATION, 0x8100, [0; 5]);
        assert_eq!(read(&mut view, 0), Ok(vec![2]));
        assert_eq!(
            read(&mut view, 1),
            Ok(0x0011_8100u32.to_le_bytes().to_vec())
        );
        assert_eq!(
            read(&mut view, 2),
            Ok(0x7F11_8130u32.to_le_bytes().to_vec())
        );
        assert_eq!(read(&mut view, 3), Err(SdoAbortCode::NoDataAvailable));
        assert_eq!(
            view.clear_error(ERR_COMMUNICATION).map(|e| e.error_code),
            Some(0)
        );
        assert_eq!(
            read(&mut view, 0),
            Ok(vec![2]),
            "the error reset is not recorded"
        );
        let write =
            |view: &mut CanView, sub, data: &[u8]| view.write(0x1003, sub, data, AlState::Op);
        assert_eq!(
            write(&mut view, 0, &[1]),
            Err(SdoAbortCode::ValueRangeExceeded)
        );
        assert_eq!(read(&mut view, 0), Ok(vec![2]));
        assert_eq!(write(&mut view, 0, &[0]), Ok(()));
        assert_eq!(read(&mut view, 0), Ok(vec![0]));
        assert_eq!(read(&mut view, 1), Err(SdoAbortCode::NoDataAvailable));
    }
}
