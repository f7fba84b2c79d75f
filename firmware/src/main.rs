//! The image of an analog product: the RTIC 2 application for the LPC1754 boards (a stub on
//! the host; build with `cargo xtask build --product NAME`). The product is the one whose
//! cargo feature is on (`firmware::products::selected`): its application behind the EtherCAT
//! slave application, and with the feature `canopen-node` (`analog-io-can`) the CAN task.
//!
//! | task            | binds / kind                 | prio | owns                                         |
//! |-----------------|------------------------------|------|----------------------------------------------|
//! | `sync0_dac`     | TIMER1 (CAP1.0, MR1, pend)   | 4    | SYNC0 capture, AD5663 + LDAC, `DacLatch`, the LDAC grid (`analog-io`) |
//! | `pdi`           | EINT3 (P0.22 falling, pend)  | 3    | `PdiSide`: ET1100 (legacy SPI), sample consumer, `SlaveApp` (with `can`, `mailbox`) |
//! | `can` (`canopen-node`) | CAN (CAN1 receive, pend) | 3 | CAN1 (P0.0/P0.1); `PdiSide` with `pdi`      |
//! | `adc_dma`       | DMA (TC per half ring)       | 2    | - (GPDMA path: counts ring halves)           |
//! | `sampler`       | TIMER2 (MR1)                 | 2    | ADC front (`adc-irq`: sample producer)       |
//! | `mailbox`       | RIT (pend only)              | 1    | - (`PdiSide` one bounded step per lock)      |
//! | `tick`          | SysTick, every 1 ms          | 1    | the MCU watchdog (fed every 10 ms); requests the PDI and CAN tasks' background work |
//! | `idle`          | -                            | 0    | `wfi`                                        |
//!
//! The tasks share the lock-free `OutputStage` (`&'static`), the two halves of the sample
//! ring (in AHB SRAM), two request flags and the `PdiSide` (the slave application and the
//! ESC). The PDI and CAN tasks run at the same priority and so never preempt each other:
//! their lock of the `PdiSide` costs nothing. The mailbox task, below them, takes it for
//! one bounded step of the mailbox job at a time (`SlaveApp::mailbox_step`), so process
//! data wait for one step at most, never for a whole mailbox exchange (docs/book/traffic.md).
//! The CAN task moves what CAN1 received
//! into its inbox at every activation, but calls the CANopen node (one frame, one PDO step
//! or its timers) only when the CAN window admits the call's kind (`stacks::canopen::window`):
//! while EtherCAT delivers outputs in regular cycles, only if the call's bound ends early
//! enough for the PDI work before the next cycle's SYNC0 edge. It makes one call per
//! activation and pends itself again while work waits; EINT3's vector comes before CAN's,
//! so a pending PDI task runs first. Neither holds the SYNC0 task (priority 4 above both).
//! Each bus has one owner. What the tasks do is the slave application's logic
//! (`firmware::stacks::ethercat`) and the product's (`firmware::products`), tested on the
//! host; the task bodies only read pins and pend each other:
//!
//! - Output oversampling (`analog-io`, `hw::ldac_grid`): at each SYNC0 edge the DAC task
//!   starts, stops or locks the LDAC grid (PWM1.4) and writes the next update; Timer1's MR1
//!   brings it back after every LDAC edge of the cycle for the next.
//! - SYNC0 edge: the DAC task latches the staged pair (`DacLatch::latch_at_sync0`: LDAC
//!   pulse or write-and-update) before it reads the capture's time, records the edge, then
//!   requests the PDI task's background work (`SlaveApp::poll`:
//!   cycle monitor, inputs of the cycle to SM3, the mailbox events).
//! - Whenever an outcome says `serve_mailbox`, the PDI task pends the mailbox task.
//! - ESC IRQ edge (or the line still asserted): `SlaveApp::on_pdi_irq`; the PDI task pends
//!   itself again while the line stays asserted, at most `pdi_task::MAX_REPENDS` times, and
//!   in DC mode once after an output event, so the safety service's register reads run in
//!   their own activation after the DAC task has preloaded the outputs.
//! - When an outcome says `apply_outputs` (free run, SM-synchronous, fault values), the PDI
//!   task pends the DAC task with the apply request (`DacLatch::apply_now`); in DC mode it
//!   pends it without the request after serving events, and the DAC task preloads freshly
//!   staged outputs into the input registers (`DacLatch::preload`), so SYNC0 only pulses
//!   LDAC.
//! - A master's INIT -> BOOT (with the bootstrap mailbox configured): the PDI task sets the
//!   boot request in RAM and resets the CPU (`hw::boot_request`); the bootloader stays.
//! - Every millisecond `tick` requests the background work too: free-run inputs,
//!   mailbox timeouts, the sample ring drained well before it fills (~4 ms), the start of
//!   the application once the ESC's EEPROM is loaded, and a stuck IRQ line served. It
//!   pends the CAN task as well: the node's timers (heartbeat, guarding, inhibit and event
//!   timers, SYNC window) at 1 ms resolution and frames the PDI side queued (Emergencies).
//! - A received CAN frame pends the CAN task (`stacks::canopen::task::run`): the frame into the inbox,
//!   one call of the node if the window admits it (its PDO steps first, its timers after
//!   each frame), the node's frames into the free transmit buffers, and the DAC task
//!   pended with the apply request when an RPDO brought outputs (`OutputSource::Can`).
//!   After each activation the PDI task pends the CAN task if a call the window refused
//!   fits now.
#![cfg_attr(target_os = "none", no_std, no_main)]

/// The hardware layer of the LPC1754 boards (register access, the only `unsafe`).
#[cfg(target_os = "none")]
#[path = "platform/hw/mod.rs"]
mod hw;

/// `analog-io-can` links the bootloader's small copy and fill routines instead of
/// compiler-builtins': they keep it in its flash budget (the module says what they cost).
#[cfg(all(target_os = "none", feature = "analog-io-can"))]
#[path = "platform/bootloader/aeabi_mem.rs"]
mod aeabi_mem;

#[cfg(all(target_os = "none", feature = "rtt"))]
use defmt_rtt as _;
#[cfg(target_os = "none")]
use panic_probe as _;

#[cfg(target_os = "none")]
#[rtic::app(device = lpc17xx_pac)]
mod rtic_app {
    use crate::hw;
    use crate::hw::adc::{AdcFront, AdcSource};
    // Unconditional: RTIC names the CAN task's resources' types outside its `cfg`.
    use crate::hw::can::Can1;
    use crate::hw::dac::Dac;
    use crate::hw::esc::Esc;
    use crate::hw::gpio::InPin;
    use crate::hw::gpio_irq::EscIrq;
    #[cfg(feature = "analog-io")]
    use crate::hw::ldac_grid::LdacGrid;
    use crate::hw::timers::{Sync0Capture, Timer1Event};
    use crate::hw::wdt::Watchdog;
    use core::sync::atomic::{AtomicBool, Ordering};
    use cortex_m::peripheral::syst::SystClkSource;
    use firmware::io::analog::outputs::{DacLatch, OutputStage};
    use firmware::io::analog::AnalogApplication;
    use firmware::products::selected as product;
    #[cfg(feature = "canopen-node")]
    use firmware::stacks::canopen::task as can_task;
    use firmware::stacks::canopen::task::CanInbox;
    use firmware::stacks::ethercat::pdi_task::{PdiTask, Wake, MAILBOX_STEPS};
    use firmware::stacks::ethercat::SlaveApp;
    use lpc17xx_pac::Interrupt;

    /// CAN1's bus timing at the product's bit rate, found when building: a rate the CAN clock
    /// cannot time exactly does not build.
    #[cfg(feature = "canopen-node")]
    const CAN_TIMING: firmware::platform::chip::can::BitTiming =
        match firmware::platform::chip::can::bit_timing(hw::PCLK_HZ, product::can::DEFAULT_BIT_RATE)
        {
            Some(t) => t,
            None => panic!("no exact CAN bit timing for the default bit rate at PCLK"),
        };

    /// Set by the PDI task before it pends TIMER1: "apply the staged outputs now" (free run,
    /// SM-synchronous, fault values), as opposed to a SYNC0 capture.
    static DAC_APPLY: AtomicBool = AtomicBool::new(false);

    /// Set before EINT3 is pended for the background work (after SYNC0, by the tick), as
    /// opposed to an IRQ edge or a self-pend for a line still asserted.
    static PDI_POLL: AtomicBool = AtomicBool::new(false);

    /// Period of the PDI task's background work without SYNC0: the SysTick period. A plain
    /// SysTick-bound task instead of async tasks on a monotonic timer: no timer queue, no
    /// dispatchers.
    const TICK_HZ: u32 = 1_000;
    /// SysTick periods between two feeds of the MCU watchdog.
    const FEED_TICKS: u32 = hw::wdt::FEED_PERIOD_MS * TICK_HZ / 1_000;

    #[shared]
    struct Shared {
        /// The slave application and the ESC, served by the PDI and the CAN task (same
        /// priority, so no lock between them) and by the mailbox task below them, which
        /// takes the lock for one bounded step at a time.
        pdi: &'static mut PdiSide,
    }

    #[local]
    struct Local {
        sync0: Sync0Capture,
        dac: Dac,
        latch: DacLatch,
        stage_dac: &'static OutputStage,
        ldac_grid: LdacGrid,
        esc_irq: EscIrq,
        esc_eeprom_loaded: InPin,
        stage_pdi: &'static OutputStage,
        stage_mailbox: &'static OutputStage,
        #[cfg(feature = "canopen-node")]
        can: Can1,
        #[cfg(feature = "canopen-node")]
        stage_can: &'static OutputStage,
        adc: AdcFront,
        wdt: Watchdog,
    }

    /// The PDI task's state: the slave application (which owns the `Sampler`), the ESC
    /// and the consumer half of the sample ring that feeds the application.
    pub struct PdiSide {
        task: PdiTask<product::Application>,
        esc: Esc,
        samples_out: AdcSource,
    }

    /// A product without output oversampling owns no LDAC grid (PWM1 stays off).
    #[cfg(not(feature = "analog-io"))]
    pub struct LdacGrid;

    #[cfg(not(feature = "analog-io"))]
    impl LdacGrid {
        fn new(_: lpc17xx_pac::PWM1) -> Self {
            Self
        }
    }

    /// Asks the DAC task to apply the staged outputs now (called from the PDI task).
    fn request_dac_apply() {
        DAC_APPLY.store(true, Ordering::Release);
        rtic::pend(Interrupt::TIMER1);
    }

    /// Asks the PDI task for its background work (`SlaveApp::poll`).
    fn request_pdi_poll() {
        PDI_POLL.store(true, Ordering::Release);
        rtic::pend(Interrupt::EINT3);
    }

    #[init(local = [
        stage: OutputStage = OutputStage::new(),
        pdi_slot: core::mem::MaybeUninit<PdiSide> = core::mem::MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let (board, clock_result) = hw::board::init(cx.device);
        if let Err(e) = clock_result {
            defmt::error!("clock setup failed: {}", e);
        }
        defmt::info!("{}: clocks {}", product::PRODUCT.name, board.clocks);
        let mut syst = cx.core.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload((board.clocks.cclk_hz / TICK_HZ).saturating_sub(1));
        syst.clear_current();

        let hw::board::Board {
            clocks: _,
            esc,
            esc_irq,
            esc_eeprom_loaded,
            sync0,
            mut dac,
            adc,
            mut wdt,
            pwm1,
            can,
        } = board;
        #[cfg(feature = "canopen-node")]
        let can = can.start(CAN_TIMING);
        #[cfg(not(feature = "canopen-node"))]
        let _ = can; // CAN1 stays in reset mode: the product has no CAN

        // Outputs to 0 V first: after an MCU-only reset the DAC still drives the old values.
        if dac.init().is_err() {
            defmt::error!("AD5663 init failed");
        }

        let (mut adc, samples_out) = hw::adc::split(adc);
        // Built in its static slot, not moved through the stack (2 KB).
        let pdi = cx.local.pdi_slot.write(PdiSide {
            task: PdiTask::new(SlaveApp::new(product::CONFIG, product::application())),
            esc,
            samples_out,
        });
        let ready = hw::board::wait_esc_eeprom_loaded(&esc_eeprom_loaded, &sync0);
        if !pdi.task.start(&mut pdi.esc, ready) {
            defmt::warn!("ET1100 PDI not ready: the PDI task starts the application later");
        }

        if wdt.caused_reset() {
            defmt::warn!("reset by the MCU watchdog");
        }
        wdt.start();
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
                ldac_grid: LdacGrid::new(pwm1),
                esc_irq,
                esc_eeprom_loaded,
                stage_pdi: stage,
                stage_mailbox: stage,
                #[cfg(feature = "canopen-node")]
                can,
                #[cfg(feature = "canopen-node")]
                stage_can: stage,
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
    #[task(binds = TIMER1, priority = 4, local = [sync0, dac, latch, stage_dac, ldac_grid])]
    fn sync0_dac(cx: sync0_dac::Context) {
        // The stage's fields by offsets from one register on the way to the LDAC edge.
        let stage = hw::in_register(*cx.local.stage_dac);
        let result = match cx.local.sync0.on_interrupt() {
            Timer1Event::Sync0(edge) => {
                // LDAC first: the capture's time is only bookkeeping for the PDI side.
                let r = cx.local.dac.execute(cx.local.latch.latch_at_sync0(stage));
                let edge_ns = cx.local.sync0.capture_ns(edge);
                #[cfg(feature = "analog-io")]
                let grid = cx
                    .local
                    .ldac_grid
                    .on_sync0(cx.local.sync0, stage.block_grid(), edge_ns);
                DacLatch::record_sync0(stage, edge_ns);
                request_pdi_poll(); // the PDI side's per-cycle work
                #[cfg(feature = "analog-io")]
                if grid {
                    if let Some(pair) = cx.local.ldac_grid.on_update(cx.local.sync0, stage) {
                        let _ = cx.local.dac.preload(pair);
                    }
                }
                r
            }
            #[cfg(feature = "analog-io")]
            Timer1Event::Update => match cx.local.ldac_grid.on_update(cx.local.sync0, stage) {
                Some(pair) => cx.local.dac.preload(pair),
                None => Ok(()),
            },
            #[cfg(not(feature = "analog-io"))]
            Timer1Event::Update => Ok(()),
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

    /// ESC SPI_IRQ (P0.22 falling edge), pended after SYNC0 / by the tick, or by itself while
    /// the line stays asserted or background work waits behind the DAC task.
    #[task(binds = EINT3, priority = 3, local = [esc_irq, esc_eeprom_loaded, stage_pdi], shared = [pdi])]
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
        let now = hw::timers::now_ns();
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
            rtic::pend(Interrupt::TIMER1);
        }
        if done.pend_again {
            rtic::pend(Interrupt::EINT3);
        }
        if done.serve_mailbox {
            rtic::pend(Interrupt::RIT);
        }
        if done.enter_bootloader {
            // From INIT: the outputs already hold their safe values.
            hw::boot_request::enter_bootloader();
        }
        // CAN frames to send, or a CAN call the window refused that fits now.
        #[cfg(feature = "canopen-node")]
        {
            let can = &pdi.task.app().application().can;
            if can.has_tx() || can.work_waiting(now) {
                rtic::pend(Interrupt::CAN);
            }
        }
    }

    /// CAN1 received a frame, or pended by the tick / the PDI task: received frames into
    /// the inbox, the node's frames and timers when the CAN window admits them, and
    /// transmissions.
    #[cfg(feature = "canopen-node")]
    #[task(binds = CAN, priority = 3, local = [can, stage_can, inbox: CanInbox = CanInbox::new()], shared = [pdi])]
    fn can(mut cx: can::Context) {
        let can = cx.local.can;
        let (inbox, stage) = (cx.local.inbox, cx.local.stage_can);
        let now = hw::timers::now_ns();
        let done = cx.shared.pdi.lock(|pdi| {
            let app = pdi.task.app_mut();
            can_task::run(can, inbox, app, stage, now)
        });
        if done.apply_outputs {
            request_dac_apply();
        }
        if done.run_again {
            rtic::pend(Interrupt::CAN);
        }
    }

    /// The mailbox (SDO, SDO Information, Emergencies, FoE), pended by the PDI task when
    /// the mailbox needs its service: one bounded step per lock of the PDI side
    /// (`SlaveApp::mailbox_step`: at most one 16-byte access to a mailbox buffer, a few to
    /// registers, or one request through the SDO server), so the SYNC0 and PDI tasks,
    /// above it, wait for one step at most, never for a whole exchange.
    #[task(binds = RIT, priority = 1, local = [stage_mailbox], shared = [pdi])]
    fn mailbox(mut cx: mailbox::Context) {
        let stage = *cx.local.stage_mailbox;
        for _ in 0..MAILBOX_STEPS {
            let now = hw::timers::now_ns();
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
        rtic::pend(Interrupt::RIT);
    }

    /// AD7689, interrupt path (`adc-irq`): CNV low, previous result to the ring, next frame.
    #[task(binds = TIMER2, priority = 2, local = [adc])]
    fn sampler(cx: sampler::Context) {
        cx.local.adc.on_timer_interrupt();
    }

    /// AD7689, GPDMA path: one terminal-count interrupt per half ring.
    #[task(binds = DMA, priority = 2)]
    fn adc_dma(_: adc_dma::Context) {
        hw::adc::on_dma_interrupt();
    }

    /// Every SysTick (1 ms): requests the PDI task's background work; every
    /// [`FEED_TICKS`] feeds the MCU watchdog, from the lowest priority, so a lock-up above
    /// starves it.
    #[task(binds = SysTick, priority = 1, local = [wdt, ticks: u32 = 0])]
    fn tick(cx: tick::Context) {
        request_pdi_poll();
        #[cfg(feature = "canopen-node")]
        rtic::pend(Interrupt::CAN);
        *cx.local.ticks += 1;
        if *cx.local.ticks >= FEED_TICKS {
            *cx.local.ticks = 0;
            cx.local.wdt.feed();
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("the application runs on the LPC1754: build it with `cargo xtask build`");
}
