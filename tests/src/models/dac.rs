//! AD5663 model at the SPI level (hardware-facts section 5; AD5663 datasheet p. 16,
//! AD5663R p. 21).
//!
//! One `SpiDevice::transaction` = one SYNC-low frame. The command executes on the 24th
//! falling SCLK edge; a frame shorter than 24 bits is aborted (nothing happens), bits
//! after the 24th are ignored (and counted). Output: `code / 65536 * 2.5 V * 4`
//! (2.5 V external reference and the board's x4 amplifier).
//!
//! At the pin level ([`Ad5663::sync_falling`], [`Ad5663::clock_bits`],
//! [`Ad5663::sync_rising`]) a frame may arrive in pieces of any width (an SSP sending two
//! 12-bit items by DMA, with SCLK idle between them: the interface is static), and the
//! command executes when the 24th bit is in, at that virtual time. Every LDAC pin edge is
//! recorded with its time ([`Ad5663::ldac_edges`]), so the update rate and each update's
//! error against a DC time grid can be measured ([`LdacEdge::grid_error_ns`]).

use crate::rig::clock::Clock;
use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use std::cell::RefCell;
use std::convert::Infallible;
use std::rc::Rc;

/// Reference voltage of the board (external).
pub const VREF: f64 = 2.5;
/// Gain of the board's output amplifier.
pub const GAIN: f64 = 4.0;

/// Power-down mode of a channel (DB5:4 of command 100).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PowerMode {
    /// Normal operation.
    #[default]
    Normal,
    /// 1 kOhm to GND.
    PullDown1k,
    /// 100 kOhm to GND.
    PullDown100k,
    /// Three-state.
    ThreeState,
}

/// One DAC register load.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DacUpdate {
    /// Virtual time (ns).
    pub time_ns: u64,
    /// Channel 0 = A, 1 = B.
    pub channel: u8,
    /// New DAC register code.
    pub code: u16,
}

/// An edge of the LDAC pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LdacEdge {
    /// Virtual time (ns).
    pub time_ns: u64,
    /// True for the falling edge (the one that loads the DAC registers).
    pub falling: bool,
}

impl LdacEdge {
    /// The edge's distance from the nearest point of the grid `origin + k * period` (ns,
    /// negative: early). `period` 0 compares with `origin` alone.
    pub fn grid_error_ns(&self, origin: u64, period: u64) -> i64 {
        let d = self.time_ns as i128 - origin as i128;
        if period == 0 {
            return d as i64;
        }
        let p = period as i128;
        let r = d.rem_euclid(p);
        (if r > p / 2 { r - p } else { r }) as i64
    }
}

/// A frame being clocked in at the pin level.
#[derive(Clone, Copy, Debug, Default)]
struct PinFrame {
    /// Bits in so far (MSB first).
    shift: u32,
    /// How many.
    bits: u32,
}

/// The AD5663 state.
#[derive(Clone, Debug)]
pub struct Ad5663 {
    clock: Clock,
    /// Input registers A, B.
    pub input: [u16; 2],
    /// DAC registers A, B (what the outputs show).
    pub dac: [u16; 2],
    /// LDAC register: bit n = 1 -> channel n updates on every write (LDAC pin ignored).
    pub ldac_reg: u8,
    /// Power mode per channel.
    pub power: [PowerMode; 2],
    /// LDAC pin level (true = high, inactive).
    pub ldac_pin_high: bool,
    /// Every DAC register load, in order.
    pub updates: Vec<DacUpdate>,
    /// Frames executed.
    pub frames: u64,
    /// Frames aborted (SYNC high before the 24th edge).
    pub aborted_frames: u64,
    /// Frames with more than 24 bits.
    pub long_frames: u64,
    /// Commands 111 received (reserved on the plain AD5663; executed as no-ops).
    pub reserved_commands: u64,
    /// Commands with a reserved address (010, 011 ...), ignored.
    pub bad_addresses: u64,
    /// Every LDAC pin edge, in order.
    pub ldac_edges: Vec<LdacEdge>,
    /// SCLK bits clocked at the pin level while SYNC was high (ignored by the chip).
    pub bits_while_deselected: u64,
    /// The pin-level frame while SYNC is low.
    pin_frame: Option<PinFrame>,
}

impl Ad5663 {
    /// A DAC at power-on (zero scale, LDAC register 0, LDAC pin high).
    pub fn new(clock: Clock) -> Self {
        Self {
            clock,
            input: [0; 2],
            dac: [0; 2],
            ldac_reg: 0,
            power: [PowerMode::Normal; 2],
            ldac_pin_high: true,
            updates: Vec::new(),
            frames: 0,
            aborted_frames: 0,
            long_frames: 0,
            reserved_commands: 0,
            bad_addresses: 0,
            ldac_edges: Vec::new(),
            bits_while_deselected: 0,
            pin_frame: None,
        }
    }

    /// SYNC falls: a frame begins (at the pin level).
    pub fn sync_falling(&mut self) {
        self.pin_frame = Some(PinFrame::default());
    }

    /// `bits` (at most 32) of `value`, MSB first, clocked in on falling SCLK edges at the
    /// current time. The command executes when the 24th bit of the frame is in; bits after
    /// it are ignored until SYNC rises. Bits while SYNC is high are ignored and counted.
    pub fn clock_bits(&mut self, value: u32, bits: u32) {
        let Some(mut f) = self.pin_frame else {
            self.bits_while_deselected += u64::from(bits);
            return;
        };
        for i in (0..bits.min(32)).rev() {
            f.bits += 1;
            if f.bits <= 24 {
                f.shift = f.shift << 1 | (value >> i) & 1;
            }
            if f.bits == 24 {
                self.execute(f.shift & 0xFF_FFFF);
            } else if f.bits == 25 {
                self.long_frames += 1;
            }
        }
        self.pin_frame = Some(f);
    }

    /// SYNC rises: a frame of fewer than 24 bits is aborted.
    pub fn sync_rising(&mut self) {
        if let Some(f) = self.pin_frame.take() {
            if (1..24).contains(&f.bits) {
                self.aborted_frames += 1;
            }
        }
    }

    /// The LDAC pin goes to `high`: a falling edge loads the channels whose LDAC bit is 0;
    /// every edge is recorded.
    pub fn set_ldac(&mut self, high: bool) {
        if high == self.ldac_pin_high {
            return;
        }
        self.ldac_pin_high = high;
        self.ldac_edges.push(LdacEdge {
            time_ns: self.clock.now_ns(),
            falling: !high,
        });
        if !high {
            self.ldac_pulse();
        }
    }

    /// The falling LDAC edges from `from_ns` on.
    pub fn ldac_falls_since(&self, from_ns: u64) -> impl Iterator<Item = &LdacEdge> {
        self.ldac_edges
            .iter()
            .filter(move |e| e.falling && e.time_ns >= from_ns)
    }

    /// Output voltage of a channel (None when powered down).
    pub fn output_volts(&self, ch: usize) -> Option<f64> {
        (self.power[ch] == PowerMode::Normal).then(|| self.dac[ch] as f64 / 65536.0 * VREF * GAIN)
    }

    fn load(&mut self, ch: usize) {
        self.dac[ch] = self.input[ch];
        self.updates.push(DacUpdate {
            time_ns: self.clock.now_ns(),
            channel: ch as u8,
            code: self.dac[ch],
        });
    }

    fn channels(addr: u8) -> Option<&'static [usize]> {
        match addr {
            0b000 => Some(&[0]),
            0b001 => Some(&[1]),
            0b111 => Some(&[0, 1]),
            _ => None,
        }
    }

    /// Executes one 24-bit word (DB23..DB0).
    pub fn execute(&mut self, word: u32) {
        self.frames += 1;
        let cmd = ((word >> 19) & 0x07) as u8;
        let addr = ((word >> 16) & 0x07) as u8;
        let data = (word & 0xFFFF) as u16;
        let chans = Self::channels(addr);
        match cmd {
            0b000 | 0b010 | 0b011 => {
                let Some(chans) = chans else {
                    self.bad_addresses += 1;
                    return;
                };
                for &c in chans {
                    self.input[c] = data;
                }
                match cmd {
                    0b000 => {
                        // Transparent channels (LDAC bit set) or LDAC pin held low update.
                        for &c in chans {
                            if self.ldac_reg & (1 << c) != 0 || !self.ldac_pin_high {
                                self.load(c);
                            }
                        }
                    }
                    0b010 => {
                        self.load(0);
                        self.load(1);
                    }
                    _ => {
                        for &c in chans {
                            self.load(c);
                        }
                    }
                }
            }
            0b001 => match chans {
                Some(chans) => chans.iter().for_each(|&c| self.load(c)),
                None => self.bad_addresses += 1,
            },
            0b100 => {
                let mode = match (data >> 4) & 0x03 {
                    0 => PowerMode::Normal,
                    1 => PowerMode::PullDown1k,
                    2 => PowerMode::PullDown100k,
                    _ => PowerMode::ThreeState,
                };
                for c in 0..2 {
                    if data & (1 << c) != 0 {
                        self.power[c] = mode;
                    }
                }
            }
            0b101 => {
                // Software reset: DAC and input registers to zero scale; DB0 = 1 also
                // resets the LDAC and power-down registers.
                self.input = [0; 2];
                self.load(0);
                self.load(1);
                if data & 0x01 != 0 {
                    self.ldac_reg = 0;
                    self.power = [PowerMode::Normal; 2];
                }
            }
            0b110 => self.ldac_reg = (data & 0x03) as u8,
            _ => self.reserved_commands += 1,
        }
    }

    /// LDAC pin falling edge: channels whose LDAC bit is 0 load their input register.
    pub fn ldac_pulse(&mut self) {
        for c in 0..2 {
            if self.ldac_reg & (1 << c) == 0 {
                self.load(c);
            }
        }
    }

    /// Outputs of both channels changed at the same virtual time in the last loads?
    pub fn last_pair_simultaneous(&self) -> bool {
        let n = self.updates.len();
        n >= 2
            && self.updates[n - 1].time_ns == self.updates[n - 2].time_ns
            && self.updates[n - 1].channel != self.updates[n - 2].channel
    }
}

/// A shared handle on the DAC model.
pub type SharedDac = Rc<RefCell<Ad5663>>;

/// The AD5663's SPI port (SYNC = chip select; mode 1).
#[derive(Clone)]
pub struct DacSpi {
    dac: SharedDac,
}

impl DacSpi {
    /// A port on `dac`.
    pub fn new(dac: SharedDac) -> Self {
        Self { dac }
    }
}

impl ErrorType for DacSpi {
    type Error = Infallible;
}

impl SpiDevice<u8> for DacSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        let mut bytes = Vec::new();
        for op in operations.iter_mut() {
            match op {
                Operation::Read(buf) => {
                    bytes.extend(std::iter::repeat_n(0u8, buf.len()));
                    buf.fill(0);
                }
                Operation::Write(buf) => bytes.extend_from_slice(buf),
                Operation::Transfer(r, w) => {
                    bytes.extend_from_slice(w);
                    bytes.extend(std::iter::repeat_n(0u8, r.len().saturating_sub(w.len())));
                    r.fill(0);
                }
                Operation::TransferInPlace(buf) => {
                    bytes.extend_from_slice(buf);
                    buf.fill(0);
                }
                Operation::DelayNs(_) => {}
            }
        }
        let mut dac = self.dac.borrow_mut();
        if bytes.len() < 3 {
            if !bytes.is_empty() {
                dac.aborted_frames += 1;
            }
            return Ok(());
        }
        if bytes.len() > 3 {
            dac.long_frames += 1;
        }
        let word = (bytes[0] as u32) << 16 | (bytes[1] as u32) << 8 | bytes[2] as u32;
        dac.execute(word);
        Ok(())
    }
}

/// The LDAC pin as an `OutputPin` (a falling edge loads the non-transparent channels).
#[derive(Clone)]
pub struct LdacPin {
    dac: SharedDac,
}

impl LdacPin {
    /// The pin of `dac`.
    pub fn new(dac: SharedDac) -> Self {
        Self { dac }
    }
}

impl PinErrorType for LdacPin {
    type Error = Infallible;
}

impl OutputPin for LdacPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.dac.borrow_mut().set_ldac(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.dac.borrow_mut().set_ldac(true);
        Ok(())
    }
}
