//! AD7689 model at the SPI level (hardware-facts section 6; AD7682/AD7689 Rev. D
//! pp. 24-30).
//!
//! One `SpiDevice::transaction` is one CNV-low period (read after conversion): the
//! result of the previous conversion is shifted out (16 bits, then the 14-bit CFG used
//! for it, left-aligned, when RB = 0), while the first 14 MOSI bits are a new CFG word
//! (taken only when its bit 13 "overwrite" is 1). The end of the transaction is the CNV
//! rising edge that starts the next conversion, sampled at that virtual time.
//!
//! Pipeline: a CFG written in frame N is latched at the end of the conversion that
//! starts when frame N ends, so it governs the conversion after that, whose data is
//! read in frame N + 2. The first two conversions after power-up (the one power-up
//! starts, and the one started at the end of frame 0) are dummies and return 0.
//!
//! At the pin level ([`Ad7689::cnv_rising`], [`Ad7689::cnv_falling`], [`Ad7689::read`]) the
//! model checks the conversion timing it sees against [`AdcTiming`] (read after conversion
//! without busy indicator: CNV high at least tCONV(max), the read while CNV is low after it,
//! CNV rising edges at least tCYC apart) and counts every breach by kind
//! ([`TimingViolations`]), so a figure of "0 violations" measured on a real CNV waveform can
//! fail.

use crate::rig::clock::Clock;
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use std::cell::RefCell;
use std::convert::Infallible;
use std::f64::consts::PI;
use std::rc::Rc;

/// Board reference voltage (external 2.5 V).
pub const VREF_EXT: f64 = 2.5;
/// The board's input divider: 0..10 V at the connector -> 0..2.5 V at the pin.
pub const DIVIDER: f64 = 4.0;
/// Minimum conversion cycle time (250 kSPS).
pub const T_CYC_NS: u64 = ad7689::unconfirmed::T_CYC_MIN_NS as u64;

/// The conversion timing the model holds the CNV pin to: the `ad7689` driver's figures
/// (`ad7689::unconfirmed`, hardware-facts section 6; UNCONFIRMED for the AD7689 itself).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AdcTiming {
    /// tCYC: CNV rising edge to the next one, at least (ns).
    pub t_cyc_min_ns: u64,
    /// tCONV(max): CNV must stay high this long before the result can be read (ns).
    pub t_conv_max_ns: u64,
    /// tCNVH: the shortest CNV high pulse (ns).
    pub t_cnvh_min_ns: u64,
}

impl Default for AdcTiming {
    fn default() -> Self {
        Self {
            t_cyc_min_ns: T_CYC_NS,
            t_conv_max_ns: ad7689::unconfirmed::T_CONV_MAX_NS as u64,
            t_cnvh_min_ns: ad7689::unconfirmed::T_CNVH_MIN_NS as u64,
        }
    }
}

/// Breaches of [`AdcTiming`] seen at the pins, by kind (tCYC ones are
/// [`Ad7689::cycle_violations`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TimingViolations {
    /// CNV fell before tCONV(max): without the busy indicator the result is not ready
    /// (the read that follows shifts out an unfinished conversion).
    pub conversion_cut: u64,
    /// CNV high pulses shorter than tCNVH.
    pub short_pulse: u64,
    /// Reads clocked while CNV was high (the chip is converting; SDO is not driven).
    pub read_while_converting: u64,
}

impl TimingViolations {
    /// All of them.
    pub fn total(&self) -> u64 {
        self.conversion_cut + self.short_pulse + self.read_while_converting
    }
}

/// A signal source at an analog input (volts at the board connector).
#[derive(Clone, Debug, PartialEq)]
pub enum Signal {
    /// A constant voltage.
    Constant(f64),
    /// `offset + amplitude * sin(2 pi freq t + phase)`.
    Sine {
        /// Amplitude (V).
        amplitude: f64,
        /// Offset (V).
        offset: f64,
        /// Frequency (Hz).
        freq_hz: f64,
        /// Phase (rad).
        phase: f64,
    },
    /// A sawtooth from `from` to `to` over `period_ns`, repeating.
    Ramp {
        /// Start voltage.
        from: f64,
        /// End voltage.
        to: f64,
        /// Period (ns).
        period_ns: u64,
    },
}

impl Signal {
    /// Value at virtual time `t_ns`.
    pub fn eval(&self, t_ns: u64) -> f64 {
        match *self {
            Signal::Constant(v) => v,
            Signal::Sine {
                amplitude,
                offset,
                freq_hz,
                phase,
            } => offset + amplitude * (2.0 * PI * freq_hz * t_ns as f64 * 1e-9 + phase).sin(),
            Signal::Ramp {
                from,
                to,
                period_ns,
            } => {
                let p = period_ns.max(1);
                from + (to - from) * ((t_ns % p) as f64 / p as f64)
            }
        }
    }
}

/// Fields of the 14-bit CFG register.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cfg(pub u16);

impl Cfg {
    /// Power-up value assumed by the model (all ones).
    pub const POWER_UP: Cfg = Cfg(0x3FFF);
    /// Bit 13: overwrite.
    pub fn overwrite(self) -> bool {
        self.0 & 0x2000 != 0
    }
    /// Bits 12:10: input configuration.
    pub fn incc(self) -> u8 {
        ((self.0 >> 10) & 0x07) as u8
    }
    /// Bits 9:7: channel / last channel of the scan.
    pub fn inx(self) -> u8 {
        ((self.0 >> 7) & 0x07) as u8
    }
    /// Bits 5:3: reference.
    pub fn reference(self) -> u8 {
        ((self.0 >> 3) & 0x07) as u8
    }
    /// Bits 2:1: sequencer.
    pub fn seq(self) -> u8 {
        ((self.0 >> 1) & 0x03) as u8
    }
    /// Bit 0: 1 = no readback.
    pub fn no_readback(self) -> bool {
        self.0 & 0x01 != 0
    }
    /// Reference voltage on this board.
    pub fn vref(self) -> f64 {
        match self.reference() {
            0b000 => 2.5,
            0b001 => 4.096,
            _ => VREF_EXT,
        }
    }
}

/// What a conversion measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// An input channel (single-ended, or the positive input of a pair).
    Channel(u8),
    /// The temperature sensor.
    Temperature,
    /// A power-up dummy conversion.
    Dummy,
}

/// One conversion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Conversion {
    /// Virtual time of the CNV rising edge (ns).
    pub time_ns: u64,
    /// What was converted.
    pub source: Source,
    /// Result code.
    pub code: u16,
    /// CFG that governed it.
    pub cfg: u16,
}

/// The AD7689 state.
#[derive(Clone, Debug)]
pub struct Ad7689 {
    clock: Clock,
    /// Per-channel signal at the board connector (0..10 V).
    pub inputs: [Signal; 8],
    /// Die temperature (deg C).
    pub temperature_c: f64,
    cfg: Cfg,
    seq_pos: u8,
    /// The conversion whose result the next frame shifts out.
    pending: Option<Conversion>,
    last_cnv_ns: Option<u64>,
    /// Every conversion, in order.
    pub conversions: Vec<Conversion>,
    /// Frames (transactions).
    pub frames: u64,
    /// CNV edges closer than tCYC (4 us) to the previous one.
    pub cycle_violations: u64,
    /// The timing the pin-level calls are checked against.
    pub timing: AdcTiming,
    /// Other timing breaches seen at the pins.
    pub violations: TimingViolations,
    /// CNV pin level (pin-level calls; high after power-up, as the first conversion runs).
    cnv_high: bool,
    /// The CFG of the read since the last CNV rising edge, latched with the next one.
    read_cfg: Option<Cfg>,
}

impl Ad7689 {
    /// An ADC at power-up with all inputs at 0 V and 25 deg C.
    ///
    /// Power-up starts the first (dummy) conversion, so the first frame reads junk and
    /// the conversion started at its end is the second dummy (it still runs with the
    /// undefined power-up CFG).
    pub fn new(clock: Clock) -> Self {
        let power_up = Conversion {
            time_ns: clock.now_ns(),
            source: Source::Dummy,
            code: 0,
            cfg: Cfg::POWER_UP.0,
        };
        Self {
            clock,
            inputs: std::array::from_fn(|_| Signal::Constant(0.0)),
            temperature_c: 25.0,
            cfg: Cfg::POWER_UP,
            seq_pos: 0,
            pending: Some(power_up),
            last_cnv_ns: None,
            conversions: vec![power_up],
            frames: 0,
            cycle_violations: 0,
            timing: AdcTiming::default(),
            violations: TimingViolations::default(),
            cnv_high: true,
            read_cfg: None,
        }
    }

    /// All timing breaches, tCYC included.
    pub fn timing_violations(&self) -> u64 {
        self.cycle_violations + self.violations.total()
    }

    /// CNV rises (pin level): the next conversion starts now, with the CFG in force; the
    /// CFG of the read before it is latched at its end. Checked: tCYC since the last rise.
    pub fn cnv_rising(&mut self) {
        if self.cnv_high {
            return;
        }
        self.cnv_high = true;
        self.start_conversion();
    }

    /// CNV falls (pin level): the chip selects its SDO for the read. Checked: the pulse is at
    /// least tCNVH and the conversion (tCONV(max)) is over.
    pub fn cnv_falling(&mut self) {
        if !self.cnv_high {
            return;
        }
        self.cnv_high = false;
        let high_ns = self
            .last_cnv_ns
            .map_or(u64::MAX, |t| self.clock.now_ns().saturating_sub(t));
        if high_ns < self.timing.t_cnvh_min_ns {
            self.violations.short_pulse += 1;
        }
        if high_ns < self.timing.t_conv_max_ns {
            self.violations.conversion_cut += 1;
        }
    }

    /// A read at the pin level: `mosi` clocked in, returns MISO (the result of the last
    /// conversion). Checked: CNV is low.
    pub fn read(&mut self, mosi: &[u8]) -> Vec<u8> {
        if self.cnv_high {
            self.violations.read_while_converting += 1;
        }
        self.shift_out(mosi)
    }

    /// The CFG currently governing new conversions.
    pub fn cfg(&self) -> Cfg {
        self.cfg
    }

    fn pin_volts(&self, ch: u8, t: u64) -> f64 {
        self.inputs[ch as usize & 7].eval(t) / DIVIDER
    }

    /// The source of the next conversion under the current CFG and sequencer.
    fn next_source(&self) -> Source {
        let c = self.cfg;
        if c.seq() == 0 {
            if c.incc() == 0b011 {
                Source::Temperature
            } else {
                Source::Channel(c.inx())
            }
        } else if self.seq_pos > c.inx() {
            Source::Temperature
        } else {
            Source::Channel(self.seq_pos)
        }
    }

    fn convert(&self, source: Source, t: u64) -> u16 {
        let c = self.cfg;
        let vref = c.vref();
        let unipolar = |v: f64| (v / vref * 65536.0).floor().clamp(0.0, 65535.0) as u16;
        let bipolar =
            |v: f64| (v / vref * 65536.0).floor().clamp(-32768.0, 32767.0) as i32 as i16 as u16;
        match source {
            Source::Dummy => 0,
            Source::Temperature => unipolar(0.283 + (self.temperature_c - 25.0) * 0.001),
            Source::Channel(ch) => {
                let v = self.pin_volts(ch, t);
                let pair = || v - self.pin_volts(ch ^ 1, t);
                match c.incc() {
                    0b111 | 0b110 => unipolar(v),
                    0b100 | 0b101 => unipolar(pair()),
                    0b010 => bipolar(v - vref / 2.0),
                    0b011 => unipolar(0.283 + (self.temperature_c - 25.0) * 0.001),
                    _ => bipolar(pair()),
                }
            }
        }
    }

    /// One frame: `mosi` clocked in, returns MISO (same length); its end is the CNV rising
    /// edge of the next conversion (a CNV pulse of no width: the harness's form).
    pub fn frame(&mut self, mosi: &[u8]) -> Vec<u8> {
        let out = self.shift_out(mosi);
        self.cnv_high = false;
        self.cnv_rising();
        out
    }

    /// Shifts out the previous conversion and takes a new CFG from the first 14 bits.
    fn shift_out(&mut self, mosi: &[u8]) -> Vec<u8> {
        self.frames += 1;
        // Shift out the previous conversion.
        let (data, cfg_used) = self
            .pending
            .map(|c| (c.code, c.cfg))
            .unwrap_or((0, self.cfg.0));
        let mut out = vec![(data >> 8) as u8, data as u8];
        if !Cfg(cfg_used).no_readback() {
            let r = cfg_used << 2;
            out.extend_from_slice(&[(r >> 8) as u8, r as u8]);
        }
        out.resize(mosi.len().max(out.len()), 0);
        out.truncate(mosi.len());
        // CFG from the first 14 bits (needs at least two bytes).
        let new_cfg = (mosi.len() >= 2)
            .then(|| Cfg(((mosi[0] as u16) << 8 | mosi[1] as u16) >> 2))
            .filter(|c| c.overwrite());
        if new_cfg.is_some() {
            self.read_cfg = new_cfg;
        }
        out
    }

    /// A conversion starts now, with the current CFG; the CFG of the last read is latched at
    /// its end.
    fn start_conversion(&mut self) {
        let t = self.clock.now_ns();
        if let Some(last) = self.last_cnv_ns {
            if t.saturating_sub(last) < self.timing.t_cyc_min_ns {
                self.cycle_violations += 1;
            }
        }
        self.last_cnv_ns = Some(t);
        let dummy = self.conversions.len() < 2;
        let source = if dummy {
            Source::Dummy
        } else {
            self.next_source()
        };
        let code = self.convert(source, t);
        let conv = Conversion {
            time_ns: t,
            source,
            code,
            cfg: self.cfg.0,
        };
        self.conversions.push(conv);
        self.pending = Some(conv);
        // Advance the sequencer.
        if !dummy && self.cfg.seq() != 0 {
            let last = if self.cfg.seq() == 0b10 {
                self.cfg.inx() + 1
            } else {
                self.cfg.inx()
            };
            self.seq_pos = if self.seq_pos >= last {
                0
            } else {
                self.seq_pos + 1
            };
        }
        if let Some(c) = self.read_cfg.take() {
            self.cfg = c;
            self.seq_pos = 0;
        }
    }
}

/// A shared handle on the ADC model.
pub type SharedAdc = Rc<RefCell<Ad7689>>;

/// The AD7689's SPI port (CNV doubles as chip select).
#[derive(Clone)]
pub struct AdcSpi {
    adc: SharedAdc,
}

impl AdcSpi {
    /// A port on `adc`.
    pub fn new(adc: SharedAdc) -> Self {
        Self { adc }
    }

    /// The ADC behind this port.
    pub fn adc(&self) -> &SharedAdc {
        &self.adc
    }
}

impl ErrorType for AdcSpi {
    type Error = Infallible;
}

impl SpiDevice<u8> for AdcSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        let mut mosi = Vec::new();
        for op in operations.iter() {
            match op {
                Operation::Read(buf) => mosi.extend(std::iter::repeat_n(0u8, buf.len())),
                Operation::Write(buf) => mosi.extend_from_slice(buf),
                Operation::Transfer(r, w) => {
                    mosi.extend_from_slice(w);
                    mosi.extend(std::iter::repeat_n(0u8, r.len().saturating_sub(w.len())));
                }
                Operation::TransferInPlace(buf) => mosi.extend_from_slice(buf),
                Operation::DelayNs(_) => {}
            }
        }
        let miso = self.adc.borrow_mut().frame(&mosi);
        let mut pos = 0;
        for op in operations.iter_mut() {
            match op {
                Operation::Read(buf) | Operation::TransferInPlace(buf) => {
                    buf.copy_from_slice(&miso[pos..pos + buf.len()]);
                    pos += buf.len();
                }
                Operation::Write(buf) => pos += buf.len(),
                Operation::Transfer(r, w) => {
                    let n = r.len().max(w.len());
                    r.copy_from_slice(&miso[pos..pos + r.len()]);
                    pos += n;
                }
                Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}
