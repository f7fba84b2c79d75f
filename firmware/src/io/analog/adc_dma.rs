//! The PDI task's side of the AD7689 scan that the GPDMA moves into a ring (the lists and
//! the Timer2 timing: `crate::platform::chip::adc_dma`; the register writes: `hw::adc_dma`): where the
//! DMA got to, and the whole scans it wrote since the last look.
//!
//! The CPU's only work per sample is the drain ([`ScanReader::drain`], whole 8-channel scans
//! into the [`Sampler`]) plus one terminal-count interrupt per half ring
//! ([`HalfCounter::on_terminal_count`]).
//!
//! Position: the RX channel's destination address says how far the DMA got within the ring;
//! the half counter says how many halves were completed. Together they give the total number
//! of words written ([`words_written`]), robust against the interrupt running late (by less
//! than one half).

use super::sampler::Sampler;
use crate::platform::board::AI_CHANNELS as CHANNELS;
use core::sync::atomic::{compiler_fence, AtomicU16, AtomicU32, Ordering};

pub use crate::platform::chip::adc_dma::{HALF_WORDS, RING_WORDS};
/// Whole scans the ring holds.
const RING_SCANS: usize = RING_WORDS / CHANNELS;
/// Bytes of one ring word (the AD7689's 16-bit result).
const WORD_BYTES: u32 = core::mem::size_of::<u16>() as u32;

const _: () = assert!(HALF_WORDS % CHANNELS == 0, "each half holds whole scans");

/// Why the DMA position cannot be used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PositionError {
    /// The destination address is neither the skip word nor inside the ring, or is odd.
    OutsideRing(u32),
}

/// Counts completed half rings; incremented by the GPDMA terminal-count interrupt.
#[derive(Debug, Default)]
pub struct HalfCounter(AtomicU32);

impl HalfCounter {
    /// No half completed.
    pub const fn new() -> Self {
        Self(AtomicU32::new(0))
    }

    /// The interrupt's work: one more half completed.
    pub fn on_terminal_count(&self) {
        // The only writer: a load/store pair is enough (no read-modify-write race).
        let n = self.0.load(Ordering::Relaxed);
        self.0.store(n.wrapping_add(1), Ordering::Release);
    }

    /// Halves completed so far.
    pub fn get(&self) -> u32 {
        self.0.load(Ordering::Acquire)
    }
}

/// Total words the RX channel has written into the ring (wrapping at 2^32), from the number
/// of completed halves and the channel's destination address. Before the ring starts (the
/// address still at `skip`) that is 0. The interrupt may lag the DMA by less than one half:
/// an address past the half the counter expects means that half is done but not yet counted.
#[inline]
pub fn words_written(halves: u32, dst: u32, ring: u32, skip: u32) -> Result<u32, PositionError> {
    let ring_bytes = RING_WORDS as u32 * WORD_BYTES;
    if dst == skip && halves == 0 {
        return Ok(0);
    }
    let offset = dst.wrapping_sub(ring);
    if offset > ring_bytes || offset % WORD_BYTES != 0 {
        return Err(PositionError::OutsideRing(dst));
    }
    let o = offset / WORD_BYTES;
    let n = RING_WORDS as u32;
    let half_start = (halves % 2) * HALF_WORDS as u32;
    // Words past the start of the half being written according to the counter, modulo the
    // ring: `o == n` (end of half B before the reload) reads as half B full while the
    // counter expects B, and as half A not started once B is counted.
    let into = (o + n - half_start) % n;
    Ok(halves.wrapping_mul(HALF_WORDS as u32).wrapping_add(into))
}

/// What one drain did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DrainReport {
    /// Whole scans added to the sampler.
    pub scans: u32,
    /// Scans skipped because the DMA had (nearly) lapped the reader.
    pub skipped: u32,
    /// `true` when the DMA overwrote words while they were being read (the drain ran too
    /// long or was pre-empted too long): the scans of this drain may mix two laps.
    pub torn: bool,
}

/// Words the reader keeps between itself and the DMA's write position: a drain that starts
/// further behind than `RING_WORDS - GUARD_WORDS` jumps ahead, so the DMA (one word per 4 us)
/// cannot reach the words being read unless the drain is held up for ~1 ms.
pub const GUARD_WORDS: u32 = RING_WORDS as u32 / 4;

/// The PDI task's side of the ring: whole scans, each word tagged by its position (the RX
/// list puts IN0 at ring index 0, and every half is a whole number of scans).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ScanReader {
    /// Words consumed (a multiple of [`CHANNELS`], wrapping with [`words_written`]).
    read: u32,
    skipped: u32,
    torn: u32,
}

impl ScanReader {
    /// A reader at the start of the ring.
    pub const fn new() -> Self {
        Self {
            read: 0,
            skipped: 0,
            torn: 0,
        }
    }

    /// Scans skipped so far (lapped by the DMA).
    pub const fn skipped(&self) -> u32 {
        self.skipped
    }

    /// Drains that were overwritten while reading.
    pub const fn torn(&self) -> u32 {
        self.torn
    }

    /// Adds every whole scan the DMA has written since the last drain to `sampler`.
    /// `written` is [`words_written`] of the moment (called twice: before and after).
    pub fn drain(
        &mut self,
        ring: &[AtomicU16; RING_WORDS],
        mut written: impl FnMut() -> Result<u32, PositionError>,
        sampler: &mut Sampler,
    ) -> Result<DrainReport, PositionError> {
        let mut report = DrainReport::default();
        let end = written()?;
        // The words before `end` are in memory before we read them.
        compiler_fence(Ordering::Acquire);
        let behind = end.wrapping_sub(self.read);
        if behind > RING_WORDS as u32 - GUARD_WORDS {
            // Keep the newest half ring, aligned to a scan.
            let from = align_down(end.wrapping_sub(HALF_WORDS as u32));
            report.skipped = from.wrapping_sub(self.read) / CHANNELS as u32;
            self.skipped = self.skipped.wrapping_add(report.skipped);
            self.read = from;
        }
        let first = self.read;
        while end.wrapping_sub(self.read) >= CHANNELS as u32 {
            // The start of a whole scan: `read` stays scan-aligned and the ring holds whole
            // scans (computed from the scan number, so the compiler sees it in range too).
            let at = self.read as usize / CHANNELS % RING_SCANS * CHANNELS;
            // Always `Some`; checked instead of indexed so no input can make the drain panic.
            let Some(scan) = ring
                .get(at..at + CHANNELS)
                .and_then(|s| <&[AtomicU16; CHANNELS]>::try_from(s).ok())
            else {
                break;
            };
            sampler.add_whole_scan(scan, |w| w.load(Ordering::Relaxed));
            self.read = self.read.wrapping_add(CHANNELS as u32);
            report.scans += 1;
        }
        compiler_fence(Ordering::Acquire);
        // The oldest word read must not have been overwritten meanwhile: the DMA writes index
        // i over index i - RING_WORDS.
        if report.scans > 0 && written()?.wrapping_sub(first) > RING_WORDS as u32 {
            report.torn = true;
            self.torn = self.torn.wrapping_add(1);
        }
        Ok(report)
    }
}

const fn align_down(words: u32) -> u32 {
    words - words % CHANNELS as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::analog::sampler::PublishMode;

    /// Any addresses: the skip word and a ring after it.
    const SKIP: u32 = 0x1000;
    const RING: u32 = 0x1010;

    #[test]
    fn words_written_at_the_half_boundaries() {
        assert_eq!(words_written(0, SKIP, RING, SKIP), Ok(0));
        assert_eq!(words_written(0, RING + 2 * 7, RING, SKIP), Ok(7));
        // At the end of half B before the reload (address one past the ring).
        assert_eq!(
            words_written(1, RING + 2 * RING_WORDS as u32, RING, SKIP),
            Ok(1024)
        );
        // The same address once half B is counted too.
        assert_eq!(
            words_written(2, RING + 2 * RING_WORDS as u32, RING, SKIP),
            Ok(1024)
        );
        // The address between the halves: half A done, counted (5) or not yet (4).
        let between = RING + 2 * HALF_WORDS as u32;
        assert_eq!(words_written(5, between, RING, SKIP), Ok(5 * 512));
        assert_eq!(words_written(4, between, RING, SKIP), Ok(5 * 512));
    }

    #[test]
    fn position_outside_the_ring_is_an_error() {
        for dst in [RING - 2, RING + 2 * RING_WORDS as u32 + 2, RING + 3, 0] {
            assert_eq!(
                words_written(3, dst, RING, SKIP),
                Err(PositionError::OutsideRing(dst))
            );
        }
        // The skip word after the ring has started is wrong too.
        assert_eq!(
            words_written(1, SKIP, RING, SKIP),
            Err(PositionError::OutsideRing(SKIP))
        );
    }

    fn ring() -> std::boxed::Box<[AtomicU16; RING_WORDS]> {
        std::boxed::Box::new(core::array::from_fn(|_| AtomicU16::new(0)))
    }

    /// The DMA writes word `total` (code = channel * 0x1000 + scan number) at its index.
    fn write(ring: &[AtomicU16; RING_WORDS], total: u32) {
        let code = (total % 8) as u16 * 0x1000 + (total / 8 % 0x1000) as u16;
        ring[total as usize % RING_WORDS].store(code, Ordering::Relaxed);
    }

    #[test]
    fn drain_takes_whole_scans_tagged_by_position() {
        let r = ring();
        let mut reader = ScanReader::new();
        let mut s = Sampler::new(PublishMode::Latest);
        for t in 0..8 * 3 + 5 {
            write(&r, t);
        }
        let rep = reader.drain(&r, || Ok(8 * 3 + 5), &mut s).unwrap();
        assert_eq!(
            rep,
            DrainReport {
                scans: 3,
                skipped: 0,
                torn: false
            }
        );
        s.publish();
        for ch in 0..8 {
            assert_eq!(s.code(ch), Some(ch as u16 * 0x1000 + 2), "channel {ch}");
        }
        // The partial scan stays for the next drain.
        for t in 29..8 * 4 {
            write(&r, t);
        }
        let rep = reader.drain(&r, || Ok(32), &mut s).unwrap();
        assert_eq!(rep.scans, 1);
        s.publish();
        assert_eq!(s.code(7), Some(0x7000 + 3));
        assert_eq!(reader.drain(&r, || Ok(32), &mut s).unwrap().scans, 0);
    }

    #[test]
    fn drain_follows_the_dma_over_many_laps_with_wrapping_counts() {
        let r = ring();
        let mut reader = ScanReader::new();
        let mut s = Sampler::new(PublishMode::Average);
        // Start near the u32 wrap to cover it.
        let start = u32::MAX - 3 * RING_WORDS as u32 + 1;
        reader.read = start;
        let mut t = start;
        let mut scans = 0;
        for step in [8u32, 13, 300, 3, 700, 64, 1] {
            for _ in 0..step * 8 / 8 {
                write(&r, t);
                t = t.wrapping_add(1);
            }
            let rep = reader.drain(&r, || Ok(t), &mut s).unwrap();
            assert_eq!(rep.skipped, 0);
            assert!(!rep.torn);
            scans += rep.scans;
        }
        assert_eq!(scans, t.wrapping_sub(start) / 8);
        assert_eq!(reader.read, align_down_wrapping(t, start));
    }

    fn align_down_wrapping(t: u32, start: u32) -> u32 {
        start.wrapping_add(align_down(t.wrapping_sub(start)))
    }

    #[test]
    fn lapped_reader_skips_to_the_newest_half_and_counts_it() {
        let r = ring();
        let mut reader = ScanReader::new();
        let mut s = Sampler::new(PublishMode::Latest);
        let end = 3 * RING_WORDS as u32 + 20;
        for t in 0..end {
            write(&r, t);
        }
        let rep = reader.drain(&r, || Ok(end), &mut s).unwrap();
        let from = align_down(end - HALF_WORDS as u32);
        assert_eq!(rep.skipped, from / 8);
        assert_eq!(rep.scans, (end - from) / 8);
        assert!(!rep.torn);
        assert_eq!(reader.skipped(), from / 8);
        s.publish();
        let last_scan = (end / 8 - 1) as u16;
        for ch in 0..8 {
            assert_eq!(s.code(ch), Some(ch as u16 * 0x1000 + last_scan));
        }
    }

    /// A fresh reader's drain where the DMA position reads `before`, then `after`.
    fn drain_between(before: u32, after: u32) -> (DrainReport, ScanReader) {
        let r = ring();
        let mut reader = ScanReader::new();
        let mut s = Sampler::new(PublishMode::Latest);
        let mut calls = 0;
        let position = || {
            calls += 1;
            Ok(if calls == 1 { before } else { after })
        };
        let rep = reader.drain(&r, position, &mut s).unwrap();
        (rep, reader)
    }

    #[test]
    fn overwrite_during_the_drain_is_reported() {
        // As far behind as allowed, and the drain was held up: the DMA ran past the oldest word.
        let (rep, reader) = drain_between(RING_WORDS as u32 - GUARD_WORDS, RING_WORDS as u32 + 1);
        assert!(rep.torn);
        assert_eq!(reader.torn(), 1);
        // Exactly one lap ahead of the oldest word is still intact.
        let (rep, reader) = drain_between(8, RING_WORDS as u32);
        assert!(!rep.torn);
        assert_eq!(reader.torn(), 0);
    }

    #[test]
    fn bad_position_stops_the_drain() {
        let r = ring();
        let mut reader = ScanReader::new();
        let mut s = Sampler::new(PublishMode::Latest);
        let e = reader.drain(&r, || Err(PositionError::OutsideRing(4)), &mut s);
        assert_eq!(e, Err(PositionError::OutsideRing(4)));
        assert_eq!(s.received(), 0);
    }

    #[test]
    fn half_counter_counts() {
        let c = HalfCounter::new();
        for _ in 0..5 {
            c.on_terminal_count();
        }
        assert_eq!(c.get(), 5);
    }
}
