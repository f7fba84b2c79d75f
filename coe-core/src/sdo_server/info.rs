//! SDO Information service responses (ETG.1000.6 5.6.3) generated as a byte stream from the
//! object dictionary description, so a response of any length can be cut into fragments
//! without a buffer: each fragment regenerates the stream and keeps its own window of it.

use crate::abort::SdoAbortCode;
use crate::od::{Access, EntryDesc, ObjectDictionary, Value};

/// What an SDO Information request asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum InfoQuery {
    /// Get OD List with this list type (0 = counts, 1 all, 2 RxPDO, 3 TxPDO, 4 backup,
    /// 5 settings).
    OdList(u16),
    /// Get Object Description.
    Object(u16),
    /// Get Entry Description with the requested value info bits.
    Entry {
        index: u16,
        subindex: u8,
        value_info: u8,
    },
}

impl InfoQuery {
    /// The response opcode (2, 4 or 6).
    pub(crate) fn response_opcode(&self) -> u8 {
        match self {
            Self::OdList(_) => 0x02,
            Self::Object(_) => 0x04,
            Self::Entry { .. } => 0x06,
        }
    }
}

/// A window onto the response stream: bytes before `skip` and beyond `out` are counted
/// but dropped.
struct Window<'a> {
    skip: usize,
    out: &'a mut [u8],
    pos: usize,
}

impl Window<'_> {
    fn push(&mut self, bytes: &[u8]) {
        for b in bytes {
            if let Some(rel) = self.pos.checked_sub(self.skip) {
                if let Some(slot) = self.out.get_mut(rel) {
                    *slot = *b;
                }
            }
            self.pos += 1;
        }
    }

    fn push_zeros(&mut self, n: usize) {
        for _ in 0..n {
            self.push(&[0]);
        }
    }

    fn written(&self) -> usize {
        self.pos.saturating_sub(self.skip).min(self.out.len())
    }
}

/// The list-type filter of Get OD List (ETG.1000.6 table 43).
fn in_list(list_type: u16, access_any: impl Fn(u16) -> bool) -> bool {
    match list_type {
        1 => true,
        2 => access_any(Access::RXPDO),
        3 => access_any(Access::TXPDO),
        4 => access_any(Access::BACKUP),
        5 => access_any(Access::SETTINGS),
        _ => false,
    }
}

fn push_value(w: &mut Window<'_>, entry: &EntryDesc, value: &Value) {
    let len = entry.byte_len();
    match *value {
        Value::Str(_) | Value::Bytes(_) => {
            let n = value.encoded_len(entry.data_type, entry.bit_len).min(len);
            match *value {
                Value::Str(s) if entry.data_type == crate::od::DataType::UnicodeString => {
                    for c in s.bytes().take(n / 2) {
                        w.push(&u16::from(c).to_le_bytes());
                    }
                    w.push_zeros(len - (n / 2) * 2);
                    return;
                }
                Value::Str(s) => w.push(s.as_bytes().get(..n).unwrap_or_default()),
                Value::Bytes(b) => w.push(b.get(..n).unwrap_or_default()),
                _ => {}
            }
            w.push_zeros(len - n);
        }
        _ => {
            let mut buf = [0u8; 8];
            let n = value
                .encode(entry.data_type, entry.bit_len, &mut buf)
                .unwrap_or(0);
            w.push(buf.get(..n.min(len)).unwrap_or_default());
            w.push_zeros(len.saturating_sub(n));
        }
    }
}

/// Generates the response data (everything after the 4-byte SDO Information header).
fn generate(
    query: &InfoQuery,
    od: &ObjectDictionary,
    w: &mut Window<'_>,
) -> Result<(), SdoAbortCode> {
    match *query {
        InfoQuery::OdList(list_type) => {
            if list_type > 5 {
                return Err(SdoAbortCode::UnsupportedAccess);
            }
            w.push(&list_type.to_le_bytes());
            if list_type == 0 {
                for t in 1..=5u16 {
                    let n = od
                        .iter()
                        .filter(|o| in_list(t, |mask| o.any_entry_has(mask)))
                        .count();
                    w.push(&u16::try_from(n).unwrap_or(u16::MAX).to_le_bytes());
                }
            } else {
                for object in od.iter() {
                    if in_list(list_type, |mask| object.any_entry_has(mask)) {
                        w.push(&object.index.to_le_bytes());
                    }
                }
            }
        }
        InfoQuery::Object(index) => {
            let object = od.find(index).ok_or(SdoAbortCode::ObjectDoesNotExist)?;
            w.push(&index.to_le_bytes());
            w.push(&object.data_type.code().to_le_bytes());
            w.push(&[object.max_subindex(), object.code.code()]);
            w.push(object.name.as_bytes());
        }
        InfoQuery::Entry {
            index,
            subindex,
            value_info,
        } => {
            let (_, entry) = od.entry(index, subindex)?;
            let info = value_info & entry.value_info();
            w.push(&index.to_le_bytes());
            w.push(&[subindex, info]);
            w.push(&entry.data_type.code().to_le_bytes());
            w.push(&entry.bit_len.to_le_bytes());
            w.push(&entry.access.bits().to_le_bytes());
            if info & 0x08 != 0 {
                w.push(&entry.unit.unwrap_or(0).to_le_bytes());
            }
            if info & 0x10 != 0 {
                push_value(w, entry, &entry.default);
            }
            if info & 0x20 != 0 {
                push_value(w, entry, &entry.min);
            }
            if info & 0x40 != 0 {
                push_value(w, entry, &entry.max);
            }
            w.push(entry.name.as_bytes());
        }
    }
    Ok(())
}

/// Length of the whole response data, or the abort code of an SDO Information error.
pub(crate) fn stream_len(query: &InfoQuery, od: &ObjectDictionary) -> Result<usize, SdoAbortCode> {
    let mut w = Window {
        skip: 0,
        out: &mut [],
        pos: 0,
    };
    generate(query, od, &mut w)?;
    Ok(w.pos)
}

/// Copies the response data from byte `skip` into `out`; returns the bytes written.
pub(crate) fn stream_chunk(
    query: &InfoQuery,
    od: &ObjectDictionary,
    skip: usize,
    out: &mut [u8],
) -> usize {
    let mut w = Window { skip, out, pos: 0 };
    match generate(query, od, &mut w) {
        Ok(()) => w.written(),
        Err(_) => 0,
    }
}
