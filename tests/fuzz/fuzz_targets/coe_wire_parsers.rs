//! Fuzz target: every wire-layer parser and view accessor on arbitrary bytes, at every
//! layer of the mailbox stack, never panics; whatever parses re-emits and parses to the same
//! value.
//!
//! The whole input goes to every parser directly (as if it started at that layer) and
//! through the mailbox stack (header -> CoE -> SDO / SDO Information / Emergency); byte 0 also
//! picks the offset of one SDO Information fragment.
#![no_main]

use coe_core::wire::{
    Coe, CoeRepr, CoeService, Direction, Emergency, EmergencyRepr, Mailbox, MailboxErrorReply,
    MailboxErrorReplyRepr, MailboxRepr, MailboxType, Sdo, SdoInfo, SdoInfoHeaderRepr,
    SdoInfoOpCode, SdoInfoRepr, SdoRepr,
};
use libfuzzer_sys::fuzz_target;

fn views(data: &[u8]) {
    let m = Mailbox::new_unchecked(data);
    let _ = (
        m.length(),
        m.address(),
        m.channel(),
        m.priority(),
        m.mailbox_type(),
    );
    let _ = (m.counter(), m.reserved(), m.payload());
    let c = Coe::new_unchecked(data);
    let _ = (c.number(), c.reserved(), c.service(), c.payload());
    let s = Sdo::new_unchecked(data);
    let _ = (
        s.command(),
        s.index(),
        s.sub_index(),
        s.expedited_data(),
        s.abort_code(),
    );
    let _ = (
        s.complete_size(),
        s.normal_data(),
        s.segment_bytes(),
        s.segment_unused(),
    );
    let i = SdoInfo::new_unchecked(data);
    let _ = (
        i.opcode(),
        i.fragments_left(),
        i.list_type(),
        i.value_info(),
        i.bit_length(),
    );
    let _ = (
        i.object_access(),
        i.object_name(),
        i.entry_data(),
        i.od_list(),
        i.abort_code(),
    );
    let e = Emergency::new_unchecked(data);
    let _ = (e.error_code(), e.error_register(), e.data());
}

fn parsers(data: &[u8]) {
    // Room for whatever parses: a repr emits at most its input plus the padding of a short
    // SDO segment (a mailbox header's length field reaches 0xFFFF, past any fixed buffer).
    let mut out = vec![0u8; data.len() + 64];
    if let Ok(r) = MailboxRepr::parse(&Mailbox::new_unchecked(data)) {
        r.emit(&mut Mailbox::new_unchecked(&mut out[..])).unwrap();
        assert_eq!(
            MailboxRepr::parse(&Mailbox::new_unchecked(&out[..r.buffer_len()])),
            Ok(r)
        );
    }
    if let Ok(r) = MailboxErrorReplyRepr::parse(&MailboxErrorReply::new_unchecked(data)) {
        r.emit(&mut MailboxErrorReply::new_unchecked(&mut out[..]))
            .unwrap();
    }
    if let Ok(r) = CoeRepr::parse(&Coe::new_unchecked(data)) {
        r.emit(&mut Coe::new_unchecked(&mut out[..])).unwrap();
        assert_eq!(CoeRepr::parse(&Coe::new_unchecked(&out[..2])), Ok(r));
    }
    for direction in [Direction::Request, Direction::Response] {
        if let Ok(r) = SdoRepr::parse(&Sdo::new_unchecked(data), direction) {
            if r.emit(&mut Sdo::new_unchecked(&mut out[..])).is_ok() {
                let n = r.buffer_len();
                assert_eq!(
                    SdoRepr::parse(&Sdo::new_unchecked(&out[..n]), direction),
                    Ok(r)
                );
            }
        }
    }
    if let Ok(r) = SdoInfoRepr::parse(&SdoInfo::new_unchecked(data)) {
        if r.emit(&mut SdoInfo::new_unchecked(&mut out[..])).is_ok() {
            let n = r.buffer_len();
            assert_eq!(
                SdoInfoRepr::parse(&SdoInfo::new_unchecked(&out[..n])),
                Ok(r)
            );
        }
        let mut chunk = [0u8; 7];
        let offset = usize::from(data.first().copied().unwrap_or(0));
        let _ = coe_core::sdo_server::info::emit_fragment(&r, offset, &mut chunk);
    }
    let _ = SdoInfoHeaderRepr::parse(&SdoInfo::new_unchecked(data));
    for op in 0..=8u8 {
        let _ = SdoInfoRepr::parse_service_data(SdoInfoOpCode::from(op), data);
    }
    if let Ok(r) = EmergencyRepr::parse(&Emergency::new_unchecked(data)) {
        r.emit(&mut Emergency::new_unchecked(&mut out[..])).unwrap();
    }
}

fn stack(data: &[u8]) {
    let Ok(mbx) = Mailbox::new_checked(data) else {
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
            let inner = coe.payload();
            match coe.service() {
                CoeService::Emergency => {
                    let _ = EmergencyRepr::parse(&Emergency::new_unchecked(inner));
                }
                CoeService::SdoInformation => {
                    let _ = SdoInfoRepr::parse(&SdoInfo::new_unchecked(inner));
                }
                service => {
                    if let Some(d) = Direction::from_service(service) {
                        let _ = SdoRepr::parse(&Sdo::new_unchecked(inner), d);
                    }
                }
            }
        }
        _ => {}
    }
}

fuzz_target!(|data: &[u8]| {
    views(data);
    parsers(data);
    stack(data);
});
