//! The evaluation of the error model on several threads
//! (`ErrorModel::with_threads`, `CalibrationOptions::threads`) gives the
//! serial evaluation's numbers to the bit: the residuals, the predictions
//! and the Jacobian of a two-armed robot with lateral compliances (with the
//! one step and with the equilibrium deflection; the benchmark's set) and
//! of a one-target set,
//! on 1, 2 and 3 threads with pose counts that do not divide evenly; and a
//! whole identification on 1 and 2 threads.

use std::borrow::Cow;

use faer::Mat;
use flexcal_calib::{
    CalibError, CalibrationOptions, Deflection, ErrorModel, FrameStarts, GravityCompliance,
    JointLaw, JointTerms, LateralCompliance, MeasurementSet, TargetPose, calibrate,
};
use flexcal_kinematics::{Model, RobotDescription};
use flexcal_optim::{Jacobian, Residuals};
use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;
#[path = "../benches/support/target_set.rs"]
mod target_set;

/// The benchmark's two-armed set (`benches/support/target_set.rs`): `n`
/// poses, a marker on each hand, 20 um of noise.
fn two_arms_set(gravity: &GravityCompliance, n: usize) -> (Model, MeasurementSet) {
    target_set::target_set("two_arms", gravity, n, 0.0, 20e-6)
}

/// `set` with an orientation (a rotation vector near 1 rad, rad) on every
/// observation of its first target, so that six-row blocks are compared
/// too.
fn first_target_oriented(set: &MeasurementSet) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let poses: Vec<TargetPose> = set
        .poses()
        .iter()
        .map(|pose| {
            let mut pose = pose.clone();
            if let Some(seen) = pose.observations[0].as_mut() {
                seen.orientation = Some(Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0)));
            }
            pose
        })
        .collect();
    MeasurementSet::from_poses("oriented", set.targets().to_vec(), poses).unwrap()
}

/// The unknowns of `problem` moved away from its start: lengths by up to
/// 1 mm, angles by up to 0.01 rad, compliances to 2-20 urad/N.m.
fn away_from_start(problem: &ErrorModel<'_>, rng: &mut ChaCha8Rng) -> Vec<f64> {
    problem
        .initial_unknowns()
        .iter()
        .zip(problem.kinds())
        .map(|(v, kind)| {
            v + match kind {
                flexcal_calib::UnknownKind::Length => rng.random_range(-1e-3..1e-3),
                flexcal_calib::UnknownKind::Angle => rng.random_range(-1e-2..1e-2),
                flexcal_calib::UnknownKind::Compliance => rng.random_range(2e-6..20e-6),
                _ => rng.random_range(-1e-2..1e-2),
            }
        })
        .collect()
}

/// Residuals, predictions, errors and Jacobian of `problem` at `x`, as
/// bits.
fn evaluation_bits(problem: &ErrorModel<'_>, x: &[f64]) -> Vec<u64> {
    let mut residuals = vec![f64::NAN; problem.n_residuals()];
    problem.residuals(x, &mut residuals).unwrap();
    let mut jacobian =
        Mat::<f64>::from_fn(problem.n_residuals(), problem.n_unknowns(), |_, _| f64::NAN);
    problem.jacobian(x, jacobian.as_mut()).unwrap();
    let mut bits: Vec<u64> = residuals.iter().map(|r| r.to_bits()).collect();
    for p in problem.predict(x).unwrap() {
        bits.extend(p.translation.vector.iter().map(|v| v.to_bits()));
        bits.extend(p.rotation.coords.iter().map(|v| v.to_bits()));
    }
    for e in problem.errors(x).unwrap() {
        bits.extend(e.position_vector.iter().map(|v| v.to_bits()));
        bits.push(e.orientation.unwrap_or(-1.0).to_bits());
    }
    for j in 0..problem.n_unknowns() {
        bits.extend((0..problem.n_residuals()).map(|i| jacobian[(i, j)].to_bits()));
    }
    bits
}

/// Asserts that `build(threads)` evaluates at `x` to the same bits on 1, 2
/// and 3 threads, and that the residuals and Jacobian are finite and not
/// all zero (the comparison compares something).
fn assert_same_bits_on_1_2_3_threads<'a>(
    label: &str,
    build: &dyn Fn(Option<usize>) -> ErrorModel<'a>,
    x: &[f64],
) {
    let serial = build(Some(1));
    assert_eq!(serial.threads(), 1);
    let reference = evaluation_bits(&serial, x);
    assert!(reference.iter().all(|b| f64::from_bits(*b).is_finite()));
    assert!(reference.iter().any(|b| f64::from_bits(*b) != 0.0));
    for threads in [2, 3] {
        let threaded = build(Some(threads));
        assert_eq!(threaded.threads(), threads);
        let bits = evaluation_bits(&threaded, x);
        assert_eq!(bits.len(), reference.len());
        let first = (0..bits.len()).find(|&i| bits[i] != reference[i]);
        assert_eq!(
            first, None,
            "{label}: {threads} threads differ at entry {first:?}"
        );
    }
}

/// 100 poses (not a multiple of 3: chunks of 33, 33 and 34 poses) of two
/// markers, the left one with its orientation rows, with the joint
/// compliances, the lateral compliances and the joint law, with the one
/// step and with the equilibrium deflection.
#[test]
fn two_armed_robot_with_lateral_compliances_evaluates_alike_on_1_2_and_3_threads() {
    let mut gravity =
        GravityCompliance::from_toml_file(&common::data_file("two_arms_masses.toml")).unwrap();
    assert_eq!(gravity.lateral, LateralCompliance::AboutX);
    let (model, set) = two_arms_set(&gravity, 100);
    let set = first_target_oriented(&set);
    let terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    let starts = FrameStarts::nominal(&set, Isometry3::identity(), None).unwrap();
    assert_eq!(starts.orientation, [true, false]);
    for deflection in [Deflection::OneStep, Deflection::equilibrium()] {
        gravity.deflection = deflection;
        let build = |threads| {
            ErrorModel::new(&model, Cow::Borrowed(&set), &starts)
                .unwrap()
                .with_elastic(Some(&gravity), &terms)
                .unwrap()
                .with_threads(threads)
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let x = away_from_start(&build(Some(1)), &mut rng);
        assert_same_bits_on_1_2_3_threads(&format!("{deflection:?}"), &build, &x);
    }
}

/// A one-target set on the UR10 (61 poses: two chunks of 30 and 31 on
/// 2 or 3 threads), its orientations fitted, with gravity.
#[test]
fn one_target_set_evaluates_alike_on_1_2_and_3_threads() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let xi = common::perturbed_geometry(
        &model,
        &mut ChaCha8Rng::seed_from_u64(11),
        0.3e-3,
        0.03f64.to_radians(),
    );
    let (frame, _) = common::generic_frame_and_target();
    let simulation = common::GravitySimulation {
        model: &model,
        gravity: &gravity,
        xi: &xi,
        payload: (5.0, Vector3::new(0.0, 0.0, 0.1)),
        frame,
        noise: 20e-6,
    };
    let set = common::with_orientation(&simulation.measure(
        61,
        12,
        "ur10",
        common::ur10_configuration,
        |q, tau| q.iter().zip(tau).map(|(q, t)| q + 15e-6 * t).collect(),
    ));
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let starts = FrameStarts::nominal(&set, Isometry3::identity(), None).unwrap();
    assert_eq!(starts.orientation, [true]);
    let build = |threads| {
        ErrorModel::new(&model, Cow::Borrowed(&set), &starts)
            .unwrap()
            .with_elastic(Some(&gravity), &JointTerms::default())
            .unwrap()
            .with_threads(threads)
    };
    let x = away_from_start(&build(Some(1)), &mut rng);
    assert_same_bits_on_1_2_3_threads("one target", &build, &x);
}

/// The whole identification of the two-armed robot's compliances on one
/// thread and on two: the same result, every figure to the bit.
#[test]
fn calibration_on_two_threads_is_the_serial_one_to_the_bit() {
    let gravity =
        GravityCompliance::from_toml_file(&common::data_file("two_arms_masses.toml")).unwrap();
    let (model, set) = two_arms_set(&gravity, 90);
    let options = |threads| CalibrationOptions {
        gravity: Some(gravity.clone()),
        threads,
        ..CalibrationOptions::default()
    };
    let serial = calibrate(&model, &set, &options(Some(1))).unwrap();
    let threaded = calibrate(&model, &set, &options(Some(2))).unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    assert_eq!(bits(&serial.xi), bits(&threaded.xi));
    assert!(
        serial.xi != serial.nominal_xi,
        "the fit moved the parameters"
    );
    // Every figure of the result, the statistics and standard errors
    // included, through its serialised form (shortest round-trip digits).
    let serial_json = serde_json::to_string(&serial).unwrap();
    assert!(serial_json.contains("compliance_"));
    assert_eq!(serial_json, serde_json::to_string(&threaded).unwrap());
}

/// A thread count of zero is refused by name.
#[test]
fn zero_threads_is_refused_by_name() {
    let gravity =
        GravityCompliance::from_toml_file(&common::data_file("two_arms_masses.toml")).unwrap();
    let (model, set) = two_arms_set(&gravity, 10);
    let options = CalibrationOptions {
        threads: Some(0),
        ..CalibrationOptions::default()
    };
    match calibrate(&model, &set, &options) {
        Err(CalibError::InvalidOption { name, .. }) => assert_eq!(name, "threads"),
        other => panic!("expected the option refused, got {:?}", other.map(|c| c.xi)),
    }
}
