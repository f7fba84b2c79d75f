//! SDO complete access (ETG.1000.6 5.6.2.1.2 / 5.6.2.4.2; ETG.1020 12.2): the whole object as
//! one byte image.
//!
//! Layout rules (the same as SOES `complete_access_subindex_loop` and the Beckhoff SSC):
//! - a transfer starts at subindex 0 (sub 0 included) or subindex 1 (sub 0 left out);
//! - sub 0 of an ARRAY/RECORD takes 16 bits: its UNSIGNED8 value and one padding byte;
//! - entries whose length is a multiple of 8 bits start at the next byte boundary;
//!   BOOLEAN/BITn entries are packed bit by bit, LSB first, right after the previous entry;
//! - only entries up to the object's current sub 0 value take part; subindices the
//!   description does not have (gaps in a RECORD) take no room;
//! - objects with strings or DOMAIN entries cannot be accessed completely (0x06010004);
//! - an upload gives zeros for entries that are not readable in the current state; a
//!   download skips entries that are not writable.

use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::od::{EntryDesc, ObjectAccess, ObjectCode, ObjectDesc};
use crate::pdo::{read_bits, write_bits};

/// Largest entry a complete access handles (64-bit types).
const MAX_ENTRY: usize = 8;

/// Largest image a complete download can put back when the application refuses it halfway
/// (kept on the stack meanwhile; a PDO mapping of 8 entries is 34 bytes).
const MAX_ROLLBACK: usize = 128;

/// The entries that take part and their bit offsets in the image (also the ESI's
/// `BitSize`/`BitOffs`, [`crate::esi`], so both describe the same image).
pub(crate) struct Layout<'a> {
    object: &'a ObjectDesc,
    start: u8,
    count: u8,
}

impl<'a> Layout<'a> {
    /// The image of every entry of `object` (from subindex 0, all subindices).
    pub(crate) fn whole(object: &'a ObjectDesc) -> Self {
        Self {
            object,
            start: 0,
            count: u8::MAX,
        }
    }

    pub(crate) fn entries(&self) -> Entries {
        Entries {
            entries: self.object.entries.iter(),
            is_var: self.object.code() == ObjectCode::Var,
            start: self.start,
            count: self.count,
            end: 0,
        }
    }

    /// Bits up to the end of the last entry.
    pub(crate) fn bits(&self) -> u32 {
        let mut entries = self.entries();
        entries.by_ref().for_each(drop);
        entries.end
    }

    fn byte_len(&self) -> usize {
        self.bits().div_ceil(8) as usize
    }
}

/// The entries of a [`Layout`] with their bit offsets.
pub(crate) struct Entries {
    entries: core::slice::Iter<'static, EntryDesc>,
    is_var: bool,
    start: u8,
    count: u8,
    /// Bits up to the end of the entries given so far.
    end: u32,
}

impl Iterator for Entries {
    type Item = (&'static EntryDesc, u32);

    // Out of line (cold: complete access only): the uploads, the downloads and the image
    // length share one copy.
    #[inline(never)]
    fn next(&mut self) -> Option<Self::Item> {
        let (start, count, is_var) = (self.start, self.count, self.is_var);
        let e = self
            .entries
            .find(|e| e.subindex >= start && (is_var || e.subindex <= count))?;
        if e.bit_len % 8 == 0 && self.end % 8 != 0 {
            self.end += 8 - self.end % 8;
        }
        let offset = self.end;
        self.end += entry_bits(is_var, e);
        Some((e, offset))
    }
}

/// Bits `entry` takes in the image: sub 0 of an ARRAY/RECORD is padded to 16 bits.
fn entry_bits(is_var: bool, entry: &EntryDesc) -> u32 {
    if entry.subindex == 0 && !is_var {
        16
    } else {
        u32::from(entry.bit_len)
    }
}

pub(crate) fn check_start(object: &ObjectDesc, start: u8) -> Result<(), SdoAbortCode> {
    let allowed = match object.code() {
        ObjectCode::Var => start == 0,
        ObjectCode::Array | ObjectCode::Record => start <= 1,
    };
    if !allowed {
        return Err(SdoAbortCode::UnsupportedAccess);
    }
    if object
        .entries
        .iter()
        .any(|e| e.data_type().is_variable_length() || e.byte_len() > MAX_ENTRY)
    {
        return Err(SdoAbortCode::CompleteAccessVariableLength);
    }
    Ok(())
}

/// The current sub 0 value of an ARRAY/RECORD (the number of entries that take part).
fn current_count<A: ObjectAccess + ?Sized>(
    object: &ObjectDesc,
    app: &mut A,
) -> Result<u8, SdoAbortCode> {
    if object.code() == ObjectCode::Var {
        return Ok(0);
    }
    let mut value = [0u8; 1];
    app.read(object.index, 0, &mut value)?;
    Ok(value[0])
}

/// Reads the whole object into `out`; returns the image length.
pub(crate) fn upload<A: ObjectAccess + ?Sized>(
    object: &ObjectDesc,
    start: u8,
    app: &mut A,
    state: AlState,
    out: &mut [u8],
) -> Result<usize, SdoAbortCode> {
    check_start(object, start)?;
    let count = current_count(object, app)?;
    let layout = Layout {
        object,
        start,
        count,
    };
    let len = layout.byte_len();
    let image = out.get_mut(..len).ok_or(SdoAbortCode::OutOfMemory)?;
    image.fill(0);
    for (entry, offset) in layout.entries() {
        if !entry.access.readable_in(state) {
            continue;
        }
        let mut value = [0u8; MAX_ENTRY];
        let n = app.read(object.index, entry.subindex, &mut value)?;
        let readable_bits = u8::try_from(n.saturating_mul(8)).unwrap_or(u8::MAX);
        let bits = u8::try_from(entry.bit_len).unwrap_or(64).min(readable_bits);
        write_bits(image, offset, bits, &value);
    }
    Ok(len)
}

/// Writes the whole object from `data`. If the application refuses a write halfway (an
/// entry it cannot map, a mapping too long for its SyncManager, after ETG.1020's sub 0 = 0),
/// the object is written back as it was: an abort changes nothing. That needs the old image
/// read first, so it holds for images up to [`MAX_ROLLBACK`] bytes; an entry that cannot be
/// read in this state (write-only) stays as written.
pub(crate) fn download<A: ObjectAccess + ?Sized>(
    object: &ObjectDesc,
    start: u8,
    data: &[u8],
    app: &mut A,
    state: AlState,
) -> Result<(), SdoAbortCode> {
    let mut saved = [0u8; MAX_ROLLBACK];
    let old = upload(object, start, app, state, &mut saved).ok();
    let mut wrote = false;
    let written = write(object, start, data, app, state, &mut wrote, false);
    if let (Err(_), true, Some(n)) = (written, wrote, old) {
        // The old image was accepted before: nothing to report if it is refused now.
        let old = saved.get(..n).unwrap_or(&[]);
        let _ = write(object, start, old, app, state, &mut wrote, true);
    }
    written
}

/// [`download`] without the way back; `wrote` is set once the first write is made. With
/// `restore` (`data` is what [`upload`] read) the entries that cannot be read are left out.
fn write<A: ObjectAccess + ?Sized>(
    object: &ObjectDesc,
    start: u8,
    data: &[u8],
    app: &mut A,
    state: AlState,
    wrote: &mut bool,
    restore: bool,
) -> Result<(), SdoAbortCode> {
    check_start(object, start)?;
    let is_var = object.code() == ObjectCode::Var;
    // Access first: nothing writable at all, or nothing writable in this state.
    let in_scope = || object.entries.iter().filter(move |e| e.subindex >= start);
    if !in_scope().any(|e| e.access.writable_in(state)) {
        return Err(if in_scope().any(|e| e.access.is_writable()) {
            SdoAbortCode::DeviceState
        } else {
            SdoAbortCode::WriteOfReadOnly
        });
    }
    let sub0 = object.entry(0).filter(|_| !is_var);
    let sub0_writable = sub0.is_some_and(|e| e.access.writable_in(state));
    // The number of entries: the new sub 0 value when the image carries a writable sub 0,
    // else the current one.
    let count = if start == 0 && sub0_writable {
        let n = *data.first().ok_or(SdoAbortCode::LengthTooLow)?;
        if n > object.max_subindex() {
            return Err(SdoAbortCode::ValueTooHigh);
        }
        n
    } else {
        current_count(object, app)?
    };
    let layout = Layout {
        object,
        start,
        count,
    };
    let expected = layout.byte_len();
    if data.len() < expected {
        return Err(SdoAbortCode::LengthTooLow);
    }
    if data.len() > expected {
        return Err(SdoAbortCode::LengthTooHigh);
    }
    // Check everything before anything is written.
    let mut any_writable = false;
    for (entry, offset) in layout.entries() {
        if !entry.access.writable_in(state) {
            continue;
        }
        any_writable = true;
        if entry.subindex != 0 || is_var {
            let mut value = [0u8; MAX_ENTRY];
            read_bits(data, offset, entry.bit_len as u8, &mut value);
            entry.check_range(&value)?;
            if state == AlState::Op && app.is_rx_mapped(object.index, entry.subindex) {
                return Err(SdoAbortCode::MappedToRxPdo);
            }
        }
    }
    if !any_writable {
        return Err(SdoAbortCode::DeviceState);
    }
    // ETG.1020 order: sub 0 = 0, the entries, sub 0 = n.
    *wrote = true;
    let write_sub0 = start == 0 && sub0_writable;
    if write_sub0 {
        app.write(object.index, 0, &[0], state)?;
    }
    for (entry, offset) in layout.entries() {
        if entry.subindex == 0 && !is_var {
            continue;
        }
        if !entry.access.writable_in(state) || (restore && !entry.access.readable_in(state)) {
            continue;
        }
        let mut value = [0u8; MAX_ENTRY];
        read_bits(data, offset, entry.bit_len as u8, &mut value);
        let bytes = value.get(..entry.byte_len()).unwrap_or(&value);
        app.write(object.index, entry.subindex, bytes, state)?;
    }
    if write_sub0 {
        app.write(object.index, 0, &[count], state)?;
    }
    Ok(())
}
