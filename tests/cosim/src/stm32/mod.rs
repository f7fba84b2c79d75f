//! The STM32F103VC's peripherals that the `analog-io-stm32` image uses, one model each, after
//! RM0008 (STM32F101/102/103/105/107 reference manual) and PM0056 (Cortex-M3 programming
//! manual): what the firmware touches and how the board depends on it. The board wiring (which
//! pin reaches which chip of the virtual board) is the machine's (`machine/stm32.rs`).
//!
//! | module    | what                                                                   |
//! |-----------|------------------------------------------------------------------------|
//! | [`rcc`]   | clock tree (HSI, HSE, PLL, prescalers), ready flags, clock enables, CSR |
//! | [`flash`] | FLASH_ACR wait states and prefetch, checked against SYSCLK             |
//! | [`gpio`]  | GPIOA..E (CRL/CRH, IDR/ODR/BSRR/BRR) and AFIO (EXTICR)                 |
//! | [`exti`]  | EXTI lines 0..18: edge detection, mask, pending                        |
//! | [`tim`]   | TIM3 and TIM8: counter, compare/PWM, input capture, forced outputs, DMA requests |
//! | [`spi`]   | SPI1/SPI2 master: frame time, TXE/RXNE/BSY/OVR, DMA requests            |
//! | [`dma`]   | DMA1's 7 channels: priorities, circular mode, half/complete flags        |
//! | [`iwdg`]  | the independent watchdog on the LSI                                    |
//! | [`fsmc`]  | FSMC bank 1 (BCR/BTR) and its accesses on the ESC's µC front end        |
//! | [`dwt`]   | DWT_CYCCNT and DEMCR.TRCENA                                            |
//! | [`sram`]  | the 48 KB SRAM, shared by the core and DMA1                            |

pub mod dma;
pub mod dwt;
pub mod exti;
pub mod flash;
pub mod fsmc;
pub mod gpio;
pub mod iwdg;
pub mod rcc;
pub mod spi;
pub mod sram;
pub mod tim;

use crate::cpu::{Engine, Shared};
use crate::image::Image;
use crate::nvic::NvicSpec;
use unicorn_engine::{Prot, Unicorn};

/// Values this model rests on that no primary source at hand confirmed (RM0008 and the
/// datasheet were recalled, not read): one place, to check against the documents or a chip.
pub mod unconfirmed {
    use crate::chip::Cpi;

    /// Cycles per instruction at 72 MHz with 2 flash wait states behind the prefetch buffer
    /// (two 64-bit lines: straight-line code runs at about one instruction per cycle, a
    /// taken branch refills the line for 2 more cycles). The LPC1754's 5/4 is kept, so the
    /// two boards' figures differ by their clocks and peripherals, not by the time model.
    pub const CPI: Cpi = Cpi { num: 5, den: 4 };
    /// HSE start-up (datasheet tSU(HSE), 8 MHz crystal: typically 2 ms).
    pub const HSE_STARTUP_NS: u64 = 2_000_000;
    /// PLL lock time (datasheet tLOCK: at most 200 us).
    pub const PLL_LOCK_NS: u64 = 200_000;
    /// The LSI the IWDG counts (datasheet: 30..60 kHz, 40 kHz typical).
    pub const LSI_HZ: u64 = 40_000;
    /// CPUID of the STM32F1's Cortex-M3 (r1p1; STKALIGN is then 0 at reset).
    pub const CPUID: u32 = 0x411F_C231;
    /// SYST_CALIB (PM0056: 9000, 1 ms at HCLK/8 = 9 MHz).
    pub const SYST_CALIB: u32 = 9_000;
    /// The FSMC's phases in the multiplexed PSRAM/NOR mode without extended mode: address
    /// (ADDSET + ADDHLD) HCLK, data DATAST HCLK, then BUSTURN HCLK; RM0008's figures add 1 or 2
    /// HCLK to some phases, which this model leaves out (as the board plan does).
    pub const FSMC_EXTRA_HCLK: u32 = 0;
    /// An EXTI edge sets the pending bit whether or not the line is unmasked (RM0008 figure
    /// "external interrupt/event controller block diagram" read so).
    pub const EXTI_PENDS_WHEN_MASKED: bool = true;
}

/// The STM32F103's NVIC: 60 interrupts (RM0008 table 63, connectivity lines aside), 4
/// priority bits (PM0056 4.3.7), r1p1 ([`unconfirmed::CPUID`]).
pub const NVIC: NvicSpec = NvicSpec {
    irqs: 60,
    prio_mask: 0xF0,
    syst_calib: unconfirmed::SYST_CALIB,
    cpuid: unconfirmed::CPUID,
    ccr_reset: 0,
};

/// Interrupt numbers (RM0008 table 63).
pub mod irq {
    /// EXTI line 0.
    pub const EXTI0: u32 = 6;
    /// DMA1 channel 1 (channel n is `DMA1_CHANNEL1 + n - 1`).
    pub const DMA1_CHANNEL1: u32 = 11;
    /// TIM3.
    pub const TIM3: u32 = 29;
    /// SPI1.
    pub const SPI1: u32 = 35;
    /// SPI2.
    pub const SPI2: u32 = 36;
    /// TIM8 capture/compare.
    pub const TIM8_CC: u32 = 46;
}

/// Peripheral base addresses (RM0008 table 3).
pub mod base {
    /// TIM3 (APB1).
    pub const TIM3: u32 = 0x4000_0400;
    /// IWDG (APB1).
    pub const IWDG: u32 = 0x4000_3000;
    /// SPI2 (APB1).
    pub const SPI2: u32 = 0x4000_3800;
    /// AFIO (APB2).
    pub const AFIO: u32 = 0x4001_0000;
    /// EXTI (APB2).
    pub const EXTI: u32 = 0x4001_0400;
    /// GPIOA (APB2); B..E follow every 0x400.
    pub const GPIOA: u32 = 0x4001_0800;
    /// SPI1 (APB2).
    pub const SPI1: u32 = 0x4001_3000;
    /// TIM8 (APB2).
    pub const TIM8: u32 = 0x4001_3400;
    /// DMA1 (AHB).
    pub const DMA1: u32 = 0x4002_0000;
    /// RCC (AHB).
    pub const RCC: u32 = 0x4002_1000;
    /// The flash interface (AHB).
    pub const FLASH: u32 = 0x4002_2000;
    /// The peripheral space the machine decodes (APB1, APB2, AHB up to the flash interface).
    pub const PERIPHERALS: (u32, u32) = (0x4000_0000, 0x2_4000);
    /// FSMC bank 1, NOR/PSRAM 1 (NE1): the ESC's 64 KB.
    pub const FSMC_BANK1: (u32, u32) = (0x6000_0000, 0x1_0000);
    /// FSMC registers.
    pub const FSMC_REGS: u32 = 0xA000_0000;
    /// DWT.
    pub const DWT: u32 = 0xE000_1000;
    /// SCS (NVIC, SCB, SysTick).
    pub const SCS: u32 = 0xE000_E000;
}

/// The chip's peripherals (the core and the NVIC are the machine's).
pub struct Stm32f103 {
    /// RCC.
    pub rcc: rcc::Rcc,
    /// FLASH_ACR.
    pub flash: flash::FlashAcr,
    /// GPIOA..E and AFIO.
    pub gpio: gpio::Gpio,
    /// EXTI.
    pub exti: exti::Exti,
    /// TIM3: the AD7689's CNV and frame requests.
    pub tim3: tim::Tim,
    /// TIM8: SYNC0's capture and LDAC.
    pub tim8: tim::Tim,
    /// SPI1: the AD7689.
    pub spi1: spi::Spi,
    /// SPI2: the AD5663.
    pub spi2: spi::Spi,
    /// DMA1.
    pub dma1: dma::Dma,
    /// IWDG.
    pub iwdg: iwdg::Iwdg,
    /// FSMC.
    pub fsmc: fsmc::Fsmc,
    /// DWT cycle counter.
    pub dwt: dwt::Dwt,
    /// The SRAM (also the engine's).
    pub sram: sram::Sram,
}

impl Stm32f103 {
    /// The chip at power-on, its SRAM `sram`.
    pub fn new(sram: sram::Sram) -> Self {
        Self::after_reset(sram, rcc::ResetFlags::POWER_ON)
    }

    /// Every peripheral at its reset state, the reset flags `flags` in RCC_CSR.
    pub fn after_reset(sram: sram::Sram, flags: u32) -> Self {
        Self {
            rcc: rcc::Rcc::new(flags),
            flash: flash::FlashAcr::new(),
            gpio: gpio::Gpio::new(),
            exti: exti::Exti::new(),
            tim3: tim::Tim::new(false),
            tim8: tim::Tim::new(true),
            spi1: spi::Spi::new(),
            spi2: spi::Spi::new(),
            dma1: dma::Dma::new(),
            iwdg: iwdg::Iwdg::new(),
            fsmc: fsmc::Fsmc::new(),
            dwt: dwt::Dwt::new(),
            sram,
        }
    }
}

/// The STM32F103's memory in the engine: flash at 0x0800_0000 and its alias at 0, the SRAM
/// (shared with the machine for DMA1), and the machine's regions: peripherals, FSMC bank 1,
/// FSMC registers, DWT, SCS. Anything else is unmapped and stops the core.
pub fn map_memory(uc: &mut Engine, image: &Image, machine: &Shared) -> Result<(), String> {
    fn err(what: &'static str) -> impl Fn(unicorn_engine::uc_error) -> String {
        move |e| format!("unicorn: {what}: {e:?}")
    }
    let flash = image.chip.flash();
    for at in [flash.start, 0] {
        uc.mem_map(u64::from(at), u64::from(flash.len), Prot::READ | Prot::EXEC)
            .map_err(err("flash"))?;
        uc.mem_write(u64::from(at), &image.flash)
            .map_err(err("flash contents"))?;
    }
    let sram = machine
        .borrow()
        .stm32()
        .map(|s| s.chip.sram.clone())
        .ok_or("the machine is not an STM32F103")?;
    sram.map(uc)?;
    let regions = [
        base::PERIPHERALS,
        base::FSMC_BANK1,
        (base::FSMC_REGS, 0x1000),
        (base::DWT, 0x1000),
        (base::SCS, 0x1000),
    ];
    for (start, len) in regions {
        uc.mmio_map(
            u64::from(start),
            u64::from(len),
            Some(move |uc: &mut Unicorn<'_, Shared>, off: u64, size: usize| {
                let m = uc.get_data().clone();
                let v = m.borrow_mut().cpu_read(start + off as u32, size);
                u64::from(v)
            }),
            Some(
                move |uc: &mut Unicorn<'_, Shared>, off: u64, size: usize, v: u64| {
                    let m = uc.get_data().clone();
                    m.borrow_mut().cpu_write(start + off as u32, size, v as u32);
                },
            ),
        )
        .map_err(err("peripheral map"))?;
    }
    Ok(())
}
