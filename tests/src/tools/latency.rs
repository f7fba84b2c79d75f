//! A histogram of durations with the figures a latency is judged by: count, mean,
//! percentiles and maximum. Used for the frame answer latency of the board on a network
//! interface ([`crate::tools::iface`]): bounded memory however long the board serves.

/// Durations in 1 us bins up to [`FINE_LIMIT_NS`], 100 us bins above up to [`COARSE_LIMIT_NS`],
/// one bin for the rest; the sum and the maximum are exact.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Latency {
    bins: Vec<u64>,
    count: u64,
    sum_ns: u64,
    max_ns: u64,
}

/// Upper end of the 1 us bins.
pub const FINE_LIMIT_NS: u64 = 2_000_000;
/// Upper end of the 100 us bins.
pub const COARSE_LIMIT_NS: u64 = 100_000_000;
const FINE_NS: u64 = 1_000;
const COARSE_NS: u64 = 100_000;
const FINE_BINS: usize = (FINE_LIMIT_NS / FINE_NS) as usize;
const BINS: usize = FINE_BINS + ((COARSE_LIMIT_NS - FINE_LIMIT_NS) / COARSE_NS) as usize + 1;

impl Default for Latency {
    fn default() -> Self {
        Self {
            bins: vec![0; BINS],
            count: 0,
            sum_ns: 0,
            max_ns: 0,
        }
    }
}

fn bin_of(ns: u64) -> usize {
    if ns < FINE_LIMIT_NS {
        (ns / FINE_NS) as usize
    } else if ns < COARSE_LIMIT_NS {
        FINE_BINS + ((ns - FINE_LIMIT_NS) / COARSE_NS) as usize
    } else {
        BINS - 1
    }
}

/// The upper end of bin `b` (ns): a percentile is never reported below its true value.
fn bin_end(b: usize) -> u64 {
    if b == BINS - 1 {
        u64::MAX
    } else if b < FINE_BINS {
        (b as u64 + 1) * FINE_NS
    } else {
        FINE_LIMIT_NS + (b - FINE_BINS + 1) as u64 * COARSE_NS
    }
}

impl Latency {
    /// Adds one duration.
    pub fn record(&mut self, ns: u64) {
        self.bins[bin_of(ns)] += 1;
        self.count += 1;
        self.sum_ns += ns;
        self.max_ns = self.max_ns.max(ns);
    }

    /// Durations recorded.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Mean (ns), 0 without any.
    pub fn mean_ns(&self) -> u64 {
        self.sum_ns.checked_div(self.count).unwrap_or(0)
    }

    /// Largest (ns).
    pub fn max_ns(&self) -> u64 {
        self.max_ns
    }

    /// The `p`-th percentile (0..=100) in ns, rounded up to its bin's end (at most the
    /// maximum); 0 without any.
    pub fn percentile_ns(&self, p: f64) -> u64 {
        if self.count == 0 {
            return 0;
        }
        let rank = ((p / 100.0) * self.count as f64).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (b, n) in self.bins.iter().enumerate() {
            seen += n;
            if seen >= rank {
                return bin_end(b).min(self.max_ns);
            }
        }
        self.max_ns
    }

    /// "mean 12 us, p99 40 us, max 310 us over 2000 frames".
    pub fn summary(&self, what: &str) -> String {
        format!(
            "mean {} us, p99 {} us, max {} us over {} {what}",
            self.mean_ns() / 1000,
            self.percentile_ns(99.0).div_ceil(1000),
            self.max_ns.div_ceil(1000),
            self.count
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_of_a_known_set() {
        let mut l = Latency::default();
        assert_eq!((l.mean_ns(), l.percentile_ns(99.0), l.max_ns()), (0, 0, 0));
        for i in 1..=100u64 {
            l.record(i * 10_000);
        }
        assert_eq!(l.count(), 100);
        assert_eq!(l.mean_ns(), 505_000);
        assert_eq!(l.percentile_ns(50.0), 501_000);
        assert_eq!(l.percentile_ns(99.0), 991_000);
        assert_eq!(l.percentile_ns(100.0), 1_000_000);
        assert_eq!(l.max_ns(), 1_000_000);
        assert_eq!(
            l.summary("frames"),
            "mean 505 us, p99 991 us, max 1000 us over 100 frames"
        );
    }

    #[test]
    fn long_durations_land_in_coarse_bins_and_the_last_one() {
        let mut l = Latency::default();
        l.record(5_000_050);
        assert_eq!(l.percentile_ns(99.0), 5_000_050, "never above the maximum");
        l.record(3_000_000_000);
        assert_eq!(l.max_ns(), 3_000_000_000);
        assert_eq!(l.percentile_ns(100.0), 3_000_000_000);
        assert_eq!(l.percentile_ns(50.0), 5_100_000);
    }
}
