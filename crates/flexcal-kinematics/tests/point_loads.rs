//! Generalised forces of point loads against the finite-difference work of a
//! constant force, on every built-in robot (closed loops and slider cranks
//! included), over seeded random configurations.

use flexcal_kinematics::{
    Data, Model, PointLoad, RobotDescription, actuated_forces_into, forward_frames,
};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

/// Work `sum_k f_k . p_k(q)` of constant forces at points fixed to frames.
fn work(model: &Model, data: &mut Data, q: &[f64], loads: &[PointLoad]) -> f64 {
    forward_frames(model, data, q, model.nominal_params()).unwrap();
    loads
        .iter()
        .map(|l| {
            let pose = data.frame_pose(l.frame).unwrap();
            l.force
                .dot(&(pose * nalgebra::Point3::from(l.point)).coords)
        })
        .sum()
}

fn check_robot(name: &str) {
    let model = RobotDescription::builtin(name).unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x6c6f6164 + name.len() as u64);
    let mut data = Data::new(&model);
    for _ in 0..6 {
        let q = common::random_configuration(&model, &mut rng);
        // A load on every frame, at a random point, with a random force.
        let loads: Vec<PointLoad> = (0..model.n_frames())
            .map(|frame| PointLoad {
                frame,
                point: Vector3::from_fn(|_, _| rng.random_range(-0.3..0.3)),
                force: Vector3::from_fn(|_, _| rng.random_range(-100.0..100.0)),
            })
            .collect();
        let mut tau = vec![0.0; model.n_actuated()];
        actuated_forces_into(
            &model,
            &mut data,
            &q,
            model.nominal_params(),
            &loads,
            &mut tau,
        )
        .unwrap();
        let h = 1e-6;
        let scale = tau.iter().fold(1.0f64, |m, t| m.max(t.abs()));
        for k in 0..model.n_actuated() {
            let mut x = q.clone();
            x[k] = q[k] + h;
            let plus = work(&model, &mut data, &x, &loads);
            x[k] = q[k] - h;
            let minus = work(&model, &mut data, &x, &loads);
            let numeric = (plus - minus) / (2.0 * h);
            assert!(
                (tau[k] - numeric).abs() < 1e-6 * scale,
                "{name}: generalised force {k} is {} analytically, {numeric} by differences, at q = {q:?}",
                tau[k]
            );
        }
    }
}

#[test]
fn generalised_forces_are_the_derivatives_of_the_work() {
    for name in ["ur10", "puma560", "ir663"] {
        check_robot(name);
    }
}

#[test]
fn a_load_on_a_missing_frame_is_an_error() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut data = Data::new(&model);
    let loads = [PointLoad {
        frame: model.n_frames(),
        point: Vector3::zeros(),
        force: Vector3::z(),
    }];
    let mut tau = vec![0.0; model.n_actuated()];
    let err = actuated_forces_into(
        &model,
        &mut data,
        &[0.1; 6],
        model.nominal_params(),
        &loads,
        &mut tau,
    )
    .unwrap_err();
    assert!(err.to_string().contains("point load"), "{err}");
}

/// The frame of each actuated coordinate is the frame its joint turns:
/// frames `1`..`6` of the built-in UR10, and a joint's axis is that
/// frame's z axis (the joint Jacobian's angular column).
#[test]
fn actuated_frames_are_the_joint_frames() {
    let model = flexcal_kinematics::RobotDescription::builtin("ur10")
        .unwrap()
        .build()
        .unwrap();
    let q = [0.3, -1.1, 0.9, -0.4, 1.2, 0.5];
    let mut data = flexcal_kinematics::Data::new(&model);
    let jac =
        flexcal_kinematics::joint_jacobian(&model, &mut data, &q, model.nominal_params()).unwrap();
    for i in 0..6 {
        let frame = model.actuated_frame(i).unwrap();
        assert_eq!(model.frame_names()[frame], (i + 1).to_string());
        let z = data.frame_pose(frame).unwrap().rotation * Vector3::z();
        let w = Vector3::new(jac[(3, i)], jac[(4, i)], jac[(5, i)]);
        assert!((z - w).norm() < 1e-12, "joint {i}: {z} vs {w}");
    }
    assert_eq!(model.actuated_frame(6), None);
}
