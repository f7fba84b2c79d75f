//! FoE, file access over EtherCAT (ETG.1000.6 5.8 "FoE"; the payload of a mailbox frame of
//! type 4).
//!
//! ```text
//!  byte 0      op code u8 (1 RRQ, 2 WRQ, 3 DATA, 4 ACK, 5 ERR, 6 BUSY)
//!  byte 1      reserved u8 (0)
//!  byte 2..6   RRQ/WRQ: password u32 | DATA/ACK: packet number u32 | ERR: error code u32 |
//!              BUSY: done u16, entire u16
//!  byte 6..    RRQ/WRQ: file name | DATA: file data | ERR: error text | BUSY: busy text
//!              (the rest of the mailbox length; no terminating NUL)
//! ```
//!
//! A file travels in DATA packets numbered from 1, each acknowledged with its number (a write
//! request is acknowledged with 0). Every packet but the last carries as many bytes as the
//! mailbox allows (its size minus the mailbox and FoE headers); a shorter one (possibly empty)
//! ends the file. BUSY asks the sender to send its last packet again later.

use super::{get_u16, get_u32, get_u8, need, set_bytes, set_u16, set_u32, set_u8, tail};
use super::{Error, Result};

mod field {
    use core::ops::Range;

    pub const OP_CODE: usize = 0;
    pub const RESERVED: usize = 1;
    /// Password, packet number or error code.
    pub const WORD: Range<usize> = 2..6;
    pub const BUSY_DONE: Range<usize> = 2..4;
    pub const BUSY_ENTIRE: Range<usize> = 4..6;
    pub const PAYLOAD: usize = 6;
}

/// Length of the FoE header (op code, reserved byte, the 32-bit word).
pub const HEADER_LEN: usize = field::PAYLOAD;

/// Mailbox frame bytes around the data of a DATA packet: the mailbox header and the FoE
/// header. A packet that fills the mailbox carries `mailbox size - DATA_OVERHEAD` bytes.
pub const DATA_OVERHEAD: usize = super::mailbox::HEADER_LEN + HEADER_LEN;

crate::open_enum! {
    /// FoE op code (byte 0), ETG.1000.6 5.8.
    pub enum FoeOpCode(u8) {
        /// Read request: file name and password.
        ReadRequest = 1,
        /// Write request: file name and password.
        WriteRequest = 2,
        /// Data packet: packet number and file data.
        Data = 3,
        /// Acknowledge of a write request (0) or of a data packet (its number).
        Ack = 4,
        /// Error: error code and text; ends the transfer.
        Error = 5,
        /// Busy: progress (done of entire) and text; the sender repeats its last packet.
        Busy = 6,
    }
}

crate::open_enum! {
    /// FoE error codes (ETG.1000.6 5.8, FoE error codes; 0x800C..0x8011 as the ETG slave
    /// stack code defines them for firmware downloads).
    pub enum FoeErrorCode(u32) {
        /// Not defined / unspecified.
        NotDefined = 0x8000,
        /// File not found.
        NotFound = 0x8001,
        /// Access denied.
        AccessDenied = 0x8002,
        /// Disk full (the file is larger than the room for it).
        DiskFull = 0x8003,
        /// Illegal operation (a packet that does not fit the transfer's state).
        Illegal = 0x8004,
        /// Packet number wrong.
        PacketNumberWrong = 0x8005,
        /// The file already exists.
        AlreadyExists = 0x8006,
        /// No such user.
        NoUser = 0x8007,
        /// Allowed in the BOOTSTRAP state only.
        BootstrapOnly = 0x8008,
        /// Not allowed in the BOOTSTRAP state.
        NotBootstrap = 0x8009,
        /// No access rights (wrong password).
        NoRights = 0x800A,
        /// Program error.
        ProgramError = 0x800B,
        /// The checksum in the file is wrong.
        InvalidChecksum = 0x800C,
        /// The hardware does not support the firmware in the file.
        InvalidFirmware = 0x800D,
        /// No file to read (identical in meaning to NotFound).
        NoFile = 0x800F,
        /// The file header is missing or wrong.
        NoFileHeader = 0x8010,
        /// The flash cannot be written.
        FlashError = 0x8011,
    }
}

impl FoeErrorCode {
    /// The standard text of the code (sent in the error packet when no better one exists).
    pub const fn text(self) -> &'static str {
        match self {
            Self::NotDefined => "Not defined",
            Self::NotFound => "Not found",
            Self::AccessDenied => "Access denied",
            Self::DiskFull => "Disk full",
            Self::Illegal => "Illegal",
            Self::PacketNumberWrong => "Packet number wrong",
            Self::AlreadyExists => "Already exists",
            Self::NoUser => "No user",
            Self::BootstrapOnly => "Bootstrap only",
            Self::NotBootstrap => "Not Bootstrap",
            Self::NoRights => "No rights",
            Self::ProgramError => "Program error",
            Self::InvalidChecksum => "Invalid checksum",
            Self::InvalidFirmware => "Invalid firmware",
            Self::NoFile => "No file",
            Self::NoFileHeader => "No file header",
            Self::FlashError => "Flash error",
            Self::Unknown(_) => "Unknown error",
        }
    }
}

/// A read/write view of an FoE packet (the mailbox payload of a type-4 frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Foe<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Foe<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> Foe<T> {
        Foe { buffer }
    }

    /// Wraps a buffer and checks it with [`check_len`](Self::check_len).
    pub fn new_checked(buffer: T) -> Result<Foe<T>> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        Ok(packet)
    }

    /// `Err(Truncated)` if the buffer is shorter than the 6-byte header.
    pub fn check_len(&self) -> Result<()> {
        need(self.buffer.as_ref().len(), HEADER_LEN)
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Op code.
    pub fn op_code(&self) -> FoeOpCode {
        FoeOpCode::from(get_u8(self.buffer.as_ref(), field::OP_CODE))
    }

    /// The reserved byte.
    pub fn reserved(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::RESERVED)
    }

    /// Password (RRQ/WRQ), packet number (DATA/ACK) or error code (ERR).
    pub fn word(&self) -> u32 {
        get_u32(self.buffer.as_ref(), field::WORD)
    }

    /// Busy: the part done.
    pub fn busy_done(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::BUSY_DONE)
    }

    /// Busy: the whole.
    pub fn busy_entire(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::BUSY_ENTIRE)
    }
}

impl<'a, T: AsRef<[u8]> + ?Sized> Foe<&'a T> {
    /// File name, file data, error text or busy text: everything after the header.
    pub fn payload(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), HEADER_LEN)
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Foe<T> {
    /// Sets the op code.
    pub fn set_op_code(&mut self, value: FoeOpCode) {
        set_u8(self.buffer.as_mut(), field::OP_CODE, value.into())
    }

    /// Sets the reserved byte.
    pub fn set_reserved(&mut self, value: u8) {
        set_u8(self.buffer.as_mut(), field::RESERVED, value)
    }

    /// Sets the password, packet number or error code.
    pub fn set_word(&mut self, value: u32) {
        set_u32(self.buffer.as_mut(), field::WORD, value)
    }

    /// Sets the busy progress.
    pub fn set_busy(&mut self, done: u16, entire: u16) {
        set_u16(self.buffer.as_mut(), field::BUSY_DONE, done);
        set_u16(self.buffer.as_mut(), field::BUSY_ENTIRE, entire);
    }

    /// Copies `data` after the header, as far as the buffer reaches.
    pub fn set_payload(&mut self, data: &[u8]) {
        set_bytes(self.buffer.as_mut(), HEADER_LEN, data)
    }
}

/// An FoE packet as values; names, data and texts borrow from the buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FoeRepr<'a> {
    /// Read request.
    ReadRequest {
        /// Password (0 if none).
        password: u32,
        /// File name (no NUL).
        file_name: &'a [u8],
    },
    /// Write request.
    WriteRequest {
        /// Password (0 if none).
        password: u32,
        /// File name (no NUL).
        file_name: &'a [u8],
    },
    /// Data packet.
    Data {
        /// Packet number, from 1.
        packet_number: u32,
        /// File data.
        data: &'a [u8],
    },
    /// Acknowledge.
    Ack {
        /// The packet acknowledged (0 for a write request).
        packet_number: u32,
    },
    /// Error.
    Error {
        /// Error code.
        code: FoeErrorCode,
        /// Error text (ASCII, may be empty).
        text: &'a [u8],
    },
    /// Busy.
    Busy {
        /// The part done.
        done: u16,
        /// The whole.
        entire: u16,
        /// Busy text (may be empty).
        text: &'a [u8],
    },
}

impl<'a> FoeRepr<'a> {
    /// An error packet with the code's standard text.
    pub const fn error(code: FoeErrorCode) -> FoeRepr<'static> {
        FoeRepr::Error {
            code,
            text: code.text().as_bytes(),
        }
    }

    /// Parses a packet. `Err(Truncated)` below 6 bytes, `Err(Malformed)` for an unknown op
    /// code. Bytes after the header of an ACK are ignored.
    pub fn parse<T: AsRef<[u8]> + ?Sized>(packet: &Foe<&'a T>) -> Result<FoeRepr<'a>> {
        packet.check_len()?;
        let payload = packet.payload();
        Ok(match packet.op_code() {
            FoeOpCode::ReadRequest => FoeRepr::ReadRequest {
                password: packet.word(),
                file_name: payload,
            },
            FoeOpCode::WriteRequest => FoeRepr::WriteRequest {
                password: packet.word(),
                file_name: payload,
            },
            FoeOpCode::Data => FoeRepr::Data {
                packet_number: packet.word(),
                data: payload,
            },
            FoeOpCode::Ack => FoeRepr::Ack {
                packet_number: packet.word(),
            },
            FoeOpCode::Error => FoeRepr::Error {
                code: FoeErrorCode::from(packet.word()),
                text: payload,
            },
            FoeOpCode::Busy => FoeRepr::Busy {
                done: packet.busy_done(),
                entire: packet.busy_entire(),
                text: payload,
            },
            FoeOpCode::Unknown(_) => return Err(Error::Malformed),
        })
    }

    /// The op code of the packet.
    pub const fn op_code(&self) -> FoeOpCode {
        match self {
            Self::ReadRequest { .. } => FoeOpCode::ReadRequest,
            Self::WriteRequest { .. } => FoeOpCode::WriteRequest,
            Self::Data { .. } => FoeOpCode::Data,
            Self::Ack { .. } => FoeOpCode::Ack,
            Self::Error { .. } => FoeOpCode::Error,
            Self::Busy { .. } => FoeOpCode::Busy,
        }
    }

    /// The bytes after the header.
    const fn payload(&self) -> &'a [u8] {
        match self {
            Self::ReadRequest { file_name, .. } | Self::WriteRequest { file_name, .. } => file_name,
            Self::Data { data, .. } => data,
            Self::Ack { .. } => &[],
            Self::Error { text, .. } | Self::Busy { text, .. } => text,
        }
    }

    /// Header plus name, data or text.
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN + self.payload().len()
    }

    /// Writes the packet; `Err(Truncated)` if the buffer is shorter than
    /// [`buffer_len`](Self::buffer_len) (nothing is written then).
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut Foe<T>) -> Result<()> {
        need(packet.buffer.as_ref().len(), self.buffer_len())?;
        packet.set_op_code(self.op_code());
        packet.set_reserved(0);
        match *self {
            Self::ReadRequest { password, .. } | Self::WriteRequest { password, .. } => {
                packet.set_word(password)
            }
            Self::Data { packet_number, .. } | Self::Ack { packet_number } => {
                packet.set_word(packet_number)
            }
            Self::Error { code, .. } => packet.set_word(code.into()),
            Self::Busy { done, entire, .. } => packet.set_busy(done, entire),
        }
        packet.set_payload(self.payload());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::{Mailbox, MailboxRepr, MailboxType};

    /// A whole write request as SOEM's `ec_FOEwrite` sends it: mailbox length 13, type FoE
    /// (4), counter 1; op code 2, password 0x12345678, file name "app.efw" (no NUL).
    static WRQ_FRAME: [u8; 23] = [
        0x0D, 0x00, 0x00, 0x00, 0x00, 0x14, // mailbox header
        0x02, 0x00, 0x78, 0x56, 0x34, 0x12, // FoE header
        b'a', b'p', b'p', b'.', b'e', b'f', b'w', // file name
        0x00, 0x00, 0x00, 0x00, // padding of the SyncManager buffer
    ];

    /// DATA packet 3 with four bytes.
    static DATA: [u8; 10] = [0x03, 0x00, 0x03, 0x00, 0x00, 0x00, 0xDE, 0xAD, 0xBE, 0xEF];

    /// ACK of packet 0x0102.
    static ACK: [u8; 6] = [0x04, 0x00, 0x02, 0x01, 0x00, 0x00];

    /// ERR 0x8001 "Not found".
    static ERR: [u8; 15] = [
        0x05, 0x00, 0x01, 0x80, 0x00, 0x00, b'N', b'o', b't', b' ', b'f', b'o', b'u', b'n', b'd',
    ];

    /// BUSY 3 of 10 with no text.
    static BUSY: [u8; 6] = [0x06, 0x00, 0x03, 0x00, 0x0A, 0x00];

    #[test]
    fn deconstruct_write_request_in_a_mailbox_frame() {
        let frame = Mailbox::new_checked(&WRQ_FRAME[..]).unwrap();
        assert_eq!(frame.mailbox_type(), MailboxType::Foe);
        assert_eq!(frame.counter(), 1);
        let foe = Foe::new_checked(frame.payload()).unwrap();
        assert_eq!(foe.op_code(), FoeOpCode::WriteRequest);
        assert_eq!(foe.reserved(), 0);
        assert_eq!(foe.word(), 0x1234_5678);
        assert_eq!(foe.payload(), b"app.efw");
    }

    #[test]
    fn construct_write_request_frame() {
        let mut bytes = [0xA5u8; 23];
        let header = MailboxRepr {
            address: 0,
            channel: 0,
            priority: 0,
            mailbox_type: MailboxType::Foe,
            counter: 1,
            payload_len: 13,
        };
        let mut frame = Mailbox::new_unchecked(&mut bytes[..]);
        header.emit(&mut frame).unwrap();
        let mut foe = Foe::new_unchecked(frame.payload_mut());
        foe.set_op_code(FoeOpCode::WriteRequest);
        foe.set_reserved(0);
        foe.set_word(0x1234_5678);
        foe.set_payload(b"app.efw");
        bytes[19..].fill(0);
        assert_eq!(bytes, WRQ_FRAME);
    }

    fn cases() -> [(&'static [u8], FoeRepr<'static>); 5] {
        [
            (
                &WRQ_FRAME[6..19],
                FoeRepr::WriteRequest {
                    password: 0x1234_5678,
                    file_name: b"app.efw",
                },
            ),
            (
                &DATA,
                FoeRepr::Data {
                    packet_number: 3,
                    data: &[0xDE, 0xAD, 0xBE, 0xEF],
                },
            ),
            (
                &ACK,
                FoeRepr::Ack {
                    packet_number: 0x0102,
                },
            ),
            (&ERR, FoeRepr::error(FoeErrorCode::NotFound)),
            (
                &BUSY,
                FoeRepr::Busy {
                    done: 3,
                    entire: 10,
                    text: &[],
                },
            ),
        ]
    }

    #[test]
    fn parse_every_op_code() {
        for (bytes, repr) in cases() {
            assert_eq!(FoeRepr::parse(&Foe::new_unchecked(bytes)), Ok(repr));
        }
        let rrq = [0x01, 0x00, 0, 0, 0, 0, b'x'];
        assert_eq!(
            FoeRepr::parse(&Foe::new_unchecked(&rrq[..])),
            Ok(FoeRepr::ReadRequest {
                password: 0,
                file_name: b"x"
            })
        );
    }

    #[test]
    fn emit_every_op_code() {
        for (bytes, repr) in cases() {
            let mut out = std::vec![0xA5u8; bytes.len() + 3];
            repr.emit(&mut Foe::new_unchecked(&mut out[..])).unwrap();
            assert_eq!(&out[..bytes.len()], bytes, "{repr:?}");
            assert_eq!(&out[bytes.len()..], &[0xA5; 3]);
            assert_eq!(repr.buffer_len(), bytes.len());
        }
    }

    #[test]
    fn short_buffers() {
        for n in 0..HEADER_LEN {
            assert_eq!(Foe::new_checked(&ACK[..n]), Err(Error::Truncated));
            assert_eq!(
                FoeRepr::parse(&Foe::new_unchecked(&ACK[..n])),
                Err(Error::Truncated)
            );
        }
        let mut out = [0xA5u8; 9];
        let data = FoeRepr::Data {
            packet_number: 1,
            data: &[1, 2, 3, 4],
        };
        assert_eq!(
            data.emit(&mut Foe::new_unchecked(&mut out[..])),
            Err(Error::Truncated)
        );
        assert_eq!(out, [0xA5; 9], "nothing written");
        // An unchecked view reads zeros outside the buffer.
        let view = Foe::new_unchecked(&ACK[..3]);
        assert_eq!(view.word(), 0);
        assert_eq!(view.payload(), &[] as &[u8]);
    }

    #[test]
    fn unknown_op_codes_are_malformed_and_survive_the_view() {
        for op in [0u8, 7, 0xFF] {
            let bytes = [op, 0, 1, 0, 0, 0];
            let view = Foe::new_unchecked(&bytes[..]);
            assert_eq!(view.op_code(), FoeOpCode::Unknown(op));
            assert_eq!(FoeRepr::parse(&view), Err(Error::Malformed));
        }
    }

    #[test]
    fn ack_ignores_trailing_bytes() {
        let bytes = [0x04, 0x00, 0x05, 0x00, 0x00, 0x00, 0xEE];
        assert_eq!(
            FoeRepr::parse(&Foe::new_unchecked(&bytes[..])),
            Ok(FoeRepr::Ack { packet_number: 5 })
        );
    }

    #[test]
    fn error_codes_and_texts() {
        let table: [(u32, FoeErrorCode, &str); 17] = [
            (0x8000, FoeErrorCode::NotDefined, "Not defined"),
            (0x8001, FoeErrorCode::NotFound, "Not found"),
            (0x8002, FoeErrorCode::AccessDenied, "Access denied"),
            (0x8003, FoeErrorCode::DiskFull, "Disk full"),
            (0x8004, FoeErrorCode::Illegal, "Illegal"),
            (
                0x8005,
                FoeErrorCode::PacketNumberWrong,
                "Packet number wrong",
            ),
            (0x8006, FoeErrorCode::AlreadyExists, "Already exists"),
            (0x8007, FoeErrorCode::NoUser, "No user"),
            (0x8008, FoeErrorCode::BootstrapOnly, "Bootstrap only"),
            (0x8009, FoeErrorCode::NotBootstrap, "Not Bootstrap"),
            (0x800A, FoeErrorCode::NoRights, "No rights"),
            (0x800B, FoeErrorCode::ProgramError, "Program error"),
            (0x800C, FoeErrorCode::InvalidChecksum, "Invalid checksum"),
            (0x800D, FoeErrorCode::InvalidFirmware, "Invalid firmware"),
            (0x800F, FoeErrorCode::NoFile, "No file"),
            (0x8010, FoeErrorCode::NoFileHeader, "No file header"),
            (0x8011, FoeErrorCode::FlashError, "Flash error"),
        ];
        for (raw, code, text) in table {
            assert_eq!(FoeErrorCode::from(raw), code);
            assert_eq!(u32::from(code), raw);
            assert_eq!(code.text(), text);
        }
        assert_eq!(FoeErrorCode::from(0x800E), FoeErrorCode::Unknown(0x800E));
        assert_eq!(FoeErrorCode::Unknown(1).text(), "Unknown error");
    }

    #[test]
    fn op_codes() {
        for (raw, op) in [
            (1u8, FoeOpCode::ReadRequest),
            (2, FoeOpCode::WriteRequest),
            (3, FoeOpCode::Data),
            (4, FoeOpCode::Ack),
            (5, FoeOpCode::Error),
            (6, FoeOpCode::Busy),
        ] {
            assert_eq!(FoeOpCode::from(raw), op);
            assert_eq!(u8::from(op), raw);
        }
    }
}
