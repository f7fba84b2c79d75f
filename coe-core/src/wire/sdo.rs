//! SDO frames (ETG.1000.6 5.6.2: SDO download expedited/normal request and response,
//! download segment, SDO upload expedited/normal, upload segment, abort SDO transfer; the
//! command byte is the CiA 301 7.2.4.3 SDO command byte).
//!
//! The view starts after the CoE header. Initiate and abort frames:
//!
//! ```text
//!  byte 0     command: size indicated b0 | expedited b1 | n [3:2] | complete access b4 |
//!             command specifier [7:5]
//!  byte 1..3  index u16
//!  byte 3     subindex
//!  byte 4..8  expedited data (4 - n bytes valid), complete size u32 (normal) or abort code u32
//!  byte 8..   data of a normal transfer
//! ```
//!
//! Segment frames:
//!
//! ```text
//!  byte 0     command: last segment b0 | n unused [3:1] | toggle b4 | command specifier [7:5]
//!  byte 1..   segment data; at least 7 bytes, a shorter segment is padded and n counts the
//!             padding (the minimum mailbox length is 10: CoE header + 8)
//! ```
//!
//! The same command specifier means different services in the two directions, so parsing
//! takes a [`Direction`]:
//!
//! | specifier | request (client -> server) | response (server -> client) |
//! |---|---|---|
//! | 0 | download segment | upload segment |
//! | 1 | initiate download | download segment |
//! | 2 | initiate upload | initiate upload |
//! | 3 | upload segment | initiate download |
//! | 4 | abort | abort |
//!
//! An abort travels with CoE service "SDO request" (2) in both directions.

use super::{
    get_u16, get_u32, get_u8, need, set_bytes, set_u16, set_u32, set_u8, tail, tail_mut,
    CoeService, Error, Result,
};
use crate::abort::SdoAbortCode;

mod field {
    use core::ops::Range;

    pub const COMMAND: usize = 0;
    pub const INDEX: Range<usize> = 1..3;
    pub const SUB_INDEX: usize = 3;
    pub const DATA: Range<usize> = 4..8;
    pub const NORMAL_DATA: usize = 8;
    pub const SEGMENT_DATA: usize = 1;
}

/// Length of an initiate or abort frame (and the minimum length of every SDO frame).
pub const HEADER_LEN: usize = field::NORMAL_DATA;

/// Length of a segment frame's header: the command byte before the segment data.
pub const SEGMENT_HEADER_LEN: usize = field::SEGMENT_DATA;

/// The fewest data bytes a segment frame carries (shorter segments are padded).
pub const MIN_SEGMENT_DATA: usize = 7;

/// Command byte bits.
mod cmd {
    pub const SIZE_INDICATED: u8 = 0x01;
    pub const EXPEDITED: u8 = 0x02;
    pub const SIZE_N_SHIFT: u8 = 2;
    pub const SIZE_N_MASK: u8 = 0x0C;
    pub const COMPLETE_ACCESS: u8 = 0x10;
    pub const TOGGLE: u8 = 0x10;
    pub const SEG_N_SHIFT: u8 = 1;
    pub const SEG_N_MASK: u8 = 0x0E;
    pub const LAST: u8 = 0x01;
    pub const SPEC_SHIFT: u8 = 5;

    // Request (client) command specifiers.
    pub const CCS_DOWNLOAD_SEGMENT: u8 = 0;
    pub const CCS_INITIATE_DOWNLOAD: u8 = 1;
    pub const CCS_INITIATE_UPLOAD: u8 = 2;
    pub const CCS_UPLOAD_SEGMENT: u8 = 3;
    // Response (server) command specifiers.
    pub const SCS_UPLOAD_SEGMENT: u8 = 0;
    pub const SCS_DOWNLOAD_SEGMENT: u8 = 1;
    pub const SCS_INITIATE_UPLOAD: u8 = 2;
    pub const SCS_INITIATE_DOWNLOAD: u8 = 3;
    // Both directions.
    pub const CS_ABORT: u8 = 4;
}

/// Which side sent a frame: the command specifier means different things in each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Client (master) to server (slave): CoE service "SDO request".
    Request,
    /// Server (slave) to client (master): CoE service "SDO response".
    Response,
}

impl Direction {
    /// The direction a CoE service implies; `None` for a service that carries no SDO.
    pub fn from_service(service: CoeService) -> Option<Direction> {
        match service {
            CoeService::SdoRequest => Some(Direction::Request),
            CoeService::SdoResponse => Some(Direction::Response),
            _ => None,
        }
    }

    /// The CoE service a frame travelling in this direction is sent with (an abort, a
    /// request-direction frame, uses "SDO request" from either side).
    pub const fn coe_service(self) -> CoeService {
        match self {
            Direction::Request => CoeService::SdoRequest,
            Direction::Response => CoeService::SdoResponse,
        }
    }
}

/// A read/write view of an SDO frame (the bytes after the CoE header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sdo<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Sdo<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> Sdo<T> {
        Sdo { buffer }
    }

    /// Wraps a buffer and checks it with [`check_len`](Self::check_len).
    pub fn new_checked(buffer: T) -> Result<Sdo<T>> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        Ok(packet)
    }

    /// `Err(Truncated)` if the buffer is shorter than 8 bytes (every SDO frame has at least
    /// the command byte and 7 more).
    pub fn check_len(&self) -> Result<()> {
        need(self.buffer.as_ref().len(), HEADER_LEN)
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The raw command byte.
    pub fn command(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::COMMAND)
    }

    /// Command specifier (bits 7:5).
    pub fn command_specifier(&self) -> u8 {
        self.command() >> cmd::SPEC_SHIFT
    }

    /// Size indicated (bit 0, initiate frames).
    pub fn size_indicated(&self) -> bool {
        self.command() & cmd::SIZE_INDICATED != 0
    }

    /// Expedited transfer (bit 1, initiate frames).
    pub fn expedited(&self) -> bool {
        self.command() & cmd::EXPEDITED != 0
    }

    /// Bytes of the 4 expedited data bytes that carry no data (bits 3:2, initiate frames).
    pub fn expedited_unused(&self) -> u8 {
        (self.command() & cmd::SIZE_N_MASK) >> cmd::SIZE_N_SHIFT
    }

    /// Complete access (bit 4, initiate frames).
    pub fn complete_access(&self) -> bool {
        self.command() & cmd::COMPLETE_ACCESS != 0
    }

    /// Toggle bit (bit 4, segment frames).
    pub fn toggle(&self) -> bool {
        self.command() & cmd::TOGGLE != 0
    }

    /// Padding bytes of a short segment (bits 3:1, segment data frames).
    pub fn segment_unused(&self) -> u8 {
        (self.command() & cmd::SEG_N_MASK) >> cmd::SEG_N_SHIFT
    }

    /// No more segments follow (bit 0, segment data frames).
    pub fn last_segment(&self) -> bool {
        self.command() & cmd::LAST != 0
    }

    /// Index (initiate and abort frames).
    pub fn index(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::INDEX)
    }

    /// Subindex (initiate and abort frames).
    pub fn sub_index(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::SUB_INDEX)
    }

    /// The 4 data bytes of an initiate frame (expedited data, all four).
    pub fn expedited_data(&self) -> [u8; 4] {
        get_u32(self.buffer.as_ref(), field::DATA).to_le_bytes()
    }

    /// Complete size of a normal initiate frame (bytes 4..8).
    pub fn complete_size(&self) -> u32 {
        get_u32(self.buffer.as_ref(), field::DATA)
    }

    /// Abort code of an abort frame (bytes 4..8).
    pub fn abort_code(&self) -> SdoAbortCode {
        SdoAbortCode::from(get_u32(self.buffer.as_ref(), field::DATA))
    }
}

impl<'a, T: AsRef<[u8]> + ?Sized> Sdo<&'a T> {
    /// The data of a normal initiate frame: everything after byte 8.
    pub fn normal_data(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), field::NORMAL_DATA)
    }

    /// Everything after the command byte of a segment frame, padding included.
    pub fn segment_bytes(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), field::SEGMENT_DATA)
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Sdo<T> {
    /// Sets the raw command byte.
    pub fn set_command(&mut self, value: u8) {
        set_u8(self.buffer.as_mut(), field::COMMAND, value)
    }

    /// Sets the index.
    pub fn set_index(&mut self, value: u16) {
        set_u16(self.buffer.as_mut(), field::INDEX, value)
    }

    /// Sets the subindex.
    pub fn set_sub_index(&mut self, value: u8) {
        set_u8(self.buffer.as_mut(), field::SUB_INDEX, value)
    }

    /// Sets the 4 data bytes of an initiate frame.
    pub fn set_expedited_data(&mut self, value: [u8; 4]) {
        set_u32(self.buffer.as_mut(), field::DATA, u32::from_le_bytes(value))
    }

    /// Sets the complete size of a normal initiate frame.
    pub fn set_complete_size(&mut self, value: u32) {
        set_u32(self.buffer.as_mut(), field::DATA, value)
    }

    /// Sets the abort code.
    pub fn set_abort_code(&mut self, value: SdoAbortCode) {
        set_u32(self.buffer.as_mut(), field::DATA, value.into())
    }

    /// The data of a normal initiate frame.
    pub fn normal_data_mut(&mut self) -> &mut [u8] {
        tail_mut(self.buffer.as_mut(), field::NORMAL_DATA)
    }

    /// Everything after the command byte of a segment frame.
    pub fn segment_bytes_mut(&mut self) -> &mut [u8] {
        tail_mut(self.buffer.as_mut(), field::SEGMENT_DATA)
    }
}

/// The data of an initiate download request or an initiate upload response.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InitData<'a> {
    /// Up to 4 bytes inside the initiate frame.
    Expedited {
        /// Exact size 1..=4 (command 0x2F/0x2B/0x27/0x23, 0x4F/0x4B/0x47/0x43), or `None`
        /// when the size is not indicated (0x22, 0x42: the object's own size applies).
        size: Option<u8>,
        /// All four data bytes as on the wire (bytes past `size` are padding).
        data: [u8; 4],
    },
    /// A normal transfer: complete size, then the first (or only) part of the data.
    Normal {
        /// Size of the whole object data (bytes 4..8).
        complete_size: u32,
        /// The data in this frame (the rest follows in segments).
        data: &'a [u8],
    },
}

impl<'a> InitData<'a> {
    /// Expedited data with the exact size of `bytes` (1..=4 bytes), zero-padded; `None` for
    /// an empty or longer slice.
    pub fn expedited(bytes: &[u8]) -> Option<InitData<'a>> {
        let size = u8::try_from(bytes.len())
            .ok()
            .filter(|n| (1..=4).contains(n))?;
        let mut data = [0u8; 4];
        set_bytes(&mut data, 0, bytes);
        Some(InitData::Expedited {
            size: Some(size),
            data,
        })
    }

    /// The data bytes (all four for an expedited transfer without size).
    pub fn bytes(&self) -> &[u8] {
        match self {
            InitData::Expedited { size, data } => {
                let n = usize::from(size.unwrap_or(4));
                data.get(..n).unwrap_or(data)
            }
            InitData::Normal { data, .. } => data,
        }
    }

    /// Bytes after the 8-byte initiate header.
    const fn extra_len(&self) -> usize {
        match self {
            InitData::Expedited { .. } => 0,
            InitData::Normal { data, .. } => data.len(),
        }
    }

    /// Bits 3:0 of the command byte.
    fn command_bits(&self) -> Result<u8> {
        match *self {
            InitData::Expedited { size: None, .. } => Ok(cmd::EXPEDITED),
            InitData::Expedited {
                size: Some(size @ 1..=4),
                ..
            } => Ok(cmd::EXPEDITED | cmd::SIZE_INDICATED | ((4 - size) << cmd::SIZE_N_SHIFT)),
            InitData::Expedited { .. } => Err(Error::Malformed),
            InitData::Normal { .. } => Ok(cmd::SIZE_INDICATED),
        }
    }

    fn parse<T: AsRef<[u8]> + ?Sized>(packet: &Sdo<&'a T>) -> Result<InitData<'a>> {
        match (packet.expedited(), packet.size_indicated()) {
            (true, true) => Ok(InitData::Expedited {
                size: Some(4 - packet.expedited_unused()),
                data: packet.expedited_data(),
            }),
            (true, false) if packet.expedited_unused() == 0 => Ok(InitData::Expedited {
                size: None,
                data: packet.expedited_data(),
            }),
            (false, true) if packet.expedited_unused() == 0 => Ok(InitData::Normal {
                complete_size: packet.complete_size(),
                data: packet.normal_data(),
            }),
            // n set without an indicated expedited size, or a normal transfer without size.
            _ => Err(Error::Malformed),
        }
    }

    fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut Sdo<T>) {
        match *self {
            InitData::Expedited { data, .. } => packet.set_expedited_data(data),
            InitData::Normal {
                complete_size,
                data,
            } => {
                packet.set_complete_size(complete_size);
                set_bytes(packet.normal_data_mut(), 0, data);
            }
        }
    }
}

/// An SDO frame as values (data borrowed from the buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SdoRepr<'a> {
    /// Initiate download request (0x21/0x22/0x23..0x2F, complete access +0x10).
    InitiateDownloadRequest {
        /// Index.
        index: u16,
        /// Subindex (0 or 1 with complete access).
        sub_index: u8,
        /// Complete access: the whole object from `sub_index` on.
        complete_access: bool,
        /// The data.
        data: InitData<'a>,
    },
    /// Initiate download response (0x60, complete access 0x70).
    InitiateDownloadResponse {
        /// Index.
        index: u16,
        /// Subindex.
        sub_index: u8,
        /// Complete access.
        complete_access: bool,
    },
    /// Initiate upload request (0x40, complete access 0x50).
    InitiateUploadRequest {
        /// Index.
        index: u16,
        /// Subindex.
        sub_index: u8,
        /// Complete access.
        complete_access: bool,
    },
    /// Initiate upload response (0x41/0x42/0x43..0x4F, complete access +0x10).
    InitiateUploadResponse {
        /// Index.
        index: u16,
        /// Subindex.
        sub_index: u8,
        /// Complete access.
        complete_access: bool,
        /// The data.
        data: InitData<'a>,
    },
    /// Download segment request (0x00 | toggle | n | last).
    DownloadSegmentRequest {
        /// Toggle bit.
        toggle: bool,
        /// No more segments follow.
        last: bool,
        /// Segment data (padding removed).
        data: &'a [u8],
    },
    /// Download segment response (0x20 | toggle).
    DownloadSegmentResponse {
        /// Toggle bit (echoes the request).
        toggle: bool,
    },
    /// Upload segment request (0x60 | toggle).
    UploadSegmentRequest {
        /// Toggle bit.
        toggle: bool,
    },
    /// Upload segment response (0x00 | toggle | n | last).
    UploadSegmentResponse {
        /// Toggle bit (echoes the request).
        toggle: bool,
        /// No more segments follow.
        last: bool,
        /// Segment data (padding removed).
        data: &'a [u8],
    },
    /// Abort SDO transfer (0x80), either direction.
    Abort {
        /// Index.
        index: u16,
        /// Subindex.
        sub_index: u8,
        /// Reason.
        code: SdoAbortCode,
    },
}

/// Parses the data of a download segment request / upload segment response.
fn parse_segment<'a, T: AsRef<[u8]> + ?Sized>(packet: &Sdo<&'a T>) -> Result<&'a [u8]> {
    let bytes = packet.segment_bytes();
    let unused = usize::from(packet.segment_unused());
    if unused != 0 && bytes.len() != MIN_SEGMENT_DATA {
        // Padding is only defined for the minimum-size frame.
        return Err(Error::Malformed);
    }
    bytes
        .get(..bytes.len().saturating_sub(unused))
        .ok_or(Error::Malformed)
}

impl<'a> SdoRepr<'a> {
    /// Parses an SDO frame sent in `direction`. Padding and reserved bytes are not checked;
    /// reserved command bits of a non-abort frame must be 0 (`Err(Malformed)`), as must the
    /// block-transfer specifiers 5..7, which CoE does not use.
    pub fn parse<T: AsRef<[u8]> + ?Sized>(
        packet: &Sdo<&'a T>,
        direction: Direction,
    ) -> Result<SdoRepr<'a>> {
        packet.check_len()?;
        let command = packet.command();
        let spec = packet.command_specifier();
        let index = packet.index();
        let sub_index = packet.sub_index();
        let complete_access = packet.complete_access();
        let toggle = packet.toggle();
        let low_bits_clear = command & 0x0F == 0;
        match (direction, spec) {
            (_, cmd::CS_ABORT) => Ok(SdoRepr::Abort {
                index,
                sub_index,
                code: packet.abort_code(),
            }),
            (Direction::Request, cmd::CCS_INITIATE_DOWNLOAD) => {
                Ok(SdoRepr::InitiateDownloadRequest {
                    index,
                    sub_index,
                    complete_access,
                    data: InitData::parse(packet)?,
                })
            }
            (Direction::Request, cmd::CCS_INITIATE_UPLOAD) if low_bits_clear => {
                Ok(SdoRepr::InitiateUploadRequest {
                    index,
                    sub_index,
                    complete_access,
                })
            }
            (Direction::Request, cmd::CCS_DOWNLOAD_SEGMENT) => {
                Ok(SdoRepr::DownloadSegmentRequest {
                    toggle,
                    last: packet.last_segment(),
                    data: parse_segment(packet)?,
                })
            }
            (Direction::Request, cmd::CCS_UPLOAD_SEGMENT) if low_bits_clear => {
                Ok(SdoRepr::UploadSegmentRequest { toggle })
            }
            (Direction::Response, cmd::SCS_INITIATE_DOWNLOAD) if low_bits_clear => {
                Ok(SdoRepr::InitiateDownloadResponse {
                    index,
                    sub_index,
                    complete_access,
                })
            }
            (Direction::Response, cmd::SCS_INITIATE_UPLOAD) => {
                Ok(SdoRepr::InitiateUploadResponse {
                    index,
                    sub_index,
                    complete_access,
                    data: InitData::parse(packet)?,
                })
            }
            (Direction::Response, cmd::SCS_DOWNLOAD_SEGMENT) if low_bits_clear => {
                Ok(SdoRepr::DownloadSegmentResponse { toggle })
            }
            (Direction::Response, cmd::SCS_UPLOAD_SEGMENT) => Ok(SdoRepr::UploadSegmentResponse {
                toggle,
                last: packet.last_segment(),
                data: parse_segment(packet)?,
            }),
            _ => Err(Error::Malformed),
        }
    }

    /// The direction this frame travels in.
    pub const fn direction(&self) -> Direction {
        match self {
            SdoRepr::InitiateDownloadRequest { .. }
            | SdoRepr::InitiateUploadRequest { .. }
            | SdoRepr::DownloadSegmentRequest { .. }
            | SdoRepr::UploadSegmentRequest { .. }
            | SdoRepr::Abort { .. } => Direction::Request,
            SdoRepr::InitiateDownloadResponse { .. }
            | SdoRepr::InitiateUploadResponse { .. }
            | SdoRepr::DownloadSegmentResponse { .. }
            | SdoRepr::UploadSegmentResponse { .. } => Direction::Response,
        }
    }

    /// The CoE service the frame is sent with (an abort uses "SDO request" in both
    /// directions).
    pub const fn coe_service(&self) -> CoeService {
        self.direction().coe_service()
    }

    /// Length of the emitted frame (without CoE header).
    pub const fn buffer_len(&self) -> usize {
        match self {
            SdoRepr::InitiateDownloadRequest { data, .. }
            | SdoRepr::InitiateUploadResponse { data, .. } => HEADER_LEN + data.extra_len(),
            SdoRepr::DownloadSegmentRequest { data, .. }
            | SdoRepr::UploadSegmentResponse { data, .. } => {
                let n = if data.len() > MIN_SEGMENT_DATA {
                    data.len()
                } else {
                    MIN_SEGMENT_DATA
                };
                field::SEGMENT_DATA + n
            }
            SdoRepr::InitiateDownloadResponse { .. }
            | SdoRepr::InitiateUploadRequest { .. }
            | SdoRepr::DownloadSegmentResponse { .. }
            | SdoRepr::UploadSegmentRequest { .. }
            | SdoRepr::Abort { .. } => HEADER_LEN,
        }
    }

    /// Writes the frame into the first [`buffer_len`](Self::buffer_len) bytes of `packet`;
    /// reserved and padding bytes are written as 0. `Err(Malformed)` for an expedited size
    /// outside 1..=4, `Err(Truncated)` for a short buffer (nothing is written then).
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut Sdo<T>) -> Result<()> {
        let ca = |on: bool| if on { cmd::COMPLETE_ACCESS } else { 0 };
        let tg = |on: bool| if on { cmd::TOGGLE } else { 0 };
        // Validate before writing anything.
        let command = match *self {
            SdoRepr::InitiateDownloadRequest {
                complete_access,
                data,
                ..
            } => {
                (cmd::CCS_INITIATE_DOWNLOAD << cmd::SPEC_SHIFT)
                    | ca(complete_access)
                    | data.command_bits()?
            }
            SdoRepr::InitiateUploadResponse {
                complete_access,
                data,
                ..
            } => {
                (cmd::SCS_INITIATE_UPLOAD << cmd::SPEC_SHIFT)
                    | ca(complete_access)
                    | data.command_bits()?
            }
            SdoRepr::InitiateDownloadResponse {
                complete_access, ..
            } => (cmd::SCS_INITIATE_DOWNLOAD << cmd::SPEC_SHIFT) | ca(complete_access),
            SdoRepr::InitiateUploadRequest {
                complete_access, ..
            } => (cmd::CCS_INITIATE_UPLOAD << cmd::SPEC_SHIFT) | ca(complete_access),
            SdoRepr::DownloadSegmentRequest { toggle, last, data }
            | SdoRepr::UploadSegmentResponse { toggle, last, data } => {
                // Specifier 0 in both cases.
                let unused = MIN_SEGMENT_DATA.saturating_sub(data.len()) as u8;
                tg(toggle) | (unused << cmd::SEG_N_SHIFT) | if last { cmd::LAST } else { 0 }
            }
            SdoRepr::DownloadSegmentResponse { toggle } => {
                (cmd::SCS_DOWNLOAD_SEGMENT << cmd::SPEC_SHIFT) | tg(toggle)
            }
            SdoRepr::UploadSegmentRequest { toggle } => {
                (cmd::CCS_UPLOAD_SEGMENT << cmd::SPEC_SHIFT) | tg(toggle)
            }
            SdoRepr::Abort { .. } => cmd::CS_ABORT << cmd::SPEC_SHIFT,
        };
        let len = self.buffer_len();
        need(packet.buffer.as_ref().len(), len)?;
        if let Some(frame) = packet.buffer.as_mut().get_mut(..len) {
            frame.fill(0);
        }
        packet.set_command(command);
        match *self {
            SdoRepr::InitiateDownloadRequest {
                index,
                sub_index,
                data,
                ..
            }
            | SdoRepr::InitiateUploadResponse {
                index,
                sub_index,
                data,
                ..
            } => {
                packet.set_index(index);
                packet.set_sub_index(sub_index);
                data.emit(packet);
            }
            SdoRepr::InitiateDownloadResponse {
                index, sub_index, ..
            }
            | SdoRepr::InitiateUploadRequest {
                index, sub_index, ..
            } => {
                packet.set_index(index);
                packet.set_sub_index(sub_index);
            }
            SdoRepr::DownloadSegmentRequest { data, .. }
            | SdoRepr::UploadSegmentResponse { data, .. } => {
                set_bytes(packet.segment_bytes_mut(), 0, data);
            }
            SdoRepr::DownloadSegmentResponse { .. } | SdoRepr::UploadSegmentRequest { .. } => {}
            SdoRepr::Abort {
                index,
                sub_index,
                code,
            } => {
                packet.set_index(index);
                packet.set_sub_index(sub_index);
                packet.set_abort_code(code);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(bytes: &[u8], direction: Direction) -> Result<SdoRepr<'_>> {
        SdoRepr::parse(&Sdo::new_unchecked(bytes), direction)
    }

    fn emit(repr: &SdoRepr<'_>, len: usize) -> [u8; 32] {
        let mut bytes = [0xa5u8; 32];
        repr.emit(&mut Sdo::new_unchecked(&mut bytes[..])).unwrap();
        assert_eq!(repr.buffer_len(), len);
        assert!(
            bytes[len..].iter().all(|&b| b == 0xa5),
            "wrote past buffer_len"
        );
        bytes
    }

    /// Parses `bytes`, checks the Repr, emits it again and compares with `bytes`.
    fn round_trip(bytes: &[u8], direction: Direction, expected: SdoRepr<'_>) {
        assert_eq!(parse(bytes, direction), Ok(expected));
        assert_eq!(expected.direction(), direction);
        let out = emit(&expected, bytes.len());
        assert_eq!(&out[..bytes.len()], bytes);
    }

    /// Expedited download of 0x1600:01 = 0x64110110 (4 bytes): command 0x23.
    static DOWNLOAD_EXP4: [u8; 8] = [0x23, 0x00, 0x16, 0x01, 0x10, 0x01, 0x11, 0x64];
    /// Expedited download of 0x1C12:00 = 1 (1 byte): command 0x2F.
    static DOWNLOAD_EXP1: [u8; 8] = [0x2F, 0x12, 0x1C, 0x00, 0x01, 0x00, 0x00, 0x00];
    /// 2 bytes: 0x6411:01 = 0x1234, command 0x2B.
    static DOWNLOAD_EXP2: [u8; 8] = [0x2B, 0x11, 0x64, 0x01, 0x34, 0x12, 0x00, 0x00];
    /// 3 bytes: 0x2000:00 = 0x56 0x34 0x12, command 0x27.
    static DOWNLOAD_EXP3: [u8; 8] = [0x27, 0x00, 0x20, 0x00, 0x56, 0x34, 0x12, 0x00];
    /// Size not indicated: command 0x22.
    static DOWNLOAD_EXP_NOSIZE: [u8; 8] = [0x22, 0x00, 0x20, 0x00, 0x01, 0x02, 0x03, 0x04];
    /// Complete access download of 0x1C12 from subindex 0, 4 bytes expedited: 0x33.
    static DOWNLOAD_EXP_CA: [u8; 8] = [0x33, 0x12, 0x1C, 0x00, 0x01, 0x00, 0x00, 0x16];
    /// Normal download 0x1008:00, 6 bytes "ABCDEF" of complete size 6: command 0x21.
    static DOWNLOAD_NORMAL: [u8; 14] = [
        0x21, 0x08, 0x10, 0x00, 0x06, 0x00, 0x00, 0x00, b'A', b'B', b'C', b'D', b'E', b'F',
    ];
    /// Normal complete-access download of 0x1C12 (sub 0), 5 of 6 bytes: command 0x31.
    static DOWNLOAD_NORMAL_CA: [u8; 13] = [
        0x31, 0x12, 0x1C, 0x00, 0x06, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x16, 0x01,
    ];
    /// Download response for 0x1600:01: 0x60.
    static DOWNLOAD_RESPONSE: [u8; 8] = [0x60, 0x00, 0x16, 0x01, 0x00, 0x00, 0x00, 0x00];
    /// Complete-access download response: 0x70.
    static DOWNLOAD_RESPONSE_CA: [u8; 8] = [0x70, 0x12, 0x1C, 0x00, 0x00, 0x00, 0x00, 0x00];
    /// Upload request 0x1018:01: 0x40.
    static UPLOAD_REQUEST: [u8; 8] = [0x40, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00];
    /// Complete-access upload request 0x1C12 from sub 0: 0x50.
    static UPLOAD_REQUEST_CA: [u8; 8] = [0x50, 0x12, 0x1C, 0x00, 0x00, 0x00, 0x00, 0x00];
    /// Upload responses with exact sizes 1..4: 0x4F, 0x4B, 0x47, 0x43.
    static UPLOAD_EXP1: [u8; 8] = [0x4F, 0x12, 0x1C, 0x00, 0x01, 0x00, 0x00, 0x00];
    static UPLOAD_EXP2: [u8; 8] = [0x4B, 0x01, 0x64, 0x03, 0xFF, 0x7F, 0x00, 0x00];
    static UPLOAD_EXP3: [u8; 8] = [0x47, 0x00, 0x20, 0x00, 0xAA, 0xBB, 0xCC, 0x00];
    static UPLOAD_EXP4: [u8; 8] = [0x43, 0x00, 0x10, 0x00, 0x91, 0x01, 0x0C, 0x00];
    /// Normal upload response: 0x1008:00 "DAC" (complete size 3): 0x41.
    static UPLOAD_NORMAL: [u8; 11] = [
        0x41, 0x08, 0x10, 0x00, 0x03, 0x00, 0x00, 0x00, b'D', b'A', b'C',
    ];
    /// Normal upload response announcing 20 bytes with 9 in this frame (segments follow).
    static UPLOAD_NORMAL_PART: [u8; 17] = [
        0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00, 1, 2, 3, 4, 5, 6, 7, 8, 9,
    ];
    /// Download segment, toggle 0, not last, 7 bytes: 0x00.
    static DOWNLOAD_SEG_FULL: [u8; 8] = [0x00, 1, 2, 3, 4, 5, 6, 7];
    /// Download segment, toggle 1, last, 3 bytes padded to 7: 0x10 | (4 << 1) | 1 = 0x19.
    static DOWNLOAD_SEG_SHORT: [u8; 8] = [0x19, 0xA, 0xB, 0xC, 0x00, 0x00, 0x00, 0x00];
    /// Download segment, toggle 0, last, 10 bytes: 0x01.
    static DOWNLOAD_SEG_LONG: [u8; 11] = [0x01, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9];
    /// Download segment, empty last segment: n = 7 -> 0x0F.
    static DOWNLOAD_SEG_EMPTY: [u8; 8] = [0x0F, 0, 0, 0, 0, 0, 0, 0];
    /// Download segment responses: 0x20 and 0x30.
    static DOWNLOAD_SEG_RESPONSE0: [u8; 8] = [0x20, 0, 0, 0, 0, 0, 0, 0];
    static DOWNLOAD_SEG_RESPONSE1: [u8; 8] = [0x30, 0, 0, 0, 0, 0, 0, 0];
    /// Upload segment requests: 0x60 and 0x70.
    static UPLOAD_SEG_REQUEST0: [u8; 8] = [0x60, 0, 0, 0, 0, 0, 0, 0];
    static UPLOAD_SEG_REQUEST1: [u8; 8] = [0x70, 0, 0, 0, 0, 0, 0, 0];
    /// Upload segment response, toggle 1, last, 5 bytes: 0x10 | (2 << 1) | 1 = 0x15.
    static UPLOAD_SEG_SHORT: [u8; 8] = [0x15, b'h', b'e', b'l', b'l', b'o', 0, 0];
    /// Upload segment response, toggle 0, not last, 9 bytes: 0x00.
    static UPLOAD_SEG_LONG: [u8; 10] = [0x00, 9, 8, 7, 6, 5, 4, 3, 2, 1];
    /// Abort 0x6000:01 "object does not exist" (0x06020000).
    static ABORT: [u8; 8] = [0x80, 0x00, 0x60, 0x01, 0x00, 0x00, 0x02, 0x06];

    #[test]
    fn deconstruct_initiate() {
        let p = Sdo::new_checked(&DOWNLOAD_EXP2[..]).unwrap();
        assert_eq!(p.command(), 0x2B);
        assert_eq!(p.command_specifier(), 1);
        assert!(p.size_indicated());
        assert!(p.expedited());
        assert_eq!(p.expedited_unused(), 2);
        assert!(!p.complete_access());
        assert_eq!(p.index(), 0x6411);
        assert_eq!(p.sub_index(), 1);
        assert_eq!(p.expedited_data(), [0x34, 0x12, 0x00, 0x00]);

        let p = Sdo::new_checked(&DOWNLOAD_NORMAL_CA[..]).unwrap();
        assert!(p.complete_access());
        assert!(!p.expedited());
        assert_eq!(p.complete_size(), 6);
        assert_eq!(p.normal_data(), &[0x02, 0x00, 0x00, 0x16, 0x01]);

        let p = Sdo::new_checked(&ABORT[..]).unwrap();
        assert_eq!(p.command_specifier(), 4);
        assert_eq!(p.abort_code(), SdoAbortCode::ObjectDoesNotExist);
    }

    #[test]
    fn deconstruct_segment() {
        let p = Sdo::new_checked(&DOWNLOAD_SEG_SHORT[..]).unwrap();
        assert_eq!(p.command_specifier(), 0);
        assert!(p.toggle());
        assert_eq!(p.segment_unused(), 4);
        assert!(p.last_segment());
        assert_eq!(p.segment_bytes(), &DOWNLOAD_SEG_SHORT[1..]);
    }

    #[test]
    fn construct() {
        let mut bytes = [0xa5u8; 8];
        let mut p = Sdo::new_unchecked(&mut bytes[..]);
        p.set_command(0x2B);
        p.set_index(0x6411);
        p.set_sub_index(1);
        p.set_expedited_data([0x34, 0x12, 0x00, 0x00]);
        assert_eq!(bytes, DOWNLOAD_EXP2);

        let mut bytes = [0xa5u8; 8];
        let mut p = Sdo::new_unchecked(&mut bytes[..]);
        p.set_command(0x80);
        p.set_index(0x6000);
        p.set_sub_index(1);
        p.set_abort_code(SdoAbortCode::ObjectDoesNotExist);
        assert_eq!(bytes, ABORT);

        let mut bytes = [0xa5u8; 14];
        let mut p = Sdo::new_unchecked(&mut bytes[..]);
        p.set_command(0x21);
        p.set_index(0x1008);
        p.set_sub_index(0);
        p.set_complete_size(6);
        p.normal_data_mut().copy_from_slice(b"ABCDEF");
        assert_eq!(bytes, DOWNLOAD_NORMAL);

        let mut bytes = [0xa5u8; 8];
        let mut p = Sdo::new_unchecked(&mut bytes[..]);
        p.set_command(0x19);
        p.segment_bytes_mut()
            .copy_from_slice(&[0xA, 0xB, 0xC, 0, 0, 0, 0]);
        assert_eq!(bytes, DOWNLOAD_SEG_SHORT);
    }

    #[test]
    fn expedited_download_exact_sizes() {
        let cases: [(&[u8; 8], u8, u16, u8); 4] = [
            (&DOWNLOAD_EXP1, 1, 0x1C12, 0),
            (&DOWNLOAD_EXP2, 2, 0x6411, 1),
            (&DOWNLOAD_EXP3, 3, 0x2000, 0),
            (&DOWNLOAD_EXP4, 4, 0x1600, 1),
        ];
        for (bytes, size, index, sub_index) in cases {
            let data = InitData::expedited(&bytes[4..4 + usize::from(size)]).unwrap();
            assert_eq!(data.bytes().len(), usize::from(size));
            round_trip(
                bytes,
                Direction::Request,
                SdoRepr::InitiateDownloadRequest {
                    index,
                    sub_index,
                    complete_access: false,
                    data,
                },
            );
        }
    }

    #[test]
    fn expedited_download_without_size() {
        let data = InitData::Expedited {
            size: None,
            data: [1, 2, 3, 4],
        };
        assert_eq!(data.bytes(), &[1, 2, 3, 4]);
        round_trip(
            &DOWNLOAD_EXP_NOSIZE,
            Direction::Request,
            SdoRepr::InitiateDownloadRequest {
                index: 0x2000,
                sub_index: 0,
                complete_access: false,
                data,
            },
        );
    }

    #[test]
    fn expedited_download_complete_access() {
        round_trip(
            &DOWNLOAD_EXP_CA,
            Direction::Request,
            SdoRepr::InitiateDownloadRequest {
                index: 0x1C12,
                sub_index: 0,
                complete_access: true,
                data: InitData::expedited(&[0x01, 0x00, 0x00, 0x16]).unwrap(),
            },
        );
    }

    #[test]
    fn normal_download() {
        round_trip(
            &DOWNLOAD_NORMAL,
            Direction::Request,
            SdoRepr::InitiateDownloadRequest {
                index: 0x1008,
                sub_index: 0,
                complete_access: false,
                data: InitData::Normal {
                    complete_size: 6,
                    data: b"ABCDEF",
                },
            },
        );
        round_trip(
            &DOWNLOAD_NORMAL_CA,
            Direction::Request,
            SdoRepr::InitiateDownloadRequest {
                index: 0x1C12,
                sub_index: 0,
                complete_access: true,
                data: InitData::Normal {
                    complete_size: 6,
                    data: &[0x02, 0x00, 0x00, 0x16, 0x01],
                },
            },
        );
    }

    #[test]
    fn download_response() {
        round_trip(
            &DOWNLOAD_RESPONSE,
            Direction::Response,
            SdoRepr::InitiateDownloadResponse {
                index: 0x1600,
                sub_index: 1,
                complete_access: false,
            },
        );
        round_trip(
            &DOWNLOAD_RESPONSE_CA,
            Direction::Response,
            SdoRepr::InitiateDownloadResponse {
                index: 0x1C12,
                sub_index: 0,
                complete_access: true,
            },
        );
    }

    #[test]
    fn upload_request() {
        round_trip(
            &UPLOAD_REQUEST,
            Direction::Request,
            SdoRepr::InitiateUploadRequest {
                index: 0x1018,
                sub_index: 1,
                complete_access: false,
            },
        );
        round_trip(
            &UPLOAD_REQUEST_CA,
            Direction::Request,
            SdoRepr::InitiateUploadRequest {
                index: 0x1C12,
                sub_index: 0,
                complete_access: true,
            },
        );
    }

    #[test]
    fn expedited_upload_exact_sizes() {
        let cases: [(&[u8; 8], usize, u16, u8); 4] = [
            (&UPLOAD_EXP1, 1, 0x1C12, 0),
            (&UPLOAD_EXP2, 2, 0x6401, 3),
            (&UPLOAD_EXP3, 3, 0x2000, 0),
            (&UPLOAD_EXP4, 4, 0x1000, 0),
        ];
        for (bytes, size, index, sub_index) in cases {
            round_trip(
                bytes,
                Direction::Response,
                SdoRepr::InitiateUploadResponse {
                    index,
                    sub_index,
                    complete_access: false,
                    data: InitData::expedited(&bytes[4..4 + size]).unwrap(),
                },
            );
        }
        // 0x1000 = 0x000C0191 as a u32 expedited upload.
        let Ok(SdoRepr::InitiateUploadResponse { data, .. }) =
            parse(&UPLOAD_EXP4, Direction::Response)
        else {
            panic!()
        };
        assert_eq!(data.bytes(), &0x000C_0191u32.to_le_bytes());
    }

    #[test]
    fn normal_upload() {
        round_trip(
            &UPLOAD_NORMAL,
            Direction::Response,
            SdoRepr::InitiateUploadResponse {
                index: 0x1008,
                sub_index: 0,
                complete_access: false,
                data: InitData::Normal {
                    complete_size: 3,
                    data: b"DAC",
                },
            },
        );
        round_trip(
            &UPLOAD_NORMAL_PART,
            Direction::Response,
            SdoRepr::InitiateUploadResponse {
                index: 0x1008,
                sub_index: 0,
                complete_access: false,
                data: InitData::Normal {
                    complete_size: 20,
                    data: &[1, 2, 3, 4, 5, 6, 7, 8, 9],
                },
            },
        );
    }

    #[test]
    fn download_segments() {
        round_trip(
            &DOWNLOAD_SEG_FULL,
            Direction::Request,
            SdoRepr::DownloadSegmentRequest {
                toggle: false,
                last: false,
                data: &[1, 2, 3, 4, 5, 6, 7],
            },
        );
        round_trip(
            &DOWNLOAD_SEG_SHORT,
            Direction::Request,
            SdoRepr::DownloadSegmentRequest {
                toggle: true,
                last: true,
                data: &[0xA, 0xB, 0xC],
            },
        );
        round_trip(
            &DOWNLOAD_SEG_LONG,
            Direction::Request,
            SdoRepr::DownloadSegmentRequest {
                toggle: false,
                last: true,
                data: &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9],
            },
        );
        round_trip(
            &DOWNLOAD_SEG_EMPTY,
            Direction::Request,
            SdoRepr::DownloadSegmentRequest {
                toggle: false,
                last: true,
                data: &[],
            },
        );
    }

    #[test]
    fn download_segment_responses() {
        round_trip(
            &DOWNLOAD_SEG_RESPONSE0,
            Direction::Response,
            SdoRepr::DownloadSegmentResponse { toggle: false },
        );
        round_trip(
            &DOWNLOAD_SEG_RESPONSE1,
            Direction::Response,
            SdoRepr::DownloadSegmentResponse { toggle: true },
        );
    }

    #[test]
    fn upload_segment_requests() {
        round_trip(
            &UPLOAD_SEG_REQUEST0,
            Direction::Request,
            SdoRepr::UploadSegmentRequest { toggle: false },
        );
        round_trip(
            &UPLOAD_SEG_REQUEST1,
            Direction::Request,
            SdoRepr::UploadSegmentRequest { toggle: true },
        );
    }

    #[test]
    fn upload_segment_responses() {
        round_trip(
            &UPLOAD_SEG_SHORT,
            Direction::Response,
            SdoRepr::UploadSegmentResponse {
                toggle: true,
                last: true,
                data: b"hello",
            },
        );
        round_trip(
            &UPLOAD_SEG_LONG,
            Direction::Response,
            SdoRepr::UploadSegmentResponse {
                toggle: false,
                last: false,
                data: &[9, 8, 7, 6, 5, 4, 3, 2, 1],
            },
        );
    }

    #[test]
    fn abort_both_directions() {
        let abort = SdoRepr::Abort {
            index: 0x6000,
            sub_index: 1,
            code: SdoAbortCode::ObjectDoesNotExist,
        };
        round_trip(&ABORT, Direction::Request, abort);
        assert_eq!(parse(&ABORT, Direction::Response), Ok(abort));
        assert_eq!(abort.coe_service(), CoeService::SdoRequest);
        // An unknown code survives.
        let bytes = [0x80, 0x00, 0x20, 0x00, 0x78, 0x56, 0x34, 0x12];
        round_trip(
            &bytes,
            Direction::Request,
            SdoRepr::Abort {
                index: 0x2000,
                sub_index: 0,
                code: SdoAbortCode::Unknown(0x1234_5678),
            },
        );
    }

    #[test]
    fn same_specifier_other_direction() {
        // 0x60: upload segment request (client) or initiate download response (server).
        assert_eq!(
            parse(&DOWNLOAD_RESPONSE, Direction::Request),
            Ok(SdoRepr::UploadSegmentRequest { toggle: false })
        );
        // 0x20 with size bits clear: a download segment response from the server, but an
        // initiate download without size and not expedited from the client.
        assert_eq!(
            parse(&DOWNLOAD_SEG_RESPONSE0, Direction::Response),
            Ok(SdoRepr::DownloadSegmentResponse { toggle: false })
        );
        assert_eq!(
            parse(&DOWNLOAD_SEG_RESPONSE0, Direction::Request),
            Err(Error::Malformed)
        );
        // 0x00: download segment (client) / upload segment (server).
        assert!(matches!(
            parse(&DOWNLOAD_SEG_FULL, Direction::Response),
            Ok(SdoRepr::UploadSegmentResponse { .. })
        ));
        // 0x40: initiate upload both ways, but a response must carry data bits.
        assert_eq!(
            parse(&UPLOAD_REQUEST, Direction::Response),
            Err(Error::Malformed)
        );
        assert_eq!(
            SdoRepr::DownloadSegmentResponse { toggle: true }.coe_service(),
            CoeService::SdoResponse
        );
        assert_eq!(
            Direction::from_service(CoeService::SdoRequest),
            Some(Direction::Request)
        );
        assert_eq!(
            Direction::from_service(CoeService::SdoResponse),
            Some(Direction::Response)
        );
        assert_eq!(Direction::from_service(CoeService::Emergency), None);
    }

    #[test]
    fn truncated() {
        for n in 0..HEADER_LEN {
            assert_eq!(
                Sdo::new_checked(&UPLOAD_REQUEST[..n]),
                Err(Error::Truncated)
            );
            assert_eq!(
                parse(&UPLOAD_REQUEST[..n], Direction::Request),
                Err(Error::Truncated)
            );
            assert_eq!(
                parse(&DOWNLOAD_SEG_FULL[..n], Direction::Request),
                Err(Error::Truncated)
            );
        }
        // Unchecked views read zeros instead of panicking.
        let p = Sdo::new_unchecked(&UPLOAD_REQUEST[..2]);
        assert_eq!(p.sub_index(), 0);
        assert_eq!(p.index(), 0);
        assert_eq!(p.normal_data(), &[] as &[u8]);
    }

    #[test]
    fn malformed() {
        let cases: [([u8; 8], Direction); 10] = [
            // Block transfer specifiers 5, 6 (and 7) are not part of CoE.
            ([0xA0, 0, 0x10, 0, 0, 0, 0, 0], Direction::Request),
            ([0xC0, 0, 0x10, 0, 0, 0, 0, 0], Direction::Request),
            ([0xE0, 0, 0x10, 0, 0, 0, 0, 0], Direction::Response),
            // Normal download without size indicated.
            ([0x20, 0, 0x10, 0, 0, 0, 0, 0], Direction::Request),
            // n set while size is not indicated (expedited) and for a normal transfer.
            ([0x26, 0, 0x10, 0, 0, 0, 0, 0], Direction::Request),
            ([0x25, 0, 0x10, 0, 4, 0, 0, 0], Direction::Request),
            // Reserved bits in an upload request / upload segment request.
            ([0x41, 0x18, 0x10, 1, 0, 0, 0, 0], Direction::Request),
            ([0x62, 0, 0, 0, 0, 0, 0, 0], Direction::Request),
            // Reserved bits in a download response / download segment response.
            ([0x61, 0, 0x16, 1, 0, 0, 0, 0], Direction::Response),
            ([0x28, 0, 0, 0, 0, 0, 0, 0], Direction::Response),
        ];
        for (bytes, direction) in cases {
            assert_eq!(
                parse(&bytes, direction),
                Err(Error::Malformed),
                "{bytes:02x?}"
            );
        }
        // Padding count in a segment longer than the minimum.
        let long = [0x03u8, 1, 2, 3, 4, 5, 6, 7, 8];
        assert_eq!(parse(&long, Direction::Request), Err(Error::Malformed));
    }

    #[test]
    fn emit_errors() {
        let bad = SdoRepr::InitiateDownloadRequest {
            index: 0x2000,
            sub_index: 0,
            complete_access: false,
            data: InitData::Expedited {
                size: Some(5),
                data: [0; 4],
            },
        };
        let mut bytes = [0xa5u8; 16];
        assert_eq!(
            bad.emit(&mut Sdo::new_unchecked(&mut bytes[..])),
            Err(Error::Malformed)
        );
        let zero = SdoRepr::InitiateUploadResponse {
            index: 0x2000,
            sub_index: 0,
            complete_access: false,
            data: InitData::Expedited {
                size: Some(0),
                data: [0; 4],
            },
        };
        assert_eq!(
            zero.emit(&mut Sdo::new_unchecked(&mut bytes[..])),
            Err(Error::Malformed)
        );
        assert_eq!(bytes, [0xa5u8; 16]);

        let normal = SdoRepr::InitiateDownloadRequest {
            index: 0x1008,
            sub_index: 0,
            complete_access: false,
            data: InitData::Normal {
                complete_size: 6,
                data: b"ABCDEF",
            },
        };
        let mut short = [0xa5u8; 13];
        assert_eq!(
            normal.emit(&mut Sdo::new_unchecked(&mut short[..])),
            Err(Error::Truncated)
        );
        assert_eq!(short, [0xa5u8; 13]);
        let seg = SdoRepr::UploadSegmentResponse {
            toggle: false,
            last: true,
            data: b"x",
        };
        let mut short = [0xa5u8; 7];
        assert_eq!(
            seg.emit(&mut Sdo::new_unchecked(&mut short[..])),
            Err(Error::Truncated)
        );
    }

    #[test]
    fn expedited_constructor_limits() {
        assert_eq!(InitData::expedited(&[]), None);
        assert_eq!(InitData::expedited(&[1, 2, 3, 4, 5]), None);
        assert_eq!(
            InitData::expedited(&[7]),
            Some(InitData::Expedited {
                size: Some(1),
                data: [7, 0, 0, 0]
            })
        );
    }
}
