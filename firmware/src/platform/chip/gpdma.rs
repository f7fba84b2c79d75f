//! The LPC17xx general-purpose DMA controller's data formats (UM10360 chapter 31): the
//! linked-list item the GPDMA reads from memory, the channel control and configuration words,
//! the request lines. Plain data, host-tested; the register writes are the firmware binary's
//! (`hw::adc_dma`).

/// A linked-list item as the GPDMA reads it from memory: source, destination, next item,
/// control (UM10360 31.5.x; same order as the channel registers at +0x00..+0x0C).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Lli {
    /// DMACCxSrcAddr.
    pub src: u32,
    /// DMACCxDestAddr.
    pub dst: u32,
    /// DMACCxLLI: address of the next item (bits 1:0 zero), 0 = end of the list.
    pub next: u32,
    /// DMACCxControl.
    pub control: u32,
}

/// Transfer width of one side of a channel (DMACCxControl SWidth/DWidth).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Width {
    /// 8 bits (000).
    Byte = 0,
    /// 16 bits (001).
    Half = 1,
    /// 32 bits (010).
    Word = 2,
}

impl Width {
    /// Bytes per transfer.
    pub const fn bytes(self) -> u32 {
        1 << self as u32
    }
}

/// DMACCxControl fields (bit positions confirmed by the `lpc1769` PAC, generated from NXP's
/// SVD): TransferSize bits 11:0, SBSize bits 14:12, DBSize bits 17:15 (000 = 1), SWidth bits 20:18,
/// DWidth bits 23:21, SI b26, DI b27, I b31 (terminal-count interrupt of this item).
pub mod control {
    /// Largest TransferSize (12 bits).
    pub const MAX_TRANSFERS: u32 = 0xFFF;
    /// SWidth shift.
    pub const SWIDTH: u32 = 18;
    /// DWidth shift.
    pub const DWIDTH: u32 = 21;
    /// Source increment.
    pub const SI: u32 = 1 << 26;
    /// Destination increment.
    pub const DI: u32 = 1 << 27;
    /// Terminal-count interrupt when this item ends.
    pub const I: u32 = 1 << 31;
}

/// One channel's DMACCxControl word: `transfers` single transfers (bursts of 1, so each
/// peripheral request moves exactly one item), widths, increments, interrupt at the end.
pub const fn control_word(
    transfers: u32,
    width: Width,
    src_increment: bool,
    dst_increment: bool,
    interrupt: bool,
) -> u32 {
    assert!(transfers >= 1 && transfers <= control::MAX_TRANSFERS);
    let w = width as u32;
    transfers
        | (w << control::SWIDTH)
        | (w << control::DWIDTH)
        | if src_increment { control::SI } else { 0 }
        | if dst_increment { control::DI } else { 0 }
        | if interrupt { control::I } else { 0 }
}

/// TransferSize of a control word.
pub const fn transfers(control: u32) -> u32 {
    control & control::MAX_TRANSFERS
}

/// DMACCxConfig fields (NXP CMSIS `lpc17xx_gpdma.h`): E b0, SrcPeripheral bits 5:1,
/// DestPeripheral bits 10:6, TransferType bits 13:11 (001 memory to peripheral, 010 peripheral to
/// memory, DMA flow control), IE b14, ITC b15, A b17 (active, read only), H b18 (halt).
pub mod config {
    /// Channel enable.
    pub const E: u32 = 1 << 0;
    /// Error interrupt unmasked.
    pub const IE: u32 = 1 << 14;
    /// Terminal-count interrupt unmasked.
    pub const ITC: u32 = 1 << 15;
    /// Memory to peripheral.
    pub const M2P: u32 = 1 << 11;
    /// Peripheral to memory.
    pub const P2M: u32 = 2 << 11;
}

/// GPDMA request lines (hardware-facts 7 and 10.B; CMSIS connection table): SSP1 TX/RX 2/3;
/// lines 8..15 are UART or timer match per DMAREQSEL bit (line - 8).
pub mod request {
    /// SSP1 receive.
    pub const SSP1_RX: u32 = 3;
    /// Timer2 MR0 (DMAREQSEL bit 4 = 1).
    pub const T2_MR0: u32 = 12;
    /// Timer2 MR1 (DMAREQSEL bit 5 = 1).
    pub const T2_MR1: u32 = 13;
    /// The DMAREQSEL bit that gives `line` (8..=15) to its timer match.
    pub const fn dmareqsel_bit(line: u32) -> u32 {
        assert!(line >= 8 && line <= 15);
        1 << (line - 8)
    }
}

/// DMACCxConfig of a memory-to-peripheral channel on request `line`, TC interrupt masked.
pub const fn config_m2p(line: u32) -> u32 {
    config::E | (line << 6) | config::M2P | config::IE
}

/// DMACCxConfig of a peripheral-to-memory channel on request `line`, TC interrupt enabled.
pub const fn config_p2m(line: u32) -> u32 {
    config::E | (line << 1) | config::P2M | config::IE | config::ITC
}

/// The first item (loaded into the channel registers) and the items in memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chain<const K: usize> {
    /// Channel registers at start.
    pub first: Lli,
    /// Items in memory, at the addresses given.
    pub items: [Lli; K],
}

#[cfg(test)]
pub(crate) mod model {
    use super::*;
    use std::collections::BTreeMap;

    /// The GPDMA's walk through a list, as UM10360 31 describes it for DMA flow control:
    /// each request moves one transfer (bursts of 1); after TransferSize transfers the channel
    /// raises TC if the item's I bit is set and loads the item at LLI.
    pub(crate) struct ChannelModel {
        pub(crate) regs: Lli,
        done: u32,
        items: BTreeMap<u32, Lli>,
    }

    /// One transfer: (source address, destination address, terminal count after it).
    pub(crate) type Transfer = (u32, u32, bool);

    impl ChannelModel {
        pub(crate) fn new<const K: usize>(chain: Chain<K>, at: [u32; K]) -> Self {
            Self {
                regs: chain.first,
                done: 0,
                items: at.into_iter().zip(chain.items).collect(),
            }
        }

        pub(crate) fn request(&mut self) -> Option<Transfer> {
            let c = self.regs.control;
            let width = 1 << ((c >> control::SWIDTH) & 7);
            assert_eq!(width, 1 << ((c >> control::DWIDTH) & 7), "equal widths");
            let t = (self.regs.src, self.regs.dst, false);
            if c & control::SI != 0 {
                self.regs.src += width;
            }
            if c & control::DI != 0 {
                self.regs.dst += width;
            }
            self.done += 1;
            if self.done < transfers(c) {
                return Some(t);
            }
            let tc = c & control::I != 0;
            self.done = 0;
            self.regs = *self.items.get(&self.regs.next)?;
            Some((t.0, t.1, tc))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_and_config_words() {
        // 512 half-words, dst increment, TC interrupt: I | DI | DWidth 1 | SWidth 1 | 0x200.
        assert_eq!(
            control_word(512, Width::Half, false, true, true),
            0x8000_0000 | 0x0800_0000 | (1 << 21) | (1 << 18) | 512
        );
        assert_eq!(
            control_word(2, Width::Word, true, false, false),
            0x0400_0000 | (2 << 21) | (2 << 18) | 2
        );
        // SSP1 RX: SrcPeripheral 3, P2M, IE, ITC, E.
        assert_eq!(
            config_p2m(request::SSP1_RX),
            1 | (3 << 1) | (2 << 11) | (1 << 14) | (1 << 15)
        );
        // T2MR1: DestPeripheral 13, M2P, IE, E (no TC interrupt).
        assert_eq!(
            config_m2p(request::T2_MR1),
            1 | (13 << 6) | (1 << 11) | (1 << 14)
        );
        assert_eq!(request::dmareqsel_bit(request::T2_MR0), 1 << 4);
        assert_eq!(request::dmareqsel_bit(request::T2_MR1), 1 << 5);
    }
}
