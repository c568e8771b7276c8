//! The pose a robot actually reaches for a command (equations (39)-(40)):
//! the geometric pose displaced by the elastic deflection under the payload
//! and the process wrench, robot and process solved together.

use flexcal_elastic::tcp::TcpDeflection;
use nalgebra::{Isometry3, Matrix3, Vector3, Vector6};

use super::error::CompensationError;
use super::model::{CompensationOptions, ElastoGeometricModel};
use super::pose::displace;
use super::workspace::CompensationData;
use crate::process::{ProcessWorkspace, ToolState};

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
impl<E: ?Sized + TcpDeflection> ElastoGeometricModel<'_, E> {
    fn total_wrench(
        &self,
        process_workspace: &mut ProcessWorkspace,
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
            let wp = process.wrench_on_tool_in(process_workspace, &tool)?;
            let r = self.cell.x_base_part.rotation;
            let f = r * Vector3::new(wp[0], wp[1], wp[2]);
            let m = r * Vector3::new(wp[3], wp[4], wp[5]);
            w += Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z);
        }
        Ok(w)
    }

    /// Wrench and deflection `(W(p), h(q, W(p)))` when the process sees
    /// the tool at `p` (base frame).
    fn reached(
        &self,
        elastic: &mut E::Workspace,
        process: &mut ProcessWorkspace,
        q: &[f64],
        p: &Vector3<f64>,
        motion_base: &Vector3<f64>,
    ) -> Result<(Vector6<f64>, Vector6<f64>), CompensationError> {
        let w = self.total_wrench(process, p, motion_base)?;
        let d = self
            .elastic
            .tcp_displacement(elastic, q, &w)
            .map_err(|e| CompensationError::Elastic(e.to_string()))?;
        Ok((w, d))
    }

    /// The pose actually reached when commanding `q` (equation (39)/(40)),
    /// robot and process solved together. `motion_base` is the direction of
    /// travel of the tool (for friction; zero at rest).
    pub fn actual_pose(
        &self,
        data: &mut CompensationData<E::Workspace>,
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
        data: &mut CompensationData<E::Workspace>,
        q: &[f64],
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        deflection_guess: Option<&Vector6<f64>>,
    ) -> Result<ActualPose, CompensationError> {
        let geometric =
            flexcal_kinematics::forward_pose(self.model, &mut data.kinematics, q, &self.xi)?;
        self.actual_from_geometric(
            &mut data.elastic,
            &mut data.process,
            q,
            geometric,
            motion_base,
            options,
            deflection_guess,
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn actual_from_geometric(
        &self,
        elastic: &mut E::Workspace,
        process: &mut ProcessWorkspace,
        q: &[f64],
        geometric: Isometry3<f64>,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        deflection_guess: Option<&Vector6<f64>>,
    ) -> Result<ActualPose, CompensationError> {
        let p0 = geometric.translation.vector;
        let tolerance = options.position_tolerance_m * 1e-2;
        // Without a process the wrench does not depend on the pose: one
        // evaluation is the equilibrium, whatever the guess.
        let start = match (self.process, deflection_guess) {
            (Some(_), Some(g)) if g.iter().all(|v| v.is_finite()) => p0 + g.fixed_rows::<3>(0),
            _ => p0,
        };
        let (mut w, mut d) = self.reached(elastic, process, q, &start, motion_base)?;
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
                let (w_new, d_new) = self.reached(elastic, process, q, &p, motion_base)?;
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
                    let r = |elastic: &mut E::Workspace,
                             process: &mut ProcessWorkspace,
                             p: &Vector3<f64>|
                     -> Result<Vector3<f64>, CompensationError> {
                        let (_, d) = self.reached(elastic, process, q, p, motion_base)?;
                        Ok(p - p0 - d.fixed_rows::<3>(0))
                    };
                    let r0 = r(elastic, process, &p)?;
                    if r0.norm() <= tolerance {
                        let (w_n, d_n) = self.reached(elastic, process, q, &p, motion_base)?;
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
                        let col =
                            (r(elastic, process, &pp)? - r(elastic, process, &pm)?) / (2.0 * h);
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
