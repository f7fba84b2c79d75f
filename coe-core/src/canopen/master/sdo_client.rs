//! The SDO client (CiA 301 7.2.4): one transfer at a time with one server, expedited and
//! segmented, upload and download, with the toggle and size checks, a timeout, and the
//! abort codes both ways. Block transfer is not implemented (the node's server has none
//! either).
//!
//! Frames are the 8 data bytes of [`crate::wire::SdoRepr`] on 0x600 + node-ID (requests)
//! and 0x580 + node-ID (answers). The client is sans-I/O: [`SdoClient::upload`] and
//! [`SdoClient::download`] give the first request, [`SdoClient::receive`] takes an answer
//! and [`SdoClient::poll`] the clock, each returning a [`Progress`]: a frame to send and/or
//! the end of the transfer.
//!
//! What the client refuses in an answer, and the abort it sends then:
//!
//! | answer | abort |
//! |---|---|
//! | another command specifier than the step expects, or a malformed frame | 0x05040001 |
//! | segment with the wrong toggle bit | 0x05030000 |
//! | more data than the client's buffer (`BUF`) | 0x05040005 |
//! | segments that do not add up to the indicated size | 0x06070010 |
//! | nothing within the timeout | 0x05040000 |
//!
//! An initiate answer for another index or subindex is ignored: it answers an earlier
//! request of a transfer that was dropped (the node booted up again and its boot began
//! anew), and the answer to this request follows.

use super::super::cob;
use super::super::frame::CanFrame;
use crate::abort::SdoAbortCode;
use crate::wire::{Direction, InitData, Sdo, SdoRepr};

/// Bytes of every SDO frame on CAN.
const FRAME_LEN: usize = 8;
/// Data bytes of a segment.
const SEGMENT_LEN: usize = 7;

/// Why a transfer failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SdoFailure {
    /// The server aborted with this code.
    Server(SdoAbortCode),
    /// The client aborted (it sent this code; 0x05040000 for a timeout).
    Client(SdoAbortCode),
}

impl SdoFailure {
    /// The abort code, whoever sent it.
    pub const fn code(self) -> SdoAbortCode {
        match self {
            Self::Server(c) | Self::Client(c) => c,
        }
    }

    /// True for the client's timeout.
    pub fn is_timeout(self) -> bool {
        self == Self::Client(SdoAbortCode::SdoProtocolTimeout)
    }
}

/// How a transfer ended: the bytes uploaded (0 for a download), or why it failed.
pub type SdoResult = Result<usize, SdoFailure>;

/// Why a request cannot start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RequestError {
    /// A transfer is in progress.
    Busy,
    /// The data do not fit the client's buffer (or are empty).
    Length,
}

/// What the client did with an answer or the clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Progress {
    /// A frame to send (the next request, or an abort).
    pub send: Option<CanFrame>,
    /// The transfer ended.
    pub done: Option<SdoResult>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum State {
    Idle,
    /// Initiate upload sent.
    Upload,
    /// Upload segment request sent (toggle in `toggle`).
    UploadSegment,
    /// Initiate download sent (segments follow unless expedited).
    Download {
        expedited: bool,
    },
    /// Download segment sent (toggle in `toggle`, `last` if it was the last).
    DownloadSegment {
        last: bool,
    },
}

/// The client of one SDO channel; `BUF` bytes of data move at most.
#[derive(Debug, Clone)]
pub struct SdoClient<const BUF: usize> {
    node: u8,
    state: State,
    index: u16,
    sub: u8,
    buf: [u8; BUF],
    /// Upload: bytes received; download: bytes to send.
    len: usize,
    /// Download: bytes sent.
    pos: usize,
    /// Upload: the size the server indicated.
    size: Option<u32>,
    toggle: bool,
    deadline_us: u64,
    timeout_us: u64,
}

impl<const BUF: usize> SdoClient<BUF> {
    /// A client of the server of `node`, answers due within `timeout_ms`.
    pub const fn new(node: u8, timeout_ms: u16) -> Self {
        Self {
            node,
            state: State::Idle,
            index: 0,
            sub: 0,
            buf: [0; BUF],
            len: 0,
            pos: 0,
            size: None,
            toggle: false,
            deadline_us: 0,
            timeout_us: timeout_ms as u64 * 1000,
        }
    }

    /// True while a transfer is in progress.
    pub const fn busy(&self) -> bool {
        !matches!(self.state, State::Idle)
    }

    /// The uploaded data of the last transfer.
    pub fn data(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// The uploaded data as a little-endian number (the first 4 bytes).
    pub fn value_u32(&self) -> u32 {
        let mut b = [0u8; 4];
        for (d, s) in b.iter_mut().zip(self.data()) {
            *d = *s;
        }
        u32::from_le_bytes(b)
    }

    /// When the transfer times out.
    pub fn deadline_us(&self) -> Option<u64> {
        self.busy().then_some(self.deadline_us)
    }

    /// Drops the transfer without a frame (the server rebooted: it forgot it too).
    pub fn cancel(&mut self) {
        self.state = State::Idle;
    }

    /// Starts an upload of `index`:`sub`; the initiate request to send.
    pub fn upload(&mut self, index: u16, sub: u8, now_us: u64) -> Result<CanFrame, RequestError> {
        if self.busy() {
            return Err(RequestError::Busy);
        }
        self.begin(index, sub, State::Upload, now_us);
        self.len = 0;
        self.size = None;
        self.request(&SdoRepr::InitiateUploadRequest {
            index,
            sub_index: sub,
            complete_access: false,
        })
        .ok_or(RequestError::Length)
    }

    /// Starts a download of `data` to `index`:`sub` (expedited up to 4 bytes, else
    /// segmented); the initiate request to send.
    pub fn download(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        now_us: u64,
    ) -> Result<CanFrame, RequestError> {
        if self.busy() {
            return Err(RequestError::Busy);
        }
        let dst = self.buf.get_mut(..data.len()).ok_or(RequestError::Length)?;
        if data.is_empty() {
            return Err(RequestError::Length);
        }
        dst.copy_from_slice(data);
        let expedited = data.len() <= 4;
        let init = match InitData::expedited(data) {
            Some(e) if expedited => e,
            _ => InitData::Normal {
                complete_size: data.len() as u32,
                data: &[],
            },
        };
        self.begin(index, sub, State::Download { expedited }, now_us);
        self.len = data.len();
        self.pos = 0;
        self.request(&SdoRepr::InitiateDownloadRequest {
            index,
            sub_index: sub,
            complete_access: false,
            data: init,
        })
        .ok_or(RequestError::Length)
    }

    fn begin(&mut self, index: u16, sub: u8, state: State, now_us: u64) {
        self.state = state;
        self.index = index;
        self.sub = sub;
        self.toggle = false;
        self.deadline_us = now_us.saturating_add(self.timeout_us);
    }

    /// The CAN frame of a request.
    fn request(&self, repr: &SdoRepr<'_>) -> Option<CanFrame> {
        let mut data = [0u8; FRAME_LEN];
        repr.emit(&mut Sdo::new_unchecked(&mut data[..])).ok()?;
        CanFrame::new(cob::SDO_RX + u16::from(self.node), &data).ok()
    }

    /// Ends the transfer with an abort of ours.
    fn abort(&mut self, code: SdoAbortCode) -> Progress {
        self.state = State::Idle;
        Progress {
            send: self.request(&SdoRepr::Abort {
                index: self.index,
                sub_index: self.sub,
                code,
            }),
            done: Some(Err(SdoFailure::Client(code))),
        }
    }

    fn finish(&mut self, result: SdoResult) -> Progress {
        self.state = State::Idle;
        Progress {
            send: None,
            done: Some(result),
        }
    }

    /// The next request of a transfer that goes on.
    fn next(&mut self, repr: &SdoRepr<'_>, now_us: u64) -> Progress {
        self.deadline_us = now_us.saturating_add(self.timeout_us);
        Progress {
            send: self.request(repr),
            done: None,
        }
    }

    /// The timeout at `now_us`: the abort to send and the failure.
    pub fn poll(&mut self, now_us: u64) -> Progress {
        match self.deadline_us() {
            Some(t) if now_us >= t => self.abort(SdoAbortCode::SdoProtocolTimeout),
            _ => Progress::default(),
        }
    }

    /// An answer of the server (the data of a frame on 0x580 + node-ID). A frame of another
    /// length than 8, or one while no transfer runs, is ignored.
    pub fn receive(&mut self, data: &[u8], now_us: u64) -> Progress {
        if !self.busy() || data.len() != FRAME_LEN {
            return Progress::default();
        }
        let Ok(view) = Sdo::new_checked(data) else {
            return Progress::default();
        };
        let Ok(repr) = SdoRepr::parse(&view, Direction::Response) else {
            return self.abort(SdoAbortCode::InvalidCommandSpecifier);
        };
        if let SdoRepr::Abort { code, .. } = repr {
            return self.finish(Err(SdoFailure::Server(code)));
        }
        match (self.state, repr) {
            (
                State::Upload,
                SdoRepr::InitiateUploadResponse {
                    index,
                    sub_index,
                    data,
                    ..
                },
            ) => {
                if (index, sub_index) != (self.index, self.sub) {
                    return Progress::default();
                }
                match data {
                    InitData::Expedited { .. } => {
                        let bytes = data.bytes();
                        match self.buf.get_mut(..bytes.len()) {
                            Some(dst) => {
                                dst.copy_from_slice(bytes);
                                self.len = bytes.len();
                                self.finish(Ok(bytes.len()))
                            }
                            None => self.abort(SdoAbortCode::OutOfMemory),
                        }
                    }
                    InitData::Normal { complete_size, .. } => {
                        if complete_size as usize > BUF {
                            return self.abort(SdoAbortCode::OutOfMemory);
                        }
                        self.size = Some(complete_size);
                        self.state = State::UploadSegment;
                        self.next(&SdoRepr::UploadSegmentRequest { toggle: false }, now_us)
                    }
                }
            }
            (State::UploadSegment, SdoRepr::UploadSegmentResponse { toggle, last, data }) => {
                if toggle != self.toggle {
                    return self.abort(SdoAbortCode::ToggleBitNotAlternated);
                }
                let end = self.len + data.len();
                let Some(dst) = self.buf.get_mut(self.len..end) else {
                    return self.abort(SdoAbortCode::OutOfMemory);
                };
                dst.copy_from_slice(data);
                self.len = end;
                let size = self.size.map_or(usize::MAX, |s| s as usize);
                if end > size || (last && end != size && self.size.is_some()) {
                    return self.abort(SdoAbortCode::LengthMismatch);
                }
                if last {
                    return self.finish(Ok(end));
                }
                self.toggle = !self.toggle;
                let toggle = self.toggle;
                self.next(&SdoRepr::UploadSegmentRequest { toggle }, now_us)
            }
            (
                State::Download { expedited },
                SdoRepr::InitiateDownloadResponse {
                    index, sub_index, ..
                },
            ) => {
                if (index, sub_index) != (self.index, self.sub) {
                    return Progress::default();
                }
                if expedited {
                    return self.finish(Ok(0));
                }
                self.send_segment(now_us)
            }
            (State::DownloadSegment { last }, SdoRepr::DownloadSegmentResponse { toggle }) => {
                if toggle != self.toggle {
                    return self.abort(SdoAbortCode::ToggleBitNotAlternated);
                }
                if last {
                    return self.finish(Ok(0));
                }
                self.toggle = !self.toggle;
                self.send_segment(now_us)
            }
            _ => self.abort(SdoAbortCode::InvalidCommandSpecifier),
        }
    }

    /// Sends the next download segment (toggle in `self.toggle`).
    fn send_segment(&mut self, now_us: u64) -> Progress {
        let end = (self.pos + SEGMENT_LEN).min(self.len);
        let last = end == self.len;
        let mut chunk = [0u8; SEGMENT_LEN];
        let n = end - self.pos;
        if let (Some(dst), Some(src)) = (chunk.get_mut(..n), self.buf.get(self.pos..end)) {
            dst.copy_from_slice(src);
        }
        self.pos = end;
        self.state = State::DownloadSegment { last };
        let toggle = self.toggle;
        self.next(
            &SdoRepr::DownloadSegmentRequest {
                toggle,
                last,
                data: chunk.get(..n).unwrap_or(&[]),
            },
            now_us,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(p: &Progress) -> [u8; 8] {
        let f = p.send.expect("a frame");
        assert_eq!(f.id(), 0x605);
        f.data().try_into().unwrap()
    }

    fn first(f: Result<CanFrame, RequestError>) -> [u8; 8] {
        let f = f.unwrap();
        assert_eq!(f.id(), 0x605);
        f.data().try_into().unwrap()
    }

    fn abort_code(bytes: [u8; 8]) -> u32 {
        assert_eq!(bytes[0], 0x80);
        u32::from_le_bytes(bytes[4..].try_into().unwrap())
    }

    /// CiA 301 expedited upload: 0x40 request, 0x43 answer with 4 bytes.
    #[test]
    fn expedited_upload_golden_frames() {
        let mut c = SdoClient::<16>::new(5, 100);
        assert_eq!(
            first(c.upload(0x1000, 0, 0)),
            [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]
        );
        assert_eq!(c.upload(0x1000, 0, 0), Err(RequestError::Busy));
        let p = c.receive(&[0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x0C, 0x00], 10);
        assert_eq!(p.send, None);
        assert_eq!(p.done, Some(Ok(4)));
        assert_eq!(c.value_u32(), 0x000C_0191);
        assert!(!c.busy());
        // One byte (0x4F), and size not indicated (0x42: all four).
        c.upload(0x1001, 0, 0).unwrap();
        assert_eq!(
            c.receive(&[0x4F, 0x01, 0x10, 0x00, 0x11, 0, 0, 0], 0).done,
            Some(Ok(1))
        );
        assert_eq!(c.data(), &[0x11]);
        c.upload(0x1001, 0, 0).unwrap();
        assert_eq!(
            c.receive(&[0x42, 0x01, 0x10, 0x00, 1, 2, 3, 4], 0).done,
            Some(Ok(4))
        );
    }

    /// A 17-byte segmented upload: 0x41 with the size, then 0x60/0x70 requests.
    #[test]
    fn segmented_upload_golden_frames() {
        let mut c = SdoClient::<32>::new(5, 100);
        c.upload(0x1008, 0, 0).unwrap();
        let p = c.receive(&[0x41, 0x08, 0x10, 0x00, 17, 0, 0, 0], 0);
        assert_eq!(frame(&p), [0x60, 0, 0, 0, 0, 0, 0, 0]);
        let p = c.receive(b"\x00Analog ", 0);
        assert_eq!(frame(&p), [0x70, 0, 0, 0, 0, 0, 0, 0]);
        let p = c.receive(b"\x10IO 8AI ", 0);
        assert_eq!(frame(&p), [0x60, 0, 0, 0, 0, 0, 0, 0]);
        let p = c.receive(b"\x092AO\0\0\0\0", 0);
        assert_eq!(p.done, Some(Ok(17)));
        assert_eq!(c.data(), b"Analog IO 8AI 2AO");
    }

    #[test]
    fn expedited_and_segmented_download_golden_frames() {
        let mut c = SdoClient::<32>::new(5, 100);
        assert_eq!(
            first(c.download(0x1017, 0, &[0xE8, 0x03], 0)),
            [0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0]
        );
        assert_eq!(
            c.receive(&[0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0], 0).done,
            Some(Ok(0))
        );
        assert_eq!(
            first(c.download(0x2001, 0, b"abcdefghij", 0)),
            [0x21, 0x01, 0x20, 0x00, 10, 0, 0, 0]
        );
        let p = c.receive(&[0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0], 0);
        assert_eq!(frame(&p), *b"\x00abcdefg");
        let p = c.receive(&[0x20, 0, 0, 0, 0, 0, 0, 0], 0);
        // 3 bytes, 4 unused, last, toggle 1: 0x10 | 4 << 1 | 1.
        assert_eq!(frame(&p), *b"\x19hij\0\0\0\0");
        assert_eq!(c.receive(&[0x30, 0, 0, 0, 0, 0, 0, 0], 0).done, Some(Ok(0)));
        assert_eq!(
            c.download(1, 0, &[0; 33], 0).unwrap_err(),
            RequestError::Length
        );
        assert_eq!(c.download(1, 0, &[], 0).unwrap_err(), RequestError::Length);
    }

    #[test]
    fn server_abort_ends_without_a_frame() {
        let mut c = SdoClient::<8>::new(5, 100);
        c.upload(0x2000, 1, 0).unwrap();
        let p = c.receive(&[0x80, 0x00, 0x20, 0x01, 0x00, 0x00, 0x02, 0x06], 0);
        assert_eq!(p.send, None);
        assert_eq!(
            p.done,
            Some(Err(SdoFailure::Server(SdoAbortCode::ObjectDoesNotExist)))
        );
    }

    #[test]
    fn client_aborts() {
        let mut c = SdoClient::<8>::new(5, 100);
        // Timeout.
        c.upload(0x1000, 0, 1_000).unwrap();
        assert_eq!(c.deadline_us(), Some(101_000));
        assert_eq!(c.poll(100_999), Progress::default());
        let p = c.poll(101_000);
        assert_eq!(abort_code(frame(&p)), 0x0504_0000);
        assert!(p.done.unwrap().unwrap_err().is_timeout());
        // The answer to an earlier request (another multiplexer) is not this one's.
        c.upload(0x1000, 0, 0).unwrap();
        let p = c.receive(&[0x43, 0x01, 0x10, 0x00, 1, 2, 3, 4], 0);
        assert_eq!(p, Progress::default());
        assert!(c.busy());
        assert_eq!(
            c.receive(&[0x43, 0x00, 0x10, 0x00, 1, 2, 3, 4], 0).done,
            Some(Ok(4))
        );
        // Wrong service.
        c.upload(0x1000, 0, 0).unwrap();
        let p = c.receive(&[0x60, 0x00, 0x10, 0x00, 0, 0, 0, 0], 0);
        assert_eq!(abort_code(frame(&p)), 0x0504_0001);
        // More than the buffer.
        c.upload(0x1008, 0, 0).unwrap();
        let p = c.receive(&[0x41, 0x08, 0x10, 0x00, 9, 0, 0, 0], 0);
        assert_eq!(abort_code(frame(&p)), 0x0504_0005);
        // Toggle not alternated.
        c.upload(0x1008, 0, 0).unwrap();
        c.receive(&[0x41, 0x08, 0x10, 0x00, 8, 0, 0, 0], 0);
        let p = c.receive(b"\x10abcdefg", 0);
        assert_eq!(abort_code(frame(&p)), 0x0503_0000);
        // Segments that do not add up to the size.
        c.upload(0x1008, 0, 0).unwrap();
        c.receive(&[0x41, 0x08, 0x10, 0x00, 8, 0, 0, 0], 0);
        let p = c.receive(b"\x05ab\0\0\0\0\0", 0);
        assert_eq!(abort_code(frame(&p)), 0x0607_0010);
        // Short frames and frames while idle are ignored.
        assert_eq!(c.receive(&[0x43, 0, 0x10, 0], 0), Progress::default());
        c.upload(0x1000, 0, 0).unwrap();
        assert_eq!(c.receive(&[0x43, 0, 0x10, 0], 0), Progress::default());
        assert!(c.busy());
        c.cancel();
        assert!(!c.busy());
    }

    mod prop {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            /// Any answers end a transfer in bounded steps with a result, never a panic;
            /// every frame the client sends is an 8-byte request to the server.
            #[test]
            fn any_answers(answers in proptest::collection::vec(proptest::array::uniform8(any::<u8>()), 0..40),
                           download in any::<bool>(), len in 1usize..20) {
                let mut c = SdoClient::<12>::new(9, 50);
                let data = [0x5Au8; 20];
                let start = if download { c.download(0x2000, 1, &data[..len], 0) } else { c.upload(0x2000, 1, 0) };
                prop_assert_eq!(start.is_ok(), !download || len <= 12);
                for (i, a) in answers.iter().enumerate() {
                    let p = c.receive(a, i as u64);
                    if let Some(f) = p.send {
                        prop_assert_eq!(f.id(), 0x609);
                        prop_assert_eq!(f.data().len(), 8);
                    }
                    if let Some(Ok(n)) = p.done {
                        prop_assert!(n <= 12);
                    }
                }
                let p = c.poll(u64::MAX);
                prop_assert!(!c.busy());
                prop_assert!(p.done.is_none() || p.done.unwrap().is_err());
            }
        }
    }
}
