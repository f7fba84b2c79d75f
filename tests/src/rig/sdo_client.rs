//! Raw mailbox access as a master does it ([`MailboxClient`]: whole-buffer writes and reads,
//! counters, the repeat request) and a minimal CoE SDO upload client on it ([`SdoUploader`]:
//! initiate upload, then upload segments until the last one; ETG.1000.6 5.6.2.2/5.6.2.3),
//! both on ethercrab's register reads and writes through the in-process rig
//! ([`crate::rig::master`]).
//!
//! The upload client exists because ethercrab 0.7.1's `SubDeviceRef::sdo_read` cannot
//! complete a segmented upload: its mailbox response parser (`mailbox/coe/mod.rs`,
//! `HeadersRaw`) decodes the top three bits of the SDO command byte into `CoeCommand`, which
//! has no variant for 0, the command specifier every upload segment response carries, so the
//! first segment fails with `Error::Wire(WireError::InvalidValue)`. (Its segment loop also
//! starts filling the buffer from 0, dropping the data the initiate response carried.) The
//! mailbox client exists for what no master API offers: leaving replies unread, resending a
//! frame with the same counter, the repeat request.

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

/// Register of SyncManager `n`'s activate byte (b1: repeat request, written by the master).
const fn sm_activate(n: u8) -> u16 {
    0x0806 + 8 * n as u16
}

/// Register of SyncManager `n`'s PDI control byte (b1: repeat acknowledge, by the slave).
const fn sm_pdi_control(n: u8) -> u16 {
    0x0807 + 8 * n as u16
}

/// Mailbox type CoE (mailbox header byte 5, bits 3..0).
pub const MAILBOX_TYPE_COE: u8 = 0x03;

/// An upload and how it travelled.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Upload {
    /// The object's bytes.
    pub data: Vec<u8>,
    /// Upload segments it took (0: expedited or a single normal response).
    pub segments: usize,
}

/// Raw mailbox access as a master does it (ETG.1000.4 mailbox handshakes): whole-buffer
/// writes to the write mailbox, status polls and whole-buffer reads of the read mailbox, the
/// repeat request. `MBX` is the mailbox size in bytes (both directions).
pub struct MailboxClient<const MBX: usize> {
    out_start: u16,
    in_start: u16,
    in_sm: u8,
    counter: u8,
}

impl<const MBX: usize> MailboxClient<MBX> {
    /// How many status polls to wait for a reply or an acknowledge.
    pub const POLLS: usize = 2000;

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

    /// The counter the next [`Self::send`] uses (1..=7).
    pub fn next_counter(&self) -> u8 {
        self.counter % 7 + 1
    }

    /// A whole write-mailbox buffer: header (length, address 0, channel 0, `mailbox_type`,
    /// `counter`) and `payload`.
    pub fn frame(mailbox_type: u8, counter: u8, payload: &[u8]) -> [u8; MBX] {
        let mut frame = [0u8; MBX];
        frame[0..2].copy_from_slice(&(payload.len() as u16).to_le_bytes());
        frame[5] = (mailbox_type & 0x0F) | (counter & 0x07) << 4;
        frame[6..6 + payload.len()].copy_from_slice(payload);
        frame
    }

    /// Writes a frame with the next counter (1..=7, never the previous one, which the slave
    /// would drop as a retry). `Ok(false)`: the write was not taken (working counter 0: the
    /// mailbox is still full).
    pub async fn send<S>(
        &mut self,
        sd: &SubDeviceRef<'_, S>,
        mailbox_type: u8,
        payload: &[u8],
    ) -> Result<bool, String> {
        let counter = self.next_counter();
        let taken = self
            .send_raw(sd, &Self::frame(mailbox_type, counter, payload))
            .await?;
        if taken {
            self.counter = counter;
        }
        Ok(taken)
    }

    /// Writes `frame` as it is (a retry keeps its counter). `Ok(false)`: not taken.
    pub async fn send_raw<S>(
        &mut self,
        sd: &SubDeviceRef<'_, S>,
        frame: &[u8; MBX],
    ) -> Result<bool, String> {
        match sd.register_write(self.out_start, *frame).await {
            Ok(_) => Ok(true),
            Err(ethercrab::error::Error::WorkingCounter { .. }) => Ok(false),
            Err(e) => Err(format!("mailbox write: {e:?}")),
        }
    }

    /// Whether the read mailbox is full.
    pub async fn reply_waiting<S>(&self, sd: &SubDeviceRef<'_, S>) -> Result<bool, String> {
        let status: u8 = sd
            .register_read(sm_status(self.in_sm))
            .await
            .map_err(|e| format!("SM status: {e:?}"))?;
        Ok(status & 0x08 != 0)
    }

    /// Reads the read mailbox if it is full (the read empties it).
    pub async fn try_read<S>(&self, sd: &SubDeviceRef<'_, S>) -> Result<Option<[u8; MBX]>, String> {
        if !self.reply_waiting(sd).await? {
            return Ok(None);
        }
        let frame: [u8; MBX] = sd
            .register_read(self.in_start)
            .await
            .map_err(|e| format!("mailbox read: {e:?}"))?;
        Ok(Some(frame))
    }

    /// Polls the read mailbox until a frame comes ([`Self::POLLS`] polls at most).
    pub async fn read<S>(&self, sd: &SubDeviceRef<'_, S>) -> Result<[u8; MBX], String> {
        for _ in 0..Self::POLLS {
            if let Some(frame) = self.try_read(sd).await? {
                return Ok(frame);
            }
        }
        Err("no mailbox reply".into())
    }

    /// The repeat request (ESC datasheet section I 8.6): toggles SM1's repeat request bit,
    /// waits for the slave's acknowledge (PDI control b1 equal to it), then reads the frame
    /// the slave wrote again.
    pub async fn repeat<S>(&self, sd: &SubDeviceRef<'_, S>) -> Result<[u8; MBX], String> {
        let activate: u8 = sd
            .register_read(sm_activate(self.in_sm))
            .await
            .map_err(|e| format!("SM activate: {e:?}"))?;
        let request = activate ^ 0x02;
        sd.register_write(sm_activate(self.in_sm), request)
            .await
            .map_err(|e| format!("repeat request: {e:?}"))?;
        for _ in 0..Self::POLLS {
            let ack: u8 = sd
                .register_read(sm_pdi_control(self.in_sm))
                .await
                .map_err(|e| format!("SM PDI control: {e:?}"))?;
            if ack & 0x02 == request & 0x02 {
                return self.read(sd).await;
            }
        }
        Err("no repeat acknowledge".into())
    }
}

/// The mailbox payload of a frame (after the 6-byte header, as long as the header says).
pub fn payload(frame: &[u8]) -> Result<&[u8], String> {
    let len = usize::from(u16::from_le_bytes([frame[0], frame[1]]));
    frame
        .get(6..6 + len)
        .ok_or_else(|| "mailbox length past the buffer".into())
}

/// An SDO request in a CoE frame: CoE header (SDO request) and the 8 SDO bytes.
pub fn sdo_request(sdo: [u8; 8]) -> [u8; 10] {
    let mut p = [0u8; 10];
    p[0..2].copy_from_slice(&(2u16 << 12).to_le_bytes());
    p[2..].copy_from_slice(&sdo);
    p
}

/// The SDO bytes of a CoE SDO response frame (an error for anything else).
pub fn sdo_response(frame: &[u8]) -> Result<Vec<u8>, String> {
    if frame[5] & 0x0F != MAILBOX_TYPE_COE {
        return Err(format!("not a CoE reply: type {}", frame[5] & 0x0F));
    }
    let body = payload(frame)?;
    let service = u16::from_le_bytes([body[0], body[1]]) >> 12;
    if service != 3 {
        return Err(format!("CoE service {service}, expected an SDO response"));
    }
    Ok(body[2..].to_vec())
}

/// An SDO upload client on the mailbox SyncManagers of one SubDevice; `MBX` is the mailbox
/// size in bytes (both directions).
pub struct SdoUploader<const MBX: usize> {
    mailbox: MailboxClient<MBX>,
}

impl<const MBX: usize> SdoUploader<MBX> {
    /// A client writing requests at `out_start` (SM0) and reading replies at `in_start`
    /// (SyncManager `in_sm`).
    pub fn new(out_start: u16, in_start: u16, in_sm: u8) -> Self {
        Self {
            mailbox: MailboxClient::new(out_start, in_start, in_sm),
        }
    }

    /// One CoE SDO request (8 bytes after the CoE header) and its SDO response data.
    async fn exchange<S>(
        &mut self,
        sd: &SubDeviceRef<'_, S>,
        sdo: [u8; 8],
    ) -> Result<Vec<u8>, String> {
        if !self
            .mailbox
            .send(sd, MAILBOX_TYPE_COE, &sdo_request(sdo))
            .await?
        {
            return Err("the write mailbox is full".into());
        }
        sdo_response(&self.mailbox.read(sd).await?)
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
