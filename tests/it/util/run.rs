//! The binary under test, temporary folders that remove themselves, and the paper's Table 1 as
//! users send it.

use grasp_orient::msg::GraspCandidate;
use serde_json::Value;
use std::io::Write;
use std::process::{Command, Output, Stdio};

/// A command that runs the `grasp_orient` binary built for these tests.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_grasp_orient"))
}

/// A fresh temporary folder named after `what`, removed with everything in it when dropped.
pub fn temp_dir(what: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("grasp_orient_{what}_"))
        .tempdir()
        .expect("a temporary folder")
}

/// The paper's Table 1 as the JSON lines `solve` reads (`examples/paper_cases.jsonl`).
pub fn paper_lines() -> String {
    include_str!("../../../examples/paper_cases.jsonl").to_string()
}

/// The same four candidates as messages.
pub fn paper_messages() -> Vec<GraspCandidate> {
    paper_lines()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| serde_json::from_str(l).expect("a candidate"))
        .collect()
}

/// Runs `cmd` with `input` on its standard input: what it printed, and how writing the input
/// went (a binary that exits before reading its input closes the pipe; the caller judges).
pub fn run_fed(mut cmd: Command, input: &str) -> (Output, std::io::Result<()>) {
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary runs");
    let written = child
        .stdin
        .take()
        .expect("stdin")
        .write_all(input.as_bytes());
    (child.wait_with_output().expect("binary exits"), written)
}

/// Every line of standard output as JSON.
pub fn json_lines(out: &Output) -> Vec<Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("every output line is JSON"))
        .collect()
}
