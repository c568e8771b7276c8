//! Compensation of one target pose: the commanded pose ("fake pose") that
//! brings the deflected robot onto the target, by fixed-point correction
//! through the joint Jacobian with a Newton fallback on the coupled system.

use flexcal_elastic::tcp::TcpDeflection;
use flexcal_kinematics::{InverseOptions, InverseTarget, inverse_pose};
use nalgebra::{Isometry3, Matrix6xX, Vector3, Vector6};

use super::equilibrium::ActualPose;
use super::error::CompensationError;
use super::jacobian::JACOBIAN_REFRESH_RATIO;
use super::model::{CompensationOptions, ElastoGeometricModel};
use super::pose::pose_difference;
use super::workspace::CompensationData;

/// How the commanded pose of a point was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompensationMethod {
    /// Fixed-point iteration converged.
    FixedPoint,
    /// Newton on the coupled system was needed.
    Newton,
}

/// Result of compensating one path point.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatedPoint {
    /// Target TCP pose in the base frame.
    pub target_base: Isometry3<f64>,
    /// Command without compensation: the inverse geometric model of the target.
    pub q_uncompensated: Vec<f64>,
    /// Pose reached with that command: error = reached (-) target [m, rad].
    pub uncompensated_error: Vector6<f64>,
    /// Compensated command (actuated coordinates).
    pub q_commanded: Vec<f64>,
    /// Commanded TCP pose (the "fake pose"), base frame: the geometric pose of
    /// `q_commanded`.
    pub commanded_base: Isometry3<f64>,
    /// Remaining error after compensation [m, rad].
    pub residual: Vector6<f64>,
    /// Wrench on the tool at the compensated equilibrium, base frame.
    pub wrench_base: Vector6<f64>,
    /// Iterations (fixed point plus Newton).
    pub iterations: usize,
    /// Which solver finished.
    pub method: CompensationMethod,
}

pub(crate) fn converged(e: &Vector6<f64>, options: &CompensationOptions) -> bool {
    e.fixed_rows::<3>(0).norm() <= options.position_tolerance_m
        && e.fixed_rows::<3>(3).norm() <= options.orientation_tolerance_rad
}

pub(crate) fn inverse_converged(e: &Vector6<f64>, options: &InverseOptions) -> bool {
    e.fixed_rows::<3>(0).norm() <= options.position_tolerance
        && e.fixed_rows::<3>(3).norm() <= options.orientation_tolerance
}

fn solve_square(jac: &Matrix6xX<f64>, rhs: &Vector6<f64>) -> Option<nalgebra::DVector<f64>> {
    let n = jac.ncols();
    if n == 6 {
        let m: nalgebra::Matrix6<f64> = jac.fixed_columns::<6>(0).into_owned();
        m.lu()
            .solve(rhs)
            .map(|v| nalgebra::DVector::from_column_slice(v.as_slice()))
    } else {
        // Redundant or deficient robots: least squares by SVD.
        let dj = nalgebra::DMatrix::from_column_slice(6, n, jac.as_slice());
        let svd = dj.svd(true, true);
        let rhs = nalgebra::DVector::from_column_slice(rhs.as_slice());
        svd.solve(&rhs, 1e-12).ok()
    }
}

/// The remaining error of an uncompensated command, for polishing it (see
/// `PathTracker::push`): the full pose error when the inverse model reaches
/// the full pose; zero otherwise, since the rotation about the tool axis is
/// then free and the full error is no error of the solution.
pub(crate) fn full_pose_error(
    pose: &Isometry3<f64>,
    target_base: &Isometry3<f64>,
    options: &InverseOptions,
) -> Vector6<f64> {
    if options.target == InverseTarget::Pose {
        pose_difference(pose, target_base)
    } else {
        Vector6::zeros()
    }
}

/// How a correction loop ended.
pub(crate) struct Correction {
    pub(crate) error: Vector6<f64>,
    pub(crate) iterations: usize,
}

impl<E: ?Sized + TcpDeflection> ElastoGeometricModel<'_, E> {
    /// The pose reached at the command `q`, its deflection solved from the
    /// one `previous` reached at a nearby command.
    fn reached_from(
        &self,
        data: &mut CompensationData<E::Workspace>,
        q: &[f64],
        previous: &ActualPose,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
    ) -> Result<ActualPose, CompensationError> {
        self.actual_pose_from_guess(data, q, motion_base, options, Some(&previous.deflection))
    }

    /// Fixed-point correction of the command `q` (whose reached pose is
    /// `actual`) until it reaches `target_base`: `q <- q - J^-1 (S(q) (-)
    /// target)`, the Jacobian reused while it contracts the error well.
    /// Stops when converged, after `max_iterations`, or when the error
    /// stalls (the caller then hands over to Newton).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn correct_command(
        &self,
        data: &mut CompensationData<E::Workspace>,
        target_base: &Isometry3<f64>,
        q: &mut [f64],
        actual: &mut ActualPose,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        max_iterations: usize,
    ) -> Result<Correction, CompensationError> {
        let limits = self.model.actuated_limits();
        let mut error = pose_difference(&actual.x_base_tcp, target_base);
        let mut iterations = 0;
        let mut previous = f64::INFINITY;
        let mut refreshed_here = false;
        while !converged(&error, options) && iterations < max_iterations {
            let size = error.norm();
            if data.jacobian.is_empty()
                || (size > JACOBIAN_REFRESH_RATIO * previous && !refreshed_here)
            {
                data.jacobian
                    .refresh(self.model, &mut data.kinematics, q, &self.xi)?;
                refreshed_here = true;
            } else {
                refreshed_here = false;
            }
            data.jacobian.correct(q, &error, Some(limits))?;
            *actual = self.reached_from(data, q, actual, motion_base, options)?;
            error = pose_difference(&actual.x_base_tcp, target_base);
            iterations += 1;
            // Stalled or growing even with a fresh Jacobian: hand over to Newton.
            if error.norm() > 0.9 * size && iterations > 3 {
                break;
            }
            previous = size;
        }
        Ok(Correction { error, iterations })
    }

    /// Newton on the coupled system, the full Jacobian of the reached pose
    /// (elastic and process terms included) by central differences.
    fn newton_command(
        &self,
        data: &mut CompensationData<E::Workspace>,
        target_base: &Isometry3<f64>,
        q: &mut [f64],
        actual: &mut ActualPose,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
    ) -> Result<Correction, CompensationError> {
        let na = self.model.n_actuated();
        let limits = self.model.actuated_limits();
        let mut error = pose_difference(&actual.x_base_tcp, target_base);
        let mut iterations = 0;
        let mut full = Matrix6xX::zeros(na);
        let mut perturbed = q.to_vec();
        while !converged(&error, options) && iterations < options.max_newton_iterations {
            for j in 0..na {
                let h = 1e-6 * (1.0 + q[j].abs());
                perturbed.copy_from_slice(q);
                perturbed[j] += h;
                let sp = self.reached_from(data, &perturbed, actual, motion_base, options)?;
                perturbed[j] -= 2.0 * h;
                let sm = self.reached_from(data, &perturbed, actual, motion_base, options)?;
                let col = pose_difference(&sp.x_base_tcp, &sm.x_base_tcp) / (2.0 * h);
                full.set_column(j, &col);
            }
            let step = solve_square(&full, &error).ok_or(CompensationError::Singular)?;
            for ((v, s), &(lo, hi)) in q.iter_mut().zip(step.iter()).zip(limits) {
                *v = (*v - s).clamp(lo, hi);
            }
            *actual = self.reached_from(data, q, actual, motion_base, options)?;
            error = pose_difference(&actual.x_base_tcp, target_base);
            iterations += 1;
        }
        Ok(Correction { error, iterations })
    }

    /// Compensates one target pose (base frame), starting the inverse model
    /// from `seed`. `motion_base` is the direction of travel (for friction).
    pub fn compensate_pose(
        &self,
        data: &mut CompensationData<E::Workspace>,
        target_base: &Isometry3<f64>,
        seed: &[f64],
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
    ) -> Result<CompensatedPoint, CompensationError> {
        self.compensate_pose_with(data, target_base, seed, motion_base, options)
            .map(|solved| solved.point)
    }

    /// [`compensate_pose`](Self::compensate_pose) with a caller's Jacobian
    /// store; also returns the deflection at the uncompensated command.
    pub(crate) fn compensate_pose_with(
        &self,
        data: &mut CompensationData<E::Workspace>,
        target_base: &Isometry3<f64>,
        seed: &[f64],
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
    ) -> Result<Solved, CompensationError> {
        let uncompensated = inverse_pose(
            self.model,
            &mut data.kinematics,
            target_base,
            seed,
            &self.xi,
            &options.inverse,
        )?;
        let inverse_error = full_pose_error(&uncompensated.pose, target_base, &options.inverse);
        let q0 = uncompensated.q;
        let actual0 = self.actual_from_geometric(
            &mut data.elastic,
            &mut data.process,
            &q0,
            uncompensated.pose,
            motion_base,
            options,
            None,
        )?;
        let uncompensated_error = pose_difference(&actual0.x_base_tcp, target_base);
        let deflection0 = actual0.deflection;
        let mut q = q0.clone();
        let mut actual = actual0;
        // The Jacobian is evaluated at this point's own command before use.
        data.jacobian.clear();
        let mut correction = self.correct_command(
            data,
            target_base,
            &mut q,
            &mut actual,
            motion_base,
            options,
            options.max_fixed_point_iterations,
        )?;
        let mut method = CompensationMethod::FixedPoint;
        if !converged(&correction.error, options) {
            method = CompensationMethod::Newton;
            let newton =
                self.newton_command(data, target_base, &mut q, &mut actual, motion_base, options)?;
            correction = Correction {
                error: newton.error,
                iterations: correction.iterations + newton.iterations,
            };
            if !converged(&correction.error, options) {
                return Err(CompensationError::NotConverged {
                    residual_m: correction.error.fixed_rows::<3>(0).norm(),
                    residual_rad: correction.error.fixed_rows::<3>(3).norm(),
                    iterations: correction.iterations,
                });
            }
        }
        Ok(Solved {
            point: CompensatedPoint {
                target_base: *target_base,
                q_uncompensated: q0,
                uncompensated_error,
                q_commanded: q,
                commanded_base: actual.x_base_geometric,
                residual: correction.error,
                wrench_base: actual.wrench_base,
                iterations: correction.iterations,
                method,
            },
            deflection_uncompensated: deflection0,
            deflection_commanded: actual.deflection,
            inverse_error,
        })
    }
}

/// A solved path point with what the tracker needs to predict the next.
pub(crate) struct Solved {
    pub(crate) point: CompensatedPoint,
    /// Deflection at the uncompensated command (m, rad).
    pub(crate) deflection_uncompensated: Vector6<f64>,
    /// Deflection at the compensated command (m, rad).
    pub(crate) deflection_commanded: Vector6<f64>,
    /// Geometric pose of the uncompensated command minus the target.
    pub(crate) inverse_error: Vector6<f64>,
}
