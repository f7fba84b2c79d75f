//! The object dictionary model (CiA 301 / ETG.1000.6 5.6): a constant, static description of
//! every object and entry, from which the SDO server, the ESI XML and the SII image are all
//! generated, plus the [`ObjectAccess`] trait through which the application supplies values.
//!
//! The firmware describes its dictionary once:
//!
//! ```
//! use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, Value};
//!
//! static OD: ObjectDictionary = ObjectDictionary::new(&[
//!     ObjectDesc::var(0x1000, "Device type", &[
//!         EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
//!             .with_default(Value::Uint(0x000C_0191)),
//!     ]),
//!     ObjectDesc::var(0x1008, "Device name", &[EntryDesc::string(0, "Device name", "DAC")]),
//!     ObjectDesc::array(0x6401, "Read analog input 16-bit", &[
//!         EntryDesc::count(2),
//!         EntryDesc::new(1, "Channel 1", DataType::Integer16, Access::RO.tx_mappable()),
//!         EntryDesc::new(2, "Channel 2", DataType::Integer16, Access::RO.tx_mappable()),
//!     ]),
//! ]);
//! // Checked at compile time:
//! const _: () = if let Err(e) = OD.validate() { panic!("{}", e.message()) };
//! assert_eq!(OD.entry(0x6401, 2).map(|(_, e)| e.bit_len), Ok(16));
//! ```

mod access;
mod store;
mod types;
mod value;

pub use access::ObjectAccess;
pub use store::{OdStore, StoreError};
pub use types::{Access, DataType, EsiTypeName, ObjectCode};
pub use value::{check_range, decode_int, decode_real, int_limits, Value};

use crate::abort::SdoAbortCode;
use crate::wire::ValueInfo;
use core::fmt;

/// One entry (subindex) of an object: type, length, access, limits and the name the SDO
/// Information service and the ESI file show.
///
/// The layout is kept small because the firmware's dictionary lives in its flash budget:
/// the default is stored in a 4-byte-aligned packed form that also carries the unit flag
/// and, for an entry with limits, the reference to its minimum and maximum (with the default
/// as a 32-bit number beside it), and the data type is its one-byte code, so an entry takes
/// 28 bytes on a 32-bit target instead of 72. Read them through [`EntryDesc::data_type`],
/// [`EntryDesc::default`], [`EntryDesc::min`], [`EntryDesc::max`] and [`EntryDesc::unit`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EntryDesc {
    /// Subindex (0 for a VAR).
    pub subindex: u8,
    /// Entry name.
    pub name: &'static str,
    /// Data type code ([`EntryDesc::data_type`]): one byte holds every type an entry can
    /// have (ETG.1000.6's codes above 0xFF are array types an entry cannot describe).
    type_code: u8,
    /// Length in bits; for strings and OCTET_STRING the maximum length (8 bits per byte).
    /// A DOMAIN may give 0: its length is whatever the application reads or accepts.
    pub bit_len: u16,
    /// Access rights and PDO/backup/settings flags.
    pub access: Access,
    /// Unit type, valid if the default's unit flag is set (see [`EntryDesc::unit`]).
    unit: u16,
    /// Default value, unit flag and limits (see [`EntryDesc::default`],
    /// [`EntryDesc::range`]).
    default: PackedValue,
}

// The firmware's dictionary sits in its flash budget: an entry stays at 28 bytes on a
// 32-bit target (checked when building for one).
#[cfg(target_pointer_width = "32")]
const _: () = assert!(core::mem::size_of::<EntryDesc>() <= 28);

/// The minimum and maximum of an entry (ESI `MinValue`/`MaxValue`, SDO Information value
/// info 0x20/0x40); writes outside them are refused. Given by reference so that entries
/// without limits (most of them) do not carry two empty values:
/// `.with_range(&ValueRange { min: Value::Int(0), max: Value::Int(10) })`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ValueRange {
    /// Minimum value; [`Value::None`] for no lower limit.
    pub min: Value,
    /// Maximum value; [`Value::None`] for no upper limit.
    pub max: Value,
}

impl ValueRange {
    /// A range from `min` to `max` (both inclusive).
    pub const fn new(min: Value, max: Value) -> Self {
        Self { min, max }
    }
}

/// A [`Value`] as stored in an [`EntryDesc`], with the entry's "has a unit type" flag and its
/// limits: 64-bit numbers as two 32-bit halves, so the entry needs only 4-byte alignment (an
/// `i64`/`f64` payload forces 8-byte alignment and padding on Cortex-M), the flag in the byte
/// after the tag that would otherwise be padding (the unit itself is [`EntryDesc`]'s `unit`),
/// and an entry with limits as their reference plus its default in 32 bits ([`Small`]), in
/// the same 12 bytes. Converted losslessly both ways; a default that a limited entry cannot
/// hold is kept as [`Small::TooWide`] for [`ObjectDictionary::validate`] to refuse.
#[derive(Debug, Clone, Copy)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum PackedValue {
    None(bool),
    Int(bool, [u32; 2]),
    Uint(bool, [u32; 2]),
    Real(bool, [u32; 2]),
    Str(bool, &'static str),
    Bytes(bool, &'static [u8]),
    Limited {
        unit: bool,
        kind: Small,
        bits: u32,
        range: &'static ValueRange,
    },
}

/// The kind of a limited entry's default, whose 32 bits [`PackedValue::Limited`] holds: an
/// `Int` within `i32`, a `Uint` within `u32`, a `Real` whose low 32 bits are zero (1.5, 0.25,
/// 4.0, ...: the upper half is kept).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Small {
    None,
    Int,
    Uint,
    Real,
    /// A default of more than 32 bits (or a string) given to an entry with limits.
    TooWide,
}

impl Small {
    const fn pack(value: Value) -> (Self, u32) {
        match value {
            Value::None => (Self::None, 0),
            Value::Int(v) if v >= i32::MIN as i64 && v <= i32::MAX as i64 => (Self::Int, v as u32),
            Value::Uint(v) if v <= u32::MAX as u64 => (Self::Uint, v as u32),
            Value::Real(v) if v.to_bits() as u32 == 0 => (Self::Real, (v.to_bits() >> 32) as u32),
            _ => (Self::TooWide, 0),
        }
    }

    const fn unpack(self, bits: u32) -> Value {
        match self {
            Self::None | Self::TooWide => Value::None,
            Self::Int => Value::Int(bits as i32 as i64),
            Self::Uint => Value::Uint(bits as u64),
            Self::Real => Value::Real(f64::from_bits((bits as u64) << 32)),
        }
    }
}

impl PackedValue {
    const fn split(bits: u64) -> [u32; 2] {
        [bits as u32, (bits >> 32) as u32]
    }

    const fn join(halves: [u32; 2]) -> u64 {
        halves[0] as u64 | (halves[1] as u64) << 32
    }

    /// `value` with the unit flag, limited by `range` if given.
    const fn pack(value: Value, unit: bool, range: Option<&'static ValueRange>) -> Self {
        if let Some(range) = range {
            let (kind, bits) = Small::pack(value);
            return Self::Limited {
                unit,
                kind,
                bits,
                range,
            };
        }
        match value {
            Value::None => Self::None(unit),
            Value::Int(v) => Self::Int(unit, Self::split(v as u64)),
            Value::Uint(v) => Self::Uint(unit, Self::split(v)),
            Value::Real(v) => Self::Real(unit, Self::split(v.to_bits())),
            Value::Str(s) => Self::Str(unit, s),
            Value::Bytes(b) => Self::Bytes(unit, b),
        }
    }

    /// `Value::Uint(value)` in place of the value, unit flag and limits kept (an object's
    /// own default, [`ObjectDesc::resolve`]).
    const fn with_uint(self, value: u32) -> Self {
        match self {
            Self::Limited { unit, range, .. } => Self::Limited {
                unit,
                kind: Small::Uint,
                bits: value,
                range,
            },
            _ => Self::Uint(self.has_unit(), [value, 0]),
        }
    }

    /// The same value with another unit flag or limits (a default a limited entry could
    /// not hold stays refused).
    const fn repack(self, unit: bool, range: Option<&'static ValueRange>) -> Self {
        match (self.lost_default(), range) {
            (true, Some(range)) => Self::Limited {
                unit,
                kind: Small::TooWide,
                bits: 0,
                range,
            },
            _ => Self::pack(self.unpack(), unit, range),
        }
    }

    const fn unpack(self) -> Value {
        match self {
            Self::None(_) => Value::None,
            Self::Int(_, h) => Value::Int(Self::join(h) as i64),
            Self::Uint(_, h) => Value::Uint(Self::join(h)),
            Self::Real(_, h) => Value::Real(f64::from_bits(Self::join(h))),
            Self::Str(_, s) => Value::Str(s),
            Self::Bytes(_, b) => Value::Bytes(b),
            Self::Limited { kind, bits, .. } => kind.unpack(bits),
        }
    }

    const fn has_unit(self) -> bool {
        match self {
            Self::None(u)
            | Self::Int(u, _)
            | Self::Uint(u, _)
            | Self::Real(u, _)
            | Self::Str(u, _)
            | Self::Bytes(u, _)
            | Self::Limited { unit: u, .. } => u,
        }
    }

    const fn range(self) -> Option<&'static ValueRange> {
        match self {
            Self::Limited { range, .. } => Some(range),
            _ => None,
        }
    }

    /// True if a default was given that a limited entry cannot hold.
    const fn lost_default(self) -> bool {
        matches!(
            self,
            Self::Limited {
                kind: Small::TooWide,
                ..
            }
        )
    }
}

impl PartialEq for PackedValue {
    fn eq(&self, other: &Self) -> bool {
        self.unpack() == other.unpack()
            && self.has_unit() == other.has_unit()
            && self.range() == other.range()
            && self.lost_default() == other.lost_default()
    }
}

impl EntryDesc {
    /// An entry of a fixed-size type with the type's bit length and no value info.
    pub const fn new(
        subindex: u8,
        name: &'static str,
        data_type: DataType,
        access: Access,
    ) -> Self {
        let bit_len = match data_type.bit_len() {
            Some(bits) => bits,
            None => 0,
        };
        let code = data_type.code();
        Self {
            subindex,
            name,
            // A code above 0xFF (no entry type) reads back as unknown type 0: refused by
            // the dictionary's validation like any type without a length.
            type_code: if code <= 0xFF { code as u8 } else { 0 },
            bit_len,
            access,
            unit: 0,
            default: PackedValue::None(false),
        }
    }

    /// A read-only VISIBLE_STRING entry holding `value` (its length is the entry length).
    pub const fn string(subindex: u8, name: &'static str, value: &'static str) -> Self {
        Self::new(subindex, name, DataType::VisibleString, Access::RO)
            .with_bits((value.len() * 8) as u16)
            .with_default(Value::Str(value))
    }

    /// Sub 0 of an ARRAY or RECORD: UNSIGNED8 "SubIndex 000", read-only, default `count`.
    pub const fn count(count: u8) -> Self {
        Self::new(0, "SubIndex 000", DataType::Unsigned8, Access::RO)
            .with_default(Value::Int(count as i64))
    }

    /// Data type.
    pub const fn data_type(&self) -> DataType {
        DataType::from_raw(self.type_code as u16)
    }

    /// Replaces the bit length (strings, OCTET_STRING, DOMAIN).
    pub const fn with_bits(mut self, bit_len: u16) -> Self {
        self.bit_len = bit_len;
        self
    }

    /// Replaces the access rights.
    pub const fn with_access(mut self, access: Access) -> Self {
        self.access = access;
        self
    }

    /// Replaces the name.
    pub const fn with_name(mut self, name: &'static str) -> Self {
        self.name = name;
        self
    }

    /// Sets the default value.
    pub const fn with_default(mut self, default: Value) -> Self {
        self.default = PackedValue::pack(default, self.default.has_unit(), self.default.range());
        self
    }

    /// Sets minimum and maximum (a `&ValueRange { .. }` literal is promoted to a constant).
    /// With limits the default must be a number of at most 32 bits (see
    /// [`OdErrorKind::DefaultTooWideForLimits`]).
    pub const fn with_range(mut self, range: &'static ValueRange) -> Self {
        self.default = self.default.repack(self.default.has_unit(), Some(range));
        self
    }

    /// Default value (ESI `DefaultValue`, SDO Information value info 0x10), or
    /// [`Value::None`].
    pub const fn default(&self) -> Value {
        self.default.unpack()
    }

    /// Minimum and maximum, if the entry has limits.
    pub const fn range(&self) -> Option<&'static ValueRange> {
        self.default.range()
    }

    /// Minimum value (ESI `MinValue`, value info 0x20), or [`Value::None`].
    pub const fn min(&self) -> Value {
        match self.range() {
            Some(r) => r.min,
            None => Value::None,
        }
    }

    /// Maximum value (ESI `MaxValue`, value info 0x40), or [`Value::None`].
    pub const fn max(&self) -> Value {
        match self.range() {
            Some(r) => r.max,
            None => Value::None,
        }
    }

    /// Unit type, if any: the UNSIGNED16 the SDO Information entry description carries
    /// with value info 0x08 (see [`crate::wire::sdo_info::UNIT_TYPE_LEN`] for the size).
    pub const fn unit(&self) -> Option<u16> {
        if self.default.has_unit() {
            Some(self.unit)
        } else {
            None
        }
    }

    /// Sets the unit type.
    pub const fn with_unit(mut self, unit: u16) -> Self {
        self.unit = unit;
        self.default = self.default.repack(true, self.default.range());
        self
    }

    /// Size in bytes of the entry in an SDO transfer (`ceil(bit_len / 8)`; BOOLEAN and BITn
    /// take one byte).
    pub const fn byte_len(&self) -> usize {
        (self.bit_len as usize).div_ceil(8)
    }

    /// Checks `bytes` (a value to be written) against `min`/`max`
    /// (0x06090031 ValueTooHigh / 0x06090032 ValueTooLow).
    pub fn check_range(&self, bytes: &[u8]) -> Result<(), SdoAbortCode> {
        match self.range() {
            Some(r) => value::check_range(self.data_type(), self.bit_len, &r.min, &r.max, bytes),
            None => Ok(()),
        }
    }

    /// Value info bits of the SDO Information entry description this entry can fill:
    /// unit, default, minimum, maximum ([`ValueInfo`] bits).
    pub const fn value_info(&self) -> u8 {
        let mut info = 0;
        if self.unit().is_some() {
            info |= ValueInfo::UNIT_TYPE;
        }
        if self.default().is_some() {
            info |= ValueInfo::DEFAULT;
        }
        if self.min().is_some() {
            info |= ValueInfo::MINIMUM;
        }
        if self.max().is_some() {
            info |= ValueInfo::MAXIMUM;
        }
        info
    }
}

/// One object: index, name, object code and its entries in subindex order.
///
/// Kept at 28 bytes on a 32-bit target (the firmware's dictionary lives in its flash budget):
/// the object code and the data type share one 16-bit word. Read them through
/// [`ObjectDesc::code`] and [`ObjectDesc::data_type`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ObjectDesc {
    /// Object index.
    pub index: u16,
    /// The object code ([`ObjectDesc::code`]) in the top two bits and the data type code
    /// ([`ObjectDesc::data_type`]) below.
    code_and_type: u16,
    /// Object name.
    pub name: &'static str,
    /// Entries sorted by subindex; an ARRAY/RECORD starts with sub 0 (UNSIGNED8). Objects
    /// of one structure (the PDO mappings, 0x1C32/0x1C33, ...) share one table and differ
    /// in [`ObjectDesc::defaults`].
    pub entries: &'static [EntryDesc],
    /// The object's own defaults, which replace the table's: read an entry's default
    /// through [`ObjectDesc::resolve`].
    pub defaults: &'static [EntryDefault],
}

#[cfg(target_pointer_width = "32")]
const _: () = assert!(core::mem::size_of::<ObjectDesc>() <= 28);

/// The data type codes an object can carry next to its object code: the data type area of
/// the dictionary (ETG.1000.6 / CiA 301: indices 0x0001..0x0FFF); a larger code is stored
/// as [`TYPE_OUT_OF_AREA`] and refused by [`ObjectDictionary::validate`].
const TYPE_BITS: u16 = 0x3FFF;
/// The stored type code of an object whose data type lies outside the data type area.
const TYPE_OUT_OF_AREA: u16 = TYPE_BITS;
const LAST_TYPE_CODE: u16 = 0x0FFF;

/// An object's own default of one of its entries (an unsigned number: PDO mappings,
/// COB-IDs, times), for entry tables shared by objects of one structure; or of a run of PDO
/// mapping entries ([`EntryDefault::mapping_run`]).
///
/// The value is kept as two 16-bit halves, so a default takes 6 bytes instead of 8 (a
/// firmware's PDO mappings and communication parameters have dozens of them); the run
/// length sits in what would be padding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EntryDefault {
    /// Subindex (the first of a run).
    pub subindex: u8,
    /// Subindices covered: 1, or the length of a mapping run.
    run: u8,
    /// Default value ([`EntryDefault::value`]), low half first.
    halves: [u16; 2],
}

const _: () = assert!(core::mem::size_of::<EntryDefault>() == 6);

/// What one step of a mapping run adds to a mapping entry: one to its subindex field
/// (`index << 16 | subindex << 8 | bit length`, [`crate::pdo::PdoEntry`]).
const MAPPING_RUN_STEP: u32 = 1 << 8;

impl EntryDefault {
    /// The default `value` of sub `subindex`.
    pub const fn new(subindex: u8, value: u32) -> Self {
        Self {
            subindex,
            run: 1,
            halves: [value as u16, (value >> 16) as u16],
        }
    }

    /// The defaults of `count` PDO mapping entries from sub `first`: sub `first + i` maps
    /// what `entry` maps with the subindex increased by `i` (e.g. `0x60200110` from sub 1,
    /// 32 times: subs 1..32 map 0x6020:01..0x6020:20, 16 bits each). A PDO of a sample array
    /// then costs one default instead of one per sample. [`ObjectDictionary::validate`]
    /// refuses an empty run and one whose subindex field would pass 255
    /// ([`OdErrorKind::BadMappingRun`]).
    pub const fn mapping_run(first: u8, count: u8, entry: u32) -> Self {
        Self {
            subindex: first,
            run: count,
            halves: [entry as u16, (entry >> 16) as u16],
        }
    }

    /// Default value of the first subindex ([`Value::Uint`]).
    pub const fn value(&self) -> u32 {
        self.halves[0] as u32 | (self.halves[1] as u32) << 16
    }

    /// Subindices covered (1 for a single default).
    pub const fn run(&self) -> u8 {
        self.run
    }

    /// The default of `subindex` if this covers it.
    pub const fn value_of(&self, subindex: u8) -> Option<u32> {
        if subindex < self.subindex || (subindex - self.subindex) as u16 >= self.run as u16 {
            return None;
        }
        let step = (subindex - self.subindex) as u32 * MAPPING_RUN_STEP;
        Some(self.value().wrapping_add(step))
    }

    /// Whether the run is well formed: not empty, the last subindex and the subindex field
    /// of its last mapping entry at most 255.
    const fn run_fits(&self) -> bool {
        let last = self.subindex as u16 + self.run as u16;
        let field = (self.value() >> 8 & 0xFF) as u16 + self.run as u16;
        self.run >= 1 && (self.run == 1 || (last <= 256 && field <= 256))
    }
}

impl ObjectDesc {
    /// A VAR: `entries` holds the single entry (subindex 0).
    pub const fn var(index: u16, name: &'static str, entries: &'static [EntryDesc]) -> Self {
        let data_type = match entries {
            [first, ..] => first.data_type(),
            [] => DataType::Unknown(0),
        };
        Self::with_code(index, name, ObjectCode::Var, data_type, entries)
    }

    /// An ARRAY: sub 0 then elements of one type; the object's type is the element type.
    pub const fn array(index: u16, name: &'static str, entries: &'static [EntryDesc]) -> Self {
        let data_type = match entries {
            [_, element, ..] => element.data_type(),
            _ => DataType::Unknown(0),
        };
        Self::with_code(index, name, ObjectCode::Array, data_type, entries)
    }

    /// A RECORD of the given record type.
    pub const fn record(
        index: u16,
        name: &'static str,
        data_type: DataType,
        entries: &'static [EntryDesc],
    ) -> Self {
        Self::with_code(index, name, ObjectCode::Record, data_type, entries)
    }

    const fn with_code(
        index: u16,
        name: &'static str,
        code: ObjectCode,
        data_type: DataType,
        entries: &'static [EntryDesc],
    ) -> Self {
        let code_bits = match code {
            ObjectCode::Var => 0,
            ObjectCode::Array => 1,
            ObjectCode::Record => 2,
        };
        let type_code = match data_type.code() {
            c if c <= LAST_TYPE_CODE => c,
            _ => TYPE_OUT_OF_AREA,
        };
        Self {
            index,
            code_and_type: code_bits << 14 | type_code,
            name,
            entries,
            defaults: &[],
        }
    }

    /// VAR, ARRAY or RECORD.
    pub const fn code(&self) -> ObjectCode {
        match self.code_and_type >> 14 {
            0 => ObjectCode::Var,
            1 => ObjectCode::Array,
            _ => ObjectCode::Record,
        }
    }

    /// The object's data type as the SDO Information object description gives it: the entry
    /// type of a VAR, the element type of an ARRAY, the record type of a RECORD (e.g.
    /// 0x0023 IDENTITY, 0x0021 PDO_MAPPING).
    pub const fn data_type(&self) -> DataType {
        DataType::from_raw(self.code_and_type & TYPE_BITS)
    }

    /// The object with its own defaults for entries of a shared table.
    pub const fn with_defaults(mut self, defaults: &'static [EntryDefault]) -> Self {
        self.defaults = defaults;
        self
    }

    /// `entry` (one of this object's) as this object has it: with the object's own default
    /// where [`ObjectDesc::defaults`] gives one. Everything that reads defaults (SDO
    /// Information, the ESI, SII and EDS generators, the stores) reads them through here.
    pub const fn resolve(&self, entry: &EntryDesc) -> EntryDesc {
        let mut rest = self.defaults;
        while let [own, tail @ ..] = rest {
            if let Some(value) = own.value_of(entry.subindex) {
                let mut own_entry = *entry;
                own_entry.default = entry.default.with_uint(value);
                return own_entry;
            }
            rest = tail;
        }
        *entry
    }

    /// The highest subindex (the "MaxSubindex" of the object description): the last entry's
    /// subindex, 0 for a VAR.
    pub const fn max_subindex(&self) -> u8 {
        match self.entries {
            [.., last] => last.subindex,
            [] => 0,
        }
    }

    /// The entry with this subindex (a linear search usable in `const` code).
    pub(crate) const fn entry_desc(&self, subindex: u8) -> Option<&'static EntryDesc> {
        let mut rest = self.entries;
        while let [entry, tail @ ..] = rest {
            if entry.subindex == subindex {
                return Some(entry);
            }
            rest = tail;
        }
        None
    }

    /// The entry with this subindex.
    pub fn entry(&self, subindex: u8) -> Option<&'static EntryDesc> {
        let entries: &'static [EntryDesc] = self.entries;
        entries
            .binary_search_by_key(&subindex, |e| e.subindex)
            .ok()
            .and_then(|i| entries.get(i))
    }

    /// True if any entry has all bits of `mask` in its access word (e.g. [`Access::RXPDO`]).
    pub fn any_entry_has(&self, mask: u16) -> bool {
        self.entries.iter().any(|e| e.access.contains(mask))
    }
}

/// The whole object dictionary: objects sorted by index.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ObjectDictionary {
    /// Objects in ascending index order.
    pub objects: &'static [ObjectDesc],
}

impl ObjectDictionary {
    /// Wraps a table; call [`ObjectDictionary::validate`] (at compile time) to check it.
    pub const fn new(objects: &'static [ObjectDesc]) -> Self {
        Self { objects }
    }

    /// Number of objects.
    pub const fn len(&self) -> usize {
        self.objects.len()
    }

    /// True if there are no objects.
    pub const fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// Objects in index order.
    pub fn iter(&self) -> core::slice::Iter<'static, ObjectDesc> {
        self.objects.iter()
    }

    /// The object with this index (binary search).
    pub fn find(&self, index: u16) -> Option<&'static ObjectDesc> {
        let objects: &'static [ObjectDesc] = self.objects;
        objects
            .binary_search_by_key(&index, |o| o.index)
            .ok()
            .and_then(|i| objects.get(i))
    }

    /// The object and entry at `index:subindex`, or the SDO abort code a server answers:
    /// 0x06020000 ObjectDoesNotExist, 0x06090011 SubindexDoesNotExist.
    pub fn entry(
        &self,
        index: u16,
        subindex: u8,
    ) -> Result<(&'static ObjectDesc, &'static EntryDesc), SdoAbortCode> {
        let object = self.find(index).ok_or(SdoAbortCode::ObjectDoesNotExist)?;
        let entry = object
            .entry(subindex)
            .ok_or(SdoAbortCode::SubindexDoesNotExist)?;
        Ok((object, entry))
    }

    /// Checks the table; usable in a `const` item:
    /// `const _: () = if let Err(e) = OD.validate() { panic!("{}", e.message()) };`
    ///
    /// Rejected: unsorted or duplicate indices; objects without entries; a VAR that is not
    /// exactly one entry at subindex 0; an ARRAY/RECORD whose sub 0 is not UNSIGNED8;
    /// unsorted or duplicate subindices; ARRAY elements of differing type or length; empty
    /// names; a bit length that does not match the type (fixed types) or is not a whole
    /// number of bytes (strings) or is zero (strings); PDO-mappable flags on a type that
    /// cannot be mapped; a default/min/max of the wrong kind or outside the type's range; a
    /// default of more than 32 bits on an entry with limits;
    /// `min > max`; a default outside `min..=max`; a string default longer than the entry.
    pub const fn validate(&self) -> Result<(), OdError> {
        let mut rest = self.objects;
        let mut previous: Option<u16> = None;
        while let [object, tail @ ..] = rest {
            if let Some(prev) = previous {
                if object.index == prev {
                    return Err(OdError::new(OdErrorKind::DuplicateIndex, object.index, 0));
                }
                if object.index < prev {
                    return Err(OdError::new(OdErrorKind::UnsortedIndex, object.index, 0));
                }
            }
            if let Err(e) = validate_object(object) {
                return Err(e);
            }
            previous = Some(object.index);
            rest = tail;
        }
        Ok(())
    }
}

const fn validate_object(object: &ObjectDesc) -> Result<(), OdError> {
    let index = object.index;
    if object.name.is_empty() {
        return Err(OdError::new(OdErrorKind::EmptyName, index, 0));
    }
    if object.code_and_type & TYPE_BITS == TYPE_OUT_OF_AREA {
        return Err(OdError::new(OdErrorKind::ObjectTypeOutOfArea, index, 0));
    }
    match (object.code(), object.entries) {
        (_, []) => return Err(OdError::new(OdErrorKind::NoEntries, index, 0)),
        (ObjectCode::Var, [only]) => {
            if only.subindex != 0 {
                return Err(OdError::new(
                    OdErrorKind::VarNotSubindexZero,
                    index,
                    only.subindex,
                ));
            }
        }
        (ObjectCode::Var, [_, second, ..]) => {
            return Err(OdError::new(
                OdErrorKind::VarNotSubindexZero,
                index,
                second.subindex,
            ))
        }
        (_, [first, ..]) => {
            if first.subindex != 0
                || !matches!(first.data_type(), DataType::Unsigned8)
                || first.bit_len != 8
            {
                return Err(OdError::new(
                    OdErrorKind::BadSubindexZero,
                    index,
                    first.subindex,
                ));
            }
        }
    }
    let mut rest = object.entries;
    let mut previous: Option<u8> = None;
    let mut element: Option<&EntryDesc> = None;
    while let [entry, tail @ ..] = rest {
        if let Some(prev) = previous {
            if entry.subindex == prev {
                return Err(OdError::new(
                    OdErrorKind::DuplicateSubindex,
                    index,
                    entry.subindex,
                ));
            }
            if entry.subindex < prev {
                return Err(OdError::new(
                    OdErrorKind::UnsortedSubindex,
                    index,
                    entry.subindex,
                ));
            }
        }
        if let Err(kind) = validate_entry(&object.resolve(entry)) {
            return Err(OdError::new(kind, index, entry.subindex));
        }
        if matches!(object.code(), ObjectCode::Array) && entry.subindex != 0 {
            match element {
                Some(first) => {
                    if first.data_type().code() != entry.data_type().code()
                        || first.bit_len != entry.bit_len
                    {
                        return Err(OdError::new(
                            OdErrorKind::ArrayElementMismatch,
                            index,
                            entry.subindex,
                        ));
                    }
                }
                None => element = Some(entry),
            }
        }
        previous = Some(entry.subindex);
        rest = tail;
    }
    let mut own = object.defaults;
    while let [default, tail @ ..] = own {
        if !default.run_fits() {
            return Err(OdError::new(
                OdErrorKind::BadMappingRun,
                index,
                default.subindex,
            ));
        }
        let mut i = 0;
        while i < default.run() {
            let sub = default.subindex + i;
            if object.entry_desc(sub).is_none() {
                return Err(OdError::new(OdErrorKind::DefaultOfNoEntry, index, sub));
            }
            i += 1;
        }
        own = tail;
    }
    Ok(())
}

const fn validate_entry(entry: &EntryDesc) -> Result<(), OdErrorKind> {
    let t = entry.data_type();
    if entry.name.is_empty() {
        return Err(OdErrorKind::EmptyName);
    }
    if entry.default.lost_default() {
        return Err(OdErrorKind::DefaultTooWideForLimits);
    }
    #[cfg(not(feature = "real"))]
    if matches!(t, DataType::Real32 | DataType::Real64) {
        return Err(OdErrorKind::RealNotEnabled);
    }
    match t.bit_len() {
        Some(bits) => {
            if entry.bit_len != bits {
                return Err(OdErrorKind::BitLengthMismatch);
            }
        }
        None => {
            if !t.is_variable_length() {
                return Err(OdErrorKind::UnsupportedType);
            }
            let unit = if matches!(t, DataType::UnicodeString) {
                16
            } else {
                8
            };
            if entry.bit_len % unit != 0 || (entry.bit_len == 0 && !matches!(t, DataType::Domain)) {
                return Err(OdErrorKind::BitLengthMismatch);
            }
        }
    }
    if (entry.access.is_rx_mappable() || entry.access.is_tx_mappable()) && !t.is_pdo_mappable() {
        return Err(OdErrorKind::NotMappableType);
    }
    let (default, min, max) = (entry.default(), entry.min(), entry.max());
    if !value_fits(entry, &default) || !value_fits(entry, &min) || !value_fits(entry, &max) {
        return Err(OdErrorKind::ValueDoesNotFitType);
    }
    // Order of min, default, max.
    match (min, max) {
        (Value::Real(lo), Value::Real(hi)) => {
            if lo > hi {
                return Err(OdErrorKind::MinGreaterThanMax);
            }
        }
        _ => {
            if let (Some(lo), Some(hi)) = (min.as_i128(), max.as_i128()) {
                if lo > hi {
                    return Err(OdErrorKind::MinGreaterThanMax);
                }
            }
        }
    }
    if let Some(d) = default.as_i128() {
        if let Some(lo) = min.as_i128() {
            if d < lo {
                return Err(OdErrorKind::DefaultOutOfRange);
            }
        }
        if let Some(hi) = max.as_i128() {
            if d > hi {
                return Err(OdErrorKind::DefaultOutOfRange);
            }
        }
    }
    if let Value::Real(d) = default {
        if let Value::Real(lo) = min {
            if d < lo {
                return Err(OdErrorKind::DefaultOutOfRange);
            }
        }
        if let Value::Real(hi) = max {
            if d > hi {
                return Err(OdErrorKind::DefaultOutOfRange);
            }
        }
    }
    Ok(())
}

/// True if `value` is of a kind that suits the entry and fits its range/length.
const fn value_fits(entry: &EntryDesc, value: &Value) -> bool {
    let t = entry.data_type();
    match *value {
        Value::None => true,
        Value::Int(_) | Value::Uint(_) => {
            let v = match value.as_i128() {
                Some(v) => v,
                None => return false,
            };
            match int_limits(t, entry.bit_len) {
                Some((lo, hi)) => v >= lo && v <= hi,
                None => false,
            }
        }
        Value::Real(_) => matches!(t, DataType::Real32 | DataType::Real64),
        Value::Str(_) | Value::Bytes(_) => {
            let len = value.encoded_len(t, entry.bit_len);
            if t.is_variable_length() {
                entry.bit_len == 0 || len <= entry.byte_len()
            } else {
                // A raw image of a fixed-size type must be exactly its size.
                matches!(value, Value::Bytes(_)) && len == entry.byte_len()
            }
        }
    }
}

/// What [`ObjectDictionary::validate`] found wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OdErrorKind {
    /// An object index is lower than the one before it.
    UnsortedIndex,
    /// An object index appears twice.
    DuplicateIndex,
    /// An object has no entries.
    NoEntries,
    /// A VAR must have exactly one entry, at subindex 0.
    VarNotSubindexZero,
    /// Sub 0 of an ARRAY/RECORD must exist and be UNSIGNED8.
    BadSubindexZero,
    /// A subindex is lower than the one before it.
    UnsortedSubindex,
    /// A subindex appears twice.
    DuplicateSubindex,
    /// ARRAY elements differ in type or length.
    ArrayElementMismatch,
    /// An object or entry has an empty name.
    EmptyName,
    /// The bit length does not match the data type.
    BitLengthMismatch,
    /// The data type is a record type or unknown and cannot describe an entry.
    UnsupportedType,
    /// An entry is marked PDO-mappable but its type cannot be mapped.
    NotMappableType,
    /// A default/min/max value is of the wrong kind or outside the type's range.
    ValueDoesNotFitType,
    /// The minimum is greater than the maximum.
    MinGreaterThanMax,
    /// The default is outside `min..=max`.
    DefaultOutOfRange,
    /// A REAL32/REAL64 entry, but coe-core is built without its `real` feature.
    RealNotEnabled,
    /// An object's own default names a subindex the object does not have.
    DefaultOfNoEntry,
    /// An entry with limits has a default that is not a number of at most 32 bits (an
    /// `Int` within `i32`, a `Uint` within `u32`, a `Real` with zero low 32 bits).
    DefaultTooWideForLimits,
    /// An object's data type code lies outside the data type area 0x0000..=0x0FFF.
    ObjectTypeOutOfArea,
    /// A run of mapping defaults ([`EntryDefault::mapping_run`]) is empty, or its last
    /// subindex or the subindex field of its last mapping entry passes 255.
    BadMappingRun,
}

impl OdErrorKind {
    /// A human-readable description.
    pub const fn message(self) -> &'static str {
        match self {
            Self::UnsortedIndex => "object indices are not in ascending order",
            Self::DuplicateIndex => "duplicate object index",
            Self::NoEntries => "object has no entries",
            Self::VarNotSubindexZero => "a VAR must have exactly one entry, at subindex 0",
            Self::BadSubindexZero => "sub 0 of an ARRAY/RECORD must be an UNSIGNED8 entry",
            Self::UnsortedSubindex => "subindices are not in ascending order",
            Self::DuplicateSubindex => "duplicate subindex",
            Self::ArrayElementMismatch => "ARRAY elements differ in type or bit length",
            Self::EmptyName => "empty object or entry name",
            Self::BitLengthMismatch => "bit length does not match the data type",
            Self::UnsupportedType => "data type cannot describe an entry",
            Self::NotMappableType => "PDO-mappable flag on a type that cannot be mapped",
            Self::ValueDoesNotFitType => {
                "default/min/max of the wrong kind or out of the type's range"
            }
            Self::MinGreaterThanMax => "minimum greater than maximum",
            Self::RealNotEnabled => {
                "REAL32/REAL64 entry, but coe-core is built without the `real` feature"
            }
            Self::DefaultOutOfRange => "default value outside min..max",
            Self::DefaultOfNoEntry => "an object's own default names no entry of it",
            Self::ObjectTypeOutOfArea => "object data type outside the data type area",
            Self::DefaultTooWideForLimits => {
                "an entry with limits needs a default of at most 32 bits"
            }
            Self::BadMappingRun => "a run of mapping defaults is empty or passes subindex 255",
        }
    }
}

/// An object dictionary validation error: what and where.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OdError {
    /// What is wrong.
    pub kind: OdErrorKind,
    /// Object index.
    pub index: u16,
    /// Subindex (0 for object-level errors).
    pub subindex: u8,
}

impl OdError {
    /// Creates an error.
    pub const fn new(kind: OdErrorKind, index: u16, subindex: u8) -> Self {
        Self {
            kind,
            index,
            subindex,
        }
    }

    /// The description of the kind (for a `const` panic message).
    pub const fn message(&self) -> &'static str {
        self.kind.message()
    }
}

impl fmt::Display for OdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "object dictionary {:#06X}:{:02X}: {}",
            self.index,
            self.subindex,
            self.kind.message()
        )
    }
}

#[cfg(test)]
mod tests;
