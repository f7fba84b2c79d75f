//! Sample buffering for the 8 analog inputs: the ring buffer between the ADC path and the
//! process-data path, and the value published per cycle (latest or averaged).
//!
//! ```text
//!  AD7689 scan (DMA / sampler task, lowest priority)
//!      |  Sample { channel, code }  (tagged by the ad7689 driver's CFG pipeline)
//!      v
//!  SampleProducer::push   -- never blocks: a full ring drops the new sample and counts it
//!  ====== SampleRing<N> (heapless SPSC queue: lock-free between the two priorities) ======
//!  SampleConsumer::drain_into(&mut Sampler)      (PDI task, once per cycle)
//!      v
//!  Sampler::publish(mode) -> one INTEGER16 value per channel for 0x6401 / the TxPDO
//! ```
//!
//! The producer and consumer halves split one ring buffer; in the RTIC application each half
//! is a task-local resource, so neither side takes a lock. A test or the virtual board can
//! skip the ring and call [`Sampler::add`] directly.
//!
//! Publishing: [`PublishMode::Latest`] takes the newest sample of each channel,
//! [`PublishMode::Average`] the rounded mean of all samples since the last publish (the
//! cycle). A channel without a new sample keeps its previous value. Scaling to INTEGER16 and
//! volts: [`crate::io::analog::scaling`].

use super::scaling::adc_code_to_ai;
use super::settings::{AI_FILTER_AVERAGE, AI_FILTER_LATEST};
use crate::platform::board::AI_CHANNELS as CHANNELS;
use crate::platform::div::div_u64_u32;
use core::sync::atomic::{AtomicU32, Ordering};
use heapless::spsc::{Consumer, Producer, Queue};

/// One conversion result, tagged with the input channel it belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Input channel 0..=7 (other values, e.g. the temperature sensor, are not published).
    pub channel: u8,
    /// Unipolar straight-binary conversion code.
    pub code: u16,
}

impl Sample {
    /// A sample.
    pub const fn new(channel: u8, code: u16) -> Self {
        Self { channel, code }
    }
}

/// What is published per cycle for each channel (the manufacturer "filter" setting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PublishMode {
    /// The newest sample (setting value 0).
    #[default]
    Latest,
    /// The rounded mean of the samples of the cycle (setting value 1).
    Average,
}

impl PublishMode {
    /// Decodes the setting value; `None` for values that name no mode.
    pub const fn from_setting(value: u8) -> Option<Self> {
        match value {
            AI_FILTER_LATEST => Some(Self::Latest),
            AI_FILTER_AVERAGE => Some(Self::Average),
            _ => None,
        }
    }

    /// The setting value.
    pub const fn setting(self) -> u8 {
        match self {
            Self::Latest => AI_FILTER_LATEST,
            Self::Average => AI_FILTER_AVERAGE,
        }
    }
}

/// The fixed-capacity ring between the ADC path and the process-data path; holds `N - 1`
/// samples (heapless SPSC queue).
pub struct SampleRing<const N: usize> {
    queue: Queue<Sample, N>,
    overruns: AtomicU32,
}

impl<const N: usize> Default for SampleRing<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SampleRing<N> {
    /// An empty ring.
    pub const fn new() -> Self {
        Self {
            queue: Queue::new(),
            overruns: AtomicU32::new(0),
        }
    }

    /// Splits the ring into its producer (ADC side) and consumer (process-data side) halves.
    pub fn split(&mut self) -> (SampleProducer<'_, N>, SampleConsumer<'_, N>) {
        let (producer, consumer) = self.queue.split();
        (
            SampleProducer {
                inner: producer,
                overruns: &self.overruns,
            },
            SampleConsumer { inner: consumer },
        )
    }

    /// Samples dropped because the ring was full.
    pub fn overruns(&self) -> u32 {
        self.overruns.load(Ordering::Relaxed)
    }
}

/// The ADC side of a [`SampleRing`].
pub struct SampleProducer<'a, const N: usize> {
    inner: Producer<'a, Sample, N>,
    overruns: &'a AtomicU32,
}

impl<const N: usize> SampleProducer<'_, N> {
    /// Queues a sample; never blocks. Returns `false` (and counts an overrun) when the ring is
    /// full: the new sample is dropped, the consumer's end is never touched.
    pub fn push(&mut self, sample: Sample) -> bool {
        match self.inner.enqueue(sample) {
            Ok(()) => true,
            Err(_) => {
                let n = self.overruns.load(Ordering::Relaxed);
                self.overruns.store(n.saturating_add(1), Ordering::Relaxed);
                false
            }
        }
    }

    /// Queues several samples; returns how many were dropped.
    pub fn push_all(&mut self, samples: &[Sample]) -> usize {
        samples.iter().filter(|s| !self.push(**s)).count()
    }

    /// Samples dropped because the ring was full.
    pub fn overruns(&self) -> u32 {
        self.overruns.load(Ordering::Relaxed)
    }
}

/// The process-data side of a [`SampleRing`].
pub struct SampleConsumer<'a, const N: usize> {
    inner: Consumer<'a, Sample, N>,
}

impl<const N: usize> SampleConsumer<'_, N> {
    /// Moves at most `N` queued samples into `sampler` (bounded: the producer may keep adding
    /// while this runs); returns how many.
    pub fn drain_into(&mut self, sampler: &mut Sampler) -> usize {
        sampler.restart_stale_sums();
        let mut moved = 0;
        while moved < N {
            match self.inner.dequeue() {
                Some(sample) => {
                    sampler.add_to_fresh_sums(sample);
                    moved += 1;
                }
                None => break,
            }
        }
        moved
    }
}

/// Per-channel accumulation over one cycle and the published values. One array per
/// quantity, so a publish copies and clears whole arrays.
#[derive(Debug, Clone, Default)]
pub struct Sampler {
    latest: [u16; CHANNELS],
    sums: [u64; CHANNELS],
    /// Set by a publish: `sums` still hold the cycle before, and the next addition starts
    /// them over (a publish in every cycle would otherwise clear 64 bytes).
    sums_stale: bool,
    /// Single samples per channel since the last publish (whole scans are in `scans`).
    counts: [u32; CHANNELS],
    /// Additions of single samples (or short scans) since the last publish: `counts` holds
    /// only zeros while this is 0.
    singles: u32,
    /// Whole scans added since the last publish: one count for all channels.
    scans: u32,
    published: [u16; CHANNELS],
    mode: PublishMode,
    rejected: u32,
    received: u32,
}

impl Sampler {
    /// A sampler with every value at 0 and the given mode.
    pub const fn new(mode: PublishMode) -> Self {
        Self {
            latest: [0; CHANNELS],
            sums: [0; CHANNELS],
            sums_stale: false,
            counts: [0; CHANNELS],
            singles: 0,
            scans: 0,
            published: [0; CHANNELS],
            mode,
            rejected: 0,
            received: 0,
        }
    }

    /// The publish mode.
    pub const fn mode(&self) -> PublishMode {
        self.mode
    }

    /// Changes the publish mode (takes effect at the next publish).
    pub fn set_mode(&mut self, mode: PublishMode) {
        self.mode = mode;
    }

    /// Adds one sample to its channel's accumulator. A sample for a channel outside 0..=7 is
    /// counted as rejected and otherwise ignored.
    pub fn add(&mut self, sample: Sample) {
        self.restart_stale_sums();
        self.add_to_fresh_sums(sample);
    }

    /// [`add`](Self::add) after [`restart_stale_sums`](Self::restart_stale_sums): a drain
    /// of many samples checks the flag once.
    fn add_to_fresh_sums(&mut self, sample: Sample) {
        let ch = usize::from(sample.channel);
        match (
            self.latest.get_mut(ch),
            self.sums.get_mut(ch),
            self.counts.get_mut(ch),
        ) {
            (Some(latest), Some(sum), Some(count)) => {
                *latest = sample.code;
                *sum = sum.saturating_add(u64::from(sample.code));
                *count = count.saturating_add(1);
                self.singles = self.singles.saturating_add(1);
                self.received = self.received.wrapping_add(1);
            }
            _ => self.rejected = self.rejected.saturating_add(1),
        }
    }

    /// Adds one scan: the i-th code is input i (at most [`CHANNELS`] codes are taken; a
    /// shorter scan counts per channel like [`add`](Self::add)).
    pub fn add_scan(&mut self, codes: impl IntoIterator<Item = u16>) {
        let mut scan = [0u16; CHANNELS];
        let mut n = 0;
        for (slot, code) in scan.iter_mut().zip(codes) {
            *slot = code;
            n += 1;
        }
        if n == CHANNELS {
            self.add_whole_scan(&scan, |c| *c);
            return;
        }
        self.restart_stale_sums();
        let channels = self
            .latest
            .iter_mut()
            .zip(&mut self.sums)
            .zip(&mut self.counts);
        for (((latest, sum), count), code) in channels.zip(scan.iter().take(n)) {
            *latest = *code;
            *sum = sum.wrapping_add(u64::from(*code));
            *count = count.saturating_add(1);
        }
        self.singles = self.singles.saturating_add(1);
        self.received = self.received.wrapping_add(n as u32);
    }

    /// Adds one whole scan: `code` of word i is input i. The DMA path's drain calls this
    /// once per scan on the ring's words instead of `add` eight times: one scan count for
    /// all channels, and the sum wraps instead of saturating (a u64 of 16-bit codes cannot
    /// wrap within 2^48 samples, ~285 years at 31.25 kSPS). A fixed-size scan read in place
    /// leaves the loop without bounds checks or a copy.
    #[inline]
    pub fn add_whole_scan<W>(&mut self, scan: &[W; CHANNELS], code: impl Fn(&W) -> u16) {
        let channels = self.latest.iter_mut().zip(&mut self.sums).zip(scan);
        // A whole scan starts every stale sum over: set, not added.
        if core::mem::take(&mut self.sums_stale) {
            for ((latest, sum), word) in channels {
                let c = code(word);
                *latest = c;
                *sum = u64::from(c);
            }
        } else {
            for ((latest, sum), word) in channels {
                let c = code(word);
                *latest = c;
                *sum = sum.wrapping_add(u64::from(c));
            }
        }
        self.scans = self.scans.saturating_add(1);
        self.received = self.received.wrapping_add(CHANNELS as u32);
    }

    /// Clears the sums if a publish left them stale (before a single sample or a short
    /// scan: they add to some channels only).
    fn restart_stale_sums(&mut self) {
        if core::mem::take(&mut self.sums_stale) {
            self.sums = [0; CHANNELS];
        }
    }

    /// Adds several samples.
    pub fn add_all(&mut self, samples: &[Sample]) {
        self.restart_stale_sums();
        for sample in samples {
            self.add_to_fresh_sums(*sample);
        }
    }

    /// Ends the cycle: every channel with new samples publishes its latest or averaged code
    /// and starts a new accumulation; channels without new samples keep their value.
    pub fn publish(&mut self) {
        let scans = core::mem::take(&mut self.scans);
        let singles = core::mem::take(&mut self.singles) != 0;
        match self.mode {
            // Every channel has a sample when a whole scan came in.
            PublishMode::Latest if scans != 0 => self.published = self.latest,
            PublishMode::Latest => {
                for i in 0..CHANNELS {
                    if self.counts[i] != 0 {
                        self.published[i] = self.latest[i];
                    }
                }
            }
            PublishMode::Average => {
                for i in 0..CHANNELS {
                    let n = self.counts[i].saturating_add(scans);
                    if n != 0 {
                        let rounded = self.sums[i].saturating_add(u64::from(n / 2));
                        self.published[i] =
                            u16::try_from(div_u64_u32(rounded, n)).unwrap_or(u16::MAX);
                    }
                }
            }
        }
        // A channel without samples since the last publish has a zero sum and count
        // already, so starting all of them over is the same as those that published. The
        // sums start over at the next addition; until then no channel has a count.
        self.sums_stale = true;
        if singles {
            self.counts = [0; CHANNELS];
        }
    }

    /// The published conversion code of `channel` (0..=7; `None` otherwise).
    pub fn code(&self, channel: usize) -> Option<u16> {
        self.published.get(channel).copied()
    }

    /// The published conversion codes of all channels.
    pub const fn codes(&self) -> &[u16; CHANNELS] {
        &self.published
    }

    /// The published 0x6401 value of `channel` (0..=7; `None` otherwise).
    pub fn value(&self, channel: usize) -> Option<i16> {
        self.code(channel).map(adc_code_to_ai)
    }

    /// All published 0x6401 values.
    pub fn values(&self) -> [i16; CHANNELS] {
        self.published.map(adc_code_to_ai)
    }

    /// Samples accepted so far (wrapping).
    pub const fn received(&self) -> u32 {
        self.received
    }

    /// Samples rejected for an unknown channel.
    pub const fn rejected(&self) -> u32 {
        self.rejected
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    #[test]
    fn latest_mode_publishes_newest_sample() {
        let mut s = Sampler::new(PublishMode::Latest);
        s.add_all(&[
            Sample::new(0, 100),
            Sample::new(0, 200),
            Sample::new(3, 0xFFFF),
        ]);
        assert_eq!(s.value(0), Some(0));
        s.publish();
        assert_eq!(s.code(0), Some(200));
        assert_eq!(s.value(0), Some(100));
        assert_eq!(s.value(3), Some(0x7FFF));
        assert_eq!(s.value(8), None);
    }

    #[test]
    fn average_mode_rounds_the_mean_of_the_cycle() {
        let mut s = Sampler::new(PublishMode::Average);
        s.add_all(&[Sample::new(1, 10), Sample::new(1, 11), Sample::new(1, 11)]);
        s.add_all(&[Sample::new(2, 0xFFFF), Sample::new(2, 0xFFFF)]);
        s.publish();
        assert_eq!(s.code(1), Some(11)); // 32 / 3 = 10.67 -> 11
        assert_eq!(s.code(2), Some(0xFFFF));
        // Next cycle starts a fresh mean.
        s.add_all(&[Sample::new(1, 1000), Sample::new(1, 2000)]);
        s.publish();
        assert_eq!(s.code(1), Some(1500));
    }

    #[test]
    fn channel_without_samples_keeps_its_value() {
        let mut s = Sampler::new(PublishMode::Average);
        s.add(Sample::new(5, 4000));
        s.publish();
        s.publish();
        assert_eq!(s.code(5), Some(4000));
    }

    #[test]
    fn mode_switch_takes_effect_at_publish() {
        let mut s = Sampler::new(PublishMode::Latest);
        s.add_all(&[Sample::new(0, 0), Sample::new(0, 1000)]);
        s.set_mode(PublishMode::Average);
        s.publish();
        assert_eq!(s.code(0), Some(500));
        assert_eq!(PublishMode::from_setting(1), Some(PublishMode::Average));
        assert_eq!(PublishMode::from_setting(2), None);
        assert_eq!(PublishMode::Average.setting(), 1);
    }

    #[test]
    fn a_scan_counts_like_eight_samples() {
        let codes = [10, 20, 30, 40, 50, 60, 70, 80];
        let mut by_scan = Sampler::new(PublishMode::Average);
        let mut by_sample = Sampler::new(PublishMode::Average);
        for k in 0..3u16 {
            by_scan.add_scan(codes.map(|c| c + k));
            for (ch, c) in codes.iter().enumerate() {
                by_sample.add(Sample::new(ch as u8, c + k));
            }
        }
        by_scan.publish();
        by_sample.publish();
        assert_eq!(by_scan.values(), by_sample.values());
        assert_eq!(by_scan.code(3), Some(41));
        assert_eq!(by_scan.received(), 24);
        // Scans and single samples mix in one mean.
        by_scan.add_scan([100u16; 8]);
        by_scan.add(Sample::new(0, 200));
        by_scan.publish();
        assert_eq!(by_scan.code(0), Some(150));
        assert_eq!(by_scan.code(1), Some(100));
        assert_eq!(by_scan.received(), 24 + 8 + 1);
        // A short scan adds only its inputs; extra codes are ignored.
        by_scan.add_scan([5u16, 6]);
        by_scan.add_scan([9u16; 9]);
        assert_eq!(by_scan.received(), 33 + 2 + 8);
        by_scan.publish();
        assert_eq!(by_scan.code(1), Some(8)); // (6 + 9) / 2 rounded
        assert_eq!(by_scan.code(2), Some(9));
    }

    /// A per-channel reference: each channel's own samples since the last publish.
    fn reference_publish(mode: PublishMode, pending: &mut [Vec<u16>; CHANNELS], out: &mut [u16]) {
        for (p, o) in pending.iter_mut().zip(out.iter_mut()) {
            if let Some(&last) = p.last() {
                let n = p.len() as u64;
                let sum: u64 = p.iter().map(|&c| u64::from(c)).sum();
                *o = match mode {
                    PublishMode::Latest => last,
                    PublishMode::Average => ((sum + n / 2) / n) as u16,
                };
            }
            p.clear();
        }
    }

    #[test]
    fn scans_samples_and_short_scans_in_any_order_match_a_per_channel_reference() {
        for mode in [PublishMode::Latest, PublishMode::Average] {
            let mut s = Sampler::new(mode);
            let mut pending: [Vec<u16>; CHANNELS] = Default::default();
            let mut expected = [0u16; CHANNELS];
            let mut x = 0x2545_F491_u32;
            for _ in 0..2000 {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                let code = (x >> 8) as u16;
                match x % 5 {
                    0 => {
                        let ch = (x >> 4) as u8 % 8;
                        s.add(Sample::new(ch, code));
                        pending[usize::from(ch)].push(code);
                    }
                    1 | 2 => {
                        let scan: [u16; CHANNELS] = core::array::from_fn(|i| code ^ i as u16);
                        s.add_scan(scan);
                        for (p, c) in pending.iter_mut().zip(scan) {
                            p.push(c);
                        }
                    }
                    3 => {
                        let short = [code, code / 2, code / 3];
                        let n = (x >> 4) as usize % 3;
                        s.add_scan(short.into_iter().take(n));
                        for (p, &c) in pending.iter_mut().zip(&short[..n]) {
                            p.push(c);
                        }
                    }
                    _ => {
                        s.publish();
                        reference_publish(mode, &mut pending, &mut expected);
                        assert_eq!(s.codes(), &expected, "{mode:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn unknown_channel_is_rejected_not_stored() {
        let mut s = Sampler::new(PublishMode::Latest);
        s.add(Sample::new(8, 123));
        s.add(Sample::new(255, 123));
        s.publish();
        assert_eq!(s.rejected(), 2);
        assert_eq!(s.received(), 0);
        assert_eq!(s.values(), [0; CHANNELS]);
    }

    #[test]
    fn ring_counts_overruns_and_never_blocks() {
        let mut ring: SampleRing<4> = SampleRing::new(); // holds 3
        let (mut tx, mut rx) = ring.split();
        let dropped = tx.push_all(&[
            Sample::new(0, 1),
            Sample::new(0, 2),
            Sample::new(0, 3),
            Sample::new(0, 4),
            Sample::new(0, 5),
        ]);
        assert_eq!(dropped, 2);
        assert_eq!(tx.overruns(), 2);
        let mut s = Sampler::new(PublishMode::Average);
        assert_eq!(rx.drain_into(&mut s), 3);
        s.publish();
        assert_eq!(s.code(0), Some(2));
        // Room again after draining.
        assert!(tx.push(Sample::new(0, 9)));
        assert_eq!(rx.drain_into(&mut s), 1);
        let _ = (tx, rx);
        assert_eq!(ring.overruns(), 2);
    }

    #[test]
    fn long_cycles_do_not_overflow_the_mean() {
        let mut s = Sampler::new(PublishMode::Average);
        for _ in 0..200_000 {
            s.add(Sample::new(7, 0xFFFF));
        }
        s.publish();
        assert_eq!(s.code(7), Some(0xFFFF));
    }
}
