//! FAULT CAMPAIGN (issue 14 section 2), ESM and configuration: state cycling in random
//! order with replies and segmented transfers pending, wrong SyncManager configurations,
//! wrong PDO mappings and assignments, illegal AL control values. The firmware's slave
//! application on the virtual board, driven by the scripted master.

mod fault_common;
use fault_common::*;
use firmware::products::analog_io::od::MODULE_DESCRIPTION_INDEX;
use virtual_board::rig::scripted::{block, state, AlStatus, ScriptedMaster, Sync};
use virtual_board::rig::sdo_client::{expedited_upload, request, sdo_request_bytes, SdoError};

const SM_SYNC: Sync = Sync::SmSync { cycle_ns: CYCLE };

/// The transitions a master may request (ETG.1000.6 6.4.1; hardware-facts 1.7), same-state
/// requests aside: I->P, P->S, S->O, O->S, P->I, S->I, O->I, S->P, O->P, I->B, B->I.
fn allowed(from: u8, to: u8) -> bool {
    use state::*;
    matches!(
        (from, to),
        (INIT, PREOP)
            | (PREOP, SAFEOP)
            | (SAFEOP, OP)
            | (OP, SAFEOP)
            | (PREOP, INIT)
            | (SAFEOP, INIT)
            | (OP, INIT)
            | (SAFEOP, PREOP)
            | (OP, PREOP)
            | (INIT, BOOT)
            | (BOOT, INIT)
    )
}

/// Whether the module accepts BOOT: its SII has a bootstrap mailbox.
fn boot_supported(m: &ScriptedMaster) -> bool {
    m.slave_info().unwrap().bootstrap_mailbox != [0; 4]
}

/// The read mailbox is empty and stays so for a while.
fn assert_read_mailbox_empty(m: &ScriptedMaster, what: &str) {
    for _ in 0..20 {
        assert!(
            !block(m.sdo().mailbox().reply_waiting(m)).unwrap(),
            "{what}: the read mailbox holds a frame"
        );
    }
}

/// What the state cycling's master has left in the mailbox.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pending {
    /// Nothing.
    None,
    /// An expedited upload of this object, its reply not read.
    Reply(u16, u8),
    /// A segmented upload of 0x2001 with this next toggle.
    Transfer(bool),
}

/// State cycling: 1000 AL control requests in random order (INIT, PREOP, SAFEOP, OP, BOOT,
/// and an undefined state), the master preparing each step as masters do (mailbox
/// SyncManagers before INIT -> PREOP, process data before PREOP -> SAFEOP, outputs in OP),
/// with replies left unread and segmented uploads left open before many of the changes.
/// Every allowed change succeeds, every forbidden one is refused with its code (0x0011,
/// 0x0012 undefined, 0x0013 BOOT without support, 0x0015 BOOT without the bootstrap
/// mailbox) and the acknowledge clears it; after
/// every INIT -> PREOP the read mailbox is empty (nothing from before INIT comes out, a
/// transfer from before INIT is gone); a reply read later always answers this session's
/// request; the DAC holds the fault values whenever the module is not in OP.
#[test]
fn state_cycling_in_random_order() {
    const SEED: u64 = 0x14_0002;
    let m = master();
    let boot = boot_supported(&m);
    let mut rng = Rng::new(SEED);
    m.configure_mailbox().unwrap();
    m.expect_state(state::PREOP).unwrap();
    fault_config(&m, [Some(0x0123), Some(0x0456)]).unwrap();
    m.configure_process_data(SM_SYNC).unwrap();
    m.request_state(state::INIT).unwrap();
    let fault = [dac_code(0x0123), dac_code(0x0456)];
    let mut now = state::INIT;
    let mut been_in_op = false;
    let mut pending = Pending::None;
    let mut counts = std::collections::BTreeMap::new();
    let targets = [
        state::INIT,
        state::PREOP,
        state::SAFEOP,
        state::OP,
        state::BOOT,
        0x05,
    ];
    let objects = [(0x1000u16, 0u8), (0x1018, 1), (0x1018, 2), (0x1C12, 0)];
    for step in 0..1000 {
        let target = targets[rng.below(targets.len() as u64) as usize];
        // Leave something in the mailbox (when it runs) before the change.
        if now != state::INIT && pending == Pending::None {
            match rng.below(3) {
                0 => {
                    let (i, s) = objects[rng.below(4) as usize];
                    let [lo, hi] = i.to_le_bytes();
                    let p = sdo_request_bytes(&[0x40, lo, hi, s, 0, 0, 0, 0]);
                    assert!(m.send_mailbox(&p).unwrap(), "step {step}");
                    pending = Pending::Reply(i, s);
                }
                1 => {
                    let r = block(m.sdo().exchange(
                        &m,
                        &request::initiate_upload(MODULE_DESCRIPTION_INDEX, 0, false),
                        &mut |_| {},
                    ))
                    .unwrap();
                    assert_eq!(r[0], 0x41, "step {step}");
                    pending = Pending::Transfer(false);
                }
                _ => {}
            }
        }
        // What the master does before asking.
        if now == state::INIT && target == state::PREOP {
            m.configure_mailbox().unwrap();
        }
        if now == state::PREOP && target == state::SAFEOP {
            m.rewrite_process_data(SM_SYNC).unwrap();
        }
        let before = m.al_status().unwrap();
        assert!(!before.error, "step {step}: error left from before");
        let s: AlStatus = m.request_state(target).unwrap();
        let outcome = if target == 0x05 {
            assert_refused(s, now, al::UNKNOWN_STATE, "undefined state");
            "refused 0x0012"
        } else if target == now {
            assert_eq!(s.pair(), (now, 0), "step {step}: same state");
            "same state"
        } else if target == state::BOOT && now == state::INIT && !boot {
            assert_refused(s, now, al::BOOTSTRAP_NOT_SUPPORTED, "BOOT");
            "refused 0x0013"
        } else if target == state::BOOT && now == state::INIT {
            // BOOT resets into the bootloader only with SM0/SM1 on the bootstrap mailbox,
            // which this master does not set (the update tests do).
            assert_refused(s, now, al::INVALID_MAILBOX_CONFIG_BOOT, "BOOT");
            "refused 0x0015"
        } else if allowed(now, target) {
            assert_eq!(
                s.pair(),
                (target, 0),
                "step {step}: {now:#x} -> {target:#x}"
            );
            "done"
        } else {
            assert_refused(s, now, al::INVALID_STATE_CHANGE, "forbidden change");
            "refused 0x0011"
        };
        *counts.entry((now, target, outcome)).or_insert(0u32) += 1;
        if s.error {
            let ack = m.request_state(now).unwrap();
            assert_eq!(ack.pair(), (now, 0), "step {step}: acknowledged");
        }
        let from = now;
        now = s.state;
        if from == state::OP && now != state::OP {
            been_in_op = true;
        }
        if from == state::INIT && now == state::PREOP {
            // A new mailbox session: nothing from before INIT.
            assert_read_mailbox_empty(&m, &format!("step {step}: after INIT -> PREOP"));
            if let Pending::Transfer(toggle) = pending {
                let r = block(m.sdo().upload_segment(&m, toggle, &mut |_| {}));
                assert!(
                    matches!(r, Err(SdoError::Abort { .. })),
                    "step {step}: a transfer from before INIT continued: {r:?}"
                );
            }
            pending = Pending::None;
        }
        if now == state::INIT || now == state::BOOT {
            pending = Pending::None;
        }
        // Outputs: in OP new ones reach the DAC; elsewhere the fault values (or 0 V
        // before the first OP) hold.
        if now == state::OP {
            let (a, b) = (rng.below(0x7FFF) as i16, rng.below(0x7FFF) as i16);
            m.cycle(&ScriptedMaster::ao_image(a, b)).unwrap();
            m.wait(CYCLE);
            assert_eq!(m.dac(), [dac_code(a), dac_code(b)], "step {step}: OP");
        } else {
            let safe = if been_in_op { fault } else { [0, 0] };
            assert_eq!(m.dac(), safe, "step {step}: {now:#x}");
        }
        // Now and then the master takes what it left.
        if now != state::INIT && now != state::BOOT && rng.below(2) == 0 {
            match pending {
                Pending::Reply(i, s) => {
                    let f = block(m.sdo().mailbox().read(&m)).unwrap();
                    let (ri, rs, _) = expedited_upload(&f).unwrap();
                    assert_eq!((ri, rs), (i, s), "step {step}: the reply to this request");
                }
                Pending::Transfer(toggle) => {
                    let (_, last) = block(m.sdo().upload_segment(&m, toggle, &mut |_| {}))
                        .unwrap_or_else(|e| panic!("step {step}: segment: {e}"));
                    if !last {
                        pending = Pending::Transfer(!toggle);
                        continue;
                    }
                }
                Pending::None => {}
            }
            pending = Pending::None;
        }
    }
    for ((from, to, outcome), n) in &counts {
        println!("{from:#04x} -> {to:#04x}: {outcome} x{n}");
    }
    // Every allowed change and every kind of refusal happened.
    for from in [state::INIT, state::PREOP, state::SAFEOP, state::OP] {
        for to in [state::INIT, state::PREOP, state::SAFEOP, state::OP] {
            if allowed(from, to) {
                assert!(counts.contains_key(&(from, to, "done")), "{from} -> {to}");
            }
        }
    }
    for outcome in ["refused 0x0011", "refused 0x0012"] {
        assert!(counts.keys().any(|k| k.2 == outcome), "{outcome}");
    }
    assert_eq!(m.take_emergencies(), []);
}

/// Illegal AL control values: an undefined state (0x0012), BOOT without a bootstrap
/// mailbox (0x0013, or 0x0015 with one in the SII but SM0/SM1 not set to it), forbidden changes (0x0011), a request for a higher state while the
/// error waits for its acknowledge (ignored: the first code stays), a lower state without
/// acknowledge (carried out, the flag stays), an acknowledge without an error (harmless).
/// The acknowledge clears each; no Emergency; the outputs stay at 0 V.
#[test]
fn illegal_al_control_values() {
    let m = master();
    for undefined in [0x05u16, 0x06, 0x07, 0x09, 0x0A, 0x0C, 0x0F] {
        let s = m.write_al_control(undefined).unwrap();
        assert_refused(s, state::INIT, al::UNKNOWN_STATE, "undefined state");
        let s = m
            .write_al_control(u16::from(state::INIT | state::ERROR))
            .unwrap();
        assert_eq!(s.pair(), (state::INIT, 0), "acknowledged");
    }
    let s = m.write_al_control(u16::from(state::BOOT)).unwrap();
    if boot_supported(&m) {
        // Without SM0/SM1 on the bootstrap mailbox (the update tests set them).
        assert_refused(s, state::INIT, al::INVALID_MAILBOX_CONFIG_BOOT, "BOOT");
    } else {
        assert_refused(s, state::INIT, al::BOOTSTRAP_NOT_SUPPORTED, "BOOT");
    }
    m.request_state(state::INIT).unwrap();
    // INIT -> SAFEOP, INIT -> OP: forbidden.
    for to in [state::SAFEOP, state::OP] {
        let s = m.write_al_control(u16::from(to)).unwrap();
        assert_refused(s, state::INIT, al::INVALID_STATE_CHANGE, "forbidden");
        m.request_state(state::INIT).unwrap();
    }
    // Acknowledge without an error: a plain request.
    let s = m
        .write_al_control(u16::from(state::INIT | state::ERROR))
        .unwrap();
    assert_eq!(s.pair(), (state::INIT, 0));
    m.configure_mailbox().unwrap();
    let s = m
        .write_al_control(u16::from(state::PREOP | state::ERROR))
        .unwrap();
    assert_eq!(s.pair(), (state::PREOP, 0));
    // PREOP -> OP and PREOP -> BOOT: forbidden.
    for to in [state::OP, state::BOOT] {
        let s = m.write_al_control(u16::from(to)).unwrap();
        assert_refused(s, state::PREOP, al::INVALID_STATE_CHANGE, "forbidden");
        // While the error waits: a higher state without acknowledge is ignored.
        let s = m.write_al_control(u16::from(state::SAFEOP)).unwrap();
        assert_refused(s, state::PREOP, al::INVALID_STATE_CHANGE, "ignored");
        m.request_state(state::PREOP).unwrap();
    }
    // A lower state without acknowledge is carried out; the flag stays until acknowledged.
    m.write_al_control(0x0F).unwrap();
    let s = m.write_al_control(u16::from(state::INIT)).unwrap();
    assert_refused(s, state::INIT, al::UNKNOWN_STATE, "lower state, flag kept");
    let s = m.request_state(state::INIT).unwrap();
    assert_eq!(s.pair(), (state::INIT, 0));
    assert_eq!(m.dac(), [0, 0]);
    m.configure_mailbox().unwrap();
    m.expect_state(state::PREOP).unwrap();
    assert!(emergencies(&m).is_empty());
}

/// Wrong SyncManager configurations. At INIT -> PREOP: SM0 too short, at the wrong start,
/// in the wrong direction, disabled, SM1 overlapping SM0: refused with 0x0016 (invalid
/// mailbox configuration), the state stays INIT. At PREOP -> SAFEOP: SM2 too short, at the
/// wrong start, in the wrong direction, disabled; SM3 too long, overlapping SM2, in the
/// wrong direction: refused with 0x001D (outputs) / 0x001E (inputs), the state stays PREOP,
/// the outputs at their fault values from the last OP. The acknowledge and the right
/// configuration then work.
#[test]
fn wrong_sync_manager_configuration() {
    let m = master();
    let (sm0, sm1) = (m.sm(0).unwrap(), m.sm(1).unwrap());
    let wrong_mailbox: [(&str, usize, [u8; 8]); 5] = [
        ("SM0 too short", 0, sm0.registers(sm0.len / 2, 1)),
        ("SM0 start", 0, {
            let mut r = sm0.registers(sm0.len, 1);
            r[0] = r[0].wrapping_add(8);
            r
        }),
        ("SM0 direction", 0, {
            let mut r = sm0.registers(sm0.len, 1);
            r[4] = sm1.control;
            r
        }),
        ("SM0 disabled", 0, sm0.registers(sm0.len, 0)),
        ("SM1 overlapping SM0", 1, {
            let mut r = sm1.registers(sm1.len, 1);
            r[0..2].copy_from_slice(&(sm0.start + sm0.len / 2).to_le_bytes());
            r
        }),
    ];
    for (what, n, regs) in wrong_mailbox {
        m.configure_mailbox().unwrap();
        m.write_sm(n, regs).unwrap();
        let s = m.request_state(state::PREOP).unwrap();
        assert_refused(s, state::INIT, al::INVALID_MAILBOX_CONFIG, what);
        let s = m.request_state(state::INIT).unwrap();
        assert_eq!(s.pair(), (state::INIT, 0), "{what}: acknowledged");
        m.write_sm(0, sm0.registers(sm0.len, 1)).unwrap();
        m.write_sm(1, sm1.registers(sm1.len, 1)).unwrap();
    }
    // Through OP once, so the outputs have fault values to hold.
    m.to_op(SM_SYNC, |m| fault_config(m, [Some(0x0321), Some(0x0654)]))
        .unwrap();
    good_cycles(&m, 5, 0x2000, 0x2000);
    m.expect_state(state::PREOP).unwrap();
    let fault = [dac_code(0x0321), dac_code(0x0654)];
    assert_eq!(m.dac(), fault);
    let image = m.image().unwrap();
    let (sm2, sm3) = (m.sm(2).unwrap(), m.sm(3).unwrap());
    let (out, inp) = (image.outputs as u16, image.inputs as u16);
    let shifted = |sm: virtual_board::rig::scripted::SiiSm, len: u16, by: u16| {
        let mut r = sm.registers(len, 1);
        r[0..2].copy_from_slice(&sm.start.wrapping_add(by).to_le_bytes());
        r
    };
    let with_control = |sm: virtual_board::rig::scripted::SiiSm, len: u16, control: u8| {
        let mut r = sm.registers(len, 1);
        r[4] = control;
        r
    };
    let wrong_pd: [(&str, usize, [u8; 8], u16); 7] = [
        (
            "SM2 too short",
            2,
            sm2.registers(out - 1, 1),
            al::INVALID_OUTPUT_CONFIG,
        ),
        (
            "SM2 start",
            2,
            shifted(sm2, out, 8),
            al::INVALID_OUTPUT_CONFIG,
        ),
        (
            "SM2 direction",
            2,
            with_control(sm2, out, sm3.control),
            al::INVALID_OUTPUT_CONFIG,
        ),
        (
            "SM2 disabled",
            2,
            sm2.registers(out, 0),
            al::INVALID_OUTPUT_CONFIG,
        ),
        (
            "SM3 too long",
            3,
            sm3.registers(inp + 2, 1),
            al::INVALID_INPUT_CONFIG,
        ),
        (
            "SM3 overlapping SM2",
            3,
            shifted(sm3, inp, sm2.start.wrapping_sub(sm3.start)),
            al::INVALID_INPUT_CONFIG,
        ),
        (
            "SM3 direction",
            3,
            with_control(sm3, inp, sm2.control & !0x40),
            al::INVALID_INPUT_CONFIG,
        ),
    ];
    for (what, n, regs, code) in wrong_pd {
        m.rewrite_process_data(SM_SYNC).unwrap();
        m.write_sm(n, regs).unwrap();
        let s = m.request_state(state::SAFEOP).unwrap();
        assert_refused(s, state::PREOP, code, what);
        assert_eq!(m.dac(), fault, "{what}: outputs safe");
        let s = m.request_state(state::PREOP).unwrap();
        assert_eq!(s.pair(), (state::PREOP, 0), "{what}: acknowledged");
    }
    m.write_sm(2, sm2.registers(out, 1)).unwrap();
    m.write_sm(3, sm3.registers(inp, 1)).unwrap();
    m.expect_state(state::SAFEOP).unwrap();
    m.expect_state(state::OP).unwrap();
    good_cycles(&m, 5, 0x1111, 0x2222);
    assert_eq!(m.dac(), [dac_code(0x1111), dac_code(0x2222)]);
    assert!(emergencies(&m).is_empty());
}

/// An SDO download to `index:sub` that must be aborted with `code`.
fn refused(m: &ScriptedMaster, index: u16, sub: u8, data: &[u8], code: u32, what: &str) {
    let c = sdo_abort(m.sdo_download(index, sub, data));
    assert_eq!(c, code, "{what}: abort {c:#010x}, expected {code:#010x}");
}

/// Wrong PDO mappings and assignments (ETG.1020 PDO configuration in PREOP): an unknown
/// object, an object not mappable as an output, a wrong (odd) bit length: 0x06040041; an
/// entry while subindex 0 is not 0: 0x06010003; a mapping or assignment longer than the
/// process image: 0x06040042; a TxPDO assigned to SM2: 0x06090030. Each is refused and
/// the previous mapping is kept. A mapping that validates but that the master sizes SM2
/// for wrongly is refused at PREOP -> SAFEOP with 0x001D. A valid odd layout (a 4-bit gap,
/// between the two outputs) works bit-exactly.
#[test]
fn wrong_pdo_mapping_and_assignment() {
    let m = master();
    m.configure_mailbox().unwrap();
    m.expect_state(state::PREOP).unwrap();
    let original = m.sdo_upload_full(0x1600, 0, true).unwrap().data;
    let first_entry = m.sdo_upload(0x1600, 1).unwrap();
    let count = m.sdo_upload(0x1600, 0).unwrap();
    let entry = |i: u16, s: u8, bits: u8| {
        (u32::from(i) << 16 | u32::from(s) << 8 | u32::from(bits)).to_le_bytes()
    };
    let kept = |what: &str| {
        assert_eq!(
            m.sdo_upload_full(0x1600, 0, true).unwrap().data,
            original,
            "{what}: previous mapping kept"
        )
    };
    refused(
        &m,
        0x1600,
        1,
        &entry(0x6411, 2, 16),
        0x0601_0003,
        "entry with sub 0 != 0",
    );
    kept("sub 0 != 0");
    m.sdo_download(0x1600, 0, &[0]).unwrap();
    for (what, e) in [
        ("unknown object", entry(0x5555, 1, 16)),
        ("input object in an RxPDO", entry(0x6401, 1, 16)),
        ("read-only object", entry(0x1000, 0, 32)),
        ("odd bit length", entry(0x6411, 1, 12)),
        ("bit length too short", entry(0x6411, 1, 8)),
    ] {
        refused(&m, 0x1600, 1, &e, 0x0604_0041, what);
        assert_eq!(
            m.sdo_upload(0x1600, 1).unwrap(),
            first_entry,
            "{what}: entry kept"
        );
    }
    m.sdo_download(0x1600, 0, &count).unwrap();
    kept("restored");
    // Too long: 8 UNSIGNED32 gaps in each RxPDO fit one PDO, not both assigned.
    let gap32 = entry(0x0007, 0, 32);
    for pdo in [0x1601u16] {
        m.sdo_download(pdo, 0, &[0]).unwrap();
        for s in 1..=8 {
            m.sdo_download(pdo, s, &gap32).unwrap();
        }
        m.sdo_download(pdo, 0, &[8]).unwrap();
    }
    m.sdo_download(0x1C12, 0, &[0]).unwrap();
    m.sdo_download(0x1C12, 1, &0x1600u16.to_le_bytes()).unwrap();
    m.sdo_download(0x1C12, 2, &0x1601u16.to_le_bytes()).unwrap();
    let before = m.sdo_upload(0x1C12, 0).unwrap();
    refused(&m, 0x1C12, 0, &[2], 0x0604_0042, "assignment too long");
    assert_eq!(m.sdo_upload(0x1C12, 0).unwrap(), before, "assignment kept");
    refused(
        &m,
        0x1C12,
        1,
        &0x1A00u16.to_le_bytes(),
        0x0609_0030,
        "TxPDO in 0x1C12",
    );
    m.sdo_download(0x1C12, 0, &[1]).unwrap();
    kept("after the assignment errors");

    // A valid mapping the master does not size SM2 for: 0x001D at PREOP -> SAFEOP.
    m.configure_process_data(SM_SYNC).unwrap();
    m.sdo_download(0x1600, 0, &[0]).unwrap();
    m.sdo_download(0x1600, 2, &entry(0x0000, 0, 4)).unwrap();
    m.sdo_download(0x1600, 3, &entry(0x6411, 2, 16)).unwrap();
    m.sdo_download(0x1600, 0, &[3]).unwrap();
    let s = m.request_state(state::SAFEOP).unwrap();
    assert_refused(
        s,
        state::PREOP,
        al::INVALID_OUTPUT_CONFIG,
        "SM2 sized for the old mapping",
    );
    m.request_state(state::PREOP).unwrap();
    // Sized right (36 bits: 5 bytes), it works, AO2 at bit offset 20.
    let image = m.configure_process_data(SM_SYNC).unwrap();
    assert_eq!(image.outputs, 5);
    let ao2 = image.layout.output(0x6411, 2).unwrap();
    assert_eq!(ao2.bit_offset, 20);
    m.expect_state(state::SAFEOP).unwrap();
    m.expect_state(state::OP).unwrap();
    let (a, b) = (0x1234i16, 0x2345i16);
    let mut out = [0u8; 5];
    out[0..2].copy_from_slice(&a.to_le_bytes());
    let v = u64::from(b as u16) << 20;
    for (i, byte) in out.iter_mut().enumerate() {
        *byte |= (v >> (8 * i)) as u8;
    }
    for _ in 0..5 {
        m.wait_cycle_slot();
        m.cycle(&out).unwrap();
    }
    m.wait(CYCLE);
    assert_eq!(m.dac(), [dac_code(a), dac_code(b)], "bit-exact unpacking");
    assert_eq!(al(&m), (state::OP, 0));
    assert!(emergencies(&m).is_empty());
    // The mapping cannot change outside PREOP.
    refused(&m, 0x1600, 0, &[0], 0x0800_0022, "mapping in OP");
}
