//! Analytic Jacobians against central finite differences on every built-in
//! robot, over seeded random configurations.

use flexcal_kinematics::{
    Data, Model, RobotDescription, forward_pose, joint_jacobian, param_jacobian,
};
use nalgebra::{DMatrix, Isometry3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

/// Central difference of the pose: [dp; dphi] with R(x+h) = exp([dphi]x) R(x).
fn pose_difference(plus: &Isometry3<f64>, minus: &Isometry3<f64>, h: f64) -> Vector6<f64> {
    let dp = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
    let dphi = (plus.rotation * minus.rotation.inverse()).scaled_axis() / (2.0 * h);
    Vector6::new(dp.x, dp.y, dp.z, dphi.x, dphi.y, dphi.z)
}

fn finite_difference_params(model: &Model, q: &[f64], xi: &[f64]) -> DMatrix<f64> {
    let mut data = Data::new(model);
    let h = 1e-6;
    let mut out = DMatrix::zeros(6, model.n_params());
    for j in 0..model.n_params() {
        let mut x = xi.to_vec();
        x[j] = xi[j] + h;
        let plus = forward_pose(model, &mut data, q, &x).unwrap();
        x[j] = xi[j] - h;
        let minus = forward_pose(model, &mut data, q, &x).unwrap();
        out.set_column(j, &pose_difference(&plus, &minus, h));
    }
    out
}

fn finite_difference_joints(model: &Model, q: &[f64], xi: &[f64]) -> DMatrix<f64> {
    let mut data = Data::new(model);
    let h = 1e-6;
    let mut out = DMatrix::zeros(6, model.n_actuated());
    for k in 0..model.n_actuated() {
        let mut x = q.to_vec();
        x[k] = q[k] + h;
        let plus = forward_pose(model, &mut data, &x, xi).unwrap();
        x[k] = q[k] - h;
        let minus = forward_pose(model, &mut data, &x, xi).unwrap();
        out.set_column(k, &pose_difference(&plus, &minus, h));
    }
    out
}

/// Largest column error relative to the Jacobian's scale (at least 1).
fn relative_error(analytic: &DMatrix<f64>, numeric: &DMatrix<f64>) -> f64 {
    let scale = analytic.amax().max(1.0);
    (analytic - numeric).amax() / scale
}

fn check_robot(name: &str, perturb_xi: bool) {
    let model = RobotDescription::builtin(name).unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x6b696e + name.len() as u64);
    let mut data = Data::new(&model);
    for _ in 0..8 {
        let q = common::random_configuration(&model, &mut rng);
        let mut xi = model.nominal_params().to_vec();
        if perturb_xi {
            for (v, p) in xi.iter_mut().zip(model.params()) {
                let scale = match p.kind {
                    flexcal_kinematics::ParamKind::Length => 1e-3,
                    flexcal_kinematics::ParamKind::Angle => 1e-3,
                };
                *v += scale * rng.random_range(-1.0..1.0);
            }
        }
        let (pose, jac) = param_jacobian(&model, &mut data, &q, &xi).unwrap();
        let fk = forward_pose(&model, &mut data, &q, &xi).unwrap();
        assert!((pose.translation.vector - fk.translation.vector).norm() < 1e-14);
        assert!(jac.amax() > 0.1, "{name}: the Jacobian is (nearly) zero");
        let fd = finite_difference_params(&model, &q, &xi);
        let err = relative_error(&jac, &fd);
        assert!(
            err < 1e-6,
            "{name}: parameter Jacobian error {err:e} at q = {q:?}"
        );
        let jq = joint_jacobian(&model, &mut data, &q, &xi).unwrap();
        let jq = DMatrix::from_column_slice(6, model.n_actuated(), jq.as_slice());
        let fdq = finite_difference_joints(&model, &q, &xi);
        let err = relative_error(&jq, &fdq);
        assert!(
            err < 1e-6,
            "{name}: joint Jacobian error {err:e} at q = {q:?}"
        );
    }
}

#[test]
fn ur10_jacobians_match_finite_differences() {
    check_robot("ur10", false);
    check_robot("ur10", true);
}

#[test]
fn puma560_jacobians_match_finite_differences() {
    check_robot("puma560", false);
    check_robot("puma560", true);
}

#[test]
fn ir663_jacobians_match_finite_differences() {
    check_robot("ir663", false);
    check_robot("ir663", true);
}
