//! End-to-end runs of `flexcal robot show` and `flexcal robot export` with
//! URDF files, and of `flexcal fk` on an exported URDF.

use std::path::{Path, PathBuf};

mod common;
use common::{flexcal, stderr, stdout};

fn path_str(p: &Path) -> &str {
    p.to_str().expect("temp paths are UTF-8")
}

fn kinematics_data(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../flexcal-kinematics/tests/data/urdf")
        .join(file)
}

#[test]
fn a_urdf_shows_as_a_description_with_named_parameters() {
    let urdf = kinematics_data("kr16_like.urdf");
    let show = flexcal(&["robot", "show", path_str(&urdf)]);
    assert!(show.status.success(), "{}", stderr(&show));
    let text = stdout(&show);
    assert!(
        text.contains("joint_a1") && text.contains("beta3"),
        "{text}"
    );
    let toml = flexcal(&["robot", "show", path_str(&urdf), "--toml"]);
    assert!(toml.status.success(), "{}", stderr(&toml));
    assert!(stdout(&toml).contains("[[frame]]"));
    // Several leaves: the tip must be chosen, and the error lists the candidates.
    let edge = kinematics_data("edge_cases.urdf");
    let ambiguous = flexcal(&["robot", "show", path_str(&edge)]);
    assert!(!ambiguous.status.success());
    assert!(
        stderr(&ambiguous).contains("side_tip"),
        "{}",
        stderr(&ambiguous)
    );
    let chosen = flexcal(&[
        "robot",
        "show",
        path_str(&edge),
        "--tip",
        "side_tip",
        "--root",
        "base_plate",
    ]);
    assert!(chosen.status.success(), "{}", stderr(&chosen));
    assert!(
        stdout(&chosen).contains("mimic leader `j2`"),
        "{}",
        stdout(&chosen)
    );
}

#[test]
fn an_exported_urdf_gives_the_poses_of_the_robot() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("ur10.urdf");
    let export = flexcal(&[
        "robot",
        "export",
        "ur10",
        "--format",
        "urdf",
        "--out",
        path_str(&urdf),
    ]);
    assert!(export.status.success(), "{}", stderr(&export));
    assert!(
        stdout(&export).contains("largest TCP displacement"),
        "{}",
        stdout(&export)
    );
    let joints = dir.path().join("joints.csv");
    std::fs::write(
        &joints,
        "q1,q2,q3,q4,q5,q6\n0.1,-1.2,1.0,-0.5,1.3,0.2\n-2.0,0.3,2.5,1.0,-3.0,4.0\n",
    )
    .unwrap();
    let poses = |robot: &str, out: &Path| {
        let fk = flexcal(&[
            "fk",
            "--robot",
            robot,
            "--input",
            path_str(&joints),
            "--output",
            path_str(out),
        ]);
        assert!(fk.status.success(), "{}", stderr(&fk));
        std::fs::read_to_string(out)
            .unwrap()
            .lines()
            .skip(1)
            .flat_map(|l| {
                l.split(',')
                    .map(|v| v.parse::<f64>().unwrap())
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<f64>>()
    };
    let a = poses("ur10", &dir.path().join("a.csv"));
    let b = poses(path_str(&urdf), &dir.path().join("b.csv"));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-9, "{x} vs {y}");
    }
    let mdh = dir.path().join("ur10.md");
    let table = flexcal(&[
        "robot",
        "export",
        "ur10",
        "--format",
        "mdh",
        "--out",
        path_str(&mdh),
    ]);
    assert!(table.status.success(), "{}", stderr(&table));
    assert!(
        std::fs::read_to_string(&mdh)
            .unwrap()
            .contains("| 3 | 2 | 0 | theta3 |")
    );
    let refused = flexcal(&["robot", "export", "ir663", "--format", "urdf"]);
    assert!(!refused.status.success());
    assert!(
        stderr(&refused).contains("four-bar"),
        "{}",
        stderr(&refused)
    );
}

#[test]
fn fk_takes_a_urdf_with_its_tip() {
    let edge = kinematics_data("edge_cases.urdf");
    let without_tip = flexcal(&["fk", "--robot", path_str(&edge), "--joints", "0,0,0,0,0,0"]);
    assert!(!without_tip.status.success());
    assert!(
        stderr(&without_tip).contains("side_tip"),
        "{}",
        stderr(&without_tip)
    );
    let fk = flexcal(&[
        "fk",
        "--robot",
        path_str(&edge),
        "--tip",
        "tip",
        "--joints",
        "0.1,0.2,0.3,0.4,0.5,0.6",
    ]);
    assert!(fk.status.success(), "{}", stderr(&fk));
    let rx90 =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../flexcal-kinematics/tests/data/symoro");
    let par = flexcal(&[
        "fk",
        "--robot",
        path_str(&rx90.join("rx90.par")),
        "--values",
        path_str(&rx90.join("rx90_values.toml")),
        "--joints",
        "0,0,0,0,0,0",
    ]);
    assert!(par.status.success(), "{}", stderr(&par));
    let missing = flexcal(&[
        "fk",
        "--robot",
        path_str(&rx90.join("rx90.par")),
        "--joints",
        "0,0,0,0,0,0",
    ]);
    assert!(!missing.status.success());
    assert!(stderr(&missing).contains("D3, RL4"), "{}", stderr(&missing));
}

/// Parses the single data row of an `fk` output into numbers.
fn fk_row(text: &str) -> Vec<f64> {
    let row = text.lines().nth(1).expect("a data row");
    row.split(',').map(|v| v.parse().unwrap()).collect()
}

#[test]
fn fk_gives_named_frames_and_refuses_unknown_ones() {
    let ur5e = kinematics_data("ur5e.urdf");
    let q = "0.1,-1.2,0.9,-0.4,1.3,0.5";
    let frames = flexcal(&[
        "fk",
        "--robot",
        path_str(&ur5e),
        "--joints",
        q,
        "--frame",
        "wrist_2_link",
        "--frame",
        "tool0",
    ]);
    assert!(frames.status.success(), "{}", stderr(&frames));
    let text = stdout(&frames);
    assert!(
        text.starts_with("wrist_2_link.x_m,wrist_2_link.y_m,wrist_2_link.z_m,wrist_2_link.qw"),
        "{text}"
    );
    let both = fk_row(&text);
    assert_eq!(both.len(), 14);
    // tool0 is the URDF's tip, so its columns are the TCP's.
    let tcp = fk_row(&stdout(&flexcal(&[
        "fk",
        "--robot",
        path_str(&ur5e),
        "--joints",
        q,
    ])));
    for k in 0..3 {
        assert!((both[7 + k] - tcp[k]).abs() < 1e-15, "column {k}");
    }
    // The same rotation: quaternions equal up to their sign.
    let dot: f64 = (3..7).map(|k| both[7 + k] * tcp[k]).sum();
    assert!((dot.abs() - 1.0).abs() < 1e-15, "{dot}");
    // The same link as the tip of the import (five joints up to it).
    let tip = fk_row(&stdout(&flexcal(&[
        "fk",
        "--robot",
        path_str(&ur5e),
        "--tip",
        "wrist_2_link",
        "--joints",
        "0.1,-1.2,0.9,-0.4,1.3",
    ])));
    for k in 0..3 {
        assert!((both[k] - tip[k]).abs() < 1e-12, "column {k}");
    }
    let unknown = flexcal(&[
        "fk",
        "--robot",
        path_str(&ur5e),
        "--joints",
        q,
        "--frame",
        "wrist_9",
    ]);
    assert!(!unknown.status.success());
    assert!(
        stderr(&unknown).contains("has no frame `wrist_9`")
            && stderr(&unknown).contains("wrist_2_link"),
        "{}",
        stderr(&unknown)
    );
    assert!(stdout(&unknown).is_empty());
}

#[test]
fn a_tip_on_a_builtin_or_toml_robot_is_honoured_or_refused_by_name() {
    let q = "0.1,-1.2,0.9,-0.4,1.3,0.5";
    let frame_5 = fk_row(&stdout(&flexcal(&[
        "fk", "--robot", "ur10", "--joints", q, "--frame", "5",
    ])));
    let tip_5 = flexcal(&["fk", "--robot", "ur10", "--tip", "5", "--joints", q]);
    assert!(tip_5.status.success(), "{}", stderr(&tip_5));
    assert_eq!(fk_row(&stdout(&tip_5))[..7], frame_5[..]);
    for (robot, file) in [("ur10", None), ("toml", Some("ur10.toml"))] {
        let dir = tempfile::tempdir().unwrap();
        let spec = match file {
            Some(name) => {
                let path = dir.path().join(name);
                let toml = flexcal(&["robot", "show", "ur10", "--toml"]);
                std::fs::write(&path, stdout(&toml)).unwrap();
                path_str(&path).to_string()
            }
            None => robot.to_string(),
        };
        let refused = flexcal(&["fk", "--robot", &spec, "--tip", "tool0", "--joints", q]);
        assert!(!refused.status.success());
        assert!(
            stderr(&refused).contains("has no frame `tool0` (frames: 1, 2, 3, 4, 5, 6)"),
            "{}",
            stderr(&refused)
        );
        let root = flexcal(&["fk", "--robot", &spec, "--root", "base", "--joints", q]);
        assert!(!root.status.success());
        assert!(
            stderr(&root).contains("only be chosen in a URDF"),
            "{}",
            stderr(&root)
        );
    }
}
