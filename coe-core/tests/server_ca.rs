//! SDO complete access (ETG.1000.6 5.6.2.1.2/5.6.2.4.2, ETG.1020 12.2): the whole object as
//! one image. Command bit 4 set in the initiate request and echoed in the response
//! (upload 0x50 -> 0x5x, download 0x3x -> 0x70).
//!
//! Image rules checked here: sub 0 of an ARRAY/RECORD takes 16 bits (value + pad byte);
//! byte-sized entries start on a byte boundary; BOOLEAN/BITn are packed LSB first.

mod server_common;

use coe_core::esm::AlState;
use coe_core::SdoAbortCode as A;
use server_common::*;

/// 0x3000: sub 0 = 6, Flag BOOL = 1, Code BIT3 = 5, Byte U8 = 0xAB, Word I16 = -2,
/// Status U16 (RO) = 0xBEEF, Dword U32 = 0x11223344.
fn mixed_bench() -> Bench {
    let mut b = Bench::new();
    let s = &mut b.app.store;
    s.set(0x3000, 1, &[1]).unwrap();
    s.set(0x3000, 2, &[5]).unwrap();
    s.set(0x3000, 3, &[0xAB]).unwrap();
    s.set(0x3000, 4, &(-2i16).to_le_bytes()).unwrap();
    s.set(0x3000, 6, &0x1122_3344u32.to_le_bytes()).unwrap();
    b
}

/// Image from sub 0: `06 00` | bit 16 Flag, bits 17..19 Code -> byte 2 = 1 | 5 << 1 = 0x0B |
/// byte 3 = 0xAB (the U8 moves to the next byte boundary) | FE FF | EF BE | 44 33 22 11.
const IMAGE_FROM_0: [u8; 12] = [
    0x06, 0x00, 0x0B, 0xAB, 0xFE, 0xFF, 0xEF, 0xBE, 0x44, 0x33, 0x22, 0x11,
];

#[test]
fn upload_from_subindex_0() {
    let mut b = mixed_bench();
    // 0x50: initiate upload with complete access. Reply 0x51: normal, size indicated, CA.
    let mut expected = resp(0x51, 0x3000, 0, [12, 0, 0, 0]);
    expected.extend_from_slice(&IMAGE_FROM_0);
    assert_eq!(b.ask(&sdo(0x50, 0x3000, 0, [0; 4])), expected);
}

#[test]
fn upload_from_subindex_1() {
    let mut b = mixed_bench();
    // Without sub 0 the bits start at 0: byte 0 = 0x0B, then AB, FE FF, EF BE, 44 33 22 11.
    let mut expected = resp(0x51, 0x3000, 1, [10, 0, 0, 0]);
    expected.extend_from_slice(&IMAGE_FROM_0[2..]);
    assert_eq!(b.ask(&sdo(0x50, 0x3000, 1, [0; 4])), expected);
}

#[test]
fn upload_of_a_var_and_a_small_array() {
    let mut b = Bench::new();
    // VAR 0x1000: four bytes, expedited with CA: 0x43 | 0x10 = 0x53.
    assert_eq!(
        b.ask(&sdo(0x50, 0x1000, 0, [0; 4])),
        resp(0x53, 0x1000, 0, [0x91, 0x01, 0x0C, 0x00])
    );
    // ARRAY 0x6401 with 2 x INTEGER16: 02 00 | 34 12 | CD AB.
    b.app.store.set(0x6401, 1, &[0x34, 0x12]).unwrap();
    b.app.store.set(0x6401, 2, &[0xCD, 0xAB]).unwrap();
    let mut expected = resp(0x51, 0x6401, 0, [6, 0, 0, 0]);
    expected.extend_from_slice(&[0x02, 0x00, 0x34, 0x12, 0xCD, 0xAB]);
    assert_eq!(b.ask(&sdo(0x50, 0x6401, 0, [0; 4])), expected);
}

#[test]
fn upload_uses_the_current_subindex_0() {
    let mut b = Bench::new();
    // 0x3001 currently holds 2 of 3 possible items.
    b.app.store.set(0x3001, 1, &[0x01, 0x01]).unwrap();
    b.app.store.set(0x3001, 2, &[0x02, 0x02]).unwrap();
    let mut expected = resp(0x51, 0x3001, 0, [6, 0, 0, 0]);
    expected.extend_from_slice(&[0x02, 0x00, 0x01, 0x01, 0x02, 0x02]);
    assert_eq!(b.ask(&sdo(0x50, 0x3001, 0, [0; 4])), expected);
    // From sub 1: just the two items, 4 bytes: expedited 0x53.
    assert_eq!(
        b.ask(&sdo(0x50, 0x3001, 1, [0; 4])),
        resp(0x53, 0x3001, 1, [0x01, 0x01, 0x02, 0x02])
    );
}

#[test]
fn start_rules_and_variable_length() {
    let mut b = Bench::new();
    // Only sub 0 or 1 may start a complete access: 0x06010000.
    assert_eq!(
        b.ask(&sdo(0x50, 0x3000, 2, [0; 4])),
        abort(0x3000, 2, A::UnsupportedAccess)
    );
    assert_eq!(
        b.ask(&sdo(0x50, 0x1000, 1, [0; 4])),
        abort(0x1000, 1, A::UnsupportedAccess)
    );
    // Strings: 0x06010004.
    assert_eq!(
        b.ask(&sdo(0x50, 0x1008, 0, [0; 4])),
        abort(0x1008, 0, A::CompleteAccessVariableLength)
    );
    assert_eq!(
        b.ask(&sdo(0x50, 0x5000, 0, [0; 4])),
        abort(0x5000, 0, A::ObjectDoesNotExist)
    );
    let mut req = sdo(0x31, 0x2006, 0, [2, 0, 0, 0]);
    req.extend_from_slice(&[0, 0]);
    assert_eq!(
        b.ask(&req),
        abort(0x2006, 0, A::CompleteAccessVariableLength)
    );
    assert_eq!(
        b.ask(&sdo(0x33, 0x3000, 3, [0; 4])),
        abort(0x3000, 3, A::UnsupportedAccess)
    );
}

#[test]
fn download_from_subindex_1() {
    let mut b = Bench::new();
    // 0x31: normal download with CA, 10 bytes (sub 0 is not in the image).
    // Flag 0, Code 3 -> byte 0 = 0b0110 = 0x06; Byte 0x12; Word 0x0102; Status (RO) ignored;
    // Dword 0xA1B2C3D4.
    let image = [0x06, 0x12, 0x02, 0x01, 0xFF, 0xFF, 0xD4, 0xC3, 0xB2, 0xA1];
    let mut req = sdo(0x31, 0x3000, 1, [10, 0, 0, 0]);
    req.extend_from_slice(&image);
    assert_eq!(b.ask(&req), resp(0x70, 0x3000, 1, [0; 4]));
    let s = &b.app.store;
    assert_eq!(s.get(0x3000, 1), Some(&[0][..]));
    assert_eq!(s.get(0x3000, 2), Some(&[3][..]));
    assert_eq!(s.get(0x3000, 3), Some(&[0x12][..]));
    assert_eq!(s.get(0x3000, 4), Some(&[0x02, 0x01][..]));
    assert_eq!(s.get(0x3000, 5), Some(&[0xEF, 0xBE][..]));
    assert_eq!(s.get(0x3000, 6), Some(&[0xD4, 0xC3, 0xB2, 0xA1][..]));
}

#[test]
fn download_from_subindex_0_follows_the_etg1020_sequence() {
    let mut b = Bench::new();
    // 0x3001: new sub 0 = 3, then three UNSIGNED16: 03 00 | 01 00 | 02 00 | 03 00.
    let mut req = sdo(0x31, 0x3001, 0, [8, 0, 0, 0]);
    req.extend_from_slice(&[0x03, 0x00, 0x01, 0x00, 0x02, 0x00, 0x03, 0x00]);
    assert_eq!(b.ask(&req), resp(0x70, 0x3001, 0, [0; 4]));
    // Written as sub 0 = 0, the entries, sub 0 = n.
    let writes: Vec<(u8, Vec<u8>)> = b
        .app
        .writes
        .iter()
        .map(|(_, s, d)| (*s, d.clone()))
        .collect();
    assert_eq!(
        writes,
        [
            (0, vec![0]),
            (1, vec![1, 0]),
            (2, vec![2, 0]),
            (3, vec![3, 0]),
            (0, vec![3])
        ]
    );
    // A shorter list in one expedited CA download: 0x33 = 4 bytes, CA: 01 00 | 0A 00.
    assert_eq!(
        b.ask(&sdo(0x33, 0x3001, 0, [0x01, 0x00, 0x0A, 0x00])),
        resp(0x70, 0x3001, 0, [0; 4])
    );
    assert_eq!(
        b.ask(&sdo(0x50, 0x3001, 0, [0; 4])),
        resp(0x53, 0x3001, 0, [0x01, 0x00, 0x0A, 0x00])
    );
}

#[test]
fn download_length_and_count_errors() {
    let mut b = Bench::new();
    // Sub 0 = 3 needs 8 bytes; 6 is too short, 10 too long.
    let mut req = sdo(0x31, 0x3001, 0, [6, 0, 0, 0]);
    req.extend_from_slice(&[0x03, 0x00, 0x01, 0x00, 0x02, 0x00]);
    assert_eq!(b.ask(&req), abort(0x3001, 0, A::LengthTooLow));
    let mut req = sdo(0x31, 0x3001, 0, [10, 0, 0, 0]);
    req.extend_from_slice(&[0x03, 0x00, 0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(b.ask(&req), abort(0x3001, 0, A::LengthTooHigh));
    // Sub 0 = 4 exceeds the highest subindex 3.
    let mut req = sdo(0x31, 0x3001, 0, [10, 0, 0, 0]);
    req.extend_from_slice(&[0x04, 0x00, 0x01, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(b.ask(&req), abort(0x3001, 0, A::ValueTooHigh));
    assert!(b.app.writes.is_empty());
}

#[test]
fn download_access_per_state() {
    let mut b = Bench::new();
    b.state = AlState::SafeOp;
    // 0x3001 is writable in PREOP only: 0x08000022.
    assert_eq!(
        b.ask(&sdo(0x33, 0x3001, 0, [0x01, 0x00, 0x0A, 0x00])),
        abort(0x3001, 0, A::DeviceState)
    );
    // 0x1018 is read-only everywhere: 0x06010002.
    let mut req = sdo(0x31, 0x1018, 1, [16, 0, 0, 0]);
    req.extend_from_slice(&[0; 16]);
    assert_eq!(b.ask(&req), abort(0x1018, 1, A::WriteOfReadOnly));
    // RxPDO-mapped entries in OP: 0x06010006.
    b.state = AlState::Op;
    b.app.ao_mapped = true;
    assert_eq!(
        b.ask(&sdo(0x33, 0x6411, 1, [0x01, 0x00, 0x02, 0x00])),
        abort(0x6411, 1, A::MappedToRxPdo)
    );
    b.app.ao_mapped = false;
    assert_eq!(
        b.ask(&sdo(0x33, 0x6411, 1, [0x01, 0x00, 0x02, 0x00])),
        resp(0x70, 0x6411, 1, [0; 4])
    );
}

#[test]
fn download_checks_ranges_before_writing() {
    let mut b = Bench::new();
    // BOOLEAN/BIT3 bits cannot exceed their range, so check the veto path instead: a vetoed
    // entry aborts with the application's code.
    b.app.veto = Some((0x3000, 6, A::CannotStore));
    let mut req = sdo(0x31, 0x3000, 1, [10, 0, 0, 0]);
    req.extend_from_slice(&[0; 10]);
    assert_eq!(b.ask(&req), abort(0x3000, 1, A::CannotStore));
}

#[test]
fn segmented_complete_access_upload() {
    // 24-byte mailbox: initiate carries 8 bytes, segments 15: 12 = 8 + 4.
    let mut b = mixed_bench();
    b.mbx = 24;
    let mut expected = resp(0x51, 0x3000, 0, [12, 0, 0, 0]);
    expected.extend_from_slice(&IMAGE_FROM_0[..8]);
    assert_eq!(b.ask(&sdo(0x50, 0x3000, 0, [0; 4])), expected);
    let mut req = vec![0x00, 0x20, 0x60];
    req.extend_from_slice(&[0; 7]);
    // Last segment, 4 bytes, 3 unused: 0x06 | 0x01 = 0x07.
    let mut last = vec![0x00, 0x30, 0x07];
    last.extend_from_slice(&IMAGE_FROM_0[8..]);
    last.extend_from_slice(&[0; 3]);
    assert_eq!(b.ask(&req), last);
}

#[test]
fn segmented_complete_access_download() {
    let mut b = Bench::new();
    // The image after `06 00`: flags, byte, word, status (ignored), dword.
    let image = [0x06, 0x12, 0x02, 0x01, 0xFF, 0xFF, 0xD4, 0xC3, 0xB2, 0xA1];
    // Initiate with 4 of the 12 bytes (sub 0 start: sub 0 of 0x3000 is read-only, so the
    // image keeps the current count 6 and 12 bytes).
    let mut req = sdo(0x31, 0x3000, 0, [12, 0, 0, 0]);
    req.extend_from_slice(&[0x06, 0x00, image[0], image[1]]);
    assert_eq!(b.ask(&req), resp(0x70, 0x3000, 0, [0; 4]));
    let mut seg = vec![0x00, 0x20, 0x01];
    seg.extend_from_slice(&image[2..10]);
    let mut ack = vec![0x00, 0x30, 0x20];
    ack.extend_from_slice(&[0; 7]);
    assert_eq!(b.ask(&seg), ack);
    assert_eq!(b.app.store.get(0x3000, 2), Some(&[3][..]));
    assert_eq!(b.app.store.get(0x3000, 5), Some(&[0xEF, 0xBE][..]));
    assert_eq!(
        b.app.store.get(0x3000, 6),
        Some(&[0xD4, 0xC3, 0xB2, 0xA1][..])
    );
}

#[test]
fn image_larger_than_the_transfer_buffer_is_out_of_memory() {
    // 0x1018 from sub 0 is 2 + 4 * 4 = 18 bytes; this server's transfer buffer holds 8.
    let mut app = App::new();
    let mut server: coe_core::sdo_server::SdoServer<64, 8, 1> = Default::default();
    let mut reply = [0u8; 64];
    let request = frame(1, &sdo(0x50, 0x1018, 0, [0; 4]));
    let n = server
        .process(&request, AlState::PreOp, &OD, &mut app, 0, &mut reply)
        .frame_len()
        .expect("a reply");
    assert_eq!(
        check_coe_frame(&reply[..n]),
        abort(0x1018, 0, A::OutOfMemory)
    );
}
