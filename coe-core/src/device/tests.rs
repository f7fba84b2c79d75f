use super::*;
use crate::od::{Access, DataType, EntryDesc, ObjectDesc, Value};
use std::boxed::Box;
use std::format;
use std::vec::Vec;

const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;
const I16: DataType = DataType::Integer16;
const RWP: Access = Access::RW_PREOP;

fn leak<T>(v: Vec<T>) -> &'static [T] {
    Box::leak(v.into_boxed_slice())
}

fn mapping(index: u16, name: &'static str, entries: &[u32]) -> ObjectDesc {
    let mut e =
        std::vec![EntryDesc::new(0, "SubIndex 000", U8, RWP)
            .with_default(Value::Uint(entries.len() as u64))];
    for (i, raw) in entries.iter().enumerate() {
        e.push(
            EntryDesc::new(i as u8 + 1, "Entry", U32, RWP)
                .with_default(Value::Uint(u64::from(*raw))),
        );
    }
    ObjectDesc::record(index, name, DataType::PdoMapping, leak(e))
}

fn assignment(index: u16, pdos: &[u16]) -> ObjectDesc {
    let mut e = std::vec![
        EntryDesc::new(0, "SubIndex 000", U8, RWP).with_default(Value::Uint(pdos.len() as u64))
    ];
    for (i, pdo) in pdos.iter().enumerate() {
        e.push(
            EntryDesc::new(i as u8 + 1, "Assign", U16, RWP)
                .with_default(Value::Uint(u64::from(*pdo))),
        );
    }
    ObjectDesc::array(index, "Assign", leak(e))
}

const NAMES: Names = Names {
    vendor_name: "Vendor",
    device_name: "Test device",
    order_code: "TD-1",
    group_type: "AnalogIO",
    group_name: "Analog I/O",
    hardware_version: "A",
    software_version: "1.0",
};

const IDENTITY: Identity = Identity {
    vendor_id: 0,
    product_code: 0x1234,
    revision: 2,
    serial_number: 7,
};

/// The objects of a valid test device, in index order.
pub(crate) fn base_objects() -> Vec<ObjectDesc> {
    std::vec![
        ObjectDesc::var(
            0x1000,
            "Device type",
            leak(std::vec![EntryDesc::new(0, "Device type", U32, Access::RO)
                .with_default(Value::Uint(0x000C_0191))]),
        ),
        ObjectDesc::var(
            0x1008,
            "Device name",
            leak(std::vec![EntryDesc::string(
                0,
                "Device name",
                "Test device"
            )]),
        ),
        ObjectDesc::record(
            0x1018,
            "Identity",
            DataType::Identity,
            leak(std::vec![
                EntryDesc::count(4),
                EntryDesc::new(1, "Vendor ID", U32, Access::RO).with_default(Value::Uint(0)),
                EntryDesc::new(2, "Product code", U32, Access::RO)
                    .with_default(Value::Uint(0x1234)),
                EntryDesc::new(3, "Revision", U32, Access::RO).with_default(Value::Uint(2)),
                EntryDesc::new(4, "Serial number", U32, Access::RO).with_default(Value::Uint(7)),
            ]),
        ),
        mapping(0x1600, "RxPDO", &[0x6411_0110, 0x6411_0210]),
        mapping(
            0x1A00,
            "TxPDO",
            &[0x6401_0110, 0x6401_0210, 0x0000_0008, 0x0005_0008]
        ),
        assignment(0x1C12, &[0x1600]),
        assignment(0x1C13, &[0x1A00]),
        ObjectDesc::var(
            0x2000,
            "Setting",
            leak(std::vec![EntryDesc::new(0, "Setting", U8, Access::RW)]),
        ),
        ObjectDesc::var(
            0x2001,
            "Tx-only",
            leak(std::vec![EntryDesc::new(
                0,
                "Tx-only",
                I16,
                Access::RO.tx_mappable()
            )]),
        ),
        ObjectDesc::array(
            0x6401,
            "AI",
            leak(std::vec![
                EntryDesc::count(2),
                EntryDesc::new(1, "AI 1", I16, Access::RO.tx_mappable()),
                EntryDesc::new(2, "AI 2", I16, Access::RO.tx_mappable()),
            ]),
        ),
        ObjectDesc::array(
            0x6411,
            "AO",
            leak(std::vec![
                EntryDesc::count(2),
                EntryDesc::new(1, "AO 1", I16, Access::RW.rx_mappable()),
                EntryDesc::new(2, "AO 2", I16, Access::RW.rx_mappable()),
            ]),
        ),
    ]
}

pub(crate) fn od(objects: Vec<ObjectDesc>) -> &'static ObjectDictionary {
    Box::leak(Box::new(ObjectDictionary::new(leak(objects))))
}

/// `base_objects` with `object` replacing the one of the same index (or inserted in order).
fn od_with(object: ObjectDesc) -> &'static ObjectDictionary {
    let mut objects = base_objects();
    match objects.binary_search_by_key(&object.index, |o| o.index) {
        Ok(i) => objects[i] = object,
        Err(i) => objects.insert(i, object),
    }
    od(objects)
}

const SMS: [SyncManagerDesc; 4] = [
    SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, 128, 0x26),
    SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, 128, 0x22),
    SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, 32, 0x64),
    SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1180, 32, 0x20),
];

const OP_MODES: &[DcOpMode] = &[DcOpMode {
    name: "DC",
    description: "DC SYNC0",
    assign_activate: 0x0300,
    sync_mode: 2,
    cycle_time_sync0: 0,
    sync0_factor: 1,
    shift_time_sync0: 0,
    sync1_factor: 0,
    shift_time_sync1: 0,
}];

/// A valid description (shared with the SII tests).
pub(crate) fn valid() -> DeviceDescription {
    DeviceDescription {
        identity: IDENTITY,
        names: NAMES,
        od: od(base_objects()),
        sync_managers: &SMS,
        fmmus: &[
            FmmuUsage::Outputs,
            FmmuUsage::Inputs,
            FmmuUsage::MailboxState,
        ],
        mailbox: MailboxDesc {
            protocols: MailboxProtocols(MailboxProtocols::COE),
            coe: CoeDetails(CoeDetails::SDO | CoeDetails::SDO_INFO),
            bootstrap: None,
        },
        dc: DcDesc {
            op_modes: OP_MODES,
            min_cycle_ns: 25_000,
            max_cycle_ns: 100_000_000,
        },
        pdi: PdiConfig {
            interface: PdiInterface::Spi {
                mode: 3,
                sel_active_high: false,
                miso_late_sample: false,
            },
            enhanced_link_detect: true,
            dc_sync_unit: true,
            dc_latch_unit: true,
            irq: PinDriver::PushPullActiveLow,
            sync0: SyncPin {
                driver: PinDriver::PushPullActiveHigh,
                output: true,
                to_al_event: false,
            },
            sync1: SyncPin {
                driver: PinDriver::PushPullActiveLow,
                output: false,
                to_al_event: false,
            },
            sync_pulse_10ns: 100,
            extended: 0,
        },
        eeprom: EepromDesc {
            size_bytes: 2048,
            station_alias: 0,
            version: 1,
        },
        process_ram: MemoryWindow::new(0x1000, 0x2000),
        ports: [PortType::Mii, PortType::Mii, PortType::None, PortType::None],
        ebus_current_ma: 0,
    }
}

fn rejected(d: &DeviceDescription) -> DescError {
    d.validate().expect_err("description should be rejected")
}

#[test]
fn valid_description_passes() {
    assert_eq!(valid().validate(), Ok(()));
}

#[test]
fn pdi_words_match_the_board_values() {
    // hardware-facts 10.C: SPI slave with enhanced link detect, DC SYNC and latch units;
    // SPI mode 3, IRQ push-pull active low, SYNC0 push-pull active high output.
    let d = valid();
    assert_eq!(d.pdi.word0(), 0x0E05);
    assert_eq!(d.pdi.word1(), 0x0603);
    let mut high_irq = d.pdi;
    high_irq.irq = PinDriver::PushPullActiveHigh;
    assert_eq!(high_irq.word1(), 0x060B);
    assert_eq!(d.eeprom.size_word(), 15);
}

#[test]
fn pdi_words_of_the_async_uc_interface() {
    // 0x0140 = 0x08; 0x0150: BUSY b1:0, IRQ b3:2, BHE polarity b4, RD polarity b7.
    let mut pdi = valid().pdi;
    pdi.interface = PdiInterface::AsyncUc16 {
        busy: PinDriver::PushPullActiveLow,
        bhe_active_high: false,
        rd_active_high: false,
    };
    assert_eq!(pdi.word0(), 0x0E08);
    assert_eq!(pdi.word1(), 0x0600);
    pdi.interface = PdiInterface::AsyncUc16 {
        busy: PinDriver::OpenSourceActiveHigh,
        bhe_active_high: true,
        rd_active_high: true,
    };
    pdi.irq = PinDriver::OpenDrainActiveLow;
    assert_eq!(pdi.word1() & 0xFF, 0b1001_0111);
}

#[test]
fn default_pdos_come_from_the_dictionary() {
    let d = valid();
    let rx: Vec<u32> = d.assigned_pdos(PdoDirection::Rx).collect();
    assert_eq!(rx, [0x1600]);
    let tx: Vec<u32> = d.assigned_pdos(PdoDirection::Tx).collect();
    assert_eq!(tx, [0x1A00]);
    let entries: Vec<PdoEntry> = d.pdo_entries(0x1A00).collect();
    assert_eq!(
        entries,
        [
            PdoEntry::new(0x6401, 1, 16),
            PdoEntry::new(0x6401, 2, 16),
            PdoEntry::gap(8),
            PdoEntry::new(0x0005, 0, 8),
        ]
    );
    assert_eq!(d.default_pdo_bits(PdoDirection::Rx), 32);
    assert_eq!(d.default_pdo_bits(PdoDirection::Tx), 48);
    assert_eq!(d.default_sm_len(&SMS[2]), 4);
    assert_eq!(d.default_sm_len(&SMS[3]), 6);
    assert_eq!(d.default_sm_len(&SMS[0]), 128);
    assert_eq!(d.sm_of_pdo(0x1600), Some(2));
    assert_eq!(d.sm_of_pdo(0x1A00), Some(3));
    assert_eq!(d.sm_of_pdo(0x2000), None);
    assert!(d.pdo_is_assigned(0x1A00));
    assert!(!d.pdo_is_assigned(0x1A01));
    assert!(!d.pdo_is_fixed(0x1600));
    let objects: Vec<u16> = d.pdo_objects(PdoDirection::Tx).map(|o| o.index).collect();
    assert_eq!(objects, [0x1A00]);
    assert_eq!(
        d.mapped_entry(PdoEntry::new(0x6411, 2, 16)).map(|e| e.name),
        Some("AO 2")
    );
    assert_eq!(d.mapped_entry(PdoEntry::gap(8)), None);
    assert_eq!(d.sync_manager(SmRole::MailboxIn).map(|(n, _)| n), Some(1));
}

#[test]
fn rejects_dictionary_errors_duplicate_and_unsorted() {
    let mut objects = base_objects();
    objects.push(objects[objects.len() - 1]);
    let d = DeviceDescription {
        od: od(objects),
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!(
        e.kind,
        DescErrorKind::Dictionary(OdErrorKind::DuplicateIndex)
    );
    assert_eq!(e.index, 0x6411);
    assert!(format!("{e}").contains("duplicate object index"), "{e}");

    let mut objects = base_objects();
    objects.swap(0, 1);
    let d = DeviceDescription {
        od: od(objects),
        ..valid()
    };
    assert_eq!(
        rejected(&d).kind,
        DescErrorKind::Dictionary(OdErrorKind::UnsortedIndex)
    );
}

#[test]
fn rejects_identity_and_name_mismatches() {
    let d = DeviceDescription {
        identity: Identity {
            revision: 3,
            ..IDENTITY
        },
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!(
        (e.kind, e.index, e.subindex),
        (DescErrorKind::IdentityMismatch, 0x1018, 3)
    );
    assert!(format!("{e}").contains("0x1018:03"), "{e}");

    let d = DeviceDescription {
        names: Names {
            device_name: "Other",
            ..NAMES
        },
        ..valid()
    };
    assert_eq!(
        (rejected(&d).kind, rejected(&d).index),
        (DescErrorKind::StringMismatch, 0x1008)
    );

    let objects = base_objects()
        .into_iter()
        .filter(|o| o.index != 0x1018)
        .collect();
    let d = DeviceDescription {
        od: od(objects),
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::MissingIdentity);

    let d = DeviceDescription {
        names: Names {
            group_type: "",
            ..NAMES
        },
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::EmptyName);
}

#[test]
fn rejects_mapping_of_a_non_mappable_entry() {
    let d = DeviceDescription {
        od: od_with(mapping(0x1600, "RxPDO", &[0x2000_0008])),
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!(
        (e.kind, e.index, e.subindex),
        (DescErrorKind::MappedNotMappable, 0x1600, 1)
    );
    assert!(format!("{e}").contains("not PDO-mappable"), "{e}");
}

#[test]
fn rejects_mapping_in_the_wrong_direction() {
    // A TxPDO-only entry in an RxPDO.
    let d = DeviceDescription {
        od: od_with(mapping(0x1600, "RxPDO", &[0x6411_0110, 0x2001_0010])),
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!(
        (e.kind, e.index, e.subindex),
        (DescErrorKind::MappedWrongDirection, 0x1600, 2)
    );
    // An RxPDO-only entry in an unassigned TxPDO is rejected as well.
    let d = DeviceDescription {
        od: od_with(mapping(0x1A01, "TxPDO 2", &[0x6411_0110])),
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::MappedWrongDirection);
}

#[test]
fn rejects_missing_and_mislengthed_mapped_entries() {
    let d = DeviceDescription {
        od: od_with(mapping(0x1600, "RxPDO", &[0x6411_0310])),
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::MappedEntryMissing);
    let d = DeviceDescription {
        od: od_with(mapping(0x1600, "RxPDO", &[0x6411_0108])),
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::MappedLengthMismatch);
    // A typed gap must have its type's length (UNSIGNED8 gap of 16 bits).
    let d = DeviceDescription {
        od: od_with(mapping(0x1A00, "TxPDO", &[0x0005_0010])),
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::MappedLengthMismatch);
}

#[test]
fn rejects_bad_assignments() {
    let d = DeviceDescription {
        od: od_with(assignment(0x1C12, &[0x1A00])),
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!(
        (e.kind, e.index, e.subindex),
        (DescErrorKind::AssignedPdoWrongDirection, 0x1C12, 1)
    );
    let d = DeviceDescription {
        od: od_with(assignment(0x1C12, &[0x1601])),
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::AssignedPdoMissing);
    // Sub 0 counting more entries than the object has.
    let bad = ObjectDesc::array(
        0x1C13,
        "Assign",
        leak(std::vec![
            EntryDesc::new(0, "SubIndex 000", U8, RWP).with_default(Value::Uint(2)),
            EntryDesc::new(1, "Assign", U16, RWP).with_default(Value::Uint(0x1A00)),
        ]),
    );
    let d = DeviceDescription {
        od: od_with(bad),
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::CountAboveEntries);
}

#[test]
fn rejects_image_without_room_sm_or_fmmu() {
    static SMALL: [SyncManagerDesc; 4] = [
        SMS[0],
        SMS[1],
        SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, 2, 0x64),
        SMS[3],
    ];
    let d = DeviceDescription {
        sync_managers: &SMALL,
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!(
        (e.kind, e.index),
        (DescErrorKind::ImageLargerThanSm, 0x1C12)
    );
    static NO_INPUTS: [SyncManagerDesc; 3] = [SMS[0], SMS[1], SMS[2]];
    let d = DeviceDescription {
        sync_managers: &NO_INPUTS,
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::PdoWithoutSm);
    let d = DeviceDescription {
        fmmus: &[FmmuUsage::Inputs],
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::PdoWithoutFmmu);
}

#[test]
fn rejects_overlapping_sync_managers() {
    // SM3 buffered: 3 x 32 bytes from 0x1100 reach 0x1160, so SM3 at 0x1140 overlaps SM2.
    static OVERLAP: [SyncManagerDesc; 4] = [
        SMS[0],
        SMS[1],
        SMS[2],
        SyncManagerDesc::new(SmRole::ProcessDataIn, 0x1140, 32, 0x20),
    ];
    let d = DeviceDescription {
        sync_managers: &OVERLAP,
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!(
        (e.kind, e.index, e.subindex),
        (DescErrorKind::SmOverlap, 2, 3)
    );
    assert_eq!(
        format!("{e}"),
        "device description: SM2 and SM3: SyncManagers overlap"
    );
    // Mailboxes (one buffer) touching end to start do not overlap.
    assert_eq!(valid().validate(), Ok(()));
}

#[test]
fn rejects_sync_manager_outside_process_ram() {
    static LOW: [SyncManagerDesc; 4] = [
        SyncManagerDesc::new(SmRole::MailboxOut, 0x0F80, 128, 0x26),
        SMS[1],
        SMS[2],
        SMS[3],
    ];
    let d = DeviceDescription {
        sync_managers: &LOW,
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!((e.kind, e.index), (DescErrorKind::SmOutsideProcessRam, 0));
    static HIGH: [SyncManagerDesc; 4] = [
        SMS[0],
        SMS[1],
        SMS[2],
        SyncManagerDesc::new(SmRole::ProcessDataIn, 0x2FE0, 16, 0x20),
    ];
    let d = DeviceDescription {
        sync_managers: &HIGH,
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::SmOutsideProcessRam);
}

#[test]
fn rejects_small_or_missing_mailbox() {
    static SMALL: [SyncManagerDesc; 4] = [
        SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, 8, 0x26),
        SMS[1],
        SMS[2],
        SMS[3],
    ];
    let d = DeviceDescription {
        sync_managers: &SMALL,
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!((e.kind, e.index), (DescErrorKind::MailboxTooSmall, 0));
    assert!(
        format!("{e}").starts_with("device description: SM0:"),
        "{e}"
    );
    static NO_MBX: [SyncManagerDesc; 2] = [SMS[2], SMS[3]];
    let d = DeviceDescription {
        sync_managers: &NO_MBX,
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::MailboxIncomplete);
}

#[test]
fn bootstrap_mailbox_is_checked() {
    let with = |out: MemoryWindow, inp: MemoryWindow, protocols: u16| DeviceDescription {
        mailbox: MailboxDesc {
            protocols: MailboxProtocols(protocols),
            bootstrap: Some((out, inp)),
            ..valid().mailbox
        },
        ..valid()
    };
    let coe_foe = MailboxProtocols::COE | MailboxProtocols::FOE;
    let good = with(
        MemoryWindow::new(0x1000, 0x200),
        MemoryWindow::new(0x1200, 0x200),
        coe_foe,
    );
    assert_eq!(good.validate(), Ok(()));
    // The same windows as the standard mailbox are fine too.
    let same = with(
        MemoryWindow::new(SMS[0].start, SMS[0].len),
        MemoryWindow::new(SMS[1].start, SMS[1].len),
        coe_foe,
    );
    assert_eq!(same.validate(), Ok(()));
    for bad in [
        // Without FoE, BOOT has nothing to serve.
        with(
            MemoryWindow::new(0x1000, 0x200),
            MemoryWindow::new(0x1200, 0x200),
            MailboxProtocols::COE,
        ),
        // Overlapping each other.
        with(
            MemoryWindow::new(0x1000, 0x200),
            MemoryWindow::new(0x11F8, 0x200),
            coe_foe,
        ),
        // Outside the process RAM, below and above.
        with(
            MemoryWindow::new(0x0F00, 0x80),
            MemoryWindow::new(0x1200, 0x80),
            coe_foe,
        ),
        with(
            MemoryWindow::new(0x1000, 0x80),
            MemoryWindow::new(0x2FC0, 0x80),
            coe_foe,
        ),
        // Smaller than the smallest frame.
        with(
            MemoryWindow::new(0x1000, 0x0F),
            MemoryWindow::new(0x1200, 0x80),
            coe_foe,
        ),
    ] {
        let e = rejected(&bad);
        assert_eq!(e.kind, DescErrorKind::BadBootstrapMailbox);
        assert!(format!("{e}").contains("bootstrap mailbox"), "{e}");
    }
}

#[test]
fn rejects_role_twice_and_control_mismatch() {
    static TWICE: [SyncManagerDesc; 4] = [SMS[0], SMS[1], SMS[2], SMS[2]];
    let d = DeviceDescription {
        sync_managers: &TWICE,
        ..valid()
    };
    assert_eq!(rejected(&d).kind, DescErrorKind::SmRoleTwice);
    // SM1 (mailbox in) with the mailbox-out direction bits.
    static WRONG: [SyncManagerDesc; 4] = [
        SMS[0],
        SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, 128, 0x26),
        SMS[2],
        SMS[3],
    ];
    let d = DeviceDescription {
        sync_managers: &WRONG,
        ..valid()
    };
    let e = rejected(&d);
    assert_eq!((e.kind, e.index), (DescErrorKind::SmControlMismatch, 1));
}

#[test]
fn rejects_bad_cycle_limits_and_eeprom_size() {
    let mut d = valid();
    d.dc.min_cycle_ns = 200_000_000;
    assert_eq!(rejected(&d).kind, DescErrorKind::BadCycleLimits);
    let mut d = valid();
    d.eeprom.size_bytes = 1000;
    assert_eq!(rejected(&d).kind, DescErrorKind::BadEepromSize);
}
