//! The LPC1754 around the core: the peripheral bus (address map of UM10360 chapter 2), the
//! time base (CPU cycles at the CCLK that SYSCON gives), the event schedule, and the board
//! wiring of hardware-facts 10.A: which pin, in which PINSEL function, reaches which chip
//! model of the virtual board.
//!
//! Routing is strict: a legacy SPI byte reaches the ET1100 only while SPI_SEL (P0.16, GPIO)
//! is low and P0.15/P0.17/P0.18 carry SCK/MISO/MOSI (function 3); SSP0 frames reach the
//! AD5663 only on P1.20/P1.24 (function 3) while SYNC (P2.2) is low; SSP1 frames reach the
//! AD7689 only on P0.7/P0.8/P0.9 (function 2) while CNV is low; CNV is MAT2.0 only on P0.6
//! function 3; SYNC0 reaches CAP1.0 only on P1.18 function 3; LDAC (P2.3) follows the GPIO
//! in function 0 and PWM1.4 in function 1 (each PWM edge at its own time); CAN1 reaches the
//! board's CAN bus only on P0.0/P0.1 (function 1) at the bus's bit rate. Anything else moves no data
//! and is reported, as is any access to a peripheral whose PCONP bit is off.
//!
//! On the STM32F103 ([`Machine::stm32`]) the time, events, NVIC and profile are these, and
//! the bus, the peripherals and the board wiring are [`stm32`]'s.

pub mod stm32;

use crate::ahb_sram::AhbSram;
use crate::chip::{Chip, Cpi};
use crate::code::Blocks;
use crate::image::Image;
use crate::nvic::{irq, Scs};
use crate::periph::can::Can;
use crate::periph::gpdma::{After, Gpdma, Transfer};
use crate::periph::gpio::{Gpio, GpioInt};
use crate::periph::pincon::PinConnect;
use crate::periph::pwm::Pwm;
use crate::periph::spi::Spi;
use crate::periph::ssp::Ssp;
use crate::periph::syscon::{Clocked, Syscon, PCONP_RESET};
use crate::periph::timer::Timer;
use crate::periph::wdt::Wdt;
use crate::periph::{Peripheral, Tick};
use crate::profile::Profile;
use embedded_hal::digital::OutputPin;
use embedded_hal::spi::{Operation, SpiDevice};
use lpc17xx_iap::model::FlashModel;
use std::rc::Rc;
use virtual_board::models::spi::SpiSession;
use virtual_board::rig::board::BoardIo;

/// Cycles per instruction of the time model: the Cortex-M3 at 100 MHz with 5 flash wait
/// states behind the LPC17xx flash accelerator (the same assumption as `cargo xtask bench`'s
/// QEMU rows): CPI = 5/4.
pub const CPI_NUM: u64 = 5;
/// See [`CPI_NUM`].
pub const CPI_DEN: u64 = 4;
/// Exception entry (Cortex-M3 TRM 5.5.1: 12 cycles), return (10), tail-chain (6).
pub const ENTRY_CYCLES: u64 = 12;
/// See [`ENTRY_CYCLES`].
pub const RETURN_CYCLES: u64 = 10;
/// See [`ENTRY_CYCLES`].
pub const TAIL_CHAIN_CYCLES: u64 = 6;

/// Pins of the board (hardware-facts 10.A).
pub mod pins {
    /// (port, pin).
    pub type Pin = (u8, u8);
    /// ET1100 SPI_CLK / SPI_DO (MISO) / SPI_DI (MOSI): legacy SPI function 3.
    pub const ESC_SCK: Pin = (0, 15);
    /// See [`ESC_SCK`].
    pub const ESC_MISO: Pin = (0, 17);
    /// See [`ESC_SCK`].
    pub const ESC_MOSI: Pin = (0, 18);
    /// ET1100 SPI_SEL (GPIO).
    pub const ESC_SEL: Pin = (0, 16);
    /// ET1100 SPI_IRQ (GPIO input, active low).
    pub const ESC_IRQ: Pin = (0, 22);
    /// ET1100 EEPROM_LOADED (GPIO input).
    pub const ESC_EEPROM_LOADED: Pin = (2, 4);
    /// ET1100 SYNC0 -> CAP1.0 (function 3).
    pub const ESC_SYNC0: Pin = (1, 18);
    /// AD5663 SCLK / DIN on SSP0 (function 3).
    pub const DAC_SCK: Pin = (1, 20);
    /// See [`DAC_SCK`].
    pub const DAC_DIN: Pin = (1, 24);
    /// AD5663 SYNC (GPIO).
    pub const DAC_SYNC: Pin = (2, 2);
    /// AD5663 LDAC: GPIO (function 0) or PWM1.4 (function 1, the oversampling outputs).
    pub const DAC_LDAC: Pin = (2, 3);
    /// The PINSEL function of [`DAC_LDAC`] that is PWM1.4.
    pub const LDAC_PWM_FUNC: u8 = 1;
    /// The PWM1 output on [`DAC_LDAC`].
    pub const LDAC_PWM_OUTPUT: usize = 4;
    /// AD7689 CNV = MAT2.0 (function 3).
    pub const ADC_CNV: Pin = (0, 6);
    /// AD7689 SCK / SDO / DIN on SSP1 (function 2).
    pub const ADC_SCK: Pin = (0, 7);
    /// See [`ADC_SCK`].
    pub const ADC_SDO: Pin = (0, 8);
    /// See [`ADC_SCK`].
    pub const ADC_DIN: Pin = (0, 9);
    /// CAN1 RD1 / TD1 to the transceiver (function 1).
    pub const CAN_RD: Pin = (0, 0);
    /// See [`CAN_RD`].
    pub const CAN_TD: Pin = (0, 1);
}

/// A peripheral slot of the address map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// 0x4000_0000.
    Wdt,
    /// TIMER0 0x4000_4000, TIMER1 0x4000_8000, TIMER2 0x4009_0000, TIMER3 0x4009_4000.
    Timer(usize),
    /// 0x4002_0000.
    Spi,
    /// 0x4002_8000.
    GpioInt,
    /// 0x4002_C000.
    PinConnect,
    /// 0x4003_0000.
    Ssp1,
    /// 0x4008_8000.
    Ssp0,
    /// 0x400F_C000.
    Syscon,
    /// 0x2009_C000.
    Gpio,
    /// 0x5000_4000.
    Gpdma,
    /// CAN1, 0x4004_4000.
    Can1,
    /// PWM1, 0x4001_8000.
    Pwm1,
    /// The CAN acceptance filter registers, 0x4003_C000.
    CanAf,
    /// 0xE000_E000.
    Scs,
    /// A peripheral the co-simulator does not model (its base).
    Unmodelled(u32),
}

impl Region {
    /// The region an APB/AHB slot base maps to.
    pub fn of_base(base: u32) -> Region {
        match base {
            0x4000_0000 => Region::Wdt,
            0x4000_4000 => Region::Timer(0),
            0x4000_8000 => Region::Timer(1),
            0x4009_0000 => Region::Timer(2),
            0x4009_4000 => Region::Timer(3),
            0x4002_0000 => Region::Spi,
            0x4002_8000 => Region::GpioInt,
            0x4002_C000 => Region::PinConnect,
            0x4003_0000 => Region::Ssp1,
            0x4008_8000 => Region::Ssp0,
            0x400F_C000 => Region::Syscon,
            0x2009_C000 => Region::Gpio,
            0x5000_4000 => Region::Gpdma,
            0x4004_4000 => Region::Can1,
            0x4001_8000 => Region::Pwm1,
            0x4003_C000 => Region::CanAf,
            0xE000_E000 => Region::Scs,
            other => Region::Unmodelled(other),
        }
    }

    fn clocked(self) -> Option<Clocked> {
        Some(match self {
            Region::Wdt => Clocked::Wdt,
            Region::Timer(n) => Clocked::Timer(n as u8),
            Region::Spi => Clocked::Spi,
            Region::Ssp0 => Clocked::Ssp0,
            Region::Ssp1 => Clocked::Ssp1,
            Region::Gpio | Region::GpioInt => Clocked::Gpio,
            Region::Gpdma => Clocked::Gpdma,
            Region::Can1 => Clocked::Can1,
            Region::Pwm1 => Clocked::Pwm1,
            _ => return None,
        })
    }
}

/// Why the CPU stopped running.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The time slice ended.
    Deadline,
    /// An exception is to be taken.
    Preempt,
    /// The chip resets (watchdog, SYSRESETREQ).
    Reset(ResetCause),
    /// A fault the run reports.
    Fault(String),
}

/// What reset the chip.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// The watchdog timed out (WDTOF).
    Watchdog,
    /// AIRCR.SYSRESETREQ.
    SysResetReq,
}

/// A reported problem, once per message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Report {
    /// Virtual time of the first occurrence (ns).
    pub time_ns: u64,
    /// The message.
    pub message: String,
}

/// Bytes and frames that crossed to the board's chips.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    /// ET1100 SPI bytes exchanged.
    pub esc_bytes: u64,
    /// AD5663 frames (SYNC-low periods) delivered.
    pub dac_frames: u64,
    /// AD7689 conversions started (CNV rising edges).
    pub adc_conversions: u64,
    /// SYNC0 edges captured by CAP1.0.
    pub sync0_captures: u64,
    /// LDAC falling edges.
    pub ldac_pulses: u64,
    /// CAN frames CAN1 sent on the board's bus.
    pub can_sent: u64,
    /// CAN frames the bus delivered into CAN1's receive buffer.
    pub can_received: u64,
}

/// The chip without the core.
pub struct Machine {
    /// Which chip it is.
    pub chip: Chip,
    cpi: Cpi,
    /// The STM32F103's peripherals and board parts (None on the LPC1754, whose peripherals
    /// are the fields below).
    pub stm32: Option<Box<stm32::Stm32Parts>>,
    /// Board handles.
    pub io: BoardIo,
    now_ps: u64,
    cycle_ps: u64,
    /// CPU cycles since power-on (instructions x CPI + exception overhead + sleep).
    pub cycles: u64,
    insn_rem: u64,
    /// Instructions executed.
    pub instructions: u64,
    /// When the current slice ends.
    pub deadline_ns: u64,
    /// The slice ends exactly at `deadline_ns` (something outside happens then, a SYNC0
    /// edge): a block that would cross it waits, the time up to it a stall. Else the slice
    /// ends with the first block that reaches it.
    pub exact_deadline: bool,
    /// Why the CPU must stop at the next block boundary.
    pub stop: Option<Stop>,
    /// Something is pending: the block hook checks the masks.
    pub check_preempt: bool,
    next_event_ns: u64,
    /// While events are served: their scheduled time (peripherals act at it, not at the
    /// block boundary where the engine noticed them).
    event_ns: Option<u64>,
    /// NVIC, SCB, SysTick.
    pub scs: Scs,
    /// SYSCON.
    pub syscon: Syscon,
    pincon: PinConnect,
    gpio: Gpio,
    gpioint: GpioInt,
    spi: Spi,
    ssp0: Ssp,
    ssp1: Ssp,
    timers: [Timer; 4],
    gpdma: Gpdma,
    wdt: Wdt,
    can1: Can,
    /// PWM1 (LDAC in the oversampling output path).
    pub pwm1: Pwm,
    /// The bus's count of frames CAN1's port sent, as far as CAN1 has been told.
    can_sent_seen: u64,
    esc_session: Option<SpiSession>,
    dac_frame: Option<Vec<u8>>,
    adc_mosi: Vec<u8>,
    cnv_high: bool,
    outputs_last: [bool; 3],
    /// Reported problems.
    pub reports: Vec<Report>,
    /// Crossings to the board.
    pub traffic: Traffic,
    /// The image's blocks (instructions, code chains).
    pub blocks: Blocks,
    /// PCONP to start from after a reset (tests: what a bootloader leaves).
    pub pconp_at_reset: u32,
    /// Cycles, stack and code per exception.
    pub profile: Profile,
    /// The AHB SRAM (the GPDMA's memory) with its watch over samples.
    pub ahb_sram: AhbSram,
    /// The flash and the IAP ROM's state ([`crate::iap`]); the engine's flash mirrors it.
    pub flash: FlashModel,
    /// IAP commands carried out.
    pub iap_calls: u64,
}

impl Machine {
    /// A chip at power-on with `image` in its flash, on `io`'s board.
    pub fn new(io: BoardIo, image: Rc<Image>) -> Self {
        let chip = image.chip;
        let mut m = Self {
            chip,
            cpi: chip.cpi(),
            stm32: (chip == Chip::Stm32f103).then(|| {
                Box::new(stm32::Stm32Parts::new(
                    virtual_board::models::esc::parallel::BusTiming::NO_CLASH,
                ))
            }),
            io,
            now_ps: 0,
            cycle_ps: 0,
            cycles: 0,
            insn_rem: 0,
            instructions: 0,
            deadline_ns: 0,
            stop: None,
            check_preempt: false,
            exact_deadline: false,
            next_event_ns: u64::MAX,
            event_ns: None,
            scs: Scs::with_spec(chip.nvic()),
            syscon: Syscon::new(PCONP_RESET, 1),
            pincon: PinConnect::new(),
            gpio: Gpio::new(),
            gpioint: GpioInt::new(),
            spi: Spi::new(),
            ssp0: Ssp::new(),
            ssp1: Ssp::new(),
            timers: Default::default(),
            gpdma: Gpdma::new(),
            wdt: Wdt::new(false),
            can1: Can::new(),
            pwm1: Pwm::new(),
            can_sent_seen: 0,
            esc_session: None,
            dac_frame: None,
            adc_mosi: Vec::new(),
            cnv_high: false,
            outputs_last: [true; 3],
            reports: Vec::new(),
            traffic: Traffic::default(),
            blocks: Blocks::new(image.clone()),
            pconp_at_reset: PCONP_RESET,
            profile: Profile::new(image.initial_sp()),
            ahb_sram: AhbSram::new(),
            flash: FlashModel::new(),
            iap_calls: 0,
        };
        m.now_ps = m.io.now_ns() * 1000;
        m.can_sent_seen = m.can_frames_left();
        m.update_cycle_time();
        m.refresh_inputs();
        m
    }

    /// A chip reset: every peripheral to its reset state (WDTOF kept after a watchdog
    /// reset), RAM and the board untouched.
    pub fn reset(&mut self, cause: ResetCause) {
        self.end_sessions();
        let watchdog = cause == ResetCause::Watchdog;
        // RSID: WDTR b2 after a watchdog reset.
        self.syscon = Syscon::new(self.pconp_at_reset, if watchdog { 4 } else { 0 });
        self.scs = Scs::with_spec(self.chip.nvic());
        if self.stm32.is_some() {
            self.stm32_reset(cause);
        }
        self.pincon = PinConnect::new();
        self.gpio = Gpio::new();
        self.gpioint = GpioInt::new();
        self.spi = Spi::new();
        self.ssp0 = Ssp::new();
        self.ssp1 = Ssp::new();
        self.timers = Default::default();
        self.gpdma = Gpdma::new();
        self.wdt = Wdt::new(watchdog);
        // Frames the controller queued before the reset count as gone.
        self.can1 = Can::new();
        self.pwm1 = Pwm::new();
        self.can_sent_seen = self.can_frames_left();
        self.stop = None;
        self.check_preempt = false;
        self.cnv_high = false;
        self.profile.reset();
        self.update_cycle_time();
        self.refresh_inputs();
        self.reschedule();
    }

    fn end_sessions(&mut self) {
        if let Some(s) = self.esc_session.take() {
            self.io.esc.esc().borrow_mut().spi_end(s);
        }
        self.dac_frame = None;
        self.adc_mosi.clear();
    }

    /// Reports a problem (once per message).
    pub fn report(&mut self, message: String) {
        if !self.reports.iter().any(|r| r.message == message) {
            self.reports.push(Report {
                time_ns: self.hw_ns(),
                message,
            });
        }
    }

    // ------------------------------------------------------------------ time

    /// Virtual time (ns) of the CPU.
    pub fn now_ns(&self) -> u64 {
        self.now_ps / 1000
    }

    /// The time the peripherals and the board see: an event's own time while it is served,
    /// else the CPU's.
    fn hw_ns(&self) -> u64 {
        self.event_ns.unwrap_or_else(|| self.now_ns())
    }

    fn update_cycle_time(&mut self) {
        self.cycle_ps = 1_000_000_000_000 / self.cclk_hz().max(1);
    }

    /// SYNC0 captures (CAP1.0) overwritten by the next edge before the CPU read them: edges
    /// the SYNC0 task never served.
    pub fn sync0_unserved(&self) -> u64 {
        if self.stm32.is_some() {
            return self.stm32_sync0_unserved();
        }
        self.timers[1].captures_unread[0]
    }

    /// Frames SSP1 (the STM32's SPI1) lost to a full RX FIFO (an unread RX buffer).
    pub fn ssp1_overruns(&self) -> u64 {
        match &self.stm32 {
            Some(p) => p.chip.spi1.overruns,
            None => self.ssp1.overruns,
        }
    }

    /// The CPU clock now.
    pub fn cclk_hz(&self) -> u64 {
        if self.stm32.is_some() {
            return self.stm32_hclk_hz();
        }
        self.syscon.cclk_hz()
    }

    /// Accounts `c` cycles (exception overhead) to the current context.
    pub fn add_cycles(&mut self, c: u64) {
        self.cycles += c;
        self.now_ps += c * self.cycle_ps;
        self.profile.charge(c);
    }

    /// Sleeps (WFI) until `t_ns`.
    pub fn sleep_until(&mut self, t_ns: u64) {
        let t_ps = t_ns * 1000;
        if t_ps > self.now_ps {
            let c = (t_ps - self.now_ps).div_ceil(self.cycle_ps);
            self.cycles += c;
            self.profile.charge_sleep(c);
            self.now_ps += c * self.cycle_ps;
        }
    }

    /// The time model's cycles per instruction from now on.
    pub fn set_cpi(&mut self, cpi: Cpi) {
        self.cpi = cpi;
        self.insn_rem = 0;
    }

    /// The next scheduled event (ns).
    pub fn next_event_ns(&self) -> u64 {
        self.next_event_ns
    }

    /// A block of `size` bytes at `addr` is about to run with SP `sp`: its instructions are
    /// counted and profiled, with the deepest SP it reaches. `bytes` reads its code when it is
    /// not in the image's flash. `masks` are PRIMASK, BASEPRI and FAULTMASK, which stay as
    /// they are through a block (writing them ends one).
    ///
    /// The events due inside the block's time are served at their own times, in order. One
    /// that makes an exception takeable stops the block before it runs: the core takes the
    /// exception at the event's time, as a Cortex-M3 does at the next instruction, and the
    /// block runs after the handler. The time up to the event is then a stall of the
    /// interrupted code (at most one block: a little pessimistic for it, exact for the
    /// handler). An exact deadline ([`Self::exact_deadline`]) inside the block stops it the
    /// same way. Returns whether the block runs.
    pub fn run_block(
        &mut self,
        addr: u32,
        size: u32,
        sp: u32,
        bytes: impl FnOnce() -> Vec<u8>,
        masks: (bool, u8, bool),
    ) -> bool {
        let n = self.blocks.get(addr, size, bytes).instructions;
        let q = n * self.cpi.num + self.insn_rem;
        let block_cycles = q / self.cpi.den;
        let end_ps = self.now_ps + block_cycles * self.cycle_ps;
        let mut passed = 0;
        loop {
            let event_ps = self.next_event_ns.saturating_mul(1000);
            let deadline_ps = match self.exact_deadline {
                true => self.deadline_ns.saturating_mul(1000),
                false => u64::MAX,
            };
            let due_ps = event_ps.min(deadline_ps);
            if due_ps >= end_ps {
                break;
            }
            if due_ps > self.now_ps {
                let c = (due_ps - self.now_ps)
                    .div_ceil(self.cycle_ps)
                    .min(block_cycles - passed);
                self.add_cycles(c);
                passed += c;
            }
            self.service_due();
            let (primask, basepri, faultmask) = masks;
            let takeable =
                self.check_preempt && self.scs.preempting(primask, basepri, faultmask).is_some();
            if takeable || self.stop.is_some() {
                return false;
            }
            if deadline_ps <= self.now_ps {
                self.stop = Some(Stop::Deadline);
                return false;
            }
            if self.next_event_ns.saturating_mul(1000) <= self.now_ps {
                // Serving reached its limit with events still due: the rest after the block.
                break;
            }
        }
        let b = self.blocks.get(addr, size, Vec::new);
        self.profile.block(&b.runs, sp.saturating_sub(b.sp_dip));
        self.instructions += n;
        self.insn_rem = q % self.cpi.den;
        self.add_cycles(block_cycles.saturating_sub(passed));
        true
    }

    // ------------------------------------------------------------------ events

    fn tick_for(&self, region: Region) -> Tick {
        Tick {
            now_ns: self.hw_ns(),
            pclk_hz: region
                .clocked()
                .map_or(self.syscon.cclk_hz(), |c| self.syscon.pclk_hz(c)),
        }
    }

    fn reschedule(&mut self) {
        let cycle_ns = |c: u64, m: &Self| -> u64 {
            let now_c = m.cycles;
            m.now_ns() + (c.saturating_sub(now_c) * m.cycle_ps).div_ceil(1000)
        };
        let mut next = u64::MAX;
        for e in [
            self.spi.next_event(),
            self.ssp0.next_event(),
            self.ssp1.next_event(),
            self.timers[0].next_event(),
            self.timers[1].next_event(),
            self.timers[2].next_event(),
            self.timers[3].next_event(),
            self.pwm1.next_event(),
            self.wdt.next_event(),
            self.scs.systick.next_wrap().map(|c| cycle_ns(c, self)),
            self.io.can.bus.borrow().next_event_ns(),
            self.stm32.as_ref().and_then(|_| self.stm32_next_event()),
        ]
        .into_iter()
        .flatten()
        {
            next = next.min(e);
        }
        self.next_event_ns = next;
    }

    /// Serves everything due at the current time; `mem` is the engine's memory (DMA).
    pub fn service_due(&mut self) {
        for _ in 0..64 {
            if self.next_event_ns > self.now_ns() {
                break;
            }
            self.event_ns = Some(self.next_event_ns);
            self.service_events();
            self.event_ns = None;
        }
    }

    fn service_events(&mut self) {
        if self
            .scs
            .systick
            .next_wrap()
            .is_some_and(|c| self.cycles >= c)
        {
            self.scs.systick.wrap(self.cycles);
            if self.scs.systick.interrupts() {
                self.scs.set_pending(crate::nvic::exc::SYSTICK);
            }
        }
        if self.stm32.is_some() {
            self.stm32_service();
            self.settle();
            return;
        }
        let t = self.tick_for(Region::Wdt);
        self.wdt.on_event(t);
        if self.wdt.take_reset_request() {
            self.stop = Some(Stop::Reset(ResetCause::Watchdog));
        }
        let t = self.tick_for(Region::Spi);
        self.spi.on_event(t);
        for n in 0..4 {
            let t = self.tick_for(Region::Timer(n));
            self.timers[n].on_event(t);
        }
        let t = self.tick_for(Region::Pwm1);
        self.pwm1.on_event(t);
        let t = self.tick_for(Region::Ssp0);
        self.ssp0.on_event(t);
        let t = self.tick_for(Region::Ssp1);
        self.ssp1.on_event(t);
        self.can_exchange();
        self.settle();
    }

    /// After any change: frames to the devices, pins, DMA, interrupt lines, schedule.
    pub fn settle(&mut self) {
        if self.stm32.is_some() {
            self.stm32_settle();
            self.reschedule();
            return;
        }
        for _ in 0..16 {
            let mut moved = self.exchange_ssp0();
            moved |= self.exchange_ssp1();
            self.update_cnv();
            moved |= self.run_dma();
            if !moved {
                break;
            }
        }
        self.pwm_ldac();
        self.update_irq_lines();
        self.reschedule();
    }

    fn update_irq_lines(&mut self) {
        let lines = [
            (irq::WDT, self.wdt.irq()),
            (irq::TIMER0, self.timers[0].irq()),
            (irq::TIMER0 + 1, self.timers[1].irq()),
            (irq::TIMER0 + 2, self.timers[2].irq()),
            (irq::TIMER0 + 3, self.timers[3].irq()),
            (irq::SPI, self.spi.irq()),
            (irq::SSP0, self.ssp0.irq()),
            (irq::SSP1, self.ssp1.irq()),
            (irq::EINT3, self.gpioint.irq()),
            (irq::DMA, self.gpdma.irq()),
            (irq::CAN, self.can1.irq()),
            (irq::PWM1, self.pwm1.irq()),
        ];
        for (n, level) in lines {
            self.scs.set_line(n, level);
        }
        self.check_preempt = self.scs.any_pending();
    }

    // ------------------------------------------------------------------ pins

    fn func(&self, p: pins::Pin) -> u8 {
        self.pincon.func(p.0, p.1)
    }

    fn routed(&mut self, what: &str, need: &[(pins::Pin, u8, &str)]) -> bool {
        let mut ok = true;
        for &(p, f, name) in need {
            let have = self.func(p);
            if have != f {
                ok = false;
                self.report(format!(
                    "{what}: P{}.{} is PINSEL function {have}, not {f} ({name}): the transfer \
                     moves no data",
                    p.0, p.1
                ));
            }
        }
        ok
    }

    /// The GPIO output level of a pin used as GPIO (None: not GPIO or not an output).
    fn gpio_out(&self, p: pins::Pin) -> Option<bool> {
        (self.func(p) == 0 && self.gpio.is_output(p.0, p.1))
            .then(|| self.gpio.level(p.0, p.1, true))
    }

    /// Inputs from the board into the pins: ESC IRQ (active low), EEPROM_LOADED.
    pub fn refresh_inputs(&mut self) {
        if self.stm32.is_some() {
            self.stm32_refresh_inputs();
            return;
        }
        let (irq, loaded) = {
            let esc = self.io.esc.esc().borrow();
            (esc.irq(), esc.pdi_operational())
        };
        let (p, n) = pins::ESC_IRQ;
        self.gpio.set_input(p, n, !irq);
        if self.func(pins::ESC_IRQ) == 0 {
            self.gpioint.sample(p, n, !irq);
        }
        let (p, n) = pins::ESC_EEPROM_LOADED;
        self.gpio.set_input(p, n, loaded);
        let level = self.gpioint.irq();
        self.scs.set_line(irq::EINT3, level);
        self.can_exchange();
        self.check_preempt |= self.scs.any_pending();
    }

    // ------------------------------------------------------------------ CAN

    /// The frames CAN1's port has sent plus those still queued at it: where a fresh
    /// controller starts counting.
    fn can_frames_left(&self) -> u64 {
        let bus = self.io.can.bus.borrow();
        bus.sent(self.io.can.port) + bus.pending(self.io.can.port) as u64
    }

    /// Whether CAN1's frames cross to the bus: powered, pins routed, equal CAN clocks, the
    /// bus's bit rate (within 0.5 %).
    fn can_link(&self) -> Result<(), String> {
        if !self.syscon.powered(Clocked::Can1) {
            return Err("CAN1 is not powered (PCONP bit 13)".into());
        }
        for (p, name) in [(pins::CAN_RD, "RD1"), (pins::CAN_TD, "TD1")] {
            let f = self.func(p);
            if f != 1 {
                return Err(format!(
                    "P{}.{} is PINSEL function {f}, not 1 ({name}): CAN1 is not on the bus",
                    p.0, p.1
                ));
            }
        }
        let pclk = self.syscon.pclk_hz(Clocked::Can1);
        if self.syscon.pclk_hz(Clocked::Can2) != pclk
            || self.syscon.pclk_hz(Clocked::CanAcf) != pclk
        {
            return Err(
                "PCLK of CAN1, CAN2 and the acceptance filter differ (UM10360 requires them equal)"
                    .into(),
            );
        }
        let rate = self.can1.bit_rate(pclk);
        let bus = u64::from(self.io.can.bus.borrow().bit_rate());
        if rate.abs_diff(bus) * 200 > bus {
            return Err(format!(
                "CAN1 runs at {rate} bit/s (BTR at PCLK {pclk} Hz), the bus at {bus} bit/s: no \
                 frame is exchanged"
            ));
        }
        Ok(())
    }

    /// The board's CAN bus up to now: sent frames free their transmit buffers, arrived
    /// frames enter the receive buffer (through the acceptance filter), requested frames go
    /// onto the bus; the interrupt line follows.
    fn can_exchange(&mut self) {
        let now = self.hw_ns();
        let port = self.io.can.port;
        let bus = self.io.can.bus.clone();
        bus.borrow_mut().advance_to(now);
        let sent = bus.borrow().sent(port);
        let quiet = sent == self.can_sent_seen
            && !bus.borrow().has_rx(port)
            && !(self.can1.operating() && self.can1.has_requests())
            && self.can1.violations.is_empty();
        if quiet {
            // Nothing crossed (asked after every event of the chip): the line and the
            // schedule only.
            self.scs.set_line(irq::CAN, self.can1.irq());
            self.check_preempt |= self.scs.any_pending();
            self.reschedule();
            return;
        }
        while self.can_sent_seen < sent {
            self.can_sent_seen += 1;
            self.can1.transmitted();
            self.traffic.can_sent += 1;
        }
        let mut arrived = Vec::new();
        while let Some((_, frame)) = bus.borrow_mut().receive(port) {
            arrived.push(frame);
        }
        if self.can1.operating() {
            let link = self.can_link();
            if !arrived.is_empty() {
                match link.clone().and_then(|()| self.can1.accepts_all()) {
                    Ok(()) => {
                        for f in &arrived {
                            if self.can1.receive(f) {
                                self.traffic.can_received += 1;
                            }
                        }
                    }
                    Err(why) => self.report(format!("CAN frame from the bus not received: {why}")),
                }
            }
            match link {
                Ok(()) => {
                    for f in self.can1.take_requests() {
                        bus.borrow_mut().send(port, f);
                    }
                }
                Err(why) if self.can1.has_requests() => {
                    self.report(format!("CAN1 transmission does not reach the bus: {why}"));
                }
                Err(_) => {}
            }
        }
        let v: Vec<String> = self.can1.violations.drain(..).collect();
        for m in v {
            self.report(format!("CAN1: {m}"));
        }
        self.scs.set_line(irq::CAN, self.can1.irq());
        self.check_preempt |= self.scs.any_pending();
        self.reschedule();
    }

    /// Output pins after a GPIO write: SPI_SEL, SYNC, LDAC edges to the chips.
    fn outputs_changed(&mut self) {
        let levels = [
            self.gpio_out(pins::ESC_SEL).unwrap_or(true),
            self.gpio_out(pins::DAC_SYNC).unwrap_or(true),
            if self.func(pins::DAC_LDAC) == pins::LDAC_PWM_FUNC {
                // PWM1.4 drives the pin: its edges come with their times (`pwm_ldac`).
                self.outputs_last[2]
            } else {
                self.gpio_out(pins::DAC_LDAC).unwrap_or(true)
            },
        ];
        let now = self.hw_ns();
        self.io.clock.set_ns(now);
        let [sel, sync, ldac] = levels;
        let [sel0, sync0, ldac0] = self.outputs_last;
        if sel != sel0 {
            let mut esc = self.io.esc.esc().borrow_mut();
            if !sel {
                self.esc_session = Some(esc.spi_begin());
            } else if let Some(s) = self.esc_session.take() {
                esc.spi_end(s);
            }
        }
        if sync != sync0 {
            if !sync {
                self.dac_frame = Some(Vec::new());
            } else if let Some(bytes) = self.dac_frame.take() {
                if !bytes.is_empty() {
                    self.traffic.dac_frames += 1;
                    let _ = self
                        .io
                        .dac
                        .transaction(&mut [Operation::Write(bytes.as_slice())]);
                }
            }
        }
        if ldac != ldac0 {
            self.ldac_to(ldac);
        }
        self.outputs_last = levels;
        self.refresh_inputs();
    }

    /// LDAC to `high` at the board's current time.
    fn ldac_to(&mut self, high: bool) {
        if !high {
            self.traffic.ldac_pulses += 1;
            let _ = self.io.ldac.set_low();
        } else {
            let _ = self.io.ldac.set_high();
        }
        self.outputs_last[2] = high;
    }

    /// PWM1.4's edges to LDAC, each at its own time, while P2.3 is PWM1.4 and PCR drives
    /// it (an undriven output leaves the pin high, as at reset).
    fn pwm_ldac(&mut self) {
        let edges = std::mem::take(&mut self.pwm1.edges);
        if self.func(pins::DAC_LDAC) != pins::LDAC_PWM_FUNC {
            return;
        }
        if self.pwm1.output(pins::LDAC_PWM_OUTPUT).is_some() {
            for e in edges {
                if usize::from(e.output) == pins::LDAC_PWM_OUTPUT && e.high != self.outputs_last[2]
                {
                    self.io.clock.set_ns(e.time_ns);
                    self.ldac_to(e.high);
                }
            }
        }
        let level = self.pwm1.output(pins::LDAC_PWM_OUTPUT).unwrap_or(true);
        if level != self.outputs_last[2] {
            self.io.clock.set_ns(self.hw_ns());
            self.ldac_to(level);
        }
    }

    /// A SYNC0 rising edge from the ESC at the current time.
    pub fn sync0_edge(&mut self) {
        if self.stm32.is_some() {
            self.stm32_sync0_edge();
            return;
        }
        if self.func(pins::ESC_SYNC0) != 3 {
            let f = self.func(pins::ESC_SYNC0);
            self.report(format!(
                "SYNC0 edge: P1.18 is PINSEL function {f}, not 3 (CAP1.0): no capture"
            ));
            return;
        }
        if !self.syscon.powered(Clocked::Timer(1)) {
            self.report("SYNC0 edge: TIMER1 is not powered (PCONP bit 2): no capture".into());
            return;
        }
        self.traffic.sync0_captures += 1;
        let t = self.tick_for(Region::Timer(1));
        self.timers[1].capture(t, 0, true);
        self.settle();
    }

    fn spi_byte(&mut self) {
        let Some(mosi) = self.spi.take_started() else {
            return;
        };
        if !self.syscon.powered(Clocked::Spi) {
            return;
        }
        let selected = self.esc_session.is_some();
        if !selected {
            self.spi.complete_with(0xFF);
            return;
        }
        let routed = self.routed(
            "legacy SPI byte to the ET1100",
            &[
                (pins::ESC_SCK, 3, "SCK"),
                (pins::ESC_MISO, 3, "MISO"),
                (pins::ESC_MOSI, 3, "MOSI"),
            ],
        );
        let esc_mode = self.io.esc.esc().borrow().peek_u8(0x0150) & 3;
        if self.spi.mode() != esc_mode {
            self.report(format!(
                "legacy SPI in mode {} but the ET1100 is configured for mode {esc_mode} (0x0150): \
                 the transfer moves no data",
                self.spi.mode()
            ));
        }
        if !routed || self.spi.mode() != esc_mode || self.spi.bits() != 8 {
            self.spi.complete_with(0xFF);
            return;
        }
        let miso = {
            let mut esc = self.io.esc.esc().borrow_mut();
            let s = self.esc_session.as_mut().expect("selected");
            esc.spi_byte(s, mosi)
        };
        self.traffic.esc_bytes += 1;
        self.spi.complete_with(miso);
    }

    fn exchange_ssp0(&mut self) -> bool {
        let Some(word) = self.ssp0.take_finished() else {
            return false;
        };
        let t = self.tick_for(Region::Ssp0);
        let routed = self.dac_frame.is_some()
            && self.routed(
                "SSP0 frame to the AD5663",
                &[(pins::DAC_SCK, 3, "SCK0"), (pins::DAC_DIN, 3, "MOSI0")],
            );
        if routed {
            if self.ssp0.mode() != 1 && self.ssp0.mode() != 2 {
                self.report(format!(
                    "SSP0 in SPI mode {}: the AD5663 samples DIN on falling SCLK edges (mode 1 or 2)",
                    self.ssp0.mode()
                ));
            } else if let Some(f) = self.dac_frame.as_mut() {
                let bits = self.ssp0.frame_bits();
                let bytes = bits.div_ceil(8);
                for i in (0..bytes).rev() {
                    f.push((u32::from(word) >> (8 * i)) as u8);
                }
            }
        }
        self.ssp0.receive(0);
        self.ssp0.kick(t);
        true
    }

    fn exchange_ssp1(&mut self) -> bool {
        let Some(word) = self.ssp1.take_finished() else {
            return false;
        };
        let t = self.tick_for(Region::Ssp1);
        let mut rx = 0;
        let selected = !self.cnv_high;
        if selected
            && self.routed(
                "SSP1 frame to the AD7689",
                &[
                    (pins::ADC_SCK, 2, "SCK1"),
                    (pins::ADC_SDO, 2, "MISO1"),
                    (pins::ADC_DIN, 2, "MOSI1"),
                ],
            )
        {
            if self.ssp1.frame_bits() != 16 || self.ssp1.mode() != 0 {
                self.report(format!(
                    "SSP1 frames of {} bits in mode {}: the AD7689 read (no busy indicator) \
                     needs 16-bit frames in mode 0",
                    self.ssp1.frame_bits(),
                    self.ssp1.mode()
                ));
            } else {
                // The result of the last conversion (no readback: 16 bits, MSB first).
                rx = self
                    .io
                    .adc
                    .adc()
                    .borrow()
                    .conversions
                    .last()
                    .map_or(0, |c| c.code);
                self.adc_mosi.extend_from_slice(&word.to_be_bytes());
            }
        }
        self.ssp1.receive(rx);
        self.ssp1.kick(t);
        true
    }

    fn update_cnv(&mut self) {
        let high = self.func(pins::ADC_CNV) == 3 && self.timers[2].match_output(0);
        if high == self.cnv_high {
            return;
        }
        self.cnv_high = high;
        if high {
            // The CNV rising edge ends the read and starts the next conversion.
            self.io.clock.set_ns(self.hw_ns());
            let mosi = std::mem::take(&mut self.adc_mosi);
            self.io.adc.adc().borrow_mut().frame(&mosi);
            self.traffic.adc_conversions += 1;
        }
    }

    // ------------------------------------------------------------------ DMA

    fn dma_requests(&self) -> u32 {
        let mut r = 0;
        if self.ssp0.tx_dma_request() {
            r |= 1;
        }
        if self.ssp0.rx_dma_request() {
            r |= 2;
        }
        if self.ssp1.tx_dma_request() {
            r |= 4;
        }
        if self.ssp1.rx_dma_request() {
            r |= 8;
        }
        let sel = self.syscon.dmareqsel();
        for n in 0..8u32 {
            if sel & (1 << n) != 0 && self.timers[(n / 2) as usize].dma_request((n % 2) as usize) {
                r |= 1 << (8 + n);
            }
        }
        r
    }

    fn run_dma(&mut self) -> bool {
        if !self.syscon.powered(Clocked::Gpdma) {
            return false;
        }
        let mut moved = false;
        for _ in 0..64 {
            let Some(x) = self.gpdma.next_transfer(self.dma_requests()) else {
                break;
            };
            moved = true;
            self.dma_move(&x);
            if let Some(line) = x.request {
                if (8..16).contains(&line) {
                    let n = line - 8;
                    self.timers[(n / 2) as usize].clear_dma_request((n % 2) as usize);
                }
            }
            match self.gpdma.transferred(&x) {
                After::LoadItem(at) => {
                    let mut b = [0u8; 16];
                    if self.dma_read(at, &mut b) {
                        let w =
                            |i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
                        self.gpdma.load_item(x.channel, [w(0), w(1), w(2), w(3)]);
                    } else {
                        self.gpdma.error(x.channel);
                    }
                }
                After::Continue | After::Stopped => {}
            }
        }
        moved
    }

    fn dma_reachable(&mut self, addr: u32, channel: usize) -> bool {
        // UNCONFIRMED (as the firmware's hw::adc_dma states): the GPDMA reaches the AHB SRAM
        // and the peripherals, not the local SRAM or the flash.
        if (0x1000_0000..0x1000_8000).contains(&addr) || addr < 0x0008_0000 {
            self.report(format!(
                "GPDMA channel {channel} accessed {addr:#010x} (local SRAM or flash), which the \
                 GPDMA does not reach: bus error"
            ));
            return false;
        }
        true
    }

    fn on_bus(addr: u32) -> bool {
        addr >= 0x4000_0000 || (0x2009_C000..0x200A_0000).contains(&addr)
    }

    fn dma_read(&mut self, addr: u32, buf: &mut [u8]) -> bool {
        if Self::on_bus(addr) {
            let base = Self::slot(addr);
            let v = self.bus_read_region(base, (addr - base) & !3);
            let bytes = v.to_le_bytes();
            let n = buf.len();
            buf.copy_from_slice(&bytes[..n]);
            true
        } else if AhbSram::contains(addr, buf.len()) {
            self.ahb_sram.dma_read(addr, buf);
            true
        } else {
            false
        }
    }

    fn dma_move(&mut self, x: &Transfer) {
        if !self.dma_reachable(x.src, x.channel) || !self.dma_reachable(x.dst, x.channel) {
            self.gpdma.error(x.channel);
            return;
        }
        let w = x.width as usize;
        let mut buf = [0u8; 4];
        if !self.dma_read(x.src, &mut buf[..w]) {
            self.gpdma.error(x.channel);
            return;
        }
        if Self::on_bus(x.dst) {
            let v = u32::from_le_bytes(buf);
            let base = Self::slot(x.dst);
            self.bus_write_region(base, (x.dst - base) & !3, v);
        } else if AhbSram::contains(x.dst, w) {
            let now = self.hw_ns();
            self.ahb_sram
                .dma_write(x.dst, &buf[..w], Self::on_bus(x.src), now);
        } else {
            self.gpdma.error(x.channel);
        }
    }

    // ------------------------------------------------------------------ bus

    fn powered(&mut self, region: Region) -> bool {
        match region.clocked() {
            Some(c) if !self.syscon.powered(c) => {
                self.report(format!(
                    "access to {} while its PCONP bit {} is 0: the peripheral does not respond",
                    c.name(),
                    c.pconp_bit().unwrap_or(0)
                ));
                false
            }
            _ => true,
        }
    }

    fn periph(&mut self, region: Region) -> Option<&mut dyn Peripheral> {
        Some(match region {
            Region::Wdt => &mut self.wdt,
            Region::Timer(n) => &mut self.timers[n],
            Region::Spi => &mut self.spi,
            Region::GpioInt => &mut self.gpioint,
            Region::PinConnect => &mut self.pincon,
            Region::Ssp1 => &mut self.ssp1,
            Region::Ssp0 => &mut self.ssp0,
            Region::Syscon => &mut self.syscon,
            Region::Gpio => &mut self.gpio,
            Region::Gpdma => &mut self.gpdma,
            Region::Can1 => &mut self.can1,
            Region::Pwm1 => &mut self.pwm1,
            Region::Scs | Region::CanAf | Region::Unmodelled(_) => return None,
        })
    }

    /// A read by the CPU (or DMA) at `offset` in the slot at `base`.
    pub fn bus_read_region(&mut self, base: u32, offset: u32) -> u32 {
        let region = Region::of_base(base);
        if region == Region::Scs {
            return self.scs.read(offset, self.cycles);
        }
        if region == Region::CanAf {
            // CANAFMR; the look-up table registers read as zero (table mode is reported).
            return if offset == 0 { self.can1.afmr() } else { 0 };
        }
        if let Region::Unmodelled(b) = region {
            self.stop = Some(Stop::Fault(format!(
                "read of {:#010x}: a peripheral the co-simulator does not model",
                b + offset
            )));
            return 0;
        }
        if !self.powered(region) {
            return 0;
        }
        if region == Region::Gpio || region == Region::GpioInt {
            self.refresh_inputs();
        }
        let t = self.tick_for(region);
        self.periph(region).map_or(0, |p| p.read(t, offset))
    }

    /// A write by the CPU (or DMA).
    pub fn bus_write_region(&mut self, base: u32, offset: u32, value: u32) {
        let region = Region::of_base(base);
        if region == Region::Scs {
            let effect = self.scs.write(offset, 4, value, self.cycles);
            if effect.reset_request {
                self.stop = Some(Stop::Reset(ResetCause::SysResetReq));
            }
            self.check_preempt = self.scs.any_pending();
            self.reschedule();
            return;
        }
        if region == Region::CanAf {
            if offset == 0 {
                self.can1.set_afmr(value);
            } else {
                self.report(format!(
                    "write of {value:#x} to the CAN acceptance filter's look-up table register \
                     {:#010x}: table mode is not modelled",
                    base + offset
                ));
            }
            return;
        }
        if let Region::Unmodelled(b) = region {
            self.stop = Some(Stop::Fault(format!(
                "write of {value:#x} to {:#010x}: a peripheral the co-simulator does not model",
                b + offset
            )));
            return;
        }
        if !self.powered(region) {
            return;
        }
        let t = self.tick_for(region);
        if let Some(p) = self.periph(region) {
            p.write(t, offset, value);
        }
        match region {
            Region::Syscon => {
                if self.syscon.take_clock_change() {
                    self.update_cycle_time();
                }
                let v: Vec<String> = self.syscon.violations.drain(..).collect();
                for m in v {
                    self.report(format!("SYSCON: {m}"));
                }
            }
            Region::Spi => {
                self.spi_byte();
                let v: Vec<String> = self.spi.violations.drain(..).collect();
                for m in v {
                    self.report(format!("SPI: {m}"));
                }
            }
            Region::Gpio => self.outputs_changed(),
            Region::Can1 => self.can_exchange(),
            Region::Wdt if self.wdt.take_reset_request() => {
                self.stop = Some(Stop::Reset(ResetCause::Watchdog));
            }
            _ => {}
        }
    }

    /// The slot base of a bus address (16 KB APB slots; the SCS is one 4 KB block).
    fn slot(addr: u32) -> u32 {
        if addr >= 0xE000_0000 {
            addr & !0xFFF
        } else {
            addr & !0x3FFF
        }
    }

    /// A CPU read of `size` bytes of the AHB SRAM (after the events due by now).
    pub fn ahb_read(&mut self, addr: u32, size: usize) -> u32 {
        self.service_due();
        let mut b = [0u8; 4];
        self.ahb_sram.cpu_read(addr, &mut b[..size]);
        u32::from_le_bytes(b)
    }

    /// A CPU write to the AHB SRAM.
    pub fn ahb_write(&mut self, addr: u32, size: usize, value: u32) {
        self.service_due();
        self.ahb_sram.cpu_write(addr, &value.to_le_bytes()[..size]);
    }

    /// A CPU access of `size` bytes at `addr` (sub-word accesses as the APB's byte lanes).
    pub fn cpu_read(&mut self, addr: u32, size: usize) -> u32 {
        self.service_due();
        if self.stm32.is_some() {
            return self.stm32_cpu_read(addr, size);
        }
        let base = Self::slot(addr);
        let shift = 8 * (addr & 3);
        let v = self.bus_read_region(base, (addr - base) & !3) >> shift;
        self.settle();
        match size {
            1 => v & 0xFF,
            2 => v & 0xFFFF,
            _ => v,
        }
    }

    /// A CPU write.
    pub fn cpu_write(&mut self, addr: u32, size: usize, value: u32) {
        self.service_due();
        if self.stm32.is_some() {
            self.stm32_cpu_write(addr, size, value);
            return;
        }
        let base = Self::slot(addr);
        let offset = addr - base;
        if Region::of_base(base) == Region::Scs && size < 4 {
            // Byte writes to the priority registers (NVIC IPR, SHPR).
            let effect = self.scs.write(offset, size, value, self.cycles);
            if effect.reset_request {
                self.stop = Some(Stop::Reset(ResetCause::SysResetReq));
            }
            self.check_preempt = self.scs.any_pending();
            return;
        }
        let shift = 8 * (addr & 3);
        let mut v = value << shift;
        if size < 4 && Region::of_base(base) == Region::Gpio {
            let lane = (if size == 1 { 0xFFu32 } else { 0xFFFF }) << shift;
            let old = self.bus_read_region(base, offset & !3);
            let reg = offset & 0x1F;
            if matches!(reg, 0x00 | 0x10 | 0x14) {
                v = (old & !lane) | (v & lane);
            }
        }
        self.bus_write_region(base, offset & !3, v);
        self.settle();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use virtual_board::rig::board::{BoardConfig, VirtualBoard as Board};

    /// A chip with blank flash on a board (no CPU: the tests drive the bus and the time).
    fn machine() -> (Board, Machine) {
        machine_with_flash(vec![0xFF; 0x8_0000])
    }

    /// A chip whose flash is all NOPs (16-bit: one instruction per 2 bytes).
    fn machine_of_nops() -> (Board, Machine) {
        machine_with_flash([0x00, 0xBF].repeat(0x4_0000))
    }

    fn machine_with_flash(flash: Vec<u8>) -> (Board, Machine) {
        let board = Board::new(BoardConfig::new(vec![0xFF; 2048]));
        let image = Image {
            chip: crate::chip::Chip::Lpc1754,
            known_product: None,
            flash,
            flash_used: 0,
            rtt: None,
            elf: Vec::new(),
            functions: Vec::new(),
            static_ram: 0,
            flash_bytes: 0,
            app_vectors: 0,
            stack_floor: crate::chip::Chip::Lpc1754.sram().start,
        };
        let m = Machine::new(board.io(), Rc::new(image));
        (board, m)
    }

    const PINSEL4: u32 = 0x4002_C010;
    const PCONP: u32 = 0x400F_C0C4;
    const PCLKSEL0: u32 = 0x400F_C1A8;
    const PWM1: u32 = 0x4001_8000;

    /// PWM1 as the oversampling outputs run it: period 100 ticks, PWM1.4 single edge, low
    /// from MR4 = 80 to the period's end, MR4 interrupt; P2.3 in function `func`.
    fn ldac_pwm(m: &mut Machine, func: u32) {
        m.cpu_write(PCONP, 4, PCONP_RESET | 1 << 6);
        m.cpu_write(PCLKSEL0, 4, 1 << 12);
        m.cpu_write(PINSEL4, 4, func << 6);
        m.cpu_write(PWM1 + 0x04, 4, 2);
        m.cpu_write(PWM1 + 0x18, 4, 99);
        m.cpu_write(PWM1 + 0x40, 4, 80);
        m.cpu_write(PWM1 + 0x14, 4, 1 << 1 | 1 << 12);
        m.cpu_write(PWM1 + 0x4C, 4, 1 << 12);
        m.cpu_write(PWM1 + 0x50, 4, 0x11);
        m.cpu_write(PWM1 + 0x04, 4, 1 | 8);
    }

    fn run_to(m: &mut Machine, t_ns: u64) {
        while m.next_event_ns() <= t_ns {
            let e = m.next_event_ns();
            m.sleep_until(e);
            m.service_due();
        }
        m.sleep_until(t_ns);
    }

    const NVIC_ISER0: u32 = 0xE000_E100;
    const UNMASKED: (bool, u8, bool) = (false, 0, false);

    /// PWM1's MR4 interrupt enabled in the NVIC; returns the time of its first MR4 match.
    fn pwm1_interrupt(m: &mut Machine) -> u64 {
        m.cpu_write(NVIC_ISER0, 4, 1 << crate::nvic::irq::PWM1);
        ldac_pwm(m, 1);
        let start = m.now_ns();
        let tick = 1_000_000_000 / m.syscon.pclk_hz(Clocked::Pwm1);
        run_to(m, start + 70 * tick);
        assert!(!m.pwm1.irq(), "no match before MR4");
        start + 80 * tick
    }

    /// A block of NOPs that spans the time `t`: `(address, size)`.
    fn block_across(m: &Machine, t: u64, instructions: u32) -> (u32, u32) {
        assert!(m.now_ns() < t, "the block starts before {t}");
        (0x100, 2 * instructions)
    }

    #[test]
    fn an_interrupt_inside_a_block_is_taken_at_its_time_and_the_block_waits() {
        let (_board, mut m) = machine_of_nops();
        let due = pwm1_interrupt(&mut m);
        m.sleep_until(due - 1_000);
        let (at, size) = block_across(&m, due, 100);
        let before = (m.instructions, m.cycles);
        assert!(!m.run_block(at, size, 0x1000_4000, Vec::new, UNMASKED));
        assert!(m.scs.preempting(false, 0, false).is_some());
        let cycle_ns = 1_000_000_000 / m.cclk_hz();
        let now = m.now_ns();
        assert!(
            now >= due && now < due + cycle_ns,
            "at the event: {now}, {due}"
        );
        assert_eq!(m.instructions, before.0, "the block has not run");
        // It runs after the handler, with all its cycles.
        let c0 = m.cycles;
        assert!(m.run_block(at, size, 0x1000_4000, Vec::new, (true, 0, false)));
        assert_eq!(m.instructions, before.0 + 100);
        assert_eq!(m.cycles - c0, 125, "100 NOPs at CPI 5/4");
        assert!(
            m.cycles - before.1 > 125,
            "the wait before the handler is a stall"
        );
    }

    #[test]
    fn a_masked_interrupt_inside_a_block_costs_the_block_nothing() {
        let (_board, mut m) = machine_of_nops();
        let due = pwm1_interrupt(&mut m);
        m.sleep_until(due - 1_000);
        let (at, size) = block_across(&m, due, 100);
        let c0 = m.cycles;
        assert!(m.run_block(at, size, 0x1000_4000, Vec::new, (true, 0, false)));
        assert_eq!(m.cycles - c0, 125, "the block's own cycles only");
        assert!(m.pwm1.irq(), "the event was served on the way");
    }

    #[test]
    fn an_exact_deadline_inside_a_block_stops_it_there() {
        let (_board, mut m) = machine_of_nops();
        let t = m.now_ns() + 500;
        m.deadline_ns = t;
        let (at, size) = block_across(&m, t, 100);
        m.exact_deadline = false;
        let c0 = m.cycles;
        assert!(m.run_block(at, size, 0x1000_4000, Vec::new, UNMASKED));
        assert_eq!(
            m.cycles - c0,
            125,
            "a slice ends with the block that reaches it"
        );
        let t = m.now_ns() + 500;
        m.deadline_ns = t;
        m.exact_deadline = true;
        assert!(!m.run_block(at, size, 0x1000_4000, Vec::new, UNMASKED));
        assert_eq!(m.stop, Some(Stop::Deadline));
        let cycle_ns = 1_000_000_000 / m.cclk_hz();
        let now = m.now_ns();
        assert!(
            now >= t && now < t + cycle_ns,
            "at the deadline: {now}, {t}"
        );
    }

    #[test]
    fn pwm1_4_drives_ldac_on_p2_3_in_function_1_each_edge_at_its_time() {
        let (board, mut m) = machine();
        ldac_pwm(&mut m, 1);
        let start = m.now_ns();
        let tick = 1_000_000_000 / m.syscon.pclk_hz(Clocked::Pwm1);
        run_to(&mut m, start + 50 * 100 * tick);
        let dac = board.dac().borrow();
        let all: Vec<u64> = dac
            .ldac_edges
            .iter()
            .filter(|e| e.falling)
            .map(|e| e.time_ns)
            .collect();
        // PWM1.4 is low until the first cycle starts: LDAC falls once when PCR drives the
        // pin (before the first MR0 reset), then once per period.
        assert!(all[0] < start + 100 * tick, "{all:?}");
        let falls = &all[1..];
        assert!(falls.len() >= 48, "{} falling edges", falls.len());
        // One fall per period, each at MR4 of its cycle: on a grid of 100 ticks.
        for t in falls {
            assert_eq!((t - falls[0]) % (100 * tick), 0, "{t}");
        }
        for w in falls.windows(2) {
            assert_eq!(w[1] - w[0], 100 * tick);
        }
        // Low for the last 20 ticks of each cycle.
        let rise = dac
            .ldac_edges
            .iter()
            .find(|e| !e.falling && e.time_ns > falls[0])
            .unwrap();
        assert_eq!(rise.time_ns - falls[0], 20 * tick);
        assert_eq!(m.traffic.ldac_pulses, all.len() as u64);
        assert!(m.pwm1.irq(), "MR4 raises PWM1's interrupt");
        assert!(m.reports.is_empty(), "{:?}", m.reports);
    }

    #[test]
    fn pwm1_edges_do_not_reach_ldac_while_p2_3_is_gpio() {
        let (board, mut m) = machine();
        ldac_pwm(&mut m, 0);
        let start = m.now_ns();
        run_to(&mut m, start + 1_000_000);
        assert!(m.pwm1.matches[4] > 0, "PWM1 runs");
        assert!(board.dac().borrow().ldac_edges.is_empty());
        assert_eq!(m.traffic.ldac_pulses, 0);
    }
}
