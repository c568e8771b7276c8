//! The checks of an identification from Python, in SI units: the
//! split-half check (`calibrate(..., split_check=True)`: each identified
//! unknown again on odd / even and first / second halves of the poses, and
//! the check in the prediction space that raises the predicted 95 % bounds;
//! `flexcal::calib::SplitCheck`) and the cross-series check
//! (`result.cross_check(other)`: the same unknowns identified again on
//! another set and compared; `flexcal::calib::CrossCheck`).

use std::sync::Arc;

use flexcal::calib::{CrossCheck, CrossEstimate, SplitCheck, UnknownEstimate};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// What `calibrate(..., split_check=True)` found (either kind of set)
/// on halves of the poses: the spread of each identified unknown against
/// its standard error, and the factor by which the predicted positions'
/// covariance understates (`prediction_ratio`), which raises every
/// predicted 95 % bound of the result.
#[pyclass(frozen, module = "flexcal", name = "SplitCheckResult")]
#[derive(Debug, Clone)]
pub struct SplitCheckResult {
    check: Arc<SplitCheck>,
    /// SI value of one display unit, per compared unknown.
    scales: Arc<Vec<f64>>,
}

impl SplitCheckResult {
    /// The check of an identification whose unknowns are `unknowns`.
    pub(crate) fn new(check: Arc<SplitCheck>, unknowns: &[UnknownEstimate]) -> Self {
        let scales = si_scales(check.unknowns.iter().map(|s| s.name.as_str()), unknowns);
        Self {
            check,
            scales: Arc::new(scales),
        }
    }

    /// Name -> value of each compared unknown, SI.
    fn by_name<'py>(
        &self,
        py: Python<'py>,
        value: impl Fn(&flexcal::calib::SplitEstimate) -> Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for (s, scale) in self.check.unknowns.iter().zip(self.scales.iter()) {
            if let Some(v) = value(s) {
                dict.set_item(&s.name, v * scale)?;
            }
        }
        Ok(dict)
    }
}

#[pymethods]
impl SplitCheckResult {
    /// `sqrt(sum |d_k|^2 / 4 / sum tr(J_k Sigma J_k^T))` over the poses and
    /// the two splits: about 1 when the standard errors hold, above 1 the
    /// factor by which they understate the predicted positions'
    /// uncertainty (None without a covariance).
    #[getter]
    fn prediction_ratio(&self) -> Option<f64> {
        self.check.prediction_ratio
    }

    /// Name -> split error (RMS of half the differences of the two
    /// complementary pairs), SI units of the unknown; unknowns that some
    /// half did not identify are left out.
    #[getter]
    fn split_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.by_name(py, |s| s.split_error)
    }

    /// Name -> standard error of the full identification, SI units.
    #[getter]
    fn standard_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.by_name(py, |s| Some(s.standard_error))
    }

    /// Name -> split error / standard error (dimensionless; above 2.5 the
    /// standard error understates).
    #[getter]
    fn ratios<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for s in &self.check.unknowns {
            if let Some(r) = s.ratio {
                dict.set_item(&s.name, r)?;
            }
        }
        Ok(dict)
    }

    /// What the check found, in sentences.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.check.notes()
    }

    fn __repr__(&self) -> String {
        format!(
            "SplitCheckResult({} unknowns compared, prediction ratio {})",
            self.check.unknowns.len(),
            self.check
                .prediction_ratio
                .map_or("none".to_string(), |r| format!("{r:.2}"))
        )
    }
}

/// SI value of one display unit of each unknown named in `names`, from the
/// identification's `unknowns` (NaN for a name it lacks).
fn si_scales<'a>(names: impl Iterator<Item = &'a str>, unknowns: &[UnknownEstimate]) -> Vec<f64> {
    names
        .map(|name| {
            unknowns
                .iter()
                .find(|u| u.name == name)
                .map_or(f64::NAN, |u| 1.0 / u.kind.display_unit().1)
        })
        .collect()
}

/// What `result.cross_check(other)` found: each unknown the identification
/// identified, identified again on the other set (its measurement frame
/// registered anew) and compared in combined standard errors (`z`; with the
/// split-half check, `z_split` with each standard error raised to its split
/// error where larger). `|z|` above 3 names a value that does not transfer.
#[pyclass(frozen, module = "flexcal", name = "CrossCheckResult")]
#[derive(Debug, Clone)]
pub struct CrossCheckResult {
    check: Arc<CrossCheck>,
    scales: Arc<Vec<f64>>,
}

impl CrossCheckResult {
    /// The check of an identification whose unknowns are `unknowns`.
    pub(crate) fn new(check: CrossCheck, unknowns: &[UnknownEstimate]) -> Self {
        let scales = si_scales(check.unknowns.iter().map(|u| u.name.as_str()), unknowns);
        Self {
            check: Arc::new(check),
            scales: Arc::new(scales),
        }
    }

    /// Name -> `value(estimate)` of each compared unknown, times its SI
    /// scale when `si`.
    fn by_name<'py>(
        &self,
        py: Python<'py>,
        si: bool,
        value: impl Fn(&CrossEstimate) -> Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for (u, scale) in self.check.unknowns.iter().zip(self.scales.iter()) {
            if let Some(v) = value(u) {
                dict.set_item(&u.name, if si { v * scale } else { v })?;
            }
        }
        Ok(dict)
    }
}

#[pymethods]
impl CrossCheckResult {
    /// Name -> value identified on the identification set, SI units.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.by_name(py, true, |u| Some(u.value))
    }

    /// Name -> value identified on the other set, SI units (left out
    /// where the other set does not identify it).
    #[getter]
    fn other_values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.by_name(py, true, |u| u.other_value)
    }

    /// Name -> `(other - value) / sqrt(se^2 + se_other^2)`.
    #[getter]
    fn z<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.by_name(py, false, |u| u.z)
    }

    /// Name -> `z` with each standard error raised to its split error where
    /// larger (with the split-half check).
    #[getter]
    fn z_split<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.by_name(py, false, |u| u.z_split)
    }

    /// The unknowns whose judged `|z|` (`z_split` when known) exceeds 3.
    #[getter]
    fn disagreeing(&self) -> Vec<String> {
        self.check.disagreeing().map(|u| u.name.clone()).collect()
    }

    /// Poses of the other set.
    #[getter]
    fn other_poses(&self) -> usize {
        self.check.other_poses
    }

    /// What the check found, in sentences.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.check.notes()
    }

    fn __repr__(&self) -> String {
        format!(
            "CrossCheckResult({} unknowns compared on {} poses of {}, {} disagreeing)",
            self.check.unknowns.len(),
            self.check.other_poses,
            self.check.other_set,
            self.check.disagreeing().count()
        )
    }
}
