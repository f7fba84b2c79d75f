//! PDO mapping (0x1600.., 0x1A00..) and assignment (0x1C12, 0x1C13), their validation against
//! the object dictionary, and bit-exact packing of the process image
//! (ETG.1000.6 5.6.7.4 / CiA 301 7.4.8; ETG.1020 "PDO configuration").
//!
//! A mapping entry is a u32: `index << 16 | subindex << 8 | bit length`. Index 0x0000, or a
//! basic data type index 0x0001..0x0007 with subindex 0, is a gap ("dummy entry"): it takes
//! room in the image but carries no object.
//!
//! The configuration sequence a master uses (ETG.1020): write sub 0 = 0, write the entries,
//! write sub 0 = n. Entries can only be written while sub 0 is 0 (else 0x06010003), and the
//! final write of sub 0 validates the whole mapping (0x06040041, 0x06040042).
//!
//! In the process image, PDOs follow each other in assignment order, entries in mapping order,
//! without alignment; bits are numbered LSB-first within each byte and bytes in ascending
//! address order (EtherCAT order), values are little-endian.

use crate::abort::SdoAbortCode;
use crate::esm::AlState;
use crate::od::{DataType, ObjectAccess, ObjectDictionary};

pub mod runs;
pub use runs::{ImageRun, ImageRuns};

/// Direction of a PDO.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PdoDirection {
    /// RxPDO: master to slave, outputs (mapping objects 0x1600..0x17FF, SM2, 0x1C12).
    Rx,
    /// TxPDO: slave to master, inputs (mapping objects 0x1A00..0x1BFF, SM3, 0x1C13).
    Tx,
}

impl PdoDirection {
    /// The direction of a mapping object index, `None` outside 0x1600..=0x17FF/0x1A00..=0x1BFF.
    pub const fn of_mapping_index(index: u16) -> Option<Self> {
        match index {
            0x1600..=0x17FF => Some(Self::Rx),
            0x1A00..=0x1BFF => Some(Self::Tx),
            _ => None,
        }
    }

    /// The direction of an assignment object index (0x1C12 Rx, 0x1C13 Tx).
    pub const fn of_assignment_index(index: u16) -> Option<Self> {
        match index {
            0x1C12 => Some(Self::Rx),
            0x1C13 => Some(Self::Tx),
            _ => None,
        }
    }
}

/// One mapping entry: `index << 16 | subindex << 8 | bit_len`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoEntry {
    /// Mapped object index (0x0000 or 0x0001..0x0007 for a gap).
    pub index: u16,
    /// Mapped subindex.
    pub subindex: u8,
    /// Length in bits.
    pub bit_len: u8,
}

impl PdoEntry {
    /// An entry.
    pub const fn new(index: u16, subindex: u8, bit_len: u8) -> Self {
        Self {
            index,
            subindex,
            bit_len,
        }
    }

    /// A gap of `bit_len` bits (index 0x0000).
    pub const fn gap(bit_len: u8) -> Self {
        Self::new(0, 0, bit_len)
    }

    /// Decodes the u32 form.
    pub const fn from_u32(raw: u32) -> Self {
        Self {
            index: (raw >> 16) as u16,
            subindex: (raw >> 8) as u8,
            bit_len: raw as u8,
        }
    }

    /// The u32 form.
    pub const fn to_u32(self) -> u32 {
        (self.index as u32) << 16 | (self.subindex as u32) << 8 | self.bit_len as u32
    }

    /// True for a gap: index 0x0000, or a basic data type index 0x0001..=0x0007 with sub 0.
    pub const fn is_gap(&self) -> bool {
        self.index == 0 || (self.index <= 7 && self.subindex == 0)
    }

    /// Checks the entry against the dictionary for a PDO of `direction`:
    /// the object must exist and be mappable that way, and the bit length must be the
    /// entry's; a typed gap must have its type's length. Any failure is 0x06040041.
    pub fn validate(
        &self,
        od: &ObjectDictionary,
        direction: PdoDirection,
    ) -> Result<(), SdoAbortCode> {
        if self.bit_len == 0 {
            return Err(SdoAbortCode::CannotBeMapped);
        }
        if self.index == 0 {
            return Ok(());
        }
        if self.is_gap() {
            return match DataType::from(self.index).bit_len() {
                Some(bits) if bits == u16::from(self.bit_len) => Ok(()),
                _ => Err(SdoAbortCode::CannotBeMapped),
            };
        }
        let (_, entry) = od
            .entry(self.index, self.subindex)
            .map_err(|_| SdoAbortCode::CannotBeMapped)?;
        let mappable = match direction {
            PdoDirection::Rx => entry.access.is_rx_mappable(),
            PdoDirection::Tx => entry.access.is_tx_mappable(),
        };
        if !mappable || entry.bit_len != u16::from(self.bit_len) {
            return Err(SdoAbortCode::CannotBeMapped);
        }
        Ok(())
    }
}

/// Writes a u8 sub 0 value, checking the SDO length.
fn sub0_value(data: &[u8]) -> Result<u8, SdoAbortCode> {
    match data {
        [n] => Ok(*n),
        [] => Err(SdoAbortCode::LengthTooLow),
        _ => Err(SdoAbortCode::LengthTooHigh),
    }
}

fn u32_value(data: &[u8]) -> Result<u32, SdoAbortCode> {
    match data {
        [a, b, c, d] => Ok(u32::from_le_bytes([*a, *b, *c, *d])),
        _ if data.len() < 4 => Err(SdoAbortCode::LengthTooLow),
        _ => Err(SdoAbortCode::LengthTooHigh),
    }
}

fn u16_value(data: &[u8]) -> Result<u16, SdoAbortCode> {
    match data {
        [a, b] => Ok(u16::from_le_bytes([*a, *b])),
        _ if data.len() < 2 => Err(SdoAbortCode::LengthTooLow),
        _ => Err(SdoAbortCode::LengthTooHigh),
    }
}

/// A PDO mapping object (0x16xx or 0x1Axx) with room for `N` entries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoMapping<const N: usize = 8> {
    index: u16,
    count: u8,
    entries: [PdoEntry; N],
}

impl<const N: usize> PdoMapping<N> {
    /// An empty mapping (sub 0 = 0).
    pub const fn new(index: u16) -> Self {
        Self {
            index,
            count: 0,
            entries: [PdoEntry::new(0, 0, 0); N],
        }
    }

    /// A mapping with these entries (a fixed default). Entries beyond `N` are dropped; use
    /// [`PdoMapping::validate`] to check the result against the dictionary.
    pub const fn with_entries(index: u16, entries: &[PdoEntry]) -> Self {
        let mut mapping = Self::new(index);
        let mut rest = entries;
        let mut i = 0;
        while let [entry, tail @ ..] = rest {
            if i < N {
                mapping.entries[i] = *entry;
                i += 1;
            }
            rest = tail;
        }
        mapping.count = if i > 255 { 255 } else { i as u8 };
        mapping
    }

    /// The mapping object index.
    pub const fn index(&self) -> u16 {
        self.index
    }

    /// The direction the index implies (`None` for an index outside the PDO ranges).
    pub const fn direction(&self) -> Option<PdoDirection> {
        PdoDirection::of_mapping_index(self.index)
    }

    /// Sub 0: number of mapped entries.
    pub const fn count(&self) -> u8 {
        self.count
    }

    /// The mapped entries (the first `count`).
    pub fn entries(&self) -> &[PdoEntry] {
        self.entries
            .get(..usize::from(self.count))
            .unwrap_or(&self.entries)
    }

    /// Total length in bits of the mapped entries (gaps included).
    pub fn bit_len(&self) -> u32 {
        self.entries().iter().map(|e| u32::from(e.bit_len)).sum()
    }

    /// Checks every mapped entry against the dictionary (0x06040041 CannotBeMapped) and the
    /// total length against `max_bits` (0x06040042 PdoLengthExceeded).
    pub fn validate(&self, od: &ObjectDictionary, max_bits: u32) -> Result<(), SdoAbortCode> {
        let direction = self.direction().ok_or(SdoAbortCode::CannotBeMapped)?;
        for entry in self.entries() {
            entry.validate(od, direction)?;
        }
        if self.bit_len() > max_bits {
            return Err(SdoAbortCode::PdoLengthExceeded);
        }
        Ok(())
    }

    /// SDO upload of a subindex: sub 0 as one byte, entries as four bytes (little-endian).
    /// Returns the bytes written into `buf`.
    pub fn read_sub(&self, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        if subindex == 0 {
            let out = buf.first_mut().ok_or(SdoAbortCode::OutOfMemory)?;
            *out = self.count;
            return Ok(1);
        }
        let entry = self
            .entries
            .get(usize::from(subindex) - 1)
            .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
        buf.get_mut(..4)
            .ok_or(SdoAbortCode::OutOfMemory)?
            .copy_from_slice(&entry.to_u32().to_le_bytes());
        Ok(4)
    }

    /// SDO download of a subindex, with the ETG.1020 rules:
    /// - sub 1..=N only while sub 0 is 0 (else 0x06010003 SubindexZeroMustBeZero); the entry
    ///   is checked against the dictionary at once (0x06040041);
    /// - sub 0 = n > N: 0x06090031 ValueTooHigh; n > 0 validates entries 1..n and the total
    ///   length against `max_bits` (0x06040041, 0x06040042) before it takes effect;
    /// - wrong data length: 0x06070012/13; subindex beyond N: 0x06090011.
    ///
    /// Whether the mapping may be changed at all in the current state (PREOP only) is the
    /// entry access rights' business, which the SDO server checks before.
    pub fn write_sub(
        &mut self,
        subindex: u8,
        data: &[u8],
        od: &ObjectDictionary,
        max_bits: u32,
    ) -> Result<(), SdoAbortCode> {
        let direction = self.direction().ok_or(SdoAbortCode::CannotBeMapped)?;
        if subindex == 0 {
            let n = sub0_value(data)?;
            if usize::from(n) > N {
                return Err(SdoAbortCode::ValueTooHigh);
            }
            let candidate = Self { count: n, ..*self };
            candidate.validate(od, max_bits)?;
            self.count = n;
            return Ok(());
        }
        let slot = usize::from(subindex) - 1;
        if slot >= N {
            return Err(SdoAbortCode::SubindexDoesNotExist);
        }
        let entry = PdoEntry::from_u32(u32_value(data)?);
        if self.count != 0 {
            return Err(SdoAbortCode::SubindexZeroMustBeZero);
        }
        entry.validate(od, direction)?;
        if let Some(e) = self.entries.get_mut(slot) {
            *e = entry;
        }
        Ok(())
    }
}

/// A PDO assignment object (0x1C12 for SM2/RxPDOs, 0x1C13 for SM3/TxPDOs) with room for `N`
/// PDOs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoAssignment<const N: usize = 4> {
    index: u16,
    count: u8,
    pdos: [u16; N],
}

impl<const N: usize> PdoAssignment<N> {
    /// An empty assignment.
    pub const fn new(index: u16) -> Self {
        Self {
            index,
            count: 0,
            pdos: [0; N],
        }
    }

    /// An assignment of these PDOs (a fixed default; PDOs beyond `N` are dropped).
    pub const fn with_pdos(index: u16, pdos: &[u16]) -> Self {
        let mut assignment = Self::new(index);
        let mut rest = pdos;
        let mut i = 0;
        while let [pdo, tail @ ..] = rest {
            if i < N {
                assignment.pdos[i] = *pdo;
                i += 1;
            }
            rest = tail;
        }
        assignment.count = if i > 255 { 255 } else { i as u8 };
        assignment
    }

    /// The assignment object index.
    pub const fn index(&self) -> u16 {
        self.index
    }

    /// The direction the index implies.
    pub const fn direction(&self) -> Option<PdoDirection> {
        PdoDirection::of_assignment_index(self.index)
    }

    /// Sub 0: number of assigned PDOs.
    pub const fn count(&self) -> u8 {
        self.count
    }

    /// The assigned mapping object indices, in order.
    pub fn pdos(&self) -> &[u16] {
        self.pdos
            .get(..usize::from(self.count))
            .unwrap_or(&self.pdos)
    }

    /// Checks that every assigned PDO is one of `mappings` of the right direction and that
    /// their total length fits `max_bits` (0x06040042). An unknown or wrong-direction PDO
    /// is 0x06090030 ValueRangeExceeded.
    pub fn validate<const M: usize>(
        &self,
        mappings: &[PdoMapping<M>],
        max_bits: u32,
    ) -> Result<(), SdoAbortCode> {
        validate_assigned(self.direction(), self.pdos(), mappings, max_bits)
    }

    /// Total length in bits of the assigned PDOs (unknown PDOs count 0).
    pub fn bit_len<const M: usize>(&self, mappings: &[PdoMapping<M>]) -> u32 {
        let direction = self.direction();
        self.pdos()
            .iter()
            .map(|p| mapping_bits(direction, *p, mappings).unwrap_or(0))
            .sum()
    }

    /// SDO upload of a subindex: sub 0 as one byte, entries as two bytes.
    pub fn read_sub(&self, subindex: u8, buf: &mut [u8]) -> Result<usize, SdoAbortCode> {
        if subindex == 0 {
            let out = buf.first_mut().ok_or(SdoAbortCode::OutOfMemory)?;
            *out = self.count;
            return Ok(1);
        }
        let pdo = self
            .pdos
            .get(usize::from(subindex) - 1)
            .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
        buf.get_mut(..2)
            .ok_or(SdoAbortCode::OutOfMemory)?
            .copy_from_slice(&pdo.to_le_bytes());
        Ok(2)
    }

    /// SDO download of a subindex with the same rules as [`PdoMapping::write_sub`]: entries
    /// only while sub 0 is 0 (0x06010003), each entry must name a PDO of `mappings` in the
    /// right direction (0x06090030), sub 0 = n validates the PDOs and the total length
    /// against `max_bits` (0x06040042).
    pub fn write_sub<const M: usize>(
        &mut self,
        subindex: u8,
        data: &[u8],
        mappings: &[PdoMapping<M>],
        max_bits: u32,
    ) -> Result<(), SdoAbortCode> {
        let direction = self.direction();
        write_assignment_sub(
            &mut self.count,
            &mut self.pdos,
            subindex,
            data,
            &mut |pdo| mapping_bits(direction, pdo, mappings),
            &mut |_| Ok(()),
            max_bits,
        )
    }

    /// [`PdoAssignment::write_sub`] for PDOs that are not all in RAM (fixed mappings of
    /// sample arrays read from the dictionary's defaults): `bits_of(pdo)` gives the length
    /// of a PDO (`None`: no such PDO; one of the other direction is refused first, both
    /// 0x06090030), and `check(pdos)` may refuse a whole assignment when sub 0 is written,
    /// after the length check (e.g.
    /// [`crate::device::oversampling::Oversampling::check_assignment`]).
    pub fn write_sub_with(
        &mut self,
        subindex: u8,
        data: &[u8],
        mut bits_of: impl FnMut(u16) -> Option<u32>,
        mut check: impl FnMut(&[u16]) -> Result<(), SdoAbortCode>,
        max_bits: u32,
    ) -> Result<(), SdoAbortCode> {
        let direction = self.direction();
        let mut bits = |pdo: u16| match PdoDirection::of_mapping_index(pdo) {
            Some(d) if Some(d) == direction => bits_of(pdo).ok_or(SdoAbortCode::ValueRangeExceeded),
            _ => Err(SdoAbortCode::ValueRangeExceeded),
        };
        write_assignment_sub(
            &mut self.count,
            &mut self.pdos,
            subindex,
            data,
            &mut bits,
            &mut check,
            max_bits,
        )
    }
}

// The checks and downloads of an assignment do not depend on its capacity nor on where the
// mappings are: one copy in a program with assignments of several sizes (cold code, run
// when a master configures the process data).
fn write_assignment_sub(
    count: &mut u8,
    pdos: &mut [u16],
    subindex: u8,
    data: &[u8],
    bits: &mut dyn FnMut(u16) -> Result<u32, SdoAbortCode>,
    check: &mut dyn FnMut(&[u16]) -> Result<(), SdoAbortCode>,
    max_bits: u32,
) -> Result<(), SdoAbortCode> {
    if subindex == 0 {
        let n = sub0_value(data)?;
        let assigned = pdos
            .get(..usize::from(n))
            .ok_or(SdoAbortCode::ValueTooHigh)?;
        let mut total = 0u32;
        for pdo in assigned {
            total += bits(*pdo)?;
        }
        if total > max_bits {
            return Err(SdoAbortCode::PdoLengthExceeded);
        }
        check(assigned)?;
        *count = n;
        return Ok(());
    }
    let slot = pdos
        .get_mut(usize::from(subindex) - 1)
        .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
    let pdo = u16_value(data)?;
    if *count != 0 {
        return Err(SdoAbortCode::SubindexZeroMustBeZero);
    }
    bits(pdo)?;
    *slot = pdo;
    Ok(())
}

#[inline(never)]
fn validate_assigned<const M: usize>(
    direction: Option<PdoDirection>,
    pdos: &[u16],
    mappings: &[PdoMapping<M>],
    max_bits: u32,
) -> Result<(), SdoAbortCode> {
    let mut total = 0u32;
    for pdo in pdos {
        total += mapping_bits(direction, *pdo, mappings)?;
    }
    if total > max_bits {
        return Err(SdoAbortCode::PdoLengthExceeded);
    }
    Ok(())
}

/// The length of mapping `pdo` if `mappings` holds it in `direction` (else 0x06090030).
fn mapping_bits<const M: usize>(
    direction: Option<PdoDirection>,
    pdo: u16,
    mappings: &[PdoMapping<M>],
) -> Result<u32, SdoAbortCode> {
    mappings
        .iter()
        .find(|m| m.index() == pdo && m.direction() == direction)
        .map(|m| m.bit_len())
        .ok_or(SdoAbortCode::ValueRangeExceeded)
}

/// One mapped object's place in the process image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageField {
    /// Object index.
    pub index: u16,
    /// Subindex.
    pub subindex: u8,
    /// Length in bits (1..=64).
    pub bit_len: u8,
    /// Bit offset from the start of the image.
    pub bit_offset: u32,
}

/// The layout of one direction's process image: where each mapped object sits, gaps
/// skipped. Built once from the assignment and the mappings (at PREOP -> SAFEOP), then used
/// every cycle to pack inputs or unpack outputs. Room for `N` mapped objects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageLayout<const N: usize = 32> {
    fields: [ImageField; N],
    count: usize,
    bit_len: u32,
}

impl<const N: usize> Default for ImageLayout<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ImageLayout<N> {
    /// An empty layout (no process data).
    pub const fn new() -> Self {
        Self {
            fields: [ImageField {
                index: 0,
                subindex: 0,
                bit_len: 0,
                bit_offset: 0,
            }; N],
            count: 0,
            bit_len: 0,
        }
    }

    /// Lays out the PDOs of `assignment` in order. Errors: an assigned PDO that is not in
    /// `mappings` (0x06090030), more than `N` mapped objects (0x06040042), an entry longer
    /// than 64 bits (0x06040041).
    pub fn build<const A: usize, const M: usize>(
        assignment: &PdoAssignment<A>,
        mappings: &[PdoMapping<M>],
    ) -> Result<Self, SdoAbortCode> {
        Self::of_pdos(assignment.pdos(), mappings)
    }

    // Not inlined into `build`: one copy for assignments of every capacity (cold code, run
    // when the process data is set up).
    #[inline(never)]
    fn of_pdos<const M: usize>(
        pdos: &[u16],
        mappings: &[PdoMapping<M>],
    ) -> Result<Self, SdoAbortCode> {
        let mut layout = Self::new();
        for pdo in pdos {
            let mapping = mappings
                .iter()
                .find(|m| m.index() == *pdo)
                .ok_or(SdoAbortCode::ValueRangeExceeded)?;
            layout.append(mapping)?;
        }
        Ok(layout)
    }

    /// The layout of one PDO on its own (a CAN PDO is one mapping, no assignment). Errors
    /// as [`ImageLayout::build`].
    pub fn of_mapping<const M: usize>(mapping: &PdoMapping<M>) -> Result<Self, SdoAbortCode> {
        let mut layout = Self::new();
        layout.append(mapping)?;
        Ok(layout)
    }

    /// Lays out the entries of `mapping` after what is there. Generic in the capacity on
    /// purpose: a CAN TPDO lays its PDO out at every transmission, and a copy per capacity
    /// keeps that inline (a shared non-generic copy is 64 B smaller and slows the CAN task).
    fn append<const M: usize>(&mut self, mapping: &PdoMapping<M>) -> Result<(), SdoAbortCode> {
        for entry in mapping.entries() {
            if !entry.is_gap() {
                if entry.bit_len > 64 {
                    return Err(SdoAbortCode::CannotBeMapped);
                }
                let field = self
                    .fields
                    .get_mut(self.count)
                    .ok_or(SdoAbortCode::PdoLengthExceeded)?;
                *field = ImageField {
                    index: entry.index,
                    subindex: entry.subindex,
                    bit_len: entry.bit_len,
                    bit_offset: self.bit_len,
                };
                self.count += 1;
            }
            self.bit_len += u32::from(entry.bit_len);
        }
        Ok(())
    }

    /// The mapped objects in image order.
    pub fn fields(&self) -> &[ImageField] {
        self.fields.get(..self.count).unwrap_or(&self.fields)
    }

    /// Image length in bits.
    pub const fn bit_len(&self) -> u32 {
        self.bit_len
    }

    /// Image length in bytes (`ceil(bits / 8)`, the SyncManager length).
    pub const fn byte_len(&self) -> usize {
        (self.bit_len as usize).div_ceil(8)
    }

    /// Packs the inputs: reads every mapped object through `app` and writes it into `image`
    /// at its bit offset. Gap bits keep what `image` held. Errors: `image` shorter than the
    /// layout (0x06040042) or whatever `app.read` returns.
    pub fn pack<A: ObjectAccess + ?Sized>(
        &self,
        app: &mut A,
        image: &mut [u8],
    ) -> Result<(), SdoAbortCode> {
        if image.len() < self.byte_len() {
            return Err(SdoAbortCode::PdoLengthExceeded);
        }
        for field in self.fields() {
            let mut value = [0u8; 8];
            app.read(field.index, field.subindex, &mut value)?;
            write_bits(image, field.bit_offset, field.bit_len, &value);
        }
        Ok(())
    }

    /// Unpacks the outputs: extracts every mapped object from `image` and hands its
    /// little-endian value (`ceil(bits / 8)` bytes) to `app.write`. Errors: `image` shorter
    /// than the layout (0x06040042) or the first error `app.write` returns.
    pub fn unpack<A: ObjectAccess + ?Sized>(
        &self,
        image: &[u8],
        app: &mut A,
        state: AlState,
    ) -> Result<(), SdoAbortCode> {
        if image.len() < self.byte_len() {
            return Err(SdoAbortCode::PdoLengthExceeded);
        }
        for field in self.fields() {
            let mut value = [0u8; 8];
            read_bits(image, field.bit_offset, field.bit_len, &mut value);
            let len = usize::from(field.bit_len).div_ceil(8);
            let bytes = value.get(..len).unwrap_or(&value);
            app.write(field.index, field.subindex, bytes, state)?;
        }
        Ok(())
    }
}

/// Writes the low `bit_len` bits of the little-endian `value` into `image` starting at
/// `bit_offset` (LSB-first within bytes). Bits outside `image` or beyond `value` are ignored.
pub fn write_bits(image: &mut [u8], bit_offset: u32, bit_len: u8, value: &[u8]) {
    let offset = bit_offset as usize;
    let len = usize::from(bit_len);
    if offset % 8 == 0 && len % 8 == 0 {
        let start = offset / 8;
        let n = (len / 8).min(value.len());
        if let (Some(dst), Some(src)) = (image.get_mut(start..start + n), value.get(..n)) {
            dst.copy_from_slice(src);
            return;
        }
    }
    for i in 0..len {
        let bit = value.get(i / 8).map_or(0, |b| (b >> (i % 8)) & 1);
        let Some(pos) = offset.checked_add(i) else {
            break; // beyond any image (a 32-bit target, an offset near u32::MAX)
        };
        if let Some(byte) = image.get_mut(pos / 8) {
            let mask = 1u8 << (pos % 8);
            if bit != 0 {
                *byte |= mask;
            } else {
                *byte &= !mask;
            }
        }
    }
}

/// Reads `bit_len` bits from `image` starting at `bit_offset` into the little-endian `value`
/// (zero-extended: bits above `bit_len` in the last byte are cleared).
pub fn read_bits(image: &[u8], bit_offset: u32, bit_len: u8, value: &mut [u8]) {
    let offset = bit_offset as usize;
    let len = usize::from(bit_len);
    let used = len.div_ceil(8);
    if let Some(v) = value.get_mut(..used) {
        v.fill(0);
    }
    if offset % 8 == 0 && len % 8 == 0 {
        let start = offset / 8;
        if let (Some(src), Some(dst)) = (image.get(start..start + used), value.get_mut(..used)) {
            dst.copy_from_slice(src);
            return;
        }
    }
    for i in 0..len {
        let Some(pos) = offset.checked_add(i) else {
            break; // beyond any image, as above
        };
        let bit = image.get(pos / 8).map_or(0, |b| (b >> (pos % 8)) & 1);
        if let Some(byte) = value.get_mut(i / 8) {
            *byte |= bit << (i % 8);
        }
    }
}
