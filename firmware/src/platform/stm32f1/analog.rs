//! The analog front end's timing and register plan on the STM32 board, host-tested: the
//! AD7689 sampled by TIM3 and DMA (no CPU per sample), the AD5663's SPI port.
//!
//! AD7689 (SPI1, DMA1): TIM3 counts at the APB1 timer clock. Its update raises CNV
//! (TIM3_CH3, PWM mode 1: high from the update to [`CNV_FALL`]), which starts a conversion;
//! CNV falls after the longest conversion time, and at [`FRAME_START`] the TIM3_CH4
//! compare requests DMA1 channel 3, which writes the next DIN word into SPI1_DR: the 16-bit
//! frame reads the result (read after conversion). SPI1's RX request moves the result into
//! the sample ring (DMA1 channel 2, circular, half and full interrupts counting halves as the
//! LPC1754's terminal counts do: `crate::io::analog::adc_dma`).
//!
//! Request map (RM0008 Table 78, DMA1 requests per channel): channel 2 SPI1_RX (and
//! TIM3_CH3, whose request stays off), channel 3 SPI1_TX and TIM3_CH4 (SPI1's TX request
//! stays off: the timer paces the frames).

use super::clocks::{ClockPlan, CLOCKS};
use crate::platform::chip::adc_dma::RING_WORDS;
use ad7689::unconfirmed::T_CONV_MAX_NS;

/// The sample period (ns): one AD7689 conversion and frame; a scan of 8 inputs takes 40 us.
/// Longer than the LPC1754's 4 us: SPI1 runs at 9 MHz here (72 MHz / 8; /4 would exceed the
/// AD7689's 16.7 MHz), so a frame takes 1.8 us after the 2.2 us conversion.
pub const SAMPLE_PERIOD_NS: u32 = 5_000;

/// TIM3's clock (Hz): the APB1 timer clock.
pub const TIM3_HZ: u32 = CLOCKS.apb1_timer_hz();

/// Timer ticks (rounded up) of `ns`.
pub const fn ticks(ns: u32) -> u32 {
    ((ns as u64 * TIM3_HZ as u64).div_ceil(1_000_000_000)) as u32
}

/// Ticks per sample period; TIM3_ARR is one less.
pub const PERIOD_TICKS: u32 = ticks(SAMPLE_PERIOD_NS);
/// CNV high from the update to here (TIM3_CCR3): the longest conversion plus 100 ns.
pub const CNV_FALL: u32 = ticks(T_CONV_MAX_NS + 100);
/// The frame's DMA request (TIM3_CCR4): two ticks after CNV fell.
pub const FRAME_START: u32 = CNV_FALL + 2;

/// SPI1's baud-rate field and clock for the AD7689 (at most 16.7 MHz).
pub const ADC_SPI: (u32, u32) = ClockPlan::spi_baud(CLOCKS.pclk2_hz, 16_700_000);
/// SPI2's baud-rate field and clock for the AD5663 (at most 50 MHz).
pub const DAC_SPI: (u32, u32) = ClockPlan::spi_baud(CLOCKS.pclk1_hz, 50_000_000);

/// Ticks of one 16-bit frame, plus 8 ticks for the DMA's and the SPI's start.
pub const FRAME_TICKS: u32 = (16 * TIM3_HZ).div_ceil(ADC_SPI.1) + 8;

/// SPI_CR1 bits (RM0008 §25.5.1).
pub mod spi_cr1 {
    /// Clock phase: second edge.
    pub const CPHA: u32 = 1 << 0;
    /// Master.
    pub const MSTR: u32 = 1 << 2;
    /// Baud rate field's shift.
    pub const BR_SHIFT: u32 = 3;
    /// SPI enable.
    pub const SPE: u32 = 1 << 6;
    /// Internal slave select (high: stays master).
    pub const SSI: u32 = 1 << 8;
    /// Software slave management.
    pub const SSM: u32 = 1 << 9;
    /// 16-bit frames.
    pub const DFF: u32 = 1 << 11;
}

/// SPI1_CR1 for the AD7689: master, mode 0, 16-bit frames, NSS by software (CNV frames the
/// conversion, the AD7689 has no chip select in this wiring), enabled.
pub const ADC_SPI_CR1: u32 = spi_cr1::MSTR
    | ADC_SPI.0 << spi_cr1::BR_SHIFT
    | spi_cr1::SSI
    | spi_cr1::SSM
    | spi_cr1::DFF
    | spi_cr1::SPE;

/// SPI2_CR1 for the AD5663: master, mode 1 (data taken on SCLK's falling edge), 8-bit
/// frames (a 24-bit command is three), NSS by software (SYNC is a GPIO), enabled.
pub const DAC_SPI_CR1: u32 = spi_cr1::CPHA
    | spi_cr1::MSTR
    | DAC_SPI.0 << spi_cr1::BR_SHIFT
    | spi_cr1::SSI
    | spi_cr1::SSM
    | spi_cr1::SPE;

/// SPI_CR2: RX DMA request enable (SPI1: the results to the ring).
pub const SPI_CR2_RXDMAEN: u32 = 1 << 0;

/// TIM3_CCMR2: CH3 PWM mode 1 with preload (CNV), CH4 frozen output compare (its match
/// only requests the DMA).
pub const TIM3_CCMR2: u32 = 0b110 << 4 | 1 << 3;
/// TIM3_CCER: CH3's output on, active high.
pub const TIM3_CCER: u32 = 1 << 8;
/// TIM3_DIER: CC4DE, the frame's DMA request.
pub const TIM3_DIER: u32 = 1 << 12;

/// DMA_CCRx bits (RM0008 §13.4.3).
pub mod dma_ccr {
    /// Channel enable.
    pub const EN: u32 = 1 << 0;
    /// Transfer-complete interrupt.
    pub const TCIE: u32 = 1 << 1;
    /// Half-transfer interrupt.
    pub const HTIE: u32 = 1 << 2;
    /// Memory to peripheral.
    pub const DIR: u32 = 1 << 4;
    /// Circular.
    pub const CIRC: u32 = 1 << 5;
    /// Memory increment.
    pub const MINC: u32 = 1 << 7;
    /// 16-bit peripheral size.
    pub const PSIZE_16: u32 = 0b01 << 8;
    /// 16-bit memory size.
    pub const MSIZE_16: u32 = 0b01 << 10;
    /// Priority very high.
    pub const PL_VERY_HIGH: u32 = 0b11 << 12;
    /// Priority high.
    pub const PL_HIGH: u32 = 0b10 << 12;
}

/// DMA1 channel 2 (SPI1 RX into the ring): circular over [`RING_WORDS`] halfwords,
/// interrupts at each half, highest priority (a late result would overrun SPI1).
pub const RX_CCR: u32 = dma_ccr::MINC
    | dma_ccr::CIRC
    | dma_ccr::PSIZE_16
    | dma_ccr::MSIZE_16
    | dma_ccr::HTIE
    | dma_ccr::TCIE
    | dma_ccr::PL_VERY_HIGH;

/// DMA1 channel 3 (one DIN word into SPI1_DR at each TIM3_CH4 request): circular over the
/// one word, memory fixed.
pub const TX_CCR: u32 =
    dma_ccr::DIR | dma_ccr::CIRC | dma_ccr::PSIZE_16 | dma_ccr::MSIZE_16 | dma_ccr::PL_HIGH;

/// The ring's length as DMA_CNDTR counts it.
pub const RX_CNDTR: u32 = RING_WORDS as u32;

/// DMA_ISR/IFCR flags of channel `n` (1..=7): global, complete, half, error.
pub const fn dma_flags(n: u32) -> u32 {
    0xF << (4 * (n - 1))
}

/// The RX channel's destination address from its remaining count (CNDTR counts down from
/// the ring's length and reloads in circular mode).
pub const fn rx_destination(ring: u32, cndtr: u32) -> u32 {
    ring + 2 * (RX_CNDTR - cndtr)
}

const _: () = assert!(PERIOD_TICKS - 1 <= 0xFFFF, "TIM3 is a 16-bit timer");
const _: () = assert!(
    FRAME_START + FRAME_TICKS < PERIOD_TICKS,
    "the frame ends before the next CNV"
);
const _: () = assert!(
    PERIOD_TICKS - ticks(T_CONV_MAX_NS) >= ticks(ad7689::unconfirmed::T_ACQ_MIN_NS),
    "the input acquires long enough between the end of a conversion and the next CNV"
);
const _: () = assert!(SAMPLE_PERIOD_NS >= ad7689::unconfirmed::T_CYC_MIN_NS);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_of_a_sample() {
        assert_eq!(TIM3_HZ, 72_000_000);
        assert_eq!(PERIOD_TICKS, 360);
        assert_eq!(CNV_FALL, 166);
        assert_eq!((FRAME_START, FRAME_TICKS), (168, 136));
    }

    #[test]
    fn spi_ports() {
        assert_eq!(ADC_SPI, (2, 9_000_000));
        assert_eq!(DAC_SPI, (0, 18_000_000));
        // SPI1: BR 010, MSTR, SPE, SSI, SSM, DFF; mode 0.
        assert_eq!(ADC_SPI_CR1, 0b1011_0101_0100);
        // SPI2: BR 000, CPHA, MSTR, SPE, SSI, SSM; 8 bits.
        assert_eq!(DAC_SPI_CR1, 0b0011_0100_0101);
    }

    #[test]
    fn dma_channels() {
        assert_eq!(RX_CCR, 0x35A6);
        assert_eq!(TX_CCR, 0x2530);
        assert_eq!(dma_flags(2), 0xF0);
        assert_eq!(dma_flags(3), 0xF00);
        assert_eq!(rx_destination(0x2000_0000, RX_CNDTR), 0x2000_0000);
        assert_eq!(rx_destination(0x2000_0000, 1), 0x2000_0000 + 2 * 1023);
    }
}
