//! `cargo xtask esi [--out DIR]`: the files a configuration tool needs, generated from the
//! device description of each product (`firmware::products`, `--product NAME` for one): the ESI XML
//! (`<order code>.xml`, ETG.2000), validated against the ETG.2000 schema when the schema and
//! `xmllint` are at hand, and the SII EEPROM image (`<order code>.bin`, the whole EEPROM:
//! the generated image, then erased bytes 0xFF) for an EEPROM programmer or a master's
//! EEPROM write, and the EDS (`<order code>.eds`, CiA 306) for CANopen tools, checked with
//! python-canopen's reader when it is installed (`cargo xtask setup` installs it; the system
//! tests compare every object with the firmware's dictionary).

use crate::util::{display, have, root, Result};
use coe_core::device::oversampling::Oversampling;
use coe_core::device::DeviceDescription;
use coe_core::eds::EdsInfo;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The ETG.2000 schema, relative to the project root: it sits beside the repository in the
/// shared vectors and is never part of it.
pub const SCHEMA: &str = "../shared/vectors/esi-schema/EtherCATInfo.xsd";

#[derive(clap::Args, Default)]
pub struct Args {
    /// Output directory (created if missing); default `target/esi` in the project.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Only this product's files (default: every product's).
    #[arg(long, value_name = "NAME")]
    pub product: Option<String>,
}

pub fn run(args: &Args) -> Result {
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| root().join("target").join("esi"));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let products = match &args.product {
        Some(name) => vec![crate::build::product(name)?],
        None => firmware::products::PRODUCTS.to_vec(),
    };
    for product in products {
        println!("{}:", product.name);
        let desc = product.device;
        let xml = write_xml(desc, product.oversampling, &dir)?;
        write_sii(desc, product.oversampling, &dir)?;
        if let Some(can) = &product.can {
            write_eds(desc, &can.eds, &dir)?;
        }
        validate(&xml)?;
    }
    Ok(())
}

/// The file name of the device's files without extension ([`coe_core::eds::FileStem`]).
pub fn file_stem(desc: &DeviceDescription) -> String {
    coe_core::eds::FileStem(desc.names.order_code).to_string()
}

/// Writes `<stem>.xml` into `dir`; returns its path.
fn write_xml(desc: &DeviceDescription, os: &Oversampling, dir: &Path) -> Result<PathBuf> {
    let mut xml = String::new();
    coe_core::esi::write_esi_with(desc, os, &mut xml).map_err(|e| e.to_string())?;
    let path = dir.join(format!("{}.xml", file_stem(desc)));
    std::fs::write(&path, &xml).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("ESI: {} ({} bytes)", path.display(), xml.len());
    Ok(path)
}

/// Writes `<stem>.eds` into `dir` (a product with CAN, the EDS's own facts `info`); returns
/// its path.
pub fn write_eds(desc: &DeviceDescription, info: &EdsInfo, dir: &Path) -> Result<PathBuf> {
    let mut eds = String::new();
    coe_core::eds::write_eds(desc, info, &mut eds).map_err(|e| e.to_string())?;
    let path = dir.join(format!("{}.eds", file_stem(desc)));
    std::fs::write(&path, &eds).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("EDS: {} ({} bytes)", path.display(), eds.len());
    Ok(path)
}

/// Writes `<stem>.bin`, the whole SII EEPROM, into `dir`; returns its path.
fn write_sii(desc: &DeviceDescription, os: &Oversampling, dir: &Path) -> Result<PathBuf> {
    let mut eeprom = vec![0u8; desc.eeprom.size_bytes as usize];
    coe_core::sii::generate_eeprom_with(desc, os, &mut eeprom).map_err(|e| e.to_string())?;
    let path = dir.join(format!("{}.bin", file_stem(desc)));
    std::fs::write(&path, &eeprom).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("SII: {} ({} bytes)", path.display(), eeprom.len());
    Ok(path)
}

/// Validates `xml` against the ETG.2000 schema with `xmllint`; says clearly when and why the
/// check was skipped.
fn validate(xml: &Path) -> Result {
    let schema = root().join(SCHEMA);
    if !schema.is_file() {
        println!(
            "ESI schema validation SKIPPED: no schema at {} (the shared vectors are not beside this checkout)",
            schema.display()
        );
        return Ok(());
    }
    if !have("xmllint") {
        println!(
            "ESI schema validation SKIPPED: xmllint is not installed (`cargo xtask setup` installs libxml2-utils)"
        );
        return Ok(());
    }
    let mut cmd = Command::new("xmllint");
    cmd.arg("--noout").arg("--schema").arg(&schema).arg(xml);
    let out = cmd
        .output()
        .map_err(|e| format!("cannot start `{}`: {e}", display(&cmd)))?;
    if out.status.success() {
        println!("ESI: valid against {}", schema.display());
        Ok(())
    } else {
        Err(format!(
            "{} does not validate against the ETG.2000 schema:\n{}",
            xml.display(),
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::products::Product;

    #[test]
    fn file_stem_keeps_safe_characters_only() {
        let mut desc = firmware::products::analog_io::device::DEVICE;
        desc.names.order_code = "AIO-8AI/2AO v1.0";
        assert_eq!(file_stem(&desc), "AIO-8AI_2AO_v1_0");
        assert_eq!(
            file_stem(&firmware::products::analog_io::device::DEVICE),
            "AIO-8AI2AO"
        );
    }

    #[test]
    fn the_module_esi_is_written() {
        let dir = std::env::temp_dir().join(format!("xtask-esi-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = write_xml(
            &firmware::products::analog_io::device::DEVICE,
            &firmware::products::analog_io::OVERSAMPLING,
            &dir,
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(text.starts_with("<?xml"));
        let product = firmware::products::analog_io::device::DEVICE
            .identity
            .product_code;
        assert!(text.contains(&format!("<Type ProductCode=\"#x{product:08X}\"")));
        assert!(text.trim_end().ends_with("</EtherCATInfo>"));
    }

    /// The module's ESI lists its oversampling op modes, each with its assignment, and
    /// validates against the ETG.2000 schema (where the schema and xmllint are at hand, as
    /// `cargo xtask esi` does it).
    #[test]
    fn the_module_esi_with_its_op_modes_validates() {
        let dir = std::env::temp_dir().join(format!("xtask-esi-op-modes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let os = &firmware::products::analog_io::OVERSAMPLING;
        let path = write_xml(&firmware::products::analog_io::device::DEVICE, os, &dir).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let valid = validate(&path);
        let _ = std::fs::remove_dir_all(&dir);
        valid.unwrap();
        assert!(!os.op_modes.is_empty());
        for mode in os.op_modes {
            let start = format!("<Name>{}</Name>", mode.mode.name);
            let element = text
                .split(&start)
                .nth(1)
                .and_then(|rest| rest.split("</OpMode>").next())
                .unwrap_or_else(|| panic!("op mode {} in the ESI", mode.mode.name));
            for sm in mode.sms {
                assert!(element.contains(&format!("<Sm No=\"{}\">", sm.sm)));
                for pdo in sm.pdos {
                    let factor = match pdo.factor {
                        0 => String::new(),
                        n => format!(" OSFac=\"{n}\""),
                    };
                    let listed = format!("<Pdo{factor}>#x{:04X}</Pdo>", pdo.index);
                    assert!(element.contains(&listed), "{}: {listed}", mode.mode.name);
                }
            }
        }
    }

    #[test]
    fn the_module_sii_is_written() {
        let dir = std::env::temp_dir().join(format!("xtask-sii-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let desc = &firmware::products::analog_io::device::DEVICE;
        let os = &firmware::products::analog_io::OVERSAMPLING;
        let path = write_sii(desc, os, &dir).unwrap();
        let bin = std::fs::read(&path).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(path.file_name().unwrap(), "AIO-8AI2AO.bin");
        assert_eq!(bin.len(), desc.eeprom.size_bytes as usize);
        let mut image = vec![0u8; bin.len()];
        let len = coe_core::sii::generate_with(desc, os, &mut image).unwrap();
        assert_eq!(&bin[..len], &image[..len]);
        assert!(bin[len..].iter().all(|b| *b == 0xFF));
        // Checksum word 7 over words 0..6, identity at words 8..
        assert_eq!(
            u16::from_le_bytes([bin[14], bin[15]]),
            u16::from(coe_core::sii::crc8(&bin[..14]))
        );
        let product = u32::from_le_bytes([bin[20], bin[21], bin[22], bin[23]]);
        assert_eq!(product, desc.identity.product_code);
    }

    /// The minimum cycle a product promises is one figure everywhere a master can read it:
    /// the product's constant (which `cargo xtask bench` checks against its measurement), the
    /// device description's DC minimum, the ESI's defaults of 0x1C32:05 and 0x1C33:05, and
    /// what the firmware's sync monitor answers for them over SDO.
    #[test]
    fn the_minimum_cycle_is_one_figure() {
        use firmware::products::analog_io::sync::{AnalogFigures, MIN_CYCLE_TIME_NS};
        for product in firmware::products::PRODUCTS {
            the_minimum_cycle_is_one_figure_in(product, MIN_CYCLE_TIME_NS);
        }
        use firmware::stacks::ethercat::sync::{SyncMonitor, SyncObject};
        let monitor = SyncMonitor::<AnalogFigures>::new();
        for object in [SyncObject::Outputs, SyncObject::Inputs { image_bytes: 16 }] {
            let mut buf = [0u8; 4];
            assert_eq!(monitor.read(object, 5, &mut buf), Ok(4));
            assert_eq!(u32::from_le_bytes(buf), MIN_CYCLE_TIME_NS);
        }
    }

    fn the_minimum_cycle_is_one_figure_in(product: &Product, min_cycle_ns: u32) {
        let desc = product.device;
        assert_eq!(desc.dc.min_cycle_ns, min_cycle_ns);
        let mut xml = String::new();
        coe_core::esi::write_esi_with(desc, product.oversampling, &mut xml).unwrap();
        for index in ["#x1C32", "#x1C33"] {
            let object = xml
                .split(&format!("<Index>{index}</Index>"))
                .nth(1)
                .unwrap_or_else(|| panic!("object {index} in the ESI"));
            let sub = object
                .split("<Name>Minimum cycle time</Name>")
                .nth(1)
                .unwrap_or_else(|| panic!("{index}:05 in the ESI"));
            let hex = sub
                .split("<DefaultData>")
                .nth(1)
                .and_then(|d| d.split("</DefaultData>").next())
                .unwrap_or_else(|| panic!("{index}:05 DefaultData"));
            let bytes: Vec<u8> = (0..hex.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
                .collect();
            assert_eq!(bytes, min_cycle_ns.to_le_bytes(), "{index}:05 = {hex}");
        }
    }
}
