//! `cargo xtask bench --by-function`: where each measured region's instructions go, per
//! function. One QEMU run of the Cortex-M3 benchmark with the plugin's instruction trace
//! ("<region> <pc>" per counted instruction); every address is symbolised with the
//! program's DWARF (inlined frames included) and counted to the innermost frame whose
//! function belongs to one of the workspace's crates, so `core` or `compiler_builtins` code
//! inlined into a project function counts to that function. Code outside any project
//! function counts under its own (outermost) name.
//!
//! Only the measured repetitions count (not the warm-up run), divided by their number, and
//! the baseline region's functions (the markers' own instructions) are subtracted as the
//! region counts subtract them; the sum over functions must equal the region's count
//! exactly. Not part of `cargo xtask test` (its unit tests are).

use super::cm3::{self, CpuReport};
use crate::util::{cargo, Result};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use virtual_board::tools::dwarf::Reader;

/// The regions of the process-data cycle, printed in this order (the JSON has all regions).
const CYCLE_REGIONS: [&str; 9] = [
    "pdi_outputs",
    "pdi_inputs",
    "dac_preload",
    "sync0_ldac",
    "sync0_record",
    "dma_scan_drain",
    "driver_read4",
    "driver_write16",
    "driver_nop",
];

/// Address -> the demangled names of its function frames, innermost (most deeply inlined)
/// first.
pub trait Symbols {
    fn frames(&self, pc: u64) -> Vec<String>;
}

/// The crate a function's path names: `firmware` of `firmware::stacks::ethercat::SlaveApp::poll`; for an
/// impl `<A as B>::f` both A's and B's (the impl lives in one of them).
fn crates_of(function: &str) -> Vec<&str> {
    fn first_segment(path: &str) -> Option<&str> {
        let (head, _) = path.split_once("::")?;
        let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
        (!head.is_empty() && head.chars().all(ident)).then_some(head)
    }
    let Some(inner) = function.strip_prefix('<') else {
        return first_segment(function).into_iter().collect();
    };
    // The text up to the matching '>', split at its top-level " as ".
    let mut depth = 0usize;
    let mut close = inner.len();
    let mut split = None;
    for (i, c) in inner.char_indices() {
        match c {
            '<' => depth += 1,
            '>' if depth == 0 => {
                close = i;
                break;
            }
            '>' => depth -= 1,
            ' ' if depth == 0 && split.is_none() && inner[i..].starts_with(" as ") => {
                split = Some(i)
            }
            _ => {}
        }
    }
    let impl_of = &inner[..close];
    match split {
        Some(i) => [&impl_of[..i], &impl_of[i + 4..]]
            .into_iter()
            .filter_map(first_segment)
            .collect(),
        None => first_segment(impl_of).into_iter().collect(),
    }
}

/// What an instruction counts to: the innermost frame whose function belongs to one of the
/// workspace's crates (`project`, as Rust names them); failing that the outermost frame (the
/// function the code was compiled into); failing that the address.
///
/// Decided by the function's path, not by the line table's file: in optimised code the
/// line of an address and its inlined-function ranges do not always agree.
pub fn owner(pc: u64, frames: &[String], project: &[String]) -> String {
    let in_project = |f: &&String| crates_of(f).iter().any(|c| project.iter().any(|p| p == c));
    match frames.iter().find(in_project).or(frames.last()) {
        Some(f) => f.clone(),
        None => format!("<no symbol at {pc:#x}>"),
    }
}

/// The workspace's crate names as paths spell them (`coe_core`), from `cargo metadata`.
pub(crate) fn workspace_crates() -> Result<Vec<String>> {
    let out = cargo()
        .args(["metadata", "--no-deps", "--format-version", "1"])
        .stderr(std::process::Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo metadata: {e}"))?;
    if !out.status.success() {
        return Err(format!("cargo metadata failed ({})", out.status));
    }
    let meta: serde_json::Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("cargo metadata: {e}"))?;
    let mut names: Vec<String> = meta["packages"]
        .as_array()
        .ok_or("cargo metadata: no packages")?
        .iter()
        .flat_map(|p| p["targets"].as_array().into_iter().flatten())
        .filter_map(|t| t["name"].as_str())
        .map(|n| n.replace('-', "_"))
        .collect();
    names.sort();
    names.dedup();
    Ok(names)
}

/// One function's share of a region.
#[derive(Debug, Clone, PartialEq)]
pub struct Share {
    pub function: String,
    /// Over all measured repetitions, baseline subtracted (negative when the function ran
    /// less than in the baseline region).
    pub total: i64,
}

impl Share {
    /// Instructions per run.
    pub fn per_run(&self, runs: u64) -> f64 {
        self.total as f64 / runs.max(1) as f64
    }
}

/// A region split by function.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionSplit {
    pub name: String,
    /// Instructions per run, as the region's count gives them.
    pub instructions: u64,
    /// Measured repetitions in the trace.
    pub runs: u64,
    /// Largest first; functions whose share is zero are left out.
    pub functions: Vec<Share>,
}

/// Per region index of the trace: executed instructions per address.
fn parse_trace(trace: &str, regions: usize) -> Result<Vec<BTreeMap<u64, u64>>> {
    let mut per_region = vec![BTreeMap::new(); regions];
    for (i, line) in trace.lines().enumerate() {
        let bad = || format!("trace line {}: `{line}`", i + 1);
        let (region, pc) = line.split_once(' ').ok_or_else(bad)?;
        let region: usize = region.parse().map_err(|_| bad())?;
        let pc = u64::from_str_radix(pc, 16).map_err(|_| bad())?;
        let counts = per_region.get_mut(region).ok_or_else(|| {
            format!(
                "trace line {}: region {region}, but the program named {regions} regions",
                i + 1
            )
        })?;
        *counts.entry(pc).or_insert(0) += 1;
    }
    Ok(per_region)
}

/// Splits every measured region of the trace by function and checks each split against the
/// region's count in `report`. `names` are the region names in plugin order (`-`: warm-up).
pub fn split(
    names: &[String],
    trace: &str,
    report: &CpuReport,
    symbols: &dyn Symbols,
    project: &[String],
) -> Result<Vec<RegionSplit>> {
    // Per name in program order: repetitions and instructions per address over all of them.
    let mut grouped: Vec<(&str, u64, BTreeMap<u64, u64>)> = Vec::new();
    for (name, counts) in names.iter().zip(parse_trace(trace, names.len())?) {
        if name == "-" {
            continue;
        }
        let i = match grouped.iter().position(|(n, _, _)| n == name) {
            Some(i) => i,
            None => {
                grouped.push((name, 0, BTreeMap::new()));
                grouped.len() - 1
            }
        };
        let (_, runs, sum) = &mut grouped[i];
        *runs += 1;
        for (pc, n) in counts {
            *sum.entry(pc).or_insert(0) += n;
        }
    }
    let (_, baseline_runs, baseline) = grouped
        .iter()
        .find(|(n, _, _)| *n == "baseline")
        .ok_or("the trace has no `baseline` region")?;

    let mut owners: BTreeMap<u64, String> = BTreeMap::new();
    let mut owner_of = |pc: u64| {
        owners
            .entry(pc)
            .or_insert_with(|| owner(pc, &symbols.frames(pc), project))
            .clone()
    };
    let mut splits = Vec::new();
    for (name, runs, counts) in grouped.iter().filter(|(n, _, _)| *n != "baseline") {
        if runs != baseline_runs {
            return Err(format!(
                "region `{name}` measured {runs} times but the baseline {baseline_runs} times: \
                 its baseline cannot be subtracted per function"
            ));
        }
        let mut per_owner: BTreeMap<String, i64> = BTreeMap::new();
        for (pc, n) in counts {
            *per_owner.entry(owner_of(*pc)).or_insert(0) += *n as i64;
        }
        for (pc, n) in baseline {
            *per_owner.entry(owner_of(*pc)).or_insert(0) -= *n as i64;
        }
        let total: i64 = per_owner.values().sum();
        let instructions = report.get(name)?;
        if total != (instructions * runs) as i64 {
            return Err(format!(
                "region `{name}`: its functions add up to {total} instructions over {runs} \
                 runs, the plugin counted {instructions} per run ({} over {runs})",
                instructions * runs
            ));
        }
        let mut functions: Vec<Share> = per_owner
            .into_iter()
            .filter(|(_, total)| *total != 0)
            .map(|(function, total)| Share { function, total })
            .collect();
        functions.sort_by(|a, b| b.total.cmp(&a.total).then(a.function.cmp(&b.function)));
        splits.push(RegionSplit {
            name: name.to_string(),
            instructions,
            runs: *runs,
            functions,
        });
    }
    Ok(splits)
}

/// The program's DWARF (inlined frames) with its symbol table for code without line
/// information.
pub(crate) struct Dwarf {
    context: addr2line::Context<Reader>,
    /// (start, end, demangled name) of the function symbols, Thumb bit cleared.
    symbols: Vec<(u64, u64, String)>,
}

impl Dwarf {
    pub(crate) fn load(elf: &Path) -> Result<Self> {
        use object::{Object, ObjectSymbol, SymbolKind};
        let data = std::fs::read(elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
        let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", elf.display()))?;
        let context = virtual_board::tools::dwarf::context(&file)
            .map_err(|e| format!("{}: DWARF: {e}", elf.display()))?;
        let symbols = file
            .symbols()
            .filter(|s| s.kind() == SymbolKind::Text && s.size() > 0)
            .filter_map(|s| {
                let start = s.address() & !1;
                let name = format!("{:#}", rustc_demangle::demangle(s.name().ok()?));
                Some((start, start + s.size(), name))
            })
            .collect();
        Ok(Self { context, symbols })
    }
}

impl Symbols for Dwarf {
    fn frames(&self, pc: u64) -> Vec<String> {
        let mut frames = Vec::new();
        if let Ok(mut iter) = self.context.find_frames(pc).skip_all_loads() {
            while let Ok(Some(frame)) = iter.next() {
                let Some(function) = frame
                    .function
                    .and_then(|f| f.demangle().ok().map(|n| n.into_owned()))
                else {
                    continue;
                };
                frames.push(function);
            }
        }
        if frames.is_empty() {
            frames.extend(
                self.symbols
                    .iter()
                    .find(|(start, end, _)| (*start..*end).contains(&pc))
                    .map(|(_, _, name)| name.clone()),
            );
        }
        frames
    }
}

/// "412" for whole numbers, "412.33" otherwise.
fn per_run_text(share: &Share, runs: u64) -> String {
    if share.total % runs.max(1) as i64 == 0 {
        format!("{}", share.total / runs.max(1) as i64)
    } else {
        format!("{:.2}", share.per_run(runs))
    }
}

fn print_region(split: &RegionSplit) {
    println!(
        "\n{}: {} instructions per run ({} runs traced, baseline subtracted)",
        split.name, split.instructions, split.runs
    );
    for share in &split.functions {
        let percent = 100.0 * share.per_run(split.runs) / split.instructions.max(1) as f64;
        println!(
            "{:>8} {percent:>5.1} %  {}",
            per_run_text(share, split.runs),
            share.function
        );
    }
}

fn json(splits: &[RegionSplit], report: &CpuReport, elf: &Path) -> serde_json::Value {
    let regions: Vec<serde_json::Value> = splits
        .iter()
        .map(|s| {
            let functions: Vec<serde_json::Value> = s
                .functions
                .iter()
                .map(|f| {
                    serde_json::json!({
                        "function": f.function,
                        "instructions": f.per_run(s.runs),
                    })
                })
                .collect();
            serde_json::json!({
                "name": s.name,
                "instructions": s.instructions,
                "runs": s.runs,
                "functions": functions,
            })
        })
        .collect();
    serde_json::json!({
        "elf": elf.display().to_string(),
        "qemu": report.qemu,
        "baseline": report.baseline,
        "regions": regions,
    })
}

/// Where the JSON goes.
fn json_path() -> PathBuf {
    cm3::bench_target_dir().join("by_function.json")
}

pub fn run() -> Result {
    let traced = cm3::traced_run()?;
    let dwarf = Dwarf::load(&traced.elf)?;
    let project = workspace_crates()?;
    let splits = split(
        &traced.names,
        &traced.trace,
        &traced.report,
        &dwarf,
        &project,
    )?;
    println!(
        "Cortex-M3 instructions per function (innermost frame in the workspace's crates; {})",
        traced.report.qemu
    );
    for name in CYCLE_REGIONS {
        let split = splits
            .iter()
            .find(|s| s.name == name)
            .ok_or_else(|| format!("the Cortex-M3 benchmark has no region `{name}`"))?;
        print_region(split);
    }
    let path = json_path();
    let text = serde_json::to_string_pretty(&json(&splits, &traced.report, &traced.elf))
        .map_err(|e| e.to_string())?;
    std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("\nJSON (every region): {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use cm3::PathCount;

    /// The workspace's crates of the fake program.
    fn project() -> Vec<String> {
        vec!["app".into(), "bench".into(), "drv".into()]
    }

    /// 0x1xx: project function `app::a` (0x110: `core::ptr::copy` inlined into it, and `a`
    /// itself inlined into `app::outer`); 0x2xx: `app::b`; 0x3xx: `compiler_builtins`'
    /// memcpy, not inlined, with its own helper inlined; 0x4xx: the marker; 0x5xx: a
    /// trait impl of a project trait for a generic type, inlined into `core` code; anything
    /// else: no symbol.
    struct Fake;

    impl Symbols for Fake {
        fn frames(&self, pc: u64) -> Vec<String> {
            let names: &[&str] = match pc >> 8 {
                1 if pc == 0x110 => &["core::ptr::copy", "app::a", "app::outer"],
                1 => &["app::a"],
                2 => &["app::b"],
                3 => &[
                    "compiler_builtins::mem::impls::copy",
                    "compiler_builtins::mem::memcpy",
                ],
                4 => &["bench::bench_begin"],
                5 => &[
                    "core::option::Option<T>::map",
                    "<&mut P as drv::pdi::Pdi>::read",
                    "core::iter::Iterator::for_each",
                    "app::c",
                ],
                _ => &[],
            };
            names.iter().map(|n| n.to_string()).collect()
        }
    }

    fn report(counts: &[(&str, u64)], baseline: u64) -> CpuReport {
        CpuReport {
            paths: counts
                .iter()
                .map(|(name, n)| PathCount {
                    name: name.to_string(),
                    instructions: *n,
                })
                .collect(),
            baseline,
            runs: 1,
            qemu: String::new(),
        }
    }

    fn region_names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    /// "<region> <pc>" lines: `pcs` executed once each in region `region`.
    fn lines(region: usize, pcs: &[u64]) -> String {
        pcs.iter().map(|pc| format!("{region} {pc:x}\n")).collect()
    }

    #[test]
    fn crates_come_from_the_path_and_both_sides_of_an_impl() {
        assert_eq!(
            crates_of("firmware::stacks::ethercat::SlaveApp::poll"),
            ["firmware"]
        );
        assert_eq!(
            crates_of("firmware::stacks::ethercat::mailbox::MailboxLink<S,_>::needs_service"),
            ["firmware"]
        );
        assert_eq!(
            crates_of("<firmware::fake_esc::FakeEsc as et1100::pdi::Pdi>::write"),
            ["firmware", "et1100"]
        );
        assert_eq!(crates_of("<&mut P as et1100::pdi::Pdi>::read"), ["et1100"]);
        assert_eq!(
            crates_of("<core::option::Option<T> as core::clone::Clone>::clone"),
            ["core", "core"]
        );
        assert_eq!(crates_of("<[T]>::len"), Vec::<&str>::new());
        assert_eq!(crates_of("__aeabi_memclr"), Vec::<&str>::new());
        assert_eq!(crates_of("OUTLINED_FUNCTION_5"), Vec::<&str>::new());
    }

    #[test]
    fn innermost_project_frame_owns_inlined_library_code() {
        let p = project();
        assert_eq!(owner(0x110, &Fake.frames(0x110), &p), "app::a");
        assert_eq!(
            owner(0x500, &Fake.frames(0x500), &p),
            "<&mut P as drv::pdi::Pdi>::read"
        );
        // Outside the workspace: the outermost frame, the function the code is in.
        assert_eq!(
            owner(0x300, &Fake.frames(0x300), &p),
            "compiler_builtins::mem::memcpy"
        );
        assert_eq!(owner(0x900, &[], &p), "<no symbol at 0x900>");
    }

    #[test]
    fn regions_split_per_function_without_warm_up_and_baseline() {
        // Warm-up (ignored), then two measured repetitions of baseline + a.
        let region_a = [0x400, 0x100, 0x110, 0x110, 0x200, 0x300, 0x300, 0x300];
        let trace = [
            lines(0, &[0x400]),
            lines(1, &[0x999; 50]),
            lines(2, &[0x400]),
            lines(3, &region_a),
            lines(4, &[0x400]),
            lines(5, &region_a),
        ]
        .concat();
        let names = region_names(&["-", "-", "baseline", "a", "baseline", "a"]);
        let splits = split(&names, &trace, &report(&[("a", 7)], 1), &Fake, &project()).unwrap();
        assert_eq!(splits.len(), 1);
        let a = &splits[0];
        assert_eq!((a.name.as_str(), a.instructions, a.runs), ("a", 7, 2));
        let got: Vec<(&str, f64)> = a
            .functions
            .iter()
            .map(|s| (s.function.as_str(), s.per_run(a.runs)))
            .collect();
        assert_eq!(
            got,
            vec![
                ("app::a", 3.0),
                ("compiler_builtins::mem::memcpy", 3.0),
                ("app::b", 1.0),
            ]
        );
    }

    #[test]
    fn a_total_that_disagrees_with_the_count_is_an_error() {
        let trace = [lines(0, &[0x400]), lines(1, &[0x400, 0x100, 0x200])].concat();
        let names = region_names(&["baseline", "a"]);
        let e = split(&names, &trace, &report(&[("a", 3)], 1), &Fake, &project()).unwrap_err();
        assert!(e.contains("add up to 2"), "{e}");
        // The same trace agrees with the right count.
        assert!(split(&names, &trace, &report(&[("a", 2)], 1), &Fake, &project()).is_ok());
    }

    #[test]
    fn bad_traces_are_errors() {
        let names = region_names(&["baseline", "a"]);
        let r = report(&[("a", 1)], 1);
        let p = project();
        let e = split(&names, "0 zz\n", &r, &Fake, &p).unwrap_err();
        assert!(e.contains("line 1"), "{e}");
        let e = split(&names, "5 100\n", &r, &Fake, &p).unwrap_err();
        assert!(e.contains("region 5"), "{e}");
        let e = split(&region_names(&["a"]), "0 100\n", &r, &Fake, &p).unwrap_err();
        assert!(e.contains("baseline"), "{e}");
        // Repetitions that differ from the baseline's cannot be subtracted per function.
        let names3 = region_names(&["baseline", "a", "a"]);
        let e = split(&names3, "", &r, &Fake, &p).unwrap_err();
        assert!(e.contains("measured 2 times"), "{e}");
        // A region the counts do not know.
        let e = split(&region_names(&["baseline", "b"]), "", &r, &Fake, &p).unwrap_err();
        assert!(e.contains("no region `b`"), "{e}");
    }

    #[test]
    fn fractional_shares_print_with_decimals() {
        let share = |total| Share {
            function: "f".into(),
            total,
        };
        assert_eq!(per_run_text(&share(9), 3), "3");
        assert_eq!(per_run_text(&share(10), 3), "3.33");
        assert_eq!(per_run_text(&share(-3), 3), "-1");
    }
}
