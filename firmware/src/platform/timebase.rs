//! A 64-bit time base from a free-running 32-bit timer counter and a high word that the
//! timer's wrap interrupt increments (the board's Timer1 at 100 MHz wraps every 42.9 s).
//!
//! Two races need care, and both are decided by the half of the 32-bit range a value lies
//! in (a value read or captured near a wrap is either just below 2^32 or just above 0):
//! - a reader above the wrap interrupt (or with it masked) sees the counter wrapped but the
//!   high word not yet incremented: [`extend`];
//! - the wrap interrupt serves a capture from just before the wrap it is counting:
//!   [`extend_capture`].

/// Half of the counter range: values below it are "just after a wrap".
const HALF: u32 = 0x8000_0000;

/// The 64-bit count from the high word `hi`, the counter `lo` and whether a wrap is pending
/// (flagged by the timer, not yet counted into `hi`). A pending wrap belongs to `lo` only if
/// `lo` was read after it (small `lo`).
pub const fn extend(hi: u32, lo: u32, wrap_pending: bool) -> u64 {
    let hi = if wrap_pending && lo < HALF {
        hi.wrapping_add(1)
    } else {
        hi
    };
    (hi as u64) << 32 | lo as u64
}

/// The 64-bit count of a capture `captured`, served by the interrupt that has just counted
/// a wrap into `hi` (`wrapped_now`): a capture taken just before that wrap (large value)
/// belongs to the previous high word.
pub const fn extend_capture(hi: u32, captured: u32, wrapped_now: bool) -> u64 {
    let hi = if wrapped_now && captured >= HALF {
        hi.wrapping_sub(1)
    } else {
        hi
    };
    (hi as u64) << 32 | captured as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_wrap_pending_is_plain_concatenation() {
        assert_eq!(extend(0, 5, false), 5);
        assert_eq!(extend(3, 0xFFFF_FFFF, false), 0x3_FFFF_FFFF);
    }

    #[test]
    fn pending_wrap_counts_for_a_counter_read_after_it() {
        assert_eq!(extend(3, 10, true), 0x4_0000_000A);
    }

    #[test]
    fn pending_wrap_does_not_count_for_a_counter_read_before_it() {
        assert_eq!(extend(3, 0xFFFF_FFF0, true), 0x3_FFFF_FFF0);
    }

    #[test]
    fn high_word_wraps_too() {
        assert_eq!(extend(u32::MAX, 1, true), 1);
    }

    #[test]
    fn capture_before_the_counted_wrap_keeps_the_old_high_word() {
        // The wrap was just counted: hi went 3 -> 4.
        assert_eq!(extend_capture(4, 0xFFFF_FF00, true), 0x3_FFFF_FF00);
        assert_eq!(extend_capture(4, 0x100, true), 0x4_0000_0100);
    }

    #[test]
    fn capture_without_a_wrap_uses_the_high_word() {
        assert_eq!(extend_capture(4, 0xFFFF_FF00, false), 0x4_FFFF_FF00);
    }

    #[test]
    fn time_is_monotonic_across_a_wrap() {
        // Reads around a wrap, as a reader above the wrap interrupt sees them.
        let before = extend(7, 0xFFFF_FFFE, false);
        let at = extend(7, 0xFFFF_FFFF, true);
        let after_pending = extend(7, 2, true);
        let after_counted = extend(8, 3, false);
        assert!(before < at && at < after_pending && after_pending < after_counted);
    }
}
