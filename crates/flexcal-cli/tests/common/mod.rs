//! Shared helpers of the end-to-end tests: running the `flexcal` binary.
// Each test file uses its own subset of these helpers.
#![allow(dead_code)]

use std::process::{Command, Output};

/// The `flexcal` binary under test, to be given arguments.
pub fn command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_flexcal"))
}

/// Runs `flexcal` with `args` and returns what it did.
pub fn flexcal(args: &[&str]) -> Output {
    command()
        .args(args)
        .output()
        .expect("the flexcal binary runs")
}

/// Standard output as text.
pub fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}
