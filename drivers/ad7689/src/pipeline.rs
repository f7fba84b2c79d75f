//! Tracking of the two-conversion CFG pipeline and the channel sequencer.
//!
//! One frame (CNV low period) reads the conversion that started at the end of the previous
//! frame (the CNV rising edge), and starts a new one when it ends. A CFG written in frame N is
//! latched at the end of the conversion started when frame N ends; so it governs the
//! conversion after that one (started at the end of frame N + 1), whose result is read in
//! frame N + 2 (datasheet "two dummy conversions"; no-OS ad7689; Linux ad7949 "two
//! transactions delay"). In a running scan, frame k + 2 (counted from the CFG frame k = 0)
//! holds scan channel k.

use crate::config::{Config, InputConfig, Sequencer};
use crate::types::Channel;

/// How the sequencer steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// Every conversion converts INx (or the temperature sensor).
    Single,
    /// Scan IN0..INx, then the temperature sensor if `temperature`.
    Scan { temperature: bool },
}

/// The CFG that governs new conversions, with the scan position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Active {
    cfg: Config,
    mode: Mode,
    pos: u8,
}

/// CFG bit 11: 0 = pairs, 1 = single channels.
const fn single_bit(cfg: &Config) -> bool {
    cfg.bits() & (1 << 11) != 0
}

impl Active {
    /// Latches `new` at the end of a conversion, after `prev`.
    fn latch(prev: Option<Active>, new: Config) -> Active {
        let restart = |mode| Active {
            cfg: new,
            mode,
            pos: 0,
        };
        match new.sequencer_setting() {
            Sequencer::Off => restart(Mode::Single),
            Sequencer::Scan => restart(Mode::Scan { temperature: false }),
            Sequencer::ScanWithTemperature => restart(Mode::Scan { temperature: true }),
            Sequencer::UpdateConfig => match prev {
                // A running scan goes on unless bit 11 or INx changes (then it restarts).
                Some(p) if p.mode != Mode::Single => {
                    let same = single_bit(&p.cfg) == single_bit(&new)
                        && p.cfg.last_channel() == new.last_channel();
                    Active {
                        cfg: new,
                        mode: p.mode,
                        pos: if same { p.pos } else { 0 },
                    }
                }
                // UNCONFIRMED: without a running scan, treated as sequencer off.
                _ => restart(Mode::Single),
            },
        }
    }

    /// Number of inputs in a scan and the step between them.
    fn scan_inputs(&self) -> (u8, u8) {
        let last = self.cfg.last_channel() & 0b111;
        if self.cfg.input_config().is_paired() {
            (last / 2 + 1, 2)
        } else {
            (last + 1, 1)
        }
    }

    /// What the next conversion measures.
    fn source(&self) -> Channel {
        if self.cfg.input_config() == InputConfig::Temperature {
            return Channel::Temperature;
        }
        match self.mode {
            Mode::Single => Channel::In(self.cfg.last_channel() & 0b111),
            Mode::Scan { .. } => {
                let (inputs, step) = self.scan_inputs();
                if self.pos < inputs {
                    Channel::In(self.pos * step)
                } else {
                    Channel::Temperature
                }
            }
        }
    }

    /// Steps the sequencer after a conversion started.
    fn advance(&mut self) {
        if let Mode::Scan { temperature } = self.mode {
            let (inputs, _) = self.scan_inputs();
            let len = inputs + temperature as u8;
            self.pos = if self.pos + 1 >= len { 0 } else { self.pos + 1 };
        }
    }
}

/// A conversion that has started: what it measures and the CFG that governs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct InFlight {
    pub channel: Channel,
    pub cfg: Config,
}

/// The pipeline state between two frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Pipeline {
    /// Governs the conversion that starts at the end of the next frame (after `pending` is
    /// latched). `None`: unknown (power-up or after an error).
    active: Option<Active>,
    /// The conversion whose result the next frame reads. `None`: unknown.
    in_flight: Option<InFlight>,
    /// Written in the last frame; latched at the end of the conversion in flight.
    pending: Option<Config>,
}

impl Pipeline {
    /// Nothing known (power-up).
    pub const fn new() -> Self {
        Self {
            active: None,
            in_flight: None,
            pending: None,
        }
    }

    /// Forget everything (after an error the frame count may be off).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// The conversion the next frame reads.
    pub fn in_flight(&self) -> Option<InFlight> {
        self.in_flight
    }

    /// A frame has ended (CNV rose): the conversion that was in flight ended before the frame
    /// (its end latched the pending CFG), a new one has started with the active CFG, and
    /// `written` (if its overwrite bit is set) is pending.
    pub fn frame_done(&mut self, written: Option<Config>) {
        if let Some(cfg) = self.pending.take() {
            self.active = Some(Active::latch(self.active, cfg));
        }
        self.in_flight = self.active.map(|a| InFlight {
            channel: a.source(),
            cfg: a.cfg,
        });
        if let Some(a) = self.active.as_mut() {
            a.advance();
        }
        self.pending = written.filter(Config::is_overwrite);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::config::{InputConfig, Reference};
    use std::{vec, vec::Vec};

    fn scan(last: u8) -> Config {
        Config::new()
            .channel(last)
            .reference(Reference::External)
            .sequencer(Sequencer::Scan)
    }

    /// Runs `n` frames writing nothing and returns what each read.
    fn run(p: &mut Pipeline, n: usize) -> Vec<Option<Channel>> {
        (0..n)
            .map(|_| {
                let r = p.in_flight().map(|f| f.channel);
                p.frame_done(None);
                r
            })
            .collect()
    }

    fn ins(list: &[u8]) -> Vec<Option<Channel>> {
        list.iter().map(|&n| Some(Channel::In(n))).collect()
    }

    #[test]
    fn scan_frame_k_plus_2_holds_channel_k() {
        let mut p = Pipeline::new();
        // Frame 0 writes the CFG.
        assert_eq!(p.in_flight(), None);
        p.frame_done(Some(scan(7)));
        let got = run(&mut p, 18);
        let mut want = vec![None]; // frame 1: the conversion started at the end of frame 0
        want.extend(ins(&[0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0]));
        assert_eq!(got, want);
    }

    #[test]
    fn scan_with_temperature() {
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(2).sequencer(Sequencer::ScanWithTemperature)));
        let got = run(&mut p, 10);
        let t = Some(Channel::Temperature);
        let i = |n| Some(Channel::In(n));
        assert_eq!(
            got,
            vec![None, i(0), i(1), i(2), t, i(0), i(1), i(2), t, i(0)]
        );
    }

    #[test]
    fn paired_scan_steps_over_even_inputs() {
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(7).input(InputConfig::UnipolarDifferential)));
        assert_eq!(run(&mut p, 6)[1..], ins(&[0, 2, 4, 6, 0])[..]);
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(5).input(InputConfig::BipolarDifferential)));
        assert_eq!(run(&mut p, 5)[1..], ins(&[0, 2, 4, 0])[..]);
    }

    #[test]
    fn single_channel_and_temperature() {
        let mut p = Pipeline::new();
        p.frame_done(Some(Config::new().channel(5)));
        assert_eq!(run(&mut p, 4)[1..], ins(&[5, 5, 5])[..]);
        let mut p = Pipeline::new();
        p.frame_done(Some(Config::new().input(InputConfig::Temperature)));
        assert_eq!(
            run(&mut p, 3)[1..],
            [Some(Channel::Temperature), Some(Channel::Temperature)]
        );
    }

    #[test]
    fn rewriting_restarts_the_scan_two_frames_later() {
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(7)));
        let _ = run(&mut p, 4); // reads None, IN0, IN1, IN2; IN3 is in flight
                                // Frame N writes a new scan; frame N+1 still reads the old scan, frame N+2 starts at IN0.
        let r = p.in_flight().map(|f| f.channel);
        p.frame_done(Some(scan(3)));
        assert_eq!(r, Some(Channel::In(3)));
        assert_eq!(run(&mut p, 6), ins(&[4, 0, 1, 2, 3, 0]));
    }

    #[test]
    fn update_config_keeps_the_scan_going() {
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(7)));
        let _ = run(&mut p, 3); // None, IN0, IN1; IN2 started
        let upd = scan(7)
            .sequencer(Sequencer::UpdateConfig)
            .reference(Reference::ExternalBuffer);
        p.frame_done(Some(upd)); // reads IN2, IN3 starts
        let got: Vec<_> = (0..4)
            .map(|_| {
                let f = p.in_flight().unwrap();
                p.frame_done(None);
                (f.channel, f.cfg.sequencer_setting())
            })
            .collect();
        assert_eq!(
            got,
            [
                (Channel::In(3), Sequencer::Scan),
                (Channel::In(4), Sequencer::UpdateConfig),
                (Channel::In(5), Sequencer::UpdateConfig),
                (Channel::In(6), Sequencer::UpdateConfig),
            ]
        );
    }

    #[test]
    fn update_config_with_new_last_channel_restarts() {
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(7)));
        let _ = run(&mut p, 3);
        p.frame_done(Some(scan(4).sequencer(Sequencer::UpdateConfig)));
        assert_eq!(run(&mut p, 7), ins(&[3, 0, 1, 2, 3, 4, 0]));
        // Changing single <-> pairs (bit 11) restarts too.
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(7)));
        let _ = run(&mut p, 4);
        let pairs = scan(7)
            .input(InputConfig::UnipolarDifferential)
            .sequencer(Sequencer::UpdateConfig);
        p.frame_done(Some(pairs));
        assert_eq!(run(&mut p, 3), ins(&[4, 0, 2]));
    }

    #[test]
    fn update_config_without_scan_is_single() {
        let mut p = Pipeline::new();
        p.frame_done(Some(
            Config::new().channel(2).sequencer(Sequencer::UpdateConfig),
        ));
        assert_eq!(run(&mut p, 3)[1..], ins(&[2, 2])[..]);
    }

    #[test]
    fn config_without_overwrite_is_ignored() {
        let mut p = Pipeline::new();
        p.frame_done(Some(scan(7)));
        let _ = run(&mut p, 2);
        // Reads IN1; the CFG without the overwrite bit changes nothing.
        p.frame_done(Some(Config::new().channel(3).overwrite(false)));
        assert_eq!(run(&mut p, 3), ins(&[2, 3, 4]));
    }

    #[test]
    fn nothing_known_without_a_write_and_after_reset() {
        let mut p = Pipeline::new();
        assert_eq!(run(&mut p, 3), vec![None, None, None]);
        p.frame_done(Some(scan(1)));
        let _ = run(&mut p, 3);
        assert!(p.in_flight().is_some());
        p.reset();
        assert_eq!(p.in_flight(), None);
        assert_eq!(run(&mut p, 2), vec![None, None]);
    }

    #[test]
    fn in_flight_carries_the_governing_cfg() {
        let mut p = Pipeline::new();
        let a = scan(1).readback(true);
        p.frame_done(Some(a));
        p.frame_done(None);
        assert_eq!(p.in_flight().map(|f| f.cfg), Some(a));
    }
}
