//! The Python suite (tests/python) as part of `cargo test`: writes the Rust
//! reference values the suite compares with, builds the package into a
//! virtual environment under the target directory (maturin, numpy and
//! pytest from PyPI), and fails when pytest fails.
//!
//! Without a Python 3 interpreter or without access to PyPI the test says
//! so on the terminal and passes, except in CI (`CI=true`), where it fails:
//! there everything must run. `FLEXCAL_PYTHON` names the interpreter
//! (default `python3`).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

use flexcal::calib::{
    CalibrationOptions, CalibrationReportJson, MeasurementSet, SelectionOptions, Weighting,
    calibrate_selected, default_method,
};
use flexcal::kinematics::{Data, RobotDescription, forward_pose, param_jacobian};

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// Says on the terminal (past the test harness's capture) why the suite
/// cannot run; fails in CI.
fn cannot_run(why: &str) {
    let message = format!("flexcal-py: Python tests NOT RUN: {why}");
    if in_ci() {
        panic!("{message} (CI=true: the Python suite must run)");
    }
    let _ = writeln!(std::io::stderr(), "\n{message}\n");
}

fn run(command: &mut Command) -> std::io::Result<Output> {
    command.output()
}

fn show(output: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

/// Reference values from the Rust library: UR10 forward poses and
/// parameter Jacobians at fixed configurations, and, with the IPA data,
/// the report of the B -> C calibration with the options `flexcal calibrate
/// --robot ur10 --format ipa` uses (positions only, uniform weights, the
/// default model selection).
fn write_reference(path: &Path) {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let mut qs = Vec::new();
    let mut fk = Vec::new();
    let mut jacobians = Vec::new();
    for k in 0..12 {
        let t = k as f64;
        let q = vec![
            -2.5 + 0.45 * t,
            -1.8 + 0.3 * t,
            2.0 - 0.35 * t,
            (0.7 * t).sin() * 2.0,
            1.0 + (0.4 * t).cos(),
            -3.0 + 0.5 * t,
        ];
        let x = forward_pose(&model, &mut data, &q, &xi).unwrap();
        let m = x.to_homogeneous();
        fk.push(
            (0..4)
                .map(|r| (0..4).map(|c| m[(r, c)]).collect::<Vec<_>>())
                .collect::<Vec<_>>(),
        );
        let (_, jac) = param_jacobian(&model, &mut data, &q, &xi).unwrap();
        jacobians.push(
            (0..6)
                .map(|r| (0..jac.ncols()).map(|c| jac[(r, c)]).collect::<Vec<_>>())
                .collect::<Vec<_>>(),
        );
        qs.push(q);
    }
    let mut reference = serde_json::json!({ "q": qs, "fk": fk, "parameter_jacobian": jacobians });
    let ipa = crate_dir().join("../../../shared/datasets/ipa-ur10");
    let b = ipa.join("Series_B/measurements_joint_configurations.csv");
    let c = ipa.join("Series_C/measurements_random_poses.csv");
    if b.exists() && c.exists() {
        let train = MeasurementSet::read_ipa(&b).unwrap();
        let test = MeasurementSet::read_ipa(&c).unwrap();
        let mut options = CalibrationOptions::for_model(&model);
        options.use_orientation = Some(false);
        options.weighting = Weighting::Uniform;
        // The command line's default model selection (cross-validation
        // from 100 poses).
        let selection = SelectionOptions {
            method: default_method(&train),
            ..SelectionOptions::default()
        };
        let (calibration, selected, _) =
            calibrate_selected(&model, &train, &options, &selection).unwrap();
        let validation = calibration.validate(&model, &test, false).unwrap();
        let mut report = CalibrationReportJson::new(model.name(), &calibration, Some(&validation));
        report.selection = selected;
        reference["ipa_b_to_c"] = serde_json::from_str(&report.to_json_string().unwrap()).unwrap();
    } else {
        println!(
            "IPA UR10 data absent ({}): no B -> C reference",
            ipa.display()
        );
    }
    std::fs::write(path, serde_json::to_string(&reference).unwrap()).unwrap();
}

#[test]
fn python_suite() {
    let work = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("flexcal-py");
    std::fs::create_dir_all(&work).unwrap();
    let reference = work.join("rust_reference.json");
    write_reference(&reference);

    let python = std::env::var("FLEXCAL_PYTHON").unwrap_or_else(|_| "python3".into());
    let venv = work.join("venv");
    let venv_python = venv.join("bin/python");
    let started = Instant::now();
    if !venv_python.exists() {
        match run(Command::new(&python).args(["-m", "venv"]).arg(&venv)) {
            Ok(o) if o.status.success() => {}
            Ok(o) => return cannot_run(&format!("`{python} -m venv` failed:\n{}", show(&o))),
            Err(e) => return cannot_run(&format!("no Python interpreter `{python}`: {e}")),
        }
    }
    let marker = venv.join(".flexcal-tools");
    if !marker.exists() {
        let o = run(Command::new(&venv_python).args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "maturin>=1.5,<2",
            "numpy",
            "pytest",
        ]))
        .unwrap();
        if !o.status.success() {
            return cannot_run(&format!(
                "pip could not install maturin, numpy and pytest:\n{}",
                show(&o)
            ));
        }
        std::fs::write(&marker, "maturin numpy pytest\n").unwrap();
    }
    let tools = started.elapsed();

    // Release profile: from cold it costs about the CPU time of a debug
    // build (neither shares the test profile's artifacts; the workspace
    // optimises dependencies in debug builds too), and the suite then runs
    // at the library's speed (unoptimised, a 200 000-configuration forward
    // model takes seconds and an elasto-geometric identification a minute).
    let target_dir = std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| crate_dir().join("../../target"));
    let build_started = Instant::now();
    let o = run(Command::new(venv.join("bin/maturin"))
        .args(["develop", "--release", "--quiet", "--manifest-path"])
        .arg(crate_dir().join("Cargo.toml"))
        .env("VIRTUAL_ENV", &venv)
        .env("CARGO_TARGET_DIR", &target_dir)
        .env_remove("CARGO_MAKEFLAGS")
        .env_remove("MAKEFLAGS"))
    .unwrap();
    assert!(o.status.success(), "maturin develop failed:\n{}", show(&o));
    let build = build_started.elapsed();

    let pytest_started = Instant::now();
    let o = run(Command::new(&venv_python)
        .args(["-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider"])
        .arg(crate_dir().join("tests/python"))
        .env("FLEXCAL_RUST_REFERENCE", &reference)
        .current_dir(crate_dir().join("tests/python")))
    .unwrap();
    let text = show(&o);
    println!("{text}");
    println!(
        "tools {:.1} s, maturin develop --release {:.1} s, pytest {:.1} s",
        tools.as_secs_f64(),
        build.as_secs_f64(),
        pytest_started.elapsed().as_secs_f64()
    );
    assert!(o.status.success(), "pytest failed:\n{text}");
    // Skips say why; make them visible on the terminal too.
    if let Some(summary) = text.lines().rev().find(|l| l.contains("skipped")) {
        let _ = writeln!(std::io::stderr(), "flexcal-py Python suite: {summary}");
    }
}
