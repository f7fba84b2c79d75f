//! Raw mailbox access as a master does it ([`MailboxClient`]: whole-buffer writes and reads,
//! counters, the repeat request) and a CoE SDO client on it ([`SdoClient`]: uploads and
//! downloads, expedited, normal and segmented; ETG.1000.6 5.6.2), on any [`RegisterPort`]:
//! ethercrab's register reads and writes through the in-process rig ([`crate::rig::master`]),
//! or the scripted master's datagrams ([`crate::rig::scripted::ScriptedMaster`]).
//!
//! The SDO client exists because ethercrab 0.7.1's `SubDeviceRef::sdo_read` cannot
//! complete a segmented upload: its mailbox response parser (`mailbox/coe/mod.rs`,
//! `HeadersRaw`) decodes the top three bits of the SDO command byte into `CoeCommand`, which
//! has no variant for 0, the command specifier every upload segment response carries, so the
//! first segment fails with `Error::Wire(WireError::InvalidValue)`. (Its segment loop also
//! starts filling the buffer from 0, dropping the data the initiate response carried; and it
//! downloads expedited only.) The mailbox client exists for what no master API offers:
//! leaving replies unread, resending a frame with the same counter, the repeat request.
//!
//! The SDO frames are built and decoded here from the specification's command bytes, not
//! with coe-core's wire layer, so the client does not share a mistake with the server it
//! tests.

use ethercrab::SubDeviceRef;
use std::fmt;
use std::future::Future;

/// SDO command specifiers (bits 7..5 of the command byte).
mod cs {
    pub const DOWNLOAD_SEGMENT_REQUEST: u8 = 0;
    pub const INITIATE_DOWNLOAD_REQUEST: u8 = 1;
    pub const INITIATE_UPLOAD_REQUEST: u8 = 2;
    pub const UPLOAD_SEGMENT_REQUEST: u8 = 3;
    pub const ABORT: u8 = 4;
    pub const UPLOAD_SEGMENT_RESPONSE: u8 = 0;
    pub const DOWNLOAD_SEGMENT_RESPONSE: u8 = 1;
    pub const INITIATE_UPLOAD_RESPONSE: u8 = 2;
    pub const INITIATE_DOWNLOAD_RESPONSE: u8 = 3;
}

/// Command byte bits of an initiate request/response.
mod bits {
    /// b0: size indicated.
    pub const SIZE_INDICATED: u8 = 0x01;
    /// b1: expedited.
    pub const EXPEDITED: u8 = 0x02;
    /// b4: complete access.
    pub const COMPLETE_ACCESS: u8 = 0x10;
    /// b0 of a segment: last segment.
    pub const LAST_SEGMENT: u8 = 0x01;
}

/// CoE services (CoE header bits 15..12).
pub mod coe_service {
    /// Emergency.
    pub const EMERGENCY: u16 = 1;
    /// SDO request.
    pub const SDO_REQUEST: u16 = 2;
    /// SDO response.
    pub const SDO_RESPONSE: u16 = 3;
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
/// Mailbox type 0: a mailbox error reply (ETG.1000.4 mailbox error).
pub const MAILBOX_TYPE_ERROR: u8 = 0x00;
/// Bytes of the mailbox header.
pub const MAILBOX_HEADER: usize = 6;

/// Register access on one SubDevice as a master does it: one datagram per call, addressed
/// to that SubDevice. A mailbox write or read the ESC does not take (working counter 0:
/// the write mailbox is full, the read mailbox empty) is `Ok(false)` / `Ok(None)`, not an
/// error; a datagram that gets no answer at all is an error.
pub trait RegisterPort {
    /// Reads one byte.
    fn read_u8(&self, addr: u16) -> impl Future<Output = Result<u8, String>>;
    /// Writes one byte.
    fn write_u8(&self, addr: u16, value: u8) -> impl Future<Output = Result<(), String>>;
    /// Writes a whole mailbox buffer; `Ok(false)`: not taken (working counter 0).
    fn write_buffer<const N: usize>(
        &self,
        addr: u16,
        data: &[u8; N],
    ) -> impl Future<Output = Result<bool, String>>;
    /// Reads a whole mailbox buffer; `Ok(None)`: nothing to read (working counter 0).
    fn read_buffer<const N: usize>(
        &self,
        addr: u16,
    ) -> impl Future<Output = Result<Option<[u8; N]>, String>>;
}

impl<S> RegisterPort for SubDeviceRef<'_, S> {
    async fn read_u8(&self, addr: u16) -> Result<u8, String> {
        self.register_read(addr)
            .await
            .map_err(|e| format!("read {addr:#06x}: {e:?}"))
    }

    async fn write_u8(&self, addr: u16, value: u8) -> Result<(), String> {
        self.register_write(addr, value)
            .await
            .map(drop)
            .map_err(|e| format!("write {addr:#06x}: {e:?}"))
    }

    async fn write_buffer<const N: usize>(
        &self,
        addr: u16,
        data: &[u8; N],
    ) -> Result<bool, String> {
        match self.register_write(addr, *data).await {
            Ok(_) => Ok(true),
            Err(ethercrab::error::Error::WorkingCounter { .. }) => Ok(false),
            Err(e) => Err(format!("write {addr:#06x}: {e:?}")),
        }
    }

    async fn read_buffer<const N: usize>(&self, addr: u16) -> Result<Option<[u8; N]>, String> {
        match self.register_read::<[u8; N]>(addr).await {
            Ok(b) => Ok(Some(b)),
            Err(ethercrab::error::Error::WorkingCounter { .. }) => Ok(None),
            Err(e) => Err(format!("read {addr:#06x}: {e:?}")),
        }
    }
}

/// An upload and how it travelled.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Upload {
    /// The object's bytes.
    pub data: Vec<u8>,
    /// Upload segments it took (0: expedited or a single normal response).
    pub segments: usize,
}

/// Why an SDO transfer failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SdoError {
    /// The server aborted the transfer with this code.
    Abort {
        /// Object index the abort names.
        index: u16,
        /// Subindex the abort names.
        sub: u8,
        /// SDO abort code (ETG.1000.6 table 41).
        code: u32,
    },
    /// The server answered with a mailbox error reply (type 0): its detail code.
    MailboxError(u16),
    /// Anything else: no reply, a reply that does not fit the request.
    Protocol(String),
}

impl SdoError {
    /// The abort code, if the server aborted.
    pub fn abort_code(&self) -> Option<u32> {
        match self {
            Self::Abort { code, .. } => Some(*code),
            _ => None,
        }
    }
}

impl fmt::Display for SdoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Abort { index, sub, code } => {
                write!(f, "abort {code:#010x} ({index:#06x}:{sub})")
            }
            Self::MailboxError(detail) => write!(f, "mailbox error reply, detail {detail}"),
            Self::Protocol(s) => f.write_str(s),
        }
    }
}

impl From<String> for SdoError {
    fn from(s: String) -> Self {
        Self::Protocol(s)
    }
}

impl From<&str> for SdoError {
    fn from(s: &str) -> Self {
        Self::Protocol(s.into())
    }
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

    /// A frame with the next counter, which counts as used (for a master that sends, and
    /// may resend, the frame itself with [`Self::send_raw`]).
    pub fn next_frame(&mut self, mailbox_type: u8, payload: &[u8]) -> [u8; MBX] {
        self.counter = self.next_counter();
        Self::frame(mailbox_type, self.counter, payload)
    }

    /// Starts the counters again (the slave does so at INIT -> PREOP).
    pub fn reset_counter(&mut self) {
        self.counter = 0;
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
    pub async fn send<P: RegisterPort>(
        &mut self,
        port: &P,
        mailbox_type: u8,
        payload: &[u8],
    ) -> Result<bool, String> {
        let counter = self.next_counter();
        let taken = self
            .send_raw(port, &Self::frame(mailbox_type, counter, payload))
            .await?;
        if taken {
            self.counter = counter;
        }
        Ok(taken)
    }

    /// Writes `frame` as it is (a retry keeps its counter). `Ok(false)`: not taken.
    pub async fn send_raw<P: RegisterPort>(
        &mut self,
        port: &P,
        frame: &[u8; MBX],
    ) -> Result<bool, String> {
        port.write_buffer(self.out_start, frame).await
    }

    /// Whether the read mailbox is full.
    pub async fn reply_waiting<P: RegisterPort>(&self, port: &P) -> Result<bool, String> {
        Ok(port.read_u8(sm_status(self.in_sm)).await? & 0x08 != 0)
    }

    /// Reads the read mailbox if it is full (the read empties it). A read whose answer is
    /// lost may have emptied the mailbox already: the repeat request has the slave write
    /// the frame again (ESC datasheet section I 8.6), whichever way it was lost.
    pub async fn try_read<P: RegisterPort>(&self, port: &P) -> Result<Option<[u8; MBX]>, String> {
        if !self.reply_waiting(port).await? {
            return Ok(None);
        }
        match port.read_buffer(self.in_start).await {
            Ok(frame) => Ok(frame),
            Err(_) => self.repeat(port).await.map(Some),
        }
    }

    /// Polls for a frame and reads it, without the recovery of [`Self::try_read`].
    async fn read_plain<P: RegisterPort>(&self, port: &P) -> Result<[u8; MBX], String> {
        for _ in 0..Self::POLLS {
            if self.reply_waiting(port).await? {
                if let Some(frame) = port.read_buffer(self.in_start).await? {
                    return Ok(frame);
                }
            }
        }
        Err("no mailbox reply".into())
    }

    /// Polls the read mailbox until a frame comes ([`Self::POLLS`] polls at most).
    pub async fn read<P: RegisterPort>(&self, port: &P) -> Result<[u8; MBX], String> {
        for _ in 0..Self::POLLS {
            if let Some(frame) = self.try_read(port).await? {
                return Ok(frame);
            }
        }
        Err("no mailbox reply".into())
    }

    /// The repeat request (ESC datasheet section I 8.6): toggles SM1's repeat request bit,
    /// waits for the slave's acknowledge (PDI control b1 equal to it), then reads the frame
    /// the slave wrote again.
    pub async fn repeat<P: RegisterPort>(&self, port: &P) -> Result<[u8; MBX], String> {
        let activate = port.read_u8(sm_activate(self.in_sm)).await?;
        let request = activate ^ 0x02;
        port.write_u8(sm_activate(self.in_sm), request).await?;
        for _ in 0..Self::POLLS {
            let ack = port.read_u8(sm_pdi_control(self.in_sm)).await?;
            if ack & 0x02 == request & 0x02 {
                return self.read_plain(port).await;
            }
        }
        Err("no repeat acknowledge".into())
    }
}

/// The mailbox payload of a frame (after the 6-byte header, as long as the header says).
pub fn payload(frame: &[u8]) -> Result<&[u8], String> {
    let len = usize::from(u16::from_le_bytes([frame[0], frame[1]]));
    frame
        .get(MAILBOX_HEADER..MAILBOX_HEADER + len)
        .ok_or_else(|| "mailbox length past the buffer".into())
}

/// The mailbox type of a frame (header byte 5, bits 3..0).
pub fn mailbox_type(frame: &[u8]) -> u8 {
    frame[5] & 0x0F
}

/// The mailbox counter of a frame (header byte 5, bits 6..4).
pub fn mailbox_counter(frame: &[u8]) -> u8 {
    (frame[5] >> 4) & 0x07
}

/// A CoE frame's service (CoE header bits 15..12), `None` for other mailbox types.
pub fn coe_service(frame: &[u8]) -> Option<u16> {
    if mailbox_type(frame) != MAILBOX_TYPE_COE {
        return None;
    }
    let body = payload(frame).ok()?;
    Some(u16::from_le_bytes([*body.first()?, *body.get(1)?]) >> 12)
}

/// An SDO request in a CoE frame: CoE header (SDO request) and the SDO bytes.
pub fn sdo_request(sdo: [u8; 8]) -> [u8; 10] {
    let mut p = [0u8; 10];
    p[0..2].copy_from_slice(&(coe_service::SDO_REQUEST << 12).to_le_bytes());
    p[2..].copy_from_slice(&sdo);
    p
}

/// The CoE payload of an SDO request of any length: CoE header and `sdo`.
pub fn sdo_request_bytes(sdo: &[u8]) -> Vec<u8> {
    let mut p = (coe_service::SDO_REQUEST << 12).to_le_bytes().to_vec();
    p.extend_from_slice(sdo);
    p
}

/// The SDO bytes of a CoE SDO frame from the server: a response, or an abort (which the
/// server sends as service "SDO request", as masters expect). A mailbox error reply is
/// [`SdoError::MailboxError`]; an abort is [`SdoError::Abort`].
pub fn sdo_response(frame: &[u8]) -> Result<Vec<u8>, SdoError> {
    if mailbox_type(frame) == MAILBOX_TYPE_ERROR {
        let body = payload(frame)?;
        return Err(match body {
            [_, _, lo, hi, ..] => SdoError::MailboxError(u16::from_le_bytes([*lo, *hi])),
            _ => SdoError::Protocol("short mailbox error reply".into()),
        });
    }
    if mailbox_type(frame) != MAILBOX_TYPE_COE {
        return Err(format!("not a CoE reply: type {}", mailbox_type(frame)).into());
    }
    let body = payload(frame)?;
    let service = u16::from_le_bytes([body[0], body[1]]) >> 12;
    let sdo = body[2..].to_vec();
    if sdo.first().map(|c| c >> 5) == Some(cs::ABORT)
        && matches!(
            service,
            coe_service::SDO_REQUEST | coe_service::SDO_RESPONSE
        )
    {
        return Err(SdoError::Abort {
            index: u16::from_le_bytes([sdo[1], sdo[2]]),
            sub: sdo[3],
            code: u32_at(&sdo, 4)?,
        });
    }
    if service != coe_service::SDO_RESPONSE {
        return Err(format!("CoE service {service}, expected an SDO response").into());
    }
    Ok(sdo)
}

/// `(index, subindex, data)` of a frame holding an expedited upload response (the data as
/// long as the command byte says).
pub fn expedited_upload(frame: &[u8]) -> Result<(u16, u8, Vec<u8>), SdoError> {
    let sdo = sdo_response(frame)?;
    match sdo.first() {
        Some(cmd)
            if cmd & 0xE3
                == cs::INITIATE_UPLOAD_RESPONSE << 5 | bits::EXPEDITED | bits::SIZE_INDICATED =>
        {
            let n = 4 - usize::from((cmd >> 2) & 0x03);
            let data = sdo.get(4..4 + n).ok_or("short expedited response")?;
            Ok((u16::from_le_bytes([sdo[1], sdo[2]]), sdo[3], data.to_vec()))
        }
        other => Err(format!("not an expedited upload response: {other:02x?}").into()),
    }
}

/// An Emergency (CoE service 1) in a read-mailbox frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Emergency {
    /// Error code (CiA 301 table 21).
    pub code: u16,
    /// Error register (0x1001) at the time.
    pub register: u8,
    /// Manufacturer-specific data.
    pub data: [u8; 5],
}

impl Emergency {
    /// The Emergency a frame carries, `None` for any other frame.
    pub fn parse(frame: &[u8]) -> Option<Self> {
        if coe_service(frame)? != coe_service::EMERGENCY {
            return None;
        }
        let body = payload(frame).ok()?;
        let e = body.get(2..10)?;
        Some(Self {
            code: u16::from_le_bytes([e[0], e[1]]),
            register: e[2],
            data: [e[3], e[4], e[5], e[6], e[7]],
        })
    }
}

/// SDO requests by their command bytes (ETG.1000.6 5.6.2; hardware-facts 3).
pub mod request {
    use super::{bits, cs};

    fn head(command: u8, index: u16, sub: u8) -> Vec<u8> {
        let [lo, hi] = index.to_le_bytes();
        vec![command, lo, hi, sub]
    }

    /// Initiate upload (`complete`: complete access from `sub`).
    pub fn initiate_upload(index: u16, sub: u8, complete: bool) -> Vec<u8> {
        let ca = if complete { bits::COMPLETE_ACCESS } else { 0 };
        let mut r = head(cs::INITIATE_UPLOAD_REQUEST << 5 | ca, index, sub);
        r.extend_from_slice(&[0; 4]);
        r
    }

    /// Upload segment request with `toggle`.
    pub fn upload_segment(toggle: bool) -> Vec<u8> {
        let mut r = vec![cs::UPLOAD_SEGMENT_REQUEST << 5 | u8::from(toggle) << 4];
        r.extend_from_slice(&[0; 7]);
        r
    }

    /// Expedited download of 1..=4 bytes (size indicated).
    pub fn expedited_download(index: u16, sub: u8, data: &[u8]) -> Vec<u8> {
        let n = data.len().clamp(1, 4);
        let unused = (4 - n) as u8;
        let command = cs::INITIATE_DOWNLOAD_REQUEST << 5
            | unused << 2
            | bits::EXPEDITED
            | bits::SIZE_INDICATED;
        let mut r = head(command, index, sub);
        let mut d = [0u8; 4];
        d[..n].copy_from_slice(&data[..n]);
        r.extend_from_slice(&d);
        r
    }

    /// Initiate a normal download of `size` bytes, with `data` (the first part, possibly
    /// none: the rest follows in segments).
    pub fn initiate_download(
        index: u16,
        sub: u8,
        complete: bool,
        size: u32,
        data: &[u8],
    ) -> Vec<u8> {
        let ca = if complete { bits::COMPLETE_ACCESS } else { 0 };
        let mut r = head(
            cs::INITIATE_DOWNLOAD_REQUEST << 5 | ca | bits::SIZE_INDICATED,
            index,
            sub,
        );
        r.extend_from_slice(&size.to_le_bytes());
        r.extend_from_slice(data);
        r
    }

    /// A download segment: `data` (padded to the minimal 7 bytes, their unused count in the
    /// command), `toggle`, `last`.
    pub fn download_segment(toggle: bool, last: bool, data: &[u8]) -> Vec<u8> {
        let unused = 7usize.saturating_sub(data.len()) as u8;
        let command = cs::DOWNLOAD_SEGMENT_REQUEST << 5
            | u8::from(toggle) << 4
            | unused << 1
            | if last { bits::LAST_SEGMENT } else { 0 };
        let mut r = vec![command];
        r.extend_from_slice(data);
        r.resize(r.len().max(8), 0);
        r
    }

    /// Abort transfer from the client.
    pub fn abort(index: u16, sub: u8, code: u32) -> Vec<u8> {
        let mut r = head(cs::ABORT << 5, index, sub);
        r.extend_from_slice(&code.to_le_bytes());
        r
    }
}

/// A CoE SDO client on the mailbox SyncManagers of one SubDevice; `MBX` is the mailbox size
/// in bytes (both directions).
pub struct SdoClient<const MBX: usize> {
    mailbox: MailboxClient<MBX>,
}

impl<const MBX: usize> SdoClient<MBX> {
    /// Data bytes of a download segment that fills the mailbox: mailbox header, CoE
    /// header and the command byte in front of it.
    pub const SEGMENT_DATA: usize = MBX - MAILBOX_HEADER - 3;

    /// A client writing requests at `out_start` (SM0) and reading replies at `in_start`
    /// (SyncManager `in_sm`).
    pub fn new(out_start: u16, in_start: u16, in_sm: u8) -> Self {
        Self {
            mailbox: MailboxClient::new(out_start, in_start, in_sm),
        }
    }

    /// The mailbox client underneath (counters, repeat request).
    pub fn mailbox(&mut self) -> &mut MailboxClient<MBX> {
        &mut self.mailbox
    }

    /// One SDO request (`sdo`: the bytes after the CoE header) and the SDO bytes of its
    /// response. A waiting frame that is not an SDO frame (an Emergency) is passed to
    /// `other` and the client reads on.
    pub async fn exchange<P: RegisterPort>(
        &mut self,
        port: &P,
        sdo: &[u8],
        other: &mut dyn FnMut([u8; MBX]),
    ) -> Result<Vec<u8>, SdoError> {
        if !self
            .mailbox
            .send(port, MAILBOX_TYPE_COE, &sdo_request_bytes(sdo))
            .await?
        {
            return Err("the write mailbox is full".into());
        }
        for _ in 0..8 {
            let frame = self.mailbox.read(port).await?;
            if coe_service(&frame) == Some(coe_service::EMERGENCY) {
                other(frame);
                continue;
            }
            return sdo_response(&frame);
        }
        Err("no SDO reply among the frames read".into())
    }

    /// Uploads `index:sub`: expedited, normal or segmented, as the server chooses.
    pub async fn upload<P: RegisterPort>(
        &mut self,
        port: &P,
        index: u16,
        sub: u8,
    ) -> Result<Upload, SdoError> {
        self.upload_with(port, index, sub, false, &mut |_| {}).await
    }

    /// Uploads `index:sub` (`complete`: complete access); Emergencies read on the way go to
    /// `other`.
    pub async fn upload_with<P: RegisterPort>(
        &mut self,
        port: &P,
        index: u16,
        sub: u8,
        complete: bool,
        other: &mut dyn FnMut([u8; MBX]),
    ) -> Result<Upload, SdoError> {
        let r = self
            .exchange(port, &request::initiate_upload(index, sub, complete), other)
            .await?;
        let cmd = *r.first().ok_or("empty SDO response")?;
        if cmd >> 5 != cs::INITIATE_UPLOAD_RESPONSE {
            return Err(format!("command specifier {} to an initiate upload", cmd >> 5).into());
        }
        if cmd & bits::EXPEDITED != 0 {
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
        let mut toggle = false;
        let mut segments = 0;
        loop {
            let (chunk, last) = self.upload_segment(port, toggle, other).await?;
            data.extend_from_slice(&chunk);
            segments += 1;
            if last {
                break;
            }
            toggle = !toggle;
        }
        if data.len() != size {
            return Err(format!("{} bytes received, {size} announced", data.len()).into());
        }
        Ok(Upload { data, segments })
    }

    /// One upload segment with `toggle`: its data and whether it was the last.
    pub async fn upload_segment<P: RegisterPort>(
        &mut self,
        port: &P,
        toggle: bool,
        other: &mut dyn FnMut([u8; MBX]),
    ) -> Result<(Vec<u8>, bool), SdoError> {
        let r = self
            .exchange(port, &request::upload_segment(toggle), other)
            .await?;
        let cmd = *r.first().ok_or("empty segment response")?;
        if cmd >> 5 != cs::UPLOAD_SEGMENT_RESPONSE {
            return Err(format!("command specifier {} to an upload segment", cmd >> 5).into());
        }
        if (cmd >> 4) & 1 != u8::from(toggle) {
            return Err("upload segment: toggle bit not alternated".into());
        }
        let mut data = &r[1..];
        if data.len() == 7 {
            // A minimal segment names its unused bytes.
            data = &data[..7 - usize::from((cmd >> 1) & 0x07)];
        }
        Ok((data.to_vec(), cmd & bits::LAST_SEGMENT != 0))
    }

    /// Downloads `data` to `index:sub`: expedited for 1..=4 bytes, else a normal download
    /// when it fits one frame, else segmented with full segments. Returns the segments it
    /// took.
    pub async fn download<P: RegisterPort>(
        &mut self,
        port: &P,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<usize, SdoError> {
        let other = &mut |_| {};
        if (1..=4).contains(&data.len()) {
            let r = self
                .exchange(port, &request::expedited_download(index, sub, data), other)
                .await?;
            return expect_initiate_download_response(&r).map(|_| 0);
        }
        let in_initiate = MBX - MAILBOX_HEADER - 2 - 8;
        if data.len() <= in_initiate {
            let size = data.len() as u32;
            let r = self
                .exchange(
                    port,
                    &request::initiate_download(index, sub, false, size, data),
                    other,
                )
                .await?;
            return expect_initiate_download_response(&r).map(|_| 0);
        }
        self.download_segmented(port, index, sub, false, data, Self::SEGMENT_DATA)
            .await
    }

    /// A segmented download: the initiate request with the size only, then segments of
    /// `segment` data bytes (1..=[`Self::SEGMENT_DATA`]). Returns the segments it took.
    pub async fn download_segmented<P: RegisterPort>(
        &mut self,
        port: &P,
        index: u16,
        sub: u8,
        complete: bool,
        data: &[u8],
        segment: usize,
    ) -> Result<usize, SdoError> {
        let other = &mut |_| {};
        let size = data.len() as u32;
        let r = self
            .exchange(
                port,
                &request::initiate_download(index, sub, complete, size, &[]),
                other,
            )
            .await?;
        expect_initiate_download_response(&r)?;
        let chunks: Vec<&[u8]> = data.chunks(segment.clamp(1, Self::SEGMENT_DATA)).collect();
        let mut toggle = false;
        for (i, chunk) in chunks.iter().enumerate() {
            let last = i + 1 == chunks.len();
            self.download_segment(port, toggle, last, chunk).await?;
            toggle = !toggle;
        }
        Ok(chunks.len())
    }

    /// One download segment; checks the response's toggle bit.
    pub async fn download_segment<P: RegisterPort>(
        &mut self,
        port: &P,
        toggle: bool,
        last: bool,
        data: &[u8],
    ) -> Result<(), SdoError> {
        let r = self
            .exchange(
                port,
                &request::download_segment(toggle, last, data),
                &mut |_| {},
            )
            .await?;
        let cmd = *r.first().ok_or("empty segment response")?;
        if cmd >> 5 != cs::DOWNLOAD_SEGMENT_RESPONSE {
            return Err(format!("command specifier {} to a download segment", cmd >> 5).into());
        }
        if (cmd >> 4) & 1 != u8::from(toggle) {
            return Err("download segment: toggle bit not alternated".into());
        }
        Ok(())
    }
}

fn expect_initiate_download_response(r: &[u8]) -> Result<(), SdoError> {
    match r.first() {
        Some(cmd) if cmd >> 5 == cs::INITIATE_DOWNLOAD_RESPONSE => Ok(()),
        other => Err(format!("{other:02x?} to an initiate download").into()),
    }
}

fn u32_at(r: &[u8], at: usize) -> Result<u32, String> {
    match r.get(at..at + 4) {
        Some([a, b, c, d]) => Ok(u32::from_le_bytes([*a, *b, *c, *d])),
        _ => Err("short SDO response".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_follow_the_command_bytes_of_the_specification() {
        // hardware-facts 3: expedited download of 1/2/4 bytes 0x2F/0x2B/0x23, upload 0x40,
        // complete access +0x10, normal download 0x21, segments 0x00|toggle|unused|last,
        // upload segment 0x60|toggle, abort 0x80.
        assert_eq!(request::expedited_download(0x6443, 1, &[1])[0], 0x2F);
        assert_eq!(request::expedited_download(0x1C32, 1, &[2, 0])[0], 0x2B);
        assert_eq!(
            request::expedited_download(0x6444, 1, &[0, 0x20, 0, 0]),
            [0x23, 0x44, 0x64, 1, 0, 0x20, 0, 0]
        );
        assert_eq!(request::initiate_upload(0x1A00, 0, true)[0], 0x50);
        assert_eq!(request::initiate_upload(0x1000, 0, false)[0], 0x40);
        assert_eq!(
            request::initiate_download(0x1A00, 0, true, 33, &[]),
            [0x31, 0x00, 0x1A, 0, 33, 0, 0, 0]
        );
        assert_eq!(request::download_segment(true, false, &[1, 2, 3])[0], 0x18);
        assert_eq!(request::download_segment(false, true, &[0; 7])[0], 0x01);
        assert_eq!(request::download_segment(false, false, &[0; 20]).len(), 21);
        assert_eq!(request::upload_segment(true)[0], 0x70);
        assert_eq!(request::abort(0x2001, 0, 0x0504_0000)[0], 0x80);
    }

    #[test]
    fn replies_decode_aborts_emergencies_and_mailbox_errors() {
        type M = MailboxClient<32>;
        let abort = M::frame(
            MAILBOX_TYPE_COE,
            1,
            &sdo_request_bytes(&request::abort(0x2001, 0, 0x0504_0000)),
        );
        assert_eq!(
            sdo_response(&abort),
            Err(SdoError::Abort {
                index: 0x2001,
                sub: 0,
                code: 0x0504_0000
            })
        );
        let mut emcy = vec![0x00, 0x10];
        emcy.extend_from_slice(&[0x50, 0x82, 0x11, 1, 2, 3, 4, 5]);
        let frame = M::frame(MAILBOX_TYPE_COE, 2, &emcy);
        assert_eq!(
            Emergency::parse(&frame),
            Some(Emergency {
                code: 0x8250,
                register: 0x11,
                data: [1, 2, 3, 4, 5]
            })
        );
        assert_eq!(Emergency::parse(&abort), None);
        let error = M::frame(MAILBOX_TYPE_ERROR, 0, &[1, 0, 2, 0]);
        assert_eq!(sdo_response(&error), Err(SdoError::MailboxError(2)));
        assert_eq!(mailbox_counter(&frame), 2);
    }
}
