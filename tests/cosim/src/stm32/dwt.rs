//! The DWT's cycle counter (ARMv7-M C1.8): CYCCNT counts core cycles while DWT_CTRL.CYCCNTENA
//! and DEMCR.TRCENA are set. The firmware's 64-bit time base rests on it.

/// DEMCR's offset in the SCS.
pub const DEMCR: u32 = 0xDFC;
const TRCENA: u32 = 1 << 24;
const CTRL: u32 = 0x000;
const CYCCNT: u32 = 0x004;

/// DWT_CTRL, DWT_CYCCNT and DEMCR.
#[derive(Clone, Debug, Default)]
pub struct Dwt {
    demcr: u32,
    ctrl: u32,
    /// CYCCNT = (cycles - base) while counting; the value while stopped.
    base: u64,
    stopped: u32,
}

impl Dwt {
    /// Reset: off.
    pub fn new() -> Self {
        Self::default()
    }

    fn counting(&self) -> bool {
        self.demcr & TRCENA != 0 && self.ctrl & 1 != 0
    }

    fn cyccnt(&self, cycles: u64) -> u32 {
        if self.counting() {
            cycles.wrapping_sub(self.base) as u32
        } else {
            self.stopped
        }
    }

    fn update(&mut self, cycles: u64, f: impl FnOnce(&mut Self)) {
        let value = self.cyccnt(cycles);
        f(self);
        self.stopped = value;
        self.base = cycles.wrapping_sub(u64::from(value));
    }

    /// DEMCR read.
    pub fn demcr(&self) -> u32 {
        self.demcr
    }

    /// DEMCR write.
    pub fn write_demcr(&mut self, cycles: u64, value: u32) {
        self.update(cycles, |d| d.demcr = value);
    }

    /// A DWT register read at `cycles`.
    pub fn read(&self, cycles: u64, offset: u32) -> u32 {
        match offset {
            // NUMCOMP 4 in bits 31:28 (the M3's DWT).
            CTRL => 4 << 28 | self.ctrl,
            CYCCNT => self.cyccnt(cycles),
            _ => 0,
        }
    }

    /// A DWT register write; `false` for a register this model does not have.
    pub fn write(&mut self, cycles: u64, offset: u32, value: u32) -> bool {
        match offset {
            CTRL => self.update(cycles, |d| d.ctrl = value & 0x0FFF_FFFF),
            CYCCNT => {
                self.stopped = value;
                self.base = cycles.wrapping_sub(u64::from(value));
            }
            _ => return false,
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_only_with_trcena_and_cyccntena() {
        let mut d = Dwt::new();
        d.write(100, CTRL, 1);
        assert_eq!(d.read(200, CYCCNT), 0, "TRCENA off");
        d.write_demcr(200, TRCENA);
        assert_eq!(d.read(1200, CYCCNT), 1000);
        d.write(1200, CTRL, 0);
        assert_eq!(d.read(5000, CYCCNT), 1000, "stopped");
    }
}
