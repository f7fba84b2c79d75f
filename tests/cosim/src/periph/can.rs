//! CAN1 (UM10360 chapter 16, base 0x4004_4000) and the acceptance filter's mode register
//! (CANAFMR, base 0x4003_C000): the registers of one controller, its double receive buffer
//! and three transmit buffers. The bus is the virtual board's ([`crate::machine`] moves the
//! frames: [`Can::take_requests`] to the bus, [`Can::transmitted`] when one has been sent,
//! [`Can::receive`] when one arrives); bit timing, power, clocks and pins are checked there.
//!
//! Modelled: reset/operating mode (MOD.RM), bus timing (BTR, writable in reset mode only),
//! the commands TR with STB1..3, RRB and CDO, the receive buffer (RBS, data overrun when both
//! halves are full), the transmit buffer status (TBS/TCS per buffer), the receive interrupt
//! (RI = RBS and IER.RIE; RRB clears it until the next frame) and acceptance filter bypass
//! (AFMR.AccBP) and off (AccOff, the reset value). Not modelled, and reported when used:
//! listen-only, self-test, sleep and the other MOD bits, abort and self-reception requests,
//! the other interrupt sources, the look-up table modes of the acceptance filter, 29-bit
//! frames; the error counters stay at zero (the virtual bus has no errors).

use super::{Peripheral, Tick};
use coe_core::canopen::CanFrame;
use std::collections::VecDeque;

const MOD: u32 = 0x00;
const CMR: u32 = 0x04;
const GSR: u32 = 0x08;
const ICR: u32 = 0x0C;
const IER: u32 = 0x10;
const BTR: u32 = 0x14;
const EWL: u32 = 0x18;
const SR: u32 = 0x1C;
const RFS: u32 = 0x20;
const RID: u32 = 0x24;
const RDA: u32 = 0x28;
const RDB: u32 = 0x2C;
/// TFI1; buffer n's four words (TFI, TID, TDA, TDB) at `TX_BASE + 0x10 * n`.
const TX_BASE: u32 = 0x30;

const MOD_RM: u32 = 1 << 0;
const MOD_TPM: u32 = 1 << 3;
const CMR_TR: u32 = 1 << 0;
const CMR_AT: u32 = 1 << 1;
const CMR_RRB: u32 = 1 << 2;
const CMR_CDO: u32 = 1 << 3;
const CMR_SRR: u32 = 1 << 4;
const CMR_STB_SHIFT: u32 = 5;
const IER_RIE: u32 = 1 << 0;
const FI_RTR: u32 = 1 << 30;
const FI_FF: u32 = 1 << 31;
/// RFS bit 10: the frame was received in acceptance filter bypass.
const RFS_BP: u32 = 1 << 10;

/// CANAFMR bits.
const AFMR_ACC_OFF: u32 = 1 << 0;
const AFMR_ACC_BP: u32 = 1 << 1;
const AFMR_EFCAN: u32 = 1 << 2;

/// Frames the receive buffer holds (UM10360: a double receive buffer).
const RX_DEPTH: usize = 2;

/// BTR after reset (UM10360 table "CAN Bus Timing register").
const BTR_RESET: u32 = 0x001C_0000;

/// Where a transmit buffer is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum TxState {
    /// Free (TBS = 1).
    Free,
    /// Requested, not yet handed to the bus.
    Requested,
    /// On its way on the bus.
    OnBus,
}

/// CAN1 and the acceptance filter mode.
#[derive(Clone, Debug)]
pub struct Can {
    mode: u32,
    ier: u32,
    btr: u32,
    ewl: u32,
    rx: VecDeque<[u32; 4]>,
    overrun: bool,
    tx: [[u32; 4]; 3],
    tx_state: [TxState; 3],
    /// Transmission complete per buffer (TCS).
    tx_complete: [bool; 3],
    /// Buffers handed to the bus, in bus order.
    on_bus: VecDeque<usize>,
    afmr: u32,
    /// Frames received into the buffer.
    pub received: u64,
    /// Frames lost to a full receive buffer.
    pub overruns: u64,
    /// Frames sent.
    pub sent: u64,
    /// Rule violations (once each).
    pub violations: Vec<String>,
}

impl Default for Can {
    fn default() -> Self {
        Self::new()
    }
}

impl Can {
    /// Reset state: reset mode, acceptance filter off.
    pub fn new() -> Self {
        Self {
            mode: MOD_RM,
            ier: 0,
            btr: BTR_RESET,
            ewl: 96,
            rx: VecDeque::new(),
            overrun: false,
            tx: [[0; 4]; 3],
            tx_state: [TxState::Free; 3],
            tx_complete: [true; 3],
            on_bus: VecDeque::new(),
            afmr: AFMR_ACC_OFF,
            received: 0,
            overruns: 0,
            sent: 0,
            violations: Vec::new(),
        }
    }

    fn violation(&mut self, msg: String) {
        if !self.violations.contains(&msg) {
            self.violations.push(msg);
        }
    }

    /// Operating mode (MOD.RM = 0): the controller takes part in bus traffic.
    pub fn operating(&self) -> bool {
        self.mode & MOD_RM == 0
    }

    /// The bit rate BTR gives at `pclk_hz` (bit/s, truncated): PCLK / ((BRP + 1) x
    /// (1 + TSEG1 + 1 + TSEG2 + 1)).
    pub fn bit_rate(&self, pclk_hz: u64) -> u64 {
        let brp = u64::from(self.btr & 0x3FF) + 1;
        let tseg1 = u64::from((self.btr >> 16) & 0xF) + 1;
        let tseg2 = u64::from((self.btr >> 20) & 0x7) + 1;
        pclk_hz / (brp * (1 + tseg1 + tseg2))
    }

    /// Whether the acceptance filter passes every frame (bypass); `Err` with the reason when
    /// it passes none or is in a mode this model does not have.
    pub fn accepts_all(&self) -> Result<(), String> {
        if self.afmr & AFMR_ACC_BP != 0 {
            Ok(())
        } else if self.afmr & AFMR_ACC_OFF != 0 {
            Err("the acceptance filter is off (AFMR.AccOff): CAN1 receives nothing".into())
        } else {
            Err(format!(
                "acceptance filter look-up table mode (AFMR {:#x}) is not modelled",
                self.afmr
            ))
        }
    }

    /// CANAFMR read.
    pub fn afmr(&self) -> u32 {
        self.afmr
    }

    /// CANAFMR write.
    pub fn set_afmr(&mut self, value: u32) {
        if value & AFMR_EFCAN != 0 {
            self.violation("FullCAN mode (AFMR.eFCAN) is not modelled".into());
        }
        self.afmr = value & 7;
    }

    /// A frame from the bus into the receive buffer (after acceptance); false (and data
    /// overrun) when both halves are full.
    pub fn receive(&mut self, frame: &CanFrame) -> bool {
        if !self.operating() {
            return false;
        }
        if self.rx.len() >= RX_DEPTH {
            self.overrun = true;
            self.overruns += 1;
            return false;
        }
        let data = frame.data();
        let mut bytes = [0u8; 8];
        bytes[..data.len()].copy_from_slice(data);
        let mut rfs = (u32::from(frame.dlc()) << 16) | RFS_BP;
        if frame.is_remote() {
            rfs |= FI_RTR;
        }
        self.rx.push_back([
            rfs,
            u32::from(frame.id()),
            u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
            u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]),
        ]);
        self.received += 1;
        true
    }

    /// The frames requested for transmission, handed to the bus now (in the order the
    /// controller would send them: lowest identifier first, MOD.TPM = 0). A buffer whose
    /// words are no CAN frame the bus carries is reported and stays requested.
    pub fn take_requests(&mut self) -> Vec<CanFrame> {
        if !self.operating() {
            return Vec::new();
        }
        let mut ready: Vec<(u32, usize, CanFrame)> = Vec::new();
        for n in 0..3 {
            if self.tx_state[n] != TxState::Requested {
                continue;
            }
            let [tfi, tid, tda, tdb] = self.tx[n];
            let dlc = ((tfi >> 16) & 0xF) as u8;
            let frame = if tfi & FI_FF != 0 {
                self.violation("29-bit frames (TFI.FF) are not modelled".into());
                None
            } else if tid > 0x7FF {
                self.violation(format!(
                    "TID{} = {tid:#x} is not an 11-bit identifier",
                    n + 1
                ));
                None
            } else if tfi & FI_RTR != 0 {
                CanFrame::remote(tid as u16, dlc.min(8)).ok()
            } else {
                let mut bytes = [0u8; 8];
                bytes[..4].copy_from_slice(&tda.to_le_bytes());
                bytes[4..].copy_from_slice(&tdb.to_le_bytes());
                CanFrame::new(tid as u16, &bytes[..usize::from(dlc.min(8))]).ok()
            };
            match frame {
                Some(f) => ready.push((
                    if self.mode & MOD_TPM != 0 {
                        tfi & 0xFF
                    } else {
                        tid
                    },
                    n,
                    f,
                )),
                None => continue,
            }
        }
        ready.sort_by_key(|(prio, n, _)| (*prio, *n));
        ready
            .into_iter()
            .map(|(_, n, f)| {
                self.tx_state[n] = TxState::OnBus;
                self.on_bus.push_back(n);
                f
            })
            .collect()
    }

    /// Whether a transmit buffer waits to be handed to the bus.
    pub fn has_requests(&self) -> bool {
        self.tx_state.contains(&TxState::Requested)
    }

    /// The oldest frame handed to the bus has been sent: its buffer is free again.
    pub fn transmitted(&mut self) {
        if let Some(n) = self.on_bus.pop_front() {
            self.tx_state[n] = TxState::Free;
            self.tx_complete[n] = true;
            self.sent += 1;
        }
    }

    fn status(&self) -> (u32, u32) {
        let rbs = u32::from(!self.rx.is_empty());
        let dos = u32::from(self.overrun) << 1;
        let mut sr = 0;
        for n in 0..3 {
            let tbs = u32::from(self.tx_state[n] == TxState::Free) << 2;
            let tcs = u32::from(self.tx_complete[n]) << 3;
            let ts = u32::from(self.tx_state[n] == TxState::OnBus) << 5;
            sr |= (rbs | dos | tbs | tcs | ts) << (8 * n);
        }
        let all_free = self.tx_state.iter().all(|s| *s == TxState::Free);
        let all_complete = self.tx_complete.iter().all(|c| *c);
        let ts = self.tx_state.contains(&TxState::OnBus);
        let gsr = rbs
            | dos
            | u32::from(all_free) << 2
            | u32::from(all_complete) << 3
            | u32::from(ts) << 5;
        (gsr, sr)
    }

    fn command(&mut self, value: u32) {
        if value & (CMR_AT | CMR_SRR) != 0 {
            self.violation(format!(
                "CMR {value:#x}: abort and self-reception requests are not modelled"
            ));
        }
        if value & CMR_RRB != 0 {
            self.rx.pop_front();
        }
        if value & CMR_CDO != 0 {
            self.overrun = false;
        }
        if value & CMR_TR != 0 {
            if !self.operating() {
                self.violation("transmission request in reset mode (MOD.RM = 1)".into());
                return;
            }
            let select = (value >> CMR_STB_SHIFT) & 7;
            if select == 0 {
                self.violation("CMR.TR without a transmit buffer selected (STB1..3)".into());
            }
            for n in 0..3 {
                if select & (1 << n) == 0 {
                    continue;
                }
                if self.tx_state[n] != TxState::Free {
                    self.violation(format!(
                        "transmission requested for buffer {} while it is not free (TBS{} = 0)",
                        n + 1,
                        n + 1
                    ));
                    continue;
                }
                self.tx_state[n] = TxState::Requested;
                self.tx_complete[n] = false;
            }
        }
    }
}

impl Peripheral for Can {
    fn read(&mut self, _t: Tick, offset: u32) -> u32 {
        let (gsr, sr) = self.status();
        let rx = self.rx.front().copied().unwrap_or_default();
        match offset {
            MOD => self.mode,
            GSR => gsr,
            ICR => u32::from(self.irq()),
            IER => self.ier,
            BTR => self.btr,
            EWL => self.ewl,
            SR => sr,
            RFS => rx[0],
            RID => rx[1],
            RDA => rx[2],
            RDB => rx[3],
            o if (TX_BASE..TX_BASE + 0x30).contains(&o) => {
                let n = ((o - TX_BASE) / 0x10) as usize;
                self.tx[n][((o % 0x10) / 4) as usize]
            }
            _ => 0,
        }
    }

    fn write(&mut self, _t: Tick, offset: u32, value: u32) {
        match offset {
            MOD => {
                if value & !(MOD_RM | MOD_TPM) != 0 {
                    self.violation(format!(
                        "MOD {value:#x}: listen-only, self-test, sleep and receive polarity are \
                         not modelled"
                    ));
                }
                self.mode = value & 0xFF;
                if !self.operating() {
                    // Reset mode: requests not yet on the bus are dropped.
                    for s in &mut self.tx_state {
                        if *s == TxState::Requested {
                            *s = TxState::Free;
                        }
                    }
                }
            }
            CMR => self.command(value),
            IER => {
                if value & !IER_RIE != 0 {
                    self.violation(format!(
                        "IER {value:#x}: interrupt sources other than RIE are not modelled"
                    ));
                }
                self.ier = value & 0x7FF;
            }
            BTR if self.operating() => {
                self.violation("BTR written in operating mode: ignored (reset mode only)".into())
            }
            BTR => self.btr = value & 0x00FF_C3FF,
            EWL => self.ewl = value & 0xFF,
            o if (TX_BASE..TX_BASE + 0x30).contains(&o) => {
                let n = ((o - TX_BASE) / 0x10) as usize;
                if self.tx_state[n] == TxState::Free {
                    self.tx[n][((o % 0x10) / 4) as usize] = value;
                } else {
                    self.violation(format!(
                        "transmit buffer {} written while it is not free (TBS{} = 0)",
                        n + 1,
                        n + 1
                    ));
                }
            }
            _ => self.violation(format!("write of {value:#x} to CAN1 offset {offset:#x}")),
        }
    }

    fn irq(&self) -> bool {
        self.operating() && self.ier & IER_RIE != 0 && !self.rx.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: Tick = Tick {
        now_ns: 0,
        pclk_hz: 100_000_000,
    };

    fn operating() -> Can {
        let mut c = Can::new();
        // 500 kbit/s: BRP 9 (10 clocks per tq), 20 tq (TSEG1 16, TSEG2 3).
        c.write(T, BTR, 9 | (15 << 16) | (2 << 20));
        c.write(T, MOD, 0);
        c
    }

    #[test]
    fn bit_rate_from_btr() {
        let c = operating();
        assert_eq!(c.bit_rate(100_000_000), 500_000);
        // Reset BTR: BRP 0, TSEG1 13, TSEG2 2: 16 tq of one PCLK.
        assert_eq!(Can::new().bit_rate(100_000_000), 100_000_000 / 16);
    }

    #[test]
    fn receive_buffer_holds_two_and_rrb_releases() {
        let mut c = operating();
        c.write(T, IER, IER_RIE);
        assert!(!c.irq());
        let f = |id| CanFrame::new(id, &[1, 2, 3, 4, 5]).unwrap();
        assert!(c.receive(&f(0x605)));
        assert!(c.receive(&f(0x000)));
        assert!(!c.receive(&f(0x080)), "third frame: overrun");
        assert!(c.irq());
        assert_eq!(c.read(T, GSR) & 3, 3, "RBS and DOS");
        assert_eq!(c.read(T, RFS), (5 << 16) | RFS_BP);
        assert_eq!(c.read(T, RID), 0x605);
        assert_eq!(c.read(T, RDA), 0x0403_0201);
        assert_eq!(c.read(T, RDB), 0x05);
        c.write(T, CMR, CMR_RRB | CMR_CDO);
        assert_eq!(c.read(T, RID), 0);
        assert_eq!(c.read(T, GSR) & 3, 1);
        c.write(T, CMR, CMR_RRB);
        assert!(!c.irq());
        assert_eq!(c.read(T, GSR) & 1, 0);
    }

    #[test]
    fn transmit_buffers_go_out_lowest_identifier_first() {
        let mut c = operating();
        for (n, id) in [(0u32, 0x705u32), (1, 0x185), (2, 0x085)] {
            c.write(T, TX_BASE + 0x10 * n, 2 << 16);
            c.write(T, TX_BASE + 0x10 * n + 4, id);
            c.write(T, TX_BASE + 0x10 * n + 8, 0xBBAA);
        }
        c.write(T, CMR, CMR_TR | (0b111 << CMR_STB_SHIFT));
        assert_eq!(c.read(T, SR) & 0x0004_0404, 0, "no buffer free");
        let ids: Vec<u16> = c.take_requests().iter().map(|f| f.id()).collect();
        assert_eq!(ids, vec![0x085, 0x185, 0x705]);
        assert!(c.take_requests().is_empty());
        c.transmitted();
        assert_eq!(
            c.read(T, SR) & (1 << 18),
            1 << 18,
            "buffer 3 free after its frame"
        );
        c.transmitted();
        c.transmitted();
        assert_eq!(c.read(T, GSR) & 0xC, 0xC, "TBS and TCS");
        assert_eq!(c.sent, 3);
        assert!(c.violations.is_empty(), "{:?}", c.violations);
    }

    #[test]
    fn reset_mode_and_filter_rules() {
        let mut c = Can::new();
        assert!(!c.receive(&CanFrame::new(1, &[]).unwrap()), "reset mode");
        assert!(c.accepts_all().is_err(), "AccOff after reset");
        c.set_afmr(AFMR_ACC_BP);
        assert!(c.accepts_all().is_ok());
        c.write(T, CMR, CMR_TR | (1 << CMR_STB_SHIFT));
        let mut c = operating();
        c.write(T, BTR, 0);
        assert_eq!(
            c.bit_rate(100_000_000),
            500_000,
            "BTR kept in operating mode"
        );
        assert!(!c.violations.is_empty());
    }
}
