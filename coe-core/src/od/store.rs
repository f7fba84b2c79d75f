//! A fixed-size RAM value store for an object dictionary (no allocation).
//!
//! Every entry gets a slot in one byte array, in dictionary order: fixed-size entries take
//! their byte length, strings/OCTET_STRING/DOMAIN a 2-byte length plus their maximum length.
//! Slots start at the entry defaults. Useful for parameters and for tests; process data
//! usually lives in the application's own variables.

use super::{EntryDesc, ObjectAccess, ObjectDictionary};
use crate::abort::SdoAbortCode;
use crate::esm::AlState;

/// Why an [`OdStore`] could not be created.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StoreError {
    /// The buffer is smaller than [`OdStore::required_size`] needs.
    TooSmall {
        /// Bytes needed.
        needed: usize,
    },
}

/// Values of all entries of an [`ObjectDictionary`] in `N` bytes.
#[derive(Debug, Clone)]
pub struct OdStore<const N: usize> {
    od: ObjectDictionary,
    data: [u8; N],
}

const fn slot_len(entry: &EntryDesc) -> usize {
    if entry.data_type().is_variable_length() {
        2 + entry.byte_len()
    } else {
        entry.byte_len()
    }
}

impl<const N: usize> OdStore<N> {
    /// Bytes a store for `od` needs.
    pub const fn required_size(od: &ObjectDictionary) -> usize {
        let mut total = 0;
        let mut objects = od.objects;
        while let [object, rest @ ..] = objects {
            let mut entries = object.entries;
            while let [entry, more @ ..] = entries {
                total += slot_len(entry);
                entries = more;
            }
            objects = rest;
        }
        total
    }

    /// A store with every entry at its default value (zero / empty where none is given).
    pub fn new(od: ObjectDictionary) -> Result<Self, StoreError> {
        let needed = Self::required_size(&od);
        if needed > N {
            return Err(StoreError::TooSmall { needed });
        }
        let mut store = Self { od, data: [0; N] };
        store.reset_to_defaults();
        Ok(store)
    }

    /// The dictionary this store holds values for.
    pub fn dictionary(&self) -> ObjectDictionary {
        self.od
    }

    /// Sets every entry back to its default.
    pub fn reset_to_defaults(&mut self) {
        let mut offset = 0;
        for object in self.od.iter() {
            for entry in object.entries {
                let entry = &object.resolve(entry);
                let len = slot_len(entry);
                if let Some(slot) = self.data.get_mut(offset..offset + len) {
                    slot.fill(0);
                    if entry.data_type().is_variable_length() {
                        let (head, body) = slot.split_at_mut(2);
                        let n = entry
                            .default()
                            .encode(entry.data_type(), entry.bit_len, body)
                            .unwrap_or(0);
                        head.copy_from_slice(&(n as u16).to_le_bytes());
                    } else {
                        let _ = entry
                            .default()
                            .encode(entry.data_type(), entry.bit_len, slot);
                    }
                }
                offset += len;
            }
        }
    }

    fn slot(&self, index: u16, subindex: u8) -> Option<(&'static EntryDesc, usize)> {
        let mut offset = 0;
        for object in self.od.iter() {
            for entry in object.entries {
                if object.index == index && entry.subindex == subindex {
                    return Some((entry, offset));
                }
                offset += slot_len(entry);
            }
        }
        None
    }

    /// The stored value (for strings: the bytes currently held).
    pub fn get(&self, index: u16, subindex: u8) -> Option<&[u8]> {
        let (entry, offset) = self.slot(index, subindex)?;
        if entry.data_type().is_variable_length() {
            let head = self.data.get(offset..offset + 2)?;
            let used = usize::from(u16::from_le_bytes([*head.first()?, *head.get(1)?]));
            self.data
                .get(offset + 2..offset + 2 + used.min(entry.byte_len()))
        } else {
            self.data.get(offset..offset + entry.byte_len())
        }
    }

    /// Stores a value without access or range checks (the application's own writes).
    /// Fixed-size entries need exactly their byte length (0x06070010 otherwise), strings at
    /// most their maximum length (0x06070012).
    pub fn set(&mut self, index: u16, subindex: u8, value: &[u8]) -> Result<(), SdoAbortCode> {
        let (entry, offset) = self
            .slot(index, subindex)
            .ok_or(SdoAbortCode::ObjectDoesNotExist)?;
        let len = entry.byte_len();
        if entry.data_type().is_variable_length() {
            if value.len() > len {
                return Err(SdoAbortCode::LengthTooHigh);
            }
            let slot = self
                .data
                .get_mut(offset..offset + 2 + len)
                .ok_or(SdoAbortCode::GeneralError)?;
            let (head, body) = slot.split_at_mut(2);
            head.copy_from_slice(&(value.len() as u16).to_le_bytes());
            body.fill(0);
            body.get_mut(..value.len())
                .ok_or(SdoAbortCode::GeneralError)?
                .copy_from_slice(value);
        } else {
            if value.len() != len {
                return Err(SdoAbortCode::LengthMismatch);
            }
            self.data
                .get_mut(offset..offset + len)
                .ok_or(SdoAbortCode::GeneralError)?
                .copy_from_slice(value);
        }
        Ok(())
    }
}

impl<const N: usize> ObjectAccess for OdStore<N> {
    fn read(&mut self, index: u16, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        let value = self
            .get(index, subindex)
            .ok_or(SdoAbortCode::ObjectDoesNotExist)?;
        buf.get_mut(..value.len())
            .ok_or(SdoAbortCode::OutOfMemory)?
            .copy_from_slice(value);
        Ok(value.len())
    }

    fn write(
        &mut self,
        index: u16,
        subindex: u8,
        data: &[u8],
        _state: AlState,
    ) -> Result<(), SdoAbortCode> {
        self.set(index, subindex, data)
    }
}
