//! SYSTEM TEST: a firmware update by an independent master, SOEM through pysoem
//! (`tests/scripts/pysoem_update.py`, the steps of SOEM's `firm_update`), of the module as
//! shipped ([`virtual_board::rig::module_cpu::ModuleCpu`]) served on one end of a veth pair
//! ([`virtual_board::tools::iface`]).
//!
//! Needs root (network namespaces, raw sockets), `ip` (iproute2), python3 with pysoem (the
//! project's setup installs it) and tshark, so it is ignored by default; `cargo xtask test`
//! runs it explicitly when it runs as root, and it fails, naming what is missing, when it
//! cannot run. As in `system_iface_veth.rs`, everything happens in a private network
//! namespace of the test's own thread.

use firmware::platform::boot::header::Target;
use firmware::products::analog_io::identity::UPDATE_TARGET;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use virtual_board::models::adc::T_CYC_NS;
use virtual_board::rig::board::{BoardConfig, VirtualBoard};
use virtual_board::rig::module_cpu::{update_file, ModuleCpu, SharedFlash};
use virtual_board::tools::iface::{ip, pysoem_missing, veth_pair_in_new_namespace};
use virtual_board::tools::iface::{serve, RawSocket, ServeOptions};
use virtual_board::tools::sim::{firmware_device, tshark};

/// The files the script writes: the refused ones first, the good one last.
fn files(dir: &Path) -> (PathBuf, Vec<PathBuf>) {
    let good = update_file(25_000, &UPDATE_TARGET, "3.0.0");
    let other_board = Target {
        board: UPDATE_TARGET.board ^ 0x10,
        ..UPDATE_TARGET
    };
    let mut bad_crc = good.clone();
    bad_crc[5_000] ^= 1;
    let bad = [
        (
            "other-board.efw",
            update_file(25_000, &other_board, "3.0.0"),
        ),
        ("bad-crc.efw", bad_crc),
        ("truncated.efw", good[..good.len() - 3_000].to_vec()),
        ("analog-io.bin", good.clone()),
    ];
    std::fs::create_dir_all(dir).unwrap();
    let write = |name: &str, data: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, data).unwrap();
        p
    };
    let bad = bad.iter().map(|(n, d)| write(n, d)).collect();
    (write("analog-io-3.0.0.efw", &good), bad)
}

/// What the board thread saw.
struct Board {
    frames: u64,
    version: Option<String>,
    boot_requests: u32,
    installs: usize,
    violations: Vec<String>,
    pcap: Vec<u8>,
}

struct Outcome {
    board: Board,
    script_ok: bool,
    lines: Vec<serde_json::Value>,
}

fn run_in_namespace(good: PathBuf, bad: Vec<PathBuf>) -> Result<Outcome, String> {
    veth_pair_in_new_namespace("vb0", "vb1")?;

    let stop = Arc::new(AtomicBool::new(false));
    let board_stop = stop.clone();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let board_thread = std::thread::spawn(move || {
        let sock = RawSocket::open("vb1").map_err(|e| e.to_string())?;
        let device = firmware_device::device()?;
        let mut board = VirtualBoard::new(BoardConfig::new(device.sii.clone()));
        let flash = SharedFlash::with_application(&update_file(20_000, &UPDATE_TARGET, "1.0.0"));
        let cpu = ModuleCpu::new(board.io(), device, T_CYC_NS, flash.clone());
        let log = cpu.log();
        board.set_cpu(Box::new(cpu));
        ready_tx.send(()).ok();
        let opts = ServeOptions {
            // Bounded even if the script never finishes.
            duration: Some(Duration::from_secs(120)),
            ..Default::default()
        };
        let stats =
            serve(&mut board, &sock, &board_stop, &opts, &mut |_| {}).map_err(|e| e.to_string())?;
        let log = log.borrow();
        Ok::<_, String>(Board {
            frames: stats.frames,
            version: flash
                .application(&firmware::products::analog_io::BOARD)
                .and_then(|h| h.version_str().map(str::to_owned)),
            boot_requests: log.boot_requests,
            installs: log.startups.iter().filter(|s| s.installed).count(),
            violations: flash.violations(),
            pcap: board.pcap().unwrap().bytes().to_vec(),
        })
    });
    ready_rx
        .recv_timeout(Duration::from_secs(5))
        .map_err(|_| "the board thread did not start".to_string())?;

    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/pysoem_update.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg("vb0")
        .arg(&good)
        .args(&bad)
        .output()
        .map_err(|e| format!("python3: {e}"));
    stop.store(true, Ordering::Relaxed);
    let board = board_thread
        .join()
        .map_err(|_| "the board thread panicked".to_string())??;
    let out = out?;
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    let lines = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).map_err(|e| format!("script output {l:?}: {e}")))
        .collect::<Result<Vec<_>, _>>()?;
    let _ = ip("link del vb0");
    Ok(Outcome {
        board,
        script_ok: out.status.success(),
        lines,
    })
}

#[test]
#[ignore = "needs root, iproute2, pysoem and tshark: `cargo xtask test` runs it as root"]
fn pysoem_updates_the_module_over_a_veth_pair() {
    if let Some(why) = pysoem_missing() {
        panic!("this test cannot run here: {why}");
    }
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("pysoem-update");
    let (good, bad) = files(&dir);
    let o = std::thread::spawn(move || run_in_namespace(good, bad))
        .join()
        .expect("namespace thread")
        .unwrap();
    for l in &o.lines {
        eprintln!("pysoem: {l}");
    }
    let step = |name: &'static str| o.lines.iter().filter(move |l| l["step"] == name);
    assert!(o.script_ok, "the script reported a failure");
    let writes: Vec<_> = step("foe write")
        .map(|l| {
            (
                l["file"].as_str().unwrap().to_owned(),
                l["accepted"] == true,
            )
        })
        .collect();
    assert_eq!(
        writes,
        [
            ("other-board.efw".to_owned(), false),
            ("bad-crc.efw".to_owned(), false),
            ("truncated.efw".to_owned(), false),
            ("analog-io.bin".to_owned(), false),
            ("analog-io-3.0.0.efw".to_owned(), true),
        ]
    );
    let back = step("back").next().expect("the module came back");
    assert_eq!(back["found"], 1);
    assert_eq!(o.board.version.as_deref(), Some("3.0.0"));
    assert_eq!((o.board.boot_requests, o.board.installs), (1, 1));
    assert_eq!(o.board.violations, Vec::<String>::new());
    eprintln!("board answered {} frames over vb1", o.board.frames);
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("system-update-pysoem.pcap");
    std::fs::write(&path, &o.board.pcap).unwrap();
    tshark::assert_clean(&path);
}
