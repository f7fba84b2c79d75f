//! The EDS file (CiA 306 electronic data sheet, INI format) generated from the
//! [`DeviceDescription`], the same one the ESI ([`crate::esi`]) and the SII ([`crate::sii`])
//! are made of, so a CANopen configuration tool sees exactly the dictionary the firmware
//! serves on CAN.
//!
//! [`write_eds`] writes through any [`core::fmt::Write`] sink (no allocation). The EDS-only
//! facts (bit rates, file version, dates) come in an [`EdsInfo`].
//!
//! How the description maps onto the file:
//! - `[DeviceInfo]`: vendor and product names and numbers from the identity and the names;
//!   `NrOfRXPDO`/`NrOfTXPDO` count the PDO communication parameters (0x1400.., 0x1800..)
//!   the dictionary has; every dummy type the PDO mapping accepts (0x0001..0x0007) is
//!   listed in `[DummyUsage]`.
//! - Objects go into `[MandatoryObjects]` (0x1000, 0x1001, 0x1018), `[OptionalObjects]`
//!   (the rest of 0x1000..0x1FFF and 0x6000..0xFFFF) and `[ManufacturerObjects]`
//!   (0x2000..0x5FFF), each with its own section; an ARRAY/RECORD has `SubNumber` and one
//!   `[iiiisubN]` section per entry (gaps in a RECORD are left out).
//! - `AccessType`: `ro`, `wo`, `rw`, and for PDO-mappable writable entries `rww` (written
//!   by RPDOs) or `rwr` (read by TPDOs); `PDOMapping=1` for every mappable entry. EtherCAT
//!   state restrictions (e.g. writable in PREOP only) have no EDS form and read as `rw`.
//! - `DefaultValue`: unsigned numbers in hex, signed in decimal, strings as they are,
//!   OCTET_STRING as hex digits; a COB-ID relative to the node-ID as `$NODEID+0x180`
//!   ([`crate::canopen::params::is_node_relative`]). Entries without a default (live
//!   values such as the analog inputs) have no `DefaultValue`.
//! - `LowLimit`/`HighLimit` from the entry's minimum and maximum.
//!
//! An INI value cannot hold a line break, leading or trailing blanks, or a `;` after a blank
//! (python's INI reader takes it for a comment): such a name or string is refused
//! ([`EdsError::UnrepresentableText`]) rather than written wrong.

use crate::canopen::params::{is_node_relative, RPDO_COMMUNICATION, TPDO_COMMUNICATION};
use crate::device::{DescError, DeviceDescription};
use crate::od::{DataType, EntryDesc, ObjectCode, ObjectDesc, Value};
use core::fmt::{self, Display, Write};

/// The EDS format version written (`EDSVersion`).
pub const EDS_VERSION: &str = "4.0";

/// The objects CiA 301 makes mandatory (`[MandatoryObjects]`).
pub const MANDATORY_OBJECTS: [u16; 3] = [0x1000, 0x1001, 0x1018];

/// CiA 301 bit rates in kbit/s, in the order of the `BaudRate_n` keys.
pub const BIT_RATES_KBIT: [u16; 8] = [10, 20, 50, 125, 250, 500, 800, 1000];

/// What the EDS says beyond the device description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EdsInfo {
    /// `FileVersion`.
    pub file_version: u8,
    /// `FileRevision`.
    pub file_revision: u8,
    /// `CreationDate` and `ModificationDate`, `mm-dd-yyyy`: the description's date, not the
    /// build's, so the file is the same on every build.
    pub date: &'static str,
    /// `CreatedBy` / `ModifiedBy`.
    pub created_by: &'static str,
    /// Supported bit rates, one flag per [`BIT_RATES_KBIT`] entry.
    pub bit_rates: [bool; 8],
    /// `Granularity` of the PDO mapping (8: whole bytes).
    pub granularity: u8,
}

/// Why no EDS was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EdsError {
    /// The description does not validate.
    Description(DescError),
    /// A name or string an INI value cannot carry.
    UnrepresentableText(&'static str),
    /// The sink refused a write.
    Write,
}

impl Display for EdsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Description(e) => write!(f, "EDS: {e}"),
            Self::UnrepresentableText(s) => write!(
                f,
                "EDS: {s:?} cannot be an INI value (line break, blanks at an end, or ' ;')"
            ),
            Self::Write => f.write_str("EDS: the output refused a write"),
        }
    }
}

impl From<fmt::Error> for EdsError {
    fn from(_: fmt::Error) -> Self {
        Self::Write
    }
}

/// The file name of a device's description files without extension: the order code with
/// anything but ASCII letters, digits, `-` and `_` written as `_` (the EDS names itself
/// `<stem>.eds` in `FileName`; the ESI and SII files take the same stem).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FileStem<'a>(pub &'a str);

impl Display for FileStem<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            let safe = c.is_ascii_alphanumeric() || c == '-' || c == '_';
            f.write_char(if safe { c } else { '_' })?;
        }
        Ok(())
    }
}

/// Checks that `text` survives as an INI value.
fn ini_text(text: &'static str) -> Result<&'static str, EdsError> {
    let bad = text.contains(['\n', '\r'])
        || text.starts_with(char::is_whitespace)
        || text.ends_with(char::is_whitespace)
        || text.contains(" ;")
        || text.contains("\t;");
    if bad {
        Err(EdsError::UnrepresentableText(text))
    } else {
        Ok(text)
    }
}

/// The `AccessType` of an entry.
fn access_type(entry: &EntryDesc) -> &'static str {
    let a = entry.access;
    match (a.is_readable(), a.is_writable()) {
        (true, true) if a.is_rx_mappable() => "rww",
        (true, true) if a.is_tx_mappable() => "rwr",
        (true, true) => "rw",
        (false, true) => "wo",
        _ => "ro",
    }
}

/// Writes a number of an entry's type: hex for unsigned, decimal for signed.
fn write_number<W: Write>(
    out: &mut W,
    data_type: DataType,
    value: &Value,
) -> Result<bool, EdsError> {
    match (*value, data_type.is_signed()) {
        (Value::Int(v), true) => write!(out, "{v}")?,
        (Value::Int(v), false) => write!(out, "0x{v:X}")?,
        (Value::Uint(v), true) => write!(out, "{}", v as i64)?,
        (Value::Uint(v), false) => write!(out, "0x{v:X}")?,
        (Value::Real(v), _) => write!(out, "{v}")?,
        _ => return Ok(false),
    }
    Ok(true)
}

/// Writes `key=value` for a value of an entry, nothing for [`Value::None`].
fn write_value<W: Write>(
    out: &mut W,
    key: &str,
    entry: &EntryDesc,
    value: &Value,
    node_relative: bool,
) -> Result<(), EdsError> {
    match *value {
        Value::None => Ok(()),
        Value::Str(s) => {
            writeln!(out, "{key}={}", ini_text(s)?)?;
            Ok(())
        }
        Value::Bytes(b) => {
            write!(out, "{key}=")?;
            for byte in b {
                write!(out, "{byte:02X}")?;
            }
            writeln!(out)?;
            Ok(())
        }
        _ => {
            write!(out, "{key}=")?;
            if node_relative {
                write!(out, "$NODEID+")?;
            }
            write_number(out, entry.data_type(), value)?;
            writeln!(out)?;
            Ok(())
        }
    }
}

/// Writes the section of one entry (`[1018sub1]`, or `[1000]` for a VAR).
fn write_entry<W: Write>(
    out: &mut W,
    object: &ObjectDesc,
    entry: &EntryDesc,
) -> Result<(), EdsError> {
    if object.code() == ObjectCode::Var {
        writeln!(out, "[{:04X}]", object.index)?;
    } else {
        writeln!(out, "[{:04X}sub{:X}]", object.index, entry.subindex)?;
    }
    writeln!(out, "ParameterName={}", ini_text(entry.name)?)?;
    writeln!(out, "ObjectType=0x7")?;
    writeln!(out, "DataType=0x{:04X}", entry.data_type().code())?;
    writeln!(out, "AccessType={}", access_type(entry))?;
    let entry = &object.resolve(entry);
    let relative = is_node_relative(object.index, entry.subindex);
    write_value(out, "DefaultValue", entry, &entry.default(), relative)?;
    write_value(out, "LowLimit", entry, &entry.min(), false)?;
    write_value(out, "HighLimit", entry, &entry.max(), false)?;
    let mappable = entry.access.is_rx_mappable() || entry.access.is_tx_mappable();
    writeln!(out, "PDOMapping={}", u8::from(mappable))?;
    writeln!(out)?;
    Ok(())
}

fn write_object<W: Write>(out: &mut W, object: &ObjectDesc) -> Result<(), EdsError> {
    if object.code() == ObjectCode::Var {
        if let Some(entry) = object.entries.first() {
            write_entry(out, object, entry)?;
        }
        return Ok(());
    }
    writeln!(out, "[{:04X}]", object.index)?;
    writeln!(out, "ParameterName={}", ini_text(object.name)?)?;
    writeln!(out, "ObjectType=0x{:X}", object.code().code())?;
    writeln!(out, "SubNumber=0x{:X}", object.entries.len())?;
    writeln!(out)?;
    for entry in object.entries {
        write_entry(out, object, entry)?;
    }
    Ok(())
}

/// Which object list an index belongs to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum List {
    Mandatory,
    Optional,
    Manufacturer,
}

fn list_of(index: u16) -> List {
    if MANDATORY_OBJECTS.contains(&index) {
        List::Mandatory
    } else if (0x2000..0x6000).contains(&index) {
        List::Manufacturer
    } else {
        List::Optional
    }
}

fn write_list<W: Write>(
    out: &mut W,
    desc: &DeviceDescription,
    name: &str,
    list: List,
) -> Result<(), EdsError> {
    let objects = || desc.od.iter().filter(move |o| list_of(o.index) == list);
    writeln!(out, "[{name}]")?;
    writeln!(out, "SupportedObjects={}", objects().count())?;
    for (n, o) in (1..).zip(objects()) {
        writeln!(out, "{n}=0x{:04X}", o.index)?;
    }
    writeln!(out)?;
    Ok(())
}

/// Writes the EDS of `desc` into `out`.
pub fn write_eds<W: Write>(
    desc: &DeviceDescription,
    info: &EdsInfo,
    out: &mut W,
) -> Result<(), EdsError> {
    desc.validate().map_err(EdsError::Description)?;
    let count_in =
        |range: core::ops::Range<u16>| desc.od.iter().filter(|o| range.contains(&o.index)).count();
    let rx_pdos = count_in(RPDO_COMMUNICATION..RPDO_COMMUNICATION + 0x200);
    let tx_pdos = count_in(TPDO_COMMUNICATION..TPDO_COMMUNICATION + 0x200);
    let id = &desc.identity;
    let names = &desc.names;

    writeln!(out, "[FileInfo]")?;
    writeln!(out, "FileName={}.eds", FileStem(names.order_code))?;
    writeln!(out, "FileVersion={}", info.file_version)?;
    writeln!(out, "FileRevision={}", info.file_revision)?;
    writeln!(out, "EDSVersion={EDS_VERSION}")?;
    writeln!(out, "Description={}", ini_text(names.device_name)?)?;
    for what in ["Creation", "Modification"] {
        writeln!(out, "{what}Time=12:00AM")?;
        writeln!(out, "{what}Date={}", ini_text(info.date)?)?;
    }
    writeln!(out, "CreatedBy={}", ini_text(info.created_by)?)?;
    writeln!(out, "ModifiedBy={}", ini_text(info.created_by)?)?;
    writeln!(out)?;

    writeln!(out, "[DeviceInfo]")?;
    writeln!(out, "VendorName={}", ini_text(names.vendor_name)?)?;
    writeln!(out, "VendorNumber=0x{:08X}", id.vendor_id)?;
    writeln!(out, "ProductName={}", ini_text(names.device_name)?)?;
    writeln!(out, "ProductNumber=0x{:08X}", id.product_code)?;
    writeln!(out, "RevisionNumber=0x{:08X}", id.revision)?;
    writeln!(out, "OrderCode={}", ini_text(names.order_code)?)?;
    for (kbit, on) in BIT_RATES_KBIT.iter().zip(info.bit_rates) {
        writeln!(out, "BaudRate_{kbit}={}", u8::from(on))?;
    }
    writeln!(out, "SimpleBootUpMaster=0")?;
    writeln!(out, "SimpleBootUpSlave=1")?;
    writeln!(out, "Granularity={}", info.granularity)?;
    writeln!(out, "DynamicChannelsSupported=0")?;
    writeln!(out, "GroupMessaging=0")?;
    writeln!(out, "NrOfRXPDO={rx_pdos}")?;
    writeln!(out, "NrOfTXPDO={tx_pdos}")?;
    writeln!(out, "LSS_Supported=0")?;
    writeln!(out)?;

    // The PDO mapping takes the basic types 0x0001..0x0007 as dummy entries.
    writeln!(out, "[DummyUsage]")?;
    for i in 1..=7 {
        writeln!(out, "Dummy{i:04}=1")?;
    }
    writeln!(out)?;

    writeln!(out, "[Comments]")?;
    writeln!(out, "Lines=1")?;
    writeln!(
        out,
        "Line1=Generated from the device description (the ESI and the SII come from the same)"
    )?;
    writeln!(out)?;

    write_list(out, desc, "MandatoryObjects", List::Mandatory)?;
    write_list(out, desc, "OptionalObjects", List::Optional)?;
    write_list(out, desc, "ManufacturerObjects", List::Manufacturer)?;
    for object in desc.od.iter() {
        write_object(out, object)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::od::{Access, ObjectDictionary, ValueRange};
    use std::string::String;

    #[test]
    fn file_stems() {
        assert_eq!(std::format!("{}", FileStem("AIO-8AI2AO")), "AIO-8AI2AO");
        assert_eq!(
            std::format!("{}", FileStem("AIO-8AI/2AO v1.0")),
            "AIO-8AI_2AO_v1_0"
        );
    }

    #[test]
    fn access_types() {
        let e = |a| EntryDesc::new(1, "x", DataType::Integer16, a);
        assert_eq!(access_type(&e(Access::RO)), "ro");
        assert_eq!(access_type(&e(Access::RO.tx_mappable())), "ro");
        assert_eq!(access_type(&e(Access::RW)), "rw");
        assert_eq!(access_type(&e(Access::RW_PREOP)), "rw");
        assert_eq!(access_type(&e(Access::RW.rx_mappable())), "rww");
        assert_eq!(access_type(&e(Access::RW.tx_mappable())), "rwr");
        assert_eq!(access_type(&e(Access::WO)), "wo");
    }

    #[test]
    fn text_that_ini_cannot_carry() {
        assert!(
            ini_text("AI 1; channel").is_ok(),
            "';' after a letter is kept"
        );
        for bad in ["a ;b", "a\nb", " lead", "trail ", "a\t;b"] {
            assert!(ini_text(bad).is_err(), "{bad:?}");
        }
    }

    static OD: ObjectDictionary = ObjectDictionary::new(&[
        ObjectDesc::var(
            0x1000,
            "Device type",
            &[
                EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
                    .with_default(Value::Uint(0x000C_0191)),
            ],
        ),
        ObjectDesc::record(
            0x1800,
            "TPDO 1 communication parameter",
            DataType::Unknown(0x20),
            &[
                EntryDesc::count(5),
                EntryDesc::new(1, "COB-ID used by TPDO", DataType::Unsigned32, Access::RW)
                    .with_default(Value::Uint(0x8000_0180)),
                EntryDesc::new(5, "Event timer", DataType::Unsigned16, Access::RW),
            ],
        ),
        ObjectDesc::var(
            0x2000,
            "Offset",
            &[EntryDesc::new(0, "Offset", DataType::Integer16, Access::RW)
                .with_default(Value::Int(-5))
                .with_range(&ValueRange {
                    min: Value::Int(-100),
                    max: Value::Int(100),
                })],
        ),
    ]);

    #[test]
    fn sections_of_the_objects() {
        let mut out = String::new();
        for o in OD.iter() {
            write_object(&mut out, o).unwrap();
        }
        let expected = "[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\n\
            AccessType=ro\nDefaultValue=0xC0191\nPDOMapping=0\n\n\
            [1800]\nParameterName=TPDO 1 communication parameter\nObjectType=0x9\nSubNumber=0x3\n\n\
            [1800sub0]\nParameterName=SubIndex 000\nObjectType=0x7\nDataType=0x0005\n\
            AccessType=ro\nDefaultValue=0x5\nPDOMapping=0\n\n\
            [1800sub1]\nParameterName=COB-ID used by TPDO\nObjectType=0x7\nDataType=0x0007\n\
            AccessType=rw\nDefaultValue=$NODEID+0x80000180\nPDOMapping=0\n\n\
            [1800sub5]\nParameterName=Event timer\nObjectType=0x7\nDataType=0x0006\n\
            AccessType=rw\nPDOMapping=0\n\n\
            [2000]\nParameterName=Offset\nObjectType=0x7\nDataType=0x0003\nAccessType=rw\n\
            DefaultValue=-5\nLowLimit=-100\nHighLimit=100\nPDOMapping=0\n\n";
        assert_eq!(out, expected);
    }

    #[test]
    fn object_lists() {
        assert!(list_of(0x1000) == List::Mandatory);
        assert!(list_of(0x1005) == List::Optional);
        assert!(list_of(0x2001) == List::Manufacturer);
        assert!(list_of(0x6401) == List::Optional);
    }
}
