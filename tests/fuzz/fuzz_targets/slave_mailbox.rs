//! Fuzz target: the firmware's slave application (ESM, mailbox link, SDO server, process
//! data) behind the register-file ESC, driven by a master whose every move comes from the
//! fuzzer: mailbox frames, reads of the reply, repeat requests, AL control values,
//! SyncManager registers, outputs, watchdog expiry, DC settings and time. The first byte's
//! low bit picks the product: `analog-io`, or `analog-io-can` (its objects and the CANopen
//! node's behind the same slave application).
//!
//! The master starts as real masters do (mailbox SyncManagers from the device description,
//! INIT -> PREOP), so the fuzzer begins inside the mailbox. After every move the application
//! serves its IRQ and its background poll, and these must hold: no panic; AL status shows a
//! defined state and an error flag only with a code; every reply the master reads is one
//! well-formed mailbox frame inside the read mailbox.
#![no_main]

use coe_core::wire::{Mailbox, MailboxRepr, MailboxType};
use firmware::fake_esc::FakeEsc;
use firmware::io::analog::outputs::OutputStage;
use firmware::products::analog_io::layout::SYNC_MANAGERS;
use firmware::products::{analog_io, analog_io_can};
use firmware::stacks::ethercat::application::Application;
use firmware::stacks::ethercat::SlaveApp;
use libfuzzer_sys::fuzz_target;

/// The process RAM of the register file: SyncManager buffers live there (an ESC's
/// SyncManagers cannot map its registers).
const PROCESS_RAM: core::ops::Range<usize> = 0x1000..0x2000;

fn serve<A: Application<Stage = OutputStage>>(
    app: &mut SlaveApp<A>,
    esc: &mut FakeEsc,
    stage: &OutputStage,
    now: u64,
) {
    let irq = app.on_pdi_irq(&mut esc.driver(), stage, now);
    let poll = app.poll(&mut esc.driver(), stage, now);
    // The mailbox task, below the PDI task, when either asked for it.
    if [irq, poll]
        .iter()
        .any(|o| o.as_ref().is_ok_and(|o| o.serve_mailbox))
    {
        let _ = app.serve_mailbox(&mut esc.driver(), stage, now);
    }
    let (status, code) = esc.al_status();
    assert!(
        matches!(status & 0x0F, 1 | 2 | 3 | 4 | 8),
        "AL status {status:#06x}"
    );
    assert!(status & 0x10 == 0 || code != 0, "error flag without a code");
}

/// Whether a SyncManager of `start`/`len` lies in the process RAM (the master side of the
/// fake writes there directly; the application's own accesses are bounds-checked by the PDI).
fn inside(start: u16, len: u16) -> bool {
    let start = usize::from(start);
    start >= PROCESS_RAM.start && start + usize::from(len) <= PROCESS_RAM.end
}

/// Whether a master write of `len` bytes at `start` would land in the read mailbox (SM1).
/// The check on every reply is about what the slave wrote there: a master that writes
/// into that memory itself (through an overlapping SyncManager, as the fuzzer can
/// configure) reads its own bytes back, whatever the slave does.
fn into_read_mailbox(esc: &FakeEsc, start: u16, len: u16) -> bool {
    let sm1 = esc.sm(1);
    let (a, b) = (u32::from(start), u32::from(start) + u32::from(len));
    let (c, d) = (
        u32::from(sm1.start),
        u32::from(sm1.start) + u32::from(sm1.length),
    );
    a < d && c < b
}

fuzz_target!(|data: &[u8]| {
    match data.split_first() {
        Some((pick, rest)) if pick & 1 == 1 => run(
            SlaveApp::new(analog_io_can::CONFIG, analog_io_can::application()),
            rest,
        ),
        _ => run(
            SlaveApp::new(analog_io::CONFIG, analog_io::application()),
            data.get(1..).unwrap_or(&[]),
        ),
    }
});

fn run<A: Application<Stage = OutputStage>>(mut app: SlaveApp<A>, data: &[u8]) {
    let mut esc = FakeEsc::new();
    let stage = OutputStage::new();
    let _ = app.start(&mut esc.driver());
    for (n, sm) in SYNC_MANAGERS.iter().enumerate().take(2) {
        esc.master_sm(n as u8, sm.start, sm.len, sm.control, true);
    }
    esc.master_al_control(0x0002);
    let mut now = 0u64;
    serve(&mut app, &mut esc, &stage, now);

    let mut reply = [0u8; 1024];
    let mut rest = data;
    while let [op, tail @ ..] = rest {
        rest = tail;
        let mut take = |n: usize| {
            let (a, b) = rest.split_at(n.min(rest.len()));
            rest = b;
            a
        };
        match op % 10 {
            // A mailbox frame (length byte first).
            0..=2 => {
                let n = usize::from(take(1).first().copied().unwrap_or(0));
                let frame = take(n);
                let sm0 = esc.sm(0);
                if inside(sm0.start, sm0.length) && !into_read_mailbox(&esc, sm0.start, sm0.length)
                {
                    esc.master_write_mailbox(frame);
                }
            }
            // The master reads the reply.
            3 => {
                let sm1 = esc.sm(1);
                if inside(sm1.start, sm1.length) {
                    if let Some(len) = esc.master_read_mailbox_into(&mut reply) {
                        let got = &reply[..len.min(reply.len())];
                        let header = MailboxRepr::parse(&Mailbox::new_unchecked(got))
                            .unwrap_or_else(|e| panic!("reply {got:02X?}: {e:?}"));
                        assert!(header.buffer_len() <= len);
                        // FoE: the application refuses firmware files outside BOOT.
                        assert!(matches!(
                            header.mailbox_type,
                            MailboxType::Coe | MailboxType::Foe | MailboxType::Error
                        ));
                    }
                }
            }
            4 => esc.master_repeat_request(),
            5 => {
                let b = take(2);
                let value = u16::from_le_bytes([
                    b.first().copied().unwrap_or(0),
                    b.get(1).copied().unwrap_or(0),
                ]);
                esc.master_al_control(value);
            }
            // SyncManager registers, written as masters do (the mailboxes in INIT only) and
            // as the ESC requires: disabled first, then rewritten.
            6 => {
                let b = take(6);
                let get = |i: usize| b.get(i).copied().unwrap_or(0);
                let n = get(0) % 4;
                let start = u16::from_le_bytes([get(1), get(2)]) & 0x1FFF;
                let len = u16::from(get(3)) * 2;
                let in_init = esc.al_status().0 & 0x0F == 1;
                if (n >= 2 || in_init) && inside(start, len) {
                    let old = esc.sm(n);
                    esc.master_sm(n, old.start, old.length, old.control, false);
                    esc.master_sm(n, start, len, get(4), get(5) & 1 != 0);
                }
            }
            7 => {
                let n = usize::from(take(1).first().copied().unwrap_or(0)) % 33;
                let bytes = take(n);
                let sm2 = esc.sm(2);
                if inside(sm2.start, sm2.length) && !into_read_mailbox(&esc, sm2.start, sm2.length)
                {
                    esc.master_write_outputs(bytes);
                }
            }
            8 => {
                let b = take(5);
                let get = |i: usize| b.get(i).copied().unwrap_or(0);
                if get(0) & 0x80 != 0 {
                    esc.expire_watchdog();
                } else {
                    let cycle = u32::from_le_bytes([get(1), get(2), get(3), get(4)]);
                    esc.master_dc(get(0), cycle);
                }
            }
            // Time: up to about 65 ms at once (mailbox timeouts, safety service).
            _ => {
                let b = take(2);
                let step = u64::from(u16::from_le_bytes([
                    b.first().copied().unwrap_or(0),
                    b.get(1).copied().unwrap_or(0),
                ]));
                now += step * 1_000;
            }
        }
        serve(&mut app, &mut esc, &stage, now);
    }
}
