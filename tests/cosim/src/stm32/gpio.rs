//! GPIOA..E and AFIO (RM0008 chapter 9): each pin's 4 configuration bits in CRL/CRH (MODE:
//! input or output speed; CNF: analog/floating/pull input, push-pull/open-drain general or
//! alternate-function output), IDR/ODR, the atomic BSRR/BRR, and AFIO's EXTICR (which
//! port's pin n drives EXTI line n). Input levels come from the board.

/// A port (A..E = 0..4) and pin number.
pub type Pin = (u8, u8);

/// What a pin is configured as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PinMode {
    /// Analog input (CNF 00, MODE 00).
    Analog,
    /// Digital input, floating or with pull (MODE 00).
    Input,
    /// General-purpose output (ODR drives it).
    Output,
    /// Alternate-function output (the peripheral drives it).
    AltOutput,
}

const CRL: u32 = 0x00;
const CRH: u32 = 0x04;
const IDR: u32 = 0x08;
const ODR: u32 = 0x0C;
const BSRR: u32 = 0x10;
const BRR: u32 = 0x14;
const LCKR: u32 = 0x18;

/// One port.
#[derive(Clone, Debug)]
struct Port {
    cr: [u32; 2],
    odr: u32,
    input: u32,
}

/// The five ports and AFIO.
#[derive(Clone, Debug)]
pub struct Gpio {
    ports: [Port; 5],
    exticr: [u32; 4],
    mapr: u32,
}

impl Default for Gpio {
    fn default() -> Self {
        Self::new()
    }
}

impl Gpio {
    /// Reset: every pin a floating input (CRL/CRH 0x4444_4444).
    pub fn new() -> Self {
        let port = Port {
            cr: [0x4444_4444; 2],
            odr: 0,
            // Undriven inputs read high (the board's pull-ups; UNCONFIRMED for unused pins).
            input: 0xFFFF,
        };
        Self {
            ports: std::array::from_fn(|_| port.clone()),
            exticr: [0; 4],
            mapr: 0,
        }
    }

    /// The configuration of a pin.
    pub fn mode(&self, (port, n): Pin) -> PinMode {
        let p = &self.ports[port as usize];
        let bits = (p.cr[usize::from(n / 8)] >> (4 * (n % 8))) & 0xF;
        let (mode, cnf) = (bits & 3, bits >> 2);
        match (mode, cnf) {
            (0, 0) => PinMode::Analog,
            (0, _) => PinMode::Input,
            (_, 0 | 1) => PinMode::Output,
            _ => PinMode::AltOutput,
        }
    }

    /// The level the pin has (an output's ODR bit, else the board's input).
    pub fn level(&self, (port, n): Pin) -> bool {
        let p = &self.ports[port as usize];
        match self.mode((port, n)) {
            PinMode::Output => p.odr & 1 << n != 0,
            _ => p.input & 1 << n != 0,
        }
    }

    /// The board drives an input.
    pub fn set_input(&mut self, (port, n): Pin, high: bool) {
        let p = &mut self.ports[port as usize];
        if high {
            p.input |= 1 << n;
        } else {
            p.input &= !(1 << n);
        }
    }

    /// The port (0..4) AFIO_EXTICR routes to EXTI line `line` (0..15).
    pub fn exti_port(&self, line: u8) -> u8 {
        ((self.exticr[usize::from(line / 4)] >> (4 * (line % 4))) & 0xF) as u8
    }

    /// A port register read.
    pub fn read(&self, port: usize, offset: u32) -> u32 {
        let p = &self.ports[port];
        match offset {
            CRL => p.cr[0],
            CRH => p.cr[1],
            IDR => (0..16u8).fold(0, |v, n| v | u32::from(self.level((port as u8, n))) << n),
            ODR => p.odr,
            _ => 0,
        }
    }

    /// A port register write.
    pub fn write(&mut self, port: usize, offset: u32, value: u32) {
        let p = &mut self.ports[port];
        match offset {
            CRL => p.cr[0] = value,
            CRH => p.cr[1] = value,
            ODR => p.odr = value & 0xFFFF,
            // Set wins over reset when both bits are written.
            BSRR => p.odr = (p.odr & !(value >> 16)) | (value & 0xFFFF),
            BRR => p.odr &= !(value & 0xFFFF),
            LCKR | IDR => {}
            _ => {}
        }
    }

    /// An AFIO register read.
    pub fn afio_read(&self, offset: u32) -> u32 {
        match offset {
            0x04 => self.mapr,
            0x08..=0x14 => self.exticr[((offset - 0x08) / 4) as usize],
            _ => 0,
        }
    }

    /// An AFIO register write.
    pub fn afio_write(&mut self, offset: u32, value: u32) {
        match offset {
            0x04 => self.mapr = value,
            0x08..=0x14 => self.exticr[((offset - 0x08) / 4) as usize] = value & 0xFFFF,
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configuration_bits_levels_and_bsrr() {
        let mut g = Gpio::new();
        assert_eq!(g.mode((1, 12)), PinMode::Input);
        // PB12: general output push-pull 50 MHz (0x3); PB13: AF push-pull (0xB).
        g.write(1, CRH, 0x44B3_4444);
        assert_eq!(g.mode((1, 12)), PinMode::Output);
        assert_eq!(g.mode((1, 13)), PinMode::AltOutput);
        g.write(1, BSRR, 1 << 12);
        assert!(g.level((1, 12)));
        g.write(1, BSRR, 1 << 28);
        assert!(!g.level((1, 12)));
        g.write(1, BSRR, 1 << 12 | 1 << 28);
        assert!(g.level((1, 12)), "set wins");
        g.set_input((2, 0), false);
        assert_eq!(g.read(2, IDR) & 1, 0);
        g.afio_write(0x08, 0x2);
        assert_eq!(g.exti_port(0), 2, "EXTI0 from port C");
    }
}
