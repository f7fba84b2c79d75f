//! Entry values as bytes, for the application's [`ObjectAccess`](coe_core::od::ObjectAccess)
//! implementations (the dictionary's values and the process-data packing).

use coe_core::SdoAbortCode;

/// Copies `bytes` to the front of `buf`; returns their length (0x05040005 if `buf` is
/// shorter). (Out of line: every object access ends here.)
#[inline(never)]
pub fn put(buf: &mut [u8], bytes: &[u8]) -> Result<usize, SdoAbortCode> {
    buf.get_mut(..bytes.len())
        .ok_or(SdoAbortCode::OutOfMemory)?
        .copy_from_slice(bytes);
    Ok(bytes.len())
}

/// Copies the `len` (at most 4) low bytes of `value`, little-endian, to the front of `buf`;
/// returns `len` (0x05040005 if `buf` is shorter).
pub fn put_le(buf: &mut [u8], value: u32, len: usize) -> Result<usize, SdoAbortCode> {
    put(buf, value.to_le_bytes().get(..len).unwrap_or(&[]))
}

/// The channel (0-based) of subindex `sub` of an array of `count` channels
/// (0x06090011 for sub 0 and beyond the last).
pub fn channel(sub: u8, count: usize) -> Result<usize, SdoAbortCode> {
    let i = usize::from(sub).wrapping_sub(1);
    if i < count {
        Ok(i)
    } else {
        Err(SdoAbortCode::SubindexDoesNotExist)
    }
}
