//! Entry values as bytes, for the application's [`ObjectAccess`](coe_core::od::ObjectAccess)
//! implementations (the dictionary's values and the process-data packing).

use coe_core::SdoAbortCode;

/// Copies `bytes` to the front of `buf`; returns their length (0x05040005 if `buf` is
/// shorter).
pub fn put(buf: &mut [u8], bytes: &[u8]) -> Result<usize, SdoAbortCode> {
    buf.get_mut(..bytes.len())
        .ok_or(SdoAbortCode::OutOfMemory)?
        .copy_from_slice(bytes);
    Ok(bytes.len())
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
