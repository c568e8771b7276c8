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
//!
//! # Threads
//! [`ElastoGeometricModel`] is immutable and shared; every thread
//! compensates with its own [`CompensationData`] (kinematics workspace,
//! the elastic model's workspace, the stored Jacobian), created once by
//! [`ElastoGeometricModel::data`].
//! [`ElastoGeometricModel::compensate_path_parallel`] cuts a long path into
//! stretches tracked in the threads of the rayon pool.
//!
//! # Modules
//! The elastic model is any [`TcpDeflection`] of flexcal-elastic
//! (re-exported here); [`Cell`] and [`CompensationOptions`] hold the cell and the settings,
//! the equilibrium of robot and process gives the [`ActualPose`], one
//! point is compensated by [`ElastoGeometricModel::compensate_pose`], whole
//! paths by the tracker.

mod equilibrium;
mod error;
mod jacobian;
mod model;
mod point;
mod pose;
mod tracking;
mod workspace;

#[cfg(test)]
mod tests;

pub use equilibrium::ActualPose;
pub use error::CompensationError;
pub use flexcal_elastic::tcp::{
    ConstantCompliance, DeflectionError, DynTcpDeflection, TcpDeflection,
};
pub use model::{Cell, CompensationOptions, ElastoGeometricModel};
pub use point::{CompensatedPoint, CompensationMethod};
pub use pose::{displace, pose_difference, position_norm};
pub use tracking::PointOutcome;
pub use workspace::CompensationData;
