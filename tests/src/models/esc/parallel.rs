//! The ET1100's 16-bit asynchronous µC PDI (0x0140 = 0x08), and seed 004's board glue in
//! front of it: an STM32 FSMC bank with the address multiplexed on the data lines and held
//! by an external latch.
//!
//! Sources: ET1100 Hardware Description (ESC datasheet Section III) §6.5.3 Table 70 for the
//! byte lanes; ESC datasheet Section II for 0x0140/0x0150; `shared/research/stm32-fsmc.md`
//! §1-§2 for the seed's wiring and the BUSY behaviour; STM32 reference manual (RM0008,
//! FSMC "general transaction rules") for the FSMC reading both byte lanes.
//!
//! One bus access is one CS-low period with RD or WR. The ESC picks the bytes from ADR\[0\]
//! and BHE (Table 70, BHE active low with 0x0150 b4 = 0):
//!
//! | ADR\[0\] | BHE | access                                       |
//! |----------|-----|----------------------------------------------|
//! | 0        | 0   | 16 bit: ADR (DATA\[7:0\]) and ADR+1 (DATA\[15:8\]) |
//! | 0        | 1   | 8 bit, low byte (even address, DATA\[7:0\])  |
//! | 1        | 0   | 8 bit, high byte (odd address, DATA\[15:8\]) |
//! | 1        | 1   | invalid: no byte is accessed                 |
//!
//! Every valid access is one [`Esc::access`] of its 1 or 2 bytes on the PDI side, the same
//! core the SPI front end uses, so the register side effects and the SyncManager buffer
//! rules are the chip's: a 16-bit access that covers the last byte of a buffer completes
//! it.
//!
//! BUSY: a read holds BUSY until the ESC has the data ([`BusTiming::read_ns`]); a write is
//! taken when WR rises and stored afterwards ([`BusTiming::write_ns`], 0x0152 b1 = 0 on the
//! ET1100), so the write itself is not held but the next access waits with BUSY until it is
//! stored. The durations are UNCONFIRMED: [`BusTiming`] takes them from the et1100 driver's
//! `unconfirmed` module, the one place for them.
//!
//! Not modelled: the 8-bit µC PDI (0x09), the IRQ and BUSY driver variants other than
//! push-pull active low, BHE and RD polarity (the callers give BHE as asserted or not), and
//! what the data lines show between accesses.

use super::{regs, Esc};
use et1100::unconfirmed::ucontroller;

/// 0x0140: the 16-bit asynchronous µC PDI (ESC datasheet Section II, PDI control).
pub const PDI_ASYNC_16BIT: u8 = 0x08;

/// What the µC reads when the ESC does not drive DATA (the PDI is not a µC PDI, or the
/// access is invalid). The board's pull resistors are not known (no schematic): only the
/// tests of those cases see this value.
pub const UNDRIVEN_DATA: u16 = 0xFFFF;

/// The bytes one access moves (Table 70).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lanes {
    /// ADR and ADR+1 (ADR even).
    Word,
    /// The even byte ADR alone, on DATA\[7:0\].
    Low,
    /// The odd byte ADR alone, on DATA\[15:8\].
    High,
}

impl Lanes {
    /// The lanes of an access at `adr` with BHE `bhe_asserted`; `None` for the invalid
    /// combination (odd address without BHE).
    pub fn decode(adr: u16, bhe_asserted: bool) -> Option<Lanes> {
        match (adr & 1 == 1, bhe_asserted) {
            (false, true) => Some(Lanes::Word),
            (false, false) => Some(Lanes::Low),
            (true, true) => Some(Lanes::High),
            (true, false) => None,
        }
    }

    /// The first byte address and the byte count.
    fn span(self, adr: u16) -> (u16, usize) {
        match self {
            Lanes::Word => (adr, 2),
            Lanes::Low | Lanes::High => (adr, 1),
        }
    }
}

/// How long the ESC holds BUSY. **UNCONFIRMED**: the values are the et1100 driver's
/// [`et1100::unconfirmed::ucontroller`], the one place for them (80 ns per access without a
/// frame competing, 260 ns when one does). Both ends are given so the benches can run at
/// each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusTiming {
    /// From RD low to valid data (BUSY released), when no write is still being stored.
    pub read_ns: u64,
    /// After WR rises: the time the ESC takes to store the write; an access that starts
    /// earlier is held with BUSY until then.
    pub write_ns: u64,
}

impl BusTiming {
    /// No frame competes for the ESC's memory (UNCONFIRMED, see the type).
    pub const NO_CLASH: BusTiming = BusTiming {
        read_ns: ucontroller::READ_BUSY_NS as u64,
        write_ns: ucontroller::WRITE_STORE_NS as u64,
    };
    /// Every access clashes with frame processing (UNCONFIRMED, see the type).
    pub const FRAME_CLASH: BusTiming = BusTiming {
        read_ns: ucontroller::READ_BUSY_CLASH_NS as u64,
        write_ns: ucontroller::WRITE_STORE_CLASH_NS as u64,
    };
}

/// What one access did on the pins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusAccess {
    /// DATA\[15:0\] as the µC samples it (reads; the lane of a byte access, the other lane
    /// [`UNDRIVEN_DATA`]'s).
    pub data: u16,
    /// How long BUSY was asserted in this access (from its start).
    pub busy_ns: u64,
    /// When RD/WR rises: the later of the µC's strobe and BUSY's release.
    pub end_ns: u64,
}

/// Counters of the parallel front end.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ParallelStats {
    /// 16-bit reads / writes.
    pub word_reads: u64,
    /// 16-bit writes.
    pub word_writes: u64,
    /// 8-bit reads (either lane).
    pub byte_reads: u64,
    /// 8-bit writes (either lane).
    pub byte_writes: u64,
    /// Accesses with ADR\[0\] = 1 and BHE not asserted: nothing moved.
    pub invalid: u64,
    /// Accesses while the PDI is not operational as a 16-bit µC PDI: nothing moved.
    pub refused: u64,
    /// Sum of the BUSY times.
    pub busy_ns: u64,
}

/// The ESC's µC PDI pins: the lane decoding, the BUSY timing and its counters. The ESC's
/// memory is the [`Esc`] passed to each access; times are on the ESC's time base.
#[derive(Clone, Debug)]
pub struct ParallelPort {
    /// The BUSY durations (UNCONFIRMED, see [`BusTiming`]).
    pub timing: BusTiming,
    /// When the last write is stored.
    busy_until_ns: u64,
    /// Counters.
    pub stats: ParallelStats,
}

impl ParallelPort {
    /// A port with the given BUSY durations.
    pub fn new(timing: BusTiming) -> Self {
        Self {
            timing,
            busy_until_ns: 0,
            stats: ParallelStats::default(),
        }
    }

    /// Whether `esc` serves this PDI: configured as the 16-bit µC PDI from a good SII.
    pub fn active(esc: &Esc) -> bool {
        esc.pdi_operational() && esc.peek_u8(regs::PDI_CONTROL) == PDI_ASYNC_16BIT
    }

    /// A read that starts at `at_ns` with RD held low for at least `strobe_ns`.
    pub fn read(
        &mut self,
        esc: &mut Esc,
        at_ns: u64,
        strobe_ns: u64,
        adr: u16,
        bhe_asserted: bool,
    ) -> BusAccess {
        self.access(esc, (at_ns, strobe_ns), adr, bhe_asserted, None)
    }

    /// A write of DATA\[15:0\] = `data` that starts at `at_ns` with WR held low for at least
    /// `strobe_ns`. The ESC takes the lanes Table 70 selects.
    pub fn write(
        &mut self,
        esc: &mut Esc,
        at_ns: u64,
        strobe_ns: u64,
        adr: u16,
        bhe_asserted: bool,
        data: u16,
    ) -> BusAccess {
        self.access(esc, (at_ns, strobe_ns), adr, bhe_asserted, Some(data))
    }

    /// One access at `(start, strobe)`: a read, or a write of `write`.
    fn access(
        &mut self,
        esc: &mut Esc,
        (at_ns, strobe_ns): (u64, u64),
        adr: u16,
        bhe_asserted: bool,
        write: Option<u16>,
    ) -> BusAccess {
        let Some((lanes, first, len)) = self.admit(esc, adr, bhe_asserted) else {
            return BusAccess {
                data: UNDRIVEN_DATA,
                busy_ns: 0,
                end_ns: at_ns + strobe_ns,
            };
        };
        // Held until the last write is stored; a read also until its data is there.
        let mut busy = self.busy_until_ns.saturating_sub(at_ns);
        let data = match write {
            None => {
                busy += self.timing.read_ns;
                let mut bytes = [0xFF; 2];
                esc.pdi_read(first, &mut bytes[..len]);
                match lanes {
                    Lanes::Word => u16::from_le_bytes(bytes),
                    Lanes::Low => u16::from_le_bytes([bytes[0], 0xFF]),
                    Lanes::High => u16::from_le_bytes([0xFF, bytes[0]]),
                }
            }
            Some(data) => {
                let [lo, hi] = data.to_le_bytes();
                match lanes {
                    Lanes::Word => esc.pdi_write(first, &[lo, hi]),
                    Lanes::Low => esc.pdi_write(first, &[lo]),
                    Lanes::High => esc.pdi_write(first, &[hi]),
                };
                data
            }
        };
        let counter = match (write.is_some(), lanes) {
            (false, Lanes::Word) => &mut self.stats.word_reads,
            (false, _) => &mut self.stats.byte_reads,
            (true, Lanes::Word) => &mut self.stats.word_writes,
            (true, _) => &mut self.stats.byte_writes,
        };
        *counter += 1;
        self.stats.busy_ns += busy;
        let end_ns = at_ns + strobe_ns.max(busy);
        if write.is_some() {
            self.busy_until_ns = end_ns + self.timing.write_ns;
        }
        BusAccess {
            data,
            busy_ns: busy,
            end_ns,
        }
    }

    /// The lanes and bytes of an access the ESC serves, or `None` (counted) when it does
    /// not: PDI not a 16-bit µC PDI, or the invalid lane combination.
    fn admit(&mut self, esc: &Esc, adr: u16, bhe_asserted: bool) -> Option<(Lanes, u16, usize)> {
        if !Self::active(esc) {
            self.stats.refused += 1;
            return None;
        }
        let Some(lanes) = Lanes::decode(adr, bhe_asserted) else {
            self.stats.invalid += 1;
            return None;
        };
        let (first, len) = lanes.span(adr);
        Some((lanes, first, len))
    }
}

/// Seed 004's glue between a 100-pin STM32F103's FSMC (address and data multiplexed on
/// AD\[15:0\], 16-bit bank) and the ESC: two 74LVT373 take AD\[15:0\] while NADV is low
/// (the 74LVT04 makes the latch enable active high) and hold it for the data phase.
///
/// With a 16-bit bank the FSMC puts the halfword address HADDR\[16:1\] on AD\[15:0\], so the
/// latch's Q\[14:0\] drive ADR\[15:1\], NBL0 drives ADR\[0\] and NBL1 drives BHE: the ESC's
/// byte address is the offset in the bank (the seed's log shows SM0 at 0x6000_0800).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AddressLatch {
    q: u16,
}

impl AddressLatch {
    /// The address phase: NADV low with `ad` on AD\[15:0\]; NADV's rising edge holds it.
    pub fn address_phase(&mut self, ad: u16) {
        self.q = ad;
    }

    /// The ESC's ADR\[15:0\] and whether BHE is asserted, for the FSMC's byte-lane outputs
    /// `nbl0`/`nbl1` (pin levels, active low).
    pub fn esc_pins(&self, nbl0: bool, nbl1: bool) -> (u16, bool) {
        ((self.q << 1) | u16::from(nbl0), !nbl1)
    }
}

/// The FSMC's own timing of one access, without BUSY (from BTR1 on the board; in ns here).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FsmcCycle {
    /// Address phase (ADDSET + ADDHLD): NADV low, the latch takes AD.
    pub address_ns: u64,
    /// Data phase (DATAST): RD/WR low at least this long, longer while NWAIT is low.
    pub strobe_ns: u64,
    /// Bus turnaround (BUSTURN) after the access.
    pub turnaround_ns: u64,
}

/// The ESC behind a 16-bit multiplexed FSMC bank as the driver's [`et1100::MemoryBus`]: the
/// test stand-in for volatile accesses at 0x6000_0000 + offset on the seed's board.
///
/// As the FSMC does (RM0008, general transaction rules), a byte read drives both NBL low and
/// reads the whole halfword (the ESC sees a 16-bit access and its side effects on both
/// bytes); a byte write drives only its lane's NBL. Time runs on the bus's own clock, which
/// starts at the ESC's time and adds each access; the ESC's time is the board's to move.
#[derive(Clone)]
pub struct EscFsmcBus {
    esc: crate::models::shared_esc::SharedEsc,
    port: ParallelPort,
    latch: AddressLatch,
    cycle: FsmcCycle,
    now_ns: u64,
    /// FSMC accesses made.
    pub accesses: u64,
    /// Time the bus was busy with them (address, data and turnaround phases, BUSY included).
    pub bus_ns: u64,
}

impl EscFsmcBus {
    /// The bus on `esc` with the ESC's BUSY `timing` and the FSMC's `cycle`.
    pub fn new(
        esc: crate::models::shared_esc::SharedEsc,
        timing: BusTiming,
        cycle: FsmcCycle,
    ) -> Self {
        Self {
            esc,
            port: ParallelPort::new(timing),
            latch: AddressLatch::default(),
            cycle,
            now_ns: 0,
            accesses: 0,
            bus_ns: 0,
        }
    }

    /// The ESC's port (its counters).
    pub fn port(&self) -> &ParallelPort {
        &self.port
    }

    /// One access: address phase, then the data phase on the port.
    fn access(&mut self, offset: u16, nbl: (bool, bool), data: Option<u16>) -> BusAccess {
        let mut esc = self.esc.borrow_mut();
        let start = self.now_ns.max(esc.now_ns());
        self.latch.address_phase(offset >> 1);
        let (adr, bhe) = self.latch.esc_pins(nbl.0, nbl.1);
        let at = start + self.cycle.address_ns;
        let strobe = self.cycle.strobe_ns;
        let done = match data {
            None => self.port.read(&mut esc, at, strobe, adr, bhe),
            Some(d) => self.port.write(&mut esc, at, strobe, adr, bhe, d),
        };
        self.now_ns = done.end_ns + self.cycle.turnaround_ns;
        self.accesses += 1;
        self.bus_ns += self.now_ns - start;
        done
    }
}

impl et1100::MemoryBus for EscFsmcBus {
    type Error = std::convert::Infallible;

    fn read_u8(&mut self, offset: u16) -> Result<u8, Self::Error> {
        let [lo, hi] = self
            .access(offset & !1, (false, false), None)
            .data
            .to_le_bytes();
        Ok(if offset & 1 == 0 { lo } else { hi })
    }

    fn write_u8(&mut self, offset: u16, value: u8) -> Result<(), Self::Error> {
        let odd = offset & 1 == 1;
        // What the FSMC drives on the other lane does not matter to the ESC; its complement
        // makes a lane mix-up visible.
        let data = if odd {
            u16::from_le_bytes([!value, value])
        } else {
            u16::from_le_bytes([value, !value])
        };
        self.access(offset, (odd, !odd), Some(data));
        Ok(())
    }

    fn read_u16(&mut self, offset: u16) -> Result<u16, Self::Error> {
        Ok(self.access(offset, (false, false), None).data)
    }

    fn write_u16(&mut self, offset: u16, value: u16) -> Result<(), Self::Error> {
        self.access(offset, (false, false), Some(value));
        Ok(())
    }
}
