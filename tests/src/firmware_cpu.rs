//! The firmware's own slave application ([`firmware::app::SlaveApp`]) running on the
//! board's models, with its interrupts in priority order on virtual time:
//!
//! | board event        | firmware task (priority)  | here                                         |
//! |--------------------|---------------------------|----------------------------------------------|
//! | SYNC0 edge         | DAC task (highest)        | [`DacLatch::on_sync0`] -> AD5663 frames / LDAC |
//! | ESC IRQ line       | PDI task (middle)         | [`SlaveApp::on_pdi_irq`], then the DAC task if pended |
//! | after every event  | PDI task background       | [`SlaveApp::poll`]                           |
//! | ADC timer (4 us)   | CNV timer + DMA (hardware)| one AD7689 frame, the sample queued for the PDI task |
//!
//! The application talks to the ESC through [`SpiEscPort`], which speaks the ET1100 SPI
//! protocol to the byte-exact SPI model ([`EscSpi`]); the DAC task writes 24-bit AD5663
//! frames and pulses LDAC; the sampler clocks 16-bit AD7689 frames. (These three adapters
//! stand in for the `et1100`, `ad5663` and `ad7689` driver crates until those land; they
//! are deliberately thin and byte-exact so swapping the real drivers in changes no
//! behaviour the master can see.)
//!
//! DC mode uses the fast path of the brief: when new outputs arrive, the DAC task preloads
//! both input registers (LDAC register 0: nothing changes), and the SYNC0 task only
//! pulses LDAC, so both channels change together at the edge.

use crate::board::{BoardIo, PdiCpu};
use crate::esc::SyncEdge;
use crate::spi::EscSpi;
use embedded_hal::digital::OutputPin;
use embedded_hal::spi::{Operation, SpiDevice};
use firmware::app::esc::EscPort;
use firmware::app::outputs::{DacAction, DacLatch, DacPair, OutputStage};
use firmware::app::process_data::ProcessData;
use firmware::app::sampler::Sample;
use firmware::app::{AppConfig, PdiOutcome, SlaveApp};
use std::convert::Infallible;

/// ET1100 SPI commands (hardware-facts 1.2).
mod cmd {
    pub const READ_WAIT: u8 = 0b011;
    pub const WRITE: u8 = 0b100;
    pub const ADDR_EXT: u8 = 0b110;
}

/// The application's [`EscPort`] over the ET1100 SPI protocol: read with a wait state and
/// 0xFF termination, write; 2-byte addressing below 0x2000, 3-byte above. Every access
/// returns the AL event bits shifted out during its address phase.
pub struct SpiEscPort {
    spi: EscSpi,
}

impl SpiEscPort {
    /// A port on the board's ESC SPI.
    pub fn new(spi: EscSpi) -> Self {
        Self { spi }
    }

    fn header(addr: u16, command: u8) -> Vec<u8> {
        if addr < 0x2000 {
            vec![(addr >> 5) as u8, ((addr & 0x1F) << 3) as u8 | command]
        } else {
            vec![
                (addr >> 5) as u8,
                ((addr & 0x1F) << 3) as u8 | cmd::ADDR_EXT,
                ((addr >> 13) << 5) as u8 | command << 2,
            ]
        }
    }

    fn events(miso: &[u8]) -> u32 {
        miso.iter()
            .enumerate()
            .fold(0u32, |acc, (i, &b)| acc | (b as u32) << (8 * i))
    }
}

impl EscPort for SpiEscPort {
    type Error = Infallible;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<u32, Infallible> {
        let mut hdr = Self::header(addr, cmd::READ_WAIT);
        hdr.push(0xFF); // wait state
        let mut ev = vec![0u8; hdr.len()];
        if buf.is_empty() {
            self.spi
                .transaction(&mut [Operation::Transfer(&mut ev, &hdr)])?;
        } else {
            let mut mosi = vec![0u8; buf.len()];
            *mosi.last_mut().unwrap_or(&mut 0) = 0xFF;
            self.spi.transaction(&mut [
                Operation::Transfer(&mut ev, &hdr),
                Operation::Transfer(buf, &mosi),
            ])?;
        }
        let n = ev.len() - 1;
        Ok(Self::events(&ev[..n]))
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<u32, Infallible> {
        let hdr = Self::header(addr, cmd::WRITE);
        let mut ev = vec![0u8; hdr.len()];
        self.spi
            .transaction(&mut [Operation::Transfer(&mut ev, &hdr), Operation::Write(data)])?;
        Ok(Self::events(&ev))
    }
}

/// What the device description gives the firmware: the object dictionary, the SyncManager
/// expectations, the default PDO configuration and the SII image.
#[derive(Clone)]
pub struct Device {
    /// For the user.
    pub description: String,
    /// The object dictionary.
    pub od: &'static coe_core::od::ObjectDictionary,
    /// SyncManagers and device ID.
    pub config: AppConfig,
    /// The default PDO configuration.
    pub process_data: ProcessData,
    /// The SII EEPROM image.
    pub sii: Vec<u8>,
}

/// AD7689 CFG: overwrite, unipolar to GND (INCC 111), scan IN0..IN7 (INx 7, SEQ 11: no
/// temperature), full bandwidth, external reference, no readback.
pub const ADC_SCAN_CFG: u16 = 0x3FFF;

/// Counters of the harness.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FirmwareStats {
    /// AD7689 frames clocked.
    pub adc_frames: u64,
    /// Samples handed to the application.
    pub samples: u64,
    /// AD5663 frames written.
    pub dac_frames: u64,
    /// LDAC pulses.
    pub ldac_pulses: u64,
    /// DAC actions by kind: (keep, pulse LDAC, write and update, apply now).
    pub sync0_pulses: u64,
    /// SYNC0 edges that kept the outputs (no fresh pair).
    pub sync0_keep: u64,
}

/// The firmware's slave application as the board's PDI-side CPU.
pub struct FirmwareCpu {
    esc: SpiEscPort,
    io: BoardIo,
    app: SlaveApp,
    stage: OutputStage,
    latch: DacLatch,
    pending: Vec<Sample>,
    adc_period_ns: u64,
    next_cnv_ns: u64,
    /// Counters.
    pub stats: FirmwareStats,
}

impl FirmwareCpu {
    /// Power-up: the application starts (AL status INIT, event mask), the DAC's LDAC
    /// register is cleared (LDAC pin controls both channels), the ADC gets its scan CFG
    /// and its conversion timer runs at `adc_period_ns` (4000 = 250 kSPS).
    pub fn new(io: BoardIo, device: &Device, adc_period_ns: u64) -> Self {
        let mut esc = SpiEscPort::new(io.esc.clone());
        let mut app = SlaveApp::new(device.od, device.config, device.process_data.clone());
        let _ = app.start(&mut esc);
        let mut cpu = Self {
            esc,
            io,
            app,
            stage: OutputStage::new(),
            latch: DacLatch::new(),
            pending: Vec::new(),
            adc_period_ns: adc_period_ns.max(1),
            next_cnv_ns: 0,
            stats: FirmwareStats::default(),
        };
        cpu.dac_frame(0b110, 0b000, 0x0000);
        cpu.next_cnv_ns = cpu.io.now_ns() + cpu.adc_period_ns;
        cpu.adc_frame(Some(ADC_SCAN_CFG));
        cpu
    }

    /// The application (state, data, mailbox).
    pub fn app(&self) -> &SlaveApp {
        &self.app
    }

    /// The output stage shared by the PDI and DAC tasks.
    pub fn stage(&self) -> &OutputStage {
        &self.stage
    }

    fn dac_frame(&mut self, command: u8, address: u8, data: u16) {
        let b = [command << 3 | address, (data >> 8) as u8, data as u8];
        let _ = self.io.dac.transaction(&mut [Operation::Write(&b)]);
        self.stats.dac_frames += 1;
    }

    fn execute(&mut self, action: DacAction) {
        match action {
            DacAction::Keep => {}
            DacAction::PulseLdac(_) => {
                let _ = self.io.ldac.set_low();
                let _ = self.io.ldac.set_high();
                self.stats.ldac_pulses += 1;
            }
            DacAction::WriteAndUpdate(p) => {
                self.write_inputs(p, true);
            }
        }
    }

    /// Writes both input registers; `update`: the second write updates all (command 010).
    fn write_inputs(&mut self, p: DacPair, update: bool) {
        self.dac_frame(0b000, 0b000, p.a);
        self.dac_frame(if update { 0b010 } else { 0b000 }, 0b001, p.b);
    }

    /// The DAC task, pended by the PDI task.
    fn dac_task(&mut self, out: PdiOutcome) {
        if out.apply_outputs {
            let a = self.latch.apply_now(&self.stage);
            self.execute(a);
        }
        if self.stage.dc_mode() {
            if let Some(p) = self.latch.preload(&self.stage) {
                self.write_inputs(p, false);
            }
        }
    }

    /// One AD7689 frame (CNV low period); `cfg` is written when given. Returns the code.
    fn adc_frame(&mut self, cfg: Option<u16>) -> u16 {
        let w = cfg.map_or(0, |c| c << 2);
        let mosi = [(w >> 8) as u8, w as u8];
        let mut miso = [0u8; 2];
        let _ = self
            .io
            .adc
            .transaction(&mut [Operation::Transfer(&mut miso, &mosi)]);
        self.stats.adc_frames += 1;
        u16::from_be_bytes(miso)
    }

    fn drain_samples(&mut self) {
        if !self.pending.is_empty() {
            self.stats.samples += self.pending.len() as u64;
            self.app.on_samples(&self.pending);
            self.pending.clear();
        }
    }
}

impl PdiCpu for FirmwareCpu {
    fn on_sync0(&mut self, io: &mut BoardIo, edge: &SyncEdge) {
        let _ = io;
        let a = self.latch.on_sync0(&self.stage, edge.time_ns);
        match a {
            DacAction::Keep => self.stats.sync0_keep += 1,
            _ => self.stats.sync0_pulses += 1,
        }
        self.execute(a);
    }

    fn on_irq(&mut self, io: &mut BoardIo) {
        self.drain_samples();
        let Ok(out) = self.app.on_pdi_irq(&mut self.esc, &self.stage, io.now_ns());
        self.dac_task(out);
    }

    fn poll(&mut self, io: &mut BoardIo) {
        self.drain_samples();
        let Ok(out) = self.app.poll(&mut self.esc, &self.stage, io.now_ns());
        self.dac_task(out);
    }

    fn next_timer_ns(&self) -> Option<u64> {
        Some(self.next_cnv_ns)
    }

    fn on_timer(&mut self, io: &mut BoardIo) {
        // Read-after-conversion: frame k >= 2 after the CFG frame (k = 0) returns the
        // conversion of IN(k - 2) mod 8 (two power-up dummies first).
        let k = self.stats.adc_frames;
        let code = self.adc_frame(None);
        if k >= 2 {
            self.pending.push(Sample::new(((k - 2) % 8) as u8, code));
        }
        self.next_cnv_ns = io.now_ns().max(self.next_cnv_ns) + self.adc_period_ns;
    }
}
