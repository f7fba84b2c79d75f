//! `analog-io-stm32`'s description: the µC PDI in the SII, CoE without FoE in the SII and
//! the ESI, and the analog objects of `analog-io` under its own identity.

use super::device::DEVICE;
use super::identity::IDENTITY;
use super::{CONFIG, PRODUCT};
use crate::products::analog_io;
use coe_core::device::{MailboxProtocols, PdiInterface};
use std::string::String;

#[test]
fn the_sii_has_the_uc_pdi_and_no_foe() {
    assert_eq!(DEVICE.validate(), Ok(()));
    assert!(matches!(
        DEVICE.pdi.interface,
        PdiInterface::AsyncUc16 { .. }
    ));
    let mut image = [0xFFu8; 2048];
    let len = coe_core::sii::generate(&DEVICE, &mut image).expect("SII image");
    assert!(len <= DEVICE.eeprom.size_bytes as usize);
    let word = |i: usize| u16::from_le_bytes([image[2 * i], image[2 * i + 1]]);
    // 16-bit asynchronous µC PDI, BUSY/IRQ push-pull active low, 1 us SYNC pulses.
    assert_eq!((word(0), word(1), word(2)), (0x0E08, 0x0600, 0x0064));
    let u32_at = |i: usize| u32::from(word(i)) | u32::from(word(i + 1)) << 16;
    assert_eq!(u32_at(0x0A), IDENTITY.product_code);
    // No bootstrap mailbox (words 0x14..0x17), mailbox protocols CoE only (word 0x1C).
    assert_eq!(
        (word(0x14), word(0x15), word(0x16), word(0x17)),
        (0, 0, 0, 0)
    );
    assert_eq!(word(0x1C), MailboxProtocols::COE);
}

#[test]
fn the_esi_says_coe_and_not_foe() {
    let mut xml = String::new();
    coe_core::esi::write_esi(&DEVICE, &mut xml).expect("ESI");
    assert!(xml.contains("AIO-8AI2AO-F103"));
    assert!(xml.contains("<CoE"), "CoE in the mailbox");
    assert!(!xml.contains("<FoE"), "no FoE: the board has no bootloader");
    assert!(!xml.contains("<BootStrap"), "no bootstrap mailbox");
}

#[test]
fn the_same_analog_objects_as_analog_io_under_its_own_identity() {
    assert!(PRODUCT.update.is_none());
    assert_eq!(CONFIG.bootstrap, None);
    assert_eq!(CONFIG.sm, analog_io::CONFIG.sm);
    assert_ne!(
        IDENTITY.product_code,
        analog_io::identity::IDENTITY.product_code
    );
    for index in [
        0x6401u16, 0x6411, 0x1600, 0x1A00, 0x1C12, 0x1C13, 0x1C32, 0x1C33,
    ] {
        assert!(DEVICE.od.find(index).is_some(), "{index:#06x}");
    }
    // Oversampling is analog-io's alone.
    assert!(DEVICE.od.find(0x6010).is_none());
}
