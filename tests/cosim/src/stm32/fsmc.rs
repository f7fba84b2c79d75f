//! The FSMC's NOR/PSRAM controller (RM0008 chapter 21), bank 1 as the board uses it: the
//! registers (BCRx, BTRx, BWTRx with their reset values) and the timing of one access from
//! BTR1 at HCLK ([`Fsmc::cycle`]). The bank's accesses go to the ESC's µC front end through
//! seed 004's address latch (the machine does the wiring, `machine/stm32.rs`); the rules the
//! board needs ([`Fsmc::check`]) are reported when broken.

use super::unconfirmed::FSMC_EXTRA_HCLK;
use crate::periph::ticks_to_ns;
use virtual_board::models::esc::parallel::FsmcCycle;

/// BCR bits.
pub mod bcr {
    /// Bank enable.
    pub const MBKEN: u32 = 1 << 0;
    /// Address/data multiplexing.
    pub const MUXEN: u32 = 1 << 1;
    /// Memory type (00 SRAM, 01 PSRAM, 10 NOR).
    pub const MTYP_SHIFT: u32 = 2;
    /// Data bus width (00 8 bit, 01 16 bit).
    pub const MWID_SHIFT: u32 = 4;
    /// NWAIT active high.
    pub const WAITPOL: u32 = 1 << 9;
    /// Write enable.
    pub const WREN: u32 = 1 << 12;
    /// Extended mode (BWTR for writes).
    pub const EXTMOD: u32 = 1 << 14;
    /// NWAIT during asynchronous accesses.
    pub const ASYNCWAIT: u32 = 1 << 15;
}

/// The registers of the four NOR/PSRAM banks.
#[derive(Clone, Debug)]
pub struct Fsmc {
    bcr: [u32; 4],
    btr: [u32; 4],
    bwtr: [u32; 4],
}

impl Default for Fsmc {
    fn default() -> Self {
        Self::new()
    }
}

impl Fsmc {
    /// Reset values (RM0008 21.5.6: BCR1 0x30DB, BCR2..4 0x30D2, BTR/BWTR 0x0FFF_FFFF).
    pub fn new() -> Self {
        Self {
            bcr: [0x30DB, 0x30D2, 0x30D2, 0x30D2],
            btr: [0x0FFF_FFFF; 4],
            bwtr: [0x0FFF_FFFF; 4],
        }
    }

    /// BCR1.
    pub fn bcr1(&self) -> u32 {
        self.bcr[0]
    }

    /// Whether bank 1 is enabled.
    pub fn bank1_enabled(&self) -> bool {
        self.bcr[0] & bcr::MBKEN != 0
    }

    /// Whether bank 1 takes writes.
    pub fn bank1_writable(&self) -> bool {
        self.bcr[0] & bcr::WREN != 0
    }

    /// Whether NWAIT stretches bank 1's asynchronous accesses.
    pub fn bank1_async_wait(&self) -> bool {
        self.bcr[0] & bcr::ASYNCWAIT != 0
    }

    /// Bank 1's access phases at `hclk_hz` (mode 1/A: the write timing is BTR's unless
    /// EXTMOD selects BWTR).
    pub fn cycle(&self, hclk_hz: u64, write: bool) -> FsmcCycle {
        let t = if write && self.bcr[0] & bcr::EXTMOD != 0 {
            self.bwtr[0]
        } else {
            self.btr[0]
        };
        let addset = u64::from(t & 0xF);
        let addhld = u64::from((t >> 4) & 0xF);
        let datast = u64::from((t >> 8) & 0xFF);
        let busturn = u64::from((t >> 16) & 0xF);
        let extra = u64::from(FSMC_EXTRA_HCLK);
        FsmcCycle {
            address_ns: ticks_to_ns(addset + addhld, hclk_hz),
            strobe_ns: ticks_to_ns(datast + extra, hclk_hz),
            turnaround_ns: ticks_to_ns(busturn, hclk_hz),
        }
    }

    /// What bank 1's settings break on the board (a 16-bit multiplexed bus through the
    /// latch, BUSY on NWAIT with the ESC's polarity `busy_active_high`), one message each.
    pub fn check(&self, busy_active_high: bool) -> Vec<String> {
        let b = self.bcr[0];
        let mut v = Vec::new();
        if (b >> bcr::MWID_SHIFT) & 3 != 1 {
            v.push(format!(
                "FSMC BCR1 {b:#x}: MWID is not 16 bit, the ESC's µC PDI is 16 bit wide"
            ));
        }
        if b & bcr::MUXEN == 0 {
            v.push(format!(
                "FSMC BCR1 {b:#x}: MUXEN off, but the board latches the address from AD[15:0] \
                 (the 100-pin package has no separate address lines)"
            ));
        }
        let mtyp = (b >> bcr::MTYP_SHIFT) & 3;
        if b & bcr::MUXEN != 0 && mtyp == 0 {
            v.push(format!(
                "FSMC BCR1 {b:#x}: MTYP SRAM with MUXEN: multiplexing is valid for PSRAM and \
                 NOR only"
            ));
        }
        if (b & bcr::WAITPOL != 0) != busy_active_high && b & bcr::ASYNCWAIT != 0 {
            v.push(format!(
                "FSMC BCR1 {b:#x}: WAITPOL {} but the ESC drives BUSY active {} (0x0150): \
                 every access waits for the wrong level",
                u32::from(b & bcr::WAITPOL != 0),
                if busy_active_high { "high" } else { "low" }
            ));
        }
        v
    }

    /// A register read (offset from 0xA000_0000).
    pub fn read(&self, offset: u32) -> u32 {
        match offset {
            0x00..=0x1C => {
                let n = (offset / 8) as usize;
                if offset.is_multiple_of(8) {
                    self.bcr[n]
                } else {
                    self.btr[n]
                }
            }
            0x104..=0x11C if offset % 8 == 4 => self.bwtr[((offset - 0x104) / 8) as usize],
            _ => 0,
        }
    }

    /// A register write; `Err` for the NAND/PC Card registers (not modelled).
    pub fn write(&mut self, offset: u32, value: u32) -> Result<(), String> {
        match offset {
            0x00..=0x1C => {
                let n = (offset / 8) as usize;
                if offset.is_multiple_of(8) {
                    self.bcr[n] = value & 0x000F_FFFF;
                } else {
                    self.btr[n] = value & 0x3FFF_FFFF;
                }
                Ok(())
            }
            0x104..=0x11C if offset % 8 == 4 => {
                self.bwtr[((offset - 0x104) / 8) as usize] = value & 0x3FFF_FFFF;
                Ok(())
            }
            other => Err(format!(
                "write of {value:#x} to FSMC register {:#010x}: the NAND/PC Card banks are not \
                 modelled",
                0xA000_0000u32 + other
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_boards_bank_1_and_its_phases() {
        let mut f = Fsmc::new();
        assert!(f.bank1_enabled(), "BCR1 reset 0x30DB has MBKEN");
        f.write(0x00, 0x30DB & !bcr::MUXEN).unwrap();
        assert!(!f.check(false).is_empty(), "not multiplexed: reported");
        f.write(0x04, 0x0FF1_0611).unwrap();
        f.write(0x00, 0x0000_90D7).unwrap();
        assert_eq!(f.check(false), Vec::<String>::new());
        assert!(
            !f.check(true).is_empty(),
            "WAITPOL against BUSY active high"
        );
        let c = f.cycle(72_000_000, false);
        assert_eq!((c.address_ns, c.strobe_ns, c.turnaround_ns), (28, 84, 14));
        assert!(f.write(0x60, 0).is_err());
    }
}
