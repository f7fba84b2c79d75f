//! The values behind the module's object dictionary: the application's
//! [`ObjectAccess`] implementation, with the write rules of the application.
//!
//! Served here (everything else reads as the entry's default from the dictionary, i.e. the
//! product's constants, [`crate::product`]: 0x1000, 0x1008..0x100A, 0x1018, 0x1C00):
//! 0x1001 error register, 0x10F1 error settings, 0x1600../0x1A00../0x1C12/0x1C13 PDO
//! configuration ([`ProcessData`]), 0x1C32/0x1C33 ([`SyncMonitor`]), 0x6401 AI values
//! ([`Sampler`]), 0x6411 AO values, 0x6443/0x6444 fault configuration, and the
//! manufacturer settings object ([`SETTINGS_INDEX`]).
//!
//! Vetoes (the SDO server has already checked existence, access per state, length and the
//! dictionary's min/max): PDO configuration and sync mode/cycle only in PREOP (0x08000022),
//! unsupported sync modes, fault modes, filter modes and fault values outside 0..=0x7FFF
//! (0x06090030).

use super::diagnostics::Diagnostics;
use super::entry_bytes::{channel, put};
use super::outputs::{AnalogOutputs, ErrorMode};
use super::process_data::ProcessData;
use super::sampler::{PublishMode, Sampler};
use super::sync::{le_u16, le_u32, SyncMonitor};
use crate::product::capacity::{AI_CHANNELS, AO_CHANNELS};
use crate::product::od::SETTINGS_INDEX;
use coe_core::od::{ObjectAccess, ObjectDictionary};
use coe_core::{AlState, SdoAbortCode};

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
            ao_written: None,
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
        let (_, entry) = self.od.entry(index, sub)?;
        let len = entry.byte_len();
        let written = entry
            .default()
            .encode(entry.data_type, entry.bit_len, buf)
            .ok_or(SdoAbortCode::OutOfMemory)?;
        if written == 0 && !entry.data_type.is_variable_length() {
            // No default given: zero.
            let out = buf.get_mut(..len).ok_or(SdoAbortCode::OutOfMemory)?;
            out.fill(0);
            return Ok(len);
        }
        Ok(written)
    }
}

impl ObjectAccess for AppData {
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        match (index, sub) {
            (0x1001, 0) => put(buf, &[self.diag.register()]),
            (0x10F1, 0) => put(buf, &[2]),
            (0x10F1, 1) => put(buf, &self.diag.local_error_reaction.to_le_bytes()),
            (0x10F1, 2) => put(buf, &self.sync.error_limit().to_le_bytes()),
            (0x1C32, _) => self.sync.read(false, sub, buf),
            (0x1C33, _) => self.sync.read(true, sub, buf),
            (i, _) if self.pd.owns(i) => self.pd.read(i, sub, buf),
            (0x6401, 0) => put(buf, &[AI_CHANNELS as u8]),
            (0x6401, _) => {
                let i = channel(sub, AI_CHANNELS)?;
                put(buf, &self.sampler.value(i).unwrap_or(0).to_le_bytes())
            }
            (0x6411 | 0x6443 | 0x6444, 0) => put(buf, &[AO_CHANNELS as u8]),
            (0x6411, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let v = self.ao_values().get(i).copied().unwrap_or(0);
                put(buf, &v.to_le_bytes())
            }
            (0x6443, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let m = self.outputs.fault_config().mode.get(i).copied();
                put(buf, &[m.unwrap_or_default().to_u8()])
            }
            (0x6444, _) => {
                let i = channel(sub, AO_CHANNELS)?;
                let v = self.outputs.fault_config().value.get(i).copied();
                put(buf, &v.unwrap_or(0).to_le_bytes())
            }
            (SETTINGS_INDEX, 1) => put(buf, &[self.sampler.mode().setting()]),
            _ => self.read_default(index, sub, buf),
        }
    }

    fn write(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        match (index, sub) {
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
