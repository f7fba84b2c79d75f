//! The ET1100 SPI_IRQ line on P0.22 (push-pull active low, SII word 1 = 0x0603) through the
//! GPIO interrupt: falling edge, EINT3 vector (IRQ 21), which all GPIO interrupts share
//! (UM10360 9.5.6; hardware-facts 7). The ESC's IRQ is a level (OR of 0x0220 & 0x0204), the
//! GPIO interrupt only sees edges: after serving, the task asks [`EscIrq::still_asserted`]
//! and pends itself again while the line stays low, so no event is lost (ESC-I 18.13.1).

use super::gpio::InPin;
use lpc17xx_pac as pac;

/// Bit of P0.22 in the port-0 GPIO interrupt registers.
const MASK: u32 = 1 << 22;

/// The ESC IRQ line (owner: the PDI task).
pub struct EscIrq {
    int: pac::GPIOINT,
    pin: InPin,
}

impl EscIrq {
    /// Enables the falling-edge interrupt of P0.22 (pin configured by the board).
    pub fn new(int: pac::GPIOINT, pin: InPin) -> Self {
        // SAFETY: IO0IntClr / IO0IntEnF bit 22 (write-1-to-clear, enable mask).
        int.clr0.write(|w| unsafe { w.bits(MASK) });
        int.enf0.modify(|r, w| unsafe { w.bits(r.bits() | MASK) });
        Self { int, pin }
    }

    /// Acknowledges the edge (call first in the handler); `true` if the pin caused it (else
    /// the handler was pended by software, e.g. after SYNC0 for the background work).
    pub fn acknowledge(&mut self) -> bool {
        let fell = self.int.statf0.read().bits() & MASK != 0;
        if fell {
            // SAFETY: write-1-to-clear.
            self.int.clr0.write(|w| unsafe { w.bits(MASK) });
        }
        fell
    }

    /// Whether the (active-low) line is still asserted after the events were served.
    pub fn still_asserted(&self) -> bool {
        !self.pin.is_high()
    }
}
