//! `tshark` as an independent check of the captures: every frame must decode as
//! EtherCAT and none may be malformed (`_ws.malformed`).

use std::path::Path;
use std::process::Command;

/// What tshark made of a capture.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TsharkSummary {
    /// Frames in the file.
    pub frames: usize,
    /// Frames decoded as EtherCAT (`ecat`).
    pub ecat: usize,
    /// Malformed frames.
    pub malformed: usize,
}

fn count(path: &Path, filter: &str) -> Result<usize, String> {
    let out = Command::new("tshark")
        .arg("-r")
        .arg(path)
        .args(["-Y", filter, "-T", "fields", "-e", "frame.number"])
        .output()
        .map_err(|e| format!("tshark: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "tshark -r {} -Y {filter}: {}",
            path.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).lines().count())
}

/// The values of `fields` (tshark field names) in each frame of `path` that matches
/// `filter`, one row per frame (a field absent from a frame gives an empty string).
pub fn fields(path: &Path, filter: &str, fields: &[&str]) -> Result<Vec<Vec<String>>, String> {
    let mut cmd = Command::new("tshark");
    cmd.arg("-r").arg(path).args(["-Y", filter, "-T", "fields"]);
    for f in fields {
        cmd.args(["-e", f]);
    }
    let out = cmd.output().map_err(|e| format!("tshark: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "tshark -r {} -Y {filter}: {}",
            path.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.split('\t').map(str::to_owned).collect())
        .collect())
}

/// Whether tshark is installed.
pub fn available() -> bool {
    Command::new("tshark")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Decodes `path` with tshark; `None` when tshark is not installed.
pub fn summarize(path: &Path) -> Option<Result<TsharkSummary, String>> {
    if !available() {
        return None;
    }
    Some((|| {
        Ok(TsharkSummary {
            frames: count(path, "frame")?,
            ecat: count(path, "ecat")?,
            malformed: count(path, "_ws.malformed")?,
        })
    })())
}

/// Test helper: asserts that every frame of `path` decodes as EtherCAT with none
/// malformed. Fails when tshark is not installed: the tests that call it are ignored by
/// default and run by `cargo xtask test`, which installs tshark.
pub fn assert_clean(path: &Path) {
    match summarize(path) {
        None => panic!(
            "tshark is not installed, so {} cannot be checked (Debian package tshark; \
             `cargo xtask setup` installs it)",
            path.display()
        ),
        Some(Err(e)) => panic!("{e}"),
        Some(Ok(s)) => {
            eprintln!(
                "tshark: {} frames, {} EtherCAT, {} malformed ({})",
                s.frames,
                s.ecat,
                s.malformed,
                path.display()
            );
            assert!(s.frames > 0, "empty capture {}", path.display());
            assert_eq!(s.ecat, s.frames, "frames not decoded as EtherCAT");
            assert_eq!(s.malformed, 0, "malformed frames in {}", path.display());
        }
    }
}

/// A scenario test and its capture check, for the integration tests: `$test` runs
/// `$scenario("$file.pcap")` (a function that plays a scenario, asserts on it and returns
/// the capture it saved); `$check` runs it again into `$file-tshark.pcap` and decodes that
/// with [`assert_clean`]. `$check` is ignored unless run explicitly (it needs tshark);
/// `cargo xtask test` installs tshark and runs it.
#[macro_export]
macro_rules! capture_tests {
    ($test:ident, $check:ident, $scenario:ident, $file:literal) => {
        #[test]
        fn $test() {
            $scenario(concat!($file, ".pcap"));
        }

        #[test]
        #[ignore = "needs tshark: `cargo xtask test` installs it and runs this"]
        fn $check() {
            $crate::tools::sim::tshark::assert_clean(&$scenario(concat!($file, "-tshark.pcap")));
        }
    };
}
