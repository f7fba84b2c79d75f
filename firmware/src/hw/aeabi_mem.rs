//! The aligned AEABI memory helpers as forwards to the unaligned ones.
//!
//! compiler-builtins links a separate implementation of each aligned variant
//! (`__aeabi_memcpy4/8`, `__aeabi_memclr4/8`: about 0.65 KB of the 32 KB flash) next to the
//! general `__aeabi_memcpy`/`__aeabi_memclr`. An aligned variant has exactly the contract of
//! the general one plus an alignment promise (RTABI 4.3.4), so forwarding is correct; the
//! general routines handle alignment themselves. compiler-builtins defines all of them weak,
//! so these strong definitions replace its aligned ones at link time.

extern "C" {
    fn __aeabi_memcpy(dest: *mut u8, src: *const u8, n: usize);
    fn __aeabi_memclr(dest: *mut u8, n: usize);
}

/// `__aeabi_memcpy` with `dest` and `src` 4-byte aligned.
///
/// # Safety
/// The contract of `__aeabi_memcpy`: `n` bytes readable at `src`, writable at `dest`, no
/// overlap.
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memcpy4(dest: *mut u8, src: *const u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memcpy(dest, src, n) }
}

/// `__aeabi_memcpy` with `dest` and `src` 8-byte aligned.
///
/// # Safety
/// As [`__aeabi_memcpy4`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memcpy8(dest: *mut u8, src: *const u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memcpy(dest, src, n) }
}

/// `__aeabi_memclr` with `dest` 4-byte aligned.
///
/// # Safety
/// The contract of `__aeabi_memclr`: `n` bytes writable at `dest`.
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memclr4(dest: *mut u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memclr(dest, n) }
}

/// `__aeabi_memclr` with `dest` 8-byte aligned.
///
/// # Safety
/// As [`__aeabi_memclr4`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memclr8(dest: *mut u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memclr(dest, n) }
}
