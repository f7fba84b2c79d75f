//! The pair of AD5663 codes both outputs change to at once: one 32-bit word, so a reader
//! never sees half a pair (`super::outputs`, `super::output_blocks`).

use super::scaling::ao_to_dac_code;
use crate::platform::board::AO_CHANNELS as CHANNELS;

/// The AD5663 codes of both channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DacPair {
    /// Channel A (0x6411:01).
    pub a: u16,
    /// Channel B (0x6411:02).
    pub b: u16,
}

impl DacPair {
    /// A pair of codes.
    pub const fn new(a: u16, b: u16) -> Self {
        Self { a, b }
    }

    /// The pair for two 0x6411 values (see [`crate::io::analog::scaling`]).
    pub const fn from_ao(ao: [i16; CHANNELS]) -> Self {
        Self::new(ao_to_dac_code(ao[0]), ao_to_dac_code(ao[1]))
    }

    /// Both codes in one word: A in the low half, B in the high half.
    pub const fn pack(self) -> u32 {
        self.a as u32 | (self.b as u32) << 16
    }

    /// The inverse of [`DacPair::pack`].
    pub const fn unpack(word: u32) -> Self {
        Self::new(word as u16, (word >> 16) as u16)
    }

    /// The code of channel `i` (0 = A, 1 = B).
    pub const fn channel(&self, i: usize) -> Option<u16> {
        match i {
            0 => Some(self.a),
            1 => Some(self.b),
            _ => None,
        }
    }
}
