//! Distributed clocks: receive-time latching, system time with offset and delay, a
//! simple drift control on writes to 0x0910, and the SYNC0/SYNC1 cyclic unit
//! (ESC datasheet Section I ch. 9, Section II 0x0900..0x09FF).

use super::{regs, regs::al_event, Esc, Side};

/// Which SYNC output produced an edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SyncSignal {
    /// SYNC0.
    Sync0,
    /// SYNC1.
    Sync1,
}

/// A rising edge of a SYNC output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncEdge {
    /// Which output.
    pub signal: SyncSignal,
    /// Virtual time of the edge (ns).
    pub time_ns: u64,
    /// DC system time of the edge (ns).
    pub system_time_ns: u64,
}

/// A fault of the SYNC0 signal on its way from the ESC to the MCU (test switch; none by
/// default).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sync0Fault {
    /// No SYNC0 pulse reaches the MCU (a broken line or pin driver); the ESC's cyclic unit
    /// and its registers run on as configured.
    Missing,
    /// Every SYNC0 pulse reaches the MCU displaced from its nominal time by a pseudo-random
    /// amount in `-max_ns..=max_ns` (from `seed`; keep `max_ns` below half a cycle so the
    /// pulses stay in order).
    Jitter {
        /// Largest displacement (ns).
        max_ns: u64,
        /// Seed of the displacements.
        seed: u64,
    },
}

impl Sync0Fault {
    /// The displacement of SYNC0 pulse number `k` (ns).
    fn displacement(&self, k: u64) -> i64 {
        match *self {
            Self::Missing => 0,
            Self::Jitter { max_ns, seed } => {
                let span = 2 * max_ns + 1;
                (splitmix64(seed ^ k.wrapping_mul(0x9E37_79B9_7F4A_7C15)) % span) as i64
                    - max_ns as i64
            }
        }
    }
}

/// SplitMix64 (a fixed, well-mixed 64-bit sequence for reproducible displacements).
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[derive(Default)]
pub(super) struct DcState {
    /// System time latched by the first byte of a read of 0x0910 (per side).
    latch_ecat: u64,
    latch_pdi: u64,
    /// Drift-control correction added to the local clock (ns).
    correction: i64,
    /// Next SYNC0 pulse (system time) while the cyclic unit runs.
    next_sync0: Option<u64>,
    /// Next SYNC1 pulse (system time).
    next_sync1: Option<u64>,
    /// SYNC0 pulses generated so far.
    sync0_pulses: u64,
}

/// The SYNC1 period for SYNC0 cycle `cycle0` and SYNC1 "cycle time" `cycle1` (0x09A0,
/// 0x09A4; `None` in single-shot mode, SYNC0 cycle 0).
///
/// 0x09A4 is the delay D of a SYNC1 pulse after a SYNC0 pulse; the counter that measures it
/// restarts at the first SYNC0 pulse after the SYNC1 pulse, so SYNC1 repeats every
/// `(floor(D / T0) + 1) * T0` (ESC datasheet section I, "SYNC1 cycle"; SOEM's `ecx_dcsync01`
/// computes its start time from the same `TrueCyclTime`, Beckhoff's SSC counts SYNC0 events
/// per SyncManager cycle the same way; research notes "oversampling" section 6). A SYNC1
/// pulse every n SYNC0 pulses therefore needs D = (n - 1) * T0 (plus a shift below T0), the
/// value SOEM, IgH and ethercrab write for factor n; D = n * T0 gives n + 1.
pub fn sync1_period(cycle0: u64, cycle1: u64) -> Option<u64> {
    (cycle0 != 0).then(|| (cycle1 / cycle0 + 1) * cycle0)
}

impl Esc {
    /// The local clock of the ESC (ns), including drift-control correction.
    pub fn dc_local_time(&self) -> u64 {
        (self.now_ns + self.cfg.dc_local_start_ns).wrapping_add_signed(self.dc.correction)
    }

    /// The DC system time (local time + 0x0920 offset).
    pub fn dc_system_time(&self) -> u64 {
        self.dc_local_time()
            .wrapping_add(self.get_u64(regs::DC_SYSTEM_TIME_OFFSET))
    }

    pub(super) fn dc_read_system_time_byte(&mut self, side: Side, a: u16) -> u8 {
        let now = self.dc_system_time();
        let latch = match side {
            Side::Ecat => &mut self.dc.latch_ecat,
            Side::Pdi => &mut self.dc.latch_pdi,
        };
        if a == regs::DC_SYSTEM_TIME {
            *latch = now;
        }
        latch.to_le_bytes()[(a - regs::DC_SYSTEM_TIME) as usize]
    }

    /// A write to 0x0900 latched the receive times of all ports.
    pub(super) fn dc_latch_receive_times(&mut self) {
        let local = self.dc_local_time();
        // Port 0 receives the frame; it comes back through the closed ports 1..3 at once.
        let t = local as u32;
        self.set_u32(regs::DC_RECEIVE_TIME_PORT0, t);
        self.set_u32(0x0904, t.wrapping_add(40));
        self.set_u32(0x0908, t.wrapping_add(40));
        self.set_u32(0x090C, t.wrapping_add(40));
        self.set_u64(regs::DC_RECEIVE_TIME_PU, local);
    }

    /// A write to 0x0910 (FRMW from the reference clock, or a plain write): compare with
    /// the local copy of the system time and nudge the local clock (a simple control loop:
    /// at most 4 ns per write, like the ESC's rate-limited speed correction).
    pub(super) fn dc_system_time_written(&mut self, bytes: &[Option<u8>; 8]) {
        let mut own = self.dc_system_time().to_le_bytes();
        for (i, b) in bytes.iter().enumerate() {
            if let Some(b) = b {
                own[i] = *b;
            }
        }
        let received = u64::from_le_bytes(own);
        let wide = bytes[4..].iter().any(|b| b.is_some());
        let delay = self.peek_u32(regs::DC_SYSTEM_TIME_DELAY) as u64;
        let local_copy = self.dc_system_time();
        let expected = received.wrapping_add(delay);
        let diff: i64 = if wide {
            local_copy.wrapping_sub(expected) as i64
        } else {
            (local_copy as u32).wrapping_sub(expected as u32) as i32 as i64
        };
        let mag = diff.unsigned_abs().min(0x7FFF_FFFF) as u32;
        let reg = if diff < 0 { mag | 0x8000_0000 } else { mag };
        self.set_u32(regs::DC_SYSTEM_TIME_DIFF, reg);
        self.dc.correction -= diff.clamp(-4, 4);
    }

    /// 0x0981 was written: start or stop the cyclic unit.
    pub(super) fn dc_activation_written(&mut self) {
        let act = self.peek_u8(regs::DC_ACTIVATION);
        self.dc.next_sync0 = None;
        self.dc.next_sync1 = None;
        let mut status = 0u8;
        if act & 0x01 != 0 && act & 0x06 != 0 {
            let start = self.get_u64(regs::DC_START_TIME);
            let now = self.dc_system_time();
            if start < now {
                // A start time in the past: the unit waits (on the real chip for a
                // 32-bit wrap); the model never starts and flags it.
                status |= 0x04;
            } else {
                if act & 0x02 != 0 {
                    self.dc.next_sync0 = Some(start);
                    status |= 0x01;
                }
                if act & 0x04 != 0 {
                    // The first SYNC1 pulse follows the first SYNC0 pulse by 0x09A4.
                    let first = start + u64::from(self.peek_u32(regs::DC_SYNC1_CYCLE));
                    self.dc.next_sync1 = Some(first);
                    self.set_u64(regs::DC_NEXT_SYNC1, first);
                    status |= 0x02;
                }
            }
        }
        self.mem[regs::DC_ACTIVATION_STATUS as usize] = status;
    }

    /// System time at which the next SYNC0 pulse reaches the MCU (displaced by a fault).
    fn next_sync0_at_pin(&self) -> Option<u64> {
        let t = self.dc.next_sync0?;
        let d = self
            .sync0_fault
            .map_or(0, |f| f.displacement(self.dc.sync0_pulses));
        Some(t.saturating_add_signed(d))
    }

    /// Virtual time of the next SYNC edge.
    pub(super) fn dc_next_edge_time(&self) -> Option<u64> {
        let sys_now = self.dc_system_time();
        [self.next_sync0_at_pin(), self.dc.next_sync1]
            .into_iter()
            .flatten()
            .min()
            .map(|t| self.now_ns + t.saturating_sub(sys_now))
    }

    /// Fires the edges that are due at the current time.
    pub(super) fn dc_fire(&mut self, edges: &mut Vec<SyncEdge>) {
        let sys_now = self.dc_system_time();
        let cycle0 = self.peek_u32(regs::DC_SYNC0_CYCLE) as u64;
        let cycle1 = self.peek_u32(regs::DC_SYNC1_CYCLE) as u64;
        let cfg = self.peek_u8(regs::SYNC_LATCH_CONFIG);
        let due = self.next_sync0_at_pin().is_some_and(|at| at <= sys_now);
        if let Some(t) = self.dc.next_sync0.filter(|_| due) {
            self.dc.sync0_pulses += 1;
            if self.sync0_fault != Some(Sync0Fault::Missing) {
                edges.push(SyncEdge {
                    signal: SyncSignal::Sync0,
                    time_ns: self.now_ns,
                    system_time_ns: t,
                });
            }
            self.mem[regs::DC_SYNC0_STATUS as usize] = 1;
            if cfg & 0x08 != 0 {
                self.set_al_event(al_event::SYNC0);
            }
            self.mem[regs::DC_ACTIVATION_STATUS as usize] &= !0x01;
            self.dc.next_sync0 = (cycle0 != 0).then_some(t + cycle0);
            if let Some(n) = self.dc.next_sync0 {
                self.set_u64(regs::DC_START_TIME, n);
            }
        }
        if let Some(t) = self.dc.next_sync1.filter(|t| *t <= sys_now) {
            edges.push(SyncEdge {
                signal: SyncSignal::Sync1,
                time_ns: self.now_ns,
                system_time_ns: t,
            });
            self.mem[regs::DC_SYNC1_STATUS as usize] = 1;
            if cfg & 0x80 != 0 {
                self.set_al_event(al_event::SYNC1);
            }
            self.mem[regs::DC_ACTIVATION_STATUS as usize] &= !0x02;
            self.dc.next_sync1 = sync1_period(cycle0, cycle1).map(|p| t + p);
            if let Some(n) = self.dc.next_sync1 {
                self.set_u64(regs::DC_NEXT_SYNC1, n);
            }
        }
    }
}
