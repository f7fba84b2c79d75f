//! Property tests: random bytes never panic the server and get no reply, a mailbox error or a
//! well-formed CoE reply; every writable entry round-trips download -> upload; segmented
//! transfers of random lengths through random mailbox sizes round-trip.

mod server_common;

use coe_core::esm::AlState;
use coe_core::od::{decode_int, int_limits, Value};
use coe_core::wire::{
    Coe, CoeService, Direction, Emergency, EmergencyRepr, Mailbox, MailboxRepr, Sdo, SdoInfo,
    SdoInfoHeaderRepr, SdoRepr,
};
use proptest::prelude::*;
use server_common::*;

/// Checks that `reply` is one of the frames the server may send.
fn assert_well_formed(reply: &[u8], mbx: usize) {
    assert!(reply.len() >= 6 && reply.len() <= mbx, "{reply:02X?}");
    let len = u16::from_le_bytes([reply[0], reply[1]]) as usize;
    assert_eq!(len + 6, reply.len());
    let data = &reply[6..];
    match reply[5] & 0x0F {
        0 => {
            assert_eq!(data.len(), 4);
            assert_eq!(&data[..2], &[0x01, 0x00]);
            let detail = u16::from_le_bytes([data[2], data[3]]);
            assert!((1..=8).contains(&detail));
        }
        3 => {
            assert!(data.len() >= 2);
            match data[1] >> 4 {
                // Abort transfer: exactly command 0x80 + index + sub + code.
                2 => {
                    assert_eq!(data.len(), 10);
                    assert_eq!(data[2], 0x80);
                }
                3 => {
                    assert!(data.len() >= 10);
                    let command = data[2];
                    match command >> 5 {
                        3 => assert_eq!(command & 0xEF, 0x60),
                        2 => {
                            if command & 0x02 != 0 {
                                assert_eq!(data.len(), 10);
                            } else {
                                let size = u32::from_le_bytes([data[6], data[7], data[8], data[9]]);
                                assert!(data.len() - 10 <= size as usize);
                            }
                        }
                        1 => assert_eq!(command & 0xEF, 0x20),
                        0 => {}
                        _ => panic!("bad response {command:#x}"),
                    }
                }
                1 => assert_eq!(data.len(), 10),
                8 => {
                    assert!(data.len() >= 6);
                    assert!(matches!(data[2] & 0x7F, 2 | 4 | 6 | 7));
                }
                s => panic!("service {s}"),
            }
        }
        t => panic!("mailbox type {t}"),
    }
    // The wire layer reads the same frame back.
    let frame = Mailbox::new_checked(reply).expect("mailbox frame");
    assert!(MailboxRepr::parse(&frame).is_ok());
    if let Ok(coe) = Coe::new_checked(frame.payload()) {
        let body = coe.payload();
        match coe.service() {
            CoeService::SdoRequest => assert!(matches!(
                SdoRepr::parse(&Sdo::new_unchecked(body), Direction::Request),
                Ok(SdoRepr::Abort { .. })
            )),
            CoeService::SdoResponse => {
                let parsed = SdoRepr::parse(&Sdo::new_unchecked(body), Direction::Response);
                assert!(parsed.is_ok(), "{reply:02X?}");
            }
            CoeService::SdoInformation => {
                assert!(SdoInfoHeaderRepr::parse(&SdoInfo::new_unchecked(body)).is_ok())
            }
            CoeService::Emergency => {
                assert!(EmergencyRepr::parse(&Emergency::new_unchecked(body)).is_ok())
            }
            _ => {}
        }
    }
}

fn state_strategy() -> impl Strategy<Value = AlState> {
    prop_oneof![
        Just(AlState::Init),
        Just(AlState::PreOp),
        Just(AlState::SafeOp),
        Just(AlState::Op),
        Just(AlState::Bootstrap),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn random_bytes_never_panic(
        frames in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..90), 1..6),
        state in state_strategy(),
        mbx in 0usize..96,
        step in 0u32..3000,
    ) {
        let mut b = Bench::with_mailbox(mbx);
        b.state = state;
        for f in &frames {
            b.now = b.now.wrapping_add(step);
            if let Some(reply) = b.raw(f) {
                assert_well_formed(&reply, mbx);
            }
            if let Some(reply) = b.poll() {
                assert_well_formed(&reply, mbx);
            }
        }
    }

    #[test]
    fn random_coe_requests_never_panic(
        requests in proptest::collection::vec(
            (prop_oneof![Just(0x20u8), Just(0x80u8), any::<u8>()],
             proptest::collection::vec(any::<u8>(), 0..70)),
            1..8),
        state in state_strategy(),
        mbx in 10usize..80,
    ) {
        let mut b = Bench::with_mailbox(mbx);
        b.state = state;
        for (service, body) in &requests {
            let mut coe = vec![0x00, *service];
            coe.extend_from_slice(body);
            let c = b.counter % 7 + 1;
            b.counter = c;
            if let Some(reply) = b.raw(&frame(c, &coe)) {
                assert_well_formed(&reply, mbx);
            }
            while let Some(reply) = b.poll() {
                assert_well_formed(&reply, mbx);
            }
        }
    }

    /// Every entry writable in PREOP with a fixed size: a random value in its type range and
    /// its min..max downloads (expedited up to 4 bytes, normal above) and uploads unchanged.
    #[test]
    fn writable_entries_round_trip(raw in any::<u64>()) {
        let mut b = Bench::new();
        // 0x1A00/0x1C13 are PDO configuration with its own rules (server_pdo_sdo.rs).
        for object in OD.iter().filter(|o| !matches!(o.index, 0x1A00 | 0x1C13)) {
            for entry in object.entries {
                if !entry.access.writable_in(AlState::PreOp)
                    || !entry.access.readable_in(AlState::PreOp)
                    || entry.data_type().is_variable_length()
                {
                    continue;
                }
                let (lo, hi) = int_limits(entry.data_type(), entry.bit_len).unwrap();
                let lo = match entry.min() { Value::Int(v) => lo.max(v.into()), _ => lo };
                let hi = match entry.max() { Value::Int(v) => hi.min(v.into()), _ => hi };
                // Sub 0 of the dynamic list must stay within its highest subindex.
                let hi = if entry.subindex == 0 && object.code() != coe_core::od::ObjectCode::Var {
                    hi.min(object.max_subindex().into())
                } else { hi };
                let value = lo + (raw as i128).rem_euclid(hi - lo + 1);
                let n = entry.byte_len();
                let bytes = &value.to_le_bytes()[..n];
                let req = if n <= 4 {
                    let mut data = [0u8; 4];
                    data[..n].copy_from_slice(bytes);
                    sdo(0x23 | (((4 - n) as u8) << 2), object.index, entry.subindex, data)
                } else {
                    let mut r = sdo(0x21, object.index, entry.subindex, (n as u32).to_le_bytes());
                    r.extend_from_slice(bytes);
                    r
                };
                prop_assert_eq!(b.ask(&req), resp(0x60, object.index, entry.subindex, [0; 4]),
                    "download {:#06x}:{}", object.index, entry.subindex);
                let up = b.ask(&sdo(0x40, object.index, entry.subindex, [0; 4]));
                let got = if up[2] & 0x02 != 0 { up[6..6 + n].to_vec() } else { up[10..].to_vec() };
                prop_assert_eq!(&got[..], bytes);
                prop_assert_eq!(decode_int(entry.data_type(), entry.bit_len, &got), Some(value));
            }
        }
    }

    /// Segmented download then segmented upload of OCTET_STRING / DOMAIN values of random
    /// length through random mailbox sizes.
    #[test]
    fn segmented_round_trip(
        index in prop_oneof![Just(0x2006u16), Just(0x2007u16)],
        len_seed in any::<u16>(),
        seed in any::<u8>(),
        mbx in 16usize..100,
    ) {
        let cap = if index == 0x2006 { 200 } else { 300 };
        let len = usize::from(len_seed) % (cap + 1);
        let value: Vec<u8> = (0..len).map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed)).collect();
        let mut b = Bench::with_mailbox(mbx);
        download(&mut b, index, &value, mbx);
        prop_assert_eq!(b.app.store.get(index, 0), Some(&value[..]));
        prop_assert_eq!(upload(&mut b, index, mbx), value);
    }
}

/// A master's segmented download through a `mbx`-byte write mailbox.
fn download(b: &mut Bench, index: u16, value: &[u8], mbx: usize) {
    let first = value.len().min(mbx - 16);
    let mut req = sdo(0x21, index, 0, (value.len() as u32).to_le_bytes());
    req.extend_from_slice(&value[..first]);
    assert_eq!(b.ask(&req), resp(0x60, index, 0, [0; 4]));
    if first == value.len() {
        return;
    }
    let mut sent = first;
    let mut toggle = 0u8;
    loop {
        let chunk = (value.len() - sent).min(mbx - 9);
        let last = sent + chunk == value.len();
        let unused = 7usize.saturating_sub(chunk);
        let command = toggle | ((unused as u8) << 1) | u8::from(last);
        let mut seg = vec![0x00, 0x20, command];
        seg.extend_from_slice(&value[sent..sent + chunk]);
        seg.resize(seg.len() + unused, 0);
        let reply = b.ask(&seg);
        assert_eq!(&reply[..3], &[0x00, 0x30, 0x20 | toggle]);
        sent += chunk;
        toggle ^= 0x10;
        if last {
            return;
        }
    }
}

/// A master's upload through a `mbx`-byte read mailbox (expedited, normal or segmented).
fn upload(b: &mut Bench, index: u16, mbx: usize) -> Vec<u8> {
    let reply = b.ask(&sdo(0x40, index, 0, [0; 4]));
    assert!(reply.len() + 6 <= mbx);
    let command = reply[2];
    if command & 0x02 != 0 {
        let n = 4 - usize::from((command >> 2) & 3);
        return reply[6..6 + n].to_vec();
    }
    let size = u32::from_le_bytes([reply[6], reply[7], reply[8], reply[9]]) as usize;
    let mut data = reply[10..].to_vec();
    let mut toggle = 0u8;
    while data.len() < size {
        let mut req = vec![0x00, 0x20, 0x60 | toggle];
        req.extend_from_slice(&[0; 7]);
        let r = b.ask(&req);
        assert!(r.len() + 6 <= mbx);
        assert_eq!(r[2] & 0x10, toggle);
        let unused = usize::from((r[2] >> 1) & 7);
        data.extend_from_slice(&r[3..r.len() - unused]);
        toggle ^= 0x10;
        if r[2] & 1 != 0 {
            break;
        }
    }
    assert_eq!(data.len(), size);
    data
}
