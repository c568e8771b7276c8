//! `flexcal calibrate --targets` end to end: a two-armed tree robot with a
//! marker on each hand, measured files written by the library from a known
//! truth, calibrated by the binary; and bad input.

use std::path::{Path, PathBuf};

use flexcal::calib::{
    MeasurementSet, Target, TargetObservation, TargetPose, read_targets, rotation_from_vector,
};
use flexcal::kinematics::{Data, ParamKind, RobotDescription, forward_frame_pose};
use flexcal::nalgebra::{Isometry3, Translation3, Vector3};

mod common;
use common::{flexcal, stderr, stdout};

fn calib_data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../flexcal-calib/tests/data")
        .join(name)
}

/// Noise-free measurements of `poses` quasi-random configurations (a
/// Weyl sequence within the joint limits, one prime's square root per
/// coordinate), starting at `first`, of the
/// robot with every parameter off by up to 0.2 mm or 0.2 mrad.
fn simulate(targets: &[Target], first: usize, poses: usize) -> MeasurementSet {
    let model = RobotDescription::from_toml_file(&calib_data("two_arms.toml"))
        .unwrap()
        .build()
        .unwrap();
    let xi: Vec<f64> = model
        .nominal_params()
        .iter()
        .zip(model.params())
        .enumerate()
        .map(|(j, (v, p))| match p.kind {
            ParamKind::Length => v + 2e-4 * (j as f64 + 1.0).sin(),
            ParamKind::Angle => v + 2e-4 * (j as f64 + 1.0).cos(),
        })
        .collect();
    let x_meas_base = Isometry3::from_parts(
        Translation3::new(2.0, 0.5, -0.8),
        rotation_from_vector(&Vector3::new(0.0, 0.1, 1.9)),
    );
    let offsets_error = Vector3::new(0.4e-3, -0.3e-3, 0.6e-3);
    let mut data = Data::new(&model);
    let poses = (first..first + poses)
        .map(|k| {
            let q: Vec<f64> = model
                .actuated_limits()
                .iter()
                .enumerate()
                .map(|(i, &(lo, hi))| {
                    // Square roots of distinct primes: irrational and
                    // independent, so that no coordinate repeats.
                    const PRIMES: [f64; 9] = [2.0, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0, 19.0, 23.0];
                    let u = ((k as f64 + 1.0) * PRIMES[i].sqrt()).fract();
                    lo + u * (hi - lo)
                })
                .collect();
            let observations = targets
                .iter()
                .map(|t| {
                    let point = Isometry3::from_parts(
                        Translation3::from(t.offset + offsets_error),
                        Default::default(),
                    );
                    let frame = model.frame_index(&t.frame).unwrap();
                    let x = forward_frame_pose(&model, &mut data, &q, &xi, frame, &point).unwrap();
                    Some(TargetObservation::new((x_meas_base * x).translation.vector))
                })
                .collect();
            TargetPose::new(Some(format!("p{k}")), q, observations)
        })
        .collect();
    MeasurementSet::from_poses("simulated", targets.to_vec(), poses).unwrap()
}

#[test]
fn two_markers_calibrate_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let targets_file = calib_data("two_arms_targets.toml");
    let targets = read_targets(&targets_file).unwrap();
    let identification = d.join("markers.csv");
    let validation = d.join("markers-validation.csv");
    simulate(&targets, 0, 60)
        .write_csv(&identification)
        .unwrap();
    simulate(&targets, 1000, 30).write_csv(&validation).unwrap();
    let robot = calib_data("two_arms.toml").display().to_string();
    let report = d.join("report.json");
    let calibrated = d.join("calibrated.toml");
    let residuals = d.join("errors.csv");
    let page = d.join("report.html");
    // A grid of seven configurations: the first poses of a third set.
    let grid = d.join("grid.csv");
    let mut grid_text = String::from("q1,q2,q3,q4,q5,q6,q7,q8,q9\n");
    for pose in simulate(&targets, 2000, 7).poses() {
        let q: Vec<String> = pose.q.iter().map(|v| format!("{v:.6}")).collect();
        grid_text.push_str(&q.join(","));
        grid_text.push('\n');
    }
    std::fs::write(&grid, grid_text).unwrap();
    let args = [
        "calibrate",
        "--robot",
        &robot,
        "--data",
        &identification.display().to_string(),
        "--targets",
        &targets_file.display().to_string(),
        "--validate",
        &validation.display().to_string(),
        "--out",
        &calibrated.display().to_string(),
        "--report",
        &report.display().to_string(),
        "--residuals",
        &residuals.display().to_string(),
        "--split-check",
        "--cross-check",
        "--accuracy-map",
        &grid.display().to_string(),
        "--html",
        &page.display().to_string(),
    ];
    let out = flexcal(&args);
    let text = stdout(&out);
    assert!(out.status.success(), "{text}\n{}", stderr(&out));
    println!("{text}");
    assert!(
        text.contains("60 poses, 120 observations of 2 targets"),
        "{text}"
    );
    // What two markers cannot see is named, with what absorbs it.
    assert!(text.contains("rLH (in target.left.z"), "{text}");
    // Per-target figures: noise-free data are fitted to round-off.
    let per_target = |section: &str, target: &str| -> f64 {
        let start = text
            .find(&format!("{section}: position error per target"))
            .unwrap();
        let line = text[start..]
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{target} on ")))
            .unwrap();
        // "... -> mean / max": the mean after.
        let after = line.rsplit("-> ").next().unwrap();
        after.split(" / ").next().unwrap().trim().parse().unwrap()
    };
    for target in ["left", "right"] {
        assert!(per_target("identification", target) < 1e-4, "{text}");
        assert!(per_target("validation", target) < 1e-3, "{text}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let after = &json["validation"]["per_target_after"];
    assert_eq!(after.as_array().unwrap().len(), 2);
    assert!(after[0]["statistics"]["position_max"].as_f64().unwrap() < 1e-6);
    let description = RobotDescription::from_toml_file(&calibrated).unwrap();
    assert!(description.notes.contains("of 2 targets"));
    description.build().unwrap();
    // The error of every validation observation: 30 poses, two markers.
    assert!(
        text.contains("error of every validation observation written to"),
        "{text}"
    );
    let csv = std::fs::read_to_string(&residuals).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("pose,target,position_error_mm,dx_mm,dy_mm,dz_mm")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 60);
    assert_eq!(rows[0][..2], ["p1000", "left"]);
    assert_eq!(rows[1][..2], ["p1000", "right"]);
    let largest = rows
        .iter()
        .map(|r| r[2].parse::<f64>().unwrap())
        .fold(0.0, f64::max);
    let reported = after
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["statistics"]["position_max"].as_f64().unwrap() * 1e3)
        .fold(0.0, f64::max);
    assert!((largest - reported).abs() < 1e-9, "{largest} {reported}");
    // Each row's norm is that of its components.
    for r in &rows {
        let v: Vec<f64> = r[2..].iter().map(|x| x.parse().unwrap()).collect();
        assert!((v[0] - (v[1] * v[1] + v[2] * v[2] + v[3] * v[3]).sqrt()).abs() < 1e-9);
    }
    // The split-half check, the validation observations against their
    // bounds, and the accuracy map: one row per configuration and marker.
    assert!(
        text.contains("Split-half check (identified again"),
        "{text}"
    );
    assert!(text.contains("% of the validation observations"), "{text}");
    assert_eq!(json["coverage"]["poses"].as_array().unwrap().len(), 60);
    assert!(text.contains("Cross-series check"), "{text}");
    assert_eq!(
        json["cross"]["other_poses"].as_u64(),
        Some(30),
        "{}",
        json["cross"]
    );
    assert!(json["split"]["unknowns"].as_array().unwrap().len() > 20);
    assert!(
        text.contains("predicted accuracy of 2 targets at 7 configurations written to"),
        "{text}"
    );
    let map = std::fs::read_to_string(d.join("grid.accuracy.csv")).unwrap();
    let mut lines = map.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("pose,target,q1,q2,q3,q4,q5,q6,q7,q8,q9,model_uncertainty_mm,bound_95_mm"),
        "{map}"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 14);
    assert_eq!(rows[0][..2], ["row 1", "left"]);
    assert_eq!(rows[13][..2], ["row 7", "right"]);
    for r in &rows {
        let bound: f64 = r[12].parse().unwrap();
        assert!(bound.is_finite() && bound >= 0.0, "{r:?}");
    }
    // The HTML page: the validation observations against their bounds and
    // the map of both markers.
    let html = std::fs::read_to_string(&page).unwrap();
    for expected in [
        "Predicted accuracy on the validation observations",
        "at 14 configurations and targets",
        "validation, right on RH, calibrated",
        ">Split-half check</h2>",
        ">Cross-series check</h2>",
        "<td>target.left.x</td>",
    ] {
        assert!(html.contains(expected), "{expected} missing");
    }
}

/// Two stations from the command line: the same robot measured from two
/// placements of the instrument, one file each (`--data A --data B`); one
/// identification with a measurement frame per station, each station held
/// out in turn, and a file given twice refused by name.
#[test]
fn two_markers_from_two_stations_calibrate_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let targets_file = calib_data("two_arms_targets.toml");
    let targets = read_targets(&targets_file).unwrap();
    let first = d.join("station-a.csv");
    let second = d.join("station-b.csv");
    simulate(&targets, 0, 40).write_csv(&first).unwrap();
    // The second placement: the same poses' positions seen from a tracker
    // moved by 1 m along x and turned by 1.5 rad (86 deg) about z.
    let moved = simulate(&targets, 500, 40);
    let turn = Isometry3::from_parts(
        Translation3::new(1.0, 0.0, 0.0),
        flexcal::nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 1.5),
    );
    let poses = moved
        .poses()
        .iter()
        .map(|p| {
            let mut p = p.clone();
            for o in p.observations.iter_mut().flatten() {
                o.position = (turn * flexcal::nalgebra::Point3::from(o.position)).coords;
            }
            p
        })
        .collect();
    MeasurementSet::from_poses("b", targets.clone(), poses)
        .unwrap()
        .write_csv(&second)
        .unwrap();
    let robot = calib_data("two_arms.toml").display().to_string();
    let report = d.join("report.json");
    let (a, b) = (first.display().to_string(), second.display().to_string());
    let t = targets_file.display().to_string();
    let r = report.display().to_string();
    let page = d.join("report.html");
    let h = page.display().to_string();
    let args = [
        "calibrate",
        "--robot",
        &robot,
        "--data",
        &a,
        "--data",
        &b,
        "--targets",
        &t,
        "--report",
        &r,
        "--hold-out-stations",
        "--html",
        &h,
    ];
    let out = flexcal(&args);
    let text = stdout(&out);
    assert!(out.status.success(), "{text}\n{}", stderr(&out));
    assert!(
        text.contains("80 poses, 160 observations of 2 targets"),
        "{text}"
    );
    assert!(
        text.contains("2 stations, each with its own measurement frame: s1 "),
        "{text}"
    );
    // Noise-free data from both placements: fitted to round-off.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let mean = json["calibration"]["training_after"]["position_mean"]
        .as_f64()
        .unwrap();
    assert!(mean < 1e-7, "{mean}");
    assert_eq!(
        json["calibration"]["station_frames"]
            .as_array()
            .unwrap()
            .len(),
        1
    );
    // Each station held out: the robot calibrated on the other predicts
    // it to round-off (noise-free data), its frame fitted again.
    assert!(text.contains("Each station held out"), "{text}");
    let held = json["station_hold_out"].as_array().unwrap();
    assert_eq!(held.len(), 2);
    // The page has the same table.
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains(">Each station held out</h2>") && html.contains("<td>station s2</td>"),
        "{html}"
    );
    for h in held {
        // Counted in observations: 40 poses of two markers.
        assert_eq!(h["after"]["n_poses"].as_u64(), Some(80), "{h}");
        assert!(h["after"]["position_mean"].as_f64().unwrap() < 1e-6, "{h}");
        assert!(h["before"]["position_mean"].as_f64().unwrap() > 1e-4, "{h}");
    }
    // The same file twice is refused, naming it.
    let out = flexcal(&[
        "calibrate",
        "--robot",
        &robot,
        "--data",
        &a,
        "--data",
        &a,
        "--targets",
        &t,
    ]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("is given twice"), "{err}");
}

/// The elasto-geometric model with two markers, from the command line: the
/// joint springs under both arms' weights (mass table with lateral
/// compliances) on a robot whose joints are rigid. The compliances come out
/// at zero (from the table's start of 10 urad/N.m), and the validation is
/// fitted to round-off.
#[test]
fn two_markers_calibrate_the_elasto_geometric_model_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let targets_file = calib_data("two_arms_targets.toml");
    let targets = read_targets(&targets_file).unwrap();
    let identification = d.join("markers.csv");
    let validation = d.join("markers-validation.csv");
    simulate(&targets, 0, 120)
        .write_csv(&identification)
        .unwrap();
    simulate(&targets, 1000, 30).write_csv(&validation).unwrap();
    let robot = calib_data("two_arms.toml").display().to_string();
    let masses = calib_data("two_arms_masses.toml").display().to_string();
    let report = d.join("report.json");
    let identification = identification.display().to_string();
    let targets_file = targets_file.display().to_string();
    let validation = validation.display().to_string();
    let report_path = report.display().to_string();
    let run = |select: &str| {
        let out = flexcal(&[
            "calibrate",
            "--robot",
            &robot,
            "--data",
            &identification,
            "--targets",
            &targets_file,
            "--validate",
            &validation,
            "--model",
            "elasto-geometric",
            "--masses",
            &masses,
            "--select",
            select,
            "--report",
            &report_path,
        ]);
        let text = stdout(&out);
        assert!(out.status.success(), "{text}\n{}", stderr(&out));
        println!("{text}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (text, json)
    };
    // Cross-validation on the 120 poses: the joints are rigid, and the
    // compliances (with the law and lateral compliances that go with them)
    // are dropped.
    let (text, json) = run("cv");
    assert!(
        text.contains("Model selection by 5-fold cross-validation"),
        "{text}"
    );
    let chosen = json["selection"]["chosen"].as_array().unwrap();
    assert!(!chosen.is_empty(), "{json}");
    assert!(
        !chosen
            .iter()
            .any(|g| g.as_str().unwrap().contains("ompliance")),
        "{chosen:?}"
    );
    // Every group identified: the compliances come out at zero.
    let (text, json) = run("none");
    let unknowns = json["calibration"]["unknowns"].as_array().unwrap();
    let identified = |name: &str| {
        unknowns
            .iter()
            .find(|u| u["name"] == name)
            // Identified, held at its bound, or judged not told apart
            // from zero (left out, at zero): noise-free data of a rigid
            // robot put it at zero every way.
            .filter(|u| u["status"] != "NonIdentifiable" && u["status"] != "NoInfluence")
            .map(|u| u["value"].as_f64().unwrap())
    };
    // The shoulders carry the arms' weight: their compliances come out at
    // zero; so does the torso's tilt under both arms.
    for name in [
        "compliance_thetaL1",
        "compliance_thetaR1",
        "lateral_compliance_theta1_x",
    ] {
        let value = identified(name).unwrap_or_else(|| panic!("{name} not identified: {text}"));
        assert!(value.abs() < 1e-8, "{name} = {value:e}");
        assert!(text.contains(name), "{text}");
    }
    let after = &json["validation"]["per_target_after"];
    for target in after.as_array().unwrap() {
        assert!(target["statistics"]["position_max"].as_f64().unwrap() < 1e-6);
    }
}

/// One marker's reading 2 mm off at one identification pose and one
/// validation pose (noise-free otherwise): the data checks name both
/// observations and the options that leave their poses out, and the run
/// with those options fits to round-off.
#[test]
fn a_marker_recording_fault_is_named_and_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let targets_file = calib_data("two_arms_targets.toml");
    let targets = read_targets(&targets_file).unwrap();
    let with_fault = |set: MeasurementSet, pose: usize, target: usize| {
        let mut poses = set.poses().to_vec();
        poses[pose].observations[target]
            .as_mut()
            .unwrap()
            .position
            .y += 2e-3;
        MeasurementSet::from_poses("simulated", targets.clone(), poses).unwrap()
    };
    let identification = d.join("markers.csv");
    let validation = d.join("markers-validation.csv");
    with_fault(simulate(&targets, 0, 60), 7, 1)
        .write_csv(&identification)
        .unwrap();
    with_fault(simulate(&targets, 1000, 30), 12, 0)
        .write_csv(&validation)
        .unwrap();
    let robot = calib_data("two_arms.toml").display().to_string();
    let report = d.join("report.json");
    let page = d.join("report.html");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "calibrate".to_string(),
            "--robot".into(),
            robot.clone(),
            "--data".into(),
            identification.display().to_string(),
            "--targets".into(),
            targets_file.display().to_string(),
            "--validate".into(),
            validation.display().to_string(),
            "--report".into(),
            report.display().to_string(),
            "--html".into(),
            page.display().to_string(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = flexcal(&args);
        let text = stdout(&out);
        assert!(out.status.success(), "{text}\n{}", stderr(&out));
        println!("{text}");
        text
    };
    let text = run(&[]);
    for expected in [
        "data check: identification set: 1 observation with a position error above 4 times the RMS error",
        "right at p7 (1.",
        "data check: to compare without the suspect observations, run again with --exclude 'right at p7'",
        "data check: validation set: 1 observation",
        "left at p1012 (1.",
        "run again with --exclude-validation 'left at p1012'",
    ] {
        assert!(text.contains(expected), "{expected} missing:\n{text}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let suspect = &json["calibration"]["data_checks"]["suspect_poses"];
    assert_eq!(suspect.as_array().unwrap().len(), 1, "{suspect}");
    assert_eq!(suspect[0]["pose"], "p7");
    assert_eq!(suspect[0]["target"], "right");
    // The page says it too.
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("Data checks")
            && html.contains("right at p7 (1.")
            && html.contains("run again with --exclude-validation 'left at p1012'"),
        "{html}"
    );
    // Without the two observations (the other marker of each pose kept) the
    // noise-free data fit to round-off, and the run says what it left out.
    let text = run(&[
        "--exclude",
        "right at p7",
        "--exclude-validation",
        "left at p1012",
    ]);
    assert!(
        text.starts_with(&format!(
            "--exclude: 0 of the 60 poses (1 of the 120 observations) of {} left out\n--exclude-validation: 0 of the 30 poses (1 of the 60 observations) of {} left out\n",
            identification.display(),
            validation.display()
        )),
        "{text}"
    );
    assert!(text.contains("60 poses, 119 observations"), "{text}");
    assert!(!text.contains("data check"), "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    for set in ["calibration", "validation"] {
        for target in json[set]["per_target_after"].as_array().unwrap() {
            let max = target["statistics"]["position_max"].as_f64().unwrap();
            assert!(max < 1e-6, "{set}: {max}");
        }
    }
    assert_eq!(json["exclusions"].as_array().unwrap().len(), 2);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("--exclude: 0 of the 60 poses (1 of the 120 observations) of")
            && !html.contains("suspect"),
        "{html}"
    );
    // A whole pose: both markers of it.
    let text = run(&["--exclude", "p7"]);
    assert!(
        text.starts_with("--exclude: 1 of the 60 poses (2 of the 120 observations) of"),
        "{text}"
    );
}

#[test]
fn bad_multi_target_input_is_a_named_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let targets_file = calib_data("two_arms_targets.toml");
    let targets = read_targets(&targets_file).unwrap();
    let identification = d.join("markers.csv");
    simulate(&targets, 0, 30)
        .write_csv(&identification)
        .unwrap();
    let robot = calib_data("two_arms.toml").display().to_string();
    let data = identification.display().to_string();
    let run = |targets: &Path, extra: &[&str]| {
        let targets = targets.display().to_string();
        let mut args = vec![
            "calibrate",
            "--robot",
            &robot,
            "--data",
            &data,
            "--targets",
            &targets,
        ];
        args.extend_from_slice(extra);
        flexcal(&args)
    };
    // A target on a frame the robot lacks.
    let wrong = d.join("wrong.toml");
    std::fs::write(
        &wrong,
        std::fs::read_to_string(&targets_file)
            .unwrap()
            .replace("\"RH\"", "\"RX\""),
    )
    .unwrap();
    let out = run(&wrong, &[]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("no frame `RX`"), "{err}");
    // An option not built for several targets.
    let out = run(&targets_file, &["--target-mm", "0,0,0.1"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("target_mm") && err.contains("several targets"),
        "{err}"
    );
    // A pose to leave out that the file does not have, and leaving out
    // validation poses without a validation set.
    let out = run(&targets_file, &["--exclude", "p7,p99"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("--exclude") && err.contains("no pose `p99`") && err.contains("markers.csv"),
        "{err}"
    );
    let out = run(&targets_file, &["--exclude-validation", "p1"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("--exclude-validation needs --validate"),
        "{err}"
    );
    // A malformed targets description names its line.
    let broken = d.join("broken.toml");
    std::fs::write(&broken, "[[target]]\nname = \"left\"\nframe = 3\n").unwrap();
    let out = run(&broken, &[]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("broken.toml:3"), "{err}");
}

/// `--deflection equilibrium` from the command line: the report says the
/// identified model uses the equilibrium because it was asked, with the
/// difference it makes; asked of the geometric model or misspelt, it is
/// refused by name and nothing is written.
#[test]
fn the_deflection_as_the_equilibrium_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let targets_file = calib_data("two_arms_targets.toml");
    let targets = read_targets(&targets_file).unwrap();
    let identification = d.join("markers.csv");
    simulate(&targets, 0, 60)
        .write_csv(&identification)
        .unwrap();
    let robot = calib_data("two_arms.toml").display().to_string();
    let masses = calib_data("two_arms_masses.toml").display().to_string();
    let report = d.join("report.json");
    let identification = identification.display().to_string();
    let targets_file = targets_file.display().to_string();
    let report_path = report.display().to_string();
    let run = |model: &str, deflection: &str| {
        let mut args = vec![
            "calibrate",
            "--robot",
            &robot,
            "--data",
            &identification,
            "--targets",
            &targets_file,
            "--model",
            model,
            "--select",
            "none",
            "--deflection",
            deflection,
            "--report",
            &report_path,
        ];
        if model == "elasto-geometric" {
            args.extend(["--masses", masses.as_str()]);
        }
        flexcal(&args)
    };
    let out = run("elasto-geometric", "equilibrium");
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let deflection = &json["calibration"]["deflection"];
    assert_eq!(deflection["used"], "equilibrium", "{deflection}");
    assert_eq!(deflection["choice"], "asked", "{deflection}");
    assert!(deflection["position_difference_max_mm"].as_f64().unwrap() >= 0.0);
    std::fs::remove_file(&report).unwrap();
    for (model, deflection, says) in [
        ("geometric", "equilibrium", "--deflection"),
        ("elasto-geometric", "two-steps", "--deflection"),
    ] {
        let out = run(model, deflection);
        assert!(!out.status.success());
        let err = stderr(&out);
        assert!(err.contains(says), "{err}");
        assert!(!report.exists());
    }
}
