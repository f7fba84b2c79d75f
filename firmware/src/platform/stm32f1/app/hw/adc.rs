//! The AD7689 sampled without the CPU (`firmware::platform::stm32f1::analog`): TIM3 raises
//! CNV every 5 us and requests one frame per sample from DMA1 channel 3 (the DIN word into
//! SPI1_DR); SPI1's received results go by DMA1 channel 2 into the sample ring, whose half
//! and full interrupts count halves. The PDI task drains whole scans from the ring
//! (`firmware::io::analog::adc_dma::ScanReader`, the LPC1754's GPDMA path's reader).
//!
//! Start-up (in `init`, interrupts off, each wait bounded): the first frames carry the CFG
//! word ([`CFG_FRAMES`]) and their results are dummies ([`FIRST_RESULT`]); the CPU reads and
//! drops those, then hands SPI1's results to the DMA, so ring word 0 holds IN0.

use super::{pac, read, time, wait, write};
use core::sync::atomic::{AtomicU16, AtomicU32, Ordering};
use firmware::io::analog::adc_dma::{words_written, HalfCounter, PositionError, ScanReader};
use firmware::io::analog::sampler::Sampler;
use firmware::io::analog::AnalogApplication;
use firmware::platform::adc_scan::{CFG_FRAMES, FIRST_RESULT, SCAN_CFG_WORD};
use firmware::platform::chip::adc_dma::RING_WORDS;
use firmware::platform::stm32f1::analog::{
    dma_ccr, dma_flags, rx_destination, ADC_SPI_CR1, CNV_FALL, FRAME_START, PERIOD_TICKS, RX_CCR,
    RX_CNDTR, SAMPLE_PERIOD_NS, SPI_CR2_RXDMAEN, TIM3_CCER, TIM3_CCMR2, TIM3_DIER, TX_CCR,
};

/// The sample ring the DMA fills (2 KB).
static RING: [AtomicU16; RING_WORDS] = [const { AtomicU16::new(0) }; RING_WORDS];
/// The DIN word DMA1 channel 3 sends in each frame: the CFG at start-up, then 0 (keeps it).
static TX_WORD: AtomicU16 = AtomicU16::new(SCAN_CFG_WORD);
/// Halves of the ring completed (the DMA interrupt).
static HALVES: HalfCounter = HalfCounter::new();
/// Transfer errors of the RX channel (the DMA interrupt).
static DMA_ERRORS: AtomicU32 = AtomicU32::new(0);

/// DMA1 channels: SPI1 RX, TIM3_CH4 (the frames).
const RX: usize = 1;
const TX: usize = 2;
/// Their numbers (1..=7) for the flags.
const RX_CHANNEL: u32 = RX as u32 + 1;
/// DMA_ISR bits of the RX channel: complete, half, error.
const RX_TC: u32 = 1 << (4 * (RX_CHANNEL - 1) + 1);
const RX_HT: u32 = 1 << (4 * (RX_CHANNEL - 1) + 2);
const RX_TE: u32 = 1 << (4 * (RX_CHANNEL - 1) + 3);
/// SPI_SR: RXNE.
const SPI_RXNE: u16 = 1 << 0;
/// Polls of RXNE for one start-up frame: a sample period is 360 cycles.
const FRAME_POLLS: u32 = 2_000;
/// TIMx: update generation, counter enable.
const EGR_UG: u32 = 1 << 0;
const CR1_CEN: u32 = 1 << 0;

/// The converter's hardware, configured and stopped.
pub struct AdcHw {
    tim: pac::TIM3,
    spi: pac::SPI1,
    dma: pac::DMA1,
}

impl AdcHw {
    /// SPI1, TIM3 and both DMA channels configured; nothing runs yet.
    pub fn new(tim: pac::TIM3, spi: pac::SPI1, dma: pac::DMA1) -> Self {
        write(spi.cr1(), ADC_SPI_CR1 as u16);
        let dr = spi.dr().as_ptr() as u32;
        let tx = dma.ch(TX);
        write(tx.par(), dr);
        write(tx.mar(), TX_WORD.as_ptr() as u32);
        write(tx.ndtr(), 1);
        write(tx.cr(), TX_CCR | dma_ccr::EN);
        let rx = dma.ch(RX);
        write(rx.par(), dr);
        write(rx.mar(), RING.as_ptr() as u32);
        write(rx.ndtr(), RX_CNDTR);
        write(rx.cr(), RX_CCR);
        write(tim.psc(), 0);
        write(tim.arr(), PERIOD_TICKS - 1);
        write(tim.ccr3(), CNV_FALL);
        write(tim.ccr4(), FRAME_START);
        write(tim.ccmr2_output(), TIM3_CCMR2);
        write(tim.ccer(), TIM3_CCER);
        write(tim.dier(), TIM3_DIER);
        write(tim.egr(), EGR_UG);
        Self { tim, spi, dma }
    }

    /// Starts the conversions; returns the time (ns) ring word 0's conversion starts.
    /// The frames before it are read and dropped here; a frame that does not come is
    /// logged and the ring starts anyway (its words then stay 0).
    pub fn start(&mut self) -> u64 {
        let t0 = time::now_ns();
        write(self.tim.cr1(), CR1_CEN);
        for frame in 0..FIRST_RESULT {
            if !wait(FRAME_POLLS, || read(self.spi.sr()) & SPI_RXNE != 0) {
                defmt::error!("AD7689 start-up frame {} did not come", frame);
            }
            let _dummy = read(self.spi.dr());
            if frame + 1 == CFG_FRAMES {
                TX_WORD.store(0, Ordering::Relaxed);
            }
        }
        write(self.spi.cr2(), SPI_CR2_RXDMAEN as u16);
        write(self.dma.ch(RX).cr(), RX_CCR | dma_ccr::EN);
        t0 + u64::from(FIRST_RESULT) * u64::from(SAMPLE_PERIOD_NS)
    }
}

/// The DMA interrupt: counts the half (or the whole) ring completed, and errors.
pub fn on_dma_interrupt() {
    // SAFETY: DMA1_ISR is read-only and IFCR write-1-to-clear: only the RX channel's flags
    // are touched, by this interrupt alone.
    let dma = unsafe { &*pac::DMA1::ptr() };
    let isr = read(dma.isr());
    write(dma.ifcr(), isr & dma_flags(RX_CHANNEL));
    if isr & RX_HT != 0 {
        HALVES.on_terminal_count();
    }
    if isr & RX_TC != 0 {
        HALVES.on_terminal_count();
    }
    if isr & RX_TE != 0 {
        DMA_ERRORS.fetch_add(1, Ordering::Relaxed);
    }
}

/// Words the RX channel has written into the ring.
fn written() -> Result<u32, PositionError> {
    // SAFETY: reads the RX channel's count only (read-only use of DMA1).
    let dma = unsafe { &*pac::DMA1::ptr() };
    let ring = RING.as_ptr() as u32;
    let dst = rx_destination(ring, read(dma.ch(RX).ndtr()));
    // The ring starts at word 0 (no skip word): "not started" and "at word 0" agree.
    words_written(HALVES.get(), dst, ring, ring)
}

/// The PDI task's side: whole scans out of the ring.
pub struct AdcSource {
    reader: ScanReader,
    position_errors: u32,
    dma_errors: u32,
    word0_ns: Option<u64>,
}

impl AdcSource {
    /// A reader at ring word 0.
    pub const fn new() -> Self {
        Self {
            reader: ScanReader::new(),
            position_errors: 0,
            dma_errors: 0,
            word0_ns: None,
        }
    }

    /// The conversions started; ring word 0 is converted at `word0_ns`.
    pub fn started(&mut self, word0_ns: u64) {
        if firmware::io::analog::oversampling::BUILT {
            self.word0_ns = Some(word0_ns);
        }
    }

    /// The ring, its write position and its timing to the oversampling stream.
    pub fn feed<A: AnalogApplication>(&mut self, app: &mut A) {
        if !firmware::io::analog::oversampling::BUILT {
            return;
        }
        let analog = app.analog();
        if let (Some(w0), Ok(n)) = (self.word0_ns, written()) {
            analog.stream.set_word0(w0);
            analog.on_adc_ring(&RING, n);
        }
    }

    /// Adds the whole scans the DMA wrote since the last call; returns the samples added.
    pub fn drain_into(&mut self, sampler: &mut Sampler) -> usize {
        let errors = DMA_ERRORS.load(Ordering::Relaxed);
        if errors != self.dma_errors {
            self.dma_errors = errors;
            defmt::error!("DMA1 channel 2 errors: {}", errors);
        }
        match self.reader.drain(&RING, written, sampler) {
            Ok(report) => report.scans as usize * firmware::platform::board::AI_CHANNELS,
            Err(PositionError::OutsideRing(dst)) => {
                if self.position_errors == 0 {
                    defmt::error!("ADC DMA address {=u32:#x} outside the ring", dst);
                }
                self.position_errors = self.position_errors.wrapping_add(1);
                0
            }
        }
    }
}
