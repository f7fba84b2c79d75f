//! The ESC's PDI on the STM32 board, as the SII's words 0/1 load it: the 16-bit asynchronous
//! µC interface (0x0140 = 0x08), BUSY and IRQ push-pull active low, BHE and RD active low,
//! SYNC0 push-pull active high into a timer capture, SYNC1 a LATCH input (ESC datasheet
//! Section II 0x0140/0x0141/0x0150/0x0151; `research/stm32-fsmc.md` §2: w0 0x0E08, w1
//! 0x0600).

use crate::platform::board::PDI as LPC_BOARD;
use coe_core::device::{PdiConfig, PdiInterface, PinDriver};

/// BUSY's driver: push-pull active low, so the FSMC's NWAIT polarity (WAITPOL 0) follows.
pub const BUSY: PinDriver = PinDriver::PushPullActiveLow;

/// The board's PDI: BUSY push-pull active low (the FSMC's NWAIT), IRQ push-pull active low
/// (an EXTI falling edge); link detection, the DC units, the SYNC/LATCH pins and the SYNC
/// pulse as on the LPC1754 board (SYNC0 push-pull active high into a rising-edge capture,
/// here TIM8_CH1; SYNC1 a LATCH input).
pub const PDI: PdiConfig = PdiConfig {
    interface: PdiInterface::AsyncUc16 {
        busy: BUSY,
        bhe_active_high: false,
        rd_active_high: false,
    },
    irq: PinDriver::PushPullActiveLow,
    ..LPC_BOARD
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
        assert_eq!(PDI.sync_pulse_10ns, spi.sync_pulse_10ns);
    }
}
