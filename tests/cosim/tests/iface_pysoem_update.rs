//! SYSTEM TEST: a firmware update of the release programs on the co-simulated LPC1754 by an
//! independent master in its own process, SOEM through pysoem (`tests/scripts/pysoem_update.py`,
//! the steps of SOEM's `firm_update`), over a veth pair as `cargo xtask sim --image --iface`
//! serves it: the application resets into the bootloader at INIT -> BOOT, a file with a bad
//! CRC is refused, the release application with another version string is taken, and after
//! BOOT -> INIT the bootloader installs it and the new application answers 0x100A with the
//! new version.
//!
//! Needs root (a network namespace, raw sockets), `ip` (iproute2), python3 with pysoem (the
//! project's setup installs it) and tshark, so it is ignored by default; `cargo xtask test`
//! runs it when it runs as root, and it fails, naming what is missing, when it cannot run.

mod common;

use common::{new_update_file, run_script_against_image};
use firmware::products::analog_io::identity::{NAMES, UPDATE_TARGET};
use serde_json::Value;
use std::path::PathBuf;
use virtual_board::tools::iface::pysoem_missing;
use virtual_board::tools::sim::tshark;

/// The software version of the file written (as long as the release version).
const NEW_VERSION: &str = "7.6.5";

fn steps<'a>(lines: &'a [Value], name: &'a str) -> impl Iterator<Item = &'a Value> {
    lines.iter().filter(move |l| l["step"] == name)
}

#[test]
#[ignore = "needs root, iproute2 (ip), python3 with pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_updates_the_image_over_a_veth_pair() {
    if let Some(why) = pysoem_missing() {
        panic!("this test cannot run here: {why}");
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("iface-pysoem-update");
    std::fs::create_dir_all(&dir).unwrap();
    let new = new_update_file(NEW_VERSION, &UPDATE_TARGET);
    let mut bad_crc = new.clone();
    let last = bad_crc.len() - 1;
    bad_crc[last] ^= 0x01;
    let (good, bad) = (dir.join("analog-io.efw"), dir.join("bad-crc.efw"));
    std::fs::write(&good, &new).unwrap();
    std::fs::write(&bad, &bad_crc).unwrap();
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scripts/pysoem_update.py");
    let args = vec![good.into_os_string(), bad.into_os_string()];
    // Wall time, bounded even if the script hangs.
    let o = std::thread::spawn(move || {
        run_script_against_image(script, args, "iface-pysoem-update.pcap", 180.0)
    })
    .join()
    .expect("namespace thread")
    .unwrap();
    for l in &o.lines {
        eprintln!("pysoem: {l}");
    }
    assert!(
        o.script_ok,
        "pysoem failed: {:?}\n{}\n{}",
        o.lines, o.stderr, o.facts
    );
    assert!(o.clean, "{}", o.facts);
    let version = |name| steps(&o.lines, name).next().map(|l| l["version"].clone());
    assert_eq!(
        version("version before"),
        Some(NAMES.software_version.into())
    );
    let writes: Vec<(&Value, &Value)> = steps(&o.lines, "foe write")
        .map(|l| (&l["file"], &l["accepted"]))
        .collect();
    assert_eq!(
        writes,
        [
            (&Value::from("bad-crc.efw"), &Value::from(false)),
            (&Value::from("analog-io.efw"), &Value::from(true))
        ]
    );
    assert_eq!(version("version after"), Some(NEW_VERSION.into()));
    tshark::assert_clean(&o.pcap);
}
