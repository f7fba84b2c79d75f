//! Timers (UM10360 chapter 21; hardware-facts 7 and 10.A/B).
//!
//! * **Timer1 = time base + SYNC0 capture.** TC counts PCLK (100 MHz, 10 ns) freely; CAP1.0
//!   (P1.18, the ET1100 SYNC0 output, push-pull active high) captures TC on the rising edge
//!   into CR0 and raises the TIMER1 interrupt: SYNC0 gets its own vector and a hardware
//!   timestamp. MR0 = 0xFFFF_FFFF interrupts once per wrap (42.9 s) to extend TC to 64 bits.
//!   The DAC task is the TIMER1 handler; it can also be pended by software (no capture flag
//!   set) for "apply outputs now".
//! * **Timer2 = AD7689 conversion clock.** MR3 resets TC every sample period; MAT2.0 (P0.6 =
//!   CNV) is set high by MR0 (conversion start) and the MR1 interrupt drives it low after
//!   tCONV, then starts the 16-bit SSP1 frame that reads the result (no busy indicator, read
//!   after conversion, CPOL = CPHA = 0). The frame runs in hardware while the CPU returns; the
//!   next MR1 interrupt collects it from the RX FIFO, so no interrupt waits on the bus.
//!
//! Timer2 here is the interrupt path (feature `adc-irq`); the default GPDMA path, which
//! drives Timer2 without any timer interrupt, is `hw::adc_dma` (see `hw::adc`).

#[cfg(feature = "adc-irq")]
use super::ssp::Ssp;
use core::sync::atomic::{AtomicU32, Ordering};
#[cfg(feature = "adc-irq")]
use firmware::platform::adc_scan::ScanPipeline;
use firmware::platform::timebase;
use lpc17xx_pac as pac;

/// Timer tick in ns (PCLK 100 MHz, PR = 0).
pub const TICK_NS: u64 = 1_000_000_000 / super::PCLK_HZ as u64;

const IR_MR0: u32 = 1 << 0;
const IR_MR1: u32 = 1 << 1;
/// MCR: MR0 interrupt (the wrap), MR1 interrupt (the DAC update after each LDAC edge).
const MCR_MR0I: u32 = 1 << 0;
const MCR_MR1I: u32 = 1 << 3;
const IR_CR0: u32 = 1 << 4;
const TCR_ENABLE: u32 = 1;
const TCR_RESET: u32 = 2;

/// High word of the 64-bit time base (Timer1 wraps); written only by the TIMER1 handler.
static TIME_HI: AtomicU32 = AtomicU32::new(0);

/// The time base in ns since boot (Timer1 extended to 64 bits). Callable from any priority.
pub fn now_ns() -> u64 {
    // SAFETY: reads of TC and IR have no side effect.
    let t1 = unsafe { &*pac::TIMER1::ptr() };
    for _ in 0..4 {
        let hi = TIME_HI.load(Ordering::Acquire);
        let lo = t1.tc.read().bits();
        let wrapped_pending = t1.ir.read().bits() & IR_MR0 != 0;
        if TIME_HI.load(Ordering::Acquire) == hi {
            // A wrap the handler has not counted yet (we run above it or it is masked).
            return timebase::extend(hi, lo, wrapped_pending) * TICK_NS;
        }
    }
    u64::from(t1.tc.read().bits()) * TICK_NS
}

/// What a TIMER1 interrupt was for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Timer1Event {
    /// A SYNC0 rising edge; its time is read with [`Sync0Capture::capture_ns`].
    Sync0(Sync0Edge),
    /// Output oversampling: Timer1's MR1 marks the moment after an LDAC edge to write the
    /// next update ([`Sync0Capture::schedule_update`]).
    Update,
    /// No capture: the handler was pended by software (or only the wrap ticked).
    Pended,
}

/// A SYNC0 capture found by [`Sync0Capture::on_interrupt`], not read yet: the IR flags it
/// was found with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct Sync0Edge {
    ir: u32,
}

/// Timer1: time base and SYNC0 capture on CAP1.0 (owner: the SYNC0/DAC task).
pub struct Sync0Capture {
    t: pac::TIMER1,
}

impl Sync0Capture {
    /// Starts the time base; capture on the rising edge with interrupt (CCR = CAP0RE | CAP0I).
    pub fn new(t: pac::TIMER1) -> Self {
        // SAFETY: documented register values (UM10360 21.6).
        t.tcr.write(|w| unsafe { w.bits(TCR_RESET) });
        t.pr.write(|w| unsafe { w.bits(0) });
        t.ctcr.write(|w| unsafe { w.bits(0) });
        t.mr[0].write(|w| unsafe { w.bits(u32::MAX) });
        t.mcr.write(|w| unsafe { w.bits(MCR_MR0I) });
        t.ccr.write(|w| unsafe { w.bits(0b101) });
        t.ir.write(|w| unsafe { w.bits(0x3F) });
        t.tcr.write(|w| unsafe { w.bits(TCR_ENABLE) });
        Self { t }
    }

    /// The time base ([`now_ns`]), for a caller that needs it to be running: Timer1 counts
    /// from [`Sync0Capture::new`] on.
    pub fn now_ns(&self) -> u64 {
        now_ns()
    }

    /// Serves the TIMER1 interrupt: a SYNC0 capture at once, with nothing read but IR (the
    /// DAC task pulses LDAC before it reads the capture's time); else counts a wrap.
    pub fn on_interrupt(&mut self) -> Timer1Event {
        let ir = self.t.ir.read().bits();
        if ir & IR_CR0 != 0 {
            return Timer1Event::Sync0(Sync0Edge { ir });
        }
        if firmware::io::analog::output_blocks::BUILT && ir & IR_MR1 != 0 {
            // SAFETY: IR is write-1-to-clear. A wrap flagged with it interrupts again.
            self.t.ir.write(|w| unsafe { w.bits(IR_MR1) });
            return Timer1Event::Update;
        }
        self.count_wrap(ir);
        Timer1Event::Pended
    }

    /// The time of `edge` (ns, the [`now_ns`] time base); counts a wrap found with it.
    pub fn capture_ns(&mut self, edge: Sync0Edge) -> u64 {
        let hi = self.count_wrap(edge.ir);
        let captured = self.t.cr[0].read().bits();
        // SAFETY: IR is write-1-to-clear.
        self.t.ir.write(|w| unsafe { w.bits(IR_CR0) });
        // A capture just before the wrap belongs to the old high word.
        let ticks = timebase::extend_capture(hi, captured, edge.ir & IR_MR0 != 0);
        ticks * TICK_NS
    }

    /// Timer1's TC (10 ns ticks, wrapping).
    pub fn ticks(&self) -> u32 {
        self.t.tc.read().bits()
    }

    /// Output oversampling: the next update interrupt ([`Timer1Event::Update`]) when TC
    /// reaches `at_ticks` (the low 32 bits of the time base in ticks).
    pub fn schedule_update(&mut self, at_ticks: u32) {
        // SAFETY: MR1 is a plain match value; MCR keeps MR0I and adds MR1I.
        self.t.mr[1].write(|w| unsafe { w.bits(at_ticks) });
        self.t.mcr.write(|w| unsafe { w.bits(MCR_MR0I | MCR_MR1I) });
    }

    /// Output oversampling off: no update interrupts.
    pub fn stop_updates(&mut self) {
        // SAFETY: as above; a pending MR1 flag is cleared with it.
        self.t.mcr.write(|w| unsafe { w.bits(MCR_MR0I) });
        self.t.ir.write(|w| unsafe { w.bits(IR_MR1) });
    }

    /// Counts the wrap if `ir` flags one; returns the high word after it.
    fn count_wrap(&mut self, ir: u32) -> u32 {
        let mut hi = TIME_HI.load(Ordering::Relaxed);
        if ir & IR_MR0 != 0 {
            // SAFETY: IR is write-1-to-clear.
            self.t.ir.write(|w| unsafe { w.bits(IR_MR0) });
            hi = hi.wrapping_add(1);
            TIME_HI.store(hi, Ordering::Release);
        }
        hi
    }
}

#[cfg(feature = "adc-irq")]
/// The sample period (MR3 + 1 ticks): 4 us = 250 kSPS aggregate, 31.25 kSPS per channel.
pub const ADC_PERIOD_TICKS: u32 = 400;
#[cfg(feature = "adc-irq")]
/// CNV high from MR0 (tick 1) to MR1: 2.3 us > tCONV max 2.2 us; the 16-bit frame (0.96 us
/// at 16.7 MHz) then ends ~3.3 us into the 4 us period, before the next CNV edge.
pub const ADC_CNV_HIGH_TICKS: u32 = 230;

#[cfg(feature = "adc-irq")]
/// Timer2 CNV generation + SSP1 frames (owner: the sampler task, TIMER2 handler).
///
/// The frames go straight into the SSP1 FIFO instead of through the `ad7689` driver's
/// `SpiDevice` path: a driver frame is a blocking transaction (about 1 us of polling at
/// 16.7 MHz in every 4 us period), while here one interrupt collects the previous frame and
/// queues the next in a few register accesses. What is sent and how results are tagged come
/// from the driver's rules all the same: the CFG word from its typed builder and the frame
/// pipeline in `firmware::platform::adc_scan`, host-tested against the driver.
pub struct AdcSampler {
    t: pac::TIMER2,
    ssp: Ssp<pac::SSP1>,
    pipeline: ScanPipeline,
    in_flight: bool,
    missed: u32,
}

#[cfg(feature = "adc-irq")]
impl AdcSampler {
    /// Configures Timer2 (stopped): MR0 sets MAT2.0 (EMC0 = 10), MR1 interrupts, MR3 resets.
    pub fn new(t: pac::TIMER2, ssp: Ssp<pac::SSP1>) -> Self {
        // SAFETY: documented register values (UM10360 21.6).
        t.tcr.write(|w| unsafe { w.bits(TCR_RESET) });
        t.pr.write(|w| unsafe { w.bits(0) });
        t.ctcr.write(|w| unsafe { w.bits(0) });
        t.mr[0].write(|w| unsafe { w.bits(1) });
        t.mr[1].write(|w| unsafe { w.bits(1 + ADC_CNV_HIGH_TICKS) });
        t.mr[3].write(|w| unsafe { w.bits(ADC_PERIOD_TICKS - 1) });
        // MR1I (b3), MR3R (b10).
        t.mcr.write(|w| unsafe { w.bits((1 << 3) | (1 << 10)) });
        // EM0 = 0 (CNV low), EMC0 [5:4] = 10: set MAT2.0 high on MR0.
        t.emr.write(|w| unsafe { w.bits(0b10 << 4) });
        t.ir.write(|w| unsafe { w.bits(0x3F) });
        Self {
            t,
            ssp,
            pipeline: ScanPipeline::new(),
            in_flight: false,
            missed: 0,
        }
    }

    /// Starts the conversions.
    pub fn start(&mut self) {
        // SAFETY: TCR enable.
        self.t.tcr.write(|w| unsafe { w.bits(TCR_ENABLE) });
    }

    /// Frames whose result was not in the FIFO when the next one was due.
    pub fn missed(&self) -> u32 {
        self.missed
    }

    /// Serves the TIMER2 (MR1) interrupt: CNV low, collect the previous frame's result,
    /// start this conversion's frame. Returns `(channel, code)` of a scan result.
    pub fn on_interrupt(&mut self) -> Option<(u8, u16)> {
        // SAFETY: IR write-1-to-clear; EMR: EM0 = 0 drives CNV low, EMC0 unchanged.
        self.t.ir.write(|w| unsafe { w.bits(IR_MR1) });
        self.t.emr.write(|w| unsafe { w.bits(0b10 << 4) });
        let mut result = None;
        if self.in_flight {
            match self.ssp.try_pop() {
                Some(code) => {
                    if let Some(ch) = self.pipeline.on_rx() {
                        result = Some((ch, code));
                    }
                }
                None => {
                    self.missed = self.missed.wrapping_add(1);
                    self.pipeline.on_rx(); // keep the channel phase
                }
            }
        }
        self.ssp.drain_rx();
        self.in_flight = self.ssp.try_push(self.pipeline.next_tx());
        result
    }
}
