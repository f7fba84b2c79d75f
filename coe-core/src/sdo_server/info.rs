//! SDO Information service responses (ETG.1000.6 5.6.3) generated as a byte stream from the
//! object dictionary description, so a response of any length can be cut into fragments
//! without a buffer: each fragment regenerates the stream through a [`FragmentWriter`] that
//! keeps only its own window. The layouts are the wire layer's ([`crate::wire::sdo_info`],
//! written through its [`ServiceDataSink`]); this module supplies the values and the
//! fragmentation.

use crate::abort::SdoAbortCode;
use crate::od::{Access, DataType, EntryDesc, ObjectDictionary, Value};
use crate::wire::{
    self, write_od_list, EntryDescriptionHead, EntryValue, OdListType, SdoInfoOpCode, SdoInfoRepr,
    ServiceDataSink, ValueInfo,
};

/// Writes a window of a byte stream: bytes before `skip` and past the end of `out` are
/// counted but dropped. Lets a response of any length be produced one fragment at a time
/// without a buffer for the whole response.
#[derive(Debug)]
pub struct FragmentWriter<'a> {
    skip: usize,
    out: &'a mut [u8],
    pos: usize,
}

impl<'a> FragmentWriter<'a> {
    /// A window that keeps stream bytes `skip .. skip + out.len()`.
    pub fn new(skip: usize, out: &'a mut [u8]) -> FragmentWriter<'a> {
        FragmentWriter { skip, out, pos: 0 }
    }

    /// Appends `n` zero bytes (padding of a value shorter than its entry).
    pub fn push_zeros(&mut self, n: usize) {
        let start = self.pos;
        let end = start.saturating_add(n);
        self.pos = end;
        let lo = start.max(self.skip);
        let hi = end.min(self.skip.saturating_add(self.out.len()));
        if lo < hi {
            if let Some(dst) = self.out.get_mut(lo - self.skip..hi - self.skip) {
                dst.fill(0);
            }
        }
    }

    /// Stream bytes seen so far (the total length once everything is pushed).
    pub fn position(&self) -> usize {
        self.pos
    }

    /// Bytes written into `out`.
    pub fn written(&self) -> usize {
        self.pos.saturating_sub(self.skip).min(self.out.len())
    }
}

impl ServiceDataSink for FragmentWriter<'_> {
    fn push(&mut self, bytes: &[u8]) {
        let start = self.pos;
        let end = start.saturating_add(bytes.len());
        self.pos = end;
        let lo = start.max(self.skip);
        let hi = end.min(self.skip.saturating_add(self.out.len()));
        if lo < hi {
            let dst = self.out.get_mut(lo - self.skip..hi - self.skip);
            let src = bytes.get(lo - start..hi - start);
            if let (Some(dst), Some(src)) = (dst, src) {
                for (d, s) in dst.iter_mut().zip(src) {
                    *d = *s;
                }
            }
        }
    }

    // One out-of-line copy: the responses write a dozen u16 fields, each would otherwise
    // carry its own conversion and call. An OD list is a u16 per object and each fragment
    // regenerates the whole list (in the mailbox task, under the lock of the PDI side): a
    // u16 outside the window is only counted, one inside it stored directly, without the
    // general path's window arithmetic and byte copy.
    #[inline(never)]
    fn push_u16(&mut self, value: u16) {
        let start = self.pos;
        let end = start.saturating_add(2);
        let window_end = self.skip.saturating_add(self.out.len());
        if end <= self.skip || start >= window_end {
            self.pos = end;
        } else if let Some(dst) = start
            .checked_sub(self.skip)
            .and_then(|at| self.out.get_mut(at..at + 2))
        {
            dst.copy_from_slice(&value.to_le_bytes());
            self.pos = end;
        } else {
            self.push(&value.to_le_bytes())
        }
    }
}

/// Writes service data bytes `offset .. offset + out.len()` of `repr` (clipped to the end
/// of the data) into `out` and returns how many were written: the payload of one fragment.
/// The caller writes the fragment's header with [`wire::SdoInfoHeaderRepr`].
pub fn emit_fragment(repr: &SdoInfoRepr<'_>, offset: usize, out: &mut [u8]) -> wire::Result<usize> {
    repr.check()?;
    let mut w = FragmentWriter::new(offset, out);
    repr.write(&mut w);
    Ok(w.written())
}

/// The number of fragments a service data stream of `total` bytes needs when each fragment
/// carries at most `per_fragment` bytes (at least 1; `None` if `per_fragment` is 0 or the
/// count does not fit the u16 fragments-left field).
pub fn fragment_count(total: usize, per_fragment: usize) -> Option<u16> {
    if per_fragment == 0 {
        return None;
    }
    u16::try_from(total.div_ceil(per_fragment).max(1)).ok()
}

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
    let data_type = entry.data_type();
    let mut number = [0u8; 8];
    let bytes = match *value {
        Value::Str(s) if data_type == DataType::UnicodeString => {
            let n = s.len().min(len / 2);
            for c in s.bytes().take(n) {
                w.push_u16(u16::from(c));
            }
            w.push_zeros(len - n * 2);
            return;
        }
        Value::Str(s) => s.as_bytes(),
        Value::Bytes(b) => b,
        _ => {
            let n = value
                .encode(data_type, entry.bit_len, &mut number)
                .unwrap_or(0);
            number.get(..n).unwrap_or_default()
        }
    };
    let n = bytes.len().min(len);
    w.push(bytes.get(..n).unwrap_or_default());
    w.push_zeros(len - n);
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
                data_type: object.data_type(),
                max_sub_index: object.max_subindex(),
                object_code: object.code().code(),
                name: object.name.as_bytes(),
            }
            .write(w);
        }
        InfoQuery::Entry {
            index,
            subindex,
            value_info,
        } => {
            let (object, entry) = od.entry(index, subindex)?;
            let entry = &object.resolve(entry);
            EntryDescriptionHead {
                index,
                sub_index: subindex,
                value_info: ValueInfo(value_info.0 & entry.value_info()),
                data_type: entry.data_type(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::{SdoInfo, SdoInfoHeaderRepr};

    #[test]
    fn fragments_reassemble_to_the_whole() {
        // OD list response of 40 objects = 2 + 80 bytes, cut into 14-byte fragments.
        let mut list = [0u8; 80];
        for (i, pair) in list.chunks_exact_mut(2).enumerate() {
            pair.copy_from_slice(&(0x2000u16 + i as u16).to_le_bytes());
        }
        let repr = SdoInfoRepr::OdListResponse {
            list_type: OdListType::AllObjects,
            list: &list,
        };
        let total = repr.service_data_len();
        assert_eq!(total, 82);
        let per = 14;
        let count = fragment_count(total, per).unwrap();
        assert_eq!(count, 6);
        let mut whole = [0u8; 82];
        let mut offset = 0;
        for k in 0..count {
            let mut frame = [0xa5u8; 4 + 14];
            let mut p = SdoInfo::new_unchecked(&mut frame[..]);
            let left = count - 1 - k;
            SdoInfoHeaderRepr {
                opcode: repr.opcode(),
                incomplete: left > 0,
                fragments_left: left,
            }
            .emit(&mut p)
            .unwrap();
            let n = emit_fragment(&repr, offset, p.payload_mut()).unwrap();
            assert_eq!(n, per.min(total - offset));
            assert_eq!(frame[0], if left > 0 { 0x82 } else { 0x02 });
            assert_eq!(u16::from_le_bytes([frame[2], frame[3]]), left);
            whole[offset..offset + n].copy_from_slice(&frame[4..4 + n]);
            offset += n;
        }
        assert_eq!(offset, total);
        assert_eq!(whole[..2], [0x01, 0x00]);
        assert_eq!(whole[2..], list);
        assert_eq!(
            SdoInfoRepr::parse_service_data(SdoInfoOpCode::GetOdListResponse, &whole),
            Ok(repr)
        );
        // Past the end nothing is written.
        let mut out = [0xa5u8; 4];
        assert_eq!(emit_fragment(&repr, 82, &mut out), Ok(0));
        assert_eq!(emit_fragment(&repr, 1000, &mut out), Ok(0));
        assert_eq!(out, [0xa5; 4]);
    }

    #[test]
    fn values_fill_exactly_their_entry() {
        let entry = |t, bits| EntryDesc::new(0, "x", t, Access::RO).with_bits(bits);
        let cases: [(EntryDesc, Value, &[u8]); 6] = [
            (
                entry(DataType::UnicodeString, 64),
                Value::Str("AB"),
                b"A\0B\0\0\0\0\0",
            ),
            (
                entry(DataType::UnicodeString, 32),
                Value::Str("ABC"),
                b"A\0B\0",
            ),
            (
                entry(DataType::VisibleString, 32),
                Value::Str("ABCDEF"),
                b"ABCD",
            ),
            (
                entry(DataType::VisibleString, 32),
                Value::Str("AB"),
                b"AB\0\0",
            ),
            (
                entry(DataType::OctetString, 24),
                Value::Bytes(&[1]),
                &[1, 0, 0],
            ),
            (
                entry(DataType::Integer16, 16),
                Value::Int(-2),
                &[0xFE, 0xFF],
            ),
        ];
        for (entry, value, expected) in cases {
            let mut out = [0xA5u8; 16];
            let mut w = FragmentWriter::new(0, &mut out);
            push_value(&mut w, &entry, &value);
            assert_eq!(w.position(), expected.len(), "{value:?}");
            assert_eq!(&out[..expected.len()], expected, "{value:?}");
        }
    }

    #[test]
    fn fragment_writer_windows() {
        let mut out = [0u8; 3];
        let mut w = FragmentWriter::new(2, &mut out);
        w.push(&[1, 2]);
        w.push(&[3]);
        w.push(&[4, 5, 6]);
        assert_eq!(w.position(), 6);
        assert_eq!(w.written(), 3);
        assert_eq!(out, [3, 4, 5]);
        let mut none: [u8; 0] = [];
        let mut w = FragmentWriter::new(usize::MAX, &mut none);
        w.push(&[1; 8]);
        assert_eq!(w.written(), 0);
        // Zeros go through the same window.
        let mut out = [0xa5u8; 3];
        let mut w = FragmentWriter::new(1, &mut out);
        w.push(&[7, 8]);
        w.push_zeros(1);
        w.push(&[9, 9]);
        assert_eq!((w.position(), w.written()), (5, 3));
        assert_eq!(out, [8, 0, 9]);
        let mut out = [0xa5u8; 2];
        let mut w = FragmentWriter::new(3, &mut out);
        w.push_zeros(4);
        assert_eq!((w.position(), w.written()), (4, 1));
        assert_eq!(out, [0, 0xa5]);
        assert_eq!(fragment_count(0, 10), Some(1));
        assert_eq!(fragment_count(10, 0), None);
        assert_eq!(fragment_count(usize::MAX, 1), None);
    }

    /// The u16 path keeps exactly the window the byte path keeps, wherever the window
    /// starts and ends (on a value, inside one, past the stream).
    #[test]
    fn u16_window_is_the_byte_window() {
        let values: [u16; 67] = core::array::from_fn(|i| 0x1000 + i as u16 * 0x0101);
        for skip in 0..140 {
            for len in 0..140 {
                let mut fast = [0xa5u8; 140];
                let mut slow = [0xa5u8; 140];
                let mut f = FragmentWriter::new(skip, &mut fast[..len]);
                let mut s = FragmentWriter::new(skip, &mut slow[..len]);
                for v in values {
                    f.push_u16(v);
                    s.push(&v.to_le_bytes());
                }
                assert_eq!(
                    (f.position(), f.written()),
                    (s.position(), s.written()),
                    "skip {skip}, len {len}"
                );
                assert_eq!(fast, slow, "skip {skip}, len {len}");
            }
        }
    }
}
