//! The LPC17xx CAN controller's data formats (UM10360 chapter 16, the same controller as the
//! LPC23xx/24xx CAN1/2): the bus timing word for a bit rate, the receive and transmit
//! buffer words of a frame, the mode, command, status and interrupt bits the driver uses.
//! Plain data, host-tested; the register accesses are the firmware binary's (`hw::can`).
//!
//! Field positions are those of the `lpc1769` PAC (generated from NXP's SVD) and UM10360:
//! CANBTR BRP bits 9:0, SJW 15:14, TSEG1 19:16, TSEG2 22:20, SAM 23; the nominal bit time is
//! `(TSEG1 + 1) + (TSEG2 + 1) + 1` CAN clocks of `(BRP + 1) / PCLK`.

use coe_core::canopen::CanFrame;

/// CANMOD bit 0: reset mode (BTR and the error counters writable, the controller off the bus).
pub const MOD_RM: u32 = 1 << 0;
/// CANMOD bit 3: transmit priority by the TFIx priority field (0: by CAN identifier).
pub const MOD_TPM: u32 = 1 << 3;

/// CANCMR bit 0: transmission request.
pub const CMR_TR: u32 = 1 << 0;
/// CANCMR bit 2: release receive buffer.
pub const CMR_RRB: u32 = 1 << 2;
/// CANCMR bit 3: clear data overrun.
pub const CMR_CDO: u32 = 1 << 3;
/// CANCMR bits 5..7: select transmit buffer 1..3.
pub const CMR_STB: [u32; 3] = [1 << 5, 1 << 6, 1 << 7];

/// CANGSR bit 0: receive buffer status (a frame is waiting).
pub const GSR_RBS: u32 = 1 << 0;
/// CANGSR bit 1: data overrun (a frame was lost: the receive buffer was full).
pub const GSR_DOS: u32 = 1 << 1;
/// CANGSR bit 7: bus-off.
pub const GSR_BS: u32 = 1 << 7;

/// CANSR bits: transmit buffer 1..3 status (1: free).
pub const SR_TBS: [u32; 3] = [1 << 2, 1 << 10, 1 << 18];

/// CANIER bit 0: receive interrupt.
pub const IER_RIE: u32 = 1 << 0;
/// CANIER bit 2: error warning interrupt (bus-off enters through it).
pub const IER_EIE: u32 = 1 << 2;

/// CANAFMR (acceptance filter mode) bit 1: bypass, every frame is received.
pub const AFMR_ACCBP: u32 = 1 << 1;

/// CANRFS / CANTFI bit 30: remote frame.
const FI_RTR: u32 = 1 << 30;
/// CANRFS / CANTFI bit 31: 29-bit frame.
const FI_FF: u32 = 1 << 31;
/// CANRFS / CANTFI bits 19:16: data length code.
const FI_DLC_SHIFT: u32 = 16;

/// Time quanta per bit the controller can count: 1 + (1..=16) + (1..=8).
const TQ_PER_BIT: core::ops::RangeInclusive<u32> = 8..=25;

/// A bus timing: prescaler and the two segments, in CAN clocks (tq).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BitTiming {
    /// Clocks of PCLK per tq (BRP + 1), 1..=1024.
    pub prescaler: u32,
    /// tq from the sync segment's end to the sample point (TSEG1 + 1), 1..=16.
    pub tseg1: u32,
    /// tq from the sample point to the bit's end (TSEG2 + 1), 1..=8.
    pub tseg2: u32,
    /// Synchronisation jump width in tq (SJW + 1), 1..=4.
    pub sjw: u32,
}

impl BitTiming {
    /// tq per bit.
    pub const fn quanta(&self) -> u32 {
        1 + self.tseg1 + self.tseg2
    }

    /// The sample point in per mille of the bit.
    pub const fn sample_point_permille(&self) -> u32 {
        (1 + self.tseg1) * 1000 / self.quanta()
    }

    /// The CANBTR word (sampled once: SAM = 0).
    pub const fn btr(&self) -> u32 {
        (self.prescaler - 1)
            | (self.sjw - 1) << 14
            | (self.tseg1 - 1) << 16
            | (self.tseg2 - 1) << 20
    }

    /// The bit rate this timing gives at `pclk_hz`.
    pub const fn bit_rate(&self, pclk_hz: u32) -> u32 {
        pclk_hz / (self.prescaler * self.quanta())
    }
}

/// CiA 301's recommended sample point for `bit_rate` (per mille): 75 % at 1 Mbit/s, 80 % at
/// 800 kbit/s, 87.5 % below.
pub const fn cia_sample_point_permille(bit_rate: u32) -> u32 {
    if bit_rate >= 1_000_000 {
        750
    } else if bit_rate >= 800_000 {
        800
    } else {
        875
    }
}

/// The timing for `bit_rate` at `pclk_hz`: an exact bit time (no rate error) with the sample
/// point at most 2.5 % from CiA 301's recommendation, and of those the most tq per bit
/// (the finest resynchronisation), then the nearest sample point. `None` if no exact timing
/// reaches it (e.g. 800 kbit/s from a 100 MHz PCLK, whose only 25-tq bit samples at 68 %).
pub const fn bit_timing(pclk_hz: u32, bit_rate: u32) -> Option<BitTiming> {
    if bit_rate == 0 {
        return None;
    }
    let want = cia_sample_point_permille(bit_rate);
    let mut best: Option<(u32, BitTiming)> = None;
    let mut quanta = *TQ_PER_BIT.start();
    while quanta <= *TQ_PER_BIT.end() {
        if let Some((error, t)) = timing_with(pclk_hz, bit_rate, quanta, want) {
            let better = match best {
                None => true,
                Some((e, b)) => quanta > b.quanta() || (quanta == b.quanta() && error < e),
            };
            if better {
                best = Some((error, t));
            }
        }
        quanta += 1;
    }
    match best {
        Some((_, t)) => Some(t),
        None => None,
    }
}

/// The timing of `quanta` tq per bit and its sample point's distance from `want` (per
/// mille), if it is exact and within 2.5 %.
const fn timing_with(
    pclk_hz: u32,
    bit_rate: u32,
    quanta: u32,
    want: u32,
) -> Option<(u32, BitTiming)> {
    // 32-bit arithmetic (no 64-bit division in the image): a product that overflows is
    // above any PCLK and cannot divide it.
    let Some(clocks) = bit_rate.checked_mul(quanta) else {
        return None;
    };
    if pclk_hz % clocks != 0 {
        return None;
    }
    let prescaler = pclk_hz / clocks;
    if prescaler < 1 || prescaler > 1024 {
        return None;
    }
    // Sample point = (1 + tseg1) / quanta, nearest the wanted one.
    let tseg1 = ((want * quanta + 500) / 1000).saturating_sub(1);
    let tseg1 = if tseg1 < 1 {
        1
    } else if tseg1 > 16 {
        16
    } else {
        tseg1
    };
    let tseg2 = quanta - 1 - tseg1;
    if tseg2 < 1 || tseg2 > 8 {
        return None;
    }
    let t = BitTiming {
        prescaler,
        tseg1,
        tseg2,
        sjw: if tseg2 < 4 { tseg2 } else { 4 },
    };
    let error = t.sample_point_permille().abs_diff(want);
    if error > 25 {
        return None;
    }
    Some((error, t))
}

/// A received frame from CANRFS, CANRID, CANRDA, CANRDB; `None` for a 29-bit frame (this
/// node uses base-format identifiers only) or a DLC above 8.
pub fn frame_from_rx(rfs: u32, rid: u32, rda: u32, rdb: u32) -> Option<CanFrame> {
    if rfs & FI_FF != 0 {
        return None;
    }
    let dlc = (rfs >> FI_DLC_SHIFT & 0xF) as u8;
    let id = (rid & 0x7FF) as u16;
    if rfs & FI_RTR != 0 {
        return CanFrame::remote(id, dlc).ok();
    }
    let mut bytes = [0u8; 8];
    bytes[..4].copy_from_slice(&rda.to_le_bytes());
    bytes[4..].copy_from_slice(&rdb.to_le_bytes());
    CanFrame::new(id, bytes.get(..usize::from(dlc))?).ok()
}

/// The transmit buffer words of `frame`: CANTFIx, CANTIDx, CANTDAx, CANTDBx.
pub fn tx_words(frame: &CanFrame) -> [u32; 4] {
    let mut bytes = [0u8; 8];
    let data = frame.data();
    bytes[..data.len()].copy_from_slice(data);
    let rtr = if frame.is_remote() { FI_RTR } else { 0 };
    [
        u32::from(frame.dlc()) << FI_DLC_SHIFT | rtr,
        u32::from(frame.id()),
        u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
        u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    const PCLK: u32 = 100_000_000;

    #[test]
    fn timings_at_100_mhz() {
        for (rate, quanta, sample) in [
            (125_000, 20, 850),
            (250_000, 20, 850),
            (500_000, 20, 850),
            (1_000_000, 20, 750),
        ] {
            let t = bit_timing(PCLK, rate).unwrap();
            assert_eq!(t.bit_rate(PCLK), rate, "exact");
            assert_eq!(
                (t.quanta(), t.sample_point_permille()),
                (quanta, sample),
                "{rate}: {t:?}"
            );
            assert!(t.sjw >= 1 && t.sjw <= t.tseg2);
        }
        // 100 MHz / 800 kbit/s = 125 clocks: only 5 x 25 tq, sampled at 68 %.
        assert_eq!(bit_timing(PCLK, 800_000), None);
        assert_eq!(bit_timing(PCLK, 0), None);
        // bit rate x tq per bit beyond 32 bits: no timing, no overflow.
        assert_eq!(bit_timing(PCLK, u32::MAX / 4), None);
    }

    #[test]
    fn btr_fields() {
        // 1 Mbit/s: BRP 4, 20 tq = 1 + 14 + 5, SJW 4.
        let t = bit_timing(PCLK, 1_000_000).unwrap();
        assert_eq!(
            t,
            BitTiming {
                prescaler: 5,
                tseg1: 14,
                tseg2: 5,
                sjw: 4
            }
        );
        assert_eq!(t.btr(), 4 | 3 << 14 | 13 << 16 | 4 << 20);
    }

    #[test]
    fn frames_through_the_buffer_words() {
        let f = CanFrame::new(0x585, &[0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x0C]).unwrap();
        let [tfi, tid, tda, tdb] = tx_words(&f);
        assert_eq!(tfi, 7 << 16);
        assert_eq!(tid, 0x585);
        assert_eq!(tda, 0x0010_0043);
        assert_eq!(tdb, 0x000C_0191);
        assert_eq!(frame_from_rx(tfi, tid, tda, tdb), Some(f));
        let r = CanFrame::remote(0x705, 1).unwrap();
        let [tfi, tid, tda, tdb] = tx_words(&r);
        assert_eq!(tfi, 1 << 16 | 1 << 30);
        assert_eq!(frame_from_rx(tfi, tid, tda, tdb), Some(r));
        assert_eq!(frame_from_rx(1 << 31, 0x1234_5678, 0, 0), None, "29-bit");
        assert_eq!(frame_from_rx(9 << 16, 0x100, 0, 0), None, "DLC 9");
    }
}
