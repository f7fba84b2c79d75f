//! Scripted SDO conversations (ETG.1000.6 5.6.2): request bytes -> reply bytes.
//!
//! Frame layout used in the expectations (all little-endian):
//! - CoE header: `00 20` SDO request (service 2), `00 30` SDO response (service 3);
//! - SDO header: command, index (2), subindex, 4 bytes (expedited data or complete size);
//! - command bits: b0 size indicated, b1 expedited, b2..3 n (4 - n bytes valid), b4 complete
//!   access (initiate) or toggle (segment), b5..7 command specifier;
//!   initiate download request 0x2x, response 0x60; initiate upload request 0x40, response
//!   0x4x; download segment request 0x0x, response 0x20/0x30; upload segment request
//!   0x60/0x70, response 0x0x/0x1x; abort 0x80 sent as service 2.

mod server_common;

use coe_core::esm::AlState;
use coe_core::SdoAbortCode as A;
use server_common::*;

// ---------------------------------------------------------------- expedited upload

#[test]
fn expedited_upload_u32() {
    let mut b = Bench::new();
    // 0x1000 UNSIGNED32 = 0x000C0191: 0x43 = upload response, expedited, size indicated, n = 0.
    assert_eq!(
        b.ask(&sdo(0x40, 0x1000, 0, [0; 4])),
        resp(0x43, 0x1000, 0, [0x91, 0x01, 0x0C, 0x00])
    );
}

#[test]
fn expedited_upload_exact_sizes() {
    let mut b = Bench::new();
    // UNSIGNED8: one byte, n = 3 -> 0x4F.
    b.app.store.set(0x2000, 0, &[0xA5]).unwrap();
    assert_eq!(
        b.ask(&sdo(0x40, 0x2000, 0, [0; 4])),
        resp(0x4F, 0x2000, 0, [0xA5, 0, 0, 0])
    );
    // UNSIGNED16 default 100 = 0x0064: n = 2 -> 0x4B.
    assert_eq!(
        b.ask(&sdo(0x40, 0x2001, 0, [0; 4])),
        resp(0x4B, 0x2001, 0, [0x64, 0x00, 0, 0])
    );
    // VISIBLE_STRING "1.0": three bytes, n = 1 -> 0x47.
    assert_eq!(
        b.ask(&sdo(0x40, 0x1009, 0, [0; 4])),
        resp(0x47, 0x1009, 0, [b'1', b'.', b'0', 0])
    );
    // Sub 0 of a RECORD: UNSIGNED8 4.
    assert_eq!(
        b.ask(&sdo(0x40, 0x1018, 0, [0; 4])),
        resp(0x4F, 0x1018, 0, [4, 0, 0, 0])
    );
    // BOOLEAN entry: one byte.
    b.app.store.set(0x3000, 1, &[1]).unwrap();
    assert_eq!(
        b.ask(&sdo(0x40, 0x3000, 1, [0; 4])),
        resp(0x4F, 0x3000, 1, [1, 0, 0, 0])
    );
}

#[test]
fn full_frame_golden_bytes() {
    let mut b = Bench::new();
    // Request: mailbox length 10, address 0, channel/prio 0, type 3 with counter 1.
    let request = frame(1, &sdo(0x40, 0x1018, 2, [0; 4]));
    assert_eq!(
        &request[..16],
        &[0x0A, 0x00, 0x00, 0x00, 0x00, 0x13, 0x00, 0x20, 0x40, 0x18, 0x10, 0x02, 0, 0, 0, 0]
    );
    // Reply: length 10, type 3, the slave's first counter 1; product code 0x00001754.
    assert_eq!(
        b.raw(&request).unwrap(),
        [
            0x0A, 0x00, 0x00, 0x00, 0x00, 0x13, 0x00, 0x30, 0x43, 0x18, 0x10, 0x02, 0x54, 0x17,
            0x00, 0x00
        ]
    );
}

// ---------------------------------------------------------------- expedited download

#[test]
fn expedited_download_and_read_back() {
    let mut b = Bench::new();
    // 0x2F: download request, expedited, size indicated, n = 3 (1 byte).
    assert_eq!(
        b.ask(&sdo(0x2F, 0x2000, 0, [0xAB, 0, 0, 0])),
        resp(0x60, 0x2000, 0, [0; 4])
    );
    assert_eq!(b.app.store.get(0x2000, 0), Some(&[0xAB][..]));
    // 0x23: 4 bytes.
    assert_eq!(
        b.ask(&sdo(0x23, 0x2002, 0, [0x78, 0x56, 0x34, 0x12])),
        resp(0x60, 0x2002, 0, [0; 4])
    );
    assert_eq!(
        b.ask(&sdo(0x40, 0x2002, 0, [0; 4])),
        resp(0x43, 0x2002, 0, [0x78, 0x56, 0x34, 0x12])
    );
    // 0x2B: 2 bytes, signed value -100 = 0xFF9C in range -100..=100.
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2003, 0, [0x9C, 0xFF, 0, 0])),
        resp(0x60, 0x2003, 0, [0; 4])
    );
}

#[test]
fn expedited_download_without_size_uses_entry_size() {
    let mut b = Bench::new();
    // 0x22: expedited, size not indicated: the entry's size (1 byte) is taken.
    assert_eq!(
        b.ask(&sdo(0x22, 0x2000, 0, [0x11, 0x22, 0x33, 0x44])),
        resp(0x60, 0x2000, 0, [0; 4])
    );
    assert_eq!(b.app.store.get(0x2000, 0), Some(&[0x11][..]));
    // A fixed 4-byte entry takes all four.
    assert_eq!(
        b.ask(&sdo(0x22, 0x2002, 0, [1, 2, 3, 4])),
        resp(0x60, 0x2002, 0, [0; 4])
    );
}

#[test]
fn download_length_errors() {
    let mut b = Bench::new();
    // 2 bytes (0x2B) into UNSIGNED8: too long, 0x06070012.
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2000, 0, [1, 0, 0, 0])),
        abort(0x2000, 0, A::LengthTooHigh)
    );
    // 1 byte (0x2F) into UNSIGNED32: too short, 0x06070013.
    assert_eq!(
        b.ask(&sdo(0x2F, 0x2002, 0, [1, 0, 0, 0])),
        abort(0x2002, 0, A::LengthTooLow)
    );
    // 3 bytes (0x27) into UNSIGNED16.
    assert_eq!(
        b.ask(&sdo(0x27, 0x2001, 0, [1, 0, 0, 0])),
        abort(0x2001, 0, A::LengthTooHigh)
    );
    // Normal download declaring 5 bytes for UNSIGNED32.
    let mut req = sdo(0x21, 0x2002, 0, [5, 0, 0, 0]);
    req.extend_from_slice(&[1, 2, 3, 4, 5]);
    assert_eq!(b.ask(&req), abort(0x2002, 0, A::LengthTooHigh));
    // A 201-byte download into the 200-byte OCTET_STRING.
    let mut req = sdo(0x21, 0x2006, 0, [201, 0, 0, 0]);
    req.extend_from_slice(&[0; 20]);
    assert_eq!(b.ask(&req), abort(0x2006, 0, A::LengthTooHigh));
    assert!(b.app.writes.is_empty());
}

#[test]
fn value_range_errors() {
    let mut b = Bench::new();
    // 0x2001 UNSIGNED16, min 10, max 1000.
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2001, 0, [0xE9, 0x03, 0, 0])),
        abort(0x2001, 0, A::ValueTooHigh)
    ); // 1001
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2001, 0, [0x09, 0x00, 0, 0])),
        abort(0x2001, 0, A::ValueTooLow)
    ); // 9
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2001, 0, [0xE8, 0x03, 0, 0])),
        resp(0x60, 0x2001, 0, [0; 4])
    ); // 1000
       // 0x2003 INTEGER16 -100..=100: -101 = 0xFF9B, 101 = 0x0065.
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2003, 0, [0x9B, 0xFF, 0, 0])),
        abort(0x2003, 0, A::ValueTooLow)
    );
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2003, 0, [0x65, 0x00, 0, 0])),
        abort(0x2003, 0, A::ValueTooHigh)
    );
    // BOOLEAN 2 and BIT3 8 do not fit their bits: 0x06090030.
    assert_eq!(
        b.ask(&sdo(0x2F, 0x3000, 1, [2, 0, 0, 0])),
        abort(0x3000, 1, A::ValueRangeExceeded)
    );
    assert_eq!(
        b.ask(&sdo(0x2F, 0x3000, 2, [8, 0, 0, 0])),
        abort(0x3000, 2, A::ValueRangeExceeded)
    );
    assert_eq!(
        b.ask(&sdo(0x2F, 0x3000, 2, [7, 0, 0, 0])),
        resp(0x60, 0x3000, 2, [0; 4])
    );
}

// ---------------------------------------------------------------- access

#[test]
fn missing_objects_and_subindices() {
    let mut b = Bench::new();
    assert_eq!(
        b.ask(&sdo(0x40, 0x5000, 0, [0; 4])),
        abort(0x5000, 0, A::ObjectDoesNotExist)
    );
    assert_eq!(
        b.ask(&sdo(0x40, 0x1018, 5, [0; 4])),
        abort(0x1018, 5, A::SubindexDoesNotExist)
    );
    assert_eq!(
        b.ask(&sdo(0x2F, 0x5000, 0, [0; 4])),
        abort(0x5000, 0, A::ObjectDoesNotExist)
    );
    assert_eq!(
        b.ask(&sdo(0x2F, 0x2000, 1, [0; 4])),
        abort(0x2000, 1, A::SubindexDoesNotExist)
    );
}

#[test]
fn read_only_write_only() {
    let mut b = Bench::new();
    assert_eq!(
        b.ask(&sdo(0x23, 0x1000, 0, [0; 4])),
        abort(0x1000, 0, A::WriteOfReadOnly)
    );
    assert_eq!(
        b.ask(&sdo(0x40, 0x2004, 0, [0; 4])),
        abort(0x2004, 0, A::ReadOfWriteOnly)
    );
    assert_eq!(
        b.ask(&sdo(0x23, 0x2004, 0, [1, 2, 3, 4])),
        resp(0x60, 0x2004, 0, [0; 4])
    );
}

#[test]
fn state_dependent_access() {
    let mut b = Bench::new();
    // 0x2005 is writable in PREOP only.
    b.state = AlState::SafeOp;
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2005, 0, [1, 0, 0, 0])),
        abort(0x2005, 0, A::DeviceState)
    );
    b.state = AlState::Op;
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2005, 0, [1, 0, 0, 0])),
        abort(0x2005, 0, A::DeviceState)
    );
    assert_eq!(
        b.ask(&sdo(0x40, 0x2005, 0, [0; 4])),
        resp(0x4B, 0x2005, 0, [0, 0, 0, 0])
    );
    b.state = AlState::PreOp;
    assert_eq!(
        b.ask(&sdo(0x2B, 0x2005, 0, [1, 0, 0, 0])),
        resp(0x60, 0x2005, 0, [0; 4])
    );
}

#[test]
fn rx_mapped_object_blocked_in_op() {
    let mut b = Bench::new();
    b.app.ao_mapped = true;
    b.state = AlState::Op;
    assert_eq!(
        b.ask(&sdo(0x2B, 0x6411, 1, [0x34, 0x12, 0, 0])),
        abort(0x6411, 1, A::MappedToRxPdo)
    );
    b.state = AlState::SafeOp;
    assert_eq!(
        b.ask(&sdo(0x2B, 0x6411, 1, [0x34, 0x12, 0, 0])),
        resp(0x60, 0x6411, 1, [0; 4])
    );
    b.app.ao_mapped = false;
    b.state = AlState::Op;
    assert_eq!(
        b.ask(&sdo(0x2B, 0x6411, 2, [0x34, 0x12, 0, 0])),
        resp(0x60, 0x6411, 2, [0; 4])
    );
}

#[test]
fn application_veto() {
    let mut b = Bench::new();
    b.app.veto = Some((0x2002, 0, A::LocalControl));
    assert_eq!(
        b.ask(&sdo(0x23, 0x2002, 0, [1, 2, 3, 4])),
        abort(0x2002, 0, A::LocalControl)
    );
    assert_eq!(b.app.store.get(0x2002, 0), Some(&[0, 0, 0, 0][..]));
}

#[test]
fn unknown_command_specifier() {
    let mut b = Bench::new();
    // ccs 5 (0xA0), 6 (0xC0), 7 (0xE0) do not exist in CoE.
    for command in [0xA0, 0xC0, 0xE0] {
        assert_eq!(
            b.ask(&sdo(command, 0x1000, 0, [0; 4])),
            abort(0x1000, 0, A::InvalidCommandSpecifier)
        );
    }
}

#[test]
fn reserved_command_bits_are_refused() {
    let mut b = Bench::new();
    // Bits an initiate command leaves reserved must be 0 (ETG.1000.6 5.6.2); the server
    // answers 0x05040001 instead of guessing: an upload request with size bits (0x41), a
    // download neither expedited nor with a size (0x20), an expedited download without
    // size but with n (0x26), a normal download with n (0x25).
    for command in [0x41u8, 0x20, 0x26, 0x25] {
        assert_eq!(
            b.ask(&sdo(command, 0x2002, 0, [1, 2, 3, 4])),
            abort(0x2002, 0, A::InvalidCommandSpecifier),
            "command {command:#04X}"
        );
    }
    assert!(b.app.writes.is_empty());
}

#[test]
fn expedited_download_without_size_into_a_u64_is_length_mismatch() {
    use coe_core::od::{Access, DataType, EntryDesc, ObjectDesc, ObjectDictionary, OdStore};
    use coe_core::sdo_server::SdoServer;
    static OD64: ObjectDictionary = ObjectDictionary::new(&[ObjectDesc::var(
        0x2000,
        "U64",
        &[EntryDesc::new(0, "U64", DataType::Unsigned64, Access::RW)],
    )]);
    let mut app = OdStore::<64>::new(OD64).unwrap();
    let mut server: SdoServer<64, 64, 1> = SdoServer::new();
    let mut reply = [0u8; 64];
    // 0x22: expedited, size not indicated: 4 bytes cannot fill an 8-byte entry.
    let request = frame(1, &sdo(0x22, 0x2000, 0, [1, 2, 3, 4]));
    let n = server
        .process(&request, AlState::PreOp, &OD64, &mut app, 0, &mut reply)
        .frame_len()
        .expect("a reply");
    assert_eq!(
        check_coe_frame(&reply[..n]),
        abort(0x2000, 0, A::LengthMismatch)
    );
}

#[test]
fn abort_from_master_gets_no_reply() {
    let mut b = Bench::new();
    assert_eq!(b.coe(&sdo(0x80, 0x1000, 0, [0, 0, 0x04, 0x05])), None);
}

// ---------------------------------------------------------------- normal transfers

#[test]
fn normal_download_and_upload() {
    let mut b = Bench::new();
    // 0x21: normal download, size indicated: complete size 10, then the data.
    let data: Vec<u8> = (1..=10).collect();
    let mut req = sdo(0x21, 0x2006, 0, [10, 0, 0, 0]);
    req.extend_from_slice(&data);
    assert_eq!(b.ask(&req), resp(0x60, 0x2006, 0, [0; 4]));
    // Upload: 0x41 normal response, complete size 10 and all data in one frame.
    let mut expected = resp(0x41, 0x2006, 0, [10, 0, 0, 0]);
    expected.extend_from_slice(&data);
    assert_eq!(b.ask(&sdo(0x40, 0x2006, 0, [0; 4])), expected);
    // A normal download of a short string: a VISIBLE_STRING takes any length up to 16.
    let mut req = sdo(0x21, 0x2008, 0, [5, 0, 0, 0]);
    req.extend_from_slice(b"hello");
    assert_eq!(b.ask(&req), resp(0x60, 0x2008, 0, [0; 4]));
    let mut expected = resp(0x41, 0x2008, 0, [5, 0, 0, 0]);
    expected.extend_from_slice(b"hello");
    assert_eq!(b.ask(&sdo(0x40, 0x2008, 0, [0; 4])), expected);
}

#[test]
fn empty_string_uploads_as_normal_with_size_zero() {
    let mut b = Bench::new();
    // 0x2007 DOMAIN holds 0 bytes: no expedited form for 0 bytes -> 0x41, size 0.
    assert_eq!(
        b.ask(&sdo(0x40, 0x2007, 0, [0; 4])),
        resp(0x41, 0x2007, 0, [0, 0, 0, 0])
    );
}

// ---------------------------------------------------------------- segmented upload

#[test]
fn segmented_upload_of_long_string() {
    // 32-byte read mailbox: the initiate response carries 32 - 16 = 16 bytes, each segment
    // 32 - 9 = 23 bytes: 87 = 16 + 23 + 23 + 23 + 2.
    let mut b = Bench::with_mailbox(32);
    let name = LONG_NAME.as_bytes();
    assert_eq!(name.len(), 87);
    let mut expected = resp(0x41, 0x1008, 0, [87, 0, 0, 0]);
    expected.extend_from_slice(&name[..16]);
    assert_eq!(b.ask(&sdo(0x40, 0x1008, 0, [0; 4])), expected);
    // Segment 1: request 0x60 (toggle 0), response 0x00 (toggle 0, more to come).
    let seg_req = |toggle: u8| {
        let mut v = vec![0x00, 0x20, 0x60 | toggle];
        v.extend_from_slice(&[0; 7]);
        v
    };
    let seg_resp = |command: u8, data: &[u8]| {
        let mut v = vec![0x00, 0x30, command];
        v.extend_from_slice(data);
        while v.len() < 10 {
            v.push(0);
        }
        v
    };
    assert_eq!(b.ask(&seg_req(0x00)), seg_resp(0x00, &name[16..39]));
    assert_eq!(b.ask(&seg_req(0x10)), seg_resp(0x10, &name[39..62]));
    assert_eq!(b.ask(&seg_req(0x00)), seg_resp(0x00, &name[62..85]));
    // Last: toggle 1, 2 bytes, 5 unused (bits 1..3 = 5), last bit: 0x10 | 0x0A | 0x01 = 0x1B.
    assert_eq!(b.ask(&seg_req(0x10)), seg_resp(0x1B, &name[85..87]));
    // Nothing in progress any more.
    assert_eq!(
        b.ask(&seg_req(0x00)),
        abort(0, 0, A::InvalidCommandSpecifier)
    );
}

#[test]
fn segmented_upload_with_64_byte_mailbox() {
    let mut b = Bench::new();
    let name = LONG_NAME.as_bytes();
    let mut expected = resp(0x41, 0x1008, 0, [87, 0, 0, 0]);
    expected.extend_from_slice(&name[..48]);
    assert_eq!(b.ask(&sdo(0x40, 0x1008, 0, [0; 4])), expected);
    let mut last = vec![0x00, 0x30, 0x01];
    last.extend_from_slice(&name[48..]);
    let mut req = vec![0x00, 0x20, 0x60];
    req.extend_from_slice(&[0; 7]);
    assert_eq!(b.ask(&req), last);
}

#[test]
fn upload_toggle_error() {
    let mut b = Bench::with_mailbox(32);
    b.ask(&sdo(0x40, 0x1008, 0, [0; 4]));
    // First segment request must have toggle 0.
    let mut req = vec![0x00, 0x20, 0x70];
    req.extend_from_slice(&[0; 7]);
    assert_eq!(b.ask(&req), abort(0x1008, 0, A::ToggleBitNotAlternated));
    // The transfer is gone.
    req[2] = 0x60;
    assert_eq!(b.ask(&req), abort(0, 0, A::InvalidCommandSpecifier));
}

// ---------------------------------------------------------------- segmented download

fn seg(command: u8, data: &[u8]) -> Vec<u8> {
    let mut v = vec![0x00, 0x20, command];
    v.extend_from_slice(data);
    while v.len() < 10 {
        v.push(0);
    }
    v
}

fn seg_ack(toggle: u8) -> Vec<u8> {
    let mut v = vec![0x00, 0x30, 0x20 | toggle];
    v.extend_from_slice(&[0; 7]);
    v
}

#[test]
fn segmented_download() {
    let mut b = Bench::new();
    let data: Vec<u8> = (0..100u8).map(|i| i.wrapping_mul(7)).collect();
    // Initiate 0x21 with complete size 100 and the first 20 bytes.
    let mut req = sdo(0x21, 0x2006, 0, [100, 0, 0, 0]);
    req.extend_from_slice(&data[..20]);
    assert_eq!(b.ask(&req), resp(0x60, 0x2006, 0, [0; 4]));
    assert!(b.app.writes.is_empty());
    // Segment toggle 0, 50 bytes, not last: command 0x00; ack 0x20.
    assert_eq!(b.ask(&seg(0x00, &data[20..70])), seg_ack(0x00));
    // Segment toggle 1, 27 bytes: 0x10; ack 0x30.
    assert_eq!(b.ask(&seg(0x10, &data[70..97])), seg_ack(0x10));
    // Last segment toggle 0, 3 bytes in a 7-byte segment: 4 unused -> 0x08 | 0x01 = 0x09.
    assert_eq!(b.ask(&seg(0x09, &data[97..100])), seg_ack(0x00));
    assert_eq!(b.app.store.get(0x2006, 0), Some(&data[..]));
    assert_eq!(b.app.writes.len(), 1);
}

#[test]
fn segmented_download_toggle_error() {
    let mut b = Bench::new();
    let mut req = sdo(0x21, 0x2006, 0, [30, 0, 0, 0]);
    req.extend_from_slice(&[1; 10]);
    b.ask(&req);
    assert_eq!(
        b.ask(&seg(0x10, &[2; 10])),
        abort(0x2006, 0, A::ToggleBitNotAlternated)
    );
    assert_eq!(
        b.ask(&seg(0x00, &[2; 10])),
        abort(0, 0, A::InvalidCommandSpecifier)
    );
    assert!(b.app.writes.is_empty());
}

#[test]
fn segmented_download_length_errors() {
    let mut b = Bench::new();
    // More data than declared.
    let mut req = sdo(0x21, 0x2006, 0, [30, 0, 0, 0]);
    req.extend_from_slice(&[1; 20]);
    b.ask(&req);
    assert_eq!(
        b.ask(&seg(0x01, &[2; 11])),
        abort(0x2006, 0, A::LengthTooHigh)
    );
    // Less data than declared when the last segment comes.
    b.ask(&req);
    assert_eq!(
        b.ask(&seg(0x01, &[2; 9])),
        abort(0x2006, 0, A::LengthTooLow)
    );
    assert!(b.app.writes.is_empty());
}

#[test]
fn malformed_segments_end_the_transfer() {
    let mut b = Bench::new();
    let mut req = sdo(0x21, 0x2006, 0, [30, 0, 0, 0]);
    req.extend_from_slice(&[1; 10]);
    b.ask(&req);
    // n (unused bytes, 0x04 = 2) only counts in a minimum 7-byte segment; here 10 bytes
    // follow. The abort names the transfer's object and the transfer ends.
    assert_eq!(
        b.ask(&seg(0x04, &[2; 10])),
        abort(0x2006, 0, A::InvalidCommandSpecifier)
    );
    assert_eq!(
        b.ask(&seg(0x00, &[2; 10])),
        abort(0, 0, A::InvalidCommandSpecifier)
    );
    assert!(b.app.writes.is_empty());
    // An upload segment request with reserved bits set (0x61) in a segmented upload.
    let mut b = Bench::with_mailbox(32);
    b.ask(&sdo(0x40, 0x1008, 0, [0; 4]));
    let mut req = vec![0x00, 0x20, 0x61];
    req.extend_from_slice(&[0; 7]);
    assert_eq!(b.ask(&req), abort(0x1008, 0, A::InvalidCommandSpecifier));
    req[2] = 0x60;
    assert_eq!(b.ask(&req), abort(0, 0, A::InvalidCommandSpecifier));
}

#[test]
fn segment_without_transfer() {
    let mut b = Bench::new();
    assert_eq!(
        b.ask(&seg(0x00, &[0; 7])),
        abort(0, 0, A::InvalidCommandSpecifier)
    );
}

#[test]
fn timeout_aborts_on_next_segment() {
    let mut b = Bench::new();
    b.now = 5_000;
    let mut req = sdo(0x21, 0x2006, 0, [30, 0, 0, 0]);
    req.extend_from_slice(&[1; 10]);
    b.ask(&req);
    // 1000 ms is still fine.
    b.now = 6_000;
    assert_eq!(b.ask(&seg(0x00, &[2; 10])), seg_ack(0x00));
    // 1001 ms after the last request: timeout.
    b.now = 7_001;
    assert_eq!(
        b.ask(&seg(0x11, &[3; 10])),
        abort(0x2006, 0, A::SdoProtocolTimeout)
    );
    assert!(b.app.writes.is_empty());
}

#[test]
fn configurable_timeout_and_clock_wrap() {
    let mut b = Bench::new();
    b.server.set_timeout_ms(50);
    b.now = u32::MAX - 10;
    let mut req = sdo(0x21, 0x2006, 0, [30, 0, 0, 0]);
    req.extend_from_slice(&[1; 10]);
    b.ask(&req);
    b.now = 20; // 31 ms later across the wrap.
    assert_eq!(b.ask(&seg(0x00, &[2; 10])), seg_ack(0x00));
    b.now = 71;
    assert_eq!(
        b.ask(&seg(0x11, &[3; 10])),
        abort(0x2006, 0, A::SdoProtocolTimeout)
    );
}

#[test]
fn other_request_kind_aborts_the_transfer() {
    let mut b = Bench::with_mailbox(32);
    // Segmented upload in progress...
    b.ask(&sdo(0x40, 0x1008, 0, [0; 4]));
    // ...a download segment is the wrong kind: the upload ends with 0x05040001.
    assert_eq!(
        b.ask(&seg(0x00, &[0; 7])),
        abort(0x1008, 0, A::InvalidCommandSpecifier)
    );
    let mut req = vec![0x00, 0x20, 0x60];
    req.extend_from_slice(&[0; 7]);
    assert_eq!(b.ask(&req), abort(0, 0, A::InvalidCommandSpecifier));
    // A new initiate simply replaces a transfer in progress.
    b.ask(&sdo(0x40, 0x1008, 0, [0; 4]));
    assert_eq!(
        b.ask(&sdo(0x40, 0x1000, 0, [0; 4])),
        resp(0x43, 0x1000, 0, [0x91, 0x01, 0x0C, 0x00])
    );
    assert_eq!(b.ask(&req), abort(0, 0, A::InvalidCommandSpecifier));
}

#[test]
fn master_abort_ends_transfer() {
    let mut b = Bench::with_mailbox(32);
    b.ask(&sdo(0x40, 0x1008, 0, [0; 4]));
    assert_eq!(b.coe(&sdo(0x80, 0x1008, 0, [0, 0, 0, 0x08])), None);
    let mut req = vec![0x00, 0x20, 0x60];
    req.extend_from_slice(&[0; 7]);
    assert_eq!(b.ask(&req), abort(0, 0, A::InvalidCommandSpecifier));
}

#[test]
fn reply_never_exceeds_the_mailbox() {
    for mbx in [16usize, 17, 20, 31, 32, 63, 64] {
        let mut b = Bench::with_mailbox(mbx);
        let reply = b.ask(&sdo(0x40, 0x1008, 0, [0; 4]));
        assert!(reply.len() + 6 <= mbx);
        let mut total = reply.len() - 10;
        let mut toggle = 0u8;
        loop {
            let mut req = vec![0x00, 0x20, 0x60 | toggle];
            req.extend_from_slice(&[0; 7]);
            let r = b.ask(&req);
            assert!(r.len() + 6 <= mbx, "mailbox {mbx}");
            assert_eq!(r[2] & 0x10, toggle);
            let unused = ((r[2] >> 1) & 7) as usize;
            total += r.len() - 3 - unused;
            toggle ^= 0x10;
            if r[2] & 1 != 0 {
                break;
            }
        }
        assert_eq!(total, 87, "mailbox {mbx}");
    }
}

#[test]
fn transfer_buffer_too_small_is_out_of_memory() {
    use coe_core::sdo_server::{Reply, SdoServer};
    // A server with a 32-byte transfer buffer cannot hold the 87-byte name or a 100-byte
    // segmented download: 0x05040005.
    let mut server: SdoServer<64, 32, 1> = SdoServer::new();
    let mut app = App::new();
    let mut reply = [0u8; 64];
    let mut ask = |server: &mut SdoServer<64, 32, 1>, counter: u8, coe: &[u8]| match server.process(
        &frame(counter, coe),
        AlState::PreOp,
        &OD,
        &mut app,
        0,
        &mut reply,
    ) {
        Reply::Frame(n) => check_coe_frame(&reply[..n]),
        Reply::None => panic!("no reply"),
    };
    assert_eq!(
        ask(&mut server, 1, &sdo(0x40, 0x1008, 0, [0; 4])),
        abort(0x1008, 0, A::OutOfMemory)
    );
    let mut req = sdo(0x21, 0x2006, 0, [100, 0, 0, 0]);
    req.extend_from_slice(&[0; 20]);
    assert_eq!(ask(&mut server, 2, &req), abort(0x2006, 0, A::OutOfMemory));
    // Small values still work.
    assert_eq!(
        ask(&mut server, 3, &sdo(0x40, 0x1000, 0, [0; 4])),
        resp(0x43, 0x1000, 0, [0x91, 0x01, 0x0C, 0x00])
    );
}
