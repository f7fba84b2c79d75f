//! The memory-mapped PDI on a fake parallel bus that records every access.

use et1100::{AlEvents, BusWidth, Error, Et1100, MemoryBus, MemoryPdi, Pdi, SyncManager};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Access {
    R8(u16),
    W8(u16, u8),
    R16(u16),
    W16(u16, u16),
}

/// 64 KiB of register file plus a log of accesses; `fail` makes every access fail.
struct FakeBus {
    mem: Vec<u8>,
    log: Vec<Access>,
    fail: bool,
}

impl FakeBus {
    fn new() -> Self {
        Self {
            mem: vec![0; 0x1_0000],
            log: Vec::new(),
            fail: false,
        }
    }

    fn check(&self) -> Result<(), &'static str> {
        if self.fail {
            Err("bus fault")
        } else {
            Ok(())
        }
    }
}

impl MemoryBus for FakeBus {
    type Error = &'static str;

    fn read_u8(&mut self, offset: u16) -> Result<u8, Self::Error> {
        self.check()?;
        self.log.push(Access::R8(offset));
        Ok(self.mem[usize::from(offset)])
    }

    fn write_u8(&mut self, offset: u16, value: u8) -> Result<(), Self::Error> {
        self.check()?;
        self.log.push(Access::W8(offset, value));
        self.mem[usize::from(offset)] = value;
        Ok(())
    }

    fn read_u16(&mut self, offset: u16) -> Result<u16, Self::Error> {
        self.check()?;
        assert_eq!(offset % 2, 0, "unaligned word read");
        self.log.push(Access::R16(offset));
        let o = usize::from(offset);
        Ok(u16::from_le_bytes([self.mem[o], self.mem[o + 1]]))
    }

    fn write_u16(&mut self, offset: u16, value: u16) -> Result<(), Self::Error> {
        self.check()?;
        assert_eq!(offset % 2, 0, "unaligned word write");
        self.log.push(Access::W16(offset, value));
        let o = usize::from(offset);
        self.mem[o..o + 2].copy_from_slice(&value.to_le_bytes());
        Ok(())
    }
}

#[test]
fn sixteen_bit_bus_reads_events_then_data_without_touching_neighbours() {
    let mut bus = FakeBus::new();
    bus.mem[0x0220..0x0224].copy_from_slice(&[0x01, 0x04, 0x00, 0x00]);
    bus.mem[0x1001..0x1006].copy_from_slice(&[1, 2, 3, 4, 5]);
    let mut pdi = MemoryPdi::new(bus, BusWidth::Bits16);
    let mut buf = [0u8; 5];
    let ev = pdi.read(0x1001, &mut buf).unwrap();
    assert_eq!(buf, [1, 2, 3, 4, 5]);
    assert!(ev.contains(AlEvents::AL_CONTROL | AlEvents::SM2));
    let bus = pdi.destroy();
    // The event bits the ET1100 has (0x0220..0x0221) in one word, then the data.
    assert_eq!(
        bus.log,
        [
            Access::R16(0x0220),
            Access::R8(0x1001),
            Access::R16(0x1002),
            Access::R16(0x1004),
        ]
    );
}

#[test]
fn sixteen_bit_bus_write_ends_with_last_byte() {
    let mut pdi = MemoryPdi::new(FakeBus::new(), BusWidth::Bits16);
    pdi.write(0x1080, &[0xA, 0xB, 0xC]).unwrap();
    let bus = pdi.destroy();
    assert_eq!(
        bus.log,
        [
            Access::R16(0x0220),
            Access::W16(0x1080, 0x0B0A),
            Access::W8(0x1082, 0x0C)
        ]
    );
    assert_eq!(bus.mem[0x1083], 0);
}

#[test]
fn eight_bit_bus_and_helpers() {
    let mut bus = FakeBus::new();
    let sm = [0x00, 0x10, 0x04, 0x00, 0x26, 0x08, 0x01, 0x00];
    bus.mem[0x0800..0x0808].copy_from_slice(&sm);
    bus.mem[0x1000..0x1004].copy_from_slice(&[9, 8, 7, 6]);
    let mut esc = Et1100::new(MemoryPdi::new(bus, BusWidth::Bits8));
    let sm0 = esc.read_sm(0).unwrap();
    assert_eq!(sm0, SyncManager::from_bytes(sm));
    let mut buf = [0u8; 4];
    esc.read_mailbox(&sm0, &mut buf).unwrap();
    assert_eq!(buf, [9, 8, 7, 6]);
    esc.set_event_mask(AlEvents::from_bits_retain(0x0000_0F11))
        .unwrap();
    let bus = esc.destroy().destroy();
    assert_eq!(bus.mem[0x0204..0x0208], [0x11, 0x0F, 0x00, 0x00]);
    // Each call: the 2 event bytes, then the data bytes, in ascending order.
    let expected_sm: Vec<Access> = (0x0220..0x0222)
        .chain(0x0800..0x0808)
        .map(Access::R8)
        .collect();
    assert_eq!(bus.log[..10], expected_sm[..]);
    assert_eq!(bus.log.len(), 10 + 6 + 6);
}

#[test]
fn range_and_bus_errors() {
    let mut pdi = MemoryPdi::new(FakeBus::new(), BusWidth::Bits16);
    let mut two = [0u8; 2];
    assert_eq!(pdi.read(0xFFFF, &mut two), Err(Error::OutOfRange));
    assert_eq!(pdi.write(0x1000, &[]), Err(Error::OutOfRange));
    assert!(pdi.bus_mut().log.is_empty());
    pdi.bus_mut().fail = true;
    assert_eq!(pdi.events(), Err(Error::Bus("bus fault")));
    assert_eq!(pdi.write(0x1000, &[1]), Err(Error::Bus("bus fault")));
}

#[test]
fn low_events_default_masks_the_upper_event_bytes() {
    let mut bus = FakeBus::new();
    bus.mem[0x0220..0x0224].copy_from_slice(&[0x01, 0x04, 0x01, 0x00]);
    let mut pdi = MemoryPdi::new(bus, BusWidth::Bits16);
    assert_eq!(pdi.events().unwrap().bits(), 0x0001_0401);
    assert_eq!(pdi.low_events().unwrap().bits(), 0x0401);
    // events: two words; low_events: one.
    assert_eq!(
        pdi.destroy().log,
        [
            Access::R16(0x0220),
            Access::R16(0x0222),
            Access::R16(0x0220)
        ]
    );
}

#[test]
fn sixteen_bit_bus_writes_an_odd_sm_buffer_without_reaching_past_it() {
    // A 5-byte buffer at an odd start (0x1181..0x1185): a leading byte, two words, and no
    // word that would reach 0x1186 (in 3-buffer mode the first byte of the next buffer).
    let mut pdi = MemoryPdi::new(FakeBus::new(), BusWidth::Bits16);
    pdi.write(0x1181, &[1, 2, 3, 4, 5]).unwrap();
    // An even start with an odd length: two words, then the last byte alone.
    pdi.write(0x1100, &[6, 7, 8, 9, 10]).unwrap();
    let bus = pdi.destroy();
    assert_eq!(
        bus.log,
        [
            Access::R16(0x0220),
            Access::W8(0x1181, 1),
            Access::W16(0x1182, 0x0302),
            Access::W16(0x1184, 0x0504),
            Access::R16(0x0220),
            Access::W16(0x1100, 0x0706),
            Access::W16(0x1102, 0x0908),
            Access::W8(0x1104, 10),
        ]
    );
    assert_eq!(bus.mem[0x1186], 0);
    assert_eq!(bus.mem[0x1105], 0);
}
