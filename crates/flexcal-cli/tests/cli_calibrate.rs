//! `flexcal twin geometric`, `flexcal calibrate` and `flexcal poses select`
//! end to end on temporary files, and bad input.

use std::path::Path;
use std::process::Output;

mod common;
use common::flexcal;

fn text(output: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).display().to_string()
}

fn read_json(path: impl AsRef<Path>) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A measurement file `DIR/name.csv` of the nominal UR10 at `n`
/// deterministic configurations spread over the workspace (`phase` shifts
/// them), its target positions (mm) seen through `place` (the tracker's
/// placement); configurations and positions by `flexcal fk`.
fn ur10_measurements(
    d: &Path,
    name: &str,
    n: usize,
    phase: f64,
    place: &dyn Fn([f64; 3]) -> [f64; 3],
) -> String {
    let q_file = path(d, &format!("{name}-q.csv"));
    let p_file = path(d, &format!("{name}-p.csv"));
    let mut q_text = String::from("q1,q2,q3,q4,q5,q6\n");
    for k in 0..n {
        let t = k as f64 + phase;
        q_text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            (0.37 * t).sin() * 2.5,
            -1.5 + (0.53 * t).sin(),
            (0.29 * t).cos() * 2.0,
            (0.71 * t).sin() * 2.0,
            0.8 + (0.43 * t).sin(),
            (0.61 * t).cos() * 2.5
        ));
    }
    std::fs::write(&q_file, &q_text).unwrap();
    let out = flexcal(&[
        "fk", "--robot", "ur10", "--input", &q_file, "--output", &p_file,
    ]);
    assert!(out.status.success(), "{}", text(&out).1);
    let poses = std::fs::read_to_string(&p_file).unwrap();
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm\n");
    for (q, p) in q_text.lines().skip(1).zip(poses.lines().skip(1)) {
        let xyz: Vec<f64> = p.split(',').take(3).map(|v| v.parse().unwrap()).collect();
        let [x, y, z] = place([xyz[0] * 1e3, xyz[1] * 1e3, xyz[2] * 1e3]);
        csv.push_str(&format!("{q},{x},{y},{z}\n"));
    }
    let file = path(d, &format!("{name}.csv"));
    std::fs::write(&file, csv).unwrap();
    file
}

#[test]
fn twin_files_calibrate_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = flexcal(&[
        "twin",
        "geometric",
        "--out",
        &d.display().to_string(),
        "--seed",
        "7",
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    for f in [
        "identification.csv",
        "validation.csv",
        "truth.toml",
        "truth.json",
    ] {
        assert!(d.join(f).exists(), "{f} written");
    }
    // `flexcal calibrate --robot ir663 --data identification.csv` and `extra`.
    let identification = path(d, "identification.csv");
    let calibrate_twin = |extra: &[&str]| {
        let mut args = vec!["calibrate", "--robot", "ir663", "--data", &identification];
        args.extend_from_slice(extra);
        flexcal(&args)
    };
    let out = calibrate_twin(&[
        "--validate",
        &path(d, "validation.csv"),
        "--fixed-target",
        "--out",
        &path(d, "calibrated.toml"),
        "--report",
        &path(d, "report.json"),
        "--html",
        &path(d, "report.html"),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("NON-IDENTIFIABLE") && stdout.contains("validation after"),
        "{stdout}"
    );
    assert!(stdout.contains("HTML report written to"), "{stdout}");
    let page = std::fs::read_to_string(d.join("report.html")).unwrap();
    assert!(
        page.starts_with("<!DOCTYPE html>")
            && page.contains("Measured error against the predicted 95 % bound"),
        "{page}"
    );
    let report: serde_json::Value = read_json(d.join("report.json"));
    let id = &report["identification"];
    // Every robot parameter is identified, non-identifiable or poorly identifiable.
    let rank = id["rank"].as_u64().unwrap() as usize;
    let non = id["non_identifiable"].as_array().unwrap().len();
    let poor = id["poorly_identifiable"].as_array().unwrap().len();
    // With the camera's frame identified (6 unknowns), which absorbs the
    // base's four parameters (alpha1, d1, theta1, r1).
    assert_eq!(rank + non + poor, 43 + 6, "{id}");
    assert!((37..=41).contains(&rank), "rank {rank}");
    assert!(!id["combinations"].as_array().unwrap().is_empty());
    // The geometric model's coverage has no torque spans.
    for entry in id["coverage"].as_array().unwrap() {
        assert!(entry.get("torque").is_none(), "{entry}");
        assert!(entry["lo"].as_f64().unwrap() <= entry["hi"].as_f64().unwrap());
    }
    let v = &report["validation"];
    for key in [
        "position_mean_mm",
        "position_rms_mm",
        "position_max_mm",
        "orientation_mean_deg",
    ] {
        assert!(v[key].as_f64().is_some(), "validation.{key}");
        assert!(id[key].as_f64().is_some(), "identification.{key}");
    }
    assert!(v["position_mean_mm"].as_f64().unwrap() < 0.1);
    // A smooth fit refuses no trial point, and says so.
    assert_eq!(id["refused_trials"], 0, "{id}");
    assert!(id.get("last_refusal").is_none(), "{id}");
    // The nominal robot registered on the camera: tenths of a millimetre.
    assert!(v["before"]["position_mean_mm"].as_f64().unwrap() > 0.3);
    // Identified unknowns carry their spread ratio, the others none.
    let parameter = |report: &serde_json::Value, name: &str| -> serde_json::Value {
        report["identification"]["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap_or_else(|| panic!("{name} in the report"))
            .clone()
    };
    for p in id["parameters"].as_array().unwrap() {
        let identified = p["status"] == "identified";
        assert_eq!(p["spread_ratio"].as_f64().is_some(), identified, "{p}");
        if identified {
            assert!(p["spread_ratio"].as_f64().unwrap() > 0.0, "{p}");
        }
    }
    // A target 5 mm further along the tool axis, kept fixed: the robot's
    // tool length rE takes the difference, to the micrometre.
    let out = calibrate_twin(&[
        "--fixed-target",
        "--target-mm",
        "0,0,5",
        "--report",
        &path(d, "report_target.json"),
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    let shifted: serde_json::Value = read_json(d.join("report_target.json"));
    let re = |r: &serde_json::Value| parameter(r, "rE")["identified"].as_f64().unwrap();
    assert!(
        (re(&report) - re(&shifted) - 5.0).abs() < 1e-3,
        "rE {} and {}",
        re(&report),
        re(&shifted)
    );
    // Poses left out by their pose_id: the report counts what is left.
    let out = calibrate_twin(&[
        "--fixed-target",
        "--exclude",
        "identification-3,identification-9",
        "--validate",
        &path(d, "validation.csv"),
        "--exclude-validation",
        "validation-1",
        "--split-check",
        "--cross-check",
        "--report",
        &path(d, "report_excluded.json"),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("--exclude: 2 of the 27 poses"), "{stdout}");
    let excluded: serde_json::Value = read_json(d.join("report_excluded.json"));
    assert_eq!(excluded["identification"]["n_poses"], 25);
    assert_eq!(excluded["validation"]["n_poses"], 15);
    // The split-half check: the twin's noise is independent, so the halves
    // agree about as the standard errors predict.
    assert!(stdout.contains("Split-half check"), "{stdout}");
    let mut ratios: Vec<f64> = excluded["split_check"]["unknowns"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|u| u["ratio"].as_f64())
        .collect();
    assert!(ratios.len() > 25, "{ratios:?}");
    ratios.sort_by(f64::total_cmp);
    assert!(ratios[ratios.len() / 2] < 1.5, "{ratios:?}");
    // The cross-series check: the validation poses are of the same robot,
    // so most unknowns agree within their standard errors. The twin's
    // drives remember the direction they were last loaded from, and the
    // two campaigns approach their poses differently: a few unknowns may
    // differ beyond chance (measured: two, a traded pair at z +4.05 and
    // -4.06), which is what the check is there to show.
    assert!(stdout.contains("Cross-series check"), "{stdout}");
    let cross = &excluded["cross_check"];
    assert_eq!(cross["other_poses"], 15);
    let z: Vec<f64> = cross["unknowns"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|u| u["z"].as_f64())
        .collect();
    assert!(z.len() > 25, "{cross}");
    let mut magnitudes: Vec<f64> = z.iter().map(|z| z.abs()).collect();
    magnitudes.sort_by(f64::total_cmp);
    assert!(magnitudes[magnitudes.len() / 2] < 1.5, "{z:?}");
    assert!(
        z.iter().filter(|z| z.abs() > 3.0).count() <= z.len() / 10,
        "{z:?}"
    );
    // A pose measured 3 mm off: named as suspect, with the option that
    // leaves it out; left out, the fit is back to the noise.
    let text_in = std::fs::read_to_string(d.join("identification.csv")).unwrap();
    let mut lines: Vec<String> = text_in.lines().map(String::from).collect();
    let x_col = lines[0].split(',').position(|h| h == "x_mm").unwrap();
    let mut cells: Vec<String> = lines[5].split(',').map(String::from).collect();
    cells[x_col] = (cells[x_col].parse::<f64>().unwrap() + 3.0).to_string();
    lines[5] = cells.join(",");
    std::fs::write(d.join("outlier.csv"), lines.join("\n") + "\n").unwrap();
    let outlier = path(d, "outlier.csv");
    let with_outlier = |extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            "--robot",
            "ir663",
            "--data",
            &outlier,
            "--fixed-target",
        ];
        args.extend_from_slice(extra);
        let out = flexcal(&args);
        let (stdout, stderr) = text(&out);
        assert!(out.status.success(), "{stdout}\n{stderr}");
        stdout
    };
    let stdout = with_outlier(&[]);
    assert!(
        stdout.contains("1 pose with a position error above 4 times the RMS error")
            && stdout.contains("run again with --exclude 'identification-5'"),
        "{stdout}"
    );
    let stdout = with_outlier(&["--exclude", "identification-5"]);
    assert!(!stdout.contains("data check"), "{stdout}");
    // The twin's noise is Gaussian: no data check fires.
    for set in ["identification", "validation"] {
        let checks = &excluded[set]["data_checks"];
        assert_eq!(
            checks["suspect_poses"].as_array().unwrap().len(),
            0,
            "{checks}"
        );
        assert_eq!(
            checks["repeated_readings"].as_array().unwrap().len(),
            0,
            "{checks}"
        );
    }
    // The calibrated robot loads back.
    let out = flexcal(&[
        "calibrate",
        "--robot",
        &path(d, "calibrated.toml"),
        "--data",
        &path(d, "validation.csv"),
        "--fixed-target",
        "--fix",
        "alpha1,d1",
    ]);
    // 16 poses x 6 rows = 96 equations for the remaining unknowns: runs.
    assert!(out.status.success(), "{:?}", text(&out));

    // Pose selection from the validation file used as a candidate pool.
    let out = flexcal(&[
        "poses",
        "select",
        "--robot",
        "ir663",
        "--candidates",
        &path(d, "identification.csv"),
        "--count",
        "12",
        "--index",
        "o3",
        "--orientation",
        "--out",
        &path(d, "selected.csv"),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let selected = std::fs::read_to_string(d.join("selected.csv")).unwrap();
    assert_eq!(selected.lines().count(), 13);
}

#[test]
fn bad_input_gives_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, body: &str| {
        std::fs::write(d.join(name), body).unwrap();
        path(d, name)
    };
    let run = |file: &str, extra: &[&str]| {
        let mut args = vec!["calibrate", "--robot", "ur10", "--data", file];
        args.extend_from_slice(extra);
        let out = flexcal(&args);
        let (stdout, stderr) = text(&out);
        assert!(!out.status.success(), "should fail: {stdout}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        stderr
    };
    let header = "q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm\n";
    let malformed = write(
        "malformed.csv",
        &format!("{header}0,0,0,0,0,0,1,2,3\n0,0,0,0,0,1,2\n"),
    );
    let err = run(&malformed, &[]);
    assert!(err.contains("malformed.csv:3"), "{err}");
    let missing = write(
        "missing.csv",
        "q1,q2,q3,q4,q5,q6,x_mm,y_mm\n0,0,0,0,0,0,1,2\n",
    );
    let err = run(&missing, &[]);
    assert!(err.contains("z_mm"), "{err}");
    let nan = write("nan.csv", &format!("{header}0,0,0,0,0,0,1,NaN,3\n"));
    let err = run(&nan, &[]);
    assert!(err.contains("nan.csv:2") && err.contains("y_mm"), "{err}");
    let few: String = (0..4)
        .map(|k| format!("0.{k},-1,1,0,1,0,{k}00,20,30\n"))
        .collect();
    let few = write("few.csv", &format!("{header}{few}"));
    let err = run(&few, &[]);
    assert!(err.contains("too few measurements"), "{err}");
    let wrong = write("wrong.csv", "q1,q2,x_mm,y_mm,z_mm\n0,0,1,2,3\n");
    let err = run(&wrong, &[]);
    assert!(err.contains("actuated coordinates"), "{err}");
    // Rank deficient with nothing fixed: with --strict an error naming the parameters.
    let rows: String = (0..30)
        .map(|k| {
            let t = k as f64;
            format!(
                "{},{},{},{},{},{},{},{},{}\n",
                0.1 * t,
                -1.0 + 0.03 * t,
                1.0 - 0.02 * t,
                0.1 * t,
                0.5,
                0.2 * t,
                1000.0 + 7.0 * t,
                (t * 0.3).sin() * 300.0,
                200.0 + t * t
            )
        })
        .collect();
    let deficient = write("deficient.csv", &format!("{header}{rows}"));
    let err = run(&deficient, &["--strict"]);
    assert!(
        err.contains("rank-deficient") && err.contains("theta1"),
        "{err}"
    );
    let err = run(&deficient, &["--fix", "nonsense"]);
    assert!(err.contains("unknown parameter `nonsense`"), "{err}");
    let err = run(&deficient, &["--target-mm", "1,2"]);
    assert!(err.contains("--target-mm takes three values"), "{err}");
    let err = run(&deficient, &["--exclude", "#3,line 99"]);
    assert!(
        err.contains("no pose `line 99`") && err.contains("deficient.csv"),
        "{err}"
    );
    let err = run(&deficient, &["--with-orientation"]);
    assert!(
        err.contains("--with-orientation") && err.contains("is for format ipa (--format ipa)"),
        "{err}"
    );
    let err = run(
        &deficient,
        &["--format", "ipa", "--with-orientation", "--position-only"],
    );
    assert!(err.contains("cannot be used with"), "{err}");
    let err = run(&deficient, &["--exclude-validation", "#3"]);
    assert!(
        err.contains("--exclude-validation needs --validate"),
        "{err}"
    );
    let err = run(&deficient, &["--cross-check"]);
    assert!(
        err.contains("--cross-check") && err.contains("--validate"),
        "{err}"
    );
}

/// `calibrate --model elasto-geometric` end to end: UR10 poses from `flexcal
/// fk`, a mass table file, the report's elastic unknowns; bad mass tables.
#[test]
fn elasto_geometric_calibration_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Seen from a tracker 3 m away.
    let measurements = |name: &str, n: usize, phase: f64| -> String {
        ur10_measurements(d, name, n, phase, &|[x, y, z]| {
            [x + 3000.0, y - 200.0, z + 100.0]
        })
    };
    let train = measurements("train", 120, 0.0);
    let validate = measurements("validate", 60, 0.5);
    let masses = path(d, "masses.toml");
    std::fs::write(
        &masses,
        "payload_mass_kg = 1.0\npayload_center_mm = [0.0, 0.0, 100.0]\ninitial_compliance_urad_per_nm = 10.0\n\n[[mass]]\nname = \"upper arm\"\nframe = \"2\"\nmass_kg = 12.93\ncenter_mm = [-306.0, 0.0, 0.0]\n\n[[mass]]\nname = \"forearm\"\nframe = \"3\"\nmass_kg = 3.87\ncenter_mm = [-286.15, 0.0, 0.0]\n",
    )
    .unwrap();
    // `flexcal calibrate --robot ur10 --data train.csv` and `extra`.
    let calibrate_ur10 = |extra: &[&str]| {
        let mut args = vec!["calibrate", "--robot", "ur10", "--data", &train];
        args.extend_from_slice(extra);
        flexcal(&args)
    };
    let report = path(d, "report.json");
    let residuals = path(d, "residuals.csv");
    // By default (120 poses) cross-validation chooses the groups of
    // unknowns: this rigid robot's compliances are not kept.
    let out = calibrate_ur10(&["--model", "elasto-geometric", "--masses", &masses]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("Model selection by 5-fold cross-validation"),
        "{stdout}"
    );
    assert!(
        stdout.contains("chosen:") && !stdout.contains("compliance_theta2"),
        "{stdout}"
    );
    let out = calibrate_ur10(&[
        "--validate",
        &validate,
        "--model",
        "elasto-geometric",
        "--masses",
        &masses,
        "--select",
        "none",
        "--report",
        &report,
        "--residuals",
        &residuals,
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("elasto-geometric") && stdout.contains("compliance_theta2"));
    assert!(stdout.contains("predicted 95 % bounds"), "{stdout}");
    // Per-pose errors of the validation set, one row per pose.
    let rows = std::fs::read_to_string(&residuals).unwrap();
    assert!(rows.starts_with(
        "pose,temperature_c,position_error_mm,orientation_error_deg,dx_mm,dy_mm,dz_mm\n"
    ));
    assert_eq!(rows.lines().count(), 61);
    for line in rows.lines().skip(1) {
        let field = |i: usize| line.split(',').nth(i).unwrap().parse::<f64>().unwrap();
        assert!(field(2) < 1e-3, "{line}");
        // The norm column is the norm of the component columns.
        let norm = (field(4).powi(2) + field(5).powi(2) + field(6).powi(2)).sqrt();
        assert!((norm - field(2)).abs() <= 1e-9 + 1e-9 * field(2), "{line}");
    }
    assert!(stdout.contains("pos RMS mm"), "{stdout}");
    let json: serde_json::Value = read_json(&report);
    assert_eq!(json["model"], "elasto-geometric");
    // An exact fit (errors of round-off size) has no suspect poses.
    let suspects = &json["identification"]["data_checks"]["suspect_poses"];
    assert_eq!(suspects.as_array().unwrap().len(), 0, "{suspects}");
    let identification = &json["identification"];
    // Gravity never loads joint 1 (vertical axis): its compliance moves
    // nothing.
    let c1 = identification["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "compliance_theta1")
        .unwrap();
    assert_eq!(c1["status"], "no-influence", "{c1}");
    let c2 = identification["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "compliance_theta2")
        .unwrap();
    assert_eq!(c2["unit"], "urad/N.m");
    // The measurements are of the rigid nominal robot: the fit ends at
    // their (zero) error, with joint 2 found stiff.
    assert!(identification["position_max_mm"].as_f64().unwrap() < 1e-3);
    assert_eq!(c2["status"], "identified");
    assert!(c2["identified"].as_f64().unwrap().abs() < 0.01);
    let history = identification["position_rms_history_mm"]
        .as_array()
        .unwrap();
    assert_eq!(
        history.len(),
        identification["cost_history"].as_array().unwrap().len()
    );
    // What the poses cover: an arc of at most a turn for each revolute
    // joint, with the gravity torque span its compliance was identified over.
    let coverage = identification["coverage"].as_array().unwrap();
    assert_eq!(coverage.len(), 6);
    for entry in coverage {
        assert_eq!(entry["unit"], "deg");
        assert_eq!(entry["periodic"], true);
        let (lo, hi) = (entry["lo"].as_f64().unwrap(), entry["hi"].as_f64().unwrap());
        assert!(lo <= hi && hi - lo < 360.0, "{entry}");
        let torque = entry["torque"].as_array().unwrap();
        assert!(torque[0].as_f64().unwrap() <= torque[1].as_f64().unwrap());
    }
    assert_eq!(coverage[1]["coordinate"], "theta2");
    assert!(coverage[1]["torque"][1].as_f64().unwrap().abs() > 1.0);
    let validation = &json["validation"];
    assert!(validation["position_mean_mm"].as_f64().unwrap() < 1e-3);
    assert!(validation["note"].as_str().unwrap().contains("re-fitted"));
    for entry in validation["extrapolated_coordinates"].as_array().unwrap() {
        let fraction = entry["fraction_outside"].as_f64().unwrap();
        assert!(entry["coordinate"].as_str().unwrap().starts_with("theta"));
        assert!(fraction > 0.0 && fraction <= 1.0);
    }

    // A robot without a built-in mass table, and a malformed table.
    let out = flexcal(&[
        "calibrate",
        "--robot",
        "puma560",
        "--data",
        &train,
        "--model",
        "elasto-geometric",
    ]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success() && !stderr.contains("panicked"));
    assert!(stderr.contains("no built-in mass table"), "{stderr}");
    let bad = path(d, "bad.toml");
    std::fs::write(
        &bad,
        "payload_mass_kg = 1.0\npayload_center_mm = [0.0, 0.0]\n",
    )
    .unwrap();
    let out = calibrate_ur10(&["--model", "elasto-geometric", "--masses", &bad]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success() && !stderr.contains("panicked"));
    assert!(stderr.contains("bad.toml:2"), "{stderr}");
    // A payload on a frame the robot does not have: named, nothing written.
    std::fs::write(
        &bad,
        "payload_mass_kg = 1.0\npayload_center_mm = [0.0, 0.0, 0.0]\npayload_frame = \"flange\"\ninitial_compliance_urad_per_nm = 10.0\n[[mass]]\nname = \"arm\"\nframe = \"2\"\nmass_kg = 10.0\ncenter_mm = [300.0, 0.0, 0.0]\n",
    )
    .unwrap();
    let unwritten = path(d, "unwritten.json");
    let out = calibrate_ur10(&[
        "--model",
        "elasto-geometric",
        "--masses",
        &bad,
        "--report",
        &unwritten,
    ]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success() && !stderr.contains("panicked"));
    assert!(stderr.contains("payload frame `flange`"), "{stderr}");
    assert!(!std::path::Path::new(&unwritten).exists());
    // So is a further payload (`[[payload]]`) on such a frame.
    std::fs::write(
        &bad,
        "payload_mass_kg = 1.0\npayload_center_mm = [0.0, 0.0, 0.0]\ninitial_compliance_urad_per_nm = 10.0\n[[mass]]\nname = \"arm\"\nframe = \"2\"\nmass_kg = 10.0\ncenter_mm = [300.0, 0.0, 0.0]\n[[payload]]\nname = \"gripper\"\nframe = \"hand\"\nmass_kg = 2.0\ncenter_mm = [0.0, 0.0, 50.0]\n",
    )
    .unwrap();
    let out = calibrate_ur10(&[
        "--model",
        "elasto-geometric",
        "--masses",
        &bad,
        "--report",
        &unwritten,
    ]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success() && !stderr.contains("panicked"));
    assert!(
        stderr.contains("payload `gripper`") && stderr.contains("no frame `hand`"),
        "{stderr}"
    );
    assert!(!std::path::Path::new(&unwritten).exists());

    // The fuzzy residual model, reported apart: these measurements are
    // exact, so it has nothing to add and the validation stays exact.
    let out = calibrate_ur10(&[
        "--validate",
        &validate,
        "--residual-model",
        "theta2,theta3",
        "--report",
        &report,
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("validation, + residual"), "{stdout}");
    let json: serde_json::Value = read_json(&report);
    let residual = &json["residual_model"];
    assert_eq!(residual["inputs"], serde_json::json!(["theta2", "theta3"]));
    assert_eq!(residual["rules"].as_array().unwrap().len(), 3);
    assert!(residual["validation"]["position_mean_mm"].as_f64().unwrap() < 1e-3);
    let out = calibrate_ur10(&["--residual-model", "theta9"]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success() && !stderr.contains("panicked"));
    assert!(
        stderr.contains("--residual-model") && stderr.contains("theta9"),
        "{stderr}"
    );
}

#[test]
fn several_stations_pool_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // One UR10 seen from two placements of the tracker: the second on the
    // other side, turned a quarter turn about the vertical.
    let station = |name: &str, n: usize, phase: f64, place: &dyn Fn([f64; 3]) -> [f64; 3]| {
        ur10_measurements(d, name, n, phase, place)
    };
    let north = station("north", 40, 0.0, &|[x, y, z]| {
        [x + 3000.0, y - 200.0, z + 100.0]
    });
    let south = station("south", 40, 0.5, &|[x, y, z]| {
        [-y - 2500.0, x + 1500.0, z - 300.0]
    });
    let report = path(d, "report.json");
    let pooled = |extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            "--robot",
            "ur10",
            "--data",
            &north,
            "--data",
            &south,
        ];
        args.extend_from_slice(extra);
        flexcal(&args)
    };
    let out = pooled(&[
        "--exclude",
        "s2:#3",
        "--report",
        &report,
        "--hold-out-stations",
        "--select",
        "none",
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("frame_s2_x"), "{stdout}");
    assert!(stdout.contains("79 poses"), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "station s2: {south} (39 poses, measurement frame frame_s2_*)"
        )),
        "{stdout}"
    );
    let json = read_json(&report);
    let id = &json["identification"];
    // The nominal robot measured exactly: nothing left.
    assert!(id["position_max_mm"].as_f64().unwrap() < 1e-6, "{id}");
    let stations = id["stations"].as_array().unwrap();
    assert_eq!(stations.len(), 2);
    assert_eq!(stations[1]["name"].as_str().unwrap(), south);
    // Each station's errors after identification, over its own poses.
    let counts: Vec<u64> = stations
        .iter()
        .map(|s| s["n_poses"].as_u64().unwrap())
        .collect();
    assert_eq!(counts, [40, 39]);
    assert!(
        stations
            .iter()
            .all(|s| s["position_max_mm"].as_f64().unwrap() < 1e-6)
    );
    assert!(stdout.contains("  station s2"), "{stdout}");
    // Each station held out: the nominal robot, measured exactly, predicts
    // the other station exactly.
    assert!(stdout.contains("Each station held out"), "{stdout}");
    let held = json["station_hold_out"].as_array().unwrap();
    assert_eq!(held.len(), 2);
    assert_eq!(held[0]["station"].as_str().unwrap(), north);
    assert!(
        held.iter()
            .all(|h| h["position_max_mm"].as_f64().unwrap() < 1e-6)
    );
    for (s, expected) in [[3000.0, -200.0, 100.0], [-2500.0, 1500.0, -300.0]]
        .iter()
        .enumerate()
    {
        let t = &stations[s]["measurement_frame"]["translation_mm"];
        for (i, e) in expected.iter().enumerate() {
            assert!(
                (t[i].as_f64().unwrap() - e).abs() < 1e-6,
                "station {s}: {t} against {expected:?}"
            );
        }
    }
    assert_eq!(
        id["measurement_frame"], stations[0]["measurement_frame"],
        "the first station's frame is the report's measurement frame"
    );
    // One station has no `stations` array.
    let single = path(d, "single.json");
    let out = flexcal(&[
        "calibrate",
        "--robot",
        "ur10",
        "--data",
        &north,
        "--report",
        &single,
    ]);
    assert!(out.status.success(), "{}", text(&out).1);
    assert!(
        read_json(&single)["identification"]
            .get("stations")
            .is_none()
    );
    // Mistakes fail with one line naming what is wrong.
    let fails_saying = |out: Output, words: &[&str]| {
        let (_, stderr) = text(&out);
        assert!(!out.status.success());
        assert!(
            words.iter().all(|w| stderr.contains(w)) && stderr.lines().count() == 1,
            "{stderr}"
        );
    };
    // A label without its station is named with the labels' form.
    fails_saying(pooled(&["--exclude", "#3"]), &["#3", "s1:#0"]);
    // Holding out a station of a single one is refused before any fit.
    let single_station = ["calibrate", "--robot", "ur10", "--data", &north];
    fails_saying(
        flexcal(&[&single_station[..], &["--hold-out-stations"]].concat()),
        &["one station"],
    );
    // The same file twice is a slip, not two stations.
    fails_saying(
        flexcal(&[&single_station[..], &["--data", &north]].concat()),
        &["given twice", &north],
    );
}

/// The compliances' judgement and the instrument's noise from the command
/// line: bad values are usage errors naming the flag, with nothing
/// written; a stated noise is used and said (text and JSON).
#[test]
fn compliance_judgement_and_noise_flags() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let train = ur10_measurements(d, "train", 60, 0.0, &|[x, y, z]| [x + 3000.0, y, z]);
    let report = path(d, "report.json");
    let calibrate = |extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            "--robot",
            "ur10",
            "--data",
            &train,
            "--model",
            "elasto-geometric",
            "--report",
            &report,
        ];
        args.extend_from_slice(extra);
        flexcal(&args)
    };
    for (flag, value) in [
        ("--noise-mm", "0"),
        ("--noise-mm", "NaN"),
        ("--min-compliance-z", "-1"),
        ("--max-se-compliance", "0"),
        ("--min-torque-share", "1.5"),
    ] {
        let out = calibrate(&[flag, value]);
        let (_, stderr) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{flag} {value}: {stderr}");
        assert!(stderr.contains(flag), "{flag} {value}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(
            !Path::new(&report).exists(),
            "{flag} {value} wrote the report"
        );
    }
    let out = calibrate(&["--noise-mm", "0.02"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("noise: the instrument's stated 0.0200 mm per position axis"),
        "{stdout}"
    );
    let json = read_json(&report);
    let noise = &json["identification"]["noise"];
    assert_eq!(noise["source"], "instrument", "{noise}");
    assert!((noise["position_std_mm"].as_f64().unwrap() - 0.02).abs() < 1e-15);
    // Without it, the noise is the fit's estimate, in mm.
    let out = calibrate(&[]);
    assert!(out.status.success());
    let json = read_json(&report);
    assert_eq!(json["identification"]["noise"]["source"], "estimated");
}

/// `--extrapolation`: the bounds include the model's growth outside the
/// training ranges, said in the printed coverage line, the report's
/// `extrapolation` object (two folds per joint) and the map's columns.
#[test]
fn extrapolation_folds_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = flexcal(&[
        "twin",
        "geometric",
        "--out",
        &d.display().to_string(),
        "--seed",
        "7",
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    // The validation poses as the map's grid: their q1..q6 columns (rad).
    let validation = std::fs::read_to_string(d.join("validation.csv")).unwrap();
    let grid: String = validation
        .lines()
        .map(|l| l.split(',').skip(1).take(6).collect::<Vec<_>>().join(","))
        .collect::<Vec<_>>()
        .join("\n");
    assert!(grid.starts_with("q1,q2,q3,q4,q5,q6\n"), "{grid}");
    std::fs::write(d.join("grid.csv"), grid + "\n").unwrap();
    let out = flexcal(&[
        "calibrate",
        "--robot",
        "ir663",
        "--data",
        &path(d, "identification.csv"),
        "--validate",
        &path(d, "validation.csv"),
        "--fixed-target",
        "--extrapolation",
        "--accuracy-map",
        &path(d, "grid.csv"),
        "--report",
        &path(d, "report.json"),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("the model's growth outside the training ranges included"),
        "{stdout}"
    );
    let report = read_json(d.join("report.json"));
    let extrapolation = &report["extrapolation"];
    assert_eq!(
        extrapolation["growth"].as_array().unwrap().len(),
        6,
        "{extrapolation}"
    );
    assert_eq!(
        extrapolation["folds"].as_array().unwrap().len(),
        12,
        "{extrapolation}"
    );
    for g in extrapolation["growth"].as_array().unwrap() {
        assert!(g["growth"].as_f64().unwrap() >= 0.0, "{g}");
    }
    let map = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.display().to_string().ends_with(".accuracy.csv"))
        .expect("accuracy map written");
    let map = std::fs::read_to_string(map).unwrap();
    assert!(
        map.lines()
            .next()
            .unwrap()
            .contains("scatter_95_mm,parameters_95_mm,extrapolation_95_mm"),
        "{map}"
    );
}

/// `--select-on`: the selection's report gives the ordinary and the
/// extrapolating scores of every candidate and says which it chose on and
/// why; a bad value is named and nothing is written.
#[test]
fn select_on_flag_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let train = ur10_measurements(d, "train", 120, 0.0, &|[x, y, z]| {
        [x + 3000.0, y - 200.0, z + 100.0]
    });
    let report = path(d, "report.json");
    let run_with = |select_on: &str, extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            "--robot",
            "ur10",
            "--data",
            &train,
            "--select",
            "cv",
            "--select-on",
            select_on,
            "--report",
            &report,
        ];
        args.extend_from_slice(extra);
        flexcal(&args)
    };
    let run = |select_on: &str| run_with(select_on, &[]);
    let out = run("extrapolation");
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("Extrapolating folds"), "{stdout}");
    assert!(
        stdout.contains("chosen on the extrapolating scores: asked for"),
        "{stdout}"
    );
    let json = read_json(&report);
    let selection = &json["selection"];
    assert_eq!(selection["select_on"], "extrapolation", "{selection}");
    assert_eq!(selection["chosen_on"], "extrapolation", "{selection}");
    let folds = selection["extrapolation_folds"].as_array().unwrap();
    assert!(!folds.is_empty(), "{selection}");
    for candidate in selection["candidates"].as_array().unwrap() {
        assert!(candidate["cv_mean_error_mm"].is_f64(), "{candidate}");
        assert!(
            candidate["extrapolation_mean_error_mm"].is_f64(),
            "{candidate}"
        );
        assert_eq!(
            candidate["extrapolation_fold_errors_mm"]
                .as_array()
                .unwrap()
                .len(),
            folds.len()
        );
    }
    // Default (auto) without --validate or --accuracy-map: no region of
    // use known, the ordinary scores.
    std::fs::remove_file(&report).unwrap();
    let out = run("auto");
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("chosen on the ordinary (interpolating) scores: no region of use given"),
        "{stdout}"
    );
    assert_eq!(
        read_json(&report)["selection"]["chosen_on"],
        "interpolation"
    );
    // The ordinary scores chose: the extrapolating ones are given for the
    // models the search moved through, every candidate's on request.
    let has_extrapolation = |json: &serde_json::Value| -> Vec<bool> {
        json["selection"]["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["extrapolation_mean_error_mm"].is_f64())
            .collect()
    };
    let path_only = has_extrapolation(&read_json(&report));
    assert!(path_only[0], "the model with every group: {path_only:?}");
    assert!(
        stdout.contains("given for the models the search moved through")
            == path_only.contains(&false),
        "{stdout}"
    );
    std::fs::remove_file(&report).unwrap();
    let out = run_with("auto", &["--every-extrapolation-score"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let every = has_extrapolation(&read_json(&report));
    assert!(every.iter().all(|&e| e), "{every:?}");
    assert_eq!(every.len(), path_only.len());
    assert!(!stdout.contains("given for the models the search moved through"));
    std::fs::remove_file(&report).unwrap();
    let out = run("sideways");
    let (stdout, stderr) = text(&out);
    assert!(!out.status.success(), "{stdout}");
    assert!(
        stderr.contains("--select-on")
            && stderr.contains("sideways")
            && stderr.contains("expected interpolation, extrapolation or auto"),
        "{stderr}"
    );
    assert!(!Path::new(&report).exists());
}
