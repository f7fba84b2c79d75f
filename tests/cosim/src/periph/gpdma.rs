//! The general purpose DMA controller (UM10360 chapter 31, base 0x5000_4000): 8 channels
//! (0 = highest priority), linked lists, terminal count and error interrupts on one line.
//!
//! Flow control by the DMA: a channel whose request line is active moves one element of
//! SWidth (burst size 1, what the firmware programs) per request; after the last element of
//! an item it raises its terminal count if the item's I bit is set and loads the next item
//! from DMACCxLLI, or stops. The data moves through [`crate::machine`], which asks
//! [`Gpdma::next_transfer`] what to move and reports back with [`Gpdma::transferred`].

use super::{Peripheral, Tick};

/// One element to move.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transfer {
    /// Channel.
    pub channel: usize,
    /// Source address.
    pub src: u32,
    /// Destination address.
    pub dst: u32,
    /// Bytes (1, 2 or 4).
    pub width: u32,
    /// The request line served (None: memory to memory).
    pub request: Option<u32>,
}

/// What a channel needs after an element moved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum After {
    /// More elements in this item.
    Continue,
    /// The item is done: load the next one (4 words) from this address.
    LoadItem(u32),
    /// The list is done: the channel stopped.
    Stopped,
}

#[derive(Clone, Copy, Debug, Default)]
struct Channel {
    src: u32,
    dst: u32,
    lli: u32,
    control: u32,
    config: u32,
}

impl Channel {
    fn enabled(&self) -> bool {
        self.config & 1 != 0
    }
    fn flow(&self) -> u32 {
        (self.config >> 11) & 7
    }
    fn request_line(&self) -> Option<u32> {
        match self.flow() {
            1 => Some((self.config >> 6) & 0x1F), // memory to peripheral: DestPeripheral
            2 => Some((self.config >> 1) & 0x1F), // peripheral to memory: SrcPeripheral
            _ => None,
        }
    }
    fn halted(&self) -> bool {
        self.config & (1 << 18) != 0
    }
}

/// The GPDMA.
#[derive(Clone, Debug, Default)]
pub struct Gpdma {
    config: u32,
    ch: [Channel; 8],
    tc_raw: u32,
    err_raw: u32,
    /// Elements moved, per channel.
    pub moved: [u64; 8],
}

impl Gpdma {
    /// Reset state.
    pub fn new() -> Self {
        Self::default()
    }

    fn width(code: u32) -> u32 {
        1 << (code & 3).min(2)
    }

    /// The next element to move under the active `requests` (bit n = line n), highest
    /// priority channel first.
    pub fn next_transfer(&self, requests: u32) -> Option<Transfer> {
        if self.config & 1 == 0 {
            return None;
        }
        self.ch.iter().enumerate().find_map(|(n, c)| {
            if !c.enabled() || c.halted() {
                return None;
            }
            let line = c.request_line();
            if line.is_some_and(|l| requests & (1 << l) == 0) {
                return None;
            }
            if c.flow() == 3 {
                return None; // peripheral to peripheral: not used, not modelled
            }
            Some(Transfer {
                channel: n,
                src: c.src,
                dst: c.dst,
                width: Self::width(c.control >> 18),
                request: line,
            })
        })
    }

    /// The element of `x` moved: addresses step, the count drops, the item may end.
    pub fn transferred(&mut self, x: &Transfer) -> After {
        let c = &mut self.ch[x.channel];
        self.moved[x.channel] += 1;
        if c.control & (1 << 26) != 0 {
            c.src = c.src.wrapping_add(Self::width(c.control >> 18));
        }
        if c.control & (1 << 27) != 0 {
            c.dst = c.dst.wrapping_add(Self::width(c.control >> 21));
        }
        let left = (c.control & 0xFFF).saturating_sub(1);
        c.control = (c.control & !0xFFF) | left;
        if left > 0 {
            return After::Continue;
        }
        if c.control & (1 << 31) != 0 {
            self.tc_raw |= 1 << x.channel;
        }
        if c.lli != 0 {
            After::LoadItem(c.lli & !3)
        } else {
            c.config &= !1;
            After::Stopped
        }
    }

    /// The next item of channel `n`: source, destination, next item, control.
    pub fn load_item(&mut self, n: usize, item: [u32; 4]) {
        let c = &mut self.ch[n];
        c.src = item[0];
        c.dst = item[1];
        c.lli = item[2];
        c.control = item[3];
    }

    /// A bus error on channel `n`: the channel stops, its error flag rises.
    pub fn error(&mut self, n: usize) {
        self.err_raw |= 1 << n;
        self.ch[n].config &= !1;
    }

    fn tc_stat(&self) -> u32 {
        (0..8)
            .filter(|&n| self.tc_raw & (1 << n) != 0 && self.ch[n].config & (1 << 15) != 0)
            .fold(0, |a, n| a | 1 << n)
    }

    fn err_stat(&self) -> u32 {
        (0..8)
            .filter(|&n| self.err_raw & (1 << n) != 0 && self.ch[n].config & (1 << 14) != 0)
            .fold(0, |a, n| a | 1 << n)
    }
}

impl Peripheral for Gpdma {
    fn read(&mut self, _t: Tick, offset: u32) -> u32 {
        match offset {
            0x000 => self.tc_stat() | self.err_stat(),
            0x004 => self.tc_stat(),
            0x00C => self.err_stat(),
            0x014 => self.tc_raw,
            0x018 => self.err_raw,
            0x01C => (0..8).fold(0, |a, n| a | u32::from(self.ch[n].enabled()) << n),
            0x030 => self.config,
            0x100..=0x1FF => {
                let c = &self.ch[((offset - 0x100) / 0x20) as usize];
                match offset % 0x20 {
                    0x00 => c.src,
                    0x04 => c.dst,
                    0x08 => c.lli,
                    0x0C => c.control,
                    // A (b17): active while enabled with elements left.
                    0x10 => c.config | u32::from(c.enabled() && c.control & 0xFFF != 0) << 17,
                    _ => 0,
                }
            }
            _ => 0,
        }
    }

    fn write(&mut self, _t: Tick, offset: u32, value: u32) {
        match offset {
            0x008 => self.tc_raw &= !(value & 0xFF),
            0x010 => self.err_raw &= !(value & 0xFF),
            0x030 => self.config = value & 3,
            0x100..=0x1FF => {
                let c = &mut self.ch[((offset - 0x100) / 0x20) as usize];
                match offset % 0x20 {
                    0x00 => c.src = value,
                    0x04 => c.dst = value,
                    0x08 => c.lli = value & !3,
                    0x0C => c.control = value,
                    0x10 => c.config = value & 0x7_FFFF & !(1 << 17),
                    _ => {}
                }
            }
            _ => {}
        }
    }

    fn irq(&self) -> bool {
        self.tc_stat() | self.err_stat() != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: Tick = Tick {
        now_ns: 0,
        pclk_hz: 0,
    };

    /// A two-element item on request line 3, with the TC interrupt, that links to itself.
    #[test]
    fn requests_items_and_terminal_count() {
        let mut d = Gpdma::new();
        d.write(T, 0x030, 1);
        d.write(T, 0x100, 0x4003_0008);
        d.write(T, 0x104, 0x2007_C000);
        d.write(T, 0x108, 0x2007_C100);
        // 2 transfers, half words, DI, I.
        d.write(T, 0x10C, 2 | (1 << 18) | (1 << 21) | (1 << 27) | (1 << 31));
        d.write(T, 0x110, 1 | (3 << 1) | (2 << 11) | (1 << 15));
        assert_eq!(d.next_transfer(0), None, "no request");
        let x = d.next_transfer(1 << 3).unwrap();
        assert_eq!((x.src, x.dst, x.width), (0x4003_0008, 0x2007_C000, 2));
        assert_eq!(d.transferred(&x), After::Continue);
        let x = d.next_transfer(1 << 3).unwrap();
        assert_eq!(x.dst, 0x2007_C002);
        assert_eq!(d.transferred(&x), After::LoadItem(0x2007_C100));
        assert!(d.irq());
        d.load_item(0, [0x4003_0008, 0x2007_C000, 0, 1 | (1 << 18) | (1 << 21)]);
        d.write(T, 0x008, 1);
        assert!(!d.irq());
        let x = d.next_transfer(1 << 3).unwrap();
        assert_eq!(d.transferred(&x), After::Stopped);
        assert_eq!(
            d.read(T, 0x01C),
            0,
            "channel stopped at the end of the list"
        );
    }
}
