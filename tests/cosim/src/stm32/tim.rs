//! TIM2..5 / TIM1, TIM8 (RM0008 chapters 14 and 15), as far as the board uses them: the
//! up-counter (PSC, buffered until the update event; ARR), the update event (overflow or
//! UG), per channel output compare (frozen, active/inactive/toggle on match, forced levels,
//! PWM 1/2) with its polarity and enable (and MOE on the advanced timers), input capture
//! from TIx on the edge the polarity selects (with over-capture), the CCxIF/UIF flags
//! (rc_w0), the interrupt enables, and the DMA requests of the compare/capture events
//! (CCxDE: one request per event, whatever the flag). Centre-aligned and down counting,
//! slave modes, the repetition counter and the break input are not modelled.

use crate::periph::{ns_to_ticks, ticks_to_ns, Tick};

const CR1: u32 = 0x00;
const CR2: u32 = 0x04;
const SMCR: u32 = 0x08;
const DIER: u32 = 0x0C;
const SR: u32 = 0x10;
const EGR: u32 = 0x14;
const CCMR1: u32 = 0x18;
const CCMR2: u32 = 0x1C;
const CCER: u32 = 0x20;
const CNT: u32 = 0x24;
const PSC: u32 = 0x28;
const ARR: u32 = 0x2C;
const RCR: u32 = 0x30;
const CCR1: u32 = 0x34;
const CCR4: u32 = 0x40;
const BDTR: u32 = 0x44;
const DCR: u32 = 0x48;

const CEN: u32 = 1 << 0;
const UIF: u32 = 1 << 0;
const MOE: u32 = 1 << 15;

/// A timer.
#[derive(Clone, Debug)]
pub struct Tim {
    advanced: bool,
    cr1: u32,
    cr2: u32,
    smcr: u32,
    dier: u32,
    sr: u32,
    ccmr: [u32; 2],
    ccer: u32,
    psc: u32,
    psc_active: u32,
    arr: u32,
    ccr: [u32; 4],
    bdtr: u32,
    /// The counter's value while stopped.
    cnt_stopped: u32,
    /// Running: the time of tick 0 and the counter's value then.
    start: Option<(u64, u32)>,
    /// Ticks since the start whose events are done.
    served: u64,
    /// The timer's clock (Hz) at the last access or event.
    clock_hz: u64,
    oc_ref: [bool; 4],
    dma_request: [bool; 4],
    /// Captures overwritten before the CPU read them (CCxOF).
    pub overcaptures: u64,
}

impl Tim {
    /// A timer at reset (`advanced`: TIM1/TIM8, with BDTR.MOE).
    pub fn new(advanced: bool) -> Self {
        Self {
            advanced,
            cr1: 0,
            cr2: 0,
            smcr: 0,
            dier: 0,
            sr: 0,
            ccmr: [0; 2],
            ccer: 0,
            psc: 0,
            psc_active: 0,
            arr: 0xFFFF,
            ccr: [0; 4],
            bdtr: 0,
            cnt_stopped: 0,
            start: None,
            served: 0,
            clock_hz: 1,
            oc_ref: [false; 4],
            dma_request: [false; 4],
            overcaptures: 0,
        }
    }

    fn period(&self) -> u64 {
        u64::from(self.arr) + 1
    }

    fn tick_hz_num(&self) -> u64 {
        self.clock_hz.max(1)
    }

    /// Ticks since the start at `now`.
    fn ticks_at(&self, now: u64) -> u64 {
        match self.start {
            Some((t0, _)) => {
                ns_to_ticks(now.saturating_sub(t0), self.tick_hz_num())
                    / (u64::from(self.psc_active) + 1)
            }
            None => 0,
        }
    }

    /// The time of tick `k` since the start.
    fn tick_time(&self, k: u64) -> u64 {
        let t0 = self.start.map_or(0, |s| s.0);
        t0 + ticks_to_ns(k * (u64::from(self.psc_active) + 1), self.tick_hz_num())
    }

    fn cnt_of_tick(&self, k: u64) -> u32 {
        let c0 = self.start.map_or(self.cnt_stopped, |s| s.1);
        ((u64::from(c0) + k) % self.period()) as u32
    }

    /// CNT at `now`.
    pub fn cnt(&self, now: u64) -> u32 {
        match self.start {
            Some(_) => self.cnt_of_tick(self.ticks_at(now)),
            None => self.cnt_stopped,
        }
    }

    fn channel_bits(&self, ch: usize) -> u32 {
        (self.ccmr[ch / 2] >> (8 * (ch % 2))) & 0xFF
    }

    fn is_input(&self, ch: usize) -> bool {
        self.channel_bits(ch) & 3 != 0
    }

    fn oc_mode(&self, ch: usize) -> u32 {
        (self.channel_bits(ch) >> 4) & 7
    }

    /// Counter values whose tick has an effect: the update (0) and the compare values of
    /// the output channels that act on a match.
    fn interests(&self) -> Vec<u32> {
        let mut v = Vec::new();
        let pwm_or_oc =
            (0..4).any(|ch| !self.is_input(ch) && matches!(self.oc_mode(ch), 1..=3 | 6 | 7));
        if self.dier & (UIF | 1 << 8) != 0 || pwm_or_oc || self.psc != self.psc_active {
            v.push(0);
        }
        for ch in 0..4 {
            let acts = !self.is_input(ch)
                && (matches!(self.oc_mode(ch), 1..=3 | 6 | 7)
                    || self.dier & (0x2 << ch | 0x200 << ch) != 0);
            if acts && self.ccr[ch] <= self.arr {
                v.push(self.ccr[ch]);
            }
        }
        v
    }

    fn next_interest_tick(&self) -> Option<u64> {
        self.start?;
        let p = self.period();
        let c0 = u64::from(self.start.map_or(0, |s| s.1));
        self.interests()
            .into_iter()
            .map(|v| {
                let first = self.served + 1;
                let at = (c0 + first) % p;
                first + (u64::from(v) + p - at) % p
            })
            .min()
    }

    /// The next instant something happens on its own.
    pub fn next_event(&self) -> Option<u64> {
        self.next_interest_tick().map(|k| self.tick_time(k))
    }

    /// Serves the ticks due at `t`.
    pub fn on_event(&mut self, t: Tick) {
        self.clock_hz = t.pclk_hz;
        let now_ticks = self.ticks_at(t.now_ns);
        for _ in 0..1024 {
            let Some(k) = self.next_interest_tick() else {
                break;
            };
            if k > now_ticks {
                break;
            }
            self.served = k;
            let v = self.cnt_of_tick(k);
            if v == 0 {
                self.sr |= UIF;
                if self.psc != self.psc_active {
                    // The buffered prescaler takes effect: the ticks restart here.
                    let at = self.tick_time(k);
                    self.psc_active = self.psc;
                    self.start = Some((at, 0));
                    self.served = 0;
                }
            }
            for ch in 0..4 {
                if self.is_input(ch) || self.ccr[ch] != v {
                    continue;
                }
                self.sr |= 0x2 << ch;
                if self.dier & 0x200 << ch != 0 {
                    self.dma_request[ch] = true;
                }
                match self.oc_mode(ch) {
                    1 => self.oc_ref[ch] = true,
                    2 => self.oc_ref[ch] = false,
                    3 => self.oc_ref[ch] = !self.oc_ref[ch],
                    _ => {}
                }
            }
        }
    }

    /// An edge on TIx of channel `ch` (`rising`) at `t`: a capture if the channel is an
    /// enabled input capture of that edge.
    pub fn capture(&mut self, t: Tick, ch: usize, rising: bool) -> bool {
        self.clock_hz = t.pclk_hz;
        let enabled = self.ccer & 1 << (4 * ch) != 0;
        let falling_selected = self.ccer & 2 << (4 * ch) != 0;
        if !self.is_input(ch) || !enabled || rising == falling_selected {
            return false;
        }
        self.ccr[ch] = self.cnt(t.now_ns);
        if self.sr & 0x2 << ch != 0 {
            self.sr |= 0x200 << ch;
            self.overcaptures += 1;
        }
        self.sr |= 0x2 << ch;
        if self.dier & 0x200 << ch != 0 {
            self.dma_request[ch] = true;
        }
        true
    }

    /// Channel `ch`'s output level, `None` while it drives nothing (an input, CCxE off, or
    /// MOE off on an advanced timer).
    pub fn output(&self, ch: usize, now: u64) -> Option<bool> {
        if self.is_input(ch) || self.ccer & 1 << (4 * ch) == 0 {
            return None;
        }
        if self.advanced && self.bdtr & MOE == 0 {
            return None;
        }
        let cnt = self.cnt(now);
        let r = match self.oc_mode(ch) {
            4 => false,
            5 => true,
            6 => cnt < self.ccr[ch],
            7 => cnt >= self.ccr[ch],
            _ => self.oc_ref[ch],
        };
        let inverted = self.ccer & 2 << (4 * ch) != 0;
        Some(r != inverted)
    }

    /// Whether channel `ch` requests DMA.
    pub fn dma_request(&self, ch: usize) -> bool {
        self.dma_request[ch]
    }

    /// The DMA served channel `ch`'s request.
    pub fn clear_dma_request(&mut self, ch: usize) {
        self.dma_request[ch] = false;
    }

    /// The capture/compare interrupt (TIM8_CC: CC1..4).
    pub fn irq_cc(&self) -> bool {
        self.sr & self.dier & 0x1E != 0
    }

    /// The global interrupt (TIM2..5: update, CC1..4, trigger).
    pub fn irq(&self) -> bool {
        self.sr & self.dier & 0x5F != 0
    }

    fn restart(&mut self, now: u64, cnt: u32) {
        self.start = Some((now, cnt));
        self.served = 0;
    }

    /// A register read.
    pub fn read(&mut self, t: Tick, offset: u32) -> u32 {
        self.clock_hz = t.pclk_hz;
        match offset {
            CR1 => self.cr1,
            CR2 => self.cr2,
            SMCR => self.smcr,
            DIER => self.dier,
            SR => self.sr,
            CCMR1 => self.ccmr[0],
            CCMR2 => self.ccmr[1],
            CCER => self.ccer,
            CNT => self.cnt(t.now_ns),
            PSC => self.psc,
            ARR => self.arr,
            CCR1..=CCR4 => {
                let ch = ((offset - CCR1) / 4) as usize;
                if self.is_input(ch) {
                    // Reading the capture clears its flag.
                    self.sr &= !(0x2 << ch);
                }
                self.ccr[ch]
            }
            BDTR if self.advanced => self.bdtr,
            _ => 0,
        }
    }

    /// A register write.
    pub fn write(&mut self, t: Tick, offset: u32, value: u32) {
        self.clock_hz = t.pclk_hz;
        let now = t.now_ns;
        match offset {
            CR1 => {
                let was = self.cr1 & CEN != 0;
                self.cr1 = value & 0x3FF;
                let on = self.cr1 & CEN != 0;
                if on && !was {
                    let c = self.cnt_stopped;
                    self.restart(now, c);
                } else if !on && was {
                    self.cnt_stopped = self.cnt(now);
                    self.start = None;
                }
            }
            CR2 => self.cr2 = value,
            SMCR => self.smcr = value,
            DIER => self.dier = value & 0x7FFF,
            // rc_w0.
            SR => self.sr &= value,
            EGR => {
                if value & 1 != 0 {
                    self.psc_active = self.psc;
                    self.sr |= UIF;
                    self.cnt_stopped = 0;
                    if self.start.is_some() {
                        self.restart(now, 0);
                    }
                }
                for ch in 0..4 {
                    if value & 0x2 << ch != 0 {
                        if self.is_input(ch) {
                            self.ccr[ch] = self.cnt(now);
                        }
                        self.sr |= 0x2 << ch;
                    }
                }
            }
            CCMR1 | CCMR2 => self.ccmr[((offset - CCMR1) / 4) as usize] = value & 0xFFFF,
            CCER => self.ccer = value & 0xFFFF,
            CNT => {
                self.cnt_stopped = value & 0xFFFF;
                if self.start.is_some() {
                    self.restart(now, value & 0xFFFF);
                }
            }
            PSC => self.psc = value & 0xFFFF,
            ARR | CCR1..=CCR4 => {
                // A change while counting: the counter goes on from where it is.
                let running = self.start.is_some().then(|| {
                    let k = self.ticks_at(now);
                    (self.tick_time(k), self.cnt_of_tick(k))
                });
                if offset == ARR {
                    self.arr = value & 0xFFFF;
                } else {
                    self.ccr[((offset - CCR1) / 4) as usize] = value & 0xFFFF;
                }
                if let Some((at, c)) = running {
                    self.restart(at, c % (self.arr + 1));
                }
            }
            RCR | DCR => {}
            BDTR if self.advanced => self.bdtr = value & 0xFFFF,
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(now_ns: u64) -> Tick {
        Tick {
            now_ns,
            pclk_hz: 72_000_000,
        }
    }

    fn run_until(tim: &mut Tim, until: u64) -> Vec<u64> {
        let mut at = Vec::new();
        while let Some(e) = tim.next_event() {
            if e > until {
                break;
            }
            tim.on_event(t(e));
            at.push(e);
        }
        at
    }

    #[test]
    fn pwm_mode_1_output_and_compare_dma_requests_each_period() {
        // TIM3 as the board runs it: 360 ticks (5 us), CH3 PWM 1 high until 166, CH4's
        // compare at 168 requests DMA.
        let mut tim = Tim::new(false);
        tim.write(t(0), ARR, 359);
        tim.write(t(0), CCR1 + 8, 166);
        tim.write(t(0), CCR4, 168);
        tim.write(t(0), CCMR2, 0b110 << 4 | 1 << 3);
        tim.write(t(0), CCER, 1 << 8);
        tim.write(t(0), DIER, 1 << 12);
        tim.write(t(0), EGR, 1);
        tim.write(t(1000), CR1, CEN);
        assert_eq!(tim.output(2, 1000), Some(true), "CNV high from the update");
        let events = run_until(&mut tim, 1000 + 5_000);
        // CC3 (166 ticks = 2306 ns), CC4 (168: 2334 ns), the update at 360 (5000 ns).
        assert_eq!(events, vec![3306, 3334, 6000]);
        assert_eq!(tim.output(2, 3306), Some(false));
        assert!(tim.dma_request(3));
        tim.clear_dma_request(3);
        run_until(&mut tim, 1000 + 10_000);
        assert!(tim.dma_request(3), "every period");
        assert_eq!(tim.output(2, 6000), Some(true));
    }

    #[test]
    fn capture_on_the_rising_edge_with_overcapture_and_forced_outputs() {
        // TIM8: CH1 capture of TI1 rising, CH2 forced, MOE.
        let mut tim = Tim::new(true);
        tim.write(t(0), CCMR1, 0b01 | 0b101 << 12);
        tim.write(t(0), CCER, 1 | 1 << 4);
        tim.write(t(0), DIER, 1 << 1);
        tim.write(t(0), CR1, CEN);
        assert_eq!(tim.output(1, 0), None, "MOE off: CH2 drives nothing");
        tim.write(t(0), BDTR, MOE);
        assert_eq!(tim.output(1, 0), Some(true));
        tim.write(t(0), CCMR1, 0b01 | 0b100 << 12);
        assert_eq!(tim.output(1, 0), Some(false));
        assert!(!tim.capture(t(1000), 0, false), "falling edge not selected");
        assert!(tim.capture(t(1000), 0, true));
        assert!(tim.irq_cc());
        assert_eq!(tim.read(t(1100), CCR1), 72);
        assert!(!tim.irq_cc(), "reading CCR1 clears CC1IF");
        tim.capture(t(2000), 0, true);
        tim.capture(t(3000), 0, true);
        assert_eq!(tim.overcaptures, 1);
        assert_ne!(tim.read(t(3000), SR) & 1 << 9, 0, "CC1OF");
        assert!(tim.next_event().is_none(), "nothing scheduled");
    }
}
