//! RCC (RM0008 section 7.3): the clock tree from the 8 MHz HSI or the board's 8 MHz HSE
//! through the PLL, the AHB/APB prescalers, the ready flags (after the start-up and lock
//! times of [`super::unconfirmed`]), the switch of SYSCLK, the peripherals' clock enables and
//! the reset flags in CSR. Rule violations (SYSCLK or PCLK1 above their limits) are reported.

use super::unconfirmed::{HSE_STARTUP_NS, PLL_LOCK_NS};
use crate::periph::Tick;

/// The HSI (RM0008 7.2.2).
pub const HSI_HZ: u64 = 8_000_000;
/// The board's crystal.
pub const HSE_HZ: u64 = 8_000_000;

const CR: u32 = 0x00;
const CFGR: u32 = 0x04;
const CIR: u32 = 0x08;
const APB2RSTR: u32 = 0x0C;
const APB1RSTR: u32 = 0x10;
const AHBENR: u32 = 0x14;
const APB2ENR: u32 = 0x18;
const APB1ENR: u32 = 0x1C;
const BDCR: u32 = 0x20;
const CSR: u32 = 0x24;

const HSION: u32 = 1 << 0;
const HSIRDY: u32 = 1 << 1;
const HSEON: u32 = 1 << 16;
const HSERDY: u32 = 1 << 17;
const PLLON: u32 = 1 << 24;
const PLLRDY: u32 = 1 << 25;
const LSION: u32 = 1 << 0;
const LSIRDY: u32 = 1 << 1;
const RMVF: u32 = 1 << 24;

/// RCC_CSR's reset flags.
pub struct ResetFlags;

impl ResetFlags {
    /// Power-on: PORRSTF and PINRSTF.
    pub const POWER_ON: u32 = 1 << 27 | 1 << 26;
    /// The IWDG: IWDGRSTF (and the NRST pin the reset drives).
    pub const IWDG: u32 = 1 << 29 | 1 << 26;
    /// SYSRESETREQ: SFTRSTF (and the pin).
    pub const SOFTWARE: u32 = 1 << 28 | 1 << 26;
}

/// A clock a peripheral needs, by its enable bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Enable {
    /// RCC_AHBENR bit.
    Ahb(u8),
    /// RCC_APB2ENR bit.
    Apb2(u8),
    /// RCC_APB1ENR bit.
    Apb1(u8),
}

impl Enable {
    /// The register and bit, for reports.
    pub fn name(self) -> String {
        match self {
            Enable::Ahb(b) => format!("RCC_AHBENR bit {b}"),
            Enable::Apb2(b) => format!("RCC_APB2ENR bit {b}"),
            Enable::Apb1(b) => format!("RCC_APB1ENR bit {b}"),
        }
    }
}

/// The RCC.
#[derive(Clone, Debug)]
pub struct Rcc {
    cr: u32,
    cfgr: u32,
    ahbenr: u32,
    apb2enr: u32,
    apb1enr: u32,
    csr: u32,
    hse_ready_at: Option<u64>,
    pll_ready_at: Option<u64>,
    /// SYSCLK's source now (SWS): 0 HSI, 1 HSE, 2 PLL.
    sws: u32,
    clock_changed: bool,
    /// Rule violations since the machine last asked.
    pub violations: Vec<String>,
}

impl Rcc {
    /// The reset state with `flags` in CSR.
    pub fn new(flags: u32) -> Self {
        Self {
            cr: 0x0000_0083 | HSIRDY,
            cfgr: 0,
            ahbenr: 0x14,
            apb2enr: 0,
            apb1enr: 0,
            csr: flags,
            hse_ready_at: None,
            pll_ready_at: None,
            sws: 0,
            clock_changed: false,
            violations: Vec::new(),
        }
    }

    fn hse_ready(&self, now: u64) -> bool {
        self.hse_ready_at.is_some_and(|t| now >= t)
    }

    fn pll_ready(&self, now: u64) -> bool {
        self.pll_ready_at.is_some_and(|t| now >= t)
    }

    /// The PLL's input (PLLSRC: HSI/2 or HSE, PLLXTPRE: HSE/2).
    fn pll_in_hz(&self) -> u64 {
        if self.cfgr & 1 << 16 == 0 {
            HSI_HZ / 2
        } else if self.cfgr & 1 << 17 != 0 {
            HSE_HZ / 2
        } else {
            HSE_HZ
        }
    }

    fn pll_hz(&self) -> u64 {
        let mul = u64::from((self.cfgr >> 18) & 0xF) + 2;
        self.pll_in_hz() * mul.min(16)
    }

    /// SYSCLK.
    pub fn sysclk_hz(&self) -> u64 {
        match self.sws {
            1 => HSE_HZ,
            2 => self.pll_hz(),
            _ => HSI_HZ,
        }
    }

    /// HCLK (the core, AHB, DMA, FSMC; SysTick with CLKSOURCE = 1).
    pub fn hclk_hz(&self) -> u64 {
        let hpre = (self.cfgr >> 4) & 0xF;
        let div = if hpre < 8 {
            1
        } else {
            [2, 4, 8, 16, 64, 128, 256, 512][(hpre - 8) as usize]
        };
        self.sysclk_hz() / div
    }

    fn apb_div(bits: u32) -> u64 {
        if bits < 4 {
            1
        } else {
            2 << (bits - 4)
        }
    }

    /// PCLK1 (APB1).
    pub fn pclk1_hz(&self) -> u64 {
        self.hclk_hz() / Self::apb_div((self.cfgr >> 8) & 7)
    }

    /// PCLK2 (APB2).
    pub fn pclk2_hz(&self) -> u64 {
        self.hclk_hz() / Self::apb_div((self.cfgr >> 11) & 7)
    }

    /// The timers' clock on APB1 (x2 when the APB1 prescaler is not 1).
    pub fn apb1_timer_hz(&self) -> u64 {
        let d = Self::apb_div((self.cfgr >> 8) & 7);
        self.pclk1_hz() * if d == 1 { 1 } else { 2 }
    }

    /// The timers' clock on APB2.
    pub fn apb2_timer_hz(&self) -> u64 {
        let d = Self::apb_div((self.cfgr >> 11) & 7);
        self.pclk2_hz() * if d == 1 { 1 } else { 2 }
    }

    /// Whether `e` is enabled.
    pub fn enabled(&self, e: Enable) -> bool {
        match e {
            Enable::Ahb(b) => self.ahbenr & 1 << b != 0,
            Enable::Apb2(b) => self.apb2enr & 1 << b != 0,
            Enable::Apb1(b) => self.apb1enr & 1 << b != 0,
        }
    }

    /// Whether SYSCLK changed since the last call.
    pub fn take_clock_change(&mut self) -> bool {
        std::mem::take(&mut self.clock_changed)
    }

    /// Starts the LSI (the IWDG does when it starts).
    pub fn start_lsi(&mut self) {
        self.csr |= LSION | LSIRDY;
    }

    fn try_switch(&mut self, now: u64) {
        let sw = self.cfgr & 3;
        let ready = match sw {
            0 => true,
            1 => self.hse_ready(now),
            2 => self.pll_ready(now),
            _ => false,
        };
        if ready && sw != self.sws {
            self.sws = sw;
            self.clock_changed = true;
            if self.sysclk_hz() > 72_000_000 {
                self.violations.push(format!(
                    "SYSCLK {} Hz is above the STM32F103's 72 MHz",
                    self.sysclk_hz()
                ));
            }
        }
        if self.pclk1_hz() > 36_000_000 {
            self.violations.push(format!(
                "PCLK1 {} Hz is above APB1's 36 MHz (RM0008 7.2)",
                self.pclk1_hz()
            ));
        }
    }

    /// A register read.
    pub fn read(&mut self, t: Tick, offset: u32) -> u32 {
        let now = t.now_ns;
        self.try_switch(now);
        match offset {
            CR => {
                let mut v = self.cr & !(HSERDY | PLLRDY);
                if self.hse_ready(now) {
                    v |= HSERDY;
                }
                if self.pll_ready(now) {
                    v |= PLLRDY;
                }
                v
            }
            CFGR => (self.cfgr & !(3 << 2)) | self.sws << 2,
            AHBENR => self.ahbenr,
            APB2ENR => self.apb2enr,
            APB1ENR => self.apb1enr,
            CSR => self.csr,
            _ => 0,
        }
    }

    /// A register write.
    pub fn write(&mut self, t: Tick, offset: u32, value: u32) {
        let now = t.now_ns;
        match offset {
            CR => {
                let was = self.cr;
                self.cr = value & (HSION | 0xF8 | HSEON | 1 << 18 | 1 << 19 | PLLON) | HSIRDY;
                if value & HSEON != 0 && was & HSEON == 0 {
                    self.hse_ready_at = Some(now + HSE_STARTUP_NS);
                } else if value & HSEON == 0 {
                    self.hse_ready_at = None;
                }
                if value & PLLON != 0 && was & PLLON == 0 {
                    if self.cfgr & 1 << 16 != 0 && self.hse_ready_at.is_none() {
                        self.violations
                            .push("PLL on with the HSE as its source while the HSE is off".into());
                    }
                    let from = self.hse_ready_at.unwrap_or(now).max(now);
                    self.pll_ready_at = Some(from + PLL_LOCK_NS);
                } else if value & PLLON == 0 {
                    if self.sws == 2 {
                        self.violations
                            .push("PLL off while it is SYSCLK (RM0008: not allowed)".into());
                    }
                    self.pll_ready_at = None;
                }
            }
            CFGR => {
                let pll_bits = 0xF << 18 | 3 << 16;
                if self.pll_ready_at.is_some() && (value ^ self.cfgr) & pll_bits != 0 {
                    self.violations.push(
                        "PLLMUL/PLLSRC/PLLXTPRE written with the PLL on (RM0008: only while it is \
                         off)"
                            .into(),
                    );
                }
                self.cfgr = value & !(3 << 2);
                let mul = u64::from((self.cfgr >> 18) & 0xF) + 2;
                if self.pll_in_hz() * mul.min(16) > 72_000_000 && self.cfgr & 3 == 2 {
                    self.violations.push(format!(
                        "PLL output {} Hz is above 72 MHz",
                        self.pll_in_hz() * mul.min(16)
                    ));
                }
            }
            CIR | APB2RSTR | APB1RSTR | BDCR => {}
            AHBENR => self.ahbenr = value & 0x557,
            APB2ENR => self.apb2enr = value & 0xFFFD,
            APB1ENR => self.apb1enr = value & 0x3AFE_C9FF,
            CSR => {
                if value & RMVF != 0 {
                    self.csr &= 0x00FF_FFFF;
                }
                self.csr = (self.csr & !LSION) | (value & LSION);
                if value & LSION != 0 {
                    self.csr |= LSIRDY;
                }
            }
            _ => {}
        }
        self.try_switch(now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(now_ns: u64) -> Tick {
        Tick { now_ns, pclk_hz: 0 }
    }

    #[test]
    fn hse_pll_and_the_switch_to_72_mhz_as_the_board_does_it() {
        let mut r = Rcc::new(ResetFlags::POWER_ON);
        assert_eq!(r.hclk_hz(), HSI_HZ);
        let cr = r.read(t(0), CR);
        r.write(t(0), CR, cr | HSEON);
        assert_eq!(r.read(t(1_000), CR) & HSERDY, 0, "not yet started");
        assert_ne!(r.read(t(HSE_STARTUP_NS), CR) & HSERDY, 0);
        // HSE x9, APB1 /2 (the board's RCC_CFGR before the switch).
        r.write(t(HSE_STARTUP_NS), CFGR, 0x001D_0400);
        let cr = r.read(t(HSE_STARTUP_NS), CR);
        r.write(t(HSE_STARTUP_NS), CR, cr | PLLON);
        let locked = HSE_STARTUP_NS + PLL_LOCK_NS;
        assert_eq!(r.read(t(locked - 1), CR) & PLLRDY, 0);
        assert_ne!(r.read(t(locked), CR) & PLLRDY, 0);
        r.write(t(locked), CFGR, 0x001D_0402);
        assert_eq!(r.read(t(locked), CFGR) >> 2 & 3, 2, "SWS = PLL");
        assert!(r.take_clock_change());
        assert_eq!(r.hclk_hz(), 72_000_000);
        assert_eq!(r.pclk1_hz(), 36_000_000);
        assert_eq!(r.apb1_timer_hz(), 72_000_000);
        assert_eq!(r.apb2_timer_hz(), 72_000_000);
        assert!(r.violations.is_empty(), "{:?}", r.violations);
    }

    #[test]
    fn the_switch_waits_for_the_pll_and_apb1_above_36_mhz_is_reported() {
        let mut r = Rcc::new(ResetFlags::POWER_ON);
        r.write(t(0), CFGR, 0x001D_0002);
        assert_eq!(r.read(t(0), CFGR) >> 2 & 3, 0, "PLL not ready: still HSI");
        r.write(t(0), CR, HSEON | PLLON);
        r.read(t(HSE_STARTUP_NS + PLL_LOCK_NS), CFGR);
        assert_eq!(r.hclk_hz(), 72_000_000);
        assert!(
            r.violations.iter().any(|v| v.contains("PCLK1")),
            "{:?}",
            r.violations
        );
    }
}
