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
    /// into `out`; returns the number of bytes, or `None` if `out` is too short (or for a
    /// [`Value::Real`] when coe-core is built without its `real` feature).
    pub fn encode(&self, data_type: DataType, bit_len: u16, out: &mut [u8]) -> Option<usize> {
        let len = self.encoded_len(data_type, bit_len);
        let out = out.get_mut(..len)?;
        match *self {
            Self::None => {}
            Self::Int(v) => copy_le(&v.to_le_bytes(), out, v < 0),
            Self::Uint(v) => copy_le(&v.to_le_bytes(), out, false),
            #[cfg(feature = "real")]
            Self::Real(v) => {
                if matches!(data_type, DataType::Real32) {
                    copy_le(&ieee::f64_to_f32(v.to_bits()).to_le_bytes(), out, false)
                } else {
                    copy_le(&v.to_le_bytes(), out, false)
                }
            }
            // Without the `real` feature no REAL entry passes `ObjectDictionary::validate`.
            #[cfg(not(feature = "real"))]
            Self::Real(_) => return None,
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
    // The last byte holds the top 1..=8 bits: masked, sign-extended for signed types; the
    // bytes above the entry are the fill. Built a byte at a time (constant shifts only:
    // no 64-bit shift helpers on the MCU).
    let top = u32::from(bit_len) - 8 * (len as u32 - 1);
    let mask = ((1u32 << top) - 1) as u8;
    let last = *src.last()? & mask;
    let negative = data_type.is_signed() && (last >> (top - 1)) & 1 == 1;
    let (fill, last) = if negative {
        (0xFF, last | !mask)
    } else {
        (0x00, last)
    };
    let mut raw = 0u64;
    for i in (0..8).rev() {
        let byte = match i.cmp(&(len - 1)) {
            core::cmp::Ordering::Greater => fill,
            core::cmp::Ordering::Equal => last,
            core::cmp::Ordering::Less => src.get(i).copied().unwrap_or(0),
        };
        raw = raw << 8 | u64::from(byte);
    }
    if data_type.is_signed() {
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
    decode_real_bits(data_type, bytes).map(f64::from_bits)
}

/// Decodes a REAL32/REAL64 image into the bit pattern of the same REAL64 value.
fn decode_real_bits(data_type: DataType, bytes: &[u8]) -> Option<u64> {
    match data_type {
        DataType::Real32 => {
            let b: [u8; 4] = bytes.get(..4)?.try_into().ok()?;
            Some(ieee::f32_to_f64(u32::from_le_bytes(b)))
        }
        DataType::Real64 => {
            let b: [u8; 8] = bytes.get(..8)?.try_into().ok()?;
            Some(u64::from_le_bytes(b))
        }
        _ => None,
    }
}

/// REAL values through their IEEE 754 bit patterns. The firmware's Cortex-M3 has no FPU:
/// `f64` comparisons and `f32`/`f64` conversions would link about 0.7 KB of soft-float
/// routines for the few range checks and defaults of REAL entries. These give the same
/// results as the float operations (tested against them).
#[cfg_attr(not(feature = "real"), allow(dead_code))]
pub(crate) mod ieee {
    const F64_EXP: u64 = 0x7FF0_0000_0000_0000;
    const F64_MAN: u64 = (1 << 52) - 1;
    const F64_SIGN: u64 = 1 << 63;

    /// True if the REAL64 pattern is a NaN.
    pub const fn is_nan(bits: u64) -> bool {
        bits & F64_EXP == F64_EXP && bits & F64_MAN != 0
    }

    /// A key whose unsigned order is the numeric order of REAL64 patterns other than NaN
    /// (-0 and +0 equal); NaN is unordered: check [`is_nan`] first.
    #[inline(never)]
    pub const fn order_key(bits: u64) -> u64 {
        if bits << 1 == 0 {
            F64_SIGN // both zeros
        } else if bits & F64_SIGN != 0 {
            !bits
        } else {
            bits | F64_SIGN
        }
    }

    /// REAL32 -> REAL64 (exact, like `f64::from(f32)`).
    #[inline(never)]
    pub const fn f32_to_f64(bits: u32) -> u64 {
        let sign = ((bits >> 31) as u64) << 63;
        let exp = (bits >> 23) & 0xFF;
        let man = (bits & 0x7F_FFFF) as u64;
        if exp == 0xFF {
            // Infinity or NaN (payload kept in the top mantissa bits).
            return sign | F64_EXP | man << 29;
        }
        if exp == 0 {
            if man == 0 {
                return sign;
            }
            // Subnormal: value = man * 2^-149, normalised for REAL64.
            let top = 63 - man.leading_zeros(); // 0..=22
            let exp64 = top as u64 + 1023 - 149;
            return sign | exp64 << 52 | (man << (52 - top)) & F64_MAN;
        }
        sign | (exp as u64 + 1023 - 127) << 52 | man << 29
    }

    /// REAL64 -> REAL32 rounded to nearest, ties to even (like `f64 as f32`; a NaN stays a
    /// quiet NaN).
    #[inline(never)]
    pub const fn f64_to_f32(bits: u64) -> u32 {
        let sign = ((bits >> 63) as u32) << 31;
        let exp = ((bits >> 52) & 0x7FF) as i32;
        let man = bits & F64_MAN;
        if exp == 0x7FF {
            let nan = if man != 0 {
                0x40_0000 | (man >> 29) as u32
            } else {
                0
            };
            return sign | 0x7F80_0000 | nan;
        }
        if exp == 0 {
            // Zero or a REAL64 subnormal: far below the smallest REAL32.
            return sign;
        }
        let e = exp - 1023 + 127; // REAL32 biased exponent
        if e >= 0xFF {
            return sign | 0x7F80_0000;
        }
        let full = man | 1 << 52; // 53 significant bits
                                  // Bits to drop: 29 for a normal result, more for a subnormal one.
        let shift = if e >= 1 { 29 } else { 29 + (1 - e) as u32 };
        if shift >= 64 {
            return sign;
        }
        let mut q = full >> shift;
        let rest = full & ((1u64 << shift) - 1);
        let half = 1u64 << (shift - 1);
        if rest > half || (rest == half && q & 1 == 1) {
            q += 1;
        }
        // A normal result: the implicit bit in q adds 1 to the exponent field, a carry out
        // of the mantissa adds another (up to infinity); a subnormal one is q itself.
        let magnitude = if e >= 1 {
            ((e as u64 - 1) << 23) + q
        } else {
            q
        };
        if magnitude >= 0x7F80_0000 {
            sign | 0x7F80_0000
        } else {
            sign | magnitude as u32
        }
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
    }
    #[cfg(feature = "real")]
    if let Some(v) = decode_real_bits(data_type, bytes) {
        // Compared through order keys: no soft-float on the MCU (see `ieee`).
        if ieee::is_nan(v) {
            return if min.is_some() || max.is_some() {
                Err(SdoAbortCode::ValueRangeExceeded)
            } else {
                Ok(())
            };
        }
        let v = ieee::order_key(v);
        if let Value::Real(lo) = *min {
            let lo = lo.to_bits();
            if !ieee::is_nan(lo) && v < ieee::order_key(lo) {
                return Err(SdoAbortCode::ValueTooLow);
            }
        }
        if let Value::Real(hi) = *max {
            let hi = hi.to_bits();
            if !ieee::is_nan(hi) && v > ieee::order_key(hi) {
                return Err(SdoAbortCode::ValueTooHigh);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit patterns around every class boundary plus a deterministic spread.
    #[cfg(feature = "real")]
    fn f64_patterns() -> std::vec::Vec<u64> {
        let mut v = std::vec![
            0,
            1,
            (1 << 52) - 1,
            1 << 52,
            0x3FF0_0000_0000_0000,
            0x7FEF_FFFF_FFFF_FFFF,
            0x7FF0_0000_0000_0000,
            0x7FF8_0000_0000_0000,
            0x7FF0_0000_0000_0001,
        ];
        for f in [
            f32::MAX,
            f32::MIN_POSITIVE,
            1e-45,
            1.5e-45,
            3.4028235e38,
            0.1,
            1.0,
        ] {
            let d = f64::from(f);
            v.extend([d.to_bits(), d.to_bits() + 1, d.to_bits() - 1]);
        }
        // Halfway cases: exactly between two REAL32 values (ties go to even).
        v.extend([
            0x3FF0_0000_1000_0000,
            0x3FF0_0000_3000_0000,
            0x47EF_FFFF_F000_0000,
        ]);
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..50_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            v.push(x);
            // Mostly near the REAL32 range.
            v.push((x & 0x800F_FFFF_FFFF_FFFF) | (((x >> 52) % 300 + 1023 - 150) << 52));
        }
        let negated: std::vec::Vec<u64> = v.iter().map(|b| b ^ 1 << 63).collect();
        v.extend(negated);
        v
    }

    #[test]
    #[cfg(feature = "real")]
    fn ieee_conversions_match_the_float_casts() {
        for bits in f64_patterns() {
            let d = f64::from_bits(bits);
            let ours = f32::from_bits(ieee::f64_to_f32(bits));
            if d.is_nan() {
                assert!(ours.is_nan(), "{bits:#x}");
            } else {
                assert_eq!(ours.to_bits(), (d as f32).to_bits(), "{bits:#x} {d:e}");
            }
            let single = (bits >> 32) as u32 ^ bits as u32;
            let f = f32::from_bits(single);
            let wide = f64::from_bits(ieee::f32_to_f64(single));
            if f.is_nan() {
                assert!(wide.is_nan(), "{single:#x}");
            } else {
                assert_eq!(wide.to_bits(), f64::from(f).to_bits(), "{single:#x} {f:e}");
            }
        }
    }

    #[test]
    #[cfg(feature = "real")]
    fn ieee_order_keys_order_like_floats() {
        let p = f64_patterns();
        for pair in p.windows(2) {
            let (a, b) = (f64::from_bits(pair[0]), f64::from_bits(pair[1]));
            let nan = ieee::is_nan(pair[0]) || ieee::is_nan(pair[1]);
            assert_eq!(nan, a.is_nan() || b.is_nan(), "{a:e} {b:e}");
            if let Some(o) = a.partial_cmp(&b) {
                let keys = (ieee::order_key(pair[0]), ieee::order_key(pair[1]));
                assert_eq!(keys.0.cmp(&keys.1), o, "{a:e} {b:e}");
            }
        }
        assert_eq!(ieee::order_key(0), ieee::order_key(1 << 63), "-0 == +0");
    }

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
    #[cfg(feature = "real")]
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
    #[cfg(feature = "real")]
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
        let (lo, hi) = (Value::Real(-0.5), Value::Real(10.0));
        let real = |v: f32| check_range(DataType::Real32, 32, &lo, &hi, &v.to_le_bytes());
        assert_eq!(real(10.0), Ok(()));
        assert_eq!(real(-0.5), Ok(()));
        assert_eq!(real(-0.0), Ok(()));
        assert_eq!(real(10.000001), Err(SdoAbortCode::ValueTooHigh));
        assert_eq!(real(-0.50001), Err(SdoAbortCode::ValueTooLow));
        assert_eq!(real(f32::NEG_INFINITY), Err(SdoAbortCode::ValueTooLow));
        assert_eq!(real(f32::NAN), Err(SdoAbortCode::ValueRangeExceeded));
        let zero = (Value::Real(0.0), Value::Real(0.0));
        assert_eq!(
            check_range(
                DataType::Real64,
                64,
                &zero.0,
                &zero.1,
                &(-0.0f64).to_le_bytes()
            ),
            Ok(()),
            "-0.0 is within 0.0..=0.0"
        );
        assert_eq!(
            check_range(
                DataType::Real64,
                64,
                &Value::None,
                &Value::None,
                &f64::NAN.to_le_bytes()
            ),
            Ok(())
        );
        assert_eq!(int_limits(DataType::Integer8, 8), Some((-128, 127)));
        assert_eq!(int_limits(DataType::Unsigned16, 16), Some((0, 65535)));
    }
}
