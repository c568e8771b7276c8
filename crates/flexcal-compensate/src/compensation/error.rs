//! Errors of the elasto-geometrical model and of compensation.

use flexcal_kinematics::KinematicsError;

use crate::process::ProcessError;

/// Errors of the elasto-geometrical model and of compensation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
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
