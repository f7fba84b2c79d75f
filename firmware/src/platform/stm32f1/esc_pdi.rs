//! The ESC's PDI on the STM32 board, as the SII's words 0/1 load it: the 16-bit asynchronous
//! µC interface (0x0140 = 0x08), BUSY and IRQ push-pull active low, BHE and RD active low,
//! SYNC0 push-pull active high into a timer capture, SYNC1 a LATCH input (ESC datasheet
//! Section II 0x0140/0x0141/0x0150/0x0151; `research/stm32-fsmc.md` §2: w0 0x0E08, w1
//! 0x0600).
//!
//! `coe_core::device::PdiConfig` describes the SPI PDI only; the product on this board (a
//! later part) needs it to describe this one too.

use crate::platform::board::PDI as LPC_BOARD;
use coe_core::device::{PinDriver, SyncPin};

/// PDI type code of the 16-bit asynchronous µC interface (register 0x0140).
pub const PDI_ASYNC_16BIT: u8 = 0x08;

/// The µC PDI's configuration (registers 0x0140/0x0141, 0x0150/0x0151).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UcPdi {
    /// 0x0141 b1: enhanced link detection.
    pub enhanced_link_detect: bool,
    /// 0x0141 b2: DC SYNC output unit.
    pub dc_sync_unit: bool,
    /// 0x0141 b3: DC latch input unit.
    pub dc_latch_unit: bool,
    /// BUSY driver and polarity (0x0150 b1:0): the FSMC's NWAIT polarity follows it.
    pub busy: PinDriver,
    /// IRQ driver and polarity (0x0150 b3:2).
    pub irq: PinDriver,
    /// BHE active high (0x0150 b4).
    pub bhe_active_high: bool,
    /// RD active high (0x0150 b7).
    pub rd_active_high: bool,
    /// SYNC0/LATCH0 (0x0151 b3:0).
    pub sync0: SyncPin,
    /// SYNC1/LATCH1 (0x0151 b7:4).
    pub sync1: SyncPin,
}

impl UcPdi {
    /// SII word 0: 0x0140 and 0x0141 (device emulation off: the µC writes AL status).
    pub const fn word0(&self) -> u16 {
        let esc_config = (self.enhanced_link_detect as u8) << 1
            | (self.dc_sync_unit as u8) << 2
            | (self.dc_latch_unit as u8) << 3;
        u16::from_le_bytes([PDI_ASYNC_16BIT, esc_config])
    }

    /// SII word 1: 0x0150 and 0x0151.
    pub const fn word1(&self) -> u16 {
        let pdi = self.busy.code()
            | self.irq.code() << 2
            | (self.bhe_active_high as u8) << 4
            | (self.rd_active_high as u8) << 7;
        u16::from_le_bytes([pdi, self.sync0.nibble() | self.sync1.nibble() << 4])
    }
}

/// The board's PDI: BUSY push-pull active low (the FSMC's NWAIT, WAITPOL 0), IRQ push-pull
/// active low (an EXTI falling edge); link detection, the DC units and the SYNC/LATCH pins
/// as on the LPC1754 board (SYNC0 push-pull active high into a rising-edge capture, here
/// TIM8_CH1; SYNC1 a LATCH input).
pub const PDI: UcPdi = UcPdi {
    enhanced_link_detect: LPC_BOARD.enhanced_link_detect,
    dc_sync_unit: LPC_BOARD.dc_sync_unit,
    dc_latch_unit: LPC_BOARD.dc_latch_unit,
    busy: PinDriver::PushPullActiveLow,
    irq: PinDriver::PushPullActiveLow,
    bhe_active_high: false,
    rd_active_high: false,
    sync0: LPC_BOARD.sync0,
    sync1: LPC_BOARD.sync1,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sii_words_of_the_research_note() {
        assert_eq!(PDI.word0(), 0x0E08);
        assert_eq!(PDI.word1(), 0x0600);
    }

    #[test]
    fn the_sync_byte_is_the_spi_boards() {
        // Only the PDI bytes differ from the LPC1754 board (0x0E05 / 0x0603).
        let spi = LPC_BOARD;
        assert_eq!(PDI.word0() >> 8, spi.word0() >> 8);
        assert_eq!(PDI.word1() >> 8, spi.word1() >> 8);
    }

    #[test]
    fn polarity_bits() {
        let p = UcPdi {
            busy: PinDriver::OpenSourceActiveHigh,
            irq: PinDriver::OpenDrainActiveLow,
            bhe_active_high: true,
            rd_active_high: true,
            ..PDI
        };
        assert_eq!(p.word1() & 0xFF, 0b1001_0111);
    }
}
