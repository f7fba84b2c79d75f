//! The boards: what the hardware is, as data. Two designs: the LPC1754 + ET1100 (SPI PDI)
//! board of the thesis with an AD7689 and an AD5663, in two assemblies (with and without the
//! CAN transceiver on CAN1), and the STM32F103VC + ET1100 (FSMC, µC PDI) board with the same
//! analog front end ([`STM32_FSMC`], `crate::platform::stm32f1`); each product names the
//! board it is built for (`crate::products`).
//!
//! A board says who makes it, which design and revision it is and what is fitted
//! ([`Board`]); the bootloader built for a board accepts the update files of every product
//! that runs on it (`crate::platform::boot::header`). The analog front end and the ESC's
//! wiring are the design's, the same in both assemblies.

use coe_core::device::{PdiConfig, PdiInterface, PinDriver, SyncPin};

/// A board as the images and the bootloader know it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Board {
    /// For people (tools, the update file's errors).
    pub name: &'static str,
    /// The ETG vendor ID of the maker: every product on the board carries it.
    pub vendor_id: u32,
    /// The board design: same MCU, memory map and wiring, so the same images run on it.
    pub design: u32,
    /// The design's revision (0x1009 names it).
    pub revision: u32,
    /// The parts fitted that a product may need ([`Options`]).
    pub options: Options,
}

impl Board {
    /// The microcontroller: which image binary, memory map and probe target. It follows
    /// from the design (a design is one MCU, memory map and wiring); a design of a new MCU
    /// adds its line here, every other is the LPC1754's.
    pub const fn mcu(&self) -> Mcu {
        match self.design {
            STM32F103_ANALOG => Mcu::Stm32f103vc,
            _ => Mcu::Lpc1754,
        }
    }
}

/// The microcontroller of a board, as the build and flash tools need it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mcu {
    /// NXP LPC1754 (Cortex-M3, 100 MHz, 128 KB flash): the image is the bootloader plus the
    /// application in its slot (`crate::platform::boot::layout`), updated over FoE.
    Lpc1754,
    /// ST STM32F103VC (Cortex-M3, 72 MHz, 256 KB flash, 48 KB SRAM, LQFP100): the
    /// application alone from the start of the flash; no bootloader, no FoE.
    Stm32f103vc,
}

impl Mcu {
    /// Flash an application image may take at most.
    pub const fn app_flash_max(self) -> u32 {
        match self {
            Mcu::Lpc1754 => crate::platform::boot::layout::APP_BUDGET,
            Mcu::Stm32f103vc => 256 * 1024,
        }
    }

    /// Whether the board's images have the bootloader (and so firmware updates over FoE).
    pub const fn has_bootloader(self) -> bool {
        matches!(self, Mcu::Lpc1754)
    }
}

/// Assembly options of a board: parts a design may or may not carry. A product needs some
/// ([`Options::CAN_TRANSCEIVER`] for CANopen on CAN1); a board has some.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Options(pub u32);

impl Options {
    /// None.
    pub const NONE: Self = Self(0);
    /// A CAN transceiver on CAN1 (P0.0/P0.1).
    pub const CAN_TRANSCEIVER: Self = Self(1 << 0);

    /// True if every option of `needed` is in `self`.
    pub const fn covers(self, needed: Self) -> bool {
        needed.0 & !self.0 == 0
    }
}

/// Vendor ID of the boards and their products.
///
/// PLACEHOLDER: 0 is not an ETG-assigned vendor ID. A product must replace it with the
/// manufacturer's own ID from the EtherCAT Technology Group before it ships (the thesis
/// board borrowed Beckhoff's ID 2; this project must not). This is the only place it is set.
pub const VENDOR_ID: u32 = 0x0000_0000;

/// The design code of the LPC1754 + ET1100 analog board.
pub const LPC1754_ANALOG: u32 = 0x0000_1754;

/// The thesis board: LPC1754 + ET1100 (SPI PDI) + AD5663 + AD7689, revision A, no CAN
/// transceiver.
pub const THESIS: Board = Board {
    name: "LPC1754 + ET1100 analog board rev A",
    vendor_id: VENDOR_ID,
    design: LPC1754_ANALOG,
    revision: 1,
    options: Options::NONE,
};

/// The thesis board with the CAN transceiver fitted on CAN1.
pub const THESIS_CAN: Board = Board {
    name: "LPC1754 + ET1100 analog board rev A with CAN",
    options: Options::CAN_TRANSCEIVER,
    ..THESIS
};

/// The design code of the STM32F103 + ET1100 (FSMC) analog board.
pub const STM32F103_ANALOG: u32 = 0x0000_F103;

/// Seed 004's board: STM32F103VC + ET1100 on the FSMC (16-bit µC PDI, multiplexed with an
/// address latch) + AD5663 + AD7689, revision A, no CAN transceiver.
pub const STM32_FSMC: Board = Board {
    name: "STM32F103VC + ET1100 (FSMC) analog board rev A",
    vendor_id: VENDOR_ID,
    design: STM32F103_ANALOG,
    revision: 1,
    options: Options::NONE,
};

/// Analog inputs (AD7689 channels).
pub const AI_CHANNELS: usize = 8;
/// Analog outputs (AD5663 channels).
pub const AO_CHANNELS: usize = 2;

/// Reference voltage of the AD7689 and the AD5663 (external 2.5 V), in microvolts.
pub const REFERENCE_UV: u32 = 2_500_000;
/// Input divider ratio (terminal voltage / ADC voltage, 1/4 divider) and output gain
/// (terminal / DAC, x4 amplifier).
pub const FRONT_END_GAIN: u32 = 4;
/// Terminal full scale in microvolts (10 V): `REFERENCE_UV * FRONT_END_GAIN`.
pub const FULL_SCALE_UV: u32 = REFERENCE_UV * FRONT_END_GAIN;

/// The ESC's PDI on the board: SPI mode 3, SPI_IRQ push-pull active low (falling-edge GPIO
/// interrupt on P0.22), SYNC0 push-pull active high into the CAP1.0 timer capture, 1 us
/// SYNC pulses (hardware-facts 10.C: SII words 0x0E05 / 0x0603 / 0x0064).
pub const PDI: PdiConfig = PdiConfig {
    interface: PdiInterface::Spi {
        mode: 3,
        sel_active_high: false,
        miso_late_sample: false,
    },
    enhanced_link_detect: true,
    dc_sync_unit: true,
    dc_latch_unit: true,
    irq: PinDriver::PushPullActiveLow,
    sync0: SyncPin {
        driver: PinDriver::PushPullActiveHigh,
        output: true,
        to_al_event: false,
    },
    sync1: SyncPin {
        driver: PinDriver::PushPullActiveLow,
        output: false,
        to_al_event: false,
    },
    sync_pulse_10ns: 100,
    extended: 0,
};

/// Bytes of the SII EEPROM (16 Kbit).
pub const EEPROM_BYTES: u32 = 2048;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_design_has_its_mcu() {
        assert_eq!(THESIS.mcu(), Mcu::Lpc1754);
        assert_eq!(THESIS_CAN.mcu(), Mcu::Lpc1754);
        assert_eq!(STM32_FSMC.mcu(), Mcu::Stm32f103vc);
    }

    #[test]
    fn the_can_assembly_covers_what_the_plain_one_has() {
        assert!(THESIS_CAN.options.covers(Options::CAN_TRANSCEIVER));
        assert!(THESIS_CAN.options.covers(THESIS.options));
        assert!(!THESIS.options.covers(Options::CAN_TRANSCEIVER));
        assert!(THESIS.options.covers(Options::NONE));
        assert_eq!(
            (THESIS.design, THESIS.revision),
            (THESIS_CAN.design, THESIS_CAN.revision)
        );
    }
}
