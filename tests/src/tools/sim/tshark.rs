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
/// malformed (prints a note and returns when tshark is not installed).
pub fn assert_clean(path: &Path) {
    match summarize(path) {
        None => eprintln!("tshark not installed: skipping the pcap decode check"),
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
