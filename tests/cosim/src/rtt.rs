//! The firmware's log: defmt frames in the RTT up-buffer 0 (`_SEGGER_RTT`, SEGGER RTT
//! control block as defmt-rtt lays it out: id[16], max_up, max_down, then per buffer name,
//! buf, size, write, read, flags), drained as a debug probe would and decoded with
//! defmt-decoder against the image's own tables.

/// The memory the log reader reaches (the local SRAM, where `_SEGGER_RTT` and its buffer
/// live).
pub trait Memory {
    /// Reads `buf.len()` bytes at `addr`; false when unmapped.
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> bool;
    /// Writes; false when unmapped or read-only.
    fn write(&mut self, addr: u32, data: &[u8]) -> bool;
}

/// The log of one run.
pub struct Rtt {
    control: Option<u32>,
    table: Option<defmt_decoder::Table>,
    raw: Vec<u8>,
    decoded_upto: usize,
    /// Decoded lines, in order.
    pub lines: Vec<String>,
}

impl Rtt {
    /// The log of an image (`elf` for the tables, `control`: address of `_SEGGER_RTT`).
    pub fn new(elf: &[u8], control: Option<u32>) -> Self {
        let table = defmt_decoder::Table::parse(elf).ok().flatten();
        Self {
            control,
            table,
            raw: Vec::new(),
            decoded_upto: 0,
            lines: Vec::new(),
        }
    }

    fn word(mem: &mut dyn Memory, addr: u32) -> Option<u32> {
        let mut b = [0u8; 4];
        mem.read(addr, &mut b).then(|| u32::from_le_bytes(b))
    }

    /// Takes what the firmware wrote since the last call; returns the new lines.
    pub fn drain(&mut self, mem: &mut dyn Memory) -> Vec<String> {
        let Some(cb) = self.control else {
            return Vec::new();
        };
        let mut id = [0u8; 16];
        if !mem.read(cb, &mut id) || !id.starts_with(b"SEGGER RTT") {
            return Vec::new(); // not initialised yet
        }
        let up = cb + 24;
        let (Some(buf), Some(size), Some(write), Some(read)) = (
            Self::word(mem, up + 4),
            Self::word(mem, up + 8),
            Self::word(mem, up + 12),
            Self::word(mem, up + 16),
        ) else {
            return Vec::new();
        };
        if size == 0 || write >= size || read >= size || write == read {
            return Vec::new();
        }
        let mut take = |from: u32, to: u32, raw: &mut Vec<u8>| {
            let mut b = vec![0u8; (to - from) as usize];
            if mem.read(buf + from, &mut b) {
                raw.extend_from_slice(&b);
            }
        };
        if write > read {
            take(read, write, &mut self.raw);
        } else {
            take(read, size, &mut self.raw);
            take(0, write, &mut self.raw);
        }
        let _ = mem.write(up + 16, &write.to_le_bytes());
        self.decode()
    }

    fn decode(&mut self) -> Vec<String> {
        let Some(table) = &self.table else {
            return Vec::new();
        };
        // Complete rzCOBS frames end with a 0 byte; decode those only.
        let Some(end) = self.raw.iter().rposition(|&b| b == 0) else {
            return Vec::new();
        };
        if end < self.decoded_upto {
            return Vec::new();
        }
        let mut dec = table.new_stream_decoder();
        dec.received(&self.raw[self.decoded_upto..=end]);
        let mut new = Vec::new();
        loop {
            match dec.decode() {
                Ok(frame) => {
                    let level = frame
                        .level()
                        .map_or("LOG".to_string(), |l| format!("{l:?}").to_uppercase());
                    new.push(format!("{level:<5} {}", frame.display_message()));
                }
                Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
                Err(defmt_decoder::DecodeError::Malformed) => {
                    new.push("(malformed defmt frame)".into());
                }
            }
        }
        self.decoded_upto = end + 1;
        self.lines.extend(new.iter().cloned());
        new
    }
}
