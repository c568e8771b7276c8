//! End-to-end runs of `flexcal robot`, `flexcal fk` and `flexcal ik`.

use std::path::Path;

mod common;
use common::{flexcal, stderr, stdout};

fn path_str(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

/// `flexcal ik --robot ur10` from the pose file `input` into `output`, with
/// `extra` arguments.
fn ik_ur10(input: &Path, output: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "ik",
        "--robot",
        "ur10",
        "--input",
        path_str(input),
        "--output",
        path_str(output),
    ];
    args.extend(extra);
    flexcal(&args)
}

#[test]
fn robot_list_and_show_round_trip_through_a_file() {
    let list = flexcal(&["robot", "list"]);
    assert!(list.status.success());
    for name in ["ur10", "ir663", "puma560"] {
        assert!(stdout(&list).contains(name), "{}", stdout(&list));
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("my_ir663.toml");
    let toml = flexcal(&["robot", "show", "ir663", "--toml"]);
    assert!(toml.status.success());
    std::fs::write(&file, toml.stdout).unwrap();
    let from_file = flexcal(&["robot", "show", path_str(&file)]);
    let builtin = flexcal(&["robot", "show", "ir663"]);
    assert!(from_file.status.success(), "{}", stderr(&from_file));
    assert_eq!(stdout(&from_file), stdout(&builtin));
    assert!(stdout(&builtin).contains("43 parameters"));
}

#[test]
fn fk_then_ik_round_trips_a_batch() {
    let dir = tempfile::tempdir().unwrap();
    let joints = dir.path().join("joints.csv");
    let poses = dir.path().join("poses.csv");
    let back = dir.path().join("back.csv");
    // A short smooth path, so that ik seeded from the previous point stays on its branch.
    let mut text = String::from("q1,q2,q3,q4,q5,q6\n");
    for k in 0..20 {
        let t = k as f64 / 20.0;
        text.push_str(&format!(
            "{},{},{},{},{},{}\n",
            0.1 + 0.3 * t,
            -1.2 + 0.2 * t,
            1.0 - 0.3 * t,
            -0.5,
            1.3 + 0.1 * t,
            0.2
        ));
    }
    std::fs::write(&joints, &text).unwrap();
    let fk = flexcal(&[
        "fk",
        "--robot",
        "ur10",
        "--input",
        path_str(&joints),
        "--output",
        path_str(&poses),
    ]);
    assert!(fk.status.success(), "{}", stderr(&fk));
    let pose_text = std::fs::read_to_string(&poses).unwrap();
    assert!(pose_text.starts_with("x_m,y_m,z_m,qw,qx,qy,qz\n"));
    assert_eq!(pose_text.lines().count(), 21);
    let ik = ik_ur10(&poses, &back, &["--seed", "0.1,-1.2,1.0,-0.5,1.3,0.2"]);
    assert!(ik.status.success(), "{}", stderr(&ik));
    let parse = |s: &str| -> Vec<Vec<f64>> {
        s.lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let original = parse(&text);
    let recovered = parse(&std::fs::read_to_string(&back).unwrap());
    for (a, b) in original.iter().zip(&recovered) {
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-8, "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn closed_loop_fk_reports_passive_joints() {
    let o = flexcal(&["fk", "--robot", "ir663", "--joints", "0,0.9,0.8,0,0.3,0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let header = out.lines().next().unwrap();
    assert_eq!(header.split(',').count(), 7 + 3, "{header}");
    assert!(header.contains("passive_"));
}

#[test]
fn bad_input_gives_one_line_errors_and_failure() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(Vec<String>, &str)> = {
        let nan = dir.path().join("nan.csv");
        std::fs::write(&nan, "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n0,NaN,0,0,0,0\n").unwrap();
        let missing = dir.path().join("missing.csv");
        std::fs::write(&missing, "q1,q2,q3\n0,0,0\n").unwrap();
        let bad_toml = dir.path().join("bad.toml");
        std::fs::write(&bad_toml, "name = \"x\"\n[[frames]\nname = 1\n").unwrap();
        vec![
            (
                vec![
                    "fk".into(),
                    "--robot".into(),
                    "nope".into(),
                    "--joints".into(),
                    "0".into(),
                ],
                "unknown robot",
            ),
            (
                vec![
                    "fk".into(),
                    "--robot".into(),
                    "ur10".into(),
                    "--joints".into(),
                    "0,1".into(),
                ],
                "6 actuated",
            ),
            (
                vec![
                    "fk".into(),
                    "--robot".into(),
                    "ur10".into(),
                    "--joints".into(),
                    "0,1,2,3,4,nan".into(),
                ],
                "not a finite number",
            ),
            (
                vec![
                    "fk".into(),
                    "--robot".into(),
                    "ur10".into(),
                    "--input".into(),
                    nan.display().to_string(),
                ],
                "nan.csv:3",
            ),
            (
                vec![
                    "fk".into(),
                    "--robot".into(),
                    "ur10".into(),
                    "--input".into(),
                    missing.display().to_string(),
                ],
                "missing column 'q4'",
            ),
            (
                vec![
                    "robot".into(),
                    "show".into(),
                    bad_toml.display().to_string(),
                ],
                "bad.toml",
            ),
        ]
    };
    for (args, expected) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = flexcal(&args);
        assert!(!o.status.success(), "{args:?} should fail");
        let err = stderr(&o);
        assert!(err.contains(expected), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn unreachable_ik_target_is_an_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("far.csv");
    let out = dir.path().join("out.csv");
    std::fs::write(&out, "previous contents\n").unwrap();
    std::fs::write(&poses, "x_m,y_m,z_m,qw,qx,qy,qz\n5.0,0,0,1,0,0,0\n").unwrap();
    let o = ik_ur10(&poses, &out, &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("far.csv:2"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "previous contents\n"
    );
}

#[test]
fn usage_errors_exit_with_2_and_failures_with_1() {
    // A flag value flexcal rejects before any work: usage error.
    let o = flexcal(&["fk", "--robot", "no-such-robot", "--joints", "0,0,0,0,0,0"]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // clap's own usage errors exit with 2 too.
    let o = flexcal(&["fk", "--no-such-flag"]);
    assert_eq!(o.status.code(), Some(2));
    // A failure of the work (a file that does not exist): 1.
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.csv");
    let o = flexcal(&[
        "identify",
        "compliance",
        "--data",
        missing.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
