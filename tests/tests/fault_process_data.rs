//! FAULT CAMPAIGN (issue 14 section 2), process data: the master stops (SM watchdog), frames
//! lost or repeated on the way, SYNC0 missing, too fast or jittering. The firmware's slave
//! application on the virtual board, driven by the scripted master; each test asserts the
//! AL state and code, the Emergency, the DAC model's outputs and what the master gets back,
//! and that the outputs hold their fault values until new outputs arrive in OP.

mod fault_common;
use fault_common::*;
use std::path::PathBuf;
use virtual_board::capture_tests;
use virtual_board::models::esc::Sync0Fault;
use virtual_board::rig::scripted::{state, ScriptedMaster, Sync};

const SM_SYNC: Sync = Sync::SmSync { cycle_ns: CYCLE };
const DC: Sync = Sync::Dc {
    cycle_ns: CYCLE as u32,
};

capture_tests!(
    sm_watchdog_in_sm_synchronous_mode,
    sm_watchdog_capture_decodes_in_tshark,
    scenario_sm_watchdog,
    "fault-sm-watchdog"
);

/// SM-synchronous: the master stops sending process data in OP. The ESC's SM watchdog
/// (100 ms default) expires: AO1 goes to its error value (0x6443:01 = 1, 0x6444:01), AO2
/// keeps its output (0x6443:02 = 0), AL status SAFEOP + error 0x001B, an Emergency 0x8250
/// (RPDO timeout) with the communication bit in 0x1001; the inputs stay valid in SAFEOP.
/// After the acknowledge the fault values stay until new outputs arrive in OP, and the
/// Emergency "no error" reports the error register cleared; 0x1003 keeps the 0x8250 until
/// the master clears it.
fn scenario_sm_watchdog(pcap: &str) -> PathBuf {
    let m = op_with(SM_SYNC, [Some(0x2000), None]);
    good_cycles(&m, 20, 0x4000, 0x7000);
    m.wait(CYCLE);
    assert_eq!(m.dac(), [0x8000, 0xE000]);
    assert_eq!(al(&m), (state::OP, 0));
    assert!(emergencies(&m).is_empty());

    // The master stops; 99 ms later nothing has happened yet, at 101 ms it has.
    m.stop_cyclic();
    let stop = m.now_ns();
    m.wait_until(stop + 99_000_000);
    assert_eq!(al(&m), (state::OP, 0));
    m.wait_until(stop + 101_000_000);
    assert_eq!(al(&m), (err(state::SAFEOP), al::SM_WATCHDOG));
    assert_eq!(
        m.dac(),
        [dac_code(0x2000), 0xE000],
        "AO1 error value, AO2 kept"
    );
    let e = emergencies(&m);
    assert_eq!(e.len(), 1, "{e:?}");
    assert_eq!(
        (e[0].code, e[0].register),
        (emcy::RPDO_TIMEOUT, ERR_COMMUNICATION)
    );
    assert_eq!(
        sdo_uint(&m, ERROR_REGISTER, 0),
        u32::from(ERR_COMMUNICATION)
    );
    // 0x1003: the Emergency is the newest error (code, 0x1001, first data byte).
    assert_eq!(sdo_uint(&m, ERROR_HISTORY, 0), 1);
    assert_eq!(
        sdo_uint(&m, ERROR_HISTORY, 1),
        u32::from(ERR_COMMUNICATION) << 16 | u32::from(emcy::RPDO_TIMEOUT)
    );
    // Complete access: sub 0 (16 bits) and only the errors recorded.
    let all = m
        .sdo_upload_full(ERROR_HISTORY, 0, true)
        .expect("complete access");
    assert_eq!(all.data, [1, 0, 0x50, 0x82, 0x11, 0]);
    // What the master gets back in SAFEOP: the inputs, working counter 3.
    assert_eq!(m.cycle(&ScriptedMaster::ao_image(1, 1)).unwrap().len(), 16);
    assert_eq!(
        m.dac(),
        [dac_code(0x2000), 0xE000],
        "outputs ignored in SAFEOP"
    );

    recover_to_op(&m, [dac_code(0x2000), 0xE000], 0x1000, 0x2000);
    let e = emergencies(&m);
    assert!(
        e.iter()
            .any(|e| e.code == emcy::NO_ERROR && e.register == 0),
        "{e:?}"
    );
    assert_eq!(sdo_uint(&m, ERROR_REGISTER, 0), 0);
    // The error reset is no error; writing 0 to 0x1003:00 clears the history, another
    // value or a write to an error is refused.
    assert_eq!(sdo_uint(&m, ERROR_HISTORY, 0), 1);
    assert_eq!(
        sdo_abort(m.sdo_download(ERROR_HISTORY, 0, &[1])),
        0x0609_0030
    );
    assert_eq!(
        sdo_abort(m.sdo_download(ERROR_HISTORY, 1, &[0; 4])),
        0x0601_0002
    );
    assert_eq!(sdo_uint(&m, ERROR_HISTORY, 0), 1);
    m.sdo_download(ERROR_HISTORY, 0, &[0])
        .expect("clear 0x1003");
    assert_eq!(sdo_uint(&m, ERROR_HISTORY, 0), 0);
    assert_eq!(sdo_abort(m.sdo_upload(ERROR_HISTORY, 1)), 0x0800_0024);
    save_pcap(&m, pcap)
}

/// DC SYNC0: the master stops sending. Every SYNC0 edge without fresh outputs is a missed SM
/// event (0x1C32:0B); the sync error counter (+3 per miss) passes 0x10F1:02 (4) at the
/// second miss: SAFEOP + 0x001A before the 100 ms SM watchdog could say 0x001B (the SSC and
/// SOES order), 0x1C32:20 sync error TRUE, Emergency 0x8700, both outputs to their error
/// values within two cycles.
#[test]
fn master_stops_in_dc_mode_gives_the_sync_error_first() {
    let m = op_with(DC, [Some(0x1000), Some(0x3000)]);
    good_cycles(&m, 30, 0x4000, 0x5000);
    m.wait(CYCLE);
    assert_eq!(m.dac(), [dac_code(0x4000), dac_code(0x5000)]);
    m.stop_cyclic();
    let stop = m.now_ns();
    idle(&m, 3 * CYCLE, CYCLE / 4);
    assert_eq!(al(&m), (err(state::SAFEOP), al::SYNC_ERROR));
    assert_eq!(m.dac(), [dac_code(0x1000), dac_code(0x3000)]);
    let fault_at = dac_loads(&m).last().unwrap().0;
    assert!(fault_at < stop + 3 * CYCLE, "fault values within 3 cycles");
    assert!(
        sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0B) >= 2,
        "0x1C32:0B SM event missed"
    );
    assert_eq!(
        sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x20),
        1,
        "0x1C32:20 sync error"
    );
    let e = emergencies(&m);
    assert_eq!(e.len(), 1, "{e:?}");
    assert_eq!(
        (e[0].code, e[0].register),
        (emcy::SYNC_ERROR, ERR_COMMUNICATION)
    );
    // Much later the SM watchdog expires too: the first error stays.
    m.wait(150_000_000);
    assert_eq!(al(&m), (err(state::SAFEOP), al::SYNC_ERROR));
    recover_to_op(&m, [dac_code(0x1000), dac_code(0x3000)], 0x0100, 0x0200);
}

/// Frames lost and repeated on the network in DC mode (ETG.1020 sync error counter, limit
/// 0x10F1:02 = 4): one lost frame is one missed SM event (+3) and the DAC holds its value
/// for that cycle; a frame delivered twice counts "cycle time too small" (0x1C32:0C) and
/// changes nothing; a lost answer (the slave got the frame) is a working-counter error
/// for the master only. Two frames lost in a row exceed the limit: SAFEOP + 0x001A.
#[test]
fn frames_lost_or_repeated_in_dc_mode() {
    let m = op_with(DC, [Some(0), Some(0)]);
    good_cycles(&m, 20, 0x1000, 0x1000);
    let missed0 = sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0B);
    let small0 = sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0C);

    // One frame lost: the master sees no answer, the DAC keeps 0x1000 for that cycle.
    m.lose_frames(1);
    let r = cycles(&m, 1, 0x2000, 0x2000);
    assert!(r[0].is_err());
    m.wait(CYCLE);
    assert_eq!(m.dac(), [dac_code(0x1000); 2], "held for the lost cycle");
    good_cycles(&m, 10, 0x2000, 0x2000);
    m.wait(CYCLE);
    assert_eq!(m.dac(), [dac_code(0x2000); 2]);
    assert_eq!(al(&m), (state::OP, 0));
    assert_eq!(sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0B), missed0 + 1);

    // A frame delivered twice: one more SM2 event in the cycle.
    m.duplicate_frames(1);
    good_cycles(&m, 1, 0x3000, 0x3000);
    good_cycles(&m, 5, 0x3000, 0x3000);
    assert_eq!(sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0C), small0 + 1);
    assert_eq!(al(&m), (state::OP, 0));

    // An answer lost: the master's working counter check fails, the outputs arrived.
    m.lose_replies(1);
    let r = cycles(&m, 1, 0x4000, 0x4000);
    assert!(r[0].is_err());
    m.wait(CYCLE);
    assert_eq!(m.dac(), [dac_code(0x4000); 2]);
    good_cycles(&m, 10, 0x4000, 0x4000);
    assert_eq!(al(&m), (state::OP, 0));
    assert!(emergencies(&m).is_empty());

    // Two frames lost in a row (the mailbox reads above ran between the cyclic frames).
    m.lose_frames(2);
    let r = cycles(&m, 2, 0x5000, 0x5000);
    assert!(r.iter().all(|r| r.is_err()));
    m.wait(CYCLE);
    assert_eq!(al(&m), (err(state::SAFEOP), al::SYNC_ERROR));
    assert_eq!(m.dac(), [0, 0], "error values");
    let e = emergencies(&m);
    assert_eq!(
        e.iter().map(|e| e.code).collect::<Vec<_>>(),
        [emcy::SYNC_ERROR]
    );
    recover_to_op(&m, [0, 0], 0x0700, 0x0800);
}

/// Frames lost in SM-synchronous mode: there is no local time base to miss an SM event
/// against (0x1C32:0B is DC only), so the module rides through short gaps; only an outage
/// as long as the SM watchdog (100 ms) is a fault.
#[test]
fn frames_lost_in_sm_synchronous_mode() {
    let m = op_with(SM_SYNC, [Some(0), Some(0)]);
    good_cycles(&m, 10, 0x1000, 0x1000);
    m.lose_frames(50);
    let r = cycles(&m, 50, 0x2000, 0x2000);
    assert!(r.iter().all(|r| r.is_err()));
    assert_eq!(al(&m), (state::OP, 0));
    assert_eq!(m.dac(), [dac_code(0x1000); 2], "held while nothing arrives");
    good_cycles(&m, 5, 0x2000, 0x2000);
    assert_eq!(m.dac(), [dac_code(0x2000); 2]);
    assert_eq!(sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0B), 0);
    assert!(emergencies(&m).is_empty());
}

/// SYNC0 never reaches the MCU (broken line) while the ESC's cyclic unit runs: in OP the
/// SYNC0 watchdog of the slave (no edge for more than 2 cycles, at least 1 ms, as the
/// SSC's Sync0WdValue) gives the fatal sync error: SAFEOP + 0x002C (ETG.1000.6 table 11,
/// SSC CheckIfEcatError), Emergency 0x8700, outputs to their error values. The outputs
/// the master sent never reached the DAC (no SYNC0 to latch them).
#[test]
fn sync0_missing_is_a_fatal_sync_error() {
    let m = op_with(DC, [Some(0x0800), Some(0x0800)]);
    good_cycles(&m, 20, 0x4000, 0x4000);
    m.wait(CYCLE);
    assert_eq!(m.dac(), [dac_code(0x4000); 2]);
    m.board().borrow().esc().borrow_mut().sync0_fault = Some(Sync0Fault::Missing);
    let broken = m.now_ns();
    let results = cycles(&m, 30, 0x6000, 0x6000);
    assert!(results.iter().any(|r| r.is_ok()));
    assert_eq!(al(&m), (err(state::SAFEOP), al::FATAL_SYNC_ERROR));
    assert_eq!(m.dac(), [dac_code(0x0800); 2]);
    let loads = dac_loads(&m);
    assert!(
        loads.iter().all(|l| l.2 != dac_code(0x6000)),
        "no output latched without SYNC0"
    );
    let fault_at = loads.last().unwrap().0;
    assert!(
        fault_at <= broken + 1_000_000 + 3 * CYCLE,
        "detected within the SYNC0 watchdog (1 ms): {} us",
        (fault_at - broken) / 1000
    );
    let e = emergencies(&m);
    assert_eq!(
        e.iter().map(|e| e.code).collect::<Vec<_>>(),
        [emcy::SYNC_ERROR]
    );
    // The line is repaired: the master acknowledges and goes back to OP.
    m.board().borrow().esc().borrow_mut().sync0_fault = None;
    recover_to_op(&m, [dac_code(0x0800); 2], 0x0300, 0x0400);
}

/// SYNC0 too fast. At PREOP -> SAFEOP a SYNC0 cycle below the minimum cycle time (0x1C32:05)
/// is refused with 0x0035 (DC sync cycle time), the outputs stay at 0 V; reprogrammed in OP
/// to a cycle below the minimum, the edges outrun the frames: missed SM events count
/// (0x1C32:0B) and the sync error takes the module to SAFEOP + 0x001A with its error values.
#[test]
fn sync0_too_fast() {
    let min = firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS;
    let m = master();
    m.configure_mailbox().unwrap();
    m.expect_state(state::PREOP).unwrap();
    fault_config(&m, [Some(0x0400), Some(0x0400)]).unwrap();
    assert_eq!(sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x05), min);
    m.configure_process_data(Sync::Dc { cycle_ns: min / 2 })
        .unwrap();
    let s = m.request_state(state::SAFEOP).unwrap();
    assert_refused(
        s,
        state::PREOP,
        al::DC_SYNC_CYCLE_TIME,
        "SYNC0 below the minimum",
    );
    assert_eq!(m.dac(), [0, 0]);
    // A cycle the module takes, then OP.
    m.set_sync(DC).unwrap();
    m.expect_state(state::SAFEOP).unwrap();
    m.expect_state(state::OP).unwrap();
    good_cycles(&m, 20, 0x2000, 0x2000);
    m.wait(CYCLE);
    assert_eq!(m.dac(), [dac_code(0x2000); 2]);
    let missed = sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0B);
    // The master reprograms SYNC0 to half the minimum cycle and keeps its 100 us frames.
    m.set_sync(Sync::Dc { cycle_ns: min / 2 }).unwrap();
    m.set_slot_cycle(CYCLE);
    cycles(&m, 10, 0x2000, 0x2000);
    assert_eq!(al(&m), (err(state::SAFEOP), al::SYNC_ERROR));
    assert_eq!(m.dac(), [dac_code(0x0400); 2]);
    assert!(sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0B) > missed);
    let e = emergencies(&m);
    assert_eq!(
        e.iter().map(|e| e.code).collect::<Vec<_>>(),
        [emcy::SYNC_ERROR]
    );
}

/// SYNC0 jittering. Each edge displaced by up to 30 us of a 100 us cycle, frames half a
/// cycle before the nominal edge: the frames still come well before their edges, every
/// output is latched, nothing counts, the module stays in OP. Frames 15 us before the
/// nominal edge with 10 us of jitter: still before their edges, but sometimes closer to
/// the edge expected from the last one than the calc+copy time (0x1C32:06), which 0x1C32:0D
/// ("shift time too short") counts, still in OP. Jitter larger than the frames' lead (45
/// us, frames 10 us ahead): edges come before their outputs, missed SM events, SAFEOP +
/// 0x001A, error values.
#[test]
fn sync0_jitter() {
    let m = op_with(DC, [Some(0x0100), Some(0x0200)]);
    good_cycles(&m, 10, 0x1000, 0x1000);
    let jitter = |max_ns, seed| {
        m.board().borrow().esc().borrow_mut().sync0_fault =
            Some(Sync0Fault::Jitter { max_ns, seed })
    };
    // 200 cycles of changing outputs the module rides through: every one latched, still in
    // OP, no missed SM event.
    let ride_through = || {
        for k in 0..200i16 {
            good_cycles(&m, 1, 0x1000 + k, 0x2000 - k);
        }
        m.wait(CYCLE);
        assert_eq!(al(&m), (state::OP, 0));
        assert_eq!(m.dac(), [dac_code(0x1000 + 199), dac_code(0x2000 - 199)]);
        assert_eq!(sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0B), 0);
    };
    jitter(30_000, 14);
    ride_through();
    assert_eq!(sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0D), 0);

    jitter(10_000, 15);
    m.set_slot_lead(15_000);
    ride_through();
    assert!(
        sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x0D) > 0,
        "0x1C32:0D counts"
    );
    assert!(emergencies(&m).is_empty());

    jitter(45_000, 16);
    m.set_slot_lead(10_000);
    cycles(&m, 100, 0x3000, 0x3000);
    assert_eq!(al(&m), (err(state::SAFEOP), al::SYNC_ERROR));
    assert_eq!(m.dac(), [dac_code(0x0100), dac_code(0x0200)]);
    let e = emergencies(&m);
    assert_eq!(
        e.iter().map(|e| e.code).collect::<Vec<_>>(),
        [emcy::SYNC_ERROR]
    );
}

/// A second sync error after the first was acknowledged: the master goes SAFEOP -> OP
/// again (as after any fault) and later loses two frames in a row. The sync error is raised
/// again (SAFEOP + 0x001A, Emergency, fault values): the monitor starts over at SAFEOP ->
/// OP (the SSC clears its SM event missed counter and sync error there), it does not stay
/// latched from the first time.
#[test]
fn a_second_sync_error_after_recovery_is_detected() {
    let m = op_with(DC, [Some(0x0200), Some(0x0300)]);
    for round in 0..3 {
        good_cycles(&m, 20, 0x1000 + round, 0x2000 + round);
        m.lose_frames(2);
        cycles(&m, 2, 0x3000, 0x3000);
        m.wait(CYCLE);
        m.stop_cyclic();
        assert_eq!(
            al(&m),
            (err(state::SAFEOP), al::SYNC_ERROR),
            "round {round}"
        );
        assert_eq!(
            m.dac(),
            [dac_code(0x0200), dac_code(0x0300)],
            "round {round}"
        );
        let e = emergencies(&m);
        assert!(
            e.iter().any(|e| e.code == emcy::SYNC_ERROR),
            "round {round}: {e:?}"
        );
        recover_to_op(&m, [dac_code(0x0200), dac_code(0x0300)], 0x0400, 0x0500);
        assert_eq!(
            sdo_uint(&m, SM_OUTPUT_PARAMETER, 0x20),
            0,
            "round {round}: cleared"
        );
    }
}
