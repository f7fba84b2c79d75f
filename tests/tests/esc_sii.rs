//! The SII EEPROM interface and the configuration loaded from SII words 0..7.

mod common;
use common::*;
use std::path::PathBuf;
use virtual_board::models::esc::{
    check_config_area, cmd, regs, sii_crc8, Esc, EscConfig, SiiConfigError,
};
use virtual_board::rig::sii_builder::{minimal_io_device, SiiBuilder};

fn sii_read(esc: &mut Esc, word: u32) -> Vec<u8> {
    let mut req = vec![0x00, 0x01];
    req.extend_from_slice(&word.to_le_bytes());
    assert_eq!(
        one(esc, cmd::FPWR, 0x1000, regs::EEPROM_CONTROL, &req).wkc,
        1
    );
    for _ in 0..100 {
        let d = one(esc, cmd::FPRD, 0x1000, regs::EEPROM_CONTROL, &[0, 0]);
        let ctl = u16::from_le_bytes([d.data[0], d.data[1]]);
        if ctl & 0x8000 == 0 {
            let n = if ctl & 0x0040 != 0 { 8 } else { 4 };
            return one(esc, cmd::FPRD, 0x1000, regs::EEPROM_DATA, &vec![0; n]).data;
        }
        esc.advance(5_000);
    }
    panic!("EEPROM stayed busy");
}

#[test]
fn crc8_golden_vectors() {
    let mut a = [0u8; 14];
    a[..4].copy_from_slice(&[0x08, 0x0E, 0x02, 0x88]);
    assert_eq!(sii_crc8(&a), 0x2F);
    let mut b = [0u8; 14];
    b[..6].copy_from_slice(&[0x05, 0x0E, 0x03, 0x06, 0x10, 0x27]);
    assert_eq!(sii_crc8(&b), 0xD7);
    // The algorithm's check value (CRC of "123456789").
    assert_eq!(sii_crc8(b"123456789"), 0xFB);
}

#[test]
fn configuration_words_load_into_registers() {
    let image = SiiBuilder::new().config_word(4, 0xBEEF).build();
    let esc = Esc::new(EscConfig::new(image));
    assert!(esc.pdi_operational());
    assert_eq!(esc.peek_u8(regs::PDI_CONTROL), 0x05, "SPI PDI");
    assert_eq!(esc.peek_u8(regs::ESC_CONFIG), 0x0E);
    assert_eq!(esc.peek_u8(regs::PDI_CONFIG), 0x03, "SPI mode 3");
    assert_eq!(esc.peek_u8(regs::SYNC_LATCH_CONFIG), 0x06);
    assert_eq!(esc.peek_u16(regs::DC_PULSE_LENGTH), 0x0064);
    assert_eq!(esc.peek_u16(regs::STATION_ALIAS), 0xBEEF);
    assert_eq!(esc.peek_u16(regs::DL_STATUS) & 1, 1);
    assert_eq!(esc.peek_u16(regs::EEPROM_CONTROL) & 0x0800, 0);
}

#[test]
fn bad_checksum_leaves_the_pdi_down() {
    let mut image = minimal_io_device();
    image[14] ^= 0xFF;
    assert!(matches!(
        check_config_area(&image),
        Err(SiiConfigError::Checksum { .. })
    ));
    let mut esc = Esc::new(EscConfig::new(image));
    assert!(!esc.pdi_operational());
    assert_eq!(
        esc.peek_u16(regs::EEPROM_CONTROL) & 0x0800,
        0x0800,
        "checksum error"
    );
    assert_eq!(
        esc.peek_u16(regs::EEPROM_CONTROL) & 0x1000,
        0x1000,
        "EEPROM not loaded"
    );
    assert_eq!(esc.peek_u16(regs::DL_STATUS) & 1, 0);
    assert_eq!(esc.peek_u8(regs::PDI_CONTROL), 0);
    // The SPI interface does not answer.
    assert_eq!(
        esc.spi_transfer(&[0x00, 0x08 | 0x03, 0xFF, 0xFF]),
        vec![0xFF; 4]
    );
}

#[test]
fn sii_reads_8_bytes_with_busy_time() {
    let image = minimal_io_device();
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    let mut req = vec![0x00, 0x01];
    req.extend_from_slice(&8u32.to_le_bytes());
    one(&mut esc, cmd::FPWR, 0x1000, regs::EEPROM_CONTROL, &req);
    let d = one(&mut esc, cmd::FPRD, 0x1000, regs::EEPROM_CONTROL, &[0, 0]);
    assert_eq!(d.data[1] & 0x80, 0x80, "busy");
    esc.advance(esc.config().eeprom_busy_ns);
    let d = one(&mut esc, cmd::FPRD, 0x1000, regs::EEPROM_CONTROL, &[0, 0]);
    assert_eq!(d.data[1] & 0x87, 0, "done, command bits cleared");
    assert_eq!(d.data[0] & 0x40, 0x40, "8-byte reads");
    let d = one(&mut esc, cmd::FPRD, 0x1000, regs::EEPROM_DATA, &[0; 8]);
    assert_eq!(d.data, image[16..24].to_vec());
    // Helper loop over the whole image.
    for w in (0..64).step_by(4) {
        assert_eq!(
            sii_read(&mut esc, w),
            image[w as usize * 2..w as usize * 2 + 8].to_vec()
        );
    }
}

#[test]
fn sii_write_needs_write_enable_and_reload_reapplies_config() {
    let mut esc = esc();
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    // Write word 4 (alias) without write enable: error b14.
    one(
        &mut esc,
        cmd::FPWR,
        0x1000,
        regs::EEPROM_DATA,
        &[0x11, 0x22],
    );
    let mut req = vec![0x00, 0x02];
    req.extend_from_slice(&4u32.to_le_bytes());
    one(&mut esc, cmd::FPWR, 0x1000, regs::EEPROM_CONTROL, &req);
    assert_eq!(esc.peek_u16(regs::EEPROM_CONTROL) & 0x4000, 0x4000);
    req[0] = 0x01;
    one(&mut esc, cmd::FPWR, 0x1000, regs::EEPROM_CONTROL, &req);
    assert_eq!(
        esc.peek_u16(regs::EEPROM_CONTROL) & 0xC000,
        0x8000,
        "busy, error cleared"
    );
    esc.advance(50_000);
    assert_eq!(&esc.sii_image()[8..10], &[0x11, 0x22]);
    // The checksum no longer matches: a reload flags it.
    one(
        &mut esc,
        cmd::FPWR,
        0x1000,
        regs::EEPROM_CONTROL,
        &[0x00, 0x04],
    );
    esc.advance(50_000);
    assert_eq!(esc.peek_u16(regs::EEPROM_CONTROL) & 0x0800, 0x0800);
    assert!(!esc.pdi_operational());
}

#[test]
fn eeprom_ownership_moves_to_the_pdi() {
    let image = minimal_io_device();
    let mut esc = esc();
    esc.ecat_write(regs::EEPROM_CONFIG, &[0x01]);
    esc.pdi_write(regs::EEPROM_PDI_ACCESS, &[0x01]);
    // ECAT commands are ignored now.
    esc.ecat_write(regs::EEPROM_CONTROL, &[0x00, 0x01, 0x08, 0, 0, 0]);
    assert_eq!(esc.peek_u16(regs::EEPROM_CONTROL) & 0x8000, 0);
    // The PDI reads.
    esc.pdi_write(regs::EEPROM_CONTROL, &[0x00, 0x01, 0x0A, 0, 0, 0]);
    esc.advance(100_000);
    let mut b = [0; 8];
    esc.pdi_read(regs::EEPROM_DATA, &mut b);
    assert_eq!(b.to_vec(), image[20..28].to_vec());
    // Force ECAT (0x0500 b1).
    esc.ecat_write(regs::EEPROM_CONFIG, &[0x03]);
    esc.ecat_write(regs::EEPROM_CONTROL, &[0x00, 0x01, 0x00, 0, 0, 0]);
    assert_eq!(esc.peek_u16(regs::EEPROM_CONTROL) & 0x8000, 0x8000);
}

fn vectors_dir() -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = root.join("../shared/vectors/sii");
    dir.is_dir().then_some(dir)
}

#[test]
#[cfg_attr(
    not(has_shared_vectors),
    ignore = "needs the real device images in ../shared/vectors/sii"
)]
fn real_sii_images_load_and_read_back() {
    let dir = vectors_dir().expect("shared/vectors/sii beside this checkout");
    let mut n = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("bin") {
            continue;
        }
        let image = std::fs::read(&path).unwrap();
        assert_eq!(check_config_area(&image), Ok(()), "{}", path.display());
        let mut esc = Esc::new(EscConfig::new(image.clone()));
        assert!(esc.pdi_operational(), "{}", path.display());
        assert_eq!(esc.peek_u8(regs::PDI_CONTROL), image[0]);
        assert_eq!(
            esc.peek_u16(regs::STATION_ALIAS),
            u16::from_le_bytes([image[8], image[9]])
        );
        let big = esc.peek_u16(regs::EEPROM_CONTROL) & 0x0080 != 0;
        assert_eq!(big, image.len() > 2048, "address algorithm bit");
        esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
        // Identity words 8..11 and the first category header at 0x40.
        assert_eq!(sii_read(&mut esc, 8), image[16..24].to_vec());
        assert_eq!(sii_read(&mut esc, 0x40), image[0x80..0x88].to_vec());
        n += 1;
    }
    assert!(n >= 7, "expected the 7 real images, found {n}");
}

#[test]
fn four_byte_read_variant() {
    let image = minimal_io_device();
    let mut cfg = EscConfig::new(image.clone());
    cfg.eeprom_read_8 = false;
    let mut esc = Esc::new(cfg);
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    assert_eq!(esc.peek_u16(regs::EEPROM_CONTROL) & 0x0040, 0);
    assert_eq!(sii_read(&mut esc, 10), image[20..24].to_vec());
}

/// Fault switch: an EEPROM that takes time to load. Until it has, the EEPROM interface is
/// busy with the load (b15) and shows "not loaded" (b12), a master's read command is refused
/// (command error b13, as with any command while busy), and the PDI is down; then the
/// configuration is in and the interface serves reads.
#[test]
fn eeprom_loading_at_power_up_keeps_the_interface_busy() {
    let mut cfg = EscConfig::new(minimal_io_device());
    cfg.eeprom_load_ns = 40_000_000;
    let mut esc = Esc::new(cfg);
    let ctl = esc.peek_u16(regs::EEPROM_CONTROL);
    assert_eq!(ctl & 0x9000, 0x9000, "busy and not loaded: {ctl:#06x}");
    assert!(!esc.pdi_operational());
    assert_eq!(esc.peek_u16(regs::DL_STATUS) & 1, 0);
    assert_eq!(esc.peek_u8(regs::PDI_CONTROL), 0);
    esc.ecat_write(regs::STATION_ADDRESS, &[0x00, 0x10]);
    let mut req = vec![0x00, 0x01];
    req.extend_from_slice(&8u32.to_le_bytes());
    one(&mut esc, cmd::FPWR, 0x1000, regs::EEPROM_CONTROL, &req);
    assert_eq!(esc.peek_u16(regs::EEPROM_CONTROL) & 0x2000, 0x2000);
    esc.advance(39_000_000);
    assert!(!esc.pdi_operational());
    esc.advance(1_000_000);
    assert!(esc.pdi_operational());
    let ctl = esc.peek_u16(regs::EEPROM_CONTROL);
    assert_eq!(ctl & 0x9800, 0, "idle and loaded: {ctl:#06x}");
    assert_eq!(esc.peek_u16(regs::DL_STATUS) & 1, 1);
    assert_eq!(esc.peek_u8(regs::PDI_CONTROL), 0x05);
    let minimal = minimal_io_device();
    assert_eq!(sii_read(&mut esc, 8)[..4], minimal[16..20]);
}
