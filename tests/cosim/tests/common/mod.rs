//! What the co-simulator's system tests share.
#![allow(dead_code)]

use ethercrab::{std::ethercat_now, PduStorage, SubDeviceState};
use firmware::platform::boot::header::{HeaderRepr, Target as UpdateTarget};
use firmware::platform::boot::layout::HEADER_BLOCK;
use firmware::products::Product;
use futures_lite::future::{block_on, or};
use lpc1754_cosim::bench::{al_status, master, step_to, Board};
use lpc1754_cosim::cosim::Options;
use lpc1754_cosim::run::{image_path_of, image_target, load_image, load_image_of, CosimHandle};
use serde_json::Value;
use std::cell::RefCell;
use std::ffi::OsString;
use std::path::PathBuf;
use std::process::Command;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use virtual_board::models::dac::DacUpdate;
use virtual_board::rig::master::tx_rx_task;
use virtual_board::tools::iface::{veth_pair_in_new_namespace, Lag, ServeStats};
use virtual_board::tools::sim::{self, Line, SimConfig, Target};

/// What a master script did against the image served on a veth pair.
pub struct ScriptRun {
    /// Frames the board answered.
    pub served: u64,
    /// The script's exit status was 0.
    pub script_ok: bool,
    /// Its JSON lines.
    pub lines: Vec<Value>,
    /// Its stderr.
    pub stderr: String,
    /// The co-simulator's summary.
    pub facts: String,
    /// No fault and no report from the co-simulator.
    pub clean: bool,
    /// The capture of the run.
    pub pcap: PathBuf,
    /// Every load of a DAC register on the board, in order.
    pub dac_updates: Vec<DacUpdate>,
    /// How far the board's CPU ran behind the wall clock, over its virtual time.
    pub lag: Lag,
}

/// A master script: `python3 PATH vb0 ARGS`.
pub struct Script {
    /// The script.
    pub path: PathBuf,
    /// Its arguments after the interface.
    pub args: Vec<OsString>,
}

/// What one script did.
pub struct ScriptOutcome {
    /// Its exit status was 0.
    pub ok: bool,
    /// Its JSON lines.
    pub lines: Vec<Value>,
    /// Its stderr.
    pub stderr: String,
}

/// Scripts run one after the other against one board on a veth pair.
pub struct BoardRun {
    /// Each script's outcome, in order.
    pub scripts: Vec<ScriptOutcome>,
    /// The board's side: frames, answer latency, lag behind the wall clock.
    pub served: ServeStats,
    /// The capture of the run.
    pub pcap: PathBuf,
    /// Every load of a DAC register on the board, in order.
    pub dac_updates: Vec<DacUpdate>,
}

/// Serves `target` on vb1 of a veth pair in a new network namespace (of the calling thread),
/// as `cargo xtask sim --iface vb1` does, and runs each of `scripts` as `python3 SCRIPT vb0
/// ARGS`, one after the other (up to the first that fails), once the board answers; the capture goes to `pcap_name` in
/// the test's temporary directory. Bounded in wall time (the board by `seconds`, the
/// masters' start by a minute).
pub fn run_scripts_on_veth(
    target: Target,
    scripts: Vec<Script>,
    pcap_name: &str,
    seconds: f64,
) -> Result<BoardRun, String> {
    run_scripts_on_veth_with(target, scripts, pcap_name, seconds, Serving::default())
}

/// How many times slower than the wall clock the board runs under SOEM's veth tests (the
/// LPC1754 and STM32 images, SOES). The images boot by checking their application's CRC
/// and answer SDO Information at full load, SOES polls the ESC over its SPI, and the
/// co-simulator does not keep up with real time there on every 2-core host (the board fell
/// 50-114 ms behind, and SOEM's working counter failed at SAFE-OP). SOEM's timeouts stay
/// wall time, so the mailbox answers are, if anything, later for it.
pub const BOARD_SLOWDOWN: u32 = 4;

/// How the board is served to the scripts, beyond what every run does.
#[derive(Clone, Copy, Debug)]
pub struct Serving {
    /// Constant voltages at the analog inputs where given ([`SimConfig::ai_levels_v`]).
    pub ai_levels_v: [Option<f64>; 8],
    /// The board's clock this many times slower than the wall clock
    /// ([`SimConfig::slowdown`]).
    pub slowdown: u32,
}

impl Default for Serving {
    fn default() -> Self {
        Self {
            ai_levels_v: [None; 8],
            slowdown: 1,
        }
    }
}

/// [`run_scripts_on_veth`], the board served as `serving` says.
pub fn run_scripts_on_veth_with(
    target: Target,
    scripts: Vec<Script>,
    pcap_name: &str,
    seconds: f64,
    serving: Serving,
) -> Result<BoardRun, String> {
    veth_pair_in_new_namespace("vb0", "vb1")?;
    let pcap = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(pcap_name);
    let cfg = SimConfig {
        iface: Some("vb1".into()),
        seconds: Some(seconds),
        pcap: Some(pcap.clone()),
        ai_levels_v: serving.ai_levels_v,
        slowdown: serving.slowdown,
        ..Default::default()
    };
    let ready = Arc::new(AtomicBool::new(false));
    let stop = Arc::new(AtomicBool::new(false));
    let (ready2, stop2) = (ready.clone(), stop.clone());
    // The masters in their own processes, started once the board answers on vb1.
    let masters = std::thread::spawn(move || {
        let deadline = Instant::now() + Duration::from_secs(60);
        while !ready2.load(Ordering::Acquire) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        // Each script starts from where the one before left the board: after a failed one
        // the others are not run.
        let mut outs = Vec::new();
        for s in &scripts {
            let out = Command::new("python3")
                .arg(&s.path)
                .arg("vb0")
                .args(&s.args)
                .output();
            let failed = !matches!(&out, Ok(o) if o.status.success());
            outs.push(out);
            if failed {
                break;
            }
        }
        stop2.store(true, Ordering::Release);
        outs
    });
    let served = sim::run_wall_clock(&cfg, target, &stop, &mut |l| {
        if let Line::Result(s) = l {
            if s.contains("waiting for frames") {
                ready.store(true, Ordering::Release);
            }
        }
    })
    .map_err(|e| e.to_string())?;
    let outs = masters
        .join()
        .map_err(|_| "the masters' thread panicked".to_string())?;
    let scripts = outs
        .into_iter()
        .map(|o| {
            let o = o.map_err(|e| format!("python3: {e}"))?;
            Ok(ScriptOutcome {
                ok: o.status.success(),
                lines: String::from_utf8_lossy(&o.stdout)
                    .lines()
                    .filter_map(|l| serde_json::from_str(l).ok())
                    .collect(),
                stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
            })
        })
        .collect::<Result<_, String>>()?;
    Ok(BoardRun {
        scripts,
        served: served.ecat,
        pcap,
        dac_updates: served.dac_updates,
    })
}

/// [`run_scripts_on_veth`] with the default product's release image and one script, with
/// the co-simulator's facts.
pub fn run_script_against_image(
    script: PathBuf,
    args: Vec<OsString>,
    pcap_name: &str,
    seconds: f64,
) -> Result<ScriptRun, String> {
    run_script_against(
        || image_target(load_image()?, Options::default()),
        script,
        vec![args],
        pcap_name,
        seconds,
    )
}

/// [`run_script_against_image`] on `product`'s release image, the script run once per
/// entry of `runs` (its arguments after the interface), one after the other against the
/// same board; the lines of all runs, in order, and `script_ok` when every run exited 0.
pub fn run_script_against_image_of(
    product: &str,
    script: PathBuf,
    runs: Vec<Vec<OsString>>,
    pcap_name: &str,
    seconds: f64,
) -> Result<ScriptRun, String> {
    run_script_against(
        || image_target(load_image_of(product)?, Options::default()),
        script,
        runs,
        pcap_name,
        seconds,
    )
}

/// The script run once per entry of `runs` against any program on the co-simulator
/// (`target` makes it the board's CPU: a product's release image, or a peer such as SOES).
pub fn run_script_against(
    target: impl FnOnce() -> Result<(Target, CosimHandle), String>,
    script: PathBuf,
    runs: Vec<Vec<OsString>>,
    pcap_name: &str,
    seconds: f64,
) -> Result<ScriptRun, String> {
    run_script_against_with(target, script, runs, pcap_name, seconds, Serving::default())
}

/// [`run_script_against`], the board served as `serving` says.
pub fn run_script_against_with(
    target: impl FnOnce() -> Result<(Target, CosimHandle), String>,
    script: PathBuf,
    runs: Vec<Vec<OsString>>,
    pcap_name: &str,
    seconds: f64,
    serving: Serving,
) -> Result<ScriptRun, String> {
    let (target, handle) = target()?;
    let expected = runs.len();
    let scripts = runs
        .into_iter()
        .map(|args| Script {
            path: script.clone(),
            args,
        })
        .collect();
    let run = run_scripts_on_veth_with(target, scripts, pcap_name, seconds, serving)?;
    let facts = handle
        .with(|c| c.facts())
        .ok_or("the co-simulator did not start")?;
    Ok(ScriptRun {
        served: run.served.frames,
        script_ok: run.scripts.len() == expected && run.scripts.iter().all(|s| s.ok),
        lines: run.scripts.iter().flat_map(|s| s.lines.clone()).collect(),
        stderr: run.scripts.iter().map(|s| s.stderr.as_str()).collect(),
        clean: facts.fault.is_none() && facts.reports.is_empty(),
        // The board's side too: a master's timeout after a quick answer was the host's.
        facts: format!(
            "{}\nboard: answers {}; lag behind the wall clock {}",
            facts.summary(),
            run.served.latency.summary("frames"),
            run.served.lag.summary(run.served.elapsed)
        ),
        pcap: run.pcap,
        dac_updates: run.dac_updates,
        lag: run.served.lag,
    })
}

/// The default product's release update file with the software version string replaced by
/// `version` wherever its image holds it, and a header made for the new image and `target`.
pub fn new_update_file(version: &str, target: &UpdateTarget) -> Vec<u8> {
    new_update_file_of(firmware::products::default(), version, target)
}

/// [`new_update_file`] from `product`'s release update file.
pub fn new_update_file_of(product: &Product, version: &str, target: &UpdateTarget) -> Vec<u8> {
    let path = image_path_of(product.name).with_extension("efw");
    let efw = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let old = product.device.names.software_version.as_bytes();
    assert_eq!(old.len(), version.len());
    let mut image = efw[HEADER_BLOCK as usize..].to_vec();
    let at: Vec<usize> = image
        .windows(old.len())
        .enumerate()
        .filter(|(_, w)| *w == old)
        .map(|(i, _)| i)
        .collect();
    // 0x100A, and the module description (0x2001) that names it.
    assert_eq!(at.len(), 2, "where the image holds its version");
    for a in at {
        image[a..a + old.len()].copy_from_slice(version.as_bytes());
    }
    let mut file = HeaderRepr::for_image(&image, target, version)
        .to_bytes()
        .to_vec();
    file.extend_from_slice(&image);
    file
}

/// The product on the STM32F103 board (issue 30).
pub fn stm32_product() -> &'static Product {
    firmware::products::PRODUCTS
        .iter()
        .copied()
        .find(|p| p.board.mcu() == firmware::platform::board::Mcu::Stm32f103vc)
        .expect("an STM32F103 product")
}

/// Boots `product`'s image, reads its identity (SII and SDO) and walks it to OP; the DAC code
/// of AO 1 after `value` went out in the process data, and the board. The core did not fault
/// and no model reported a problem.
pub fn boot_to_op(product: &'static Product, value: i16) -> (u16, Board) {
    let image = load_image_of(product.name).expect("the product's release image");
    assert_eq!(
        image.product().map(|p| p.name),
        Some(product.name),
        "the update file in the slot is the product's"
    );
    let (target, handle) = image_target(image, Options::default()).expect("boot ROM checks");
    let board = Rc::new(RefCell::new(target.into_board(|_| {})));
    let storage = Box::new(PduStorage::new());
    let (md, tx, rx) = master(&storage).unwrap();
    let names = product.device.names;
    let identity = product.device.identity;
    block_on(or(
        async {
            let group = md
                .init_single_group::<2, 64>(ethercat_now)
                .await
                .expect("init");
            {
                let sd = group.subdevice(&md, 0).unwrap();
                assert_eq!(sd.status().await.unwrap().0, SubDeviceState::PreOp);
                assert_eq!(sd.name(), names.order_code, "SII name");
                assert_eq!(sd.identity().product_id, identity.product_code, "SII");
                assert_eq!(
                    sd.sdo_read::<u32>(0x1018, 2).await.unwrap(),
                    identity.product_code,
                    "the running application's 0x1018:02"
                );
                let name: heapless::String<64> = sd.sdo_read(0x1008, 0).await.unwrap();
                assert_eq!(name.as_str(), names.device_name);
                // The CANopen objects are the CAN product's alone.
                let heartbeat = sd.sdo_read::<u16>(0x1017, 0).await;
                assert_eq!(heartbeat.is_ok(), product.can.is_some(), "0x1017");
            }
            let group = group.into_op(&md).await.expect("OP");
            for _ in 0..50 {
                {
                    let sd = group.subdevice(&md, 0).unwrap();
                    let mut o = sd.outputs_raw_mut();
                    o[..2].copy_from_slice(&value.to_le_bytes());
                }
                group.tx_rx(&md).await.expect("cycle");
                let t = board.borrow().now_ns() + 1_000_000;
                step_to(&board, t);
            }
            assert_eq!(al_status(&board), (0x0008, 0), "OP, no error");
        },
        tx_rx_task(board.clone(), tx, rx),
    ));
    let facts = handle.with(|c| c.facts()).expect("co-simulator built");
    assert!(facts.fault.is_none(), "{}", facts.summary());
    assert!(facts.reports.is_empty(), "{}", facts.summary());
    let dac = {
        let b = board.borrow();
        assert_eq!(
            b.esc().borrow().spi_stats.errors,
            0,
            "ET1100 SPI protocol errors"
        );
        let dac = b.dac().borrow().dac[0];
        dac
    };
    (dac, board)
}

/// The line of a master script's step `name` (the scripts print one JSON object per step).
pub fn step<'a>(lines: &'a [Value], name: &str) -> &'a Value {
    lines
        .iter()
        .find(|l| l["step"] == name)
        .unwrap_or_else(|| panic!("no step {name} in {lines:?}"))
}

/// Runs a master script (`run`) and, when it failed after a cycle the master itself started
/// late (the host did not run it for a whole cycle: a void run, whatever the slave then did),
/// once more. A failure without a late cycle stands.
pub fn unless_the_master_was_late(run: impl Fn() -> ScriptRun) -> ScriptRun {
    let first = run();
    let late = first
        .lines
        .iter()
        .any(|l| l["step"] == "process_data" && l["late_cycles"].as_u64().is_some_and(|n| n > 0));
    if first.script_ok || !late {
        return first;
    }
    eprintln!("the master started a cycle late (the host stalled): the run is repeated once");
    run()
}

/// The pysoem master's process-data step: `cycles` exchanges, each with the expected working
/// counter, but for those on cycles the master itself started late (the host did not run it
/// for milliseconds: the exchange and SOEM's 2 ms receive timeout took more than a cycle).
pub fn assert_every_exchange_answered(pd: &Value, cycles: u32) {
    assert_eq!(pd["cycles"], cycles, "{pd}");
    let good = pd["good_wkc"].as_u64().unwrap_or(0);
    let late = pd["late_cycles"].as_u64().unwrap_or(0);
    assert!(
        good + late >= u64::from(cycles),
        "working counters missed on cycles that were not late: {pd}"
    );
}
