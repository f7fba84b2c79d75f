//! 64-by-32-bit unsigned division with the Cortex-M3's 32-bit `UDIV`.
//!
//! A plain `u64 / u64` links compiler-builtins' `__aeabi_uldivmod` (about 0.9 KB of the
//! 32 KB flash) and runs in software. The firmware only divides 64-bit times and sums by
//! 32-bit numbers, and mostly by constants below 2^16, so the quotient is built from 32-bit
//! divisions: exact, and the same result as `n / u64::from(d)`.

/// `n / d` (exact, truncated), for `d > 0`; `d == 0` gives `u64::MAX` (no panic).
///
/// - `n < 2^32`: one 32-bit division;
/// - `d <= 2^16`: four divisions of 16-bit digits (the remainder stays below `d`, so
///   `rem << 16 | digit` fits 32 bits);
/// - otherwise: the high word by one division, then the low word by restoring binary long
///   division (32 steps; only for large divisors of large numbers, not on a hot path).
#[inline(never)]
pub const fn div_u64_u32(n: u64, d: u32) -> u64 {
    if d == 0 {
        return u64::MAX;
    }
    if n >> 32 == 0 {
        return (n as u32 / d) as u64;
    }
    let (hi, lo) = ((n >> 32) as u32, n as u32);
    if d <= 1 << 16 {
        // Digits 3..0 of 16 bits each (constant shifts: no 64-bit shift helper either).
        let digits = [hi >> 16, hi & 0xFFFF, lo >> 16, lo & 0xFFFF];
        let mut q = [0u32; 4];
        let mut rem = 0u32;
        let mut i = 0;
        while i < 4 {
            let part = (rem << 16) | digits[i];
            q[i] = part / d;
            rem = part % d;
            i += 1;
        }
        return ((q[0] << 16 | q[1]) as u64) << 32 | (q[2] << 16 | q[3]) as u64;
    }
    let q_hi = hi / d;
    // rem < d < 2^32 throughout; rem * 2 + bit may need 33 bits, hence u64.
    let mut rem = (hi % d) as u64;
    let mut rest = lo;
    let mut q_lo = 0u32;
    let mut i = 0;
    while i < 32 {
        rem = (rem << 1) | (rest >> 31) as u64;
        rest <<= 1;
        q_lo <<= 1;
        if rem >= d as u64 {
            rem -= d as u64;
            q_lo |= 1;
        }
        i += 1;
    }
    (q_hi as u64) << 32 | q_lo as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_u64_division_on_edges() {
        let ns = [
            0u64,
            1,
            0xFFFF_FFFF,
            1 << 32,
            (1 << 32) + 1,
            0x1234_5678_9ABC_DEF0,
            u64::MAX,
            u64::MAX - 1,
            1_000_000 * 0xFFFF_FFFF,
        ];
        let ds = [
            1u32,
            2,
            3,
            7,
            15_625,
            0xFFFF,
            1 << 16,
            (1 << 16) + 1,
            1_000_000,
            0x8000_0000,
            0xFFFF_FFFE,
            u32::MAX,
        ];
        for n in ns {
            for d in ds {
                assert_eq!(div_u64_u32(n, d), n / u64::from(d), "{n:#x} / {d:#x}");
            }
        }
        assert_eq!(div_u64_u32(5, 0), u64::MAX);
    }

    #[test]
    fn matches_u64_division_on_a_spread_of_values() {
        // xorshift: deterministic, covers all three paths.
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for _ in 0..20_000 {
            let n = next() >> (next() % 64);
            let d = (next() >> (next() % 64)) as u32;
            if d != 0 {
                assert_eq!(div_u64_u32(n, d), n / u64::from(d), "{n:#x} / {d:#x}");
            }
        }
    }
}
