//! (Interrupt path, feature `adc-irq`; the GPDMA path keeps its ring in `adc_dma`.)
//! Big buffers in the AHB SRAM bank (0x2007_C000, 16 KB), section `.ahbsram` (NOLOAD in
//! `memory.x`: not zeroed by the runtime). Each buffer is handed out once, initialised, as a
//! `&'static mut`. They do not count against the 6 KB static RAM budget of the local SRAM;
//! `cargo xtask size` lists them separately.

use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};
use firmware::io::analog::sampler::SampleRing;

/// Capacity of the AD7689 sample ring (holds N - 1 samples: ~4 ms at 250 kSPS).
pub const SAMPLE_RING_LEN: usize = 1024;

/// The ring between the sampler task and the PDI task.
pub type SampleRingBuf = SampleRing<SAMPLE_RING_LEN>;

#[link_section = ".ahbsram.sample_ring"]
static mut SAMPLE_RING: MaybeUninit<SampleRingBuf> = MaybeUninit::uninit();
static SAMPLE_RING_TAKEN: AtomicBool = AtomicBool::new(false);

/// The sample ring, initialised empty; `None` after the first call.
pub fn sample_ring() -> Option<&'static mut SampleRingBuf> {
    if SAMPLE_RING_TAKEN.swap(true, Ordering::AcqRel) {
        return None;
    }
    // SAFETY: the flag above hands the static out at most once, so this is the only reference;
    // `write` initialises it before use.
    let slot = unsafe { &mut *core::ptr::addr_of_mut!(SAMPLE_RING) };
    Some(slot.write(SampleRingBuf::new()))
}
