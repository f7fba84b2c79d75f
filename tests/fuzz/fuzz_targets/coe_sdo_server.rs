//! Fuzz target: any sequence of mailbox frames into the SDO server, in any ESM state, through
//! any read-mailbox size, never panics, and every reply fits the mailbox and carries a
//! consistent mailbox header.
//!
//! Input layout: byte 0 = state selector, byte 1 = read-mailbox size, byte 2 = clock step,
//! then frames separated by the length byte in front of each.
//!
//! Run: `cargo xtask fuzz --target coe_sdo_server` (see the `[[bin]]` entries
//! in this crate's Cargo.toml).
#![no_main]

use coe_core::esm::AlState;
use coe_core::od::{
    Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, OdStore, Value, ValueRange,
};
use coe_core::sdo_server::{Emergency, Reply, SdoServer};
use coe_core::wire::{Mailbox, MailboxRepr, MailboxType};
use libfuzzer_sys::fuzz_target;

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
        &[EntryDesc::string(
            0,
            "Device name",
            "A device name long enough to need a segmented upload in a small mailbox",
        )],
    ),
    ObjectDesc::var(
        0x2000,
        "U16",
        &[EntryDesc::new(0, "U16", DataType::Unsigned16, Access::RW)
            .with_range(&ValueRange {
                min: Value::Int(1),
                max: Value::Int(999),
            })
            .with_default(Value::Int(5))],
    ),
    ObjectDesc::var(
        0x2001,
        "Octets",
        &[EntryDesc::new(0, "Octets", DataType::OctetString, Access::RW).with_bits(800)],
    ),
    ObjectDesc::record(
        0x3000,
        "Record",
        DataType::Unknown(0x40),
        &[
            EntryDesc::count(3).with_access(Access::RW_PREOP),
            EntryDesc::new(1, "Flag", DataType::Boolean, Access::RW),
            EntryDesc::new(2, "Bits", DataType::Bit3, Access::RW),
            EntryDesc::new(3, "Word", DataType::Integer16, Access::WO),
        ],
    ),
    ObjectDesc::array(
        0x6401,
        "AI",
        &[
            EntryDesc::count(2),
            EntryDesc::new(1, "AI 1", DataType::Integer16, Access::RO.tx_mappable()),
            EntryDesc::new(2, "AI 2", DataType::Integer16, Access::RO.tx_mappable()),
        ],
    ),
]);

const STATES: [AlState; 5] = [
    AlState::Init,
    AlState::PreOp,
    AlState::SafeOp,
    AlState::Op,
    AlState::Bootstrap,
];

/// A reply fits the buffer, its mailbox header parses, its length field covers exactly the
/// frame, and it is a CoE frame or a mailbox error reply.
fn check(reply: Reply, buf: &[u8]) {
    if let Reply::Frame(n) = reply {
        let frame = buf.get(..n).expect("reply fits the read mailbox");
        let header = MailboxRepr::parse(&Mailbox::new_unchecked(frame)).expect("mailbox header");
        assert_eq!(header.buffer_len(), n);
        assert!(matches!(
            header.mailbox_type,
            MailboxType::Coe | MailboxType::Error
        ));
    }
}

fuzz_target!(|data: &[u8]| {
    let [state, mbx, step, rest @ ..] = data else {
        return;
    };
    let state = STATES[usize::from(*state) % STATES.len()];
    let mut server: SdoServer<128, 256, 2> = SdoServer::new();
    let Ok(mut app) = OdStore::<512>::new(OD) else {
        return;
    };
    let mut reply = vec![0u8; usize::from(*mbx) % 140];
    let mut now = 0u32;
    let mut rest = rest;
    while let [len, tail @ ..] = rest {
        let len = usize::from(*len).min(tail.len());
        let (frame, next) = tail.split_at(len);
        rest = next;
        now = now.wrapping_add(u32::from(*step) * 8);
        let r = server.process(frame, state, &OD, &mut app, now, &mut reply);
        check(r, &reply);
        server.queue_emergency(Emergency::default());
        let r = server.poll(&OD, &mut reply);
        check(r, &reply);
        let r = server.repeat(&mut reply);
        check(r, &reply);
    }
});
