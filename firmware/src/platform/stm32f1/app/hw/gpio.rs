//! The pin table (`firmware::platform::stm32f1::pins::PINS`) written to the ports, and the
//! pins the firmware reads or drives itself.

use super::{pac, read, write};
use core::convert::Infallible;
use firmware::platform::stm32f1::pins::{self, Pin, Port, Signal};

/// The address of `port`'s registers.
fn base(port: Port) -> usize {
    (match port {
        Port::A => pac::GPIOA::PTR,
        Port::B => pac::GPIOB::PTR,
        Port::C => pac::GPIOC::PTR,
        Port::D => pac::GPIOD::PTR,
        Port::E => pac::GPIOE::PTR,
    }) as usize
}

/// The register block at `base`.
fn block_at(base: usize) -> &'static pac::gpioa::RegisterBlock {
    // SAFETY: `base` is a port's address from [`base`], valid for the whole program. Each
    // pin object touches only its own bit (IDR reads, BSRR's atomic set/reset).
    unsafe { &*(base as *const pac::gpioa::RegisterBlock) }
}

/// The register block of `port`.
fn block(port: Port) -> &'static pac::gpioa::RegisterBlock {
    block_at(base(port))
}

/// Every port's CRL/CRH from the pin table (call once, with the ports clocked).
pub fn configure_all() {
    for port in [Port::A, Port::B, Port::C, Port::D, Port::E] {
        let (crl, crh) = pins::port_config(port);
        let gpio = block(port);
        write(gpio.crl(), crl);
        write(gpio.crh(), crh);
    }
}

/// The pin of `signal` in the table (a missing one does not build).
pub const fn pin_of(signal: Signal) -> Pin {
    match pins::find(signal) {
        Some(a) => a.pin,
        None => panic!("a signal the firmware uses is missing from the pin table"),
    }
}

/// An input pin.
#[derive(Debug)]
pub struct InPin {
    base: usize,
    mask: u32,
}

impl InPin {
    /// The pin (configured as an input by the table).
    pub fn new(pin: Pin) -> Self {
        Self {
            base: base(pin.port),
            mask: 1 << pin.number,
        }
    }

    /// Whether the pin reads high.
    pub fn is_high(&self) -> bool {
        read(block_at(self.base).idr()) & self.mask != 0
    }
}

/// A push-pull output pin.
#[derive(Debug)]
pub struct OutPin {
    base: usize,
    number: u8,
}

impl OutPin {
    /// The pin (configured as an output by the table), driven to `high` first.
    pub fn new(pin: Pin, high: bool) -> Self {
        let p = Self {
            base: base(pin.port),
            number: pin.number,
        };
        p.set(high);
        p
    }

    /// Drives the pin (BSRR: set in the low half, reset in the high half; no read).
    #[inline(always)]
    pub fn set(&self, high: bool) {
        let bit = if high { 0 } else { 16 } + u32::from(self.number);
        write(block_at(self.base).bsrr(), 1 << bit);
    }
}

impl embedded_hal::digital::ErrorType for OutPin {
    type Error = Infallible;
}

impl embedded_hal::digital::OutputPin for OutPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.set(false);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.set(true);
        Ok(())
    }
}
