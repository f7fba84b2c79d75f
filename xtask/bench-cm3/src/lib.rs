//! The firmware's hot paths as benchmark scenarios, for a real Cortex-M3 instruction set
//! (`cargo xtask bench` runs `src/main.rs` under QEMU with an instruction-counting plugin).
//!
//! Everything measured is the firmware's own code ([`firmware::stacks::ethercat`], `coe-core`); only the
//! ESC is the register file of the firmware's tests ([`FakeEsc`], in RAM), so the counts are
//! the application's CPU work without the SPI transfers (those are counted in bytes on the
//! virtual board and converted to time separately). A [`Rig`] is brought to OP in DC SYNC0
//! mode with the module's own description ([`firmware::products::analog_io`]:
//! default process data 2 AO in SM2, 8 AI in SM3), then each path is
//! prepared (not measured), run (measured) and checked (not measured):
//!
//! | path            | firmware code                                   | when it runs on the board |
//! |-----------------|-------------------------------------------------|---------------------------|
//! | `sync0_ldac`    | [`DacLatch::latch_at_sync0`] with a preloaded pair: up to the LDAC edge | SYNC0 task, every cycle |
//! | `sync0_record`  | [`DacLatch::record_sync0`]: the edge recorded after the LDAC edge | SYNC0 task, every cycle |
//! | `dac_preload`   | [`DacLatch::preload`]                           | DAC task after new outputs|
//! | `pdi_outputs`   | [`SlaveApp::on_pdi_irq`] on the SM2 event       | PDI task, every cycle     |
//! | `pdi_inputs`    | [`SlaveApp::poll`] after a SYNC0 edge (SM3), one whole ADC scan drained before it ([`Rig::adc_scan`]) | PDI task, every cycle |
//! | `sdo_upload`    | [`SlaveApp::on_pdi_irq`] on SM0 and the mailbox task's steps: expedited upload 0x1018:02 | per SDO request |
//! | `sdo_download`  | [`SlaveApp::on_pdi_irq`] on SM0 and the mailbox task's steps: expedited download 0x6443:01 | per SDO request |
//! | `dma_scan_drain`| [`ScanReader::drain`] of one scan from the GPDMA ring, incl. both position computations ([`words_written`]) | PDI task (default GPDMA path) |
//! | `dma_half_irq`  | [`HalfCounter::on_terminal_count`]              | GPDMA interrupt, per half ring |
//! | `sample_push`   | [`SampleProducer::push`] of one sample          | sampler, 250 000 /s (`adc-irq`) |
//! | `sampler_drain` | [`SampleConsumer::drain_into`] of one 8-channel scan | PDI task (`adc-irq`) |
//! | `esc_read4`, `esc_write16`, `esc_nop` | the register file itself (not firmware): its cost per access | - |
//! | `driver_read4`, `driver_write16`, `driver_nop` | the `et1100` SPI driver's work per access ([`driver_port`]) | every ESC access |
#![no_std]
#![forbid(unsafe_code)]

use core::convert::Infallible;
use core::hint::black_box;
use core::sync::atomic::{AtomicU16, AtomicU32, Ordering};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use et1100::{Et1100, SpiPdi};
pub use firmware::fake_esc::FakeEsc;
use firmware::io::analog::adc_dma::{
    words_written, HalfCounter, PositionError, ScanReader, HALF_WORDS, RING_WORDS,
};
use firmware::io::analog::outputs::{DacAction, DacLatch, DacPair, OutputStage};
use firmware::io::analog::sampler::{PublishMode, Sample, SampleConsumer, SampleProducer, Sampler};
use firmware::platform::board::AI_CHANNELS as CHANNELS;
use firmware::products::analog_io::{self, Application, CONFIG};
use firmware::stacks::ethercat::mailbox::MAILBOX_SIZE;
use firmware::stacks::ethercat::{PdiOutcome, SlaveApp};

/// Ring length of the sampler scenario (one scan fits many times).
pub const RING: usize = 64;

/// A scenario that did not do what it should (the benchmark would measure the wrong thing).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CheckFailed(pub &'static str);

/// The slave application in OP (DC SYNC0) on the register-file ESC.
pub struct Rig {
    /// The ESC (master side through its `master_*` methods).
    pub esc: FakeEsc,
    /// The slave application with the default product's application.
    pub app: SlaveApp<Application>,
    /// The PDI -> DAC task stage.
    pub stage: OutputStage,
    /// The DAC task's latch.
    pub latch: DacLatch,
    /// The PDI task's sampler (fed by the ring).
    pub sampler: Sampler,
    now_ns: u64,
    counter: u8,
    cycle: u16,
    output_len: u16,
    reply: [u8; MAILBOX_SIZE],
}

impl Rig {
    /// Power-up and the master's ESM walk to OP with DC SYNC0 at `cycle_ns`.
    pub fn new(cycle_ns: u32) -> Result<Self, CheckFailed> {
        let mut esc = FakeEsc::new();
        let pd = analog_io::process_data();
        let (out_len, in_len) = (pd.output_len() as u16, pd.input_len() as u16);
        let mut app = SlaveApp::new(CONFIG, analog_io::application());
        app.start(&mut esc.driver())
            .map_err(|_| CheckFailed("start"))?;
        let mut rig = Self {
            esc,
            app,
            stage: OutputStage::new(),
            latch: DacLatch::new(),
            sampler: Sampler::new(PublishMode::Latest),
            now_ns: 0,
            counter: 0,
            cycle: 0,
            reply: [0; MAILBOX_SIZE],
            output_len: out_len,
        };
        let [m0, m1, p2, p3] = CONFIG.sm;
        rig.esc.master_sm(0, m0.start, m0.len, m0.control, true);
        rig.esc.master_sm(1, m1.start, m1.len, m1.control, true);
        rig.request(0x02, "INIT -> PREOP")?;
        rig.esc.master_sm(2, p2.start, out_len, p2.control, true);
        rig.esc.master_sm(3, p3.start, in_len, p3.control, true);
        // DC: cyclic unit + SYNC0 (0x0981 = 0x03).
        rig.esc.master_dc(0x03, cycle_ns);
        rig.request(0x04, "PREOP -> SAFEOP")?;
        rig.request(0x08, "SAFEOP -> OP")?;
        Ok(rig)
    }

    fn tick(&mut self) -> u64 {
        self.now_ns += 10_000;
        self.now_ns
    }

    fn request(&mut self, state: u16, what: &'static str) -> Result<(), CheckFailed> {
        self.esc.master_al_control(state);
        self.irq().map_err(|_| CheckFailed(what))?;
        if self.esc.al_status() == (state, 0) {
            Ok(())
        } else {
            Err(CheckFailed(what))
        }
    }

    /// The PDI IRQ handler once, then the mailbox task's steps if it asked for them.
    pub fn irq(&mut self) -> Result<PdiOutcome, CheckFailed> {
        let now = self.tick();
        let failed = |_| CheckFailed("ESC access failed");
        let mut out = self
            .app
            .on_pdi_irq(&mut self.esc.driver(), &self.stage, now)
            .map_err(failed)?;
        if out.serve_mailbox {
            let mbx = self
                .app
                .serve_mailbox(&mut self.esc.driver(), &self.stage, now);
            out.apply_outputs |= mbx.map_err(failed)?.apply_outputs;
        }
        Ok(out)
    }

    /// The PDI task's background call once.
    pub fn poll(&mut self) -> Result<PdiOutcome, CheckFailed> {
        let now = self.tick();
        self.app
            .poll(&mut self.esc.driver(), &self.stage, now)
            .map_err(|_| CheckFailed("ESC access failed"))
    }

    /// The SYNC0 task once: [`Rig::sync0_latch`], then [`Rig::sync0_record`].
    pub fn sync0(&mut self) -> DacAction {
        let action = self.sync0_latch();
        self.sync0_record();
        action
    }

    /// The SYNC0 task up to the LDAC edge: the latch decision.
    pub fn sync0_latch(&mut self) -> DacAction {
        self.latch.latch_at_sync0(&self.stage)
    }

    /// The SYNC0 task after the LDAC edge: the edge recorded for the PDI side.
    pub fn sync0_record(&mut self) {
        let now = self.tick();
        DacLatch::record_sync0(&self.stage, now);
    }

    /// The DAC task's preload once.
    pub fn preload(&mut self) -> Option<DacPair> {
        self.latch.preload(&self.stage)
    }

    /// Master side of a cycle: fresh outputs (both AO) into SM2.
    pub fn master_outputs(&mut self) {
        self.cycle = self.cycle.wrapping_add(1);
        let a = (self.cycle & 0x3FFF) as i16;
        let b = 0x2000 - a;
        let mut image = [0u8; 64];
        image[..2].copy_from_slice(&a.to_le_bytes());
        image[2..4].copy_from_slice(&b.to_le_bytes());
        let n = usize::from(self.output_len).min(image.len());
        self.esc.master_write_outputs(&image[..n]);
    }

    /// The ADC side of a cycle: one whole 8-channel scan drained into the application's
    /// sampler, as the PDI task does before the inputs of every DC cycle on the image (the
    /// shortest cycle is longer than a 32 us scan). Returns the codes the inputs must carry.
    pub fn adc_scan(&mut self) -> [u16; CHANNELS] {
        let base = self.cycle.wrapping_mul(8);
        let mut scan = [0u16; CHANNELS];
        for (code, n) in scan.iter_mut().zip(0u16..) {
            *code = base.wrapping_add(n);
        }
        self.app
            .application_mut()
            .sampler
            .add_whole_scan(&scan, |c| *c);
        scan
    }

    /// Whether the last inputs published `scan`.
    pub fn check_published(&self, scan: &[u16; CHANNELS]) -> Result<(), CheckFailed> {
        if self.app.application().sampler.codes() == scan {
            Ok(())
        } else {
            Err(CheckFailed("pdi_inputs: the scan was not published"))
        }
    }

    /// One whole DC cycle without measuring (outputs, preload, SYNC0, scan, inputs).
    pub fn cycle(&mut self) -> Result<(), CheckFailed> {
        self.master_outputs();
        self.irq()?;
        self.preload();
        self.sync0();
        let scan = self.adc_scan();
        self.poll()?;
        self.check_published(&scan)?;
        self.check_op()
    }

    /// Still in OP without error.
    pub fn check_op(&self) -> Result<(), CheckFailed> {
        if self.esc.al_status() == (0x08, 0) {
            Ok(())
        } else {
            Err(CheckFailed("the slave left OP"))
        }
    }

    /// Master side: an SDO request (expedited frame) into SM0.
    pub fn master_sdo(
        &mut self,
        command: u8,
        index: u16,
        sub: u8,
        data: [u8; 4],
    ) -> Result<(), CheckFailed> {
        self.counter = self.counter % 7 + 1;
        let i = index.to_le_bytes();
        let frame = [
            10,
            0,
            0,
            0,
            0x00,
            0x03 | self.counter << 4,
            0x00,
            0x20,
            command,
            i[0],
            i[1],
            sub,
            data[0],
            data[1],
            data[2],
            data[3],
        ];
        if self.esc.master_write_mailbox(&frame) {
            Ok(())
        } else {
            Err(CheckFailed("SM0 still full"))
        }
    }

    /// Master side: takes the SDO reply from SM1; returns its SDO command byte and data.
    pub fn master_sdo_reply(&mut self) -> Result<(u8, [u8; 4]), CheckFailed> {
        let mut reply = self.reply;
        self.esc
            .master_read_mailbox_into(&mut reply)
            .ok_or(CheckFailed("no SDO reply in SM1"))?;
        self.reply = reply;
        // The SM1 event: the PDI task sees the mailbox free again.
        self.irq()?;
        Ok((reply[8], [reply[12], reply[13], reply[14], reply[15]]))
    }
}

/// One sample per call, channels in scan order.
pub fn push_one(producer: &mut SampleProducer<'_, RING>, k: u32) -> bool {
    producer.push(Sample::new((k % 8) as u8, (k as u16).wrapping_mul(257)))
}

/// Queues one 8-channel scan (not measured).
pub fn queue_scan(producer: &mut SampleProducer<'_, RING>) -> Result<(), CheckFailed> {
    for ch in 0..8u8 {
        if !producer.push(Sample::new(ch, 0x1000 * u16::from(ch))) {
            return Err(CheckFailed("sample ring full"));
        }
    }
    Ok(())
}

/// Moves the queued samples into the sampler.
pub fn drain(consumer: &mut SampleConsumer<'_, RING>, sampler: &mut Sampler) -> usize {
    consumer.drain_into(sampler)
}

/// The GPDMA path's PDI-side state: the ring the DMA fills, the half count its interrupt
/// keeps and a stand-in for the RX channel's destination address register (a plain memory
/// word here; its bus access is added in the bench's model, not counted).
pub struct DmaRig {
    /// The ring (the DMA's destination).
    pub ring: [AtomicU16; RING_WORDS],
    /// The interrupt's half count.
    pub halves: HalfCounter,
    /// DMACC0DestAddr stand-in.
    pub dst: AtomicU32,
    /// The PDI task's reader.
    pub reader: ScanReader,
    written: u32,
}

/// Where the ring "is" for the address arithmetic (any word-aligned AHB SRAM address).
const RING_ADDR: u32 = 0x2007_C000;
/// The skip word's address (just after the ring).
const SKIP_ADDR: u32 = RING_ADDR + 2 * RING_WORDS as u32;

impl Default for DmaRig {
    fn default() -> Self {
        Self::new()
    }
}

impl DmaRig {
    /// An empty ring, the DMA at its start.
    pub fn new() -> Self {
        Self {
            ring: core::array::from_fn(|_| AtomicU16::new(0)),
            halves: HalfCounter::new(),
            dst: AtomicU32::new(RING_ADDR),
            reader: ScanReader::new(),
            written: 0,
        }
    }

    /// The DMA writes one scan (not measured): words, address, and the half count as the
    /// interrupt would keep it.
    pub fn dma_writes_scan(&mut self) {
        for ch in 0..8u32 {
            let i = self.written as usize % RING_WORDS;
            self.ring[i].store((0x1000 * ch + self.written / 8) as u16, Ordering::Relaxed);
            self.written = self.written.wrapping_add(1);
            if self.written % HALF_WORDS as u32 == 0 {
                self.halves.on_terminal_count();
            }
        }
        let at = self.written as usize % RING_WORDS;
        self.dst.store(RING_ADDR + 2 * at as u32, Ordering::Relaxed);
    }

    /// The position as `hw::adc_dma` computes it (the register read replaced by a load).
    pub fn words_written(&self) -> Result<u32, PositionError> {
        let halves = self.halves.get();
        let dst = self.dst.load(Ordering::Relaxed);
        words_written(halves, dst, RING_ADDR, SKIP_ADDR)
    }

    /// The PDI task's drain; returns the scans added.
    pub fn drain(&mut self, sampler: &mut Sampler) -> Result<u32, CheckFailed> {
        let Self {
            ring,
            halves,
            dst,
            reader,
            ..
        } = self;
        let position = || {
            words_written(
                halves.get(),
                dst.load(Ordering::Relaxed),
                RING_ADDR,
                SKIP_ADDR,
            )
        };
        reader
            .drain(ring, position, sampler)
            .map(|r| r.scans)
            .map_err(|_| CheckFailed("DMA position outside the ring"))
    }
}

/// An SPI device that clocks nothing: MISO reads as 0. Under the `et1100` driver it leaves
/// the driver's own work per access (address phase, wait and termination bytes, event bits)
/// plus a minimal per-byte loop; the bus time itself is counted in bytes elsewhere.
#[derive(Debug, Default)]
pub struct NullSpi;

impl ErrorType for NullSpi {
    type Error = Infallible;
}

impl SpiDevice<u8> for NullSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        // Opaque to the optimiser, as the bus's registers are: the driver must build every
        // byte it sends and cannot drop the bytes it receives, however little is done here.
        for op in black_box(operations).iter_mut() {
            match op {
                Operation::Read(buf)
                | Operation::Transfer(buf, _)
                | Operation::TransferInPlace(buf) => {
                    buf.fill(0);
                    black_box(buf);
                }
                Operation::Write(_) | Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}

/// The `et1100` SPI driver over [`NullSpi`], as the firmware's application drives it.
pub fn driver_port() -> Et1100<SpiPdi<NullSpi>> {
    Et1100::new(SpiPdi::new(NullSpi))
}

#[cfg(test)]
mod tests;
