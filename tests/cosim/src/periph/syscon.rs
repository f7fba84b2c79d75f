//! System control (UM10360 chapter 3 and 4, base 0x400F_C000): flash accelerator timing,
//! PLL0 with its feed sequence and lock, CPU clock divider, clock source, peripheral power
//! (PCONP) and peripheral clocks (PCLKSEL), DMA request select, the main oscillator.
//!
//! Strict where the manual is: PLL0CON/PLL0CFG take effect only after the feed sequence
//! 0xAA, 0x55 on consecutive APB writes; connecting PLL0 before PLOCK0 or outside the FCCO
//! range 275..550 MHz, a CCLK above the part's 100 MHz, too few flash wait states for the
//! clock, and PCLKSEL changes while PLL0 is connected (UM10360 4.7.3 note) are reported.

use super::{Peripheral, Tick};

/// Internal RC oscillator.
pub const IRC_HZ: u64 = 4_000_000;
/// The board's crystal.
pub const XTAL_HZ: u64 = 12_000_000;
/// The LPC1754's maximum CPU clock.
pub const CCLK_MAX_HZ: u64 = 100_000_000;

/// Timing this model assumes where UM10360 gives no number (UNCONFIRMED; here only so the
/// firmware's bounded waits see a plausible delay).
pub mod unconfirmed {
    /// Main oscillator start-up until SCS.OSCSTAT (crystal dependent; ~1 ms).
    pub const OSC_START_NS: u64 = 1_000_000;
    /// PLL0 enable until PLOCK0.
    pub const PLL_LOCK_NS: u64 = 100_000;
}

/// PCONP at reset (UM10360 table 46): TIM0/1, UART0/1, PWM1, I2C0, SPI, RTC, SSP1, GPIO,
/// I2C1, SSP0, I2C2 powered.
pub const PCONP_RESET: u32 = 0x0428_87DE;

/// Peripherals the co-simulator models, with their PCONP bit and PCLKSEL field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clocked {
    /// Watchdog (clocked from its own WDCLKSEL source, PCLKSEL0 1:0 for PCLK).
    Wdt,
    /// Timer 0..3.
    Timer(u8),
    /// Legacy SPI.
    Spi,
    /// SSP0.
    Ssp0,
    /// SSP1.
    Ssp1,
    /// GPIO (FIO and the GPIO interrupts).
    Gpio,
    /// General purpose DMA.
    Gpdma,
    /// CAN1.
    Can1,
    /// CAN2 (not used; its PCLK must equal CAN1's).
    Can2,
    /// PWM1 (the AD5663's LDAC in the oversampling output path).
    Pwm1,
    /// The CAN acceptance filter (no power bit of its own; its PCLK must equal CAN1's).
    CanAcf,
}

impl Clocked {
    /// PCONP bit (None: always powered).
    pub fn pconp_bit(self) -> Option<u32> {
        Some(match self {
            Clocked::Wdt | Clocked::CanAcf => return None,
            Clocked::Timer(0) => 1,
            Clocked::Timer(1) => 2,
            Clocked::Timer(2) => 22,
            Clocked::Timer(_) => 23,
            Clocked::Spi => 8,
            Clocked::Ssp1 => 10,
            Clocked::Gpio => 15,
            Clocked::Ssp0 => 21,
            Clocked::Gpdma => 29,
            Clocked::Can1 => 13,
            Clocked::Can2 => 14,
            Clocked::Pwm1 => 6,
        })
    }

    /// (PCLKSEL register 0/1, bit position) of the PCLK divider (None: CCLK).
    fn pclksel(self) -> Option<(usize, u32)> {
        Some(match self {
            Clocked::Wdt => (0, 0),
            Clocked::Timer(0) => (0, 2),
            Clocked::Timer(1) => (0, 4),
            Clocked::Spi => (0, 16),
            Clocked::Ssp1 => (0, 20),
            Clocked::Ssp0 => (1, 10),
            Clocked::Timer(2) => (1, 12),
            Clocked::Timer(_) => (1, 14),
            Clocked::Can1 => (0, 26),
            Clocked::Can2 => (0, 28),
            Clocked::CanAcf => (0, 30),
            Clocked::Pwm1 => (0, 12),
            Clocked::Gpio | Clocked::Gpdma => return None,
        })
    }

    /// Name as UM10360 writes it.
    pub fn name(self) -> String {
        match self {
            Clocked::Wdt => "WDT".into(),
            Clocked::Timer(n) => format!("TIMER{n}"),
            Clocked::Spi => "SPI".into(),
            Clocked::Ssp0 => "SSP0".into(),
            Clocked::Ssp1 => "SSP1".into(),
            Clocked::Gpio => "GPIO".into(),
            Clocked::Gpdma => "GPDMA".into(),
            Clocked::Can1 => "CAN1".into(),
            Clocked::Can2 => "CAN2".into(),
            Clocked::CanAcf => "CAN acceptance filter".into(),
            Clocked::Pwm1 => "PWM1".into(),
        }
    }
}

const PLLE: u32 = 1 << 24;
const PLLC: u32 = 1 << 25;
const PLOCK: u32 = 1 << 26;

/// SYSCON state.
#[derive(Clone, Debug)]
pub struct Syscon {
    flashcfg: u32,
    pll0con_shadow: u32,
    pll0cfg_shadow: u32,
    pll0con: u32,
    pll0cfg: u32,
    feed_aa: bool,
    lock_at_ns: Option<u64>,
    cclkcfg: u32,
    clksrcsel: u32,
    scs: u32,
    osc_ready_at_ns: Option<u64>,
    pclksel: [u32; 2],
    pconp: u32,
    dmareqsel: u32,
    rsid: u32,
    other: Vec<(u32, u32)>,
    /// Rule violations seen (message per kind, once).
    pub violations: Vec<String>,
    /// Whether CCLK changed since the last [`Syscon::take_clock_change`].
    clock_changed: bool,
}

impl Syscon {
    /// The reset state (`pconp`: PCONP after reset, [`PCONP_RESET`] from a power-on).
    pub fn new(pconp: u32, rsid: u32) -> Self {
        Self {
            flashcfg: 0x303A,
            pll0con_shadow: 0,
            pll0cfg_shadow: 0,
            pll0con: 0,
            pll0cfg: 0,
            feed_aa: false,
            lock_at_ns: None,
            cclkcfg: 0,
            clksrcsel: 0,
            scs: 0,
            osc_ready_at_ns: None,
            pclksel: [0, 0],
            pconp,
            dmareqsel: 0,
            rsid,
            other: Vec::new(),
            violations: Vec::new(),
            clock_changed: false,
        }
    }

    fn violation(&mut self, msg: String) {
        if !self.violations.contains(&msg) {
            self.violations.push(msg);
        }
    }

    fn locked(&self, now: u64) -> bool {
        self.lock_at_ns.is_some_and(|t| now >= t)
    }

    fn osc_ready(&self, now: u64) -> bool {
        self.osc_ready_at_ns.is_some_and(|t| now >= t)
    }

    /// PLL0's input clock (CLKSRCSEL).
    fn pll_in_hz(&self) -> u64 {
        match self.clksrcsel & 3 {
            1 => XTAL_HZ,
            2 => 32_768,
            _ => IRC_HZ,
        }
    }

    /// FCCO of the committed PLL0CFG.
    pub fn fcco_hz(&self) -> u64 {
        let m = u64::from(self.pll0cfg & 0x7FFF) + 1;
        let n = u64::from((self.pll0cfg >> 16) & 0xFF) + 1;
        2 * m * self.pll_in_hz() / n
    }

    /// Whether PLL0 drives CCLK (enabled, connected).
    pub fn pll_connected(&self) -> bool {
        self.pll0con & 3 == 3
    }

    /// The CPU clock.
    pub fn cclk_hz(&self) -> u64 {
        let div = u64::from(self.cclkcfg & 0xFF) + 1;
        if self.pll_connected() {
            self.fcco_hz() / div
        } else {
            self.pll_in_hz() / div
        }
    }

    /// PCLK of a peripheral.
    pub fn pclk_hz(&self, p: Clocked) -> u64 {
        let cclk = self.cclk_hz();
        match p.pclksel() {
            None => cclk,
            Some((reg, shift)) => match (self.pclksel[reg] >> shift) & 3 {
                0 => cclk / 4,
                1 => cclk,
                2 => cclk / 2,
                // 11 selects CCLK / 6 for CAN1, CAN2 and the acceptance filter.
                _ if matches!(p, Clocked::Can1 | Clocked::Can2 | Clocked::CanAcf) => cclk / 6,
                _ => cclk / 8,
            },
        }
    }

    /// Whether a peripheral has power (PCONP).
    pub fn powered(&self, p: Clocked) -> bool {
        p.pconp_bit().is_none_or(|b| self.pconp & (1 << b) != 0)
    }

    /// DMAREQSEL (0x400F_C1C4): bit n gives request line 8 + n to timer match n.
    pub fn dmareqsel(&self) -> u32 {
        self.dmareqsel
    }

    /// True once after every change of CCLK.
    pub fn take_clock_change(&mut self) -> bool {
        std::mem::take(&mut self.clock_changed)
    }

    /// FLASHTIM (clocks per flash access - 1) needed for `cclk` (UM10360 table 58).
    fn flashtim_needed(cclk: u64) -> u32 {
        match cclk {
            0..=20_000_000 => 0,
            20_000_001..=40_000_000 => 1,
            40_000_001..=60_000_000 => 2,
            60_000_001..=80_000_000 => 3,
            _ => 4,
        }
    }

    fn check_clock(&mut self) {
        let cclk = self.cclk_hz();
        if cclk > CCLK_MAX_HZ {
            self.violation(format!(
                "CCLK {cclk} Hz exceeds the LPC1754's 100 MHz (PLL0CFG {:#x}, CCLKCFG {})",
                self.pll0cfg, self.cclkcfg
            ));
        }
        let flashtim = (self.flashcfg >> 12) & 0xF;
        if flashtim < Self::flashtim_needed(cclk) {
            self.violation(format!(
                "FLASHCFG FLASHTIM {flashtim} is too fast for CCLK {cclk} Hz (needs {})",
                Self::flashtim_needed(cclk)
            ));
        }
    }

    fn feed(&mut self, now: u64) {
        let was_connected = self.pll_connected();
        let old_cclk = self.cclk_hz();
        let enable = self.pll0con_shadow & 1 != 0;
        let connect = self.pll0con_shadow & 2 != 0;
        if self.pll0cfg_shadow != self.pll0cfg {
            if self.pll0con & 1 != 0 {
                self.violation(
                    "PLL0CFG changed while PLL0 is enabled (UM10360 4.5.13: disable it first)"
                        .into(),
                );
            }
            self.pll0cfg = self.pll0cfg_shadow;
            self.lock_at_ns = None;
        }
        if enable && self.pll0con & 1 == 0 {
            self.lock_at_ns = Some(now + unconfirmed::PLL_LOCK_NS);
            let f = self.fcco_hz();
            if !(275_000_000..=550_000_000).contains(&f) {
                self.violation(format!(
                    "PLL0 enabled with FCCO {f} Hz outside 275..550 MHz (PLL0CFG {:#x})",
                    self.pll0cfg
                ));
            }
        }
        if !enable {
            self.lock_at_ns = None;
        }
        if connect && enable && !was_connected && !self.locked(now) {
            self.violation("PLL0 connected before PLOCK0 (UM10360 4.5.13)".into());
        }
        if connect && !enable {
            self.violation("PLL0 connect requested while disabled (ignored)".into());
        }
        self.pll0con = self.pll0con_shadow & if enable { 3 } else { 0 };
        if self.pll_connected() != was_connected || self.cclk_hz() != old_cclk {
            self.clock_changed = true;
        }
        self.check_clock();
    }

    /// PCLKSEL0/1 (reported, for the PCLKSEL-with-PLL0-connected rule).
    pub fn pclksel(&self) -> [u32; 2] {
        self.pclksel
    }
}

impl Peripheral for Syscon {
    fn read(&mut self, t: Tick, offset: u32) -> u32 {
        let now = t.now_ns;
        match offset {
            0x000 => self.flashcfg,
            0x080 => self.pll0con_shadow,
            0x084 => self.pll0cfg_shadow,
            0x088 => {
                let mut v = self.pll0cfg & 0x00FF_7FFF;
                if self.pll0con & 1 != 0 {
                    v |= PLLE;
                }
                if self.pll0con & 2 != 0 {
                    v |= PLLC;
                }
                if self.pll0con & 1 != 0 && self.locked(now) {
                    v |= PLOCK;
                }
                v
            }
            0x0C4 => self.pconp,
            0x104 => self.cclkcfg,
            0x10C => self.clksrcsel,
            0x180 => self.rsid,
            0x1A0 => {
                let mut v = self.scs;
                if self.scs & (1 << 5) != 0 && self.osc_ready(now) {
                    v |= 1 << 6;
                }
                v
            }
            0x1A8 => self.pclksel[0],
            0x1AC => self.pclksel[1],
            0x1C4 => self.dmareqsel,
            _ => self
                .other
                .iter()
                .find(|(o, _)| *o == offset)
                .map_or(0, |(_, v)| *v),
        }
    }

    fn write(&mut self, t: Tick, offset: u32, value: u32) {
        let now = t.now_ns;
        // The feed sequence is two consecutive writes to PLL0FEED.
        if offset != 0x08C {
            self.feed_aa = false;
        }
        match offset {
            0x000 => {
                self.flashcfg = value;
                self.check_clock();
            }
            0x080 => self.pll0con_shadow = value & 3,
            0x084 => self.pll0cfg_shadow = value & 0x00FF_7FFF,
            0x08C => match value & 0xFF {
                0xAA => self.feed_aa = true,
                0x55 if self.feed_aa => {
                    self.feed_aa = false;
                    self.feed(now);
                }
                _ => self.feed_aa = false,
            },
            0x0C4 => self.pconp = value,
            0x104 => {
                let old = self.cclk_hz();
                self.cclkcfg = value & 0xFF;
                if self.cclk_hz() != old {
                    self.clock_changed = true;
                }
                self.check_clock();
            }
            0x10C => {
                if self.pll_connected() {
                    self.violation("CLKSRCSEL changed while PLL0 is connected".into());
                }
                let old = self.cclk_hz();
                self.clksrcsel = value & 3;
                if value & 3 == 1 && !self.osc_ready(now) {
                    self.violation(
                        "CLKSRCSEL selects the main oscillator before SCS.OSCSTAT".into(),
                    );
                }
                if self.cclk_hz() != old {
                    self.clock_changed = true;
                }
            }
            0x180 => self.rsid &= !value,
            0x1A0 => {
                if value & (1 << 5) != 0 && self.osc_ready_at_ns.is_none() {
                    self.osc_ready_at_ns = Some(now + unconfirmed::OSC_START_NS);
                }
                self.scs = value & 0x30;
            }
            0x1A8 | 0x1AC => {
                if self.pll_connected() {
                    self.violation(
                        "PCLKSEL written while PLL0 is connected (UM10360 4.7.3 note)".into(),
                    );
                }
                self.pclksel[((offset - 0x1A8) / 4) as usize] = value;
            }
            0x1C4 => self.dmareqsel = value & 0xFF,
            _ => match self.other.iter_mut().find(|(o, _)| *o == offset) {
                Some(slot) => slot.1 = value,
                None => self.other.push((offset, value)),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(now_ns: u64) -> Tick {
        Tick { now_ns, pclk_hz: 0 }
    }

    fn feed(s: &mut Syscon, now: u64) {
        s.write(t(now), 0x8C, 0xAA);
        s.write(t(now), 0x8C, 0x55);
    }

    /// The firmware's sequence (hw::clocks, UM10360 4.5.13) reaches 100 MHz without a
    /// reported rule.
    #[test]
    fn pll0_setup_sequence() {
        let mut s = Syscon::new(PCONP_RESET, 1);
        assert_eq!(s.cclk_hz(), IRC_HZ);
        s.write(t(0), 0x000, 0x503A);
        s.write(t(0), 0x1A0, 1 << 5);
        assert_eq!(s.read(t(10), 0x1A0) & (1 << 6), 0);
        assert_ne!(s.read(t(2_000_000), 0x1A0) & (1 << 6), 0);
        s.write(t(2_000_000), 0x10C, 1);
        s.write(t(2_000_000), 0x084, (5 << 16) | 99);
        assert_eq!(
            s.read(t(0), 0x088) & 0x7FFF,
            0,
            "not committed without the feed"
        );
        feed(&mut s, 2_000_000);
        s.write(t(2_000_000), 0x080, 1);
        // A broken feed commits nothing.
        s.write(t(2_000_000), 0x8C, 0xAA);
        s.write(t(2_000_000), 0x104, 3);
        s.write(t(2_000_000), 0x8C, 0x55);
        assert_eq!(s.read(t(2_000_000), 0x088) & PLLE, 0);
        feed(&mut s, 2_000_000);
        assert_ne!(s.read(t(2_000_000), 0x088) & PLLE, 0);
        assert_eq!(s.read(t(2_000_000), 0x088) & PLOCK, 0);
        assert_ne!(s.read(t(2_200_000), 0x088) & PLOCK, 0);
        s.write(t(2_200_000), 0x080, 3);
        feed(&mut s, 2_200_000);
        assert!(s.take_clock_change());
        assert_eq!(s.cclk_hz(), 100_000_000);
        s.write(t(2_200_000), 0x000, 0x403A);
        assert!(s.violations.is_empty(), "{:?}", s.violations);
    }

    #[test]
    fn rule_violations_are_reported() {
        let mut s = Syscon::new(PCONP_RESET, 1);
        s.write(t(0), 0x084, (5 << 16) | 99); // 400 MHz from the IRC: FCCO 133 MHz
        feed(&mut s, 0);
        s.write(t(0), 0x080, 1);
        feed(&mut s, 0);
        s.write(t(0), 0x080, 3);
        feed(&mut s, 0);
        let all = s.violations.join("\n");
        assert!(all.contains("outside 275..550 MHz"), "{all}");
        assert!(all.contains("before PLOCK0"), "{all}");
        assert!(all.contains("FLASHTIM"), "{all}");
    }

    #[test]
    fn power_and_peripheral_clocks() {
        let mut s = Syscon::new(PCONP_RESET, 1);
        assert!(s.powered(Clocked::Ssp1) && !s.powered(Clocked::Timer(2)));
        s.write(t(0), 0x0C4, PCONP_RESET & !(1 << 10));
        assert!(!s.powered(Clocked::Ssp1));
        s.write(t(0), 0x1A8, 0b01 << 16);
        assert_eq!(s.pclk_hz(Clocked::Spi), IRC_HZ);
        assert_eq!(s.pclk_hz(Clocked::Ssp1), IRC_HZ / 4);
    }
}
