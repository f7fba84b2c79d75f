//! Small AEABI `memcpy`, `memset` and `memclr` (RTABI 4.3.4) for the bootloader, because
//! compiler-builtins' do not fit its flash region (`BOOT_BUDGET`, 12 KB; the 8 KB of the
//! flash plan is out of reach either way). compiler-builtins' are tuned for speed (unrolled,
//! misaligned sources by funnel shifts, a separate copy for each aligned variant). The
//! bootloader's flash as `cargo xtask build` prints it (from 0 to the end of its image):
//! 13120 B without this file (over by 832 B, the link fails), 12264 B with the copy alone,
//! 11928 B with the copy and the clear. The fills (`memset`, 404 B in compiler-builtins) came
//! later, when the board check and the idle wait left the bootloader 232 B over its region.
//! The `analog-io-can` application links this file too (`firmware/src/main.rs`): the
//! mailbox task left it 420 B over its 48 KB; with these routines it is under it, and its
//! process-data path is no slower (3 000 DC cycles at 100 us with CAN load, PDI task mean
//! 2 755 cycles against 2 783, CPU load 66.6 % against 67.8 %: its copies are short, where
//! compiler-builtins' dispatch costs more than it gains). The other images keep
//! compiler-builtins'.
//!
//! The bootloader's copies and clears are short (mailbox frames, 1 KB flash chunks): a word
//! loop when the pointers and the length allow it, else a byte loop, is enough.
//! compiler-builtins defines these weak, so these strong definitions replace them at link
//! time. The loops use volatile accesses so that the compiler cannot recognise them as a
//! copy or a clear and turn them back into calls of these very functions.

use core::ptr::{read_volatile, write_volatile};

/// Copies `n` bytes from `src` to `dest`: 32-bit words when `dest`, `src` and `n` are all
/// multiples of 4, else bytes.
///
/// # Safety
/// `n` bytes readable at `src` and writable at `dest`; the regions do not overlap.
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memcpy(dest: *mut u8, src: *const u8, n: usize) {
    if (dest as usize | src as usize | n) & 3 == 0 {
        let (d, s) = (dest.cast::<u32>(), src.cast::<u32>());
        for i in 0..n / 4 {
            // SAFETY: word i lies inside both regions (n is a multiple of 4) and both
            // pointers are 4-byte aligned.
            unsafe { write_volatile(d.add(i), read_volatile(s.add(i))) };
        }
    } else {
        for i in 0..n {
            // SAFETY: byte i lies inside both regions.
            unsafe { write_volatile(dest.add(i), read_volatile(src.add(i))) };
        }
    }
}

/// `__aeabi_memcpy` with `dest` and `src` 4-byte aligned.
///
/// # Safety
/// As [`__aeabi_memcpy`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memcpy4(dest: *mut u8, src: *const u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memcpy(dest, src, n) }
}

/// `__aeabi_memcpy` with `dest` and `src` 8-byte aligned.
///
/// # Safety
/// As [`__aeabi_memcpy`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memcpy8(dest: *mut u8, src: *const u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memcpy(dest, src, n) }
}

/// Sets `n` bytes at `dest` to the low byte of `c` (the AEABI argument order: length before
/// value): 32-bit words when `dest` and `n` are multiples of 4, else bytes.
///
/// # Safety
/// `n` bytes writable at `dest`.
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memset(dest: *mut u8, n: usize, c: i32) {
    let byte = c as u8;
    if (dest as usize | n) & 3 == 0 {
        let d = dest.cast::<u32>();
        let word = u32::from_ne_bytes([byte; 4]);
        for i in 0..n / 4 {
            // SAFETY: word i lies inside the region and the pointer is 4-byte aligned.
            unsafe { write_volatile(d.add(i), word) };
        }
    } else {
        for i in 0..n {
            // SAFETY: byte i lies inside the region.
            unsafe { write_volatile(dest.add(i), byte) };
        }
    }
}

/// `__aeabi_memset` with `dest` 4-byte aligned.
///
/// # Safety
/// As [`__aeabi_memset`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memset4(dest: *mut u8, n: usize, c: i32) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memset(dest, n, c) }
}

/// `__aeabi_memset` with `dest` 8-byte aligned.
///
/// # Safety
/// As [`__aeabi_memset`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memset8(dest: *mut u8, n: usize, c: i32) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memset(dest, n, c) }
}

/// Sets `n` bytes at `dest` to zero ([`__aeabi_memset`] with 0).
///
/// # Safety
/// `n` bytes writable at `dest`.
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memclr(dest: *mut u8, n: usize) {
    // SAFETY: same contract, with the value 0.
    unsafe { __aeabi_memset(dest, n, 0) }
}

/// `__aeabi_memclr` with `dest` 4-byte aligned.
///
/// # Safety
/// As [`__aeabi_memclr`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memclr4(dest: *mut u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memset(dest, n, 0) }
}

/// `__aeabi_memclr` with `dest` 8-byte aligned.
///
/// # Safety
/// As [`__aeabi_memclr`].
#[no_mangle]
pub unsafe extern "C" fn __aeabi_memclr8(dest: *mut u8, n: usize) {
    // SAFETY: same contract, forwarded unchanged.
    unsafe { __aeabi_memset(dest, n, 0) }
}
