//! SDO Information service responses (ETG.1000.6 5.6.3) generated as a byte stream from the
//! object dictionary description, so a response of any length can be cut into fragments
//! without a buffer: each fragment regenerates the stream through a
//! [`FragmentWriter`] that keeps only its own window. The layouts are the wire layer's
//! ([`crate::wire::sdo_info`]); this module only supplies the values.

use crate::abort::SdoAbortCode;
use crate::od::{Access, DataType, EntryDesc, ObjectDictionary, Value};
use crate::wire::{
    write_od_list, EntryDescriptionHead, EntryValue, FragmentWriter, OdListType, SdoInfoOpCode,
    SdoInfoRepr, ValueInfo,
};

/// What an SDO Information request asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum InfoQuery {
    /// Get OD List with this list type.
    OdList(OdListType),
    /// Get Object Description.
    Object(u16),
    /// Get Entry Description with the requested value info bits.
    Entry {
        index: u16,
        subindex: u8,
        value_info: ValueInfo,
    },
}

impl InfoQuery {
    /// The query of an SDO Information request; `None` for anything but the three requests.
    pub(crate) fn from_request(request: &SdoInfoRepr<'_>) -> Option<InfoQuery> {
        match *request {
            SdoInfoRepr::OdListRequest { list_type } => Some(Self::OdList(list_type)),
            SdoInfoRepr::ObjectDescriptionRequest { index } => Some(Self::Object(index)),
            SdoInfoRepr::EntryDescriptionRequest {
                index,
                sub_index,
                value_info,
            } => Some(Self::Entry {
                index,
                subindex: sub_index,
                value_info,
            }),
            _ => None,
        }
    }

    /// The response opcode.
    pub(crate) fn response_opcode(&self) -> SdoInfoOpCode {
        match self {
            Self::OdList(_) => SdoInfoOpCode::GetOdListResponse,
            Self::Object(_) => SdoInfoOpCode::GetObjectDescriptionResponse,
            Self::Entry { .. } => SdoInfoOpCode::GetEntryDescriptionResponse,
        }
    }
}

/// The access flag an object needs in one of its entries to be in an OD list (list types
/// 1..5, ETG.1000.6 5.6.3 Get OD List); `None` for list type 0 and unknown types.
fn list_filter(list_type: OdListType) -> Option<Option<u16>> {
    match list_type {
        OdListType::AllObjects => Some(None),
        OdListType::RxPdoMappable => Some(Some(Access::RXPDO)),
        OdListType::TxPdoMappable => Some(Some(Access::TXPDO)),
        OdListType::StoredForReplacement => Some(Some(Access::BACKUP)),
        OdListType::StartupParameters => Some(Some(Access::SETTINGS)),
        _ => None,
    }
}

/// The indices of the objects in an OD list of list type 1..5.
fn list_members(
    od: &ObjectDictionary,
    filter: Option<u16>,
) -> impl Iterator<Item = u16> + Clone + '_ {
    od.iter()
        .filter(move |o| filter.is_none_or(|mask| o.any_entry_has(mask)))
        .map(|o| o.index)
}

/// Writes an entry's default/minimum/maximum: exactly `entry.byte_len()` bytes, strings
/// zero-padded, a UNICODE_STRING as UTF-16LE code units.
fn push_value(w: &mut FragmentWriter<'_>, entry: &EntryDesc, value: &Value) {
    let len = entry.byte_len();
    match *value {
        Value::Str(s) if entry.data_type == DataType::UnicodeString => {
            let n = value.encoded_len(entry.data_type, entry.bit_len).min(len) / 2;
            for c in s.bytes().take(n) {
                w.push_u16(u16::from(c));
            }
            w.push_zeros(len - n * 2);
        }
        Value::Str(_) | Value::Bytes(_) => {
            let n = value.encoded_len(entry.data_type, entry.bit_len).min(len);
            let bytes = match *value {
                Value::Str(s) => s.as_bytes(),
                Value::Bytes(b) => b,
                _ => &[],
            };
            w.push(bytes.get(..n).unwrap_or_default());
            w.push_zeros(len - n);
        }
        _ => {
            let mut buf = [0u8; 8];
            let n = value
                .encode(entry.data_type, entry.bit_len, &mut buf)
                .unwrap_or(0)
                .min(len);
            w.push(buf.get(..n).unwrap_or_default());
            w.push_zeros(len - n);
        }
    }
}

/// Generates the response service data (everything after the SDO Information header).
fn generate(
    query: &InfoQuery,
    od: &ObjectDictionary,
    w: &mut FragmentWriter<'_>,
) -> Result<(), SdoAbortCode> {
    match *query {
        InfoQuery::OdList(OdListType::NumberOfObjects) => {
            let counts = [
                OdListType::AllObjects,
                OdListType::RxPdoMappable,
                OdListType::TxPdoMappable,
                OdListType::StoredForReplacement,
                OdListType::StartupParameters,
            ]
            .map(|t| {
                let n = list_filter(t).map_or(0, |f| list_members(od, f).count());
                u16::try_from(n).unwrap_or(u16::MAX)
            });
            write_od_list(w, OdListType::NumberOfObjects, counts);
        }
        InfoQuery::OdList(list_type) => {
            let filter = list_filter(list_type).ok_or(SdoAbortCode::UnsupportedAccess)?;
            write_od_list(w, list_type, list_members(od, filter));
        }
        InfoQuery::Object(index) => {
            let object = od.find(index).ok_or(SdoAbortCode::ObjectDoesNotExist)?;
            SdoInfoRepr::ObjectDescriptionResponse {
                index,
                data_type: object.data_type,
                max_sub_index: object.max_subindex(),
                object_code: object.code.code(),
                name: object.name.as_bytes(),
            }
            .write(w);
        }
        InfoQuery::Entry {
            index,
            subindex,
            value_info,
        } => {
            let (_, entry) = od.entry(index, subindex)?;
            EntryDescriptionHead {
                index,
                sub_index: subindex,
                value_info: ValueInfo(value_info.0 & entry.value_info()),
                data_type: entry.data_type,
                bit_length: entry.bit_len,
                access: entry.access,
                unit_type: entry.unit().unwrap_or(0),
            }
            .write(
                w,
                |which, w| {
                    let value = match which {
                        EntryValue::Default => entry.default(),
                        EntryValue::Minimum => entry.min(),
                        EntryValue::Maximum => entry.max(),
                    };
                    push_value(w, entry, &value);
                },
                entry.name.as_bytes(),
            );
        }
    }
    Ok(())
}

/// Length of the whole response data, or the abort code of an SDO Information error.
pub(crate) fn stream_len(query: &InfoQuery, od: &ObjectDictionary) -> Result<usize, SdoAbortCode> {
    let mut w = FragmentWriter::new(0, &mut []);
    generate(query, od, &mut w)?;
    Ok(w.position())
}

/// Copies the response data from byte `skip` into `out`; returns the bytes written.
pub(crate) fn stream_chunk(
    query: &InfoQuery,
    od: &ObjectDictionary,
    skip: usize,
    out: &mut [u8],
) -> usize {
    let mut w = FragmentWriter::new(skip, out);
    match generate(query, od, &mut w) {
        Ok(()) => w.written(),
        Err(_) => 0,
    }
}
