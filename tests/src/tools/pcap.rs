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
