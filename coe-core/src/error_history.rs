//! The pre-defined error field (object 0x1003, CiA 301 7.5.2.3): the Emergencies a device
//! has sent, newest first, for both fieldbuses.
//!
//! CiA 301 7.5.2.3: sub 0 is the number of errors recorded (UNSIGNED8; writing 0 clears the
//! history, any other value is refused with 0x06090030); subs 1.. are UNSIGNED32, read-only,
//! newest at sub 1, each holding the Emergency error code in bits 0..15 and manufacturer-
//! specific additional information in bits 16..31; a new error pushes the older ones one
//! sub up and the oldest falls off when the field is full; the error reset (code 0x0000)
//! is not an error and is not recorded. A sub above the number of errors holds nothing: it
//! is answered with 0x08000024 "no data available" (CiA 301 table 22), as other CiA 301
//! implementations answer it.
//!
//! The additional information used here: bits 16..23 the error register (0x1001) the
//! Emergency carried, bits 24..31 its first manufacturer-specific byte (the split the Elmo
//! CiA 301 implementation guide documents: error code, error register, manufacturer-specific
//! byte), so a CANopen tool shows which channel or node an error was about.

use crate::abort::SdoAbortCode;
use crate::wire::EmergencyRepr;

/// The last `N` errors, newest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ErrorHistory<const N: usize> {
    /// A ring: the newest at `newest`, older ones after it (no shifting, no `memmove`),
    /// as little-endian bytes (byte-aligned: the history adds no padding to its holder).
    fields: [[u8; 4]; N],
    newest: u8,
    len: u8,
}

impl<const N: usize> Default for ErrorHistory<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ErrorHistory<N> {
    /// Sub 0 fits in a byte (CiA 301: at most 254 errors).
    const CAPACITY_FITS: () = assert!(N >= 1 && N <= 254);

    /// No error recorded.
    pub const fn new() -> Self {
        let () = Self::CAPACITY_FITS;
        Self {
            fields: [[0; 4]; N],
            newest: 0,
            len: 0,
        }
    }

    /// The 0x1003 value an Emergency is recorded as.
    pub const fn field(emergency: &EmergencyRepr) -> u32 {
        emergency.error_code as u32
            | (emergency.error_register as u32) << 16
            | (emergency.data[0] as u32) << 24
    }

    /// Records `emergency` at sub 1; the oldest falls off when full. The error reset (code
    /// 0x0000) is not recorded.
    pub fn record(&mut self, emergency: &EmergencyRepr) {
        if emergency.error_code != 0 {
            self.push(Self::field(emergency));
        }
    }

    // Out of line: every Emergency path would carry a copy.
    #[inline(never)]
    fn push(&mut self, field: u32) {
        self.newest = self.slot(N - 1);
        if let Some(slot) = self.fields.get_mut(usize::from(self.newest)) {
            *slot = field.to_le_bytes();
        }
        self.len = (self.len + 1).min(N as u8);
    }

    /// Sub 0: the number of errors recorded.
    pub const fn len(&self) -> u8 {
        self.len
    }

    /// True if no error is recorded.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Sub `subindex` (1 = newest), or 0x08000024 if it holds no error.
    pub fn get(&self, subindex: u8) -> Result<u32, SdoAbortCode> {
        match subindex {
            1.. if subindex <= self.len => self
                .fields
                .get(usize::from(self.slot(usize::from(subindex - 1))))
                .map(|bytes| u32::from_le_bytes(*bytes))
                .ok_or(SdoAbortCode::NoDataAvailable),
            _ => Err(SdoAbortCode::NoDataAvailable),
        }
    }

    /// The ring slot `age` places after the newest (`age` < N).
    fn slot(&self, age: usize) -> u8 {
        ((usize::from(self.newest) + age) % N) as u8
    }

    /// A download to sub `subindex`: 0 written to sub 0 clears the history; another value
    /// is refused with 0x06090030, another length with 0x06070010, another sub with
    /// 0x06010002 (read only).
    pub fn write(&mut self, subindex: u8, data: &[u8]) -> Result<(), SdoAbortCode> {
        match (subindex, data) {
            (0, [0]) => {
                self.len = 0;
                Ok(())
            }
            (0, [_]) => Err(SdoAbortCode::ValueRangeExceeded),
            (0, _) => Err(SdoAbortCode::LengthMismatch),
            _ => Err(SdoAbortCode::WriteOfReadOnly),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn emcy(code: u16, register: u8, first: u8) -> EmergencyRepr {
        EmergencyRepr {
            error_code: code,
            error_register: register,
            data: [first, 0xAA, 0xBB, 0xCC, 0xDD],
        }
    }

    fn subs<const N: usize>(h: &ErrorHistory<N>) -> std::vec::Vec<u32> {
        (1..=h.len()).map(|s| h.get(s).unwrap()).collect()
    }

    #[test]
    fn field_layout_code_register_first_data_byte() {
        assert_eq!(
            ErrorHistory::<4>::field(&emcy(0xFF01, 0x81, 0x02)),
            0x0281_FF01
        );
        assert_eq!(
            ErrorHistory::<4>::field(&emcy(0x8250, 0x11, 0)),
            0x0011_8250
        );
    }

    #[test]
    fn newest_first_and_the_oldest_falls_off() {
        let mut h = ErrorHistory::<3>::new();
        assert!(h.is_empty());
        for code in [0x1000, 0x2000, 0x3000] {
            h.record(&emcy(code, 1, 0));
        }
        assert_eq!(subs(&h), [0x0001_3000, 0x0001_2000, 0x0001_1000]);
        h.record(&emcy(0x4000, 1, 0));
        assert_eq!(h.len(), 3);
        assert_eq!(subs(&h), [0x0001_4000, 0x0001_3000, 0x0001_2000]);
    }

    #[test]
    fn the_error_reset_is_not_recorded() {
        let mut h = ErrorHistory::<4>::new();
        h.record(&emcy(0x8250, 0x11, 0));
        h.record(&emcy(0x0000, 0, 0));
        assert_eq!(subs(&h), [0x0011_8250]);
    }

    #[test]
    fn subs_above_the_count_have_no_data() {
        let mut h = ErrorHistory::<4>::new();
        assert_eq!(h.get(1), Err(SdoAbortCode::NoDataAvailable));
        h.record(&emcy(0x8700, 0x11, 0));
        assert_eq!(h.get(1), Ok(0x0011_8700));
        assert_eq!(h.get(2), Err(SdoAbortCode::NoDataAvailable));
        assert_eq!(h.get(0), Err(SdoAbortCode::NoDataAvailable));
        assert_eq!(h.get(255), Err(SdoAbortCode::NoDataAvailable));
    }

    #[test]
    fn writing_zero_clears_anything_else_is_refused() {
        let mut h = ErrorHistory::<4>::new();
        h.record(&emcy(0x8250, 0x11, 0));
        h.record(&emcy(0x5000, 0x01, 3));
        assert_eq!(h.write(0, &[2]), Err(SdoAbortCode::ValueRangeExceeded));
        assert_eq!(h.write(0, &[0, 0]), Err(SdoAbortCode::LengthMismatch));
        assert_eq!(
            h.write(1, &[0, 0, 0, 0]),
            Err(SdoAbortCode::WriteOfReadOnly)
        );
        assert_eq!(h.len(), 2, "a refused write loses nothing");
        assert_eq!(h.write(0, &[0]), Ok(()));
        assert!(h.is_empty());
        assert_eq!(h.get(1), Err(SdoAbortCode::NoDataAvailable));
        // Cleared entries do not come back with the next error.
        h.record(&emcy(0x8700, 0x11, 0));
        assert_eq!(subs(&h), [0x0011_8700]);
    }

    #[test]
    fn a_single_entry_history_keeps_the_newest() {
        let mut h = ErrorHistory::<1>::new();
        h.record(&emcy(0x1000, 1, 0));
        h.record(&emcy(0x2000, 1, 0));
        assert_eq!(subs(&h), [0x0001_2000]);
    }
}
