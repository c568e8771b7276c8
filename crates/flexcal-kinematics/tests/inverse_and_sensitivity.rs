//! Inverse model round trips, sensitivity indices, frame invariants.

use flexcal_kinematics::{
    Data, InverseOptions, InverseTarget, KinematicsError, ParamKind, RobotDescription,
    builtin_robot_names, forward_frames, forward_pose, inverse_pose, joint_jacobian,
    sensitivity_indices,
};
use nalgebra::{Isometry3, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

#[test]
fn forward_then_inverse_round_trips_on_every_builtin() {
    for name in builtin_robot_names() {
        let model = RobotDescription::builtin(name).unwrap().build().unwrap();
        let xi = model.nominal_params().to_vec();
        let mut data = Data::new(&model);
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        for _ in 0..10 {
            let q = common::random_configuration(&model, &mut rng);
            let target = forward_pose(&model, &mut data, &q, &xi).unwrap();
            let seed: Vec<f64> = q
                .iter()
                .map(|v| v + 0.02 * rng.random_range(-1.0..1.0))
                .collect();
            let s = inverse_pose(
                &model,
                &mut data,
                &target,
                &seed,
                &xi,
                &InverseOptions::default(),
            )
            .unwrap_or_else(|e| panic!("{name}: {e} from q = {q:?}"));
            let reached = forward_pose(&model, &mut data, &s.q, &xi).unwrap();
            let e = (reached.translation.vector - target.translation.vector).norm();
            assert!(e < 1e-9, "{name}: {e:e} m");
            assert!(reached.rotation.angle_to(&target.rotation) < 1e-9);
            // Nearest branch to the seed: the configuration itself comes back.
            for (a, b) in s.q.iter().zip(&q) {
                assert!((a - b).abs() < 1e-6, "{name}: {a} vs {b}");
            }
        }
    }
}

#[test]
fn tool_axis_target_leaves_rotation_about_the_axis_free() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let q = [0.3, -1.3, 1.4, -1.6, -1.57, 0.4];
    let mut target = forward_pose(&model, &mut data, &q, &xi).unwrap();
    target.rotation *= nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.7);
    let options = InverseOptions {
        target: InverseTarget::PositionAndToolAxis,
        ..InverseOptions::default()
    };
    let s = inverse_pose(&model, &mut data, &target, &q, &xi, &options).unwrap();
    let reached = forward_pose(&model, &mut data, &s.q, &xi).unwrap();
    assert!((reached.translation.vector - target.translation.vector).norm() < 1e-9);
    let z = reached.rotation * Vector3::z();
    let zt = target.rotation * Vector3::z();
    assert!((z - zt).norm() < 1e-9);
}

#[test]
fn unreachable_target_is_an_error() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let target = Isometry3::translation(3.0, 0.0, 0.5);
    let err = inverse_pose(
        &model,
        &mut data,
        &target,
        &[0.0; 6],
        &xi,
        &InverseOptions::default(),
    )
    .unwrap_err();
    match err {
        KinematicsError::Unreachable { position_error, .. } => assert!(position_error > 1.0),
        other => panic!("expected Unreachable, got {other:?}"),
    }
}

#[test]
fn sensitivity_of_lengths_and_base_rotation_have_closed_forms() {
    let model = RobotDescription::builtin("puma560")
        .unwrap()
        .build()
        .unwrap();
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let mut rng = ChaCha8Rng::seed_from_u64(55);
    let configurations: Vec<Vec<f64>> = (0..12)
        .map(|_| common::random_configuration(&model, &mut rng))
        .collect();
    let table = sensitivity_indices(&model, &mut data, &configurations, &xi).unwrap();
    assert_eq!(table.n_configurations, 12);
    for (j, p) in model.params().iter().enumerate() {
        if p.kind == ParamKind::Length {
            // A length error translates the TCP by itself, without turning it.
            assert!((table.mean_position[j] - 1.0).abs() < 1e-12, "{}", p.name);
            assert!(table.max_orientation[j] < 1e-12, "{}", p.name);
        } else {
            assert!(
                (table.mean_orientation[j] - 1.0).abs() < 1e-12,
                "{}",
                p.name
            );
        }
    }
    // theta1 turns the TCP about the base z axis: mu_P = distance to the axis.
    let j = model.param_index("theta1").unwrap();
    let mut sum = 0.0;
    for q in &configurations {
        let x = forward_pose(&model, &mut data, q, &xi).unwrap();
        sum += x.translation.vector.xy().norm();
    }
    assert!((table.mean_position[j] - sum / 12.0).abs() < 1e-12);
}

proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: 48,
        // Seeded: every run draws the same cases.
        rng_seed: proptest::test_runner::RngSeed::Fixed(20130009),
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    })]

    /// Frames compose: the TCP is the end frame times the tool, and each
    /// revolute column of the joint Jacobian is a unit rotation.
    #[test]
    fn frames_compose_and_revolute_columns_are_unit(seed in any::<u64>(), robot in 0usize..3) {
        let name = builtin_robot_names()[robot];
        let model = RobotDescription::builtin(name).unwrap().build().unwrap();
        let xi = model.nominal_params().to_vec();
        let mut data = Data::new(&model);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let q = common::random_configuration(&model, &mut rng);
        let x = forward_pose(&model, &mut data, &q, &xi).unwrap();
        forward_frames(&model, &mut data, &q, &xi).unwrap();
        let end = data.frame_pose(model.end_frame()).unwrap() * model.tool();
        prop_assert!((end.translation.vector - x.translation.vector).norm() < 1e-12);
        prop_assert!(end.rotation.angle_to(&x.rotation) < 1e-12);
        for i in 0..model.n_frames() {
            let pose = data.frame_pose(i).unwrap();
            let parent = model.antecedent(i).map(|p| data.frame_pose(p).unwrap()).unwrap_or_else(Isometry3::identity);
            let local = parent.inverse() * pose;
            prop_assert!(local.translation.vector.iter().all(|v| v.is_finite()));
        }
        if model.is_serial() {
            let jac = joint_jacobian(&model, &mut data, &q, &xi).unwrap();
            for k in 0..model.n_actuated() {
                let w = jac.fixed_view::<3, 1>(3, k).norm();
                prop_assert!((w - 1.0).abs() < 1e-12);
            }
        }
    }
}
