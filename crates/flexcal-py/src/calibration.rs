//! `flexcal.calibrate` and its result: the identification of a robot from
//! a measurement set, with the fields of the JSON report.

use std::path::PathBuf;
use std::sync::Arc;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::calib::{
    Calibration, CalibrationOptions, CalibrationReportJson, CancelToken, CrossCheck,
    ErrorStatistics as Stats, FrameTreatment, GravityCompliance, Method, SelectionMethod,
    SelectionOptions, SelectionReport, SplitCheck, UnknownStatus, ValidationReport, Weighting,
    calibrate_selected,
};
use flexcal::kinematics::Model;
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{exact, to_numpy};
use crate::errors::{Failure, InputError, calib_error};
use crate::interrupt::{run_cancellable, run_interruptible};
use crate::measurement::{MeasurementSet, Origin};
use crate::robot::Robot;

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

/// The result of `calibrate`: the identified unknowns and what the poses
/// could identify, the fields of the JSON report in SI units, the
/// calibrated robot, validation on another set and the JSON report itself.
#[pyclass(frozen, module = "flexcal", name = "CalibrationResult")]
#[derive(Debug)]
pub struct CalibrationResult {
    calibration: Arc<Calibration>,
    nominal: Arc<Model>,
    calibrated: Robot,
    selection: Option<Arc<SelectionReport>>,
    station_hold_out: Arc<Vec<flexcal::calib::StationHoldOut>>,
    split: Option<Arc<SplitCheck>>,
    /// The options of the identified (selected) model, for the checks that
    /// identify it again.
    options: Arc<CalibrationOptions>,
}

impl CalibrationResult {
    /// The result of a calibration run of the facade (a campaign's), the
    /// robot `nominal`, calibrated as `calibrated`.
    pub(crate) fn from_run(
        run: flexcal::calibration::CalibrationRun,
        nominal: Arc<Model>,
        calibrated: Robot,
    ) -> Self {
        Self {
            calibration: Arc::new(run.calibration),
            nominal,
            calibrated,
            selection: run.selection.map(Arc::new),
            station_hold_out: Arc::new(run.station_hold_out),
            split: run.split.map(Arc::new),
            options: Arc::new(run.options),
        }
    }
}

#[pymethods]
impl CalibrationResult {
    /// The calibrated robot (its nominal values are the identified ones).
    #[getter]
    fn robot(&self) -> Robot {
        self.calibrated.clone()
    }

    /// The split-half check (`split_check=True`), or None. Its prediction
    /// ratio raises the bounds of `predicted_accuracy` and
    /// `accuracy_coverage` where it is above 1.
    #[getter]
    fn split_check(&self) -> Option<crate::checks::SplitCheckResult> {
        self.split.as_ref().map(|check| {
            crate::checks::SplitCheckResult::new(Arc::clone(check), &self.calibration.unknowns)
        })
    }

    /// The model selection that chose the identified groups of unknowns
    /// (`select="cv"` or `"bic"`), or None without selection.
    #[getter]
    fn selection(&self) -> Option<SelectionResult> {
        self.selection.as_ref().map(|report| SelectionResult {
            report: Arc::clone(report),
        })
    }

    /// `"geometric"` or `"elasto-geometric"`.
    #[getter]
    fn model(&self) -> &'static str {
        if self.calibration.elastic.is_some() {
            "elasto-geometric"
        } else {
            "geometric"
        }
    }

    /// Every unknown (robot parameters, measurement frame, target, and for
    /// the elasto-geometric model compliances and payload).
    #[getter]
    fn parameters(&self) -> Vec<UnknownEstimate> {
        unknown_estimates(&self.calibration.unknowns)
    }

    /// Identified value of every unknown by name (SI units).
    #[getter]
    fn identified<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for u in &self.calibration.unknowns {
            d.set_item(&u.name, u.value)?;
        }
        Ok(d)
    }

    /// Standard error of every identified unknown by name (SI units).
    #[getter]
    fn standard_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for u in &self.calibration.unknowns {
            if let Some(s) = u.standard_error {
                d.set_item(&u.name, s)?;
            }
        }
        Ok(d)
    }

    /// What the identification poses cover of each actuated coordinate, by
    /// name: `(lo, hi)` (rad or m); for a revolute coordinate the arc from
    /// `lo` to `hi` of the circle (the model is 2 pi-periodic in it).
    #[getter]
    fn actuated_ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        ranges_by_name(py, &self.calibration, &self.calibration.actuated_ranges)
    }

    /// Span `(lo, hi)` of each actuated coordinate's gravity torque over the
    /// identification poses (N.m, or N), by name: the torques the joint
    /// compliances were identified over. Empty for the geometric model.
    #[getter]
    fn torque_ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        ranges_by_name(py, &self.calibration, &self.calibration.torque_ranges)
    }

    /// Number of identified unknowns.
    #[getter]
    fn rank(&self) -> usize {
        self.calibration.rank()
    }

    /// Number of unknowns in the model (robot + 6 frame + 6 target, ...).
    #[getter]
    fn n_unknowns(&self) -> usize {
        self.calibration.unknowns.len()
    }

    /// Free unknowns considered (not fixed, with influence).
    #[getter]
    fn n_free(&self) -> usize {
        self.calibration.identifiability.names.len()
    }

    /// Unknowns beyond the numerical rank (kept at nominal).
    #[getter]
    fn non_identifiable(&self) -> Vec<String> {
        self.calibration
            .non_identifiable()
            .into_iter()
            .map(String::from)
            .collect()
    }

    /// Unknowns kept at nominal because their standard error would exceed the limit.
    #[getter]
    fn poorly_identifiable(&self) -> Vec<String> {
        self.calibration
            .poorly_identifiable()
            .into_iter()
            .map(String::from)
            .collect()
    }

    /// The combinations the identified unknowns stand for (like (C.1)), as text.
    #[getter]
    fn combinations(&self) -> Vec<String> {
        self.calibration.combination_lines.clone()
    }

    /// The same combinations as terms: identified name -> [(absorbed
    /// name, coefficient)], `name_id = name + sum coefficient * absorbed`,
    /// coefficients in SI units (m per m, m per rad, ...).
    #[getter]
    fn combination_terms<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for c in &self.calibration.combinations {
            d.set_item(&c.name, c.terms.clone())?;
        }
        Ok(d)
    }

    /// What the poses could not identify, in sentences.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.calibration.identifiability_notes()
    }

    /// Repeated readings and suspect poses of the identification set
    /// (errors above four times the RMS after the fit), in sentences; empty
    /// when the data pass both checks.
    #[getter]
    fn data_checks(&self) -> Vec<String> {
        self.calibration.data_checks.notes("identification")
    }

    /// Condition number of the scaled base columns.
    #[getter]
    fn condition_number(&self) -> f64 {
        self.calibration.solve.condition_number
    }

    /// Singular values of the scaled, weighted Jacobian of the identified unknowns.
    #[getter]
    fn singular_values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let s = self.calibration.solve.singular_values.clone();
        let n = s.len();
        to_numpy(py, s, &[n])
    }

    /// The solver's termination reason.
    #[getter]
    fn termination(&self) -> String {
        format!("{:?}", self.calibration.solve.termination)
    }

    /// Whether the termination is a convergence test.
    #[getter]
    fn converged(&self) -> bool {
        self.calibration.solve.termination.is_converged()
    }

    /// Iterations of the final solve.
    #[getter]
    fn iterations(&self) -> usize {
        self.calibration.solve.iterations
    }

    /// Cost 1/2 ||W r||^2 at the start and after each iteration, every solve
    /// in order (Figure 7's data), shape (k,).
    #[getter]
    fn cost_history<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let h = self.calibration.cost_history.clone();
        let n = h.len();
        to_numpy(py, h, &[n])
    }

    /// RMS position error (m) at the same iterates, shape (k,).
    #[getter]
    fn position_rms_history<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let h: Vec<f64> = self
            .calibration
            .residual_history
            .iter()
            .map(|h| h.position_rms)
            .collect();
        let n = h.len();
        to_numpy(py, h, &[n])
    }

    /// Errors on the identification set with the nominal robot (frames registered).
    #[getter]
    fn before(&self) -> ErrorStatistics {
        (&self.calibration.training_before).into()
    }

    /// Errors on the identification set after identification.
    #[getter]
    fn after(&self) -> ErrorStatistics {
        (&self.calibration.training_after).into()
    }

    /// With `hold_out_stations=True`: each station held out in turn,
    /// `(station, chosen groups or None, errors before, errors after)` on
    /// its poses with the robot identified on the other stations (empty
    /// otherwise).
    #[getter]
    #[allow(clippy::type_complexity)]
    fn station_hold_out(&self) -> Vec<HoldOutRow> {
        hold_out_rows(&self.station_hold_out)
    }

    /// Errors after identification of each station's poses, by station
    /// name (one entry for a set of one station).
    #[getter]
    fn station_errors(&self) -> Vec<(String, ErrorStatistics)> {
        self.calibration
            .station_names
            .iter()
            .zip(&self.calibration.station_errors)
            .map(|(name, errors)| (name.clone(), errors.into()))
            .collect()
    }

    /// Position error of every identification pose after identification,
    /// shape (n,), m.
    #[getter]
    fn position_errors<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let errors: Vec<f64> = self
            .calibration
            .observation_errors
            .iter()
            .map(|e| e.error.norm())
            .collect();
        let n = errors.len();
        to_numpy(py, errors, &[n])
    }

    /// The identified measurement frame x_meas_base (4 x 4, m); of the
    /// first station when the set has several.
    #[getter]
    fn measurement_frame<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        matrix(py, &self.calibration.x_meas_base)
    }

    /// The identified measurement frame of every station (4 x 4, m), by
    /// station name; one entry for a set of one station.
    #[getter]
    fn station_frames<'py>(&self, py: Python<'py>) -> Vec<(String, Bound<'py, PyArrayDyn<f64>>)> {
        std::iter::once(&self.calibration.x_meas_base)
            .chain(&self.calibration.station_frames)
            .zip(&self.calibration.station_names)
            .map(|(frame, name)| (name.clone(), matrix(py, frame)))
            .collect()
    }

    /// The identified target pose in the TCP frame x_tcp_target (4 x 4, m).
    #[getter]
    fn target<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        matrix(py, &self.calibration.x_tcp_target())
    }

    /// Errors of the calibrated robot on another set: only the measurement
    /// frame (and with `refit_target` the target position) is re-fitted on
    /// it, the robot frozen. Releases the GIL; Ctrl-C interrupts the wait.
    #[pyo3(signature = (other, refit_target = false))]
    fn validate(
        &self,
        py: Python<'_>,
        other: &MeasurementSet,
        refit_target: bool,
    ) -> PyResult<ValidationResult> {
        let calibration = Arc::clone(&self.calibration);
        let model = Arc::clone(&self.nominal);
        let set = Arc::clone(&other.set);
        let report = run_interruptible(py, move || {
            Ok(calibration.validate(&model, &set, refit_target)?)
        })?;
        Ok(ValidationResult {
            report: Arc::new(report),
        })
    }

    /// The cross-series check on `other`: the unknowns this identification
    /// identified, identified again on `other` (its measurement frame
    /// registered anew, everything else at its start) and compared in
    /// combined standard errors; with this result's split-half check, the
    /// other set gets one too (`z_split`). Runs without the GIL; Ctrl-C
    /// stops it within one solver iteration.
    fn cross_check(
        &self,
        py: Python<'_>,
        other: &MeasurementSet,
    ) -> PyResult<crate::checks::CrossCheckResult> {
        let calibration = Arc::clone(&self.calibration);
        let model = Arc::clone(&self.nominal);
        let set = Arc::clone(&other.set);
        let split = self.split.clone();
        let (options, cancel) = cancellable(&self.options);
        let check = run_cancellable(py, Some(cancel), move || {
            Ok(CrossCheck::new(
                &model,
                &*set,
                &options,
                &calibration,
                split.as_deref(),
            )?)
        })?;
        Ok(crate::checks::CrossCheckResult::new(
            check,
            &self.calibration.unknowns,
        ))
    }

    /// Predicted 95 % bound of the position error at each configuration of
    /// `q` (rad or m; shape (dof,) or (n, dof)): the identification's
    /// covariance, conditioned on the measurement frame, carried to the
    /// target position, with the training residuals' scatter.
    fn predicted_accuracy(
        &self,
        q: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    ) -> PyResult<crate::accuracy::AccuracyResult> {
        let q = crate::arrays::rows("q", &q, self.nominal.n_actuated())?;
        crate::accuracy::predicted(&self.calibration, &self.nominal, &q, self.split.as_deref())
    }

    /// The predicted 95 % bounds at the poses of `other` with their
    /// measured errors after calibration (the measurement frame re-fitted
    /// as in `validate`) and the share within the bound. Releases the GIL;
    /// Ctrl-C interrupts the wait.
    fn accuracy_coverage(
        &self,
        py: Python<'_>,
        other: &MeasurementSet,
    ) -> PyResult<crate::accuracy::AccuracyResult> {
        let calibration = Arc::clone(&self.calibration);
        let model = Arc::clone(&self.nominal);
        let set = Arc::clone(&other.set);
        let split = self.split.clone();
        run_interruptible(py, move || {
            Ok(crate::accuracy::coverage(
                &calibration,
                &model,
                &set,
                split.as_deref(),
            )?)
        })
    }

    /// The JSON report, as `flexcal calibrate --report` writes it (mm and
    /// deg at this boundary), with the validation when given.
    #[pyo3(signature = (validation = None))]
    fn to_json(&self, validation: Option<&ValidationResult>) -> PyResult<String> {
        let mut report = CalibrationReportJson::new(
            self.nominal.name(),
            &self.calibration,
            validation.map(|v| v.report.as_ref()),
        );
        report.selection = self.selection.as_deref().cloned();
        report.station_hold_out = self
            .station_hold_out
            .iter()
            .map(flexcal::calib::StationHoldOutJson::from)
            .collect();
        report.to_json_string().map_err(|e| calib_error(&e))
    }

    fn __repr__(&self) -> String {
        format!(
            "CalibrationResult(robot={:?}, rank {} of {}, identification mean {:.4} mm after, {:.4} mm before)",
            self.nominal.name(),
            self.calibration.rank(),
            self.calibration.unknowns.len(),
            self.calibration.training_after.position_mean * 1e3,
            self.calibration.training_before.position_mean * 1e3
        )
    }
}

/// Identifies the robot's parameters (and the measurement frame and target
/// offset unless fixed) from a measurement set: equations (7)-(12) and
/// (49)-(53) of Marie, Courteille, Maurine 2013.
///
/// Options (SI units): `model` `"geometric"` or `"elasto-geometric"` (joint
/// compliances under gravity and the payload; mass table built in for the
/// UR10, else `masses`, a TOML file); `fix` names kept at nominal; `defer`
/// names left out of the base set first; `method` `"lm"` or `"gn"`;
/// `weights` `"file"` or `"uniform"` (default: uniform for the IPA format,
/// else file); `use_orientation` (default: the data's, positions only for
/// the IPA format); `fixed_frame`, `fixed_target`; `target` (3,) starting
/// target position in the end frame (m); `max_se_length` (m, default 5e-3)
/// and `max_se_angle` (rad, default 0.25 deg) for the noise-aware rank;
/// `strict` fails on rank deficiency; `max_iterations`; `select` the model
/// selection of `flexcal calibrate --select`: `"cv"` (cross-validation over
/// the poses), `"bic"` or `"none"` (every group of unknowns the options
/// allow, the identifiability analysis alone deciding); by default, as on the
/// command line, `"cv"` from 100 poses and `"none"` below; its report in
/// `result.selection`. `hold_out_stations` (a set of several stations,
/// `MeasurementSet.pooled`): also each station held out in turn, identified
/// on the others and validated on it (`result.station_hold_out`).
/// `select_on`: which cross-validated score the selection chooses on,
/// `"interpolation"`, `"extrapolation"` or `"auto"` (default: the
/// extrapolating folds when `region`, configurations (n, n_actuated) in rad
/// or m where the calibrated robot is to be used, leaves the training
/// poses' range; without `region`, the ordinary folds).
/// `split_check`: identify again on odd / even and first / second halves of
/// the poses (four more identifications; `result.split_check`), which
/// raises the predicted 95 % bounds where the standard errors understate.
/// `max_se_compliance` (rad/N.m, default 1e-3), `min_compliance_z` (default
/// 2) and `noise` (the instrument's, m per position axis; default: from the
/// file or the fit): see `judgement_options`.
///
/// Runs without the GIL; Ctrl-C returns at once with `KeyboardInterrupt`
/// and stops the identification within one solver iteration.
#[pyfunction]
#[pyo3(signature = (robot, data, model = "geometric", fix = Vec::new(), defer = None, method = "lm", weights = None, use_orientation = None, fixed_frame = false, fixed_target = false, target = None, max_se_length = None, max_se_angle = None, strict = false, masses = None, max_iterations = None, select = None, hold_out_stations = false, split_check = false, max_se_compliance = None, min_compliance_z = None, noise = None, select_on = None, region = None))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate<'py>(
    py: Python<'py>,
    robot: &Robot,
    data: &MeasurementSet,
    model: &str,
    fix: Vec<String>,
    defer: Option<Vec<String>>,
    method: &str,
    weights: Option<&str>,
    use_orientation: Option<bool>,
    fixed_frame: bool,
    fixed_target: bool,
    target: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    max_se_length: Option<f64>,
    max_se_angle: Option<f64>,
    strict: bool,
    masses: Option<PathBuf>,
    max_iterations: Option<usize>,
    select: Option<&str>,
    hold_out_stations: bool,
    split_check: bool,
    max_se_compliance: Option<f64>,
    min_compliance_z: Option<f64>,
    noise: Option<f64>,
    select_on: Option<&str>,
    region: Option<Vec<Vec<f64>>>,
) -> PyResult<CalibrationResult> {
    let nominal = Arc::clone(&robot.model);
    let mut selection = selection_options(select, data.set.len())?;
    if let Some(name) = select_on {
        selection.select_on = name
            .parse()
            .map_err(|e: String| InputError::new_err(format!("select_on: {e}")))?;
    }
    if let Some(region) = region {
        let na = nominal.n_actuated();
        if let Some((k, q)) = region
            .iter()
            .enumerate()
            .find(|(_, q)| q.len() != na || !q.iter().all(|v| v.is_finite()))
        {
            return Err(InputError::new_err(format!(
                "region: row {k} has {} values, expected {na} finite ones (rad or m)",
                q.len()
            )));
        }
        selection.region = region;
    }
    let mut options = CalibrationOptions::for_model(&nominal);
    options.method = match method {
        "lm" => Method::LevenbergMarquardt,
        "gn" => Method::GaussNewton,
        other => {
            return Err(InputError::new_err(format!(
                "method: expected \"lm\" or \"gn\", got {other:?}"
            )));
        }
    };
    let weights = weights.unwrap_or(match data.origin {
        Origin::Own => "file",
        Origin::Ipa => "uniform",
    });
    options.weighting = match weights {
        "file" => Weighting::FromFile,
        "uniform" => Weighting::Uniform,
        other => {
            return Err(InputError::new_err(format!(
                "weights: expected \"file\" or \"uniform\", got {other:?}"
            )));
        }
    };
    options.use_orientation = match (use_orientation, data.origin) {
        (Some(u), _) => Some(u),
        (None, Origin::Ipa) => Some(false),
        (None, Origin::Own) => None,
    };
    options.fixed = fix;
    if let Some(defer) = defer {
        options.deferred = defer;
    }
    if fixed_frame {
        options.measurement_frame = FrameTreatment::Fixed;
    }
    if fixed_target {
        options.target = FrameTreatment::Fixed;
    }
    if let Some(target) = target {
        let (t, _) = exact("target", &target, &[Some(3)])?;
        let rotation = data
            .set
            .nominal_target
            .map(|t| t.rotation)
            .unwrap_or_else(UnitQuaternion::identity);
        options.target_value = Some(Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            rotation,
        ));
    }
    for (name, value) in [
        ("max_se_length", max_se_length),
        ("max_se_angle", max_se_angle),
    ] {
        if let Some(v) = value {
            if !(v.is_finite() && v > 0.0) {
                return Err(InputError::new_err(format!(
                    "{name}: must be finite and > 0, got {v}"
                )));
            }
        }
    }
    if let Some(v) = max_se_length {
        options.max_standard_error_length = v;
    }
    if let Some(v) = max_se_angle {
        options.max_standard_error_angle = v;
    }
    if let Some(n) = max_iterations {
        options.max_iterations = n;
    }
    options.require_full_rank = strict;
    options.gravity = gravity_option(model, masses, &nominal)?;
    judgement_options(&mut options, max_se_compliance, min_compliance_z, noise)?;
    let cancel = CancelToken::new();
    options.cancel = Some(cancel.clone());
    let set = Arc::clone(&data.set);
    let model = Arc::clone(&nominal);
    let (calibration, selection, calibrated, held, split, chosen) =
        run_cancellable(py, Some(cancel), move || {
            let (calibration, report, chosen) =
                calibrate_selected(&model, &*set, &options, &selection)?;
            let split = split_check
                .then(|| SplitCheck::new(&model, &*set, &chosen, &calibration))
                .transpose()?;
            let calibrated = calibration
                .description(&model)?
                .build()
                .map_err(Failure::Kinematics)?;
            let held = if hold_out_stations {
                flexcal::calib::hold_out_stations(&model, &*set, &options, &selection)?
            } else {
                Vec::new()
            };
            Ok((calibration, report, calibrated, held, split, chosen))
        })?;
    Ok(CalibrationResult {
        calibration: Arc::new(calibration),
        nominal,
        calibrated: Robot::new(calibrated),
        selection: selection.map(Arc::new),
        station_hold_out: Arc::new(held),
        split: split.map(Arc::new),
        options: Arc::new(chosen),
    })
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

/// `{coordinate name: (lo, hi)}` of per-coordinate coverages of a calibration
/// (empty when `ranges` is).
fn ranges_by_name<'py>(
    py: Python<'py>,
    calibration: &Calibration,
    ranges: &[flexcal::calib::CoordinateCoverage],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, r) in calibration.actuated_names.iter().zip(ranges) {
        d.set_item(name, (r.lo, r.hi))?;
    }
    Ok(d)
}
