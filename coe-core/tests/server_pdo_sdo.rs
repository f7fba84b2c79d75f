//! PDO mapping and assignment configured over SDO, the way a master does it (ETG.1020:
//! sub 0 = 0, entries, sub 0 = n), with the mapping logic of `coe_core::pdo` behind the
//! application's `ObjectAccess`. The test device's SM3 image holds 32 bits.

mod server_common;

use coe_core::esm::AlState;
use coe_core::SdoAbortCode as A;
use server_common::*;

#[test]
fn expedited_uploads_as_ethercrab_reads_them() {
    let mut b = Bench::new();
    // 0x1C13:00 as u8, 0x1C13:01 as u16, 0x1A00:00 as u8, 0x1A00:01 as u32: all expedited.
    assert_eq!(
        b.ask(&sdo(0x40, 0x1C13, 0, [0; 4])),
        resp(0x4F, 0x1C13, 0, [1, 0, 0, 0])
    );
    assert_eq!(
        b.ask(&sdo(0x40, 0x1C13, 1, [0; 4])),
        resp(0x4B, 0x1C13, 1, [0x00, 0x1A, 0, 0])
    );
    assert_eq!(
        b.ask(&sdo(0x40, 0x1A00, 0, [0; 4])),
        resp(0x4F, 0x1A00, 0, [1, 0, 0, 0])
    );
    // 0x64010110 = 0x6401:01, 16 bit.
    assert_eq!(
        b.ask(&sdo(0x40, 0x1A00, 1, [0; 4])),
        resp(0x43, 0x1A00, 1, [0x10, 0x01, 0x01, 0x64])
    );
}

#[test]
fn remap_in_preop() {
    let mut b = Bench::new();
    let ok = |i, s| resp(0x60, i, s, [0; 4]);
    // An entry cannot change while sub 0 != 0.
    assert_eq!(
        b.ask(&sdo(0x23, 0x1A00, 2, [0x10, 0x02, 0x01, 0x64])),
        abort(0x1A00, 2, A::SubindexZeroMustBeZero)
    );
    assert_eq!(b.ask(&sdo(0x2F, 0x1A00, 0, [0, 0, 0, 0])), ok(0x1A00, 0));
    assert_eq!(
        b.ask(&sdo(0x23, 0x1A00, 1, [0x10, 0x02, 0x01, 0x64])),
        ok(0x1A00, 1)
    );
    // An output (0x6411:01, RxPDO-mappable only) in a TxPDO: 0x06040041.
    assert_eq!(
        b.ask(&sdo(0x23, 0x1A00, 2, [0x10, 0x01, 0x11, 0x64])),
        abort(0x1A00, 2, A::CannotBeMapped)
    );
    // Wrong bit length for 0x6401:01: 0x06040041.
    assert_eq!(
        b.ask(&sdo(0x23, 0x1A00, 2, [0x08, 0x01, 0x01, 0x64])),
        abort(0x1A00, 2, A::CannotBeMapped)
    );
    assert_eq!(
        b.ask(&sdo(0x23, 0x1A00, 2, [0x10, 0x01, 0x01, 0x64])),
        ok(0x1A00, 2)
    );
    // A third 16-bit entry (a gap of INTEGER16) makes 48 bits > 32: sub 0 = 3 -> 0x06040042.
    assert_eq!(
        b.ask(&sdo(0x23, 0x1A00, 3, [0x10, 0x00, 0x03, 0x00])),
        ok(0x1A00, 3)
    );
    assert_eq!(
        b.ask(&sdo(0x2F, 0x1A00, 0, [3, 0, 0, 0])),
        abort(0x1A00, 0, A::PdoLengthExceeded)
    );
    assert_eq!(b.ask(&sdo(0x2F, 0x1A00, 0, [2, 0, 0, 0])), ok(0x1A00, 0));
    assert_eq!(b.app.txpdo[0].bit_len(), 32);
    // Not in SAFEOP (the entries are RW in PREOP only).
    b.state = AlState::SafeOp;
    assert_eq!(
        b.ask(&sdo(0x2F, 0x1A00, 0, [0, 0, 0, 0])),
        abort(0x1A00, 0, A::DeviceState)
    );
}

#[test]
fn reassign_in_preop() {
    let mut b = Bench::new();
    assert_eq!(
        b.ask(&sdo(0x2B, 0x1C13, 1, [0x00, 0x1A, 0, 0])),
        abort(0x1C13, 1, A::SubindexZeroMustBeZero)
    );
    assert_eq!(
        b.ask(&sdo(0x2F, 0x1C13, 0, [0, 0, 0, 0])),
        resp(0x60, 0x1C13, 0, [0; 4])
    );
    // 0x1A01 does not exist.
    assert_eq!(
        b.ask(&sdo(0x2B, 0x1C13, 1, [0x01, 0x1A, 0, 0])),
        abort(0x1C13, 1, A::ValueRangeExceeded)
    );
    assert_eq!(
        b.ask(&sdo(0x2B, 0x1C13, 1, [0x00, 0x1A, 0, 0])),
        resp(0x60, 0x1C13, 1, [0; 4])
    );
    assert_eq!(
        b.ask(&sdo(0x2F, 0x1C13, 0, [1, 0, 0, 0])),
        resp(0x60, 0x1C13, 0, [0; 4])
    );
}

#[test]
fn complete_access_remap() {
    let mut b = Bench::new();
    // From sub 0: count 2 and two entries: 02 00 | 10 01 01 64 | 10 02 01 64 (10 bytes).
    let mut req = sdo(0x31, 0x1A00, 0, [10, 0, 0, 0]);
    req.extend_from_slice(&[0x02, 0x00, 0x10, 0x01, 0x01, 0x64, 0x10, 0x02, 0x01, 0x64]);
    assert_eq!(b.ask(&req), resp(0x70, 0x1A00, 0, [0; 4]));
    assert_eq!(b.app.txpdo[0].count(), 2);
    let mut expected = resp(0x51, 0x1A00, 0, [10, 0, 0, 0]);
    expected.extend_from_slice(&[0x02, 0x00, 0x10, 0x01, 0x01, 0x64, 0x10, 0x02, 0x01, 0x64]);
    assert_eq!(b.ask(&sdo(0x50, 0x1A00, 0, [0; 4])), expected);
    // From sub 1 the count stays 2, which is not 0: the mapping refuses with 0x06010003.
    let mut req = sdo(0x31, 0x1A00, 1, [8, 0, 0, 0]);
    req.extend_from_slice(&[0x10, 0x02, 0x01, 0x64, 0x10, 0x01, 0x01, 0x64]);
    assert_eq!(b.ask(&req), abort(0x1A00, 1, A::SubindexZeroMustBeZero));
}

#[test]
fn a_refused_complete_access_remap_leaves_the_mapping_as_it_was() {
    let mut b = Bench::new();
    let whole = sdo(0x50, 0x1A00, 0, [0; 4]);
    let before = b.ask(&whole);
    // The second entry, 0x6411:01, is an output: not TxPDO-mappable (0x06040041), refused
    // after sub 0 = 0 and the first entry were written.
    let mut req = sdo(0x31, 0x1A00, 0, [10, 0, 0, 0]);
    req.extend_from_slice(&[0x02, 0x00, 0x10, 0x02, 0x01, 0x64, 0x10, 0x01, 0x11, 0x64]);
    assert_eq!(b.ask(&req), abort(0x1A00, 0, A::CannotBeMapped));
    assert_eq!(b.ask(&whole), before);
    assert_eq!(b.app.txpdo[0].count(), 1);
    // Two inputs and a 16-bit gap do not fit the 32-bit SM3 image: refused at the final
    // sub 0 (0x06040042), after every entry was written.
    let mut req = sdo(0x31, 0x1A00, 0, [14, 0, 0, 0]);
    req.extend_from_slice(&[0x03, 0x00, 0x10, 0x02, 0x01, 0x64, 0x10, 0x01, 0x01, 0x64]);
    req.extend_from_slice(&[0x10, 0x00, 0x03, 0x00]);
    assert_eq!(b.ask(&req), abort(0x1A00, 0, A::PdoLengthExceeded));
    assert_eq!(b.ask(&whole), before);
    assert_eq!(b.app.txpdo[0].count(), 1);
}
