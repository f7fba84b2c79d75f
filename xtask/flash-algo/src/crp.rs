//! The Code Read Protection word at 0x2FC (UM10360 32.6; hardware-facts section 7): the boot
//! ROM reads it at reset. CRP3 disables SWD and ISP for ever, so a flash algorithm must not
//! write a lock value by accident.

/// Address of the CRP word.
pub const CRP_ADDRESS: u32 = 0x2FC;
/// CRP1: SWD off, partial ISP.
pub const CRP1: u32 = 0x1234_5678;
/// CRP2: SWD off, ISP only with a full erase.
pub const CRP2: u32 = 0x8765_4321;
/// CRP3: SWD and ISP off, permanently.
pub const CRP3: u32 = 0x4321_8765;
/// NO_ISP: P2.10 is not sampled at reset, no ISP entry.
pub const NO_ISP: u32 = 0x4E69_7370;
/// Every value that restricts access.
pub const LOCK_VALUES: [u32; 4] = [CRP1, CRP2, CRP3, NO_ISP];

/// The word a write of `data` at `addr` puts at [`CRP_ADDRESS`], as the flash will hold it
/// (bytes the write does not cover stay erased, 0xFF); `None` if the write misses the word.
pub fn crp_word_written(addr: u32, data: &[u8]) -> Option<u32> {
    let end = u64::from(addr) + data.len() as u64;
    let crp = u64::from(CRP_ADDRESS);
    if data.is_empty() || u64::from(addr) >= crp + 4 || end <= crp {
        return None;
    }
    let mut bytes = [0xFF; 4];
    for (i, b) in bytes.iter_mut().enumerate() {
        let a = crp + i as u64;
        if a >= u64::from(addr) && a < end {
            if let Some(v) = data.get((a - u64::from(addr)) as usize) {
                *b = *v;
            }
        }
    }
    Some(u32::from_le_bytes(bytes))
}

/// The lock value a write of `data` at `addr` would program into erased flash, if any.
pub fn lock_value_written(addr: u32, data: &[u8]) -> Option<u32> {
    lock_value_resulting(addr, data, u32::MAX)
}

/// The lock value flash would hold at [`CRP_ADDRESS`] after a write of `data` at `addr` over
/// a word that holds `current` now, if any. Programming only clears bits (the result is
/// `written & current`), so two writes that are harmless alone can together form a lock value.
pub fn lock_value_resulting(addr: u32, data: &[u8], current: u32) -> Option<u32> {
    crp_word_written(addr, data)
        .map(|w| w & current)
        .filter(|w| LOCK_VALUES.contains(w))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn page_with(word: u32) -> [u8; 1024] {
        let mut p = [0xFF; 1024];
        p[0x2FC..0x300].copy_from_slice(&word.to_le_bytes());
        p
    }

    #[test]
    fn finds_the_word_in_the_page_that_holds_it() {
        assert_eq!(crp_word_written(0, &page_with(CRP3)), Some(CRP3));
        assert_eq!(lock_value_written(0, &page_with(CRP3)), Some(CRP3));
        for v in LOCK_VALUES {
            assert_eq!(lock_value_written(0, &page_with(v)), Some(v));
        }
        assert_eq!(lock_value_written(0, &page_with(0xFFFF_FFFF)), None);
        // Over a word that is not erased, the bits already cleared count too.
        assert_eq!(
            lock_value_resulting(0, &page_with(CRP3 | 0xFF), CRP3 | 0xFF00),
            Some(CRP3)
        );
        assert_eq!(lock_value_resulting(0, &page_with(CRP3), 0), None);
        assert_eq!(lock_value_resulting(0x400, &page_with(CRP3), CRP3), None);
        assert_eq!(lock_value_written(0, &page_with(CRP1 ^ 1)), None);
        // A 256-byte write at 0x200 holds it at offset 0xFC.
        let mut p = [0u8; 256];
        p[0xFC..].copy_from_slice(&NO_ISP.to_le_bytes());
        assert_eq!(lock_value_written(0x200, &p), Some(NO_ISP));
    }

    #[test]
    fn writes_that_miss_it() {
        let p = [0x12u8; 256];
        assert_eq!(crp_word_written(0x300, &p), None);
        assert_eq!(crp_word_written(0x1000, &p), None);
        assert_eq!(crp_word_written(0x1FC, &p[..0x100]), None); // ends at 0x2FC
        assert_eq!(crp_word_written(0, &[]), None);
        assert_eq!(crp_word_written(u32::MAX, &p), None);
    }

    #[test]
    fn partial_cover_pads_with_erased_bytes() {
        // Two bytes ending at 0x2FE: the upper half stays 0xFFFF.
        assert_eq!(crp_word_written(0x2FC, &[0x78, 0x56]), Some(0xFFFF_5678));
        // The top two bytes of CRP1 alone do not make a lock value...
        assert_eq!(lock_value_written(0x2FE, &[0x34, 0x12]), None);
        // ...and the lower half alone is not a lock value either (0xFFFF_5678); but written
        // over the upper half already in flash it completes CRP1, which the guard sees
        // because it checks the word flash will hold.
        assert_eq!(lock_value_written(0x2FC, &[0x78, 0x56]), None);
        assert_eq!(
            lock_value_resulting(0x2FC, &[0x78, 0x56], 0x1234_FFFF),
            Some(CRP1)
        );
    }
}
