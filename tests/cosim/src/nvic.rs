//! The Cortex-M3 system control space (ARMv7-M ARM B3; Cortex-M3 TRM chapters 6 and 8) with
//! the chip's parameters ([`NvicSpec`]: the LPC1754's 35 interrupts and 5 priority bits, UM10360
//! chapters 6 and 34; the STM32F103's 60 and 4, RM0008/PM0056): NVIC, SCB (ICSR, VTOR, AIRCR,
//! SHPR, CCR), SysTick, and the exception state the harness keeps (pending and active
//! exceptions, execution priority, interrupt lines).
//!
//! unicorn has none of this in M-profile mode: `cpu` does the stacking and the returns, this
//! module decides what is pending, what may preempt and where the vector is.

/// Exception numbers (ARMv7-M B1.5.2).
pub mod exc {
    /// Reset.
    pub const RESET: u32 = 1;
    /// Non-maskable interrupt.
    pub const NMI: u32 = 2;
    /// HardFault.
    pub const HARD_FAULT: u32 = 3;
    /// SVCall.
    pub const SVCALL: u32 = 11;
    /// PendSV.
    pub const PENDSV: u32 = 14;
    /// SysTick.
    pub const SYSTICK: u32 = 15;
    /// First external interrupt (IRQ 0).
    pub const IRQ0: u32 = 16;
}

/// External interrupts of the LPC17xx (UM10360 table 50).
pub mod irq {
    /// Watchdog.
    pub const WDT: u32 = 0;
    /// Timer 0..3.
    pub const TIMER0: u32 = 1;
    /// PWM1.
    pub const PWM1: u32 = 9;
    /// SPI.
    pub const SPI: u32 = 13;
    /// SSP0.
    pub const SSP0: u32 = 14;
    /// SSP1.
    pub const SSP1: u32 = 15;
    /// EINT3, shared with the GPIO interrupts.
    pub const EINT3: u32 = 21;
    /// CAN1, CAN2 and the acceptance filter.
    pub const CAN: u32 = 25;
    /// General purpose DMA.
    pub const DMA: u32 = 26;
    /// Number of interrupts of the LPC17xx.
    pub const COUNT: u32 = 35;
}

/// Implemented priority bits: 5 (UM10360 6.4: bits 7:3 of each priority byte).
pub const PRIO_MASK: u8 = 0xF8;
/// SYST_CALIB of the LPC17xx (UM10360 23.4.4: 10 ms at 100 MHz, TENMS = 999 999).
pub const SYST_CALIB: u32 = 0x000F_423F;
/// CPUID of the LPC17xx's Cortex-M3 r2p0.
pub const CPUID: u32 = 0x412F_C230;

/// The NVIC and SCB as a chip implements them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NvicSpec {
    /// External interrupts.
    pub irqs: u32,
    /// The implemented bits of a priority byte.
    pub prio_mask: u8,
    /// SYST_CALIB.
    pub syst_calib: u32,
    /// CPUID.
    pub cpuid: u32,
    /// CCR at reset (STKALIGN is 0 on r1p1, 1 from r2p0).
    pub ccr_reset: u32,
}

impl NvicSpec {
    /// The LPC1754 ([`irq::COUNT`], [`PRIO_MASK`], [`SYST_CALIB`], [`CPUID`]; r2p0, STKALIGN
    /// set at reset).
    pub const LPC1754: NvicSpec = NvicSpec {
        irqs: irq::COUNT,
        prio_mask: PRIO_MASK,
        syst_calib: SYST_CALIB,
        cpuid: CPUID,
        ccr_reset: 0x200,
    };
}

/// Exception numbers the state has room for (16 system + up to 64 external).
const EXCEPTIONS: usize = 80;

/// SysTick (ARMv7-M B3.3): counts CPU cycles down from RVR; an interrupt per wrap when
/// TICKINT.
#[derive(Clone, Debug, Default)]
pub struct SysTick {
    csr: u32,
    rvr: u32,
    /// When running: the cycle count (CPU cycles since boot) at which CVR reads 0 next.
    zero_at_cycle: Option<u64>,
    /// CVR while stopped.
    cvr: u32,
    count_flag: bool,
    calib: u32,
}

impl SysTick {
    const ENABLE: u32 = 1;
    const TICKINT: u32 = 2;
    const CLKSOURCE: u32 = 4;

    fn period(&self) -> u64 {
        u64::from(self.rvr & 0x00FF_FFFF) + 1
    }

    /// The cycle of the next wrap (the interrupt), if counting.
    pub fn next_wrap(&self) -> Option<u64> {
        self.zero_at_cycle
    }

    /// Whether a wrap requests the SysTick exception.
    pub fn interrupts(&self) -> bool {
        self.csr & Self::TICKINT != 0
    }

    /// Serves a wrap at `cycle`: reload, COUNTFLAG.
    pub fn wrap(&mut self, cycle: u64) {
        if let Some(z) = self.zero_at_cycle {
            if cycle >= z {
                self.count_flag = true;
                let period = self.period();
                let missed = (cycle - z) / period;
                self.zero_at_cycle = Some(z + (missed + 1) * period);
            }
        }
    }

    fn cvr_at(&self, cycle: u64) -> u32 {
        match self.zero_at_cycle {
            Some(z) => (z.saturating_sub(cycle) % self.period()) as u32,
            None => self.cvr,
        }
    }

    fn read(&mut self, offset: u32, cycle: u64) -> u32 {
        match offset {
            0x10 => {
                let v = self.csr | if self.count_flag { 1 << 16 } else { 0 };
                self.count_flag = false;
                v
            }
            0x14 => self.rvr,
            0x18 => self.cvr_at(cycle),
            0x1C => self.calib,
            _ => 0,
        }
    }

    fn write(&mut self, offset: u32, value: u32, cycle: u64) {
        match offset {
            0x10 => {
                let was = self.csr & Self::ENABLE != 0;
                self.csr = value & (Self::ENABLE | Self::TICKINT | Self::CLKSOURCE);
                let now = self.csr & Self::ENABLE != 0;
                if now && !was {
                    // CVR 0 loads RVR on the next cycle; else it counts down from CVR.
                    let first = if self.cvr == 0 {
                        self.period()
                    } else {
                        u64::from(self.cvr)
                    };
                    self.zero_at_cycle = Some(cycle + first);
                } else if !now && was {
                    self.cvr = self.cvr_at(cycle);
                    self.zero_at_cycle = None;
                }
            }
            0x14 => self.rvr = value & 0x00FF_FFFF,
            0x18 => {
                // Any write clears CVR and COUNTFLAG; the counter reloads on the next cycle.
                self.cvr = 0;
                self.count_flag = false;
                if self.zero_at_cycle.is_some() {
                    self.zero_at_cycle = Some(cycle + self.period());
                }
            }
            _ => {}
        }
    }

    /// Whether the SysTick uses the CPU clock (CLKSOURCE = 1); the external STCLK is not
    /// modelled.
    pub fn uses_cpu_clock(&self) -> bool {
        self.csr & Self::CLKSOURCE != 0
    }

    /// Whether it counts.
    pub fn enabled(&self) -> bool {
        self.csr & Self::ENABLE != 0
    }
}

/// What a write to the SCS asks of the CPU beyond register state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScsEffect {
    /// AIRCR.SYSRESETREQ with the right key: reset the chip.
    pub reset_request: bool,
}

/// The NVIC, SCB and SysTick state.
#[derive(Clone, Debug)]
pub struct Scs {
    spec: NvicSpec,
    enabled: u128,
    pending: u128,
    /// Active exceptions, innermost last.
    active: Vec<u32>,
    /// Interrupt lines asserted by the peripherals (level).
    lines: u128,
    prio: [u8; EXCEPTIONS],
    vtor: u32,
    prigroup: u32,
    scr: u32,
    ccr: u32,
    /// SysTick.
    pub systick: SysTick,
    /// Exceptions taken, per exception number.
    pub taken: [u64; EXCEPTIONS],
    /// Writes to implemented-but-ignored or unknown SCS registers (offset, value).
    pub unmodelled: Vec<(u32, u32)>,
}

impl Default for Scs {
    fn default() -> Self {
        Self::new()
    }
}

fn bit(e: u32) -> u128 {
    1u128 << e
}

impl Scs {
    /// The reset state of the LPC1754's.
    pub fn new() -> Self {
        Self::with_spec(NvicSpec::LPC1754)
    }

    /// The reset state of a chip's.
    pub fn with_spec(spec: NvicSpec) -> Self {
        Self {
            spec,
            enabled: 0,
            pending: 0,
            active: Vec::new(),
            lines: 0,
            prio: [0; EXCEPTIONS],
            vtor: 0,
            prigroup: 0,
            scr: 0,
            ccr: spec.ccr_reset,
            systick: SysTick {
                calib: spec.syst_calib,
                ..SysTick::default()
            },
            taken: [0; EXCEPTIONS],
            unmodelled: Vec::new(),
        }
    }

    /// VTOR.
    pub fn vtor(&self) -> u32 {
        self.vtor
    }

    /// Whether 8-byte stack alignment is forced on exception entry (CCR.STKALIGN).
    pub fn stack_align_8(&self) -> bool {
        self.ccr & 0x200 != 0
    }

    /// Priority of exception `e` (fixed negative ones for Reset, NMI, HardFault).
    pub fn priority(&self, e: u32) -> i32 {
        match e {
            exc::RESET => -3,
            exc::NMI => -2,
            exc::HARD_FAULT => -1,
            _ => i32::from(self.prio[e as usize]),
        }
    }

    fn group(&self, p: i32) -> i32 {
        if p < 0 {
            return p;
        }
        // Subpriority bits below PRIGROUP + 1 do not preempt.
        let sub_bits = self.prigroup + 1;
        p & !((1 << sub_bits) - 1)
    }

    fn is_enabled(&self, e: u32) -> bool {
        e < exc::IRQ0 || self.enabled & bit(e) != 0
    }

    /// The execution priority: the active exceptions, BASEPRI, PRIMASK, FAULTMASK
    /// (ARMv7-M B1.5.4); 256 in thread mode with nothing masked.
    pub fn execution_priority(&self, primask: bool, basepri: u8, faultmask: bool) -> i32 {
        let mut p = 256;
        for &e in &self.active {
            p = p.min(self.group(self.priority(e)));
        }
        let basepri = basepri & self.spec.prio_mask;
        if basepri != 0 {
            p = p.min(self.group(i32::from(basepri)));
        }
        if primask {
            p = p.min(0);
        }
        if faultmask {
            p = p.min(-1);
        }
        p
    }

    /// The pending, enabled exception of highest priority (lowest number on a tie).
    pub fn highest_pending(&self) -> Option<u32> {
        let mut best: Option<(i32, u32)> = None;
        let mut bits = self.pending;
        while bits != 0 {
            let e = bits.trailing_zeros();
            bits &= bits - 1;
            if !self.is_enabled(e) {
                continue;
            }
            let p = self.group(self.priority(e));
            if best.is_none_or(|(bp, _)| p < bp) {
                best = Some((p, e));
            }
        }
        best.map(|(_, e)| e)
    }

    /// The exception that preempts now, if any.
    pub fn preempting(&self, primask: bool, basepri: u8, faultmask: bool) -> Option<u32> {
        let e = self.highest_pending()?;
        (self.group(self.priority(e)) < self.execution_priority(primask, basepri, faultmask))
            .then_some(e)
    }

    /// Whether anything is pending and enabled (the cheap test before reading the masks).
    pub fn any_pending(&self) -> bool {
        self.highest_pending().is_some()
    }

    /// Whether a WFI wakes: an exception that would preempt with PRIMASK clear.
    pub fn wakes_from_wfi(&self, basepri: u8, faultmask: bool) -> bool {
        self.preempting(false, basepri, faultmask).is_some()
    }

    /// Sets exception `e` pending.
    pub fn set_pending(&mut self, e: u32) {
        if e < exc::IRQ0 + self.spec.irqs {
            self.pending |= bit(e);
        }
    }

    /// Asserts or releases the line of IRQ `n` (level); an asserted line pends its
    /// interrupt unless it is active (it pends again on return if still asserted).
    pub fn set_line(&mut self, n: u32, asserted: bool) {
        let e = exc::IRQ0 + n;
        if asserted {
            self.lines |= bit(e);
            if !self.active.contains(&e) {
                self.pending |= bit(e);
            }
        } else {
            self.lines &= !bit(e);
        }
    }

    /// Exception entry: `e` becomes active and stops pending. Returns the vector address.
    pub fn activate(&mut self, e: u32) -> u32 {
        self.pending &= !bit(e);
        self.active.push(e);
        self.taken[e as usize] += 1;
        self.vtor + 4 * e
    }

    /// Exception return of the innermost active exception: returns it. An interrupt whose
    /// line is still asserted pends again.
    pub fn deactivate(&mut self) -> Option<u32> {
        let e = self.active.pop()?;
        if self.lines & bit(e) != 0 {
            self.pending |= bit(e);
        }
        Some(e)
    }

    /// The innermost active exception (IPSR), 0 in thread mode.
    pub fn current(&self) -> u32 {
        self.active.last().copied().unwrap_or(0)
    }

    /// Nesting depth.
    pub fn depth(&self) -> usize {
        self.active.len()
    }

    /// Whether WFI/sleep goes to deep sleep (SCR.SLEEPDEEP: not modelled beyond sleep).
    pub fn sleep_deep(&self) -> bool {
        self.scr & 4 != 0
    }

    fn word_of(bits: u128, first_irq: u32) -> u32 {
        (bits >> (exc::IRQ0 + first_irq)) as u32
    }

    fn mask_irqs(&self, word_index: u32, value: u32) -> u128 {
        let shift = exc::IRQ0 + 32 * word_index;
        let valid = if self.spec.irqs > 32 * word_index {
            let n = (self.spec.irqs - 32 * word_index).min(32);
            if n == 32 {
                u32::MAX
            } else {
                (1 << n) - 1
            }
        } else {
            0
        };
        u128::from(value & valid).checked_shl(shift).unwrap_or(0)
    }

    /// A read of the SCS at `offset` from 0xE000_E000 (`cycle`: CPU cycles for SysTick).
    pub fn read(&mut self, offset: u32, cycle: u64) -> u32 {
        let nvic_word = |base: u32| (offset - base) / 4;
        match offset {
            0x004 => (self.spec.irqs - 1) / 32, // ICTR
            0x010..=0x01F => self.systick.read(offset, cycle),
            0x100..=0x11F => Self::word_of(self.enabled, 32 * nvic_word(0x100)),
            0x180..=0x19F => Self::word_of(self.enabled, 32 * nvic_word(0x180)),
            0x200..=0x21F => Self::word_of(self.pending, 32 * nvic_word(0x200)),
            0x280..=0x29F => Self::word_of(self.pending, 32 * nvic_word(0x280)),
            0x300..=0x31F => {
                let active = self.active.iter().fold(0u128, |a, &e| a | bit(e));
                Self::word_of(active, 32 * nvic_word(0x300))
            }
            0x400..=0x4EF => {
                let first = offset - 0x400;
                (0..4).fold(0, |v, i| {
                    let e = exc::IRQ0 + first + i;
                    let p = if e < exc::IRQ0 + self.spec.irqs {
                        self.prio[e as usize]
                    } else {
                        0
                    };
                    v | u32::from(p) << (8 * i)
                })
            }
            0xD00 => self.spec.cpuid,
            0xD04 => self.icsr(),
            0xD08 => self.vtor,
            0xD0C => 0xFA05_0000 | self.prigroup << 8,
            0xD10 => self.scr,
            0xD14 => self.ccr,
            0xD18..=0xD23 => {
                let first = 4 + offset - 0xD18;
                (0..4).fold(0, |v, i| {
                    v | u32::from(self.prio[(first + i) as usize]) << (8 * i)
                })
            }
            _ => 0,
        }
    }

    fn icsr(&self) -> u32 {
        let vectactive = self.current();
        let vectpending = self.highest_pending().unwrap_or(0);
        let isrpending = (self.pending >> exc::IRQ0) != 0;
        let rettobase = self.active.len() <= 1;
        let mut v = vectactive | vectpending << 12;
        if isrpending {
            v |= 1 << 22;
        }
        if rettobase && !self.active.is_empty() {
            v |= 1 << 11;
        }
        if self.pending & bit(exc::PENDSV) != 0 {
            v |= 1 << 28;
        }
        if self.pending & bit(exc::SYSTICK) != 0 {
            v |= 1 << 26;
        }
        v
    }

    /// A write of `value` (`size` bytes) at `offset`.
    pub fn write(&mut self, offset: u32, size: usize, value: u32, cycle: u64) -> ScsEffect {
        let mut effect = ScsEffect::default();
        let nvic_word = |base: u32| (offset - base) / 4;
        match offset {
            0x010..=0x01F => self.systick.write(offset, value, cycle),
            0x100..=0x11F => self.enabled |= self.mask_irqs(nvic_word(0x100), value),
            0x180..=0x19F => self.enabled &= !self.mask_irqs(nvic_word(0x180), value),
            0x200..=0x21F => self.pending |= self.mask_irqs(nvic_word(0x200), value),
            0x280..=0x29F => self.pending &= !self.mask_irqs(nvic_word(0x280), value),
            0x400..=0x4EF => {
                for i in 0..size as u32 {
                    let e = exc::IRQ0 + offset - 0x400 + i;
                    if e < exc::IRQ0 + self.spec.irqs {
                        self.prio[e as usize] = (value >> (8 * i)) as u8 & self.spec.prio_mask;
                    }
                }
            }
            0xD04 => {
                if value & (1 << 31) != 0 {
                    self.pending |= bit(exc::NMI);
                }
                if value & (1 << 28) != 0 {
                    self.pending |= bit(exc::PENDSV);
                }
                if value & (1 << 27) != 0 {
                    self.pending &= !bit(exc::PENDSV);
                }
                if value & (1 << 26) != 0 {
                    self.pending |= bit(exc::SYSTICK);
                }
                if value & (1 << 25) != 0 {
                    self.pending &= !bit(exc::SYSTICK);
                }
            }
            // TBLOFF bits 29:7 (UM10360 34.4.3.5: the table in code or SRAM).
            0xD08 => self.vtor = value & 0x3FFF_FF80,
            0xD0C => {
                if value >> 16 == 0x05FA {
                    self.prigroup = (value >> 8) & 7;
                    if value & (1 << 2) != 0 {
                        effect.reset_request = true;
                    }
                }
            }
            0xD10 => self.scr = value & 0x16,
            0xD14 => self.ccr = value & 0x31B,
            0xD18..=0xD23 => {
                for i in 0..size as u32 {
                    let e = 4 + offset - 0xD18 + i;
                    self.prio[e as usize] = (value >> (8 * i)) as u8 & self.spec.prio_mask;
                }
            }
            0xF00 => self.set_pending(exc::IRQ0 + (value & 0x1FF).min(self.spec.irqs - 1)),
            _ => self.unmodelled.push((offset, value)),
        }
        effect
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rtic_like() -> Scs {
        let mut s = Scs::new();
        // TIMER1 prio 3, EINT3 prio 2, SysTick prio 1 (RTIC: (32 - p) << 3).
        s.write(0x400 + irq::TIMER0 + 1, 1, 29 << 3, 0);
        s.write(0x400 + irq::EINT3, 1, 30 << 3, 0);
        s.write(0xD18 + 11, 1, 31 << 3, 0);
        s.write(0x100, 4, (1 << (irq::TIMER0 + 1)) | (1 << irq::EINT3), 0);
        s
    }

    #[test]
    fn priorities_preemption_and_masks() {
        let mut s = rtic_like();
        let t1 = exc::IRQ0 + 2;
        let eint3 = exc::IRQ0 + irq::EINT3;
        assert_eq!(s.priority(t1), 0xE8);
        // 3 bits below the 5 implemented ones read as zero.
        s.write(0x400 + 5, 1, 0xFF, 0);
        assert_eq!(s.read(0x404, 0) >> 8 & 0xFF, 0xF8);
        s.set_pending(eint3);
        assert_eq!(s.preempting(false, 0, false), Some(eint3));
        assert_eq!(s.preempting(true, 0, false), None, "PRIMASK masks");
        assert_eq!(
            s.preempting(false, 0xF0, false),
            None,
            "BASEPRI 0xF0 masks 0xF0"
        );
        assert!(s.wakes_from_wfi(0, false), "WFI wakes with PRIMASK set");
        assert_eq!(s.activate(eint3), 4 * eint3);
        // A higher priority one preempts the active handler; the same level does not.
        s.set_pending(t1);
        assert_eq!(s.preempting(false, 0, false), Some(t1));
        s.activate(t1);
        s.set_pending(exc::SYSTICK);
        assert_eq!(s.preempting(false, 0, false), None);
        assert_eq!(s.deactivate(), Some(t1));
        assert_eq!(s.deactivate(), Some(eint3));
        assert_eq!(s.preempting(false, 0, false), Some(exc::SYSTICK));
        // Disabled interrupts never preempt.
        s.write(0x180, 4, 1 << irq::EINT3, 0);
        s.set_pending(eint3);
        assert_eq!(s.highest_pending(), Some(exc::SYSTICK));
    }

    #[test]
    fn level_lines_pend_again_after_return() {
        let mut s = rtic_like();
        let eint3 = exc::IRQ0 + irq::EINT3;
        s.set_line(irq::EINT3, true);
        s.activate(eint3);
        assert_eq!(s.highest_pending(), None);
        s.deactivate();
        assert_eq!(s.highest_pending(), Some(eint3), "still asserted");
        s.activate(eint3);
        s.set_line(irq::EINT3, false);
        s.deactivate();
        assert_eq!(s.highest_pending(), None);
    }

    #[test]
    fn systick_counts_cpu_cycles() {
        let mut s = Scs::new();
        s.write(0x14, 4, 99_999, 0);
        s.write(0x18, 4, 0, 0);
        s.write(0x10, 4, 0b111, 1000);
        assert_eq!(s.systick.next_wrap(), Some(101_000));
        assert_eq!(s.read(0x18, 51_000), 50_000);
        s.systick.wrap(101_000);
        assert_eq!(s.systick.next_wrap(), Some(201_000));
        assert_eq!(s.read(0x10, 0) >> 16 & 1, 1, "COUNTFLAG");
        assert_eq!(s.read(0x10, 0) >> 16 & 1, 0, "cleared by the read");
    }

    #[test]
    fn sysresetreq_needs_the_key_and_stir_pends() {
        let mut s = Scs::new();
        assert!(!s.write(0xD0C, 4, 1 << 2, 0).reset_request);
        assert!(s.write(0xD0C, 4, 0x05FA_0004, 0).reset_request);
        s.write(0x100, 4, 1 << irq::DMA, 0);
        s.write(0xF00, 4, irq::DMA, 0);
        assert_eq!(s.highest_pending(), Some(exc::IRQ0 + irq::DMA));
        assert_eq!(s.read(0xD04, 0) >> 12 & 0x1FF, exc::IRQ0 + irq::DMA);
    }
}
