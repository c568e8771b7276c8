//! Shared helpers of the end-to-end tests: running the `flexcal` binary,
//! the commands several tests chain (the twin's elastic campaign, the two
//! elastic identifications), and reading what they write.
// Each test file uses its own subset of these helpers.
#![allow(dead_code)]

use std::path::Path;
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

/// Runs a prepared `flexcal` command that must succeed (its output is in
/// the failure message otherwise) and returns what it did.
pub fn run(command: &mut Command) -> Output {
    let out = command.output().expect("the flexcal binary runs");
    assert!(
        out.status.success(),
        "{command:?}\nstdout:\n{}\nstderr:\n{}",
        stdout(&out),
        stderr(&out)
    );
    out
}

/// Standard output as text.
pub fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// A JSON file's content.
pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `flexcal twin elastic --seed SEED --out OUT`: the virtual IR-663's
/// deflection campaign, which must be written.
pub fn twin_elastic(out: &Path, seed: u64) {
    run(command()
        .args(["twin", "elastic", "--seed", &seed.to_string(), "--out"])
        .arg(out));
}

/// `flexcal identify stiffness --robot ir663 --elastic ELASTIC --data DATA`,
/// to be given further arguments.
pub fn identify_stiffness(elastic: &str, data: &Path) -> Command {
    let mut c = command();
    c.args([
        "identify",
        "stiffness",
        "--robot",
        "ir663",
        "--elastic",
        elastic,
    ])
    .arg("--data")
    .arg(data);
    c
}

/// `flexcal identify compliance --data DATA`, to be given further arguments.
pub fn identify_compliance(data: &Path) -> Command {
    let mut c = command();
    c.args(["identify", "compliance", "--data"]).arg(data);
    c
}
