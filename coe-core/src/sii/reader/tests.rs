//! Reader tests: a hand-made image as golden bytes, the generator's output read back, broken
//! images, arbitrary bytes, and the dumps of real devices.

use super::*;
use crate::device::tests::valid;
use crate::device::SmRole;
use crate::sii::generate;
use crate::sii::tests::vectors_dir;
use proptest::prelude::*;
use std::vec::Vec;

/// Fixed area: PDI SPI + DC (0x0E05), SPI mode 3 / SYNC0 push-pull (0x0603), SYNC impulse
/// 1 us (0x0064), alias 0x1234, checksum 0x15 (CRC-8 of words 0..6); vendor 0x00000ABC,
/// product 0x00010203, revision 0x00020000, serial 7; bootstrap mailbox 0x1000/0x0100,
/// 0x1100/0x0100; standard mailbox 0x1000/0x0080, 0x1080/0x0080; CoE + FoE (0x000C);
/// 2 Kbit - 1 = 1; version 1.
const FIXED_WORDS: [u16; 64] = {
    let mut w = [0u16; 64];
    w[0x00] = 0x0E05;
    w[0x01] = 0x0603;
    w[0x02] = 0x0064;
    w[0x04] = 0x1234;
    w[0x07] = 0x0015;
    w[0x08] = 0x0ABC;
    w[0x0A] = 0x0203;
    w[0x0B] = 0x0001;
    w[0x0D] = 0x0002;
    w[0x0E] = 0x0007;
    w[0x14] = 0x1000;
    w[0x15] = 0x0100;
    w[0x16] = 0x1100;
    w[0x17] = 0x0100;
    w[0x18] = 0x1000;
    w[0x19] = 0x0080;
    w[0x1A] = 0x1080;
    w[0x1B] = 0x0080;
    w[0x1C] = 0x000C;
    w[0x3E] = 0x0001;
    w[0x3F] = 0x0001;
    w
};

/// Categories after the fixed area.
static CATEGORIES: [u8; 130] = [
    // Strings (10), 6 words: 2 strings "AI", "Analog", one pad byte.
    0x0A, 0x00, 0x06, 0x00, //
    0x02, 0x02, b'A', b'I', 0x06, b'A', b'n', b'a', b'l', b'o', b'g', 0x00,
    // General (30), 16 words: group 1, image 0, order 2, name 2, CoE 0x23, FoE 1,
    // flags 0x01 (SAFEOP enable), E-bus -100 mA, ports MII/MII (0x0011).
    0x1E, 0x00, 0x10, 0x00, //
    0x01, 0x00, 0x02, 0x02, 0x00, 0x23, 0x01, 0x00, 0x00, 0x00, 0x00, 0x01, 0x9C, 0xFF, 0x00, 0x00,
    0x11, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, //
    // SyncM (41), 8 words: SM0 0x1000/128 0x26 mailbox out, SM1 0x1080/128 0x22 mailbox in.
    0x29, 0x00, 0x08, 0x00, //
    0x00, 0x10, 0x80, 0x00, 0x26, 0x00, 0x01, 0x01, //
    0x80, 0x10, 0x80, 0x00, 0x22, 0x00, 0x01, 0x02, //
    // TxPDO (50), 12 words: 0x1A00 on SM3, name 1, two INT16 entries 0x6401:01/02 named 1.
    0x32, 0x00, 0x0C, 0x00, //
    0x00, 0x1A, 0x02, 0x03, 0x00, 0x01, 0x00, 0x00, //
    0x01, 0x64, 0x01, 0x01, 0x03, 0x10, 0x00, 0x00, //
    0x01, 0x64, 0x02, 0x01, 0x03, 0x10, 0x00, 0x00, //
    // DC (60), 12 words: one mode, AssignActivate 0x0300, SYNC0 factor 1, name 1, desc 2.
    0x3C, 0x00, 0x0C, 0x00, //
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x03,
    0x01, 0x00, 0x01, 0x02, 0x00, 0x00, 0x00, 0x00, //
    // End.
    0xFF, 0xFF,
];

fn golden() -> Vec<u8> {
    let mut image: Vec<u8> = FIXED_WORDS.iter().flat_map(|w| w.to_le_bytes()).collect();
    image.extend_from_slice(&CATEGORIES);
    image
}

#[test]
fn fixed_area() {
    let image = golden();
    let sii = Sii::new_checked(&image[..]).unwrap();
    assert!(sii.checksum_valid());
    assert_eq!(sii.checksum(), 0x15);
    assert_eq!(sii.word(0), 0x0E05);
    assert_eq!(sii.word(4), 0x1234);
    assert_eq!(
        sii.identity(),
        Identity {
            vendor_id: 0xABC,
            product_code: 0x0001_0203,
            revision: 0x0002_0000,
            serial_number: 7,
        }
    );
    assert_eq!(
        sii.bootstrap_mailbox(),
        MailboxLayout {
            receive_offset: 0x1000,
            receive_size: 0x100,
            send_offset: 0x1100,
            send_size: 0x100,
        }
    );
    assert_eq!(
        sii.standard_mailbox(),
        MailboxLayout {
            receive_offset: 0x1000,
            receive_size: 0x80,
            send_offset: 0x1080,
            send_size: 0x80,
        }
    );
    assert_eq!(sii.mailbox_protocols(), 0x000C);
    assert_eq!(sii.eeprom_kbit(), 2);
    assert_eq!(sii.version(), 1);
}

#[test]
fn a_wrong_checksum_is_seen() {
    let mut image = golden();
    image[2] ^= 0x01;
    assert!(!Sii::new_checked(&image[..]).unwrap().checksum_valid());
}

#[test]
fn categories_in_order_with_their_offsets() {
    let image = golden();
    let sii = Sii::new_checked(&image[..]).unwrap();
    let found: Vec<(u16, usize, usize)> = sii
        .categories()
        .map(|c| c.unwrap())
        .map(|c| (c.kind, c.at, c.data.len()))
        .collect();
    assert_eq!(
        found,
        [
            (10, 0x80, 12),
            (30, 0x90, 32),
            (41, 0xB4, 16),
            (50, 0xC8, 24),
            (60, 0xE4, 24),
        ]
    );
}

#[test]
fn category_bodies() {
    let image = golden();
    let sii = Sii::new_checked(&image[..]).unwrap();

    let strings = sii.strings();
    assert_eq!(strings.declared_count(), 2);
    assert_eq!(strings.get(0), None);
    assert_eq!(strings.get(1), Some(&b"AI"[..]));
    assert_eq!(strings.get(2), Some(&b"Analog"[..]));
    assert_eq!(strings.get(3), None);

    let general = General::new(sii.category(category::GENERAL).unwrap().unwrap());
    assert_eq!(
        (
            general.group_index(),
            general.image_index(),
            general.order_index(),
            general.name_index()
        ),
        (1, 0, 2, 2)
    );
    assert_eq!(general.coe_details(), 0x23);
    assert_eq!(general.foe_details(), 1);
    assert_eq!(general.eoe_details(), 0);
    assert_eq!(general.flags(), 0x01);
    assert_eq!(general.ebus_current_ma(), -100);
    assert_eq!(general.physical_ports(), 0x0011);
    assert_eq!(general.id_address(), 0);

    let sms: Vec<_> =
        SyncManagers::new(sii.category(category::SYNC_MANAGER).unwrap().unwrap()).collect();
    assert_eq!(
        sms,
        [
            SyncManagerEntry {
                start: 0x1000,
                len: 0x80,
                control: 0x26,
                status: 0,
                enable: 1,
                sm_type: 1,
            },
            SyncManagerEntry {
                start: 0x1080,
                len: 0x80,
                control: 0x22,
                status: 0,
                enable: 1,
                sm_type: 2,
            },
        ]
    );
    assert_eq!(sms[1].role(), Some(SmRole::MailboxIn));

    let pdos: Vec<_> = Pdos::new(sii.category(category::TXPDO).unwrap().unwrap())
        .map(|p| p.unwrap())
        .collect();
    assert_eq!(pdos.len(), 1);
    let pdo = pdos[0];
    assert_eq!(
        (
            pdo.index,
            pdo.sync_manager,
            pdo.dc_sync,
            pdo.name_index,
            pdo.flags
        ),
        (0x1A00, 3, 0, 1, 0)
    );
    assert_eq!(pdo.entry_count(), 2);
    let entries: Vec<_> = pdo.entries().collect();
    assert_eq!(
        entries[1],
        PdoEntry {
            index: 0x6401,
            sub_index: 2,
            name_index: 1,
            data_type: 0x03,
            bit_len: 16,
            flags: 0,
        }
    );

    let modes: Vec<_> = DcOpModes::new(sii.category(category::DC).unwrap().unwrap()).collect();
    assert_eq!(
        modes,
        [DcOpMode {
            cycle_time_sync0: 0,
            shift_time_sync0: 0,
            shift_time_sync1: 0,
            sync1_factor: 0,
            assign_activate: 0x0300,
            sync0_factor: 1,
            name_index: 1,
            description_index: 2,
        }]
    );
    assert_eq!(sii.category(category::RXPDO), None);
}

#[test]
fn broken_images_are_errors() {
    assert_eq!(
        Sii::new_checked(&[0u8; 127][..]),
        Err(ReadError::NoFixedArea { len: 127 })
    );

    // The DC category claims 14 words: past the end marker and the image.
    let mut image = golden();
    image[0x80 + 0x64 + 2] = 14;
    let sii = Sii::new_checked(&image[..]).unwrap();
    let last = sii.categories().last().unwrap();
    assert_eq!(last, Err(ReadError::CategoryOverrun { kind: 60, at: 0xE4 }));
    assert_eq!(
        sii.category(category::DC),
        Some(Err(ReadError::CategoryOverrun { kind: 60, at: 0xE4 }))
    );
    // Categories before the broken one are still found.
    assert!(matches!(sii.category(category::TXPDO), Some(Ok(_))));

    // Three bytes after the last category: not a header, not an end marker.
    let mut image = golden();
    image.truncate(image.len() - 2);
    image.extend_from_slice(&[0x0A, 0x00, 0x01]);
    let sii = Sii::new_checked(&image[..]).unwrap();
    assert_eq!(
        sii.categories().last().unwrap(),
        Err(ReadError::TruncatedHeader { at: 0x100 })
    );

    // The PDO declares 3 entries but the category holds 2.
    let mut image = golden();
    image[0x80 + 0x48 + 4 + 2] = 3;
    let sii = Sii::new_checked(&image[..]).unwrap();
    let mut pdos = Pdos::new(sii.category(category::TXPDO).unwrap().unwrap());
    assert_eq!(
        pdos.next(),
        Some(Err(ReadError::PdoOverrun { index: 0x1A00 }))
    );
    assert_eq!(pdos.next(), None);
}

#[test]
fn an_image_may_end_after_its_last_category() {
    let mut image = golden();
    image.truncate(image.len() - 2);
    let sii = Sii::new_checked(&image[..]).unwrap();
    assert_eq!(sii.categories().count(), 5);
    assert!(sii.categories().all(|c| c.is_ok()));
}

#[test]
fn a_string_cut_off_by_the_category_end_is_not_returned() {
    let strings = Strings::new(&[3, 2, b'o', b'k', 5, b'c', b'u']);
    assert_eq!(strings.get(1), Some(&b"ok"[..]));
    assert_eq!(strings.get(2), None);
    assert_eq!(strings.iter().count(), 1);
}

#[test]
fn the_generated_image_reads_back_as_its_description() {
    let desc = valid();
    let mut buf = [0u8; 4096];
    let n = generate(&desc, &mut buf).unwrap();
    let sii = Sii::new_checked(&buf[..n]).unwrap();
    assert!(sii.checksum_valid());
    assert_eq!(
        sii.identity(),
        Identity {
            vendor_id: desc.identity.vendor_id,
            product_code: desc.identity.product_code,
            revision: desc.identity.revision,
            serial_number: desc.identity.serial_number,
        }
    );
    assert!(sii.categories().all(|c| c.is_ok()));
    let general = General::new(sii.category(category::GENERAL).unwrap().unwrap());
    assert_eq!(
        sii.strings().get(general.name_index()),
        Some(desc.names.device_name.as_bytes())
    );
    let sms: Vec<_> =
        SyncManagers::new(sii.category(category::SYNC_MANAGER).unwrap().unwrap()).collect();
    assert_eq!(sms.len(), desc.sync_managers.len());
    for (read, described) in sms.iter().zip(desc.sync_managers) {
        assert_eq!(read.start, described.start);
        assert_eq!(read.control, described.control);
        assert_eq!(read.enable & 1 != 0, described.enable);
        assert_eq!(read.role(), Some(described.role));
    }
    // The standard mailbox words agree with the mailbox SyncManagers.
    let mailbox = sii.standard_mailbox();
    assert_eq!(
        (mailbox.receive_offset, mailbox.receive_size),
        (sms[0].start, sms[0].len)
    );
    assert_eq!(
        (mailbox.send_offset, mailbox.send_size),
        (sms[1].start, sms[1].len)
    );
}

#[test]
#[cfg_attr(
    not(has_shared_vectors),
    ignore = "needs the real device images in ../shared/vectors/sii"
)]
fn real_device_images_read_to_the_end_marker() {
    let dir = vectors_dir().expect("../shared/vectors/sii");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "bin"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 7, "the seven images of vectors/README.md");
    for path in files {
        let image = std::fs::read(&path).unwrap();
        let name = path.display();
        let sii = Sii::new_checked(&image[..]).unwrap();
        assert!(sii.checksum_valid(), "{name}: checksum");
        let categories: Vec<_> = sii
            .categories()
            .collect::<Result<_, _>>()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(categories.iter().any(|c| c.kind == category::GENERAL));
        let strings = sii.strings();
        let general = General::new(sii.category(category::GENERAL).unwrap().unwrap());
        assert!(strings.get(general.name_index()).is_some(), "{name}: name");
        for kind in [category::TXPDO, category::RXPDO] {
            if let Some(body) = sii.category(kind) {
                for pdo in Pdos::new(body.unwrap()) {
                    let pdo = pdo.unwrap_or_else(|e| panic!("{name}: {e}"));
                    assert!(usize::from(pdo.name_index) <= strings.iter().count());
                }
            }
        }
    }
}

proptest! {
    /// Arbitrary bytes never panic any accessor, and every category the iterator yields
    /// lies inside the image.
    #[test]
    fn arbitrary_bytes_never_panic(image in proptest::collection::vec(any::<u8>(), 0..600)) {
        let sii = Sii::new_unchecked(&image[..]);
        let _ = (sii.checksum_valid(), sii.identity(), sii.standard_mailbox(), sii.version());
        for c in sii.categories().flatten() {
            prop_assert!(c.at + 4 + c.data.len() <= image.len());
            let _ = General::new(c.data).physical_ports();
            let _ = SyncManagers::new(c.data).count();
            for pdo in Pdos::new(c.data).flatten() {
                let _ = pdo.entries().count();
            }
            let _ = DcOpModes::new(c.data).count();
            let _ = Strings::new(c.data).iter().count();
        }
        prop_assert!(sii.categories().count() <= image.len() / 4 + 1);
    }
}

#[test]
fn sync_manager_type_codes_round_trip() {
    for role in [
        SmRole::MailboxOut,
        SmRole::MailboxIn,
        SmRole::ProcessDataOut,
        SmRole::ProcessDataIn,
    ] {
        assert_eq!(SmRole::from_sii_type(role.sii_type()), Some(role));
    }
    assert_eq!(SmRole::from_sii_type(0), None);
    assert_eq!(SmRole::from_sii_type(5), None);
}
