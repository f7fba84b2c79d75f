//! A minimal CoE SDO upload client on raw mailbox access (ethercrab's register reads and
//! writes through the in-process rig, [`crate::master`]): initiate upload, then upload
//! segments until the last one (ETG.1000.6 5.6.2.2/5.6.2.3).
//!
//! It exists because ethercrab 0.7.1's `SubDeviceRef::sdo_read` cannot complete a
//! segmented upload: its mailbox response parser (`mailbox/coe/mod.rs`, `HeadersRaw`)
//! decodes the top three bits of the SDO command byte into `CoeCommand`, which has no
//! variant for 0, the command specifier every upload segment response carries, so the
//! first segment fails with `Error::Wire(WireError::InvalidValue)`. (Its segment loop also
//! starts filling the buffer from 0, dropping the data the initiate response carried.)

use ethercrab::SubDeviceRef;

/// SDO command specifiers (bits 7..5 of the command byte).
mod cs {
    pub const UPLOAD_SEGMENT_RESPONSE: u8 = 0;
    pub const INITIATE_UPLOAD_RESPONSE: u8 = 2;
    pub const ABORT: u8 = 4;
}

/// Register of SyncManager `n`'s status byte (b3: mailbox full).
const fn sm_status(n: u8) -> u16 {
    0x0805 + 8 * n as u16
}

/// An upload and how it travelled.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Upload {
    /// The object's bytes.
    pub data: Vec<u8>,
    /// Upload segments it took (0: expedited or a single normal response).
    pub segments: usize,
}

/// An SDO upload client on the mailbox SyncManagers of one SubDevice; `MBX` is the mailbox
/// size in bytes (both directions).
pub struct SdoUploader<const MBX: usize> {
    out_start: u16,
    in_start: u16,
    in_sm: u8,
    counter: u8,
}

impl<const MBX: usize> SdoUploader<MBX> {
    /// How many SM1 status polls to wait for a reply.
    const POLLS: usize = 2000;

    /// A client writing requests at `out_start` (SM0) and reading replies at `in_start`
    /// (SyncManager `in_sm`).
    pub fn new(out_start: u16, in_start: u16, in_sm: u8) -> Self {
        Self {
            out_start,
            in_start,
            in_sm,
            counter: 0,
        }
    }

    /// One CoE SDO request (8 bytes after the CoE header) and its SDO response data.
    async fn exchange<S>(
        &mut self,
        sd: &SubDeviceRef<'_, S>,
        sdo: [u8; 8],
    ) -> Result<Vec<u8>, String> {
        // Counters 1..=7, never repeating the previous one (a repeat is dropped as a duplicate).
        self.counter = self.counter % 7 + 1;
        let mut frame = [0u8; MBX];
        frame[0..2].copy_from_slice(&10u16.to_le_bytes()); // CoE header + 8 bytes
        frame[5] = 0x03 | self.counter << 4; // type CoE
        frame[6..8].copy_from_slice(&(2u16 << 12).to_le_bytes()); // SDO request
        frame[8..16].copy_from_slice(&sdo);
        sd.register_write(self.out_start, frame)
            .await
            .map_err(|e| format!("mailbox write: {e:?}"))?;
        for _ in 0..Self::POLLS {
            let status: u8 = sd
                .register_read(sm_status(self.in_sm))
                .await
                .map_err(|e| format!("SM status: {e:?}"))?;
            if status & 0x08 == 0 {
                continue;
            }
            let reply: [u8; MBX] = sd
                .register_read(self.in_start)
                .await
                .map_err(|e| format!("mailbox read: {e:?}"))?;
            let len = usize::from(u16::from_le_bytes([reply[0], reply[1]]));
            let body = reply
                .get(6..6 + len)
                .ok_or("mailbox length past the buffer")?;
            if reply[5] & 0x0F != 0x03 {
                return Err(format!("not a CoE reply: type {}", reply[5] & 0x0F));
            }
            let service = u16::from_le_bytes([body[0], body[1]]) >> 12;
            if service != 3 {
                return Err(format!("CoE service {service}, expected an SDO response"));
            }
            return Ok(body[2..].to_vec());
        }
        Err("no mailbox reply".into())
    }

    /// Uploads `index:sub`: expedited, normal or segmented, as the server chooses.
    pub async fn upload<S>(
        &mut self,
        sd: &SubDeviceRef<'_, S>,
        index: u16,
        sub: u8,
    ) -> Result<Upload, String> {
        let [lo, hi] = index.to_le_bytes();
        let r = self.exchange(sd, [0x40, lo, hi, sub, 0, 0, 0, 0]).await?;
        let cmd = *r.first().ok_or("empty SDO response")?;
        match cmd >> 5 {
            cs::INITIATE_UPLOAD_RESPONSE => {}
            cs::ABORT => return Err(format!("abort {:#010x}", u32_at(&r, 4)?)),
            other => return Err(format!("command specifier {other} to an initiate upload")),
        }
        if cmd & 0x02 != 0 {
            let n = usize::from((cmd >> 2) & 0x03);
            let data = r.get(4..8 - n).ok_or("short expedited response")?.to_vec();
            return Ok(Upload { data, segments: 0 });
        }
        let size = u32_at(&r, 4)? as usize;
        let mut data = r.get(8..).unwrap_or(&[]).to_vec();
        if data.len() >= size {
            data.truncate(size);
            return Ok(Upload { data, segments: 0 });
        }
        // The initiate response carried the first part; the segments bring the rest.
        let mut toggle = 0u8;
        let mut segments = 0;
        loop {
            let r = self
                .exchange(sd, [0x60 | toggle << 4, 0, 0, 0, 0, 0, 0, 0])
                .await?;
            let cmd = *r.first().ok_or("empty segment response")?;
            match cmd >> 5 {
                cs::UPLOAD_SEGMENT_RESPONSE => {}
                cs::ABORT => return Err(format!("abort {:#010x}", u32_at(&r, 4)?)),
                other => return Err(format!("command specifier {other} to an upload segment")),
            }
            if (cmd >> 4) & 1 != toggle {
                return Err(format!("segment {segments}: toggle bit not alternated"));
            }
            let mut payload = &r[1..];
            if payload.len() == 7 {
                // A minimal segment names its unused bytes.
                payload = &payload[..7 - usize::from((cmd >> 1) & 0x07)];
            }
            data.extend_from_slice(payload);
            segments += 1;
            if cmd & 0x01 != 0 {
                break;
            }
            toggle ^= 1;
        }
        if data.len() != size {
            return Err(format!("{} bytes received, {size} announced", data.len()));
        }
        Ok(Upload { data, segments })
    }
}

fn u32_at(r: &[u8], at: usize) -> Result<u32, String> {
    match r.get(at..at + 4) {
        Some([a, b, c, d]) => Ok(u32::from_le_bytes([*a, *b, *c, *d])),
        _ => Err("short SDO response".into()),
    }
}
