//! A communication parameter's entry in SDO transfers: up to 32 bits, little-endian, of
//! the entry's length in bytes. The node's parameters ([`super::params`], [`super::pdo`])
//! give each entry as a value and a length, and these two move it.

use crate::abort::SdoAbortCode;

/// Writes the `len` low bytes of `value` into `buf` (little-endian); returns `len`.
pub fn put_le(buf: &mut [u8], value: u32, len: usize) -> Result<usize, SdoAbortCode> {
    let bytes = value.to_le_bytes();
    let bytes = bytes.get(..len).ok_or(SdoAbortCode::OutOfMemory)?;
    buf.get_mut(..len)
        .ok_or(SdoAbortCode::OutOfMemory)?
        .copy_from_slice(bytes);
    Ok(len)
}

/// The little-endian value of an entry of `len` bytes (1..=4), or the length abort.
pub fn take_le(data: &[u8], len: usize) -> Result<u32, SdoAbortCode> {
    if data.len() < len {
        return Err(SdoAbortCode::LengthTooLow);
    }
    if data.len() > len {
        return Err(SdoAbortCode::LengthTooHigh);
    }
    let mut bytes = [0u8; 4];
    bytes
        .get_mut(..len)
        .ok_or(SdoAbortCode::LengthTooHigh)?
        .copy_from_slice(data);
    Ok(u32::from_le_bytes(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_move_as_their_length_in_bytes() {
        let mut buf = [0xAA; 4];
        assert_eq!(put_le(&mut buf, 0x0102_0304, 2), Ok(2));
        assert_eq!(buf, [0x04, 0x03, 0xAA, 0xAA]);
        assert_eq!(
            put_le(&mut buf[..1], 0x1234, 2),
            Err(SdoAbortCode::OutOfMemory)
        );
        assert_eq!(take_le(&[0x04, 0x03], 2), Ok(0x0304));
        assert_eq!(take_le(&[0x04], 2), Err(SdoAbortCode::LengthTooLow));
        assert_eq!(take_le(&[1, 2, 3], 2), Err(SdoAbortCode::LengthTooHigh));
        assert_eq!(take_le(&[1, 2, 3, 4], 4), Ok(0x0403_0201));
    }
}
