//! Captures: the classic pcap the virtual board writes (LINKTYPE_ETHERNET = 1, nanosecond
//! timestamps, magic 0xA1B23C4D) for the frames it sees in both directions, and the pcapng
//! the real-world captures are stored in, both through the `pcap-file` crate.

use byteorder_slice::LittleEndian;
use pcap_file::pcap::{PcapHeader, PcapPacket, PcapReader};
use pcap_file::pcapng::{Block, PcapNgReader};
use pcap_file::{DataLink, Endianness, TsResolution};
use std::io::{self, Write};
use std::path::Path;
use std::time::Duration;

/// Link type Ethernet.
pub const LINKTYPE_ETHERNET: u32 = 1;
/// Magic of nanosecond-resolution classic pcap.
pub const MAGIC_NS: u32 = 0xA1B2_3C4D;

/// The header of every capture the board writes.
const HEADER: PcapHeader = PcapHeader {
    version_major: 2,
    version_minor: 4,
    ts_correction: 0,
    ts_accuracy: 0,
    snaplen: 65535,
    datalink: DataLink::ETHERNET,
    ts_resolution: TsResolution::NanoSecond,
    endianness: Endianness::Little,
};

/// An in-memory pcap capture.
#[derive(Clone, Debug)]
pub struct PcapWriter {
    buf: Vec<u8>,
    frames: usize,
}

impl Default for PcapWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl PcapWriter {
    /// A capture with only the global header.
    pub fn new() -> Self {
        let mut buf = Vec::with_capacity(1 << 16);
        // Writing into a Vec cannot fail.
        let _ = HEADER.write_to(&mut buf);
        Self { buf, frames: 0 }
    }

    /// Appends one frame captured at virtual time `time_ns`.
    pub fn record(&mut self, time_ns: u64, frame: &[u8]) {
        let len = u32::try_from(frame.len()).unwrap_or(u32::MAX);
        let packet = PcapPacket::new(Duration::from_nanos(time_ns), len, frame);
        let _ = packet.write_to::<_, LittleEndian>(
            &mut self.buf,
            HEADER.ts_resolution,
            HEADER.snaplen.max(len),
        );
        self.frames += 1;
    }

    /// Number of frames recorded.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The capture file bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.buf
    }

    /// Writes the capture to `w`.
    pub fn write_to(&self, mut w: impl Write) -> io::Result<()> {
        w.write_all(&self.buf)
    }

    /// Writes the capture to a file.
    pub fn save(&self, path: impl AsRef<Path>) -> io::Result<()> {
        std::fs::write(path, &self.buf)
    }
}

/// Reads back the records of a capture written by [`PcapWriter`]: (time_ns, frame).
pub fn read_records(bytes: &[u8]) -> Option<Vec<(u64, Vec<u8>)>> {
    let mut reader = PcapReader::new(bytes).ok()?;
    if reader.header().ts_resolution != TsResolution::NanoSecond {
        return None;
    }
    let mut out = Vec::new();
    while let Some(packet) = reader.next_packet() {
        let packet = packet.ok()?;
        let time_ns = u64::try_from(packet.timestamp.as_nanos()).ok()?;
        out.push((time_ns, packet.data.into_owned()));
    }
    Some(out)
}

/// Reads the packets of a pcapng capture (Wireshark's default format, as the real-world
/// captures are stored) whose interface has link type Ethernet: Enhanced and Simple Packet
/// Blocks, every section, either byte order. `None` when the bytes are not pcapng or a block
/// runs past the end.
pub fn read_pcapng(bytes: &[u8]) -> Option<Vec<Vec<u8>>> {
    let mut reader = PcapNgReader::new(bytes).ok()?;
    let mut packets = Vec::new();
    while let Some(block) = reader.next_block() {
        // Owned, so that the reader's interfaces can be asked about it.
        let block = block.ok()?.into_owned();
        match block {
            Block::EnhancedPacket(p) => {
                let ethernet = reader.interfaces().get(p.interface_id as usize);
                if ethernet.is_some_and(|i| i.linktype == DataLink::ETHERNET) {
                    packets.push(p.data.into_owned());
                }
            }
            Block::SimplePacket(p) => {
                // A simple packet belongs to the section's first interface; its block is
                // padded to 4 bytes, the original length says how much is the frame.
                let ethernet = reader.interfaces().first();
                if ethernet.is_some_and(|i| i.linktype == DataLink::ETHERNET) {
                    let len = (p.original_len as usize).min(p.data.len());
                    packets.push(p.data[..len].to_vec());
                }
            }
            _ => {}
        }
    }
    Some(packets)
}
