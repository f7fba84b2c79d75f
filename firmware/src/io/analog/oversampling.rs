//! Input oversampling (docs/book/oversampling.md): every AD7689 conversion reaches the
//! master exactly once, in blocks cut from the DMA ring at DC times.
//!
//! - [`InputBlocks`]: the oversampling part of the TxPDO assignment (0x1A10 block status,
//!   0x1A11 block time, sample PDOs 0x1A20..), its order rule and its bytes in the image.
//! - [`SampleStream`]: the block cutter. Ring word `w` is a conversion taken at MCU time
//!   `word0 + w x period` (the ADC runs free on Timer2, whose start the hardware layer
//!   records); block `c`, written after SYNC0 edge `c`, holds the whole scans whose first
//!   conversion started in `[edge(c-1) - lead, edge(c) - lead)`. So every conversion is in
//!   exactly one block, decided by its time, whatever the frame or the poll does.
//! - The block's DC time comes from one read of the ESC's next SYNC0 time (0x0990) at
//!   PREOP -> SAFEOP ([`SampleStream::set_dc_reference`]) and the captured SYNC0 edges
//!   after it: the DC time of edge `e` is that reference plus whole cycles.
//! - [`admit`]: the PREOP -> SAFEOP checks of a configuration against the SYNC0 cycle.
//!
//! The ADC grid is not trimmed to the DC grid: the sample times are measured against it
//! at every edge instead (status bit [`STATUS_NOT_LOCKED`] until the DC reference is
//! known). On one crystal (the co-simulator) the two grids keep their phase; on a board a
//! 100 ppm difference moves the phase by 0.1 us per ms, which the block time reports.

use super::adc_dma::RING_WORDS;
use super::block_assignment::BlockPdos;
use crate::platform::board::AI_CHANNELS as CHANNELS;
use crate::platform::chip::adc_dma::{PERIOD_TICKS, TICK_NS};
use crate::platform::div::div_u64_u32;
use coe_core::{AlStatusCode, SdoAbortCode};
use core::sync::atomic::{compiler_fence, AtomicU16, Ordering};

/// Whether input oversampling is in this build: in the images of the products that offer
/// it (`analog-io`) and on the host; other images (`analog-io-can`, whose flash is full)
/// leave its code out, as their dictionaries leave its objects out.
pub const BUILT: bool = cfg!(any(feature = "analog-io", not(target_os = "none")));

/// The application's stream: [`SampleStream`] where oversampling is built in, else
/// [`NoStream`] (nothing, no code).
#[cfg(any(feature = "analog-io", not(target_os = "none")))]
pub type Stream = SampleStream;
/// The application's stream: [`SampleStream`] where oversampling is built in, else
/// [`NoStream`] (nothing, no code).
#[cfg(not(any(feature = "analog-io", not(target_os = "none"))))]
pub type Stream = NoStream;

/// The stream of a build without oversampling: the same calls, doing nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NoStream;

impl NoStream {
    /// Nothing to keep.
    pub const fn new() -> Self {
        Self
    }
    /// Ignored.
    pub fn set_word0(&mut self, _: u64) {}
    /// Ignored.
    pub fn set_ring(&mut self, _: &'static [AtomicU16; RING_WORDS], _: u32) {}
    /// Ignored.
    pub fn restart(&mut self, _: InputBlocks) {}
    /// Ignored.
    pub fn set_dc_reference(&mut self, _: u32, _: u64, _: Option<u32>) {}
    /// Ignored.
    pub fn on_edge(&mut self, _: u64, _: u32, _: u32) {}
    /// Ignored.
    pub fn on_output_refused(&mut self) {}
    /// Nothing to write (no oversampling PDO can be assigned).
    pub fn write(&self, _: &mut [u8]) {}
}

/// Conversion period (ns): 4 us, 250 kSPS aggregate.
pub const PERIOD_NS: u32 = PERIOD_TICKS * TICK_NS;
/// How long before its SYNC0 edge a block closes (ns): the last scan's last result is in
/// memory by then (one conversion period plus the DMA), with room for the poll's delay.
pub const LEAD_NS: u32 = 40_000;
/// Sample slots per sample PDO (0x6020 + b : 01..20).
pub const SLOTS_PER_PDO: usize = 32;
/// Sample PDOs offered (0x1A20..0x1A27).
pub const SAMPLE_PDOS: usize = 8;
/// Largest number of sample slots.
pub const MAX_SLOTS: usize = SLOTS_PER_PDO * SAMPLE_PDOS;
/// The block status PDO (0x6010:01..03).
pub const STATUS_PDO: u16 = 0x1A10;
/// The block time PDO (0x6010:04).
pub const TIME_PDO: u16 = 0x1A11;
/// The first sample PDO.
pub const SAMPLE_PDO: u16 = 0x1A20;
/// The block header object.
pub const BLOCK_INDEX: u16 = 0x6010;
/// The oversampling settings object (0x8000: channels, period, slots, lead).
pub const SETTINGS_INDEX: u16 = 0x8000;
/// The first sample array object.
pub const SAMPLES_INDEX: u16 = 0x6020;
/// Bytes of 0x1A10: scan counter (UINT32), scans (UINT8), status (UINT8).
pub const STATUS_BYTES: usize = 6;
/// Bytes of 0x1A11: block time (UINT64).
pub const TIME_BYTES: usize = 8;
/// The largest oversampling part of the input image.
pub const MAX_BYTES: usize = STATUS_BYTES + TIME_BYTES + 2 * MAX_SLOTS;

/// Status bit 0: conversions were lost inside the module before this block (the scan
/// counter jumps by as many scans).
pub const STATUS_OVERRUN: u8 = 1 << 0;
/// Status bit 1: the block's DC time is not known (no DC reference yet).
pub const STATUS_NOT_LOCKED: u8 = 1 << 1;
/// Status bit 2: the outputs held since the previous block: the update block for this
/// block's SYNC0 edge (or one before it) came too late or never, so the update interrupt
/// played no new value that cycle (output oversampling only).
pub const STATUS_OUTPUTS_HELD: u8 = 1 << 2;
/// Status bit 3: the module refused an update block since the previous block (no two of
/// its reads agreed, or its block counter 0x7010:01 repeated the previous block's); that
/// cycle's outputs held (bit 2 too).
pub const STATUS_OUTPUTS_REFUSED: u8 = 1 << 3;

/// Scan length in ns.
const SCAN_NS: u64 = CHANNELS as u64 * PERIOD_NS as u64;
/// Words the cutter keeps between a block's start and the DMA's write position: older
/// words may be overwritten while they are copied.
const RING_SAFE_WORDS: u32 = (RING_WORDS - RING_WORDS / 4) as u32;

/// The oversampling PDOs of a TxPDO assignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct InputBlocks {
    /// 0x1A10 assigned.
    pub status: bool,
    /// 0x1A11 assigned.
    pub time: bool,
    /// Sample PDOs assigned (0x1A20 ..).
    pub sample_pdos: u8,
}

impl InputBlocks {
    /// No oversampling PDO.
    pub const NONE: Self = Self {
        status: false,
        time: false,
        sample_pdos: 0,
    };

    /// The oversampling PDOs of the inputs: 0x1A10, 0x1A11, then the sample PDOs.
    const PDOS: BlockPdos<'static> = BlockPdos {
        leading: &[STATUS_PDO, TIME_PDO],
        first: SAMPLE_PDO,
        count: SAMPLE_PDOS,
    };

    /// Whether `pdo` is one of the oversampling PDOs.
    pub const fn is_block_pdo(pdo: u16) -> bool {
        pdo == STATUS_PDO
            || pdo == TIME_PDO
            || (pdo >= SAMPLE_PDO && pdo < SAMPLE_PDO + SAMPLE_PDOS as u16)
    }

    /// The length in bits of an oversampling PDO.
    pub const fn pdo_bits(pdo: u16) -> Option<u32> {
        if pdo == STATUS_PDO {
            Some(STATUS_BYTES as u32 * 8)
        } else if pdo == TIME_PDO {
            Some(TIME_BYTES as u32 * 8)
        } else if Self::is_block_pdo(pdo) {
            Some(SLOTS_PER_PDO as u32 * 16)
        } else {
            None
        }
    }

    /// Splits an assignment into the plain PDOs before the oversampling ones (how many) and
    /// the oversampling part. The order rule: plain PDOs first, then 0x1A10, optionally
    /// 0x1A11, then the sample PDOs from 0x1A20 on, one by one; the status comes with any
    /// other oversampling PDO, since without it a master cannot tell the valid samples.
    /// Anything else is 0x06040043.
    pub fn split(pdos: &[u16]) -> Result<(usize, Self), SdoAbortCode> {
        let split = Self::PDOS.split(pdos)?;
        let blocks = Self {
            status: split.has(0),
            time: split.has(1),
            sample_pdos: split.numbered,
        };
        if (blocks.time || blocks.sample_pdos > 0) && !blocks.status {
            return Err(SdoAbortCode::ParameterIncompatible);
        }
        Ok((split.plain, blocks))
    }

    /// Whether any oversampling PDO is assigned.
    pub const fn any(&self) -> bool {
        self.status
    }

    /// Sample slots assigned.
    pub const fn slots(&self) -> usize {
        self.sample_pdos as usize * SLOTS_PER_PDO
    }

    /// Bytes of the oversampling part of the image.
    pub const fn byte_len(&self) -> usize {
        (if self.status { STATUS_BYTES } else { 0 })
            + (if self.time { TIME_BYTES } else { 0 })
            + 2 * self.slots()
    }
}

/// Bus cost of one byte over the SPI PDI in ns (the bench's model: 0.64 us on the wire plus
/// the handling), for the admission check.
pub const PDI_BYTE_NS: u64 = 740;
/// The CPU per cycle beyond the bytes (ns): the fixed work of a DC cycle on the image.
pub const CYCLE_FIXED_NS: u64 = 25_000;

/// PREOP -> SAFEOP: whether `blocks` with `input_bytes` in all can be served at SYNC0
/// cycle `cycle_ns` (0: no DC). Oversampling needs DC SYNC0 (0x0030); the slots must hold
/// the largest block of the cycle (0x001E); the inputs' PDI time and the fixed work must
/// fit in 80 % of the cycle (0x0035).
pub fn admit(
    blocks: &InputBlocks,
    input_bytes: usize,
    output_bytes: usize,
    dc_cycle_ns: Option<u32>,
) -> Result<(), AlStatusCode> {
    if !blocks.any() {
        return Ok(());
    }
    let Some(cycle) = dc_cycle_ns.filter(|c| *c > 0) else {
        return Err(AlStatusCode::InvalidDcSyncConfiguration);
    };
    let most_scans = u64::from(cycle).div_ceil(SCAN_NS) as usize;
    if blocks.sample_pdos > 0 && blocks.slots() < most_scans * CHANNELS {
        return Err(AlStatusCode::InvalidInputConfiguration);
    }
    let bytes = (input_bytes + 2 * output_bytes) as u64;
    if bytes * PDI_BYTE_NS + CYCLE_FIXED_NS > u64::from(cycle) * 8 / 10 {
        return Err(AlStatusCode::DcInvalidSyncCycleTime);
    }
    Ok(())
}

/// One cut block: ring words `start .. start + words`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Block {
    /// Scan counter of its first scan (0x6010:01).
    pub counter: u32,
    /// First ring word (total count, wrapping).
    pub start: u32,
    /// Words (whole scans).
    pub words: u32,
    /// Status bits (0x6010:03).
    pub status: u8,
    /// DC time of its first conversion (0x6010:04), 0 when not known.
    pub time_dc: u64,
}

impl Block {
    /// Whole scans (0x6010:02).
    pub const fn scans(&self) -> u8 {
        (self.words / CHANNELS as u32) as u8
    }
}

/// The DC time of one captured SYNC0 edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct EdgeTime {
    mcu_lo: u32,
    dc: u64,
}

/// The block cutter (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct SampleStream {
    blocks: InputBlocks,
    /// MCU time (ns) of ring word 0's conversion; `None` before the ADC runs.
    word0_ns: Option<u64>,
    /// The DMA's ring (none in a harness without the DMA).
    ring: Option<&'static [AtomicU16; RING_WORDS]>,
    /// Words the DMA has written (total, wrapping).
    written: u32,
    cycle_ns: u32,
    /// The next SYNC0 edge's DC time read at the start, and the last edge captured before
    /// that read (`None`: none yet, the next edge is the one).
    dc_start: Option<(u64, Option<u32>)>,
    reference: Option<EdgeTime>,
    /// The next block's first word, once the stream runs.
    next: Option<u32>,
    /// The stream's first word (scan counter 0).
    first: u32,
    block: Block,
    /// The output holds counted at the last cut (`None`: none cut yet).
    holds: Option<u32>,
    /// An update block was refused since the last cut.
    refused: bool,
}

impl SampleStream {
    /// A stopped stream.
    pub const fn new() -> Self {
        Self {
            blocks: InputBlocks::NONE,
            word0_ns: None,
            ring: None,
            written: 0,
            cycle_ns: 0,
            dc_start: None,
            reference: None,
            next: None,
            first: 0,
            block: Block {
                counter: 0,
                start: 0,
                words: 0,
                status: 0,
                time_dc: 0,
            },
            holds: None,
            refused: false,
        }
    }

    /// The ADC's timing: ring word 0 was converted at MCU time `word0_ns`.
    pub fn set_word0(&mut self, word0_ns: u64) {
        self.word0_ns = Some(word0_ns);
    }

    /// The DMA's ring and position: `written` words in all (wrapping).
    pub fn set_ring(&mut self, ring: &'static [AtomicU16; RING_WORDS], written: u32) {
        self.ring = Some(ring);
        self.written = written;
    }

    /// The DMA's position alone (tests without a ring).
    #[cfg(test)]
    pub fn set_written(&mut self, written: u32) {
        self.written = written;
    }

    /// PREOP -> SAFEOP: a new stream for `blocks` (it starts at the next edge).
    pub fn restart(&mut self, blocks: InputBlocks) {
        *self = Self {
            blocks,
            word0_ns: self.word0_ns,
            ring: self.ring,
            written: self.written,
            ..Self::new()
        };
    }

    /// DC SYNC0 runs with `cycle_ns`; `next_dc` is the ESC's next SYNC0 time (0x0990) read
    /// after the edge captured at `previous_edge_lo` (`None`: before the first edge).
    pub fn set_dc_reference(&mut self, cycle_ns: u32, next_dc: u64, previous_edge_lo: Option<u32>) {
        self.cycle_ns = cycle_ns;
        self.dc_start = Some((next_dc, previous_edge_lo));
        self.reference = previous_edge_lo.map(|lo| EdgeTime {
            mcu_lo: lo,
            dc: next_dc.wrapping_sub(u64::from(cycle_ns)),
        });
    }

    /// The oversampling PDOs in effect.
    pub const fn blocks(&self) -> &InputBlocks {
        &self.blocks
    }

    /// The last cut block.
    pub const fn block(&self) -> &Block {
        &self.block
    }

    /// The DC time of the edge captured at MCU time `edge_lo` (low 32 bits, ns).
    fn edge_dc(&mut self, edge_lo: u32) -> Option<u64> {
        if self.reference.is_none() {
            let (next_dc, _) = self.dc_start?;
            self.reference = Some(EdgeTime {
                mcu_lo: edge_lo,
                dc: next_dc,
            });
        }
        let r = self.reference?;
        // The reference is the last edge seen, well within 2 s (32-bit arithmetic: no
        // 64-bit division on the PDI path).
        let cycle = self.cycle_ns.clamp(1, i32::MAX as u32) as i32;
        let since = edge_lo.wrapping_sub(r.mcu_lo) as i32;
        let cycles = since.saturating_add(cycle / 2).div_euclid(cycle);
        let dc =
            r.dc.wrapping_add((i64::from(cycles) * i64::from(cycle)) as u64);
        // The newest edge is the next one's reference, so the distance stays short.
        self.reference = Some(EdgeTime {
            mcu_lo: edge_lo,
            dc,
        });
        Some(dc)
    }

    /// The first word of the block that closes at the edge at MCU time `edge_ns`: the first
    /// whole scan whose first conversion is not before `edge - lead`.
    fn cut_word(&self, word0: u64, edge_ns: u64) -> u32 {
        let close = edge_ns.saturating_sub(u64::from(LEAD_NS));
        let since = close.saturating_sub(word0) + SCAN_NS - 1;
        let scans = div_u64_u32(since, SCAN_NS as u32);
        (scans * CHANNELS as u64) as u32
    }

    /// Cuts the block of the SYNC0 edge captured at `edge_lo` (low 32 bits of its MCU time
    /// in ns), seen at MCU time `now_ns`, with the output side's news since the previous
    /// cut: `output_holds` is the count of cycles whose outputs held
    /// ([`super::outputs::OutputStage::output_holds`]), and a refusal noted by
    /// [`Self::on_output_refused`] is taken. The first edge of a stream starts it (an empty
    /// block, scan counter 0 next).
    pub fn on_edge(&mut self, now_ns: u64, edge_lo: u32, output_holds: u32) {
        if !self.blocks.any() {
            return;
        }
        let Some(word0) = self.word0_ns else {
            return;
        };
        let outputs = self.output_status(output_holds);
        // Signed: the SYNC0 task may have captured the edge after the caller read `now_ns`
        // (it preempts the PDI task in between).
        let behind = (now_ns as u32).wrapping_sub(edge_lo) as i32;
        let edge_ns = now_ns.wrapping_add_signed(-i64::from(behind));
        let edge_dc = self.edge_dc(edge_lo);
        let mut end = self.cut_word(word0, edge_ns);
        // Not converted yet (the lead keeps this from happening): the rest comes next time.
        if end.wrapping_sub(self.written) as i32 > 0 {
            end = self.written - self.written % CHANNELS as u32;
        }
        let Some(mut start) = self.next else {
            self.next = Some(end);
            self.first = end;
            self.block = Block {
                counter: 0,
                start: end,
                words: 0,
                status: outputs
                    | if edge_dc.is_some() {
                        0
                    } else {
                        STATUS_NOT_LOCKED
                    },
                time_dc: 0,
            };
            return;
        };
        let mut status = outputs;
        if end.wrapping_sub(start) as i32 <= 0 {
            end = start;
        }
        let room = self.blocks.slots() as u32;
        if self.written.wrapping_sub(start) > RING_SAFE_WORDS {
            // Lapped by the DMA: the oldest whole scan still safe to copy.
            let oldest = self.written.wrapping_sub(RING_SAFE_WORDS);
            start =
                oldest.wrapping_add((CHANNELS as u32 - oldest % CHANNELS as u32) % CHANNELS as u32);
            status |= STATUS_OVERRUN;
        }
        // The block status alone (no sample PDO) carries no sample: none is lost.
        if room > 0 && end.wrapping_sub(start) > room {
            start = end.wrapping_sub(room);
            status |= STATUS_OVERRUN;
        }
        if (end.wrapping_sub(start) as i32) < 0 {
            start = end;
        }
        let word_ns = word0.wrapping_add(u64::from(start) * u64::from(PERIOD_NS));
        let time_dc = match edge_dc {
            Some(dc) => dc.wrapping_add(word_ns.wrapping_sub(edge_ns)),
            None => {
                status |= STATUS_NOT_LOCKED;
                0
            }
        };
        self.block = Block {
            counter: start.wrapping_sub(self.first) / CHANNELS as u32,
            start,
            words: end.wrapping_sub(start),
            status,
            time_dc,
        };
        self.next = Some(end);
    }

    /// The output side's status bits of the block cut now: `holds` is the count of cycles
    /// whose outputs held ([`super::outputs::OutputStage::output_holds`]); a change since
    /// the previous cut is [`STATUS_OUTPUTS_HELD`], an update block refused since then
    /// [`STATUS_OUTPUTS_REFUSED`]. The stream's first cut only takes the count.
    fn output_status(&mut self, holds: u32) -> u8 {
        let mut status = 0;
        if self.holds.replace(holds).is_some_and(|h| h != holds) {
            status |= STATUS_OUTPUTS_HELD;
        }
        if core::mem::take(&mut self.refused) {
            status |= STATUS_OUTPUTS_REFUSED;
        }
        status
    }

    /// An update block was refused (its reads disagreed or its counter repeated): the next
    /// cut's block says so.
    pub fn on_output_refused(&mut self) {
        self.refused = true;
    }

    /// Writes the oversampling part of the image (`out`, [`InputBlocks::byte_len`] bytes):
    /// the header of the last block and its samples from the ring, the unused slots 0.
    pub fn write(&self, out: &mut [u8]) {
        let b = &self.block;
        let ring = self.ring;
        let mut rest = out;
        if self.blocks.status {
            let Some((head, tail)) = rest.split_at_mut_checked(STATUS_BYTES) else {
                return;
            };
            let [c0, c1, c2, c3] = b.counter.to_le_bytes();
            head.copy_from_slice(&[c0, c1, c2, c3, b.scans(), b.status]);
            rest = tail;
        }
        if self.blocks.time {
            let Some((head, tail)) = rest.split_at_mut_checked(TIME_BYTES) else {
                return;
            };
            head.copy_from_slice(&b.time_dc.to_le_bytes());
            rest = tail;
        }
        compiler_fence(Ordering::Acquire);
        let mut slots = rest.chunks_exact_mut(2);
        if let Some(ring) = ring {
            for (w, slot) in (0..b.words).zip(&mut slots) {
                let i = b.start.wrapping_add(w) as usize % RING_WORDS;
                let code = ring.get(i).map_or(0, |a| a.load(Ordering::Relaxed));
                slot.copy_from_slice(&code.to_le_bytes());
            }
        }
        for slot in slots {
            slot.fill(0);
        }
    }
}

#[cfg(test)]
mod tests;
