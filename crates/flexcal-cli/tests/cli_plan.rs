//! `flexcal plan` end to end on temporary files, and bad input that must
//! give a named error and write nothing.

mod common;
use common::flexcal;

fn stdout(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

const BOX: &str = "-90:90,-125:-35,30:125,-140:30,30:150,-170:170";

/// `flexcal plan` for the UR10 in `BOX` (noise 0.02 mm, 20 region points,
/// at most 20 poses) with `[candidate count, poses]` and `extra` flags,
/// writing `poses.csv` and `plan.json` into `dir`; the output and the
/// report's path.
fn ur10_plan(
    dir: &std::path::Path,
    [candidates, poses]: [&str; 2],
    extra: &[&str],
) -> (std::process::Output, std::path::PathBuf) {
    let report = dir.join("plan.json");
    let out_file = dir.join("poses.csv");
    let mut args = vec![
        "plan",
        "--robot",
        "ur10",
        "--noise-mm",
        "0.02",
        "--box-deg",
        BOX,
        "--candidate-count",
        candidates,
        "--region-count",
        "20",
        "--poses",
        poses,
        "--max-poses",
        "20",
    ];
    args.extend_from_slice(extra);
    args.extend([
        "--out",
        out_file.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    (flexcal(&args), report)
}

#[test]
fn plan_writes_the_poses_programs_and_pages() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let out = flexcal(&[
        "plan",
        "--robot",
        "ur10",
        "--noise-mm",
        "0.02,0.02,0.03",
        "--box-deg",
        BOX,
        "--candidate-count",
        "60",
        "--region-count",
        "40",
        "--poses",
        "20",
        "--max-poses",
        "40",
        "--out",
        &p("poses.csv"),
        "--krl",
        &p("plan.src"),
        "--rapid",
        &p("plan.mod"),
        "--joints-csv",
        &p("joints.csv"),
        "--report",
        &p("plan.json"),
        "--html",
        &p("plan.html"),
    ]);
    assert!(out.status.success(), "{}\n{}", stdout(&out), stderr(&out));
    let text = stdout(&out);
    assert!(
        text.contains("plan for ur10 (geometric model): 20 poses of 60 candidates"),
        "{text}"
    );
    assert!(text.contains("<- knee"), "{text}");
    assert!(text.contains("planned 20 poses: rank"), "{text}");
    let poses = std::fs::read_to_string(p("poses.csv")).unwrap();
    assert_eq!(poses.lines().count(), 21, "{poses}");
    assert!(poses.starts_with("q1,q2,q3,q4,q5,q6"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("plan.json")).unwrap()).unwrap();
    assert_eq!(json["count"], 20);
    assert_eq!(json["configurations"].as_array().unwrap().len(), 20);
    // The planned rows are the candidates' rows, each once.
    let mut rows: Vec<u64> = json["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    rows.sort_unstable();
    rows.dedup();
    assert_eq!(rows.len(), 20);
    assert!(rows.iter().all(|&r| r < 60));
    let krl = std::fs::read_to_string(p("plan.src")).unwrap();
    assert!(krl.contains("DEF flexcal_plan"), "{krl}");
    let joints = std::fs::read_to_string(p("joints.csv")).unwrap();
    assert_eq!(joints.lines().count(), 21);
    // The configurations file is what `flexcal fk` reads.
    let fk = flexcal(&[
        "fk",
        "--robot",
        "ur10",
        "--input",
        &p("poses.csv"),
        "--output",
        &p("tcp.csv"),
    ]);
    assert!(fk.status.success(), "{}", stderr(&fk));
    assert!(
        std::fs::read_to_string(p("plan.html"))
            .unwrap()
            .contains("<svg")
    );
}

/// An instrument measuring full poses: the plan says so, and its JSON
/// carries the orientation noise.
#[test]
fn plan_with_full_poses() {
    let dir = tempfile::tempdir().unwrap();
    let (out, report) = ur10_plan(
        dir.path(),
        ["40", "12"],
        &[
            "--orientation-noise-deg",
            "0.01,0.01,0.02",
            "--frame-uncertainty",
            "as-identified",
        ],
    );
    assert!(out.status.success(), "{}\n{}", stdout(&out), stderr(&out));
    let text = stdout(&out);
    assert!(
        text.contains("noise 0.0200/0.0200/0.0200 mm and 0.0100/0.0100/0.0200 deg (full poses); frame as identified"),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    assert_eq!(
        json["instrument"]["orientation_noise_deg"],
        serde_json::json!([0.01, 0.01, 0.02])
    );
    assert_eq!(json["count"], 12);
    assert_eq!(json["instrument"]["frame"], "as-identified");
    let (out, _) = ur10_plan(
        dir.path(),
        ["40", "12"],
        &["--frame-uncertainty", "sideways"],
    );
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("expected registered or as-identified"),
        "{}",
        stderr(&out)
    );
}

/// An instrument that sees part of the cell: the plan says how many
/// candidates it left out and why, and its JSON counts them.
#[test]
fn plan_within_the_instruments_sight() {
    let dir = tempfile::tempdir().unwrap();
    let (out, report) = ur10_plan(
        dir.path(),
        ["100", "15"],
        &[
            "--reach-box-mm",
            "-2000:2000,-2000:2000,-200:2000",
            "--sight-from-mm",
            "2500,0,500",
            "--max-incidence-deg",
            "110",
        ],
    );
    assert!(out.status.success(), "{}\n{}", stdout(&out), stderr(&out));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    let count = |k: &str| json[k].as_u64().unwrap();
    let left_out = count("outside_reach_box") + count("facing_away");
    assert_eq!(count("candidates") + left_out, 100, "{json}");
    assert!(left_out > 0, "{json}");
    assert!(
        stdout(&out).contains(&format!(
            "left out {left_out} candidates the instrument cannot see"
        )),
        "{}",
        stdout(&out)
    );
    assert_eq!(
        json["instrument"]["sight"]["line_of_sight"]["max_incidence_deg"],
        serde_json::json!(110.0)
    );
}

/// Each bad input gets a one-line error naming what was wrong, and the
/// output file is not written.
#[test]
fn bad_plans_are_refused_by_name_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("poses.csv");
    let region = dir.path().join("region.csv");
    std::fs::write(&region, "q1,q2,q3,q4,q5,q6\n0,-1,1,0,1,0\n0,-1,1,0,1,20\n").unwrap();
    let region = region.display().to_string();
    let empty = dir.path().join("empty.csv");
    std::fs::write(&empty, "q1,q2,q3,q4,q5,q6\n").unwrap();
    let empty = empty.display().to_string();
    let cases: [(&[&str], &str); 12] = [
        (
            &["--noise-mm", "0", "--box-deg", BOX],
            "noise along x must be finite and > 0",
        ),
        (&["--noise-mm", "nan", "--box-deg", BOX], "noise along x"),
        (
            &[
                "--noise-mm",
                "0.02",
                "--box-deg",
                "-90:90,-35:-35,30:125,-140:30,30:150,-170:170",
            ],
            "the range of",
        ),
        (
            &["--noise-mm", "0.02", "--box-deg", BOX, "--region", &region],
            "region.csv:3: theta6 = 20 outside the joint limits",
        ),
        (
            &[
                "--noise-mm",
                "0.02",
                "--box-deg",
                BOX,
                "--candidate-count",
                "30",
                "--poses",
                "31",
            ],
            "31 poses asked for, but only 30 candidates",
        ),
        (
            &[
                "--noise-mm",
                "0.02",
                "--orientation-noise-deg",
                "0.01,0.01,0",
                "--box-deg",
                BOX,
            ],
            "orientation_noise_deg: the instrument's noise along z must be finite and > 0 deg",
        ),
        (
            &[
                "--noise-mm",
                "0.02",
                "--orientation-noise-deg",
                "0.01,0.01",
                "--box-deg",
                BOX,
            ],
            "--orientation-noise-deg takes one value or three x,y,z (deg), got 2",
        ),
        (
            &[
                "--noise-mm",
                "0.02",
                "--box-deg",
                "-400:90,-125:-35,30:125,-140:30,30:150,-170:170",
            ],
            "leaves the joint limits",
        ),
        (
            &["--noise-mm", "0.02", "--box-deg", BOX, "--region", &empty],
            "empty.csv",
        ),
        (
            &[
                "--noise-mm",
                "0.02",
                "--box-deg",
                BOX,
                "--reach-box-mm",
                "-500:500,300:300,0:1000",
            ],
            "reach_box_mm: the range along y must be finite with lo < hi",
        ),
        (
            &[
                "--noise-mm",
                "0.02",
                "--box-deg",
                BOX,
                "--reach-box-mm",
                "5000:6000,-9000:9000,-9000:9000",
            ],
            "the instrument sees none of the 200 candidates: 200 outside the reach box",
        ),
        (
            &[
                "--noise-mm",
                "0.02",
                "--box-deg",
                BOX,
                "--sight-from-mm",
                "2000,0,500",
                "--max-incidence-deg",
                "0",
            ],
            "max_incidence_deg: must be in (0, 180] deg",
        ),
    ];
    for (args, expected) in cases {
        let mut all = vec![
            "plan",
            "--robot",
            "ur10",
            "--out",
            out_file.to_str().unwrap(),
        ];
        all.extend_from_slice(args);
        let out = flexcal(&all);
        assert!(!out.status.success(), "{all:?} succeeded");
        let err = stderr(&out);
        assert!(err.contains(expected), "{all:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!out_file.exists(), "{all:?} wrote the pose file");
    }
}

/// A file of `flexcal-calib`'s test data (the two-armed robot).
fn calib_data(name: &str) -> String {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../flexcal-calib/tests/data")
        .join(name)
        .display()
        .to_string()
}

/// Rotates `v` by the unit quaternion `(w, x, y, z)`:
/// `v + 2 w (u x v) + 2 u x (u x v)` with `u = (x, y, z)`.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let u = [q[1], q[2], q[3]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let t = cross(u, v);
    let tt = cross(u, t);
    [0, 1, 2].map(|i| v[i] + 2.0 * q[0] * t[i] + 2.0 * tt[i])
}

/// The two-armed robot with a marker on each hand (`--targets`, the file
/// `calibrate` reads): the plan prints and writes each target's
/// prediction, and its words on what the campaign cannot determine are
/// those `calibrate --targets` prints for the same poses measured (the
/// nominal markers' positions from `flexcal fk`, the plan's noise as the
/// file's standard deviations). A targets file naming a frame the robot
/// lacks is refused by name.
#[test]
fn plan_with_a_target_on_each_hand() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let robot = calib_data("two_arms.toml");
    let targets = calib_data("two_arms_targets.toml");
    let plan_args = |targets: &str, out: &str| -> Vec<String> {
        [
            "plan",
            "--robot",
            &robot,
            "--targets",
            targets,
            "--noise-mm",
            "0.02",
            "--candidate-count",
            "60",
            "--region-count",
            "20",
            "--poses",
            "20",
            "--max-poses",
            "25",
            "--out",
            out,
        ]
        .map(String::from)
        .to_vec()
    };
    let mut args = plan_args(&targets, &p("poses.csv"));
    args.extend(["--report", &p("plan.json"), "--html", &p("plan.html")].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = flexcal(&args);
    assert!(out.status.success(), "{}\n{}", stdout(&out), stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("targets: left, right"), "{text}");
    assert!(
        text.contains("target left: predicted 95 % bound mean"),
        "{text}"
    );
    assert!(
        text.contains("target right: predicted 95 % bound mean"),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("plan.json")).unwrap()).unwrap();
    let per_target = json["prediction"]["per_target"].as_array().unwrap();
    assert_eq!(per_target.len(), 2);
    assert_eq!(per_target[1]["target"], "right");
    let html = std::fs::read_to_string(p("plan.html")).unwrap();
    assert!(html.contains("mean, target right"));
    // The planned poses measured: the nominal markers, 30 mm along x and
    // 40 mm along z of each hand's frame.
    let fk = flexcal(&[
        "fk",
        "--robot",
        &robot,
        "--input",
        &p("poses.csv"),
        "--frame",
        "LH",
        "--frame",
        "RH",
    ]);
    assert!(fk.status.success(), "{}", stderr(&fk));
    let poses = std::fs::read_to_string(p("poses.csv")).unwrap();
    let mut csv = String::from(poses.lines().next().unwrap());
    for hand in ["left", "right"] {
        for axis in ["x", "y", "z"] {
            csv += &format!(",{hand}_{axis}_mm,{hand}_s{axis}_mm");
        }
    }
    csv.push('\n');
    for (q, frames) in poses.lines().skip(1).zip(stdout(&fk).lines().skip(1)) {
        let v: Vec<f64> = frames.split(',').map(|c| c.parse().unwrap()).collect();
        csv += q;
        for hand in v.chunks(7) {
            let offset = rotate([hand[3], hand[4], hand[5], hand[6]], [0.030, 0.0, 0.040]);
            for i in 0..3 {
                csv += &format!(",{},0.02", (hand[i] + offset[i]) * 1e3);
            }
        }
        csv.push('\n');
    }
    std::fs::write(p("measured.csv"), csv).unwrap();
    let calibrated = flexcal(&[
        "calibrate",
        "--robot",
        &robot,
        "--targets",
        &targets,
        "--data",
        &p("measured.csv"),
    ]);
    let said = stdout(&calibrated);
    assert!(
        calibrated.status.success(),
        "{said}\n{}",
        stderr(&calibrated)
    );
    let notes = json["prediction"]["identifiability_notes"]
        .as_array()
        .unwrap();
    assert!(!notes.is_empty());
    for note in notes {
        let note = note.as_str().unwrap();
        assert!(said.contains(note), "plan: {note}\ncalibrate:\n{said}");
    }
    // A target on a frame the robot does not have.
    let wrong = p("wrong.toml");
    std::fs::write(
        &wrong,
        std::fs::read_to_string(&targets)
            .unwrap()
            .replace("\"RH\"", "\"RX\""),
    )
    .unwrap();
    let args = plan_args(&wrong, &p("wrong.csv"));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = flexcal(&args);
    assert!(!out.status.success());
    let message = stderr(&out);
    assert!(
        message.contains("target `right`") && message.contains("no frame `RX`"),
        "{message}"
    );
    assert!(!std::path::Path::new(&p("wrong.csv")).exists());
}

/// `plan --prior`: an earlier calibration's report (`calibrate
/// --split-check --extrapolation`) floors the plan's noise at its
/// residual scatter, raises the identification part by its split-half
/// inflation and adds its growth outside the planned poses' ranges; each
/// part of every region point's bound is recomputed here from the
/// report's figures. A prior of another robot, an unreadable file and a
/// report without the split-half check are refused by name.
#[test]
fn plan_with_an_earlier_calibration_as_prior() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = |name: &str| d.join(name).display().to_string();
    let out = flexcal(&["twin", "geometric", "--out", &p(""), "--seed", "7"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = flexcal(&[
        "calibrate",
        "--robot",
        "ir663",
        "--data",
        &p("identification.csv"),
        "--validate",
        &p("validation.csv"),
        "--fixed-target",
        "--split-check",
        "--extrapolation",
        "--report",
        &p("prior.json"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p(name)).unwrap()).unwrap()
    };
    let prior = read("prior.json");
    let scatter_mm = prior["identification"]["residual_scatter_mm"]
        .as_f64()
        .unwrap();
    let ratio = prior["split_check"]["prediction_ratio"].as_f64().unwrap();
    // A noise below the prior's scatter: the prior's is the floor.
    let noise_mm = 0.5 * scatter_mm;
    let plan = |robot: &str, prior: &str| {
        flexcal(&[
            "plan",
            "--robot",
            robot,
            "--fixed-target",
            "--noise-mm",
            &noise_mm.to_string(),
            "--prior",
            prior,
            "--candidate-count",
            "60",
            "--region-count",
            "40",
            "--poses",
            "20",
            "--max-poses",
            "20",
            "--out",
            &p("poses.csv"),
            "--report",
            &p("plan.json"),
        ])
    };
    let out = plan("ir663", &p("prior.json"));
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("the prior's residual scatter"),
        "{}",
        stdout(&out)
    );
    let json = read("plan.json");
    let used = &json["prior"];
    // JSON numbers read back within an ulp or two.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(
        close(used["floor_mm"][0].as_f64().unwrap(), scatter_mm),
        "{used}"
    );
    let inflation = ratio.max(1.0);
    assert!(
        close(used["inflation"].as_f64().unwrap(), inflation),
        "{used}"
    );
    assert_eq!(used["extrapolation"], true, "{used}");
    // The parts, point by point: the scatter part of the floor, the
    // parameters part the inflated identification's, the extrapolation
    // part zero inside every planned range, the bound their root sum of
    // squares.
    let chi = 7.814_727_903_251_178f64.sqrt();
    let mut outside = 0;
    for point in json["prediction"]["map"]["poses"].as_array().unwrap() {
        let parts = &point["parts"];
        let part = |name: &str| parts[name].as_f64().unwrap();
        assert!(
            (part("scatter_mm") - chi * scatter_mm).abs() < 1e-9,
            "{point}"
        );
        let trace_mm = point["model_uncertainty_mm"].as_f64().unwrap();
        assert!((part("parameters_mm") - chi * trace_mm / 3f64.sqrt()).abs() < 1e-9);
        let root = (part("scatter_mm").powi(2)
            + part("parameters_mm").powi(2)
            + part("extrapolation_mm").powi(2))
        .sqrt();
        assert!((point["bound_95_mm"].as_f64().unwrap() - root).abs() < 1e-9);
        if point["outside_training_range"]
            .as_array()
            .unwrap()
            .is_empty()
        {
            assert_eq!(part("extrapolation_mm"), 0.0, "{point}");
        } else {
            outside += 1;
        }
    }
    assert!(outside > 0, "no region point outside the planned ranges");
    let mut no_split = prior.clone();
    no_split.as_object_mut().unwrap().remove("split_check");
    std::fs::write(p("no_split.json"), no_split.to_string()).unwrap();
    for (robot, file, expected) in [
        (
            "ur10",
            p("prior.json"),
            "a calibration of 'ir663', not of 'ur10'",
        ),
        ("ir663", p("missing.json"), "missing.json"),
        (
            "ir663",
            p("no_split.json"),
            "calibrate the prior with --split-check",
        ),
        ("ir663", p("identification.csv"), "not a calibration report"),
    ] {
        let _ = std::fs::remove_file(p("plan.json"));
        let out = plan(robot, &file);
        assert!(!out.status.success(), "{file} succeeded");
        let err = stderr(&out);
        assert!(err.contains(expected), "{file}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!d.join("plan.json").exists(), "{file} wrote the plan");
    }
}
