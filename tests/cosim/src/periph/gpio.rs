//! GPIO (UM10360 chapter 9): the fast GPIO block FIO at 0x2009_C000 (per port, stride 0x20:
//! FIODIR +0, FIOMASK +0x10, FIOPIN +0x14, FIOSET +0x18, FIOCLR +0x1C) and the GPIO
//! interrupt registers at 0x4002_8080 (edge detection on ports 0 and 2, one line into the
//! NVIC shared with EINT3).
//!
//! A pin's level is its output latch when FIODIR makes it an output, else what the board
//! drives into it ([`Gpio::set_input`]); an undriven input reads its pad resistor.

use super::{Peripheral, Tick};

const PORTS: usize = 5;

/// The FIO block.
#[derive(Clone, Debug)]
pub struct Gpio {
    dir: [u32; PORTS],
    mask: [u32; PORTS],
    out: [u32; PORTS],
    /// Levels driven into the pins by the board (bit set = high), and which are driven.
    ext_level: [u32; PORTS],
    ext_driven: [u32; PORTS],
}

impl Default for Gpio {
    fn default() -> Self {
        Self::new()
    }
}

impl Gpio {
    /// Reset: all inputs, nothing masked, latches 0.
    pub fn new() -> Self {
        Self {
            dir: [0; PORTS],
            mask: [0; PORTS],
            out: [0; PORTS],
            ext_level: [0; PORTS],
            ext_driven: [0; PORTS],
        }
    }

    /// The board drives `Pport.pin` to `high`.
    pub fn set_input(&mut self, port: u8, pin: u8, high: bool) {
        let p = usize::from(port);
        self.ext_driven[p] |= 1 << pin;
        if high {
            self.ext_level[p] |= 1 << pin;
        } else {
            self.ext_level[p] &= !(1 << pin);
        }
    }

    /// The level of a pin (`pull_up`: what an undriven input reads).
    pub fn level(&self, port: u8, pin: u8, pull_up: bool) -> bool {
        let p = usize::from(port);
        let m = 1u32 << pin;
        if self.dir[p] & m != 0 {
            self.out[p] & m != 0
        } else if self.ext_driven[p] & m != 0 {
            self.ext_level[p] & m != 0
        } else {
            pull_up
        }
    }

    /// Whether the pin is an output.
    pub fn is_output(&self, port: u8, pin: u8) -> bool {
        self.dir[usize::from(port)] & (1 << pin) != 0
    }

    fn pins(&self, p: usize) -> u32 {
        (self.dir[p] & self.out[p])
            | (!self.dir[p] & self.ext_level[p])
            | (!self.dir[p] & !self.ext_driven[p])
    }
}

impl Peripheral for Gpio {
    fn read(&mut self, _t: Tick, offset: u32) -> u32 {
        let p = (offset / 0x20) as usize;
        if p >= PORTS {
            return 0;
        }
        match offset % 0x20 {
            0x00 => self.dir[p],
            0x10 => self.mask[p],
            0x14 => self.pins(p) & !self.mask[p],
            0x18 => self.out[p] & !self.mask[p],
            _ => 0,
        }
    }

    fn write(&mut self, _t: Tick, offset: u32, value: u32) {
        let p = (offset / 0x20) as usize;
        if p >= PORTS {
            return;
        }
        let writable = !self.mask[p];
        match offset % 0x20 {
            0x00 => self.dir[p] = value,
            0x10 => self.mask[p] = value,
            0x14 => self.out[p] = (self.out[p] & !writable) | (value & writable),
            0x18 => self.out[p] |= value & writable,
            0x1C => self.out[p] &= !(value & writable),
            _ => {}
        }
    }
}

/// The GPIO interrupt block (registers from 0x4002_8080; offsets here from 0x4002_8000).
#[derive(Clone, Debug, Default)]
pub struct GpioInt {
    en_r: [u32; 2],
    en_f: [u32; 2],
    stat_r: [u32; 2],
    stat_f: [u32; 2],
    last: [u32; 2],
    primed: [u32; 2],
}

impl GpioInt {
    /// Reset: nothing enabled.
    pub fn new() -> Self {
        Self::default()
    }

    fn index(port: u8) -> Option<usize> {
        match port {
            0 => Some(0),
            2 => Some(1),
            _ => None,
        }
    }

    /// A pin of port 0 or 2 reads `high` now: an enabled edge sets its status.
    pub fn sample(&mut self, port: u8, pin: u8, high: bool) {
        let Some(i) = Self::index(port) else { return };
        let m = 1u32 << pin;
        let was = self.last[i] & m != 0;
        if self.primed[i] & m != 0 {
            if high && !was && self.en_r[i] & m != 0 {
                self.stat_r[i] |= m;
            }
            if !high && was && self.en_f[i] & m != 0 {
                self.stat_f[i] |= m;
            }
        }
        self.primed[i] |= m;
        if high {
            self.last[i] |= m;
        } else {
            self.last[i] &= !m;
        }
    }
}

impl Peripheral for GpioInt {
    fn read(&mut self, _t: Tick, offset: u32) -> u32 {
        match offset {
            0x80 => {
                u32::from(self.stat_r[0] | self.stat_f[0] != 0)
                    | u32::from(self.stat_r[1] | self.stat_f[1] != 0) << 2
            }
            0x84 => self.stat_r[0],
            0x88 => self.stat_f[0],
            0x90 => self.en_r[0],
            0x94 => self.en_f[0],
            0xA4 => self.stat_r[1],
            0xA8 => self.stat_f[1],
            0xB0 => self.en_r[1],
            0xB4 => self.en_f[1],
            _ => 0,
        }
    }

    fn write(&mut self, _t: Tick, offset: u32, value: u32) {
        match offset {
            0x8C => {
                self.stat_r[0] &= !value;
                self.stat_f[0] &= !value;
            }
            0x90 => self.en_r[0] = value,
            0x94 => self.en_f[0] = value,
            0xAC => {
                self.stat_r[1] &= !value;
                self.stat_f[1] &= !value;
            }
            0xB0 => self.en_r[1] = value,
            0xB4 => self.en_f[1] = value,
            _ => {}
        }
    }

    fn irq(&self) -> bool {
        self.stat_r.iter().chain(&self.stat_f).any(|&s| s != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: Tick = Tick {
        now_ns: 0,
        pclk_hz: 0,
    };

    #[test]
    fn outputs_inputs_and_mask() {
        let mut g = Gpio::new();
        g.write(T, 0x00, 1 << 16); // P0.16 output
        g.write(T, 0x18, 1 << 16);
        assert!(g.level(0, 16, false));
        g.write(T, 0x1C, 1 << 16);
        assert!(!g.level(0, 16, true));
        g.set_input(0, 22, false);
        assert_eq!(g.read(T, 0x14) & (1 << 22), 0);
        g.set_input(0, 22, true);
        assert_ne!(g.read(T, 0x14) & (1 << 22), 0);
        g.write(T, 0x10, 1 << 16);
        g.write(T, 0x18, 1 << 16);
        assert!(!g.level(0, 16, true), "masked bits are not written");
    }

    #[test]
    fn falling_edges_set_status_until_cleared() {
        let mut i = GpioInt::new();
        i.write(T, 0x94, 1 << 22);
        i.sample(0, 22, true);
        assert!(!i.irq());
        i.sample(0, 22, false);
        assert!(i.irq());
        assert_eq!(i.read(T, 0x88), 1 << 22);
        assert_eq!(i.read(T, 0x80), 1);
        i.write(T, 0x8C, 1 << 22);
        assert!(!i.irq());
        i.sample(0, 22, false);
        assert!(!i.irq(), "a level is not an edge");
    }
}
