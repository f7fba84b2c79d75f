//! CPU cost on a Cortex-M3: builds `xtask/bench-cm3` for thumbv7m-none-eabi and the
//! instruction-counting QEMU plugin (`xtask/qemu-plugin/insn_count.c`, with the system `cc`),
//! runs the program on QEMU's lm3s6965evb with `-icount shift=0` and pairs the plugin's
//! per-region counts with the region names the program prints through semihosting.

use crate::build::{target_dir, Profile, TARGET};
use crate::util::{display, exec, have, root, Result};
use object::{Object, ObjectSymbol};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The QEMU binary and machine (a Cortex-M3 with flash at 0 and SRAM at 0x2000_0000).
pub const QEMU: &str = "qemu-system-arm";
const MACHINE: &str = "lm3s6965evb";
/// The bench program's package and binary.
const PACKAGE: &str = "bench-cm3";
/// A run that takes longer has hung (it takes well under a second).
const TIMEOUT: Duration = Duration::from_secs(60);

/// Instructions of one measured path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PathCount {
    /// Region name printed by the program.
    pub name: String,
    /// Instructions per run, the markers' own instructions (`baseline`) subtracted.
    pub instructions: u64,
}

/// What the QEMU runs measured.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CpuReport {
    /// Per path, in program order.
    pub paths: Vec<PathCount>,
    /// The markers' own instructions (an empty region).
    pub baseline: u64,
    /// QEMU runs whose counts were compared (all identical, or the run fails).
    pub runs: usize,
    /// `qemu-system-arm --version`, first line.
    pub qemu: String,
}

impl CpuReport {
    /// Instructions of the path `name`.
    pub fn get(&self, name: &str) -> Result<u64> {
        self.paths
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.instructions)
            .ok_or_else(|| format!("the Cortex-M3 benchmark has no region `{name}`"))
    }
}

/// Pairs the program's region names (stdout) with the plugin's counts (its output file),
/// checks that the measured repetitions of a path agree and subtracts the baseline.
pub fn pair_regions(stdout: &str, counts: &str) -> Result<(Vec<PathCount>, u64)> {
    let names: Vec<&str> = region_names(stdout).collect();
    let mut values = Vec::new();
    for (i, line) in counts.lines().enumerate() {
        let mut it = line.split_whitespace();
        match (it.next(), it.next(), it.next()) {
            (Some("region"), Some(n), Some(c)) if n.parse() == Ok(i) => values.push(
                c.parse::<u64>()
                    .map_err(|_| format!("plugin output line {}: `{line}`", i + 1))?,
            ),
            _ => return Err(format!("plugin output line {}: `{line}`", i + 1)),
        }
    }
    if names.len() != values.len() {
        return Err(format!(
            "{} regions named by the program but {} counted by the plugin",
            names.len(),
            values.len()
        ));
    }
    let mut per_name: Vec<(String, Vec<u64>)> = Vec::new();
    for (name, v) in names.iter().zip(&values) {
        if *name == "-" {
            continue; // warm-up run
        }
        match per_name.iter_mut().find(|(n, _)| n == name) {
            Some((_, vs)) => vs.push(*v),
            None => per_name.push((name.to_string(), vec![*v])),
        }
    }
    for (name, vs) in &per_name {
        if vs.iter().any(|v| *v != vs[0]) {
            return Err(format!(
                "region `{name}` counted differently in its repetitions: {vs:?}"
            ));
        }
    }
    let baseline = per_name
        .iter()
        .find(|(n, _)| n == "baseline")
        .map(|(_, v)| v[0])
        .ok_or("the program measured no `baseline` region")?;
    let paths = per_name
        .into_iter()
        .filter(|(n, _)| n != "baseline")
        .map(|(name, v)| PathCount {
            name,
            instructions: v[0].saturating_sub(baseline),
        })
        .collect();
    Ok((paths, baseline))
}

/// The region names the program printed, in order (`-` for the warm-up run).
fn region_names(stdout: &str) -> impl Iterator<Item = &str> {
    stdout
        .lines()
        .filter_map(|l| l.trim().strip_prefix("region "))
}

pub fn bench_target_dir() -> PathBuf {
    target_dir().join("bench")
}

/// Builds the program (release, thumbv7m-none-eabi, with `profile`). The workspace's
/// target linker is the firmware's flip-link, which relocates the stack for the LPC1754's
/// memory.x; this program has its own complete linker script, so it links with rust-lld
/// directly.
fn build_program(profile: &Profile) -> Result<PathBuf> {
    exec(
        profile
            .cargo()
            .args([
                "rustc",
                "--quiet",
                "--release",
                "-p",
                PACKAGE,
                "--bin",
                PACKAGE,
            ])
            .args(["--target", TARGET])
            .args(profile.config_args())
            .args(["--", "-C", "linker=rust-lld"]),
    )?;
    Ok(profile.release_dir().join(PACKAGE))
}

/// Builds the plugin with the system C compiler.
fn build_plugin() -> Result<PathBuf> {
    let src = root().join("xtask").join("qemu-plugin");
    let out = bench_target_dir();
    std::fs::create_dir_all(&out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let so = out.join("libinsn_count.so");
    if !have("cc") {
        return Err(
            "no C compiler `cc` on the PATH (Debian package gcc) for the QEMU plugin".into(),
        );
    }
    exec(
        Command::new("cc")
            .args(["-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-Werror"])
            .arg("-fvisibility=hidden")
            .arg("-o")
            .arg(&so)
            .arg(src.join("insn_count.c")),
    )?;
    Ok(so)
}

/// The entry addresses (Thumb bit cleared) of the two marker functions.
fn marker_addresses(elf: &Path) -> Result<(u64, u64)> {
    let data = std::fs::read(elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
    let find = |name: &str| {
        file.symbols()
            .find(|s| s.name() == Ok(name))
            .map(|s| s.address() & !1)
            .ok_or_else(|| format!("{}: no symbol `{name}`", elf.display()))
    };
    let (b, e) = (find("bench_begin")?, find("bench_end")?);
    if b == e {
        return Err("bench_begin and bench_end were merged into one function".into());
    }
    Ok((b, e))
}

fn qemu_version() -> String {
    Command::new(QEMU)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .next()
                .map(str::to_string)
        })
        .unwrap_or_default()
}

/// One QEMU run: (console output, plugin output). With `trace`, the plugin also writes
/// "<region> <pc>" per counted instruction to that file.
fn run_qemu(
    elf: &Path,
    plugin: &Path,
    markers: (u64, u64),
    n: usize,
    trace: Option<&Path>,
) -> Result<(String, String)> {
    let counts = bench_target_dir().join(format!("insn_count.{n}.txt"));
    let _ = std::fs::remove_file(&counts);
    let mut plugin_args = format!(
        "{},begin={:#x},end={:#x},out={}",
        plugin.display(),
        markers.0,
        markers.1,
        counts.display()
    );
    if let Some(trace) = trace {
        plugin_args.push_str(&format!(",trace={}", trace.display()));
    }
    let mut cmd = Command::new(QEMU);
    cmd.args(["-M", MACHINE, "-cpu", "cortex-m3", "-icount", "shift=0"])
        .args(["-display", "none", "-monitor", "none", "-serial", "null"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-plugin")
        .arg(plugin_args)
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    eprintln!("$ {}", display(&cmd));
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start {QEMU}: {e}"))?;
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break s;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("{QEMU} did not finish within {TIMEOUT:?}"));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let out = child.wait_with_output().map_err(|e| e.to_string())?;
    // The semihosting console and QEMU's own messages: both streams, in that order.
    let console = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if !status.success() || !console.lines().any(|l| l.trim() == "done") {
        return Err(format!(
            "the Cortex-M3 benchmark failed ({status}):\n{console}"
        ));
    }
    let counts = std::fs::read_to_string(&counts)
        .map_err(|e| format!("the plugin wrote no counts ({}): {e}", counts.display()))?;
    Ok((console, counts))
}

/// Builds the program (with `profile`) and the plugin: (ELF, plugin, marker addresses).
fn prepare(profile: &Profile) -> Result<(PathBuf, PathBuf, (u64, u64))> {
    if !have(QEMU) {
        return Err(format!(
            "{QEMU} is not installed: the CPU figures need it (Debian package qemu-system-arm; \
             `cargo xtask setup` installs it when run as root)"
        ));
    }
    let elf = build_program(profile)?;
    let plugin = build_plugin()?;
    let markers = marker_addresses(&elf)?;
    Ok((elf, plugin, markers))
}

/// Builds (with `profile`) and runs the benchmark `runs` times; every run must count the
/// same.
pub fn measure(runs: usize, profile: &Profile) -> Result<CpuReport> {
    let (elf, plugin, markers) = prepare(profile)?;
    let mut first: Option<(Vec<PathCount>, u64)> = None;
    for n in 0..runs.max(1) {
        let (stdout, counts) = run_qemu(&elf, &plugin, markers, n, None)?;
        let got = pair_regions(&stdout, &counts)?;
        match &first {
            None => first = Some(got),
            Some(f) if *f == got => {}
            Some(f) => {
                return Err(format!(
                    "QEMU run {n} counted differently from run 0: {:?} vs {:?}",
                    got, f
                ))
            }
        }
    }
    let (paths, baseline) = first.ok_or("no QEMU run")?;
    Ok(CpuReport {
        paths,
        baseline,
        runs: runs.max(1),
        qemu: qemu_version(),
    })
}

/// One run with the plugin's instruction trace, for splitting the counts by function.
pub struct TracedRun {
    /// The benchmark program (its DWARF symbolises the trace).
    pub elf: PathBuf,
    /// The run's counts, as [`measure`] gives them.
    pub report: CpuReport,
    /// Region names in plugin order (`-` for the warm-up run), as the program printed them.
    pub names: Vec<String>,
    /// "<region> <pc>" per counted instruction.
    pub trace: String,
}

/// Builds (with the release profile) and runs the benchmark once with the trace.
pub fn traced_run() -> Result<TracedRun> {
    let (elf, plugin, markers) = prepare(&super::cm3_profile())?;
    let trace_path = bench_target_dir().join("insn_trace.txt");
    let _ = std::fs::remove_file(&trace_path);
    let (stdout, counts) = run_qemu(&elf, &plugin, markers, 0, Some(&trace_path))?;
    let (paths, baseline) = pair_regions(&stdout, &counts)?;
    let trace = std::fs::read_to_string(&trace_path)
        .map_err(|e| format!("the plugin wrote no trace ({}): {e}", trace_path.display()))?;
    Ok(TracedRun {
        elf,
        report: CpuReport {
            paths,
            baseline,
            runs: 1,
            qemu: qemu_version(),
        },
        names: region_names(&stdout).map(str::to_string).collect(),
        trace,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_pair_in_order_and_subtract_the_baseline() {
        let stdout = "Timer with period zero\nregion -\nregion -\nregion baseline\nregion a\n\
                      region baseline\nregion a\ndone\n";
        let counts = "region 0 9\nregion 1 100\nregion 2 9\nregion 3 50\nregion 4 9\nregion 5 50\n";
        let (paths, base) = pair_regions(stdout, counts).unwrap();
        assert_eq!(base, 9);
        assert_eq!(
            paths,
            vec![PathCount {
                name: "a".into(),
                instructions: 41
            }]
        );
    }

    #[test]
    fn disagreeing_repetitions_and_missing_counts_are_errors() {
        let stdout = "region baseline\nregion a\nregion baseline\nregion a\n";
        let e = pair_regions(stdout, "region 0 9\nregion 1 50\nregion 2 9\nregion 3 51\n");
        assert!(e.unwrap_err().contains("counted differently"));
        let e = pair_regions(stdout, "region 0 9\n");
        assert!(e.unwrap_err().contains("4 regions named"));
        let e = pair_regions("region a\n", "region 0 5\n");
        assert!(e.unwrap_err().contains("baseline"));
        let e = pair_regions("region a\n", "region 7 5\n");
        assert!(e.unwrap_err().contains("line 1"));
    }
}
