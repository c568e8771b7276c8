//! The precomputed serial-chain evaluator against the general forward
//! model: at random parameter vectors and random configurations (seeded),
//! `SerialChain` gives `forward_pose`'s TCP pose to 1e-12 (m, and unitless
//! rotation entries) for the built-in UR10 and PUMA 560 and for imported
//! URDF chains with prismatic and fixed joints; robots that are not serial
//! chains and non-finite configurations are refused by name.

use std::path::PathBuf;

use flexcal_kinematics::{
    Data, ImportOptions, ImportedRobot, KinematicsError, Model, ParamKind, RobotDescription,
    SerialChain, forward_pose,
};
use nalgebra::Matrix4;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const TOLERANCE: f64 = 1e-12;

fn urdf_model(file: &str, tip: Option<&str>) -> Model {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/urdf")
        .join(file);
    let options = ImportOptions {
        tip: tip.map(String::from),
        ..ImportOptions::default()
    };
    ImportedRobot::read_urdf(&path, &options)
        .expect("import")
        .description
        .build()
        .expect("build")
}

/// xi with every parameter moved from its nominal value by up to 5 mm or
/// 0.05 rad: well beyond a calibration's corrections, so that every
/// constant part of the chain differs from the nominal one.
fn random_xi(model: &Model, rng: &mut ChaCha8Rng) -> Vec<f64> {
    model
        .nominal_params()
        .iter()
        .zip(model.params())
        .map(|(&v, p)| {
            let scale = match p.kind {
                ParamKind::Length => 0.005,
                ParamKind::Angle => 0.05,
            };
            v + rng.random_range(-scale..scale)
        })
        .collect()
}

fn random_q(model: &Model, rng: &mut ChaCha8Rng) -> Vec<f64> {
    model
        .actuated_limits()
        .iter()
        .map(|&(lo, hi)| rng.random_range(lo.max(-4.0)..hi.min(4.0)))
        .collect()
}

fn max_difference(a: &Matrix4<f64>, b: &Matrix4<f64>) -> f64 {
    (a - b).abs().max()
}

/// 40 parameter vectors x 25 configurations, each also through the batch
/// call; returns the largest difference seen.
fn check_against_forward_pose(model: &Model, seed: u64) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut data = Data::new(model);
    let mut worst = 0.0f64;
    for _ in 0..40 {
        let xi = random_xi(model, &mut rng);
        let chain = SerialChain::new(model, &xi).expect("serial chain");
        assert_eq!(chain.n_actuated(), model.n_actuated());
        let qs: Vec<Vec<f64>> = (0..25).map(|_| random_q(model, &mut rng)).collect();
        let mut batch = vec![f64::NAN; 16 * qs.len()];
        chain
            .matrices_into(&qs.concat(), &mut batch)
            .expect("batch");
        for (k, q) in qs.iter().enumerate() {
            let reference = forward_pose(model, &mut data, q, &xi).expect("forward_pose");
            let matrix = chain.matrix(q).expect("matrix");
            let difference = max_difference(&matrix, &reference.to_homogeneous());
            assert!(
                difference < TOLERANCE,
                "{}: matrix differs by {difference:.2e} at q = {q:?}",
                model.name()
            );
            let pose = chain.pose(q).expect("pose");
            let difference_pose =
                max_difference(&pose.to_homogeneous(), &reference.to_homogeneous());
            assert!(
                difference_pose < TOLERANCE,
                "{}: pose differs",
                model.name()
            );
            let row = Matrix4::from_row_slice(&batch[16 * k..16 * (k + 1)]);
            assert_eq!(row, matrix, "{}: batch row {k}", model.name());
            worst = worst.max(difference).max(difference_pose);
        }
    }
    worst
}

#[test]
fn ur10_serial_chain_matches_forward_pose() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let worst = check_against_forward_pose(&model, 10);
    eprintln!("ur10: largest difference {worst:.2e}");
}

#[test]
fn puma560_serial_chain_matches_forward_pose() {
    let model = RobotDescription::builtin("puma560")
        .unwrap()
        .build()
        .unwrap();
    check_against_forward_pose(&model, 560);
}

#[test]
fn imported_chain_with_prismatic_and_fixed_joints_matches_forward_pose() {
    let model = urdf_model("prismatic_first.urdf", None);
    assert!(
        model
            .actuated_kinds()
            .contains(&flexcal_kinematics::ActuatedKind::Prismatic),
        "the test robot has prismatic joints"
    );
    check_against_forward_pose(&model, 7);
}

#[test]
fn imported_industrial_chain_matches_forward_pose() {
    check_against_forward_pose(&urdf_model("kr16_like.urdf", None), 16);
}

#[test]
fn closed_loop_and_coupled_robots_are_refused_by_name() {
    let ir663 = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let e = SerialChain::new(&ir663, ir663.nominal_params()).unwrap_err();
    assert!(
        matches!(&e, KinematicsError::NotSerial { robot, reason } if robot == "ir663" && reason.contains("loop")),
        "{e}"
    );
    // Mimic joints on the TCP path are couplings: not a serial chain.
    let mimic = urdf_model("edge_cases.urdf", Some("tip"));
    let e = SerialChain::new(&mimic, mimic.nominal_params()).unwrap_err();
    assert!(
        matches!(&e, KinematicsError::NotSerial { reason, .. } if reason.contains("frame `")),
        "{e}"
    );
}

#[test]
fn bad_inputs_are_named() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let xi = model.nominal_params();
    let e = SerialChain::new(&model, &xi[..3]).unwrap_err();
    assert!(matches!(e, KinematicsError::WrongLength { .. }), "{e}");
    let chain = SerialChain::new(&model, xi).unwrap();
    let e = chain.matrix(&[0.0; 5]).unwrap_err();
    assert!(matches!(e, KinematicsError::WrongLength { .. }), "{e}");
    let e = chain
        .pose(&[0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0])
        .unwrap_err();
    assert_eq!(e.to_string(), "q[1] is not finite");
    let mut q = vec![0.1; 12];
    q[9] = f64::INFINITY;
    let mut out = vec![0.0; 32];
    let e = chain.matrices_into(&q, &mut out).unwrap_err();
    assert_eq!(e.to_string(), "q[1, 3] is not finite");
    let e = chain.matrices_into(&q[..11], &mut out).unwrap_err();
    assert!(matches!(e, KinematicsError::WrongLength { .. }), "{e}");
    let e = chain.matrices_into(&q, &mut out[..30]).unwrap_err();
    assert!(matches!(e, KinematicsError::WrongLength { .. }), "{e}");
}

/// The batch kernel evaluates four configurations at a time and the rest
/// one by one: every batch size from 0 to 11 (whole groups, remainders of
/// 1-3, remainders only) gives `matrix`'s result to the bit, including
/// coordinates far outside the inline sine's range (|q| >= 1e5 rad, std's
/// sine then) mixed into a group with ordinary ones.
#[test]
fn batches_of_every_size_match_single_calls_to_the_bit() {
    for (model, seed) in [
        (
            RobotDescription::builtin("ur10").unwrap().build().unwrap(),
            3,
        ),
        (urdf_model("prismatic_first.urdf", None), 4),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let xi = random_xi(&model, &mut rng);
        let chain = SerialChain::new(&model, &xi).unwrap();
        let n_actuated = chain.n_actuated();
        for n in 0..12 {
            let mut q: Vec<f64> = (0..n).flat_map(|_| random_q(&model, &mut rng)).collect();
            if n > 2 {
                q[n_actuated + 1] = 1.5e5;
                q[2 * n_actuated] = -7e8;
            }
            let mut batch = vec![f64::NAN; 16 * n];
            chain.matrices_into(&q, &mut batch).unwrap();
            for (k, row) in batch.chunks_exact(16).enumerate() {
                let single = chain
                    .matrix(&q[k * n_actuated..(k + 1) * n_actuated])
                    .unwrap();
                assert_eq!(
                    Matrix4::from_row_slice(row),
                    single,
                    "{}: row {k} of {n}",
                    model.name()
                );
            }
        }
    }
}

/// A non-finite coordinate anywhere in a batch (inside a group of four or in
/// the remainder) is named by row and column before anything is written.
#[test]
fn non_finite_values_in_a_batch_are_named_and_nothing_is_written() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let chain = SerialChain::new(&model, model.nominal_params()).unwrap();
    for (row, column, value) in [
        (2, 4, f64::NAN),
        (5, 0, f64::NEG_INFINITY),
        (4, 5, f64::INFINITY),
    ] {
        let mut q = vec![0.2; 6 * 6];
        q[6 * row + column] = value;
        let mut out = vec![-1.0; 16 * 6];
        let e = chain.matrices_into(&q, &mut out).unwrap_err();
        assert_eq!(e.to_string(), format!("q[{row}, {column}] is not finite"));
        assert!(
            out.iter().all(|&v| v == -1.0),
            "output written before the error"
        );
    }
}
