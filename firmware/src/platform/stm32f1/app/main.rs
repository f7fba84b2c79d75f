//! The image of `analog-io-stm32`: the RTIC 2 application for the STM32F103VC board (a stub
//! on the host; build with `cargo xtask build --product analog-io-stm32`). It runs the same
//! slave application as the LPC1754 images (`firmware::stacks::ethercat`, generic over
//! `et1100::Pdi`), here over the ET1100's 16-bit µC PDI on the FSMC.
//!
//! | task        | binds / kind                   | prio | owns                                   |
//! |-------------|--------------------------------|------|----------------------------------------|
//! | `sync0_dac` | TIM8_CC (CH1 capture, pend)    | 4    | SYNC0 capture, AD5663 + LDAC, `DacLatch` |
//! | `pdi`       | EXTI0 (PC0 falling, pend)      | 3    | `PdiSide`: ET1100 (FSMC), sample consumer, `SlaveApp` |
//! | `adc_dma`   | DMA1_CHANNEL2 (half ring)      | 2    | - (counts ring halves)                 |
//! | `mailbox`   | UART5 (pend only; UART5 unused) | 1   | - (`PdiSide` one bounded step per lock) |
//! | `tick`      | SysTick, every 1 ms            | 1    | the watchdog (fed every 10 ms); requests the PDI task's background work |
//! | `idle`      | -                              | 0    | `wfi`                                  |
//!
//! The task bodies are the LPC1754 image's (`src/main.rs`) without CAN and without the
//! bootloader: the product has no bootstrap mailbox, so the slave application refuses BOOT
//! and never asks for the bootloader. The PDI and mailbox tasks share the `PdiSide` (the
//! mailbox takes its lock for one bounded step at a time, so process data never waits for a
//! whole mailbox exchange); otherwise the tasks share only the lock-free `OutputStage`
//! (`&'static`), the sample ring and two request flags.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod hw;

#[cfg(all(target_os = "none", feature = "rtt"))]
use defmt_rtt as _;
#[cfg(target_os = "none")]
use panic_probe as _;

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f1::stm32f103)]
mod rtic_app {
    use crate::hw;
    use crate::hw::adc::{AdcHw, AdcSource};
    use crate::hw::dac::Dac;
    use crate::hw::esc::{Esc, EscIrq};
    use crate::hw::gpio::InPin;
    use crate::hw::sync0::{Sync0Capture, Tim8Event};
    use crate::hw::wdt::Watchdog;
    use core::sync::atomic::{AtomicBool, Ordering};
    use cortex_m::peripheral::syst::SystClkSource;
    use firmware::io::analog::outputs::{DacLatch, OutputStage};
    use firmware::io::analog::AnalogApplication;
    use firmware::platform::stm32f1::time::CYCLE_HZ;
    use firmware::products::selected as product;
    use firmware::stacks::ethercat::pdi_task::{PdiTask, Wake, MAILBOX_STEPS};
    use firmware::stacks::ethercat::SlaveApp;
    use stm32f1::stm32f103::Interrupt;

    /// Set by the PDI task before it pends TIM8_CC: "apply the staged outputs now".
    static DAC_APPLY: AtomicBool = AtomicBool::new(false);

    /// Set before EXTI0 is pended for the background work (after SYNC0, by the tick).
    static PDI_POLL: AtomicBool = AtomicBool::new(false);

    /// SysTick rate: the background work without SYNC0.
    const TICK_HZ: u32 = 1_000;
    /// SysTick periods between two feeds of the watchdog.
    const FEED_TICKS: u32 = hw::wdt::FEED_PERIOD_MS * TICK_HZ / 1_000;

    #[shared]
    struct Shared {
        /// The slave application and the ESC: the PDI task's, lent to the mailbox task below
        /// it one bounded step at a time.
        pdi: &'static mut PdiSide,
    }

    #[local]
    struct Local {
        sync0: Sync0Capture,
        dac: Dac,
        latch: DacLatch,
        stage_dac: &'static OutputStage,
        esc_irq: EscIrq,
        esc_eeprom_loaded: InPin,
        stage_pdi: &'static OutputStage,
        stage_mailbox: &'static OutputStage,
        wdt: Watchdog,
    }

    /// The PDI task's state: the slave application, the ESC and the consumer side of the
    /// sample ring.
    pub struct PdiSide {
        task: PdiTask<product::Application>,
        esc: Esc,
        samples_out: AdcSource,
    }

    fn request_dac_apply() {
        DAC_APPLY.store(true, Ordering::Release);
        rtic::pend(Interrupt::TIM8_CC);
    }

    fn request_pdi_poll() {
        PDI_POLL.store(true, Ordering::Release);
        rtic::pend(Interrupt::EXTI0);
    }

    #[init(local = [
        stage: OutputStage = OutputStage::new(),
        pdi_slot: core::mem::MaybeUninit<PdiSide> = core::mem::MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mut core = cx.core;
        let (board, clock_result) = hw::board::init(cx.device, &mut core.DCB, &mut core.DWT);
        if let Err(e) = clock_result {
            defmt::error!("clock setup failed: {}", e);
        }
        defmt::info!("{}: HCLK {} Hz", product::PRODUCT.name, CYCLE_HZ);
        let mut syst = core.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload((CYCLE_HZ / TICK_HZ).saturating_sub(1));
        syst.clear_current();

        let hw::board::Board {
            esc,
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

        let pdi = cx.local.pdi_slot.write(PdiSide {
            task: PdiTask::new(SlaveApp::new(product::CONFIG, product::application())),
            esc,
            samples_out: AdcSource::new(),
        });
        let ready = hw::board::wait_esc_eeprom_loaded(&esc_eeprom_loaded);
        if !pdi.task.start(&mut pdi.esc, ready) {
            defmt::warn!("ET1100 PDI not ready: the PDI task starts the application later");
        }

        if wdt.caused_reset() {
            defmt::warn!("reset by the watchdog");
        }
        wdt.start();
        let mut adc: AdcHw = adc;
        let word0_ns = adc.start();
        pdi.samples_out.started(word0_ns);
        syst.enable_interrupt();
        syst.enable_counter();

        let stage: &'static OutputStage = cx.local.stage;
        (
            Shared { pdi },
            Local {
                sync0,
                dac,
                latch: DacLatch::new(),
                stage_dac: stage,
                esc_irq,
                esc_eeprom_loaded,
                stage_pdi: stage,
                stage_mailbox: stage,
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

    /// SYNC0 edge (TIM8_CH1 capture) -> latch the DAC pair; or, pended by the PDI task,
    /// apply now / preload the input registers for the next edge (DC fast path).
    #[task(binds = TIM8_CC, priority = 4, local = [sync0, dac, latch, stage_dac])]
    fn sync0_dac(cx: sync0_dac::Context) {
        let stage = *cx.local.stage_dac;
        let result = match cx.local.sync0.on_interrupt() {
            Tim8Event::Sync0(edge) => {
                // LDAC first: the capture's time is only bookkeeping for the PDI side.
                let r = cx.local.dac.execute(cx.local.latch.latch_at_sync0(stage));
                DacLatch::record_sync0(stage, cx.local.sync0.capture_ns(edge));
                request_pdi_poll();
                r
            }
            Tim8Event::Pended if DAC_APPLY.swap(false, Ordering::AcqRel) => {
                let action = cx.local.latch.apply_now(stage);
                cx.local.dac.execute(action)
            }
            Tim8Event::Pended if stage.dc_mode() => match cx.local.latch.preload(stage) {
                Some(pair) => cx.local.dac.preload(pair),
                None => Ok(()),
            },
            Tim8Event::Pended => Ok(()),
        };
        if result.is_err() {
            defmt::error!("AD5663 write failed");
        }
    }

    /// ESC IRQ (PC0 falling edge), pended after SYNC0 / by the tick, or by itself while the
    /// line stays asserted or background work waits behind the DAC task.
    #[task(binds = EXTI0, priority = 3, local = [esc_irq, esc_eeprom_loaded, stage_pdi], shared = [pdi])]
    fn pdi(mut cx: pdi::Context) {
        // The highest priority of the resource's users: the lock costs nothing.
        cx.shared.pdi.lock(|pdi| pdi_task(pdi, cx.local));
    }

    /// The body of the PDI task.
    fn pdi_task(pdi: &mut PdiSide, local: pdi::LocalResources<'_>) {
        let pdi::LocalResources {
            esc_irq,
            esc_eeprom_loaded,
            stage_pdi,
            ..
        } = local;
        let wake = Wake {
            edge: esc_irq.acknowledge(),
            line_asserted: esc_irq.still_asserted(),
            poll: PDI_POLL.swap(false, Ordering::AcqRel),
            pdi_ready: esc_eeprom_loaded.is_high(),
        };
        let now = hw::time::now_ns();
        let samples = &mut pdi.samples_out;
        let done = pdi.task.run(
            &mut pdi.esc,
            stage_pdi,
            now,
            wake,
            || esc_irq.still_asserted(),
            |app| {
                samples.drain_into(&mut app.analog().sampler);
                samples.feed(app);
            },
        );
        if done.apply_outputs {
            request_dac_apply();
        } else if done.preload_outputs {
            rtic::pend(Interrupt::TIM8_CC);
        }
        if done.pend_again {
            rtic::pend(Interrupt::EXTI0);
        }
        if done.serve_mailbox {
            rtic::pend(Interrupt::UART5);
        }
        if done.enter_bootloader {
            // Not reachable with this product's configuration (no bootstrap mailbox).
            defmt::error!("BOOT requested, but this board has no bootloader");
        }
    }

    /// The mailbox (SDO, SDO Information, Emergencies), pended by the PDI task when the
    /// mailbox needs its service: one bounded step per lock of the PDI side
    /// (`SlaveApp::mailbox_step`), so the SYNC0 and PDI tasks above it wait for one step at
    /// most. UART5 is not used on this board: only software pends it.
    #[task(binds = UART5, priority = 1, local = [stage_mailbox], shared = [pdi])]
    fn mailbox(mut cx: mailbox::Context) {
        let stage = *cx.local.stage_mailbox;
        for _ in 0..MAILBOX_STEPS {
            let now = hw::time::now_ns();
            let step = cx
                .shared
                .pdi
                .lock(|pdi| pdi.task.mailbox_step(&mut pdi.esc, stage, now));
            if step.apply_outputs {
                request_dac_apply();
            }
            if !step.more {
                return;
            }
        }
        rtic::pend(Interrupt::UART5);
    }

    /// DMA1 channel 2: one interrupt per half ring.
    #[task(binds = DMA1_CHANNEL2, priority = 2)]
    fn adc_dma(_: adc_dma::Context) {
        hw::adc::on_dma_interrupt();
    }

    /// Every SysTick (1 ms): requests the PDI task's background work; every
    /// [`FEED_TICKS`] feeds the watchdog, from the lowest priority.
    #[task(binds = SysTick, priority = 1, local = [wdt, ticks: u32 = 0])]
    fn tick(cx: tick::Context) {
        request_pdi_poll();
        *cx.local.ticks += 1;
        if *cx.local.ticks >= FEED_TICKS {
            *cx.local.ticks = 0;
            cx.local.wdt.feed();
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("the application runs on the STM32F103: build it with `cargo xtask build --product analog-io-stm32`");
}
