//! EXTI (RM0008 section 10.2): per line a rising and a falling trigger, the interrupt mask,
//! the software interrupt, and the pending bit (write 1 to clear). Lines 0..4 have their own
//! interrupt; the machine asserts EXTI0's while its pending and mask bits are both set.

use super::unconfirmed::EXTI_PENDS_WHEN_MASKED;

const IMR: u32 = 0x00;
const EMR: u32 = 0x04;
const RTSR: u32 = 0x08;
const FTSR: u32 = 0x0C;
const SWIER: u32 = 0x10;
const PR: u32 = 0x14;
const LINES: u32 = (1 << 19) - 1;

/// EXTI.
#[derive(Clone, Debug, Default)]
pub struct Exti {
    imr: u32,
    emr: u32,
    rtsr: u32,
    ftsr: u32,
    swier: u32,
    pr: u32,
    levels: u32,
}

impl Exti {
    /// Reset: everything masked, no trigger; every input line high (idle).
    pub fn new() -> Self {
        Self {
            levels: LINES,
            ..Default::default()
        }
    }

    /// Line `n`'s input is now `high`: a selected edge sets its pending bit.
    pub fn input(&mut self, n: u32, high: bool) {
        let bit = 1 << n;
        let was = self.levels & bit != 0;
        if was == high {
            return;
        }
        self.levels ^= bit;
        let triggered = if high { self.rtsr } else { self.ftsr } & bit != 0;
        if triggered && (EXTI_PENDS_WHEN_MASKED || self.imr & bit != 0) {
            self.pr |= bit;
        }
    }

    /// Whether line `n` requests its interrupt.
    pub fn irq(&self, n: u32) -> bool {
        self.pr & self.imr & 1 << n != 0
    }

    /// A register read.
    pub fn read(&self, offset: u32) -> u32 {
        match offset {
            IMR => self.imr,
            EMR => self.emr,
            RTSR => self.rtsr,
            FTSR => self.ftsr,
            SWIER => self.swier,
            PR => self.pr,
            _ => 0,
        }
    }

    /// A register write.
    pub fn write(&mut self, offset: u32, value: u32) {
        let value = value & LINES;
        match offset {
            IMR => self.imr = value,
            EMR => self.emr = value,
            RTSR => self.rtsr = value,
            FTSR => self.ftsr = value,
            SWIER => {
                // A 0 -> 1 write pends an unmasked line.
                let rising = value & !self.swier;
                self.pr |= rising & self.imr;
                self.swier = value;
            }
            PR => {
                self.pr &= !value;
                self.swier &= !value;
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn falling_edge_pends_and_write_one_clears() {
        let mut e = Exti::new();
        e.write(FTSR, 1);
        e.write(IMR, 1);
        e.input(0, true);
        assert!(!e.irq(0));
        e.input(0, false);
        assert!(e.irq(0));
        e.input(0, false);
        e.write(PR, 1);
        assert!(!e.irq(0), "level stays low: no new edge");
        e.input(0, true);
        assert!(!e.irq(0), "rising edge not selected");
    }
}
