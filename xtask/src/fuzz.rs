//! `cargo xtask fuzz`: runs the cargo-fuzz targets of `tests/fuzz` for a while each and fails
//! on the first crash.
//!
//! cargo-fuzz passes nightly-only flags (the sanitizer, coverage instrumentation); on the pinned
//! stable toolchain `RUSTC_BOOTSTRAP=1` lets them through. Every target starts from its kept
//! corpus (`tests/fuzz/corpus/NAME`, not in git) plus seeds taken from the real-world vectors
//! next to the checkout (`../shared/vectors`: mailbox frames of TwinCAT and SOEM captures, SII
//! images of real devices) and from the firmware's own description, and the CAN targets from
//! the traffic of coe-core's master booting and running in-process slaves on the virtual bus;
//! the seeds are regenerated on every run into `target/fuzz/seeds`, never copied into the
//! repository.

use crate::setup;
use crate::util::{cargo, display, root, Result};
use coe_core::canopen::master::config::{Identity, MasterConfig, NodeConfig, PdoConfig};
use coe_core::canopen::CanFrame;
use coe_core::pdo::PdoEntry;
use coe_core::wire::{Mailbox, MailboxRepr};
use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use virtual_board::models::esc::{cmd, parse_frame};
use virtual_board::rig::can_slave::{InProcessSlave, SlaveIdentity};
use virtual_board::rig::master_host::{CanNetwork, TestMaster};
use virtual_board::tools::pcap::read_pcapng;

/// The fuzz crate (its own workspace).
const FUZZ_DIR: &str = "tests/fuzz";

/// Seconds one input may run before libFuzzer reports it as a hang.
const HANG_SECONDS: u32 = 10;

#[derive(clap::Args, Debug, Default)]
pub struct Args {
    /// Run only this target (repeat for several); default: every target of tests/fuzz.
    #[arg(long = "target", value_name = "NAME")]
    pub targets: Vec<String>,
    /// Seconds per target.
    #[arg(long, value_name = "N", default_value_t = 30)]
    pub seconds: u32,
    /// Print the targets and exit.
    #[arg(long)]
    pub list: bool,
}

/// What one target reached.
struct Outcome {
    target: String,
    executions: u64,
    corpus: usize,
    seconds: f64,
}

pub fn run(args: &Args) -> Result {
    setup::cargo_fuzz()?;
    let all = targets()?;
    if args.list {
        for t in &all {
            println!("{t}");
        }
        return Ok(());
    }
    let chosen: Vec<String> = if args.targets.is_empty() {
        all.clone()
    } else {
        for t in &args.targets {
            if !all.contains(t) {
                return Err(format!(
                    "no fuzz target `{t}` in {FUZZ_DIR} (there are: {})",
                    all.join(", ")
                ));
            }
        }
        args.targets.clone()
    };
    if args.seconds == 0 {
        return Err("--seconds must be at least 1".into());
    }
    let seeds = root().join("target/fuzz/seeds");
    write_seeds(&seeds)?;
    let mut outcomes = Vec::new();
    for target in &chosen {
        outcomes.push(run_target(target, args.seconds, &seeds.join(target))?);
    }
    println!("| target | executions | corpus | seconds |");
    println!("|---|---|---|---|");
    for o in &outcomes {
        println!(
            "| {} | {} | {} | {:.0} |",
            o.target, o.executions, o.corpus, o.seconds
        );
    }
    let total: u64 = outcomes.iter().map(|o| o.executions).sum();
    println!("{total} executions in total, no crash");
    Ok(())
}

/// The `[[bin]]` targets of the fuzz crate, as cargo-fuzz lists them.
fn targets() -> Result<Vec<String>> {
    let out = fuzz_command()
        .arg("list")
        .args(["--fuzz-dir", FUZZ_DIR])
        .output()
        .map_err(|e| format!("cannot run cargo fuzz list: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cargo fuzz list failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(String::from)
        .collect())
}

/// `cargo fuzz` with what it needs on the stable toolchain, built into the workspace's target
/// directory (one place to clean).
fn fuzz_command() -> Command {
    let mut cmd = cargo();
    cmd.arg("fuzz").env("RUSTC_BOOTSTRAP", "1");
    cmd
}

fn run_target(target: &str, seconds: u32, seeds: &Path) -> Result<Outcome> {
    let corpus = root().join(FUZZ_DIR).join("corpus").join(target);
    let artifacts = root().join(FUZZ_DIR).join("artifacts").join(target);
    let logs = root().join("target/fuzz/logs");
    for dir in [&corpus, &artifacts, &logs] {
        fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let log = logs.join(format!("{target}.log"));
    let mut cmd = fuzz_command();
    cmd.args([
        "run",
        "--fuzz-dir",
        FUZZ_DIR,
        "--target-dir",
        "target/fuzz/build",
    ])
    .arg(target)
    .arg(&corpus);
    if seeds.is_dir() {
        cmd.arg(seeds);
    }
    cmd.arg("--")
        .arg(format!("-max_total_time={seconds}"))
        // An input that runs this long is a hang (an unbounded wait): a failure.
        .arg(format!("-timeout={HANG_SECONDS}"))
        .arg(format!("-artifact_prefix={}/", artifacts.display()))
        .arg("-print_final_stats=1");
    eprintln!("$ {}  (log: {})", display(&cmd), log.display());
    let start = Instant::now();
    let output = cmd
        .output()
        .map_err(|e| format!("cannot start cargo fuzz: {e}"))?;
    let text = String::from_utf8_lossy(&output.stderr).into_owned();
    fs::write(&log, &text).map_err(|e| format!("{}: {e}", log.display()))?;
    if !output.status.success() {
        let tail: Vec<&str> = text.lines().rev().take(40).collect();
        for line in tail.iter().rev() {
            eprintln!("{line}");
        }
        return Err(format!(
            "fuzz target `{target}` failed ({}): the crashing input is in {} (whole log: {})",
            output.status,
            artifacts.display(),
            log.display()
        ));
    }
    let executions = final_stat(&text, "stat::number_of_executed_units:").ok_or_else(|| {
        format!(
            "fuzz target `{target}`: no final statistics in the log {}",
            log.display()
        )
    })?;
    Ok(Outcome {
        target: target.to_string(),
        executions,
        corpus: fs::read_dir(&corpus).map(|d| d.count()).unwrap_or(0),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The value of a `-print_final_stats` line.
fn final_stat(log: &str, key: &str) -> Option<u64> {
    log.lines()
        .rev()
        .find_map(|l| l.trim().strip_prefix(key))
        .and_then(|v| v.trim().parse().ok())
}

/// The real-world vectors next to the checkout, if present.
fn vectors() -> Option<PathBuf> {
    let dir = root().join("../shared/vectors");
    dir.is_dir().then_some(dir)
}

/// Writes the seed inputs of every target under `dir/TARGET/`.
fn write_seeds(dir: &Path) -> Result {
    let _ = fs::remove_dir_all(dir);
    let mut frames = MailboxFrames::default();
    let mut siis: Vec<Vec<u8>> = vec![firmware_sii()?];
    match vectors() {
        Some(v) => {
            for path in files(&v.join("captures"), "pcapng")? {
                let bytes = fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
                let packets = read_pcapng(&bytes)
                    .ok_or_else(|| format!("{}: not a pcapng capture", path.display()))?;
                frames.collect(&packets);
            }
            for path in files(&v.join("sii"), "bin")? {
                siis.push(fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?);
            }
        }
        None => eprintln!("note: no ../shared/vectors next to the checkout: seeds from the firmware's description only"),
    }
    eprintln!(
        "fuzz seeds: {} mailbox frames ({} requests) from the captures, {} SII images",
        frames.all.len(),
        frames.requests.len(),
        siis.len()
    );
    save(&dir.join("coe_wire_parsers"), frames.all.iter())?;
    save(&dir.join("coe_sdo_server"), frames.server_sessions().iter())?;
    save(&dir.join("slave_mailbox"), frames.master_sessions().iter())?;
    let can = CanTraffic::record();
    eprintln!(
        "fuzz seeds: {} CAN frames from the nodes, {} from the master",
        can.from_nodes.len(),
        can.from_master.len()
    );
    save(&dir.join("can_master"), can_stream(&can.from_nodes).iter())?;
    save(&dir.join("can_node"), can_stream(&can.from_master).iter())?;
    save(&dir.join("sii_reader"), siis.iter())
}

/// The CAN traffic of coe-core's master booting three in-process nodes (the configuration of
/// the `can_master` target: 2 and 4 synchronous with heartbeat, 3 event-driven and guarded)
/// and running them at 1 Mbit/s; the master's frames renumbered for node 5 (the `can_node`
/// target's node).
struct CanTraffic {
    from_nodes: Vec<(u64, CanFrame)>,
    from_master: Vec<(u64, CanFrame)>,
}

impl CanTraffic {
    fn record() -> Self {
        let node = |id: u8, transmission_type: u8| {
            let mut n = NodeConfig::new(id);
            n.identity = Identity {
                device_type: 0x0002_0192,
                vendor_id: 0x1234,
                ..Identity::default()
            };
            let entries = [PdoEntry::new(0x6041, 0, 16), PdoEntry::new(0x6064, 0, 32)];
            let outputs = [PdoEntry::new(0x6040, 0, 16), PdoEntry::new(0x607A, 0, 32)];
            let mut t = PdoConfig::new(1, 0x180 + u16::from(id), transmission_type, &entries);
            t.deadline_ms = 20;
            n.tpdo[0] = Some(t);
            let mut r = PdoConfig::new(1, 0x200 + u16::from(id), transmission_type, &outputs);
            r.event_timer_ms = 10;
            n.rpdo[0] = Some(r);
            n.heartbeat_producer_ms = 10;
            n.heartbeat_consumer_ms = 30;
            n
        };
        let mut guarded = node(3, 255);
        guarded.heartbeat_consumer_ms = 0;
        guarded.guard_time_ms = 10;
        guarded.life_time_factor = 2;
        let mut places = [NodeConfig::EMPTY; 16];
        places[..3].copy_from_slice(&[node(2, 1), guarded, node(4, 1)]);
        let cfg = MasterConfig {
            sync_period_us: 2_000,
            boot_wait_ms: 20,
            ..MasterConfig::default()
        };
        let Ok(master) = TestMaster::new(cfg, places) else {
            return Self {
                from_nodes: Vec::new(),
                from_master: Vec::new(),
            };
        };
        let mut net = CanNetwork::new(1_000_000, master);
        for id in [2, 3, 4] {
            let identity = SlaveIdentity {
                device_type: 0x0002_0192,
                vendor_id: 0x1234,
                product_code: 1,
                revision: 1,
                serial: u32::from(id),
            };
            let s = InProcessSlave::attach(&mut net.bus, id, identity);
            net.slaves.push(s);
        }
        net.master.master.start(0);
        net.run(300_000_000, 2_000_000, &mut |net, k| {
            for slot in 0..3 {
                let _ = net
                    .master
                    .master
                    .set_output(slot, 0, &[0x0F, 0, k as u8, 0, 0, 0]);
            }
        });
        let master_port = net.master.port;
        let (mut from_nodes, mut from_master) = (Vec::new(), Vec::new());
        for (t, port, f) in &net.bus.log {
            if *port == master_port {
                from_master.push((*t, for_node_5(f)));
            } else {
                from_nodes.push((*t, *f));
            }
        }
        Self {
            from_nodes,
            from_master,
        }
    }
}

/// A frame of the master for nodes 2..4 as one for node 5.
fn for_node_5(f: &CanFrame) -> CanFrame {
    let id = f.id();
    let data = f.data();
    if id == 0 && data.len() == 2 && data[1] != 0 {
        return CanFrame::new(0, &[data[0], 5]).unwrap_or(*f);
    }
    let node_based = matches!(id & 0x780, 0x200 | 0x600 | 0x700) && (2..=4).contains(&(id & 0x7F));
    if !node_based {
        return *f;
    }
    let id = (id & !0x7F) | 5;
    if f.is_remote() {
        CanFrame::remote(id, f.dlc()).unwrap_or(*f)
    } else {
        CanFrame::new(id, data).unwrap_or(*f)
    }
}

/// Frames in the CAN targets' input form (`tests/fuzz/fuzz_targets/can_stream.rs`), 64 per
/// input.
fn can_stream(frames: &[(u64, CanFrame)]) -> Vec<Vec<u8>> {
    frames
        .chunks(64)
        .map(|chunk| {
            let mut input = Vec::new();
            let mut last = chunk.first().map_or(0, |(t, _)| *t);
            for (t, f) in chunk {
                let dt_ms = ((t - last) / 1_000_000).min(255) as u8;
                last = *t;
                let [lo, hi] = f.id().to_le_bytes();
                input.extend_from_slice(&[u8::from(f.is_remote()), dt_ms, lo, hi, f.dlc()]);
                input.extend_from_slice(f.data());
            }
            input
        })
        .collect()
}

fn files(dir: &Path, extension: &str) -> Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == extension))
        .collect();
    out.sort();
    Ok(out)
}

fn save<'a>(dir: &Path, inputs: impl Iterator<Item = &'a Vec<u8>>) -> Result {
    fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for (i, input) in inputs.enumerate() {
        let path = dir.join(format!("seed-{i:05}"));
        fs::write(&path, input).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}

/// The firmware's SII EEPROM, as `cargo xtask esi` writes it.
fn firmware_sii() -> Result<Vec<u8>> {
    let product = &firmware::products::analog_io::PRODUCT;
    let desc = product.device;
    let mut eeprom = vec![0u8; desc.eeprom.size_bytes as usize];
    coe_core::sii::generate_eeprom_with(desc, product.oversampling, &mut eeprom)
        .map_err(|e| e.to_string())?;
    Ok(eeprom)
}

/// Mailbox frames found in captured EtherCAT datagrams.
#[derive(Default)]
struct MailboxFrames {
    /// Every distinct frame, requests and replies.
    all: BTreeSet<Vec<u8>>,
    /// Frames a master wrote (the write mailbox), in capture order.
    requests: Vec<Vec<u8>>,
}

impl MailboxFrames {
    /// Takes every datagram payload that starts with a whole mailbox frame. Only mailbox
    /// SyncManager buffers hold such bytes in practice; a register that happens to look like
    /// one is still a fine fuzz seed.
    fn collect(&mut self, packets: &[Vec<u8>]) {
        for packet in packets {
            for d in parse_frame(packet).unwrap_or_default() {
                let Ok(repr) = MailboxRepr::parse(&Mailbox::new_unchecked(&d.data[..])) else {
                    continue;
                };
                let n = repr.buffer_len();
                if repr.payload_len == 0 || n > d.data.len() {
                    continue;
                }
                let frame = d.data[..n].to_vec();
                // A write mailbox frame passes the capture twice (to the slave and back).
                let written = matches!(d.command, cmd::FPWR | cmd::APWR | cmd::BWR);
                if written && self.requests.last() != Some(&frame) {
                    self.requests.push(frame.clone());
                }
                self.all.insert(frame);
            }
        }
    }

    /// Inputs of the `coe_sdo_server` target: byte 0 state (1 = PREOP), byte 1 read-mailbox
    /// size, byte 2 clock step, then length-prefixed frames; 16 requests per input.
    fn server_sessions(&self) -> Vec<Vec<u8>> {
        self.requests
            .chunks(16)
            .map(|chunk| {
                let mut input = vec![1, 128, 1];
                for f in chunk.iter().filter(|f| f.len() <= 255) {
                    input.push(f.len() as u8);
                    input.extend_from_slice(f);
                }
                input
            })
            .collect()
    }

    /// Inputs of the `slave_mailbox` target: the product (first byte, the products in
    /// turn), then each request written (op 0, length, frame) and its reply read (op 3);
    /// 16 requests per input.
    fn master_sessions(&self) -> Vec<Vec<u8>> {
        self.requests
            .chunks(16)
            .enumerate()
            .map(|(i, chunk)| {
                let mut input = vec![(i % 2) as u8];
                for f in chunk.iter().filter(|f| f.len() <= 255) {
                    input.extend_from_slice(&[0, f.len() as u8]);
                    input.extend_from_slice(f);
                    input.push(3);
                }
                input
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn final_stat_takes_the_last_value() {
        let log =
            "stat::number_of_executed_units: 12\nnoise\nstat::number_of_executed_units: 345\n";
        assert_eq!(
            final_stat(log, "stat::number_of_executed_units:"),
            Some(345)
        );
        assert_eq!(
            final_stat("nothing", "stat::number_of_executed_units:"),
            None
        );
    }

    #[test]
    fn can_seeds_from_the_masters_traffic() {
        let can = CanTraffic::record();
        // Boot SDO answers, heartbeats and TPDOs of the nodes; NMT, SDO requests, SYNC and
        // guard requests of the master, renumbered for node 5.
        assert!(can.from_nodes.iter().any(|(_, f)| f.id() == 0x582));
        assert!(can.from_nodes.iter().any(|(_, f)| f.id() == 0x184));
        assert!(can.from_master.iter().any(|(_, f)| f.id() == 0x605));
        assert!(can
            .from_master
            .iter()
            .any(|(_, f)| f.is_remote() && f.id() == 0x705));
        assert!(can.from_master.iter().any(|(_, f)| f.id() == 0x080));
        assert!(!can.from_master.iter().any(|(_, f)| f.id() == 0x602));
        let inputs = can_stream(&can.from_master);
        assert!(inputs.len() > 2);
        let f = CanFrame::new(0x123, &[9, 8]).unwrap();
        assert_eq!(
            can_stream(&[(0, f), (3_000_000, f)]),
            [vec![0, 0, 0x23, 0x01, 2, 9, 8, 0, 3, 0x23, 0x01, 2, 9, 8]]
        );
    }

    #[test]
    fn mailbox_frames_from_datagrams() {
        use virtual_board::models::esc::FrameBuilder;
        // An SDO upload request (mailbox length 10, CoE, counter 1) written by FPWR, the
        // same frame on its way back (counted once), an empty read (length 0: no frame) and a
        // register read too short for a mailbox header.
        let request = [
            0x0A, 0x00, 0x00, 0x00, 0x00, 0x13, 0x00, 0x20, 0x40, 0x18, 0x10, 0x02, 0, 0, 0, 0,
        ];
        let frame = FrameBuilder::new()
            .datagram_raw(cmd::FPWR, 0x1000_1001, &request, 1)
            .datagram_raw(cmd::FPWR, 0x1000_1001, &request, 1)
            .datagram_raw(cmd::FPRD, 0x1080_1001, &[0u8; 16], 1)
            .datagram_raw(cmd::FPRD, 0x0130_1001, &[0x02, 0x00], 1)
            .build();
        let mut frames = MailboxFrames::default();
        frames.collect(&[frame]);
        assert_eq!(frames.all.len(), 1);
        assert_eq!(frames.requests, [request.to_vec()]);
        let sessions = frames.server_sessions();
        assert_eq!(sessions.len(), 1);
        assert_eq!(&sessions[0][..4], &[1, 128, 1, 16]);
        assert_eq!(&sessions[0][4..], &request);
        let sessions = frames.master_sessions();
        assert_eq!(sessions.len(), 1);
        // The product (the first one), the request written, its reply read.
        assert_eq!(&sessions[0][..3], &[0, 0, 16]);
        assert_eq!(&sessions[0][3..19], &request);
        assert_eq!(sessions[0][19..], [3]);
    }
}
