//! SYMORO `.par` import: the RX-90, the Stanford arm, the SR400 (one
//! parallelogram loop), a two-loop palletizer and the Eloise hand (a tree)
//! against the independent evaluation of `scripts/par_reference.py` (end
//! frame, every leaf, the loops' passive joints: 1e-9 m, 1e-9 on the rotation
//! entries, 1e-9 rad), a parallelogram loop against its closed form, and the
//! named errors for missing symbols and inconsistent counts.

use std::path::PathBuf;

use flexcal_kinematics::{
    Data, ImportOptions, ImportedRobot, KinematicsError, forward_frames, forward_pose,
};
use nalgebra::Matrix3;
use std::f64::consts::PI;

fn symoro(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/symoro")
        .join(file)
}

fn options(values: &str) -> ImportOptions {
    ImportOptions {
        values: Some(symoro(values)),
        ..ImportOptions::default()
    }
}

/// Worst position (m) and rotation-entry differences between `x` and a
/// reference pose record (`position_m`, `rotation`).
fn pose_difference(x: &nalgebra::Isometry3<f64>, record: &serde_json::Value) -> (f64, f64) {
    let dp = (0..3)
        .map(|k| (x.translation.vector[k] - record["position_m"][k].as_f64().unwrap()).abs())
        .fold(0.0, f64::max);
    let r_ref = Matrix3::from_fn(|i, j| record["rotation"][i][j].as_f64().unwrap());
    let dr = (x.rotation.to_rotation_matrix().matrix() - r_ref)
        .abs()
        .max();
    (dp, dr)
}

/// Compares flexcal's import of a case with `scripts/par_reference.py`: the
/// end frame, every leaf of a tree and the passive joints of the loops, each
/// configuration assembled from the values file's home configuration (a
/// fresh [`Data`], as the reference's Newton starts from home).
fn check(case: &str, tip: Option<&str>) {
    let reference_path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join(format!("tests/data/symoro_reference/{case}.json"));
    let reference: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(reference_path).unwrap()).unwrap();
    let par = reference["par"].as_str().unwrap();
    let values = reference["values"].as_str().unwrap();
    let mut o = options(values);
    o.tip = tip.map(str::to_string);
    let model = ImportedRobot::read_par(&symoro(par), &o)
        .unwrap()
        .description
        .build()
        .unwrap();
    let joints: Vec<&str> = reference["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j.as_str().unwrap())
        .collect();
    assert_eq!(model.actuated_names(), joints.as_slice(), "{case}");
    // Passive joints: reference variable -> frame number, in flexcal's order.
    let passive_frames: Vec<(String, String)> = reference["passive"]
        .as_object()
        .map(|m| {
            m.iter()
                .map(|(v, f)| (v.clone(), f.as_str().unwrap().to_string()))
                .collect()
        })
        .unwrap_or_default();
    let mut flexcal_passive: Vec<&str> = model.passive_names().iter().map(String::as_str).collect();
    flexcal_passive.sort_unstable();
    let mut reference_passive: Vec<&str> = passive_frames.iter().map(|(_, f)| f.as_str()).collect();
    reference_passive.sort_unstable();
    assert_eq!(flexcal_passive, reference_passive, "{case}: passive joints");
    let leaves: Vec<&str> = reference["leaves"]
        .as_array()
        .map(|l| l.iter().map(|f| f.as_str().unwrap()).collect())
        .unwrap_or_default();
    let xi = model.nominal_params().to_vec();
    let (mut dp, mut dr, mut dq) = (0.0f64, 0.0f64, 0.0f64);
    let mut compared = 0;
    for c in reference["configurations"].as_array().unwrap() {
        let q: Vec<f64> = c["q"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let mut data = Data::new(&model);
        let x = forward_pose(&model, &mut data, &q, &xi).unwrap();
        if c.get("position_m").is_some() {
            let (p, r) = pose_difference(&x, c);
            (dp, dr) = (dp.max(p), dr.max(r));
            compared += 1;
        }
        for leaf in &leaves {
            let i = model.frame_index(leaf).unwrap();
            let (p, r) = pose_difference(&data.frame_pose(i).unwrap(), &c["leaves"][*leaf]);
            (dp, dr) = (dp.max(p), dr.max(r));
            compared += 1;
        }
        for (variable, frame) in &passive_frames {
            let k = model
                .passive_names()
                .iter()
                .position(|n| n == frame)
                .unwrap();
            let expected = c["passive"][variable].as_f64().unwrap();
            // Angles that differ by whole turns are one configuration.
            let d = (data.passive_values()[k] - expected + PI).rem_euclid(2.0 * PI) - PI;
            dq = dq.max(d.abs());
        }
    }
    println!(
        "{case}: {} parameters, {compared} poses, {} passive joints; worst {dp:.2e} m, {dr:.2e} (rotation entries), {dq:.2e} (passive joints, rad)",
        model.n_params(),
        passive_frames.len()
    );
    assert!(compared >= 24, "{case}: only {compared} poses compared");
    assert!(
        dp < 1e-9 && dr < 1e-9 && dq < 1e-9,
        "{case}: {dp:.3e} m, {dr:.3e}, passive {dq:.3e} rad"
    );
}

#[test]
fn rx90_matches_the_independent_evaluation() {
    check("rx90", None);
}

#[test]
fn stanford_arm_matches_the_independent_evaluation() {
    check("stanford", None);
}

#[test]
fn sr400_with_its_parallelogram_matches_the_independent_evaluation() {
    check("sr400", None);
}

#[test]
fn two_loop_palletizer_matches_the_independent_evaluation() {
    check("palletizer", None);
}

#[test]
fn eloise_hand_tree_matches_the_independent_evaluation_at_every_fingertip() {
    // A tree has no single end: without a tip the import names the candidates.
    let e =
        ImportedRobot::read_par(&symoro("eloise.par"), &options("eloise_values.toml")).unwrap_err();
    match &e {
        KinematicsError::AmbiguousTip { candidates, .. } => assert_eq!(candidates, "4, 8, 12, 16"),
        other => panic!("expected AmbiguousTip, got {other}"),
    }
    check("eloise", Some("8"));
}

#[test]
fn a_parallelogram_loop_keeps_its_coupler_parallel_to_the_ground() {
    let mut o = options("fourbar_values.toml");
    o.tip = Some("2".into());
    let model = ImportedRobot::read_par(&symoro("fourbar.par"), &o)
        .unwrap()
        .description
        .build()
        .unwrap();
    assert_eq!(model.n_actuated(), 1);
    let mut data = Data::new(&model);
    let xi = model.nominal_params().to_vec();
    let mut q1 = 1.0f64;
    // A sweep from the home configuration, each solve seeded by the previous one.
    while q1 > 0.3 {
        let x = forward_pose(&model, &mut data, &[q1], &xi).unwrap();
        let expected = nalgebra::Vector3::new(0.3 * q1.cos(), 0.3 * q1.sin(), 0.0);
        assert!((x.translation.vector - expected).norm() < 1e-9, "q1 = {q1}");
        assert!(
            x.rotation.angle() < 1e-9,
            "q1 = {q1}: coupler turned by {}",
            x.rotation.angle()
        );
        forward_frames(&model, &mut data, &[q1], &xi).unwrap();
        q1 -= 0.05;
    }
}

#[test]
fn missing_symbols_and_inconsistent_counts_are_named_errors() {
    let e = ImportedRobot::read_par(&symoro("rx90.par"), &ImportOptions::default()).unwrap_err();
    match &e {
        KinematicsError::MissingSymbols { symbols, .. } => assert_eq!(symbols, "D3, RL4"),
        other => panic!("expected MissingSymbols, got {other}"),
    }
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.par");
    std::fs::write(
        &bad,
        "NL = 3\nNJ = 4\nNF = 4\nAnt = {0,1,2,3}\nSigma = {0,0,0,0}\n",
    )
    .unwrap();
    let e = ImportedRobot::read_par(&bad, &ImportOptions::default()).unwrap_err();
    assert!(matches!(e, KinematicsError::Symoro { line: 3, .. }), "{e}");
    assert!(e.to_string().contains("NF must be"), "{e}");
    std::fs::write(
        &bad,
        "NL = 2\nNJ = 2\nNF = 2\nAnt = {0,1,1}\nSigma = {0,0}\n",
    )
    .unwrap();
    let e = ImportedRobot::read_par(&bad, &ImportOptions::default()).unwrap_err();
    assert!(matches!(e, KinematicsError::Symoro { line: 4, .. }), "{e}");
    std::fs::write(
        &bad,
        "NL = 2\nNJ = 2\nNF = 2\nAnt = {0,1}\nSigma = {0,0}\nd = {0, 1e999}\n",
    )
    .unwrap();
    let e = ImportedRobot::read_par(&bad, &ImportOptions::default()).unwrap_err();
    assert!(e.to_string().contains("not"), "{e}");
}
