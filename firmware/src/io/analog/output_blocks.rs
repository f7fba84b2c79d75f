//! Output oversampling (docs/book/oversampling.md, "The output process data"): a block of
//! n updates per channel per cycle, played at n equal sub-intervals locked to SYNC0.
//!
//! - [`OutputBlocks`]: the oversampling part of the RxPDO assignment (0x1610 block counter,
//!   update PDOs 0x1620..), its order rule and its bytes in the image.
//! - [`admit`]: the PREOP -> SAFEOP checks of a factor against the SYNC0 cycle (AL 0x0030,
//!   0x001D, 0x0035); never a silent degradation.
//! - [`UpdateRing`]: the hand-over of decoded blocks from the PDI task (single writer) to
//!   the update interrupt (single reader, higher priority), lock-free like
//!   [`super::outputs::OutputStage`]: the reader only ever plays a whole published block, or
//!   holds.
//! - [`GridLock`]: the LDAC grid (PWM1, period T/n) phase-locked to the captured SYNC0 edge:
//!   the falling edge of update 0 on the edge itself, corrected by changing one PWM period.
//!
//! Timing of a block (n updates, interval P = T/n): update k of the block that plays from
//! SYNC0 edge c is latched by the LDAC edge at `SYNC0(c) + k P`. The update interrupt runs
//! after each LDAC edge and writes the next update's frames into the AD5663's input
//! registers; after update n-1 it takes the next block, so a block must be published before
//! `SYNC0(c) - P`. A block that is not in by then is not played: the outputs hold (the input
//! registers keep the last update, which every LDAC edge latches again).

use coe_core::{AlStatusCode, SdoAbortCode};
use core::sync::atomic::{AtomicU32, Ordering};

use super::block_assignment::BlockPdos;
use super::dac_pair::DacPair;

/// Whether output oversampling is in this build: in the images of the products that offer
/// it (`analog-io`) and on the host, as [`super::oversampling::BUILT`].
pub const BUILT: bool = super::oversampling::BUILT;

/// Updates the ring holds: none in a build without output oversampling.
const RING_UPDATES: usize = if BUILT { MAX_UPDATES } else { 0 };

/// Updates carried by one update PDO (0x7020 + u : 01..0A, AO1/AO2 interleaved).
pub const UPDATES_PER_PDO: usize = 5;
/// Update PDOs offered (0x1620..0x1629).
pub const UPDATE_PDOS: usize = 10;
/// Largest number of updates per cycle.
pub const MAX_UPDATES: usize = UPDATES_PER_PDO * UPDATE_PDOS;
/// The block counter PDO (0x7010:01).
pub const COUNTER_PDO: u16 = 0x1610;
/// The first update PDO.
pub const UPDATE_PDO: u16 = 0x1620;
/// The block counter object.
pub const COUNTER_INDEX: u16 = 0x7010;
/// The first update array object.
pub const UPDATES_INDEX: u16 = 0x7020;
/// Bytes of 0x1610: the block counter (UINT16).
pub const COUNTER_BYTES: usize = 2;
/// Bytes of one update (two UINT16 codes).
pub const UPDATE_BYTES: usize = 4;
/// The largest oversampling part of the output image.
pub const MAX_BYTES: usize = COUNTER_BYTES + UPDATE_BYTES * MAX_UPDATES;

/// PWM1 tick (ns): PCLK 100 MHz, PR = 0.
pub const TICK_NS: u32 = 10;
/// Shortest update interval (ns): the update interrupt writes two 24-bit frames (about
/// 2.5 us with its entry) and must be done before the next LDAC edge, with room for the
/// interrupt's latency behind the SYNC0 task.
pub const MIN_INTERVAL_NS: u32 = 10_000;
/// LDAC low time per update (PWM1 ticks): 200 ns, the falling edge is the update.
pub const LDAC_LOW_TICKS: u32 = 20;
/// CPU per update on the image (ns), for the admission: the update interrupt's entry,
/// the two frames and the bookkeeping. Measured (`lpc1754-cosim oversampling`, 1 ms with
/// 8 sample PDOs): 20 updates per cycle raise the load from 52.1 % to 78.0 %, 259 us, of
/// which 118 us are the 160 PDI bytes: 7 us per update. (With 3 us, 40 updates at 1 ms
/// were admitted and starved the watchdog.)
pub const UPDATE_CPU_NS: u64 = 7_000;

/// The oversampling PDOs of an RxPDO assignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OutputBlocks {
    /// 0x1610 assigned.
    pub counter: bool,
    /// Update PDOs assigned (0x1620 ..).
    pub update_pdos: u8,
}

impl OutputBlocks {
    /// No oversampling PDO.
    pub const NONE: Self = Self {
        counter: false,
        update_pdos: 0,
    };

    /// The oversampling PDOs of the outputs: 0x1610, then the update PDOs.
    const PDOS: BlockPdos<'static> = BlockPdos {
        leading: &[COUNTER_PDO],
        first: UPDATE_PDO,
        count: UPDATE_PDOS,
    };

    /// Whether `pdo` is one of the output oversampling PDOs.
    pub const fn is_block_pdo(pdo: u16) -> bool {
        pdo == COUNTER_PDO || (pdo >= UPDATE_PDO && pdo < UPDATE_PDO + UPDATE_PDOS as u16)
    }

    /// The length in bits of an output oversampling PDO.
    pub const fn pdo_bits(pdo: u16) -> Option<u32> {
        if pdo == COUNTER_PDO {
            Some(COUNTER_BYTES as u32 * 8)
        } else if Self::is_block_pdo(pdo) {
            Some((UPDATES_PER_PDO * UPDATE_BYTES) as u32 * 8)
        } else {
            None
        }
    }

    /// Splits an assignment into the plain PDOs before the oversampling ones (how many) and
    /// the oversampling part. The order rule: plain PDOs first, then optionally 0x1610, then
    /// the update PDOs from 0x1620 on, one by one, at least one of them when 0x1610 is
    /// there. Anything else is 0x06040043.
    pub fn split(pdos: &[u16]) -> Result<(usize, Self), SdoAbortCode> {
        let split = Self::PDOS.split(pdos)?;
        let blocks = Self {
            counter: split.has(0),
            update_pdos: split.numbered,
        };
        if blocks.counter && blocks.update_pdos == 0 {
            return Err(SdoAbortCode::ParameterIncompatible);
        }
        Ok((split.plain, blocks))
    }

    /// Whether any update PDO is assigned.
    pub const fn any(&self) -> bool {
        self.update_pdos > 0
    }

    /// n, the updates per cycle.
    pub const fn updates(&self) -> usize {
        self.update_pdos as usize * UPDATES_PER_PDO
    }

    /// Bytes of the oversampling part of the image.
    pub const fn byte_len(&self) -> usize {
        (if self.counter { COUNTER_BYTES } else { 0 }) + UPDATE_BYTES * self.updates()
    }
}

/// An LDAC grid: the update interval in PWM1 ticks and the updates per cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Grid {
    /// P = T/n in ticks.
    pub period: u32,
    /// n.
    pub updates: u32,
}

impl Grid {
    /// No grid: one pair per cycle.
    pub const OFF: Self = Self {
        period: 0,
        updates: 0,
    };

    /// In one word (period in bits 0..23, n in 24..31) for the stage.
    pub const fn pack(self) -> u32 {
        self.period & 0x00FF_FFFF | self.updates << 24
    }

    /// The inverse of [`Grid::pack`].
    pub const fn unpack(word: u32) -> Self {
        Self {
            period: word & 0x00FF_FFFF,
            updates: word >> 24,
        }
    }
}

/// PREOP -> SAFEOP: the LDAC grid for `blocks` at SYNC0 cycle `dc_cycle_ns` (`None` or 0:
/// no DC), the update interval in PWM1 ticks, or why it cannot be served: update PDOs need
/// DC SYNC0 (0x0030); the interval T/n must be a whole number of ticks and at least
/// [`MIN_INTERVAL_NS`] (0x001D); the PDI bytes of both directions (outputs read twice), the
/// update interrupts and the fixed work must fit in 80 % of the cycle (0x0035).
/// `Ok(None)`: no output oversampling.
pub fn admit(
    blocks: &OutputBlocks,
    input_bytes: usize,
    output_bytes: usize,
    dc_cycle_ns: Option<u32>,
) -> Result<Option<Grid>, AlStatusCode> {
    if !blocks.any() {
        return Ok(None);
    }
    let Some(cycle) = dc_cycle_ns.filter(|c| *c > 0) else {
        return Err(AlStatusCode::InvalidDcSyncConfiguration);
    };
    let n = blocks.updates() as u32;
    let interval_ns = cycle / n;
    if interval_ns * n != cycle || interval_ns % TICK_NS != 0 || interval_ns < MIN_INTERVAL_NS {
        return Err(AlStatusCode::InvalidOutputConfiguration);
    }
    let pdi = (input_bytes + 2 * output_bytes) as u64 * super::oversampling::PDI_BYTE_NS;
    let cpu = pdi + super::oversampling::CYCLE_FIXED_NS + u64::from(n) * UPDATE_CPU_NS;
    if cpu > u64::from(cycle) * 8 / 10 {
        return Err(AlStatusCode::DcInvalidSyncCycleTime);
    }
    Ok(Some(Grid {
        period: interval_ns / TICK_NS,
        updates: n,
    }))
}

/// Decodes the update part of an output image (`image`: n x (AO1, AO2) little-endian raw
/// AD5663 codes) into `out`; returns how many updates it held.
pub fn decode(image: &[u8], out: &mut [DacPair]) -> usize {
    let mut n = 0;
    for (pair, bytes) in out.iter_mut().zip(image.chunks_exact(UPDATE_BYTES)) {
        if let [a0, a1, b0, b1] = *bytes {
            *pair = DacPair::new(u16::from_le_bytes([a0, a1]), u16::from_le_bytes([b0, b1]));
            n += 1;
        }
    }
    n
}

/// The control word's fields: sequence (bits 31..8) and the block's update count (7..0).
const COUNT_MASK: u32 = 0xFF;

/// Two halves of [`MAX_UPDATES`] packed pairs: the PDI task fills the half that does not
/// play and publishes it with its update count and the SYNC0 edge it is for; the update
/// interrupt switches to it after the last update of the playing block. Publishing with a
/// count of 0 stops the playing (the fault reaction: nothing from a block is written any
/// more, the input registers are the fault path's).
#[derive(Debug)]
pub struct UpdateRing {
    halves: [[AtomicU32; RING_UPDATES]; 2],
    /// Sequence << 8 | count of the published half (`half` = sequence & 1).
    control: AtomicU32,
    /// The SYNC0 edge count the published block is for (it plays from that edge).
    for_edge: AtomicU32,
    /// Blocks published too late or never (the edge played the held values).
    underruns: AtomicU32,
}

impl Default for UpdateRing {
    fn default() -> Self {
        Self::new()
    }
}

impl UpdateRing {
    /// Empty, nothing published.
    pub const fn new() -> Self {
        Self {
            halves: [const { [const { AtomicU32::new(0) }; RING_UPDATES] }; 2],
            control: AtomicU32::new(0),
            for_edge: AtomicU32::new(0),
            underruns: AtomicU32::new(0),
        }
    }

    /// PDI side: publishes `pairs` as the block that plays from SYNC0 edge `edge` (the
    /// count of edges the SYNC0 task has recorded, plus one: the next edge).
    /// A second block for the same edge is dropped: the half it would fill may be the one
    /// playing (a block alternates halves with each publication).
    pub fn publish(&self, pairs: &[DacPair], edge: u32) {
        if self.has_block_for(edge) {
            return;
        }
        let control = self.control.load(Ordering::Acquire);
        let seq = (control >> 8).wrapping_add(1);
        let half = (seq & 1) as usize;
        // RING_UPDATES is 0 in the products built without output oversampling.
        #[allow(clippy::unnecessary_min_or_max)]
        let n = pairs.len().min(RING_UPDATES);
        if let Some(dst) = self.halves.get(half) {
            for (slot, pair) in dst.iter().zip(pairs.iter().take(n)) {
                slot.store(pair.pack(), Ordering::Relaxed);
            }
        }
        self.for_edge.store(edge, Ordering::Relaxed);
        self.control.store(seq << 8 | n as u32, Ordering::Release);
    }

    /// Whether a block is published for SYNC0 edge `edge` (and not stopped).
    pub fn has_block_for(&self, edge: u32) -> bool {
        self.control.load(Ordering::Acquire) & COUNT_MASK != 0
            && self.for_edge.load(Ordering::Relaxed) == edge
    }

    /// PDI side: stops the playing (fault reaction, leaving OP).
    pub fn stop(&self) {
        let seq = (self.control.load(Ordering::Acquire) >> 8).wrapping_add(1);
        self.control.store(seq << 8, Ordering::Release);
    }

    /// Blocks that did not come in time.
    pub fn underruns(&self) -> u32 {
        self.underruns.load(Ordering::Relaxed)
    }
}

/// The update interrupt's side of an [`UpdateRing`].
#[derive(Debug, Clone, Copy, Default)]
pub struct UpdatePlayer {
    /// Sequence of the block playing (`None`: holding).
    playing: Option<u32>,
    /// Updates of the block playing.
    count: u32,
    /// The next update to write (index in the block).
    next: u32,
    /// Updates per cycle (n).
    per_cycle: u32,
    /// The update the last LDAC edge latched (0 at a SYNC0 edge).
    latched: u32,
}

impl UpdatePlayer {
    /// Holding, for `per_cycle` updates per cycle.
    pub const fn new(per_cycle: u32) -> Self {
        Self {
            playing: None,
            count: 0,
            next: 0,
            per_cycle,
            latched: 0,
        }
    }

    /// A SYNC0 edge: the LDAC edge on it latched update 0 (the grid is locked to it).
    pub fn on_sync0(&mut self) {
        self.latched = 0;
    }

    /// After an LDAC edge: the pair to write into the input registers for the next edge
    /// (`None`: write nothing, the outputs hold). `edges` is the SYNC0 task's edge count.
    pub fn after_edge(&mut self, ring: &UpdateRing, edges: u32) -> Option<DacPair> {
        let k = self.latched;
        self.latched = (k + 1) % self.per_cycle.max(1);
        let control = ring.control.load(Ordering::Acquire);
        let seq = control >> 8;
        if control & COUNT_MASK == 0 {
            // Stopped: the fault path owns the input registers.
            self.playing = None;
            return None;
        }
        if self.latched == 0 {
            // The next edge is SYNC0 edge `edges + 1`: its block, if it came in time.
            let fresh = self.playing != Some(seq)
                && ring.for_edge.load(Ordering::Relaxed) == edges.wrapping_add(1);
            if fresh {
                self.playing = Some(seq);
                self.count = control & COUNT_MASK;
                self.next = 0;
            } else {
                ring.underruns.fetch_add(1, Ordering::Relaxed);
                self.playing = None;
                return None;
            }
        }
        let seq = self.playing?;
        let i = self.next;
        if i >= self.count {
            return None;
        }
        self.next = i + 1;
        let half = ring.halves.get((seq & 1) as usize)?;
        half.get(i as usize)
            .map(|w| DacPair::unpack(w.load(Ordering::Relaxed)))
    }
}

/// The LDAC grid's lock to SYNC0: PWM1 runs with period P ticks (MR0 = P - 1) and LDAC
/// (single-edge PWM1.4) falls at MR4 = P - [`LDAC_LOW_TICKS`]; the falling edge of update 0
/// belongs on the SYNC0 edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridLock {
    period: u32,
    /// A corrected period was written and not restored yet.
    corrected: bool,
}

impl GridLock {
    /// The grid of `period` ticks (from [`admit`]).
    pub const fn new(period: u32) -> Self {
        Self {
            period,
            corrected: false,
        }
    }

    /// MR0 for the period P.
    pub const fn mr0(&self) -> u32 {
        self.period - 1
    }

    /// MR4: LDAC falls here.
    pub const fn mr4(&self) -> u32 {
        self.period - LDAC_LOW_TICKS
    }

    /// At a SYNC0 edge where PWM1's TC was `tc_at_edge`: the MR0 value for one period that
    /// puts the next falling edges on the grid (`None`: on it already). The period is
    /// shortened by at most `LDAC_LOW_TICKS - 2` (so MR4 still matches in it), otherwise
    /// lengthened.
    pub fn on_edge(&mut self, tc_at_edge: u32) -> Option<u32> {
        let p = self.period;
        // How long ago (ticks) LDAC fell before the edge, in 0..P.
        let ahead = (tc_at_edge % p + p - self.mr4()) % p;
        if ahead == 0 || self.corrected {
            return None;
        }
        let shorten = p - ahead;
        self.corrected = true;
        Some(if shorten <= LDAC_LOW_TICKS - 2 {
            self.mr0() - shorten
        } else {
            self.mr0() + ahead
        })
    }

    /// After an LDAC edge: whether to write MR0 back to P - 1 (`shadow_latched`: the
    /// corrected MR0 went from the shadow register into effect, LER bit 0 clear).
    pub fn restore(&mut self, shadow_latched: bool) -> Option<u32> {
        if self.corrected && shadow_latched {
            self.corrected = false;
            return Some(self.mr0());
        }
        None
    }
}

#[cfg(test)]
mod tests;
