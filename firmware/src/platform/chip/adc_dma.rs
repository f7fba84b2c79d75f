//! The AD7689 scan on Timer2 and the GPDMA (hardware-facts 10.B): the Timer2 timing and the
//! three channels' linked lists. Plain data and arithmetic, tested on the host against a
//! model of the GPDMA's list walk and against the `ad7689` driver; the register writes are
//! the firmware binary's (`hw::adc_dma`), the reading of the ring the application's
//! (`crate::io::analog::adc_dma`).
//!
//! ```text
//!  Timer2 (TC 0..PERIOD-1, MR3 resets)
//!   MR0 match --toggle--> MAT2.0 = CNV      (rises at CNV_RISE, falls at CNV_FALL)
//!   MR0 match --DMA req 12--> ch CNV: MR0 <- [CNV_FALL, CNV_RISE] (circular list)
//!   MR1 match --DMA req 13--> ch TX:  SSP1 DR <- CFG, CFG, 0, 0, 0 ...  (one 16-bit frame)
//!  SSP1 RX  --DMA req 3---> ch RX:  3 start-up dummies -> skip word, then
//!                                   ring half A (TC irq) -> ring half B (TC irq) -> half A ...
//! ```

use super::gpdma::{control, control_word, Chain, Lli, Width};
use crate::platform::adc_scan::{CFG_FRAMES, FIRST_RESULT, SCAN_CFG_WORD};

/// Words of the sample ring (two halves of [`HALF_WORDS`]): ~4.1 ms at 250 kSPS.
pub const RING_WORDS: usize = 1024;
/// Words per half ring (one terminal-count interrupt each).
pub const HALF_WORDS: usize = RING_WORDS / 2;

// ---------------------------------------------------------------- timing (Timer2 ticks)

/// Timer2 tick: PCLK 100 MHz, PR = 0.
pub const TICK_NS: u32 = 10;
/// Sample period (MR3 + 1 ticks): 4 us = 250 kSPS aggregate, 31.25 kSPS per channel.
pub const PERIOD_TICKS: u32 = 400;
/// CNV rises at this TC value (MR0's first value).
pub const CNV_RISE: u32 = 1;
/// CNV stays high tCONV max plus 100 ns of margin (2.3 us), then falls: the result is on SDO.
pub const CNV_FALL: u32 = CNV_RISE + T_CONV_MAX_TICKS + 10;
/// The TX frame is requested 20 ns after CNV falls (CNV low to first SCK >= 10 ns).
pub const FRAME_START: u32 = CNV_FALL + 2;
/// SSP1 SCK in Hz (`hw::ssp::SspConfig::AD7689`: 100 MHz / 6).
pub const SCK_HZ: u32 = 16_666_666;
/// Ticks of one 16-bit frame, rounded up, plus 20 ticks of DMA request latency and AHB/APB
/// arbitration (an allowance, not a datasheet figure).
pub const FRAME_TICKS: u32 = (16 * (1_000_000_000 / TICK_NS)).div_ceil(SCK_HZ) + 20;
/// Quiet time before the next CNV rise (hardware-facts 6: ~20 ns).
pub const QUIET_TICKS: u32 = 2;
/// tCONV max in ticks (the driver's `ad7689::unconfirmed::T_CONV_MAX_NS`, hardware-facts 6;
/// UNCONFIRMED for the AD7689 itself, kept in that one place).
pub const T_CONV_MAX_TICKS: u32 = ad7689::unconfirmed::T_CONV_MAX_NS.div_ceil(TICK_NS);
/// tACQ min in ticks (end of conversion to the next rise; `ad7689::unconfirmed::T_ACQ_MIN_NS`).
pub const T_ACQ_MIN_TICKS: u32 = ad7689::unconfirmed::T_ACQ_MIN_NS.div_ceil(TICK_NS);

/// The two MR0 values the CNV channel writes in turn: after the rise, the fall; after the
/// fall, the next rise.
pub const MR0_SEQUENCE: [u32; 2] = [CNV_FALL, CNV_RISE];

const _: () = assert!(CNV_FALL - CNV_RISE >= T_CONV_MAX_TICKS);
const _: () = assert!(PERIOD_TICKS - T_CONV_MAX_TICKS >= T_ACQ_MIN_TICKS);
const _: () = assert!(FRAME_START + FRAME_TICKS + QUIET_TICKS <= PERIOD_TICKS + CNV_RISE);
const _: () = assert!(CNV_RISE < CNV_FALL && CNV_FALL < FRAME_START && FRAME_START < PERIOD_TICKS);

// ---------------------------------------------------------------- the three channel lists

/// Start-up frames that hold no scan result (the CFG pipeline, `adc_scan`).
pub const SKIP_FRAMES: u32 = FIRST_RESULT;
/// From Timer2's start (TC = 0) to the conversion whose result is ring word 0, in ns: the
/// CNV rise (the AD7689 samples there) of period [`SKIP_FRAMES`] (each period's frame reads
/// that period's conversion; the first results go to the skip word). Ring word `w` is the
/// conversion `w x` [`PERIOD_TICKS`] ticks later.
pub const fn word0_after_start_ns() -> u64 {
    (SKIP_FRAMES as u64 * PERIOD_TICKS as u64 + CNV_RISE as u64) * TICK_NS as u64
}

/// Transfers of the TX channel's NOP item before it reloads itself.
pub const NOP_TRANSFERS: u32 = control::MAX_TRANSFERS;

const _: () = assert!(HALF_WORDS as u32 <= control::MAX_TRANSFERS);

/// Where the RX channel's lists point (addresses in the GPDMA's reach, i.e. AHB SRAM).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RxAddresses {
    /// SSP1 DR.
    pub ssp_dr: u32,
    /// A half-word that swallows the start-up dummies.
    pub skip: u32,
    /// The ring ([`RING_WORDS`] half-words).
    pub ring: u32,
    /// Where the two ring items are stored.
    pub items: [u32; 2],
}

/// RX: the [`SKIP_FRAMES`] dummies into `skip`, then ring half A, half B, half A ... with a
/// terminal-count interrupt at the end of each half.
pub const fn rx_chain(a: RxAddresses) -> Chain<2> {
    let half = control_word(HALF_WORDS as u32, Width::Half, false, true, true);
    let half_bytes = HALF_WORDS as u32 * Width::Half.bytes();
    Chain {
        first: Lli {
            src: a.ssp_dr,
            dst: a.skip,
            next: a.items[0],
            control: control_word(SKIP_FRAMES, Width::Half, false, false, false),
        },
        items: [
            Lli {
                src: a.ssp_dr,
                dst: a.ring,
                next: a.items[1],
                control: half,
            },
            Lli {
                src: a.ssp_dr,
                dst: a.ring + half_bytes,
                next: a.items[0],
                control: half,
            },
        ],
    }
}

/// Where the TX channel's lists point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TxAddresses {
    /// SSP1 DR.
    pub ssp_dr: u32,
    /// A half-word holding [`TX_WORDS`]`[0]` (the CFG).
    pub cfg: u32,
    /// A half-word holding [`TX_WORDS`]`[1]` (the NOP).
    pub nop: u32,
    /// Where the NOP item is stored.
    pub item: u32,
}

/// The words the TX channel sends from: the CFG (start-up) and the NOP (DIN low keeps the
/// CFG while the sequencer runs: bit 13 = 0, hardware-facts 6).
pub const TX_WORDS: [u16; 2] = [SCAN_CFG_WORD, 0];

/// TX: the CFG in the first two frames (`adc_scan`'s start-up), then the NOP for ever (one item that
/// links to itself; no interrupt).
pub const fn tx_chain(a: TxAddresses) -> Chain<1> {
    Chain {
        first: Lli {
            src: a.cfg,
            dst: a.ssp_dr,
            next: a.item,
            control: control_word(CFG_FRAMES, Width::Half, false, false, false),
        },
        items: [Lli {
            src: a.nop,
            dst: a.ssp_dr,
            next: a.item,
            control: control_word(NOP_TRANSFERS, Width::Half, false, false, false),
        }],
    }
}

/// Where the CNV channel's lists point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CnvAddresses {
    /// Timer2 MR0.
    pub mr0: u32,
    /// Two words holding [`MR0_SEQUENCE`].
    pub table: u32,
    /// Where the item is stored.
    pub item: u32,
}

/// CNV: MR0 <- CNV_FALL at the rise, MR0 <- CNV_RISE at the fall, for ever (one item of two
/// transfers that links to itself, which also rewinds the source).
pub const fn cnv_chain(a: CnvAddresses) -> Chain<1> {
    let item = Lli {
        src: a.table,
        dst: a.mr0,
        next: a.item,
        control: control_word(MR0_SEQUENCE.len() as u32, Width::Word, true, false, false),
    };
    Chain {
        first: item,
        items: [item],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::analog::adc_dma::{words_written, RING_WORDS};
    use crate::platform::adc_scan::{ScanPipeline, SCAN_CONFIG};
    use crate::platform::chip::gpdma::model::ChannelModel;
    use ad7689::{Ad7689, Channel};
    use core::sync::atomic::{AtomicU16, Ordering};
    use embedded_hal_mock::eh1::delay::NoopDelay;
    use embedded_hal_mock::eh1::spi::{Mock, Transaction};
    use std::collections::BTreeMap;
    use std::vec::Vec;

    const SSP_DR: u32 = 0x4003_0008;
    const MR0: u32 = 0x4009_0018;
    const SKIP: u32 = 0x2007_C000;
    const RING: u32 = 0x2007_C010;

    fn rx_addresses() -> RxAddresses {
        RxAddresses {
            ssp_dr: SSP_DR,
            skip: SKIP,
            ring: RING,
            items: [0x2007_D000, 0x2007_D010],
        }
    }

    fn ring() -> std::boxed::Box<[AtomicU16; RING_WORDS]> {
        std::boxed::Box::new(core::array::from_fn(|_| AtomicU16::new(0)))
    }

    #[test]
    fn rx_list_skips_the_dummies_then_cycles_the_two_halves() {
        let a = rx_addresses();
        let mut ch = ChannelModel::new(rx_chain(a), a.items);
        for _ in 0..SKIP_FRAMES {
            let (src, dst, tc) = ch.request().unwrap();
            assert_eq!((src, dst, tc), (SSP_DR, SKIP, false));
        }
        for lap in 0..3u32 {
            for i in 0..RING_WORDS as u32 {
                let (src, dst, tc) = ch.request().unwrap();
                assert_eq!(src, SSP_DR);
                assert_eq!(dst, RING + 2 * i, "lap {lap} word {i}");
                assert_eq!(tc, i as usize % HALF_WORDS == HALF_WORDS - 1, "word {i}");
            }
        }
    }

    #[test]
    fn tx_list_sends_the_cfg_twice_then_nops_across_reloads() {
        let a = TxAddresses {
            ssp_dr: SSP_DR,
            cfg: 0x2007_E000,
            nop: 0x2007_E002,
            item: 0x2007_E010,
        };
        let words = BTreeMap::from([(a.cfg, TX_WORDS[0]), (a.nop, TX_WORDS[1])]);
        let mut ch = ChannelModel::new(tx_chain(a), [a.item]);
        let mut p = ScanPipeline::new();
        for frame in 0..3 * NOP_TRANSFERS {
            let (src, dst, tc) = ch.request().unwrap();
            assert_eq!(dst, SSP_DR);
            assert!(!tc);
            assert_eq!(words[&src], p.next_tx(), "frame {frame}");
            p.on_rx();
        }
        // The NOP keeps the sequencer's CFG: bit 13 (overwrite) of CFG << 2 is 0.
        assert_eq!(TX_WORDS[1] & (1 << 15), 0);
    }

    #[test]
    fn cnv_list_alternates_fall_and_rise() {
        let a = CnvAddresses {
            mr0: MR0,
            table: 0x2007_F000,
            item: 0x2007_F010,
        };
        let mut ch = ChannelModel::new(cnv_chain(a), [a.item]);
        for k in 0..10u32 {
            let (src, dst, tc) = ch.request().unwrap();
            assert_eq!(dst, MR0);
            assert!(!tc);
            // Request k comes from match k: even = at the rise (next: fall), odd = at the fall.
            assert_eq!(src, a.table + 4 * (k % 2));
            assert_eq!(
                MR0_SEQUENCE[(k % 2) as usize],
                if k % 2 == 0 { CNV_FALL } else { CNV_RISE }
            );
        }
    }

    /// Position from (halves counted, destination address) for every word of three laps and
    /// every interrupt lag up to one half.
    #[test]
    fn words_written_from_address_and_half_count() {
        let a = rx_addresses();
        for lag in [0u32, 1, 17, HALF_WORDS as u32 - 1] {
            let mut ch = ChannelModel::new(rx_chain(a), a.items);
            let mut pending: Vec<u32> = Vec::new(); // words at which a TC happened
            let mut halves = 0u32;
            let mut ring_words = 0u32;
            assert_eq!(words_written(0, ch.regs.dst, RING, SKIP), Ok(0));
            for _ in 0..SKIP_FRAMES + 3 * RING_WORDS as u32 {
                let (_, dst, tc) = ch.request().unwrap();
                if dst != SKIP {
                    ring_words += 1;
                }
                if tc {
                    pending.push(ring_words);
                }
                // The interrupt runs `lag` words after its TC.
                while pending.first().is_some_and(|&at| ring_words >= at + lag) {
                    pending.remove(0);
                    halves += 1;
                }
                assert_eq!(
                    words_written(halves, ch.regs.dst, RING, SKIP),
                    Ok(ring_words),
                    "lag {lag}, after {ring_words} words"
                );
            }
        }
    }

    /// End to end: the TX and RX lists walked frame by frame against the `ad7689` driver's
    /// view of the same frames; every ring word is the input the driver names for it.
    #[test]
    fn dma_frames_agree_with_the_driver() {
        const FRAMES: usize = 3 + 8 * 4;
        let ta = TxAddresses {
            ssp_dr: SSP_DR,
            cfg: 0x2007_E000,
            nop: 0x2007_E002,
            item: 0x2007_E010,
        };
        let ra = rx_addresses();
        let words = BTreeMap::from([(ta.cfg, TX_WORDS[0]), (ta.nop, TX_WORDS[1])]);
        let mut tx = ChannelModel::new(tx_chain(ta), [ta.item]);
        let mut rx = ChannelModel::new(rx_chain(ra), ra.items);
        let r = ring();
        let mut expected = Vec::new();
        for k in 0..FRAMES {
            let din = words[&tx.request().unwrap().0].to_be_bytes();
            let sdo = (k as u16 * 0x0101).to_be_bytes();
            expected.push(Transaction::transaction_start());
            expected.push(Transaction::transfer_in_place(din.to_vec(), sdo.to_vec()));
            expected.push(Transaction::transaction_end());
            let (_, dst, _) = rx.request().unwrap();
            if dst != SKIP {
                r[((dst - RING) / 2) as usize].store(k as u16 * 0x0101, Ordering::Relaxed);
            }
        }
        let mut adc = Ad7689::new(Mock::new(&expected));
        let mut delay = NoopDelay::new();
        adc.start(SCAN_CONFIG, &mut delay).unwrap();
        for k in 3..FRAMES {
            let s = adc.read_when_ready(&mut delay).unwrap().unwrap();
            let i = k - 3;
            assert_eq!(s.channel, Channel::In((i % 8) as u8), "frame {k}");
            assert_eq!(r[i].load(Ordering::Relaxed), s.code, "ring word {i}");
        }
        adc.destroy().done();
    }
}
