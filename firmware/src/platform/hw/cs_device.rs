//! The `SpiDevice` of the board's buses: a bus plus a GPIO chip select held low for a whole
//! transaction. In place of embedded-hal-bus's `ExclusiveDevice`: the bus error is the
//! device error (the chip select cannot fail), so no error wrapping per bus (flash).

use super::delay::CycleDelay;
use super::gpio::OutPin;
use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{ErrorType, Operation, SpiBus, SpiDevice};

/// A bus with its chip select (active low).
pub struct CsDevice<B> {
    bus: B,
    cs: OutPin,
}

impl<B> CsDevice<B> {
    /// The device on `bus` selected by `cs` (left high until a transaction).
    pub fn new(bus: B, cs: OutPin) -> Self {
        cs.set(true);
        Self { bus, cs }
    }
}

impl<B: ErrorType> ErrorType for CsDevice<B> {
    type Error = B::Error;
}

impl<B: SpiBus<u8>> SpiDevice<u8> for CsDevice<B> {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), B::Error> {
        self.cs.set(false);
        let result = self.run(operations);
        // Deselected on every path, also after a bus error.
        self.cs.set(true);
        result
    }
}

impl<B: SpiBus<u8>> CsDevice<B> {
    /// The operations on the selected device, up to the first bus error.
    fn run(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), B::Error> {
        for op in operations {
            match op {
                Operation::Read(words) => self.bus.read(words)?,
                Operation::Write(words) => self.bus.write(words)?,
                Operation::Transfer(read, write) => self.bus.transfer(read, write)?,
                Operation::TransferInPlace(words) => self.bus.transfer_in_place(words)?,
                Operation::DelayNs(ns) => CycleDelay.delay_ns(*ns),
            }
        }
        self.bus.flush()
    }
}
