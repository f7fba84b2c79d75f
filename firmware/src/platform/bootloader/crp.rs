//! The Code Read Protection word (UM10360 section 32.6; hardware-facts section 7).
//!
//! The boot ROM reads the word at flash address 0x2FC: 0x12345678 (CRP1), 0x87654321
//! (CRP2), 0x43218765 (CRP3: SWD and ISP disabled for ever) and 0x4E697370 (NO_ISP: P2.10 not
//! sampled) restrict access; any other value means no protection. This firmware ships
//! **0xFFFF_FFFF = no CRP**: the module stays debuggable over SWD and recoverable through UART
//! ISP. The bootloader owns the first sector, so the word is its: `memory-boot.x` places the
//! `.crp` section at exactly 0x2FC and starts `.text` at 0x300;
//! `cargo xtask build` refuses an image with one of the four protection values unless
//! `--allow-crp` is given.

/// The chosen CRP value: none.
pub const CRP_WORD: u32 = 0xFFFF_FFFF;

#[link_section = ".crp"]
#[used]
static CRP: u32 = CRP_WORD;
