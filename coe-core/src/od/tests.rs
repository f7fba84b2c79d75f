use super::*;
use crate::esm::AlState;

static OD: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::var(
        0x1000,
        "Device type",
        &[
            EntryDesc::new(0, "Device type", DataType::Unsigned32, Access::RO)
                .with_default(Value::Uint(0x000C_0191)),
        ],
    ),
    ObjectDesc::var(
        0x1008,
        "Device name",
        &[EntryDesc::string(0, "Device name", "DAC")],
    ),
    ObjectDesc::record(
        0x1018,
        "Identity",
        DataType::Identity,
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "Vendor ID", DataType::Unsigned32, Access::RO),
            EntryDesc::new(2, "Product code", DataType::Unsigned32, Access::RO),
        ],
    ),
    ObjectDesc::array(
        0x6411,
        "Write analog output 16-bit",
        &[
            EntryDesc::count(2),
            EntryDesc::new(
                1,
                "Channel 1",
                DataType::Integer16,
                Access::RW.rx_mappable(),
            )
            .with_range(&ValueRange {
                min: Value::Int(-1000),
                max: Value::Int(1000),
            }),
            EntryDesc::new(
                2,
                "Channel 2",
                DataType::Integer16,
                Access::RW.rx_mappable(),
            ),
        ],
    ),
]);

const _: () = if let Err(e) = OD.validate() {
    panic!("{}", e.message())
};

#[test]
fn lookup_and_iteration() {
    assert_eq!(OD.len(), 4);
    assert_eq!(OD.find(0x1018).map(|o| o.max_subindex()), Some(2));
    assert!(OD.find(0x1001).is_none());
    assert_eq!(
        OD.entry(0x1001, 0).err(),
        Some(SdoAbortCode::ObjectDoesNotExist)
    );
    assert_eq!(
        OD.entry(0x1018, 3).err(),
        Some(SdoAbortCode::SubindexDoesNotExist)
    );
    let (obj, e) = OD.entry(0x6411, 1).unwrap_or_else(|_| panic!());
    assert_eq!(obj.code(), ObjectCode::Array);
    assert_eq!(obj.data_type(), DataType::Integer16);
    assert_eq!(e.bit_len, 16);
    assert_eq!(e.value_info(), 0x60);
    let indices: std::vec::Vec<u16> = OD.iter().map(|o| o.index).collect();
    assert_eq!(indices, [0x1000, 0x1008, 0x1018, 0x6411]);
    assert!(OD
        .find(0x6411)
        .is_some_and(|o| o.any_entry_has(Access::RXPDO)));
    assert_eq!(OD.find(0x1008).map(|o| o.entries[0].bit_len), Some(24));
}

macro_rules! check {
    ($($t:tt)*) => {{
        const OBJECTS: &[ObjectDesc] = $($t)*;
        ObjectDictionary::new(OBJECTS).validate().map_err(|e| e.kind)
    }};
}

const U8: EntryDesc = EntryDesc::new(0, "x", DataType::Unsigned8, Access::RW);

#[test]
fn validate_rejects_bad_tables() {
    assert_eq!(
        check!(&[
            ObjectDesc::var(2, "a", &[U8]),
            ObjectDesc::var(1, "b", &[U8])
        ]),
        Err(OdErrorKind::UnsortedIndex)
    );
    assert_eq!(
        check!(&[
            ObjectDesc::var(2, "a", &[U8]),
            ObjectDesc::var(2, "b", &[U8])
        ]),
        Err(OdErrorKind::DuplicateIndex)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(2, "a", &[])]),
        Err(OdErrorKind::NoEntries)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(2, "a", &[U8, U8])]),
        Err(OdErrorKind::VarNotSubindexZero)
    );
    assert_eq!(
        check!(&[ObjectDesc::array(
            2,
            "a",
            &[EntryDesc::count(2), U8.with_access(Access::RO), U8]
        )]),
        Err(OdErrorKind::DuplicateSubindex)
    );
    assert_eq!(
        check!(&[ObjectDesc::record(
            2,
            "a",
            DataType::Unknown(0x40),
            &[
                EntryDesc::count(2),
                EntryDesc::new(2, "b", DataType::Unsigned8, Access::RO),
                EntryDesc::new(1, "c", DataType::Unsigned8, Access::RO),
            ]
        )]),
        Err(OdErrorKind::UnsortedSubindex)
    );
    assert_eq!(
        check!(&[ObjectDesc::array(
            2,
            "a",
            &[EntryDesc::new(0, "n", DataType::Unsigned16, Access::RO)]
        )]),
        Err(OdErrorKind::BadSubindexZero)
    );
    assert_eq!(
        check!(&[ObjectDesc::array(
            2,
            "a",
            &[
                EntryDesc::count(2),
                EntryDesc::new(1, "b", DataType::Unsigned8, Access::RO),
                EntryDesc::new(2, "c", DataType::Unsigned16, Access::RO),
            ]
        )]),
        Err(OdErrorKind::ArrayElementMismatch)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(2, "a", &[U8.with_bits(16)])]),
        Err(OdErrorKind::BitLengthMismatch)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(
            2,
            "a",
            &[EntryDesc::new(0, "s", DataType::VisibleString, Access::RO)]
        )]),
        Err(OdErrorKind::BitLengthMismatch)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(
            2,
            "a",
            &[
                EntryDesc::new(0, "s", DataType::VisibleString, Access::RO.tx_mappable())
                    .with_bits(8)
            ]
        )]),
        Err(OdErrorKind::NotMappableType)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(
            2,
            "a",
            &[U8.with_range(&ValueRange {
                min: Value::Int(10),
                max: Value::Int(5),
            })]
        )]),
        Err(OdErrorKind::MinGreaterThanMax)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(
            2,
            "a",
            &[U8.with_range(&ValueRange {
                min: Value::Int(1),
                max: Value::Int(5),
            })
            .with_default(Value::Int(6))]
        )]),
        Err(OdErrorKind::DefaultOutOfRange)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(2, "a", &[U8.with_default(Value::Int(256))])]),
        Err(OdErrorKind::ValueDoesNotFitType)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(2, "a", &[U8.with_default(Value::Str("x"))])]),
        Err(OdErrorKind::ValueDoesNotFitType)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(
            2,
            "a",
            &[EntryDesc::string(0, "s", "abc").with_bits(16)]
        )]),
        Err(OdErrorKind::ValueDoesNotFitType)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(2, "", &[U8])]),
        Err(OdErrorKind::EmptyName)
    );
    assert_eq!(
        check!(&[ObjectDesc::var(
            2,
            "a",
            &[EntryDesc::new(0, "r", DataType::Identity, Access::RO).with_bits(8)]
        )]),
        Err(OdErrorKind::UnsupportedType)
    );
    const BAD: &[ObjectDesc] = &[ObjectDesc::var(0x2000, "a", &[U8.with_bits(9)])];
    let e = ObjectDictionary::new(BAD).validate().err();
    assert_eq!(
        e.map(|e| std::format!("{e}")).as_deref(),
        Some("object dictionary 0x2000:00: bit length does not match the data type")
    );
}

#[test]
fn store_defaults_and_writes() {
    let mut store: OdStore<64> = OdStore::new(OD).unwrap_or_else(|_| panic!());
    assert_eq!(OdStore::<64>::required_size(&OD), 4 + 5 + 1 + 8 + 1 + 4);
    assert_eq!(store.get(0x1000, 0), Some(&[0x91, 0x01, 0x0C, 0x00][..]));
    assert_eq!(store.get(0x1008, 0), Some(&b"DAC"[..]));
    assert_eq!(store.get(0x6411, 0), Some(&[2][..]));
    let mut buf = [0u8; 8];
    assert_eq!(store.read(0x1008, 0, &mut buf), Ok(3));
    assert_eq!(store.write(0x6411, 2, &[0x34, 0x12], AlState::Op), Ok(()));
    assert_eq!(store.get(0x6411, 2), Some(&[0x34, 0x12][..]));
    assert_eq!(
        store.write(0x6411, 2, &[0x34], AlState::Op),
        Err(SdoAbortCode::LengthMismatch)
    );
    assert_eq!(store.set(0x1008, 0, b"AB"), Ok(()));
    assert_eq!(store.get(0x1008, 0), Some(&b"AB"[..]));
    assert_eq!(
        store.set(0x1008, 0, b"ABCD"),
        Err(SdoAbortCode::LengthTooHigh)
    );
    assert_eq!(
        OdStore::<8>::new(OD).err(),
        Some(StoreError::TooSmall { needed: 23 })
    );
}

#[test]
#[cfg(not(feature = "real"))]
fn real_entries_need_the_real_feature() {
    static OD: ObjectDictionary = ObjectDictionary::new(&[ObjectDesc::var(
        0x2000,
        "Gain",
        &[EntryDesc::new(0, "Gain", DataType::Real32, Access::RW)],
    )]);
    assert_eq!(
        OD.validate().map_err(|e| e.kind),
        Err(OdErrorKind::RealNotEnabled)
    );
    let mut buf = [0u8; 4];
    assert_eq!(
        Value::Real(1.0).encode(DataType::Real32, 32, &mut buf),
        None
    );
}

#[test]
fn default_and_range_read_back_unchanged() {
    let values = [
        Value::None,
        Value::Int(i64::MIN),
        Value::Int(-2),
        Value::Uint(u64::MAX),
        Value::Uint(0x1234_5678_9ABC_DEF0),
        Value::Real(-1.5e300),
        Value::Real(f64::MIN_POSITIVE),
        Value::Str("DAC"),
        Value::Bytes(&[1, 2, 3]),
    ];
    let base = EntryDesc::new(1, "x", DataType::Unsigned64, Access::RW);
    for v in values {
        assert_eq!(base.with_default(v).default(), v, "{v:?}");
    }
    assert_eq!(
        (base.min(), base.max(), base.range()),
        (Value::None, Value::None, None)
    );
    static RANGE: ValueRange = ValueRange::new(Value::Int(-3), Value::Uint(7));
    let limited = base.with_range(&RANGE);
    assert_eq!(
        (limited.min(), limited.max()),
        (Value::Int(-3), Value::Uint(7))
    );
    assert_eq!(
        limited.value_info(),
        ValueInfo::MINIMUM | ValueInfo::MAXIMUM
    );
    assert_eq!(base.with_unit(0x26).unit(), Some(0x26));
    assert_eq!(base.with_unit(0).unit(), Some(0), "unit 0 is a unit");
    // Unit and default are set independently, in either order.
    let a = base.with_unit(0x26).with_default(Value::Int(-2));
    let b = base.with_default(Value::Int(-2)).with_unit(0x26);
    assert_eq!((a.unit(), a.default()), (Some(0x26), Value::Int(-2)));
    assert_eq!(a, b);
    assert_ne!(a, base.with_default(Value::Int(-2)));
    assert_eq!(a.value_info(), ValueInfo::UNIT_TYPE | ValueInfo::DEFAULT);
}

/// An entry keeps its data type as a one-byte code: every type code up to 0xFF reads back as
/// given; a code above (ETG.1000.6's array types, which cannot describe an entry) reads back
/// as unknown type 0 and the dictionary refuses it.
#[test]
fn entry_data_types_read_back() {
    for code in 0..=0xFFu16 {
        let t = DataType::from(code);
        assert_eq!(
            EntryDesc::new(0, "x", t, Access::RO).data_type(),
            t,
            "{code:#x}"
        );
        assert_eq!(DataType::from_raw(code), t);
    }
    const WIDE: EntryDesc = EntryDesc::new(0, "x", DataType::Unknown(0x0260), Access::RO);
    assert_eq!(WIDE.data_type(), DataType::Unknown(0));
    assert_eq!(
        check!(&[ObjectDesc::var(1, "a", &[WIDE])]),
        Err(OdErrorKind::UnsupportedType)
    );
}

/// Two objects of one structure: one entry table, each object's defaults its own.
static SHARED_ENTRIES: [EntryDesc; 3] = [
    EntryDesc::count(2),
    EntryDesc::new(1, "COB-ID", DataType::Unsigned32, Access::RW),
    EntryDesc::new(2, "Type", DataType::Unsigned8, Access::RW).with_default(Value::Uint(255)),
];
static SHARED: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::record(0x1800, "TPDO 1", DataType::Unknown(0x20), &SHARED_ENTRIES)
        .with_defaults(&[EntryDefault::new(1, 0x181)]),
    ObjectDesc::record(0x1801, "TPDO 2", DataType::Unknown(0x20), &SHARED_ENTRIES)
        .with_defaults(&[EntryDefault::new(1, 0x281), EntryDefault::new(2, 1)]),
]);
const _: () = if let Err(e) = SHARED.validate() {
    panic!("{}", e.message())
};

#[test]
fn objects_sharing_entries_keep_their_own_defaults() {
    let default = |index, sub| {
        let (object, entry) = SHARED.entry(index, sub).unwrap();
        let entry = object.resolve(entry);
        (
            entry.default(),
            entry.value_info() & ValueInfo::DEFAULT != 0,
        )
    };
    assert_eq!(default(0x1800, 1), (Value::Uint(0x181), true));
    assert_eq!(default(0x1800, 2), (Value::Uint(255), true), "the table's");
    assert_eq!(default(0x1801, 1), (Value::Uint(0x281), true));
    assert_eq!(default(0x1801, 2), (Value::Uint(1), true));
    // Without its own default an entry has none if the table has none.
    let bare = ObjectDesc::record(0x1802, "TPDO 3", DataType::Unknown(0x20), &SHARED_ENTRIES);
    assert_eq!(bare.resolve(&SHARED_ENTRIES[1]).default(), Value::None);
    // A store starts from each object's own defaults.
    let store: OdStore<16> = OdStore::new(SHARED).unwrap_or_else(|_| panic!());
    assert_eq!(store.get(0x1800, 1), Some(&0x181u32.to_le_bytes()[..]));
    assert_eq!(store.get(0x1801, 2), Some(&[1][..]));
    assert_eq!(store.get(0x1800, 2), Some(&[255][..]));
}

#[test]
fn an_own_default_must_name_an_entry() {
    assert_eq!(
        check!(&[
            ObjectDesc::record(2, "a", DataType::Unknown(0x20), &SHARED_ENTRIES)
                .with_defaults(&[EntryDefault::new(3, 1)])
        ]),
        Err(OdErrorKind::DefaultOfNoEntry)
    );
    assert_eq!(
        check!(&[
            ObjectDesc::record(2, "a", DataType::Unknown(0x20), &SHARED_ENTRIES)
                .with_defaults(&[EntryDefault::new(2, 256)])
        ]),
        Err(OdErrorKind::ValueDoesNotFitType),
        "an own default is checked against its entry like the table's"
    );
}

/// Sub 0 and 32 UNSIGNED32 mapping slots: the table of a PDO of 32 samples.
static MAPPING_32: [EntryDesc; 33] = {
    let mut out = [EntryDesc::count(32); 33];
    let mut i = 1;
    while i < 33 {
        out[i] = EntryDesc::new(i as u8, "Entry", DataType::Unsigned32, Access::RO);
        i += 1;
    }
    out
};

/// 0x1A20 maps 0x6020:01..20 and 0x1A21 0x6021:01..20, each with one run of defaults.
static RUN_MAPPINGS: ObjectDictionary = ObjectDictionary::new(&[
    ObjectDesc::record(0x1A20, "Samples 1", DataType::Unknown(0x21), &MAPPING_32)
        .with_defaults(&[EntryDefault::mapping_run(1, 32, 0x6020_0110)]),
    ObjectDesc::record(0x1A21, "Samples 2", DataType::Unknown(0x21), &MAPPING_32).with_defaults(&[
        EntryDefault::new(0, 31),
        EntryDefault::mapping_run(1, 31, 0x6021_0110),
        EntryDefault::new(32, 0),
    ]),
]);
const _: () = if let Err(e) = RUN_MAPPINGS.validate() {
    panic!("{}", e.message())
};

#[test]
fn a_mapping_run_gives_each_subindex_its_entry() {
    let default = |index, sub| {
        let (object, entry) = RUN_MAPPINGS.entry(index, sub).unwrap();
        object.resolve(entry).default()
    };
    assert_eq!(default(0x1A20, 0), Value::Int(32), "the table's count");
    assert_eq!(default(0x1A20, 1), Value::Uint(0x6020_0110));
    assert_eq!(default(0x1A20, 2), Value::Uint(0x6020_0210));
    assert_eq!(default(0x1A20, 32), Value::Uint(0x6020_2010));
    assert_eq!(
        default(0x1A21, 0),
        Value::Uint(31),
        "an own default beside the run"
    );
    assert_eq!(default(0x1A21, 31), Value::Uint(0x6021_1F10));
    assert_eq!(
        default(0x1A21, 32),
        Value::Uint(0),
        "a single default after it"
    );
    let run = EntryDefault::mapping_run(5, 3, 0x7000_0710);
    assert_eq!(run.run(), 3);
    assert_eq!(
        (4..=8)
            .map(|s| run.value_of(s))
            .collect::<std::vec::Vec<_>>(),
        [
            None,
            Some(0x7000_0710),
            Some(0x7000_0810),
            Some(0x7000_0910),
            None
        ]
    );
    assert_eq!(EntryDefault::new(7, 9).value_of(7), Some(9));
    assert_eq!(EntryDefault::new(7, 9).value_of(8), None);
    // A store starts from the run's values.
    let store: OdStore<512> = OdStore::new(RUN_MAPPINGS).unwrap_or_else(|_| panic!());
    assert_eq!(
        store.get(0x1A20, 3),
        Some(&0x6020_0310u32.to_le_bytes()[..])
    );
}

#[test]
fn a_mapping_run_must_fit_its_object_and_the_subindex_field() {
    let with = |d: EntryDefault| {
        let defaults: &'static [EntryDefault] = std::boxed::Box::leak(std::boxed::Box::new([d]));
        let objects: &'static [ObjectDesc] =
            std::boxed::Box::leak(std::boxed::Box::new([ObjectDesc::record(
                0x1A00,
                "m",
                DataType::Unknown(0x21),
                &MAPPING_32,
            )
            .with_defaults(defaults)]));
        ObjectDictionary::new(objects)
            .validate()
            .map_err(|e| e.kind)
    };
    assert_eq!(with(EntryDefault::mapping_run(1, 32, 0x6000_0110)), Ok(()));
    assert_eq!(
        with(EntryDefault::mapping_run(2, 32, 0x6000_0110)),
        Err(OdErrorKind::DefaultOfNoEntry),
        "sub 33 does not exist"
    );
    assert_eq!(
        with(EntryDefault::mapping_run(1, 0, 0x6000_0110)),
        Err(OdErrorKind::BadMappingRun),
        "empty"
    );
    assert_eq!(
        with(EntryDefault::mapping_run(1, 2, 0x6000_FF10)),
        Err(OdErrorKind::BadMappingRun),
        "the subindex field would carry into the index"
    );
    assert_eq!(with(EntryDefault::mapping_run(1, 1, 0x6000_FF10)), Ok(()));
}

/// An entry with limits keeps them beside its default in the same packed field: every
/// default of at most 32 bits reads back, with the unit and limits, in any order of the
/// builders; a wider default (or a string) on a limited entry is refused by validation.
#[test]
fn limits_keep_a_default_of_32_bits() {
    static RANGE: ValueRange = ValueRange::new(Value::Int(-3), Value::Uint(7));
    let base = EntryDesc::new(1, "x", DataType::Integer64, Access::RW);
    for v in [
        Value::None,
        Value::Int(i32::MIN as i64),
        Value::Int(-2),
        Value::Uint(u32::MAX as u64),
        Value::Real(1.5),
        Value::Real(-4.0),
    ] {
        let a = base.with_default(v).with_range(&RANGE).with_unit(0x26);
        let b = base.with_unit(0x26).with_range(&RANGE).with_default(v);
        assert_eq!(a, b, "{v:?}");
        assert_eq!(
            (a.default(), a.min(), a.max(), a.unit()),
            (v, Value::Int(-3), Value::Uint(7), Some(0x26)),
            "{v:?}"
        );
        assert_eq!(a.range(), Some(&RANGE));
    }
    for wide in [
        Value::Int(i32::MIN as i64 - 1),
        Value::Uint(u32::MAX as u64 + 1),
        Value::Real(0.1),
        Value::Str("DAC"),
        Value::Bytes(&[1]),
    ] {
        for entry in [
            base.with_default(wide).with_range(&RANGE),
            base.with_range(&RANGE).with_default(wide),
            base.with_default(wide).with_range(&RANGE).with_unit(1),
            base.with_range(&RANGE)
                .with_default(wide)
                .with_range(&RANGE),
        ] {
            assert_eq!(
                validate_entry(&entry),
                Err(OdErrorKind::DefaultTooWideForLimits),
                "{wide:?}"
            );
        }
        // Without limits the same default is kept whole.
        assert_eq!(base.with_default(wide).default(), wide);
    }
    // A narrow default given after a refused one replaces it.
    let fixed = base
        .with_range(&RANGE)
        .with_default(Value::Uint(u64::MAX))
        .with_default(Value::Int(1));
    assert_eq!(validate_entry(&fixed), Ok(()));
    assert_eq!(fixed.default(), Value::Int(1));
}

/// An object keeps its object code and data type in one word: every code of the data type
/// area reads back beside each object code; a type beyond the area is refused.
#[test]
fn object_code_and_type_share_a_word() {
    static VAR: [EntryDesc; 1] = [EntryDesc::new(0, "a", DataType::Unsigned16, Access::RO)];
    static ARRAY: [EntryDesc; 2] = [
        EntryDesc::count(1),
        EntryDesc::new(1, "a", DataType::Integer32, Access::RO),
    ];
    let var = ObjectDesc::var(1, "a", &VAR);
    assert_eq!(
        (var.code(), var.data_type()),
        (ObjectCode::Var, DataType::Unsigned16)
    );
    let array = ObjectDesc::array(1, "a", &ARRAY);
    assert_eq!(
        (array.code(), array.data_type()),
        (ObjectCode::Array, DataType::Integer32)
    );
    for code in [0x0000, 0x0001, 0x0023, 0x0042, 0x0FFF] {
        let record = ObjectDesc::record(1, "a", DataType::from_raw(code), &ARRAY);
        assert_eq!(record.code(), ObjectCode::Record);
        assert_eq!(record.data_type().code(), code);
    }
    assert_eq!(
        check!(&[ObjectDesc::record(
            2,
            "a",
            DataType::Unknown(0x1000),
            &[EntryDesc::count(0)]
        )]),
        Err(OdErrorKind::ObjectTypeOutOfArea)
    );
}
