//! `flexcal.MeasurementSet`: measured poses from arrays or files.

use std::path::PathBuf;
use std::sync::Arc;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::calib::{Measurement, MeasurementSet as Set};
use nalgebra::Vector3;
use numpy::PyArrayDyn;
use pyo3::prelude::*;

use crate::arrays::{exact, to_numpy};
use crate::errors::{InputError, ShapeError, calib_error};

/// The file format a set was read from: it decides the defaults of
/// `calibrate` as the command line does (the IPA export is weighted
/// uniformly and used positions-only unless asked otherwise).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// Arrays or flexcal's own CSV.
    Own,
    /// The IPA laser-tracker export.
    Ipa,
    /// Arrays or flexcal's CSV with a targets description: several
    /// targets per pose (or one, named), each on a frame of the robot.
    Targets,
}

/// A validated set of measured poses: actuated coordinates q (rad, m) and
/// the target position (m) seen in the measurement frame, optionally its
/// orientation (rotation vector, rad) and standard deviations; or, with a
/// targets description, the position (and orientation) of each of several
/// targets, NaN where one was not seen.
#[pyclass(frozen, module = "flexcal", name = "MeasurementSet")]
#[derive(Debug, Clone)]
pub struct MeasurementSet {
    pub(crate) set: Arc<Set>,
    pub(crate) origin: Origin,
}

fn column3(values: &[f64], k: usize) -> Vector3<f64> {
    Vector3::new(values[3 * k], values[3 * k + 1], values[3 * k + 2])
}

#[pymethods]
impl MeasurementSet {
    /// A set from arrays: `q` (n, dof) in rad or m, `positions` (n, 3) in m,
    /// `orientations` (n, 3) rotation vectors in rad, `std` (n, 3) position
    /// standard deviations in m, `orientation_std` (n, 3) in rad,
    /// `pose_ids` n labels. `source` names the set in messages.
    ///
    /// Several targets: `targets` a list of `(name, frame, offset)` (the
    /// frame a frame of the robot or `"tcp"`, the nominal offset (3,) in
    /// it, m), `positions` and `orientations` (n, n_targets, 3) with NaN
    /// for a target not seen on a pose (a target whose orientations are
    /// all NaN has none: its positions only are fitted), `fixed` the names
    /// of targets whose offset is known (not identified); `std` and
    /// `orientation_std` are then refused (the observations weigh alike).
    #[staticmethod]
    #[pyo3(signature = (q, positions, orientations = None, std = None, orientation_std = None, pose_ids = None, source = "arrays", targets = None, fixed = Vec::new()))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays<'py>(
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        positions: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        orientations: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        std: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        orientation_std: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        pose_ids: Option<Vec<String>>,
        source: &str,
        targets: Option<crate::targets::TargetArrays<'py>>,
        fixed: Vec<String>,
    ) -> PyResult<Self> {
        if let Some(targets) = targets {
            if let Some(name) = [
                ("std", std.is_some()),
                ("orientation_std", orientation_std.is_some()),
            ]
            .iter()
            .find_map(|(name, given)| given.then_some(*name))
            {
                return Err(InputError::new_err(format!(
                    "{name}: not available with targets (the observations of several targets weigh alike)"
                )));
            }
            let set = crate::targets::set_from_arrays(
                targets,
                q,
                positions,
                fixed,
                pose_ids,
                source,
                orientations,
            )?;
            return Ok(Self {
                set: Arc::new(set),
                origin: Origin::Targets,
            });
        }
        if let Some(name) = fixed.first() {
            return Err(InputError::new_err(format!(
                "fixed: `{name}` given without targets (fixed names targets of the targets list)"
            )));
        }
        let (q, n, dof) = crate::arrays::configurations(&q)?;
        let (p, _) = exact("positions", &positions, &[Some(n), Some(3)])?;
        let optional = |name: &str, a: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>| {
            a.map(|a| exact(name, &a, &[Some(n), Some(3)]).map(|r| r.0))
                .transpose()
        };
        let o = optional("orientations", orientations)?;
        let s = optional("std", std)?;
        let os = optional("orientation_std", orientation_std)?;
        if let Some(ids) = &pose_ids {
            if ids.len() != n {
                return Err(ShapeError::new_err(format!(
                    "pose_ids: expected {n} labels (one per pose), got {}",
                    ids.len()
                )));
            }
        }
        if os.is_some() && o.is_none() {
            return Err(InputError::new_err(
                "orientation_std: given without orientations",
            ));
        }
        let measurements = (0..n)
            .map(|k| {
                let mut m = Measurement::new(q[k * dof..(k + 1) * dof].to_vec(), column3(&p, k));
                m.orientation = o.as_deref().map(|o| column3(o, k));
                m.position_std = s.as_deref().map(|s| column3(s, k));
                m.orientation_std = os.as_deref().map(|s| column3(s, k));
                m.pose_id = pose_ids.as_ref().map(|ids| ids[k].clone());
                m
            })
            .collect();
        let set = Set::new(source, measurements).map_err(|e| calib_error(&e))?;
        Ok(Self {
            set: Arc::new(set),
            origin: Origin::Own,
        })
    }

    /// Reads a measurement file: `format="own"` (flexcal's CSV: q1..qn,
    /// x_mm, y_mm, z_mm, ...) or `"ipa"` (the IPA UR10 laser-tracker export;
    /// its probe offset becomes the starting target). With `targets` (the
    /// TOML targets description, docs/file-formats.md): flexcal's CSV with
    /// per-target columns (mm).
    #[staticmethod]
    #[pyo3(signature = (path, format = "own", targets = None))]
    fn read_csv(path: PathBuf, format: &str, targets: Option<PathBuf>) -> PyResult<Self> {
        if let Some(targets) = targets {
            if format != "own" {
                return Err(InputError::new_err(format!(
                    "format: {format:?} has no per-target columns; with targets the format is \"own\""
                )));
            }
            return Ok(Self {
                set: Arc::new(crate::targets::read_csv(&path, &targets)?),
                origin: Origin::Targets,
            });
        }
        let (set, origin) = match format {
            "own" => (Set::read_csv(&path), Origin::Own),
            "ipa" => (Set::read_ipa(&path), Origin::Ipa),
            other => {
                return Err(InputError::new_err(format!(
                    "format: expected \"own\" or \"ipa\", got {other:?}"
                )));
            }
        };
        Ok(Self {
            set: Arc::new(set.map_err(|e| calib_error(&e))?),
            origin,
        })
    }

    /// Writes the set in flexcal's CSV format (mm, deg), atomically.
    fn write_csv(&self, path: PathBuf) -> PyResult<()> {
        self.set.write_csv(&path).map_err(|e| calib_error(&e))
    }

    /// Several sets as the stations of one calibration: each keeps its own
    /// measurement frame (a tracker moved, a campaign of another day), the
    /// robot and the target are shared. Labels then carry the station's
    /// number (`s2:line 534`). The sets must come from the same format.
    #[staticmethod]
    fn pooled(sets: Vec<PyRef<'_, MeasurementSet>>) -> PyResult<Self> {
        let origin = sets.first().map_or(Origin::Own, |s| s.origin);
        if sets.iter().any(|s| s.origin != origin) {
            return Err(InputError::new_err(
                "sets: pooled sets must come from the same format (own, ipa, or with targets)",
            ));
        }
        let owned: Vec<Set> = sets.iter().map(|s| (*s.set).clone()).collect();
        Ok(Self {
            set: Arc::new(Set::pooled(&owned).map_err(|e| calib_error(&e))?),
            origin,
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

    /// The poses at `indices` (for splitting a set).
    fn subset(&self, indices: Vec<usize>) -> PyResult<Self> {
        Ok(Self {
            set: Arc::new(self.set.subset(&indices).map_err(|e| calib_error(&e))?),
            origin: self.origin,
        })
    }

    /// The set without the poses labelled `labels` (as `labels` lists them:
    /// a pose_id, `#k`, or `line N` for the IPA format).
    fn excluding(&self, labels: Vec<String>) -> PyResult<Self> {
        Ok(Self {
            set: Arc::new(self.set.excluding(&labels).map_err(|e| calib_error(&e))?),
            origin: self.origin,
        })
    }

    /// Where the set comes from (file name), as messages name it.
    #[getter]
    fn source(&self) -> String {
        self.set.source.clone()
    }

    /// `"own"`, `"ipa"` or `"targets"`: the format the set was read from
    /// (arrays: own; with a targets description: targets).
    #[getter]
    fn format(&self) -> &'static str {
        match self.origin {
            Origin::Own => "own",
            Origin::Ipa => "ipa",
            Origin::Targets => "targets",
        }
    }

    /// Names of the targets, in the order of `positions` with several
    /// targets (`["tcp"]` for a one-target file).
    #[getter]
    fn target_names(&self) -> Vec<String> {
        self.set.targets().iter().map(|t| t.name.clone()).collect()
    }

    /// The frame each target is fixed to, in the order of `target_names`.
    #[getter]
    fn target_frames(&self) -> Vec<String> {
        self.set.targets().iter().map(|t| t.frame.clone()).collect()
    }

    /// Number of (pose, target) observations.
    #[getter]
    fn n_observations(&self) -> usize {
        self.set.n_observations()
    }

    /// Actuated coordinates, shape (n, dof), rad or m.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let data = self
            .set
            .poses()
            .iter()
            .flat_map(|p| p.q.iter().copied())
            .collect();
        to_numpy(py, data, &[self.set.len(), self.set.n_actuated()])
    }

    /// Measured target positions in the measurement frame, shape (n, 3), m;
    /// with a targets description (n, n_targets, 3), NaN where a target was
    /// not seen.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        if self.origin == Origin::Targets {
            return crate::targets::positions(py, &self.set);
        }
        let data = self
            .set
            .measurements()
            .iter()
            .flat_map(|m| m.position.iter().copied().collect::<Vec<_>>())
            .collect();
        to_numpy(py, data, &[self.set.len(), 3])
    }

    /// Measured orientations (rotation vectors, rad), shape (n, 3), or None;
    /// with a targets description (n, n_targets, 3), NaN where a target was
    /// not seen or carries none.
    #[getter]
    fn orientations<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArrayDyn<f64>>> {
        if self.origin == Origin::Targets {
            return crate::targets::orientations(py, &self.set);
        }
        let data: Option<Vec<f64>> = self
            .set
            .measurements()
            .iter()
            .map(|m| m.orientation.map(|o| [o.x, o.y, o.z]))
            .collect::<Option<Vec<_>>>()
            .map(|v| v.concat());
        data.map(|d| to_numpy(py, d, &[self.set.len(), 3]))
    }

    /// Labels of the poses (pose_id, `#k`, or `line N`), as reports name them.
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.set.labels()
    }

    /// Number of actuated coordinates per pose.
    #[getter]
    fn dof(&self) -> usize {
        self.set.n_actuated()
    }

    /// Whether orientations are measured.
    #[getter]
    fn has_orientation(&self) -> bool {
        self.set.has_orientation()
    }

    /// The nominal target pose in the TCP frame (4 x 4, m) when the file
    /// format knows it (the IPA probe offset), else None.
    #[getter]
    fn nominal_target<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArrayDyn<f64>>> {
        self.set.nominal_target().map(|x| {
            let m = x.to_homogeneous();
            to_numpy(py, m.transpose().as_slice().to_vec(), &[4, 4])
        })
    }

    fn __len__(&self) -> usize {
        self.set.len()
    }

    fn __repr__(&self) -> String {
        if self.origin == Origin::Targets {
            return format!(
                "MeasurementSet(source={:?}, poses={}, dof={}, targets={:?})",
                self.set.source,
                self.set.len(),
                self.set.n_actuated(),
                self.target_names()
            );
        }
        format!(
            "MeasurementSet(source={:?}, poses={}, dof={}, orientation={})",
            self.set.source,
            self.set.len(),
            self.set.n_actuated(),
            self.set.has_orientation()
        )
    }
}
