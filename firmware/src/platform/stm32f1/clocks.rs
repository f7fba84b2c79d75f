//! The clock tree: HSE 8 MHz crystal, PLL x9 = 72 MHz SYSCLK = HCLK, APB1 /2 = 36 MHz, APB2
//! /1 = 72 MHz, and the flash wait states for it (RM0008 §7.3.2 RCC_CFGR, §3.3.3 FLASH_ACR).

/// The board's crystal.
pub const HSE_HZ: u32 = 8_000_000;
/// The PLL multiplier (PLLMUL).
pub const PLL_MUL: u32 = 9;

/// SYSCLK, HCLK and APB2 at most (RM0008).
pub const SYSCLK_MAX_HZ: u32 = 72_000_000;
/// APB1 at most (RM0008).
pub const APB1_MAX_HZ: u32 = 36_000_000;

/// The clocks the board runs at.
pub const CLOCKS: ClockPlan = ClockPlan::hse_pll(HSE_HZ, PLL_MUL);

const _: () = assert!(CLOCKS.sysclk_hz <= SYSCLK_MAX_HZ);
const _: () = assert!(CLOCKS.pclk1_hz <= APB1_MAX_HZ);
const _: () = assert!(PLL_MUL >= 2 && PLL_MUL <= 16);

/// The clock tree from the HSE through the PLL, with HCLK = SYSCLK, APB2 = HCLK and APB1
/// divided down to its limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClockPlan {
    /// PLL multiplier (2..=16).
    pub pll_mul: u32,
    /// SYSCLK = HCLK (AHB prescaler 1): the core, the FSMC, the DMA.
    pub sysclk_hz: u32,
    /// APB1 prescaler (1, 2, 4, 8, 16).
    pub ppre1: u32,
    /// PCLK1: SPI2, TIM2..7 registers.
    pub pclk1_hz: u32,
    /// PCLK2 (APB2 prescaler 1): SPI1, TIM1/TIM8, GPIO, AFIO, EXTI.
    pub pclk2_hz: u32,
    /// Flash wait states (FLASH_ACR LATENCY).
    pub flash_latency: u32,
}

impl ClockPlan {
    /// The plan for `hse_hz` and PLL multiplier `pll_mul`.
    pub const fn hse_pll(hse_hz: u32, pll_mul: u32) -> Self {
        let sysclk_hz = hse_hz.saturating_mul(pll_mul);
        let mut ppre1 = 1;
        while sysclk_hz / ppre1 > APB1_MAX_HZ && ppre1 < 16 {
            ppre1 *= 2;
        }
        // RM0008 FLASH_ACR: 0 wait states up to 24 MHz, 1 up to 48 MHz, 2 above.
        let flash_latency = if sysclk_hz <= 24_000_000 {
            0
        } else if sysclk_hz <= 48_000_000 {
            1
        } else {
            2
        };
        Self {
            pll_mul,
            sysclk_hz,
            ppre1,
            pclk1_hz: sysclk_hz / ppre1,
            pclk2_hz: sysclk_hz,
            flash_latency,
        }
    }

    /// HCLK (AHB prescaler 1).
    pub const fn hclk_hz(&self) -> u32 {
        self.sysclk_hz
    }

    /// The clock of TIM2..7 (APB1 timers): PCLK1, doubled when APB1 is divided.
    pub const fn apb1_timer_hz(&self) -> u32 {
        if self.ppre1 == 1 {
            self.pclk1_hz
        } else {
            self.pclk1_hz * 2
        }
    }

    /// The clock of TIM1/TIM8 (APB2 timers, APB2 prescaler 1).
    pub const fn apb2_timer_hz(&self) -> u32 {
        self.pclk2_hz
    }

    /// RCC_CFGR once the PLL is locked: SW = PLL, HPRE /1, PPRE1, PPRE2 /1, PLLSRC = HSE,
    /// PLLXTPRE /1, PLLMUL; ADCPRE and USBPRE at reset (the internal ADC and USB are unused).
    pub const fn cfgr(&self) -> u32 {
        const SW_PLL: u32 = 0b10;
        const PLLSRC_HSE: u32 = 1 << 16;
        let ppre1 = match self.ppre1 {
            1 => 0b000,
            2 => 0b100,
            4 => 0b101,
            8 => 0b110,
            _ => 0b111,
        };
        let pllmul = (self.pll_mul.saturating_sub(2) & 0xF) << 18;
        SW_PLL | ppre1 << 8 | PLLSRC_HSE | pllmul
    }

    /// RCC_CFGR while the PLL locks: the same prescalers and PLL settings, SW still HSI.
    pub const fn cfgr_before_switch(&self) -> u32 {
        self.cfgr() & !0b11
    }

    /// FLASH_ACR: LATENCY and the prefetch buffer on (PRFTBE, b4; on at reset, kept).
    pub const fn flash_acr(&self) -> u32 {
        const PRFTBE: u32 = 1 << 4;
        self.flash_latency | PRFTBE
    }

    /// The SPI baud-rate field BR (f = PCLK / 2^(BR+1)) for the fastest clock at most
    /// `max_hz` from `pclk_hz`, and that clock; the slowest (BR = 7) if none is slow enough.
    pub const fn spi_baud(pclk_hz: u32, max_hz: u32) -> (u32, u32) {
        let mut br = 0;
        while br < 7 && pclk_hz >> (br + 1) > max_hz {
            br += 1;
        }
        (br, pclk_hz >> (br + 1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hse_8_mhz_times_9_is_72_mhz_with_apb1_halved_and_2_wait_states() {
        assert_eq!(CLOCKS.sysclk_hz, 72_000_000);
        assert_eq!(CLOCKS.hclk_hz(), 72_000_000);
        assert_eq!((CLOCKS.ppre1, CLOCKS.pclk1_hz), (2, 36_000_000));
        assert_eq!(CLOCKS.pclk2_hz, 72_000_000);
        assert_eq!(CLOCKS.apb1_timer_hz(), 72_000_000);
        assert_eq!(CLOCKS.apb2_timer_hz(), 72_000_000);
        assert_eq!(CLOCKS.flash_latency, 2);
    }

    #[test]
    fn register_values() {
        // PLLMUL 0111 (x9) << 18, PLLSRC << 16, PPRE1 100 (/2) << 8, SW 10.
        assert_eq!(CLOCKS.cfgr(), 0x001D_0402);
        assert_eq!(CLOCKS.cfgr_before_switch(), 0x001D_0400);
        assert_eq!(CLOCKS.flash_acr(), 0x12);
    }

    #[test]
    fn slower_plans() {
        let p = ClockPlan::hse_pll(8_000_000, 4);
        assert_eq!((p.sysclk_hz, p.ppre1, p.flash_latency), (32_000_000, 1, 1));
        assert_eq!(p.apb1_timer_hz(), 32_000_000);
        assert_eq!(p.cfgr() >> 18 & 0xF, 0b0010);
        assert_eq!(ClockPlan::hse_pll(8_000_000, 2).flash_latency, 0);
    }

    #[test]
    fn spi_clocks_for_the_converters() {
        // AD7689 at most 16.7 MHz (hardware-facts) on SPI1 (PCLK2 72 MHz): /8 = 9 MHz.
        assert_eq!(ClockPlan::spi_baud(72_000_000, 16_700_000), (2, 9_000_000));
        // AD5663 at most 50 MHz on SPI2 (PCLK1 36 MHz): /2 = 18 MHz.
        assert_eq!(ClockPlan::spi_baud(36_000_000, 50_000_000), (0, 18_000_000));
        assert_eq!(ClockPlan::spi_baud(72_000_000, 1), (7, 281_250));
    }
}
