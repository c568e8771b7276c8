//! Elastic models seen from the tool centre point: the seam between the
//! elastic models of this crate and the compensation of tool paths
//! (flexcal-compensate).
//!
//! Compensation needs one thing from an elastic model: the TCP's elastic
//! displacement `dS = h(q, W)` (equations (28), (38), (64) of the reference
//! paper) for a configuration `q` and a wrench `W` on the tool. The
//! [`TcpDeflection`] trait says exactly that, in the house's Model/Data
//! shape: the implementing model is immutable and shared by every thread;
//! each thread owns a [`TcpDeflection::Workspace`], created once by
//! [`TcpDeflection::workspace`], into which an evaluation writes its
//! intermediate results, so evaluating along a path allocates nothing.
//!
//! Three models implement it:
//! - [`FeTcpModel`]: the FE beam model ([`crate::model`]) with geometric
//!   parameters `xi` and stiffness parameters `Gamma`. Its workspace holds
//!   the structure, its factorization and the compliance `C_eq` condensed
//!   onto the TCP for the last configuration, so that the robot-process
//!   equilibrium (several wrenches in one configuration) assembles and
//!   factors once per configuration.
//! - `fuzzy_compliance::RobotFuzzyCompliance`: the fuzzy compliance
//!   model (38), (70) bound to its robot.
//! - [`ConstantCompliance`]: a configuration-independent compliance, a
//!   stand-in and a test fixture.
//!
//! Callers that choose a model at run time (a CLI flag, a file) hold a
//! `&dyn` [`DynTcpDeflection`], which every [`TcpDeflection`] is, and which is
//! itself a [`TcpDeflection`] whose workspace is boxed once per thread.
//!
//! ```
//! use flexcal_elastic::description::ElasticDescription;
//! use flexcal_elastic::model::ElasticModel;
//! use flexcal_elastic::tcp::{FeTcpModel, TcpDeflection};
//! use flexcal_kinematics::{RobotDescription, actuated_from_joint_angles};
//! use nalgebra::Vector6;
//!
//! let robot = RobotDescription::builtin("ir663")?.build()?;
//! let model = ElasticModel::new(&robot, &ElasticDescription::builtin("ir663")?)?;
//! let gamma = model.nominal_gamma();
//! let fe = FeTcpModel::new(model, robot.nominal_params().to_vec(), gamma, "FE beam model")?;
//! let mut workspace = fe.workspace()?; // one per thread
//! let q = actuated_from_joint_angles(&robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0])?;
//! let down = Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0); // [N; N.m]
//! let d = fe.tcp_displacement(&mut workspace, &q, &down)?; // [m; rad]
//! assert!(d[2] < 0.0 && d[2] > -5e-3);
//! # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
//! ```

use std::any::Any;

use nalgebra::{Matrix6, Vector6};

use crate::model::{ElasticData, ElasticModel, tcp_compliance};

/// Error of an elastic model evaluation, as reported by its implementation.
pub type DeflectionError = Box<dyn std::error::Error + Send + Sync>;

/// An elastic model of a robot seen from its TCP: the displacement of the
/// tool under a wrench, in any configuration. The model is immutable and
/// shared between threads; each thread evaluates it with its own
/// [`Workspace`](Self::Workspace).
pub trait TcpDeflection: Send + Sync {
    /// Per-thread buffers of an evaluation (for example the FE structure
    /// and its factorization). Created once per thread by
    /// [`workspace`](Self::workspace).
    type Workspace: Send + 'static;

    /// A short description for reports.
    fn describe(&self) -> String;

    /// A fresh workspace for this model.
    ///
    /// # Errors
    /// When the model's buffers cannot be set up (an FE structure whose
    /// topology cannot be ordered).
    fn workspace(&self) -> Result<Self::Workspace, DeflectionError>;

    /// Elastic displacement `[dp; dphi]` of the TCP (m, rad), in the robot
    /// base frame, for actuated coordinates `q` under the wrench
    /// `wrench_base` `[f; m]` (N, N.m) applied at the TCP and expressed in the
    /// base frame. The robot's own weight is left out: it is part of what the
    /// geometric calibration absorbed, and the elastic campaigns measure
    /// loaded minus unloaded poses.
    ///
    /// # Errors
    /// A `q` of the wrong length, a configuration the model cannot place, a
    /// non-finite wrench.
    fn tcp_displacement(
        &self,
        workspace: &mut Self::Workspace,
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DeflectionError>;
}

/// A [`TcpDeflection`] chosen at run time: object-safe, its workspace boxed.
/// Every [`TcpDeflection`] implements it, and `dyn DynTcpDeflection` is
/// itself a [`TcpDeflection`], so `&dyn DynTcpDeflection` goes wherever a
/// model goes.
pub trait DynTcpDeflection: Send + Sync {
    /// [`TcpDeflection::describe`].
    fn describe_dyn(&self) -> String;

    /// [`TcpDeflection::workspace`], boxed.
    ///
    /// # Errors
    /// As [`TcpDeflection::workspace`].
    fn workspace_dyn(&self) -> Result<Box<dyn Any + Send>, DeflectionError>;

    /// [`TcpDeflection::tcp_displacement`] with a workspace from
    /// [`workspace_dyn`](Self::workspace_dyn).
    ///
    /// # Errors
    /// As [`TcpDeflection::tcp_displacement`], and a workspace of another
    /// model.
    fn tcp_displacement_dyn(
        &self,
        workspace: &mut (dyn Any + Send),
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DeflectionError>;
}

impl<T: TcpDeflection> DynTcpDeflection for T {
    fn describe_dyn(&self) -> String {
        self.describe()
    }

    fn workspace_dyn(&self) -> Result<Box<dyn Any + Send>, DeflectionError> {
        Ok(Box::new(self.workspace()?))
    }

    fn tcp_displacement_dyn(
        &self,
        workspace: &mut (dyn Any + Send),
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DeflectionError> {
        let workspace = workspace
            .downcast_mut::<T::Workspace>()
            .ok_or("the workspace belongs to another elastic model")?;
        self.tcp_displacement(workspace, q, wrench_base)
    }
}

impl TcpDeflection for dyn DynTcpDeflection + '_ {
    type Workspace = Box<dyn Any + Send>;

    fn describe(&self) -> String {
        self.describe_dyn()
    }

    fn workspace(&self) -> Result<Self::Workspace, DeflectionError> {
        self.workspace_dyn()
    }

    fn tcp_displacement(
        &self,
        workspace: &mut Self::Workspace,
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DeflectionError> {
        self.tcp_displacement_dyn(workspace.as_mut(), q, wrench_base)
    }
}

/// An elastic model with a configuration-independent compliance matrix
/// (6 x 6, SI units, base frame): a simple stand-in and a test fixture.
#[derive(Debug, Clone, PartialEq)]
pub struct ConstantCompliance {
    /// Compliance `C` such that `dS = C W` (m/N, rad/(N.m), ...).
    pub compliance: Matrix6<f64>,
}

impl TcpDeflection for ConstantCompliance {
    type Workspace = ();

    fn describe(&self) -> String {
        "constant compliance".into()
    }

    fn workspace(&self) -> Result<(), DeflectionError> {
        Ok(())
    }

    fn tcp_displacement(
        &self,
        _workspace: &mut (),
        _q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DeflectionError> {
        Ok(self.compliance * wrench_base)
    }
}

/// The FE beam model seen from the TCP, for compensation: the TCP
/// displacement under an external wrench, `dS = C_eq W` (28), (63)-(64),
/// with the model's geometric parameters `xi` and stiffness parameters
/// `Gamma` fixed.
#[derive(Debug, Clone)]
pub struct FeTcpModel {
    model: ElasticModel,
    xi: Vec<f64>,
    gamma: Vec<f64>,
    label: String,
}

/// Workspace of a [`FeTcpModel`]: the FE workspace and the TCP compliance
/// of the last configuration, reused while the configuration is unchanged.
#[derive(Debug, Clone)]
pub struct FeTcpWorkspace {
    data: ElasticData,
    /// Configuration whose compliance `c_eq` holds (empty: none yet).
    q: Vec<f64>,
    c_eq: Matrix6<f64>,
}

impl FeTcpModel {
    /// Wraps an FE model with geometric parameters `xi` (SI) and stiffness
    /// parameters `gamma` (in the order of [`ElasticModel::parameters`]).
    ///
    /// # Errors
    /// A `gamma` of the wrong length or with a non-positive value.
    pub fn new(
        model: ElasticModel,
        xi: Vec<f64>,
        gamma: Vec<f64>,
        label: impl Into<String>,
    ) -> Result<Self, crate::ElasticError> {
        model.check_gamma(&gamma)?;
        Ok(Self {
            model,
            xi,
            gamma,
            label: label.into(),
        })
    }

    /// The FE model.
    pub fn model(&self) -> &ElasticModel {
        &self.model
    }

    /// Geometric parameters xi (SI).
    pub fn xi(&self) -> &[f64] {
        &self.xi
    }

    /// Stiffness parameters Gamma (SI).
    pub fn gamma(&self) -> &[f64] {
        &self.gamma
    }
}

impl TcpDeflection for FeTcpModel {
    type Workspace = FeTcpWorkspace;

    fn describe(&self) -> String {
        self.label.clone()
    }

    fn workspace(&self) -> Result<FeTcpWorkspace, DeflectionError> {
        Ok(FeTcpWorkspace {
            data: ElasticData::new(&self.model)?,
            q: Vec::with_capacity(self.model.robot().n_actuated()),
            c_eq: Matrix6::zeros(),
        })
    }

    fn tcp_displacement(
        &self,
        workspace: &mut FeTcpWorkspace,
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DeflectionError> {
        if !wrench_base.iter().all(|v| v.is_finite()) {
            return Err(format!("TCP wrench not finite: {wrench_base:?}").into());
        }
        // With the structure condensed onto the TCP and the load at the TCP
        // only, the TCP displacement is exactly C_eq W: one assembly and
        // factorization per configuration, a 6 x 6 product per wrench.
        if workspace.q.as_slice() != q {
            workspace.q.clear();
            workspace.c_eq =
                tcp_compliance(&self.model, &mut workspace.data, q, &self.xi, &self.gamma)?;
            workspace.q.extend_from_slice(q);
        }
        Ok(workspace.c_eq * wrench_base)
    }
}
