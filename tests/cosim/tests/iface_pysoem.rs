//! SYSTEM TEST: the release image on the co-simulated LPC1754, served on a network interface
//! as `cargo xtask sim --image --iface vb1` serves it, driven by an independent master in its
//! own process: SOEM through pysoem (`scripts/pysoem_master.py`): PRE-OP, SDO uploads of the
//! identity, the process-data mapping, SAFE-OP, OP with 200 process-data exchanges, INIT.
//!
//! Needs root (a network namespace, raw sockets), `ip` (iproute2), python3 with pysoem (the
//! project's setup installs it) and tshark, so it is ignored by default; `cargo xtask test`
//! runs it when it runs as root, and it fails, naming what is missing, when it cannot run.
//! Everything happens in a private network namespace of the test's own thread.

mod common;

use common::{run_script_against, run_script_against_image};
use firmware::product::identity::{IDENTITY, NAMES};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::peer::soes;
use serde_json::Value;
use std::path::PathBuf;
use virtual_board::tools::iface::pysoem_missing;
use virtual_board::tools::sim::tshark;

/// Process-data exchanges the script runs in OP.
const CYCLES: u32 = 200;

fn step<'a>(lines: &'a [Value], name: &str) -> &'a Value {
    lines
        .iter()
        .find(|l| l["step"] == name)
        .unwrap_or_else(|| panic!("no step {name} in {lines:?}"))
}

#[test]
#[ignore = "needs root, iproute2 (ip), python3 with pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_drives_the_image_over_a_veth_pair() {
    if let Some(why) = pysoem_missing() {
        panic!("this test cannot run here: {why}");
    }
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scripts/pysoem_master.py");
    let args = vec![CYCLES.to_string().into()];
    // Wall time, bounded even if the script hangs.
    let o = std::thread::spawn(move || {
        run_script_against_image(script, args, "iface-pysoem-image.pcap", 120.0)
    })
    .join()
    .expect("namespace thread")
    .unwrap();
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
    assert_eq!(step(&o.lines, "op")["ok"], true);
    let pd = step(&o.lines, "process_data");
    assert_eq!(pd["good_wkc"], CYCLES);
    assert_eq!(pd["state"], 8, "still in OP after the exchanges");
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
    let args = vec![CYCLES.to_string().into()];
    let o = std::thread::spawn(move || {
        run_script_against(
            || soes::target(soes::load()?, Options::default()),
            script,
            args,
            "iface-pysoem-soes.pcap",
            120.0,
        )
    })
    .join()
    .expect("namespace thread")
    .unwrap();
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
    assert_eq!(pd["good_wkc"], CYCLES);
    assert_eq!(pd["state"], 8, "still in OP after the exchanges");
    tshark::assert_clean(&o.pcap);
}
