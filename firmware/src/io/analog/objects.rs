//! The analog I/O as an application: the values behind the CiA 401 objects, the process
//! data and the write rules ([`AnalogIo`], the [`ObjectAccess`] of the analog products),
//! and what the EtherCAT slave application asks of it ([`Application`]).
//!
//! Served here (everything else reads as the entry's default from the dictionary, i.e. the
//! product's constants, `crate::products`: 0x1000, 0x1008..0x100A, 0x1018, 0x1C00):
//! 0x1001 error register, 0x1003 error history, 0x10F1:01 local error reaction,
//! 0x1600../0x1A00../0x1C12/0x1C13 PDO configuration ([`ProcessData`]), 0x6401 AI values
//! ([`Sampler`]), 0x6411 AO values, 0x6443/0x6444 fault configuration, and the manufacturer
//! settings object ([`SETTINGS_INDEX`]), and the slave application's sync objects from the
//! sync monitor kept here (0x1C32, 0x1C33, 0x10F1:02, [`SyncMonitor`]); a product with
//! another fieldbus adds that fieldbus's objects around these.
//!
//! Vetoes (the SDO server has already checked existence, access per state, length and the
//! dictionary's min/max): PDO configuration only in PREOP (0x08000022), fault modes,
//! filter modes and fault values outside 0..=0x7FFF (0x06090030), and 0x1003:00 other than
//! 0 (0x06090030, CiA 301).

use super::adc_dma::RING_WORDS;
#[cfg(any(feature = "analog-io", not(target_os = "none")))]
use super::output_blocks::{self, Grid, MAX_UPDATES};
#[cfg(any(feature = "analog-io", not(target_os = "none")))]
use super::outputs::DacPair;
use super::outputs::{AnalogOutputs, ErrorMode, OutputStage};
use super::oversampling::{self, Stream};
use super::process_data::{ProcessData, SlotValues, MAX_OUTPUT_IMAGE};
use super::sampler::{PublishMode, Sampler};
use super::settings::SETTINGS_INDEX;
use crate::platform::board::{AI_CHANNELS, AO_CHANNELS};
use crate::stacks::diagnostics::{Diagnostics, EMCY_AO_OUT_OF_RANGE, ERR_MANUFACTURER};
use crate::stacks::entry_bytes::{channel, put_le};
use crate::stacks::ethercat::sync::{le_u16, le_u32, Figures, SyncMonitor, SyncObject};
use crate::stacks::ethercat::{Application, DcStart, Effects};
use coe_core::device::SyncManagerDesc;
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::{AlState, AlStatusCode, SdoAbortCode};
use core::sync::atomic::AtomicU16;
use et1100::SyncManager;

/// The analog I/O behind the dictionary, in an image with the sync figures `F`.
pub struct AnalogIo<F> {
    od: &'static ObjectDictionary,
    /// AO values and fault configuration.
    pub outputs: AnalogOutputs,
    /// AI samples and published values.
    pub sampler: Sampler,
    /// PDO configuration and images.
    pub pd: ProcessData,
    /// Error register, error history and 0x10F1:01.
    pub diag: Diagnostics,
    /// The slave application's sync mode, 0x1C32/0x1C33 and cycle monitor.
    pub sync: SyncMonitor<F>,
    /// The input oversampling blocks.
    pub stream: Stream,
    /// Output oversampling: the LDAC grid admitted at PREOP -> SAFEOP (only in a build with
    /// it, so the others keep their layout).
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    block_grid: Grid,
    /// Output oversampling: the last update block's counter (0x7010:01, `None`: none since
    /// PREOP -> SAFEOP or no 0x1610 assigned).
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    block_counter: Option<u16>,
    ao_written: Option<[i16; AO_CHANNELS]>,
}

impl<F: Figures> AnalogIo<F> {
    /// The analog I/O on dictionary `od` with the PDO configuration `pd`.
    pub fn new(od: &'static ObjectDictionary, pd: ProcessData) -> Self {
        Self {
            od,
            outputs: AnalogOutputs::new(),
            sampler: Sampler::new(PublishMode::Latest),
            pd,
            diag: Diagnostics::new(),
            sync: SyncMonitor::new(),
            stream: Stream::new(),
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            block_grid: Grid::OFF,
            #[cfg(any(feature = "analog-io", not(target_os = "none")))]
            block_counter: None,
            ao_written: None,
        }
    }

    /// The ADC's DMA ring and how many words its DMA has written so far (the RTIC
    /// application, before each PDI activation's work).
    pub fn on_adc_ring(&mut self, ring: &'static [AtomicU16; RING_WORDS], written: u32) {
        self.stream.set_ring(ring, written);
    }

    /// Adds samples directly (harnesses without a ring).
    pub fn on_samples(&mut self, samples: &[super::sampler::Sample]) {
        self.sampler.add_all(samples);
    }

    /// New output values: staged for the DAC when `in_op` ([`AnalogOutputs::set_values`]),
    /// and what the output task must do added to `effects`: the apply request when staged,
    /// and the Emergency the out-of-range rule asks for: 0xFF01 (data byte 0: the channels)
    /// when a value becomes negative, the error reset when all are back in range. (The
    /// Emergency is written only when there is one: the process-data path calls this every
    /// cycle. Out of line in the CAN product's image, where several callers share it and
    /// flash is short.)
    pub fn stage_outputs(
        &mut self,
        values: [i16; AO_CHANNELS],
        in_op: bool,
        stage: &OutputStage,
        effects: &mut Effects,
    ) {
        let set = self.outputs.set_values(values, in_op, stage);
        effects.apply_outputs |= set.staged;
        if set.newly_out_of_range {
            let mask = values
                .iter()
                .enumerate()
                .fold(0u8, |m, (i, v)| if *v < 0 { m | 1 << i } else { m });
            effects.emergency = Some(self.diag.raise(
                ERR_MANUFACTURER,
                EMCY_AO_OUT_OF_RANGE,
                [mask, 0, 0, 0, 0],
            ));
        } else if !set.out_of_range {
            if let Some(e) = self.diag.clear(ERR_MANUFACTURER) {
                effects.emergency = Some(e);
            }
        }
    }

    /// The application parameters back to their power-on values (a reset of the
    /// application, e.g. CAN NMT reset node): AO fault configuration and AI filter.
    pub fn reset_parameters(&mut self) {
        *self.outputs.fault_config_mut() = *AnalogOutputs::new().fault_config();
        self.sampler.set_mode(PublishMode::Latest);
    }

    /// The dictionary.
    pub fn od(&self) -> &'static ObjectDictionary {
        self.od
    }

    /// Output oversampling: the block of the output image to the update interrupt, for the
    /// next SYNC0 edge (the grid starts with the first block). Out of line: the plain path
    /// of `take_outputs` stays as it was.
    #[inline(never)]
    #[cfg(any(feature = "analog-io", not(target_os = "none")))]
    fn publish_block(&mut self, stage: &OutputStage) {
        if stage.block_grid() != self.block_grid {
            stage.set_block_grid(self.block_grid);
        }
        let next = stage.sync0_counts().edges.wrapping_add(1);
        // A second frame before the same edge: its block is dropped (the first one plays).
        if stage.blocks.has_block_for(next) {
            return;
        }
        // A block counter equal to the last block's, for a new edge, is the same block sent
        // again (the master's task did not run): refused, the outputs hold rather than
        // repeat it.
        if let Some(counter) = self.pd.output_block_counter() {
            if self.block_counter.replace(counter) == Some(counter) {
                self.stream.on_output_refused();
                return;
            }
        }
        let mut pairs = [DacPair::default(); MAX_UPDATES];
        let n = output_blocks::decode(self.pd.output_updates(), &mut pairs);
        if let (Some(block), Some(last)) = (pairs.get(..n), n.checked_sub(1)) {
            stage.blocks.publish(block, next);
            if let Some(p) = pairs.get(last) {
                self.outputs.set_block_values(*p);
            }
        }
    }

    /// AO values written by SDO since the last call (to be staged by the caller).
    pub fn take_ao_written(&mut self) -> Option<[i16; AO_CHANNELS]> {
        self.ao_written.take()
    }

    fn ao_values(&self) -> [i16; AO_CHANNELS] {
        self.ao_written.unwrap_or(self.outputs.values())
    }

    fn read_default(&self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        let (object, entry) = self.od.entry(index, sub)?;
        let entry = object.resolve(entry);
        let len = entry.byte_len();
        let written = entry
            .default()
            .encode(entry.data_type(), entry.bit_len, buf)
            .ok_or(SdoAbortCode::OutOfMemory)?;
        if written == 0 && !entry.data_type().is_variable_length() {
            // No default given: zero.
            let out = buf.get_mut(..len).ok_or(SdoAbortCode::OutOfMemory)?;
            out.fill(0);
            return Ok(len);
        }
        Ok(written)
    }
}

/// An INTEGER16 as the low half of [`put_le`]'s value.
fn int16(v: i16) -> u32 {
    u32::from(v as u16)
}

impl<F: Figures> ObjectAccess for AnalogIo<F> {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        // The application's values as a number and its length in bytes, copied in one place.
        let (value, len): (u32, usize) = match (index, sub) {
            (0x1001, 0) => (self.diag.register().into(), 1),
            (0x1003, 0) => (self.diag.history.len().into(), 1),
            (0x1003, _) => (self.diag.history.get(sub)?, 4),
            (0x10F1, 0) => (2, 1),
            (0x10F1, 1) => (self.diag.local_error_reaction, 4),
            (0x10F1, 2) => (self.sync.error_limit().into(), 2),
            (0x1C32, _) => return self.sync.read(SyncObject::Outputs, sub, buf),
            // Calc and copy: the assigned image's, the oversampling blocks' SM3 write too.
            (0x1C33, _) => {
                let image_bytes = self.pd.input_len();
                return self.sync.read(SyncObject::Inputs { image_bytes }, sub, buf);
            }
            (i, _) if self.pd.owns(i) => return self.pd.read(i, sub, buf),
            (0x6401, 0) => (AI_CHANNELS as u32, 1),
            (0x6401, _) => {
                let i = channel(sub, AI_CHANNELS)?;
                (int16(self.sampler.value(i).unwrap_or(0)), 2)
            }
            (0x6411 | 0x6443 | 0x6444, 0) => (AO_CHANNELS as u32, 1),
            (0x6411, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                (int16(self.ao_values().get(i).copied().unwrap_or(0)), 2)
            }
            (0x6443, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let m = self.outputs.fault_config().mode.get(i).copied();
                (m.unwrap_or_default().to_u8().into(), 1)
            }
            (0x6444, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let v = self.outputs.fault_config().value.get(i).copied();
                (v.unwrap_or(0) as u32, 4)
            }
            (SETTINGS_INDEX, 1) => (self.sampler.mode().setting().into(), 1),
            (oversampling::SETTINGS_INDEX, 3) if oversampling::BUILT => {
                (self.pd.assigned_slots() as u32, 2)
            }
            _ => return self.read_default(index, sub, buf),
        };
        put_le(buf, value, len)
    }

    fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        match (index, sub) {
            (0x1003, _) => self.diag.history.write(sub, data),
            (0x10F1, 1) => {
                self.diag.local_error_reaction = le_u32(data)?;
                Ok(())
            }
            (0x10F1, 2) => {
                self.sync.set_error_limit(le_u16(data)?);
                Ok(())
            }
            (0x1C32 | 0x1C33, 1 | 2) if state != AlState::PreOp => Err(SdoAbortCode::DeviceState),
            (0x1C32, _) => self.sync.write(false, sub, data),
            (0x1C33, _) => self.sync.write(true, sub, data),
            (i, _) if self.pd.owns(i) => self.pd.write(i, sub, data, state, self.od),
            (0x6411, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let v = i16::from_le_bytes(match data {
                    [a, b] => [*a, *b],
                    _ => return Err(SdoAbortCode::LengthMismatch),
                });
                let mut values = self.ao_values();
                if let Some(slot) = values.get_mut(i) {
                    *slot = v;
                }
                self.ao_written = Some(values);
                Ok(())
            }
            (0x6443, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let mode = match data {
                    [m] => ErrorMode::from_u8(*m).ok_or(SdoAbortCode::ValueRangeExceeded)?,
                    _ => return Err(SdoAbortCode::LengthMismatch),
                };
                if let Some(slot) = self.outputs.fault_config_mut().mode.get_mut(i) {
                    *slot = mode;
                }
                Ok(())
            }
            (0x6444, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let v = le_u32(data)? as i32;
                if !(0..=i32::from(i16::MAX)).contains(&v) {
                    return Err(SdoAbortCode::ValueRangeExceeded);
                }
                if let Some(slot) = self.outputs.fault_config_mut().value.get_mut(i) {
                    *slot = v;
                }
                Ok(())
            }
            (SETTINGS_INDEX, 1) => {
                let mode = match data {
                    [m] => PublishMode::from_setting(*m).ok_or(SdoAbortCode::ValueRangeExceeded)?,
                    _ => return Err(SdoAbortCode::LengthMismatch),
                };
                self.sampler.set_mode(mode);
                Ok(())
            }
            _ => {
                self.od.entry(index, sub)?;
                Err(SdoAbortCode::CannotStore)
            }
        }
    }

    fn is_rx_mapped(&self, index: u16, subindex: u8) -> bool {
        self.pd.is_rx_mapped(index, subindex)
    }
}

impl<F: Figures> Application for AnalogIo<F> {
    type Stage = OutputStage;
    type Figures = F;
    type OutputBuffer = [u8; MAX_OUTPUT_IMAGE];

    fn output_buffer() -> [u8; MAX_OUTPUT_IMAGE] {
        [0; MAX_OUTPUT_IMAGE]
    }

    fn od(&self) -> &'static ObjectDictionary {
        self.od
    }

    fn diagnostics(&mut self) -> &mut Diagnostics {
        &mut self.diag
    }

    fn sync(&self) -> &SyncMonitor<F> {
        &self.sync
    }

    fn sync_mut(&mut self) -> &mut SyncMonitor<F> {
        &mut self.sync
    }

    fn with_objects<R>(
        &mut self,
        _: &OutputStage,
        _: u64,
        serve: impl FnOnce(&mut dyn ObjectAccess) -> R,
    ) -> R {
        serve(self)
    }

    /// SDO-written outputs take effect in OP.
    fn after_mailbox(&mut self, in_op: bool, stage: &OutputStage) -> Effects {
        let mut effects = Effects::default();
        if let Some(values) = self.take_ao_written() {
            self.stage_outputs(values, in_op, stage, &mut effects);
        }
        effects
    }

    fn set_running(&mut self, _: bool) {}

    fn enter_fault(&mut self, stage: &OutputStage) {
        self.outputs.enter_fault(stage);
    }

    fn output_len(&self) -> usize {
        self.pd.output_len()
    }

    fn prepare(
        &mut self,
        sm2: &SyncManager,
        sm3: &SyncManager,
        expect2: &SyncManagerDesc,
        expect3: &SyncManagerDesc,
    ) -> Result<(), AlStatusCode> {
        self.pd.prepare(self.od, sm2, sm3, expect2, expect3)?;
        if oversampling::BUILT {
            self.stream.restart(*self.pd.input_blocks());
        }
        Ok(())
    }

    const WANTS_DC_START: bool = oversampling::BUILT;

    /// Oversampling needs DC SYNC0 and a configuration that fits its cycle
    /// ([`oversampling::admit`]); the stream's DC times come from `dc`.
    fn start_sync(&mut self, dc: Option<DcStart>) -> Result<(), AlStatusCode> {
        if !oversampling::BUILT {
            return Ok(());
        }
        let blocks = *self.pd.input_blocks();
        let cycle = dc.map(|d| d.cycle_ns);
        let (inputs, outputs) = (self.pd.input_len(), self.pd.output_len());
        oversampling::admit(&blocks, inputs, outputs, cycle)?;
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        {
            let updates = *self.pd.output_blocks_in_effect();
            self.block_grid =
                output_blocks::admit(&updates, inputs, outputs, cycle)?.unwrap_or(Grid::OFF);
            self.block_counter = None;
        }
        if let Some(d) = dc {
            self.stream
                .set_dc_reference(d.cycle_ns, d.next_sync0_dc, d.previous_edge_lo);
        }
        Ok(())
    }

    fn on_outputs_refused(&mut self) {
        self.stream.on_output_refused();
    }

    fn on_cycle_polled(&mut self, stage: &OutputStage, now_ns: u64, edge_lo: Option<u32>) {
        if let Some(lo) = edge_lo.filter(|_| oversampling::BUILT) {
            self.stream.on_edge(now_ns, lo, stage.output_holds());
        }
    }

    fn output_image(&mut self) -> &mut [u8] {
        self.pd.output_image_mut()
    }

    // One caller, on the SM2 path of every cycle.
    #[inline(always)]
    fn take_outputs(&mut self, stage: &OutputStage) -> Effects {
        #[cfg(any(feature = "analog-io", not(target_os = "none")))]
        if self.block_grid != Grid::OFF {
            self.publish_block(stage);
            return Effects::default();
        }
        match self.pd.unpack_ao(self.outputs.values(), AlState::Op) {
            Ok(ao) => {
                let mut effects = Effects::default();
                self.stage_outputs(ao, true, stage, &mut effects);
                effects.apply_outputs = true;
                effects
            }
            Err(_) => Effects::default(),
        }
    }

    fn input_image(&mut self) -> Option<&[u8]> {
        if oversampling::BUILT {
            self.stream.write(self.pd.input_blocks_image_mut());
        }
        self.sampler.publish();
        let ao = self.outputs.values();
        let values = SlotValues {
            ai_codes: self.sampler.codes(),
            ao: &ao,
            error_register: self.diag.register(),
        };
        self.pd.pack_values(&values).ok()
    }
}

/// An application built on the analog I/O (the analog products'): the RTIC application
/// drains the samples into it.
pub trait AnalogApplication {
    /// The image's sync figures.
    type Figures: Figures;
    /// The analog I/O.
    fn analog(&mut self) -> &mut AnalogIo<Self::Figures>;
}

impl<F: Figures> AnalogApplication for AnalogIo<F> {
    type Figures = F;
    fn analog(&mut self) -> &mut AnalogIo<F> {
        self
    }
}
