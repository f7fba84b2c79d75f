//! AD5663 model at the SPI level (hardware-facts section 5; AD5663 datasheet p. 16,
//! AD5663R p. 21).
//!
//! One `SpiDevice::transaction` = one SYNC-low frame. The command executes on the 24th
//! falling SCLK edge; a frame shorter than 24 bits is aborted (nothing happens), bits
//! after the 24th are ignored (and counted). Output: `code / 65536 * 2.5 V * 4`
//! (2.5 V external reference and the board's x4 amplifier).

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
        }
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
        let mut d = self.dac.borrow_mut();
        if d.ldac_pin_high {
            d.ldac_pin_high = false;
            d.ldac_pulse();
        }
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.dac.borrow_mut().ldac_pin_high = true;
        Ok(())
    }
}
