//! PWM1 (UM10360 chapter 24; base 0x4001_8000): a timer with seven match registers that
//! drives the outputs PWM1.1..6. TC counts PCLK / (PR + 1) while TCR.enable and not
//! TCR.reset; on TC = MRn the MCR bits raise the interrupt flag, reset TC on the next tick or
//! stop the counter. In PWM mode (TCR.3) MR0 sets the period: a write to a match register goes
//! to its shadow, which becomes active at the start of the next PWM cycle (TC reset by MR0)
//! when its LER bit is set, so a period or an edge changes between cycles, never inside one.
//!
//! Outputs (PCR.PWMSELn selects double edge for n = 2..6, PCR.PWMENAn drives the pin):
//! a single-edge output goes high at the start of each cycle (unless its match value is 0)
//! and low at its MRn match; a double-edge output goes high at MR(n-1) and low at MRn. A
//! match value beyond MR0 never matches, so such an edge does not happen.
//!
//! The firmware's oversampling design (docs/book/oversampling.md) drives the AD5663's LDAC
//! from PWM1.4 on P2.3: one short low pulse per DAC update, its falling edge at MR4.
//! UNCONFIRMED (UM10360 does not say it in these words): the first cycle starts at the first
//! MR0 reset after the counter is enabled (single-edge outputs stay low for the first period);
//! when a set and a clear of a double-edge output fall on the same tick, the clear wins.

use super::{ns_to_ticks, ticks_to_ns, Peripheral, Tick};

/// Match registers MR0..MR6.
pub const MATCHES: usize = 7;

const TCR_ENABLE: u32 = 1;
const TCR_RESET: u32 = 2;
const TCR_PWM: u32 = 8;

/// An edge of one output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PwmEdge {
    /// Virtual time (ns).
    pub time_ns: u64,
    /// The output, 1..=6.
    pub output: u8,
    /// The new level.
    pub high: bool,
}

/// PWM1.
#[derive(Clone, Debug, Default)]
pub struct Pwm {
    ir: u32,
    tcr: u32,
    pr: u32,
    mcr: u32,
    mr: [u32; MATCHES],
    shadow: [u32; MATCHES],
    pcr: u32,
    ler: u32,
    ctcr: u32,
    pclk_hz: u64,
    /// Where TC was `anchor_tc` (a tick boundary).
    anchor_ns: u64,
    anchor_tc: u32,
    /// The anchor's TC value has had its matches.
    anchor_matched: bool,
    /// The next cycle starts here (TC reset by MR0).
    cycle_start_ns: Option<u64>,
    /// Output levels, bit n = PWM1.n.
    levels: u8,
    /// Output edges in order (what the pins would show where enabled).
    pub edges: Vec<PwmEdge>,
    /// Matches fired, per MR.
    pub matches: [u64; MATCHES],
    /// PWM cycles started.
    pub cycles: u64,
}

impl Pwm {
    /// Reset state.
    pub fn new() -> Self {
        Self::default()
    }

    fn running(&self) -> bool {
        self.tcr & TCR_ENABLE != 0 && self.tcr & TCR_RESET == 0 && self.pclk_hz != 0
    }

    fn tick_ns(&self, k: u64) -> u64 {
        ticks_to_ns(k * (u64::from(self.pr) + 1), self.pclk_hz)
    }

    /// TC at `now` (held at the anchor when stopped).
    pub fn tc_at(&self, now: u64) -> u32 {
        if !self.running() || now < self.anchor_ns {
            return self.anchor_tc;
        }
        let k = ns_to_ticks(now - self.anchor_ns, self.pclk_hz) / (u64::from(self.pr) + 1);
        self.anchor_tc.wrapping_add(k as u32)
    }

    /// The level of PWM1.`n` (1..=6), whether or not PCR drives the pin.
    pub fn level(&self, n: usize) -> bool {
        self.levels & (1 << n) != 0
    }

    /// PWM1.`n` (1..=6) as the pin shows it: `None` when PCR.PWMENAn leaves it undriven.
    pub fn output(&self, n: usize) -> Option<bool> {
        (self.pcr & (1 << (8 + n)) != 0).then(|| self.level(n))
    }

    fn double_edge(&self, n: usize) -> bool {
        (2..=6).contains(&n) && self.pcr & (1 << n) != 0
    }

    fn set_level(&mut self, at: u64, n: usize, high: bool) {
        if self.level(n) == high {
            return;
        }
        self.levels ^= 1 << n;
        self.edges.push(PwmEdge {
            time_ns: at,
            output: n as u8,
            high,
        });
    }

    /// The next instant something happens: a match or the start of a cycle.
    fn next_due(&self) -> Option<u64> {
        if !self.running() {
            return None;
        }
        let next_match = (0..MATCHES)
            .filter_map(|n| {
                let mut d = u64::from(self.mr[n].wrapping_sub(self.anchor_tc));
                if d == 0 && self.anchor_matched {
                    d = 1 << 32;
                }
                // In PWM mode TC never passes MR0: a larger value never matches.
                let beyond = self.tcr & TCR_PWM != 0 && n != 0 && self.mr[n] > self.mr[0];
                (!beyond).then_some(d)
            })
            .min()
            .map(|d| self.anchor_ns + self.tick_ns(d));
        match (next_match, self.cycle_start_ns) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn catch_up(&mut self, t: Tick) {
        if self.pclk_hz != t.pclk_hz {
            let tc = self.tc_at(t.now_ns);
            self.anchor_tc = tc;
            self.anchor_ns = t.now_ns;
            self.pclk_hz = t.pclk_hz;
        }
        while let Some(at) = self.next_due() {
            if at > t.now_ns {
                break;
            }
            if self.cycle_start_ns == Some(at) {
                self.cycle_start(at);
            } else {
                self.fire(at);
            }
        }
    }

    /// TC is 0 again: shadows with their LER bit set become active, single-edge outputs go
    /// high (those whose match value is not 0), and matches at 0 fire.
    fn cycle_start(&mut self, at: u64) {
        self.cycle_start_ns = None;
        self.cycles += 1;
        for n in 0..MATCHES {
            if self.ler & (1 << n) != 0 {
                self.mr[n] = self.shadow[n];
            }
        }
        self.ler = 0;
        for n in 1..=6 {
            if !self.double_edge(n) && self.mr[n] != 0 {
                self.set_level(at, n, true);
            }
        }
        self.anchor_ns = at;
        self.anchor_tc = 0;
        self.anchor_matched = false;
    }

    fn fire(&mut self, at: u64) {
        let tc = self.tc_at(at);
        self.anchor_ns = at;
        self.anchor_tc = tc;
        self.anchor_matched = true;
        let mut reset = false;
        let mut stop = false;
        let mut set = 0u8;
        let mut clear = 0u8;
        for n in 0..MATCHES {
            if self.mr[n] != tc {
                continue;
            }
            self.matches[n] += 1;
            let bits = self.mcr >> (3 * n);
            if bits & 1 != 0 {
                self.ir |= if n < 4 { 1 << n } else { 1 << (n + 4) };
            }
            reset |= bits & 2 != 0;
            stop |= bits & 4 != 0;
            if (1..=6).contains(&n) {
                clear |= 1 << n;
            }
            if n < 6 && self.double_edge(n + 1) {
                set |= 1 << (n + 1);
            }
        }
        for n in 1..=6 {
            if clear & (1 << n) != 0 {
                self.set_level(at, n, false);
            } else if set & (1 << n) != 0 {
                self.set_level(at, n, true);
            }
        }
        if stop {
            self.tcr &= !TCR_ENABLE;
        }
        if reset && !stop {
            self.cycle_start_ns = Some(at + self.tick_ns(1));
        }
    }

    fn write_match(&mut self, n: usize, value: u32) {
        self.shadow[n] = value;
        if self.tcr & TCR_PWM == 0 {
            self.mr[n] = value;
        }
    }
}

impl Peripheral for Pwm {
    fn read(&mut self, t: Tick, offset: u32) -> u32 {
        self.catch_up(t);
        match offset {
            0x00 => self.ir,
            0x04 => self.tcr,
            0x08 => self.tc_at(t.now_ns),
            0x0C => self.pr,
            0x14 => self.mcr,
            0x18..=0x24 => self.mr[((offset - 0x18) / 4) as usize],
            0x40..=0x48 => self.mr[((offset - 0x40) / 4) as usize + 4],
            0x4C => self.pcr,
            0x50 => self.ler,
            0x70 => self.ctcr,
            _ => 0,
        }
    }

    fn write(&mut self, t: Tick, offset: u32, value: u32) {
        self.catch_up(t);
        let now = t.now_ns;
        match offset {
            0x00 => self.ir &= !value,
            0x04 => {
                let tc = self.tc_at(now);
                self.tcr = value & (TCR_ENABLE | TCR_RESET | TCR_PWM);
                self.anchor_tc = if value & TCR_RESET != 0 { 0 } else { tc };
                self.anchor_ns = now;
                // A match needs TC to change to the value; starting at it is none.
                self.anchor_matched = true;
                self.pclk_hz = t.pclk_hz;
                if value & TCR_RESET != 0 {
                    self.cycle_start_ns = None;
                }
            }
            0x08 => {
                self.anchor_tc = value;
                self.anchor_ns = now;
                self.anchor_matched = true;
            }
            0x0C => {
                let tc = self.tc_at(now);
                self.pr = value;
                self.anchor_tc = tc;
                self.anchor_ns = now;
            }
            0x14 => self.mcr = value & 0x1F_FFFF,
            0x18..=0x24 => self.write_match(((offset - 0x18) / 4) as usize, value),
            0x40..=0x48 => self.write_match(((offset - 0x40) / 4) as usize + 4, value),
            0x4C => self.pcr = value & 0x7E7C,
            0x50 => self.ler = value & 0x7F,
            0x70 => self.ctcr = value & 0xF,
            _ => {}
        }
    }

    fn next_event(&self) -> Option<u64> {
        self.next_due()
    }

    fn on_event(&mut self, t: Tick) {
        self.catch_up(t);
    }

    fn irq(&self) -> bool {
        self.ir & 0x73F != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::periph::testing::{run_until, t};

    /// The LDAC waveform of the design: period 20 us (MR0 = 1999, reset), PWM1.4 single edge,
    /// low for the last 200 ns of each cycle (MR4 = 1980); the falling edges lie on the 20 us
    /// grid, 19.8 us after each cycle start.
    fn ldac_pwm(p: &mut Pwm) {
        p.write(t(0), 0x04, TCR_RESET);
        p.write(t(0), 0x18, 1_999);
        p.write(t(0), 0x40, 1_980);
        p.write(t(0), 0x14, 1 << 1); // MR0 resets
        p.write(t(0), 0x4C, 1 << 12); // PWMENA4, single edge
        p.write(t(0), 0x50, 0b1_0001); // latch MR0, MR4
        p.write(t(0), 0x04, TCR_ENABLE | TCR_PWM);
    }

    fn edges_of(p: &Pwm, output: u8, high: bool) -> Vec<u64> {
        p.edges
            .iter()
            .filter(|e| e.output == output && e.high == high)
            .map(|e| e.time_ns)
            .collect()
    }

    #[test]
    fn single_edge_output_falls_at_its_match_every_cycle() {
        let mut p = Pwm::new();
        ldac_pwm(&mut p);
        assert_eq!(
            p.output(4),
            Some(false),
            "nothing before the first cycle start"
        );
        run_until(&mut p, 100_000);
        // The first cycle starts at the first MR0 reset (20 us); each one rises at its
        // start and falls 200 ns before its end.
        assert_eq!(
            edges_of(&p, 4, true),
            [20_000, 40_000, 60_000, 80_000, 100_000]
        );
        assert_eq!(edges_of(&p, 4, false), [39_800, 59_800, 79_800, 99_800]);
        assert_eq!(p.output(1), None, "PWM1.1 not enabled");
        assert_eq!(p.cycles, 5);
    }

    /// A new period written in the middle of a cycle takes effect at the next cycle start
    /// (shadow + LER), so one cycle can be lengthened or shortened by a few ticks: the lock
    /// of the DAC grid to SYNC0.
    #[test]
    fn shadow_registers_take_effect_at_the_next_cycle() {
        let mut p = Pwm::new();
        ldac_pwm(&mut p);
        run_until(&mut p, 45_000);
        p.write(t(45_000), 0x18, 2_004); // the cycle from 60 us lasts 50 ns longer
        p.write(t(45_000), 0x50, 1);
        assert_eq!(p.read(t(45_000), 0x18), 1_999, "still active");
        run_until(&mut p, 65_000);
        assert_eq!(p.read(t(65_000), 0x18), 2_004, "active from 60 us");
        p.write(t(65_000), 0x18, 1_999); // and back from the cycle after it
        p.write(t(65_000), 0x50, 1);
        run_until(&mut p, 121_000);
        assert_eq!(
            edges_of(&p, 4, true),
            [20_000, 40_000, 60_000, 80_050, 100_050, 120_050]
        );
        assert_eq!(
            edges_of(&p, 4, false),
            [39_800, 59_800, 79_800, 99_850, 119_850]
        );
    }

    #[test]
    fn double_edge_output_and_match_interrupts() {
        let mut p = Pwm::new();
        p.write(t(0), 0x04, TCR_RESET);
        p.write(t(0), 0x18, 999);
        p.write(t(0), 0x1C, 100); // MR1: set PWM1.2
        p.write(t(0), 0x20, 300); // MR2: clear PWM1.2
        p.write(t(0), 0x14, 1 << 1 | 1 << 6); // MR0 resets, MR2 interrupts
        p.write(t(0), 0x4C, 1 << 2 | 1 << 10); // PWMSEL2 double edge, PWMENA2
        p.write(t(0), 0x50, 0b111);
        p.write(t(0), 0x04, TCR_ENABLE | TCR_PWM);
        run_until(&mut p, 25_000);
        let edges: Vec<(u64, bool)> = p
            .edges
            .iter()
            .filter(|e| e.output == 2)
            .map(|e| (e.time_ns, e.high))
            .collect();
        assert_eq!(
            edges,
            [
                (1_000, true),
                (3_000, false),
                (11_000, true),
                (13_000, false),
                (21_000, true),
                (23_000, false)
            ],
            "from the first period on: the matches set and clear it"
        );
        assert!(p.irq());
        assert_eq!(p.read(t(25_000), 0x00), 1 << 2);
        p.write(t(25_000), 0x00, 1 << 2);
        assert!(!p.irq());
        assert_eq!(p.cycles, 2);
    }

    #[test]
    fn outside_pwm_mode_matches_act_at_once_and_stop_stops() {
        let mut p = Pwm::new();
        p.write(t(0), 0x04, TCR_RESET);
        p.write(t(0), 0x18, 499);
        p.write(t(0), 0x14, 1 << 2 | 1); // MR0 stops the counter and interrupts
        p.write(t(0), 0x04, TCR_ENABLE);
        run_until(&mut p, 1_000_000);
        assert_eq!(p.read(t(1_000_000), 0x08), 499);
        assert_eq!(p.read(t(1_000_000), 0x04) & TCR_ENABLE, 0);
        assert_eq!(p.matches[0], 1);
        assert!(p.irq());
    }
}
