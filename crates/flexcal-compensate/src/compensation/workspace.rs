//! The per-thread workspace of compensation.

use flexcal_kinematics::Data;

use super::jacobian::JacobianCache;
use crate::process::ProcessWorkspace;

/// Per-thread workspace of an
/// [`ElastoGeometricModel`](super::ElastoGeometricModel): the kinematics
/// workspace, the elastic model's workspace `W` and the stored joint
/// Jacobian of the correction steps. Created once per thread by
/// [`ElastoGeometricModel::data`](super::ElastoGeometricModel::data); one
/// model is shared by many threads, each with its own workspace.
pub struct CompensationData<W> {
    /// Kinematics workspace (forward model, Jacobians).
    pub kinematics: Data,
    /// Workspace of the elastic model.
    pub elastic: W,
    /// Workspace of the process model.
    pub process: ProcessWorkspace,
    pub(crate) jacobian: JacobianCache,
}

impl<W> CompensationData<W> {
    pub(crate) fn from_parts(kinematics: Data, elastic: W, n_actuated: usize) -> Self {
        Self {
            kinematics,
            elastic,
            process: ProcessWorkspace::default(),
            jacobian: JacobianCache::new(n_actuated),
        }
    }
}

impl<W> std::fmt::Debug for CompensationData<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CompensationData").finish_non_exhaustive()
    }
}
