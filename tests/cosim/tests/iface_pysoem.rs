//! SYSTEM TEST: the release image on the co-simulated LPC1754, served on a network interface
//! as `cargo xtask sim --image --iface vb1` serves it, driven by an independent master in its
//! own process: SOEM through pysoem (`scripts/pysoem_master.py`): PRE-OP, SDO uploads of the
//! identity, the process-data mapping, SAFE-OP, OP with 200 process-data exchanges, INIT.
//!
//! Needs root (a network namespace, raw sockets), `ip` (iproute2), python3 with pysoem (the
//! project's setup installs it) and tshark, so it is ignored by default; `cargo xtask test`
//! runs it when it runs as root, and it fails, naming what is missing, when it cannot run.
//! Everything happens in a private network namespace of the test's own thread.

use firmware::product::identity::{IDENTITY, NAMES};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_target, load_image};
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use virtual_board::tools::iface::{veth_missing, veth_pair_in_new_namespace};
use virtual_board::tools::sim::{self, tshark, Line, SimConfig};

/// Process-data exchanges the script runs in OP.
const CYCLES: u32 = 200;

fn missing() -> Option<String> {
    veth_missing().or_else(|| {
        let pysoem = Command::new("python3")
            .args(["-c", "import pysoem"])
            .output();
        (!pysoem.is_ok_and(|o| o.status.success()))
            .then(|| "python3 with pysoem is not installed (`cargo xtask setup`)".into())
    })
}

struct Outcome {
    served: u64,
    script_ok: bool,
    lines: Vec<Value>,
    stderr: String,
    facts: String,
    clean: bool,
    pcap: PathBuf,
}

fn run_in_namespace() -> Result<Outcome, String> {
    veth_pair_in_new_namespace("vb0", "vb1")?;
    let image = load_image()?;
    let (target, handle) = image_target(image, Options::default())?;
    let pcap = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("iface-pysoem-image.pcap");
    let cfg = SimConfig {
        iface: Some("vb1".into()),
        // Wall time, bounded even if the script hangs.
        seconds: Some(120.0),
        pcap: Some(pcap.clone()),
        ..Default::default()
    };
    let ready = Arc::new(AtomicBool::new(false));
    let stop = Arc::new(AtomicBool::new(false));
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scripts/pysoem_master.py");
    let (ready2, stop2) = (ready.clone(), stop.clone());
    // The master in its own process, started once the board answers on vb1.
    let master = std::thread::spawn(move || {
        let deadline = Instant::now() + Duration::from_secs(60);
        while !ready2.load(Ordering::Acquire) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        let out = Command::new("python3")
            .arg(&script)
            .args(["vb0", &CYCLES.to_string()])
            .output();
        stop2.store(true, Ordering::Release);
        out
    });
    let served = sim::run_on_interface(&cfg, target, &stop, &mut |l| {
        if let Line::Result(s) = l {
            if s.contains("waiting for EtherCAT frames") {
                ready.store(true, Ordering::Release);
            }
        }
    })
    .map_err(|e| e.to_string())?;
    let out = master
        .join()
        .map_err(|_| "the master thread panicked".to_string())?
        .map_err(|e| format!("python3: {e}"))?;
    let facts = handle
        .with(|c| c.facts())
        .ok_or("the co-simulator did not start")?;
    let lines = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    Ok(Outcome {
        served: served.frames,
        script_ok: out.status.success(),
        lines,
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        clean: facts.fault.is_none() && facts.reports.is_empty(),
        facts: facts.summary(),
        pcap,
    })
}

fn step<'a>(lines: &'a [Value], name: &str) -> &'a Value {
    lines
        .iter()
        .find(|l| l["step"] == name)
        .unwrap_or_else(|| panic!("no step {name} in {lines:?}"))
}

#[test]
#[ignore = "needs root, iproute2 (ip), python3 with pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_drives_the_image_over_a_veth_pair() {
    if let Some(why) = missing() {
        panic!("this test cannot run here: {why}");
    }
    let o = std::thread::spawn(run_in_namespace)
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
