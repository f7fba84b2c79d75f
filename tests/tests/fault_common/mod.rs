//! Helpers shared by the fault campaign (issue 14 section 2): the firmware's board driven by
//! the scripted master ([`ScriptedMaster`]), the module's objects by their CiA 401 / ETG.1020
//! numbers, and the checks every fault test makes (AL status, Emergency, DAC, what the
//! master gets back).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use virtual_board::models::spi::SpiStats;
use virtual_board::rig::board::BoardConfig;
use virtual_board::rig::firmware_cpu::{FirmwareCpu, FirmwareStats};
use virtual_board::rig::scripted::{state, AlStatus, MasterError, ScriptedMaster, Sync};
use virtual_board::rig::sdo_client::{Emergency, SdoError};

/// A tiny reproducible generator (xorshift64*).
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed` (any value, 0 included).
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// A value in `0..n`.
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
    /// A value in `lo..=hi`.
    pub fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.below(hi - lo + 1)
    }
    /// True `percent` times in a hundred.
    pub fn chance(&mut self, percent: u64) -> bool {
        self.below(100) < percent
    }
}

/// The cycle of the campaign's process data: the advertised minimum
/// (`firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS`), the shortest the firmware accepts.
pub const CYCLE: u64 = firmware::products::analog_io::sync::MIN_CYCLE_TIME_NS as u64;

/// CiA 401 AO error mode (0x6443: 1 = go to the error value, 0 = keep) and error value
/// (0x6444, INTEGER32 in 0x6411 units).
pub const AO_ERROR_MODE: u16 = 0x6443;
/// See [`AO_ERROR_MODE`].
pub const AO_ERROR_VALUE: u16 = 0x6444;
/// Error register (CiA 301 0x1001).
pub const ERROR_REGISTER: u16 = 0x1001;
/// Pre-defined error field (CiA 301 7.5.2.3): the Emergencies sent, newest at sub 1.
pub const ERROR_HISTORY: u16 = 0x1003;
/// Sync Manager 2 parameters (ETG.1020 0x1C32).
pub const SM_OUTPUT_PARAMETER: u16 = 0x1C32;

/// AL status codes (ETG.1000.6 table 11, hardware-facts 1.6).
pub mod al {
    pub const INVALID_STATE_CHANGE: u16 = 0x0011;
    pub const UNKNOWN_STATE: u16 = 0x0012;
    pub const BOOTSTRAP_NOT_SUPPORTED: u16 = 0x0013;
    pub const INVALID_MAILBOX_CONFIG_BOOT: u16 = 0x0015;
    pub const INVALID_MAILBOX_CONFIG: u16 = 0x0016;
    pub const SYNC_ERROR: u16 = 0x001A;
    pub const SM_WATCHDOG: u16 = 0x001B;
    pub const INVALID_OUTPUT_CONFIG: u16 = 0x001D;
    pub const INVALID_INPUT_CONFIG: u16 = 0x001E;
    pub const INVALID_INPUT_MAPPING: u16 = 0x0024;
    pub const INVALID_OUTPUT_MAPPING: u16 = 0x0025;
    pub const FATAL_SYNC_ERROR: u16 = 0x002C;
    pub const INVALID_DC_SYNC_CONFIG: u16 = 0x0030;
    pub const DC_SYNC_CYCLE_TIME: u16 = 0x0035;
}

/// Emergency error codes (CiA 301 table 21).
pub mod emcy {
    /// No error / error reset.
    pub const NO_ERROR: u16 = 0x0000;
    /// RPDO timeout: the process-data watchdog expired.
    pub const RPDO_TIMEOUT: u16 = 0x8250;
    /// Synchronisation error (as EtherCAT devices use 0x8700 for ETG.1020 sync errors).
    pub const SYNC_ERROR: u16 = 0x8700;
    /// Device hardware: the module's SPI link to its ESC saw errors.
    pub const PDI_ERROR: u16 = 0x5000;
}

/// 0x1001 bits: generic error (b0) and communication error (b4).
pub const ERR_COMMUNICATION: u8 = 0x11;

/// The DAC code of an 0x6411 value (0..=0x7FFF -> 0..=0xFFFE: 0..10 V; scaling module of the
/// firmware, `AO << 1`).
pub fn dac_code(ao: i16) -> u16 {
    (ao.max(0) as u16) << 1
}

/// A firmware board with the scripted master, after power-up, brought up (SII read).
pub fn master() -> ScriptedMaster {
    master_with(|_| {})
}

/// As [`master`], with the board's configuration edited first (fault switches).
pub fn master_with(edit: impl FnOnce(&mut BoardConfig)) -> ScriptedMaster {
    let m = ScriptedMaster::firmware(edit);
    m.wait(2_000_000);
    m.init().expect("bring-up");
    m
}

/// Writes the fault configuration in PREOP: per channel `Some(value)` = error value,
/// `None` = keep the output.
pub fn fault_config(m: &ScriptedMaster, ch: [Option<i32>; 2]) -> Result<(), MasterError> {
    for (sub, c) in (1u8..).zip(ch) {
        m.sdo_download(AO_ERROR_MODE, sub, &[u8::from(c.is_some())])?;
        if let Some(v) = c {
            m.sdo_download(AO_ERROR_VALUE, sub, &v.to_le_bytes())?;
        }
    }
    Ok(())
}

/// A board in OP with `sync`, the fault configuration `ch` written in PREOP, the master
/// sending process data (outputs 0) every cycle in the background.
pub fn op_with(sync: Sync, ch: [Option<i32>; 2]) -> ScriptedMaster {
    let m = master();
    m.to_op(sync, |m| fault_config(m, ch)).expect("to OP");
    m.start_cyclic(&ScriptedMaster::ao_image(0, 0));
    m
}

/// `n` cycles writing `(a, b)`: each waits for its slot and sends one LRW; the results.
pub fn cycles(m: &ScriptedMaster, n: usize, a: i16, b: i16) -> Vec<Result<Vec<u8>, MasterError>> {
    (0..n)
        .map(|_| {
            m.wait_cycle_slot();
            m.cycle(&ScriptedMaster::ao_image(a, b))
        })
        .collect()
}

/// `n` cycles that must all succeed (working counter 3).
pub fn good_cycles(m: &ScriptedMaster, n: usize, a: i16, b: i16) {
    for (i, r) in cycles(m, n, a, b).into_iter().enumerate() {
        r.unwrap_or_else(|e| panic!("cycle {i}: {e}"));
    }
}

/// Lets `ns` pass in steps of `step` (a master that keeps only polling AL status).
pub fn idle(m: &ScriptedMaster, ns: u64, step: u64) {
    let end = m.now_ns() + ns;
    while m.now_ns() < end {
        m.wait(step.min(end - m.now_ns()));
    }
}

/// AL status and code, e.g. `(0x14, 0x001B)`.
pub fn al(m: &ScriptedMaster) -> (u8, u16) {
    m.al_status().expect("AL status").pair()
}

/// The Emergencies waiting in the read mailbox (all of them).
pub fn emergencies(m: &ScriptedMaster) -> Vec<Emergency> {
    m.drain_mailbox(16).expect("mailbox");
    let unexpected = m.take_unexpected();
    assert!(
        unexpected.is_empty(),
        "frames other than Emergencies: {:02x?}",
        unexpected.iter().map(|f| &f[..16]).collect::<Vec<_>>()
    );
    m.take_emergencies()
}

/// An unsigned value read over SDO (1..=4 bytes, little-endian).
pub fn sdo_uint(m: &ScriptedMaster, index: u16, sub: u8) -> u32 {
    let d = m
        .sdo_upload(index, sub)
        .unwrap_or_else(|e| panic!("upload {index:#06x}:{sub}: {e}"));
    d.iter().rev().fold(0u32, |v, b| v << 8 | u32::from(*b))
}

/// The abort code of an SDO transfer that must be refused.
pub fn sdo_abort<T: std::fmt::Debug>(r: Result<T, SdoError>) -> u32 {
    match r {
        Err(SdoError::Abort { code, .. }) => code,
        other => panic!("expected an SDO abort, got {other:?}"),
    }
}

/// After a fault: the master stops its process data, acknowledges and goes back to OP.
/// Until new outputs come in OP the DAC holds `fault` (codes); then it follows the outputs,
/// which the master sends every cycle from there on.
pub fn recover_to_op(m: &ScriptedMaster, fault: [u16; 2], a: i16, b: i16) {
    m.stop_cyclic();
    let s = m.request_state(state::SAFEOP).expect("acknowledge");
    assert_eq!(s.pair(), (state::SAFEOP, 0), "error acknowledged in SAFEOP");
    let s = m.request_state(state::OP).expect("OP");
    assert_eq!(s.pair(), (state::OP, 0));
    m.wait(5 * CYCLE);
    assert_eq!(
        m.dac(),
        fault,
        "the fault values stay until new outputs in OP"
    );
    good_cycles(m, 10, a, b);
    m.start_cyclic(&ScriptedMaster::ao_image(a, b));
    m.wait(2 * CYCLE);
    assert_eq!(
        m.dac(),
        [dac_code(a), dac_code(b)],
        "new outputs on the DAC"
    );
    assert_eq!(al(m), (state::OP, 0));
}

/// Every DAC register load since the start: `(time, channel, code)`.
pub fn dac_loads(m: &ScriptedMaster) -> Vec<(u64, u8, u16)> {
    let b = m.board().borrow();
    let d = b.dac().borrow();
    d.updates
        .iter()
        .map(|u| (u.time_ns, u.channel, u.code))
        .collect()
}

/// The firmware harness's counters (init, ticks, samples).
pub fn firmware_stats(m: &ScriptedMaster) -> FirmwareStats {
    let b = m.board().borrow();
    let cpu = b
        .cpu()
        .as_any()
        .and_then(|a| a.downcast_ref::<FirmwareCpu>());
    cpu.expect("the firmware runs on the board").stats.clone()
}

/// The ESC's SPI counters (transactions, PDI errors the ESC saw).
pub fn spi_stats(m: &ScriptedMaster) -> SpiStats {
    m.board().borrow().esc().borrow().spi_stats.clone()
}

/// Saves the traffic as a pcap under CARGO_TARGET_TMPDIR; returns its path (for the
/// capture checks, [`virtual_board::capture_tests`]).
pub fn save_pcap(m: &ScriptedMaster, name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let b = m.board().borrow();
    b.pcap()
        .expect("capture on")
        .save(&path)
        .expect("pcap written");
    path
}

/// AL status with the error flag.
pub fn err(state: u8) -> u8 {
    state | state::ERROR
}

/// Asserts `s` shows `state` with error `code`.
pub fn assert_refused(s: AlStatus, state: u8, code: u16, what: &str) {
    assert_eq!(s.pair(), (err(state), code), "{what}");
}
