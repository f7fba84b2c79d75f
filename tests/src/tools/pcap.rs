//! Classic pcap writer (LINKTYPE_ETHERNET = 1, nanosecond timestamps, magic
//! 0xA1B23C4D) for the frames the virtual board sees, in both directions.

use std::io::{self, Write};
use std::path::Path;

/// Link type Ethernet.
pub const LINKTYPE_ETHERNET: u32 = 1;
/// Magic of nanosecond-resolution classic pcap.
pub const MAGIC_NS: u32 = 0xA1B2_3C4D;

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
        buf.extend_from_slice(&MAGIC_NS.to_le_bytes());
        buf.extend_from_slice(&2u16.to_le_bytes());
        buf.extend_from_slice(&4u16.to_le_bytes());
        buf.extend_from_slice(&0i32.to_le_bytes()); // thiszone
        buf.extend_from_slice(&0u32.to_le_bytes()); // sigfigs
        buf.extend_from_slice(&65535u32.to_le_bytes()); // snaplen
        buf.extend_from_slice(&LINKTYPE_ETHERNET.to_le_bytes());
        Self { buf, frames: 0 }
    }

    /// Appends one frame captured at virtual time `time_ns`.
    pub fn record(&mut self, time_ns: u64, frame: &[u8]) {
        let sec = (time_ns / 1_000_000_000) as u32;
        let nsec = (time_ns % 1_000_000_000) as u32;
        self.buf.extend_from_slice(&sec.to_le_bytes());
        self.buf.extend_from_slice(&nsec.to_le_bytes());
        self.buf
            .extend_from_slice(&(frame.len() as u32).to_le_bytes());
        self.buf
            .extend_from_slice(&(frame.len() as u32).to_le_bytes());
        self.buf.extend_from_slice(frame);
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
    if bytes.len() < 24 || u32::from_le_bytes(bytes[0..4].try_into().ok()?) != MAGIC_NS {
        return None;
    }
    let mut pos = 24;
    let mut out = Vec::new();
    while pos + 16 <= bytes.len() {
        let sec = u32::from_le_bytes(bytes[pos..pos + 4].try_into().ok()?) as u64;
        let nsec = u32::from_le_bytes(bytes[pos + 4..pos + 8].try_into().ok()?) as u64;
        let len = u32::from_le_bytes(bytes[pos + 8..pos + 12].try_into().ok()?) as usize;
        pos += 16;
        out.push((
            sec * 1_000_000_000 + nsec,
            bytes.get(pos..pos + len)?.to_vec(),
        ));
        pos += len;
    }
    Some(out)
}

/// Reads the packets of a pcapng capture (Wireshark's default format, as the real-world
/// captures are stored) whose interface has link type Ethernet: Enhanced and Simple Packet
/// Blocks, every section, either byte order. `None` when the bytes are not pcapng or a block
/// runs past the end.
pub fn read_pcapng(bytes: &[u8]) -> Option<Vec<Vec<u8>>> {
    const SECTION_HEADER: u32 = 0x0A0D_0D0A;
    const INTERFACE_DESCRIPTION: u32 = 1;
    const SIMPLE_PACKET: u32 = 3;
    const ENHANCED_PACKET: u32 = 6;
    const BYTE_ORDER_MAGIC: u32 = 0x1A2B_3C4D;

    let mut big_endian = false;
    let u32_at = |big: bool, at: usize| -> Option<u32> {
        let b: [u8; 4] = bytes.get(at..at + 4)?.try_into().ok()?;
        Some(if big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    };
    let u16_at = |big: bool, at: usize| -> Option<u16> {
        let b: [u8; 2] = bytes.get(at..at + 2)?.try_into().ok()?;
        Some(if big {
            u16::from_be_bytes(b)
        } else {
            u16::from_le_bytes(b)
        })
    };
    if u32_at(false, 0)? != SECTION_HEADER {
        return None;
    }
    let mut link_types: Vec<u16> = Vec::new();
    let mut packets = Vec::new();
    let mut pos = 0;
    while pos + 12 <= bytes.len() {
        let kind = u32_at(big_endian, pos)?;
        if kind == SECTION_HEADER {
            big_endian = match u32_at(false, pos + 8)? {
                BYTE_ORDER_MAGIC => false,
                m if m.swap_bytes() == BYTE_ORDER_MAGIC => true,
                _ => return None,
            };
            link_types.clear();
        }
        let len = usize::try_from(u32_at(big_endian, pos + 4)?).ok()?;
        if len < 12 || pos + len > bytes.len() {
            return None;
        }
        let body = pos + 8;
        match kind {
            INTERFACE_DESCRIPTION => link_types.push(u16_at(big_endian, body)?),
            ENHANCED_PACKET => {
                let interface = usize::try_from(u32_at(big_endian, body)?).ok()?;
                let captured = usize::try_from(u32_at(big_endian, body + 12)?).ok()?;
                let data = bytes.get(body + 20..body + 20 + captured)?;
                if link_types.get(interface) == Some(&(LINKTYPE_ETHERNET as u16)) {
                    packets.push(data.to_vec());
                }
            }
            SIMPLE_PACKET => {
                let original = usize::try_from(u32_at(big_endian, body)?).ok()?;
                let data = bytes.get(body + 4..(body + 4 + original).min(pos + len - 4))?;
                if link_types.first() == Some(&(LINKTYPE_ETHERNET as u16)) {
                    packets.push(data.to_vec());
                }
            }
            _ => {}
        }
        pos += len;
    }
    Some(packets)
}
