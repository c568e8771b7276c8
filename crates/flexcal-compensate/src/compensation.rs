//! The elasto-geometrical model (39)-(40) and the computation of commanded
//! poses ("fake poses") that bring the deflected robot onto a target path.
//!
//! # The model
//! For actuated coordinates `q`, the tool lands at
//! `S(q) = f(q, xi) (+) h(q, W)`: the geometric forward model followed by the
//! elastic TCP displacement `h = [dp; dphi]` under the wrench `W` on the tool.
//! `W` is the payload (a constant wrench in the base frame, e.g. the 920 N
//! dead weight of the paper's experiment) plus the process wrench, which
//! depends on where the tool actually is. The actual pose is therefore the
//! fixed point `S = f (+) h(q, W(S))`, found by fixed-point iteration (the
//! coupling `|dh/dS| = (process stiffness) x (robot compliance)` is small,
//! about 0.05 for the forming beam) with a Newton fallback on the position.
//!
//! # Compensation
//! Find `q` such that `S(q) = target`. Starting from the inverse geometric
//! model of the target (which gives the predicted uncompensated error), each
//! fixed-point step corrects the command by the remaining error through the
//! joint Jacobian: `q <- q - J(q)^-1 (S(q) (-) target)`. It converges
//! linearly at the rate of the neglected `dh/dq`; when it stalls, Newton on
//! the coupled system with the full Jacobian of `S(q)` (elastic and process
//! terms included, by central differences) takes over.
//!
//! # Paths
//! Along a path the solution moves continuously, so
//! [`ElastoGeometricModel::compensate_path`] predicts each point from the
//! last three (quadratic extrapolation along the path length of the
//! uncompensated command, of the correction and of the deflections) and
//! corrects the prediction with a stored joint Jacobian, to the same
//! tolerances. On a finely sampled path a point then costs one geometric and
//! one elastic evaluation for each of the uncompensated and the compensated
//! command, instead of an inverse-model solve and three or more of each.

use flexcal_kinematics::{
    Data, InverseOptions, InverseTarget, KinematicsError, Model, inverse_pose, joint_jacobian_into,
};
use nalgebra::{
    Isometry3, Matrix3, Matrix6xX, SVector, Translation3, UnitQuaternion, Vector3, Vector6,
};

use crate::path::PathPoint;
use crate::process::{ProcessError, ProcessModel, ToolState};

/// Error of an elastic model evaluation, as reported by its implementation.
pub type ElasticEvalError = Box<dyn std::error::Error + Send + Sync>;

/// An elastic model of a robot, seen from its TCP: the FE beam model, a
/// joint-compliance model or the fuzzy compliance model all implement it.
pub trait ElasticModel: Send + Sync {
    /// A short description for reports.
    fn describe(&self) -> String;

    /// Elastic displacement `[dp; dphi]` of the TCP (m, rad), in the robot
    /// base frame, for actuated coordinates `q` under the wrench
    /// `wrench_base` `[f; m]` (N, N.m) applied at the TCP and expressed in the
    /// base frame. Models that include the robot's own weight add its effect.
    fn tcp_displacement(
        &self,
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, ElasticEvalError>;
}

/// An elastic model with a configuration-independent compliance matrix
/// (6 x 6, SI units, base frame): a simple stand-in and a test fixture.
#[derive(Debug, Clone, PartialEq)]
pub struct ConstantCompliance {
    /// Compliance `C` such that `dS = C W` (m/N, rad/(N.m), ...).
    pub compliance: nalgebra::Matrix6<f64>,
}

impl ElasticModel for ConstantCompliance {
    fn describe(&self) -> String {
        "constant compliance".into()
    }

    fn tcp_displacement(
        &self,
        _q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, ElasticEvalError> {
        Ok(self.compliance * wrench_base)
    }
}

/// Errors of the elasto-geometrical model and of compensation.
#[derive(Debug, thiserror::Error)]
pub enum CompensationError {
    /// The geometric model failed (loop cannot close, wrong lengths...).
    #[error(transparent)]
    Kinematics(#[from] KinematicsError),
    /// The process model failed.
    #[error(transparent)]
    Process(#[from] ProcessError),
    /// The elastic model failed.
    #[error("elastic model: {0}")]
    Elastic(String),
    /// The robot and the process found no common equilibrium.
    #[error(
        "robot and process found no common equilibrium in {iterations} iterations (last change {last_change_m:.3e} m)"
    )]
    CouplingDiverged {
        /// Iterations spent.
        iterations: usize,
        /// Size of the last position change (m).
        last_change_m: f64,
    },
    /// The commanded pose iteration did not reach the tolerance.
    #[error(
        "compensation did not converge: residual {residual_m:.3e} m / {residual_rad:.3e} rad after {iterations} iterations"
    )]
    NotConverged {
        /// Remaining position error (m).
        residual_m: f64,
        /// Remaining orientation error (rad).
        residual_rad: f64,
        /// Iterations spent (fixed point and Newton).
        iterations: usize,
    },
    /// The joint Jacobian is singular at the commanded configuration.
    #[error("the robot is at a singular configuration: the correction cannot be solved")]
    Singular,
}

/// The robot's cell and load: where the part is and what the tool carries.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Pose of the part frame R_p in the robot base frame R_0.
    pub x_base_part: Isometry3<f64>,
    /// Constant wrench on the tool (payload, dead weight), base frame [N, N.m].
    pub payload_base: Vector6<f64>,
}

/// Settings of the solvers.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensationOptions {
    /// Position tolerance on the compensated pose (m) (default 1e-9).
    pub position_tolerance_m: f64,
    /// Orientation tolerance (rad) (default 1e-9).
    pub orientation_tolerance_rad: f64,
    /// Fixed-point iterations before Newton takes over (default 30).
    pub max_fixed_point_iterations: usize,
    /// Newton iterations (default 20).
    pub max_newton_iterations: usize,
    /// Iterations of the robot-process equilibrium (default 100).
    pub max_coupling_iterations: usize,
    /// Inverse-model settings for the uncompensated command.
    pub inverse: InverseOptions,
}

impl Default for CompensationOptions {
    fn default() -> Self {
        Self {
            position_tolerance_m: 1e-9,
            orientation_tolerance_rad: 1e-9,
            max_fixed_point_iterations: 30,
            max_newton_iterations: 20,
            max_coupling_iterations: 100,
            inverse: InverseOptions::default(),
        }
    }
}

/// The elasto-geometrical model of a robot in its cell: geometry (model and
/// identified parameters xi), elasticity, payload and process.
pub struct ElastoGeometricModel<'a> {
    /// Geometric model.
    pub model: &'a Model,
    /// Geometric parameters xi (SI).
    pub xi: Vec<f64>,
    /// Elastic model.
    pub elastic: &'a dyn ElasticModel,
    /// Process model (None: payload only).
    pub process: Option<&'a dyn ProcessModel>,
    /// Cell and payload.
    pub cell: Cell,
}

/// The pose the robot actually reaches for a command.
#[derive(Debug, Clone, PartialEq)]
pub struct ActualPose {
    /// Reached TCP pose in the base frame.
    pub x_base_tcp: Isometry3<f64>,
    /// Geometric (unloaded) TCP pose in the base frame.
    pub x_base_geometric: Isometry3<f64>,
    /// Total wrench on the tool at equilibrium, base frame [N, N.m].
    pub wrench_base: Vector6<f64>,
    /// Elastic displacement at equilibrium [m, rad].
    pub deflection: Vector6<f64>,
    /// Iterations of the robot-process equilibrium.
    pub coupling_iterations: usize,
}

/// Applies a small displacement `[dp; dphi]` to a pose: translation added,
/// rotation `exp([dphi]x) R`.
pub fn displace(x: &Isometry3<f64>, d: &Vector6<f64>) -> Isometry3<f64> {
    let dp = Vector3::new(d[0], d[1], d[2]);
    let dphi = Vector3::new(d[3], d[4], d[5]);
    Isometry3::from_parts(
        Translation3::from(x.translation.vector + dp),
        UnitQuaternion::from_scaled_axis(dphi) * x.rotation,
    )
}

/// Pose difference `[p_a - p_b; phi]` with `R_a = exp([phi]x) R_b`.
pub fn pose_difference(a: &Isometry3<f64>, b: &Isometry3<f64>) -> Vector6<f64> {
    let dp = a.translation.vector - b.translation.vector;
    let phi = (a.rotation * b.rotation.inverse()).scaled_axis();
    Vector6::new(dp.x, dp.y, dp.z, phi.x, phi.y, phi.z)
}

impl<'a> ElastoGeometricModel<'a> {
    /// The model with the robot's nominal geometric parameters.
    pub fn with_nominal_geometry(
        model: &'a Model,
        elastic: &'a dyn ElasticModel,
        process: Option<&'a dyn ProcessModel>,
        cell: Cell,
    ) -> Self {
        Self {
            model,
            xi: model.nominal_params().to_vec(),
            elastic,
            process,
            cell,
        }
    }
}

impl Cell {
    /// A cell whose part frame is the robot base frame, with a payload
    /// wrench (base frame, N and N.m).
    pub fn payload_only(payload_base: Vector6<f64>) -> Self {
        Self {
            x_base_part: Isometry3::identity(),
            payload_base,
        }
    }
}

impl ElastoGeometricModel<'_> {
    fn total_wrench(
        &self,
        tcp_base: &Vector3<f64>,
        motion_base: &Vector3<f64>,
    ) -> Result<Vector6<f64>, CompensationError> {
        let mut w = self.cell.payload_base;
        if let Some(process) = self.process {
            let x_part_base = self.cell.x_base_part.inverse();
            let tool = ToolState {
                position: x_part_base.transform_point(&(*tcp_base).into()).coords,
                motion: x_part_base.rotation * motion_base,
            };
            let wp = process.wrench_on_tool(&tool)?;
            let r = self.cell.x_base_part.rotation;
            let f = r * Vector3::new(wp[0], wp[1], wp[2]);
            let m = r * Vector3::new(wp[3], wp[4], wp[5]);
            w += Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z);
        }
        Ok(w)
    }

    fn deflection(
        &self,
        q: &[f64],
        wrench: &Vector6<f64>,
    ) -> Result<Vector6<f64>, CompensationError> {
        self.elastic
            .tcp_displacement(q, wrench)
            .map_err(|e| CompensationError::Elastic(e.to_string()))
    }

    /// The pose actually reached when commanding `q` (equation (39)/(40)),
    /// robot and process solved together. `motion_base` is the direction of
    /// travel of the tool (for friction; zero at rest).
    pub fn actual_pose(
        &self,
        data: &mut Data,
        q: &[f64],
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
    ) -> Result<ActualPose, CompensationError> {
        self.actual_pose_from_guess(data, q, motion_base, options, None)
    }

    /// [`actual_pose`](Self::actual_pose) with the robot-process equilibrium
    /// started from `deflection_guess` (m, rad) instead of the unloaded
    /// pose: along a path, or between the iterations of one compensation,
    /// the deflection barely changes, so a close guess saves most of the
    /// coupling iterations. The result does not depend on the guess beyond
    /// the coupling tolerance.
    pub fn actual_pose_from_guess(
        &self,
        data: &mut Data,
        q: &[f64],
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        deflection_guess: Option<&Vector6<f64>>,
    ) -> Result<ActualPose, CompensationError> {
        let geometric = flexcal_kinematics::forward_pose(self.model, data, q, &self.xi)?;
        self.actual_from_geometric(q, geometric, motion_base, options, deflection_guess)
    }

    fn actual_from_geometric(
        &self,
        q: &[f64],
        geometric: Isometry3<f64>,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        deflection_guess: Option<&Vector6<f64>>,
    ) -> Result<ActualPose, CompensationError> {
        let p0 = geometric.translation.vector;
        // g(p) = position reached when the process sees the tool at p.
        let reached =
            |p: &Vector3<f64>| -> Result<(Vector6<f64>, Vector6<f64>), CompensationError> {
                let w = self.total_wrench(p, motion_base)?;
                let d = self.deflection(q, &w)?;
                Ok((w, d))
            };
        let tolerance = options.position_tolerance_m * 1e-2;
        // Without a process the wrench does not depend on the pose: one
        // evaluation is the equilibrium, whatever the guess.
        let start = match (self.process, deflection_guess) {
            (Some(_), Some(g)) if g.iter().all(|v| v.is_finite()) => p0 + g.fixed_rows::<3>(0),
            _ => p0,
        };
        let (mut w, mut d) = reached(&start)?;
        let mut p = p0 + d.fixed_rows::<3>(0);
        let mut iterations = 1;
        let mut last_change = f64::INFINITY;
        // A guessed start is itself an iterate: the first evaluation already
        // measures how far the guess was from its image.
        let guessed = start != p0;
        if guessed {
            last_change = (p - start).norm();
        }
        if self.process.is_some() && !(guessed && last_change <= tolerance) {
            let mut converged = false;
            while iterations < options.max_coupling_iterations {
                let (w_new, d_new) = reached(&p)?;
                let p_new = p0 + d_new.fixed_rows::<3>(0);
                last_change = (p_new - p).norm();
                w = w_new;
                d = d_new;
                p = p_new;
                iterations += 1;
                if last_change <= tolerance {
                    converged = true;
                    break;
                }
                if iterations > 8 && !last_change.is_finite() {
                    break;
                }
            }
            if !converged {
                // Newton on r(p) = p - p0 - dp(W(p)) with a central-difference Jacobian.
                p = p0 + d.fixed_rows::<3>(0);
                for _ in 0..options.max_newton_iterations {
                    let r = |p: &Vector3<f64>| -> Result<Vector3<f64>, CompensationError> {
                        let (_, d) = reached(p)?;
                        Ok(p - p0 - d.fixed_rows::<3>(0))
                    };
                    let r0 = r(&p)?;
                    if r0.norm() <= tolerance {
                        let (w_n, d_n) = reached(&p)?;
                        w = w_n;
                        d = d_n;
                        converged = true;
                        break;
                    }
                    let mut jac = Matrix3::zeros();
                    let h = 1e-7;
                    for j in 0..3 {
                        let mut pp = p;
                        let mut pm = p;
                        pp[j] += h;
                        pm[j] -= h;
                        let col = (r(&pp)? - r(&pm)?) / (2.0 * h);
                        jac.set_column(j, &col);
                    }
                    let step = jac.lu().solve(&(-r0)).ok_or(CompensationError::Singular)?;
                    last_change = step.norm();
                    p += step;
                    iterations += 1;
                }
                if !converged {
                    return Err(CompensationError::CouplingDiverged {
                        iterations,
                        last_change_m: last_change,
                    });
                }
            }
        }
        Ok(ActualPose {
            x_base_tcp: displace(&geometric, &d),
            x_base_geometric: geometric,
            wrench_base: w,
            deflection: d,
            coupling_iterations: iterations,
        })
    }
}

/// How the commanded pose of a point was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
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
    pub method: Method,
}

/// Outcome of one path point: its 1-based line in the path file and the
/// result or the reason it failed.
#[derive(Debug)]
pub struct PointOutcome {
    /// Line of the point in its file (0 for points built in memory).
    pub line: usize,
    /// The result.
    pub result: Result<CompensatedPoint, CompensationError>,
}

fn converged(e: &Vector6<f64>, options: &CompensationOptions) -> bool {
    e.fixed_rows::<3>(0).norm() <= options.position_tolerance_m
        && e.fixed_rows::<3>(3).norm() <= options.orientation_tolerance_rad
}

fn inverse_converged(e: &Vector6<f64>, options: &InverseOptions) -> bool {
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
fn full_pose_error(
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

/// A step whose error shrinks by less than this factor marks the stored
/// joint Jacobian as too far from the current configuration: it is
/// recomputed there. A fresh Jacobian contracts by the ratio of the neglected
/// elastic term (about 1e-3 for the paper's robot), a Jacobian stored a few
/// millimetres of path earlier by about 1e-2, so a factorisation is reused
/// over many iterations and path points.
const JACOBIAN_REFRESH_RATIO: f64 = 0.1;

/// The joint Jacobian at some recent configuration, factored once and
/// reused for the correction steps: the corrections converge at the rate of
/// the Jacobian's error, so a slightly stale one costs little and saves a
/// Jacobian evaluation and a factorisation per step.
enum JacobianFactor {
    /// No Jacobian yet.
    Empty,
    /// Six actuated coordinates: LU of the square Jacobian.
    Square(Box<nalgebra::LU<f64, nalgebra::U6, nalgebra::U6>>),
    /// Redundant or deficient robots: least squares by SVD.
    LeastSquares(Box<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>>),
}

struct JacobianCache {
    jacobian: Matrix6xX<f64>,
    factor: JacobianFactor,
    step: Vec<f64>,
}

impl JacobianCache {
    fn new(n_actuated: usize) -> Self {
        Self {
            jacobian: Matrix6xX::zeros(n_actuated),
            factor: JacobianFactor::Empty,
            step: vec![0.0; n_actuated],
        }
    }

    fn is_empty(&self) -> bool {
        matches!(self.factor, JacobianFactor::Empty)
    }

    /// Evaluates and factors the Jacobian at `q`; returns the geometric pose.
    fn refresh(
        &mut self,
        model: &Model,
        data: &mut Data,
        q: &[f64],
        xi: &[f64],
    ) -> Result<Isometry3<f64>, CompensationError> {
        let pose = joint_jacobian_into(model, data, q, xi, &mut self.jacobian)?;
        self.factor = if self.jacobian.ncols() == 6 {
            let m: nalgebra::Matrix6<f64> = self.jacobian.fixed_columns::<6>(0).into_owned();
            JacobianFactor::Square(Box::new(m.lu()))
        } else {
            let dj = nalgebra::DMatrix::from_column_slice(
                6,
                self.jacobian.ncols(),
                self.jacobian.as_slice(),
            );
            JacobianFactor::LeastSquares(Box::new(dj.svd(true, true)))
        };
        Ok(pose)
    }

    /// `q <- clamp(q - J^-1 error)`.
    fn correct(
        &mut self,
        q: &mut [f64],
        error: &Vector6<f64>,
        limits: &[(f64, f64)],
    ) -> Result<(), CompensationError> {
        match &self.factor {
            JacobianFactor::Empty => return Err(CompensationError::Singular),
            JacobianFactor::Square(lu) => {
                let step = lu.solve(error).ok_or(CompensationError::Singular)?;
                self.step.copy_from_slice(step.as_slice());
            }
            JacobianFactor::LeastSquares(svd) => {
                let rhs = nalgebra::DVector::from_column_slice(error.as_slice());
                let step = svd
                    .solve(&rhs, 1e-12)
                    .map_err(|_| CompensationError::Singular)?;
                self.step.copy_from_slice(step.as_slice());
            }
        }
        for ((v, s), &(lo, hi)) in q.iter_mut().zip(&self.step).zip(limits) {
            *v = (*v - s).clamp(lo, hi);
        }
        Ok(())
    }
}

/// How a correction loop ended.
struct Correction {
    error: Vector6<f64>,
    iterations: usize,
}

impl ElastoGeometricModel<'_> {
    /// Fixed-point correction of the command `q` (whose reached pose is
    /// `actual`) until it reaches `target_base`: `q <- q - J^-1 (S(q) (-)
    /// target)`, the Jacobian reused while it contracts the error well.
    /// Stops when converged, after `max_iterations`, or when the error
    /// stalls (the caller then hands over to Newton).
    #[allow(clippy::too_many_arguments)]
    fn correct_command(
        &self,
        data: &mut Data,
        target_base: &Isometry3<f64>,
        q: &mut [f64],
        actual: &mut ActualPose,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        jacobian: &mut JacobianCache,
        max_iterations: usize,
    ) -> Result<Correction, CompensationError> {
        let limits = self.model.actuated_limits();
        let mut error = pose_difference(&actual.x_base_tcp, target_base);
        let mut iterations = 0;
        let mut previous = f64::INFINITY;
        let mut refreshed_here = false;
        while !converged(&error, options) && iterations < max_iterations {
            let size = error.norm();
            if jacobian.is_empty() || (size > JACOBIAN_REFRESH_RATIO * previous && !refreshed_here)
            {
                jacobian.refresh(self.model, data, q, &self.xi)?;
                refreshed_here = true;
            } else {
                refreshed_here = false;
            }
            jacobian.correct(q, &error, limits)?;
            *actual = self.actual_pose_from_guess(
                data,
                q,
                motion_base,
                options,
                Some(&actual.deflection),
            )?;
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
        data: &mut Data,
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
                let sp = self.actual_pose_from_guess(
                    data,
                    &perturbed,
                    motion_base,
                    options,
                    Some(&actual.deflection),
                )?;
                perturbed[j] -= 2.0 * h;
                let sm = self.actual_pose_from_guess(
                    data,
                    &perturbed,
                    motion_base,
                    options,
                    Some(&actual.deflection),
                )?;
                let col = pose_difference(&sp.x_base_tcp, &sm.x_base_tcp) / (2.0 * h);
                full.set_column(j, &col);
            }
            let step = solve_square(&full, &error).ok_or(CompensationError::Singular)?;
            for ((v, s), &(lo, hi)) in q.iter_mut().zip(step.iter()).zip(limits) {
                *v = (*v - s).clamp(lo, hi);
            }
            *actual = self.actual_pose_from_guess(
                data,
                q,
                motion_base,
                options,
                Some(&actual.deflection),
            )?;
            error = pose_difference(&actual.x_base_tcp, target_base);
            iterations += 1;
        }
        Ok(Correction { error, iterations })
    }

    /// Compensates one target pose (base frame), starting the inverse model
    /// from `seed`. `motion_base` is the direction of travel (for friction).
    pub fn compensate_pose(
        &self,
        data: &mut Data,
        target_base: &Isometry3<f64>,
        seed: &[f64],
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
    ) -> Result<CompensatedPoint, CompensationError> {
        let mut jacobian = JacobianCache::new(self.model.n_actuated());
        self.compensate_pose_with(data, target_base, seed, motion_base, options, &mut jacobian)
            .map(|solved| solved.point)
    }

    /// [`compensate_pose`](Self::compensate_pose) with a caller's Jacobian
    /// store; also returns the deflection at the uncompensated command.
    fn compensate_pose_with(
        &self,
        data: &mut Data,
        target_base: &Isometry3<f64>,
        seed: &[f64],
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        jacobian: &mut JacobianCache,
    ) -> Result<Solved, CompensationError> {
        let uncompensated = inverse_pose(
            self.model,
            data,
            target_base,
            seed,
            &self.xi,
            &options.inverse,
        )?;
        let inverse_error = full_pose_error(&uncompensated.pose, target_base, &options.inverse);
        let q0 = uncompensated.q;
        let actual0 =
            self.actual_from_geometric(&q0, uncompensated.pose, motion_base, options, None)?;
        let uncompensated_error = pose_difference(&actual0.x_base_tcp, target_base);
        let deflection0 = actual0.deflection;
        let mut q = q0.clone();
        let mut actual = actual0;
        // The Jacobian is evaluated at this point's own command before use.
        jacobian.factor = JacobianFactor::Empty;
        let mut correction = self.correct_command(
            data,
            target_base,
            &mut q,
            &mut actual,
            motion_base,
            options,
            jacobian,
            options.max_fixed_point_iterations,
        )?;
        let mut method = Method::FixedPoint;
        if !converged(&correction.error, options) {
            method = Method::Newton;
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

    /// Compensates a whole path given in the part frame. Each point starts
    /// from the previous point's command (so the path stays on one branch);
    /// the first from `seed`. Every point is reported, failed ones with their
    /// reason, so a caller can list all bad points at once.
    ///
    /// Paths are continuous, so each point is first predicted from the last
    /// points (commands, correction and deflections extrapolated along the
    /// path length) and then corrected: Newton steps on the inverse
    /// geometric model and fixed-point steps on the command, both with a
    /// stored joint Jacobian, until the same tolerances as
    /// [`compensate_pose`](Self::compensate_pose) are met. On a finely
    /// sampled path the prediction usually meets them at once, so a point
    /// costs one geometric and one elastic evaluation for the uncompensated
    /// command and as many for the compensated one. A point whose
    /// prediction does not converge quickly (a corner, a jump) is solved
    /// from scratch by [`compensate_pose`](Self::compensate_pose); the
    /// results agree within the tolerances.
    pub fn compensate_path(
        &self,
        data: &mut Data,
        path: &[PathPoint],
        seed: &[f64],
        options: &CompensationOptions,
    ) -> Vec<PointOutcome> {
        let mut seed = seed.to_vec();
        let targets: Vec<Isometry3<f64>> = path
            .iter()
            .map(|p| self.cell.x_base_part * p.x_part_tcp)
            .collect();
        let mut tracker = PathTracker::new(self.model.n_actuated());
        let mut length = 0.0;
        let mut outcomes = Vec::with_capacity(path.len());
        for (i, (point, target)) in path.iter().zip(&targets).enumerate() {
            let next = targets
                .get(i + 1)
                .or_else(|| i.checked_sub(1).map(|j| &targets[j]));
            let motion = match next {
                Some(n) if i + 1 < targets.len() => {
                    n.translation.vector - target.translation.vector
                }
                Some(p) => target.translation.vector - p.translation.vector,
                None => Vector3::zeros(),
            };
            if i > 0 {
                length += path_distance(&targets[i - 1], target);
            }
            let tracked = if tracker.samples.is_empty() {
                None
            } else {
                self.compensate_tracked(data, target, length, &motion, options, &mut tracker)
                    .ok()
                    .flatten()
            };
            let result = match tracked {
                Some(found) => Ok(found),
                None => self.compensate_pose_with(
                    data,
                    target,
                    &seed,
                    &motion,
                    options,
                    &mut tracker.jacobian,
                ),
            };
            let result = match result {
                Ok(solved) => {
                    seed.clone_from(&solved.point.q_commanded);
                    tracker.push(length, &solved);
                    Ok(solved.point)
                }
                Err(e) => {
                    tracker.samples.clear();
                    Err(e)
                }
            };
            outcomes.push(PointOutcome {
                line: point.line,
                result,
            });
        }
        outcomes
    }

    /// One path point predicted from the tracker's samples and corrected.
    /// `Ok(None)` when the prediction does not converge in a few steps.
    fn compensate_tracked(
        &self,
        data: &mut Data,
        target_base: &Isometry3<f64>,
        length: f64,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        tracker: &mut PathTracker,
    ) -> Result<Option<Solved>, CompensationError> {
        let model = self.model;
        let limits = model.actuated_limits();
        let weights = tracker.weights(length);
        // Uncompensated command: Newton on the inverse geometric model from
        // the extrapolated command.
        let mut q0 = tracker.extrapolate(&weights, |s| &s.q_uncompensated);
        for (v, &(lo, hi)) in q0.iter_mut().zip(limits) {
            *v = v.clamp(lo, hi);
        }
        let mut inverse_error = Vector6::zeros();
        let pose0 = if options.inverse.target == InverseTarget::Pose {
            let mut found = None;
            let mut previous = f64::INFINITY;
            let mut refreshed_here = false;
            for step in 0..=MAX_TRACKING_STEPS {
                let pose = flexcal_kinematics::forward_pose(model, data, &q0, &self.xi)?;
                let error = pose_difference(&pose, target_base);
                if inverse_converged(&error, &options.inverse) {
                    inverse_error = error;
                    found = Some(pose);
                    break;
                }
                if step == MAX_TRACKING_STEPS {
                    break;
                }
                let size = error.norm();
                if tracker.jacobian.is_empty()
                    || (size > JACOBIAN_REFRESH_RATIO * previous && !refreshed_here)
                {
                    tracker.jacobian.refresh(model, data, &q0, &self.xi)?;
                    refreshed_here = true;
                } else {
                    refreshed_here = false;
                }
                tracker.jacobian.correct(&mut q0, &error, limits)?;
                previous = size;
            }
            match found {
                Some(pose) => pose,
                None => return Ok(None),
            }
        } else {
            // Other targets leave freedoms to the inverse model's own solver.
            let solution = inverse_pose(model, data, target_base, &q0, &self.xi, &options.inverse)?;
            q0 = solution.q;
            solution.pose
        };
        let guess0 = tracker.extrapolate_vector(&weights, |s| &s.deflection_uncompensated);
        let actual0 =
            self.actual_from_geometric(&q0, pose0, motion_base, options, Some(&guess0))?;
        let uncompensated_error = pose_difference(&actual0.x_base_tcp, target_base);
        let deflection0 = actual0.deflection;
        // Compensated command: the extrapolated correction added to this
        // point's uncompensated command (the correction varies more slowly
        // than the command itself).
        let correction = tracker.extrapolate_correction(&weights);
        let mut q = q0.clone();
        for ((v, c), &(lo, hi)) in q.iter_mut().zip(&correction).zip(limits) {
            *v = (*v + c).clamp(lo, hi);
        }
        let mut actual = if q == q0 {
            actual0
        } else {
            let guess = tracker.extrapolate_vector(&weights, |s| &s.deflection_commanded);
            self.actual_pose_from_guess(data, &q, motion_base, options, Some(&guess))?
        };
        let result = self.correct_command(
            data,
            target_base,
            &mut q,
            &mut actual,
            motion_base,
            options,
            &mut tracker.jacobian,
            MAX_TRACKING_STEPS,
        )?;
        if !converged(&result.error, options) {
            return Ok(None);
        }
        Ok(Some(Solved {
            point: CompensatedPoint {
                target_base: *target_base,
                q_uncompensated: q0,
                uncompensated_error,
                q_commanded: q,
                commanded_base: actual.x_base_geometric,
                residual: result.error,
                wrench_base: actual.wrench_base,
                iterations: result.iterations,
                method: Method::FixedPoint,
            },
            deflection_uncompensated: deflection0,
            deflection_commanded: actual.deflection,
            inverse_error,
        }))
    }
}

/// A solved path point with what the tracker needs to predict the next.
struct Solved {
    point: CompensatedPoint,
    /// Deflection at the uncompensated command (m, rad).
    deflection_uncompensated: Vector6<f64>,
    /// Deflection at the compensated command (m, rad).
    deflection_commanded: Vector6<f64>,
    /// Geometric pose of the uncompensated command minus the target.
    inverse_error: Vector6<f64>,
}

/// Correction steps allowed to a predicted path point before it is solved
/// from scratch.
const MAX_TRACKING_STEPS: usize = 6;

/// Distance between two poses along a path: position change (m) plus
/// rotation (rad) counted as 1 m per radian. Only ratios of such distances
/// are used (to place the points for extrapolation), so the weighting of
/// rotation merely needs to be of the robot's size.
fn path_distance(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
    let d = pose_difference(a, b);
    d.fixed_rows::<3>(0).norm() + d.fixed_rows::<3>(3).norm()
}

/// The last solved points of a path, for prediction.
struct TrackSample {
    length: f64,
    q_uncompensated: Vec<f64>,
    q_commanded: Vec<f64>,
    deflection_uncompensated: Vector6<f64>,
    deflection_commanded: Vector6<f64>,
}

/// Path-following state of [`ElastoGeometricModel::compensate_path`]: the
/// last three solved points (quadratic extrapolation: its error is of the
/// third order in the point spacing) and the stored joint Jacobian.
struct PathTracker {
    samples: std::collections::VecDeque<TrackSample>,
    jacobian: JacobianCache,
}

impl PathTracker {
    fn new(n_actuated: usize) -> Self {
        Self {
            samples: std::collections::VecDeque::with_capacity(3),
            jacobian: JacobianCache::new(n_actuated),
        }
    }

    /// Stores a solved point. Its commands met the tolerances but may sit
    /// anywhere within them, and extrapolation amplifies such scatter (up
    /// to 7 times for three points), which would make the next prediction
    /// miss the tolerance it has to meet. So the stored commands are first
    /// polished by one step on their known remaining errors with the stored
    /// Jacobian: linear algebra only, no model evaluation.
    fn push(&mut self, length: f64, solved: &Solved) {
        let mut sample = if self.samples.len() == 3 {
            self.samples.pop_front()
        } else {
            None
        }
        .unwrap_or_else(|| TrackSample {
            length,
            q_uncompensated: Vec::new(),
            q_commanded: Vec::new(),
            deflection_uncompensated: Vector6::zeros(),
            deflection_commanded: Vector6::zeros(),
        });
        let point = &solved.point;
        sample.length = length;
        sample.q_uncompensated.clone_from(&point.q_uncompensated);
        sample.q_commanded.clone_from(&point.q_commanded);
        sample.deflection_uncompensated = solved.deflection_uncompensated;
        sample.deflection_commanded = solved.deflection_commanded;
        if !self.jacobian.is_empty() {
            // Polishing is an improvement only: a failed solve keeps the
            // commands as they are.
            let unlimited = vec![(f64::NEG_INFINITY, f64::INFINITY); point.q_commanded.len()];
            let _ = self.jacobian.correct(
                &mut sample.q_uncompensated,
                &solved.inverse_error,
                &unlimited,
            );
            let _ = self
                .jacobian
                .correct(&mut sample.q_commanded, &point.residual, &unlimited);
        }
        self.samples.push_back(sample);
    }

    /// Lagrange weights of the stored samples (oldest first) for the path
    /// length `length`. Fewer samples are used when they would extrapolate
    /// too far (a jump in the path) or when two share a length.
    fn weights(&self, length: f64) -> Vec<f64> {
        let n = self.samples.len();
        let mut used = n;
        while used > 1 {
            let nodes: Vec<f64> = self
                .samples
                .iter()
                .skip(n - used)
                .map(|s| s.length)
                .collect();
            let increasing = nodes.windows(2).all(|w| w[1] > w[0]);
            let span = nodes[used - 1] - nodes[0];
            let ahead = length - nodes[used - 1];
            if increasing && ahead >= 0.0 && ahead <= 1.5 * span {
                break;
            }
            used -= 1;
        }
        let nodes: Vec<f64> = self
            .samples
            .iter()
            .skip(n - used)
            .map(|s| s.length)
            .collect();
        let mut weights = vec![0.0; n - used];
        for (i, &xi) in nodes.iter().enumerate() {
            let mut w = 1.0;
            for (j, &xj) in nodes.iter().enumerate() {
                if i != j {
                    w *= (length - xj) / (xi - xj);
                }
            }
            weights.push(w);
        }
        weights
    }

    fn extrapolate(&self, weights: &[f64], field: impl Fn(&TrackSample) -> &Vec<f64>) -> Vec<f64> {
        let mut out = vec![0.0; self.jacobian.step.len()];
        for (s, &w) in self.samples.iter().zip(weights) {
            if w != 0.0 {
                for (o, v) in out.iter_mut().zip(field(s)) {
                    *o += w * v;
                }
            }
        }
        out
    }

    fn extrapolate_vector(
        &self,
        weights: &[f64],
        field: impl Fn(&TrackSample) -> &Vector6<f64>,
    ) -> Vector6<f64> {
        self.samples
            .iter()
            .zip(weights)
            .fold(Vector6::zeros(), |acc, (s, &w)| acc + field(s) * w)
    }

    fn extrapolate_correction(&self, weights: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.jacobian.step.len()];
        for (s, &w) in self.samples.iter().zip(weights) {
            if w != 0.0 {
                for ((o, c), u) in out.iter_mut().zip(&s.q_commanded).zip(&s.q_uncompensated) {
                    *o += w * (c - u);
                }
            }
        }
        out
    }
}

/// Size of the position part of an error vector (m).
pub fn position_norm(e: &SVector<f64, 6>) -> f64 {
    e.fixed_rows::<3>(0).norm()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::process::{BeamTheory, CantileverBeam, ConstantWrench};
    use flexcal_kinematics::RobotDescription;
    use nalgebra::Matrix6;

    fn compliance() -> ConstantCompliance {
        // ~1.5e-3 mm/N in translation, like the paper's robot, slightly coupled.
        let mut c = Matrix6::from_diagonal(&Vector6::new(1.5e-6, 1.2e-6, 1.5e-6, 2e-7, 2e-7, 2e-7));
        c[(0, 2)] = 3e-7;
        c[(2, 0)] = 3e-7;
        ConstantCompliance { compliance: c }
    }

    /// The UR10 of these tests and the compliance above.
    struct Ur10 {
        model: Model,
        elastic: ConstantCompliance,
    }

    impl Ur10 {
        fn new() -> Self {
            Self {
                model: RobotDescription::builtin("ur10").unwrap().build().unwrap(),
                elastic: compliance(),
            }
        }

        /// Its elasto-geometric model: nominal geometry, `process`, `cell`.
        fn egm<'a>(
            &'a self,
            process: Option<&'a dyn ProcessModel>,
            cell: Cell,
        ) -> ElastoGeometricModel<'a> {
            ElastoGeometricModel::with_nominal_geometry(&self.model, &self.elastic, process, cell)
        }
    }

    fn tool_down_at(p: Vector3<f64>) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(p),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
        )
    }

    /// The part frame of the path tests, with a payload (N, N.m in R0).
    fn part_cell(payload_base: Vector6<f64>) -> Cell {
        Cell {
            x_base_part: Isometry3::translation(0.3, 0.25, 0.2),
            payload_base,
        }
    }

    /// A configuration near the targets of these tests (elbow up, tool down).
    const SEED: [f64; 6] = [0.3, -1.2, 1.5, -1.9, -1.57, 0.0];

    fn compensate_at_rest(
        egm: &ElastoGeometricModel<'_>,
        data: &mut Data,
        target: &Isometry3<f64>,
    ) -> CompensatedPoint {
        egm.compensate_pose(data, target, &SEED, &Vector3::zeros(), &Default::default())
            .unwrap()
    }

    #[test]
    fn zero_load_compensation_is_the_inverse_model() {
        let ur10 = Ur10::new();
        let mut data = Data::new(&ur10.model);
        let egm = ur10.egm(None, Cell::payload_only(Vector6::zeros()));
        let target = tool_down_at(Vector3::new(0.6, 0.3, 0.4));
        let c = compensate_at_rest(&egm, &mut data, &target);
        assert_eq!(c.iterations, 0);
        assert_eq!(c.q_commanded, c.q_uncompensated);
        assert!(position_norm(&c.uncompensated_error) < 1e-9);
    }

    #[test]
    fn payload_is_compensated_to_solver_tolerance() {
        let ur10 = Ur10::new();
        let mut data = Data::new(&ur10.model);
        let egm = ur10.egm(
            None,
            Cell::payload_only(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
        );
        let target = tool_down_at(Vector3::new(0.6, 0.3, 0.4));
        let c = compensate_at_rest(&egm, &mut data, &target);
        // Uncompensated: 920 N x 1.5e-3 mm/N ~ 1.4 mm down.
        assert!((c.uncompensated_error[2] + 920.0 * 1.5e-6).abs() < 1e-9);
        assert!(position_norm(&c.residual) <= 1e-9);
        // The fake pose sits above the target by the deflection.
        let lift = c.commanded_base.translation.vector.z - target.translation.vector.z;
        assert!((lift - 920.0 * 1.5e-6).abs() < 1e-6, "{lift}");
    }

    #[test]
    fn forming_beam_and_robot_are_solved_together() {
        let ur10 = Ur10::new();
        let mut data = Data::new(&ur10.model);
        let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
        // Beam along base x, clamp at x = 0.3, top surface at z = 0.2.
        let x_base_part = Isometry3::translation(0.3, 0.25, 0.2);
        let egm = ur10.egm(
            Some(&beam),
            Cell {
                x_base_part,
                payload_base: Vector6::zeros(),
            },
        );
        let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
        let path: Vec<PathPoint> = (0..5)
            .map(|i| PathPoint {
                line: i + 2,
                x_part_tcp: Isometry3::from_parts(
                    Translation3::new(0.58 - 0.05 * i as f64, 0.0, -0.025),
                    down,
                ),
            })
            .collect();
        let outcomes = egm.compensate_path(&mut data, &path, &SEED, &Default::default());
        let mut previous_error = 0.0;
        for o in &outcomes {
            let c = o.result.as_ref().unwrap();
            // The beam pushes the tool up: the uncompensated tool sits above
            // the target, by more as the tool nears the clamp (stiffer beam).
            assert!(c.uncompensated_error[2] > 0.0);
            assert!(c.uncompensated_error[2] > previous_error);
            previous_error = c.uncompensated_error[2];
            assert!(position_norm(&c.residual) <= 1e-9);
            // At equilibrium the wrench equals the beam's reaction at the reached point.
            let reached = displace(
                &c.commanded_base,
                &ur10
                    .elastic
                    .tcp_displacement(&c.q_commanded, &c.wrench_base)
                    .unwrap(),
            );
            let in_part = x_base_part.inverse() * reached;
            let w = beam
                .wrench_on_tool(&ToolState::at(in_part.translation.vector))
                .unwrap();
            assert!((w[2] - c.wrench_base[2]).abs() < 1e-3 * w[2].abs());
        }
    }

    #[test]
    fn unreachable_points_are_reported_per_point() {
        let ur10 = Ur10::new();
        let mut data = Data::new(&ur10.model);
        let constant = ConstantWrench {
            wrench: Vector6::new(0.0, 0.0, 100.0, 0.0, 0.0, 0.0),
        };
        let egm = ur10.egm(Some(&constant), Cell::payload_only(Vector6::zeros()));
        let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
        let path = vec![
            PathPoint {
                line: 2,
                x_part_tcp: Isometry3::from_parts(Translation3::new(0.6, 0.3, 0.4), down),
            },
            PathPoint {
                line: 3,
                x_part_tcp: Isometry3::from_parts(Translation3::new(4.0, 0.0, 0.0), down),
            },
        ];
        let outcomes = egm.compensate_path(&mut data, &path, &SEED, &Default::default());
        assert!(outcomes[0].result.is_ok());
        let err = outcomes[1].result.as_ref().unwrap_err();
        assert_eq!(outcomes[1].line, 3);
        assert!(
            matches!(
                err,
                CompensationError::Kinematics(KinematicsError::Unreachable { .. })
            ),
            "{err}"
        );
    }

    /// An elastic model that counts its evaluations.
    struct Counting<'a> {
        inner: &'a dyn ElasticModel,
        calls: std::sync::atomic::AtomicUsize,
    }

    impl ElasticModel for Counting<'_> {
        fn describe(&self) -> String {
            self.inner.describe()
        }

        fn tcp_displacement(
            &self,
            q: &[f64],
            wrench_base: &Vector6<f64>,
        ) -> Result<Vector6<f64>, ElasticEvalError> {
            self.calls
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.inner.tcp_displacement(q, wrench_base)
        }
    }

    /// A finely sampled straight travel along base -x, tool down, in the
    /// part frame of `forming_beam_and_robot_are_solved_together`.
    fn fine_travel(points: usize) -> Vec<PathPoint> {
        let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
        (0..points)
            .map(|i| PathPoint {
                line: i + 2,
                x_part_tcp: Isometry3::from_parts(
                    Translation3::new(0.58 - 0.2 * i as f64 / (points - 1) as f64, 0.0, -0.025),
                    down,
                ),
            })
            .collect()
    }

    /// Compensates every point on its own, seeded by the previous point's
    /// command: the reference the path tracker must reproduce.
    fn cold_path(
        egm: &ElastoGeometricModel<'_>,
        data: &mut Data,
        path: &[PathPoint],
    ) -> Vec<CompensatedPoint> {
        let mut seed = SEED.to_vec();
        let targets: Vec<Isometry3<f64>> = path
            .iter()
            .map(|p| egm.cell.x_base_part * p.x_part_tcp)
            .collect();
        let mut out = Vec::new();
        for (i, target) in targets.iter().enumerate() {
            let motion = if i + 1 < targets.len() {
                targets[i + 1].translation.vector - target.translation.vector
            } else {
                target.translation.vector - targets[i - 1].translation.vector
            };
            let c = egm
                .compensate_pose(data, target, &seed, &motion, &Default::default())
                .unwrap();
            seed.clone_from(&c.q_commanded);
            out.push(c);
        }
        out
    }

    fn assert_tracked_equals_cold(with_beam: bool) {
        let ur10 = Ur10::new();
        let mut data = Data::new(&ur10.model);
        let elastic = Counting {
            inner: &ur10.elastic,
            calls: 0.into(),
        };
        let beam = CantileverBeam::reference(BeamTheory::SmallDeflection);
        // The counting wrapper, not the plain compliance.
        let egm = ElastoGeometricModel::with_nominal_geometry(
            &ur10.model,
            &elastic,
            with_beam.then_some(&beam as &dyn ProcessModel),
            part_cell(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
        );
        let points = 1000;
        let path = fine_travel(points);
        let cold = cold_path(&egm, &mut data, &path);
        let cold_calls = elastic.calls.swap(0, std::sync::atomic::Ordering::Relaxed);
        let tracked = egm.compensate_path(&mut data, &path, &SEED, &Default::default());
        let tracked_calls = elastic.calls.load(std::sync::atomic::Ordering::Relaxed);
        let options = CompensationOptions::default();
        for (t, c) in tracked.iter().zip(&cold) {
            let t = t.result.as_ref().unwrap();
            // Both meet the tolerances on the same branch...
            assert!(converged(&t.residual, &options), "{:?}", t.residual);
            // ...so commands agree to the tolerance over the Jacobian's
            // smallest gain, and predicted errors to the tolerance.
            for (a, b) in t.q_commanded.iter().zip(&c.q_commanded) {
                assert!((a - b).abs() < 1e-7, "{a} vs {b}");
            }
            for (a, b) in t.q_uncompensated.iter().zip(&c.q_uncompensated) {
                assert!((a - b).abs() < 1e-8, "{a} vs {b}");
            }
            assert!((t.uncompensated_error - c.uncompensated_error).norm() < 1e-9);
            assert!((t.wrench_base - c.wrench_base).norm() < 1e-3);
        }
        // The tracker is what makes paths cheap: it must cut the elastic
        // evaluations (two per point once it runs, one for the uncompensated
        // and one for the compensated command, plus the coupling's extra
        // evaluations with the beam; a point solved from scratch needs at
        // least three, with the beam over twenty).
        let per_point = if with_beam { 3 } else { 2 };
        assert!(
            tracked_calls <= per_point * points + 20,
            "tracked {tracked_calls}, cold {cold_calls}"
        );
        assert!(
            tracked_calls < cold_calls,
            "tracked {tracked_calls}, cold {cold_calls}"
        );
    }

    #[test]
    fn tracked_path_equals_points_solved_from_scratch_under_payload() {
        assert_tracked_equals_cold(false);
    }

    #[test]
    fn tracked_path_equals_points_solved_from_scratch_with_the_beam() {
        assert_tracked_equals_cold(true);
    }

    #[test]
    fn tracked_path_without_load_is_the_inverse_model() {
        let ur10 = Ur10::new();
        let mut data = Data::new(&ur10.model);
        let egm = ur10.egm(None, part_cell(Vector6::zeros()));
        let outcomes = egm.compensate_path(&mut data, &fine_travel(50), &SEED, &Default::default());
        for o in &outcomes {
            let c = o.result.as_ref().unwrap();
            assert_eq!(c.iterations, 0);
            assert_eq!(c.q_commanded, c.q_uncompensated);
            assert!(c.uncompensated_error.norm() < 1e-9);
        }
    }

    #[test]
    fn tracked_path_with_a_free_tool_rotation_meets_the_tolerances() {
        let ur10 = Ur10::new();
        let mut data = Data::new(&ur10.model);
        let egm = ur10.egm(
            None,
            part_cell(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
        );
        let mut options = CompensationOptions::default();
        options.inverse.target = InverseTarget::PositionAndToolAxis;
        let path = fine_travel(100);
        let outcomes = egm.compensate_path(&mut data, &path, &SEED, &options);
        for (o, p) in outcomes.iter().zip(&path) {
            let c = o.result.as_ref().unwrap();
            assert!(converged(&c.residual, &options), "{:?}", c.residual);
            // The uncompensated command reaches the target's position.
            let reached = flexcal_kinematics::forward_pose(
                &ur10.model,
                &mut data,
                &c.q_uncompensated,
                &egm.xi,
            )
            .unwrap();
            let target = egm.cell.x_base_part * p.x_part_tcp;
            assert!((reached.translation.vector - target.translation.vector).norm() < 1e-9);
        }
    }
}
