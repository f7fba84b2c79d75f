//! The figures that turn counts into time: the board's clocks and the Cortex-M3's exception
//! timing (hardware-facts sections 7 and 8). Assumptions that no measurement here can
//! confirm are marked UNCONFIRMED and live only in this file.

/// CPU clock of the LPC1754 (CCLK).
pub const CPU_HZ: f64 = 100e6;

/// Cycles per instruction at 100 MHz. UNCONFIRMED (no board): the LPC17xx runs from flash
/// with 5 wait states behind the flash accelerator's 128-bit prefetch lines; straight Thumb-2
/// code runs near 1 cycle per instruction, taken branches and literal loads cost refills, and
/// loads/stores take 2 cycles. 1.25 is a middle estimate; the instruction counts are exact.
pub const CPI: f64 = 1.25;

/// SPI clock of the ET1100 PDI on the legacy SPI (PCLK / 8, its fastest setting).
pub const ESC_SPI_HZ: f64 = 12.5e6;

/// Time between two bytes beyond their 8 clocks on the FIFO-less legacy SPI (write DR, poll
/// SPIF, read DR). UNCONFIRMED: hardware-facts 8 estimates 0.1-0.2 us; the lower end is used.
pub const SPI_BYTE_GAP_US: f64 = 0.1;

/// SPI_SEL high time and chip-select handling per transaction. UNCONFIRMED for the ET1100
/// (its SPI timing table was not found); Beckhoff's SSC keeps about 250 ns between accesses.
pub const SPI_SELECT_GAP_US: f64 = 0.25;

/// Cortex-M3 exception entry (12 cycles, ARM Cortex-M3 TRM "exception entry and exit") and
/// exit (10 cycles, without tail-chaining).
pub const EXCEPTION_ENTRY_CYCLES: f64 = 12.0;
/// Exception exit.
pub const EXCEPTION_EXIT_CYCLES: f64 = 10.0;

/// AD5663 on SSP0: 25 MHz, 24-bit frames (hardware-facts 8).
pub const DAC_SPI_HZ: f64 = 25e6;
/// Bits of one AD5663 frame.
pub const DAC_FRAME_BITS: f64 = 24.0;

/// AD7689 aggregate rate of the scan (one CNV every 4 us).
pub const ADC_RATE_SPS: f64 = 250e3;

/// Peripheral register accesses of the sampler interrupt that QEMU cannot run (the
/// lm3s6965 has no LPC17xx timers/SSP): IR and EMR writes, SSP SR and DR reads for the result,
/// SR read for the drain, SR read and DR write for the next frame = 7 APB accesses of about
/// 3 cycles each. UNCONFIRMED (estimate from the code in firmware/src/platform/hw/timers.rs).
pub const SAMPLER_ISR_REGISTER_CYCLES: f64 = 7.0 * 3.0;

/// GPDMA path: the RX channel's destination-address register read in each position
/// computation (an AHB register; two per drain). UNCONFIRMED: ~3 cycles each, including
/// arbitration with the DMA's own transfers.
pub const DMA_POSITION_REGISTER_CYCLES: f64 = 3.0;

/// GPDMA path: the terminal-count interrupt's register accesses (IntTCStat read, IntTCClear
/// write, IntErrStat read; firmware/src/platform/hw/adc_dma.rs), ~3 cycles each. UNCONFIRMED.
pub const DMA_IRQ_REGISTER_CYCLES: f64 = 3.0 * 3.0;

/// Channels per AD7689 scan (one whole scan per drain step on the GPDMA path).
pub const ADC_SCAN_WORDS: f64 = firmware::platform::board::AI_CHANNELS as f64;

/// Words per half ring of the GPDMA path (one terminal-count interrupt each).
pub const ADC_DMA_HALF_WORDS: f64 = firmware::io::analog::adc_dma::HALF_WORDS as f64;

/// Microseconds of `instructions` at [`CPI`] and [`CPU_HZ`].
pub fn cpu_us(instructions: f64) -> f64 {
    instructions * CPI / CPU_HZ * 1e6
}

/// Microseconds of `cycles` at [`CPU_HZ`].
pub fn cycles_us(cycles: f64) -> f64 {
    cycles / CPU_HZ * 1e6
}

/// Microseconds of `bytes` in `transactions` on the ESC's SPI.
pub fn spi_us(bytes: f64, transactions: f64) -> f64 {
    bytes * (8.0 / ESC_SPI_HZ * 1e6 + SPI_BYTE_GAP_US) + transactions * SPI_SELECT_GAP_US
}

/// Microseconds of `bytes` on the ESC's SPI clock alone (no gaps).
pub fn spi_wire_us(bytes: f64) -> f64 {
    bytes * 8.0 / ESC_SPI_HZ * 1e6
}

/// Microseconds of `frames` AD5663 frames on SSP0.
pub fn dac_us(frames: f64) -> f64 {
    frames * DAC_FRAME_BITS / DAC_SPI_HZ * 1e6
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions() {
        // hardware-facts 8: 25 bytes at 12.5 MHz = 16 us on the wire.
        assert!((spi_wire_us(25.0) - 16.0).abs() < 1e-9);
        assert!((spi_us(25.0, 2.0) - (16.0 + 2.5 + 0.5)).abs() < 1e-9);
        // AD5663: one 24-bit frame at 25 MHz = 0.96 us.
        assert!((dac_us(1.0) - 0.96).abs() < 1e-9);
        assert!((cpu_us(100.0) - 1.25).abs() < 1e-9);
        assert!((cycles_us(100.0) - 1.0).abs() < 1e-9);
    }
}
