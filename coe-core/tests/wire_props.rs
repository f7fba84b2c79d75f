//! Property tests of the wire layer: random bytes never make a parser or an accessor panic,
//! and valid frames survive parse -> emit -> parse (and emit -> parse -> emit byte for byte).

use coe_core::abort::SdoAbortCode;
use coe_core::od::{Access, DataType};
use coe_core::wire::sdo_info::{value_len, ValueInfo};
use coe_core::wire::{
    Coe, CoeRepr, CoeService, Direction, Emergency, EmergencyRepr, Error, InitData, Mailbox,
    MailboxErrorReply, MailboxErrorReplyRepr, MailboxRepr, MailboxType, OdListType, Sdo, SdoInfo,
    SdoInfoHeaderRepr, SdoInfoOpCode, SdoInfoRepr, SdoRepr,
};
use proptest::prelude::*;

/// Touches every getter of every view (unchecked, so out-of-range reads are exercised).
fn read_all_views(bytes: &[u8]) {
    let m = Mailbox::new_unchecked(bytes);
    let _ = (
        m.length(),
        m.address(),
        m.channel(),
        m.priority(),
        m.mailbox_type(),
    );
    let _ = (m.counter(), m.reserved(), m.frame_len(), m.payload());
    let e = MailboxErrorReply::new_unchecked(bytes);
    let _ = (e.service_type(), e.detail());
    let c = Coe::new_unchecked(bytes);
    let _ = (c.number(), c.reserved(), c.service(), c.payload());
    let s = Sdo::new_unchecked(bytes);
    let _ = (
        s.command(),
        s.command_specifier(),
        s.size_indicated(),
        s.expedited(),
    );
    let _ = (
        s.expedited_unused(),
        s.complete_access(),
        s.toggle(),
        s.segment_unused(),
    );
    let _ = (
        s.last_segment(),
        s.index(),
        s.sub_index(),
        s.expedited_data(),
    );
    let _ = (
        s.complete_size(),
        s.abort_code(),
        s.normal_data(),
        s.segment_bytes(),
    );
    let i = SdoInfo::new_unchecked(bytes);
    let _ = (
        i.opcode(),
        i.incomplete(),
        i.reserved(),
        i.fragments_left(),
        i.list_type(),
    );
    let _ = (
        i.index(),
        i.object_data_type(),
        i.max_sub_index(),
        i.object_code(),
    );
    let _ = (
        i.sub_index(),
        i.value_info(),
        i.entry_data_type(),
        i.bit_length(),
    );
    let _ = (i.object_access(), i.abort_code(), i.payload(), i.od_list());
    let _ = (i.object_name(), i.entry_data());
    let g = Emergency::new_unchecked(bytes);
    let _ = (g.error_code(), g.error_register(), g.data());
}

/// Runs every parser on `bytes`; where one succeeds, emits the result and parses it again.
fn parse_all(bytes: &[u8]) {
    let mut out = [0u8; 1100];

    if let Ok(r) = MailboxRepr::parse(&Mailbox::new_unchecked(bytes)) {
        assert!(r.buffer_len() <= bytes.len());
        let mut p = Mailbox::new_unchecked(&mut out[..r.buffer_len()]);
        r.emit(&mut p).unwrap();
        assert_eq!(
            MailboxRepr::parse(&Mailbox::new_unchecked(&out[..r.buffer_len()])),
            Ok(r)
        );
        assert_eq!(out[..4], bytes[..4]);
    }
    if let Ok(r) = MailboxErrorReplyRepr::parse(&MailboxErrorReply::new_unchecked(bytes)) {
        r.emit(&mut MailboxErrorReply::new_unchecked(&mut out[..]))
            .unwrap();
        assert_eq!(out[..4], bytes[..4]);
    }
    if let Ok(r) = CoeRepr::parse(&Coe::new_unchecked(bytes)) {
        r.emit(&mut Coe::new_unchecked(&mut out[..])).unwrap();
        assert_eq!(CoeRepr::parse(&Coe::new_unchecked(&out[..2])), Ok(r));
    }
    for direction in [Direction::Request, Direction::Response] {
        if let Ok(r) = SdoRepr::parse(&Sdo::new_unchecked(bytes), direction) {
            let n = r.buffer_len();
            r.emit(&mut Sdo::new_unchecked(&mut out[..])).unwrap();
            let again = SdoRepr::parse(&Sdo::new_unchecked(&out[..n]), direction).unwrap();
            // Abort frames parse in both directions; the rest keep their direction.
            assert_eq!(again, r);
            // The command byte and (for initiate and abort frames) index/subindex are kept.
            if !matches!(r, SdoRepr::Abort { .. }) {
                assert_eq!(out[0], bytes[0]);
            }
        }
    }
    if let Ok(r) = SdoInfoRepr::parse(&SdoInfo::new_unchecked(bytes)) {
        let n = r.buffer_len();
        r.emit(&mut SdoInfo::new_unchecked(&mut out[..])).unwrap();
        assert_eq!(
            SdoInfoRepr::parse(&SdoInfo::new_unchecked(&out[..n])),
            Ok(r)
        );
    }
    if let Ok(h) = SdoInfoHeaderRepr::parse(&SdoInfo::new_unchecked(bytes)) {
        h.emit(&mut SdoInfo::new_unchecked(&mut out[..])).unwrap();
        assert_eq!(out[0], bytes[0]);
        assert_eq!(out[2..4], bytes[2..4]);
    }
    for op in 0..=8u8 {
        let _ = SdoInfoRepr::parse_service_data(SdoInfoOpCode::from(op), bytes);
    }
    if let Ok(r) = EmergencyRepr::parse(&Emergency::new_unchecked(bytes)) {
        r.emit(&mut Emergency::new_unchecked(&mut out[..])).unwrap();
        assert_eq!(out[..8], bytes[..8]);
    }
}

/// The whole mailbox stack: header, then the protocol the type names.
fn parse_stack(bytes: &[u8]) {
    let Ok(mbx) = Mailbox::new_checked(bytes) else {
        return;
    };
    let payload = mbx.payload();
    match mbx.mailbox_type() {
        MailboxType::Error => {
            let _ = MailboxErrorReplyRepr::parse(&MailboxErrorReply::new_unchecked(payload));
        }
        MailboxType::Coe => {
            let Ok(coe) = Coe::new_checked(payload) else {
                return;
            };
            let data = coe.payload();
            match coe.service() {
                CoeService::Emergency => {
                    let _ = EmergencyRepr::parse(&Emergency::new_unchecked(data));
                }
                CoeService::SdoInformation => {
                    let _ = SdoInfoRepr::parse(&SdoInfo::new_unchecked(data));
                }
                service => {
                    if let Some(d) = Direction::from_service(service) {
                        let _ = SdoRepr::parse(&Sdo::new_unchecked(data), d);
                    }
                }
            }
        }
        _ => {}
    }
}

fn init_data() -> impl Strategy<Value = (Option<u8>, [u8; 4], u32, Vec<u8>, u8)> {
    (
        prop::option::of(1u8..=4),
        any::<[u8; 4]>(),
        any::<u32>(),
        prop::collection::vec(any::<u8>(), 0..40),
        0u8..2,
    )
}

fn make_init(d: &(Option<u8>, [u8; 4], u32, Vec<u8>, u8)) -> InitData<'_> {
    let (size, data, complete_size, normal, kind) = d;
    if *kind == 0 {
        InitData::Expedited {
            size: *size,
            data: *data,
        }
    } else {
        InitData::Normal {
            complete_size: *complete_size,
            data: normal,
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        read_all_views(&bytes);
        parse_all(&bytes);
        parse_stack(&bytes);
    }

    #[test]
    fn random_mailbox_frames_never_panic(
        len in 0u16..300,
        b4 in any::<u8>(),
        b5 in any::<u8>(),
        coe in any::<[u8; 2]>(),
        body in prop::collection::vec(any::<u8>(), 0..300),
    ) {
        // A plausible header in front of random protocol bytes reaches the inner parsers.
        let mut frame = Vec::new();
        frame.extend_from_slice(&len.to_le_bytes());
        frame.extend_from_slice(&[0, 0, b4, b5]);
        frame.extend_from_slice(&coe);
        frame.extend_from_slice(&body);
        parse_stack(&frame);
        read_all_views(&frame);
    }

    #[test]
    fn mailbox_round_trip(
        address in any::<u16>(),
        channel in 0u8..64,
        priority in 0u8..4,
        ty in 0u8..16,
        counter in 0u8..8,
        payload in prop::collection::vec(any::<u8>(), 0..64),
        pad in 0usize..8,
    ) {
        let repr = MailboxRepr {
            address,
            channel,
            priority,
            mailbox_type: MailboxType::from(ty),
            counter,
            payload_len: payload.len(),
        };
        let mut buf = vec![0xa5u8; repr.buffer_len() + pad];
        let mut p = Mailbox::new_unchecked(&mut buf[..]);
        repr.emit(&mut p).unwrap();
        p.payload_mut().copy_from_slice(&payload);
        let view = Mailbox::new_checked(&buf[..]).unwrap();
        prop_assert_eq!(MailboxRepr::parse(&view), Ok(repr));
        prop_assert_eq!(view.payload(), &payload[..]);
        // Any cut inside the frame is truncated.
        let cut = repr.buffer_len() - 1;
        prop_assert_eq!(Mailbox::new_checked(&buf[..cut]), Err(Error::Truncated));
        // Emit of the parsed header reproduces the bytes.
        let mut again = buf.clone();
        MailboxRepr::parse(&view).unwrap().emit(&mut Mailbox::new_unchecked(&mut again[..])).unwrap();
        prop_assert_eq!(again, buf);
    }

    #[test]
    fn coe_round_trip(number in 0u16..0x200, service in 0u8..16) {
        let repr = CoeRepr { number, service: CoeService::from(service) };
        let mut buf = [0xa5u8; 2];
        repr.emit(&mut Coe::new_unchecked(&mut buf[..])).unwrap();
        prop_assert_eq!(CoeRepr::parse(&Coe::new_unchecked(&buf[..])), Ok(repr));
        prop_assert_eq!(u16::from_le_bytes(buf), number | (u16::from(service) << 12));
    }

    #[test]
    fn sdo_round_trip(
        which in 0u8..9,
        index in any::<u16>(),
        sub_index in any::<u8>(),
        ca in any::<bool>(),
        toggle in any::<bool>(),
        last in any::<bool>(),
        init in init_data(),
        seg in prop::collection::vec(any::<u8>(), 0..40),
        code in any::<u32>(),
    ) {
        let data = make_init(&init);
        let repr = match which {
            0 => SdoRepr::InitiateDownloadRequest { index, sub_index, complete_access: ca, data },
            1 => SdoRepr::InitiateDownloadResponse { index, sub_index, complete_access: ca },
            2 => SdoRepr::InitiateUploadRequest { index, sub_index, complete_access: ca },
            3 => SdoRepr::InitiateUploadResponse { index, sub_index, complete_access: ca, data },
            4 => SdoRepr::DownloadSegmentRequest { toggle, last, data: &seg },
            5 => SdoRepr::DownloadSegmentResponse { toggle },
            6 => SdoRepr::UploadSegmentRequest { toggle },
            7 => SdoRepr::UploadSegmentResponse { toggle, last, data: &seg },
            _ => SdoRepr::Abort { index, sub_index, code: SdoAbortCode::from(code) },
        };
        let mut buf = vec![0xa5u8; repr.buffer_len() + 4];
        repr.emit(&mut Sdo::new_unchecked(&mut buf[..])).unwrap();
        prop_assert!(buf[repr.buffer_len()..].iter().all(|&b| b == 0xa5));
        let frame = &buf[..repr.buffer_len()];
        prop_assert!(frame.len() >= 8);
        let parsed = SdoRepr::parse(&Sdo::new_unchecked(frame), repr.direction()).unwrap();
        prop_assert_eq!(parsed, repr);
        // emit(parse(bytes)) == bytes.
        let mut again = vec![0x5au8; frame.len()];
        parsed.emit(&mut Sdo::new_unchecked(&mut again[..])).unwrap();
        prop_assert_eq!(&again[..], frame);
        // One byte less is never accepted as the same frame.
        let short = &frame[..frame.len() - 1];
        prop_assert_ne!(SdoRepr::parse(&Sdo::new_unchecked(short), repr.direction()), Ok(repr));
    }

    #[test]
    fn sdo_info_round_trip(
        which in 0u8..7,
        index in any::<u16>(),
        sub_index in any::<u8>(),
        list_type in 0u16..8,
        list in prop::collection::vec(any::<u16>(), 0..30),
        data_type in any::<u16>(),
        max_sub in any::<u8>(),
        object_code in 7u8..10,
        name in prop::collection::vec(any::<u8>(), 0..30),
        info_bits in any::<u8>(),
        bit_length in 0u16..80,
        access in 0u16..0x400,
        unit in any::<u16>(),
        values in prop::collection::vec(any::<u8>(), 30),
        code in any::<u32>(),
        per_fragment in 1usize..20,
    ) {
        let list_bytes: Vec<u8> = list.iter().flat_map(|v| v.to_le_bytes()).collect();
        let value_info = ValueInfo(info_bits & 0x7F);
        let n = value_len(bit_length);
        let pick = |flag: u8, k: usize| -> &[u8] {
            if value_info.contains(flag) { &values[k * 10..k * 10 + n] } else { &[] }
        };
        let repr = match which {
            0 => SdoInfoRepr::OdListRequest { list_type: OdListType::from(list_type) },
            1 => SdoInfoRepr::OdListResponse { list_type: OdListType::from(list_type), list: &list_bytes },
            2 => SdoInfoRepr::ObjectDescriptionRequest { index },
            3 => SdoInfoRepr::ObjectDescriptionResponse {
                index,
                data_type: DataType::from(data_type),
                max_sub_index: max_sub,
                object_code,
                name: &name,
            },
            4 => SdoInfoRepr::EntryDescriptionRequest { index, sub_index, value_info },
            5 => SdoInfoRepr::EntryDescriptionResponse {
                index,
                sub_index,
                value_info,
                data_type: DataType::from(data_type),
                bit_length,
                access: Access(access),
                unit_type: if value_info.contains(ValueInfo::UNIT_TYPE) { unit } else { 0 },
                default: pick(ValueInfo::DEFAULT, 0),
                minimum: pick(ValueInfo::MINIMUM, 1),
                maximum: pick(ValueInfo::MAXIMUM, 2),
                name: &name,
            },
            _ => SdoInfoRepr::Error { code: SdoAbortCode::from(code) },
        };
        let mut buf = vec![0xa5u8; repr.buffer_len() + 3];
        repr.emit(&mut SdoInfo::new_unchecked(&mut buf[..])).unwrap();
        prop_assert!(buf[repr.buffer_len()..].iter().all(|&b| b == 0xa5));
        let frame = &buf[..repr.buffer_len()];
        let parsed = SdoInfoRepr::parse(&SdoInfo::new_unchecked(frame)).unwrap();
        prop_assert_eq!(parsed, repr);
        let mut again = vec![0u8; frame.len()];
        parsed.emit(&mut SdoInfo::new_unchecked(&mut again[..])).unwrap();
        prop_assert_eq!(&again[..], frame);

        // Fragments of any size concatenate to the unfragmented service data.
        let total = repr.service_data_len();
        let mut joined = Vec::new();
        let mut chunk = vec![0u8; per_fragment];
        while joined.len() < total {
            let k = coe_core::sdo_server::info::emit_fragment(&repr, joined.len(), &mut chunk).unwrap();
            prop_assert!(k > 0);
            joined.extend_from_slice(&chunk[..k]);
        }
        prop_assert_eq!(&joined[..], &frame[4..]);
    }

    #[test]
    fn emergency_round_trip(error_code in any::<u16>(), reg in any::<u8>(), data in any::<[u8; 5]>()) {
        let repr = EmergencyRepr { error_code, error_register: reg, data };
        let mut buf = [0xa5u8; 8];
        repr.emit(&mut Emergency::new_unchecked(&mut buf[..])).unwrap();
        prop_assert_eq!(EmergencyRepr::parse(&Emergency::new_unchecked(&buf[..])), Ok(repr));
    }

    #[test]
    fn mailbox_error_reply_round_trip(code in any::<u16>(), counter in 0u8..8, address in any::<u16>()) {
        let repr = MailboxErrorReplyRepr { code: code.into() };
        let mut buf = [0xa5u8; 10];
        prop_assert_eq!(repr.emit_frame(&mut buf, address, counter), Ok(10));
        let m = Mailbox::new_checked(&buf[..]).unwrap();
        prop_assert_eq!(m.mailbox_type(), MailboxType::Error);
        prop_assert_eq!(m.counter(), counter);
        prop_assert_eq!(MailboxErrorReplyRepr::parse(&MailboxErrorReply::new_unchecked(m.payload())), Ok(repr));
    }
}
