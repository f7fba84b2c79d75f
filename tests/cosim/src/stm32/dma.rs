//! DMA1 (RM0008 chapter 13): 7 channels, each with CCR (EN, TCIE/HTIE/TEIE, DIR, CIRC,
//! PINC/MINC, PSIZE/MSIZE, PL, MEM2MEM), CNDTR, CPAR, CMAR; the arbiter serves the requesting
//! channel of highest priority (PL, then the lower number); ISR's TC/HT/TE and GIF per
//! channel, cleared through IFCR; circular mode reloads the count and the addresses. Which
//! peripheral requests which channel is the machine's (RM0008 table 78).

const ISR: u32 = 0x00;
const IFCR: u32 = 0x04;

const EN: u32 = 1 << 0;
const TCIE: u32 = 1 << 1;
const HTIE: u32 = 1 << 2;
const TEIE: u32 = 1 << 3;
const DIR: u32 = 1 << 4;
const CIRC: u32 = 1 << 5;
const PINC: u32 = 1 << 6;
const MINC: u32 = 1 << 7;
const MEM2MEM: u32 = 1 << 14;

/// One channel.
#[derive(Clone, Debug, Default)]
struct Channel {
    ccr: u32,
    cndtr: u32,
    cpar: u32,
    cmar: u32,
    /// The count and the addresses as the transfer goes (CPAR/CMAR keep their values).
    reload: u32,
    par: u32,
    mar: u32,
}

/// One transfer the arbiter grants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transfer {
    /// Channel index (0 = channel 1).
    pub channel: usize,
    /// Source and destination addresses.
    pub src: u32,
    /// See [`Transfer::src`].
    pub dst: u32,
    /// Bytes read from the source.
    pub src_bytes: usize,
    /// Bytes written to the destination.
    pub dst_bytes: usize,
}

/// DMA1.
#[derive(Clone, Debug, Default)]
pub struct Dma {
    ch: [Channel; 7],
    isr: u32,
}

fn size(bits: u32) -> usize {
    match bits & 3 {
        0 => 1,
        1 => 2,
        _ => 4,
    }
}

impl Dma {
    /// Reset.
    pub fn new() -> Self {
        Self::default()
    }

    /// The channel (0..6) the arbiter serves for `requests` (bit n: channel n + 1's
    /// peripheral requests), if any.
    pub fn next_transfer(&self, requests: u32) -> Option<Transfer> {
        let c = (0..7)
            .filter(|&n| {
                let ch = &self.ch[n];
                ch.ccr & EN != 0
                    && ch.cndtr > 0
                    && (requests & 1 << n != 0 || ch.ccr & MEM2MEM != 0)
            })
            .max_by_key(|&n| ((self.ch[n].ccr >> 12) & 3, 7 - n))?;
        let ch = &self.ch[c];
        let psize = size(ch.ccr >> 8);
        let msize = size(ch.ccr >> 10);
        Some(if ch.ccr & DIR != 0 {
            Transfer {
                channel: c,
                src: ch.mar,
                dst: ch.par,
                src_bytes: msize,
                dst_bytes: psize,
            }
        } else {
            Transfer {
                channel: c,
                src: ch.par,
                dst: ch.mar,
                src_bytes: psize,
                dst_bytes: msize,
            }
        })
    }

    /// The transfer `x` is done: addresses, count, flags, circular reload.
    pub fn transferred(&mut self, x: &Transfer) {
        let ch = &mut self.ch[x.channel];
        if ch.ccr & PINC != 0 {
            ch.par = ch.par.wrapping_add(size(ch.ccr >> 8) as u32);
        }
        if ch.ccr & MINC != 0 {
            ch.mar = ch.mar.wrapping_add(size(ch.ccr >> 10) as u32);
        }
        ch.cndtr -= 1;
        let shift = 4 * x.channel;
        if ch.cndtr == ch.reload / 2 {
            self.isr |= 0b0101 << shift;
        }
        if ch.cndtr == 0 {
            self.isr |= 0b0011 << shift;
            if ch.ccr & CIRC != 0 {
                ch.cndtr = ch.reload;
                ch.par = ch.cpar;
                ch.mar = ch.cmar;
            }
        }
    }

    /// A bus error on `x`: TEIF, and the channel disables itself.
    pub fn error(&mut self, x: &Transfer) {
        self.isr |= 0b1001 << (4 * x.channel);
        self.ch[x.channel].ccr &= !EN;
    }

    /// The interrupt of channel `c` (0..6).
    pub fn irq(&self, c: usize) -> bool {
        let flags = (self.isr >> (4 * c)) & 0xF;
        let ccr = self.ch[c].ccr;
        (flags & 2 != 0 && ccr & TCIE != 0)
            || (flags & 4 != 0 && ccr & HTIE != 0)
            || (flags & 8 != 0 && ccr & TEIE != 0)
    }

    /// A register read.
    pub fn read(&self, offset: u32) -> u32 {
        match offset {
            ISR => self.isr,
            IFCR => 0,
            0x08..=0x8B => {
                let ch = &self.ch[((offset - 0x08) / 20) as usize];
                match (offset - 0x08) % 20 {
                    0 => ch.ccr,
                    4 => ch.cndtr,
                    8 => ch.cpar,
                    12 => ch.cmar,
                    _ => 0,
                }
            }
            _ => 0,
        }
    }

    /// A register write; `Err` for a write the channel refuses while enabled (RM0008: CNDTR,
    /// CPAR and CMAR are read-only while EN is set).
    pub fn write(&mut self, offset: u32, value: u32) -> Result<(), String> {
        match offset {
            ISR => {}
            IFCR => {
                for c in 0..7 {
                    let v = (value >> (4 * c)) & 0xF;
                    // CGIF clears all four.
                    let clear = if v & 1 != 0 { 0xF } else { v };
                    self.isr &= !(clear << (4 * c));
                }
            }
            0x08..=0x8B => {
                let n = ((offset - 0x08) / 20) as usize;
                let ch = &mut self.ch[n];
                let reg = (offset - 0x08) % 20;
                if reg != 0 && ch.ccr & EN != 0 {
                    return Err(format!(
                        "DMA1 channel {}: write of {value:#x} to offset {reg:#x} while the \
                         channel is enabled (read-only then): ignored",
                        n + 1
                    ));
                }
                match reg {
                    0 => {
                        let was = ch.ccr & EN != 0;
                        ch.ccr = value & 0x7FFF;
                        if ch.ccr & EN != 0 && !was {
                            ch.reload = ch.cndtr;
                            ch.par = ch.cpar;
                            ch.mar = ch.cmar;
                        }
                    }
                    4 => ch.cndtr = value & 0xFFFF,
                    8 => ch.cpar = value,
                    12 => ch.cmar = value,
                    _ => {}
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Channel `c`'s remaining count (CNDTR).
    pub fn cndtr(&self, c: usize) -> u32 {
        self.ch[c].cndtr
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circular_peripheral_to_memory_with_half_and_complete_flags() {
        let mut d = Dma::new();
        // Channel 2: SPI1 DR -> ring of 4 halfwords, circular, HT/TC interrupts.
        d.write(0x08 + 20 + 4, 4).unwrap();
        d.write(0x08 + 20 + 8, 0x4001_300C).unwrap();
        d.write(0x08 + 20 + 12, 0x2000_0000).unwrap();
        let ccr = EN | TCIE | HTIE | CIRC | MINC | 1 << 8 | 1 << 10 | 3 << 12;
        d.write(0x08 + 20, ccr).unwrap();
        assert!(
            d.write(0x08 + 20 + 4, 8).is_err(),
            "CNDTR locked while enabled"
        );
        assert_eq!(d.next_transfer(0), None, "no request");
        let mut dsts = Vec::new();
        for _ in 0..5 {
            let x = d.next_transfer(1 << 1).unwrap();
            assert_eq!((x.src, x.src_bytes), (0x4001_300C, 2));
            dsts.push(x.dst);
            d.transferred(&x);
            if dsts.len() == 2 {
                assert!(d.irq(1) && d.read(ISR) & 0xF0 == 0x50, "half");
                d.write(IFCR, 1 << 4).unwrap();
            }
        }
        assert_eq!(
            dsts,
            [
                0x2000_0000,
                0x2000_0002,
                0x2000_0004,
                0x2000_0006,
                0x2000_0000
            ]
        );
        assert_eq!(d.read(ISR) >> 4 & 0xF, 0x3, "complete");
        assert_eq!(d.cndtr(1), 3);
    }

    #[test]
    fn priority_then_lower_channel() {
        let mut d = Dma::new();
        for (n, pl) in [(1usize, 2u32), (2, 3), (4, 3)] {
            d.write(0x08 + 20 * n as u32 + 4, 1).unwrap();
            d.write(0x08 + 20 * n as u32, EN | pl << 12).unwrap();
        }
        assert_eq!(d.next_transfer(0x7F).unwrap().channel, 2);
    }
}
