//! `flexcal twin forming` and `flexcal compensate` run end to end on temporary files.

use std::path::Path;
use std::process::Output;

mod common;
use common::{flexcal, identify_compliance, identify_stiffness, run, stderr, twin_elastic};

fn text(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap()
}

/// Header and rows of a CSV file written by `compensate`.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let content = text(path);
    let mut lines = content.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}

fn column(header: &[String], rows: &[Vec<String>], name: &str) -> Vec<f64> {
    let j = header.iter().position(|h| h == name).unwrap();
    rows.iter().map(|r| r[j].parse::<f64>().unwrap()).collect()
}

/// Writes the twin's forming target path into `dir` and returns its path.
fn forming_target(dir: &Path) -> std::path::PathBuf {
    let twin = dir.join("twin");
    let out = flexcal(&["twin", "forming", "--out", twin.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    for file in [
        "target_path.csv",
        "forming_result.json",
        "forming_paths.csv",
    ] {
        assert!(twin.join(file).exists(), "{file} missing");
    }
    twin.join("target_path.csv")
}

/// `flexcal compensate` of the path file `path` with the built-in FE model,
/// the forming cell's part pose and `process`, into `out`, with `extra`
/// arguments.
fn compensate(path: &Path, process: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "compensate",
        "--robot",
        "ir663",
        "--elastic",
        "fe:ir663",
        "--path",
        path.to_str().unwrap(),
        "--part-pose",
        "1200,0,1450,0,0,0",
        "--process",
        process,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    flexcal(&args)
}

#[test]
fn twin_forming_compensation_reaches_the_target_and_writes_krl() {
    let dir = tempfile::tempdir().unwrap();
    let target = forming_target(dir.path());
    let json: serde_json::Value =
        serde_json::from_str(&text(&dir.path().join("twin/forming_result.json"))).unwrap();
    let before = json["uncompensated"]["max_abs_deviation_z_mm"]
        .as_f64()
        .unwrap();
    let after = json["compensated"][0]["max_abs_deviation_z_mm"]
        .as_f64()
        .unwrap();
    // Compensating with the nominal FE model removes part of the sag.
    assert!(
        after < before,
        "compensated {after} mm vs uncompensated {before} mm"
    );

    let out_csv = dir.path().join("commanded.csv");
    let krl = dir.path().join("path.src");
    let out = compensate(
        &target,
        "cantilever:585,50,14,Al-5005,large",
        &out_csv,
        &["--payload", "0,0,-920", "--krl", krl.to_str().unwrap()],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let n_points = text(&target).lines().count() - 1;
    let (header, rows) = read_csv(&out_csv);
    assert_eq!(rows.len(), n_points);
    let lines = column(&header, &rows, "line");
    assert_eq!(lines[0], 2.0);
    for r in column(&header, &rows, "res_mm") {
        assert!(r < 1e-6, "residual {r} mm");
    }
    // At the first point the tool only touches the beam: the 920 N dead
    // weight alone makes it sag by millimetres; deeper in, the beam pushes back.
    let dz = column(&header, &rows, "pred_dz_mm");
    assert!(dz[0] < -1.0, "{dz:?}");
    assert!(dz[n_points - 1] > dz[0], "{dz:?}");
    let program = text(&krl);
    assert_eq!(program.matches("PTP {").count(), 1);
    assert_eq!(program.matches("LIN {").count(), n_points - 1);
}

#[test]
fn rapid_and_joint_trajectory_exports_carry_the_commanded_path() {
    let dir = tempfile::tempdir().unwrap();
    let target = forming_target(dir.path());
    let out_csv = dir.path().join("commanded.csv");
    let rapid = dir.path().join("path.mod");
    let joints = dir.path().join("joints.csv");
    let out = compensate(
        &target,
        "constant:0,0,-920,0,0,0",
        &out_csv,
        &[
            "--rapid",
            rapid.to_str().unwrap(),
            "--joints-csv",
            joints.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let (header, rows) = read_csv(&out_csv);
    let module = text(&rapid);
    assert!(module.contains("MODULE"), "{module}");
    // One robtarget per point: a joint move to the first, linear moves on.
    assert_eq!(module.matches("CONST robtarget").count(), rows.len());
    assert_eq!(module.matches("MoveJ ").count(), 1);
    assert_eq!(module.matches("MoveL ").count(), rows.len() - 1);
    let (j_header, j_rows) = read_csv(&joints);
    assert_eq!(j_rows.len(), rows.len());
    // The trajectory holds the commanded coordinates of the main output
    // (rad and m there, deg and mm in the trajectory).
    for (k, name) in j_header.iter().enumerate() {
        let q = column(&header, &rows, &format!("q{}", k + 1));
        let scale = if name.ends_with("_deg") {
            180.0 / std::f64::consts::PI
        } else {
            assert!(name.ends_with("_mm"), "{name}");
            1e3
        };
        let exported = column(&j_header, &j_rows, name);
        for (a, b) in q.iter().zip(&exported) {
            assert!((a * scale - b).abs() < 1e-6, "{name}: {a} vs {b}");
        }
    }
}

#[test]
fn zero_load_commands_the_inverse_model() {
    let dir = tempfile::tempdir().unwrap();
    let target = forming_target(dir.path());
    let out_csv = dir.path().join("commanded.csv");
    let out = compensate(&target, "constant:0,0,0,0,0,0", &out_csv, &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (header, rows) = read_csv(&out_csv);
    let (t_header, t_rows) = read_csv(&target);
    for name in ["pred_dx_mm", "pred_dy_mm", "pred_dz_mm", "iterations"] {
        for v in column(&header, &rows, name) {
            assert!(v.abs() < 1e-9, "{name} = {v}");
        }
    }
    // The commanded pose is the target itself, moved by the part pose.
    let offsets = [("x_mm", 1200.0), ("y_mm", 0.0), ("z_mm", 1450.0)];
    for (name, offset) in offsets {
        let commanded = column(&header, &rows, name);
        let wanted = column(&t_header, &t_rows, name);
        for (c, w) in commanded.iter().zip(&wanted) {
            assert!(
                (c - (w + offset)).abs() < 1e-5,
                "{name}: {c} vs {}",
                w + offset
            );
        }
    }
    for name in ["qw", "qx", "qy", "qz"] {
        let commanded = column(&header, &rows, name);
        let wanted = column(&t_header, &t_rows, name);
        for (c, w) in commanded.iter().zip(&wanted) {
            assert!((c - w).abs() < 1e-8, "{name}: {c} vs {w}");
        }
    }
}

#[test]
fn unreachable_point_is_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("far.csv");
    std::fs::write(&path, "x_mm,y_mm,z_mm\n580,0,0\n5000,0,0\n560,0,0\n").unwrap();
    let out_csv = dir.path().join("commanded.csv");
    std::fs::write(&out_csv, "previous content\n").unwrap();
    let krl = dir.path().join("path.src");
    let out = compensate(
        &path,
        "constant:0,0,-100,0,0,0",
        &out_csv,
        &["--krl", krl.to_str().unwrap()],
    );
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("line 3:"), "{err}");
    assert!(
        !err.contains("line 2:") && !err.contains("line 4:"),
        "{err}"
    );
    assert_eq!(text(&out_csv), "previous content\n");
    assert!(!krl.exists());
}

#[test]
fn malformed_path_gives_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let out_csv = dir.path().join("commanded.csv");
    let cases = [
        ("missing.csv", "x_mm,y_mm\n580,0\n", "z_mm"),
        ("nan.csv", "x_mm,y_mm,z_mm\n580,0,0\nNaN,0,0\n", ":3"),
    ];
    for (name, content, expected) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, content).unwrap();
        let out = compensate(&path, "constant:0,0,0,0,0,0", &out_csv, &[]);
        assert!(!out.status.success());
        let err = stderr(&out);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(name) && err.contains(expected), "{err}");
        assert!(!out_csv.exists());
    }
}

fn run_ok(args: &[&str]) {
    let out = flexcal(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
}

#[test]
fn identified_models_compensate_the_twin_forming_path() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    run_ok(&["twin", "geometric", "--out", &p("geo")]);
    let identification = p("geo/identification.csv");
    let validation = p("geo/validation.csv");
    run_ok(&[
        "calibrate",
        "--robot",
        "ir663",
        "--data",
        &identification,
        "--validate",
        &validation,
        "--fixed-target",
        "--out",
        &p("calibrated.toml"),
        "--report",
        &p("calibration.json"),
    ]);
    let elastic = dir.path().join("elastic");
    twin_elastic(&elastic, 7);
    run(identify_stiffness("ir663", &elastic)
        .args([
            "--train-load",
            "900",
            "--search-evaluations",
            "0",
            "--report",
        ])
        .arg(dir.path().join("stiffness.json")));
    run(identify_compliance(&elastic)
        .args([
            "--inputs",
            "theta2,theta8",
            "--train-load",
            "900",
            "--seed",
            "1",
            "--out",
        ])
        .arg(dir.path().join("fuzzy.toml")));
    run_ok(&[
        "twin",
        "forming",
        "--out",
        &p("forming"),
        "--calibrated",
        &p("calibrated.toml"),
        "--calibration-report",
        &p("calibration.json"),
        "--fe-report",
        &p("stiffness.json"),
        "--fuzzy",
        &p("fuzzy.toml"),
    ]);
    let json: serde_json::Value =
        serde_json::from_str(&text(&dir.path().join("forming/forming_result.json"))).unwrap();
    let before = json["uncompensated"]["max_abs_deviation_z_mm"]
        .as_f64()
        .unwrap();
    let compensated = json["compensated"].as_array().unwrap();
    assert_eq!(compensated.len(), 2);
    for c in compensated {
        let after = c["max_abs_deviation_z_mm"].as_f64().unwrap();
        // The paper's claim: identified models remove most of the deviation.
        assert!(
            after < 0.2 * before,
            "{}: {after} mm vs {before} mm",
            c["label"]
        );
    }
    let figure = text(&dir.path().join("forming/forming_paths.csv"));
    let n_points = text(&dir.path().join("forming/target_path.csv"))
        .lines()
        .count()
        - 1;
    assert_eq!(figure.lines().count(), 1 + 3 * n_points);

    let target = dir.path().join("forming/target_path.csv");
    let calibrated = p("calibrated.toml");
    for (elastic, report) in [
        (format!("fuzzy:{}", p("fuzzy.toml")), None),
        ("fe:ir663".to_string(), Some(p("stiffness.json"))),
    ] {
        let out_csv = dir.path().join("commanded.csv");
        let mut args = vec![
            "compensate",
            "--robot",
            "ir663",
            "--calibrated",
            &calibrated,
            "--elastic",
            &elastic,
            "--path",
            target.to_str().unwrap(),
            "--part-pose",
            "1200,0,1450,0,0,0",
            "--process",
            "cantilever:585,50,14,Al-5005",
            "--payload",
            "0,0,-920",
            "--out",
            out_csv.to_str().unwrap(),
        ];
        if let Some(r) = &report {
            args.extend(["--gamma-report", r]);
        }
        run_ok(&args);
        let (header, rows) = read_csv(&out_csv);
        assert_eq!(rows.len(), n_points);
        for r in column(&header, &rows, "res_mm") {
            assert!(r < 1e-6, "{elastic}: residual {r} mm");
        }
    }
}

/// Runs `flexcal compensate` with the FE model and the stiffness report
/// `report_text` on a one-point path; returns its standard error, after
/// checking that it failed.
fn compensate_with_gamma_report(report_text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("stiffness.json");
    std::fs::write(&report, report_text).unwrap();
    let path = dir.path().join("path.csv");
    std::fs::write(&path, "x_mm,y_mm,z_mm\n580,0,0\n").unwrap();
    let out = compensate(
        &path,
        "constant:0,0,0,0,0,0",
        &dir.path().join("out.csv"),
        &["--gamma-report", report.to_str().unwrap()],
    );
    assert!(!out.status.success());
    stderr(&out)
}

#[test]
fn gamma_report_of_another_model_is_refused() {
    // A well-formed stiffness report of a model with another parameter.
    let text = r#"{"robot": "ir663", "elastic": "other", "train_load_n": 900.0,
        "train_sets": [], "seed": 1,
        "parameters": [{"name": "k_wrong", "value": 1.0, "unit": "N.m/rad",
                        "after_global_search": 1.0, "sensitivity_sigma_per_ln": 1.0}],
        "identifiability": {"names": ["k_wrong"], "structural_rank": 1,
            "structural_singular_values": [1.0], "weighted_singular_values": [1.0],
            "sensitivity": [1.0], "groups": [], "identifiable": ["k_wrong"], "undetermined": []},
        "identifiability_text": [],
        "solver": {"termination": "Converged", "iterations": 1, "residual_evaluations": 1,
            "jacobian_evaluations": 1, "rank": 1, "n_free": 1, "singular_values": [1.0],
            "condition_number": 1.0, "cost_history": []},
        "global_search": {"evaluations": 0, "best_value": null},
        "criterion_mm2": 0.0,
        "per_load": {"rows": [], "overall_rms_mm": 0.0, "count": 0},
        "noise_floor_rms_mm": 0.0}
"#;
    let err = compensate_with_gamma_report(text);
    assert!(
        err.contains("stiffness.json") && err.contains("parameters"),
        "{err}"
    );
}

#[test]
fn a_file_that_is_not_a_stiffness_report_is_refused_by_name() {
    let err = compensate_with_gamma_report(r#"{"parameters": [{"name": "k", "value": 1.0}]}"#);
    assert!(
        err.contains("stiffness.json") && err.contains("not a stiffness report"),
        "{err}"
    );
}
