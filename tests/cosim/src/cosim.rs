//! The co-simulated LPC1754 as the virtual board's CPU: the release image runs from reset on
//! [`crate::cpu::Core`], wired to the board's ET1100, AD5663 and AD7689 models through
//! [`crate::machine::Machine`], on the board's virtual time.

use crate::ahb_sram::SampleWatch;
use crate::cpu::{Core, EngineMem, Fault};
use crate::image::{Crp, Image, ImageError};
use crate::machine::{Machine, Report, ResetCause, Traffic, CPI_DEN, CPI_NUM};
use crate::nvic::exc;
use crate::profile::{ExceptionStats, THREAD};
use crate::rtt::Rtt;
use std::cell::RefCell;
use std::fmt::Write as _;
use std::rc::Rc;
use virtual_board::models::esc::SyncEdge;
use virtual_board::rig::board::{BoardIo, PdiCpu};

/// Longest stretch the board's ESC model lags behind the CPU: the board stops at least this
/// often while the CPU runs (SPI accesses see ESC time within it).
pub const BOARD_STEP_NS: u64 = 10_000;
/// On the wall clock, a slice that ends this close before a SYNC edge ends exactly: longer
/// than the longest instruction block's time, so the block cannot pass the edge.
const EDGE_GUARD_NS: u64 = 2_000;

/// How to start the chip.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// PCONP after reset instead of UM10360's reset value (what a bootloader leaves).
    pub pconp_at_reset: Option<u32>,
    /// Print the firmware's defmt log to stderr as it comes.
    pub echo_log: bool,
    /// From this virtual time on, interrupts stay disabled for ever (PRIMASK = 1 forced):
    /// a stuck critical section, for the watchdog test.
    pub lock_up_at_ns: Option<u64>,
    /// The ET1100's BUSY times on its µC PDI (the STM32F103's FSMC) instead of the model's
    /// `BusTiming::NO_CLASH` (both ends of the UNCONFIRMED range can be run).
    pub esc_bus_timing: Option<virtual_board::models::esc::parallel::BusTiming>,
    /// The time model's cycles per instruction instead of the chip's (a sensitivity run).
    pub cpi: Option<crate::chip::Cpi>,
}

/// What the co-simulation shows about the image (the "image facts").
#[derive(Clone, Debug, Default)]
pub struct Facts {
    /// Instructions executed.
    pub instructions: u64,
    /// CPU cycles (instructions x CPI + exception entry/return + sleep).
    pub cycles: u64,
    /// Cycles asleep in WFI.
    pub sleep_cycles: u64,
    /// Virtual time (ns).
    pub time_ns: u64,
    /// Deepest stack use (bytes) and the stack's size.
    pub stack_used: u32,
    /// See [`Facts::stack_used`].
    pub stack_size: u32,
    /// Thread mode's deepest stack since the first exception (idle's, under the tasks;
    /// init's is in thread mode's [`ExceptionStats::max_stack`]).
    pub thread_stack_with_tasks: u32,
    /// Per exception number: name and figures (thread mode, number 0, first).
    pub exceptions: Vec<(u32, String, ExceptionStats)>,
    /// NVIC priority byte of each exception in [`Facts::exceptions`] (thread mode has none).
    pub priorities: Vec<(u32, u8)>,
    /// Instructions per context and code chain.
    pub code: Vec<CodeCycles>,
    /// The chains of functions by number ([`crate::code`]): outermost (the symbol) first,
    /// the inlined ones after it.
    pub chains: Vec<Vec<String>>,
    /// Crossings to the board's chips.
    pub traffic: Traffic,
    /// AD7689 results the GPDMA wrote, read and lost ([`crate::ahb_sram`]).
    pub samples: SampleWatch,
    /// AD7689 frames lost to a full SSP1 RX FIFO.
    pub ssp1_overruns: u64,
    /// FSMC bus cycles to the ET1100 (the STM32F103) and the time they took (ns, BUSY
    /// included).
    pub fsmc_cycles: u64,
    /// See [`Facts::fsmc_cycles`].
    pub fsmc_ns: u64,
    /// SYNC0 edges captured by CAP1.0 whose capture the CPU never read before the next one.
    pub sync0_unserved: u64,
    /// Problems the models reported.
    pub reports: Vec<Report>,
    /// The core's fault, if any.
    pub fault: Option<Fault>,
    /// Resets (cause, time).
    pub resets: Vec<(ResetCause, u64)>,
    /// The CRP level of the image.
    pub crp: Option<Crp>,
    /// CCLK at the end (Hz).
    pub cclk_hz: u64,
}

/// Instructions one context executed in one chain of functions ([`crate::code`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CodeCycles {
    /// The context: exception number, 0 for thread mode.
    pub context: u32,
    /// The chain of functions (a number into [`Facts::chains`]).
    pub chain: u32,
    /// Instructions executed.
    pub instructions: u64,
}

/// Cycles of `instructions` at the time model's CPI.
pub fn instruction_cycles(instructions: u64) -> u64 {
    instructions * CPI_NUM / CPI_DEN
}

impl Facts {
    /// The functions context `context` executed its own instructions in (the innermost
    /// function of each chain), with their cycles, most first.
    pub fn own_functions(&self, context: u32) -> Vec<(String, u64)> {
        self.innermost(
            self.code
                .iter()
                .filter(|c| c.context == context)
                .map(|c| (c.chain, c.instructions)),
        )
    }

    /// The functions of the longest activation of exception `n` (its own code), with their
    /// cycles, most first.
    pub fn longest_functions(&self, n: u32) -> Vec<(String, u64)> {
        self.exception(n)
            .map(|e| self.innermost(e.longest_code.iter().copied()))
            .unwrap_or_default()
    }

    /// The functions of `chain`.
    pub fn chain(&self, chain: u32) -> &[String] {
        self.chains
            .get(chain as usize)
            .map_or(&[], |c| c.as_slice())
    }

    /// (chain, instructions) summed per innermost function, in cycles, most first.
    fn innermost(&self, code: impl Iterator<Item = (u32, u64)>) -> Vec<(String, u64)> {
        let mut by_name: Vec<(String, u64)> = Vec::new();
        for (chain, n) in code {
            let name = self.chain(chain).last().cloned().unwrap_or_default();
            match by_name.iter_mut().find(|(f, _)| *f == name) {
                Some((_, i)) => *i += n,
                None => by_name.push((name, n)),
            }
        }
        let mut out: Vec<(String, u64)> = by_name
            .into_iter()
            .map(|(n, i)| (n, instruction_cycles(i)))
            .collect();
        out.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        out
    }

    /// Cycles of instructions (any context, or `context`) in code of a function whose name
    /// `matches`, inlined or not: every chain with such a function in it counts.
    pub fn cycles_in(&self, context: Option<u32>, matches: impl Fn(&str) -> bool) -> u64 {
        instruction_cycles(
            self.code
                .iter()
                .filter(|c| context.is_none_or(|x| x == c.context))
                .filter(|c| self.chain(c.chain).iter().any(|n| matches(n)))
                .map(|c| c.instructions)
                .sum(),
        )
    }

    /// The figures of exception `n` (0: thread mode).
    pub fn exception(&self, n: u32) -> Option<&ExceptionStats> {
        self.exceptions.iter().find(|e| e.0 == n).map(|e| &e.2)
    }

    /// CPU load: cycles not asleep.
    pub fn cpu_load(&self) -> f64 {
        if self.cycles == 0 {
            return 0.0;
        }
        (self.cycles - self.sleep_cycles) as f64 / self.cycles as f64
    }

    /// The facts as text (one line each).
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "image: {} instructions, {} cycles (CPI {CPI_NUM}/{CPI_DEN} + exception entry/return), {:.6} s virtual at CCLK {} MHz",
            self.instructions,
            self.cycles,
            self.time_ns as f64 * 1e-9,
            self.cclk_hz / 1_000_000
        );
        let _ = writeln!(
            s,
            "image: CPU load {:.1} % (cycles not in WFI)",
            100.0 * self.cpu_load()
        );
        let _ = writeln!(
            s,
            "image: deepest stack {} B of {} B",
            self.stack_used, self.stack_size
        );
        for (n, name, e) in &self.exceptions {
            let _ = writeln!(
                s,
                "image: {:<17} {:>8} activations, entry..return {:>6.0} cycles mean, {:>6} max; \
                 own cycles {:>5.1} %; stack {:>4} B",
                format!("{name} ({n})"),
                e.count,
                e.cycles as f64 / e.count.max(1) as f64,
                e.max_cycles,
                100.0 * e.own_cycles as f64 / self.cycles.max(1) as f64,
                e.max_stack
            );
            let top: Vec<String> = self
                .own_functions(*n)
                .iter()
                .take(3)
                .map(|(f, c)| {
                    format!(
                        "{f} {:.1} %",
                        100.0 * *c as f64 / e.own_cycles.max(1) as f64
                    )
                })
                .collect();
            if !top.is_empty() {
                let _ = writeln!(s, "image:     most of it in {}", top.join(", "));
            }
        }
        let t = &self.traffic;
        let _ = writeln!(
            s,
            "image: board traffic: {} ET1100 SPI bytes, {} AD5663 frames, {} LDAC pulses, {} AD7689 conversions, {} SYNC0 captures, {} CAN frames sent, {} received",
            t.esc_bytes,
            t.dac_frames,
            t.ldac_pulses,
            t.adc_conversions,
            t.sync0_captures,
            t.can_sent,
            t.can_received
        );
        if self.fsmc_cycles > 0 {
            let _ = writeln!(
                s,
                "image: ET1100 on FSMC bank 1: {} bus cycles, {:.1} us of bus time ({:.0} ns each)",
                self.fsmc_cycles,
                self.fsmc_ns as f64 / 1e3,
                self.fsmc_ns as f64 / self.fsmc_cycles as f64
            );
        }
        let w = &self.samples;
        let _ = writeln!(
            s,
            "image: AD7689 results through the GPDMA: {} written, {} read by the CPU, {} lost \
             (overwritten unread), {} lost to SSP1 RX overruns",
            w.written, w.read, w.lost, self.ssp1_overruns
        );
        for (cause, t) in &self.resets {
            let _ = writeln!(s, "image: reset by {cause:?} at {:.6} s", *t as f64 * 1e-9);
        }
        for r in &self.reports {
            let _ = writeln!(
                s,
                "image: REPORTED at {:.6} s: {}",
                r.time_ns as f64 * 1e-9,
                r.message
            );
        }
        if let Some(f) = &self.fault {
            let _ = writeln!(s, "image: {f}");
        }
        s
    }
}

/// The name of exception `n` on the STM32F103 (RM0008 table 63; the ones the image binds, the
/// others by number).
fn stm32_irq_name(irq: u32) -> Option<&'static str> {
    use crate::stm32::irq;
    Some(match irq {
        irq::EXTI0 => "EXTI0",
        irq::TIM3 => "TIM3",
        irq::SPI1 => "SPI1",
        irq::SPI2 => "SPI2",
        irq::TIM8_CC => "TIM8_CC",
        n if (irq::DMA1_CHANNEL1..irq::DMA1_CHANNEL1 + 7).contains(&n) => [
            "DMA1_CH1", "DMA1_CH2", "DMA1_CH3", "DMA1_CH4", "DMA1_CH5", "DMA1_CH6", "DMA1_CH7",
        ][(n - irq::DMA1_CHANNEL1) as usize],
        _ => return None,
    })
}

/// The name of exception `n` on `chip`.
pub fn exception_name_on(chip: crate::chip::Chip, n: u32) -> String {
    if chip == crate::chip::Chip::Stm32f103 && n >= exc::IRQ0 {
        return stm32_irq_name(n - exc::IRQ0).map_or(format!("IRQ{}", n - exc::IRQ0), String::from);
    }
    exception_name(n)
}

/// The name of exception `n` on the LPC17xx.
pub fn exception_name(n: u32) -> String {
    const IRQS: [&str; 35] = [
        "WDT", "TIMER0", "TIMER1", "TIMER2", "TIMER3", "UART0", "UART1", "UART2", "UART3", "PWM1",
        "I2C0", "I2C1", "I2C2", "SPI", "SSP0", "SSP1", "PLL0", "RTC", "EINT0", "EINT1", "EINT2",
        "EINT3", "ADC", "BOD", "USB", "CAN", "DMA", "I2S", "ENET", "RIT", "MCPWM", "QEI", "PLL1",
        "USBACT", "CANACT",
    ];
    match n {
        THREAD => "thread".into(),
        exc::NMI => "NMI".into(),
        exc::HARD_FAULT => "HardFault".into(),
        exc::SVCALL => "SVCall".into(),
        exc::PENDSV => "PendSV".into(),
        exc::SYSTICK => "SysTick".into(),
        n if n >= exc::IRQ0 => IRQS
            .get((n - exc::IRQ0) as usize)
            .map_or(format!("IRQ{}", n - exc::IRQ0), |s| (*s).to_string()),
        n => format!("exc{n}"),
    }
}

/// The co-simulated MCU.
pub struct Cosim {
    core: Core,
    rtt: Rtt,
    options: Options,
    crp: Crp,
    /// Resets seen when the lock-up was injected (the lock-up ends with the next reset).
    locked_up: Option<usize>,
}

impl Cosim {
    /// The chip with `image` in flash, at power-on, on the board behind `io`. Fails as the
    /// boot ROM would (a wrong vector checksum never starts).
    pub fn new(image: Rc<Image>, io: BoardIo, options: Options) -> Result<Self, ImageError> {
        let crp = image.boot_rom_check()?;
        let mut machine = Machine::new(io, image.clone());
        if let Some(p) = options.pconp_at_reset {
            if let Some(l) = machine.lpc17xx_mut() {
                l.pconp_at_reset = p;
            }
            machine.reset(ResetCause::SysResetReq);
        }
        if let Some(cpi) = options.cpi {
            machine.set_cpi(cpi);
        }
        if let (Some(t), Some(p)) = (options.esc_bus_timing, machine.stm32_mut()) {
            p.esc_port.timing = t;
        }
        let machine = Rc::new(RefCell::new(machine));
        let core = Core::new(image.clone(), machine).map_err(ImageError::Elf)?;
        let rtt = Rtt::new(&image.elf, image.rtt);
        Ok(Self {
            core,
            rtt,
            options,
            crp,
            locked_up: None,
        })
    }

    /// Where the core is: PC and the function there.
    pub fn where_is_pc(&self) -> String {
        let pc = self
            .core
            .uc
            .reg_read(unicorn_engine::RegisterARM::PC)
            .unwrap_or(0) as u32;
        match self.core.image().symbolize(pc) {
            Some((f, off)) => format!("{pc:#010x} ({f}+{off:#x})"),
            None => format!("{pc:#010x}"),
        }
    }

    /// The log lines so far.
    pub fn log(&self) -> &[String] {
        &self.rtt.lines
    }

    /// The fault of the core, if any.
    pub fn fault(&self) -> Option<&Fault> {
        self.core.fault.as_ref()
    }

    /// The flash as it is now (the LPC1754's IAP ROM's writes included; another chip's is
    /// the image's, which nothing writes).
    pub fn flash(&self) -> Vec<u8> {
        match self.core.machine.borrow().lpc17xx() {
            Some(l) => l.flash.flash().to_vec(),
            None => self.core.image().flash.clone(),
        }
    }

    /// Problems the models reported.
    pub fn reports(&self) -> Vec<Report> {
        self.core.machine.borrow().reports.clone()
    }

    /// The figures so far.
    pub fn facts(&self) -> Facts {
        let m = self.core.machine.borrow();
        let exceptions = m
            .profile
            .exceptions
            .iter()
            .enumerate()
            .filter(|(n, e)| *n == THREAD as usize || e.count > 0)
            .map(|(n, e)| (n as u32, exception_name_on(m.chip, n as u32), e.clone()))
            .collect();
        let priorities = m
            .profile
            .exceptions
            .iter()
            .enumerate()
            .filter(|(n, e)| *n != THREAD as usize && e.count > 0)
            .map(|(n, _)| (n as u32, m.scs.priority(n as u32).clamp(0, 255) as u8))
            .collect();
        let code = m
            .profile
            .instructions()
            .map(|(context, chain, instructions)| CodeCycles {
                context,
                chain,
                instructions,
            })
            .collect();
        let chains = (0..m.blocks.code.chains() as u32)
            .map(|c| {
                m.blocks
                    .code
                    .chain(c)
                    .into_iter()
                    .map(String::from)
                    .collect()
            })
            .collect();
        Facts {
            instructions: m.instructions,
            cycles: m.cycles,
            sleep_cycles: m.profile.sleep_cycles,
            time_ns: m.now_ns(),
            stack_used: self.core.stack_high_water(),
            stack_size: self.core.stack_size(),
            thread_stack_with_tasks: m.profile.thread_stack_with_tasks(),
            exceptions,
            priorities,
            code,
            chains,
            traffic: m.traffic.clone(),
            samples: m.samples(),
            ssp1_overruns: m.ssp1_overruns(),
            fsmc_cycles: m.stm32().map_or(0, |p| p.fsmc_accesses),
            fsmc_ns: m.stm32().map_or(0, |p| p.fsmc_ns),
            sync0_unserved: m.sync0_unserved(),
            reports: m.reports.clone(),
            fault: self.core.fault.clone(),
            resets: self.core.resets.clone(),
            crp: Some(self.crp),
            cclk_hz: m.cclk_hz(),
        }
    }

    fn drain_log(&mut self) {
        let lines = self.rtt.drain(&mut EngineMem(&mut self.core.uc));
        if self.options.echo_log {
            for l in lines {
                eprintln!("[firmware] {l}");
            }
        }
    }

    fn inject(&mut self, t_ns: u64) -> u64 {
        match self.options.lock_up_at_ns {
            Some(at) if self.locked_up.is_none() && t_ns >= at => {
                let now = self.core.machine.borrow().now_ns();
                if now < at {
                    return at;
                }
                self.locked_up = Some(self.core.resets.len());
                let _ = self
                    .core
                    .uc
                    .reg_write(unicorn_engine::RegisterARM::PRIMASK, 1);
                t_ns
            }
            _ => t_ns,
        }
    }

    fn keep_locked(&mut self) {
        if self.locked_up == Some(self.core.resets.len()) {
            let _ = self
                .core
                .uc
                .reg_write(unicorn_engine::RegisterARM::PRIMASK, 1);
        }
    }
}

impl PdiCpu for Cosim {
    fn runs_continuously(&self) -> bool {
        true
    }

    fn run_until(&mut self, io: &mut BoardIo, t_ns: u64) {
        // A SYNC edge then (the next one, or on the wall clock one that waits for the CPU):
        // the core reaches it exactly, so that its capture and interrupt come at the edge's
        // time. On the wall clock the slices end anywhere: one that ends right before an
        // edge ends exactly too, so that its last block does not pass the edge.
        let esc = io.esc.esc();
        let near = if esc.on_wall_clock() {
            EDGE_GUARD_NS
        } else {
            0
        };
        let edge = esc.sync_edge_near(t_ns, near);
        let mut t = self.inject(t_ns);
        loop {
            self.keep_locked();
            if edge && t == t_ns {
                self.core.run_until_exactly(t);
            } else {
                self.core.run_until(t);
            }
            if t >= t_ns {
                break;
            }
            t = self.inject(t_ns);
        }
        self.drain_log();
    }

    fn on_sync0(&mut self, _io: &mut BoardIo, _edge: &SyncEdge) {
        let mut m = self.core.machine.borrow_mut();
        m.sync0_edge();
    }

    fn next_timer_ns(&self) -> Option<u64> {
        Some(self.core.machine.borrow().now_ns() + BOARD_STEP_NS)
    }

    fn next_wake_ns(&self, _io: &BoardIo) -> u64 {
        self.core.next_wake_ns()
    }

    fn idle_until(&mut self, _io: &mut BoardIo, t_ns: u64) -> u64 {
        self.core.idle_until(t_ns)
    }
}
