//! The elasto-geometrical model of a robot in its cell, and its settings.

use flexcal_elastic::tcp::{DynTcpDeflection, TcpDeflection};
use flexcal_kinematics::{Data, InverseOptions, Model};
use nalgebra::{Isometry3, Vector6};

use super::error::CompensationError;
use super::workspace::CompensationData;
use crate::process::ProcessModel;

/// The robot's cell and load: where the part is and what the tool carries.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Pose of the part frame R_p in the robot base frame R_0.
    pub x_base_part: Isometry3<f64>,
    /// Constant wrench on the tool (payload, dead weight), base frame [N, N.m].
    pub payload_base: Vector6<f64>,
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
/// identified parameters xi), elasticity, payload and process. Immutable and
/// shared by every thread; each thread compensates with its own
/// [`CompensationData`] from [`data`](Self::data).
///
/// The elastic model `E` is any [`TcpDeflection`]: a concrete type (the
/// FE beam model, the fuzzy compliance model), or, by default,
/// `dyn DynTcpDeflection` for a model chosen at run time.
pub struct ElastoGeometricModel<'a, E: ?Sized + TcpDeflection = dyn DynTcpDeflection + 'a> {
    /// Geometric model.
    pub model: &'a Model,
    /// Geometric parameters xi (SI).
    pub xi: Vec<f64>,
    /// Elastic model.
    pub elastic: &'a E,
    /// Process model (None: payload only).
    pub process: Option<&'a dyn ProcessModel>,
    /// Cell and payload.
    pub cell: Cell,
}

impl<'a, E: ?Sized + TcpDeflection> ElastoGeometricModel<'a, E> {
    /// The model with the robot's nominal geometric parameters.
    pub fn with_nominal_geometry(
        model: &'a Model,
        elastic: &'a E,
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

    /// A workspace for one thread: create it once and pass it to every
    /// call of that thread.
    ///
    /// # Errors
    /// [`CompensationError::Elastic`] when the elastic model cannot set up
    /// its workspace.
    pub fn data(&self) -> Result<CompensationData<E::Workspace>, CompensationError> {
        let elastic = self
            .elastic
            .workspace()
            .map_err(|e| CompensationError::Elastic(e.to_string()))?;
        Ok(CompensationData::from_parts(
            Data::new(self.model),
            elastic,
            self.model.n_actuated(),
        ))
    }
}
