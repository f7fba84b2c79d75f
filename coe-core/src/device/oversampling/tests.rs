//! A description with replicated PDOs and an op mode that assigns them (shared with the ESI
//! and SII tests), and the checks of [`Oversampling::validate`].

use super::*;
use crate::device::tests::{base_objects, od, valid};
use crate::device::{SmRole, SyncManagerDesc};
use crate::od::{Access, DataType, EntryDefault, EntryDesc, ObjectDesc, Value};
use std::boxed::Box;
use std::vec::Vec;

const U8: DataType = DataType::Unsigned8;
const U16: DataType = DataType::Unsigned16;
const U32: DataType = DataType::Unsigned32;

fn leak<T>(v: Vec<T>) -> &'static [T] {
    Box::leak(v.into_boxed_slice())
}

/// A fixed mapping object of `slots` entries whose defaults are one mapping run.
fn run_mapping(index: u16, name: &'static str, slots: u8, first: u32) -> ObjectDesc {
    let mut e = std::vec![EntryDesc::count(slots)];
    for i in 1..=slots {
        e.push(EntryDesc::new(i, "Entry", U32, Access::RO));
    }
    let defaults = leak(std::vec![EntryDefault::mapping_run(1, slots, first)]);
    ObjectDesc::record(index, name, DataType::PdoMapping, leak(e)).with_defaults(defaults)
}

/// A fixed mapping object with these entries.
fn fixed_mapping(index: u16, name: &'static str, entries: &[u32]) -> ObjectDesc {
    let mut e = std::vec![EntryDesc::count(entries.len() as u8)];
    for (i, raw) in entries.iter().enumerate() {
        e.push(
            EntryDesc::new(i as u8 + 1, "Entry", U32, Access::RO)
                .with_default(Value::Uint(u64::from(*raw))),
        );
    }
    ObjectDesc::record(index, name, DataType::PdoMapping, leak(e))
}

/// An ARRAY of `n` UINT samples, mappable one way.
fn samples(index: u16, name: &'static str, n: u8, access: Access) -> ObjectDesc {
    let mut e = std::vec![EntryDesc::count(n)];
    for i in 1..=n {
        let name: &'static str = Box::leak(std::format!("Sample {i}").into_boxed_str());
        e.push(EntryDesc::new(i, name, U16, access));
    }
    ObjectDesc::array(index, name, leak(e))
}

/// The base objects plus: AO block 0x1610 (0x7010:01), AO updates 0x1620..0x1622 (each
/// 0x7020+u:01..04, replicas of 0x1620), AI status 0x1A10 (0x6010:01..03) and time 0x1A11
/// (0x6010:04), AI samples 0x1A20..0x1A23 (each 0x6020+b:01..08, replicas of 0x1A20).
pub(crate) fn os_objects() -> Vec<ObjectDesc> {
    let tx = Access::RO.tx_mappable();
    let rx = Access::RW.rx_mappable();
    let mut objects = base_objects();
    objects.extend([
        fixed_mapping(0x1610, "AO block", &[0x7010_0110]),
        run_mapping(0x1620, "AO updates 1-2", 4, 0x7020_0110),
        run_mapping(0x1621, "AO updates 3-4", 4, 0x7021_0110),
        run_mapping(0x1622, "AO updates 5-6", 4, 0x7022_0110),
        fixed_mapping(0x1A10, "AI block", &[0x6010_0120, 0x6010_0208, 0x6010_0308]),
        fixed_mapping(0x1A11, "AI block time", &[0x6010_0440]),
        run_mapping(0x1A20, "AI samples 1-8", 8, 0x6020_0110),
        run_mapping(0x1A21, "AI samples 9-16", 8, 0x6021_0110),
        run_mapping(0x1A22, "AI samples 17-24", 8, 0x6022_0110),
        run_mapping(0x1A23, "AI samples 25-32", 8, 0x6023_0110),
        ObjectDesc::record(
            0x6010,
            "AI block",
            DataType::Unknown(0x40),
            leak(std::vec![
                EntryDesc::count(4),
                EntryDesc::new(1, "Scan counter", U32, tx),
                EntryDesc::new(2, "Scans", U8, tx),
                EntryDesc::new(3, "Status", U8, tx),
                EntryDesc::new(4, "Time", DataType::Unsigned64, tx),
            ]),
        ),
        samples(0x6020, "AI samples 1-8", 8, tx),
        samples(0x6021, "AI samples 9-16", 8, tx),
        samples(0x6022, "AI samples 17-24", 8, tx),
        samples(0x6023, "AI samples 25-32", 8, tx),
        ObjectDesc::array(
            0x7010,
            "AO block",
            leak(std::vec![
                EntryDesc::count(1),
                EntryDesc::new(1, "Block counter", U16, rx)
            ]),
        ),
        samples(0x7020, "AO updates 1-2", 4, rx),
        samples(0x7021, "AO updates 3-4", 4, rx),
        samples(0x7022, "AO updates 5-6", 4, rx),
    ]);
    objects.sort_by_key(|o| o.index);
    // Entry names unique per object, as the ESI needs them.
    for object in objects.iter_mut() {
        if matches!(object.index, 0x1600..=0x1BFF | 0x1C12 | 0x1C13) {
            let entries: Vec<EntryDesc> = object
                .entries
                .iter()
                .map(|e| e.with_name(sub_name(e.subindex)))
                .collect();
            object.entries = leak(entries);
        }
    }
    objects
}

fn sub_name(sub: u8) -> &'static str {
    Box::leak(std::format!("SubIndex {sub:03}").into_boxed_str())
}

/// SM2 with room for 64 bytes, SM3 for 96.
const OS_SMS: [SyncManagerDesc; 4] = [
    SyncManagerDesc::new(SmRole::MailboxOut, 0x1000, 128, 0x26),
    SyncManagerDesc::new(SmRole::MailboxIn, 0x1080, 128, 0x22),
    SyncManagerDesc::new(SmRole::ProcessDataOut, 0x1100, 64, 0x64),
    SyncManagerDesc::new(SmRole::ProcessDataIn, 0x11C0, 96, 0x20),
];

pub(crate) const OS_REPLICAS: [PdoReplicas; 2] = [
    PdoReplicas {
        base: 0x1620,
        default_factor: 2,
        min_factor: 1,
        max_factor: 3,
        index_increment: 1,
    },
    PdoReplicas {
        base: 0x1A20,
        default_factor: 4,
        min_factor: 1,
        max_factor: 4,
        index_increment: 1,
    },
];

pub(crate) const OS_MODE: DcOpMode = DcOpMode {
    name: "DC-OS",
    description: "DC, 4 AO updates and 32 AI samples per cycle",
    assign_activate: 0x0300,
    sync_mode: 2,
    cycle_time_sync0: 0,
    sync0_factor: 1,
    shift_time_sync0: 0,
    sync1_factor: 0,
    shift_time_sync1: 0,
};

pub(crate) const OS_OP_MODES: [OpModeWithPdos; 1] = [OpModeWithPdos {
    mode: OS_MODE,
    sms: &[
        OpModeSm {
            sm: 2,
            pdos: &[OpModePdo::plain(0x1610), OpModePdo::replicated(0x1620, 2)],
        },
        OpModeSm {
            sm: 3,
            pdos: &[
                OpModePdo::plain(0x1A10),
                OpModePdo::plain(0x1A11),
                OpModePdo::replicated(0x1A20, 4),
            ],
        },
    ],
}];

pub(crate) const OS: Oversampling = Oversampling {
    replicas: &OS_REPLICAS,
    op_modes: &OS_OP_MODES,
};

/// The device of [`os_objects`].
pub(crate) fn os_device() -> DeviceDescription {
    DeviceDescription {
        od: od(os_objects()),
        sync_managers: &OS_SMS,
        ..valid()
    }
}

fn os_with(replicas: &[PdoReplicas], op_modes: &[OpModeWithPdos]) -> Oversampling {
    Oversampling {
        replicas: leak(replicas.to_vec()),
        op_modes: leak(op_modes.to_vec()),
    }
}

fn mode_with(sm: u8, pdos: &[OpModePdo]) -> OpModeWithPdos {
    OpModeWithPdos {
        mode: OS_MODE,
        sms: leak(std::vec![OpModeSm {
            sm,
            pdos: leak(pdos.to_vec())
        }]),
    }
}

fn kind(os: &Oversampling, desc: &DeviceDescription) -> Result<(), (DescErrorKind, u16, u8)> {
    os.validate(desc).map_err(|e| (e.kind, e.index, e.subindex))
}

#[test]
fn the_test_description_validates_and_none_adds_nothing() {
    let desc = os_device();
    assert_eq!(desc.validate(), Ok(()));
    assert_eq!(OS.validate(&desc), Ok(()));
    assert_eq!(Oversampling::NONE.validate(&desc), Ok(()));
    assert_eq!(Oversampling::NONE.validate(&valid()), Ok(()));
}

#[test]
fn groups_and_listing() {
    assert_eq!(
        OS.group_of(0x1620).map(|(g, k)| (g.base, k)),
        Some((0x1620, 0))
    );
    assert_eq!(
        OS.group_of(0x1622).map(|(g, k)| (g.base, k)),
        Some((0x1620, 2))
    );
    assert_eq!(OS.group_of(0x1623), None, "past OSMax");
    assert_eq!(OS.group_of(0x1A10), None);
    assert!(OS.is_listed(0x1620) && OS.is_listed(0x1A10) && OS.is_listed(0x1600));
    assert!(!OS.is_listed(0x1621) && !OS.is_listed(0x1A23));
    assert_eq!(
        OS_REPLICAS[1].replicated(PdoEntry::new(0x6020, 3, 16), 2),
        PdoEntry::new(0x6022, 3, 16)
    );
    assert_eq!(
        OS_REPLICAS[1].replicated(PdoEntry::gap(8), 2),
        PdoEntry::gap(8)
    );
    assert_eq!(OpModePdo::plain(0x1A10).copies(), 1);
    assert_eq!(OpModePdo::replicated(0x1A20, 3).copies(), 3);
}

#[test]
fn bad_factor_limits_are_refused() {
    let desc = os_device();
    for (min, default, max) in [(0, 1, 3), (2, 2, 1), (2, 1, 3), (1, 4, 3)] {
        let group = PdoReplicas {
            min_factor: min,
            default_factor: default,
            max_factor: max,
            ..OS_REPLICAS[0]
        };
        assert_eq!(
            kind(&os_with(&[group], &[]), &desc),
            Err((DescErrorKind::BadOversamplingFactors, 0x1620, 0)),
            "{min} {default} {max}"
        );
    }
}

#[test]
fn replicas_must_exist_and_map_the_base_moved_by_the_increment() {
    let desc = os_device();
    let group = |max, inc| PdoReplicas {
        max_factor: max,
        index_increment: inc,
        default_factor: 1,
        ..OS_REPLICAS[0]
    };
    // 0x1623 does not exist.
    assert_eq!(
        kind(&os_with(&[group(4, 1)], &[]), &desc),
        Err((DescErrorKind::ReplicaMismatch, 0x1623, 3))
    );
    // Replica 1 maps 0x7021, not 0x7030.
    assert_eq!(
        kind(&os_with(&[group(3, 0x10)], &[]), &desc),
        Err((DescErrorKind::ReplicaMismatch, 0x1621, 1))
    );
    // The base must be a mapping object of the dictionary.
    let missing = PdoReplicas {
        base: 0x1630,
        ..group(1, 1)
    };
    assert_eq!(
        kind(&os_with(&[missing], &[]), &desc),
        Err((DescErrorKind::ReplicaMismatch, 0x1630, 0))
    );
    // The inputs' group with a smaller maximum is fine.
    let inputs = PdoReplicas {
        base: 0x1A20,
        ..group(2, 1)
    };
    assert_eq!(kind(&os_with(&[inputs], &[]), &desc), Ok(()));
}

#[test]
fn op_modes_are_checked_pdo_by_pdo() {
    let desc = os_device();
    let check =
        |sm, pdos: &[OpModePdo]| kind(&os_with(&OS_REPLICAS, &[mode_with(sm, pdos)]), &desc);
    assert_eq!(check(3, &[OpModePdo::replicated(0x1A20, 4)]), Ok(()));
    assert_eq!(
        check(1, &[OpModePdo::plain(0x1A10)]),
        Err((DescErrorKind::BadOpModePdo, 0, 1)),
        "SM1 is a mailbox"
    );
    assert_eq!(
        check(7, &[OpModePdo::plain(0x1A10)]),
        Err((DescErrorKind::BadOpModePdo, 0, 7)),
        "no SM7"
    );
    assert_eq!(
        check(2, &[OpModePdo::plain(0x1A10)]),
        Err((DescErrorKind::BadOpModePdo, 0x1A10, 2)),
        "a TxPDO in the outputs"
    );
    assert_eq!(
        check(3, &[OpModePdo::plain(0x1A55)]),
        Err((DescErrorKind::BadOpModePdo, 0x1A55, 3)),
        "no such PDO"
    );
    assert_eq!(
        check(3, &[OpModePdo::plain(0x1A21)]),
        Err((DescErrorKind::BadOpModePdo, 0x1A21, 3)),
        "a replica instead of its base"
    );
    assert_eq!(
        check(3, &[OpModePdo::replicated(0x1A20, 5)]),
        Err((DescErrorKind::BadOpModePdo, 0x1A20, 3)),
        "above OSMax"
    );
    assert_eq!(
        check(3, &[OpModePdo::replicated(0x1A10, 2)]),
        Err((DescErrorKind::BadOpModePdo, 0x1A10, 3)),
        "a factor on a plain PDO"
    );
    // 6 + 8 + 4 x 16 = 78 bytes fit SM3's 96; twice the status does not matter, more
    // samples would: 0x1A00 (8 bytes) + 78 + 16 = 102.
    assert_eq!(
        check(
            3,
            &[
                OpModePdo::plain(0x1A00),
                OpModePdo::plain(0x1A10),
                OpModePdo::plain(0x1A11),
                OpModePdo::replicated(0x1A20, 4),
                OpModePdo::plain(0x1A10),
                OpModePdo::plain(0x1A11),
            ]
        ),
        Err((DescErrorKind::OpModeImageLargerThanSm, 0, 3))
    );
    let nameless = OpModeWithPdos {
        mode: DcOpMode {
            name: "",
            ..OS_MODE
        },
        sms: &[],
    };
    assert_eq!(
        kind(&os_with(&[], &[nameless]), &desc),
        Err((DescErrorKind::EmptyName, 0, 0))
    );
}

/// Usable in a `const` item, as the firmware checks its description.
const _: () = {
    let ok = Oversampling::NONE;
    let _ = ok.is_listed(0x1A00);
};

#[test]
fn an_assignment_takes_the_replicas_in_order_after_their_base() {
    let ok = |pdos: &[u16]| OS.check_assignment(pdos);
    let bad = Err(crate::abort::SdoAbortCode::ParameterIncompatible);
    assert_eq!(ok(&[0x1A10, 0x1A11, 0x1A20, 0x1A21, 0x1A22]), Ok(()));
    assert_eq!(ok(&[0x1A20, 0x1A21, 0x1A00]), Ok(()));
    assert_eq!(ok(&[0x1A00]), Ok(()));
    assert_eq!(ok(&[]), Ok(()));
    assert_eq!(ok(&[0x1A21]), bad, "a replica without its base");
    assert_eq!(ok(&[0x1A20, 0x1A22]), bad, "a gap");
    assert_eq!(ok(&[0x1A20, 0x1A10, 0x1A21]), bad, "another PDO in between");
    assert_eq!(ok(&[0x1A20, 0x1A21, 0x1A20]), bad, "the group twice");
    assert_eq!(ok(&[0x1620, 0x1621, 0x1622]), Ok(()));
    assert_eq!(Oversampling::NONE.check_assignment(&[0x1A21]), Ok(()));
}

/// 0x1C13 over SDO with the mappings read from the dictionary's defaults (fixed sample
/// PDOs need no RAM), the group order checked when sub 0 is written.
#[test]
fn an_assignment_of_fixed_pdos_is_written_and_checked() {
    use crate::abort::SdoAbortCode;
    use crate::pdo::PdoAssignment;
    let desc = os_device();
    let bits_of = |pdo: u16| {
        let _ = desc.od.find(pdo)?;
        Some(desc.pdo_entries(pdo).map(|e| u32::from(e.bit_len)).sum())
    };
    let mut a: PdoAssignment<8> = PdoAssignment::new(0x1C13);
    let write = |a: &mut PdoAssignment<8>, sub: u8, data: &[u8]| {
        a.write_sub_with(sub, data, bits_of, |p| OS.check_assignment(p), 64 * 8)
    };
    for (sub, pdo) in [(1u8, 0x1A10u16), (2, 0x1A11), (3, 0x1A20), (4, 0x1A21)] {
        assert_eq!(write(&mut a, sub, &pdo.to_le_bytes()), Ok(()));
    }
    assert_eq!(write(&mut a, 0, &[4]), Ok(()));
    assert_eq!(a.pdos(), [0x1A10, 0x1A11, 0x1A20, 0x1A21]);
    // 6 + 8 + 2 x 16 = 46 bytes fit the 64 allowed here; six PDOs (78 bytes) do not.
    assert_eq!(write(&mut a, 0, &[0]), Ok(()));
    assert_eq!(write(&mut a, 5, &0x1A22u16.to_le_bytes()), Ok(()));
    assert_eq!(write(&mut a, 6, &0x1A23u16.to_le_bytes()), Ok(()));
    assert_eq!(write(&mut a, 0, &[6]), Err(SdoAbortCode::PdoLengthExceeded));
    // Out of order: refused when sub 0 is written, the assignment keeps sub 0 = 0.
    assert_eq!(write(&mut a, 3, &0x1A21u16.to_le_bytes()), Ok(()));
    assert_eq!(write(&mut a, 4, &0x1A20u16.to_le_bytes()), Ok(()));
    assert_eq!(
        write(&mut a, 0, &[4]),
        Err(SdoAbortCode::ParameterIncompatible)
    );
    assert_eq!(a.count(), 0);
    // An RxPDO or an unknown PDO in the TxPDO assignment.
    assert_eq!(
        write(&mut a, 1, &0x1620u16.to_le_bytes()),
        Err(SdoAbortCode::ValueRangeExceeded)
    );
    assert_eq!(
        write(&mut a, 1, &0x1A77u16.to_le_bytes()),
        Err(SdoAbortCode::ValueRangeExceeded)
    );
}
