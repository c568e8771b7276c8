//! Predicted accuracy of a calibrated robot from Python: the 95 % bound of
//! the position error at any configuration and its check on a measured set
//! (`flexcal::calib::AccuracyMap`), in SI units.

use std::sync::Arc;

use flexcal::calib::AccuracyMap;
use pyo3::prelude::*;

use crate::arrays::{Rows, to_numpy};
use numpy::PyArrayDyn;

/// Predicted 95 % bounds of the position error at a set of configurations
/// (`CalibrationResult.predicted_accuracy`) or at the poses of a measured
/// set with their actual errors (`CalibrationResult.accuracy_coverage`);
/// with several targets one entry per pose and
/// target.
#[pyclass(frozen, module = "flexcal", name = "AccuracyResult")]
#[derive(Debug)]
pub struct AccuracyResult {
    map: Arc<AccuracyMap>,
}

impl AccuracyResult {
    /// The map for Python.
    pub(crate) fn new(map: AccuracyMap) -> Self {
        Self { map: Arc::new(map) }
    }
}

fn column<'py>(
    py: Python<'py>,
    map: &AccuracyMap,
    value: impl Fn(&flexcal::calib::PoseAccuracy) -> f64,
) -> Bound<'py, PyArrayDyn<f64>> {
    let values: Vec<f64> = map.poses.iter().map(value).collect();
    to_numpy(py, values, &[map.poses.len()])
}

#[pymethods]
impl AccuracyResult {
    /// 95 % bound on the position error at each pose, shape (n,), m.
    #[getter]
    fn bound_95<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        column(py, &self.map, |p| p.bound_95_mm * 1e-3)
    }

    /// The identification's own uncertainty at each pose,
    /// `sqrt(tr Sigma_pred)`, shape (n,), m.
    #[getter]
    fn model_uncertainty<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        column(py, &self.map, |p| p.model_uncertainty_mm * 1e-3)
    }

    /// Measured position error after calibration at each pose, shape (n,),
    /// m (NaN at configurations without a measurement).
    #[getter]
    fn actual_error<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        column(py, &self.map, |p| {
            p.actual_error_mm.map_or(f64::NAN, |e| e * 1e-3)
        })
    }

    /// The calibrated target position at each pose in the robot base
    /// frame, shape (n, 3), m.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let values: Vec<f64> = self
            .map
            .poses
            .iter()
            .flat_map(|p| p.position_mm.map(|v| v * 1e-3))
            .collect();
        to_numpy(py, values, &[self.map.poses.len(), 3])
    }

    /// Per pose, the actuated coordinates (names) at which it lies outside
    /// the identification poses' range: there the bound assumes the model
    /// holds beyond the data.
    #[getter]
    fn outside_training_range(&self) -> Vec<Vec<String>> {
        self.map
            .poses
            .iter()
            .map(|p| p.outside_training_range.clone())
            .collect()
    }

    /// Number of poses outside the identification poses' range of at least
    /// one coordinate.
    #[getter]
    fn extrapolated_poses(&self) -> usize {
        self.map.extrapolated_poses
    }

    /// Share of the measured poses whose error lies within its bound
    /// (None without measurements).
    #[getter]
    fn coverage(&self) -> Option<f64> {
        self.map.coverage
    }

    /// Per-axis scatter of the training residuals, m.
    #[getter]
    fn residual_scatter(&self) -> f64 {
        self.map.residual_scatter_mm * 1e-3
    }

    /// The target of each entry, with several targets (one entry per pose
    /// and target, pose by pose); None for the one target of a
    /// `CalibrationResult`.
    #[getter]
    fn targets(&self) -> Option<Vec<String>> {
        self.map
            .poses
            .iter()
            .map(|p| p.target.clone())
            .collect::<Option<Vec<String>>>()
            .filter(|_| !self.map.poses.is_empty())
    }

    /// Factor on every standard deviation from the split-half check (1:
    /// none).
    #[getter]
    fn inflation(&self) -> f64 {
        self.map.inflation
    }

    /// The map as `flexcal calibrate --accuracy-map` writes it (CSV, mm).
    fn to_csv(&self) -> String {
        self.map.to_csv_string()
    }

    fn __repr__(&self) -> String {
        format!(
            "AccuracyResult({} poses, mean 95 % bound {:.4} mm{}{})",
            self.map.poses.len(),
            self.map.mean_bound_95_mm,
            self.map
                .coverage
                .map_or(String::new(), |c| format!(", coverage {:.1} %", 100.0 * c)),
            if self.map.extrapolated_poses > 0 {
                format!(", {} extrapolated", self.map.extrapolated_poses)
            } else {
                String::new()
            }
        )
    }
}

/// The rows of `q` as configurations.
pub(crate) fn configurations(q: &Rows) -> Vec<Vec<f64>> {
    (0..q.n).map(|k| q.row(k).to_vec()).collect()
}
