//! An SII EEPROM image from an ESI file (ETG.2000), for a peer whose device description is
//! its ESI (the SOES port's `tests/soes/esi/soes-analog-io.xml`): the configuration words
//! (`Eeprom/ConfigData`), the identity, the standard mailbox and its protocols, the
//! strings and the General category (order, name, CoE details), the FMMUs, SyncManagers
//! and fixed PDOs (ETG.2010 categories 10, 30, 40, 41, 50, 51).

use roxmltree::{Document, Node};
use virtual_board::rig::sii_builder::{SiiBuilder, SiiPdo, SiiPdoEntry, SiiSyncManager};

/// A number of an ESI file: `#x` hexadecimal or decimal.
fn number(text: &str) -> Result<u32, String> {
    let t = text.trim();
    match t.strip_prefix("#x") {
        Some(hex) => u32::from_str_radix(hex, 16),
        None => t.parse(),
    }
    .map_err(|_| format!("ESI: {t:?} is not a number"))
}

fn child<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Result<Node<'a, 'i>, String> {
    node.children()
        .find(|c| c.has_tag_name(name))
        .ok_or_else(|| format!("ESI: <{}> has no <{name}>", node.tag_name().name()))
}

fn text<'a>(node: Node<'a, '_>, name: &str) -> Result<&'a str, String> {
    Ok(child(node, name)?.text().unwrap_or_default().trim())
}

fn attr(node: Node<'_, '_>, name: &str) -> Result<u32, String> {
    number(
        node.attribute(name)
            .ok_or_else(|| format!("ESI: <{}> has no {name} attribute", node.tag_name().name()))?,
    )
}

/// CoE data type code of an ESI base type name (ETG.1000.6 table 64).
fn data_type(name: &str) -> Result<u8, String> {
    Ok(match name {
        "BOOL" => 0x01,
        "SINT" => 0x02,
        "INT" => 0x03,
        "DINT" => 0x04,
        "USINT" => 0x05,
        "UINT" => 0x06,
        "UDINT" => 0x07,
        "REAL" => 0x08,
        other => return Err(format!("ESI: PDO entry data type {other} not handled")),
    })
}

/// The PDOs (`RxPdo` or `TxPdo`) of a device.
fn pdos(device: Node<'_, '_>, kind: &str) -> Result<Vec<SiiPdo>, String> {
    let mut out = Vec::new();
    for pdo in device.children().filter(|c| c.has_tag_name(kind)) {
        let mut entries = Vec::new();
        for e in pdo.children().filter(|c| c.has_tag_name("Entry")) {
            entries.push(SiiPdoEntry {
                index: number(text(e, "Index")?)? as u16,
                subindex: number(text(e, "SubIndex")?)? as u8,
                data_type: data_type(text(e, "DataType")?)?,
                bits: number(text(e, "BitLen")?)? as u8,
            });
        }
        out.push(SiiPdo {
            index: number(text(pdo, "Index")?)? as u16,
            sm: attr(pdo, "Sm")? as u8,
            entries,
        });
    }
    Ok(out)
}

/// The SII image of the first device of the ESI document `xml`.
pub fn sii_from_esi(xml: &str) -> Result<Vec<u8>, String> {
    let doc = Document::parse(xml).map_err(|e| format!("ESI: {e}"))?;
    let root = doc.root_element();
    let vendor = number(text(child(root, "Vendor")?, "Id")?)?;
    let device = child(child(child(root, "Descriptions")?, "Devices")?, "Device")?;
    let ty = child(device, "Type")?;
    let order = ty.text().unwrap_or_default().trim();
    let mut sii =
        SiiBuilder::new().identity(vendor, attr(ty, "ProductCode")?, attr(ty, "RevisionNo")?, 0);
    let eeprom = child(device, "Eeprom")?;
    let config = text(eeprom, "ConfigData")?;
    if config.len() != 28 {
        return Err("ESI: ConfigData must hold the 7 configuration words (14 bytes)".into());
    }
    for i in 0..7 {
        let word = u16::from_str_radix(&config[4 * i..4 * i + 4], 16)
            .map_err(|_| format!("ESI: ConfigData {config:?} is not hexadecimal"))?;
        sii = sii.config_word(i, word.swap_bytes());
    }
    let sms: Vec<Node> = device.children().filter(|c| c.has_tag_name("Sm")).collect();
    for (n, sm) in sms.iter().enumerate() {
        let usage = match sm.text().unwrap_or_default().trim() {
            "MBoxOut" => 1,
            "MBoxIn" => 2,
            "Outputs" => 3,
            "Inputs" => 4,
            other => return Err(format!("ESI: SyncManager {n} of kind {other:?}")),
        };
        sii = sii.sync_manager(SiiSyncManager {
            start: attr(*sm, "StartAddress")? as u16,
            len: sm.attribute("DefaultSize").map_or(Ok(0), number)? as u16,
            control: attr(*sm, "ControlByte")? as u8,
            enable: attr(*sm, "Enable")? as u8,
            usage,
        });
    }
    let mailbox = child(device, "Mailbox")?;
    let coe = child(mailbox, "CoE")?;
    let flag = |name: &str| coe.attribute(name) == Some("true");
    // General category, CoE details (ETG.2010 table 4): SDO, SDO Information, PDO assign,
    // PDO configuration, upload at startup, SDO complete access.
    let coe_details = 0x01
        | if flag("SdoInfo") { 0x02 } else { 0 }
        | if flag("PdoUpload") { 0x10 } else { 0 }
        | if flag("CompleteAccess") { 0x20 } else { 0 };
    let (mbx_out, mbx_in) = match sms.as_slice() {
        [out, inp, ..] => (
            (
                attr(*out, "StartAddress")? as u16,
                attr(*out, "DefaultSize")? as u16,
            ),
            (
                attr(*inp, "StartAddress")? as u16,
                attr(*inp, "DefaultSize")? as u16,
            ),
        ),
        _ => return Err("ESI: a device with a mailbox needs SM0 and SM1".into()),
    };
    // Mailbox protocols (SII word 0x1C): CoE.
    sii = sii.mailbox(mbx_out, mbx_in, 0x0004);
    let mut name = 0;
    sii = sii.string(order, &mut name).general(name, coe_details);
    let fmmus: Vec<u8> = device
        .children()
        .filter(|c| c.has_tag_name("Fmmu"))
        .map(|f| match f.text().unwrap_or_default().trim() {
            "Outputs" => 1,
            "Inputs" => 2,
            "MBoxState" => 3,
            _ => 0,
        })
        .collect();
    sii = sii.fmmus(&fmmus);
    for p in pdos(device, "TxPdo")? {
        sii = sii.txpdo(p);
    }
    for p in pdos(device, "RxPdo")? {
        sii = sii.rxpdo(p);
    }
    Ok(sii.build())
}
