use super::*;
use std::boxed::Box;
use std::vec::Vec;

#[test]
fn assignment_split_and_order_rule() {
    let ok = |pdos: &[u16]| InputBlocks::split(pdos).unwrap();
    assert_eq!(ok(&[0x1A00]), (1, InputBlocks::NONE));
    assert_eq!(
        ok(&[0x1A00, 0x1A10, 0x1A11, 0x1A20, 0x1A21]),
        (
            1,
            InputBlocks {
                status: true,
                time: true,
                sample_pdos: 2
            }
        )
    );
    let all: Vec<u16> = [0x1A10]
        .into_iter()
        .chain((0..8).map(|b| 0x1A20 + b))
        .collect();
    let (plain, blocks) = ok(&all);
    assert_eq!(
        (plain, blocks.slots(), blocks.byte_len()),
        (0, 256, 6 + 512)
    );
    assert_eq!(ok(&[0x1A10]).1.byte_len(), 6);
    for bad in [
        &[0x1A20][..],             // no status
        &[0x1A10, 0x1A21],         // a gap
        &[0x1A10, 0x1A20, 0x1A20], // twice
        &[0x1A10, 0x1A20, 0x1A11], // time after samples
        &[0x1A10, 0x1A00],         // a plain PDO after the blocks
        &[0x1A11, 0x1A10],         // time before status
        &[0x1A10, 0x1A20, 0x1A22], // skipped
        &[0x1A10, 0x1A11, 0x1A11], // time twice
    ] {
        assert_eq!(
            InputBlocks::split(bad),
            Err(SdoAbortCode::ParameterIncompatible),
            "{bad:x?}"
        );
    }
    assert_eq!(InputBlocks::pdo_bits(0x1A10), Some(48));
    assert_eq!(InputBlocks::pdo_bits(0x1A11), Some(64));
    assert_eq!(InputBlocks::pdo_bits(0x1A27), Some(512));
    assert_eq!(InputBlocks::pdo_bits(0x1A28), None);
    assert_eq!(InputBlocks::pdo_bits(0x1A00), None);
}

#[test]
fn the_block_pdos_are_the_ones_the_split_knows() {
    assert!((0x1A00..0x1C00).all(|p| InputBlocks::is_block_pdo(p) == InputBlocks::PDOS.contains(p)));
}

fn blocks(sample_pdos: u8) -> InputBlocks {
    InputBlocks {
        status: true,
        time: true,
        sample_pdos,
    }
}

#[test]
fn admission_codes() {
    let b = blocks(8);
    assert_eq!(admit(&InputBlocks::NONE, 16, 4, None), Ok(()));
    assert_eq!(
        admit(&b, 526, 4, None),
        Err(AlStatusCode::InvalidDcSyncConfiguration)
    );
    assert_eq!(admit(&b, 526, 4, Some(1_000_000)), Ok(()));
    // 1 ms needs 32 scans = 256 slots: 7 PDOs are too few.
    assert_eq!(
        admit(&blocks(7), 462, 4, Some(1_000_000)),
        Err(AlStatusCode::InvalidInputConfiguration)
    );
    // 250 us: 8 scans, 2 PDOs.
    assert_eq!(admit(&blocks(2), 142, 4, Some(250_000)), Ok(()));
    assert_eq!(
        admit(&blocks(1), 78, 4, Some(250_000)),
        Err(AlStatusCode::InvalidInputConfiguration)
    );
    // 100 us: 4 scans fit one PDO; the status and one PDO fit the cycle without outputs
    // (70 B: 77 us of 80), not with the two outputs read twice (8 B more).
    let lean = InputBlocks {
        status: true,
        time: false,
        sample_pdos: 1,
    };
    assert_eq!(admit(&lean, 70, 0, Some(100_000)), Ok(()));
    assert_eq!(
        admit(&lean, 70, 4, Some(100_000)),
        Err(AlStatusCode::DcInvalidSyncCycleTime)
    );
}

/// A virtual ADC and SYNC0: conversion `w` at `WORD0 + w x 4 us` (MCU time), its word in
/// the ring 3 us later; SYNC0 edge `c` at `FIRST_EDGE + c x cycle` (MCU), DC time = MCU time
/// + `DC_OFFSET`; each edge polled `POLL_DELAY` after it.
const WORD0: u64 = 1_234_560;
const FIRST_EDGE: u64 = 5_000_000;
const DC_OFFSET: u64 = 7_000_000_000;
const POLL_DELAY: u64 = 3_000;

fn written_at(t: u64) -> u32 {
    if t < WORD0 + 3_000 {
        0
    } else {
        ((t - WORD0 - 3_000) / 4_000 + 1) as u32
    }
}

fn ring() -> Box<[AtomicU16; RING_WORDS]> {
    Box::new(core::array::from_fn(|_| AtomicU16::new(0)))
}

/// Runs `cycles` edges of `cycle_ns` and returns the blocks (after the starting edge).
fn run(stream: &mut SampleStream, cycle_ns: u64, cycles: u64, skip: &[u64]) -> Vec<Block> {
    stream.set_word0(WORD0);
    let mut out = Vec::new();
    for c in 0..=cycles {
        if skip.contains(&c) {
            continue;
        }
        let edge = FIRST_EDGE + c * cycle_ns;
        let now = edge + POLL_DELAY;
        stream.set_written(written_at(now));
        stream.on_edge(now, edge as u32, 0);
        if c > 0 {
            out.push(*stream.block());
        }
    }
    out
}

#[test]
fn the_block_status_alone_counts_the_scans_and_flags_no_overrun() {
    let mut s = SampleStream::new();
    s.restart(InputBlocks {
        status: true,
        time: false,
        sample_pdos: 0,
    });
    s.set_dc_reference(1_000_000, FIRST_EDGE + DC_OFFSET, None);
    let got = run(&mut s, 1_000_000, 100, &[]);
    let mut counter = 0;
    for b in &got {
        assert_eq!((b.status, b.counter), (0, counter), "{b:?}");
        assert!((31..=32).contains(&b.scans()), "{b:?}");
        counter += u32::from(b.scans());
    }
}

#[test]
fn every_conversion_in_exactly_one_block_at_its_time() {
    for (cycle, pdos) in [
        (1_000_000u64, 8u8),
        (250_000, 2),
        (100_000, 1),
        (500_000, 4),
    ] {
        let mut s = SampleStream::new();
        s.restart(blocks(pdos));
        // The DC reference read before the first edge: that edge is at `next_dc`.
        s.set_dc_reference(cycle as u32, FIRST_EDGE + DC_OFFSET, None);
        // 5 000 cycles: past the 32-bit wrap of the edge times (4.3 s) at 1 ms.
        let got = run(&mut s, cycle, 5_000, &[]);
        let mut next_word = None;
        let mut counter = 0u32;
        let mut scans = std::collections::BTreeSet::new();
        for (c, b) in got.iter().enumerate() {
            assert_eq!(b.status, 0, "cycle {cycle}, block {c}: {b:?}");
            assert_eq!(b.counter, counter, "counter continuous");
            if let Some(n) = next_word {
                assert_eq!(b.start, n, "no gap, no overlap");
            }
            // The block's conversions lie in [edge(c) - lead, edge(c+1) - lead).
            let (edge0, edge1) = (
                FIRST_EDGE + c as u64 * cycle,
                FIRST_EDGE + (c as u64 + 1) * cycle,
            );
            let t_first = WORD0 + u64::from(b.start) * 4_000;
            let t_end = WORD0 + u64::from(b.start + b.words) * 4_000;
            assert!(t_first >= edge0 - 40_000 && t_first < edge0 - 40_000 + 32_000);
            assert!(t_end >= edge1 - 40_000 && t_end < edge1 - 40_000 + 32_000);
            assert_eq!(
                b.time_dc,
                t_first + DC_OFFSET,
                "DC time of the first conversion"
            );
            scans.insert(b.scans());
            next_word = Some(b.start + b.words);
            counter += u32::from(b.scans());
        }
        let per_cycle = cycle as f64 / 32_000.0;
        let expect: Vec<u8> = [per_cycle.floor() as u8, per_cycle.ceil() as u8]
            .into_iter()
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        assert_eq!(
            scans.into_iter().collect::<Vec<_>>(),
            expect,
            "cycle {cycle}"
        );
        // The average rate: every conversion of 5000 cycles, within one scan.
        let total = u64::from(counter) * 8;
        let want = 5_000 * cycle / 4_000;
        assert!(total.abs_diff(want) <= 8, "{total} of {want}");
    }
}

#[test]
fn reference_from_an_earlier_edge_and_missed_polls() {
    let cycle = 1_000_000u64;
    let mut s = SampleStream::new();
    s.restart(blocks(8));
    // The reference read after edge -1 (its capture known): the next edge is edge 0.
    let before = FIRST_EDGE - cycle;
    s.set_dc_reference(cycle as u32, FIRST_EDGE + DC_OFFSET, Some(before as u32));
    // Edges 5 and 6 are not polled: the block of edge 7 holds three cycles and overruns
    // its slots (the counter jumps by the scans lost).
    let got = run(&mut s, cycle, 10, &[5, 6]);
    let late = got.iter().find(|b| b.status & STATUS_OVERRUN != 0).unwrap();
    assert_eq!(late.words, 256);
    let before_late = got[got.iter().position(|b| b == late).unwrap() - 1];
    assert!(late.counter > before_late.counter + u32::from(before_late.scans()));
    for b in &got {
        assert_eq!(b.time_dc, WORD0 + u64::from(b.start) * 4_000 + DC_OFFSET);
    }
}

#[test]
fn without_dc_reference_the_block_says_not_locked() {
    let mut s = SampleStream::new();
    s.restart(blocks(8));
    let got = run(&mut s, 1_000_000, 3, &[]);
    assert!(got
        .iter()
        .all(|b| b.status == STATUS_NOT_LOCKED && b.time_dc == 0));
    assert!(got.iter().all(|b| b.scans() >= 31));
}

#[test]
fn a_lapped_ring_is_an_overrun_and_the_stream_goes_on() {
    let cycle = 1_000_000u64;
    let mut s = SampleStream::new();
    s.restart(blocks(8));
    s.set_dc_reference(cycle as u32, FIRST_EDGE + DC_OFFSET, None);
    // Edges 2..=4 lost: more than the ring (4 ms) went by.
    let got = run(&mut s, cycle, 8, &[2, 3, 4, 5]);
    let lapped = got[1];
    assert_eq!(lapped.status, STATUS_OVERRUN);
    // The following block is clean again and continues it.
    let next = got[2];
    assert_eq!(next.status, 0);
    assert_eq!(next.start, lapped.start + lapped.words);
    assert_eq!(next.counter, lapped.counter + u32::from(lapped.scans()));
}

/// A stream of four sample PDOs at `cycle` ns, its DC reference read before the first edge
/// and the ADC's grid known.
fn stream_of_4_pdos(cycle: u64) -> SampleStream {
    let mut s = SampleStream::new();
    s.restart(blocks(4));
    s.set_dc_reference(cycle as u32, FIRST_EDGE + DC_OFFSET, None);
    s.set_word0(WORD0);
    s
}

#[test]
fn an_edge_captured_after_the_callers_time_starts_the_stream_at_counter_0() {
    // The SYNC0 task preempted the PDI task between its time read and the edge's read: the
    // edge is 2 us after `now`.
    let cycle = 500_000;
    let mut s = stream_of_4_pdos(cycle);
    for c in 0..4 {
        let edge = FIRST_EDGE + c * cycle;
        let now = if c == 0 {
            edge - 2_000
        } else {
            edge + POLL_DELAY
        };
        s.set_written(written_at(now));
        s.on_edge(now, edge as u32, 0);
    }
    let b = *s.block();
    assert_eq!(b.status, 0, "no overrun: {b:?}");
    assert_eq!(u64::from(b.counter), 2 * cycle / SCAN_NS, "{b:?}");
}

#[test]
fn a_cycle_whose_outputs_held_or_were_refused_flags_the_next_block_alone() {
    let cycle = 500_000;
    let mut s = stream_of_4_pdos(cycle);
    // The update interrupt's count of held cycles at each cut: 7 already at the stream's
    // start (an earlier stream's), one more before edge 3, two more before edge 5; a block
    // refused before edge 5 and one before edge 6.
    let holds = [7, 7, 7, 8, 8, 10, 10, 10];
    let refused_before = [5, 6];
    let mut status = Vec::new();
    for (c, held) in (0u64..).zip(holds) {
        if refused_before.contains(&c) {
            s.on_output_refused();
        }
        let edge = FIRST_EDGE + c * cycle;
        let now = edge + POLL_DELAY;
        s.set_written(written_at(now));
        s.on_edge(now, edge as u32, held);
        status.push(s.block().status);
    }
    let (h, r) = (STATUS_OUTPUTS_HELD, STATUS_OUTPUTS_REFUSED);
    assert_eq!(status, [0, 0, 0, h, 0, h | r, r, 0]);
    // A new stream starts from the count it finds.
    s.restart(blocks(4));
    let edge = FIRST_EDGE + 9 * cycle;
    s.on_edge(edge + POLL_DELAY, edge as u32, 11);
    assert_eq!(s.block().status & h, 0);
}

#[test]
fn no_stream_without_oversampling_pdos_or_adc() {
    let mut s = SampleStream::new();
    s.set_word0(WORD0);
    s.on_edge(FIRST_EDGE, FIRST_EDGE as u32, 0);
    assert_eq!(s.block(), &Block::default());
    let mut s = SampleStream::new();
    s.restart(blocks(1));
    s.on_edge(FIRST_EDGE, FIRST_EDGE as u32, 0);
    assert_eq!(s.block(), &Block::default());
}

#[test]
fn image_bytes_header_time_and_samples() {
    let r = ring();
    for (i, w) in r.iter().enumerate() {
        w.store(i as u16 ^ 0xA500, Ordering::Relaxed);
    }
    let mut s = SampleStream::new();
    s.restart(blocks(1));
    s.set_dc_reference(100_000, FIRST_EDGE + DC_OFFSET, None);
    let got = run(&mut s, 100_000, 300, &[]);
    let b = *got.last().unwrap();
    let leaked: &'static [AtomicU16; RING_WORDS] = Box::leak(r);
    let written = s.written;
    s.set_ring(leaked, written);
    assert!(b.start as usize / RING_WORDS >= 1, "wrapped the ring");
    let mut out = [0xEEu8; 6 + 8 + 64];
    s.write(&mut out);
    assert_eq!(&out[..4], &b.counter.to_le_bytes());
    assert_eq!(out[4], b.scans());
    assert_eq!(out[5], 0);
    assert_eq!(&out[6..14], &b.time_dc.to_le_bytes());
    let words = b.words as usize;
    for k in 0..32 {
        let v = u16::from_le_bytes([out[14 + 2 * k], out[15 + 2 * k]]);
        let want = if k < words {
            ((b.start as usize + k) % RING_WORDS) as u16 ^ 0xA500
        } else {
            0
        };
        assert_eq!(v, want, "slot {k}");
    }
    // Without a ring (a harness without the DMA) the samples read 0.
    s.ring = None;
    s.write(&mut out);
    assert!(out[14..].iter().all(|b| *b == 0));
}
