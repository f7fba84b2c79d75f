//! The firmware's own slave application ([`firmware::app::SlaveApp`]) running on the
//! board's models through the real driver crates, with its interrupts in priority order on
//! virtual time:
//!
//! | board event        | firmware task (priority)  | here                                         |
//! |--------------------|---------------------------|----------------------------------------------|
//! | SYNC0 edge         | DAC task (highest)        | [`DacLatch::on_sync0`] -> `ad5663` (LDAC pulse or two frames) |
//! | ESC IRQ line       | PDI task (middle)         | [`SlaveApp::on_pdi_irq`], then the DAC task if pended |
//! | after every event  | PDI task background       | [`SlaveApp::poll`]                           |
//! | ADC timer (4 us)   | CNV timer + SSP (hardware)| one `ad7689` frame, the sample queued for the PDI task |
//!
//! The drivers are the ones the board runs:
//! - ESC: `et1100::Et1100<SpiPdi<EscSpi>>`, the application's `EscPort` through the
//!   firmware's own impl (`firmware/src/app/esc/driver.rs`), over the byte-exact SPI model.
//! - DAC: `ad5663::Ad5663` on the DAC model's SPI port with the LDAC pin model.
//! - ADC: `ad7689::Ad7689` (read after conversion, CNV = chip select) on the ADC model; the
//!   driver tracks the CFG pipeline and tags every sample with its channel.
//!
//! DC mode uses the fast path of the brief: when new outputs arrive, the DAC task stages
//! both input registers (LDAC register 0: nothing changes), and the SYNC0 task only
//! pulses LDAC, so both channels change together at the edge.

use crate::adc::AdcSpi;
use crate::board::{BoardIo, PdiCpu};
use crate::dac::{DacSpi, LdacPin};
use crate::esc::SyncEdge;
use crate::spi::EscSpi;
use ad5663::{Ad5663, Channel, LdacMask, PowerMode};
use ad7689::{Ad7689, Config, Reference, Sequencer};
use et1100::{Et1100, SpiPdi};
use firmware::app::outputs::{DacAction, DacLatch, OutputStage};
use firmware::app::process_data::ProcessData;
use firmware::app::sampler::Sample;
use firmware::app::{AppConfig, PdiOutcome, SlaveApp};

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
/// temperature), full bandwidth, external reference with buffer, no readback: CFG 0x3FFF,
/// the firmware's `ADC_SCAN_CFG` (firmware/src/hw/timers.rs).
pub const ADC_SCAN: Config = Config::new()
    .channel(7)
    .reference(Reference::ExternalBuffer)
    .sequencer(Sequencer::Scan);

/// Frames after power-up whose results are discarded: two carry the CFG, the third may
/// still hold a conversion under the power-up CFG (as `Ad7689::start` does it).
const ADC_START_FRAMES: u64 = 3;

/// The ESC as the application sees it.
type Esc = Et1100<SpiPdi<EscSpi>>;
/// The DAC with its LDAC pin.
type Dac = Ad5663<DacSpi, ad5663::ic::Ad5663, LdacPin>;

/// Counters of the harness.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FirmwareStats {
    /// AD7689 frames clocked.
    pub adc_frames: u64,
    /// Samples handed to the application.
    pub samples: u64,
    /// AD5663 commands sent (one 24-bit frame each).
    pub dac_frames: u64,
    /// LDAC pulses.
    pub ldac_pulses: u64,
    /// SYNC0 edges that changed the outputs.
    pub sync0_pulses: u64,
    /// SYNC0 edges that kept the outputs (no fresh pair).
    pub sync0_keep: u64,
    /// Driver errors (ESC, DAC or ADC); none are expected on the models.
    pub driver_errors: u64,
}

/// The firmware's slave application as the board's PDI-side CPU.
pub struct FirmwareCpu {
    esc: Esc,
    dac: Dac,
    adc: Ad7689<AdcSpi>,
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
    /// Power-up: the application starts (AL status INIT, event mask), the DAC gets both
    /// channels powered and LDAC register 0 (the LDAC pin controls both channels), and the
    /// ADC's conversion timer runs at `adc_period_ns` (4000 = 250 kSPS); its first two
    /// frames write the scan CFG.
    pub fn new(io: BoardIo, device: &Device, adc_period_ns: u64) -> Self {
        let mut esc = Et1100::new(SpiPdi::new(io.esc.clone()));
        let mut app = SlaveApp::new(device.od, device.config, device.process_data.clone());
        let started = app.start(&mut esc).is_ok();
        let Ok(dac) = Ad5663::new_ad5663(io.dac.clone()).with_ldac(io.ldac.clone());
        let mut cpu = Self {
            esc,
            dac,
            adc: Ad7689::new(io.adc.clone()),
            app,
            stage: OutputStage::new(),
            latch: DacLatch::new(),
            pending: Vec::new(),
            adc_period_ns: adc_period_ns.max(1),
            next_cnv_ns: io.now_ns() + adc_period_ns.max(1),
            stats: FirmwareStats::default(),
        };
        cpu.count(started);
        let ok = cpu
            .dac
            .set_power_mode(Channel::Both, PowerMode::Normal)
            .is_ok()
            && cpu.dac.set_ldac_mask(LdacMask::None).is_ok();
        cpu.stats.dac_frames += 2;
        cpu.count(ok);
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

    fn count(&mut self, ok: bool) {
        if !ok {
            self.stats.driver_errors += 1;
        }
    }

    /// Carries out the DAC task's action with the driver.
    fn execute(&mut self, action: DacAction) {
        let ok = match action {
            DacAction::Keep => true,
            DacAction::PulseLdac(_) => {
                self.stats.ldac_pulses += 1;
                self.dac.pulse_ldac().is_ok()
            }
            DacAction::WriteAndUpdate(p) => {
                self.stats.dac_frames += 2;
                self.dac.write_both_simultaneous(p.a, p.b).is_ok()
            }
        };
        self.count(ok);
    }

    /// The DAC task, pended by the PDI task.
    fn dac_task(&mut self, out: PdiOutcome) {
        if out.apply_outputs {
            let a = self.latch.apply_now(&self.stage);
            self.execute(a);
        }
        if self.stage.dc_mode() {
            if let Some(p) = self.latch.preload(&self.stage) {
                self.stats.dac_frames += 2;
                let ok = self.dac.stage_both(p.a, p.b).is_ok();
                self.count(ok);
            }
        }
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
    fn on_sync0(&mut self, _io: &mut BoardIo, edge: &SyncEdge) {
        let a = self.latch.on_sync0(&self.stage, edge.time_ns);
        match a {
            DacAction::Keep => self.stats.sync0_keep += 1,
            _ => self.stats.sync0_pulses += 1,
        }
        self.execute(a);
    }

    fn on_irq(&mut self, io: &mut BoardIo) {
        self.drain_samples();
        match self.app.on_pdi_irq(&mut self.esc, &self.stage, io.now_ns()) {
            Ok(out) => self.dac_task(out),
            Err(_) => self.stats.driver_errors += 1,
        }
    }

    fn poll(&mut self, io: &mut BoardIo) {
        self.drain_samples();
        match self.app.poll(&mut self.esc, &self.stage, io.now_ns()) {
            Ok(out) => self.dac_task(out),
            Err(_) => self.stats.driver_errors += 1,
        }
    }

    fn next_timer_ns(&self) -> Option<u64> {
        Some(self.next_cnv_ns)
    }

    /// One CNV period: one AD7689 frame (the timer paces them at `adc_period_ns`, so the
    /// driver's own `wait_ready` is not needed). The first frames run the driver's
    /// start-up sequence; after that every result comes tagged with its input.
    fn on_timer(&mut self, io: &mut BoardIo) {
        let k = self.stats.adc_frames;
        self.stats.adc_frames += 1;
        let result = if k < ADC_START_FRAMES - 1 {
            self.adc.read_and_configure(ADC_SCAN)
        } else {
            self.adc.read()
        };
        match result {
            Ok(Some(s)) if k >= ADC_START_FRAMES => {
                if let Some(ch) = s.channel.input() {
                    self.pending.push(Sample::new(ch, s.code));
                }
            }
            Ok(_) => {}
            Err(_) => self.stats.driver_errors += 1,
        }
        self.next_cnv_ns = io.now_ns().max(self.next_cnv_ns) + self.adc_period_ns;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_cfg_is_the_firmware_word() {
        assert_eq!(ADC_SCAN.bits(), 0x3FFF);
    }
}
