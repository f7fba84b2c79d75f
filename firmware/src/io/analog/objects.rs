//! The values behind the module's object dictionary: the application's
//! [`ObjectAccess`] implementation, with the write rules of the application.
//!
//! Served here (everything else reads as the entry's default from the dictionary, i.e. the
//! product's constants, [`crate::products::analog_io`]: 0x1000, 0x1008..0x100A, 0x1018, 0x1C00):
//! 0x1001 error register, 0x1003 error history, 0x10F1 error settings,
//! 0x1600../0x1A00../0x1C12/0x1C13 PDO configuration ([`ProcessData`]), 0x1C32/0x1C33
//! ([`SyncMonitor`]), 0x6401 AI values ([`Sampler`]), 0x6411 AO values, 0x6443/0x6444 fault
//! configuration, and the manufacturer settings object ([`SETTINGS_INDEX`]), and for the CAN
//! side the process-data source ([`PROCESS_DATA_SOURCE_INDEX`]) and 0x6423
//! ([`AI_INTERRUPT_ENABLE_INDEX`]).
//!
//! Vetoes (the SDO server has already checked existence, access per state, length and the
//! dictionary's min/max): PDO configuration and sync mode/cycle only in PREOP (0x08000022),
//! and the PDO configuration not while EtherCAT runs process data whichever fieldbus asks;
//! the process-data source only while neither fieldbus runs process data (0x08000022),
//! unsupported sync modes, fault modes, filter modes and fault values outside 0..=0x7FFF
//! (0x06090030), and 0x1003:00 other than 0 (0x06090030, CiA 301).

use super::outputs::{AnalogOutputs, ErrorMode, OutputStage, SetOutcome};
use super::process_data::ProcessData;
use super::sampler::{PublishMode, Sampler};
use crate::products::analog_io::can::{
    AI_INTERRUPT_ENABLE_INDEX, PROCESS_DATA_SOURCE_INDEX, SOURCE_CAN, SOURCE_ETHERCAT,
};
use crate::products::analog_io::capacity::{AI_CHANNELS, AO_CHANNELS};
use crate::products::analog_io::od::SETTINGS_INDEX;
use crate::stacks::diagnostics::{Diagnostics, EMCY_AO_OUT_OF_RANGE, ERR_MANUFACTURER};
use crate::stacks::entry_bytes::{channel, put_le};
use crate::stacks::ethercat::sync::{le_u16, le_u32, SyncMonitor};
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::sdo_server::Emergency;
use coe_core::{AlState, SdoAbortCode};

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

/// Which fieldbus runs process data now (set by the ESM and the CAN node).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Running {
    /// The ESM is in SAFEOP or OP.
    pub ethercat: bool,
    /// The CAN node is operational.
    pub can: bool,
}

/// The application data behind the dictionary.
pub struct AppData {
    od: &'static ObjectDictionary,
    /// AO values and fault configuration.
    pub outputs: AnalogOutputs,
    /// AI samples and published values.
    pub sampler: Sampler,
    /// Sync mode and 0x1C32/0x1C33.
    pub sync: SyncMonitor,
    /// PDO configuration and images.
    pub pd: ProcessData,
    /// Error register and 0x10F1:01.
    pub diag: Diagnostics,
    /// Which fieldbus drives the outputs.
    pub source: OutputSource,
    /// CiA 401 0x6423: event-driven CAN TPDOs go out on a change of the inputs.
    pub ai_events: bool,
    /// Which fieldbus runs process data.
    pub running: Running,
    ao_written: Option<[i16; AO_CHANNELS]>,
}

impl AppData {
    /// Application data for `od` with the PDO configuration `pd`.
    pub fn new(od: &'static ObjectDictionary, pd: ProcessData) -> Self {
        Self {
            od,
            outputs: AnalogOutputs::new(),
            sampler: Sampler::new(PublishMode::Latest),
            sync: SyncMonitor::new(),
            pd,
            diag: Diagnostics::new(),
            source: OutputSource::EtherCat,
            ai_events: false,
            running: Running {
                ethercat: false,
                can: false,
            },
            ao_written: None,
        }
    }

    /// New output values: staged for the DAC when `in_op` ([`AnalogOutputs::set_values`]),
    /// and the Emergency the out-of-range rule asks for: 0xFF01 (data byte 0: the channels)
    /// when a value becomes negative, the error reset when all are back in range.
    pub fn set_outputs(
        &mut self,
        values: [i16; AO_CHANNELS],
        in_op: bool,
        stage: &OutputStage,
    ) -> (SetOutcome, Option<Emergency>) {
        let set = self.outputs.set_values(values, in_op, stage);
        let emergency = if set.newly_out_of_range {
            let mask = values
                .iter()
                .enumerate()
                .fold(0u8, |m, (i, v)| if *v < 0 { m | 1 << i } else { m });
            Some(
                self.diag
                    .raise(ERR_MANUFACTURER, EMCY_AO_OUT_OF_RANGE, [mask, 0, 0, 0, 0]),
            )
        } else if !set.out_of_range {
            self.diag.clear(ERR_MANUFACTURER)
        } else {
            None
        };
        (set, emergency)
    }

    /// The application parameters back to their power-on values (CAN NMT reset node): AO
    /// fault configuration, AI filter, 0x6423 and the process-data source; the PDO
    /// configuration too unless EtherCAT runs process data on it.
    pub fn reset_parameters(&mut self) {
        *self.outputs.fault_config_mut() = *AnalogOutputs::new().fault_config();
        self.sampler.set_mode(PublishMode::Latest);
        self.ai_events = false;
        self.source = OutputSource::EtherCat;
        self.reset_pdo_configuration();
    }

    /// The PDO configuration back to its defaults (CAN NMT reset communication while CAN
    /// drives the outputs), unless EtherCAT runs process data on it.
    pub fn reset_pdo_configuration(&mut self) {
        if !self.running.ethercat {
            self.pd.reset();
        }
    }

    /// The dictionary.
    pub fn od(&self) -> &'static ObjectDictionary {
        self.od
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

impl ObjectAccess for AppData {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        // The application's values as a number and its length in bytes, copied in one place.
        let (value, len): (u32, usize) = match (index, sub) {
            (0x1001, 0) => (self.diag.register().into(), 1),
            (0x1003, 0) => (self.diag.history.len().into(), 1),
            (0x1003, _) => (self.diag.history.get(sub)?, 4),
            (0x10F1, 0) => (2, 1),
            (0x10F1, 1) => (self.diag.local_error_reaction, 4),
            (0x10F1, 2) => (self.sync.error_limit().into(), 2),
            (0x1C32, _) => return self.sync.read(false, sub, buf),
            (0x1C33, _) => return self.sync.read(true, sub, buf),
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
            (PROCESS_DATA_SOURCE_INDEX, 0) => (self.source.value().into(), 1),
            (AI_INTERRUPT_ENABLE_INDEX, 0) => (u32::from(self.ai_events), 1),
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
            // The other fieldbus may be in its configuration state while EtherCAT runs.
            (i, _) if self.pd.owns(i) && self.running.ethercat => Err(SdoAbortCode::DeviceState),
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
            (PROCESS_DATA_SOURCE_INDEX, 0) => {
                let source = match data {
                    [v] => OutputSource::from_value(*v).ok_or(SdoAbortCode::ValueRangeExceeded)?,
                    _ => return Err(SdoAbortCode::LengthMismatch),
                };
                if source != self.source && (self.running.ethercat || self.running.can) {
                    return Err(SdoAbortCode::DeviceState);
                }
                self.source = source;
                Ok(())
            }
            (AI_INTERRUPT_ENABLE_INDEX, 0) => {
                self.ai_events = match data {
                    [0] => false,
                    [1] => true,
                    [_] => return Err(SdoAbortCode::ValueRangeExceeded),
                    _ => return Err(SdoAbortCode::LengthMismatch),
                };
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
