//! The STM32F103's 48 KB SRAM, one buffer for both bus masters: the core reaches it through
//! the engine (mapped onto the buffer), DMA1 through [`Sram::read`] and [`Sram::write`]. The
//! ADC's sample ring and the DMA's DIN word are in this SRAM, as on the chip.

use crate::chip::{Chip, Span};
use crate::cpu::Engine;
use std::cell::UnsafeCell;
use std::rc::Rc;
use unicorn_engine::Prot;

/// The buffer (never moved or resized while the engine maps it).
struct Buffer(UnsafeCell<Box<[u8]>>);

/// The SRAM, shared by the engine and the machine.
#[derive(Clone)]
pub struct Sram {
    span: Span,
    buf: Rc<Buffer>,
}

impl Sram {
    /// Zeroed SRAM of the chip's size.
    pub fn new() -> Self {
        let span = Chip::Stm32f103.sram();
        Self {
            span,
            buf: Rc::new(Buffer(UnsafeCell::new(
                vec![0u8; span.len as usize].into_boxed_slice(),
            ))),
        }
    }

    /// Whether `[addr, addr + n)` is SRAM.
    pub fn contains(&self, addr: u32, n: u32) -> bool {
        self.span.contains(addr, n)
    }

    /// Maps the buffer into the engine at the SRAM's address.
    pub fn map(&self, uc: &mut Engine) -> Result<(), String> {
        let ptr = self.ptr();
        // SAFETY: the buffer lives as long as the engine: the engine's data (the machine)
        // holds this `Sram` (an `Rc` of the buffer), and the buffer is a boxed slice that is
        // never reallocated. The engine and the machine run on one thread and never at the
        // same time (the machine's accesses happen in hooks, while the engine waits).
        unsafe {
            uc.mem_map_ptr(
                u64::from(self.span.start),
                u64::from(self.span.len),
                Prot::ALL,
                ptr.cast(),
            )
        }
        .map_err(|e| format!("unicorn: SRAM: {e:?}"))
    }

    fn ptr(&self) -> *mut u8 {
        // SAFETY: only the pointer is taken; accesses go through `read`/`write` below.
        unsafe { (*self.buf.0.get()).as_mut_ptr() }
    }

    /// DMA reads `buf.len()` bytes at `addr` (inside the SRAM: [`Sram::contains`]).
    pub fn read(&self, addr: u32, buf: &mut [u8]) {
        if !self.contains(addr, buf.len() as u32) {
            return;
        }
        let at = (addr - self.span.start) as usize;
        // SAFETY: in bounds (checked above); no reference into the buffer is alive (the
        // engine is stopped in a hook while the machine runs).
        unsafe { std::ptr::copy_nonoverlapping(self.ptr().add(at), buf.as_mut_ptr(), buf.len()) }
    }

    /// DMA writes `data` at `addr` (inside the SRAM).
    pub fn write(&self, addr: u32, data: &[u8]) {
        if !self.contains(addr, data.len() as u32) {
            return;
        }
        let at = (addr - self.span.start) as usize;
        // SAFETY: as `read`.
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), self.ptr().add(at), data.len()) }
    }
}

impl Default for Sram {
    fn default() -> Self {
        Self::new()
    }
}
