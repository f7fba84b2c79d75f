//! [`EscPort`] on the `et1100` driver: the same application runs on the board's SPI PDI,
//! a memory-mapped PDI, and the virtual board's byte-exact SPI model.

use super::EscPort;
use et1100::{Et1100, Pdi};

impl<P: Pdi> EscPort for Et1100<P>
where
    P::BusError: core::fmt::Debug,
{
    type Error = et1100::Error<P::BusError>;

    fn read(&mut self, addr: u16, buf: &mut [u8]) -> Result<u32, Self::Error> {
        Et1100::read(self, addr, buf).map(|e| e.bits())
    }

    fn write(&mut self, addr: u16, data: &[u8]) -> Result<u32, Self::Error> {
        Et1100::write(self, addr, data).map(|e| e.bits())
    }

    fn events(&mut self) -> Result<u32, Self::Error> {
        // The application needs bits 0..11 only: the cheapest event access (SPI: 2 bytes).
        Et1100::low_events(self).map(|e| e.bits())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::convert::Infallible;
    use et1100::MemoryBus;

    /// A 64 KiB byte-addressed bus standing in for a memory-mapped ESC.
    struct Ram(std::vec::Vec<u8>);

    impl MemoryBus for Ram {
        type Error = Infallible;
        fn read_u8(&mut self, offset: u16) -> Result<u8, Infallible> {
            Ok(self.0[usize::from(offset)])
        }
        fn write_u8(&mut self, offset: u16, value: u8) -> Result<(), Infallible> {
            self.0[usize::from(offset)] = value;
            Ok(())
        }
        fn read_u16(&mut self, offset: u16) -> Result<u16, Infallible> {
            let o = usize::from(offset);
            Ok(u16::from_le_bytes([self.0[o], self.0[o + 1]]))
        }
        fn write_u16(&mut self, offset: u16, value: u16) -> Result<(), Infallible> {
            let o = usize::from(offset);
            self.0[o..o + 2].copy_from_slice(&value.to_le_bytes());
            Ok(())
        }
    }

    #[test]
    fn driver_accesses_carry_the_event_bits() {
        let mut ram = Ram(std::vec![0; 0x1_0000]);
        ram.0[0x0220..0x0224].copy_from_slice(&0x0000_0101u32.to_le_bytes());
        ram.0[0x0120] = 0x02;
        let mut esc = Et1100::new(et1100::MemoryPdi::new(ram, et1100::BusWidth::Bits16));
        let mut control = [0u8; 2];
        let events = EscPort::read(&mut esc, 0x0120, &mut control).unwrap();
        assert_eq!(events, 0x0101);
        assert_eq!(control, [0x02, 0x00]);
        assert_eq!(
            EscPort::write(&mut esc, 0x0130, &[0x02, 0x00]).unwrap(),
            0x0101
        );
        assert_eq!(EscPort::events(&mut esc).unwrap(), 0x0101);
        // Bits 16.. (SM8..SM15, which the ET1100 does not have) are not read.
        let mut ram = Ram(std::vec![0; 0x1_0000]);
        ram.0[0x0220..0x0224].copy_from_slice(&0x0001_0101u32.to_le_bytes());
        let mut esc2 = Et1100::new(et1100::MemoryPdi::new(ram, et1100::BusWidth::Bits16));
        assert_eq!(EscPort::events(&mut esc2).unwrap(), 0x0101);
    }
}
