//! The binary under test, and temporary folders that remove themselves.

use std::process::Command;

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
