//! Several measured targets per pose (markers on the hands of a two-armed
//! robot, reflectors on a tool): the constructors and arrays of
//! `flexcal.MeasurementSet` when it is given a targets description
//! (`MeasurementSet.from_arrays(..., targets=...)`,
//! `MeasurementSet.read_csv(path, targets=...)`).

use std::path::Path;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::calib::{
    FrameTreatment, MeasurementSet as Set, Target, TargetObservation, TargetPose, read_targets,
};
use nalgebra::Vector3;
use numpy::PyArrayDyn;
use pyo3::prelude::*;

use crate::arrays::{exact, to_numpy};
use crate::errors::{InputError, NotFiniteError, ShapeError, calib_error};

/// The targets of `from_arrays`: `(name, frame, nominal offset (3,) m)`.
pub(crate) type TargetArrays<'py> =
    Vec<(String, String, PyArrayLikeDyn<'py, f64, AllowTypeChange>)>;

/// A set of several targets from arrays (see `MeasurementSet.from_arrays`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn set_from_arrays<'py>(
    targets: TargetArrays<'py>,
    q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    positions: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    fixed: Vec<String>,
    pose_ids: Option<Vec<String>>,
    source: &str,
    orientations: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
) -> PyResult<Set> {
    let mut described = Vec::with_capacity(targets.len());
    for (name, frame, offset) in &targets {
        let (o, _) = exact(&format!("offset of target `{name}`"), offset, &[Some(3)])?;
        let mut target = Target::new(name, frame, Vector3::new(o[0], o[1], o[2]));
        if fixed.contains(name) {
            target.treatment = FrameTreatment::Fixed;
        }
        described.push(target);
    }
    if let Some(unknown) = fixed
        .iter()
        .find(|f| !described.iter().any(|t| &t.name == *f))
    {
        return Err(InputError::new_err(format!(
            "fixed: no target named `{unknown}`"
        )));
    }
    let (q, n, dof) = crate::arrays::configurations(&q)?;
    let view = positions.as_array();
    let t = described.len();
    if view.shape() != [n, t, 3] {
        return Err(ShapeError::new_err(format!(
            "positions: expected shape ({n}, {t}, 3) (poses, targets, xyz), got {:?}",
            view.shape()
        )));
    }
    if let Some(ids) = &pose_ids {
        if ids.len() != n {
            return Err(ShapeError::new_err(format!(
                "pose_ids: expected {n} labels (one per pose), got {}",
                ids.len()
            )));
        }
    }
    let turns = orientations.as_ref().map(|o| o.as_array());
    if let Some(turns) = &turns {
        if turns.shape() != [n, t, 3] {
            return Err(ShapeError::new_err(format!(
                "orientations: expected shape ({n}, {t}, 3) (poses, targets, rotation vector), got {:?}",
                turns.shape()
            )));
        }
    }
    let mut poses = Vec::with_capacity(n);
    for k in 0..n {
        let mut observations = Vec::with_capacity(t);
        for (j, target) in described.iter().enumerate() {
            let p = Vector3::new(view[[k, j, 0]], view[[k, j, 1]], view[[k, j, 2]]);
            let turn = turns
                .as_ref()
                .map(|o| Vector3::new(o[[k, j, 0]], o[[k, j, 1]], o[[k, j, 2]]))
                .filter(|r| !r.iter().all(|v| v.is_nan()));
            if turn.is_some_and(|r| !r.iter().all(|v| v.is_finite())) {
                return Err(NotFiniteError::new_err(format!(
                    "orientations[{k}, {j}] (target `{}`): all three NaN or all finite",
                    target.name
                )));
            }
            let observation = if p.iter().all(|v| v.is_nan()) {
                None
            } else if p.iter().all(|v| v.is_finite()) {
                Some(TargetObservation {
                    orientation: turn,
                    ..TargetObservation::new(p)
                })
            } else {
                return Err(NotFiniteError::new_err(format!(
                    "positions[{k}, {j}] (target `{}`): all three NaN (not seen) or all finite, got {:?}",
                    target.name,
                    p.as_slice()
                )));
            };
            observations.push(observation);
        }
        poses.push(TargetPose::new(
            pose_ids.as_ref().map(|ids| ids[k].clone()),
            q[k * dof..(k + 1) * dof].to_vec(),
            observations,
        ));
    }
    Set::from_poses(source, described, poses).map_err(|e| calib_error(&e))
}

/// flexcal's CSV with per-target columns (mm), the targets described by
/// the TOML file `targets` (docs/file-formats.md).
pub(crate) fn read_csv(path: &Path, targets: &Path) -> PyResult<Set> {
    let targets = read_targets(targets).map_err(|e| calib_error(&e))?;
    Set::read_targets_csv(path, &targets).map_err(|e| calib_error(&e))
}

/// Positions per target, shape (n, n_targets, 3), m; NaN where a target
/// was not seen.
pub(crate) fn positions<'py>(py: Python<'py>, set: &Set) -> Bound<'py, PyArrayDyn<f64>> {
    per_target(py, set, |o| Some(o.position))
        .unwrap_or_else(|| to_numpy(py, Vec::new(), &[set.len(), set.targets().len(), 3]))
}

/// Orientations per target (rotation vectors, rad), shape (n, n_targets,
/// 3), NaN where a target was not seen or carries none; None when no
/// target carries one.
pub(crate) fn orientations<'py>(py: Python<'py>, set: &Set) -> Option<Bound<'py, PyArrayDyn<f64>>> {
    per_target(py, set, |o| o.orientation)
}

/// `value` of every observation as an (n, n_targets, 3) array, NaN where
/// there is none; None when no observation has one.
fn per_target<'py>(
    py: Python<'py>,
    set: &Set,
    value: impl Fn(&TargetObservation) -> Option<Vector3<f64>>,
) -> Option<Bound<'py, PyArrayDyn<f64>>> {
    let poses = set.poses();
    let mut any = false;
    let values = poses
        .iter()
        .flat_map(|p| p.observations.iter())
        .flat_map(|o| match o.as_ref().and_then(&value) {
            Some(v) => {
                any = true;
                [v.x, v.y, v.z]
            }
            None => [f64::NAN; 3],
        })
        .collect();
    any.then(|| to_numpy(py, values, &[poses.len(), set.targets().len(), 3]))
}
