//! SYSTEM TEST: coe-core's CANopen master against slaves nobody here wrote, several at once
//! on the virtual CAN bus, through the board's socketcand server (wall-clock time):
//! - three durand nodes (PyPI durand, a pure-Python CANopen slave), 10..12;
//! - python-canopen's LocalNode with the glue it needs (`tests/python/can_slaves.py`), 20;
//! - the project's own node: the firmware's CAN node on the virtual board, 5, guarded by
//!   RTR (python-can's socketcand interface carries no remote frames, so guarding runs
//!   against the in-process node only);
//! - node 30, configured as mandatory and absent.
//!
//! Checked: the boot with the identity check and the remote PDO configuration, which each
//! third-party node then reports itself (its own reading of what the master wrote); every
//! present node operational and node 30 reported with CiA 302's letter B; data both ways
//! through each node's own PDOs; an Emergency of a durand node; a durand node lost (its
//! connection closed: heartbeat) and taken back when it comes again; the firmware's node
//! lost by guarding when its transceiver breaks (bus-off) and taken back after recovery.
//!
//! Needs python3 with durand, canopen and python-can (PyPI), so it is ignored by default;
//! `cargo xtask test` runs it (its setup installs them).

use coe_core::canopen::master::boot::BootError;
use coe_core::canopen::master::config::{
    Identity, MasterConfig, NodeConfig, PdoConfig, StartupSdo,
};
use coe_core::canopen::master::events::{LossCause, MasterEvent};
use coe_core::canopen::master::NodePhase;
use coe_core::pdo::PdoEntry;
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};
use virtual_board::models::can::{ErrorState, PortFault};
use virtual_board::rig::board::VirtualBoard;
use virtual_board::rig::master_host::{MasterOnBus, TestMaster};
use virtual_board::tools::sim;
use virtual_board::tools::socketcand::SocketcandServer;

const FIRMWARE: u8 = 5;
const DURAND: [u8; 3] = [10, 11, 12];
const LOCAL: u8 = 20;
const ABSENT: u8 = 30;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn python() -> Result<(), String> {
    let out = Command::new("python3")
        .args(["-c", "import durand, canopen, can"])
        .output()
        .map_err(|e| format!("python3 cannot be started ({e})"))?;
    if !out.status.success() {
        return Err(format!(
            "python3 lacks durand, canopen or python-can (`cargo xtask setup` installs them): {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(())
}

/// 8 bytes in at 0x2000, 8 out at 0x2100, on every SYNC; heartbeat.
fn python_node(node: u8) -> NodeConfig {
    let bytes =
        |index: u16| -> Vec<PdoEntry> { (1..=8).map(|s| PdoEntry::new(index, s, 8)).collect() };
    let mut n = NodeConfig::new(node);
    n.identity = Identity {
        device_type: 0x000F_0191,
        vendor_id: 0x0000_ABCD,
        product_code: 0x1000 + u32::from(node),
        revision: 1,
        serial: u32::from(node),
    };
    n.mandatory = true;
    n.tpdo[0] = Some(PdoConfig::new(
        1,
        0x180 + u16::from(node),
        1,
        &bytes(0x2000),
    ));
    n.rpdo[0] = Some(PdoConfig::new(
        1,
        0x200 + u16::from(node),
        1,
        &bytes(0x2100),
    ));
    n.heartbeat_producer_ms = 100;
    n.heartbeat_consumer_ms = 500;
    n
}

/// The firmware's node: the CiA 401 analog inputs 1..4 in, the two outputs out; guarded.
fn firmware_node() -> NodeConfig {
    let mut n = NodeConfig::new(FIRMWARE);
    n.identity.device_type = 0x000C_0191;
    n.mandatory = true;
    n.disable_unused_pdos = true;
    n.tpdo[0] = Some(PdoConfig::new(
        2,
        0x280 + u16::from(FIRMWARE),
        1,
        &(1..=4)
            .map(|s| PdoEntry::new(0x6401, s, 16))
            .collect::<Vec<_>>(),
    ));
    n.rpdo[0] = Some(PdoConfig::new(
        2,
        0x300 + u16::from(FIRMWARE),
        1,
        &[PdoEntry::new(0x6411, 1, 16), PdoEntry::new(0x6411, 2, 16)],
    ));
    n.guard_time_ms = 50;
    n.life_time_factor = 3;
    // 0x2002 = 1: CAN drives the outputs (EtherCAT does by default).
    n.push_startup(StartupSdo {
        index: 0x2002,
        sub: 0,
        size: 1,
        value: 1,
    });
    n
}

/// The board, the socketcand server, the master, the Python slaves.
struct Rig {
    board: VirtualBoard,
    server: SocketcandServer,
    master: MasterOnBus,
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<String>,
    seen: Vec<String>,
    start: Instant,
    t0: u64,
}

impl Rig {
    fn now_us(&self) -> u64 {
        self.board.now_ns() / 1000
    }

    /// Brings the board up to the wall clock and serves everyone once.
    fn serve(&mut self) {
        let wall = self.t0 + self.start.elapsed().as_nanos() as u64;
        if self.board.now_ns() + 500_000 > wall {
            self.server.wait(Duration::from_micros(500));
        }
        let wall = self.t0 + self.start.elapsed().as_nanos() as u64;
        // At most 20 ms per call, in steps of 0.5 ms: the master sees the bus often.
        for _ in 0..40 {
            if self.board.now_ns() >= wall {
                break;
            }
            let step = (wall - self.board.now_ns()).min(500_000);
            self.board.step(step);
            self.bus_round();
        }
        self.bus_round();
        while let Ok(l) = self.lines.try_recv() {
            self.seen.push(l);
        }
    }

    fn bus_round(&mut self) {
        let bus = self.board.can().clone();
        self.server.serve(&mut bus.borrow_mut());
        let now = self.board.now_ns();
        self.master.service(&mut bus.borrow_mut(), now);
    }

    fn say(&mut self, line: &str) {
        writeln!(self.stdin, "{line}").unwrap();
        self.stdin.flush().unwrap();
    }

    /// Serves until `done` holds; panics naming `what` after `secs`.
    fn until(&mut self, what: &str, secs: u64, mut done: impl FnMut(&mut Rig) -> bool) {
        let end = Instant::now() + Duration::from_secs(secs);
        while !done(self) {
            if Instant::now() > end {
                let events: Vec<String> = self
                    .master
                    .events
                    .iter()
                    .map(|(t, e)| format!("{:.3} s {e:?}", *t as f64 / 1e9))
                    .collect();
                let phases: Vec<String> = (0..6)
                    .map(|s| format!("{s}: {:?}", self.master.master.phase(s)))
                    .collect();
                let _ = self.child.kill();
                panic!(
                    "timed out waiting for {what}\nphases {phases:?}\nevents:\n{}\npython:\n{}",
                    events.join("\n"),
                    self.seen.join("\n")
                );
            }
            self.serve();
        }
    }

    fn events_since(&self, from: usize) -> Vec<MasterEvent> {
        self.master.events_since(from)
    }
}

#[test]
#[ignore = "needs python3 with durand, canopen and python-can; cargo xtask test installs and runs them"]
fn the_master_runs_durand_python_canopen_and_the_firmware_node() {
    python().unwrap();
    let target =
        sim::firmware_target_of(&firmware::products::analog_io_can::PRODUCT, FIRMWARE).unwrap();
    let board = target.into_board(|b| b.capture = false);
    let server = SocketcandServer::bind(0).unwrap();
    let mut places = [NodeConfig::EMPTY; 16];
    places[0] = firmware_node();
    for (i, n) in DURAND.iter().enumerate() {
        places[1 + i] = python_node(*n);
    }
    places[4] = python_node(LOCAL);
    places[5] = python_node(ABSENT);
    let cfg = MasterConfig {
        sync_period_us: 20_000,
        sdo_timeout_ms: 500,
        boot_wait_ms: 1_000,
        retry_ms: 2_000,
        heartbeat_ms: 0,
        ..MasterConfig::default()
    };
    let master = MasterOnBus::attach(
        &mut board.can().borrow_mut(),
        TestMaster::new(cfg, places).unwrap(),
    );
    let durand: Vec<String> = DURAND.iter().map(|n| n.to_string()).collect();
    let mut child = Command::new("python3")
        .arg(repo().join("python/can_slaves.py"))
        .env("CAN_PORT", server.port().to_string())
        .env("DURAND", durand.join(","))
        .env("LOCAL", LOCAL.to_string())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let stdin = child.stdin.take().unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, lines) = mpsc::channel();
    std::thread::spawn(move || {
        for l in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(l).is_err() {
                break;
            }
        }
    });
    let t0 = board.now_ns();
    let mut rig = Rig {
        board,
        server,
        master,
        child,
        stdin,
        lines,
        seen: Vec::new(),
        start: Instant::now(),
        t0,
    };
    rig.until("the Python slaves", 60, |r| {
        r.seen.iter().any(|l| l == "READY")
    });

    // Boot: every present node operational, the absent mandatory one with B.
    let boot_start = rig.now_us();
    rig.master.master.start(boot_start);
    rig.until("five nodes operational and node 30's error", 60, |r| {
        r.master.master.operational() == 5
            && r.master.master.last_boot_error(5) == Some(BootError::NoDeviceType)
    });
    println!(
        "boot of 5 nodes (3 durand, python-canopen LocalNode, firmware) in {:.0} ms of bus time",
        (rig.now_us() - boot_start) as f64 / 1e3
    );
    let events = rig.events_since(0);
    let letters: Vec<(u8, char)> = events
        .iter()
        .filter_map(|e| match e {
            MasterEvent::BootError { node, error, .. } => Some((*node, error.letter())),
            _ => None,
        })
        .collect();
    assert!(letters.iter().all(|l| *l == (ABSENT, 'B')), "{events:?}");
    assert_eq!(
        rig.master.master.phase(5),
        Some(NodePhase::Failed(BootError::NoDeviceType, None))
    );
    assert!(
        !rig.master.master.all_mandatory_operational(),
        "node 30 is mandatory"
    );

    // The third-party nodes report the PDO configuration the master wrote.
    for n in DURAND.iter().copied().chain([LOCAL]) {
        rig.say(&format!("DUMP {n}"));
        let done = format!("DUMPED {n}");
        rig.until("the PDO dump", 20, |r| r.seen.contains(&done));
        let prefix = format!("PDO {n} ");
        let dump: BTreeMap<String, u32> = rig
            .seen
            .iter()
            .filter_map(|l| l.strip_prefix(&prefix))
            .filter_map(|kv| {
                let (k, v) = kv.split_once('=')?;
                Some((
                    k.to_string(),
                    u32::from_str_radix(v.trim_start_matches("0x"), 16).ok()?,
                ))
            })
            .collect();
        assert_eq!(
            dump["1800:1"] & 0x8000_07FF,
            0x180 + u32::from(n),
            "node {n}"
        );
        assert_eq!(dump["1800:2"], 1, "node {n}");
        assert_eq!(dump["1A00:0"], 8, "node {n}");
        assert_eq!(dump["1A00:3"], 0x2000_0308, "node {n}");
        assert_eq!(
            dump["1400:1"] & 0x8000_07FF,
            0x200 + u32::from(n),
            "node {n}"
        );
        assert_eq!(dump["1600:8"], 0x2100_0808, "node {n}");
    }

    // Data both ways: each Python node adds one to what it gets and sends it back.
    for slot in 1..=4 {
        let out: Vec<u8> = (0..8).map(|i| (slot * 16 + i) as u8).collect();
        rig.master.master.set_output(slot, 0, &out).unwrap();
    }
    rig.master
        .master
        .set_output(0, 0, &[0x34, 0x12, 0x00, 0x20])
        .unwrap();
    rig.until("the outputs back as inputs", 20, |r| {
        (1..=4).all(|slot| {
            let want: Vec<u8> = (0..8).map(|i| (slot * 16 + i + 1) as u8).collect();
            r.master.master.input(slot, 0) == Some(&want[..])
        }) && r.master.master.input(0, 0).is_some()
    });
    // The firmware's node took its outputs (read back over the master's SDO client).
    let from = rig.master.events.len();
    let now = rig.now_us();
    rig.master.master.sdo_upload(0, 0x6411, 2, now).unwrap();
    rig.until("the SDO upload", 10, |r| {
        r.events_since(from)
            .iter()
            .any(|e| matches!(e, MasterEvent::SdoDone { .. }))
    });
    assert_eq!(rig.master.master.sdo_data(0), &[0x00, 0x20]);

    // An Emergency of durand node 12.
    let from = rig.master.events.len();
    rig.say("EMCY 12");
    rig.until("node 12's Emergency", 10, |r| {
        r.events_since(from)
            .iter()
            .any(|e| matches!(e, MasterEvent::Emergency { node: 12, emergency, .. } if emergency.error_code == 0x1000))
    });

    // Durand node 11 goes away (heartbeat loss) and comes again (boot-up, configured
    // again, operational).
    let from = rig.master.events.len();
    let t_kill = rig.now_us();
    rig.say("KILL 11");
    rig.until("node 11 lost", 10, |r| {
        r.events_since(from).contains(&MasterEvent::NodeLost {
            slot: 2,
            node: 11,
            cause: LossCause::Heartbeat,
        })
    });
    println!(
        "durand node 11 lost {:.0} ms after its connection closed (consumer time 500 ms)",
        (rig.now_us() - t_kill) as f64 / 1e3
    );
    rig.say("REVIVE 11");
    rig.until("node 11 back", 30, |r| {
        r.events_since(from)
            .contains(&MasterEvent::NodeReturned { slot: 2, node: 11 })
    });
    rig.until("node 11's data again", 10, |r| {
        let want: Vec<u8> = (0..8).map(|i| (2 * 16 + i + 1) as u8).collect();
        r.master.master.input_stats(2, 0).unwrap().received > 0
            && r.master.master.input(2, 0) == Some(&want[..])
    });

    // The firmware's node: its transceiver breaks, it goes bus-off, guarding loses it; the
    // transceiver mended and the controller recovered, guarding finds it again.
    let from = rig.master.events.len();
    let port = rig.board.io().can.port;
    rig.board
        .can()
        .borrow_mut()
        .set_fault(port, Some(PortFault::Corrupt));
    rig.until("node 5 lost by guarding", 20, |r| {
        r.events_since(from).contains(&MasterEvent::NodeLost {
            slot: 0,
            node: FIRMWARE,
            cause: LossCause::Guarding,
        })
    });
    assert_eq!(
        rig.board.can().borrow().error_state(port),
        ErrorState::BusOff
    );
    {
        let bus = rig.board.can().clone();
        let mut bus = bus.borrow_mut();
        bus.set_fault(port, None);
        bus.recover(port);
    }
    rig.until("node 5 back", 20, |r| {
        r.events_since(from).contains(&MasterEvent::NodeReturned {
            slot: 0,
            node: FIRMWARE,
        })
    });
    assert_eq!(rig.master.master.operational(), 5);

    rig.say("QUIT");
    let status = rig.child.wait().unwrap();
    assert!(status.success(), "the Python slaves failed: {status}");
    let stats = rig.master.master.stats();
    println!(
        "master: {} frames received, {} SYNCs, {} RPDOs, {} events dropped",
        stats.received,
        stats.syncs,
        stats.rpdos,
        rig.master.master.events_dropped()
    );
}
