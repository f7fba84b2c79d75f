//! Pin connect block (UM10360 chapter 8, base 0x4002_C000): PINSEL0..10 (2 bits per pin:
//! function 0 = GPIO, 1..3 = the alternates of UM10360 tables 79..85), PINMODE0..9 (pad
//! resistor), PINMODE_OD0..4 (open drain). The routing checks against these live in
//! [`crate::machine`]: a transfer on pins not multiplexed to the peripheral moves no data.

use super::{Peripheral, Tick};

/// PINSEL, PINMODE and PINMODE_OD.
#[derive(Clone, Debug, Default)]
pub struct PinConnect {
    pinsel: [u32; 11],
    pinmode: [u32; 10],
    od: [u32; 5],
}

impl PinConnect {
    /// The reset state: every pin GPIO with pull-up.
    pub fn new() -> Self {
        Self::default()
    }

    /// The PINSEL function (0..=3) of `Pport.pin`.
    pub fn func(&self, port: u8, pin: u8) -> u8 {
        let index = usize::from(port) * 2 + usize::from(pin / 16);
        let shift = u32::from(pin % 16) * 2;
        self.pinsel
            .get(index)
            .map_or(0, |v| ((v >> shift) & 3) as u8)
    }

    /// The PINMODE bits (00 pull-up, 01 repeater, 10 none, 11 pull-down) of `Pport.pin`.
    pub fn mode(&self, port: u8, pin: u8) -> u8 {
        let index = usize::from(port) * 2 + usize::from(pin / 16);
        let shift = u32::from(pin % 16) * 2;
        self.pinmode
            .get(index)
            .map_or(0, |v| ((v >> shift) & 3) as u8)
    }
}

impl Peripheral for PinConnect {
    fn read(&mut self, _t: Tick, offset: u32) -> u32 {
        let i = (offset / 4) as usize;
        match offset {
            0x00..=0x28 => self.pinsel[i],
            0x40..=0x64 => self.pinmode[i - 0x10],
            0x68..=0x78 => self.od[i - 0x1A],
            _ => 0,
        }
    }

    fn write(&mut self, _t: Tick, offset: u32, value: u32) {
        let i = (offset / 4) as usize;
        match offset {
            0x00..=0x28 => self.pinsel[i] = value,
            0x40..=0x64 => self.pinmode[i - 0x10] = value,
            0x68..=0x78 => self.od[i - 0x1A] = value,
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn functions_per_pin() {
        let mut p = PinConnect::new();
        let t = Tick {
            now_ns: 0,
            pclk_hz: 0,
        };
        // PINSEL0 bits 31:30 = P0.15, PINSEL1 bits 5:4 = P0.18, PINSEL3 bits 5:4 = P1.18.
        p.write(t, 0x00, 3 << 30);
        p.write(t, 0x04, 3 << 4);
        p.write(t, 0x0C, 3 << 4);
        p.write(t, 0x48, 2 << 8);
        assert_eq!((p.func(0, 15), p.func(0, 18), p.func(1, 18)), (3, 3, 3));
        assert_eq!((p.func(0, 16), p.func(0, 17)), (0, 0));
        assert_eq!(p.mode(1, 4), 2);
    }
}
