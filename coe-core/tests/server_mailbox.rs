//! Mailbox layer (ETG.1000.4 5.6, ETG.1000.6 5.3): header checks and mailbox error replies,
//! counters, duplicates, the repeat backup, Emergencies.
//!
//! Header: u16 length of the data, u16 address, byte 4 channel (b0..5) | priority (b6..7),
//! byte 5 type (b0..3: 0 error, 3 CoE, 4 FoE) | counter (b4..6).
//! Mailbox error reply: type 0, length 4, u16 0x0001 then u16 detail code.

mod server_common;

use coe_core::esm::AlState;
use coe_core::mailbox::Emergency;
use coe_core::sdo_server::{Reply, SdoServer};
use server_common::*;

fn upload_1000() -> Vec<u8> {
    sdo(0x40, 0x1000, 0, [0; 4])
}

fn mailbox_error(counter: u8, detail: u16) -> Vec<u8> {
    let mut v = vec![0x04, 0x00, 0x00, 0x00, 0x00, counter << 4];
    v.extend_from_slice(&[0x01, 0x00]);
    v.extend_from_slice(&detail.to_le_bytes());
    v
}

fn counter_of(reply: &[u8]) -> u8 {
    (reply[5] >> 4) & 7
}

#[test]
fn duplicate_counter_is_dropped() {
    let mut b = Bench::new();
    let request = frame(3, &upload_1000());
    assert!(b.raw(&request).is_some());
    // The same counter again: a retry of a frame already served, no reply.
    assert_eq!(b.raw(&request), None);
    assert_eq!(b.raw(&request), None);
    // The next counter is served.
    assert!(b.raw(&frame(4, &upload_1000())).is_some());
    // Counter 0 means "no counter": never a duplicate.
    assert!(b.raw(&frame(0, &upload_1000())).is_some());
    assert!(b.raw(&frame(0, &upload_1000())).is_some());
}

#[test]
fn own_counter_runs_1_to_7_and_wraps_to_1() {
    let mut b = Bench::new();
    let counters: Vec<u8> = (0..9)
        .map(|_| {
            let c = b.counter % 7 + 1;
            b.counter = c;
            counter_of(&b.raw(&frame(c, &upload_1000())).unwrap())
        })
        .collect();
    assert_eq!(counters, [1, 2, 3, 4, 5, 6, 7, 1, 2]);
}

#[test]
fn repeat_sends_the_same_frame_again() {
    let mut b = Bench::new();
    let first = b.raw(&frame(1, &upload_1000())).unwrap();
    let mut again = [0u8; 64];
    assert_eq!(b.server.repeat(&mut again), Reply::Frame(first.len()));
    assert_eq!(&again[..first.len()], &first[..]);
    assert_eq!(b.server.mailbox().last_frame(), &first[..]);
    // A buffer too small for it: nothing.
    let mut tiny = [0u8; 8];
    assert_eq!(b.server.repeat(&mut tiny), Reply::None);
}

#[test]
fn repeat_before_any_frame_is_nothing() {
    let server: SdoServer = SdoServer::new();
    let mut reply = [0u8; 64];
    assert_eq!(server.repeat(&mut reply), Reply::None);
}

#[test]
fn init_to_preop_resets_counters() {
    let mut b = Bench::new();
    b.raw(&frame(5, &upload_1000())).unwrap();
    b.raw(&frame(6, &upload_1000())).unwrap();
    b.server.on_state_change(AlState::PreOp, AlState::Init);
    b.server.on_state_change(AlState::Init, AlState::PreOp);
    // Counter 6 again is a new conversation, and the slave starts at 1 again.
    let reply = b.raw(&frame(6, &upload_1000())).unwrap();
    assert_eq!(counter_of(&reply), 1);
    assert!(b.server.mailbox().last_frame() == &reply[..]);
}

#[test]
fn length_beyond_buffer_is_invalid_size() {
    let mut b = Bench::new();
    // Length 100 in a 64-byte mailbox.
    let mut request = frame(1, &upload_1000());
    request[0] = 100;
    assert_eq!(b.raw(&request).unwrap(), mailbox_error(1, 0x0008));
}

#[test]
fn unsupported_protocol() {
    let mut b = Bench::new();
    // Type 4 (FoE) and 5 (SoE), 1 (AoE): not offered.
    for (i, t) in [4u8, 5, 1, 15].into_iter().enumerate() {
        let mut request = frame(1 + i as u8, &upload_1000());
        request[5] = (request[5] & 0xF0) | t;
        assert_eq!(b.raw(&request).unwrap(), mailbox_error(1 + i as u8, 0x0002));
    }
}

#[test]
fn too_short_frames() {
    let mut b = Bench::new();
    // Less than a mailbox header.
    assert_eq!(
        b.raw(&[0x0A, 0x00, 0x00]).unwrap(),
        mailbox_error(1, 0x0006)
    );
    // A CoE frame of 1 byte (no CoE header).
    assert_eq!(b.raw(&frame(1, &[0x00])).unwrap(), mailbox_error(2, 0x0006));
    // An SDO request of 6 bytes.
    assert_eq!(
        b.raw(&frame(2, &[0x00, 0x20, 0x40, 0x00, 0x10, 0x00]))
            .unwrap(),
        mailbox_error(3, 0x0006)
    );
}

#[test]
fn unsupported_coe_services() {
    let mut b = Bench::new();
    // Emergency (1), SDO response (3), TxPDO (4), RxPDO (5), remote requests (6, 7):
    // "service not supported" (4). Service 0 and 9..15: "invalid header" (5).
    let mut counter = 0;
    for (service, detail) in [
        (1u8, 4u16),
        (3, 4),
        (4, 4),
        (5, 4),
        (6, 4),
        (7, 4),
        (0, 5),
        (9, 5),
        (15, 5),
    ] {
        counter = counter % 7 + 1;
        let reply = b.raw(&frame(
            counter,
            &[0x00, service << 4, 0, 0, 0, 0, 0, 0, 0, 0],
        ));
        let expected_counter = b.server.mailbox().last_frame()[5] >> 4;
        assert_eq!(
            reply.unwrap(),
            mailbox_error(expected_counter, detail),
            "service {service}"
        );
    }
}

#[test]
fn reply_buffer_too_small_gives_nothing() {
    let mut b = Bench::with_mailbox(12);
    assert_eq!(b.raw(&frame(1, &upload_1000())), None);
    // A mailbox error still fits 10 bytes.
    let mut request = frame(2, &upload_1000());
    request[5] = 0x24; // type 4
    assert_eq!(b.raw(&request).unwrap(), mailbox_error(1, 0x0002));
}

#[test]
fn emergency_frame() {
    let mut b = Bench::new();
    assert_eq!(b.poll(), None);
    assert!(!b.server.has_outgoing());
    b.server.queue_emergency(Emergency {
        error_code: 0x8700,
        error_register: 0x11,
        data: [1, 2, 3, 4, 5],
    });
    assert!(b.server.has_outgoing());
    // Length 10, type CoE, counter 1; CoE header service 1 (0x1000 -> 00 10);
    // error code 0x8700, error register 0x11, 5 data bytes.
    assert_eq!(
        b.poll().unwrap(),
        [0x0A, 0x00, 0x00, 0x00, 0x00, 0x13, 0x00, 0x10, 0x00, 0x87, 0x11, 1, 2, 3, 4, 5]
    );
    assert_eq!(b.poll(), None);
}

#[test]
fn emergency_queue_keeps_the_newest() {
    let mut b = Bench::new();
    for code in 1..=6u16 {
        b.server.queue_emergency(Emergency {
            error_code: code,
            error_register: 0,
            data: [0; 5],
        });
    }
    assert_eq!(b.server.mailbox().pending_emergencies(), 4);
    assert_eq!(b.server.mailbox().dropped_emergencies(), 2);
    let codes: Vec<u8> = std::iter::from_fn(|| b.poll()).map(|f| f[8]).collect();
    assert_eq!(codes, [3, 4, 5, 6]);
}

#[test]
fn no_emergency_during_a_segmented_transfer() {
    let mut b = Bench::with_mailbox(32);
    b.ask(&sdo(0x40, 0x1008, 0, [0; 4]));
    b.server.queue_emergency(Emergency::default());
    assert!(!b.server.has_outgoing());
    assert_eq!(b.poll(), None);
    // Finish the upload: 87 = 16 + 23 * 3 + 2.
    let mut toggle = 0;
    loop {
        let mut req = vec![0x00, 0x20, 0x60 | toggle];
        req.extend_from_slice(&[0; 7]);
        let r = b.ask(&req);
        toggle ^= 0x10;
        if r[2] & 1 != 0 {
            break;
        }
    }
    assert!(b.server.has_outgoing());
    assert!(b.poll().is_some());
    assert!(!b.server.has_outgoing());
}
