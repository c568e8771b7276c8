//! SYMORO `.par` import: the RX-90 and the Stanford arm against the
//! independent evaluation of `scripts/par_reference.py` (1e-9 m, 1e-9 on the
//! rotation entries), a parallelogram loop against its closed form, and the
//! named errors for missing symbols and inconsistent counts.

use std::path::PathBuf;

use flexcal_kinematics::{
    Data, ImportOptions, ImportedRobot, KinematicsError, forward_frames, forward_pose,
};
use nalgebra::Matrix3;

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

fn check(case: &str) {
    let reference_path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join(format!("tests/data/symoro_reference/{case}.json"));
    let reference: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(reference_path).unwrap()).unwrap();
    let par = reference["par"].as_str().unwrap();
    let values = reference["values"].as_str().unwrap();
    let model = ImportedRobot::read_par(&symoro(par), &options(values))
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
    let mut data = Data::new(&model);
    let xi = model.nominal_params().to_vec();
    let (mut dp, mut dr) = (0.0f64, 0.0f64);
    for c in reference["configurations"].as_array().unwrap() {
        let q: Vec<f64> = c["q"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let x = forward_pose(&model, &mut data, &q, &xi).unwrap();
        for k in 0..3 {
            dp = dp.max((x.translation.vector[k] - c["position_m"][k].as_f64().unwrap()).abs());
        }
        let r_ref = Matrix3::from_fn(|i, j| c["rotation"][i][j].as_f64().unwrap());
        dr = dr.max(
            (x.rotation.to_rotation_matrix().matrix() - r_ref)
                .abs()
                .max(),
        );
    }
    println!(
        "{case}: {} parameters; worst {dp:.2e} m, {dr:.2e} (rotation entries)",
        model.n_params()
    );
    assert!(dp < 1e-9 && dr < 1e-9, "{case}: {dp:.3e} m, {dr:.3e}");
}

#[test]
fn rx90_matches_the_independent_evaluation() {
    check("rx90");
}

#[test]
fn stanford_arm_matches_the_independent_evaluation() {
    check("stanford");
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
