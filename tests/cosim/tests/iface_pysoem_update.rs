//! SYSTEM TEST: a firmware update of the release programs on the co-simulated LPC1754 by an
//! independent master in its own process, SOEM through pysoem (`tests/scripts/pysoem_update.py`,
//! the steps of SOEM's `firm_update`), over a veth pair as `cargo xtask sim --image --iface`
//! serves it: the application resets into the bootloader at INIT -> BOOT, a file with a bad
//! CRC and the CAN product's release file (the board lacks the CAN transceiver) are refused,
//! the release application with another version string is taken, and after BOOT -> INIT the
//! bootloader installs it and the new application answers 0x100A with the new version. On
//! the CAN product's image, files for another board and with a bad CRC are refused and the
//! old application answers afterwards; then its new version is taken and answers.
//!
//! Needs root (a network namespace, raw sockets), `ip` (iproute2), python3 with pysoem (the
//! project's setup installs it) and tshark, so it is ignored by default; `cargo xtask test`
//! runs it when it runs as root, and it fails, naming what is missing, when it cannot run.

mod common;

use common::{new_update_file, new_update_file_of, run_script_against_image_of, ScriptRun};
use firmware::platform::boot::header::Target;
use firmware::products::analog_io::identity::{IDENTITY, NAMES, UPDATE_TARGET};
use firmware::products::analog_io_can;
use lpc1754_cosim::run::image_path_of;
use serde_json::Value;
use std::ffi::OsString;
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
    let can = image_path_of(analog_io_can::PRODUCT.name).with_extension("efw");
    let args = vec![
        good.into_os_string(),
        bad.into_os_string(),
        can.into_os_string(),
    ];
    let o = run(
        firmware::products::default().name,
        vec![args],
        "iface-pysoem-update.pcap",
        180.0,
    );
    let version = |name| steps(&o.lines, name).next().map(|l| l["version"].clone());
    assert_eq!(
        version("version before"),
        Some(NAMES.software_version.into())
    );
    assert_eq!(
        writes(&o),
        [
            (&Value::from("bad-crc.efw"), &Value::from(false)),
            (&Value::from("analog-io-can.efw"), &Value::from(false)),
            (&Value::from("analog-io.efw"), &Value::from(true))
        ]
    );
    assert_eq!(version("version after"), Some(NEW_VERSION.into()));
    let product = |name| steps(&o.lines, name).next().map(|l| l["product"].clone());
    assert_eq!(product("version after"), Some(IDENTITY.product_code.into()));
    tshark::assert_clean(&o.pcap);
}

/// On the CAN product's image, two runs of the script against the same board: first a file
/// for another board and one with a bad CRC, each refused with an FoE error, and after
/// BOOT -> INIT the old application answers, its version and product code unchanged; then
/// the CAN product's release application with another version string is taken and
/// installed, and the new application answers.
#[test]
#[ignore = "needs root, iproute2 (ip), python3 with pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_updates_the_can_image_after_refused_files() {
    if let Some(why) = pysoem_missing() {
        panic!("this test cannot run here: {why}");
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("iface-pysoem-update-can");
    std::fs::create_dir_all(&dir).unwrap();
    let product = analog_io_can::PRODUCT;
    let target = analog_io_can::identity::UPDATE_TARGET;
    let new = new_update_file_of(&product, NEW_VERSION, &target);
    let mut bad_crc = new.clone();
    let last = bad_crc.len() - 1;
    bad_crc[last] ^= 0x01;
    let other_board = new_update_file_of(
        &product,
        NEW_VERSION,
        &Target {
            board: target.board + 1,
            ..target
        },
    );
    let write = |name: &str, data: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, data).unwrap();
        p.into_os_string()
    };
    let runs = vec![
        // "-": no file is to be taken.
        vec![
            "-".into(),
            write("other-board.efw", &other_board),
            write("bad-crc.efw", &bad_crc),
        ],
        vec![write("analog-io-can.efw", &new)],
    ];
    let o = run(product.name, runs, "iface-pysoem-update-can.pcap", 300.0);
    assert_eq!(
        writes(&o),
        [
            (&Value::from("other-board.efw"), &Value::from(false)),
            (&Value::from("bad-crc.efw"), &Value::from(false)),
            (&Value::from("analog-io-can.efw"), &Value::from(true)),
        ]
    );
    // SOEM's ec_FOEwrite answers -EC_ERR_TYPE_FOE_ERROR to the slave's FoE error.
    let results: Vec<&Value> = steps(&o.lines, "foe write").map(|l| &l["result"]).collect();
    assert_eq!(
        results[..2],
        [&Value::from(-5), &Value::from(-5)],
        "FoE errors"
    );
    let old = analog_io_can::identity::NAMES.software_version;
    let code = Value::from(analog_io_can::identity::IDENTITY.product_code);
    let seen: Vec<(&Value, &Value)> = o
        .lines
        .iter()
        .filter(|l| l["step"] == "version before" || l["step"] == "version after")
        .map(|l| (&l["version"], &l["product"]))
        .collect();
    assert_eq!(
        seen,
        [
            (&Value::from(old), &code),
            (&Value::from(old), &code),
            (&Value::from(old), &code),
            (&Value::from(NEW_VERSION), &code),
        ],
        "before and after the refused files, before and after the update"
    );
    tshark::assert_clean(&o.pcap);
}

/// The script run against `product`'s image once per entry of `runs`, in a thread of its
/// own (bounded in wall time even if the script hangs); every run exited 0 and the
/// co-simulator saw no fault and no report.
fn run(product: &'static str, runs: Vec<Vec<OsString>>, pcap: &str, seconds: f64) -> ScriptRun {
    let pcap = pcap.to_owned();
    let o = std::thread::spawn(move || {
        run_script_against_image_of(product, script(), runs, &pcap, seconds)
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
    o
}

/// The files written, each with whether the slave took it.
fn writes(o: &ScriptRun) -> Vec<(&Value, &Value)> {
    steps(&o.lines, "foe write")
        .map(|l| (&l["file"], &l["accepted"]))
        .collect()
}

fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scripts/pysoem_update.py")
}
