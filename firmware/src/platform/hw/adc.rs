//! The AD7689 sampling path, chosen at build time.
//!
//! * Default: **GPDMA** ([`super::adc_dma`]): Timer2 matches request the DMA, which toggles
//!   CNV, sends the frames and fills a ring in AHB SRAM; the CPU takes one interrupt per half
//!   ring and the PDI task drains whole scans (`firmware::io::analog::adc_dma`).
//! * Feature `adc-irq`: the **interrupt** path ([`super::timers::AdcSampler`]): one TIMER2
//!   interrupt per sample (`cargo xtask bench` prints its CPU share, F3-irq). Kept because the
//!   DMA path could not be run on a board here: the list walk, the CFG sequence and the ring
//!   arithmetic are host-tested against a GPDMA model and the `ad7689` driver, but the
//!   timer-match DMA requests and the other items of `adc_dma`'s UNCONFIRMED block are not.
//!   If the board shows the DMA path wrong, build with `--features adc-irq`.
//!
//! Both give the same three things to `main.rs`: [`AdcHw`] (built by the board),
//! [`AdcFront`] (the sampler task's, TIMER2 vector) and [`AdcSource`] (the PDI task's
//! `drain_into`), plus [`on_dma_interrupt`] for the GPDMA vector.

use super::ssp::Ssp;
use firmware::io::analog::sampler::Sampler;
use firmware::io::analog::AnalogApplication;
use lpc17xx_pac as pac;

#[cfg(not(feature = "adc-irq"))]
mod path {
    use super::*;
    use crate::hw::adc_dma::{AdcDma, DmaRing};
    use firmware::io::analog::adc_dma::{PositionError, ScanReader};

    /// The configured (stopped) sampling hardware.
    pub struct AdcHw(AdcDma);

    impl AdcHw {
        /// Timer2 + SSP1 + GPDMA.
        pub fn new(t: pac::TIMER2, ssp: Ssp<pac::SSP1>, dma: pac::GPDMA) -> Self {
            Self(AdcDma::new(t, ssp, dma).expect("the ADC DMA is built once, by the board"))
        }
    }

    /// The sampler task's part: starts the timer; the TIMER2 vector is unused (masked).
    pub struct AdcFront(AdcDma);

    impl AdcFront {
        /// Starts the conversions; returns when ring word 0 is converted (time base ns).
        pub fn start(&mut self) -> u64 {
            self.0.start()
        }

        /// TIMER2 is masked on this path; should it fire anyway (match flags raising the
        /// line without MCR interrupt bits, UNCONFIRMED), it is masked again so it cannot
        /// storm, without touching the MR0/MR1 flags the DMA requests may depend on.
        pub fn on_timer_interrupt(&mut self) {
            self.0.silence_timer_interrupt();
        }
    }

    /// The PDI task's part: whole scans out of the DMA ring.
    pub struct AdcSource {
        ring: DmaRing,
        reader: ScanReader,
        position_errors: u32,
        dma_errors: u32,
        word0_ns: Option<u64>,
    }

    impl AdcSource {
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
            if let (Some(w0), Ok(written)) = (self.word0_ns, self.ring.words_written()) {
                analog.stream.set_word0(w0);
                analog.on_adc_ring(self.ring.ring, written);
            }
        }

        /// Adds the whole scans the DMA wrote since the last call; returns the samples added.
        pub fn drain_into(&mut self, sampler: &mut Sampler) -> usize {
            self.check_errors();
            let ring = self.ring;
            match self
                .reader
                .drain(ring.ring, || ring.words_written(), sampler)
            {
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

        /// Logs a GPDMA error once per new error (a channel stops on an error, so the ring
        /// then stops filling and the published values stop changing).
        pub fn check_errors(&mut self) {
            let errors = AdcDma::errors();
            if errors != self.dma_errors {
                self.dma_errors = errors;
                defmt::error!("GPDMA errors: {}", errors);
            }
        }
    }

    /// Splits the hardware between the sampler task and the PDI task.
    pub fn split(hw: AdcHw) -> (AdcFront, AdcSource) {
        let ring = hw.0.ring();
        (
            AdcFront(hw.0),
            AdcSource {
                ring,
                reader: ScanReader::new(),
                position_errors: 0,
                dma_errors: 0,
                word0_ns: None,
            },
        )
    }

    /// The GPDMA interrupt (one per half ring).
    pub fn on_dma_interrupt() {
        crate::hw::adc_dma::on_dma_interrupt();
    }
}

#[cfg(feature = "adc-irq")]
mod path {
    use super::*;
    use crate::hw::mem::{self, SAMPLE_RING_LEN};
    use crate::hw::timers::AdcSampler;
    use firmware::io::analog::sampler::{Sample, SampleConsumer, SampleProducer};

    /// The configured (stopped) sampling hardware.
    pub struct AdcHw(AdcSampler);

    impl AdcHw {
        /// Timer2 + SSP1 (the GPDMA stays unused and unpowered).
        pub fn new(t: pac::TIMER2, ssp: Ssp<pac::SSP1>, _dma: pac::GPDMA) -> Self {
            Self(AdcSampler::new(t, ssp))
        }
    }

    /// The sampler task's part: the TIMER2 interrupt and the ring's producer.
    pub struct AdcFront {
        adc: AdcSampler,
        samples_in: SampleProducer<'static, SAMPLE_RING_LEN>,
        missed_seen: u32,
    }

    impl AdcFront {
        /// Starts the conversions (no ring: the oversampling stream gets none, 0 returned).
        pub fn start(&mut self) -> u64 {
            self.adc.start();
            0
        }

        /// CNV low, previous result into the ring, next frame started.
        pub fn on_timer_interrupt(&mut self) {
            if let Some((channel, code)) = self.adc.on_interrupt() {
                self.samples_in.push(Sample::new(channel, code));
            }
            // A frame not back in time (rare: logged per occurrence, not per sample).
            let missed = self.adc.missed();
            if missed != self.missed_seen {
                self.missed_seen = missed;
                defmt::warn!("AD7689 frames missed: {}", missed);
            }
        }
    }

    /// The PDI task's part: the ring's consumer.
    pub struct AdcSource(SampleConsumer<'static, SAMPLE_RING_LEN>);

    impl AdcSource {
        /// No ring on this path: nothing to record.
        pub fn started(&mut self, _word0_ns: u64) {}

        /// No ring on this path: the oversampling blocks stay empty.
        pub fn feed<A: AnalogApplication>(&mut self, _app: &mut A) {}

        /// Moves every queued sample into `sampler`; returns how many.
        pub fn drain_into(&mut self, sampler: &mut Sampler) -> usize {
            self.0.drain_into(sampler)
        }
    }

    /// Splits the hardware between the sampler task and the PDI task.
    pub fn split(hw: AdcHw) -> (AdcFront, AdcSource) {
        let ring = mem::sample_ring().expect("sample ring is taken only here");
        let (samples_in, samples_out) = ring.split();
        (
            AdcFront {
                adc: hw.0,
                samples_in,
                missed_seen: 0,
            },
            AdcSource(samples_out),
        )
    }

    /// No DMA channel is enabled on this path: the GPDMA vector never fires.
    pub fn on_dma_interrupt() {}
}

pub use path::{on_dma_interrupt, split, AdcFront, AdcHw, AdcSource};
