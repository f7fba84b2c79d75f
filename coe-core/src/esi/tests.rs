//! The ESI file parsed back with an XML parser and checked against the description, value
//! by value; the expected values (type names, bit offsets, byte images, checksum) are
//! computed here independently of the generator.

use super::*;
use crate::device::oversampling::tests::{os_device, OS};
use crate::device::oversampling::{OpModePdo, OpModeSm, OpModeWithPdos, Oversampling, PdoReplicas};
use crate::device::tests::valid;
use crate::device::{
    CoeDetails, DcDesc, DcOpMode, DescErrorKind, EepromDesc, FmmuUsage, Identity, MailboxDesc,
    MemoryWindow, Names, PortType, SmRole, SyncManagerDesc,
};
use crate::od::{ObjectDictionary, OdErrorKind, ValueRange};
use roxmltree::{Document, Node};
use std::boxed::Box;
use std::path::PathBuf;
use std::string::{String, ToString};
use std::vec::Vec;
use std::{format, vec};

const BOOL: DataType = DataType::Boolean;
const I16: DataType = DataType::Integer16;
const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const RO: Access = Access::RO;
const RW: Access = Access::RW;
const RWP: Access = Access::RW_PREOP;

fn leak<T>(v: Vec<T>) -> &'static [T] {
    Box::leak(v.into_boxed_slice())
}

fn sub_name(i: usize) -> &'static str {
    Box::leak(format!("SubIndex {i:03}").into_boxed_str())
}

/// Sub 0 (count `count`, access `sub0`) and one entry per default, `slots` entries in all.
fn table(
    count: usize,
    slots: usize,
    t: DataType,
    access: Access,
    defaults: &[u32],
) -> &'static [EntryDesc] {
    let mut e = vec![EntryDesc::count(count as u8).with_access(access)];
    for i in 1..=slots {
        let mut entry = EntryDesc::new(i as u8, sub_name(i), t, access);
        if let Some(d) = defaults.get(i - 1) {
            entry = entry.with_default(Value::Uint(u64::from(*d)));
        }
        e.push(entry);
    }
    leak(e)
}

fn mapping(index: u16, name: &'static str, access: Access, entries: &[u32]) -> ObjectDesc {
    ObjectDesc::record(
        index,
        name,
        DataType::PdoMapping,
        table(entries.len(), 8, U32, access, entries),
    )
}

fn channels(names: &[&'static str], t: DataType, access: Access) -> &'static [EntryDesc] {
    let mut e = vec![EntryDesc::count(names.len() as u8)];
    for (i, n) in names.iter().enumerate() {
        e.push(EntryDesc::new(i as u8 + 1, n, t, access));
    }
    leak(e)
}

const MODULE_TEXT: &str = "8 analog inputs 0..10 V and 2 analog outputs 0..10 V; \
     LPC1754 + ET1100 on SPI; CoE with SDO Information and complete access.";

/// The dictionary of a module like ours: 8 AI, 2 AO, configurable PDOs, sync parameters,
/// settings with units, ranges and backup flags, a long string, an octet string, a REAL32,
/// and an ARRAY whose elements differ in access.
fn objects() -> Vec<ObjectDesc> {
    let ai: Vec<u32> = (1..=8).map(|s| 0x6401_0010 | s << 8).collect();
    vec![
        ObjectDesc::var(
            0x1000,
            "Device type",
            leak(vec![
                EntryDesc::new(0, "Device type", U32, RO).with_default(Value::Uint(0x000C_0191))
            ]),
        ),
        ObjectDesc::var(
            0x1001,
            "Error register",
            leak(vec![EntryDesc::new(
                0,
                "Error register",
                U8,
                RO.tx_mappable(),
            )]),
        ),
        ObjectDesc::var(
            0x1008,
            "Device name",
            leak(vec![EntryDesc::string(
                0,
                "Device name",
                "Analog IO 8AI 2AO",
            )]),
        ),
        ObjectDesc::var(
            0x1009,
            "Hardware version",
            leak(vec![EntryDesc::string(0, "Hardware version", "rev A")]),
        ),
        ObjectDesc::var(
            0x100A,
            "Software version",
            leak(vec![EntryDesc::string(0, "Software version", "0.1.0")]),
        ),
        ObjectDesc::record(
            0x1018,
            "Identity",
            DataType::Identity,
            leak(vec![
                EntryDesc::count(4),
                EntryDesc::new(1, "Vendor ID", U32, RO).with_default(Value::Uint(0)),
                EntryDesc::new(2, "Product code", U32, RO).with_default(Value::Uint(0x1754)),
                EntryDesc::new(3, "Revision", U32, RO).with_default(Value::Uint(0x0001_0000)),
                EntryDesc::new(4, "Serial number", U32, RO).with_default(Value::Uint(0)),
            ]),
        ),
        ObjectDesc::record(
            0x10F1,
            "Error settings",
            DataType::Unknown(0x40),
            leak(vec![
                EntryDesc::count(2),
                EntryDesc::new(1, "Local error reaction", U32, RW).with_default(Value::Uint(0)),
                EntryDesc::new(2, "Sync error counter limit", U16, RW).with_default(Value::Uint(4)),
            ]),
        ),
        mapping(0x1600, "RxPDO 1", RWP, &[0x6411_0110, 0x6411_0210]),
        mapping(0x1601, "RxPDO 2", RWP, &[]),
        mapping(0x1A00, "TxPDO 1", RWP, &ai),
        // Fixed (sub 0 read-only), not assigned, with a gap.
        mapping(0x1A01, "Status", RO, &[0x1001_0008, 0x0000_0008]),
        ObjectDesc::array(
            0x1C00,
            "Sync manager type",
            table(4, 4, U8, RO, &[1, 2, 3, 4]),
        ),
        ObjectDesc::array(0x1C12, "RxPDO assign", table(1, 2, U16, RWP, &[0x1600])),
        ObjectDesc::array(0x1C13, "TxPDO assign", table(1, 2, U16, RWP, &[0x1A00])),
        ObjectDesc::record(
            0x1C32,
            "SM output parameter",
            DataType::Unknown(0x42),
            leak(vec![
                EntryDesc::new(0, "SubIndex 000", U8, RO).with_default(Value::Uint(0x20)),
                EntryDesc::new(1, "Sync mode", U16, RWP).with_default(Value::Uint(1)),
                EntryDesc::new(2, "Cycle time", U32, RWP).with_default(Value::Uint(0)),
                EntryDesc::new(4, "Sync modes supported", U16, RO)
                    .with_default(Value::Uint(0x0007)),
                EntryDesc::new(5, "Minimum cycle time", U32, RO).with_default(Value::Uint(125_000)),
                EntryDesc::new(0x0B, "SM event missed", U16, RO),
                EntryDesc::new(0x20, "Sync error", BOOL, RO),
            ]),
        ),
        ObjectDesc::record(
            0x2000,
            "Analog input settings",
            DataType::Unknown(0x41),
            leak(vec![
                EntryDesc::count(3),
                EntryDesc::new(1, "Filter", U8, RW.backup().settings())
                    .with_default(Value::Uint(1))
                    .with_range(&ValueRange {
                        min: Value::Uint(0),
                        max: Value::Uint(3),
                    }),
                EntryDesc::new(2, "Full scale", U32, RO)
                    .with_default(Value::Uint(10_000_000))
                    .with_unit(0x0026),
                EntryDesc::new(3, "Offset", DataType::Integer16, Access::RW_PREOP_SAFEOP)
                    .with_default(Value::Int(-2))
                    .with_range(&ValueRange {
                        min: Value::Int(-100),
                        max: Value::Int(100),
                    }),
            ]),
        ),
        ObjectDesc::var(
            0x2001,
            "Module description",
            leak(vec![EntryDesc::string(
                0,
                "Module description",
                MODULE_TEXT,
            )]),
        ),
        ObjectDesc::var(
            0x2002,
            "Calibration block",
            leak(vec![EntryDesc::new(
                0,
                "Calibration block",
                DataType::OctetString,
                RO,
            )
            .with_bits(32)
            .with_default(Value::Bytes(&[0xDE, 0xAD, 0xBE, 0xEF]))]),
        ),
        ObjectDesc::var(
            0x2003,
            "Gain",
            leak(vec![EntryDesc::new(0, "Gain", DataType::Real32, RW)
                .with_default(Value::Real(1.5))
                .with_range(&ValueRange {
                    min: Value::Real(0.0),
                    max: Value::Real(4.0),
                })]),
        ),
        ObjectDesc::var(
            0x2004,
            "Write-only command",
            leak(vec![EntryDesc::new(
                0,
                "Write-only command",
                U16,
                Access::WO,
            )]),
        ),
        ObjectDesc::array(
            0x6401,
            "Read analog input 16-bit",
            channels(
                &[
                    "AI 1", "AI 2", "AI 3", "AI 4", "AI 5", "AI 6", "AI 7", "AI 8",
                ],
                I16,
                RO.tx_mappable(),
            ),
        ),
        ObjectDesc::array(
            0x6411,
            "Write analog output 16-bit",
            channels(&["AO 1", "AO 2"], I16, RW.rx_mappable()),
        ),
        // Elements of one type but differing access: written as a record-style data type.
        ObjectDesc::array(
            0x8000,
            "Channel enable",
            leak(vec![
                EntryDesc::count(2),
                EntryDesc::new(1, "Channel 1 enable", BOOL, RW).with_default(Value::Uint(1)),
                EntryDesc::new(2, "Channel 2 enable", BOOL, RO).with_default(Value::Uint(0)),
            ]),
        ),
    ]
}

const SMS: [SyncManagerDesc; 4] = [
    SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, 128, 0x26),
    SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, 128, 0x22),
    SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, 32, 0x64),
    SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1180, 32, 0x20),
];

const OP_MODES: &[DcOpMode] = &[
    DcOpMode {
        name: "SM-Synchron",
        description: "SM-Synchron (outputs on the SM2 event)",
        assign_activate: 0,
        sync_mode: 1,
        cycle_time_sync0: 0,
        sync0_factor: 0,
        shift_time_sync0: 0,
        sync1_factor: 0,
        shift_time_sync1: 0,
    },
    DcOpMode {
        name: "DC",
        description: "DC-Synchron (outputs latched at SYNC0)",
        assign_activate: 0x0300,
        sync_mode: 2,
        cycle_time_sync0: 0,
        sync0_factor: 1,
        shift_time_sync0: 5_000,
        sync1_factor: 0,
        shift_time_sync1: 0,
    },
    DcOpMode {
        name: "DC-Sync01",
        description: "",
        assign_activate: 0x0700,
        sync_mode: 3,
        cycle_time_sync0: 1_000_000,
        sync0_factor: 0,
        shift_time_sync0: 0,
        sync1_factor: 2,
        shift_time_sync1: 10_000,
    },
];

fn device(objects: Vec<ObjectDesc>) -> DeviceDescription {
    DeviceDescription {
        identity: Identity {
            vendor_id: 0,
            product_code: 0x1754,
            revision: 0x0001_0000,
            serial_number: 0,
        },
        names: Names {
            vendor_name: "Placeholder vendor",
            device_name: "Analog IO 8AI 2AO",
            order_code: "AIO-8AI2AO",
            group_type: "AnalogIO",
            group_name: "Analog I/O",
            hardware_version: "rev A",
            software_version: "0.1.0",
        },
        od: Box::leak(Box::new(ObjectDictionary::new(leak(objects)))),
        sync_managers: &SMS,
        fmmus: &[
            FmmuUsage::Outputs,
            FmmuUsage::Inputs,
            FmmuUsage::MailboxState,
        ],
        mailbox: MailboxDesc {
            protocols: MailboxProtocols(MailboxProtocols::COE | MailboxProtocols::FOE),
            coe: CoeDetails(
                CoeDetails::SDO
                    | CoeDetails::SDO_INFO
                    | CoeDetails::PDO_ASSIGN
                    | CoeDetails::PDO_CONFIG
                    | CoeDetails::COMPLETE_ACCESS,
            ),
            bootstrap: Some((
                MemoryWindow::new(0x1000, 0x80),
                MemoryWindow::new(0x1080, 0x80),
            )),
        },
        dc: DcDesc {
            op_modes: OP_MODES,
            min_cycle_ns: 125_000,
            max_cycle_ns: u32::MAX,
        },
        eeprom: EepromDesc {
            size_bytes: 2048,
            station_alias: 0x1234,
            version: 1,
        },
        // PDI, process RAM, ports: as the device tests' valid description.
        ..valid()
    }
}

fn module() -> DeviceDescription {
    device(objects())
}

fn esi(desc: &DeviceDescription) -> String {
    let mut out = String::new();
    write_esi(desc, &mut out).unwrap_or_else(|e| panic!("{e}"));
    out
}

/// `objects()` with the object of `object.index` replaced (or inserted in order).
fn objects_with(object: ObjectDesc) -> Vec<ObjectDesc> {
    let mut objects = objects();
    match objects.binary_search_by_key(&object.index, |o| o.index) {
        Ok(i) => objects[i] = object,
        Err(i) => objects.insert(i, object),
    }
    objects
}

// ---- reading the document ----

fn child<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Node<'a, 'i> {
    node.children()
        .find(|n| n.has_tag_name(name))
        .unwrap_or_else(|| panic!("<{}> has no <{name}>", node.tag_name().name()))
}

fn opt_child<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    node.children().find(|n| n.has_tag_name(name))
}

fn children<'a, 'i>(node: Node<'a, 'i>, name: &'static str) -> Vec<Node<'a, 'i>> {
    node.children().filter(|n| n.has_tag_name(name)).collect()
}

fn text<'a>(node: Node<'a, '_>) -> &'a str {
    node.text().unwrap_or("")
}

fn child_text<'a>(node: Node<'a, '_>, name: &str) -> &'a str {
    text(child(node, name))
}

/// A HexDecValue: `#x1A00` or `123`.
fn hexdec(s: &str) -> i128 {
    match s.strip_prefix("#x") {
        Some(hex) => i128::from_str_radix(hex, 16).unwrap_or_else(|_| panic!("bad hex {s:?}")),
        None => s.parse().unwrap_or_else(|_| panic!("bad number {s:?}")),
    }
}

fn child_num(node: Node<'_, '_>, name: &str) -> i128 {
    hexdec(child_text(node, name))
}

fn attr_num(node: Node<'_, '_>, name: &str) -> Option<i128> {
    node.attribute(name).map(hexdec)
}

fn hex_bytes(s: &str) -> Vec<u8> {
    assert!(s.len() % 2 == 0, "odd hexBinary {s:?}");
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

fn xml_bool(s: &str) -> bool {
    match s {
        "true" | "1" => true,
        "false" | "0" => false,
        _ => panic!("not an xs:boolean: {s:?}"),
    }
}

// ---- the expected values, computed independently ----

/// ETG.2000 names of the basic types this test uses.
fn expected_type(e: &EntryDesc) -> String {
    match e.data_type() {
        DataType::Boolean => "BOOL".into(),
        DataType::Unsigned8 => "USINT".into(),
        DataType::Unsigned16 => "UINT".into(),
        DataType::Unsigned32 => "UDINT".into(),
        DataType::Integer16 => "INT".into(),
        DataType::Real32 => "REAL".into(),
        DataType::VisibleString => format!("STRING({})", e.bit_len / 8),
        DataType::OctetString => format!("ARRAY [0..{}] OF BYTE", e.bit_len / 8 - 1),
        other => panic!("the test does not know {other:?}"),
    }
}

/// Complete-access bit offsets: sub 0 of an ARRAY/RECORD 16 bits, whole-byte entries on a
/// byte boundary, bit entries packed.
fn expected_offsets(object: &ObjectDesc) -> (Vec<u32>, u32) {
    let mut offsets = Vec::new();
    let mut bit = 0u32;
    for e in object.entries {
        if e.bit_len % 8 == 0 {
            bit = bit.div_ceil(8) * 8;
        }
        offsets.push(bit);
        bit += if e.subindex == 0 {
            16
        } else {
            u32::from(e.bit_len)
        };
    }
    (offsets, bit.div_ceil(8) * 8)
}

/// The little-endian SDO image of a value.
fn expected_bytes(e: &EntryDesc, v: &Value) -> Option<Vec<u8>> {
    let len = usize::from(e.bit_len).div_ceil(8);
    match *v {
        Value::None => None,
        Value::Int(x) => Some(x.to_le_bytes()[..len].to_vec()),
        Value::Uint(x) => Some(x.to_le_bytes()[..len].to_vec()),
        Value::Real(x) if e.data_type() == DataType::Real32 => {
            Some((x as f32).to_le_bytes().to_vec())
        }
        Value::Real(x) => Some(x.to_le_bytes().to_vec()),
        Value::Bytes(b) => Some(b.to_vec()),
        Value::Str(s) => Some(s.as_bytes().to_vec()),
    }
}

fn expected_restriction(bits: u16) -> Option<&'static str> {
    match bits {
        0b001 => Some("PreOP"),
        0b011 => Some("PreOP_SafeOP"),
        0b101 => Some("PreOP_OP"),
        0b010 => Some("SafeOP"),
        0b110 => Some("SafeOP_OP"),
        0b100 => Some("OP"),
        _ => None,
    }
}

/// The default of `object:sub` as a number, straight from the table.
fn raw_default(object: &ObjectDesc, sub: u8) -> Option<u32> {
    object
        .entries
        .iter()
        .find(|e| e.subindex == sub)
        .and_then(|e| e.default().as_i128())
        .map(|v| v as u32)
}

/// CRC-8, polynomial 0x07, initial 0xFF, bit by bit.
fn crc8_bitwise(data: &[u8]) -> u8 {
    let mut crc = 0xFFu8;
    for &byte in data {
        for bit in (0..8).rev() {
            let feedback = (crc >> 7) ^ ((byte >> bit) & 1);
            crc <<= 1;
            if feedback != 0 {
                crc ^= 0x07;
            }
        }
    }
    crc
}

// ---- the checks ----

fn check_info(info: Option<Node<'_, '_>>, e: &EntryDesc, what: &str) {
    let find = |name: &str| {
        info.and_then(|i| opt_child(i, name))
            .map(|n| text(n).to_string())
    };
    match (e.data_type(), e.default()) {
        (DataType::VisibleString, Value::Str(s)) => {
            assert_eq!(
                find("DefaultString").as_deref(),
                Some(s),
                "{what} DefaultString"
            );
            assert_eq!(find("DefaultData"), None, "{what}");
        }
        _ => {
            for (tag, value) in [
                ("DefaultData", &e.default()),
                ("MinData", &e.min()),
                ("MaxData", &e.max()),
            ] {
                assert_eq!(
                    find(tag).map(|t| hex_bytes(&t)),
                    expected_bytes(e, value),
                    "{what} {tag}"
                );
            }
        }
    }
    assert_eq!(
        find("Unit").map(|u| hexdec(&u) as u16),
        e.unit(),
        "{what} Unit"
    );
}

fn check_flags(flags: Node<'_, '_>, access: Access, what: &str) {
    let a = child(flags, "Access");
    let expected = match (access.bits() & 0x07 != 0, access.bits() & 0x38 != 0) {
        (true, true) => "rw",
        (false, true) => "wo",
        _ => "ro",
    };
    assert_eq!(text(a), expected, "{what} Access");
    assert_eq!(
        a.attribute("WriteRestrictions"),
        expected_restriction((access.bits() >> 3) & 7),
        "{what} WriteRestrictions"
    );
    assert_eq!(
        a.attribute("ReadRestrictions"),
        expected_restriction(access.bits() & 7),
        "{what} ReadRestrictions"
    );
    let mapping = match (access.is_rx_mappable(), access.is_tx_mappable()) {
        (true, true) => Some("RT"),
        (true, false) => Some("R"),
        (false, true) => Some("T"),
        _ => None,
    };
    assert_eq!(
        opt_child(flags, "PdoMapping").map(text),
        mapping,
        "{what} PdoMapping"
    );
    let flag = |name| opt_child(flags, name).map(|n| child_num_text(n));
    assert_eq!(
        flag("Backup"),
        access.contains(Access::BACKUP).then_some(1),
        "{what} Backup"
    );
    assert_eq!(
        flag("Setting"),
        access.contains(Access::SETTINGS).then_some(1),
        "{what} Setting"
    );
}

fn child_num_text(n: Node<'_, '_>) -> i128 {
    hexdec(text(n))
}

/// The `DataType` called `name` (exactly one).
fn data_type<'a, 'i>(dict: Node<'a, 'i>, name: &str) -> Node<'a, 'i> {
    let matches: Vec<_> = children(child(dict, "DataTypes"), "DataType")
        .into_iter()
        .filter(|d| child_text(*d, "Name") == name)
        .collect();
    assert_eq!(
        matches.len(),
        1,
        "DataType {name:?} defined {} times",
        matches.len()
    );
    matches[0]
}

fn check_object(dict: Node<'_, '_>, xml: Node<'_, '_>, object: &ObjectDesc) {
    let what = format!("object {:#06X}", object.index);
    assert_eq!(child_num(xml, "Index"), i128::from(object.index), "{what}");
    let name = child(xml, "Name");
    assert_eq!(text(name), object.name, "{what} Name");
    assert_eq!(name.attribute("LcId"), Some("1033"));
    let type_name = child_text(xml, "Type");
    let info = opt_child(xml, "Info");
    if object.code() == ObjectCode::Var {
        let e = &object.entries[0];
        assert_eq!(type_name, expected_type(e), "{what} Type");
        assert_eq!(
            child_num(xml, "BitSize"),
            i128::from(e.bit_len),
            "{what} BitSize"
        );
        let base = data_type(dict, type_name);
        assert_eq!(
            child_num(base, "BitSize"),
            i128::from(e.bit_len),
            "{what} type BitSize"
        );
        check_info(info, e, &what);
        check_flags(child(xml, "Flags"), e.access, &what);
        return;
    }
    assert_eq!(type_name, format!("DT{:04X}", object.index), "{what} Type");
    let (offsets, bits) = expected_offsets(object);
    assert_eq!(
        child_num(xml, "BitSize"),
        i128::from(bits),
        "{what} BitSize"
    );
    check_flags(child(xml, "Flags"), object.entries[0].access, &what);
    let dt = data_type(dict, type_name);
    assert_eq!(
        child_num(dt, "BitSize"),
        i128::from(bits),
        "{what} type BitSize"
    );
    let info_items = children(info.expect("ARRAY/RECORD without Info"), "SubItem");
    assert_eq!(
        info_items.len(),
        object.entries.len(),
        "{what} Info SubItems"
    );
    let sub_items = children(dt, "SubItem");
    let elements = sub_items
        .iter()
        .find(|s| child_text(**s, "Name") == "Elements");
    for (k, e) in object.entries.iter().enumerate() {
        let what = format!("{what}:{:02X}", e.subindex);
        // Object Info: name and values, in subindex order.
        assert_eq!(
            child_text(info_items[k], "Name"),
            e.name,
            "{what} Info Name"
        );
        check_info(Some(child(info_items[k], "Info")), e, &what);
        // Data type: the entry's own SubItem, or the array's Elements.
        let own = sub_items.iter().find(|s| {
            opt_child(**s, "SubIdx").is_some_and(|n| hexdec(text(n)) == i128::from(e.subindex))
        });
        match (own, elements) {
            (Some(s), _) => {
                assert_eq!(child_text(*s, "Name"), e.name, "{what} SubItem Name");
                assert_eq!(
                    child_text(*s, "Type"),
                    expected_type(e),
                    "{what} SubItem Type"
                );
                assert_eq!(child_num(*s, "BitSize"), i128::from(e.bit_len), "{what}");
                assert_eq!(
                    child_num(*s, "BitOffs"),
                    i128::from(offsets[k]),
                    "{what} BitOffs"
                );
                check_flags(child(*s, "Flags"), e.access, &what);
                data_type(dict, &expected_type(e));
            }
            (None, Some(el)) => {
                assert_eq!(
                    object.code(),
                    ObjectCode::Array,
                    "{what}: only arrays have Elements"
                );
                let n = object.entries.len() - 1;
                assert_eq!(
                    usize::from(e.subindex),
                    k,
                    "{what}: elements are subindices 1..n"
                );
                let arr = data_type(dict, child_text(*el, "Type"));
                assert_eq!(
                    child_text(arr, "BaseType"),
                    expected_type(e),
                    "{what} BaseType"
                );
                let array_info = child(arr, "ArrayInfo");
                assert_eq!(child_num(array_info, "LBound"), 1);
                assert_eq!(
                    child_num(array_info, "Elements"),
                    n as i128,
                    "{what} Elements"
                );
                let total = n as i128 * i128::from(e.bit_len);
                assert_eq!(child_num(arr, "BitSize"), total, "{what}");
                assert_eq!(child_num(*el, "BitSize"), total, "{what}");
                assert_eq!(
                    child_num(*el, "BitOffs"),
                    i128::from(offsets[1]),
                    "{what} BitOffs"
                );
                check_flags(child(*el, "Flags"), e.access, &what);
            }
            (None, None) => panic!("{what}: no SubItem in {type_name}"),
        }
    }
}

fn check_pdos(
    device: Node<'_, '_>,
    desc: &DeviceDescription,
    tag: &'static str,
    range: core::ops::RangeInclusive<u16>,
    assign: u16,
    sm: u8,
) {
    let pdos = children(device, tag);
    let objects: Vec<&ObjectDesc> = desc
        .od
        .iter()
        .filter(|o| range.contains(&o.index))
        .collect();
    assert_eq!(pdos.len(), objects.len(), "{tag} count");
    let assign = desc.od.find(assign).unwrap();
    let assigned: Vec<u32> = (1..=raw_default(assign, 0).unwrap() as u8)
        .map(|s| raw_default(assign, s).unwrap())
        .collect();
    for (xml, object) in pdos.iter().zip(objects) {
        let what = format!("{tag} {:#06X}", object.index);
        assert_eq!(child_num(*xml, "Index"), i128::from(object.index), "{what}");
        assert_eq!(child_text(*xml, "Name"), object.name, "{what} Name");
        let fixed = !object.entries[0].access.is_writable();
        assert_eq!(
            xml.attribute("Fixed").map(xml_bool).unwrap_or(false),
            fixed,
            "{what} Fixed"
        );
        let is_assigned = assigned.contains(&u32::from(object.index));
        assert_eq!(
            attr_num(*xml, "Sm"),
            is_assigned.then_some(i128::from(sm)),
            "{what} Sm"
        );
        // The assignment is configurable (PdoAssign), so nothing is mandatory.
        assert_eq!(xml.attribute("Mandatory"), None, "{what}");
        let entries = children(*xml, "Entry");
        let count = raw_default(object, 0).unwrap() as u8;
        assert_eq!(entries.len(), usize::from(count), "{what} entries");
        for (sub, entry) in (1..=count).zip(entries) {
            let raw = raw_default(object, sub).unwrap();
            let (index, subindex, bits) = ((raw >> 16) as u16, (raw >> 8) as u8, raw as u8);
            assert_eq!(child_num(entry, "BitLen"), i128::from(bits), "{what}:{sub}");
            if index == 0 {
                assert_eq!(child_num(entry, "Index"), 0, "{what}:{sub} gap");
                assert!(
                    opt_child(entry, "SubIndex").is_none() && opt_child(entry, "Name").is_none()
                );
                continue;
            }
            assert_eq!(child_num(entry, "Index"), i128::from(index), "{what}:{sub}");
            assert_eq!(
                child_num(entry, "SubIndex"),
                i128::from(subindex),
                "{what}:{sub}"
            );
            let target = desc
                .od
                .find(index)
                .unwrap()
                .entries
                .iter()
                .find(|e| e.subindex == subindex)
                .unwrap();
            assert_eq!(child_text(entry, "Name"), target.name, "{what}:{sub} Name");
            assert_eq!(
                child_text(entry, "DataType"),
                expected_type(target),
                "{what}:{sub} DataType"
            );
        }
    }
}

/// Every check of the document against the description.
fn check_document(xml: &str, desc: &DeviceDescription) {
    let doc = Document::parse(xml).unwrap_or_else(|e| panic!("not well-formed: {e}"));
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "EtherCATInfo");
    assert_eq!(
        root.attribute((
            "http://www.w3.org/2001/XMLSchema-instance",
            "noNamespaceSchemaLocation"
        )),
        Some("EtherCATInfo.xsd")
    );
    let vendor = child(root, "Vendor");
    assert_eq!(child_num(vendor, "Id"), i128::from(desc.identity.vendor_id));
    assert_eq!(child_text(vendor, "Name"), desc.names.vendor_name);
    let descriptions = child(root, "Descriptions");
    let group = child(child(descriptions, "Groups"), "Group");
    assert_eq!(child_text(group, "Type"), desc.names.group_type);
    assert_eq!(child_text(group, "Name"), desc.names.group_name);
    let devices = children(child(descriptions, "Devices"), "Device");
    assert_eq!(devices.len(), 1);
    let device = devices[0];
    assert_eq!(device.attribute("Physics"), Some("YY"));
    let ty = child(device, "Type");
    assert_eq!(text(ty), desc.names.order_code);
    assert_eq!(
        attr_num(ty, "ProductCode"),
        Some(i128::from(desc.identity.product_code))
    );
    assert_eq!(
        attr_num(ty, "RevisionNo"),
        Some(i128::from(desc.identity.revision))
    );
    assert_eq!(child_text(device, "Name"), desc.names.device_name);
    assert_eq!(child(device, "Name").attribute("LcId"), Some("1033"));
    assert_eq!(child_text(device, "GroupType"), desc.names.group_type);

    // Profile: device type 0x000C0191 = profile 401, additional information 12.
    let profile = child(device, "Profile");
    let device_type = raw_default(desc.od.find(0x1000).unwrap(), 0).unwrap();
    assert_eq!(
        child_num(profile, "ProfileNo"),
        i128::from(device_type & 0xFFFF)
    );
    assert_eq!(child_num(profile, "AddInfo"), i128::from(device_type >> 16));
    let dict = child(profile, "Dictionary");
    let objects = children(child(dict, "Objects"), "Object");
    assert_eq!(objects.len(), desc.od.len(), "one Object per object");
    for (xml, object) in objects.iter().zip(desc.od.iter()) {
        check_object(dict, *xml, object);
    }
    // Data type names are unique, and every type an object or SubItem names exists.
    let types: Vec<&str> = children(child(dict, "DataTypes"), "DataType")
        .iter()
        .map(|d| child_text(*d, "Name"))
        .collect();
    for (i, t) in types.iter().enumerate() {
        assert!(!types[..i].contains(t), "DataType {t} twice");
    }
    for node in doc.descendants().filter(|n| {
        n.has_tag_name("Type")
            && n.parent()
                .is_some_and(|p| p.has_tag_name("Object") || p.has_tag_name("SubItem"))
    }) {
        assert!(
            types.contains(&text(node)),
            "type {} not defined",
            text(node)
        );
    }

    // FMMUs, SyncManagers.
    let fmmus: Vec<&str> = children(device, "Fmmu").into_iter().map(text).collect();
    assert_eq!(fmmus, ["Outputs", "Inputs", "MBoxState"]);
    let sms = children(device, "Sm");
    assert_eq!(sms.len(), desc.sync_managers.len());
    // Default sizes: the mailboxes; 2 AO x 16 bit; 8 AI x 16 bit.
    let default_sizes = [128, 128, 4, 16];
    for (n, (xml, sm)) in sms.iter().zip(desc.sync_managers).enumerate() {
        let what = format!("SM{n}");
        let role = match sm.role {
            SmRole::MailboxOut => "MBoxOut",
            SmRole::MailboxIn => "MBoxIn",
            SmRole::ProcessDataOut => "Outputs",
            SmRole::ProcessDataIn => "Inputs",
        };
        assert_eq!(text(*xml), role, "{what}");
        assert_eq!(
            attr_num(*xml, "StartAddress"),
            Some(i128::from(sm.start)),
            "{what}"
        );
        assert_eq!(
            attr_num(*xml, "ControlByte"),
            Some(i128::from(sm.control)),
            "{what}"
        );
        assert_eq!(
            attr_num(*xml, "Enable"),
            Some(i128::from(sm.enable)),
            "{what}"
        );
        assert_eq!(
            attr_num(*xml, "DefaultSize"),
            Some(default_sizes[n]),
            "{what}"
        );
        assert_eq!(
            attr_num(*xml, "MaxSize"),
            Some(i128::from(sm.len)),
            "{what}"
        );
        let min = sm.role.is_mailbox().then_some(i128::from(sm.len));
        assert_eq!(attr_num(*xml, "MinSize"), min, "{what}");
    }

    // PDOs.
    check_pdos(device, desc, "RxPdo", 0x1600..=0x17FF, 0x1C12, 2);
    check_pdos(device, desc, "TxPdo", 0x1A00..=0x1BFF, 0x1C13, 3);

    // Mailbox.
    let mailbox = child(device, "Mailbox");
    let coe = child(mailbox, "CoE");
    let details = desc.mailbox.coe.bits();
    for (attr, bit) in [
        ("SdoInfo", CoeDetails::SDO_INFO),
        ("PdoAssign", CoeDetails::PDO_ASSIGN),
        ("PdoConfig", CoeDetails::PDO_CONFIG),
        ("PdoUpload", CoeDetails::UPLOAD_AT_STARTUP),
        ("CompleteAccess", CoeDetails::COMPLETE_ACCESS),
    ] {
        let value = coe.attribute(attr).map(xml_bool);
        assert_eq!(value, Some(details & bit != 0), "CoE {attr}");
    }
    // FoE is an empty element; nothing else is offered.
    assert_eq!(
        opt_child(mailbox, "FoE").is_some(),
        desc.mailbox.protocols.foe(),
        "FoE"
    );
    if let Some(foe) = opt_child(mailbox, "FoE") {
        assert_eq!(foe.children().filter(Node::is_element).count(), 0);
        assert_eq!(foe.attributes().count(), 0);
    }
    assert_eq!(
        mailbox.children().filter(Node::is_element).count(),
        1 + usize::from(desc.mailbox.protocols.foe()),
        "CoE and FoE only"
    );

    // DC op modes.
    let modes = children(child(device, "Dc"), "OpMode");
    assert_eq!(modes.len(), desc.dc.op_modes.len());
    for (xml, mode) in modes.iter().zip(desc.dc.op_modes) {
        let what = mode.name;
        assert_eq!(child_text(*xml, "Name"), mode.name);
        assert_eq!(
            opt_child(*xml, "Desc").map(text).unwrap_or(""),
            mode.description,
            "{what}"
        );
        assert_eq!(
            child_num(*xml, "AssignActivate"),
            i128::from(mode.assign_activate),
            "{what}"
        );
        let sync0 = opt_child(*xml, "CycleTimeSync0");
        if mode.assign_activate == 0 {
            assert!(sync0.is_none(), "{what}: no SYNC0 without DC");
            continue;
        }
        let sync0 = sync0.unwrap();
        assert_eq!(
            hexdec(text(sync0)),
            i128::from(mode.cycle_time_sync0),
            "{what}"
        );
        assert_eq!(
            attr_num(sync0, "Factor"),
            Some(i128::from(mode.sync0_factor)),
            "{what}"
        );
        assert_eq!(
            child_num(*xml, "ShiftTimeSync0"),
            i128::from(mode.shift_time_sync0),
            "{what}"
        );
        let sync1 = opt_child(*xml, "CycleTimeSync1");
        assert_eq!(
            sync1.and_then(|n| attr_num(n, "Factor")),
            (mode.sync1_factor != 0).then_some(i128::from(mode.sync1_factor)),
            "{what}"
        );
        if mode.sync1_factor != 0 {
            assert_eq!(
                child_num(*xml, "ShiftTimeSync1"),
                i128::from(mode.shift_time_sync1),
                "{what}"
            );
        }
    }

    // EEPROM: size, config area = the SII image's words 0..7 with a valid checksum.
    let eeprom = child(device, "Eeprom");
    assert_eq!(
        child_num(eeprom, "ByteSize"),
        i128::from(desc.eeprom.size_bytes)
    );
    let config = hex_bytes(child_text(eeprom, "ConfigData"));
    let mut image = vec![0u8; desc.eeprom.size_bytes as usize];
    crate::sii::generate(desc, &mut image).unwrap();
    assert_eq!(config, image[..16], "ConfigData = SII words 0..7");
    assert_eq!(config[14], crc8_bitwise(&config[..14]), "checksum word 7");
    assert_eq!(config[15], 0);
    assert_eq!(
        u16::from_le_bytes([config[4], config[5]]),
        desc.pdi.sync_pulse_10ns
    );
    assert_eq!(
        u16::from_le_bytes([config[8], config[9]]),
        desc.eeprom.station_alias
    );
    let boot = opt_child(eeprom, "BootStrap").map(|n| hex_bytes(text(n)));
    let expected = desc.mailbox.bootstrap.map(|(o, i)| {
        [o.start, o.len, i.start, i.len]
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect::<Vec<u8>>()
    });
    assert_eq!(boot, expected, "BootStrap");
}

#[test]
fn esi_matches_the_description_in_every_value() {
    let desc = module();
    let xml = esi(&desc);
    check_document(&xml, &desc);
}

#[test]
fn generation_is_deterministic() {
    assert_eq!(esi(&module()), esi(&module()));
}

#[test]
fn arrays_take_the_array_info_form_only_when_uniform() {
    let xml = esi(&module());
    assert!(xml.contains("<Name>DT6401ARR</Name>"));
    assert!(xml.contains("<Name>DT1C12ARR</Name>"));
    // 0x8000's elements differ in access: one SubItem per element instead.
    assert!(!xml.contains("DT8000ARR"));
    assert!(xml.contains("<Name>Channel 2 enable</Name>"));
}

#[test]
fn expected_fragments_of_the_module() {
    // A few spot values as a reader of the file would see them.
    let xml = esi(&module());
    for fragment in [
        "<Type ProductCode=\"#x00001754\" RevisionNo=\"#x00010000\">AIO-8AI2AO</Type>",
        "<ProfileNo>401</ProfileNo>",
        "<AddInfo>12</AddInfo>",
        "<Access WriteRestrictions=\"PreOP\">rw</Access>",
        "<Sm MinSize=\"128\" MaxSize=\"128\" DefaultSize=\"128\" StartAddress=\"#x1000\" ControlByte=\"#x26\" Enable=\"1\">MBoxOut</Sm>",
        "<RxPdo Sm=\"2\">",
        "<TxPdo Fixed=\"1\">",
        "<DefaultData>FEFF</DefaultData>",
        "<DefaultData>0000C03F</DefaultData>",
        "<AssignActivate>#x0300</AssignActivate>",
        "<CoE SdoInfo=\"true\" PdoAssign=\"true\" PdoConfig=\"true\" PdoUpload=\"false\" CompleteAccess=\"true\"/>",
    ] {
        assert!(xml.contains(fragment), "missing {fragment}\n{xml}");
    }
}

#[test]
fn text_is_escaped() {
    let name = "Gain <x2> & \"offset\" 'q'";
    let objects = objects_with(ObjectDesc::var(
        0x2005,
        name,
        leak(vec![EntryDesc::string(0, name, "a<b&c")]),
    ));
    let mut desc = device(objects);
    desc.names.vendor_name = "Smith & Sons <GmbH>";
    let xml = esi(&desc);
    assert!(xml.contains("Gain &lt;x2&gt; &amp; &quot;offset&quot; &apos;q&apos;"));
    assert!(xml.contains("<DefaultString>a&lt;b&amp;c</DefaultString>"));
    check_document(&xml, &desc);
}

#[test]
fn a_renamed_object_appears_in_the_file() {
    let before = esi(&module());
    let renamed = ObjectDesc::array(
        0x6411,
        "Analog outputs (renamed)",
        channels(&["AO 1", "AO 2"], I16, RW.rx_mappable()),
    );
    let desc = device(objects_with(renamed));
    let after = esi(&desc);
    assert!(!before.contains("Analog outputs (renamed)"));
    assert!(after.contains("<Name LcId=\"1033\">Analog outputs (renamed)</Name>"));
    check_document(&after, &desc);
}

#[test]
fn a_changed_mapping_changes_pdos_and_sm_size() {
    // Map only AI 1..4: the TxPDO lists four entries, the inputs SM defaults to 8 bytes.
    let ai: Vec<u32> = (1..=4).map(|s| 0x6401_0010 | s << 8).collect();
    let desc = device(objects_with(mapping(0x1A00, "TxPDO 1", RWP, &ai)));
    let xml = esi(&desc);
    assert!(xml.contains("DefaultSize=\"8\" StartAddress=\"#x1180\""));
    let doc = Document::parse(&xml).unwrap();
    let tx = doc.descendants().find(|n| n.has_tag_name("TxPdo")).unwrap();
    assert_eq!(children(tx, "Entry").len(), 4);
}

#[test]
fn bad_descriptions_are_rejected_with_the_problem_named() {
    let duplicate = {
        let mut o = objects();
        let copy = o[1];
        o.insert(1, copy);
        device(o)
    };
    let unmappable = device(objects_with(mapping(
        0x1A00,
        "TxPDO 1",
        RWP,
        &[0x1000_0020],
    )));
    let mut overlap = module();
    overlap.sync_managers = leak(vec![
        SMS[0],
        SyncManagerDesc::new(SmRole::MailboxIn, 0x1040, 128, 0x22),
        SMS[2],
        SMS[3],
    ]);
    for (desc, kind, text) in [
        (
            duplicate,
            DescErrorKind::Dictionary(OdErrorKind::DuplicateIndex),
            "0x1001:00: duplicate object index",
        ),
        (
            unmappable,
            DescErrorKind::MappedNotMappable,
            "0x1A00:01: PDO mapping names an entry that is not PDO-mappable",
        ),
        (
            overlap,
            DescErrorKind::SmOverlap,
            "SM0 and SM1: SyncManagers overlap",
        ),
    ] {
        let mut out = String::new();
        let err = write_esi(&desc, &mut out).unwrap_err();
        match err {
            EsiError::Description(e) => assert_eq!(e.kind, kind),
            other => panic!("{other:?}"),
        }
        let message = err.to_string();
        assert!(message.contains(text), "{message}");
        assert!(out.is_empty(), "nothing written for a bad description");
    }
}

#[test]
fn duplicate_entry_names_are_rejected() {
    let record = ObjectDesc::record(
        0x2000,
        "Settings",
        DataType::Unknown(0x41),
        leak(vec![
            EntryDesc::count(2),
            EntryDesc::new(1, "Value", U8, RW),
            EntryDesc::new(2, "Value", U8, RW),
        ]),
    );
    let err = write_esi(&device(objects_with(record)), &mut String::new()).unwrap_err();
    assert_eq!(
        err,
        EsiError::DuplicateEntryName {
            index: 0x2000,
            subindex: 2
        }
    );
    assert!(err.to_string().contains("0x2000:02"));
}

#[test]
fn control_characters_are_rejected() {
    let bad = "bell\u{7}";
    let objects = objects_with(ObjectDesc::var(
        0x2005,
        bad,
        leak(vec![EntryDesc::new(0, "x", U8, RO)]),
    ));
    let err = write_esi(&device(objects), &mut String::new()).unwrap_err();
    assert_eq!(err, EsiError::UnrepresentableText(bad));
    // Tab and new line are fine.
    let objects = objects_with(ObjectDesc::var(
        0x2005,
        "a\tb\nc",
        leak(vec![EntryDesc::new(0, "x", U8, RO)]),
    ));
    esi(&device(objects));
}

#[test]
fn a_failing_sink_is_reported() {
    /// Accepts `room` bytes, then refuses.
    struct Short {
        room: usize,
    }
    impl Write for Short {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            self.room = self.room.checked_sub(s.len()).ok_or(fmt::Error)?;
            Ok(())
        }
    }
    let desc = module();
    let full = esi(&desc).len();
    assert_eq!(
        write_esi(&desc, &mut Short { room: 100 }),
        Err(EsiError::Write)
    );
    assert_eq!(
        write_esi(&desc, &mut Short { room: full - 1 }),
        Err(EsiError::Write)
    );
    assert_eq!(write_esi(&desc, &mut Short { room: full }), Ok(()));
}

/// The ETG.2000 schema, if this checkout sits next to the shared vectors.
fn schema() -> Option<PathBuf> {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .map(|a| a.join("shared/vectors/esi-schema/EtherCATInfo.xsd"))
        .find(|p| p.is_file())
}

/// Variants that reach every optional part of the file: all mailbox protocols, E-Bus
/// ports with a current, no bootstrap, no DC, escaped text, a mandatory fixed assignment.
fn variants() -> Vec<(&'static str, DeviceDescription)> {
    let mut all_protocols = module();
    all_protocols.mailbox.protocols = MailboxProtocols(0x003F);
    all_protocols.mailbox.bootstrap = None;
    all_protocols.ports = [
        PortType::Ebus,
        PortType::Ebus,
        PortType::None,
        PortType::Ebus,
    ];
    all_protocols.ebus_current_ma = 120;
    let mut plain = module();
    plain.dc.op_modes = &[];
    plain.mailbox.coe = CoeDetails(CoeDetails::SDO);
    plain.names.vendor_name = "Smith & Sons <GmbH> \"quoted\" 'single'";
    vec![
        ("module", module()),
        ("all-protocols", all_protocols),
        ("plain", plain),
    ]
}

#[test]
fn ports_current_and_protocols_of_the_variants() {
    let [(_, module), (_, all), (_, plain)] = <[_; 3]>::try_from(variants()).ok().unwrap();
    let xml = esi(&all);
    assert!(xml.contains("<Device Physics=\"KK K\">"));
    assert!(xml.contains("<EBusCurrent>120</EBusCurrent>"));
    let doc = Document::parse(&xml).unwrap();
    let mailbox = doc
        .descendants()
        .find(|n| n.has_tag_name("Mailbox"))
        .unwrap();
    let tags: Vec<&str> = mailbox
        .children()
        .filter(Node::is_element)
        .map(|n| n.tag_name().name())
        .collect();
    assert_eq!(tags, ["AoE", "EoE", "CoE", "FoE", "SoE", "VoE"]);
    assert!(!xml.contains("<BootStrap>"));
    let xml = esi(&plain);
    assert!(!xml.contains("<Dc>"));
    // Assignment not configurable: assigned PDOs are mandatory.
    assert!(xml.contains("<RxPdo Mandatory=\"1\" Sm=\"2\">"));
    assert!(!esi(&module).contains("Mandatory"));
}

#[test]
#[cfg_attr(
    not(has_shared_vectors),
    ignore = "needs the ETG.2000 schema in ../shared/vectors/esi-schema"
)]
fn the_file_validates_against_the_etg2000_schema() {
    let xsd = schema().expect("shared/vectors/esi-schema beside this checkout");
    let dir = std::env::temp_dir().join(format!("coe-core-esi-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut files = Vec::new();
    for (name, desc) in variants() {
        let file = dir.join(format!("{name}.xml"));
        std::fs::write(&file, esi(&desc)).unwrap();
        files.push(file);
    }
    let os = dir.join("oversampling.xml");
    std::fs::write(&os, esi_os(&os_device(), &OS)).unwrap();
    files.push(os);
    let run = std::process::Command::new("xmllint")
        .arg("--noout")
        .arg("--schema")
        .arg(&xsd)
        .args(&files)
        .output();
    let _ = std::fs::remove_dir_all(&dir);
    let out = run.expect("xmllint (Debian package libxml2-utils)");
    assert!(
        out.status.success(),
        "schema validation failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

// ---- oversampling ----

fn esi_os(desc: &DeviceDescription, os: &Oversampling) -> String {
    let mut out = String::new();
    write_esi_with(desc, os, &mut out).unwrap_or_else(|e| panic!("{e}"));
    out
}

#[test]
fn without_oversampling_the_file_is_the_plain_one() {
    for (name, desc) in variants() {
        assert_eq!(esi_os(&desc, &Oversampling::NONE), esi(&desc), "{name}");
    }
}

/// The PDOs of `tag` in the file: index and the four oversampling attributes.
fn listed(device: Node<'_, '_>, tag: &'static str) -> Vec<(i128, [Option<i128>; 4])> {
    children(device, tag)
        .iter()
        .map(|p| {
            (
                child_num(*p, "Index"),
                ["OSFac", "OSMin", "OSMax", "OSIndexInc"].map(|a| attr_num(*p, a)),
            )
        })
        .collect()
}

#[test]
fn a_replicated_pdo_is_listed_once_with_its_attributes() {
    let desc = os_device();
    let xml = esi_os(&desc, &OS);
    let doc = Document::parse(&xml).unwrap();
    let device = doc
        .descendants()
        .find(|n| n.has_tag_name("Device"))
        .unwrap();
    let none = [None; 4];
    assert_eq!(
        listed(device, "RxPdo"),
        [
            (0x1600, none),
            (0x1610, none),
            (0x1620, [Some(2), Some(1), Some(3), Some(1)]),
        ]
    );
    assert_eq!(
        listed(device, "TxPdo"),
        [
            (0x1A00, none),
            (0x1A10, none),
            (0x1A11, none),
            (0x1A20, [Some(4), Some(1), Some(4), Some(1)]),
        ]
    );
    // The base's entries as usual; every replica in the dictionary.
    let base = children(device, "TxPdo")[3];
    assert_eq!(children(base, "Entry").len(), 8);
    let objects: Vec<i128> = doc
        .descendants()
        .filter(|n| n.has_tag_name("Object"))
        .map(|o| child_num(o, "Index"))
        .collect();
    for index in [0x1621, 0x1622, 0x1A21, 0x1A22, 0x1A23, 0x6023, 0x7022] {
        assert!(objects.contains(&index), "{index:#06X} in the dictionary");
    }
}

#[test]
fn an_op_mode_carries_its_assignment_after_the_plain_modes() {
    let xml = esi_os(&os_device(), &OS);
    let expected = "\
\t\t\t\t<Dc>
\t\t\t\t\t<OpMode>
\t\t\t\t\t\t<Name>DC</Name>
\t\t\t\t\t\t<Desc>DC SYNC0</Desc>
\t\t\t\t\t\t<AssignActivate>#x0300</AssignActivate>
\t\t\t\t\t\t<CycleTimeSync0 Factor=\"1\">0</CycleTimeSync0>
\t\t\t\t\t\t<ShiftTimeSync0>0</ShiftTimeSync0>
\t\t\t\t\t</OpMode>
\t\t\t\t\t<OpMode>
\t\t\t\t\t\t<Name>DC-OS</Name>
\t\t\t\t\t\t<Desc>DC, 4 AO updates and 32 AI samples per cycle</Desc>
\t\t\t\t\t\t<AssignActivate>#x0300</AssignActivate>
\t\t\t\t\t\t<CycleTimeSync0 Factor=\"1\">0</CycleTimeSync0>
\t\t\t\t\t\t<ShiftTimeSync0>0</ShiftTimeSync0>
\t\t\t\t\t\t<Sm No=\"2\">
\t\t\t\t\t\t\t<Pdo>#x1610</Pdo>
\t\t\t\t\t\t\t<Pdo OSFac=\"2\">#x1620</Pdo>
\t\t\t\t\t\t</Sm>
\t\t\t\t\t\t<Sm No=\"3\">
\t\t\t\t\t\t\t<Pdo>#x1A10</Pdo>
\t\t\t\t\t\t\t<Pdo>#x1A11</Pdo>
\t\t\t\t\t\t\t<Pdo OSFac=\"4\">#x1A20</Pdo>
\t\t\t\t\t\t</Sm>
\t\t\t\t\t</OpMode>
\t\t\t\t</Dc>
";
    assert!(xml.contains(expected), "{xml}");
    // Op modes with assignments alone make a Dc element too.
    let mut desc = os_device();
    desc.dc.op_modes = &[];
    let xml = esi_os(&desc, &OS);
    assert_eq!(xml.matches("<OpMode>").count(), 1);
}

#[test]
fn a_bad_oversampling_part_writes_nothing() {
    let desc = os_device();
    let bad = Oversampling {
        replicas: &[PdoReplicas {
            base: 0x1A20,
            default_factor: 9,
            min_factor: 1,
            max_factor: 4,
            index_increment: 1,
        }],
        op_modes: &[],
    };
    let mut out = String::new();
    let err = write_esi_with(&desc, &bad, &mut out).unwrap_err();
    assert!(matches!(
        err,
        EsiError::Description(DescError {
            kind: DescErrorKind::BadOversamplingFactors,
            index: 0x1A20,
            ..
        })
    ));
    assert!(out.is_empty());
    const WRONG_SM: [OpModeWithPdos; 1] = [OpModeWithPdos {
        mode: OS.op_modes[0].mode,
        sms: &[OpModeSm {
            sm: 2,
            pdos: &[OpModePdo::replicated(0x1A20, 1)],
        }],
    }];
    let wrong_sm = Oversampling {
        replicas: OS.replicas,
        op_modes: &WRONG_SM,
    };
    assert!(write_esi_with(&desc, &wrong_sm, &mut out).is_err());
}
