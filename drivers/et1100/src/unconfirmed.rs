//! The one place for hardware facts that are **UNCONFIRMED** (hardware-facts section 1:
//! no primary or second source found; verify on the board).
//!
//! - SPI read command: the ET1100's minimum pause between address and data for command 2
//!   (read without wait state) is unconfirmed (240 ns is a TMC8462 value). This driver therefore
//!   always uses command 3 (read with one 0xFF wait-state byte), which needs no timing at all;
//!   see [`READ_COMMAND`].
//! - Maximum SPI clock and minimum SPI_SEL high time between accesses: unconfirmed for the
//!   ET1100 (20 MHz is often quoted; the EL9800 sample waits ~250 ns between accesses). The
//!   driver does not control them: configure the SPI peripheral (mode 3, see hardware-facts 1.1)
//!   and the `SpiDevice` chip-select timing accordingly.

/// SPI command used for every read (see the module documentation).
// UNCONFIRMED: command 2 would need an ET1100-specific pause; command 3 avoids it.
pub(crate) const READ_COMMAND: u8 = 0b011;
