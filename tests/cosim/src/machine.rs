//! The machine around the core: what every chip shares, and the chip's own models chosen
//! once from the image.
//!
//! Shared ([`Cortex`]): the time base (CPU cycles at the chip's clock), the event schedule,
//! the NVIC, SCB and SysTick ([`crate::nvic`], sized by [`Chip::nvic`]), the profile, the
//! board's handles, the reports, the crossings to the board's chips, and the frames in flight
//! to the AD5663 and the AD7689 (both boards carry them).
//!
//! Per family ([`Peripherals`]): the peripherals, the bus decode and the board wiring of the
//! pin map: the LPC17xx's in [`lpc17xx`], the STM32F1's in [`stm32`]. A [`Machine`] holds
//! one of them; each access matches the enum once and the chip's code runs with the shared
//! part (`cx`) beside it, with no dynamic dispatch.

pub mod lpc17xx;
pub mod stm32;

use crate::ahb_sram::SampleWatch;
use crate::chip::{Chip, Cpi};
use crate::code::Blocks;
use crate::image::Image;
use crate::nvic::Scs;
use crate::profile::Profile;
use embedded_hal::digital::OutputPin;
use embedded_hal::spi::{Operation, SpiDevice};
use lpc17xx::Lpc17xx;
use std::ops::{Deref, DerefMut};
use std::rc::Rc;
use stm32::Stm32Parts;
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

/// The chip's own models: its peripherals, bus decode and board wiring.
pub enum Peripherals {
    /// The LPC1754's.
    Lpc17xx(Box<Lpc17xx>),
    /// The STM32F103's.
    Stm32f1(Box<Stm32Parts>),
}

/// What every chip shares: time, events, the NVIC, the profile, the board.
pub struct Cortex {
    cpi: Cpi,
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
    /// The AD5663 frame while its SYNC is low.
    dac_frame: Option<Vec<u8>>,
    /// The bytes sent to the AD7689 since its last conversion started.
    adc_mosi: Vec<u8>,
    /// The AD7689's CNV level.
    cnv_high: bool,
    /// The levels last driven on the ESC's select, the AD5663's SYNC and LDAC.
    outputs_last: [bool; 3],
    /// Reported problems.
    pub reports: Vec<Report>,
    /// Crossings to the board.
    pub traffic: Traffic,
    /// The image's blocks (instructions, code chains).
    pub blocks: Blocks,
    /// Cycles, stack and code per exception.
    pub profile: Profile,
}

/// The chip without the core: the shared part ([`Cortex`], which the machine dereferences
/// to) and the chip's models.
pub struct Machine {
    /// Which chip it is.
    pub chip: Chip,
    cortex: Cortex,
    peripherals: Peripherals,
}

impl Deref for Machine {
    type Target = Cortex;

    fn deref(&self) -> &Cortex {
        &self.cortex
    }
}

impl DerefMut for Machine {
    fn deref_mut(&mut self) -> &mut Cortex {
        &mut self.cortex
    }
}

impl Cortex {
    /// Reports a problem (once per message).
    pub fn report(&mut self, message: String) {
        if !self.reports.iter().any(|r| r.message == message) {
            self.reports.push(Report {
                time_ns: self.hw_ns(),
                message,
            });
        }
    }

    /// Virtual time (ns) of the CPU.
    pub fn now_ns(&self) -> u64 {
        self.now_ps / 1000
    }

    /// The time the peripherals and the board see: an event's own time while it is served,
    /// else the CPU's.
    fn hw_ns(&self) -> u64 {
        self.event_ns.unwrap_or_else(|| self.now_ns())
    }

    /// The CPU clock is `cclk_hz` from now on.
    fn set_cycle_time(&mut self, cclk_hz: u64) {
        self.cycle_ps = 1_000_000_000_000 / cclk_hz.max(1);
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

    /// The next event: the chip's (`chip_next`), SysTick's wrap, the board's CAN bus.
    fn reschedule(&mut self, chip_next: Option<u64>) {
        let cycle_ns = |c: u64, m: &Self| -> u64 {
            let now_c = m.cycles;
            m.now_ns() + (c.saturating_sub(now_c) * m.cycle_ps).div_ceil(1000)
        };
        let mut next = u64::MAX;
        for e in [
            chip_next,
            self.scs.systick.next_wrap().map(|c| cycle_ns(c, self)),
            self.io.can.bus.borrow().next_event_ns(),
        ]
        .into_iter()
        .flatten()
        {
            next = next.min(e);
        }
        self.next_event_ns = next;
    }

    /// SysTick's wrap when it is due.
    fn service_systick(&mut self) {
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
    }

    /// The AD5663's SYNC to `high`: low opens a frame, high ends it and delivers its bytes
    /// (if any) to the DAC.
    fn dac_sync(&mut self, high: bool) {
        if !high {
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

    /// A serial frame of `bits` to the AD5663's open frame, MSB first (none open: dropped).
    fn dac_word(&mut self, word: u16, bits: u32) {
        if let Some(f) = self.dac_frame.as_mut() {
            for i in (0..bits.div_ceil(8)).rev() {
                f.push((u32::from(word) >> (8 * i)) as u8);
            }
        }
    }

    /// A 16-bit read frame to the AD7689 that sent `word`: the result of the last
    /// conversion (no readback, MSB first).
    fn adc_read(&mut self, word: u16) -> u16 {
        self.adc_mosi.extend_from_slice(&word.to_be_bytes());
        self.io
            .adc
            .adc()
            .borrow()
            .conversions
            .last()
            .map_or(0, |c| c.code)
    }

    /// The AD7689's CNV at `high` now: the rising edge ends the read and starts the next
    /// conversion.
    fn adc_cnv(&mut self, high: bool) {
        if high == self.cnv_high {
            return;
        }
        self.cnv_high = high;
        if high {
            self.io.clock.set_ns(self.hw_ns());
            let mosi = std::mem::take(&mut self.adc_mosi);
            self.io.adc.adc().borrow_mut().frame(&mosi);
            self.traffic.adc_conversions += 1;
        }
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
}

impl Machine {
    /// A chip at power-on with `image` in its flash, on `io`'s board.
    pub fn new(io: BoardIo, image: Rc<Image>) -> Self {
        let chip = image.chip;
        let mut cortex = Cortex {
            cpi: chip.cpi(),
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
            dac_frame: None,
            adc_mosi: Vec::new(),
            cnv_high: false,
            outputs_last: [true; 3],
            reports: Vec::new(),
            traffic: Traffic::default(),
            blocks: Blocks::new(image.clone()),
            profile: Profile::new(image.initial_sp()),
        };
        cortex.now_ps = cortex.io.now_ns() * 1000;
        let peripherals = match chip {
            Chip::Lpc1754 => Peripherals::Lpc17xx(Box::new(Lpc17xx::new(&cortex))),
            Chip::Stm32f103 => Peripherals::Stm32f1(Box::new(Stm32Parts::new(
                virtual_board::models::esc::parallel::BusTiming::NO_CLASH,
            ))),
        };
        let mut m = Self {
            chip,
            cortex,
            peripherals,
        };
        let cclk = m.cclk_hz();
        m.cortex.set_cycle_time(cclk);
        m.refresh_inputs();
        m
    }

    /// The LPC1754's models (None on another chip).
    pub fn lpc17xx(&self) -> Option<&Lpc17xx> {
        match &self.peripherals {
            Peripherals::Lpc17xx(l) => Some(l),
            Peripherals::Stm32f1(_) => None,
        }
    }

    /// See [`Machine::lpc17xx`].
    pub fn lpc17xx_mut(&mut self) -> Option<&mut Lpc17xx> {
        match &mut self.peripherals {
            Peripherals::Lpc17xx(l) => Some(l),
            Peripherals::Stm32f1(_) => None,
        }
    }

    /// The STM32F103's models and board parts (None on another chip).
    pub fn stm32(&self) -> Option<&Stm32Parts> {
        match &self.peripherals {
            Peripherals::Stm32f1(s) => Some(s),
            Peripherals::Lpc17xx(_) => None,
        }
    }

    /// See [`Machine::stm32`].
    pub fn stm32_mut(&mut self) -> Option<&mut Stm32Parts> {
        match &mut self.peripherals {
            Peripherals::Stm32f1(s) => Some(s),
            Peripherals::Lpc17xx(_) => None,
        }
    }

    /// A chip reset: every peripheral to its reset state (WDTOF kept after a watchdog
    /// reset), RAM and the board untouched.
    pub fn reset(&mut self, cause: ResetCause) {
        let cx = &mut self.cortex;
        if let Peripherals::Lpc17xx(l) = &mut self.peripherals {
            l.end_session(cx);
        }
        cx.dac_frame = None;
        cx.adc_mosi.clear();
        cx.scs = Scs::with_spec(self.chip.nvic());
        match &mut self.peripherals {
            Peripherals::Lpc17xx(l) => l.reset(cx, cause),
            Peripherals::Stm32f1(s) => s.reset(cause),
        }
        cx.stop = None;
        cx.check_preempt = false;
        cx.cnv_high = false;
        cx.profile.reset();
        let cclk = self.cclk_hz();
        self.cortex.set_cycle_time(cclk);
        self.refresh_inputs();
        let next = self.chip_next_event();
        self.cortex.reschedule(next);
    }

    /// SYNC0 captures overwritten by the next edge before the CPU read them: edges the
    /// SYNC0 task never served.
    pub fn sync0_unserved(&self) -> u64 {
        match &self.peripherals {
            Peripherals::Lpc17xx(l) => l.sync0_unserved(),
            Peripherals::Stm32f1(s) => s.sync0_unserved(),
        }
    }

    /// Frames SSP1 (the STM32's SPI1) lost to a full RX FIFO (an unread RX buffer).
    pub fn ssp1_overruns(&self) -> u64 {
        match &self.peripherals {
            Peripherals::Lpc17xx(l) => l.ssp1.overruns,
            Peripherals::Stm32f1(s) => s.chip.spi1.overruns,
        }
    }

    /// AD7689 results the GPDMA wrote to the LPC1754's AHB SRAM, read and lost (none on
    /// another chip).
    pub fn samples(&self) -> SampleWatch {
        match &self.peripherals {
            Peripherals::Lpc17xx(l) => l.ahb_sram.watch.clone(),
            Peripherals::Stm32f1(_) => SampleWatch::default(),
        }
    }

    /// The CPU clock now.
    pub fn cclk_hz(&self) -> u64 {
        match &self.peripherals {
            Peripherals::Lpc17xx(l) => l.cclk_hz(),
            Peripherals::Stm32f1(s) => s.hclk_hz(),
        }
    }

    fn chip_next_event(&self) -> Option<u64> {
        match &self.peripherals {
            Peripherals::Lpc17xx(l) => l.next_event(),
            Peripherals::Stm32f1(s) => s.next_event(),
        }
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
    /// handler). An exact deadline ([`Cortex::exact_deadline`]) inside the block stops it the
    /// same way. Returns whether the block runs.
    pub fn run_block(
        &mut self,
        addr: u32,
        size: u32,
        sp: u32,
        bytes: impl FnOnce() -> Vec<u8>,
        masks: (bool, u8, bool),
    ) -> bool {
        let n = self.cortex.blocks.get(addr, size, bytes).instructions;
        let q = n * self.cortex.cpi.num + self.cortex.insn_rem;
        let block_cycles = q / self.cortex.cpi.den;
        let end_ps = self.cortex.now_ps + block_cycles * self.cortex.cycle_ps;
        let mut passed = 0;
        loop {
            let event_ps = self.cortex.next_event_ns.saturating_mul(1000);
            let deadline_ps = match self.cortex.exact_deadline {
                true => self.cortex.deadline_ns.saturating_mul(1000),
                false => u64::MAX,
            };
            let due_ps = event_ps.min(deadline_ps);
            if due_ps >= end_ps {
                break;
            }
            if due_ps > self.cortex.now_ps {
                let c = (due_ps - self.cortex.now_ps)
                    .div_ceil(self.cortex.cycle_ps)
                    .min(block_cycles - passed);
                self.cortex.add_cycles(c);
                passed += c;
            }
            self.service_due();
            let (primask, basepri, faultmask) = masks;
            let takeable = self.cortex.check_preempt
                && self
                    .cortex
                    .scs
                    .preempting(primask, basepri, faultmask)
                    .is_some();
            if takeable || self.cortex.stop.is_some() {
                return false;
            }
            if deadline_ps <= self.cortex.now_ps {
                self.cortex.stop = Some(Stop::Deadline);
                return false;
            }
            if self.cortex.next_event_ns.saturating_mul(1000) <= self.cortex.now_ps {
                // Serving reached its limit with events still due: the rest after the block.
                break;
            }
        }
        let b = self.cortex.blocks.get(addr, size, Vec::new);
        self.cortex
            .profile
            .block(&b.runs, sp.saturating_sub(b.sp_dip));
        self.cortex.instructions += n;
        self.cortex.insn_rem = q % self.cortex.cpi.den;
        self.cortex.add_cycles(block_cycles.saturating_sub(passed));
        true
    }

    /// Serves everything due at the current time.
    pub fn service_due(&mut self) {
        for _ in 0..64 {
            if self.cortex.next_event_ns > self.cortex.now_ns() {
                break;
            }
            self.cortex.event_ns = Some(self.cortex.next_event_ns);
            self.cortex.service_systick();
            let cx = &mut self.cortex;
            match &mut self.peripherals {
                Peripherals::Lpc17xx(l) => l.service(cx),
                Peripherals::Stm32f1(s) => s.service(cx),
            }
            self.cortex.event_ns = None;
        }
    }

    /// After any change: frames to the devices, pins, DMA, interrupt lines, schedule.
    pub fn settle(&mut self) {
        let cx = &mut self.cortex;
        match &mut self.peripherals {
            Peripherals::Lpc17xx(l) => l.settle(cx),
            Peripherals::Stm32f1(s) => s.settle(cx),
        }
    }

    /// Inputs from the board into the pins: the ESC's IRQ (active low), EEPROM_LOADED.
    pub fn refresh_inputs(&mut self) {
        let cx = &mut self.cortex;
        match &mut self.peripherals {
            Peripherals::Lpc17xx(l) => l.refresh_inputs(cx),
            Peripherals::Stm32f1(s) => s.refresh_inputs(cx),
        }
    }

    /// A SYNC0 rising edge from the ESC at the current time.
    pub fn sync0_edge(&mut self) {
        let cx = &mut self.cortex;
        match &mut self.peripherals {
            Peripherals::Lpc17xx(l) => l.sync0_edge(cx),
            Peripherals::Stm32f1(s) => s.sync0_edge(cx),
        }
    }

    /// A CPU read of `size` bytes at `addr` (after the events due by now).
    pub fn cpu_read(&mut self, addr: u32, size: usize) -> u32 {
        self.service_due();
        let cx = &mut self.cortex;
        match &mut self.peripherals {
            Peripherals::Lpc17xx(l) => l.cpu_read(cx, addr, size),
            Peripherals::Stm32f1(s) => s.cpu_read(cx, addr, size),
        }
    }

    /// A CPU write.
    pub fn cpu_write(&mut self, addr: u32, size: usize, value: u32) {
        self.service_due();
        let cx = &mut self.cortex;
        match &mut self.peripherals {
            Peripherals::Lpc17xx(l) => l.cpu_write(cx, addr, size, value),
            Peripherals::Stm32f1(s) => s.cpu_write(cx, addr, size, value),
        }
    }

    /// A CPU read of `size` bytes of the LPC1754's AHB SRAM (after the events due by now;
    /// the engine maps it on that chip only, another reads 0).
    pub fn ahb_read(&mut self, addr: u32, size: usize) -> u32 {
        self.service_due();
        self.lpc17xx_mut().map_or(0, |l| l.ahb_read(addr, size))
    }

    /// A CPU write to the AHB SRAM (see [`Machine::ahb_read`]).
    pub fn ahb_write(&mut self, addr: u32, size: usize, value: u32) {
        self.service_due();
        if let Some(l) = self.lpc17xx_mut() {
            l.ahb_write(addr, size, value);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::lpc17xx::tests::{ldac_pwm, lpc, machine_of_nops, run_to};
    use super::*;
    use crate::periph::syscon::Clocked;
    use crate::periph::Peripheral;

    const NVIC_ISER0: u32 = 0xE000_E100;
    const UNMASKED: (bool, u8, bool) = (false, 0, false);

    /// PWM1's MR4 interrupt enabled in the NVIC; returns the time of its first MR4 match.
    fn pwm1_interrupt(m: &mut Machine) -> u64 {
        m.cpu_write(NVIC_ISER0, 4, 1 << crate::nvic::irq::PWM1);
        ldac_pwm(m, 1);
        let start = m.now_ns();
        let tick = 1_000_000_000 / lpc(m).syscon.pclk_hz(Clocked::Pwm1);
        run_to(m, start + 70 * tick);
        assert!(!lpc(m).pwm1.irq(), "no match before MR4");
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
        assert!(lpc(&m).pwm1.irq(), "the event was served on the way");
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
}
