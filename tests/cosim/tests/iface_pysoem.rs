//! SYSTEM TEST: the release image on the co-simulated LPC1754, served on a network interface
//! as `cargo xtask sim --image --iface vb1` serves it, driven by an independent master in its
//! own process: SOEM through pysoem (`scripts/pysoem_master.py`) with its default timeouts:
//! PRE-OP, SDO uploads of the identity, DC, the process-data mapping, SAFE-OP, OP with 2 000
//! process-data exchanges in step with SYNC0, the cycle monitor over SDO, the SM watchdog in
//! SM-synchronous mode (0x001B), the object dictionary through SDO Information, INIT.
//!
//! The process data are checked against the board's converters: each AD7689 input is held
//! at its own voltage and every value the master read must be that voltage truncated to the
//! 15 bits of 0x6401; every output pair the module took must reach the AD5663 model's
//! registers as `AO << 1`, in order, with nothing between.
//!
//! Needs root (a network namespace, raw sockets), `ip` (iproute2), python3 with pysoem (the
//! project's setup installs it) and tshark, so it is ignored by default; `cargo xtask test`
//! runs it when it runs as root, and it fails, naming what is missing, when it cannot run.
//! Everything happens in a private network namespace of the test's own thread.

mod common;

use common::{run_script_against_with, step, ScriptRun, Serving, BOARD_SLOWDOWN};
use firmware::products::analog_io::device::DEVICE;
use firmware::products::analog_io::identity::{IDENTITY, NAMES};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::peer::soes;
use lpc1754_cosim::run::{image_target, load_image};
use serde_json::Value;
use std::path::PathBuf;
use virtual_board::tools::analog_check::{
    check_inputs, check_outputs_on_the_wall_clock, OutputsTaken, AI_LEVELS_V,
};
use virtual_board::tools::iface::pysoem_missing;
use virtual_board::tools::sim::tshark;

/// Process-data exchanges the script runs in OP.
const CYCLES: u32 = 2000;
/// The script's default DC cycle (ns).
const CYCLE_NS: u64 = 4_000_000;

/// The pysoem master's process-data step checked against the board's converters: every
/// value it read at the inputs (the lowest and the highest per channel) is the input's
/// voltage truncated to a 0x6401 step, and every output pair the module took reached the
/// DAC, in order, but for those beside a late master cycle and those the board's CPU skipped
/// while it ran more than half a cycle behind the wall clock (`tools::analog_check`).
fn assert_analog_values(o: &ScriptRun, pd: &Value) {
    let facts = &o.facts;
    for which in ["ai_min", "ai_max"] {
        let values: Vec<i16> = serde_json::from_value(pd[which].clone())
            .unwrap_or_else(|e| panic!("{which}: {e}: {pd}"));
        if let Err(e) = check_inputs(&AI_LEVELS_V, &values) {
            panic!("{e} ({which})\n{facts}");
        }
    }
    let taken: Vec<(i16, i16, bool)> = serde_json::from_value(pd["outputs_taken"].clone())
        .unwrap_or_else(|e| panic!("outputs_taken: {e}: {pd}"));
    let taken: Vec<OutputsTaken> = taken
        .into_iter()
        .map(|(a, b, may_be_replaced)| OutputsTaken {
            values: [a, b],
            may_be_replaced,
        })
        .collect();
    assert!(taken.len() > 100, "only {} output pairs", taken.len());
    // The frame of the next pair arrives half a cycle before the SYNC0 edge after the one
    // that should have put this pair out.
    let on_dac = check_outputs_on_the_wall_clock(&taken, &o.dac_updates, &o.lag, CYCLE_NS / 2)
        .unwrap_or_else(|e| panic!("{e}\n{facts}"));
    eprintln!("{on_dac}\n{facts}");
}

#[test]
#[ignore = "needs root, iproute2 (ip), python3 with pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_drives_the_image_over_a_veth_pair() {
    if let Some(why) = pysoem_missing() {
        panic!("this test cannot run here: {why}");
    }
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scripts/pysoem_master.py");
    let args = vec![
        CYCLES.to_string().into(),
        "--slowdown".into(),
        BOARD_SLOWDOWN.to_string().into(),
    ];
    // Wall time, bounded even if the script hangs.
    let o = common::unless_the_master_was_late(|| {
        let (script, args) = (script.clone(), args.clone());
        std::thread::spawn(move || {
            run_script_against_with(
                || image_target(load_image()?, Options::default()),
                script,
                vec![args],
                "iface-pysoem-image.pcap",
                120.0,
                Serving {
                    ai_levels_v: AI_LEVELS_V.map(Some),
                    slowdown: BOARD_SLOWDOWN,
                },
            )
        })
        .join()
        .expect("namespace thread")
        .unwrap()
    });
    assert!(
        o.script_ok,
        "pysoem failed: {:?}\n{}\n{}",
        o.lines, o.stderr, o.facts
    );
    assert!(o.clean, "{}", o.facts);
    assert!(o.served > 100, "only {} frames", o.served);
    // SOEM names a slave by the first string of the SII (ec_config.c), which the generator
    // fills with the group type.
    assert_eq!(step(&o.lines, "sii")["name"], NAMES.group_type);
    let sdo = step(&o.lines, "sdo");
    assert_eq!(sdo["device_type"], 0x000C_0191);
    assert_eq!(sdo["name"], NAMES.device_name);
    let identity: Vec<u64> = serde_json::from_value(sdo["identity"].clone()).unwrap();
    assert_eq!(
        identity,
        [
            IDENTITY.vendor_id,
            IDENTITY.product_code,
            IDENTITY.revision,
            IDENTITY.serial_number
        ]
        .map(u64::from)
    );
    let map = step(&o.lines, "config_map");
    assert_eq!(
        (map["outputs"].as_u64(), map["inputs"].as_u64()),
        (Some(4), Some(16))
    );
    assert_eq!(step(&o.lines, "dc")["found"], true);
    assert_eq!(step(&o.lines, "safeop")["sync_mode"], 2, "DC SYNC0 mode");
    assert_eq!(step(&o.lines, "op")["ok"], true);
    let pd = step(&o.lines, "process_data");
    common::assert_every_exchange_answered(pd, CYCLES);
    assert_eq!(pd["state"], 8, "still in OP after the exchanges");
    assert_analog_values(&o, pd);
    assert_eq!(step(&o.lines, "sync_monitor")["sync_error"], 0);
    let wd = step(&o.lines, "watchdog");
    assert_eq!(wd["sync_mode"], 1, "SM-synchronous");
    assert_eq!(
        (wd["state"].as_u64(), wd["al_status_code"].as_u64()),
        (Some(0x14), Some(0x1B))
    );
    assert_eq!(wd["ok"], true, "{wd}");
    // SDO Information: every object of the firmware's dictionary, by its name.
    let objects = &step(&o.lines, "sdo_info")["objects"];
    for obj in DEVICE.od.iter() {
        let got = &objects[format!("{:#06x}", obj.index)];
        assert_eq!(got["name"], obj.name, "{:#06x} in {objects}", obj.index);
    }
    assert_eq!(objects.as_object().map(|m| m.len()), Some(DEVICE.od.len()));
    assert_eq!(step(&o.lines, "init")["state"], 1, "{:?}", o.lines);
    tshark::assert_clean(&o.pcap);
}

/// SOES (tests/soes) served the same way and driven by the same script: SOEM brings it to OP
/// and exchanges process data with it.
#[test]
#[ignore = "needs root, iproute2 (ip), python3 with pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_drives_soes_over_a_veth_pair() {
    if let Some(why) = pysoem_missing() {
        panic!("this test cannot run here: {why}");
    }
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scripts/pysoem_master.py");
    // SOES has no cycle monitor objects (0x1C32:0B..0x20): the script stops after OP. SOES
    // polls the ESC over its SPI without interrupts, and the co-simulator fell 114 ms behind
    // the wall clock with it on a 2-core CI host: it gets the image's slowdown.
    let args = vec![
        CYCLES.to_string().into(),
        "--op-only".into(),
        "--slowdown".into(),
        BOARD_SLOWDOWN.to_string().into(),
    ];
    let o = common::unless_the_master_was_late(|| {
        let (script, args) = (script.clone(), args.clone());
        std::thread::spawn(move || {
            run_script_against_with(
                || soes::target(soes::load()?, Options::default()),
                script,
                vec![args],
                "iface-pysoem-soes.pcap",
                120.0,
                Serving {
                    slowdown: BOARD_SLOWDOWN,
                    ..Serving::default()
                },
            )
        })
        .join()
        .expect("namespace thread")
        .unwrap()
    });
    assert!(
        o.script_ok,
        "pysoem failed: {:?}\n{}\n{}",
        o.lines, o.stderr, o.facts
    );
    assert!(o.clean, "{}", o.facts);
    assert_eq!(step(&o.lines, "sii")["name"], "SOES analog I/O");
    let sdo = step(&o.lines, "sdo");
    assert_eq!(sdo["device_type"], 0x000C_0191);
    assert_eq!(sdo["name"], "SOES analog I/O");
    let identity: Vec<u64> = serde_json::from_value(sdo["identity"].clone()).unwrap();
    assert_eq!(identity[1], 0x534F_4553, "SOES's product code");
    let map = step(&o.lines, "config_map");
    assert_eq!(
        (map["outputs"].as_u64(), map["inputs"].as_u64()),
        (Some(4), Some(16))
    );
    assert_eq!(step(&o.lines, "op")["ok"], true);
    let pd = step(&o.lines, "process_data");
    common::assert_every_exchange_answered(pd, CYCLES);
    assert_eq!(pd["state"], 8, "still in OP after the exchanges");
    assert_eq!(step(&o.lines, "init")["state"], 1, "{:?}", o.lines);
    tshark::assert_clean(&o.pcap);
}
