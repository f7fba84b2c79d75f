//! The ET1100 on FSMC bank 1 (NE1, 0x6000_0000): the `et1100` driver's 16-bit `MemoryPdi`
//! over volatile halfword and byte accesses of the bank (ESC byte address = offset in the
//! bank, `firmware::platform::stm32f1::fsmc`), and its IRQ on EXTI0 (PC0, falling edge).
//! The slave application takes this `Et1100` as it is (generic over the driver's `Pdi`).

use super::gpio::{pin_of, InPin};
use super::{pac, read, set_bits, write};
use core::convert::Infallible;
use et1100::{BusWidth, Et1100, MemoryBus, MemoryPdi};
use firmware::platform::stm32f1::fsmc::{BANK1, BCR1, BTR1};
use firmware::platform::stm32f1::pins::{esc_irq_exticr, Signal, ESC_IRQ_EXTI_LINE};

/// The ESC's window on the FSMC: only volatile u8/u16 accesses, each one bus cycle (the
/// ESC's SyncManager buffers count accesses: never a memcpy or a 32-bit access here).
#[derive(Debug)]
pub struct FsmcBus(());

impl FsmcBus {
    fn at<T>(offset: u16) -> *mut T {
        (BANK1 + u32::from(offset)) as *mut T
    }
}

impl MemoryBus for FsmcBus {
    type Error = Infallible;

    #[inline(always)]
    fn read_u8(&mut self, offset: u16) -> Result<u8, Infallible> {
        // SAFETY: bank 1 is configured (only [`init`] builds an `FsmcBus`); every offset of
        // the ESC's 64 KB space is inside the bank, and BUSY stretches the access.
        Ok(unsafe { Self::at::<u8>(offset).read_volatile() })
    }

    #[inline(always)]
    fn write_u8(&mut self, offset: u16, value: u8) -> Result<(), Infallible> {
        // SAFETY: as `read_u8`.
        unsafe { Self::at::<u8>(offset).write_volatile(value) };
        Ok(())
    }

    #[inline(always)]
    fn read_u16(&mut self, offset: u16) -> Result<u16, Infallible> {
        // SAFETY: as `read_u8`; the driver passes even offsets.
        Ok(unsafe { Self::at::<u16>(offset).read_volatile() })
    }

    #[inline(always)]
    fn write_u16(&mut self, offset: u16, value: u16) -> Result<(), Infallible> {
        // SAFETY: as `read_u16`.
        unsafe { Self::at::<u16>(offset).write_volatile(value) };
        Ok(())
    }
}

/// The ET1100 on the FSMC (owner: the PDI task).
pub type Esc = Et1100<MemoryPdi<FsmcBus>>;

/// Bank 1 for the ESC (BTR1 first: the bank is enabled by BCR1), with FSMC clocked and the
/// pins configured.
pub fn init(fsmc: pac::FSMC) -> Esc {
    write(fsmc.btr1(), BTR1);
    write(fsmc.bcr1(), BCR1);
    Et1100::new(MemoryPdi::new(FsmcBus(()), BusWidth::Bits16))
}

/// The ESC's IRQ line on EXTI (owner: the PDI task).
pub struct EscIrq {
    exti: pac::EXTI,
    pin: InPin,
}

/// The line's bit in the EXTI registers.
const LINE: u32 = 1 << ESC_IRQ_EXTI_LINE;

impl EscIrq {
    /// Routes the pin's port to its EXTI line, falling edge, unmasked.
    pub fn new(exti: pac::EXTI, afio: &pac::afio::RegisterBlock) -> Self {
        let (index, value) = esc_irq_exticr();
        match index {
            1 => set_bits(afio.exticr1(), value),
            2 => set_bits(afio.exticr2(), value),
            3 => set_bits(afio.exticr3(), value),
            _ => set_bits(afio.exticr4(), value),
        }
        set_bits(exti.ftsr(), LINE);
        write(exti.pr(), LINE);
        set_bits(exti.imr(), LINE);
        Self {
            exti,
            pin: InPin::new(pin_of(Signal::EscIrq)),
        }
    }

    /// Acknowledges the edge (call first in the handler); `true` if the pin caused it (else
    /// the handler was pended by software).
    pub fn acknowledge(&mut self) -> bool {
        let fell = read(self.exti.pr()) & LINE != 0;
        if fell {
            // Write-1-to-clear.
            write(self.exti.pr(), LINE);
        }
        fell
    }

    /// Whether the (active-low) line is still asserted after the events were served.
    pub fn still_asserted(&self) -> bool {
        !self.pin.is_high()
    }
}
