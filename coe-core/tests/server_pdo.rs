//! PDO mapping/assignment validation (ETG.1020 configuration sequence) and bit-exact packing.

use coe_core::esm::AlState;
use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, OdStore};
use coe_core::pdo::{
    read_bits, write_bits, ImageLayout, PdoAssignment, PdoDirection, PdoEntry, PdoMapping,
};
use coe_core::SdoAbortCode;

const TX: Access = Access::RO.tx_mappable();
const RX: Access = Access::RW.rx_mappable();

static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x2000,
        "Not mappable",
        &[EntryDesc::new(
            0,
            "Not mappable",
            DataType::Unsigned16,
            Access::RW,
        )],
    ),
    ObjectDesc::record(
        0x6000,
        "Inputs",
        DataType::Unknown(0x0040),
        &[
            EntryDesc::count(5),
            EntryDesc::new(1, "Flag", DataType::Boolean, TX),
            EntryDesc::new(2, "Value", DataType::Integer16, TX),
            EntryDesc::new(3, "Code", DataType::Bit3, TX),
            EntryDesc::new(4, "Byte", DataType::Unsigned8, TX),
            EntryDesc::new(5, "Counter", DataType::Unsigned32, TX),
        ],
    ),
    ObjectDesc::record(
        0x7000,
        "Outputs",
        DataType::Unknown(0x0040),
        &[
            EntryDesc::count(3),
            EntryDesc::new(1, "Enable", DataType::Boolean, RX),
            EntryDesc::new(2, "Setpoint", DataType::Integer16, RX),
            EntryDesc::new(3, "Mode", DataType::Bit3, RX),
        ],
    ),
]);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};

#[test]
fn entry_u32_form() {
    // ETG/CiA 301: index << 16 | sub << 8 | bit length; 0x6401:01, 16 bit = 0x64010110.
    let e = PdoEntry::from_u32(0x6401_0110);
    assert_eq!(e, PdoEntry::new(0x6401, 1, 16));
    assert_eq!(e.to_u32(), 0x6401_0110);
    assert!(!e.is_gap());
    assert!(PdoEntry::from_u32(0x0000_0007).is_gap());
    assert!(PdoEntry::from_u32(0x0005_0008).is_gap());
    assert!(!PdoEntry::from_u32(0x0005_0108).is_gap());
    assert_eq!(
        PdoDirection::of_mapping_index(0x1601),
        Some(PdoDirection::Rx)
    );
    assert_eq!(
        PdoDirection::of_mapping_index(0x1A05),
        Some(PdoDirection::Tx)
    );
    assert_eq!(PdoDirection::of_mapping_index(0x1C12), None);
    assert_eq!(
        PdoDirection::of_assignment_index(0x1C13),
        Some(PdoDirection::Tx)
    );
}

#[test]
fn entry_validation_against_the_dictionary() {
    let ok = |raw: u32, d| PdoEntry::from_u32(raw).validate(&OD, d);
    assert_eq!(ok(0x6000_0210, PdoDirection::Tx), Ok(()));
    assert_eq!(ok(0x0000_0005, PdoDirection::Tx), Ok(()));
    assert_eq!(ok(0x0003_0010, PdoDirection::Rx), Ok(())); // INTEGER16 gap
    assert_eq!(
        ok(0x0003_0008, PdoDirection::Rx),
        Err(SdoAbortCode::CannotBeMapped)
    );
    // Wrong direction: an input mapped into an RxPDO.
    assert_eq!(
        ok(0x6000_0210, PdoDirection::Rx),
        Err(SdoAbortCode::CannotBeMapped)
    );
    // Not mappable at all.
    assert_eq!(
        ok(0x2000_0010, PdoDirection::Tx),
        Err(SdoAbortCode::CannotBeMapped)
    );
    // No such object / subindex.
    assert_eq!(
        ok(0x6001_0110, PdoDirection::Tx),
        Err(SdoAbortCode::CannotBeMapped)
    );
    assert_eq!(
        ok(0x6000_0908, PdoDirection::Tx),
        Err(SdoAbortCode::CannotBeMapped)
    );
    // Bit length does not match the entry.
    assert_eq!(
        ok(0x6000_0208, PdoDirection::Tx),
        Err(SdoAbortCode::CannotBeMapped)
    );
    assert_eq!(
        ok(0x6000_0200, PdoDirection::Tx),
        Err(SdoAbortCode::CannotBeMapped)
    );
}

#[test]
fn mapping_configuration_sequence() {
    let mut m: PdoMapping<4> = PdoMapping::with_entries(0x1A00, &[PdoEntry::new(0x6000, 2, 16)]);
    let mut buf = [0u8; 4];
    assert_eq!(m.read_sub(0, &mut buf), Ok(1));
    assert_eq!(buf[0], 1);
    assert_eq!(m.read_sub(1, &mut buf), Ok(4));
    assert_eq!(buf, [0x10, 0x02, 0x00, 0x60]);
    assert_eq!(
        m.read_sub(5, &mut buf),
        Err(SdoAbortCode::SubindexDoesNotExist)
    );

    // An entry cannot be written while sub 0 != 0.
    assert_eq!(
        m.write_sub(2, &0x6000_0108u32.to_le_bytes(), &OD, 64),
        Err(SdoAbortCode::SubindexZeroMustBeZero)
    );
    // Step 1: sub 0 = 0.
    assert_eq!(m.write_sub(0, &[0], &OD, 64), Ok(()));
    assert_eq!(m.count(), 0);
    // Step 2: entries, each checked at once.
    assert_eq!(
        m.write_sub(1, &0x6000_0101u32.to_le_bytes(), &OD, 64),
        Ok(())
    );
    assert_eq!(
        m.write_sub(2, &0x0000_0007u32.to_le_bytes(), &OD, 64),
        Ok(())
    );
    assert_eq!(
        m.write_sub(3, &0x6000_0520u32.to_le_bytes(), &OD, 64),
        Ok(())
    );
    assert_eq!(
        m.write_sub(4, &0x7000_0210u32.to_le_bytes(), &OD, 64),
        Err(SdoAbortCode::CannotBeMapped)
    );
    assert_eq!(
        m.write_sub(5, &0x6000_0210u32.to_le_bytes(), &OD, 64),
        Err(SdoAbortCode::SubindexDoesNotExist)
    );
    assert_eq!(
        m.write_sub(4, &[1, 2], &OD, 64),
        Err(SdoAbortCode::LengthTooLow)
    );
    assert_eq!(
        m.write_sub(4, &[1, 2, 3, 4, 5], &OD, 64),
        Err(SdoAbortCode::LengthTooHigh)
    );
    // Step 3: sub 0 = n validates; 1 + 7 + 32 = 40 bits.
    assert_eq!(
        m.write_sub(0, &[5], &OD, 64),
        Err(SdoAbortCode::ValueTooHigh)
    );
    assert_eq!(
        m.write_sub(0, &[3], &OD, 39),
        Err(SdoAbortCode::PdoLengthExceeded)
    );
    assert_eq!(m.count(), 0);
    assert_eq!(m.write_sub(0, &[3], &OD, 40), Ok(()));
    assert_eq!(m.count(), 3);
    assert_eq!(m.bit_len(), 40);
    assert_eq!(
        m.write_sub(0, &[3, 0], &OD, 40),
        Err(SdoAbortCode::LengthTooHigh)
    );
    assert_eq!(
        m.write_sub(0, &[], &OD, 40),
        Err(SdoAbortCode::LengthTooLow)
    );
}

#[test]
fn sub0_validates_a_stale_entry() {
    // A fixed default that maps an input into an RxPDO is caught by validate and sub 0 = n.
    let mut m: PdoMapping<2> = PdoMapping::with_entries(0x1600, &[PdoEntry::new(0x6000, 2, 16)]);
    assert_eq!(m.validate(&OD, 64), Err(SdoAbortCode::CannotBeMapped));
    assert_eq!(m.write_sub(0, &[0], &OD, 64), Ok(()));
    assert_eq!(
        m.write_sub(0, &[1], &OD, 64),
        Err(SdoAbortCode::CannotBeMapped)
    );
    assert_eq!(m.count(), 0);
}

#[test]
fn assignment_configuration_sequence() {
    let maps: [PdoMapping<4>; 3] = [
        PdoMapping::with_entries(0x1600, &[PdoEntry::new(0x7000, 2, 16)]),
        PdoMapping::with_entries(0x1601, &[PdoEntry::new(0x7000, 1, 1), PdoEntry::gap(7)]),
        PdoMapping::with_entries(0x1A00, &[PdoEntry::new(0x6000, 2, 16)]),
    ];
    let mut a: PdoAssignment<2> = PdoAssignment::with_pdos(0x1C12, &[0x1600]);
    assert_eq!(a.validate(&maps, 16), Ok(()));
    let mut buf = [0u8; 2];
    assert_eq!(a.read_sub(1, &mut buf), Ok(2));
    assert_eq!(buf, [0x00, 0x16]);
    assert_eq!(
        a.write_sub(2, &[0x01, 0x16], &maps, 24),
        Err(SdoAbortCode::SubindexZeroMustBeZero)
    );
    assert_eq!(a.write_sub(0, &[0], &maps, 24), Ok(()));
    assert_eq!(a.write_sub(2, &[0x01, 0x16], &maps, 24), Ok(()));
    // A TxPDO cannot be assigned to SM2; unknown PDOs neither.
    assert_eq!(
        a.write_sub(1, &[0x00, 0x1A], &maps, 24),
        Err(SdoAbortCode::ValueRangeExceeded)
    );
    assert_eq!(
        a.write_sub(1, &[0x05, 0x16], &maps, 24),
        Err(SdoAbortCode::ValueRangeExceeded)
    );
    assert_eq!(
        a.write_sub(3, &[0x00, 0x16], &maps, 24),
        Err(SdoAbortCode::SubindexDoesNotExist)
    );
    assert_eq!(a.write_sub(1, &[0x00, 0x16], &maps, 24), Ok(()));
    assert_eq!(
        a.write_sub(0, &[2], &maps, 23),
        Err(SdoAbortCode::PdoLengthExceeded)
    );
    assert_eq!(
        a.write_sub(0, &[3], &maps, 64),
        Err(SdoAbortCode::ValueTooHigh)
    );
    assert_eq!(a.write_sub(0, &[2], &maps, 24), Ok(()));
    assert_eq!(a.pdos(), &[0x1600, 0x1601]);
    assert_eq!(a.bit_len(&maps), 24);
}

/// The layout of the test TxPDO and the image derived bit by bit:
///
/// | entry | bits | value | image bits |
/// |---|---|---|---|
/// | 0x6000:01 BOOL | 1 | 1 | 0 |
/// | gap 0x0000 | 7 | - | 1..=7 (stay 0) |
/// | 0x6000:02 INT16 | 16 | -2 = 0xFFFE | 8..=23 |
/// | 0x6000:03 BIT3 | 3 | 0b101 | 24..=26 |
/// | 0x6000:04 U8 | 8 | 0xA5 | 27..=34 |
/// | gap 0x0001:00 (BOOLEAN) | 1 | - | 35 |
/// | 0x6000:05 U32 | 32 | 0x12345678 | 36..=67 |
///
/// byte 0 = 0x01; bytes 1, 2 = FE FF; byte 3 = 0b101 | (0xA5 & 0x1F) << 3 = 0x05 | 0x28 = 0x2D;
/// byte 4 = 0xA5 >> 5 = 0x05 | (0x12345678 & 0xF) << 4 = 0x80 -> 0x85;
/// bytes 5..=8 = (0x12345678 >> 4) = 0x01234567 little-endian -> 67 45 23 01. 68 bits, 9 bytes.
#[test]
fn pack_non_byte_aligned_inputs() {
    let tx: [PdoMapping<8>; 1] = [PdoMapping::with_entries(
        0x1A00,
        &[
            PdoEntry::from_u32(0x6000_0101),
            PdoEntry::from_u32(0x0000_0007),
            PdoEntry::from_u32(0x6000_0210),
            PdoEntry::from_u32(0x6000_0303),
            PdoEntry::from_u32(0x6000_0408),
            PdoEntry::from_u32(0x0001_0001),
            PdoEntry::from_u32(0x6000_0520),
        ],
    )];
    assert_eq!(tx[0].validate(&OD, 68), Ok(()));
    let assign: PdoAssignment<1> = PdoAssignment::with_pdos(0x1C13, &[0x1A00]);
    let layout: ImageLayout<8> = ImageLayout::build(&assign, &tx).unwrap();
    assert_eq!(layout.bit_len(), 68);
    assert_eq!(layout.byte_len(), 9);
    let offsets: Vec<u32> = layout.fields().iter().map(|f| f.bit_offset).collect();
    assert_eq!(offsets, [0, 8, 24, 27, 36]);

    let mut store: OdStore<64> = OdStore::new(OD).unwrap();
    store.set(0x6000, 1, &[1]).unwrap();
    store.set(0x6000, 2, &(-2i16).to_le_bytes()).unwrap();
    store.set(0x6000, 3, &[0b101]).unwrap();
    store.set(0x6000, 4, &[0xA5]).unwrap();
    store.set(0x6000, 5, &0x1234_5678u32.to_le_bytes()).unwrap();
    let mut image = [0u8; 9];
    layout.pack(&mut store, &mut image).unwrap();
    assert_eq!(
        image,
        [0x01, 0xFE, 0xFF, 0x2D, 0x85, 0x67, 0x45, 0x23, 0x01]
    );
    let mut short = [0u8; 8];
    assert_eq!(
        layout.pack(&mut store, &mut short),
        Err(SdoAbortCode::PdoLengthExceeded)
    );
}

/// Outputs: 0x7000:03 BIT3 at 0, gap 5, 0x7000:02 INT16 at 8, 0x7000:01 BOOL at 24, gap 7.
/// Image 06 34 12 01 -> Mode = 6, Setpoint = 0x1234, Enable = 1.
#[test]
fn unpack_outputs() {
    let rx: [PdoMapping<8>; 2] = [
        PdoMapping::with_entries(
            0x1600,
            &[
                PdoEntry::from_u32(0x7000_0303),
                PdoEntry::from_u32(0x0000_0005),
                PdoEntry::from_u32(0x7000_0210),
            ],
        ),
        PdoMapping::with_entries(
            0x1601,
            &[
                PdoEntry::from_u32(0x7000_0101),
                PdoEntry::from_u32(0x0000_0007),
            ],
        ),
    ];
    let assign: PdoAssignment<2> = PdoAssignment::with_pdos(0x1C12, &[0x1600, 0x1601]);
    assert_eq!(assign.validate(&rx, 32), Ok(()));
    let layout: ImageLayout<4> = ImageLayout::build(&assign, &rx).unwrap();
    assert_eq!(layout.byte_len(), 4);
    let mut store: OdStore<64> = OdStore::new(OD).unwrap();
    // Garbage in the gap bits must not leak into the values.
    layout
        .unpack(&[0xFE, 0x34, 0x12, 0xFF], &mut store, AlState::Op)
        .unwrap();
    assert_eq!(store.get(0x7000, 3), Some(&[6][..]));
    assert_eq!(store.get(0x7000, 2), Some(&[0x34, 0x12][..]));
    assert_eq!(store.get(0x7000, 1), Some(&[1][..]));
}

#[test]
fn layout_capacity_and_unknown_pdo() {
    let maps: [PdoMapping<4>; 1] = [PdoMapping::with_entries(
        0x1A00,
        &[
            PdoEntry::new(0x6000, 1, 1),
            PdoEntry::new(0x6000, 2, 16),
            PdoEntry::new(0x6000, 4, 8),
        ],
    )];
    let assign: PdoAssignment<2> = PdoAssignment::with_pdos(0x1C13, &[0x1A00]);
    assert_eq!(
        ImageLayout::<2>::build(&assign, &maps).err(),
        Some(SdoAbortCode::PdoLengthExceeded)
    );
    let bad: PdoAssignment<2> = PdoAssignment::with_pdos(0x1C13, &[0x1A01]);
    assert_eq!(
        ImageLayout::<4>::build(&bad, &maps).err(),
        Some(SdoAbortCode::ValueRangeExceeded)
    );
    let empty = ImageLayout::<4>::new();
    assert_eq!(empty.byte_len(), 0);
}

#[test]
fn bit_primitives_round_trip() {
    for offset in 0..24u32 {
        for len in 1..=40u8 {
            let value: u64 = 0xDEAD_BEEF_CAFE_F00D & ((1u64 << len) - 1);
            let mut image = [0x5Au8; 8];
            let before = image;
            write_bits(&mut image, offset, len, &value.to_le_bytes());
            let mut out = [0u8; 8];
            read_bits(&image, offset, len, &mut out);
            assert_eq!(u64::from_le_bytes(out), value, "offset {offset} len {len}");
            // Bits outside the field are untouched.
            let mask: u64 = ((1u64 << len) - 1) << offset;
            assert_eq!(
                u64::from_le_bytes(image) & !mask,
                u64::from_le_bytes(before) & !mask
            );
        }
    }
}
