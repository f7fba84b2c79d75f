//! CAN1 of the LPC1754 (UM10360 chapter 16) on P0.0 RD1 / P0.1 TD1 ([`super::board`]): the
//! controller the CAN task serves ([`firmware::stacks::canopen::task`]).
//!
//! - Clock: PCLK_CAN1 = PCLK_CAN2 = PCLK_ACF = CCLK / 1 = 100 MHz (UM10360 requires the
//!   three equal; [`super::clocks`]); the bus timing comes from
//!   [`firmware::platform::chip::can::bit_timing`] (10, 20, 50, 125, 250, 500 kbit/s and 1 Mbit/s
//!   exactly, as the EDS lists them; 800 kbit/s has no exact timing at 100 MHz), worked
//!   out when the firmware is built ([`super::board`]), so a rate without one does not build.
//! - Acceptance filter in bypass (AFMR.AccBP): every frame of the bus is received, the
//!   CANopen node picks its own; no look-up table to keep in step with configurable
//!   COB-IDs. The cost is an interrupt per frame on the bus.
//! - Three transmit buffers, filled in the order the node gives (highest priority first);
//!   the controller's arbitration between them follows the CAN identifier (MOD.TPM = 0).
//! - The receive interrupt (IER.RIE) pends the CAN task; a data overrun (the receive
//!   buffer was full: the task was held longer than a frame) is counted; bus-off is left by
//!   clearing reset mode (the controller then waits for 128 x 11 recessive bits itself).
//!
//! UNCONFIRMED on a board (no hardware here): the register sequence is UM10360's and the
//! PAC's field layout (host-tested formats in `firmware::platform::chip::can`), not run on a part.

use coe_core::canopen::CanFrame;
use firmware::platform::chip::can::{
    frame_from_rx, tx_words, BitTiming, AFMR_ACCBP, CMR_CDO, CMR_RRB, CMR_STB, CMR_TR, GSR_BS,
    GSR_DOS, GSR_RBS, IER_RIE, MOD_RM, SR_TBS,
};
use firmware::stacks::canopen::task::CanController;
use lpc17xx_pac as pac;

/// Frames [`Can1::receive`] looks at for one of base format.
const RX_LOOKS: usize = 4;

/// Counters of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, defmt::Format)]
pub struct CanStats {
    /// Frames lost because the receive buffer was full.
    pub overruns: u32,
    /// Bus-off events left.
    pub bus_off: u32,
}

/// CAN1 as the board brings it up: powered and clocked, its pins on RD1/TD1, the
/// controller in reset mode; a product with a CANopen node starts it ([`CanPort::start`]),
/// any other leaves it so.
pub struct CanPort {
    /// The controller.
    pub can: pac::CAN1,
    /// The acceptance filter.
    pub af: pac::CANAF,
}

impl CanPort {
    /// Starts CAN1 with `timing` ([`Can1::new`]).
    pub fn start(self, timing: BitTiming) -> Can1 {
        Can1::new(self.can, &self.af, timing)
    }
}

/// CAN1, in operating mode.
pub struct Can1 {
    can: pac::CAN1,
    /// Counters.
    pub stats: CanStats,
}

impl Can1 {
    /// Starts CAN1 with `timing` (powered and clocked by [`super::clocks`], pins by
    /// [`super::board`], the timing found at build time by
    /// [`firmware::platform::chip::can::bit_timing`]): reset mode, bus
    /// timing, acceptance filter bypass, receive interrupt, operating mode.
    pub fn new(can: pac::CAN1, af: &pac::CANAF, timing: BitTiming) -> Self {
        // SAFETY (all raw writes): UM10360 chapter 16 register values; BTR only in reset mode.
        can.mod_.write(|w| unsafe { w.bits(MOD_RM) });
        can.ier.write(|w| unsafe { w.bits(0) });
        can.btr.write(|w| unsafe { w.bits(timing.btr()) });
        af.afmr.write(|w| unsafe { w.bits(AFMR_ACCBP) });
        can.ier.write(|w| unsafe { w.bits(IER_RIE) });
        can.mod_.write(|w| unsafe { w.bits(0) });
        Self {
            can,
            stats: CanStats::default(),
        }
    }

    fn command(&mut self, bits: u32) {
        // SAFETY: CANCMR command bits of UM10360 table 3xx.
        self.can.cmr.write(|w| unsafe { w.bits(bits) });
    }
}

impl CanController for Can1 {
    fn receive(&mut self) -> Option<CanFrame> {
        // A 29-bit frame is not for this node: the next one is looked at, a few at most
        // (the receive buffer holds little).
        for _ in 0..RX_LOOKS {
            let gsr = self.can.gsr.read().bits();
            if gsr & GSR_BS != 0 {
                // Bus-off puts the controller in reset mode; leaving it starts the recovery.
                self.stats.bus_off = self.stats.bus_off.wrapping_add(1);
                // SAFETY: MOD = 0, operating mode.
                self.can.mod_.write(|w| unsafe { w.bits(0) });
            }
            if gsr & GSR_DOS != 0 {
                self.stats.overruns = self.stats.overruns.wrapping_add(1);
                self.command(CMR_CDO);
            }
            if gsr & GSR_RBS == 0 {
                return None;
            }
            let frame = frame_from_rx(
                self.can.rfs.read().bits(),
                self.can.rid.read().bits(),
                self.can.rda.read().bits(),
                self.can.rdb.read().bits(),
            );
            self.command(CMR_RRB);
            if frame.is_some() {
                return frame;
            }
        }
        None
    }

    fn transmit(&mut self, frame: &CanFrame) -> bool {
        let sr = self.can.sr.read().bits();
        let Some(buffer) = SR_TBS.iter().position(|b| sr & b != 0) else {
            return false;
        };
        let [tfi, tid, tda, tdb] = tx_words(frame);
        // SAFETY: the transmit buffer words of a free buffer (TBSn = 1).
        unsafe {
            match buffer {
                0 => {
                    self.can.tfi1.write(|w| w.bits(tfi));
                    self.can.tid1.write(|w| w.bits(tid));
                    self.can.tda1.write(|w| w.bits(tda));
                    self.can.tdb1.write(|w| w.bits(tdb));
                }
                1 => {
                    self.can.tfi2.write(|w| w.bits(tfi));
                    self.can.tid2.write(|w| w.bits(tid));
                    self.can.tda2.write(|w| w.bits(tda));
                    self.can.tdb2.write(|w| w.bits(tdb));
                }
                _ => {
                    self.can.tfi3.write(|w| w.bits(tfi));
                    self.can.tid3.write(|w| w.bits(tid));
                    self.can.tda3.write(|w| w.bits(tda));
                    self.can.tdb3.write(|w| w.bits(tdb));
                }
            }
        }
        let select = CMR_STB.get(buffer).copied().unwrap_or(0);
        self.command(CMR_TR | select);
        true
    }
}
