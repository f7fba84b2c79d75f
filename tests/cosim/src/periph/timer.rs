//! TIMER0..3 (UM10360 chapter 21; bases 0x4000_4000, 0x4000_8000, 0x4009_0000,
//! 0x4009_4000): TC counts PCLK / (PR + 1) while TCR.enable and not TCR.reset; on TC = MRn
//! the MCR bits interrupt (IR), reset TC on the next tick or stop the counter, EMR drives the
//! MATn.m output (nothing/clear/set/toggle); CCR captures TC into CRn on CAPn.m edges.
//! Matches of MR0 and MR1 also raise DMA requests, which [`crate::machine`] routes through
//! DMAREQSEL to the GPDMA.

use super::{ns_to_ticks, ticks_to_ns, Peripheral, Tick};

/// How a timer's DMA request behaves where UM10360 is silent (UNCONFIRMED, the same
/// assumption as the firmware's `hw::adc_dma::unconfirmed`): a match request is held until
/// the GPDMA services it, and writing the MRn flag of IR clears it.
pub mod unconfirmed {
    /// Whether a match request stays pending until serviced.
    pub const REQUEST_HELD: bool = true;
}

/// One timer.
#[derive(Clone, Debug, Default)]
pub struct Timer {
    ir: u32,
    tcr: u32,
    pr: u32,
    mcr: u32,
    mr: [u32; 4],
    ccr: u32,
    cr: [u32; 2],
    emr: u32,
    ctcr: u32,
    anchor_ns: u64,
    anchor_tc: u32,
    anchor_matched: bool,
    held_tc: u32,
    pclk_hz: u64,
    dma_request: [bool; 2],
    /// CRn holds a capture no read has taken and whose interrupt is not acknowledged.
    cr_unread: [bool; 2],
    /// Matches fired, per MR.
    pub matches: [u64; 4],
    /// Captures into CRn, per n.
    pub captures: [u64; 2],
    /// Captures overwritten by the next one before a read of CRn took them or the CPU
    /// acknowledged their interrupt (IR): edges no handler served.
    pub captures_unread: [u64; 2],
    /// [`Timer::next_match`] as of the last change (asked for after every access).
    next: Option<(u64, u32)>,
}

impl Timer {
    /// Reset state.
    pub fn new() -> Self {
        Self::default()
    }

    fn running(&self) -> bool {
        self.tcr & 1 != 0 && self.tcr & 2 == 0
    }

    fn tick_ns(&self, k: u64) -> u64 {
        ticks_to_ns(k * (u64::from(self.pr) + 1), self.pclk_hz)
    }

    /// TC at `now`.
    pub fn tc_at(&self, now: u64) -> u32 {
        if !self.running() {
            return self.anchor_tc;
        }
        if now < self.anchor_ns {
            return self.held_tc;
        }
        let k = ns_to_ticks(now - self.anchor_ns, self.pclk_hz) / (u64::from(self.pr) + 1);
        self.anchor_tc.wrapping_add(k as u32)
    }

    /// The last tick boundary at or before `now` and TC there (the anchor moved forward
    /// without changing the tick phase).
    fn aligned(&self, now: u64) -> (u64, u32) {
        if !self.running() || now < self.anchor_ns || self.pclk_hz == 0 {
            return (now.max(self.anchor_ns), self.tc_at(now));
        }
        let k = ns_to_ticks(now - self.anchor_ns, self.pclk_hz) / (u64::from(self.pr) + 1);
        (
            self.anchor_ns + self.tick_ns(k),
            self.anchor_tc.wrapping_add(k as u32),
        )
    }

    fn rebase(&mut self, t: Tick) {
        if self.pclk_hz != t.pclk_hz || !self.running() {
            let (at, tc) = self.aligned(t.now_ns);
            self.anchor_tc = tc;
            self.anchor_ns = at;
            self.anchor_matched = false;
            self.pclk_hz = t.pclk_hz;
        }
    }

    /// The next match instant, if running.
    fn next_match(&self) -> Option<(u64, u32)> {
        self.next
    }

    /// Recomputes [`Timer::next_match`] after a change.
    fn changed(&mut self) {
        self.next = self.compute_next_match();
    }

    fn compute_next_match(&self) -> Option<(u64, u32)> {
        if !self.running() || self.pclk_hz == 0 {
            return None;
        }
        let mut best: Option<u64> = None;
        for n in 0..4 {
            let mut d = u64::from(self.mr[n].wrapping_sub(self.anchor_tc));
            if d == 0 && self.anchor_matched {
                d = 1 << 32;
            }
            best = Some(best.map_or(d, |b| b.min(d)));
        }
        let d = best?;
        Some((
            self.anchor_ns + self.tick_ns(d),
            self.anchor_tc.wrapping_add(d as u32),
        ))
    }

    fn catch_up(&mut self, t: Tick) {
        // Nothing due and nothing to re-anchor: the cached next match stands (the common
        // case: every event of the chip asks every timer).
        if self.running()
            && self.pclk_hz == t.pclk_hz
            && self.next.is_none_or(|(at, _)| at > t.now_ns)
        {
            return;
        }
        while let Some((at, tc)) = self.compute_next_match() {
            if at > t.now_ns {
                break;
            }
            self.fire(at, tc);
        }
        self.rebase(t);
        self.changed();
    }

    fn fire(&mut self, at: u64, tc: u32) {
        self.anchor_ns = at;
        self.anchor_tc = tc;
        self.anchor_matched = true;
        let mut reset = false;
        let mut stop = false;
        for n in 0..4 {
            if self.mr[n] != tc {
                continue;
            }
            self.matches[n] += 1;
            let bits = self.mcr >> (3 * n);
            if bits & 1 != 0 {
                self.ir |= 1 << n;
            }
            reset |= bits & 2 != 0;
            stop |= bits & 4 != 0;
            let em = 1 << n;
            match (self.emr >> (4 + 2 * n)) & 3 {
                1 => self.emr &= !em,
                2 => self.emr |= em,
                3 => self.emr ^= em,
                _ => {}
            }
            if n < 2 {
                self.dma_request[n] = true;
            }
        }
        if stop {
            self.tcr &= !1;
        }
        if reset {
            // TC shows the match value for one more tick, then 0.
            self.held_tc = tc;
            self.anchor_ns = at + self.tick_ns(1);
            self.anchor_tc = 0;
            self.anchor_matched = false;
        }
    }

    /// EMn: the level of MATn.m.
    pub fn match_output(&self, n: usize) -> bool {
        self.emr & (1 << n) != 0
    }

    /// A level change on CAPn.m at `t`: captures on an enabled edge.
    pub fn capture(&mut self, t: Tick, n: usize, rising: bool) {
        self.catch_up(t);
        let bits = self.ccr >> (3 * n);
        let edge = if rising { bits & 1 } else { bits & 2 };
        if edge != 0 {
            self.captures[n] += 1;
            if self.cr_unread[n] {
                self.captures_unread[n] += 1;
            }
            self.cr_unread[n] = true;
            self.cr[n] = self.tc_at(t.now_ns);
            if bits & 4 != 0 {
                self.ir |= 1 << (4 + n);
            }
        }
    }

    /// The DMA request of MRn (n = 0, 1), taken by the GPDMA.
    pub fn dma_request(&self, n: usize) -> bool {
        self.dma_request[n]
    }

    /// The GPDMA served the request of MRn.
    pub fn clear_dma_request(&mut self, n: usize) {
        self.dma_request[n] = false;
    }
}

impl Peripheral for Timer {
    fn read(&mut self, t: Tick, offset: u32) -> u32 {
        self.catch_up(t);
        match offset {
            0x00 => self.ir,
            0x04 => self.tcr,
            0x08 => self.tc_at(t.now_ns),
            0x0C => self.pr,
            0x10 => 0, // PC: the prescale phase is not kept
            0x14 => self.mcr,
            0x18..=0x24 => self.mr[((offset - 0x18) / 4) as usize],
            0x28 => self.ccr,
            0x2C | 0x30 => {
                let n = ((offset - 0x2C) / 4) as usize;
                self.cr_unread[n] = false;
                self.cr[n]
            }
            0x3C => self.emr,
            0x70 => self.ctcr,
            _ => 0,
        }
    }

    fn write(&mut self, t: Tick, offset: u32, value: u32) {
        self.catch_up(t);
        let now = t.now_ns;
        match offset {
            0x00 => {
                self.ir &= !value;
                for n in 0..2 {
                    if value & (1 << (4 + n)) != 0 {
                        self.cr_unread[n] = false;
                    }
                }
                if !unconfirmed::REQUEST_HELD || value & 3 != 0 {
                    for n in 0..2 {
                        if value & (1 << n) != 0 {
                            self.dma_request[n] = false;
                        }
                    }
                }
            }
            0x04 => {
                let tc = self.tc_at(now);
                self.tcr = value & 3;
                self.anchor_tc = if value & 2 != 0 { 0 } else { tc };
                self.anchor_ns = now;
                // A match needs TC to change to the value; starting at it is none.
                self.anchor_matched = true;
                self.pclk_hz = t.pclk_hz;
            }
            0x08 => {
                self.anchor_tc = value;
                self.anchor_ns = now;
                self.anchor_matched = true;
            }
            0x0C => {
                let (at, tc) = self.aligned(now);
                self.pr = value;
                self.anchor_tc = tc;
                self.anchor_ns = at;
            }
            0x14 => self.mcr = value & 0xFFF,
            0x18..=0x24 => {
                self.mr[((offset - 0x18) / 4) as usize] = value;
                if now >= self.anchor_ns {
                    // Re-anchor so a match just written at the current TC is not lost or
                    // fired twice.
                    let (at, tc) = self.aligned(now);
                    self.anchor_tc = tc;
                    self.anchor_ns = at;
                    self.anchor_matched = self.mr.contains(&tc);
                }
            }
            0x28 => self.ccr = value & 0x3F,
            0x3C => self.emr = value & 0xFFF,
            0x70 => self.ctcr = value & 0xF,
            _ => {}
        }
        self.changed();
    }

    fn next_event(&self) -> Option<u64> {
        self.next_match().map(|(at, _)| at)
    }

    fn on_event(&mut self, t: Tick) {
        self.catch_up(t);
    }

    fn irq(&self) -> bool {
        self.ir & 0x3F != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periph::testing::{run_until, t};

    /// Timer2 as the ADC DMA path sets it up: MR3 resets every 400 ticks, MR0 toggles
    /// MAT2.0, MR0/MR1 request DMA.
    #[test]
    fn period_reset_toggle_and_dma_requests() {
        let mut tm = Timer::new();
        tm.write(t(0), 0x04, 2);
        tm.write(t(0), 0x18, 1);
        tm.write(t(0), 0x1C, 233);
        tm.write(t(0), 0x24, 399);
        tm.write(t(0), 0x14, 1 << 10);
        tm.write(t(0), 0x3C, 0b11 << 4);
        tm.write(t(0), 0x04, 1);
        assert_eq!(tm.next_event(), Some(10));
        run_until(&mut tm, 10);
        assert!(tm.match_output(0) && tm.dma_request(0));
        tm.clear_dma_request(0);
        run_until(&mut tm, 2330);
        assert!(tm.dma_request(1));
        run_until(&mut tm, 3990);
        assert_eq!(tm.read(t(3995), 0x08), 399, "MR3 holds for one tick");
        assert_eq!(tm.read(t(4000), 0x08), 0, "then TC is 0");
        run_until(&mut tm, 4010);
        assert!(!tm.match_output(0), "toggled again one period later");
        // MR2 = 0 matches when the MR3 reset brings TC to 0 (not when the timer starts).
        assert_eq!(tm.matches, [2, 1, 1, 1]);
        assert!(!tm.irq(), "no MCR interrupt bits");
    }

    /// Timer0 as the oversampling design's DAC frame timer (docs/book/oversampling.md):
    /// period Q = P / 4 (MR3 resets), MR0 = 0 toggles MAT0.0 (the AD5663's SYNC) at each
    /// quarter start and requests DMA (the frame's first 12-bit item), MR1 = Q / 2 requests
    /// DMA (the second item). SYNC is low in quarters 0 and 2 of every update, high in 1 and 3.
    #[test]
    fn quarter_timer_toggles_sync_and_requests_two_items_per_quarter() {
        let q = 500u32; // 5 us: P = 20 us, 50 kHz
        let mut tm = Timer::new();
        tm.write(t(0), 0x04, 2);
        tm.write(t(0), 0x18, 0);
        tm.write(t(0), 0x1C, q / 2);
        tm.write(t(0), 0x24, q - 1);
        tm.write(t(0), 0x14, 1 << 10); // MR3 resets
        tm.write(t(0), 0x3C, 1 | 0b11 << 4); // EM0 = 1 (SYNC idle high), toggle on MR0
        tm.write(t(0), 0x04, 1);
        let mut sync = Vec::new();
        let mut requests = Vec::new();
        while let Some(e) = tm.next_event() {
            if e > 40_000 {
                break;
            }
            tm.on_event(t(e));
            for n in 0..2 {
                if tm.dma_request(n) {
                    requests.push((e, n));
                    tm.clear_dma_request(n);
                }
            }
            if sync.last().map(|&(_, l)| l) != Some(tm.match_output(0)) {
                sync.push((e, tm.match_output(0)));
            }
        }
        // MR0 = 0 matches each time MR3 brings TC to 0: at 5, 10, 15 ... us.
        let first: Vec<(u64, bool)> = sync.iter().copied().take(5).collect();
        assert_eq!(
            first,
            [
                (2_500, true),
                (5_000, false),
                (10_000, true),
                (15_000, false),
                (20_000, true)
            ]
        );
        let per_quarter: Vec<(u64, usize)> = requests.iter().copied().skip(1).take(4).collect();
        assert_eq!(
            per_quarter,
            [(5_000, 0), (7_500, 1), (10_000, 0), (12_500, 1)]
        );
    }

    #[test]
    fn capture_and_wrap_interrupt() {
        let mut tm = Timer::new();
        tm.write(t(0), 0x04, 2);
        tm.write(t(0), 0x18, u32::MAX);
        tm.write(t(0), 0x14, 1);
        tm.write(t(0), 0x28, 0b101);
        tm.write(t(0), 0x04, 1);
        tm.capture(t(12_345), 0, false);
        assert!(!tm.irq(), "falling edge not enabled");
        tm.capture(t(12_345), 0, true);
        assert_eq!(tm.read(t(20_000), 0x2C), 1234);
        tm.capture(t(30_000), 0, true);
        tm.capture(t(40_000), 0, true);
        assert_eq!(
            (tm.captures[0], tm.captures_unread[0]),
            (3, 1),
            "the second unread"
        );
        assert_eq!(tm.read(t(40_000), 0x2C), 4000);
        assert_eq!(tm.read(t(20_000), 0x00), 1 << 4);
        tm.write(t(20_000), 0x00, 1 << 4);
        let wrap = tm.next_event().unwrap();
        assert_eq!(wrap, 42_949_672_950);
        tm.on_event(t(wrap));
        assert_eq!(tm.read(t(wrap), 0x00), 1);
    }
}
