use super::*;
use std::vec;
use std::vec::Vec;

#[test]
fn split_takes_the_counter_then_update_pdos_in_order() {
    assert_eq!(
        OutputBlocks::split(&[0x1600, 0x1610, 0x1620, 0x1621]),
        Ok((
            1,
            OutputBlocks {
                counter: true,
                update_pdos: 2
            }
        ))
    );
    assert_eq!(
        OutputBlocks::split(&[0x1620]),
        Ok((
            0,
            OutputBlocks {
                counter: false,
                update_pdos: 1
            }
        ))
    );
    assert_eq!(OutputBlocks::split(&[0x1600]), Ok((1, OutputBlocks::NONE)));
    for bad in [
        &[0x1621][..],
        &[0x1620, 0x1622],
        &[0x1610],
        &[0x1620, 0x1610],
        &[0x1620, 0x1600],
        &[0x1620, 0x1621, 0x1620],
    ] {
        assert_eq!(
            OutputBlocks::split(bad),
            Err(SdoAbortCode::ParameterIncompatible),
            "{bad:x?}"
        );
    }
    let all: Vec<u16> = (0..UPDATE_PDOS as u16).map(|u| UPDATE_PDO + u).collect();
    let (_, b) = OutputBlocks::split(&all).unwrap();
    assert_eq!(b.updates(), MAX_UPDATES);
    assert_eq!(b.byte_len(), 200);
}

#[test]
fn the_block_pdos_are_the_ones_the_split_knows() {
    assert!(
        (0x1600..0x1800).all(|p| OutputBlocks::is_block_pdo(p) == OutputBlocks::PDOS.contains(p))
    );
}

#[test]
fn pdo_lengths() {
    assert_eq!(OutputBlocks::pdo_bits(0x1610), Some(16));
    assert_eq!(OutputBlocks::pdo_bits(0x1620), Some(160));
    assert_eq!(OutputBlocks::pdo_bits(0x1629), Some(160));
    assert_eq!(OutputBlocks::pdo_bits(0x162A), None);
    assert_eq!(OutputBlocks::pdo_bits(0x1600), None);
}

fn blocks(update_pdos: u8) -> OutputBlocks {
    OutputBlocks {
        counter: false,
        update_pdos,
    }
}

#[test]
fn admission_refuses_what_cannot_be_served() {
    // 1 ms, 50 updates: 20 us, 2 000 ticks.
    assert_eq!(
        admit(&blocks(10), 0, 200, Some(1_000_000)),
        Ok(Some(Grid {
            period: 2_000,
            updates: 50
        }))
    );
    // 1 ms, 20 updates (50 us), with the full input stream (526 B).
    assert_eq!(
        admit(&blocks(4), 526, 80, Some(1_000_000)),
        Ok(Some(Grid {
            period: 5_000,
            updates: 20
        }))
    );
    // 250 us, 5 updates: 50 us.
    assert_eq!(
        admit(&blocks(1), 142, 20, Some(250_000)),
        Ok(Some(Grid {
            period: 5_000,
            updates: 5
        }))
    );
    let g = Grid {
        period: 100_000,
        updates: 50,
    };
    assert_eq!(Grid::unpack(g.pack()), g);
    // Nothing assigned: nothing to check.
    assert_eq!(admit(&OutputBlocks::NONE, 0, 4, None), Ok(None));
    // No DC.
    assert_eq!(
        admit(&blocks(1), 0, 20, None),
        Err(AlStatusCode::InvalidDcSyncConfiguration)
    );
    assert_eq!(
        admit(&blocks(1), 0, 20, Some(0)),
        Err(AlStatusCode::InvalidDcSyncConfiguration)
    );
    // 100 us / 15 is not whole; 100 us / 50 is 2 us (below 10 us).
    assert_eq!(
        admit(&blocks(3), 0, 60, Some(100_000)),
        Err(AlStatusCode::InvalidOutputConfiguration)
    );
    assert_eq!(
        admit(&blocks(10), 0, 200, Some(100_000)),
        Err(AlStatusCode::InvalidOutputConfiguration)
    );
    // 1 ms / 5 = 200 us is whole but 1 000 005 ns / 5 is not a whole tick.
    assert_eq!(
        admit(&blocks(1), 0, 20, Some(1_000_005)),
        Err(AlStatusCode::InvalidOutputConfiguration)
    );
    // 250 us, 25 updates (10 us) with the inputs: the bus does not fit.
    assert_eq!(
        admit(&blocks(5), 142, 100, Some(250_000)),
        Err(AlStatusCode::DcInvalidSyncCycleTime)
    );
}

#[test]
fn decode_reads_interleaved_little_endian_pairs() {
    let image = [0x34, 0x12, 0x78, 0x56, 0xFF, 0xFF, 0x00, 0x00, 0xAA];
    let mut out = [DacPair::default(); 4];
    assert_eq!(decode(&image, &mut out), 2);
    assert_eq!(out[0], DacPair::new(0x1234, 0x5678));
    assert_eq!(out[1], DacPair::new(0xFFFF, 0));
    assert_eq!(out[2], DacPair::default());
}

fn pairs(base: u16, n: usize) -> Vec<DacPair> {
    (0..n as u16)
        .map(|k| DacPair::new(base + k, base + 100 + k))
        .collect()
}

/// Plays `cycles` cycles of n updates; before cycle c (SYNC0 edge c + 1, the edge count
/// then being c) `publish(c)` may publish. Returns what each update interrupt wrote.
fn play(
    n: u32,
    ring: &UpdateRing,
    cycles: u32,
    mut publish: impl FnMut(u32, &UpdateRing),
) -> Vec<Option<DacPair>> {
    let mut p = UpdatePlayer::new(n);
    let mut out = Vec::new();
    // The edges between SYNC0 edge c (count c) and the next; the update before edge c + 1
    // takes block c + 1.
    for c in 0..cycles {
        p.on_sync0();
        publish(c, ring);
        for _ in 0..n {
            out.push(p.after_edge(ring, c));
        }
    }
    out
}

#[test]
fn a_block_plays_from_the_edge_it_was_published_for() {
    let ring = UpdateRing::new();
    let n = 5;
    let out = play(n, &ring, 4, |c, r| {
        if c >= 1 {
            r.publish(&pairs(c as u16 * 10, n as usize), c + 1);
        }
    });
    // Cycle 0 and 1 up to its publication: nothing published yet, so nothing plays (not an
    // underrun: the ring has not started). Cycle 1 publishes block 2, written from the last
    // interrupt of cycle 1 on: update 0 of block 2 before edge 2, updates 1..4 in cycle 2.
    assert!(out[..9].iter().all(Option::is_none), "{out:?}");
    assert_eq!(out[9], Some(DacPair::new(10, 110)));
    assert_eq!(out[10], Some(DacPair::new(11, 111)));
    assert_eq!(out[13], Some(DacPair::new(14, 114)));
    assert_eq!(out[14], Some(DacPair::new(20, 120)));
    assert_eq!(ring.underruns(), 0);
}

#[test]
fn a_late_block_is_not_played_and_the_outputs_hold() {
    let ring = UpdateRing::new();
    let n = 5;
    let out = play(n, &ring, 4, |c, r| {
        // Block for edge 2 published only after edge 2 (late); the next one in time.
        match c {
            0 => r.publish(&pairs(0, 5), 1),
            2 => r.publish(&pairs(20, 5), 2),
            _ => {}
        }
    });
    // Block 1 plays (its update 0 written at the end of cycle 0).
    assert_eq!(out[4], Some(DacPair::new(0, 100)));
    assert_eq!(out[8], Some(DacPair::new(4, 104)));
    // Before edge 2 nothing for edge 2: hold through cycle 2 and the late block never plays.
    assert!(out[9..].iter().all(Option::is_none), "{out:?}");
    assert_eq!(ring.underruns(), 3);
}

#[test]
fn stop_ends_the_playing_at_once() {
    let ring = UpdateRing::new();
    let mut p = UpdatePlayer::new(5);
    p.on_sync0();
    ring.publish(&pairs(0, 5), 1);
    for _ in 0..4 {
        assert_eq!(p.after_edge(&ring, 0), None);
    }
    assert_eq!(p.after_edge(&ring, 0), Some(DacPair::new(0, 100)));
    p.on_sync0();
    assert_eq!(p.after_edge(&ring, 1), Some(DacPair::new(1, 101)));
    ring.stop();
    for _ in 0..10 {
        assert_eq!(p.after_edge(&ring, 1), None);
    }
}

/// PWM1 as the lock sees it: the falling edges (TC = MR4) in absolute ticks, given the
/// periods the lock asks for.
#[test]
fn the_grid_locks_to_the_edge_in_one_correction() {
    for offset in [0u32, 1, 7, 18, 19, 500, 1_999] {
        let p = 2_000u32;
        let mut lock = GridLock::new(p);
        // TC was 0 at tick `offset`; SYNC0 edges every 20 periods from tick 100 000.
        let edge = 100_000u32;
        let tc = (edge - offset) % p;
        let mr0 = lock.on_edge(tc);
        let mut t = edge - tc; // start of the PWM cycle holding the edge
        let mut falls = Vec::new();
        let mut periods = vec![p; 3];
        match mr0 {
            // Written after the edge: takes effect at the next cycle start.
            Some(m) => periods[1] = m + 1,
            None => assert_eq!((tc + p - lock.mr4()) % p, 0),
        }
        for len in periods {
            falls.push(t + lock.mr4());
            t += len;
        }
        let last = *falls.last().unwrap();
        assert_eq!((last - edge) % p, 0, "offset {offset}: {falls:?}");
        if mr0.is_some() {
            assert_eq!(
                lock.on_edge(0),
                None,
                "no second correction before the restore"
            );
            assert_eq!(lock.restore(false), None);
            assert_eq!(lock.restore(true), Some(p - 1));
            assert_eq!(lock.restore(true), None);
        }
        // Every corrected period still has its falling edge (MR4 inside the period).
        if let Some(m) = mr0 {
            assert!(m > lock.mr4(), "offset {offset}");
        }
    }
}

#[test]
fn a_second_block_for_the_same_edge_is_dropped() {
    let ring = UpdateRing::new();
    let mut p = UpdatePlayer::new(2);
    ring.publish(&pairs(0, 2), 1);
    p.on_sync0();
    assert_eq!(p.after_edge(&ring, 0), None);
    assert_eq!(p.after_edge(&ring, 0), Some(DacPair::new(0, 100)));
    // Edge 1: block 1 plays; block 2 comes, then another for edge 2 (dropped: it would
    // overwrite the half playing).
    p.on_sync0();
    ring.publish(&pairs(20, 2), 2);
    ring.publish(&pairs(50, 2), 2);
    assert!(ring.has_block_for(2));
    assert_eq!(p.after_edge(&ring, 1), Some(DacPair::new(1, 101)));
    assert_eq!(p.after_edge(&ring, 1), Some(DacPair::new(20, 120)));
    p.on_sync0();
    assert_eq!(p.after_edge(&ring, 2), Some(DacPair::new(21, 121)));
}
