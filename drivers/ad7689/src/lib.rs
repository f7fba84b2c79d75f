//! Platform-agnostic driver for the Analog Devices [AD7689] (and AD7682) 8-channel, 16-bit,
//! 250 kSPS PulSAR ADC, based on the [`embedded-hal`] 1.0 traits.
//!
//! [AD7689]: https://www.analog.com/en/products/ad7689.html
//! [`embedded-hal`]: https://docs.rs/embedded-hal/1
//!
//! This driver allows you to:
//! - Build the 14-bit configuration register with a typed builder ([`Config`]: overwrite,
//!   input configuration, channel, bandwidth, reference, sequencer, readback).
//! - Read after conversion without busy indicator (CNV is the SPI chip select: [`Rac`]) or
//!   with busy indicator (the driver drives CNV and watches SDO: [`Busy`]).
//! - Get every result tagged with the input (or the temperature sensor) it belongs to,
//!   through the two-conversion CFG pipeline and the channel sequencer ([`Sample`]).
//! - Read the CFG back with every result and have it checked (`Config::readback(true)`).
//! - Convert codes to volts and degrees ([`unipolar_volts`], [`bipolar_volts`],
//!   [`temperature_celsius`], [`InputScale`] for a board's input divider).
//!
//! ## The device
//!
//! Eight inputs (single-ended to GND or COM, or pairs, unipolar or bipolar), a temperature
//! sensor, internal 2.5 V / 4.096 V references, a channel sequencer, and a 4-wire serial
//! interface: CNV (rising edge starts a conversion; low selects the serial port), SCK, DIN,
//! SDO. Datasheet: [AD7682/AD7689 (PDF)], Rev. D: configuration register p. 25/26, read/write
//! timing pp. 27-30.
//!
//! [AD7682/AD7689 (PDF)]: https://www.analog.com/media/en/technical-documentation/data-sheets/AD7682_7689.pdf
//!
//! ## Frames
//!
//! Each frame is one [`SpiDevice`](embedded_hal::spi::SpiDevice) transaction with one
//! `TransferInPlace`: the CFG goes in on DIN MSB first during the first 14 SCK (the 16-bit
//! word `CFG << 2`, or zeros to keep the CFG), the result of the previous conversion comes out
//! on SDO MSB first, followed by the 14-bit CFG that governed it when readback is on.
//!
//! | interface | SPI mode | frame | result | CFG readback |
//! |---|---|---|---|---|
//! | [`Rac`], no readback | 0 ([`MODE_RAC`]) | 16 bits | bits 15..0 | - |
//! | [`Rac`], readback | 0 | 32 bits | bits 31..16 | bits 15..2 |
//! | [`Busy`], no readback | 3 ([`MODE_BUSY`]) | 24 bits | bits 23..8 | - |
//! | [`Busy`], readback | 3 | 32 bits | bits 31..16 | bits 15..2 |
//!
//! Without busy indicator CNV (the chip select) stays high for at least tCONV after a frame
//! before the next frame reads the result; [`Ad7689::wait_ready`] waits tCYC with a
//! [`DelayNs`](embedded_hal::delay::DelayNs), or the caller paces the frames (a timer).
//! With busy indicator CNV must be low at the end of the conversion, which a `SpiDevice`
//! cannot do across a wait; the driver therefore owns CNV in that mode, pulses it after each
//! frame and waits for SDO low (bounded, [`Error::Timeout`]). See [`Busy`].
//!
//! ## The pipeline
//!
//! A frame reads the conversion that started when the previous frame ended. A CFG written in
//! frame N is latched at the end of the conversion started when frame N ends, so it governs
//! the conversion after that, whose result arrives in frame N + 2. After power-up two dummy
//! conversions are needed ([`Ad7689::start`] runs the whole sequence). The driver keeps track
//! of what is in flight, including the sequencer position, so every [`Sample`] carries its
//! [`Channel`]: in a running scan frame k + 2 holds scan channel k; rewriting INCC/INx
//! restarts the scan. A result whose CFG the driver does not know is returned as `None`.
//!
//! Timing values and the few sequencer details without a primary source are collected in
//! [`unconfirmed`].
//!
//! ## Features
//!
//! - `defmt`: `defmt::Format` for the public types.
//!
//! MSRV: Rust 1.85.
//!
//! ## Example
//!
//! Scan IN0..IN7 (unipolar to GND, external 2.5 V reference) on a board with 1/4 input
//! dividers, read after conversion without busy indicator:
//!
//! ```
//! use ad7689::{Ad7689, Channel, Config, InputScale, Reference, Sequencer};
//! use embedded_hal_mock::eh1::delay::NoopDelay;
//! use embedded_hal_mock::eh1::spi::{Mock, Transaction};
//!
//! // One frame: CNV low, 16 bits in and out at once, CNV high.
//! fn frame(din: [u8; 2], sdo: [u8; 2]) -> [Transaction<u8>; 3] {
//!     [
//!         Transaction::transaction_start(),
//!         Transaction::transfer_in_place(din.to_vec(), sdo.to_vec()),
//!         Transaction::transaction_end(),
//!     ]
//! }
//! let mut expected = Vec::new();
//! expected.extend(frame([0xFF, 0xDC], [0x12, 0x34])); // CFG 0x3FF7, dummy
//! expected.extend(frame([0xFF, 0xDC], [0x56, 0x78])); // CFG again, dummy
//! expected.extend(frame([0x00, 0x00], [0x9A, 0xBC])); // dummy
//! expected.extend(frame([0x00, 0x00], [0x80, 0x00])); // IN0
//! expected.extend(frame([0x00, 0x00], [0x40, 0x00])); // IN1
//!
//! let mut adc = Ad7689::new(Mock::new(&expected));
//! let cfg = Config::new()
//!     .channel(7)
//!     .reference(Reference::External)
//!     .sequencer(Sequencer::Scan);
//! assert_eq!(cfg.word(), 0xFFDC);
//! let mut delay = NoopDelay::new();
//! adc.start(cfg, &mut delay).unwrap();
//!
//! let board = InputScale::new(2.5, 4.0);
//! let s = adc.read_when_ready(&mut delay).unwrap().unwrap();
//! assert_eq!((s.channel, board.volts(s.code)), (Channel::In(0), 5.0));
//! let s = adc.read_when_ready(&mut delay).unwrap().unwrap();
//! assert_eq!((s.channel, board.volts(s.code)), (Channel::In(1), 2.5));
//!
//! adc.destroy().done();
//! ```
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

mod command;
mod config;
mod conversion;
mod device;
mod interface;
mod pipeline;
mod types;
pub mod unconfirmed;

pub use config::{Bandwidth, Config, InputConfig, Reference, Sequencer};
pub use conversion::{bipolar_volts, temperature_celsius, unipolar_volts, InputScale};
pub use device::Ad7689;
pub use interface::{Busy, BusyLine, Interface, Rac, BUSY_POLL_NS, DEFAULT_BUSY_TIMEOUT_NS};
pub use types::{Channel, Error, NoPin, Sample};

use embedded_hal::spi::{Mode, MODE_0, MODE_3};

/// SPI mode for read after conversion without busy indicator: mode 0 (CPOL = 0, CPHA = 0).
pub const MODE_RAC: Mode = MODE_0;

/// SPI mode for read after conversion with busy indicator: mode 3 (CPOL = 1, CPHA = 1), as
/// the datasheet suggests (SCK idles high).
pub const MODE_BUSY: Mode = MODE_3;

/// The README's example, compiled as a doctest so that it cannot go stale.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctest;
