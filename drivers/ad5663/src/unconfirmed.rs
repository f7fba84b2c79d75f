//! Every fact this crate relies on that is **UNCONFIRMED** (no primary source seen), in one
//! place. Verify these on hardware before depending on them.
//!
//! Confirmed, for contrast (AD5663R datasheet p. 21, two copies; the plain AD5663 page was not
//! seen and is assumed to match): 24-bit frames, the command executes on the 24th falling SCLK
//! edge, SYNC high before the 24th edge aborts the frame, SYNC high for at least
//! [`SYNC_HIGH_MIN_NS`](crate::SYNC_HIGH_MIN_NS) before the next frame.
//!
//! Also **UNCONFIRMED**, without a constant:
//! - that command 111 is *reserved* on the plain AD5663. Its own command table was not seen;
//!   the non-R siblings (AD5624/AD5664) list 111 as reserved and the AD5663 has no internal
//!   reference. The driver therefore sends 111 only for [`ic::Ad5663R`](crate::ic::Ad5663R).
//! - that the CLR pin (asynchronous clear to zero scale) is active low and must be held high.
//!   This driver does not drive CLR.

/// **UNCONFIRMED**: DB0 of the reset command (101). With DB0 = 1 the reset is said to also
/// clear the LDAC and power-down registers (back to the power-on state); with DB0 = 0 only the
/// input and DAC registers. Taken from the AD5663R command description as summarised in the
/// project's hardware facts; not checked against the AD5663 datasheet itself.
pub const FULL_RESET_DB0: u16 = 0x0001;

/// **UNCONFIRMED**: minimum LDAC low pulse width. The value is the one of related Analog
/// Devices nanoDACs; the AD5663 timing table was not seen. [`Ad5663::pulse_ldac`](crate::Ad5663::pulse_ldac)
/// drives two GPIO writes back to back, which is longer than this on a Cortex-M3 at 100 MHz
/// with a peripheral-bus GPIO, but not necessarily on every MCU.
pub const LDAC_LOW_MIN_NS: u32 = 20;
