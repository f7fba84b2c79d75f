//! The object dictionary chapter's tables, from the device description the firmware, the
//! ESI, the SII image and the EDS are made from: one section per object, one row per entry,
//! with the defaults the device starts with (an object's own defaults applied, as an SDO
//! upload after power-on answers).

use coe_core::device::DeviceDescription;
use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, Value};
use firmware::products::Product;
use std::fmt::Write;

/// The whole generated chapter body: a part per product, each with its own anchors.
pub fn markdown_of_products(products: &[&Product]) -> String {
    let mut out = String::new();
    for p in products {
        let _ = writeln!(out, "\n## Product `{}` {{#{}}}\n", p.name, p.name);
        out.push_str(&markdown(p.name, p.device));
    }
    out
}

/// One product's tables (`product` prefixes the anchors).
pub fn markdown(product: &str, desc: &DeviceDescription) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} objects, generated from the device description of **{}** (order code {}, product \
         code {:#010x}, revision {:#010x}).\n",
        desc.od.len(),
        desc.names.device_name,
        desc.names.order_code,
        desc.identity.product_code,
        desc.identity.revision
    );
    out.push_str("| Index | Name | Object code | Entries |\n|---|---|---|---|\n");
    for object in desc.od.iter() {
        let _ = writeln!(
            out,
            "| [{:#06X}](#{}) | {} | {} | {} |",
            object.index,
            anchor(product, object),
            cell(object.name),
            object.code().name(),
            object.entries.len()
        );
    }
    for object in desc.od.iter() {
        section(&mut out, product, object);
    }
    out
}

/// The id of an object's section (given explicitly, so links do not depend on how the
/// book derives ids from headings).
fn anchor(product: &str, object: &ObjectDesc) -> String {
    format!("{product}-object-{:04x}", object.index)
}

fn section(out: &mut String, product: &str, object: &ObjectDesc) {
    let _ = writeln!(
        out,
        "\n### {:#06X} {} {{#{}}}\n",
        object.index,
        object.name,
        anchor(product, object)
    );
    let _ = writeln!(
        out,
        "{}, data type {}.\n",
        object.code().name(),
        type_name(object.data_type(), 0)
    );
    out.push_str(
        "| Sub | Name | Type | Access | PDO | Default | Minimum | Maximum |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for entry in object.entries {
        let e = object.resolve(entry);
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            e.subindex,
            cell(e.name),
            type_name(e.data_type(), e.bit_len),
            access(e.access),
            e.access.esi_pdo_mapping().map_or("", |m| match m {
                "R" => "RxPDO",
                "T" => "TxPDO",
                _ => "Rx/TxPDO",
            }),
            value(&e, e.default()),
            value(&e, e.min()),
            value(&e, e.max()),
        );
    }
}

fn type_name(t: DataType, bit_len: u16) -> String {
    match t {
        DataType::Unknown(code) => format!("{code:#06x}"),
        _ => t.esi_name(bit_len).to_string(),
    }
}

/// `rw`, `ro` or `wo`, with the states a restricted right applies in.
fn access(a: Access) -> String {
    let mut text = a.esi_access().to_string();
    if let Some(states) = a.esi_write_restrictions() {
        let _ = write!(text, " (write: {})", states.replace('_', ", "));
    }
    if let Some(states) = a.esi_read_restrictions() {
        let _ = write!(text, " (read: {})", states.replace('_', ", "));
    }
    text
}

/// A value as the tables show it: unsigned numbers of index-like size in hex, strings
/// quoted, byte strings as hex bytes.
fn value(entry: &EntryDesc, v: Value) -> String {
    match v {
        Value::None => String::new(),
        Value::Int(n) => n.to_string(),
        Value::Uint(n) if n > 0xFF || entry.bit_len >= 32 && n > 9 => format!("{n:#x}"),
        Value::Uint(n) => n.to_string(),
        Value::Real(x) => x.to_string(),
        Value::Str(s) => format!("\"{}\"", cell(s)),
        Value::Bytes(b) => b
            .iter()
            .map(|x| format!("{x:02X}"))
            .collect::<Vec<_>>()
            .join(" "),
    }
}

/// Text safe inside a table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_object_and_entry_of_every_product_has_a_row() {
        let all = markdown_of_products(&firmware::products::PRODUCTS);
        for p in firmware::products::PRODUCTS {
            assert!(all.contains(&format!("## Product `{}` {{#{}}}", p.name, p.name)));
            every_object_and_entry_has_a_row(p.name, p.device);
        }
    }

    fn every_object_and_entry_has_a_row(product: &str, desc: &DeviceDescription) {
        let md = markdown(product, desc);
        for object in desc.od.iter() {
            let heading = format!(
                "### {:#06X} {} {{#{product}-object-{:04x}}}",
                object.index, object.name, object.index
            );
            assert!(md.contains(&heading), "{heading}");
        }
        let rows = md
            .lines()
            .filter(|l| {
                l.starts_with("| ")
                    && !l.starts_with("| Sub")
                    && !l.starts_with("| Index")
                    && !l.starts_with("| [")
            })
            .count();
        let entries: usize = desc.od.iter().map(|o| o.entries.len()).sum();
        assert_eq!(rows, entries);
    }

    #[test]
    fn values_read_as_a_user_expects() {
        let e = EntryDesc::new(1, "x", DataType::Unsigned32, Access::RO);
        assert_eq!(value(&e, Value::Uint(0x6401_0110)), "0x64010110");
        assert_eq!(value(&e, Value::Uint(3)), "3");
        assert_eq!(value(&e, Value::Int(-5)), "-5");
        assert_eq!(value(&e, Value::Str("a|b")), "\"a\\|b\"");
        assert_eq!(value(&e, Value::None), "");
        assert_eq!(access(Access::RW_PREOP), "rw (write: PreOP)");
        assert_eq!(access(Access::RO), "ro");
    }
}
