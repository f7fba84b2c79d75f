//! Constant values of an entry description (default, minimum, maximum) and the little-endian
//! encoding of entry values.

use super::types::DataType;
use crate::abort::SdoAbortCode;

/// A constant value in an entry description: the default, minimum or maximum value.
///
/// Integer types (BOOLEAN, INTEGERn, UNSIGNEDn, BITn) take [`Value::Int`] or [`Value::Uint`],
/// REAL32/REAL64 take [`Value::Real`], strings take [`Value::Str`], anything may take
/// [`Value::Bytes`] (the raw little-endian image).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Value {
    /// No value given.
    None,
    /// A signed number.
    Int(i64),
    /// An unsigned number (for UNSIGNED64 values above `i64::MAX`).
    Uint(u64),
    /// A floating-point number.
    Real(f64),
    /// A string (VISIBLE_STRING; for UNICODE_STRING the ASCII characters widened to UTF-16).
    Str(&'static str),
    /// The raw little-endian byte image.
    Bytes(&'static [u8]),
}

impl Value {
    /// True unless [`Value::None`].
    pub const fn is_some(&self) -> bool {
        !matches!(self, Self::None)
    }

    /// The value as a number, if it is one (`Int`, `Uint`).
    pub const fn as_i128(&self) -> Option<i128> {
        match *self {
            Self::Int(v) => Some(v as i128),
            Self::Uint(v) => Some(v as i128),
            _ => None,
        }
    }

    /// Number of bytes [`Value::encode`] writes for an entry of `data_type` and `bit_len`.
    pub const fn encoded_len(&self, data_type: DataType, bit_len: u16) -> usize {
        match *self {
            Self::None => 0,
            Self::Str(s) => {
                if matches!(data_type, DataType::UnicodeString) {
                    s.len() * 2
                } else {
                    s.len()
                }
            }
            Self::Bytes(b) => b.len(),
            Self::Int(_) | Self::Uint(_) | Self::Real(_) => (bit_len as usize).div_ceil(8),
        }
    }

    /// Writes the little-endian image of the value for an entry of `data_type` and `bit_len`
    /// into `out`; returns the number of bytes, or `None` if `out` is too short.
    pub fn encode(&self, data_type: DataType, bit_len: u16, out: &mut [u8]) -> Option<usize> {
        let len = self.encoded_len(data_type, bit_len);
        let out = out.get_mut(..len)?;
        match *self {
            Self::None => {}
            Self::Int(v) => copy_le(&v.to_le_bytes(), out, v < 0),
            Self::Uint(v) => copy_le(&v.to_le_bytes(), out, false),
            Self::Real(v) => {
                if matches!(data_type, DataType::Real32) {
                    copy_le(&(v as f32).to_le_bytes(), out, false)
                } else {
                    copy_le(&v.to_le_bytes(), out, false)
                }
            }
            Self::Str(s) => {
                if matches!(data_type, DataType::UnicodeString) {
                    for (pair, c) in out.chunks_exact_mut(2).zip(s.bytes()) {
                        pair.copy_from_slice(&u16::from(c).to_le_bytes());
                    }
                } else {
                    out.copy_from_slice(s.as_bytes());
                }
            }
            Self::Bytes(b) => out.copy_from_slice(b),
        }
        Some(len)
    }
}

/// Copies `src` (little-endian) into `out`, sign- or zero-extending if `out` is longer.
fn copy_le(src: &[u8], out: &mut [u8], negative: bool) {
    let fill = if negative { 0xFF } else { 0x00 };
    for (i, byte) in out.iter_mut().enumerate() {
        *byte = src.get(i).copied().unwrap_or(fill);
    }
}

/// Decodes the little-endian image of an integer-like entry (BOOLEAN, INTEGERn, UNSIGNEDn,
/// BITn) of `bit_len` bits; signed types are sign-extended. `None` if the type is not an
/// integer type or `bytes` is shorter than the entry.
pub fn decode_int(data_type: DataType, bit_len: u16, bytes: &[u8]) -> Option<i128> {
    if !data_type.is_integer() || bit_len == 0 || bit_len > 64 {
        return None;
    }
    let len = usize::from(bit_len).div_ceil(8);
    let src = bytes.get(..len)?;
    let mut raw = 0u64;
    for (i, b) in src.iter().enumerate() {
        raw |= u64::from(*b) << (8 * i);
    }
    if bit_len < 64 {
        raw &= (1u64 << bit_len) - 1;
    }
    if data_type.is_signed() && bit_len < 64 && raw & (1u64 << (bit_len - 1)) != 0 {
        Some(i128::from(raw) - (1i128 << bit_len))
    } else if data_type.is_signed() {
        Some(i128::from(raw as i64))
    } else {
        Some(i128::from(raw))
    }
}

/// The smallest and largest number an integer-like entry of `bit_len` bits can hold.
pub const fn int_limits(data_type: DataType, bit_len: u16) -> Option<(i128, i128)> {
    if !data_type.is_integer() || bit_len == 0 || bit_len > 64 {
        return None;
    }
    if data_type.is_signed() {
        let half = 1i128 << (bit_len - 1);
        Some((-half, half - 1))
    } else {
        Some((0, (1i128 << bit_len) - 1))
    }
}

/// Decodes a REAL32/REAL64 image.
pub fn decode_real(data_type: DataType, bytes: &[u8]) -> Option<f64> {
    match data_type {
        DataType::Real32 => {
            let b: [u8; 4] = bytes.get(..4)?.try_into().ok()?;
            Some(f64::from(f32::from_le_bytes(b)))
        }
        DataType::Real64 => {
            let b: [u8; 8] = bytes.get(..8)?.try_into().ok()?;
            Some(f64::from_le_bytes(b))
        }
        _ => None,
    }
}

/// Checks a written value against the minimum and maximum of its entry description:
/// `Err(ValueTooLow)` (0x06090032) below `min`, `Err(ValueTooHigh)` (0x06090031) above `max`.
/// Values of types without an order (strings, DOMAIN) and entries without limits pass.
pub fn check_range(
    data_type: DataType,
    bit_len: u16,
    min: &Value,
    max: &Value,
    bytes: &[u8],
) -> Result<(), SdoAbortCode> {
    if let Some(v) = decode_int(data_type, bit_len, bytes) {
        if let Some(lo) = min.as_i128() {
            if v < lo {
                return Err(SdoAbortCode::ValueTooLow);
            }
        }
        if let Some(hi) = max.as_i128() {
            if v > hi {
                return Err(SdoAbortCode::ValueTooHigh);
            }
        }
    } else if let Some(v) = decode_real(data_type, bytes) {
        if v.is_nan() && (min.is_some() || max.is_some()) {
            return Err(SdoAbortCode::ValueRangeExceeded);
        }
        if let Value::Real(lo) = *min {
            if v < lo {
                return Err(SdoAbortCode::ValueTooLow);
            }
        }
        if let Value::Real(hi) = *max {
            if v > hi {
                return Err(SdoAbortCode::ValueTooHigh);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_integers_little_endian() {
        let mut buf = [0xAAu8; 8];
        assert_eq!(
            Value::Int(-2).encode(DataType::Integer16, 16, &mut buf),
            Some(2)
        );
        assert_eq!(buf[..3], [0xFE, 0xFF, 0xAA]);
        assert_eq!(
            Value::Uint(0x000C_0191).encode(DataType::Unsigned32, 32, &mut buf),
            Some(4)
        );
        assert_eq!(buf[..4], [0x91, 0x01, 0x0C, 0x00]);
        assert_eq!(
            Value::Int(0x123456).encode(DataType::Unsigned24, 24, &mut buf),
            Some(3)
        );
        assert_eq!(buf[..3], [0x56, 0x34, 0x12]);
        assert_eq!(
            Value::Int(1).encode(DataType::Boolean, 1, &mut buf),
            Some(1)
        );
        assert_eq!(buf[0], 1);
        assert_eq!(
            Value::Int(1).encode(DataType::Unsigned32, 32, &mut buf[..3]),
            None
        );
    }

    #[test]
    fn encode_strings() {
        let mut buf = [0u8; 8];
        assert_eq!(
            Value::Str("DAC").encode(DataType::VisibleString, 24, &mut buf),
            Some(3)
        );
        assert_eq!(&buf[..3], b"DAC");
        assert_eq!(
            Value::Str("AB").encode(DataType::UnicodeString, 32, &mut buf),
            Some(4)
        );
        assert_eq!(buf[..4], [b'A', 0, b'B', 0]);
        assert_eq!(
            Value::Real(1.0).encode(DataType::Real32, 32, &mut buf),
            Some(4)
        );
        assert_eq!(buf[..4], [0x00, 0x00, 0x80, 0x3F]);
    }

    #[test]
    fn decode_sign_extends() {
        assert_eq!(decode_int(DataType::Integer16, 16, &[0xFE, 0xFF]), Some(-2));
        assert_eq!(
            decode_int(DataType::Unsigned16, 16, &[0xFE, 0xFF]),
            Some(0xFFFE)
        );
        assert_eq!(
            decode_int(DataType::Integer24, 24, &[0, 0, 0x80]),
            Some(-0x80_0000)
        );
        assert_eq!(decode_int(DataType::Bit3, 3, &[0xFF]), Some(7));
        assert_eq!(decode_int(DataType::Integer64, 64, &[0xFF; 8]), Some(-1));
        assert_eq!(
            decode_int(DataType::Unsigned64, 64, &[0xFF; 8]),
            Some(u64::MAX.into())
        );
        assert_eq!(decode_int(DataType::Unsigned32, 32, &[1, 2]), None);
        assert_eq!(decode_int(DataType::VisibleString, 8, &[1]), None);
    }

    #[test]
    fn range_check_codes() {
        let (lo, hi) = (Value::Int(-100), Value::Int(100));
        let t = DataType::Integer16;
        assert_eq!(check_range(t, 16, &lo, &hi, &100i16.to_le_bytes()), Ok(()));
        assert_eq!(
            check_range(t, 16, &lo, &hi, &101i16.to_le_bytes()),
            Err(SdoAbortCode::ValueTooHigh)
        );
        assert_eq!(
            check_range(t, 16, &lo, &hi, &(-101i16).to_le_bytes()),
            Err(SdoAbortCode::ValueTooLow)
        );
        assert_eq!(
            check_range(t, 16, &Value::None, &Value::None, &[0, 0x80]),
            Ok(())
        );
        assert_eq!(
            check_range(
                DataType::Real32,
                32,
                &Value::Real(0.0),
                &Value::Real(10.0),
                &11.0f32.to_le_bytes()
            ),
            Err(SdoAbortCode::ValueTooHigh)
        );
        assert_eq!(int_limits(DataType::Integer8, 8), Some((-128, 127)));
        assert_eq!(int_limits(DataType::Unsigned16, 16), Some((0, 65535)));
    }
}
