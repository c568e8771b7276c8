//! Several measured targets per pose (markers on the hands of a two-armed
//! robot, reflectors on a tool): `flexcal.TargetMeasurementSet` and the
//! validation of a calibration on it (`flexcal.ValidationResult`, the same
//! class as for one target).
//! `flexcal.calibrate` takes such a set as it takes a `MeasurementSet`.

use std::path::PathBuf;
use std::sync::Arc;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::calib::{
    FrameTreatment, MeasurementSet as Set, Target, TargetObservation, TargetPose, read_targets,
};
use nalgebra::Vector3;
use numpy::PyArrayDyn;
use pyo3::prelude::*;

use crate::arrays::{exact, to_numpy};
use crate::errors::{InputError, NotFiniteError, ShapeError, calib_error};

/// Measured poses of several targets: actuated coordinates q (rad, m) and,
/// per target, its position (m) in the measurement frame, or nothing where
/// it was occluded.
#[pyclass(frozen, module = "flexcal", name = "TargetMeasurementSet")]
#[derive(Debug, Clone)]
pub struct TargetMeasurementSet {
    pub(crate) set: Arc<Set>,
}

#[pymethods]
impl TargetMeasurementSet {
    /// A set from arrays: `targets` a list of `(name, frame, offset)` (the
    /// frame a frame of the robot or `"tcp"`, the nominal offset (3,) in it,
    /// m), `q` (n, dof) in rad or m, `positions` (n, n_targets, 3) in m with
    /// NaN for a target not seen on a pose; `fixed` the names of targets
    /// whose offset is known (not identified); `pose_ids` n labels;
    /// `orientations` (n, n_targets, 3) rotation vectors in rad of each
    /// target's measured orientation in the measurement frame, NaN where
    /// not seen (a target whose orientations are all NaN has none: its
    /// positions only are fitted).
    #[staticmethod]
    #[pyo3(signature = (targets, q, positions, fixed = Vec::new(), pose_ids = None, source = "arrays", orientations = None))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays<'py>(
        targets: Vec<(String, String, PyArrayLikeDyn<'py, f64, AllowTypeChange>)>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        positions: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        fixed: Vec<String>,
        pose_ids: Option<Vec<String>>,
        source: &str,
        orientations: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    ) -> PyResult<Self> {
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
        let (q, q_shape) = exact("q", &q, &[None, None])?;
        let (n, dof) = (q_shape[0], q_shape[1]);
        if n == 0 || dof == 0 {
            return Err(ShapeError::new_err(format!(
                "q: expected shape (n, dof) with n, dof > 0, got ({n}, {dof})"
            )));
        }
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
            poses.push(TargetPose {
                pose_id: pose_ids.as_ref().map(|ids| ids[k].clone()),
                q: q[k * dof..(k + 1) * dof].to_vec(),
                observations,
                wrench: None,
                temperature_c: None,
            });
        }
        Ok(Self {
            set: Arc::new(Set::from_poses(source, described, poses).map_err(|e| calib_error(&e))?),
        })
    }

    /// flexcal's CSV with per-target columns (mm), the targets described by
    /// the TOML file `targets` (docs/file-formats.md).
    #[staticmethod]
    fn read_csv(path: PathBuf, targets: PathBuf) -> PyResult<Self> {
        let targets = read_targets(&targets).map_err(|e| calib_error(&e))?;
        Ok(Self {
            set: Arc::new(Set::read_targets_csv(&path, &targets).map_err(|e| calib_error(&e))?),
        })
    }

    /// Writes the set in flexcal's CSV (mm), atomically.
    fn write_csv(&self, path: PathBuf) -> PyResult<()> {
        self.set.write_csv(&path).map_err(|e| calib_error(&e))
    }

    /// Several sets of the same targets as the stations of one
    /// calibration: each keeps its own measurement frame (the tracker
    /// moved to see the other hand), the robot and the targets' offsets are
    /// shared. Labels then carry the station's number (`s2:p17`).
    #[staticmethod]
    fn pooled(sets: Vec<PyRef<'_, TargetMeasurementSet>>) -> PyResult<Self> {
        let owned: Vec<Set> = sets.iter().map(|s| (*s.set).clone()).collect();
        Ok(Self {
            set: Arc::new(Set::pooled(&owned).map_err(|e| calib_error(&e))?),
        })
    }

    /// Names of the stations (a file, or a `station` column's values).
    #[getter]
    fn station_names(&self) -> Vec<String> {
        self.set.station_names().to_vec()
    }

    /// The station (index into `station_names`) of each pose.
    #[getter]
    fn station_of(&self) -> Vec<usize> {
        (0..self.set.len())
            .map(|k| self.set.station_of(k))
            .collect()
    }

    /// The label of every pose, as reports and `excluding` name it: its
    /// `pose_id`, or `#k` from its index; `s2:` before a second station's.
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.set.labels()
    }

    /// The set without the poses labelled `labels` (every target of a pose
    /// with it); the poses kept keep their labels.
    fn excluding(&self, labels: Vec<String>) -> PyResult<Self> {
        Ok(Self {
            set: Arc::new(self.set.excluding(&labels).map_err(|e| calib_error(&e))?),
        })
    }

    /// Names of the targets, in the order of `positions`.
    #[getter]
    fn target_names(&self) -> Vec<String> {
        self.set.targets().iter().map(|t| t.name.clone()).collect()
    }

    /// The frame each target is fixed to, in the order of `target_names`.
    #[getter]
    fn target_frames(&self) -> Vec<String> {
        self.set.targets().iter().map(|t| t.frame.clone()).collect()
    }

    /// Actuated coordinates, shape (n, dof), rad or m.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let poses = self.set.poses();
        let dof = self.set.n_actuated();
        let q = poses.iter().flat_map(|p| p.q.iter().copied()).collect();
        to_numpy(py, q, &[poses.len(), dof])
    }

    /// Positions, shape (n, n_targets, 3), m; NaN where a target was not seen.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let poses = self.set.poses();
        let t = self.set.targets().len();
        let values = poses
            .iter()
            .flat_map(|p| {
                p.observations.iter().flat_map(|o| match o {
                    Some(o) => [o.position.x, o.position.y, o.position.z],
                    None => [f64::NAN; 3],
                })
            })
            .collect();
        to_numpy(py, values, &[poses.len(), t, 3])
    }

    /// Number of (pose, target) observations.
    #[getter]
    fn n_observations(&self) -> usize {
        self.set.n_observations()
    }

    /// Name of the set in messages (its file).
    #[getter]
    fn source(&self) -> String {
        self.set.source.clone()
    }

    fn __len__(&self) -> usize {
        self.set.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "TargetMeasurementSet({:?}, {} poses, targets {:?})",
            self.set.source,
            self.set.len(),
            self.target_names()
        )
    }
}
