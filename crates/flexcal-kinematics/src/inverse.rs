//! Inverse model (6): damped least squares within the joint limits.

use nalgebra::{Isometry3, Matrix6, Matrix6xX, UnitQuaternion, Vector3, Vector6};

use crate::KinematicsError;
use crate::error::check_vector;
use crate::forward::joint_jacobian_into;
use crate::{Data, Model};

/// What the inverse model must reach.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InverseTarget {
    /// Full TCP pose (position and orientation).
    #[default]
    Pose,
    /// TCP position and the direction of the TCP z axis (tool axis); the
    /// rotation about the tool axis is free.
    PositionAndToolAxis,
}

/// Settings of [`inverse_pose`].
#[derive(Debug, Clone, PartialEq)]
pub struct InverseOptions {
    /// What to reach (default the full pose).
    pub target: InverseTarget,
    /// Maximum iterations (default 200).
    pub max_iterations: usize,
    /// Position tolerance (m) (default 1e-11).
    pub position_tolerance: f64,
    /// Orientation tolerance (rad) (default 1e-11).
    pub orientation_tolerance: f64,
    /// Initial damping of the least squares (m) (default 1e-3); adapted
    /// Levenberg-Marquardt style.
    pub initial_damping: f64,
}

impl Default for InverseOptions {
    fn default() -> Self {
        Self {
            target: InverseTarget::Pose,
            max_iterations: 200,
            position_tolerance: 1e-11,
            orientation_tolerance: 1e-11,
            initial_damping: 1e-3,
        }
    }
}

/// Result of [`inverse_pose`].
#[derive(Debug, Clone, PartialEq)]
pub struct InverseSolution {
    /// Actuated coordinates reaching the target (rad, m), within limits.
    pub q: Vec<f64>,
    /// Pose reached `x_base_tcp`.
    pub pose: Isometry3<f64>,
    /// Remaining position error (m).
    pub position_error: f64,
    /// Remaining orientation error (rad).
    pub orientation_error: f64,
    /// Iterations spent.
    pub iterations: usize,
}

/// Pose error `[p_target - p; phi]` with `R_target = exp([phi]x) R`.
fn pose_error(target: &Isometry3<f64>, pose: &Isometry3<f64>, kind: InverseTarget) -> Vector6<f64> {
    let dp = target.translation.vector - pose.translation.vector;
    let phi = match kind {
        InverseTarget::Pose => (target.rotation * pose.rotation.inverse()).scaled_axis(),
        InverseTarget::PositionAndToolAxis => {
            let z = pose.rotation * Vector3::z();
            let zt = target.rotation * Vector3::z();
            UnitQuaternion::rotation_between(&z, &zt)
                .map(|r| r.scaled_axis())
                // Opposite axes: any perpendicular half turn.
                .unwrap_or_else(|| {
                    let axis = z
                        .cross(&Vector3::x())
                        .try_normalize(1e-6)
                        .unwrap_or_else(|| z.cross(&Vector3::y()).normalize());
                    axis * std::f64::consts::PI
                })
        }
    };
    Vector6::new(dp.x, dp.y, dp.z, phi.x, phi.y, phi.z)
}

/// Inverse model `q = g(S, xi)` (6): actuated coordinates that bring the TCP to
/// `target` (`x_base_tcp`), by damped least squares on the joint Jacobian,
/// clamped to the joint limits, starting from `seed` (so the solution is the
/// branch nearest the seed).
///
/// Errors: [`KinematicsError::Unreachable`] when no configuration within the
/// limits reaches the tolerances.
pub fn inverse_pose(
    model: &Model,
    data: &mut Data,
    target: &Isometry3<f64>,
    seed: &[f64],
    xi: &[f64],
    options: &InverseOptions,
) -> Result<InverseSolution, KinematicsError> {
    check_vector("seed", seed, model.n_actuated())?;
    check_vector("xi", xi, model.n_params())?;
    let t = target.translation.vector;
    if !(t.iter().all(|v| v.is_finite()) && target.rotation.coords.iter().all(|v| v.is_finite())) {
        return Err(KinematicsError::NotFinite {
            what: "inverse target".into(),
        });
    }
    let na = model.n_actuated();
    let limits = model.actuated_limits();
    let clamp = |q: &mut [f64]| {
        for (v, &(lo, hi)) in q.iter_mut().zip(limits) {
            *v = v.clamp(lo, hi);
        }
    };
    let mut q = seed.to_vec();
    clamp(&mut q);
    let mut jac = Matrix6xX::zeros(na);
    let mut pose = joint_jacobian_into(model, data, &q, xi, &mut jac)?;
    let mut err = pose_error(target, &pose, options.target);
    let cost = |e: &Vector6<f64>| e.norm_squared();
    let mut lambda = options.initial_damping;
    let mut trial = vec![0.0; na];
    let mut trial_jac = Matrix6xX::zeros(na);
    let mut iterations = 0;
    while iterations < options.max_iterations {
        let pos_err = err.fixed_rows::<3>(0).norm();
        let rot_err = err.fixed_rows::<3>(3).norm();
        if pos_err <= options.position_tolerance && rot_err <= options.orientation_tolerance {
            return Ok(InverseSolution {
                q,
                pose,
                position_error: pos_err,
                orientation_error: rot_err,
                iterations,
            });
        }
        iterations += 1;
        let mut j = jac.clone();
        if options.target == InverseTarget::PositionAndToolAxis {
            // Rotation about the tool axis is free: project it out.
            let z = pose.rotation * Vector3::z();
            let projector = nalgebra::Matrix3::identity() - z * z.transpose();
            let ang = projector * j.fixed_rows::<3>(3);
            j.fixed_rows_mut::<3>(3).copy_from(&ang);
        }
        // dq = J^T (J J^T + lambda^2 I)^-1 e, solved by Cholesky.
        let a: Matrix6<f64> = &j * j.transpose() + Matrix6::identity() * (lambda * lambda);
        let Some(chol) = a.cholesky() else {
            lambda *= 10.0;
            continue;
        };
        let dq = j.transpose() * chol.solve(&err);
        for k in 0..na {
            trial[k] = q[k] + dq[k];
        }
        clamp(&mut trial);
        match joint_jacobian_into(model, data, &trial, xi, &mut trial_jac) {
            Ok(trial_pose) => {
                let trial_err = pose_error(target, &trial_pose, options.target);
                if cost(&trial_err) < cost(&err) {
                    q.copy_from_slice(&trial);
                    pose = trial_pose;
                    err = trial_err;
                    std::mem::swap(&mut jac, &mut trial_jac);
                    lambda = (lambda * 0.1).max(1e-12);
                } else {
                    lambda *= 10.0;
                }
            }
            Err(_) => lambda *= 10.0,
        }
        if lambda > 1e6 {
            break;
        }
    }
    // Restore the data of the best configuration for the caller.
    let _ = joint_jacobian_into(model, data, &q, xi, &mut jac);
    Err(KinematicsError::Unreachable {
        position_error: err.fixed_rows::<3>(0).norm(),
        orientation_error: err.fixed_rows::<3>(3).norm(),
        iterations,
    })
}
