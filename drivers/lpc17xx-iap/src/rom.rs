//! The IAP ROM of the chip (Arm bare-metal targets only): the only `unsafe` code of the
//! crate.
//!
//! The ROM is a Thumb function at [`IAP_ENTRY`] that reads five command words and writes five
//! result words (UM10360 32.8). While it erases or programs, the flash cannot be read, so
//! [`Rom::call`] masks interrupts for the call (a handler in flash would fault) and restores
//! the mask after it; the caller's own code may run from flash, since the CPU stays in the ROM
//! until the command is done. The ROM uses the top 32 bytes of the local SRAM
//! ([`crate::iap::IAP_RAM_START`]..): the linker scripts of the users of this crate keep their data and
//! stack out of them.

#![allow(unsafe_code)]

use crate::iap::{IapEntry, IAP_ENTRY};
use crate::sector::FLASH_SIZE;

/// The chip's IAP ROM; user flash must be mapped at 0 (MEMMAP = 1, the state after the boot
/// ROM has started user code).
#[derive(Debug, Default)]
pub struct Rom;

/// PRIMASK now, then masks interrupts.
#[inline(always)]
fn mask_interrupts() -> u32 {
    let primask: u32;
    // SAFETY: reading PRIMASK and setting it have no memory effect; the value read is
    // restored by `restore_interrupts`.
    unsafe {
        core::arch::asm!("mrs {}, PRIMASK", out(reg) primask, options(nomem, nostack, preserves_flags));
        core::arch::asm!("cpsid i", options(nomem, nostack, preserves_flags));
    }
    primask
}

/// Unmasks interrupts if they were unmasked before [`mask_interrupts`].
#[inline(always)]
fn restore_interrupts(primask: u32) {
    if primask & 1 == 0 {
        // SAFETY: as above.
        unsafe { core::arch::asm!("cpsie i", options(nomem, nostack, preserves_flags)) };
    }
}

/// The flash byte at address 0 (a Rust pointer cannot be null, the Cortex-M's address 0 is
/// flash).
fn byte_at_zero() -> u8 {
    let value: u32;
    // SAFETY: a byte load from address 0, the first byte of the user flash mapped there.
    unsafe {
        core::arch::asm!("ldrb {v}, [{a}]", v = out(reg) value, a = in(reg) 0u32,
            options(readonly, nostack, preserves_flags));
    }
    value as u8
}

impl IapEntry for Rom {
    fn call(&mut self, command: &[u32; 5], _source: &[u8]) -> [u32; 5] {
        let mut result = [0u32; 5];
        let primask = mask_interrupts();
        // SAFETY: 0x1FFF_1FF1 is the IAP ROM's Thumb entry point on every LPC17xx (UM10360
        // 32.8); it reads five command words and writes five result words, both arrays live
        // on our stack for the whole call; interrupts are masked during it. The ROM reads
        // the RAM a copy names by itself (`_source` is that RAM).
        unsafe {
            let iap: extern "C" fn(*const u32, *mut u32) = core::mem::transmute(IAP_ENTRY as usize);
            iap(command.as_ptr(), result.as_mut_ptr());
        }
        restore_interrupts(primask);
        result
    }

    fn ram_address(&self, buf: &[u8]) -> u32 {
        // The chip's addresses are 32 bits wide.
        buf.as_ptr() as usize as u32
    }

    fn read_flash(&self, addr: u32, buf: &mut [u8]) {
        let end = addr.saturating_add(buf.len() as u32).min(FLASH_SIZE);
        let inside = end.saturating_sub(addr) as usize;
        let (flash, outside) = buf.split_at_mut(inside.min(buf.len()));
        let (flash, from) = match flash.split_first_mut() {
            Some((first, rest)) if addr == 0 => {
                *first = byte_at_zero();
                (rest, 1)
            }
            _ => (flash, addr),
        };
        if !flash.is_empty() {
            // SAFETY: user flash is mapped at 0 and every address in 1..FLASH_SIZE is
            // readable memory; nothing programs the flash while this copy runs (the ROM is
            // only entered through `call`, which does not return before the flash is idle).
            let src = unsafe { core::slice::from_raw_parts(from as *const u8, flash.len()) };
            flash.copy_from_slice(src);
        }
        outside.fill(0xFF);
    }
}
