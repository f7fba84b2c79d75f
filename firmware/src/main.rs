//! RTIC 2 application for the LPC1754 (a stub on the host; build with `cargo xtask build`).
//!
//! | task            | binds / kind          | prio | owns                                     |
//! |-----------------|-----------------------|------|------------------------------------------|
//! | `sync0_dac`     | TIMER1 (CAP1.0, pend) | 3    | SYNC0 capture, AD5663 + LDAC, `DacLatch` |
//! | `pdi`           | EINT3 (P0.22 falling) | 2    | ET1100 (legacy SPI), sample consumer     |
//! | `adc_dma`       | DMA (TC per half ring)| 1    | - (GPDMA path: counts ring halves)       |
//! | `sampler`       | TIMER2 (MR1)          | 1    | ADC front (`adc-irq`: sample producer)   |
//! | `feed_watchdog` | async, SysTick        | 1    | the MCU watchdog                         |
//! | `idle`          | -                     | 0    | `wfi`                                    |
//!
//! The tasks share only the lock-free `OutputStage` (`&'static`) and the two halves of the
//! sample ring (in AHB SRAM); no resource needs a lock. Each bus has one owner. The task
//! bodies call the hardware layer ([`hw`]) and the slave application's logic
//! (`firmware::app`), which is tested on the host.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod hw;

#[cfg(target_os = "none")]
use {defmt_rtt as _, panic_probe as _};

#[cfg(target_os = "none")]
#[rtic::app(device = lpc17xx_pac, dispatchers = [UART2, UART3])]
mod rtic_app {
    use crate::hw;
    use crate::hw::adc::{AdcFront, AdcSource};
    use crate::hw::dac::Dac;
    use crate::hw::esc::EscPdi;
    use crate::hw::gpio_irq::EscIrq;
    use crate::hw::timers::{Sync0Capture, Timer1Event};
    use crate::hw::wdt::Watchdog;
    use core::sync::atomic::{AtomicBool, Ordering};
    use firmware::app::esc::{reg, EscPort};
    use firmware::app::outputs::{DacLatch, OutputStage};
    use firmware::app::pdi_task::LevelIrq;
    use firmware::app::sampler::{PublishMode, Sampler};
    use lpc17xx_pac::Interrupt;
    use rtic_monotonics::systick::prelude::*;

    systick_monotonic!(Mono, 1_000);

    /// Set by the PDI task before it pends TIMER1: "apply the staged outputs now" (free run,
    /// SM-synchronous, fault values), as opposed to a SYNC0 capture.
    static DAC_APPLY: AtomicBool = AtomicBool::new(false);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        sync0: Sync0Capture,
        dac: Dac,
        latch: DacLatch,
        stage_dac: &'static OutputStage,
        esc: EscPdi,
        esc_irq: EscIrq,
        pdi: PdiSide,
        stage_pdi: &'static OutputStage,
        adc: AdcFront,
        wdt: Watchdog,
    }

    /// The PDI task's state besides the ESC.
    ///
    /// SEAM for the slave application: once `firmware::device` (object dictionary, SM
    /// expectations, default PDO configuration) lands, this holds the `SlaveApp` (which owns
    /// the `Sampler`), `start` calls `SlaveApp::start(esc)` instead of masking the ESC
    /// events, and `serve` becomes `app.on_pdi_irq(esc, stage, now)` (pin edge) /
    /// `app.poll(esc, stage, now)` (pended), calling [`request_dac_apply`] when the outcome's
    /// `apply_outputs` is set.
    pub struct PdiSide {
        samples_out: AdcSource,
        sampler: Sampler,
        line: LevelIrq,
        bus_errors: u32,
    }

    impl PdiSide {
        /// Power-up of the PDI side. Without the application nothing serves the AL events, so
        /// the event mask is cleared: the ESC keeps SPI_IRQ released and reports INIT.
        fn start(&mut self, esc: &mut EscPdi) -> Result<(), hw::esc::EscError> {
            esc.write(reg::AL_EVENT_MASK, &0u32.to_le_bytes())?;
            Ok(())
        }

        /// One activation of the PDI task: the AL events of the ESC (pin edge or pended
        /// after SYNC0) and the samples of the ring.
        fn serve(&mut self, esc: &mut EscPdi, _stage: &OutputStage, _now_ns: u64) {
            self.samples_out.drain_into(&mut self.sampler);
            match esc.events() {
                Ok(events) => defmt::trace!("AL events {=u32:#x}", events),
                Err(_) => self.bus_errors = self.bus_errors.wrapping_add(1),
            }
        }
    }

    /// Asks the DAC task to apply the staged outputs now (called from the PDI task).
    #[allow(dead_code)] // used by the slave application's PDI path (see `PdiSide`)
    pub fn request_dac_apply() {
        DAC_APPLY.store(true, Ordering::Release);
        rtic::pend(Interrupt::TIMER1);
    }

    #[init(local = [stage: OutputStage = OutputStage::new()])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let (board, clock_result) = hw::board::init(cx.device);
        if let Err(e) = clock_result {
            defmt::error!("clock setup failed: {}", e);
        }
        defmt::info!("analog-io: clocks {}", board.clocks);
        Mono::start(cx.core.SYST, board.clocks.cclk_hz);

        let hw::board::Board {
            clocks: _,
            mut esc,
            esc_irq,
            esc_eeprom_loaded,
            sync0,
            mut dac,
            adc,
            mut wdt,
        } = board;

        // Outputs to 0 V first: after an MCU-only reset the DAC still drives the old values.
        if dac.init().is_err() {
            defmt::error!("AD5663 init failed");
        }

        let (mut adc, samples_out) = hw::adc::split(adc);
        let mut pdi = PdiSide {
            samples_out,
            sampler: Sampler::new(PublishMode::Latest),
            line: LevelIrq::new(),
            bus_errors: 0,
        };

        if !hw::board::wait_esc_eeprom_loaded(&esc_eeprom_loaded) {
            defmt::warn!("ET1100 EEPROM not loaded yet: PDI may not be operational");
        }
        if pdi.start(&mut esc).is_err() {
            defmt::error!("ET1100: no answer on the SPI PDI");
        }
        if wdt.caused_reset() {
            defmt::warn!("reset by the MCU watchdog");
        }
        wdt.start();
        adc.start();
        if feed_watchdog::spawn().is_err() {
            defmt::error!("watchdog feeder not spawned");
        }

        let stage: &'static OutputStage = cx.local.stage;
        (
            Shared {},
            Local {
                sync0,
                dac,
                latch: DacLatch::new(),
                stage_dac: stage,
                esc,
                esc_irq,
                pdi,
                stage_pdi: stage,
                adc,
                wdt,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// SYNC0 edge (CAP1.0 capture) -> latch the DAC pair; or, pended by the PDI task, apply
    /// now / preload the input registers for the next edge (DC fast path).
    #[task(binds = TIMER1, priority = 3, local = [sync0, dac, latch, stage_dac])]
    fn sync0_dac(cx: sync0_dac::Context) {
        let stage = *cx.local.stage_dac;
        let result = match cx.local.sync0.on_interrupt() {
            Timer1Event::Sync0(t_ns) => {
                let action = cx.local.latch.on_sync0(stage, t_ns);
                let r = cx.local.dac.execute(action);
                rtic::pend(Interrupt::EINT3); // the PDI side's per-cycle work
                r
            }
            Timer1Event::Pended if DAC_APPLY.swap(false, Ordering::AcqRel) => {
                let action = cx.local.latch.apply_now(stage);
                cx.local.dac.execute(action)
            }
            Timer1Event::Pended if stage.dc_mode() => match cx.local.latch.preload(stage) {
                Some(pair) => cx.local.dac.preload(pair),
                None => Ok(()),
            },
            Timer1Event::Pended => Ok(()),
        };
        if result.is_err() {
            defmt::error!("AD5663 write failed");
        }
    }

    /// ESC SPI_IRQ (P0.22 falling edge), or pended after SYNC0.
    #[task(binds = EINT3, priority = 2, local = [esc, esc_irq, pdi, stage_pdi])]
    fn pdi(cx: pdi::Context) {
        let pdi::LocalResources {
            esc,
            esc_irq,
            pdi,
            stage_pdi,
            ..
        } = cx.local;
        let edge = esc_irq.acknowledge();
        pdi.serve(esc, stage_pdi, hw::timers::now_ns());
        // SPI_IRQ is a level: serve again while it stays asserted (bounded).
        if pdi.line.after_serve(edge, esc_irq.still_asserted()) {
            rtic::pend(Interrupt::EINT3);
        }
    }

    /// AD7689, interrupt path (`adc-irq`): CNV low, previous result to the ring, next frame.
    #[task(binds = TIMER2, priority = 1, local = [adc])]
    fn sampler(cx: sampler::Context) {
        cx.local.adc.on_timer_interrupt();
    }

    /// AD7689, GPDMA path: one terminal-count interrupt per half ring.
    #[task(binds = DMA, priority = 1)]
    fn adc_dma(_: adc_dma::Context) {
        hw::adc::on_dma_interrupt();
    }

    /// Feeds the MCU watchdog from the lowest priority: a lock-up above starves it.
    #[task(priority = 1, local = [wdt])]
    async fn feed_watchdog(cx: feed_watchdog::Context) {
        loop {
            cx.local.wdt.feed();
            Mono::delay(hw::wdt::FEED_PERIOD_MS.millis()).await;
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("analog-io runs on the LPC1754: build it with `cargo xtask build`");
}
