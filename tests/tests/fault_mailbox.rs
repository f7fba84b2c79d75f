//! FAULT CAMPAIGN (issue 14 section 2), mailbox: a cable pulled in the middle of segmented
//! transfers, a flood of requests with replies read late, a storm of repeat requests and a
//! master resending frames it lost. The firmware's slave application on the virtual board,
//! driven by the scripted master's raw mailbox access (`MailboxClient`, `SdoClient`).

mod fault_common;
use fault_common::*;
use firmware::products::analog_io::od::{MODULE_DESCRIPTION, MODULE_DESCRIPTION_INDEX};
use std::path::PathBuf;
use virtual_board::capture_tests;
use virtual_board::models::esc::{cmd, FrameBuilder};
use virtual_board::rig::scripted::{block, state, ScriptedMaster, Sync, STATION};
use virtual_board::rig::sdo_client::{
    expedited_upload, mailbox_counter, request, sdo_request_bytes, SdoError, MAILBOX_TYPE_COE,
};

/// SDO abort: SDO protocol timed out (ETG.1000.6 table 41).
const ABORT_TIMEOUT: u32 = 0x0504_0000;

/// The master in PREOP with its mailbox set up.
fn preop() -> ScriptedMaster {
    let m = master();
    m.configure_mailbox().unwrap();
    m.expect_state(state::PREOP).unwrap();
    m
}

/// Upload `index:sub` expedited and return the value's bytes.
fn upload(m: &ScriptedMaster, index: u16, sub: u8) -> Vec<u8> {
    m.sdo_upload(index, sub)
        .unwrap_or_else(|e| panic!("{index:#06x}:{sub}: {e}"))
}

capture_tests!(
    cable_pulled_during_segmented_transfers,
    cable_pulled_capture_decodes_in_tshark,
    scenario_cable_pulled,
    "fault-cable-segmented"
);

/// The cable is pulled in the middle of a segmented upload (the module description 0x2001)
/// and of a segmented download (0x1A00 by complete access, 7-byte segments): the request
/// reached the slave, its answer did not reach the master. After 2 s (beyond the server's
/// 1 s transfer timeout) the cable is back: the master reads and discards the stale answer
/// (as ethercrab does before a request), its next segment request gets the abort 0x05040000,
/// and the next request works (a new upload, a new download). The module stays in PREOP
/// without error, no Emergency, the outputs at 0 V.
fn scenario_cable_pulled(pcap: &str) -> PathBuf {
    let m = preop();
    let other = &mut |_| {};
    // Upload: the initiate response, then the cable goes with the first segment's answer.
    let first = block(m.sdo().exchange(
        &m,
        &request::initiate_upload(MODULE_DESCRIPTION_INDEX, 0, false),
        other,
    ))
    .unwrap();
    assert_eq!(first[0], 0x41, "normal upload with size");
    assert!(block(m.sdo().mailbox().send(
        &m,
        MAILBOX_TYPE_COE,
        &sdo_request_bytes(&request::upload_segment(false))
    ))
    .unwrap());
    m.pull_cable();
    assert!(
        block(m.sdo().mailbox().read(&m)).is_err(),
        "nothing comes back"
    );
    m.wait(2_000_000_000);
    m.plug_cable();
    assert_eq!(
        m.drain_mailbox(4).unwrap(),
        1,
        "the stale segment, discarded"
    );
    m.take_unexpected();
    // The master asks again for the segment it did not get.
    let r = block(m.sdo().upload_segment(&m, false, other));
    assert_eq!(r.unwrap_err().abort_code(), Some(ABORT_TIMEOUT));
    let up = m
        .sdo_upload_full(MODULE_DESCRIPTION_INDEX, 0, false)
        .unwrap();
    assert_eq!(std::str::from_utf8(&up.data).unwrap(), MODULE_DESCRIPTION);
    assert!(up.segments >= 2);

    // Download: 0x1A00 complete as uploaded, in 7-byte segments; the cable goes after two.
    let image = m.sdo_upload_full(0x1A00, 0, true).unwrap().data;
    let size = image.len() as u32;
    let r = block(m.sdo().exchange(
        &m,
        &request::initiate_download(0x1A00, 0, true, size, &[]),
        other,
    ))
    .unwrap();
    assert_eq!(r[0], 0x70, "initiate download response, complete access");
    block(m.sdo().download_segment(&m, false, false, &image[0..7])).unwrap();
    block(m.sdo().download_segment(&m, true, false, &image[7..14])).unwrap();
    assert!(block(m.sdo().mailbox().send(
        &m,
        MAILBOX_TYPE_COE,
        &sdo_request_bytes(&request::download_segment(false, false, &image[14..21]))
    ))
    .unwrap());
    m.pull_cable();
    m.wait(2_000_000_000);
    m.plug_cable();
    assert_eq!(m.drain_mailbox(4).unwrap(), 1);
    m.take_unexpected();
    let r = block(m.sdo().download_segment(&m, true, false, &image[21..28]));
    assert_eq!(r.unwrap_err().abort_code(), Some(ABORT_TIMEOUT));
    // The next download works, and the mapping is the one uploaded.
    let n = block(m.sdo().download_segmented(&m, 0x1A00, 0, true, &image, 7)).unwrap();
    assert_eq!(n, image.len().div_ceil(7));
    assert_eq!(m.sdo_upload_full(0x1A00, 0, true).unwrap().data, image);

    assert_eq!(al(&m), (state::PREOP, 0));
    assert!(emergencies(&m).is_empty());
    assert_eq!(m.dac(), [0, 0]);
    save_pcap(&m, pcap)
}

/// The cable is pulled in OP (SM-synchronous) in the middle of a segmented upload: the SM
/// watchdog takes the module to SAFEOP + 0x001B with its error values while the master is
/// away. Back, the master discards the stale segment, gets the timeout abort for its next
/// segment request, the Emergency 0x8250 follows once the transfer is over (never in the
/// middle of one), and a new upload works.
#[test]
fn cable_pulled_during_a_segmented_upload_in_op() {
    let m = op_with(
        Sync::SmSync { cycle_ns: CYCLE },
        [Some(0x0400), Some(0x0800)],
    );
    good_cycles(&m, 10, 0x3000, 0x3000);
    let other = &mut |_| {};
    block(m.sdo().exchange(
        &m,
        &request::initiate_upload(MODULE_DESCRIPTION_INDEX, 0, false),
        other,
    ))
    .unwrap();
    assert!(block(m.sdo().mailbox().send(
        &m,
        MAILBOX_TYPE_COE,
        &sdo_request_bytes(&request::upload_segment(false))
    ))
    .unwrap());
    m.pull_cable();
    m.wait(2_000_000_000);
    m.plug_cable();
    m.stop_cyclic();
    assert_eq!(al(&m), (err(state::SAFEOP), al::SM_WATCHDOG));
    assert_eq!(m.dac(), [dac_code(0x0400), dac_code(0x0800)]);
    assert_eq!(m.drain_mailbox(4).unwrap(), 1, "the stale segment");
    assert_eq!(m.take_emergencies(), [], "no Emergency inside the transfer");
    m.take_unexpected();
    let r = block(m.sdo().upload_segment(&m, false, other));
    assert_eq!(r.unwrap_err().abort_code(), Some(ABORT_TIMEOUT));
    let e = emergencies(&m);
    assert_eq!(
        e.iter().map(|e| e.code).collect::<Vec<_>>(),
        [emcy::RPDO_TIMEOUT]
    );
    let up = m
        .sdo_upload_full(MODULE_DESCRIPTION_INDEX, 0, false)
        .unwrap();
    assert_eq!(std::str::from_utf8(&up.data).unwrap(), MODULE_DESCRIPTION);
    recover_to_op(&m, [dac_code(0x0400), dac_code(0x0800)], 0x0100, 0x0100);
}

/// The objects the flood asks for, with their values.
fn flood_objects() -> Vec<(u16, u8, Vec<u8>)> {
    let id = firmware::products::analog_io::identity::IDENTITY;
    vec![
        (
            0x1000,
            0,
            firmware::products::analog_io::od::DEVICE_TYPE
                .to_le_bytes()
                .to_vec(),
        ),
        (0x1018, 1, id.vendor_id.to_le_bytes().to_vec()),
        (0x1018, 2, id.product_code.to_le_bytes().to_vec()),
        (0x1018, 3, id.revision.to_le_bytes().to_vec()),
        (0x1018, 4, id.serial_number.to_le_bytes().to_vec()),
        (0x1C12, 0, vec![1]),
        (0x1C13, 1, 0x1A00u16.to_le_bytes().to_vec()),
        (0x6443, 1, vec![1]),
    ]
}

/// `(index, sub, data)` of an expedited upload response.
fn expedited(frame: &[u8]) -> (u16, u8, Vec<u8>) {
    expedited_upload(frame).unwrap()
}

/// Mailbox flood: the master writes requests as fast as the working counter lets it (a
/// write to a full write mailbox gets working counter 0 and is not taken) and reads the
/// replies late, in bursts. Every accepted request is answered exactly once, in order,
/// with its own value; nothing is lost; refused writes are just that.
#[test]
fn mailbox_flood_with_replies_read_late() {
    let m = preop();
    let objects = flood_objects();
    let mut accepted = Vec::new();
    let mut refused = 0;
    let mut replies = Vec::new();
    let mut k = 0usize;
    for round in 0..40 {
        // A burst of writes, back to back.
        for _ in 0..(1 + round % 5) {
            let (index, sub, _) = &objects[k % objects.len()];
            let [lo, hi] = index.to_le_bytes();
            let payload = sdo_request_bytes(&[0x40, lo, hi, *sub, 0, 0, 0, 0]);
            if block(m.sdo().mailbox().send(&m, MAILBOX_TYPE_COE, &payload)).unwrap() {
                accepted.push(k % objects.len());
                k += 1;
            } else {
                refused += 1;
            }
        }
        // Replies read late: sometimes none, sometimes a few.
        for _ in 0..(round % 3) {
            if let Some(f) = block(m.sdo().mailbox().try_read(&m)).unwrap() {
                replies.push(f);
            }
            m.wait(20_000);
        }
    }
    // Drain what is left.
    for _ in 0..200 {
        match block(m.sdo().mailbox().try_read(&m)).unwrap() {
            Some(f) => replies.push(f),
            None if replies.len() == accepted.len() => break,
            None => m.wait(50_000),
        }
    }
    assert!(
        refused > 10,
        "the flood hit a full mailbox ({refused} refused)"
    );
    assert!(accepted.len() > 20);
    assert_eq!(
        replies.len(),
        accepted.len(),
        "one reply per accepted request"
    );
    for (i, (frame, want)) in replies.iter().zip(&accepted).enumerate() {
        let (index, sub, data) = expedited(frame);
        let (wi, ws, wd) = &objects[*want];
        assert_eq!((index, sub, &data), (*wi, *ws, wd), "reply {i} in order");
    }
    // The counters of the replies run 1..7 without a gap or a repeat.
    let counters: Vec<u8> = replies.iter().map(|f| mailbox_counter(f)).collect();
    for w in counters.windows(2) {
        assert_eq!(w[1], w[0] % 7 + 1, "{counters:?}");
    }
    assert_eq!(al(&m), (state::PREOP, 0));
    assert!(emergencies(&m).is_empty());
}

/// Repeat-request storm: after one reply, 100 repeat requests (SM1 repeat bit toggled, the
/// slave acknowledges each) all return the identical last reply; then the mailbox goes on
/// normally. A master that loses the answer to its read of the reply (the ESC freed the
/// buffer, the data is gone) gets it back with the repeat request.
#[test]
fn repeat_request_storm_returns_the_identical_last_reply() {
    let m = preop();
    let payload = sdo_request_bytes(&[0x40, 0x18, 0x10, 2, 0, 0, 0, 0]);
    assert!(block(m.sdo().mailbox().send(&m, MAILBOX_TYPE_COE, &payload)).unwrap());
    let reply = block(m.sdo().mailbox().read(&m)).unwrap();
    assert_eq!(expedited(&reply).0, 0x1018);
    for i in 0..100 {
        let again =
            block(m.sdo().mailbox().repeat(&m)).unwrap_or_else(|e| panic!("repeat {i}: {e}"));
        assert_eq!(again, reply, "repeat {i}");
    }
    assert!(!block(m.sdo().mailbox().reply_waiting(&m)).unwrap());
    // The answer to the read of a reply is lost: the repeat request brings it back.
    let payload = sdo_request_bytes(&[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]);
    assert!(block(m.sdo().mailbox().send(&m, MAILBOX_TYPE_COE, &payload)).unwrap());
    for _ in 0..100 {
        if block(m.sdo().mailbox().reply_waiting(&m)).unwrap() {
            break;
        }
    }
    m.lose_replies(1);
    let recovered = block(m.sdo().mailbox().try_read(&m))
        .unwrap()
        .expect("recovered by the repeat");
    assert_eq!(
        expedited(&recovered),
        (
            0x1000,
            0,
            firmware::products::analog_io::od::DEVICE_TYPE
                .to_le_bytes()
                .to_vec()
        )
    );
    assert_eq!(m.net_stats().lost_from_slave, 1);
    // The mailbox goes on.
    assert_eq!(
        upload(&m, 0x1018, 1),
        firmware::products::analog_io::identity::IDENTITY
            .vendor_id
            .to_le_bytes()
    );
    assert_eq!(al(&m), (state::PREOP, 0));
}

/// A master resending a frame it lost (same counter): if the first copy reached the slave,
/// the second is dropped as a repeated counter and the master gets one reply; if the first
/// copy was lost on the way, the second is served. Either way: one reply per request, the
/// values right, and an SDO read after it works (the failure users report of other stacks).
#[test]
fn duplicate_writes_with_the_same_counter() {
    let m = preop();
    let frame = m.sdo().mailbox().next_frame(
        MAILBOX_TYPE_COE,
        &sdo_request_bytes(&[0x40, 0x18, 0x10, 2, 0, 0, 0, 0]),
    );
    // The answer to the write is lost: the master does not know whether it was taken.
    m.lose_replies(1);
    assert_eq!(m.write_once(0x1000, &frame), None);
    // It resends the frame unchanged once the mailbox takes it again.
    let mut resent = false;
    for _ in 0..100 {
        m.wait(20_000);
        if let Some(f) = block(m.sdo().mailbox().try_read(&m)).unwrap() {
            assert_eq!(expedited(&f).0, 0x1018);
        }
        if m.write_once(0x1000, &frame) == Some(1) {
            resent = true;
            break;
        }
    }
    assert!(resent);
    m.wait(200_000);
    assert!(
        block(m.sdo().mailbox().try_read(&m)).unwrap().is_none(),
        "the resent copy is dropped: one reply only"
    );
    // The whole frame lost before the slave: the resend is served.
    let frame = m.sdo().mailbox().next_frame(
        MAILBOX_TYPE_COE,
        &sdo_request_bytes(&[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]),
    );
    m.lose_frames(1);
    assert_eq!(m.write_once(0x1000, &frame), None);
    assert_eq!(m.write_once(0x1000, &frame), Some(1));
    let reply = block(m.sdo().mailbox().read(&m)).unwrap();
    assert_eq!(expedited(&reply).0, 0x1000);
    // The scripted master's own SDO client resends lost writes the same way.
    m.lose_replies(1);
    assert_eq!(
        upload(&m, 0x1018, 3),
        firmware::products::analog_io::identity::IDENTITY
            .revision
            .to_le_bytes()
    );
    m.lose_frames(1);
    assert_eq!(
        upload(&m, 0x1018, 2),
        firmware::products::analog_io::identity::IDENTITY
            .product_code
            .to_le_bytes()
    );
    assert!(matches!(
        m.sdo_upload(0x1018, 9),
        Err(SdoError::Abort {
            code: 0x0609_0011,
            ..
        })
    ));
    assert_eq!(al(&m), (state::PREOP, 0));
}

/// SOEM's `ecx_mbxreceive` drops an Emergency it reads and reads SM1 again at once; finding
/// it empty, it takes the frame for lost and toggles the repeat request. When a new request
/// waits in SM0 by then (the slave could not read it while SM1 was full), repeating the
/// dropped frame starts the same race again, and SOEM's SDO Information calls failed that
/// way on a loaded host. The master has moved on to a new request, so the frame it asks for
/// again was one it did not ask for: the waiting request's reply answers the repeat. Here
/// the frame in SM1 is an older reply, read in the same frame as the repeat request (the
/// slave sees both at once, as when it is slower than the master's second read).
#[test]
fn a_repeat_with_a_new_request_waiting_is_answered_by_its_reply() {
    let m = preop();
    let first = sdo_request_bytes(&[0x40, 0x18, 0x10, 2, 0, 0, 0, 0]);
    assert!(block(m.sdo().mailbox().send(&m, MAILBOX_TYPE_COE, &first)).unwrap());
    assert!((0..100).any(|_| block(m.sdo().mailbox().reply_waiting(&m)).unwrap()));
    let next = sdo_request_bytes(&[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]);
    assert!(block(m.sdo().mailbox().send(&m, MAILBOX_TYPE_COE, &next)).unwrap());
    m.wait(500_000);
    let activate = m.read(0x080E, 1).unwrap()[0];
    let request = activate ^ 0x02;
    let frame = FrameBuilder::new()
        .datagram(cmd::FPRD, STATION, 0x1080, &[0; 128])
        .datagram(cmd::FPWR, STATION, 0x080E, &[request]);
    let got = m.transmit(&frame).expect("an answer");
    assert_eq!(got[0].wkc, 1);
    assert_eq!(expedited_upload(&got[0].data).unwrap().0, 0x1018);
    assert!(
        (0..100).any(|_| m.read(0x080F, 1).unwrap()[0] & 0x02 == request & 0x02),
        "the repeat is acknowledged"
    );
    let reply = block(m.sdo().mailbox().read(&m)).unwrap();
    assert_eq!(
        expedited_upload(&reply).unwrap(),
        (
            0x1000,
            0,
            firmware::products::analog_io::od::DEVICE_TYPE
                .to_le_bytes()
                .to_vec()
        ),
        "the waiting request's reply, not the older frame again"
    );
    // Nothing stale or doubled follows: the next exchange gets its own reply.
    assert_eq!(
        upload(&m, 0x1018, 1),
        firmware::products::analog_io::identity::IDENTITY
            .vendor_id
            .to_le_bytes()
    );
    assert!(m.take_unexpected().is_empty());
    assert_eq!(al(&m), (state::PREOP, 0));
}
