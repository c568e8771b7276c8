//! `flexcal.calibrate` and its result: the identification of a robot from
//! a measurement set, with the fields of the JSON report.

use std::path::PathBuf;
use std::sync::Arc;

use flexcal::calib::{
    CalibrationOptions, CancelToken, ErrorStatistics as Stats, GravityCompliance, SelectionMethod,
    SelectionOptions, SelectionReport, UnknownStatus, ValidationReport,
};
use flexcal::kinematics::Model;
use nalgebra::Isometry3;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::to_numpy;
use crate::errors::{InputError, calib_error};

/// Mean, RMS and maximum of the pose errors of a set (m, rad).
#[pyclass(frozen, module = "flexcal", name = "ErrorStatistics", get_all)]
#[derive(Debug, Clone)]
pub struct ErrorStatistics {
    /// Number of poses.
    pub n_poses: usize,
    /// Mean position error (m).
    pub position_mean: f64,
    /// RMS position error (m).
    pub position_rms: f64,
    /// Maximum position error (m).
    pub position_max: f64,
    /// Mean orientation error (rad), when orientations are used.
    pub orientation_mean: Option<f64>,
    /// RMS orientation error (rad), when orientations are used.
    pub orientation_rms: Option<f64>,
    /// Maximum orientation error (rad), when orientations are used.
    pub orientation_max: Option<f64>,
}

impl From<&Stats> for ErrorStatistics {
    fn from(s: &Stats) -> Self {
        let o = s.orientation_mean_rms_max;
        Self {
            n_poses: s.n_poses,
            position_mean: s.position_mean,
            position_rms: s.position_rms,
            position_max: s.position_max,
            orientation_mean: o.map(|o| o.0),
            orientation_rms: o.map(|o| o.1),
            orientation_max: o.map(|o| o.2),
        }
    }
}

#[pymethods]
impl ErrorStatistics {
    fn __repr__(&self) -> String {
        format!(
            "ErrorStatistics(n_poses={}, position mean/rms/max = {:.4} / {:.4} / {:.4} mm)",
            self.n_poses,
            self.position_mean * 1e3,
            self.position_rms * 1e3,
            self.position_max * 1e3
        )
    }
}

/// One unknown of the identification (SI units).
#[pyclass(frozen, module = "flexcal", name = "UnknownEstimate", get_all)]
#[derive(Debug, Clone)]
pub struct UnknownEstimate {
    /// Name (a robot parameter, `frame_x..frame_rz`, `target_x..target_rz`,
    /// `compliance_<joint>`, `payload_mass`, `payload_mx..mz`).
    pub name: String,
    /// SI unit: `m`, `rad`, `rad/N.m` (`m/N` for a linear joint), `kg`, `kg.m`.
    pub unit: &'static str,
    /// Starting (nominal) value.
    pub nominal: f64,
    /// Identified value (the nominal one unless identified).
    pub identified: f64,
    /// `identified - nominal`.
    pub delta: f64,
    /// Standard error (identified unknowns only).
    pub standard_error: Option<f64>,
    /// Standard error over the one of as many poses spread over the joint
    /// ranges (identified unknowns only).
    pub spread_ratio: Option<f64>,
    /// `identified`, `fixed`, `non-identifiable`, `poorly-identifiable` or `no-influence`.
    pub status: &'static str,
}

#[pymethods]
impl UnknownEstimate {
    fn __repr__(&self) -> String {
        format!(
            "UnknownEstimate(name={:?}, identified={} {}, standard_error={:?}, status={:?})",
            self.name, self.identified, self.unit, self.standard_error, self.status
        )
    }
}

/// The Python view of the library's unknowns.
pub(crate) fn unknown_estimates(
    unknowns: &[flexcal::calib::UnknownEstimate],
) -> Vec<UnknownEstimate> {
    unknowns
        .iter()
        .map(|u| UnknownEstimate {
            name: u.name.clone(),
            unit: u.kind.si_unit(),
            nominal: u.initial,
            identified: u.value,
            delta: u.value - u.initial,
            standard_error: u.standard_error,
            spread_ratio: u.spread_ratio,
            status: UnknownStatus::name(u.status),
        })
        .collect()
}

/// The compliances' judgement and the noise, as `flexcal calibrate`'s
/// `--max-se-compliance`, `--min-compliance-z` and `--noise-mm` set them,
/// in SI: an absolute standard-error limit (rad/N.m), the z a compliance
/// needs to be kept, the instrument's noise per position axis (m).
pub(crate) fn judgement_options(
    options: &mut CalibrationOptions,
    max_se_compliance: Option<f64>,
    min_compliance_z: Option<f64>,
    noise: Option<f64>,
) -> PyResult<()> {
    let positive = |name: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(InputError::new_err(format!(
                "{name}: must be finite and > 0, got {v}"
            )))
        }
    };
    if let Some(v) = max_se_compliance {
        options.max_standard_error_compliance = positive("max_se_compliance", v)?;
    }
    if let Some(v) = min_compliance_z {
        options.min_compliance_z = positive("min_compliance_z", v)?;
    }
    if let Some(v) = noise {
        options.instrument_noise = Some(flexcal::calib::InstrumentNoise {
            position_std: positive("noise", v)?,
            orientation_std: None,
        });
    }
    Ok(())
}

/// The position error norm of every pose, shape (n,), m.
fn position_norms<'py>(
    py: Python<'py>,
    errors: &[flexcal::calib::PoseError],
) -> Bound<'py, PyArrayDyn<f64>> {
    let e: Vec<f64> = errors.iter().map(|e| e.position).collect();
    to_numpy(py, e, &[errors.len()])
}

pub(crate) fn matrix<'py>(py: Python<'py>, x: &Isometry3<f64>) -> Bound<'py, PyArrayDyn<f64>> {
    let m = x.to_homogeneous().transpose();
    to_numpy(py, m.as_slice().to_vec(), &[4, 4])
}

/// `{target name: ErrorStatistics}`.
pub(crate) fn per_target<'py>(
    py: Python<'py>,
    errors: &[flexcal::calib::TargetErrors],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for e in errors {
        d.set_item(&e.target, ErrorStatistics::from(&e.statistics))?;
    }
    Ok(d)
}

/// `([(pose, target)], errors (n_observations, 3) in m)`: measured minus
/// predicted position of every observation, in the measurement frame.
pub(crate) fn observation_errors<'py>(
    py: Python<'py>,
    errors: &[flexcal::calib::ObservationError],
) -> (Vec<(String, String)>, Bound<'py, PyArrayDyn<f64>>) {
    let labels = errors
        .iter()
        .map(|e| (e.pose.clone(), e.target.clone()))
        .collect();
    let values = errors
        .iter()
        .flat_map(|e| e.error.iter().copied())
        .collect();
    (labels, to_numpy(py, values, &[errors.len(), 3]))
}

/// Errors of a calibrated robot on another measurement set (validation).
#[pyclass(frozen, module = "flexcal", name = "ValidationResult")]
#[derive(Debug, Clone)]
pub struct ValidationResult {
    pub(crate) report: Arc<ValidationReport>,
}

#[pymethods]
impl ValidationResult {
    /// Errors with the nominal robot (its frames fitted to this set).
    #[getter]
    fn before(&self) -> ErrorStatistics {
        (&self.report.before).into()
    }

    /// Errors with the calibrated robot.
    #[getter]
    fn after(&self) -> ErrorStatistics {
        (&self.report.after).into()
    }

    /// Position error of every pose after calibration, shape (n,), m.
    #[getter]
    fn position_errors<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        position_norms(py, &self.report.after_per_pose)
    }

    /// `measured - predicted` position of every pose after calibration, in
    /// the measurement frame, shape (n, 3), m.
    #[getter]
    fn error_vectors<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let e: Vec<f64> = self
            .report
            .after_per_pose
            .iter()
            .flat_map(|e| {
                [
                    e.position_vector.x,
                    e.position_vector.y,
                    e.position_vector.z,
                ]
            })
            .collect();
        to_numpy(py, e, &[self.report.after_per_pose.len(), 3])
    }

    /// The measurement frame x_meas_base used for the errors after (4 x 4, m).
    #[getter]
    fn measurement_frame<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        matrix(py, &self.report.measurement_frame)
    }

    /// How the measurement frame was obtained, in words.
    #[getter]
    fn note(&self) -> String {
        self.report.frame_note.clone()
    }

    /// Repeated readings and suspect poses of the set (errors above four
    /// times the RMS after calibration), in sentences; empty when the data
    /// pass both checks.
    #[getter]
    fn data_checks(&self) -> Vec<String> {
        self.report.data_checks.notes("validation")
    }

    /// Actuated coordinates that leave the identification poses' range on
    /// some poses: (name, fraction of the poses outside).
    #[getter]
    fn extrapolated_coordinates(&self) -> Vec<(String, f64)> {
        self.report.extrapolated_coordinates.clone()
    }

    /// `{target: ErrorStatistics}` before (`tcp` for one target per pose).
    #[getter]
    fn per_target_before<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.report.per_target_before)
    }

    /// `{target: ErrorStatistics}` after.
    #[getter]
    fn per_target_after<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.report.per_target_after)
    }

    /// Whether the measurement frame was fitted again on the set.
    #[getter]
    fn frame_refitted(&self) -> bool {
        self.report.frame_refitted
    }

    /// `([(pose, target)], errors (n_observations, 3) in m)` after
    /// calibration: measured minus predicted, in the measurement frame.
    #[getter]
    fn observation_errors<'py>(
        &self,
        py: Python<'py>,
    ) -> (Vec<(String, String)>, Bound<'py, PyArrayDyn<f64>>) {
        observation_errors(py, &self.report.observation_errors)
    }

    fn __repr__(&self) -> String {
        format!(
            "ValidationResult(before mean {:.4} mm, after mean {:.4} mm, {} poses)",
            self.report.before.position_mean * 1e3,
            self.report.after.position_mean * 1e3,
            self.report.after.n_poses
        )
    }
}

/// One candidate model scored by the model selection (SI units).
#[pyclass(frozen, module = "flexcal", name = "SelectionCandidate", get_all)]
#[derive(Debug, Clone)]
pub struct SelectionCandidate {
    /// The optional groups of unknowns it identifies (`offsets`, `tilts`,
    /// `compliances`, `joint law`, `cyclic`).
    pub groups: Vec<&'static str>,
    /// `offsets + tilts`, or `base` without optional groups.
    pub label: String,
    /// Cross-validated mean position error over the held-out poses (m).
    pub cv_mean_error: Option<f64>,
    /// Its standard error, from the spread of the per-fold means (m).
    pub cv_standard_error: Option<f64>,
    /// Mean held-out position error of each fold (m).
    pub cv_fold_errors: Vec<f64>,
    /// Mean position error over the poses held out by the extrapolating
    /// folds (m; cross-validation).
    pub extrapolation_mean_error: Option<f64>,
    /// Its standard error, from the spread of the per-fold means (m).
    pub extrapolation_standard_error: Option<f64>,
    /// BIC of the full fit (dimensionless), when scored by BIC.
    pub bic: Option<f64>,
    /// Identified unknowns of the full fit (BIC) or their mean over the
    /// folds (cross-validation).
    pub identified: f64,
    /// Why it could not be scored, if it could not.
    pub failure: Option<String>,
}

#[pymethods]
impl SelectionCandidate {
    fn __repr__(&self) -> String {
        format!(
            "SelectionCandidate(label={:?}, cv_mean_error={:?}, bic={:?}, identified={})",
            self.label, self.cv_mean_error, self.bic, self.identified
        )
    }
}

/// What the model selection of `calibrate(..., select=...)` scored and
/// chose: the report `flexcal calibrate --select` prints.
#[pyclass(frozen, module = "flexcal", name = "SelectionResult")]
#[derive(Debug, Clone)]
pub struct SelectionResult {
    pub(crate) report: Arc<SelectionReport>,
}

#[pymethods]
impl SelectionResult {
    /// `"cv"` or `"bic"`.
    #[getter]
    fn method(&self) -> &'static str {
        match self.report.method {
            SelectionMethod::CrossValidation => "cv",
            SelectionMethod::Bic => "bic",
            _ => "none",
        }
    }

    /// Number of folds (cross-validation).
    #[getter]
    fn folds(&self) -> usize {
        self.report.folds
    }

    /// Poses in each fold (cross-validation).
    #[getter]
    fn fold_sizes(&self) -> Vec<usize> {
        self.report.fold_sizes.clone()
    }

    /// Every candidate scored, in the order of the search.
    #[getter]
    fn candidates(&self) -> Vec<SelectionCandidate> {
        self.report
            .candidates
            .iter()
            .map(|c| SelectionCandidate {
                groups: c.groups.iter().map(|g| g.label()).collect(),
                label: c.label(),
                cv_mean_error: c.cv_mean_error_mm.map(|e| e * 1e-3),
                cv_standard_error: c.cv_standard_error_mm.map(|e| e * 1e-3),
                cv_fold_errors: c.cv_fold_errors_mm.iter().map(|e| e * 1e-3).collect(),
                extrapolation_mean_error: c.extrapolation_mean_error_mm.map(|e| e * 1e-3),
                extrapolation_standard_error: c.extrapolation_standard_error_mm.map(|e| e * 1e-3),
                bic: c.bic,
                identified: c.identified,
                failure: c.failure.clone(),
            })
            .collect()
    }

    /// The score the search chose on: `"interpolation"` (the ordinary
    /// folds) or `"extrapolation"` (the extrapolating folds).
    #[getter]
    fn chosen_on(&self) -> &'static str {
        self.report.chosen_on.label()
    }

    /// Why that score, in one sentence.
    #[getter]
    fn chosen_on_reason(&self) -> String {
        self.report.chosen_on_reason.clone()
    }

    /// The extrapolating folds, each as `joint (which ends, N poses)`.
    #[getter]
    fn extrapolation_folds(&self) -> Vec<String> {
        self.report
            .extrapolation_folds
            .iter()
            .map(|f| f.label())
            .collect()
    }

    /// The optional groups of the chosen model (empty: the base model).
    #[getter]
    fn chosen(&self) -> Vec<&'static str> {
        self.report.chosen.iter().map(|g| g.label()).collect()
    }

    /// Why the chosen model won, one sentence per search step.
    #[getter]
    fn why(&self) -> Vec<String> {
        self.report.reasons.clone()
    }

    /// The report as text, one line per candidate, then the reasons.
    fn lines(&self) -> Vec<String> {
        self.report.lines()
    }

    fn __repr__(&self) -> String {
        format!(
            "SelectionResult(method={:?}, {} candidates, chosen={:?})",
            self.method(),
            self.report.candidates.len(),
            self.chosen()
        )
    }
}

/// One station held out, as a Python tuple: (station, groups chosen or None
/// without selection, errors before, errors after).
pub(crate) type HoldOutRow = (
    String,
    Option<Vec<String>>,
    ErrorStatistics,
    ErrorStatistics,
);

/// Each station held out, as Python tuples ([`HoldOutRow`]).
pub(crate) fn hold_out_rows(held: &[flexcal::calib::StationHoldOut]) -> Vec<HoldOutRow> {
    held.iter()
        .map(|h| {
            (
                h.station.clone(),
                h.chosen.clone(),
                (&h.before).into(),
                (&h.after).into(),
            )
        })
        .collect()
}

/// `options` with a fresh cancellation token, and the token: an
/// identification that Ctrl-C stops within one solver iteration.
pub(crate) fn cancellable(options: &CalibrationOptions) -> (CalibrationOptions, CancelToken) {
    let cancel = CancelToken::new();
    let options = CalibrationOptions {
        cancel: Some(cancel.clone()),
        ..options.clone()
    };
    (options, cancel)
}

/// The model selection of `select` (`"cv"`, `"bic"`, `"none"`; by
/// default, as on the command line, cross-validation from
/// [`flexcal::calib::MIN_POSES_FOR_CROSS_VALIDATION`] poses).
pub(crate) fn selection_options(select: Option<&str>, poses: usize) -> PyResult<SelectionOptions> {
    Ok(SelectionOptions {
        method: match select {
            None => flexcal::calib::default_method_for(poses),
            Some("cv") => SelectionMethod::CrossValidation,
            Some("bic") => SelectionMethod::Bic,
            Some("none") => SelectionMethod::None,
            Some(other) => {
                return Err(InputError::new_err(format!(
                    "select: expected \"cv\", \"bic\" or \"none\", got {other:?}"
                )));
            }
        },
        ..SelectionOptions::default()
    })
}

/// The gravity loading of `model` (`"geometric"`: none;
/// `"elasto-geometric"`: the mass table `masses`, else the robot's built-in
/// one).
pub(crate) fn gravity_option(
    model: &str,
    masses: Option<PathBuf>,
    robot: &Model,
) -> PyResult<Option<GravityCompliance>> {
    match (model, masses) {
        ("geometric", None) => Ok(None),
        ("geometric", Some(_)) => Err(InputError::new_err(
            "masses: only for model=\"elasto-geometric\"",
        )),
        ("elasto-geometric", Some(path)) => Ok(Some(
            GravityCompliance::from_toml_file(&path).map_err(|e| calib_error(&e))?,
        )),
        ("elasto-geometric", None) => Ok(Some(
            GravityCompliance::builtin(robot).map_err(|e| calib_error(&e))?,
        )),
        (other, _) => Err(InputError::new_err(format!(
            "model: expected \"geometric\" or \"elasto-geometric\", got {other:?}"
        ))),
    }
}
