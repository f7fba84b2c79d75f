use super::*;
use crate::products::analog_io::od::{DEVICE_TYPE, MODULE_DESCRIPTION, MODULE_DESCRIPTION_INDEX};
use crate::stacks::ethercat::mailbox::MAILBOX_SIZE;
use crate::stacks::ethercat::sync::SUPPORTED_MODES;
use coe_core::od::{ObjectDictionary, Value};
use coe_core::pdo::{PdoDirection, PdoEntry};
use std::vec::Vec;

fn default_of(od: &ObjectDictionary, index: u16, sub: u8) -> Value {
    let (object, entry) = od.entry(index, sub).expect("entry exists");
    object.resolve(entry).default()
}

#[test]
fn description_validates() {
    assert_eq!(DEVICE.validate(), Ok(()));
}

#[test]
fn identity_objects_match_the_description() {
    assert_eq!(
        default_of(&OD, 0x1000, 0),
        Value::Uint(u64::from(DEVICE_TYPE))
    );
    let identity = [
        IDENTITY.vendor_id,
        IDENTITY.product_code,
        IDENTITY.revision,
        IDENTITY.serial_number,
    ];
    for (sub, expected) in (1..=4).zip(identity) {
        assert_eq!(
            default_of(&OD, 0x1018, sub),
            Value::Uint(u64::from(expected))
        );
    }
    assert_eq!(DEVICE.identity.vendor_id, 0, "placeholder vendor");
    assert_eq!(default_of(&OD, 0x1008, 0), Value::Str(NAMES.device_name));
    assert_eq!(
        default_of(&OD, 0x1009, 0),
        Value::Str(NAMES.hardware_version)
    );
    assert_eq!(
        default_of(&OD, 0x100A, 0),
        Value::Str(env!("CARGO_PKG_VERSION"))
    );
    assert_eq!(
        default_of(&OD, MODULE_DESCRIPTION_INDEX, 0),
        Value::Str(MODULE_DESCRIPTION)
    );
}

#[test]
fn default_pdo_mapping_is_ao_out_and_ai_in() {
    let rx: Vec<u32> = DEVICE.assigned_pdos(PdoDirection::Rx).collect();
    let tx: Vec<u32> = DEVICE.assigned_pdos(PdoDirection::Tx).collect();
    assert_eq!(
        (rx.as_slice(), tx.as_slice()),
        (&[0x1600][..], &[0x1A00][..])
    );
    let ao: Vec<PdoEntry> = DEVICE.pdo_entries(0x1600).collect();
    assert_eq!(
        ao,
        [PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)]
    );
    let ai: Vec<PdoEntry> = DEVICE.pdo_entries(0x1A00).collect();
    let expected: Vec<PdoEntry> = (1..=8).map(|s| PdoEntry::new(0x6401, s, 16)).collect();
    assert_eq!(ai, expected);
    // The CiA 401 CAN PDOs (`analog_io_can::can`): 0x1601 the outputs, 0x1A01/0x1A02 four inputs
    // each; not assigned on EtherCAT by default.
    assert_eq!(DEVICE.pdo_entries(0x1601).collect::<Vec<_>>(), ao);
    assert_eq!(
        DEVICE.pdo_entries(0x1A01).collect::<Vec<_>>(),
        expected[..4]
    );
    assert_eq!(
        DEVICE.pdo_entries(0x1A02).collect::<Vec<_>>(),
        expected[4..]
    );
    assert_eq!(DEVICE.default_pdo_bits(PdoDirection::Rx), 32);
    assert_eq!(DEVICE.default_pdo_bits(PdoDirection::Tx), 128);
    assert_eq!(DEVICE.default_sm_len(&SYNC_MANAGERS[2]), 4);
    assert_eq!(DEVICE.default_sm_len(&SYNC_MANAGERS[3]), 16);
}

#[test]
fn pdi_and_dc_match_the_board() {
    assert_eq!(DEVICE.pdi.word0(), 0x0E05);
    assert_eq!(DEVICE.pdi.word1(), 0x0603);
    assert_eq!(DEVICE.pdi.sync_pulse_10ns, 100, "1 us SYNC pulses");
    assert_eq!(DEVICE.dc.min_cycle_ns, MIN_CYCLE_TIME_NS);
    for mode in DEVICE.dc.op_modes {
        let bit = match mode.sync_mode {
            0 => 0x01,
            1 => 0x02,
            2 => 0x04,
            other => panic!("unexpected sync mode {other}"),
        };
        assert_ne!(SUPPORTED_MODES & bit, 0, "{}", mode.name);
        assert_eq!(
            mode.assign_activate != 0,
            mode.sync_mode == 2,
            "{}",
            mode.name
        );
    }
    assert_eq!(DEVICE.eeprom.size_word(), 15, "16 Kbit");
}

#[test]
fn sii_image_fits_the_eeprom_and_carries_the_identity() {
    let mut image = [0xFFu8; 2048];
    let os = &super::super::OVERSAMPLING;
    let len = coe_core::sii::generate_with(&DEVICE, os, &mut image).expect("SII image");
    assert!(len <= DEVICE.eeprom.size_bytes as usize);
    let word = |i: usize| u16::from_le_bytes([image[2 * i], image[2 * i + 1]]);
    assert_eq!((word(0), word(1), word(2)), (0x0E05, 0x0603, 0x0064));
    let u32_at = |i: usize| u32::from(word(i)) | u32::from(word(i + 1)) << 16;
    assert_eq!(u32_at(8), IDENTITY.vendor_id);
    assert_eq!(u32_at(0x0A), IDENTITY.product_code);
    assert_eq!(u32_at(0x0C), IDENTITY.revision);
    assert_eq!((word(0x18), word(0x19)), (0x1000, MAILBOX_SIZE as u16));
    assert_eq!((word(0x1A), word(0x1B)), (0x1080, MAILBOX_SIZE as u16));
}
