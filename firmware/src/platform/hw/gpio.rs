//! GPIO pins through the fast GPIO block (FIO, 0x2009_C000, stride 0x20 per port:
//! DIR +0, MASK +0x10, PIN +0x14, SET +0x18, CLR +0x1C; hardware-facts section 7).
//!
//! A pin is a value made once by the board bring-up (`crate::hw::board`) from the pin map;
//! SET/CLR are write-1-to-act registers, so pins of one port owned by different tasks never
//! race (no read-modify-write).

use core::convert::Infallible;
use core::ptr;

/// A port pin `Pport.pin`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pin {
    /// GPIO port 0..=4.
    pub port: u8,
    /// Bit 0..=31.
    pub pin: u8,
}

impl Pin {
    /// `Pport.pin`.
    pub const fn new(port: u8, pin: u8) -> Self {
        Self { port, pin }
    }
}

const FIO_BASE: usize = 0x2009_C000;
const FIODIR: usize = 0x00;
const FIOPIN: usize = 0x14;
const FIOSET: usize = 0x18;
const FIOCLR: usize = 0x1C;

/// The address of port `port`'s register block (the offsets above are added to it).
fn port_block(port: u8) -> usize {
    FIO_BASE + usize::from(port) * 0x20
}

/// Register `offset` of the port block at `block`.
fn reg(block: usize, offset: usize) -> *mut u32 {
    (block + offset) as *mut u32
}

/// A push-pull output (chip selects, LDAC, CLR).
#[derive(Debug)]
pub struct OutPin {
    /// The port's register block, computed once (a pin access is then one store).
    block: usize,
    mask: u32,
}

impl OutPin {
    /// Makes `pin` an output at `high` (level written before the direction, no glitch).
    /// Only the board bring-up calls this, once per pin of the pin map.
    pub(super) fn new(pin: Pin, high: bool) -> Self {
        let p = Self {
            block: port_block(pin.port),
            mask: 1 << pin.pin,
        };
        p.set(high);
        // SAFETY: FIODIR of an existing port; the read-modify-write runs in a critical
        // section during board init, before any task can touch GPIO.
        cortex_m::interrupt::free(|_| unsafe {
            let dir = reg(p.block, FIODIR);
            ptr::write_volatile(dir, ptr::read_volatile(dir) | p.mask);
        });
        p
    }

    /// Drives the pin high (`true`) or low.
    #[inline(always)]
    pub fn set(&self, high: bool) {
        let offset = if high { FIOSET } else { FIOCLR };
        // SAFETY: FIOSET/FIOCLR are write-1-to-act: only this pin's bit changes.
        unsafe { ptr::write_volatile(reg(self.block, offset), self.mask) }
    }

    /// The level the pin reads back.
    pub fn is_high(&self) -> bool {
        // SAFETY: a read of FIOPIN has no side effect.
        unsafe { ptr::read_volatile(reg(self.block, FIOPIN)) & self.mask != 0 }
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

/// A GPIO input (ESC IRQ line, EEPROM_LOADED).
#[derive(Debug)]
pub struct InPin {
    /// The port (its block worked out per read): input reads are few, and the
    /// bootloader's polling code stays smaller so.
    port: u8,
    mask: u32,
}

impl InPin {
    /// `pin` as an input (the reset direction); only the board bring-up calls this.
    pub(super) fn new(pin: Pin) -> Self {
        Self {
            port: pin.port,
            mask: 1 << pin.pin,
        }
    }

    /// The pin level.
    #[inline(always)]
    pub fn is_high(&self) -> bool {
        // SAFETY: a read of FIOPIN has no side effect.
        unsafe { ptr::read_volatile(reg(port_block(self.port), FIOPIN)) & self.mask != 0 }
    }
}
