//! SDO Information service (ETG.1000.6 5.6.3): CoE header `00 80` (service 8), then the
//! SDO Information header: opcode (b0..6) | incomplete (b7), reserved byte, u16 fragments
//! left; then the service data. Opcodes: 1/2 OD list, 3/4 object description, 5/6 entry
//! description, 7 error (u32 abort code).

mod server_common;

use coe_core::mailbox::Emergency;
use coe_core::SdoAbortCode as A;
use server_common::*;

fn info(opcode: u8, body: &[u8]) -> Vec<u8> {
    let mut v = vec![0x00, 0x80, opcode, 0x00, 0x00, 0x00];
    v.extend_from_slice(body);
    v
}

fn info_resp(opcode_flags: u8, fragments_left: u16, body: &[u8]) -> Vec<u8> {
    let mut v = vec![0x00, 0x80, opcode_flags, 0x00];
    v.extend_from_slice(&fragments_left.to_le_bytes());
    v.extend_from_slice(body);
    v
}

fn info_error(code: A) -> Vec<u8> {
    info_resp(0x07, 0, &u32::from(code).to_le_bytes())
}

const ALL: [u16; 19] = [
    0x1000, 0x1008, 0x1009, 0x1018, 0x1A00, 0x1C13, 0x2000, 0x2001, 0x2002, 0x2003, 0x2004, 0x2005,
    0x2006, 0x2007, 0x2008, 0x3000, 0x3001, 0x6401, 0x6411,
];

fn le16(values: &[u16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn od_list_counts() {
    let mut b = Bench::new();
    // List type 0: the lengths of lists 1..5: all 19, RxPDO 1 (0x6411), TxPDO 1 (0x6401),
    // backup 1 (0x2001), settings 1 (0x2002).
    let mut body = vec![0x00, 0x00];
    body.extend_from_slice(&le16(&[19, 1, 1, 1, 1]));
    assert_eq!(b.ask(&info(0x01, &[0x00, 0x00])), info_resp(0x02, 0, &body));
}

#[test]
fn od_list_each_type() {
    let mut b = Bench::new();
    let mut body = vec![0x01, 0x00];
    body.extend_from_slice(&le16(&ALL));
    assert_eq!(b.ask(&info(0x01, &[0x01, 0x00])), info_resp(0x02, 0, &body));
    for (list, index) in [(2u16, 0x6411u16), (3, 0x6401), (4, 0x2001), (5, 0x2002)] {
        let mut body = list.to_le_bytes().to_vec();
        body.extend_from_slice(&index.to_le_bytes());
        assert_eq!(
            b.ask(&info(0x01, &list.to_le_bytes())),
            info_resp(0x02, 0, &body),
            "list type {list}"
        );
    }
    assert_eq!(
        b.ask(&info(0x01, &[0x06, 0x00])),
        info_error(A::UnsupportedAccess)
    );
}

#[test]
fn od_list_in_fragments() {
    // 24-byte mailbox: 24 - 12 = 12 data bytes per fragment; 2 + 38 = 40 bytes = 4 fragments.
    let mut b = Bench::with_mailbox(24);
    let mut stream = vec![0x01, 0x00];
    stream.extend_from_slice(&le16(&ALL));
    assert_eq!(stream.len(), 40);
    // First: opcode 2 with the incomplete bit (0x82), 3 fragments left.
    assert_eq!(
        b.ask(&info(0x01, &[0x01, 0x00])),
        info_resp(0x82, 3, &stream[..12])
    );
    // The rest come without a request, one per free mailbox.
    assert_eq!(
        check_coe_frame(&b.poll().unwrap()),
        info_resp(0x82, 2, &stream[12..24])
    );
    assert_eq!(
        check_coe_frame(&b.poll().unwrap()),
        info_resp(0x82, 1, &stream[24..36])
    );
    assert_eq!(
        check_coe_frame(&b.poll().unwrap()),
        info_resp(0x02, 0, &stream[36..40])
    );
    assert_eq!(b.poll(), None);
}

#[test]
fn new_request_drops_pending_fragments() {
    let mut b = Bench::with_mailbox(24);
    b.server.queue_emergency(Emergency {
        error_code: 0x8700,
        error_register: 0x11,
        data: [0; 5],
    });
    b.ask(&info(0x01, &[0x01, 0x00]));
    assert!(b.server.busy());
    // Fragments wait for the read mailbox.
    assert!(b.server.has_outgoing());
    // A new request: the old response ends, the new one is served. The object description
    // of 0x1000 is 6 + 11 = 17 bytes: 12 in the first fragment (0x84, 1 left), 5 in the last.
    let mut first = vec![0x00, 0x10, 0x07, 0x00, 0x00, 0x07];
    first.extend_from_slice(b"Device");
    assert_eq!(
        b.ask(&info(0x03, &[0x00, 0x10])),
        info_resp(0x84, 1, &first)
    );
    assert_eq!(
        check_coe_frame(&b.poll().unwrap()),
        info_resp(0x04, 0, b" type")
    );
    // Then the queued Emergency.
    let emcy = check_coe_frame(&b.poll().unwrap());
    assert_eq!(emcy, [0x00, 0x10, 0x00, 0x87, 0x11, 0, 0, 0, 0, 0]);
}

#[test]
fn object_descriptions() {
    let mut b = Bench::new();
    // 0x1018 RECORD of type IDENTITY (0x0023), max subindex 4, object code 9.
    let mut body = vec![0x18, 0x10, 0x23, 0x00, 0x04, 0x09];
    body.extend_from_slice(b"Identity");
    assert_eq!(b.ask(&info(0x03, &[0x18, 0x10])), info_resp(0x04, 0, &body));
    // 0x6411 ARRAY of INTEGER16 (0x0003), max subindex 2, object code 8.
    let mut body = vec![0x11, 0x64, 0x03, 0x00, 0x02, 0x08];
    body.extend_from_slice(b"Write analog output 16-bit");
    assert_eq!(b.ask(&info(0x03, &[0x11, 0x64])), info_resp(0x04, 0, &body));
    // 0x1000 VAR of UNSIGNED32, max subindex 0, object code 7.
    let mut body = vec![0x00, 0x10, 0x07, 0x00, 0x00, 0x07];
    body.extend_from_slice(b"Device type");
    assert_eq!(b.ask(&info(0x03, &[0x00, 0x10])), info_resp(0x04, 0, &body));
    // Unknown object: SDO Information error with 0x06020000.
    assert_eq!(
        b.ask(&info(0x03, &[0x00, 0x50])),
        info_error(A::ObjectDoesNotExist)
    );
}

#[test]
fn entry_description_with_all_value_info() {
    let mut b = Bench::new();
    // 0x2001:00, value info 0x78 (unit 0x08, default 0x10, min 0x20, max 0x40).
    // Data type UNSIGNED16 (6), 16 bits, access RW + backup = 0x013F, unit type 0x0026
    // (UNSIGNED16, see wire::sdo_info::UNIT_TYPE_LEN), default 100, min 10, max 1000, name.
    let mut body = vec![
        0x01, 0x20, 0x00, 0x78, // index, subindex, value info
        0x06, 0x00, 0x10, 0x00, 0x3F, 0x01, // data type, bit length, access
        0x26, 0x00, // unit type
        0x64, 0x00, 0x0A, 0x00, 0xE8, 0x03, // default, minimum, maximum
    ];
    body.extend_from_slice(b"U16 ranged");
    assert_eq!(
        b.ask(&info(0x05, &[0x01, 0x20, 0x00, 0x78])),
        info_resp(0x06, 0, &body)
    );
}

#[test]
fn entry_description_without_and_with_partial_value_info() {
    let mut b = Bench::new();
    // 0x6411:01 INTEGER16, access RW + RxPDO = 0x007F, no value info requested.
    let mut body = vec![0x11, 0x64, 0x01, 0x00, 0x03, 0x00, 0x10, 0x00, 0x7F, 0x00];
    body.extend_from_slice(b"AO 1");
    assert_eq!(
        b.ask(&info(0x05, &[0x11, 0x64, 0x01, 0x00])),
        info_resp(0x06, 0, &body)
    );
    // 0x1018:00 asked for everything, has only a default (4): value info 0x10.
    let mut body = vec![
        0x18, 0x10, 0x00, 0x10, 0x05, 0x00, 0x08, 0x00, 0x07, 0x00, 0x04,
    ];
    body.extend_from_slice(b"SubIndex 000");
    assert_eq!(
        b.ask(&info(0x05, &[0x18, 0x10, 0x00, 0x78])),
        info_resp(0x06, 0, &body)
    );
    // 0x6401:02 INTEGER16, RO + TxPDO = 0x0087.
    let mut body = vec![0x01, 0x64, 0x02, 0x00, 0x03, 0x00, 0x10, 0x00, 0x87, 0x00];
    body.extend_from_slice(b"AI 2");
    assert_eq!(
        b.ask(&info(0x05, &[0x01, 0x64, 0x02, 0x00])),
        info_resp(0x06, 0, &body)
    );
}

#[test]
fn entry_description_fragmented_default() {
    // 0x1008 default = the 87-byte name: 10 + 87 + 11 = 108 bytes in 52-byte fragments.
    let mut b = Bench::new();
    let mut stream = vec![0x08, 0x10, 0x00, 0x10, 0x09, 0x00];
    stream.extend_from_slice(&(87u16 * 8).to_le_bytes());
    stream.extend_from_slice(&[0x07, 0x00]);
    stream.extend_from_slice(LONG_NAME.as_bytes());
    stream.extend_from_slice(b"Device name");
    assert_eq!(stream.len(), 108);
    assert_eq!(
        b.ask(&info(0x05, &[0x08, 0x10, 0x00, 0x10])),
        info_resp(0x86, 2, &stream[..52])
    );
    assert_eq!(
        check_coe_frame(&b.poll().unwrap()),
        info_resp(0x86, 1, &stream[52..104])
    );
    assert_eq!(
        check_coe_frame(&b.poll().unwrap()),
        info_resp(0x06, 0, &stream[104..])
    );
}

#[test]
fn entry_description_errors() {
    let mut b = Bench::new();
    assert_eq!(
        b.ask(&info(0x05, &[0x18, 0x10, 0x09, 0x00])),
        info_error(A::SubindexDoesNotExist)
    );
    assert_eq!(
        b.ask(&info(0x05, &[0x00, 0x50, 0x00, 0x00])),
        info_error(A::ObjectDoesNotExist)
    );
}

#[test]
fn unknown_opcode_and_short_requests() {
    let mut b = Bench::new();
    // Opcode 9 (and the response opcodes sent by a confused master) are not requests.
    assert_eq!(
        b.ask(&info(0x09, &[0; 4])),
        info_error(A::InvalidCommandSpecifier)
    );
    assert_eq!(
        b.ask(&info(0x02, &[0; 4])),
        info_error(A::InvalidCommandSpecifier)
    );
    // An OD list request without its list type: mailbox error (type 0, length 4) with
    // service 0x0001 and detail 6 "size too short".
    let c = b.counter + 1;
    let reply = b
        .raw(&frame(c, &[0x00, 0x80, 0x01, 0x00, 0x00, 0x00]))
        .unwrap();
    assert_eq!(&reply[..5], &[0x04, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(reply[5] & 0x0F, 0x00);
    assert_eq!(&reply[6..], &[0x01, 0x00, 0x06, 0x00]);
}
