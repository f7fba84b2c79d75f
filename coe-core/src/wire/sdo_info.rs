//! SDO Information service (ETG.1000.6 5.6.3: SDO Information header, Get OD List
//! request/response, Get Object Description request/response, Get Entry Description
//! request/response, SDO Info Error request).
//!
//! The view starts after the CoE header (service 8):
//!
//! ```text
//!  byte 0     opcode [6:0] | incomplete b7 (more fragments follow)
//!  byte 1     reserved
//!  byte 2..4  fragments left u16
//!  byte 4..   service data
//! ```
//!
//! | opcode | service data |
//! |---|---|
//! | 1 OD list request | list type u16 |
//! | 2 OD list response | list type u16, index u16 ... (list type 0: five counts) |
//! | 3 object description request | index u16 |
//! | 4 object description response | index u16, data type u16, max subindex u8, object code u8, name |
//! | 5 entry description request | index u16, subindex u8, value info u8 |
//! | 6 entry description response | index u16, subindex u8, value info u8, data type u16, bit length u16, object access u16, (unit type u16), (default), (minimum), (maximum), name; parenthesised fields only with their value info bit |
//! | 7 SDO Info error | abort code u32 |
//!
//! Names carry no NUL; their length follows from the mailbox length. A long response is
//! split into fragments: every fragment has the header (incomplete set on all but the last,
//! fragments left counting down to 0) followed by the next slice of the service data.
//! [`SdoInfoRepr::write`] streams the service data into a [`ServiceDataSink`] (the SDO
//! server's fragment writer, `crate::sdo_server::info::FragmentWriter`, keeps one
//! fragment's slice of it); [`SdoInfoRepr::parse`] reads a whole (unfragmented or
//! reassembled) message.

use super::{get_u16, get_u32, get_u8, need, set_u16, set_u8, tail, tail_mut, Error, Result};
use crate::abort::SdoAbortCode;
use crate::od::{Access, DataType};

mod field {
    use core::ops::Range;

    pub const OPCODE: usize = 0;
    pub const RESERVED: usize = 1;
    pub const FRAGMENTS_LEFT: Range<usize> = 2..4;
    pub const PAYLOAD: usize = 4;

    // Service data fields, as offsets into the frame.
    pub const LIST_TYPE: Range<usize> = 4..6;
    pub const LIST: usize = 6;
    pub const INDEX: Range<usize> = 4..6;
    pub const OBJ_DATA_TYPE: Range<usize> = 6..8;
    pub const MAX_SUB_INDEX: usize = 8;
    pub const OBJECT_CODE: usize = 9;
    pub const OBJ_NAME: usize = 10;
    pub const SUB_INDEX: usize = 6;
    pub const VALUE_INFO: usize = 7;
    pub const ENTRY_DATA_TYPE: Range<usize> = 8..10;
    pub const BIT_LENGTH: Range<usize> = 10..12;
    pub const OBJECT_ACCESS: Range<usize> = 12..14;
    pub const ENTRY_DATA: usize = 14;
    pub const ABORT_CODE: Range<usize> = 4..8;
}

/// Length of the SDO Information header.
pub const HEADER_LEN: usize = field::PAYLOAD;

crate::open_enum! {
    /// SDO Information opcode (header byte 0 bits 6:0), ETG.1000.6 5.6.3.
    pub enum SdoInfoOpCode(u8) {
        /// Get OD List request.
        GetOdListRequest = 1,
        /// Get OD List response.
        GetOdListResponse = 2,
        /// Get Object Description request.
        GetObjectDescriptionRequest = 3,
        /// Get Object Description response.
        GetObjectDescriptionResponse = 4,
        /// Get Entry Description request.
        GetEntryDescriptionRequest = 5,
        /// Get Entry Description response.
        GetEntryDescriptionResponse = 6,
        /// SDO Info Error request.
        SdoInfoError = 7,
    }
}

crate::open_enum! {
    /// List type of Get OD List, ETG.1000.6 5.6.3.
    pub enum OdListType(u16) {
        /// The number of objects in each of the five lists below.
        NumberOfObjects = 0,
        /// All objects.
        AllObjects = 1,
        /// Objects with an RxPDO-mappable entry.
        RxPdoMappable = 2,
        /// Objects with a TxPDO-mappable entry.
        TxPdoMappable = 3,
        /// Objects stored for a device replacement (backup).
        StoredForReplacement = 4,
        /// Objects used as startup parameters (settings).
        StartupParameters = 5,
    }
}

/// The value info byte of an entry description: which optional fields the request asks
/// for and the response carries (ETG.1000.6 5.6.3, Get Entry Description).
///
/// Bits 0..2 carry no data in the response (SOES names them access rights, object
/// category and PDO mapping); they are kept as they are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ValueInfo(pub u8);

impl ValueInfo {
    /// Unit type included: an UNSIGNED16 ([`UNIT_TYPE_LEN`] bytes).
    pub const UNIT_TYPE: u8 = 0x08;
    /// Default value included.
    pub const DEFAULT: u8 = 0x10;
    /// Minimum value included.
    pub const MINIMUM: u8 = 0x20;
    /// Maximum value included.
    pub const MAXIMUM: u8 = 0x40;

    /// True if all bits of `mask` are set.
    pub const fn contains(self, mask: u8) -> bool {
        self.0 & mask == mask
    }
}

/// Length of the unit type of an entry description response: UNSIGNED16.
///
/// The ETG.1000.6 text itself was not at hand; the size follows the two Beckhoff sources
/// that read or write the field: the SSC `sdoinfoserv.h` (`TSDOINFOENTRYDESC`: "UINT16
/// UnitType; // optional if bit3 of valueInfo", and `SIZEOF_MAXVALUEINFO 26 // 2 Bytes
/// UnitType + (3 * DEFTYPE_REAL64)`) and the Wireshark EtherCAT mailbox dissector
/// (`plugins/ethercat/packet-ecatmb.c`, contributed by Beckhoff: 2 bytes when value info
/// bit 3 is set). SOES and the IgH master never ask for the unit.
pub const UNIT_TYPE_LEN: usize = 2;

/// Which optional value of an entry description a writer is asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EntryValue {
    /// Default value ([`ValueInfo::DEFAULT`]).
    Default,
    /// Minimum value ([`ValueInfo::MINIMUM`]).
    Minimum,
    /// Maximum value ([`ValueInfo::MAXIMUM`]).
    Maximum,
}

impl EntryValue {
    /// The three values in the order they follow each other on the wire.
    pub const ALL: [EntryValue; 3] = [
        EntryValue::Default,
        EntryValue::Minimum,
        EntryValue::Maximum,
    ];

    /// The value info bit that includes this value.
    pub const fn flag(self) -> u8 {
        match self {
            EntryValue::Default => ValueInfo::DEFAULT,
            EntryValue::Minimum => ValueInfo::MINIMUM,
            EntryValue::Maximum => ValueInfo::MAXIMUM,
        }
    }
}

/// The fixed fields of a Get Entry Description response; [`write`](Self::write) streams the
/// whole service data with the optional values supplied by the caller. Both
/// [`SdoInfoRepr::EntryDescriptionResponse`] and a server that encodes the values straight
/// from its object dictionary write through it, so the layout exists once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EntryDescriptionHead {
    /// Index.
    pub index: u16,
    /// Subindex.
    pub sub_index: u8,
    /// Optional fields present.
    pub value_info: ValueInfo,
    /// Data type.
    pub data_type: DataType,
    /// Bit length.
    pub bit_length: u16,
    /// Access rights and mapping flags.
    pub access: Access,
    /// Unit type (written with [`ValueInfo::UNIT_TYPE`]).
    pub unit_type: u16,
}

impl EntryDescriptionHead {
    /// Streams the service data: the fixed fields, the unit type and each value that the
    /// value info selects (`value` writes it and must push exactly
    /// [`value_len`]`(bit_length)` bytes), then the name.
    pub fn write<W: ServiceDataSink + ?Sized>(
        &self,
        w: &mut W,
        mut value: impl FnMut(EntryValue, &mut W),
        name: &[u8],
    ) {
        w.push_u16(self.index);
        w.push(&[self.sub_index, self.value_info.0]);
        w.push_u16(self.data_type.into());
        w.push_u16(self.bit_length);
        w.push_u16(self.access.bits());
        if self.value_info.contains(ValueInfo::UNIT_TYPE) {
            w.push_u16(self.unit_type);
        }
        for which in EntryValue::ALL {
            if self.value_info.contains(which.flag()) {
                value(which, w);
            }
        }
        w.push(name);
    }
}

/// Streams the service data of a Get OD List response: the list type, then one u16 per
/// index (for list type 0 the five counts).
pub fn write_od_list<W: ServiceDataSink + ?Sized>(
    w: &mut W,
    list_type: OdListType,
    indices: impl IntoIterator<Item = u16>,
) {
    w.push_u16(list_type.into());
    for index in indices {
        w.push_u16(index);
    }
}

/// A read/write view of an SDO Information frame (the bytes after the CoE header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SdoInfo<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> SdoInfo<T> {
    /// Wraps a buffer without checking it (for emitting).
    pub const fn new_unchecked(buffer: T) -> SdoInfo<T> {
        SdoInfo { buffer }
    }

    /// Wraps a buffer and checks it with [`check_len`](Self::check_len).
    pub fn new_checked(buffer: T) -> Result<SdoInfo<T>> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        Ok(packet)
    }

    /// `Err(Truncated)` if the buffer is shorter than the 4-byte header. The service data is
    /// checked by [`SdoInfoRepr::parse`]; its field getters read 0 past the end.
    pub fn check_len(&self) -> Result<()> {
        need(self.buffer.as_ref().len(), HEADER_LEN)
    }

    /// Gives the buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Opcode.
    pub fn opcode(&self) -> SdoInfoOpCode {
        SdoInfoOpCode::from(get_u8(self.buffer.as_ref(), field::OPCODE) & 0x7F)
    }

    /// More fragments follow.
    pub fn incomplete(&self) -> bool {
        get_u8(self.buffer.as_ref(), field::OPCODE) & 0x80 != 0
    }

    /// Reserved byte.
    pub fn reserved(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::RESERVED)
    }

    /// Fragments left after this one.
    pub fn fragments_left(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::FRAGMENTS_LEFT)
    }

    /// List type (OD list request and first fragment of the response).
    pub fn list_type(&self) -> OdListType {
        OdListType::from(get_u16(self.buffer.as_ref(), field::LIST_TYPE))
    }

    /// Index (object and entry description).
    pub fn index(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::INDEX)
    }

    /// Data type of an object description response.
    pub fn object_data_type(&self) -> DataType {
        DataType::from(get_u16(self.buffer.as_ref(), field::OBJ_DATA_TYPE))
    }

    /// Maximum subindex of an object description response.
    pub fn max_sub_index(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::MAX_SUB_INDEX)
    }

    /// Object code of an object description response (7 VAR, 8 ARRAY, 9 RECORD).
    pub fn object_code(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::OBJECT_CODE)
    }

    /// Subindex of an entry description.
    pub fn sub_index(&self) -> u8 {
        get_u8(self.buffer.as_ref(), field::SUB_INDEX)
    }

    /// Value info of an entry description.
    pub fn value_info(&self) -> ValueInfo {
        ValueInfo(get_u8(self.buffer.as_ref(), field::VALUE_INFO))
    }

    /// Data type of an entry description response.
    pub fn entry_data_type(&self) -> DataType {
        DataType::from(get_u16(self.buffer.as_ref(), field::ENTRY_DATA_TYPE))
    }

    /// Bit length of an entry description response.
    pub fn bit_length(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::BIT_LENGTH)
    }

    /// Object access word of an entry description response.
    pub fn object_access(&self) -> Access {
        Access(get_u16(self.buffer.as_ref(), field::OBJECT_ACCESS))
    }

    /// Abort code of an SDO Info error.
    pub fn abort_code(&self) -> SdoAbortCode {
        SdoAbortCode::from(get_u32(self.buffer.as_ref(), field::ABORT_CODE))
    }
}

impl<'a, T: AsRef<[u8]> + ?Sized> SdoInfo<&'a T> {
    /// The service data (after the 4-byte header).
    pub fn payload(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), field::PAYLOAD)
    }

    /// The index list of an unfragmented OD list response (after the list type).
    pub fn od_list(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), field::LIST)
    }

    /// The name of an object description response.
    pub fn object_name(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), field::OBJ_NAME)
    }

    /// Everything after the object access word of an entry description response (optional
    /// values, then the name).
    pub fn entry_data(&self) -> &'a [u8] {
        tail(self.buffer.as_ref(), field::ENTRY_DATA)
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> SdoInfo<T> {
    /// Sets the opcode (7 bits; the top bit is dropped).
    pub fn set_opcode(&mut self, value: SdoInfoOpCode) {
        let data = self.buffer.as_mut();
        let b = get_u8(data, field::OPCODE);
        set_u8(data, field::OPCODE, (b & 0x80) | (u8::from(value) & 0x7F));
    }

    /// Sets the incomplete bit.
    pub fn set_incomplete(&mut self, value: bool) {
        let data = self.buffer.as_mut();
        let b = get_u8(data, field::OPCODE);
        set_u8(
            data,
            field::OPCODE,
            (b & 0x7F) | if value { 0x80 } else { 0 },
        );
    }

    /// Sets the reserved byte.
    pub fn set_reserved(&mut self, value: u8) {
        set_u8(self.buffer.as_mut(), field::RESERVED, value)
    }

    /// Sets the fragments-left count.
    pub fn set_fragments_left(&mut self, value: u16) {
        set_u16(self.buffer.as_mut(), field::FRAGMENTS_LEFT, value)
    }

    /// The service data (after the header).
    pub fn payload_mut(&mut self) -> &mut [u8] {
        tail_mut(self.buffer.as_mut(), field::PAYLOAD)
    }
}

/// The SDO Information header as values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SdoInfoHeaderRepr {
    /// Opcode.
    pub opcode: SdoInfoOpCode,
    /// More fragments follow.
    pub incomplete: bool,
    /// Fragments left after this one.
    pub fragments_left: u16,
}

impl SdoInfoHeaderRepr {
    /// Parses the header (the reserved byte is ignored).
    pub fn parse<T: AsRef<[u8]> + ?Sized>(packet: &SdoInfo<&T>) -> Result<SdoInfoHeaderRepr> {
        packet.check_len()?;
        Ok(SdoInfoHeaderRepr {
            opcode: packet.opcode(),
            incomplete: packet.incomplete(),
            fragments_left: packet.fragments_left(),
        })
    }

    /// Always 4.
    pub const fn buffer_len(&self) -> usize {
        HEADER_LEN
    }

    /// Writes the header (reserved byte 0). `Err(Malformed)` for an opcode above 0x7F.
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut SdoInfo<T>) -> Result<()> {
        if u8::from(self.opcode) > 0x7F {
            return Err(Error::Malformed);
        }
        need(packet.buffer.as_ref().len(), HEADER_LEN)?;
        packet.set_opcode(self.opcode);
        packet.set_incomplete(self.incomplete);
        packet.set_reserved(0);
        packet.set_fragments_left(self.fragments_left);
        Ok(())
    }
}

/// Receives the service data of an SDO Information message as a byte stream, in order:
/// a whole frame's payload ([`SdoInfoRepr::emit`]) or, in the SDO server, the slice one
/// fragment carries.
pub trait ServiceDataSink {
    /// Appends `bytes` to the stream.
    fn push(&mut self, bytes: &[u8]);

    /// Appends a little-endian u16.
    fn push_u16(&mut self, value: u16) {
        self.push(&value.to_le_bytes())
    }
}

/// The sink of [`SdoInfoRepr::emit`] and [`SdoInfoRepr::service_data_len`]: writes the
/// stream from the start of `out`, counts what does not fit.
struct Cursor<'a> {
    out: &'a mut [u8],
    pos: usize,
}

impl ServiceDataSink for Cursor<'_> {
    fn push(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.pos..) {
            for (d, s) in dst.iter_mut().zip(bytes) {
                *d = *s;
            }
        }
        self.pos = self.pos.saturating_add(bytes.len());
    }
}

/// An SDO Information message as values (service data borrowed from the buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SdoInfoRepr<'a> {
    /// Get OD List request.
    OdListRequest {
        /// Which list.
        list_type: OdListType,
    },
    /// Get OD List response.
    OdListResponse {
        /// Which list.
        list_type: OdListType,
        /// Little-endian u16 indices (five counts for list type 0); see [`iter_u16`].
        list: &'a [u8],
    },
    /// Get Object Description request.
    ObjectDescriptionRequest {
        /// Index.
        index: u16,
    },
    /// Get Object Description response.
    ObjectDescriptionResponse {
        /// Index.
        index: u16,
        /// Data type (of the VAR, the ARRAY elements or the RECORD type).
        data_type: DataType,
        /// Highest subindex.
        max_sub_index: u8,
        /// Object code: 7 VAR, 8 ARRAY, 9 RECORD.
        object_code: u8,
        /// Name, no NUL.
        name: &'a [u8],
    },
    /// Get Entry Description request.
    EntryDescriptionRequest {
        /// Index.
        index: u16,
        /// Subindex.
        sub_index: u8,
        /// Optional fields wanted.
        value_info: ValueInfo,
    },
    /// Get Entry Description response.
    EntryDescriptionResponse {
        /// Index.
        index: u16,
        /// Subindex.
        sub_index: u8,
        /// Optional fields present.
        value_info: ValueInfo,
        /// Data type.
        data_type: DataType,
        /// Bit length.
        bit_length: u16,
        /// Access rights and mapping flags.
        access: Access,
        /// Unit type, UNSIGNED16 (present with [`ValueInfo::UNIT_TYPE`]; else 0; see
        /// [`UNIT_TYPE_LEN`]).
        unit_type: u16,
        /// Default value, ceil(bit_length / 8) bytes (with [`ValueInfo::DEFAULT`]; else empty).
        default: &'a [u8],
        /// Minimum value (with [`ValueInfo::MINIMUM`]; else empty).
        minimum: &'a [u8],
        /// Maximum value (with [`ValueInfo::MAXIMUM`]; else empty).
        maximum: &'a [u8],
        /// Name, no NUL.
        name: &'a [u8],
    },
    /// SDO Info Error request.
    Error {
        /// Reason.
        code: SdoAbortCode,
    },
}

/// The little-endian u16 values of an OD list (a trailing odd byte is ignored).
pub fn iter_u16(list: &[u8]) -> impl Iterator<Item = u16> + '_ {
    list.chunks_exact(2)
        .map(|c| u16::from_le_bytes([get_u8(c, 0), get_u8(c, 1)]))
}

/// Bytes of a default/minimum/maximum value for an entry of `bit_length` bits.
pub const fn value_len(bit_length: u16) -> usize {
    (bit_length as usize).div_ceil(8)
}

/// Splits `n` bytes off the front of `data`.
fn take<'a>(data: &mut &'a [u8], n: usize) -> Result<&'a [u8]> {
    if data.len() < n {
        return Err(Error::Truncated);
    }
    let (head, rest) = data.split_at(n);
    *data = rest;
    Ok(head)
}

impl<'a> SdoInfoRepr<'a> {
    /// Parses a whole message: an unfragmented frame, or fragments reassembled by the caller
    /// (see [`parse_service_data`](Self::parse_service_data)). Header flags are not checked;
    /// read them with [`SdoInfoHeaderRepr`].
    pub fn parse<T: AsRef<[u8]> + ?Sized>(packet: &SdoInfo<&'a T>) -> Result<SdoInfoRepr<'a>> {
        packet.check_len()?;
        Self::parse_service_data(packet.opcode(), packet.payload())
    }

    /// Parses the service data of one of the three requests a server answers (Get OD List,
    /// Get Object Description, Get Entry Description) like
    /// [`parse_service_data`](Self::parse_service_data); `None` for any other opcode. A
    /// server needs only this, so the response parsers stay out of its image.
    pub fn parse_request(opcode: SdoInfoOpCode, data: &'a [u8]) -> Option<Result<SdoInfoRepr<'a>>> {
        let at = |offset: usize| offset - field::PAYLOAD;
        let u16_at = |r: core::ops::Range<usize>| get_u16(data, at(r.start)..at(r.end));
        let parsed = match opcode {
            SdoInfoOpCode::GetOdListRequest => {
                need(data.len(), at(field::LIST_TYPE.end)).map(|()| SdoInfoRepr::OdListRequest {
                    list_type: OdListType::from(u16_at(field::LIST_TYPE)),
                })
            }
            SdoInfoOpCode::GetObjectDescriptionRequest => need(data.len(), at(field::INDEX.end))
                .map(|()| SdoInfoRepr::ObjectDescriptionRequest {
                    index: u16_at(field::INDEX),
                }),
            SdoInfoOpCode::GetEntryDescriptionRequest => {
                need(data.len(), at(field::VALUE_INFO) + 1).map(|()| {
                    SdoInfoRepr::EntryDescriptionRequest {
                        index: u16_at(field::INDEX),
                        sub_index: get_u8(data, at(field::SUB_INDEX)),
                        value_info: ValueInfo(get_u8(data, at(field::VALUE_INFO))),
                    }
                })
            }
            _ => return None,
        };
        Some(parsed)
    }

    /// Parses the service data of a message with `opcode`. Bytes after a fixed-length
    /// request or error are ignored; `Err(Malformed)` for an unknown opcode or an OD list
    /// of odd length.
    pub fn parse_service_data(opcode: SdoInfoOpCode, data: &'a [u8]) -> Result<SdoInfoRepr<'a>> {
        if let Some(request) = Self::parse_request(opcode, data) {
            return request;
        }
        // The view's getters take frame offsets; rebuild a frame-relative reader.
        let at = |offset: usize| offset - field::PAYLOAD;
        let u16_at = |r: core::ops::Range<usize>| get_u16(data, at(r.start)..at(r.end));
        match opcode {
            SdoInfoOpCode::GetOdListResponse => {
                need(data.len(), at(field::LIST))?;
                let list = tail(data, at(field::LIST));
                if list.len() % 2 != 0 {
                    return Err(Error::Malformed);
                }
                Ok(SdoInfoRepr::OdListResponse {
                    list_type: OdListType::from(u16_at(field::LIST_TYPE)),
                    list,
                })
            }
            SdoInfoOpCode::GetObjectDescriptionResponse => {
                need(data.len(), at(field::OBJ_NAME))?;
                Ok(SdoInfoRepr::ObjectDescriptionResponse {
                    index: u16_at(field::INDEX),
                    data_type: DataType::from(u16_at(field::OBJ_DATA_TYPE)),
                    max_sub_index: get_u8(data, at(field::MAX_SUB_INDEX)),
                    object_code: get_u8(data, at(field::OBJECT_CODE)),
                    name: tail(data, at(field::OBJ_NAME)),
                })
            }
            SdoInfoOpCode::GetEntryDescriptionResponse => {
                need(data.len(), at(field::ENTRY_DATA))?;
                let value_info = ValueInfo(get_u8(data, at(field::VALUE_INFO)));
                let bit_length = u16_at(field::BIT_LENGTH);
                let n = value_len(bit_length);
                let mut rest = tail(data, at(field::ENTRY_DATA));
                let mut optional = |flag: u8, len: usize| -> Result<&'a [u8]> {
                    if value_info.contains(flag) {
                        take(&mut rest, len)
                    } else {
                        Ok(&[])
                    }
                };
                let unit_type = get_u16(optional(ValueInfo::UNIT_TYPE, UNIT_TYPE_LEN)?, 0..2);
                let default = optional(ValueInfo::DEFAULT, n)?;
                let minimum = optional(ValueInfo::MINIMUM, n)?;
                let maximum = optional(ValueInfo::MAXIMUM, n)?;
                Ok(SdoInfoRepr::EntryDescriptionResponse {
                    index: u16_at(field::INDEX),
                    sub_index: get_u8(data, at(field::SUB_INDEX)),
                    value_info,
                    data_type: DataType::from(u16_at(field::ENTRY_DATA_TYPE)),
                    bit_length,
                    access: Access(u16_at(field::OBJECT_ACCESS)),
                    unit_type,
                    default,
                    minimum,
                    maximum,
                    name: rest,
                })
            }
            SdoInfoOpCode::SdoInfoError => {
                need(data.len(), at(field::ABORT_CODE.end))?;
                Ok(SdoInfoRepr::Error {
                    code: SdoAbortCode::from(get_u32(
                        data,
                        at(field::ABORT_CODE.start)..at(field::ABORT_CODE.end),
                    )),
                })
            }
            // The requests were parsed above.
            SdoInfoOpCode::GetOdListRequest
            | SdoInfoOpCode::GetObjectDescriptionRequest
            | SdoInfoOpCode::GetEntryDescriptionRequest
            | SdoInfoOpCode::Unknown(_) => Err(Error::Malformed),
        }
    }

    /// The opcode of this message.
    pub const fn opcode(&self) -> SdoInfoOpCode {
        match self {
            SdoInfoRepr::OdListRequest { .. } => SdoInfoOpCode::GetOdListRequest,
            SdoInfoRepr::OdListResponse { .. } => SdoInfoOpCode::GetOdListResponse,
            SdoInfoRepr::ObjectDescriptionRequest { .. } => {
                SdoInfoOpCode::GetObjectDescriptionRequest
            }
            SdoInfoRepr::ObjectDescriptionResponse { .. } => {
                SdoInfoOpCode::GetObjectDescriptionResponse
            }
            SdoInfoRepr::EntryDescriptionRequest { .. } => {
                SdoInfoOpCode::GetEntryDescriptionRequest
            }
            SdoInfoRepr::EntryDescriptionResponse { .. } => {
                SdoInfoOpCode::GetEntryDescriptionResponse
            }
            SdoInfoRepr::Error { .. } => SdoInfoOpCode::SdoInfoError,
        }
    }

    /// Checks what the emitter cannot express: an OD list of odd length, optional values
    /// whose length is not ceil(bit_length / 8).
    #[inline(always)]
    pub fn check(&self) -> Result<()> {
        match *self {
            SdoInfoRepr::OdListResponse { list, .. } if list.len() % 2 != 0 => {
                Err(Error::Malformed)
            }
            SdoInfoRepr::EntryDescriptionResponse {
                value_info,
                bit_length,
                default,
                minimum,
                maximum,
                ..
            } => {
                let n = value_len(bit_length);
                let ok = |flag: u8, v: &[u8]| {
                    if value_info.contains(flag) {
                        v.len() == n
                    } else {
                        v.is_empty()
                    }
                };
                if ok(ValueInfo::DEFAULT, default)
                    && ok(ValueInfo::MINIMUM, minimum)
                    && ok(ValueInfo::MAXIMUM, maximum)
                {
                    Ok(())
                } else {
                    Err(Error::Malformed)
                }
            }
            _ => Ok(()),
        }
    }

    /// Streams the service data into `w`, unchecked: [`emit`](Self::emit) calls
    /// [`check`](Self::check) first, and so must a caller that emits fragments.
    // Inlined: the server writes one known variant (object description, error), so only
    // that arm lands in its image.
    #[inline(always)]
    pub fn write<W: ServiceDataSink + ?Sized>(&self, w: &mut W) {
        match *self {
            SdoInfoRepr::OdListRequest { list_type } => w.push_u16(list_type.into()),
            SdoInfoRepr::OdListResponse { list_type, list } => {
                write_od_list(w, list_type, iter_u16(list))
            }
            SdoInfoRepr::ObjectDescriptionRequest { index } => w.push_u16(index),
            SdoInfoRepr::ObjectDescriptionResponse {
                index,
                data_type,
                max_sub_index,
                object_code,
                name,
            } => {
                w.push_u16(index);
                w.push_u16(data_type.into());
                w.push(&[max_sub_index, object_code]);
                w.push(name);
            }
            SdoInfoRepr::EntryDescriptionRequest {
                index,
                sub_index,
                value_info,
            } => {
                w.push_u16(index);
                w.push(&[sub_index, value_info.0]);
            }
            SdoInfoRepr::EntryDescriptionResponse {
                index,
                sub_index,
                value_info,
                data_type,
                bit_length,
                access,
                unit_type,
                default,
                minimum,
                maximum,
                name,
            } => EntryDescriptionHead {
                index,
                sub_index,
                value_info,
                data_type,
                bit_length,
                access,
                unit_type,
            }
            .write(
                w,
                |which, w| {
                    w.push(match which {
                        EntryValue::Default => default,
                        EntryValue::Minimum => minimum,
                        EntryValue::Maximum => maximum,
                    })
                },
                name,
            ),
            SdoInfoRepr::Error { code } => w.push(&u32::from(code).to_le_bytes()),
        }
    }

    /// Length of the whole service data (all fragments together).
    #[inline(always)]
    pub fn service_data_len(&self) -> usize {
        let mut w = Cursor {
            out: &mut [],
            pos: 0,
        };
        self.write(&mut w);
        w.pos
    }

    /// Header plus service data of an unfragmented frame.
    #[inline(always)]
    pub fn buffer_len(&self) -> usize {
        HEADER_LEN + self.service_data_len()
    }

    /// Writes the message unfragmented (incomplete 0, fragments left 0).
    #[inline(always)]
    pub fn emit<T: AsRef<[u8]> + AsMut<[u8]>>(&self, packet: &mut SdoInfo<T>) -> Result<()> {
        self.check()?;
        need(packet.buffer.as_ref().len(), self.buffer_len())?;
        SdoInfoHeaderRepr {
            opcode: self.opcode(),
            incomplete: false,
            fragments_left: 0,
        }
        .emit(packet)?;
        self.write(&mut Cursor {
            out: packet.payload_mut(),
            pos: 0,
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(bytes: &[u8]) -> Result<SdoInfoRepr<'_>> {
        SdoInfoRepr::parse(&SdoInfo::new_unchecked(bytes))
    }

    fn round_trip(bytes: &[u8], expected: SdoInfoRepr<'_>) {
        assert_eq!(parse(bytes), Ok(expected));
        assert_eq!(expected.buffer_len(), bytes.len());
        let mut out = [0xa5u8; 64];
        expected
            .emit(&mut SdoInfo::new_unchecked(&mut out[..]))
            .unwrap();
        assert_eq!(&out[..bytes.len()], bytes);
        assert!(out[bytes.len()..].iter().all(|&b| b == 0xa5));
    }

    /// Get OD List request, all objects.
    static OD_LIST_REQUEST: [u8; 6] = [0x01, 0x00, 0x00, 0x00, 0x01, 0x00];
    /// Get OD List response, all objects: 0x1000, 0x1008, 0x1018, 0x6401.
    static OD_LIST_RESPONSE: [u8; 14] = [
        0x02, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x10, 0x08, 0x10, 0x18, 0x10, 0x01, 0x64,
    ];
    /// Get OD List response, list type 0: counts 4, 1, 1, 0, 0.
    static OD_LIST_COUNTS: [u8; 16] = [
        0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04, 0x00, 0x01, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00,
        0x00,
    ];
    /// Get Object Description request 0x1018.
    static OBJ_REQUEST: [u8; 6] = [0x03, 0x00, 0x00, 0x00, 0x18, 0x10];
    /// Get Object Description response 0x1018: type 0x0023 IDENTITY, max sub 4, RECORD (9),
    /// name "Identity".
    static OBJ_RESPONSE: [u8; 18] = [
        0x04, 0x00, 0x00, 0x00, 0x18, 0x10, 0x23, 0x00, 0x04, 0x09, b'I', b'd', b'e', b'n', b't',
        b'i', b't', b'y',
    ];
    /// Get Entry Description request 0x6411:01, value info: unit, default, min, max.
    static ENTRY_REQUEST: [u8; 8] = [0x05, 0x00, 0x00, 0x00, 0x11, 0x64, 0x01, 0x78];
    /// Get Entry Description response 0x6411:01: INTEGER16 (3), 16 bits, access RW all
    /// states + RxPDO (0x007F), unit 0x0000, default 0, min -32768, max 32767, name "AO 1".
    static ENTRY_RESPONSE: [u8; 28] = [
        0x06, 0x00, 0x00, 0x00, // header
        0x11, 0x64, 0x01, 0x78, // index, sub, value info
        0x03, 0x00, 0x10, 0x00, 0x7F, 0x00, // data type, bit length, access
        0x00, 0x00, // unit type
        0x00, 0x00, 0x00, 0x80, 0xFF, 0x7F, // default, minimum, maximum
        b'A', b'O', b' ', b'1', // name
        0xEE, 0xEE, // (trimmed off in tests)
    ];
    /// Entry description response without optional values: 0x1000:00 UNSIGNED32 RO
    /// "Device type".
    static ENTRY_RESPONSE_PLAIN: [u8; 25] = [
        0x06, 0x00, 0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x07, 0x00, 0x20, 0x00, 0x07, 0x00, b'D',
        b'e', b'v', b'i', b'c', b'e', b' ', b't', b'y', b'p', b'e',
    ];
    /// SDO Info error: object does not exist.
    static INFO_ERROR: [u8; 8] = [0x07, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x06];
    /// A middle fragment: opcode 2, incomplete, reserved 0, 3 fragments left.
    static FRAGMENT_HEADER: [u8; 4] = [0x82, 0x00, 0x03, 0x00];

    #[test]
    fn parse_request_only_requests() {
        let data = [0x34, 0x12, 0x05, 0x70];
        for opcode in [
            SdoInfoOpCode::GetOdListRequest,
            SdoInfoOpCode::GetObjectDescriptionRequest,
            SdoInfoOpCode::GetEntryDescriptionRequest,
        ] {
            assert_eq!(
                SdoInfoRepr::parse_request(opcode, &data),
                Some(SdoInfoRepr::parse_service_data(opcode, &data)),
                "{opcode:?}"
            );
            assert_eq!(
                SdoInfoRepr::parse_request(opcode, &[]),
                Some(Err(Error::Truncated)),
                "{opcode:?}"
            );
        }
        assert_eq!(
            SdoInfoRepr::parse_request(SdoInfoOpCode::GetEntryDescriptionRequest, &data),
            Some(Ok(SdoInfoRepr::EntryDescriptionRequest {
                index: 0x1234,
                sub_index: 5,
                value_info: ValueInfo(0x70),
            }))
        );
        for opcode in [
            SdoInfoOpCode::GetOdListResponse,
            SdoInfoOpCode::GetObjectDescriptionResponse,
            SdoInfoOpCode::GetEntryDescriptionResponse,
            SdoInfoOpCode::SdoInfoError,
            SdoInfoOpCode::Unknown(0x7F),
        ] {
            assert_eq!(
                SdoInfoRepr::parse_request(opcode, &data),
                None,
                "{opcode:?}"
            );
        }
    }

    #[test]
    fn deconstruct() {
        let p = SdoInfo::new_checked(&ENTRY_RESPONSE[..26]).unwrap();
        assert_eq!(p.opcode(), SdoInfoOpCode::GetEntryDescriptionResponse);
        assert!(!p.incomplete());
        assert_eq!(p.reserved(), 0);
        assert_eq!(p.fragments_left(), 0);
        assert_eq!(p.index(), 0x6411);
        assert_eq!(p.sub_index(), 1);
        assert_eq!(p.value_info(), ValueInfo(0x78));
        assert_eq!(p.entry_data_type(), DataType::from(3u16));
        assert_eq!(p.bit_length(), 16);
        assert_eq!(p.object_access(), Access(0x007F));
        assert_eq!(p.entry_data(), &ENTRY_RESPONSE[14..26]);

        let p = SdoInfo::new_checked(&OBJ_RESPONSE[..]).unwrap();
        assert_eq!(p.object_data_type(), DataType::from(0x23u16));
        assert_eq!(p.max_sub_index(), 4);
        assert_eq!(p.object_code(), 9);
        assert_eq!(p.object_name(), b"Identity");

        let p = SdoInfo::new_checked(&OD_LIST_RESPONSE[..]).unwrap();
        assert_eq!(p.list_type(), OdListType::AllObjects);
        assert_eq!(p.od_list(), &OD_LIST_RESPONSE[6..]);
        assert_eq!(p.payload(), &OD_LIST_RESPONSE[4..]);

        let p = SdoInfo::new_checked(&INFO_ERROR[..]).unwrap();
        assert_eq!(p.abort_code(), SdoAbortCode::ObjectDoesNotExist);

        let p = SdoInfo::new_checked(&FRAGMENT_HEADER[..]).unwrap();
        assert_eq!(p.opcode(), SdoInfoOpCode::GetOdListResponse);
        assert!(p.incomplete());
        assert_eq!(p.fragments_left(), 3);
    }

    #[test]
    fn construct_header() {
        let mut bytes = [0xa5u8; 4];
        let mut p = SdoInfo::new_unchecked(&mut bytes[..]);
        p.set_opcode(SdoInfoOpCode::GetOdListResponse);
        p.set_incomplete(true);
        p.set_reserved(0);
        p.set_fragments_left(3);
        assert_eq!(bytes, FRAGMENT_HEADER);

        let mut bytes = [0xa5u8; 4];
        SdoInfoHeaderRepr {
            opcode: SdoInfoOpCode::GetOdListResponse,
            incomplete: true,
            fragments_left: 3,
        }
        .emit(&mut SdoInfo::new_unchecked(&mut bytes[..]))
        .unwrap();
        assert_eq!(bytes, FRAGMENT_HEADER);
        assert_eq!(
            SdoInfoHeaderRepr::parse(&SdoInfo::new_unchecked(&FRAGMENT_HEADER[..])),
            Ok(SdoInfoHeaderRepr {
                opcode: SdoInfoOpCode::GetOdListResponse,
                incomplete: true,
                fragments_left: 3,
            })
        );
    }

    #[test]
    fn od_list() {
        round_trip(
            &OD_LIST_REQUEST,
            SdoInfoRepr::OdListRequest {
                list_type: OdListType::AllObjects,
            },
        );
        round_trip(
            &OD_LIST_RESPONSE,
            SdoInfoRepr::OdListResponse {
                list_type: OdListType::AllObjects,
                list: &OD_LIST_RESPONSE[6..],
            },
        );
        let list: [u16; 4] = [0x1000, 0x1008, 0x1018, 0x6401];
        assert!(iter_u16(&OD_LIST_RESPONSE[6..]).eq(list));
        round_trip(
            &OD_LIST_COUNTS,
            SdoInfoRepr::OdListResponse {
                list_type: OdListType::NumberOfObjects,
                list: &OD_LIST_COUNTS[6..],
            },
        );
        assert!(iter_u16(&OD_LIST_COUNTS[6..]).eq([4, 1, 1, 0, 0]));
    }

    #[test]
    fn list_types() {
        let table: [(u16, OdListType); 6] = [
            (0, OdListType::NumberOfObjects),
            (1, OdListType::AllObjects),
            (2, OdListType::RxPdoMappable),
            (3, OdListType::TxPdoMappable),
            (4, OdListType::StoredForReplacement),
            (5, OdListType::StartupParameters),
        ];
        for (raw, t) in table {
            assert_eq!(OdListType::from(raw), t);
            assert_eq!(u16::from(t), raw);
        }
        let unknown = [0x01, 0x00, 0x00, 0x00, 0x06, 0x00];
        round_trip(
            &unknown,
            SdoInfoRepr::OdListRequest {
                list_type: OdListType::Unknown(6),
            },
        );
    }

    #[test]
    fn object_description() {
        round_trip(
            &OBJ_REQUEST,
            SdoInfoRepr::ObjectDescriptionRequest { index: 0x1018 },
        );
        round_trip(
            &OBJ_RESPONSE,
            SdoInfoRepr::ObjectDescriptionResponse {
                index: 0x1018,
                data_type: DataType::from(0x23u16),
                max_sub_index: 4,
                object_code: 9,
                name: b"Identity",
            },
        );
    }

    #[test]
    fn entry_description() {
        round_trip(
            &ENTRY_REQUEST,
            SdoInfoRepr::EntryDescriptionRequest {
                index: 0x6411,
                sub_index: 1,
                value_info: ValueInfo(0x78),
            },
        );
        round_trip(
            &ENTRY_RESPONSE[..26],
            SdoInfoRepr::EntryDescriptionResponse {
                index: 0x6411,
                sub_index: 1,
                value_info: ValueInfo(0x78),
                data_type: DataType::from(3u16),
                bit_length: 16,
                access: Access(0x007F),
                unit_type: 0,
                default: &[0x00, 0x00],
                minimum: &[0x00, 0x80],
                maximum: &[0xFF, 0x7F],
                name: b"AO 1",
            },
        );
        round_trip(
            &ENTRY_RESPONSE_PLAIN,
            SdoInfoRepr::EntryDescriptionResponse {
                index: 0x1000,
                sub_index: 0,
                value_info: ValueInfo(0),
                data_type: DataType::from(7u16),
                bit_length: 32,
                access: Access::RO,
                unit_type: 0,
                default: &[],
                minimum: &[],
                maximum: &[],
                name: b"Device type",
            },
        );
    }

    #[test]
    fn entry_description_partial_value_info() {
        // Only maximum (0x40) of a BOOLEAN (1 bit -> 1 byte), plus the SOES bits 0..2.
        let bytes = [
            0x06, 0x00, 0x00, 0x00, 0x00, 0x30, 0x01, 0x47, 0x01, 0x00, 0x01, 0x00, 0x3F, 0x00,
            0x01, b'F',
        ];
        round_trip(
            &bytes,
            SdoInfoRepr::EntryDescriptionResponse {
                index: 0x3000,
                sub_index: 1,
                value_info: ValueInfo(0x47),
                data_type: DataType::from(1u16),
                bit_length: 1,
                access: Access::RW,
                unit_type: 0,
                default: &[],
                minimum: &[],
                maximum: &[0x01],
                name: b"F",
            },
        );
    }

    #[test]
    fn info_error() {
        round_trip(
            &INFO_ERROR,
            SdoInfoRepr::Error {
                code: SdoAbortCode::ObjectDoesNotExist,
            },
        );
    }

    #[test]
    fn opcodes() {
        let table: [(u8, SdoInfoOpCode); 7] = [
            (1, SdoInfoOpCode::GetOdListRequest),
            (2, SdoInfoOpCode::GetOdListResponse),
            (3, SdoInfoOpCode::GetObjectDescriptionRequest),
            (4, SdoInfoOpCode::GetObjectDescriptionResponse),
            (5, SdoInfoOpCode::GetEntryDescriptionRequest),
            (6, SdoInfoOpCode::GetEntryDescriptionResponse),
            (7, SdoInfoOpCode::SdoInfoError),
        ];
        for (raw, op) in table {
            assert_eq!(SdoInfoOpCode::from(raw), op);
            assert_eq!(u8::from(op), raw);
        }
        assert_eq!(parse(&[0x08, 0, 0, 0, 0, 0, 0, 0]), Err(Error::Malformed));
        assert_eq!(parse(&[0x00, 0, 0, 0, 0, 0, 0, 0]), Err(Error::Malformed));
    }

    #[test]
    fn truncated() {
        for n in 0..HEADER_LEN {
            assert_eq!(
                SdoInfo::new_checked(&OD_LIST_REQUEST[..n]),
                Err(Error::Truncated)
            );
        }
        let cases: [(&[u8], usize); 7] = [
            (&OD_LIST_REQUEST, 6),
            (&OD_LIST_RESPONSE, 6),
            (&OBJ_REQUEST, 6),
            (&OBJ_RESPONSE, 10),
            (&ENTRY_REQUEST, 8),
            (&ENTRY_RESPONSE[..26], 22),
            (&INFO_ERROR, 8),
        ];
        for (bytes, min) in cases {
            for n in HEADER_LEN..min {
                assert_eq!(
                    parse(&bytes[..n]),
                    Err(Error::Truncated),
                    "{bytes:02x?} at {n}"
                );
            }
            assert!(parse(&bytes[..min]).is_ok(), "{bytes:02x?} at {min}");
        }
        // Value info promises a unit type that is not there.
        let no_unit = [
            0x06, 0, 0, 0, 0x00, 0x10, 0x00, 0x08, 0x07, 0x00, 0x20, 0x00, 0x07, 0x00, 0x01,
        ];
        assert_eq!(parse(&no_unit), Err(Error::Truncated));
        // Unchecked views read zeros.
        assert_eq!(
            SdoInfo::new_unchecked(&OD_LIST_REQUEST[..1]).fragments_left(),
            0
        );
        assert_eq!(
            SdoInfo::new_unchecked(&OD_LIST_REQUEST[..1]).payload(),
            &[] as &[u8]
        );
    }

    #[test]
    fn malformed() {
        // An OD list with half an index.
        assert_eq!(parse(&OD_LIST_RESPONSE[..13]), Err(Error::Malformed));
        let odd = SdoInfoRepr::OdListResponse {
            list_type: OdListType::AllObjects,
            list: &[1, 2, 3],
        };
        let mut out = [0xa5u8; 16];
        assert_eq!(
            odd.emit(&mut SdoInfo::new_unchecked(&mut out[..])),
            Err(Error::Malformed)
        );
        // Default value of the wrong size; a value given without its flag.
        let mut entry = SdoInfoRepr::EntryDescriptionResponse {
            index: 0x6411,
            sub_index: 1,
            value_info: ValueInfo(ValueInfo::DEFAULT),
            data_type: DataType::from(3u16),
            bit_length: 16,
            access: Access::RW,
            unit_type: 0,
            default: &[0],
            minimum: &[],
            maximum: &[],
            name: b"x",
        };
        assert_eq!(
            entry.emit(&mut SdoInfo::new_unchecked(&mut out[..])),
            Err(Error::Malformed)
        );
        assert_eq!(entry.check(), Err(Error::Malformed));
        if let SdoInfoRepr::EntryDescriptionResponse {
            ref mut value_info,
            ref mut default,
            ref mut minimum,
            ..
        } = entry
        {
            *value_info = ValueInfo(0);
            *default = &[];
            *minimum = &[0, 0];
        }
        assert_eq!(
            entry.emit(&mut SdoInfo::new_unchecked(&mut out[..])),
            Err(Error::Malformed)
        );
        assert_eq!(out, [0xa5u8; 16]);
    }

    #[test]
    fn emit_short_buffer() {
        let repr = SdoInfoRepr::ObjectDescriptionResponse {
            index: 0x1018,
            data_type: DataType::from(0x23u16),
            max_sub_index: 4,
            object_code: 9,
            name: b"Identity",
        };
        let mut out = [0xa5u8; 17];
        assert_eq!(
            repr.emit(&mut SdoInfo::new_unchecked(&mut out[..])),
            Err(Error::Truncated)
        );
        assert_eq!(out, [0xa5u8; 17]);
        let mut three = [0u8; 3];
        assert_eq!(
            SdoInfoHeaderRepr {
                opcode: SdoInfoOpCode::SdoInfoError,
                incomplete: false,
                fragments_left: 0,
            }
            .emit(&mut SdoInfo::new_unchecked(&mut three[..])),
            Err(Error::Truncated)
        );
    }
}
