//! Mailbox header and mailbox error reply (ETG.1000.4 5.6: mailbox header, mailbox error
//! reply and its error codes; ESC datasheet section I, 8 "SyncManager, mailbox").
//!
//! ```text
//!  byte 0..2  length   u16  bytes after the header
//!  byte 2..4  address  u16  station address of the originator (0 from the master)
//!  byte 4     channel [5:0] | priority [7:6]
//!  byte 5     type [3:0] | counter [6:4] | reserved b7
//!  byte 6..   payload (length bytes; the SyncManager buffer may be longer, rest is padding)
//! ```
//!
//! A mailbox error reply is a mailbox frame of type 0 (ERR) with length 4: u16 service type
//! 0x0001 and a u16 detail ([`MailboxErrorCode`]).

use super::{get_u16, get_u8, need, set_u16, set_u8, tail, tail_mut, Error, Result};

mod field {
    use core::ops::Range;

    pub const LENGTH: Range<usize> = 0..2;
    pub const ADDRESS: Range<usize> = 2..4;
    pub const CHANNEL_PRIORITY: usize = 4;
    pub const TYPE_COUNTER: usize = 5;
    pub const PAYLOAD: usize = 6;

    pub const ERR_SERVICE: Range<usize> = 0..2;
    pub const ERR_DETAIL: Range<usize> = 2..4;
}

/// Length of the mailbox header.
pub const HEADER_LEN: usize = field::PAYLOAD;

/// The service type word of a mailbox error reply.
pub const ERROR_SERVICE_TYPE: u16 = 0x0001;

/// Length of the payload of a mailbox error reply.
pub const ERROR_REPLY_LEN: usize = 4;

/// The mailbox counter that follows `counter`: 1..7, 7 wrapping to 1 (0 means "not used", and
/// is followed by 1), ETG.1000.4 5.6.
pub const fn next_counter(counter: u8) -> u8 {
    match counter {
        1..=6 => counter + 1,
        _ => 1,
    }
}

crate::open_enum! {
    /// Mailbox type (header byte 5 bits 3:0), ETG.1000.4 5.6.
    pub enum MailboxType(u8) {
        /// Mailbox error reply (ERR).
        Error = 0,
        /// ADS over EtherCAT.
        Aoe = 1,
        /// Ethernet over EtherCAT.
        Eoe = 2,
        /// CANopen over EtherCAT.
        Coe = 3,
        /// File access over EtherCAT.
        Foe = 4,
        /// Servo profile over EtherCAT.
        Soe = 5,
        /// Vendor specific.
        Voe = 15,
    }
}

crate::open_enum! {
    /// Detail of a mailbox error reply, ETG.1000.4 5.6.
    pub enum MailboxErrorCode(u16) {
        /// Syntax of the 6-byte mailbox header is wrong.
        Syntax = 0x0001,
        /// The mailbox protocol is not supported.
        UnsupportedProtocol = 0x0002,
        /// The channel field is invalid.
        InvalidChannel = 0x0003,
        /// The service in the mailbox protocol is not supported.
        ServiceNotSupported = 0x0004,
        /// The mailbox protocol header is invalid (excluding the mailbox header).
        InvalidHeader = 0x0005,
        /// The length of the received mailbox data is too short.
        SizeTooShort = 0x0006,
        /// The mailbox protocol cannot be processed: no more memory.
        NoMoreMemory = 0x0007,
        /// The length of the data is inconsistent.
        InvalidSize = 0x0008,
    }
}

/// A read/write view of a mailbox frame (header + payload).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mailbox<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Mailbox<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> Mailbox<T> {
        Mailbox { buffer }
    }

    /// Wraps a buffer and checks it with [`check_len`](Self::check_len).
    pub fn new_checked(buffer: T) -> Result<Mailbox<T>> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        Ok(packet)
    }

    /// `Err(Truncated)` if the buffer is shorter than the header, or than the header plus the
    /// length field (a mailbox error reply "InvalidSize" in the slave). The buffer may be
    /// longer (a SyncManager buffer is padded).
    pub fn check_len(&self) -> Result<()> {
        let len = self.buffer.as_ref().len();
        need(len, HEADER_LEN)?;
        need(len, HEADER_LEN + usize::from(self.length()))
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Length field: the number of bytes after the header.
    pub fn length(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::LENGTH)
    }

    /// Station address of the originator.
    pub fn address(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::ADDRESS)
    }

    /// Channel (byte 4 bits 5:0; 0 for CoE).
    pub fn channel(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::CHANNEL_PRIORITY) & 0x3F
    }

    /// Priority (byte 4 bits 7:6).
    pub fn priority(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::CHANNEL_PRIORITY) >> 6
    }

    /// Mailbox type (byte 5 bits 3:0).
    pub fn mailbox_type(&self) -> MailboxType {
        MailboxType::from(get_u8(self.buffer.as_ref(), field::TYPE_COUNTER) & 0x0F)
    }

    /// Counter (byte 5 bits 6:4): 1..7, 0 = not used.
    pub fn counter(&self) -> u8 {
        (get_u8(self.buffer.as_ref(), field::TYPE_COUNTER) >> 4) & 0x07
    }

    /// Reserved bit (byte 5 bit 7).
    pub fn reserved(&self) -> bool {
        get_u8(self.buffer.as_ref(), field::TYPE_COUNTER) & 0x80 != 0
    }

    /// Header plus payload length: the bytes of the frame proper.
    pub fn frame_len(&self) -> usize {
        HEADER_LEN + usize::from(self.length())
    }
}

impl<'a, T: AsRef<[u8]> + ?Sized> Mailbox<&'a T> {
    /// The payload: exactly `length` bytes after the header (clipped to the buffer on an
    /// unchecked view).
    pub fn payload(&self) -> &'a [u8] {
        let data = tail(self.buffer.as_ref(), HEADER_LEN);
        data.get(..usize::from(self.length())).unwrap_or(data)
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Mailbox<T> {
    /// Sets the length field.
    pub fn set_length(&mut self, value: u16) {
        set_u16(self.buffer.as_mut(), field::LENGTH, value)
    }

    /// Sets the address field.
    pub fn set_address(&mut self, value: u16) {
        set_u16(self.buffer.as_mut(), field::ADDRESS, value)
    }

    /// Sets the channel (6 bits; higher bits are dropped).
    pub fn set_channel(&mut self, value: u8) {
        let data = self.buffer.as_mut();
        let b = get_u8(data, field::CHANNEL_PRIORITY);
        set_u8(data, field::CHANNEL_PRIORITY, (b & 0xC0) | (value & 0x3F));
    }

    /// Sets the priority (2 bits; higher bits are dropped).
    pub fn set_priority(&mut self, value: u8) {
        let data = self.buffer.as_mut();
        let b = get_u8(data, field::CHANNEL_PRIORITY);
        set_u8(data, field::CHANNEL_PRIORITY, (b & 0x3F) | (value << 6));
    }

    /// Sets the mailbox type (4 bits; higher bits are dropped).
    pub fn set_mailbox_type(&mut self, value: MailboxType) {
        let data = self.buffer.as_mut();
        let b = get_u8(data, field::TYPE_COUNTER);
        set_u8(
            data,
            field::TYPE_COUNTER,
            (b & 0xF0) | (u8::from(value) & 0x0F),
        );
    }

    /// Sets the counter (3 bits; higher bits are dropped).
    pub fn set_counter(&mut self, value: u8) {
        let data = self.buffer.as_mut();
        let b = get_u8(data, field::TYPE_COUNTER);
        set_u8(
            data,
            field::TYPE_COUNTER,
            (b & 0x8F) | ((value & 0x07) << 4),
        );
    }

    /// Sets the reserved bit.
    pub fn set_reserved(&mut self, value: bool) {
        let data = self.buffer.as_mut();
        let b = get_u8(data, field::TYPE_COUNTER);
        set_u8(
            data,
            field::TYPE_COUNTER,
            (b & 0x7F) | if value { 0x80 } else { 0 },
        );
    }

    /// The payload, `length` bytes after the header (clipped to the buffer).
    pub fn payload_mut(&mut self) -> &mut [u8] {
        let length = usize::from(self.length());
        let data = tail_mut(self.buffer.as_mut(), HEADER_LEN);
        let n = length.min(data.len());
        data.get_mut(..n).unwrap_or_default()
    }
}

/// The mailbox header as values; the payload stays in the buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MailboxRepr {
    /// Station address (0 from the master; the slave answers with 0 or its own address).
    pub address: u16,
    /// Channel, 0..=63.
    pub channel: u8,
    /// Priority, 0..=3.
    pub priority: u8,
    /// Protocol of the payload.
    pub mailbox_type: MailboxType,
    /// Counter 1..=7, 0 = not used.
    pub counter: u8,
    /// Payload length (the header's length field).
    pub payload_len: usize,
}

impl MailboxRepr {
    /// Parses a mailbox header (checking the length field against the buffer).
    pub fn parse<T: AsRef<[u8]> + ?Sized>(packet: &Mailbox<&T>) -> Result<MailboxRepr> {
        packet.check_len()?;
        Ok(MailboxRepr {
            address: packet.address(),
            channel: packet.channel(),
            priority: packet.priority(),
            mailbox_type: packet.mailbox_type(),
            counter: packet.counter(),
            payload_len: usize::from(packet.length()),
        })
    }

    /// Header plus payload.
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN + self.payload_len
    }

    /// Writes the header (the caller writes the payload into
    /// [`payload_mut`](Mailbox::payload_mut)). `Err(Malformed)` for a field out of its range,
    /// `Err(Truncated)` if the buffer is shorter than [`buffer_len`](Self::buffer_len).
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut Mailbox<T>) -> Result<()> {
        let length = u16::try_from(self.payload_len).map_err(|_| Error::Malformed)?;
        let type_raw = u8::from(self.mailbox_type);
        if self.channel > 0x3F || self.priority > 3 || type_raw > 0x0F || self.counter > 7 {
            return Err(Error::Malformed);
        }
        need(packet.buffer.as_ref().len(), self.buffer_len())?;
        packet.set_length(length);
        packet.set_address(self.address);
        packet.set_channel(self.channel);
        packet.set_priority(self.priority);
        packet.set_mailbox_type(self.mailbox_type);
        packet.set_counter(self.counter);
        packet.set_reserved(false);
        Ok(())
    }
}

/// A read/write view of the payload of a mailbox error reply (4 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MailboxErrorReply<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> MailboxErrorReply<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> MailboxErrorReply<T> {
        MailboxErrorReply { buffer }
    }

    /// Wraps a buffer and checks it with [`check_len`](Self::check_len).
    pub fn new_checked(buffer: T) -> Result<MailboxErrorReply<T>> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        Ok(packet)
    }

    /// `Err(Truncated)` if the buffer is shorter than 4 bytes.
    pub fn check_len(&self) -> Result<()> {
        need(self.buffer.as_ref().len(), ERROR_REPLY_LEN)
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Service type word (0x0001).
    pub fn service_type(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::ERR_SERVICE)
    }

    /// Error detail.
    pub fn detail(&self) -> MailboxErrorCode {
        MailboxErrorCode::from(get_u16(self.buffer.as_ref(), field::ERR_DETAIL))
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> MailboxErrorReply<T> {
    /// Sets the service type word.
    pub fn set_service_type(&mut self, value: u16) {
        set_u16(self.buffer.as_mut(), field::ERR_SERVICE, value)
    }

    /// Sets the error detail.
    pub fn set_detail(&mut self, value: MailboxErrorCode) {
        set_u16(self.buffer.as_mut(), field::ERR_DETAIL, value.into())
    }
}

/// A mailbox error reply as a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MailboxErrorReplyRepr {
    /// Error detail.
    pub code: MailboxErrorCode,
}

impl MailboxErrorReplyRepr {
    /// Parses the payload of a type-0 mailbox frame; `Err(Malformed)` if the service type is
    /// not 0x0001.
    pub fn parse<T: AsRef<[u8]> + ?Sized>(
        packet: &MailboxErrorReply<&T>,
    ) -> Result<MailboxErrorReplyRepr> {
        packet.check_len()?;
        if packet.service_type() != ERROR_SERVICE_TYPE {
            return Err(Error::Malformed);
        }
        Ok(MailboxErrorReplyRepr {
            code: packet.detail(),
        })
    }

    /// Always 4.
    pub const fn buffer_len(&self) -> usize {
        ERROR_REPLY_LEN
    }

    /// Writes the payload.
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(
        &self,
        packet: &mut MailboxErrorReply<T>,
    ) -> Result<()> {
        need(packet.buffer.as_ref().len(), ERROR_REPLY_LEN)?;
        packet.set_service_type(ERROR_SERVICE_TYPE);
        packet.set_detail(self.code);
        Ok(())
    }

    /// Writes a whole mailbox error frame (header of type 0 with length 4, then the payload)
    /// into `buffer` and returns its length (10).
    pub fn emit_frame(&self, buffer: &mut [u8], address: u16, counter: u8) -> Result<usize> {
        let header = MailboxRepr {
            address,
            channel: 0,
            priority: 0,
            mailbox_type: MailboxType::Error,
            counter,
            payload_len: ERROR_REPLY_LEN,
        };
        let mut frame = Mailbox::new_unchecked(&mut *buffer);
        header.emit(&mut frame)?;
        self.emit(&mut MailboxErrorReply::new_unchecked(frame.payload_mut()))?;
        Ok(header.buffer_len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An SDO upload request 0x1018:01 as a master sends it: length 10, address 0, channel 0,
    /// priority 0, type CoE (3), counter 2, then the CoE/SDO bytes; padded to 16 bytes as in
    /// a SyncManager buffer.
    static FRAME_BYTES: [u8; 16] = [
        0x0A, 0x00, 0x00, 0x00, 0x00, 0x23, // mailbox header
        0x00, 0x20, 0x40, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00, // CoE + SDO
    ];

    static PAYLOAD_BYTES: [u8; 10] = [0x00, 0x20, 0x40, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00];

    /// Header with every field set: length 2, address 0x1234, channel 5, priority 3,
    /// type VoE (15), counter 7.
    static FULL_HEADER: [u8; 8] = [0x02, 0x00, 0x34, 0x12, 0xC5, 0x7F, 0xAB, 0xCD];

    /// Mailbox error reply "unsupported protocol" with counter 1.
    static ERROR_FRAME: [u8; 10] = [0x04, 0x00, 0x00, 0x00, 0x00, 0x10, 0x01, 0x00, 0x02, 0x00];

    fn repr() -> MailboxRepr {
        MailboxRepr {
            address: 0,
            channel: 0,
            priority: 0,
            mailbox_type: MailboxType::Coe,
            counter: 2,
            payload_len: 10,
        }
    }

    #[test]
    fn deconstruct() {
        let packet = Mailbox::new_checked(&FRAME_BYTES[..]).unwrap();
        assert_eq!(packet.length(), 10);
        assert_eq!(packet.address(), 0);
        assert_eq!(packet.channel(), 0);
        assert_eq!(packet.priority(), 0);
        assert_eq!(packet.mailbox_type(), MailboxType::Coe);
        assert_eq!(packet.counter(), 2);
        assert!(!packet.reserved());
        assert_eq!(packet.frame_len(), 16);
        assert_eq!(packet.payload(), &PAYLOAD_BYTES[..]);
    }

    #[test]
    fn deconstruct_every_field() {
        let packet = Mailbox::new_checked(&FULL_HEADER[..]).unwrap();
        assert_eq!(packet.length(), 2);
        assert_eq!(packet.address(), 0x1234);
        assert_eq!(packet.channel(), 5);
        assert_eq!(packet.priority(), 3);
        assert_eq!(packet.mailbox_type(), MailboxType::Voe);
        assert_eq!(packet.counter(), 7);
        assert_eq!(packet.payload(), &[0xAB, 0xCD]);
    }

    #[test]
    fn construct() {
        let mut bytes = [0xa5u8; 16];
        let mut packet = Mailbox::new_unchecked(&mut bytes[..]);
        packet.set_length(10);
        packet.set_address(0);
        packet.set_channel(0);
        packet.set_priority(0);
        packet.set_mailbox_type(MailboxType::Coe);
        packet.set_counter(2);
        packet.set_reserved(false);
        packet.payload_mut().copy_from_slice(&PAYLOAD_BYTES);
        assert_eq!(bytes, FRAME_BYTES);
    }

    #[test]
    fn parse() {
        let packet = Mailbox::new_unchecked(&FRAME_BYTES[..]);
        assert_eq!(MailboxRepr::parse(&packet), Ok(repr()));
    }

    #[test]
    fn emit() {
        let mut bytes = [0xa5u8; 16];
        let mut packet = Mailbox::new_unchecked(&mut bytes[..]);
        repr().emit(&mut packet).unwrap();
        packet.payload_mut().copy_from_slice(&PAYLOAD_BYTES);
        assert_eq!(bytes, FRAME_BYTES);
        assert_eq!(repr().buffer_len(), 16);
    }

    #[test]
    fn emit_every_field() {
        let mut bytes = [0xa5u8; 8];
        let r = MailboxRepr {
            address: 0x1234,
            channel: 5,
            priority: 3,
            mailbox_type: MailboxType::Voe,
            counter: 7,
            payload_len: 2,
        };
        let mut packet = Mailbox::new_unchecked(&mut bytes[..]);
        r.emit(&mut packet).unwrap();
        packet.payload_mut().copy_from_slice(&[0xAB, 0xCD]);
        assert_eq!(bytes, FULL_HEADER);
        assert_eq!(
            MailboxRepr::parse(&Mailbox::new_unchecked(&FULL_HEADER[..])),
            Ok(r)
        );
    }

    #[test]
    fn emit_out_of_range_fields() {
        let mut bytes = [0u8; 64];
        for bad in [
            MailboxRepr {
                channel: 64,
                ..repr()
            },
            MailboxRepr {
                priority: 4,
                ..repr()
            },
            MailboxRepr {
                counter: 8,
                ..repr()
            },
            MailboxRepr {
                mailbox_type: MailboxType::Unknown(16),
                ..repr()
            },
            MailboxRepr {
                payload_len: 0x1_0000,
                ..repr()
            },
        ] {
            assert_eq!(
                bad.emit(&mut Mailbox::new_unchecked(&mut bytes[..])),
                Err(Error::Malformed)
            );
        }
    }

    #[test]
    fn emit_short_buffer() {
        let mut bytes = [0xa5u8; 15];
        assert_eq!(
            repr().emit(&mut Mailbox::new_unchecked(&mut bytes[..])),
            Err(Error::Truncated)
        );
        assert_eq!(bytes, [0xa5u8; 15]);
    }

    #[test]
    fn truncated_header() {
        for n in 0..HEADER_LEN {
            assert_eq!(
                Mailbox::new_checked(&FRAME_BYTES[..n]),
                Err(Error::Truncated)
            );
        }
    }

    #[test]
    fn impossible_length() {
        // Length 10 but only 9 payload bytes: "InvalidSize" in the slave.
        assert_eq!(
            Mailbox::new_checked(&FRAME_BYTES[..15]),
            Err(Error::Truncated)
        );
        assert_eq!(
            MailboxRepr::parse(&Mailbox::new_unchecked(&FRAME_BYTES[..15])),
            Err(Error::Truncated)
        );
        // The unchecked view clips instead of panicking.
        assert_eq!(
            Mailbox::new_unchecked(&FRAME_BYTES[..15]).payload(),
            &PAYLOAD_BYTES[..9]
        );
        assert_eq!(
            Mailbox::new_unchecked(&FRAME_BYTES[..3]).payload(),
            &[] as &[u8]
        );
        assert_eq!(Mailbox::new_unchecked(&FRAME_BYTES[..3]).counter(), 0);
        // Length 0xFFFF in a 128-byte buffer.
        let mut big = [0u8; 128];
        big[0] = 0xFF;
        big[1] = 0xFF;
        assert_eq!(Mailbox::new_checked(&big[..]), Err(Error::Truncated));
    }

    #[test]
    fn unknown_type_survives() {
        let bytes = [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C];
        let r = MailboxRepr::parse(&Mailbox::new_unchecked(&bytes[..])).unwrap();
        assert_eq!(r.mailbox_type, MailboxType::Unknown(12));
        let mut out = [0xa5u8; 6];
        r.emit(&mut Mailbox::new_unchecked(&mut out[..])).unwrap();
        assert_eq!(out, bytes);
    }

    #[test]
    fn mailbox_type_codes() {
        let table: [(u8, MailboxType); 7] = [
            (0, MailboxType::Error),
            (1, MailboxType::Aoe),
            (2, MailboxType::Eoe),
            (3, MailboxType::Coe),
            (4, MailboxType::Foe),
            (5, MailboxType::Soe),
            (15, MailboxType::Voe),
        ];
        for (raw, ty) in table {
            assert_eq!(MailboxType::from(raw), ty);
            assert_eq!(u8::from(ty), raw);
        }
    }

    #[test]
    fn counter_sequence() {
        assert_eq!(next_counter(0), 1);
        let mut c = 1;
        let mut seen = [0u8; 8];
        for s in seen.iter_mut() {
            *s = c;
            c = next_counter(c);
        }
        assert_eq!(seen, [1, 2, 3, 4, 5, 6, 7, 1]);
        assert_eq!(next_counter(8), 1);
        assert_eq!(next_counter(0xFF), 1);
    }

    #[test]
    fn error_reply_deconstruct() {
        let frame = Mailbox::new_checked(&ERROR_FRAME[..]).unwrap();
        assert_eq!(frame.mailbox_type(), MailboxType::Error);
        assert_eq!(frame.counter(), 1);
        let reply = MailboxErrorReply::new_checked(frame.payload()).unwrap();
        assert_eq!(reply.service_type(), 0x0001);
        assert_eq!(reply.detail(), MailboxErrorCode::UnsupportedProtocol);
    }

    #[test]
    fn error_reply_construct() {
        let mut bytes = [0xa5u8; 4];
        let mut reply = MailboxErrorReply::new_unchecked(&mut bytes[..]);
        reply.set_service_type(1);
        reply.set_detail(MailboxErrorCode::UnsupportedProtocol);
        assert_eq!(bytes, ERROR_FRAME[6..]);
    }

    #[test]
    fn error_reply_parse_emit() {
        let r = MailboxErrorReplyRepr::parse(&MailboxErrorReply::new_unchecked(&ERROR_FRAME[6..]));
        assert_eq!(
            r,
            Ok(MailboxErrorReplyRepr {
                code: MailboxErrorCode::UnsupportedProtocol
            })
        );
        let mut bytes = [0xa5u8; 12];
        let n = MailboxErrorReplyRepr {
            code: MailboxErrorCode::UnsupportedProtocol,
        }
        .emit_frame(&mut bytes, 0, 1)
        .unwrap();
        assert_eq!(n, 10);
        assert_eq!(bytes[..10], ERROR_FRAME);
        assert_eq!(bytes[10..], [0xa5, 0xa5]);
    }

    #[test]
    fn error_reply_bad_service_and_length() {
        let bytes = [0x02, 0x00, 0x02, 0x00];
        assert_eq!(
            MailboxErrorReplyRepr::parse(&MailboxErrorReply::new_unchecked(&bytes[..])),
            Err(Error::Malformed)
        );
        assert_eq!(
            MailboxErrorReply::new_checked(&bytes[..3]),
            Err(Error::Truncated)
        );
        let mut short = [0u8; 9];
        assert_eq!(
            MailboxErrorReplyRepr {
                code: MailboxErrorCode::Syntax
            }
            .emit_frame(&mut short, 0, 1),
            Err(Error::Truncated)
        );
    }

    #[test]
    fn error_codes() {
        let table: [(u16, MailboxErrorCode); 8] = [
            (1, MailboxErrorCode::Syntax),
            (2, MailboxErrorCode::UnsupportedProtocol),
            (3, MailboxErrorCode::InvalidChannel),
            (4, MailboxErrorCode::ServiceNotSupported),
            (5, MailboxErrorCode::InvalidHeader),
            (6, MailboxErrorCode::SizeTooShort),
            (7, MailboxErrorCode::NoMoreMemory),
            (8, MailboxErrorCode::InvalidSize),
        ];
        for (raw, code) in table {
            assert_eq!(MailboxErrorCode::from(raw), code);
            assert_eq!(u16::from(code), raw);
        }
        assert_eq!(MailboxErrorCode::from(9), MailboxErrorCode::Unknown(9));
    }
}
