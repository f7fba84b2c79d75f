//! The AD7689 scan moved by the GPDMA (hardware-facts 10.B): what the DMA channels are told
//! and how the PDI task reads what they wrote. Only the register writes live in the hardware
//! layer (`hw::adc_dma`); everything here is plain data and arithmetic, tested on the host
//! against a model of the GPDMA's linked-list walk and against the `ad7689` driver.
//!
//! ```text
//!  Timer2 (TC 0..PERIOD-1, MR3 resets)
//!   MR0 match --toggle--> MAT2.0 = CNV      (rises at CNV_RISE, falls at CNV_FALL)
//!   MR0 match --DMA req 12--> ch CNV: MR0 <- [CNV_FALL, CNV_RISE] (circular list)
//!   MR1 match --DMA req 13--> ch TX:  SSP1 DR <- CFG, CFG, 0, 0, 0 ...  (one 16-bit frame)
//!  SSP1 RX  --DMA req 3---> ch RX:  3 start-up dummies -> skip word, then
//!                                   ring half A (TC irq) -> ring half B (TC irq) -> half A ...
//! ```
//!
//! The CPU's only work per sample is the drain ([`ScanReader::drain`], whole 8-channel scans
//! into the [`Sampler`]) plus one terminal-count interrupt per half ring
//! ([`HalfCounter::on_terminal_count`]).
//!
//! Position: the RX channel's destination address register says how far the DMA got within
//! the ring; the half counter says how many halves were completed. Together they give the
//! total number of words written ([`words_written`]), robust against the interrupt running
//! late (by less than one half).

use super::adc_scan::{CFG_FRAMES, FIRST_RESULT, SCAN_CFG_WORD};
use super::sampler::Sampler;
use crate::product::capacity::AI_CHANNELS as CHANNELS;
use core::sync::atomic::{compiler_fence, AtomicU16, AtomicU32, Ordering};

// ---------------------------------------------------------------- GPDMA words (UM10360 31)

/// A linked-list item as the GPDMA reads it from memory: source, destination, next item,
/// control (UM10360 31.5.x; same order as the channel registers at +0x00..+0x0C).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Lli {
    /// DMACCxSrcAddr.
    pub src: u32,
    /// DMACCxDestAddr.
    pub dst: u32,
    /// DMACCxLLI: address of the next item (bits 1:0 zero), 0 = end of the list.
    pub next: u32,
    /// DMACCxControl.
    pub control: u32,
}

/// Transfer width of one side of a channel (DMACCxControl SWidth/DWidth).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Width {
    /// 8 bits (000).
    Byte = 0,
    /// 16 bits (001).
    Half = 1,
    /// 32 bits (010).
    Word = 2,
}

impl Width {
    /// Bytes per transfer.
    pub const fn bytes(self) -> u32 {
        1 << self as u32
    }
}

/// DMACCxControl fields (bit positions confirmed by the `lpc1769` PAC, generated from NXP's
/// SVD): TransferSize bits 11:0, SBSize bits 14:12, DBSize bits 17:15 (000 = 1), SWidth bits 20:18,
/// DWidth bits 23:21, SI b26, DI b27, I b31 (terminal-count interrupt of this item).
pub mod control {
    /// Largest TransferSize (12 bits).
    pub const MAX_TRANSFERS: u32 = 0xFFF;
    /// SWidth shift.
    pub const SWIDTH: u32 = 18;
    /// DWidth shift.
    pub const DWIDTH: u32 = 21;
    /// Source increment.
    pub const SI: u32 = 1 << 26;
    /// Destination increment.
    pub const DI: u32 = 1 << 27;
    /// Terminal-count interrupt when this item ends.
    pub const I: u32 = 1 << 31;
}

/// One channel's DMACCxControl word: `transfers` single transfers (bursts of 1, so each
/// peripheral request moves exactly one item), widths, increments, interrupt at the end.
pub const fn control_word(
    transfers: u32,
    width: Width,
    src_increment: bool,
    dst_increment: bool,
    interrupt: bool,
) -> u32 {
    assert!(transfers >= 1 && transfers <= control::MAX_TRANSFERS);
    let w = width as u32;
    transfers
        | (w << control::SWIDTH)
        | (w << control::DWIDTH)
        | if src_increment { control::SI } else { 0 }
        | if dst_increment { control::DI } else { 0 }
        | if interrupt { control::I } else { 0 }
}

/// TransferSize of a control word.
pub const fn transfers(control: u32) -> u32 {
    control & control::MAX_TRANSFERS
}

/// DMACCxConfig fields (NXP CMSIS `lpc17xx_gpdma.h`): E b0, SrcPeripheral bits 5:1,
/// DestPeripheral bits 10:6, TransferType bits 13:11 (001 memory to peripheral, 010 peripheral to
/// memory, DMA flow control), IE b14, ITC b15, A b17 (active, read only), H b18 (halt).
pub mod config {
    /// Channel enable.
    pub const E: u32 = 1 << 0;
    /// Error interrupt unmasked.
    pub const IE: u32 = 1 << 14;
    /// Terminal-count interrupt unmasked.
    pub const ITC: u32 = 1 << 15;
    /// Memory to peripheral.
    pub const M2P: u32 = 1 << 11;
    /// Peripheral to memory.
    pub const P2M: u32 = 2 << 11;
}

/// GPDMA request lines (hardware-facts 7 and 10.B; CMSIS connection table): SSP1 TX/RX 2/3;
/// lines 8..15 are UART or timer match per DMAREQSEL bit (line - 8).
pub mod request {
    /// SSP1 receive.
    pub const SSP1_RX: u32 = 3;
    /// Timer2 MR0 (DMAREQSEL bit 4 = 1).
    pub const T2_MR0: u32 = 12;
    /// Timer2 MR1 (DMAREQSEL bit 5 = 1).
    pub const T2_MR1: u32 = 13;
    /// The DMAREQSEL bit that gives `line` (8..=15) to its timer match.
    pub const fn dmareqsel_bit(line: u32) -> u32 {
        assert!(line >= 8 && line <= 15);
        1 << (line - 8)
    }
}

/// DMACCxConfig of a memory-to-peripheral channel on request `line`, TC interrupt masked.
pub const fn config_m2p(line: u32) -> u32 {
    config::E | (line << 6) | config::M2P | config::IE
}

/// DMACCxConfig of a peripheral-to-memory channel on request `line`, TC interrupt enabled.
pub const fn config_p2m(line: u32) -> u32 {
    config::E | (line << 1) | config::P2M | config::IE | config::ITC
}

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

/// Words of the sample ring (two halves of [`HALF_WORDS`]): ~4.1 ms at 250 kSPS.
pub const RING_WORDS: usize = 1024;
/// Words per half ring = transfers of one RX list item (one TC interrupt each).
pub const HALF_WORDS: usize = RING_WORDS / 2;
/// Start-up frames that hold no scan result (the CFG pipeline, `adc_scan`).
pub const SKIP_FRAMES: u32 = FIRST_RESULT;
/// Transfers of the TX channel's NOP item before it reloads itself.
pub const NOP_TRANSFERS: u32 = control::MAX_TRANSFERS;

const _: () = assert!(HALF_WORDS % CHANNELS == 0 && HALF_WORDS as u32 <= control::MAX_TRANSFERS);

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

/// The first item (loaded into the channel registers) and the items in memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chain<const K: usize> {
    /// Channel registers at start.
    pub first: Lli,
    /// Items in memory, at the addresses given.
    pub items: [Lli; K],
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

// ---------------------------------------------------------------- position and drain

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
    let ring_bytes = RING_WORDS as u32 * Width::Half.bytes();
    if dst == skip && halves == 0 {
        return Ok(0);
    }
    let offset = dst.wrapping_sub(ring);
    if offset > ring_bytes || offset % 2 != 0 {
        return Err(PositionError::OutsideRing(dst));
    }
    let o = offset / 2;
    let n = RING_WORDS as u32;
    let half_start = (halves % 2) * HALF_WORDS as u32;
    // Words past the start of the half being written according to the counter; `o == n`
    // (end of half B before the reload) reads as n - HALF (half B full).
    let into = if o == n && half_start == HALF_WORDS as u32 {
        HALF_WORDS as u32
    } else {
        (o + n - half_start) % n
    };
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
            let at = self.read as usize % RING_WORDS;
            // `read` stays scan-aligned and the ring holds whole scans, so this is always
            // `Some`; checked instead of indexed so no input can make the drain panic.
            let Some(scan) = ring.get(at..at + CHANNELS) else {
                break;
            };
            sampler.add_scan(scan.iter().map(|w| w.load(Ordering::Relaxed)));
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
    use crate::app::adc_scan::{ScanPipeline, SCAN_CONFIG};
    use crate::app::sampler::PublishMode;
    use ad7689::{Ad7689, Channel};
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

    /// The GPDMA's walk through a list, as UM10360 31 describes it for DMA flow control:
    /// each request moves one transfer (bursts of 1); after TransferSize transfers the channel
    /// raises TC if the item's I bit is set and loads the item at LLI.
    struct ChannelModel {
        regs: Lli,
        done: u32,
        items: BTreeMap<u32, Lli>,
    }

    /// One transfer: (source address, destination address, terminal count after it).
    type Transfer = (u32, u32, bool);

    impl ChannelModel {
        fn new<const K: usize>(chain: Chain<K>, at: [u32; K]) -> Self {
            Self {
                regs: chain.first,
                done: 0,
                items: at.into_iter().zip(chain.items).collect(),
            }
        }

        fn request(&mut self) -> Option<Transfer> {
            let c = self.regs.control;
            let width = 1 << ((c >> control::SWIDTH) & 7);
            assert_eq!(width, 1 << ((c >> control::DWIDTH) & 7), "equal widths");
            let t = (self.regs.src, self.regs.dst, false);
            if c & control::SI != 0 {
                self.regs.src += width;
            }
            if c & control::DI != 0 {
                self.regs.dst += width;
            }
            self.done += 1;
            if self.done < transfers(c) {
                return Some(t);
            }
            let tc = c & control::I != 0;
            self.done = 0;
            self.regs = *self.items.get(&self.regs.next)?;
            Some((t.0, t.1, tc))
        }
    }

    #[test]
    fn control_and_config_words() {
        // 512 half-words, dst increment, TC interrupt: I | DI | DWidth 1 | SWidth 1 | 0x200.
        assert_eq!(
            control_word(512, Width::Half, false, true, true),
            0x8000_0000 | 0x0800_0000 | (1 << 21) | (1 << 18) | 512
        );
        assert_eq!(
            control_word(2, Width::Word, true, false, false),
            0x0400_0000 | (2 << 21) | (2 << 18) | 2
        );
        // SSP1 RX: SrcPeripheral 3, P2M, IE, ITC, E.
        assert_eq!(
            config_p2m(request::SSP1_RX),
            1 | (3 << 1) | (2 << 11) | (1 << 14) | (1 << 15)
        );
        // T2MR1: DestPeripheral 13, M2P, IE, E (no TC interrupt).
        assert_eq!(
            config_m2p(request::T2_MR1),
            1 | (13 << 6) | (1 << 11) | (1 << 14)
        );
        assert_eq!(request::dmareqsel_bit(request::T2_MR0), 1 << 4);
        assert_eq!(request::dmareqsel_bit(request::T2_MR1), 1 << 5);
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
        // At the end of half B before the reload (address one past the ring).
        assert_eq!(
            words_written(1, RING + 2 * RING_WORDS as u32, RING, SKIP),
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

    #[test]
    fn half_counter_counts() {
        let c = HalfCounter::new();
        for _ in 0..5 {
            c.on_terminal_count();
        }
        assert_eq!(c.get(), 5);
    }
}
