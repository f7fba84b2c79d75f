//! Platform-agnostic driver for the Analog Devices [AD5663] and [AD5663R] dual 16-bit
//! nanoDAC®, based on the [`embedded-hal`] 1.0 traits.
//!
//! [AD5663]: https://www.analog.com/en/products/ad5663.html
//! [AD5663R]: https://www.analog.com/en/products/ad5663r.html
//! [`embedded-hal`]: https://docs.rs/embedded-hal/1
//!
//! This driver allows you to:
//! - Write the input register, update the DAC register, or both, of channel A, B or both
//!   ([`write_input`], [`update_dac`], [`write_input_update_all`], [`write_and_update`]).
//! - Update both outputs at the same moment, with or without an LDAC pin
//!   ([`write_both_simultaneous`], [`stage_both`] + [`pulse_ldac`]).
//! - Select power-down modes per channel ([`set_power_mode`]), reset ([`reset`]), set up the
//!   LDAC register ([`set_ldac_mask`]).
//! - Switch the internal reference of the AD5663R ([`set_internal_reference`]; the plain
//!   AD5663 cannot send that command: the chip variant is a type parameter).
//! - Convert between volts and codes for a board with any reference and output gain
//!   ([`OutputScale`], [`code_to_volts`], [`volts_to_code`]).
//!
//! [`write_input`]: Ad5663::write_input
//! [`update_dac`]: Ad5663::update_dac
//! [`write_input_update_all`]: Ad5663::write_input_update_all
//! [`write_and_update`]: Ad5663::write_and_update
//! [`write_both_simultaneous`]: Ad5663::write_both_simultaneous
//! [`stage_both`]: Ad5663::stage_both
//! [`pulse_ldac`]: Ad5663::pulse_ldac
//! [`set_power_mode`]: Ad5663::set_power_mode
//! [`reset`]: Ad5663::reset
//! [`set_ldac_mask`]: Ad5663::set_ldac_mask
//! [`set_internal_reference`]: Ad5663::set_internal_reference
//!
//! ## The device
//!
//! Two 16-bit voltage-output DACs with a write-only 3-wire serial interface (SCLK up to
//! 50 MHz, DIN, SYNC). Each frame is 24 bits, MSB first: two don't-care bits, a 3-bit
//! command, a 3-bit address (A = 000, B = 001, both = 111) and 16 data bits. The command
//! executes on the 24th falling SCLK edge; SYNC going high earlier aborts the frame. Each
//! channel has an input register and a DAC register; the DAC register drives the output and
//! is loaded from the input register by the LDAC pin (active low), by a command, or on every
//! write for channels set *transparent* in the LDAC register. Power-on: outputs at zero scale,
//! LDAC register 0, normal power mode. Datasheets: [AD5663 (PDF)], [AD5663R (PDF)]
//! (command table p. 21).
//!
//! [AD5663 (PDF)]: https://www.analog.com/media/en/technical-documentation/data-sheets/AD5663.pdf
//! [AD5663R (PDF)]: https://www.analog.com/media/en/technical-documentation/data-sheets/AD5623R_5643R_5663R.pdf
//!
//! ## Bus
//!
//! Bound by [`SpiDevice`](embedded_hal::spi::SpiDevice): the device owns the chip select, which
//! is the DAC's SYNC pin; compose a bus and a GPIO with
//! `embedded_hal_bus::spi::ExclusiveDevice` (or a shared-bus device). Every command is exactly
//! one transaction with one 3-byte write. The DAC samples DIN on the *falling* SCLK edge: use
//! SPI mode 1 ([`MODE`], CPOL = 0, CPHA = 1); mode 2 (CPOL = 1, CPHA = 0) also works, since
//! it also presents data for the falling edge (the Linux ad5624r driver uses it). SYNC must
//! stay high at least [`SYNC_HIGH_MIN_NS`] between frames (the SpiDevice's job). Items not
//! confirmed by a primary source are collected in [`unconfirmed`].
//!
//! ## Simultaneous update of both channels
//!
//! | way | frames at the update | outputs change | needs |
//! |---|---|---|---|
//! | [`write_both_simultaneous`] | 2 (`write input A`, `write input B, update all`) | together, at the end of the 2nd frame: ≈2.1 µs after the start at 25 MHz | LDAC register 0, LDAC pin high |
//! | [`stage_both`] early, [`pulse_ldac`] at the event | 0 (two pin writes) | together, at the LDAC falling edge | LDAC register 0, an LDAC pin |
//! | [`set_ldac_mask`]`(LdacMask::Both)` (thesis word `0x00300003`) | 2 | one after the other, ≈1 µs apart | - |
//!
//! The firmware of this project stages new outputs as soon as they arrive and only pulses
//! LDAC in its SYNC0 task.
//!
//! ## Features
//!
//! - `defmt`: `defmt::Format` for the public types.
//!
//! MSRV: Rust 1.85.
//!
//! ## Example
//!
//! ```
//! use ad5663::{Ad5663, Channel, OutputScale};
//! use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTransaction};
//! use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiTransaction};
//!
//! // What the DAC must see: "write input A" 0x4000, "write input B" 0xC000.
//! let spi = SpiMock::new(&[
//!     SpiTransaction::transaction_start(),
//!     SpiTransaction::write_vec(vec![0x00, 0x40, 0x00]),
//!     SpiTransaction::transaction_end(),
//!     SpiTransaction::transaction_start(),
//!     SpiTransaction::write_vec(vec![0x01, 0xC0, 0x00]),
//!     SpiTransaction::transaction_end(),
//! ]);
//! let ldac = PinMock::new(&[
//!     PinTransaction::set(State::High), // with_ldac: inactive
//!     PinTransaction::set(State::Low),  // pulse_ldac
//!     PinTransaction::set(State::High),
//! ]);
//!
//! let mut dac = Ad5663::new_ad5663(spi).with_ldac(ldac).unwrap();
//! // The board: 2.5 V reference, x4 amplifier, 0..10 V.
//! let board = OutputScale::new(2.5, 4.0);
//! let a = board.code(2.5).unwrap();
//! let b = board.code(7.5).unwrap();
//! dac.stage_both(a, b).unwrap(); // when new values arrive
//! dac.pulse_ldac().unwrap(); // at the SYNC0 edge: both change together
//!
//! let (mut spi, mut ldac) = dac.destroy_with_ldac();
//! spi.done();
//! ldac.done();
//! ```
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

mod command;
mod device;
mod scale;
mod types;
pub mod unconfirmed;

pub use device::Ad5663;
pub use scale::{code_to_volts, volts_to_code, volts_to_code_clamped, OutputScale};
pub use types::{ic, Channel, Error, InvalidChannel, LdacMask, NoLdac, PowerMode, ResetMode};

use embedded_hal::spi::{Mode, MODE_1};

/// SPI mode of the AD5663: mode 1 (CPOL = 0, CPHA = 1). Mode 2 also works (see the crate
/// docs).
pub const MODE: Mode = MODE_1;

/// Minimum SYNC high time between two frames, ns (AD5663R datasheet p. 21; the chip-select gap
/// of the SpiDevice).
pub const SYNC_HIGH_MIN_NS: u32 = 15;

/// The README's example, compiled as a doctest so that it cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctest;
