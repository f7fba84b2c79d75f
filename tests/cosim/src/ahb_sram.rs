//! The AHB SRAM bank 0 (16 KB at 0x2007_C000), where the GPDMA works, with a watch over the
//! words the GPDMA fills from a peripheral (the AD7689 results from SSP1): a result is
//! **lost** when the GPDMA overwrites it before the CPU read it. Only words the CPU has read
//! at least once count (a word it never reads, like the DMA list's skip word for the
//! start-up frames, is not a sample the firmware takes).
//!
//! The machine owns the bank: the CPU reaches it through the engine's MMIO callbacks, the
//! GPDMA directly, so both are seen.

/// Base and size of the bank.
pub const BASE: u32 = 0x2007_C000;
/// See [`BASE`].
pub const SIZE: u32 = 0x4000;

/// What the watch saw.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SampleWatch {
    /// Halfwords the GPDMA wrote from a peripheral.
    pub written: u64,
    /// Of those, read by the CPU before they were overwritten.
    pub read: u64,
    /// Overwritten by the GPDMA before the CPU read them (in words the CPU reads).
    pub lost: u64,
    /// Virtual time (ns) of the first loss.
    pub first_lost_ns: Option<u64>,
}

/// The bank and its watch.
pub struct AhbSram {
    bytes: Vec<u8>,
    /// Per halfword: written from a peripheral and not read since.
    unread: Vec<bool>,
    /// Per halfword: the CPU has read it.
    taken: Vec<bool>,
    /// The figures.
    pub watch: SampleWatch,
}

impl Default for AhbSram {
    fn default() -> Self {
        Self::new()
    }
}

impl AhbSram {
    /// The bank at power-on (zeros: UM10360 leaves SRAM undefined; nothing relies on it).
    pub fn new() -> Self {
        Self {
            bytes: vec![0; SIZE as usize],
            unread: vec![false; SIZE as usize / 2],
            taken: vec![false; SIZE as usize / 2],
            watch: SampleWatch::default(),
        }
    }

    /// Whether `len` bytes at `addr` lie in the bank.
    pub fn contains(addr: u32, len: usize) -> bool {
        addr >= BASE && u64::from(addr) + len as u64 <= u64::from(BASE + SIZE)
    }

    fn range(addr: u32, len: usize) -> std::ops::Range<usize> {
        let at = (addr - BASE) as usize;
        at..at + len
    }

    /// A CPU read: the halfwords it covers count as taken.
    pub fn cpu_read(&mut self, addr: u32, buf: &mut [u8]) {
        let r = Self::range(addr, buf.len());
        buf.copy_from_slice(&self.bytes[r.clone()]);
        for h in r.start / 2..r.end.div_ceil(2) {
            if self.unread[h] {
                self.unread[h] = false;
                self.watch.read += 1;
            }
            self.taken[h] = true;
        }
    }

    /// A CPU write.
    pub fn cpu_write(&mut self, addr: u32, data: &[u8]) {
        let r = Self::range(addr, data.len());
        self.bytes[r.clone()].copy_from_slice(data);
        for h in r.start / 2..r.end.div_ceil(2) {
            self.unread[h] = false;
        }
    }

    /// A GPDMA read (lists, source words): not a CPU read.
    pub fn dma_read(&self, addr: u32, buf: &mut [u8]) {
        buf.copy_from_slice(&self.bytes[Self::range(addr, buf.len())]);
    }

    /// A GPDMA write at `now_ns`; `from_peripheral` when its source is a peripheral (a
    /// sample), which the watch follows.
    pub fn dma_write(&mut self, addr: u32, data: &[u8], from_peripheral: bool, now_ns: u64) {
        let r = Self::range(addr, data.len());
        self.bytes[r.clone()].copy_from_slice(data);
        for h in r.start / 2..r.end.div_ceil(2) {
            if from_peripheral {
                if self.unread[h] && self.taken[h] {
                    self.watch.lost += 1;
                    self.watch.first_lost_ns.get_or_insert(now_ns);
                }
                self.unread[h] = true;
                self.watch.written += 1;
            } else {
                self.unread[h] = false;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sample_overwritten_before_the_cpu_read_it_is_lost() {
        let mut m = AhbSram::new();
        let ring = BASE + 0x100;
        let skip = BASE + 0x800;
        // Start-up frames into a word the CPU never reads: not samples it takes.
        for _ in 0..3 {
            m.dma_write(skip, &[1, 0], true, 0);
        }
        assert_eq!(m.watch.lost, 0);
        m.dma_write(ring, &[0x34, 0x12], true, 10);
        let mut b = [0u8; 2];
        m.cpu_read(ring, &mut b);
        assert_eq!(b, [0x34, 0x12]);
        m.dma_write(ring, &[0x35, 0x12], true, 20);
        m.cpu_read(ring, &mut b);
        assert_eq!((m.watch.written, m.watch.read, m.watch.lost), (5, 2, 0));
        // Written twice without a read in between: the first is lost.
        m.dma_write(ring, &[0x36, 0x12], true, 30);
        m.dma_write(ring, &[0x37, 0x12], true, 40);
        assert_eq!(m.watch.lost, 1);
        assert_eq!(m.watch.first_lost_ns, Some(40));
        // A word read as part of a 32-bit read counts as read.
        let mut w = [0u8; 4];
        m.cpu_read(ring, &mut w);
        m.dma_write(ring, &[0, 0], true, 50);
        assert_eq!(m.watch.lost, 1);
        assert!(AhbSram::contains(BASE + SIZE - 4, 4));
        assert!(!AhbSram::contains(BASE + SIZE - 2, 4));
        assert!(!AhbSram::contains(BASE - 2, 2));
    }
}
