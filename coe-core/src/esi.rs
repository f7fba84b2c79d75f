//! The ESI file (EtherCAT Slave Information, ETG.2000 XML) generated from the
//! [`DeviceDescription`], so the configuration tool sees exactly what the firmware serves and
//! the SII EEPROM ([`crate::sii`]) holds.
//!
//! [`write_esi`] writes through any [`core::fmt::Write`] sink (no allocation). Element order
//! follows the sequences of the ETG.2000 schema (`EtherCATInfo.xsd` / `EtherCATBase.xsd`,
//! schema 1.14); the output validates against it.
//!
//! How the description maps onto the file:
//! - `Profile/ProfileNo` and `AddInfo` are the low and high 16 bits of the 0x1000 default.
//! - Every object appears in `Dictionary/Objects`; every type an entry uses in
//!   `Dictionary/DataTypes`: the basic types (`UINT`, `STRING(n)`, ...) once each, and per
//!   ARRAY/RECORD a `DTxxxx` type whose `SubItem`s carry name, type, `BitSize`, `BitOffs` (the
//!   complete-access layout) and access flags. An ARRAY whose elements are subindices 1..n
//!   with one access right is written the usual way, `DTxxxxARR` with `ArrayInfo`.
//! - Defaults, minimum and maximum are `DefaultData`/`MinData`/`MaxData` (the little-endian
//!   SDO image in hex); VISIBLE_STRING and UNICODE_STRING defaults are `DefaultString`.
//! - `Access` is `ro`/`rw`/`wo` with `ReadRestrictions`/`WriteRestrictions` when the right
//!   holds only in some states (e.g. `WriteRestrictions="PreOP"`).
//! - Every PDO mapping object is an `RxPdo`/`TxPdo`; those in the default assignment carry
//!   `Sm`; `Fixed` when its sub 0 is not writable, `Mandatory` when assigned and the
//!   assignment cannot be changed (no PDO assign in the CoE details). Gaps are entries with
//!   `Index` `#x0`.
//! - `Eeprom/ConfigData` is SII words 0..7 (PDI configuration, alias, checksum) as the SII
//!   generator writes them, so the two cannot differ.
//! - With [`write_esi_with`], the oversampling part ([`Oversampling`]): a replicated PDO is
//!   listed once, its base with `OSFac`, `OSMin`, `OSMax` and `OSIndexInc` (the replicas
//!   stay in the dictionary); its op modes follow the plain ones, each with its `Sm`
//!   elements and `Pdo OSFac`.

use crate::device::oversampling::{OpModeSm, Oversampling};
use crate::device::{DcOpMode, DescError, DeviceDescription, MailboxProtocols};
use crate::od::{Access, DataType, EntryDesc, EsiTypeName, ObjectCode, ObjectDesc, Value};
use crate::pdo::PdoDirection;
use crate::sdo_server::Layout;
use crate::sii::{self, SiiError};
use core::fmt::{self, Display, Write};

/// The schema version the output follows (`EtherCATInfo/@Version`).
pub const SCHEMA_VERSION: &str = "1.14";

/// The language of every name (`LcId`, 1033 = English).
pub const LCID_ENGLISH: u16 = 1033;

/// The device type object; its default gives `ProfileNo` and `AddInfo`.
pub const DEVICE_TYPE_INDEX: u16 = 0x1000;

/// Bytes of `Eeprom/ConfigData`: SII words 0..7.
pub const CONFIG_DATA_LEN: usize = 16;

/// Why no ESI file was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EsiError {
    /// The description does not validate.
    Description(DescError),
    /// No SII image can be made of the description, so there is no ConfigData to give.
    Sii(SiiError),
    /// Two entries of an ARRAY/RECORD have the same name (the schema requires the `SubItem`
    /// names of a data type to differ).
    DuplicateEntryName {
        /// The object.
        index: u16,
        /// The second entry of that name.
        subindex: u8,
    },
    /// A name or string holds a control character XML 1.0 cannot carry (the string).
    UnrepresentableText(&'static str),
    /// The sink refused a write.
    Write,
}

impl Display for EsiError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Description(e) => write!(f, "ESI: {e}"),
            Self::Sii(e) => write!(f, "ESI: ConfigData: {e}"),
            Self::DuplicateEntryName { index, subindex } => write!(
                f,
                "ESI: object {index:#06X}:{subindex:02X}: entry name used twice in the object"
            ),
            Self::UnrepresentableText(s) => {
                write!(f, "ESI: control character in {s:?}: XML cannot carry it")
            }
            Self::Write => f.write_str("ESI: the output refused a write"),
        }
    }
}

impl From<DescError> for EsiError {
    fn from(e: DescError) -> Self {
        Self::Description(e)
    }
}

impl From<fmt::Error> for EsiError {
    fn from(_: fmt::Error) -> Self {
        Self::Write
    }
}

/// Writes the ESI file of `desc` into `out`. The description is validated first; a
/// description that does not validate, or of which no SII image can be made, writes nothing.
pub fn write_esi<W: Write>(desc: &DeviceDescription, out: &mut W) -> Result<(), EsiError> {
    write_esi_with(desc, &Oversampling::NONE, out)
}

/// [`write_esi`] with the oversampling part `os` of the description (validated with it).
pub fn write_esi_with<W: Write>(
    desc: &DeviceDescription,
    os: &Oversampling,
    out: &mut W,
) -> Result<(), EsiError> {
    desc.validate()?;
    os.validate(desc)?;
    let config = config_data(desc, os)?;
    check_entry_names(desc)?;
    let mut xml = Xml {
        out,
        depth: 0,
        bad_text: None,
    };
    xml.document(desc, os, &config)?;
    match xml.bad_text {
        Some(s) => Err(EsiError::UnrepresentableText(s)),
        None => Ok(()),
    }
}

/// SII words 0..7 exactly as [`sii::generate`] writes them (it fills as much of the buffer
/// as there is and reports the size it would need).
fn config_data(
    desc: &DeviceDescription,
    os: &Oversampling,
) -> Result<[u8; CONFIG_DATA_LEN], EsiError> {
    let mut head = [0u8; CONFIG_DATA_LEN];
    // The SII of the same description, oversampling part included (it decides whether
    // the image fits the EEPROM).
    match sii::generate_with(desc, os, &mut head) {
        Ok(_) | Err(SiiError::BufferTooSmall { .. }) => Ok(head),
        Err(SiiError::Description(e)) => Err(EsiError::Description(e)),
        Err(e) => Err(EsiError::Sii(e)),
    }
}

/// Rejects an ARRAY/RECORD with two entries of one name (they become `SubItem`s of one
/// data type, whose names the schema keys).
fn check_entry_names(desc: &DeviceDescription) -> Result<(), EsiError> {
    for object in desc.od.iter() {
        if object.code() == ObjectCode::Var {
            continue;
        }
        for (i, entry) in object.entries.iter().enumerate() {
            let earlier = object.entries.get(..i).unwrap_or(&[]);
            if earlier.iter().any(|e| e.name == entry.name) {
                return Err(EsiError::DuplicateEntryName {
                    index: object.index,
                    subindex: entry.subindex,
                });
            }
        }
    }
    Ok(())
}

/// Bit offsets of an object's entries in its complete-access image (ETG.1020 12.2): the
/// layout `sdo_server::complete` transfers, from the same code.
fn entry_offsets(object: &ObjectDesc) -> impl Iterator<Item = (&'static EntryDesc, u32)> {
    Layout::whole(object).entries()
}

/// `BitSize` of an object: the entry's length for a VAR, the whole bytes of the
/// complete-access image for an ARRAY/RECORD.
fn object_bits(object: &ObjectDesc) -> u32 {
    match object.code() {
        ObjectCode::Var => object.entries.first().map_or(0, |e| u32::from(e.bit_len)),
        ObjectCode::Array | ObjectCode::Record => Layout::whole(object).bits().div_ceil(8) * 8,
    }
}

/// The elements of an ARRAY that the `ArrayInfo` form describes: subindices 1..=n, one
/// access right (type and length are the same by [`crate::od::ObjectDictionary::validate`]).
fn uniform_elements(object: &ObjectDesc) -> Option<&'static [EntryDesc]> {
    let entries: &'static [EntryDesc] = object.entries;
    match (object.code(), entries) {
        (ObjectCode::Array, [_, first, ..]) => {
            let elements = entries.get(1..)?;
            let contiguous = elements
                .iter()
                .enumerate()
                .all(|(i, e)| usize::from(e.subindex) == i + 1 && e.access == first.access);
            contiguous.then_some(elements)
        }
        _ => None,
    }
}

/// The ESI name of an entry's type.
fn type_name(entry: &EntryDesc) -> EsiTypeName {
    entry.data_type().esi_name(entry.bit_len)
}

/// `#x` and upper-case hex digits, zero-padded to `width` (the schema's HexDecValue).
struct Hex(u32, usize);

impl Display for Hex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#x{:01$X}", self.0, self.1)
    }
}

/// An object index as `#x1A00`.
fn idx(index: u16) -> Hex {
    Hex(u32::from(index), 4)
}

/// Bytes as hexBinary.
struct HexBytes<'a>(&'a [u8]);

impl Display for HexBytes<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.iter().try_for_each(|b| write!(f, "{b:02X}"))
    }
}

/// The name of an ARRAY/RECORD's data type, `DT1018`, or of an array's element list,
/// `DT6401ARR`.
struct DtName(u16, bool);

impl Display for DtName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "DT{:04X}{}", self.0, if self.1 { "ARR" } else { "" })
    }
}

/// A value as the file gives it.
enum ValueText {
    /// A string default (`DefaultString`).
    Text(&'static str),
    /// A numeric value's little-endian image (at most 64 bits).
    Number([u8; 8], usize),
    /// Raw bytes (OCTET_STRING, DOMAIN, a string in a non-string type).
    Raw(&'static [u8]),
}

impl ValueText {
    fn of(entry: &EntryDesc, value: &Value) -> Option<Self> {
        match *value {
            Value::None => None,
            Value::Str(s)
                if matches!(
                    entry.data_type(),
                    DataType::VisibleString | DataType::UnicodeString
                ) =>
            {
                Some(Self::Text(s))
            }
            Value::Str(s) => Some(Self::Raw(s.as_bytes())),
            Value::Bytes(b) => Some(Self::Raw(b)),
            Value::Int(_) | Value::Uint(_) | Value::Real(_) => {
                let mut buf = [0u8; 8];
                value
                    .encode(entry.data_type(), entry.bit_len, &mut buf)
                    .map(|len| Self::Number(buf, len))
            }
        }
    }
}

/// The XML writer: indentation, escaping, and the first string that could not be written.
struct Xml<'w, W: Write> {
    out: &'w mut W,
    depth: usize,
    bad_text: Option<&'static str>,
}

impl<W: Write> Xml<'_, W> {
    fn indent(&mut self) -> fmt::Result {
        for _ in 0..self.depth {
            self.out.write_char('\t')?;
        }
        Ok(())
    }

    /// `<name` (attributes follow, then [`Xml::open_end`], [`Xml::body_end`] or
    /// [`Xml::empty_end`]).
    fn start(&mut self, name: &str) -> fmt::Result {
        self.indent()?;
        write!(self.out, "<{name}")
    }

    /// ` name="value"` for a value that needs no escaping (numbers, hex, fixed words).
    fn attr(&mut self, name: &str, value: impl Display) -> fmt::Result {
        write!(self.out, " {name}=\"{value}\"")
    }

    /// `>` and a new line: children follow.
    fn open_end(&mut self) -> fmt::Result {
        self.depth += 1;
        self.out.write_str(">\n")
    }

    /// `/>`.
    fn empty_end(&mut self) -> fmt::Result {
        self.out.write_str("/>\n")
    }

    /// `>value</name>`.
    fn body_end(&mut self, name: &str, value: impl Display) -> fmt::Result {
        writeln!(self.out, ">{value}</{name}>")
    }

    /// `>text</name>`, escaped.
    fn body_text_end(&mut self, name: &str, text: &'static str) -> fmt::Result {
        self.out.write_char('>')?;
        self.escaped(text)?;
        writeln!(self.out, "</{name}>")
    }

    /// `<name>` on its own line.
    fn open(&mut self, name: &str) -> fmt::Result {
        self.start(name)?;
        self.open_end()
    }

    /// `</name>` on its own line.
    fn close(&mut self, name: &str) -> fmt::Result {
        self.depth = self.depth.saturating_sub(1);
        self.indent()?;
        writeln!(self.out, "</{name}>")
    }

    /// `<name>value</name>` for a value that needs no escaping.
    fn leaf(&mut self, name: &str, value: impl Display) -> fmt::Result {
        self.start(name)?;
        self.body_end(name, value)
    }

    /// `<name>text</name>`, escaped.
    fn leaf_text(&mut self, name: &str, text: &'static str) -> fmt::Result {
        self.start(name)?;
        self.body_text_end(name, text)
    }

    /// `<name LcId="1033">text</name>` (the schema's NameType).
    fn name(&mut self, name: &str, text: &'static str) -> fmt::Result {
        self.start(name)?;
        self.attr("LcId", LCID_ENGLISH)?;
        self.body_text_end(name, text)
    }

    /// Writes `text` with `& < > " '` as entity references. Control characters other than
    /// tab, LF and CR cannot appear in XML 1.0 at all; they are remembered (and written as
    /// U+FFFD so the document stays well-formed) and fail the generation.
    fn escaped(&mut self, text: &'static str) -> fmt::Result {
        for c in text.chars() {
            match c {
                '&' => self.out.write_str("&amp;")?,
                '<' => self.out.write_str("&lt;")?,
                '>' => self.out.write_str("&gt;")?,
                '"' => self.out.write_str("&quot;")?,
                '\'' => self.out.write_str("&apos;")?,
                '\t' | '\n' | '\r' => self.out.write_char(c)?,
                c if u32::from(c) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => {
                    self.bad_text.get_or_insert(text);
                    self.out.write_char('\u{FFFD}')?;
                }
                c => self.out.write_char(c)?,
            }
        }
        Ok(())
    }

    fn document(
        &mut self,
        desc: &DeviceDescription,
        os: &Oversampling,
        config: &[u8],
    ) -> fmt::Result {
        self.out
            .write_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n")?;
        self.start("EtherCATInfo")?;
        self.attr("xmlns:xsi", "http://www.w3.org/2001/XMLSchema-instance")?;
        self.attr("xsi:noNamespaceSchemaLocation", "EtherCATInfo.xsd")?;
        self.attr("Version", SCHEMA_VERSION)?;
        self.open_end()?;
        self.open("Vendor")?;
        self.leaf("Id", Hex(desc.identity.vendor_id, 8))?;
        self.name("Name", desc.names.vendor_name)?;
        self.close("Vendor")?;
        self.open("Descriptions")?;
        self.open("Groups")?;
        self.open("Group")?;
        self.leaf_text("Type", desc.names.group_type)?;
        self.name("Name", desc.names.group_name)?;
        self.close("Group")?;
        self.close("Groups")?;
        self.open("Devices")?;
        self.device(desc, os, config)?;
        self.close("Devices")?;
        self.close("Descriptions")?;
        self.close("EtherCATInfo")
    }

    fn device(
        &mut self,
        desc: &DeviceDescription,
        os: &Oversampling,
        config: &[u8],
    ) -> fmt::Result {
        self.start("Device")?;
        self.attr("Physics", Physics(desc))?;
        self.open_end()?;
        let id = &desc.identity;
        self.start("Type")?;
        self.attr("ProductCode", Hex(id.product_code, 8))?;
        self.attr("RevisionNo", Hex(id.revision, 8))?;
        self.body_text_end("Type", desc.names.order_code)?;
        self.name("Name", desc.names.device_name)?;
        if desc.ebus_current_ma != 0 {
            self.open("Info")?;
            self.open("Electrical")?;
            self.leaf("EBusCurrent", desc.ebus_current_ma)?;
            self.close("Electrical")?;
            self.close("Info")?;
        }
        self.leaf_text("GroupType", desc.names.group_type)?;
        self.profile(desc)?;
        for usage in desc.fmmus {
            if let Some(text) = usage.esi_name() {
                self.leaf("Fmmu", text)?;
            }
        }
        self.sync_managers(desc)?;
        self.pdos(desc, os, PdoDirection::Rx)?;
        self.pdos(desc, os, PdoDirection::Tx)?;
        self.mailbox(desc)?;
        self.dc(desc, os)?;
        self.open("Eeprom")?;
        self.leaf("ByteSize", desc.eeprom.size_bytes)?;
        self.leaf("ConfigData", HexBytes(config))?;
        if let Some((out, inp)) = desc.mailbox.bootstrap {
            let mut words = [0u8; 8];
            for (pair, word) in words
                .chunks_exact_mut(2)
                .zip([out.start, out.len, inp.start, inp.len])
            {
                pair.copy_from_slice(&word.to_le_bytes());
            }
            self.leaf("BootStrap", HexBytes(&words))?;
        }
        self.close("Eeprom")?;
        self.close("Device")
    }

    fn profile(&mut self, desc: &DeviceDescription) -> fmt::Result {
        self.open("Profile")?;
        let device_type = desc
            .od
            .entry(DEVICE_TYPE_INDEX, 0)
            .ok()
            .and_then(|(o, e)| o.resolve(e).default().as_i128())
            .and_then(|v| u32::try_from(v).ok());
        if let Some(device_type) = device_type {
            self.leaf("ProfileNo", device_type & 0xFFFF)?;
            self.leaf("AddInfo", device_type >> 16)?;
        }
        self.open("Dictionary")?;
        self.data_types(desc)?;
        self.open("Objects")?;
        for object in desc.od.iter() {
            self.object(object)?;
        }
        self.close("Objects")?;
        self.close("Dictionary")?;
        self.close("Profile")
    }

    /// Every basic type an entry uses (once), then the ARRAY/RECORD types.
    fn data_types(&mut self, desc: &DeviceDescription) -> fmt::Result {
        self.open("DataTypes")?;
        let all = || desc.od.iter().flat_map(|o| o.entries.iter());
        for (i, entry) in all().enumerate() {
            let name = type_name(entry);
            if all().take(i).any(|earlier| type_name(earlier) == name) {
                continue;
            }
            self.open("DataType")?;
            self.leaf("Name", name)?;
            self.leaf("BitSize", entry.bit_len)?;
            self.close("DataType")?;
        }
        for object in desc.od.iter() {
            if object.code() != ObjectCode::Var {
                self.complex_type(object)?;
            }
        }
        self.close("DataTypes")
    }

    fn complex_type(&mut self, object: &ObjectDesc) -> fmt::Result {
        let elements = uniform_elements(object);
        if let Some(elements @ [first, ..]) = elements {
            self.open("DataType")?;
            self.leaf("Name", DtName(object.index, true))?;
            self.leaf("BaseType", type_name(first))?;
            self.leaf("BitSize", elements.len() * usize::from(first.bit_len))?;
            self.open("ArrayInfo")?;
            self.leaf("LBound", 1)?;
            self.leaf("Elements", elements.len())?;
            self.close("ArrayInfo")?;
            self.close("DataType")?;
        }
        self.open("DataType")?;
        self.leaf("Name", DtName(object.index, false))?;
        self.leaf("BitSize", object_bits(object))?;
        for (entry, offset) in entry_offsets(object) {
            match elements {
                Some(elements @ [first, ..]) if entry.subindex != 0 => {
                    // One SubItem for all elements, at the first element's offset.
                    if entry.subindex == first.subindex {
                        self.open("SubItem")?;
                        self.leaf("Name", "Elements")?;
                        self.leaf("Type", DtName(object.index, true))?;
                        self.leaf("BitSize", elements.len() * usize::from(first.bit_len))?;
                        self.leaf("BitOffs", offset)?;
                        self.flags(first.access)?;
                        self.close("SubItem")?;
                    }
                }
                _ => {
                    self.open("SubItem")?;
                    self.leaf("SubIdx", entry.subindex)?;
                    self.leaf_text("Name", entry.name)?;
                    self.leaf("Type", type_name(entry))?;
                    self.leaf("BitSize", entry.bit_len)?;
                    self.leaf("BitOffs", offset)?;
                    self.flags(entry.access)?;
                    self.close("SubItem")?;
                }
            }
        }
        self.close("DataType")
    }

    fn object(&mut self, object: &ObjectDesc) -> fmt::Result {
        self.open("Object")?;
        self.leaf("Index", idx(object.index))?;
        self.name("Name", object.name)?;
        match (object.code(), object.entries) {
            (ObjectCode::Var, [entry]) => {
                let entry = &object.resolve(entry);
                self.leaf("Type", type_name(entry))?;
                self.leaf("BitSize", entry.bit_len)?;
                if has_info(entry) {
                    self.open("Info")?;
                    self.info(entry)?;
                    self.close("Info")?;
                }
                self.flags(entry.access)?;
            }
            (_, entries) => {
                self.leaf("Type", DtName(object.index, false))?;
                self.leaf("BitSize", object_bits(object))?;
                self.open("Info")?;
                for entry in entries {
                    let entry = &object.resolve(entry);
                    self.open("SubItem")?;
                    self.leaf_text("Name", entry.name)?;
                    self.open("Info")?;
                    self.info(entry)?;
                    self.close("Info")?;
                    self.close("SubItem")?;
                }
                self.close("Info")?;
                // The object's own access is that of sub 0 (as vendor files give it).
                if let Some(sub0) = entries.first() {
                    self.flags(sub0.access)?;
                }
            }
        }
        self.close("Object")
    }

    /// The content of an ObjectInfoType: default/minimum/maximum, unit.
    fn info(&mut self, entry: &EntryDesc) -> fmt::Result {
        match ValueText::of(entry, &entry.default()) {
            Some(ValueText::Text(s)) => self.leaf_text("DefaultString", s)?,
            default => {
                for (tag, value) in [
                    ("MinData", ValueText::of(entry, &entry.min())),
                    ("MaxData", ValueText::of(entry, &entry.max())),
                    ("DefaultData", default),
                ] {
                    match value {
                        Some(ValueText::Number(buf, len)) => {
                            self.leaf(tag, HexBytes(buf.get(..len).unwrap_or(&[])))?
                        }
                        Some(ValueText::Raw(bytes)) => self.leaf(tag, HexBytes(bytes))?,
                        // A string minimum/maximum has no place in the schema.
                        Some(ValueText::Text(_)) | None => {}
                    }
                }
            }
        }
        if let Some(unit) = entry.unit() {
            self.leaf("Unit", Hex(u32::from(unit), 4))?;
        }
        Ok(())
    }

    fn flags(&mut self, access: Access) -> fmt::Result {
        self.open("Flags")?;
        self.start("Access")?;
        if let Some(r) = access.esi_read_restrictions() {
            self.attr("ReadRestrictions", r)?;
        }
        if let Some(w) = access.esi_write_restrictions() {
            self.attr("WriteRestrictions", w)?;
        }
        self.body_end("Access", access.esi_access())?;
        if let Some(mapping) = access.esi_pdo_mapping() {
            self.leaf("PdoMapping", mapping)?;
        }
        if access.contains(Access::BACKUP) {
            self.leaf("Backup", 1)?;
        }
        if access.contains(Access::SETTINGS) {
            self.leaf("Setting", 1)?;
        }
        self.close("Flags")
    }

    fn sync_managers(&mut self, desc: &DeviceDescription) -> fmt::Result {
        for sm in desc.sync_managers {
            self.start("Sm")?;
            if sm.role.is_mailbox() {
                self.attr("MinSize", sm.len)?;
            }
            self.attr("MaxSize", sm.len)?;
            self.attr("DefaultSize", desc.default_sm_len(sm))?;
            self.attr("StartAddress", Hex(u32::from(sm.start), 4))?;
            self.attr("ControlByte", Hex(u32::from(sm.control), 2))?;
            self.attr("Enable", u8::from(sm.enable))?;
            self.body_end("Sm", sm.role.esi_name())?;
        }
        Ok(())
    }

    fn pdos(
        &mut self,
        desc: &DeviceDescription,
        os: &Oversampling,
        direction: PdoDirection,
    ) -> fmt::Result {
        let tag = match direction {
            PdoDirection::Rx => "RxPdo",
            PdoDirection::Tx => "TxPdo",
        };
        for object in desc.pdo_objects(direction) {
            let index = object.index;
            if !os.is_listed(index) {
                continue;
            }
            self.start(tag)?;
            if desc.pdo_is_fixed(index) {
                self.attr("Fixed", 1)?;
            }
            if desc.pdo_is_assigned(index) {
                if !desc.mailbox.coe.pdo_assign() {
                    self.attr("Mandatory", 1)?;
                }
                if let Some(sm) = desc.sm_of_pdo(index) {
                    self.attr("Sm", sm)?;
                }
            }
            if let Some((group, _)) = os.group_of(index) {
                self.attr("OSFac", group.default_factor)?;
                self.attr("OSMin", group.min_factor)?;
                self.attr("OSMax", group.max_factor)?;
                self.attr("OSIndexInc", group.index_increment)?;
            }
            self.open_end()?;
            self.leaf("Index", idx(index))?;
            self.name("Name", object.name)?;
            for entry in desc.pdo_entries(index) {
                self.open("Entry")?;
                if entry.is_gap() {
                    self.leaf("Index", Hex(0, 1))?;
                    self.leaf("BitLen", entry.bit_len)?;
                } else {
                    self.leaf("Index", idx(entry.index))?;
                    self.leaf("SubIndex", entry.subindex)?;
                    self.leaf("BitLen", entry.bit_len)?;
                    if let Some(mapped) = desc.mapped_entry(entry) {
                        self.name("Name", mapped.name)?;
                        self.leaf("DataType", type_name(mapped))?;
                    }
                }
                self.close("Entry")?;
            }
            self.close(tag)?;
        }
        Ok(())
    }

    fn mailbox(&mut self, desc: &DeviceDescription) -> fmt::Result {
        let protocols = desc.mailbox.protocols;
        if !protocols.any() {
            return Ok(());
        }
        self.open("Mailbox")?;
        // In the schema's order.
        for (bit, tag) in [
            (MailboxProtocols::AOE, "AoE"),
            (MailboxProtocols::EOE, "EoE"),
            (MailboxProtocols::COE, "CoE"),
            (MailboxProtocols::FOE, "FoE"),
            (MailboxProtocols::SOE, "SoE"),
            (MailboxProtocols::VOE, "VoE"),
        ] {
            if protocols.bits() & bit == 0 {
                continue;
            }
            self.start(tag)?;
            if bit == MailboxProtocols::COE {
                let coe = desc.mailbox.coe;
                self.attr("SdoInfo", Bool(coe.sdo_info()))?;
                self.attr("PdoAssign", Bool(coe.pdo_assign()))?;
                self.attr("PdoConfig", Bool(coe.pdo_config()))?;
                self.attr("PdoUpload", Bool(coe.upload_at_startup()))?;
                self.attr("CompleteAccess", Bool(coe.complete_access()))?;
            }
            self.empty_end()?;
        }
        self.close("Mailbox")
    }

    fn dc(&mut self, desc: &DeviceDescription, os: &Oversampling) -> fmt::Result {
        if desc.dc.op_modes.is_empty() && os.op_modes.is_empty() {
            return Ok(());
        }
        self.open("Dc")?;
        for mode in desc.dc.op_modes {
            self.op_mode(mode, &[])?;
        }
        for mode in os.op_modes {
            self.op_mode(&mode.mode, mode.sms)?;
        }
        self.close("Dc")
    }

    fn op_mode(&mut self, mode: &DcOpMode, sms: &[OpModeSm]) -> fmt::Result {
        self.open("OpMode")?;
        self.leaf_text("Name", mode.name)?;
        if !mode.description.is_empty() {
            self.leaf_text("Desc", mode.description)?;
        }
        self.leaf("AssignActivate", Hex(u32::from(mode.assign_activate), 4))?;
        if mode.assign_activate != 0 {
            self.start("CycleTimeSync0")?;
            self.attr("Factor", mode.sync0_factor)?;
            self.body_end("CycleTimeSync0", mode.cycle_time_sync0)?;
            self.leaf("ShiftTimeSync0", mode.shift_time_sync0)?;
            if mode.sync1_factor != 0 {
                // The SYNC1 cycle follows from the factor alone.
                self.start("CycleTimeSync1")?;
                self.attr("Factor", mode.sync1_factor)?;
                self.body_end("CycleTimeSync1", 0)?;
                self.leaf("ShiftTimeSync1", mode.shift_time_sync1)?;
            }
        }
        for sm in sms {
            self.start("Sm")?;
            self.attr("No", sm.sm)?;
            self.open_end()?;
            for pdo in sm.pdos {
                self.start("Pdo")?;
                if pdo.factor != 0 {
                    self.attr("OSFac", pdo.factor)?;
                }
                self.body_end("Pdo", idx(pdo.index))?;
            }
            self.close("Sm")?;
        }
        self.close("OpMode")
    }
}

/// True if an entry has anything for an `Info` element.
fn has_info(entry: &EntryDesc) -> bool {
    entry.default().is_some()
        || entry.min().is_some()
        || entry.max().is_some()
        || entry.unit().is_some()
}

/// An xs:boolean as vendor files write it.
struct Bool(bool);

impl Display for Bool {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0 { "true" } else { "false" })
    }
}

/// The `Physics` attribute: one letter per port, trailing unused ports left out.
struct Physics<'a>(&'a DeviceDescription);

impl Display for Physics<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ports = &self.0.ports;
        let used = ports
            .iter()
            .rposition(|p| p.esi_letter() != ' ')
            .map_or(0, |last| last + 1);
        ports
            .iter()
            .take(used)
            .try_for_each(|p| f.write_char(p.esi_letter()))
    }
}

// The test device has a REAL32 entry.
#[cfg(all(test, feature = "real"))]
mod tests;
