//! FSMC bank 1 (NE1, 0x6000_0000) for the ET1100's 16-bit asynchronous µC PDI, address and
//! data multiplexed (the 100-pin package has no separate A0..A15) with the address held by
//! two 74LVT373 enabled through a 74LVT04 from NADV (seed 004). RM0008 §21.5.6 (BCR/BTR).
//!
//! BUSY drives NWAIT, which stretches the asynchronous accesses (ASYNCWAIT), so the data
//! phase only has to cover the ESC's BUSY assertion delay: DATAST = 4 HCLK + that delay
//! (the reference manual's asynchronous-wait rule as the research note gives it; check it
//! against RM0008's "asynchronous wait" section before relying on it).
//!
//! The ET1100's timing is the et1100 driver's [`ucontroller`] (UNCONFIRMED, the one place
//! for it); the latch's is [`LATCH`] (UNCONFIRMED, below).

use super::clocks::CLOCKS;
use super::esc_pdi;
use coe_core::device::PinDriver;
use et1100::unconfirmed::ucontroller;

/// The bank's base: ESC byte address `a` is at `BANK1 + a` (the seed's log shows SM0's
/// registers at 0x6000_0800).
pub const BANK1: u32 = 0x6000_0000;

/// BCR1 and BTR1 at reset (RM0008): bank 1 enabled, NOR, multiplexed, 16 bit, write enable,
/// WAITEN; all timings at their maximum.
pub const BCR1_RESET: u32 = 0x0000_30DB;
/// See [`BCR1_RESET`].
pub const BTR1_RESET: u32 = 0x0FFF_FFFF;

/// The board's glue between the FSMC and the ESC. **UNCONFIRMED**: no datasheet of the
/// latch and inverter was consulted here; these are typical 74LVT figures at 3.3 V with a
/// margin. Check them against the parts fitted.
pub const LATCH: LatchTiming = LatchTiming {
    setup_ns: 2,
    hold_ns: 6,
};

/// The latch's timing as the FSMC sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LatchTiming {
    /// AD stable before NADV rises (74LVT373 data setup to LE falling, plus skew).
    pub setup_ns: u32,
    /// AD held after NADV rises: the inverter's delay until LE falls plus the latch's hold.
    pub hold_ns: u32,
}

/// The four timing fields of an asynchronous multiplexed access, in HCLK cycles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MuxTiming {
    /// Address phase with NADV low (ADDSET, 1..=15).
    pub addset: u32,
    /// Address held after NADV rises (ADDHLD, 1..=15).
    pub addhld: u32,
    /// Data phase: RD/WR low, stretched while NWAIT is asserted (DATAST, 1..=255).
    pub datast: u32,
    /// Bus turnaround after the access (BUSTURN, 0..=15).
    pub busturn: u32,
}

/// HCLK cycles covering `ns` at `hclk_hz` (rounded up).
pub const fn cycles(ns: u32, hclk_hz: u32) -> u32 {
    let c = (ns as u64 * hclk_hz as u64).div_ceil(1_000_000_000);
    if c > u32::MAX as u64 {
        u32::MAX
    } else {
        c as u32
    }
}

/// `c` HCLK cycles at `hclk_hz` in ns (rounded down).
const fn nanoseconds(c: u32, hclk_hz: u32) -> u32 {
    if hclk_hz == 0 {
        return 0;
    }
    ((c as u64 * 1_000_000_000) / hclk_hz as u64) as u32
}

const fn clamp(v: u32, min: u32, max: u32) -> u32 {
    if v < min {
        min
    } else if v > max {
        max
    } else {
        v
    }
}

impl MuxTiming {
    /// The timing for the ESC behind the latch at `hclk_hz`.
    pub const fn for_esc(hclk_hz: u32) -> Self {
        Self {
            addset: clamp(cycles(LATCH.setup_ns, hclk_hz), 1, 15),
            addhld: clamp(cycles(LATCH.hold_ns, hclk_hz), 1, 15),
            datast: clamp(4 + cycles(ucontroller::BUSY_ASSERT_MAX_NS, hclk_hz), 1, 255),
            busturn: clamp(cycles(ucontroller::DATA_RELEASE_MAX_NS, hclk_hz), 0, 15),
        }
    }

    /// BTR1: the four fields; CLKDIV and DATLAT (synchronous only) and ACCMOD (extended
    /// mode only) at their reset values.
    pub const fn btr(&self) -> u32 {
        const SYNC_FIELDS_AT_RESET: u32 = 0x0FF0_0000;
        SYNC_FIELDS_AT_RESET
            | self.busturn << 16
            | self.datast << 8
            | self.addhld << 4
            | self.addset
    }

    /// An access without BUSY in ns at `hclk_hz`: (address phase, data phase, turnaround).
    pub const fn phases_ns(&self, hclk_hz: u32) -> (u32, u32, u32) {
        (
            nanoseconds(self.addset + self.addhld, hclk_hz),
            nanoseconds(self.datast, hclk_hz),
            nanoseconds(self.busturn, hclk_hz),
        )
    }
}

/// The board's timing at its HCLK.
pub const TIMING: MuxTiming = MuxTiming::for_esc(CLOCKS.hclk_hz());

/// BCR1 bits (RM0008 §21.5.6).
pub mod bcr {
    /// Memory bank enable.
    pub const MBKEN: u32 = 1 << 0;
    /// Address/data multiplexing.
    pub const MUXEN: u32 = 1 << 1;
    /// Memory type field (00 SRAM, 01 PSRAM, 10 NOR).
    pub const MTYP_MASK: u32 = 0b11 << 2;
    /// PSRAM: with SRAM the FSMC does not multiplex (MUXEN is valid for NOR and PSRAM).
    pub const MTYP_PSRAM: u32 = 0b01 << 2;
    /// Memory width field (00 8 bit, 01 16 bit).
    pub const MWID_MASK: u32 = 0b11 << 4;
    /// 16 bit.
    pub const MWID_16: u32 = 0b01 << 4;
    /// NWAIT polarity: 1 = active high.
    pub const WAITPOL: u32 = 1 << 9;
    /// Write enable.
    pub const WREN: u32 = 1 << 12;
    /// NWAIT in synchronous burst mode (unused here).
    pub const WAITEN: u32 = 1 << 13;
    /// Extended mode (separate write timing).
    pub const EXTMOD: u32 = 1 << 14;
    /// NWAIT during asynchronous accesses.
    pub const ASYNCWAIT: u32 = 1 << 15;
}

/// BCR1 from its reset value: PSRAM in place of NOR (multiplexing stays on), 16 bit, write
/// enabled, NWAIT taken in asynchronous accesses with the polarity of the ESC's BUSY driver,
/// not in burst mode; FACCEN and the reserved bit 7 as at reset.
pub const fn bcr1(busy: PinDriver) -> u32 {
    let waitpol = match busy {
        PinDriver::PushPullActiveHigh | PinDriver::OpenSourceActiveHigh => bcr::WAITPOL,
        PinDriver::PushPullActiveLow | PinDriver::OpenDrainActiveLow => 0,
    };
    let keep =
        BCR1_RESET & !(bcr::MTYP_MASK | bcr::MWID_MASK | bcr::WAITEN | bcr::EXTMOD | bcr::WAITPOL);
    keep | bcr::MBKEN
        | bcr::MUXEN
        | bcr::MTYP_PSRAM
        | bcr::MWID_16
        | bcr::WREN
        | bcr::ASYNCWAIT
        | waitpol
}

/// The board's BCR1.
pub const BCR1: u32 = bcr1(esc_pdi::BUSY);
/// The board's BTR1.
pub const BTR1: u32 = TIMING.btr();

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_timing_at_72_mhz() {
        // 13.9 ns per HCLK: latch setup 2 ns and hold 6 ns take one cycle each; BUSY's
        // assertion (20 ns) two on top of the four the wait rule asks; data release (10 ns)
        // one.
        assert_eq!(
            TIMING,
            MuxTiming {
                addset: 1,
                addhld: 1,
                datast: 6,
                busturn: 1
            }
        );
        assert_eq!(TIMING.phases_ns(72_000_000), (27, 83, 13));
    }

    #[test]
    fn register_values() {
        // 0x30DB with MTYP NOR -> PSRAM, WAITEN off, ASYNCWAIT on.
        assert_eq!(BCR1, 0x0000_90D7);
        assert_eq!(BCR1 & bcr::MUXEN, bcr::MUXEN);
        assert_eq!(BCR1 & bcr::WAITPOL, 0, "BUSY is push-pull active low");
        // DATLAT/CLKDIV at reset, BUSTURN 1, DATAST 6, ADDHLD 1, ADDSET 1.
        assert_eq!(BTR1, 0x0FF1_0611);
    }

    #[test]
    fn an_active_high_busy_inverts_nwait() {
        assert_eq!(bcr1(PinDriver::PushPullActiveHigh), BCR1 | bcr::WAITPOL);
    }

    #[test]
    fn a_faster_clock_takes_more_cycles() {
        // 168 MHz (an F407's HCLK, 5.95 ns): the same nanoseconds, more cycles.
        let t = MuxTiming::for_esc(168_000_000);
        assert_eq!((t.addset, t.addhld, t.datast, t.busturn), (1, 2, 8, 2));
        assert_eq!(cycles(0, 72_000_000), 0);
        assert_eq!(cycles(14, 72_000_000), 2);
        assert_eq!(cycles(13, 72_000_000), 1);
    }
}
