//! The one place for hardware facts that are **UNCONFIRMED** (hardware-facts section 1:
//! no primary or second source found; verify on the board).
//!
//! - SPI read command: the ET1100's minimum pause between address and data for command 2
//!   (read without wait state) is unconfirmed (240 ns is a TMC8462 value). This driver therefore
//!   always uses command 3 (read with one 0xFF wait-state byte), which needs no timing at all;
//!   see `READ_COMMAND` in this module (crate-internal).
//! - Maximum SPI clock and minimum SPI_SEL high time between accesses: unconfirmed for the
//!   ET1100 (20 MHz is often quoted; the EL9800 sample waits ~250 ns between accesses). The
//!   driver does not control them: configure the SPI peripheral (mode 3, see hardware-facts 1.1)
//!   and the `SpiDevice` chip-select timing accordingly.
//! - The 16-bit asynchronous µC PDI's AC timing ([`ucontroller`]): the ET1100 Section III
//!   tables were not found. The values are working assumptions (`research/stm32-fsmc.md` §2);
//!   the ESC model's front end and the STM32 board's FSMC timing both take them from here.

/// SPI command used for every read (see the module documentation).
// UNCONFIRMED: command 2 would need an ET1100-specific pause; command 3 avoids it.
pub(crate) const READ_COMMAND: u8 = 0b011;

/// The 16-bit asynchronous µC PDI (0x0140 = 0x08), in ns. **UNCONFIRMED**, every one: the
/// ET1100's AC tables for this PDI were not found. What is known: BUSY holds an access until
/// the internal memory access is done, a write is stored after WR rises so the next access
/// sees BUSY, and the same PDI logic on SPI needs about 240 ns before read data (TMC8462).
pub mod ucontroller {
    /// BUSY time of a read when no frame competes for the memory.
    pub const READ_BUSY_NS: u32 = 80;
    /// BUSY time of a read when it clashes with frame processing.
    pub const READ_BUSY_CLASH_NS: u32 = 260;
    /// Time the ESC takes to store a write after WR rises (no frame competing).
    pub const WRITE_STORE_NS: u32 = 80;
    /// The same when it clashes with frame processing.
    pub const WRITE_STORE_CLASH_NS: u32 = 260;
    /// Longest delay from CS with RD or WR asserted to BUSY asserted: the µC must not
    /// sample BUSY earlier (the FSMC's DATAST covers it).
    pub const BUSY_ASSERT_MAX_NS: u32 = 20;
    /// Longest delay from RD released to DATA released (high impedance): the bus
    /// turnaround before the µC drives the next address.
    pub const DATA_RELEASE_MAX_NS: u32 = 10;
}
