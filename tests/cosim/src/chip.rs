//! Which microcontroller the co-simulator is: its memory map, its NVIC and its time model.
//! The core ([`crate::cpu`]), the exception model ([`crate::nvic`]), time and profile are
//! shared ([`crate::machine::Cortex`]); the peripherals and their wiring are the chip's
//! ([`crate::machine::lpc17xx`] on [`crate::periph`] for the LPC1754,
//! [`crate::machine::stm32`] on [`crate::stm32`] for the STM32F103). A chip is told by where
//! its image is linked.

use crate::nvic::NvicSpec;

/// A co-simulated microcontroller.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Chip {
    /// NXP LPC1754 (UM10360): the thesis board.
    #[default]
    Lpc1754,
    /// ST STM32F103VC (RM0008, high density): seed 004's board, the ET1100 on the FSMC.
    Stm32f103,
}

/// A region of memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    /// First address.
    pub start: u32,
    /// Bytes.
    pub len: u32,
}

impl Span {
    /// Whether `[addr, addr + n)` lies inside.
    pub fn contains(&self, addr: u32, n: u32) -> bool {
        addr >= self.start && u64::from(addr) + u64::from(n) <= self.end()
    }

    /// One past the last address.
    pub fn end(&self) -> u64 {
        u64::from(self.start) + u64::from(self.len)
    }
}

/// Cycles per instruction of a chip's time model, `num / den`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cpi {
    /// Numerator.
    pub num: u64,
    /// Denominator.
    pub den: u64,
}

impl Chip {
    /// The chip of a board's microcontroller.
    pub fn of(mcu: firmware::platform::board::Mcu) -> Chip {
        match mcu {
            firmware::platform::board::Mcu::Lpc1754 => Chip::Lpc1754,
            firmware::platform::board::Mcu::Stm32f103vc => Chip::Stm32f103,
        }
    }

    /// The chip whose flash holds a program loaded at `addr`.
    pub fn of_load_address(addr: u32) -> Option<Chip> {
        [Chip::Lpc1754, Chip::Stm32f103]
            .into_iter()
            .find(|c| c.flash().contains(addr, 1))
    }

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Chip::Lpc1754 => "LPC1754",
            Chip::Stm32f103 => "STM32F103VC",
        }
    }

    /// The core clock the boards run (the LPC1754's PLL0 at 100 MHz, the STM32's HSE x 9).
    pub fn clock_hz(self) -> u64 {
        match self {
            Chip::Lpc1754 => 100_000_000,
            Chip::Stm32f103 => 72_000_000,
        }
    }

    /// The on-chip flash (the STM32's is also seen at 0 when it boots from the main flash,
    /// BOOT0 low: RM0008 3.4).
    pub fn flash(self) -> Span {
        match self {
            Chip::Lpc1754 => Span {
                start: 0,
                len: 128 * 1024,
            },
            Chip::Stm32f103 => Span {
                start: 0x0800_0000,
                len: 256 * 1024,
            },
        }
    }

    /// The SRAM the core's stack and statics are in (the LPC1754's local SRAM; its AHB SRAM
    /// is the machine's, [`crate::ahb_sram`]).
    pub fn sram(self) -> Span {
        match self {
            Chip::Lpc1754 => Span {
                start: 0x1000_0000,
                len: 0x4000,
            },
            Chip::Stm32f103 => Span {
                start: 0x2000_0000,
                len: 48 * 1024,
            },
        }
    }

    /// The NVIC's size and priority bits, SYST_CALIB, CPUID.
    pub fn nvic(self) -> NvicSpec {
        match self {
            Chip::Lpc1754 => NvicSpec::LPC1754,
            Chip::Stm32f103 => crate::stm32::NVIC,
        }
    }

    /// The time model's cycles per instruction.
    pub fn cpi(self) -> Cpi {
        match self {
            Chip::Lpc1754 => Cpi {
                num: crate::machine::CPI_NUM,
                den: crate::machine::CPI_DEN,
            },
            Chip::Stm32f103 => crate::stm32::unconfirmed::CPI,
        }
    }
}
