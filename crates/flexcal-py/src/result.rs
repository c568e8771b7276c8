//! `flexcal.CalibrationResult`: the one result of `flexcal.calibrate`, for
//! a `MeasurementSet` of one target per pose and of several alike. The library's `Calibration` is one type
//! for both; so is this class. Its checks (`validate`, `cross_check`,
//! `accuracy_coverage`) take another set of the same kind as the one it
//! was identified from.

use std::sync::Arc;

use flexcal::calib::{
    Calibration, CalibrationOptions, CalibrationReportJson, CrossCheck, ExtrapolationModel,
    MeasurementSet as TargetSet, Refit, SelectionReport, SplitCheck, StationHoldOut,
};
use flexcal::calibration::CalibrationRun;
use flexcal::kinematics::Model;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::accuracy::{AccuracyResult, configurations};
use crate::arrays::{AllowTypeChange, PyArrayLikeDyn, to_numpy};
use crate::calibration::{
    ErrorStatistics, HoldOutRow, SelectionResult, UnknownEstimate, ValidationResult, cancellable,
    hold_out_rows, matrix, observation_errors, per_target, unknown_estimates,
};
use crate::checks::{CrossCheckResult, SplitCheckResult};
use crate::errors::{Failure, InputError, calib_error};
use crate::interrupt::{run_cancellable, run_interruptible};
use crate::measurement::MeasurementSet;
use crate::robot::Robot;

/// A measurement set of either kind, as `calibrate` and the result's
/// checks take it.
pub(crate) enum AnySet {
    /// One target per pose.
    One(
        Arc<flexcal::calib::MeasurementSet>,
        crate::measurement::Origin,
    ),
    /// Several targets per pose.
    Targets(Arc<TargetSet>),
}

impl AnySet {
    /// `object` as a set; `name` is the argument's name in the error.
    ///
    /// # Errors
    /// `InputError` naming `name` when `object` is neither kind of set.
    pub(crate) fn extract(name: &str, object: &Bound<'_, PyAny>) -> PyResult<Self> {
        if let Ok(set) = object.extract::<PyRef<'_, MeasurementSet>>() {
            return Ok(match set.origin {
                crate::measurement::Origin::Targets => Self::Targets(Arc::clone(&set.set)),
                origin => Self::One(Arc::clone(&set.set), origin),
            });
        }
        Err(InputError::new_err(format!(
            "{name}: expected a MeasurementSet, got {}",
            object.get_type().name()?
        )))
    }

    /// Number of poses.
    pub(crate) fn len(&self) -> usize {
        match self {
            Self::One(set, _) => set.len(),
            Self::Targets(set) => set.len(),
        }
    }
}

/// The result of `calibrate`: the identified unknowns and what the poses
/// could identify, the errors (per target with several), the calibrated
/// robot, validation on another set of the same kind, predicted accuracy
/// and the JSON report, in SI units.
#[pyclass(frozen, module = "flexcal", name = "CalibrationResult")]
#[derive(Debug)]
pub struct CalibrationResult {
    pub(crate) calibration: Arc<Calibration>,
    pub(crate) nominal: Arc<Model>,
    pub(crate) calibrated: Robot,
    pub(crate) selection: Option<Arc<SelectionReport>>,
    pub(crate) station_hold_out: Arc<Vec<StationHoldOut>>,
    pub(crate) split: Option<Arc<SplitCheck>>,
    /// The options of the identified (selected) model, for the checks that
    /// identify it again.
    pub(crate) options: Arc<CalibrationOptions>,
    /// The set of several targets it was identified from (its JSON report
    /// is the multi-target run's); `None` for one target per pose.
    pub(crate) targets_data: Option<Arc<TargetSet>>,
    /// The model's error growth outside the training ranges
    /// (`extrapolation=True`), added to every predicted bound.
    pub(crate) extrapolation: Option<Arc<ExtrapolationModel>>,
}

impl CalibrationResult {
    /// Whether `report` validates this result's targets (by name, in
    /// order): what `to_json` takes.
    fn same_targets(&self, report: &flexcal::calib::ValidationReport) -> bool {
        report.per_target_after.iter().map(|t| &t.target).eq(self
            .calibration
            .targets
            .iter()
            .map(|t| &t.name))
    }

    /// The result of a calibration run of the facade (a campaign's), the
    /// robot `nominal`, calibrated as `calibrated`.
    pub(crate) fn from_run(
        run: flexcal::calibration::CalibrationRun,
        nominal: Arc<Model>,
        calibrated: Robot,
    ) -> Self {
        // A set of several targets stays with the result: its JSON and
        // checks give per-target figures.
        let targets_data = run.several_targets().then(|| Arc::new(run.data));
        Self {
            calibration: Arc::new(run.calibration),
            nominal,
            calibrated,
            selection: run.selection.map(Arc::new),
            station_hold_out: Arc::new(run.station_hold_out),
            split: run.split.map(Arc::new),
            options: Arc::new(run.options),
            targets_data,
            extrapolation: None,
        }
    }

    /// `map` widened by the error growth outside the training ranges when
    /// the result has one.
    fn widened(&self, map: flexcal::calib::AccuracyMap) -> AccuracyResult {
        AccuracyResult::new(match &self.extrapolation {
            Some(growth) => map.with_extrapolation(growth),
            None => map,
        })
    }

    /// The set `other` of the kind this result was identified from.
    fn same_kind(&self, other: &Bound<'_, PyAny>) -> PyResult<AnySet> {
        let set = AnySet::extract("other", other)?;
        match (&set, self.targets_data.is_some()) {
            (AnySet::One(..), false) | (AnySet::Targets(_), true) => Ok(set),
            (AnySet::One(..), true) => Err(InputError::new_err(
                "other: a set of one target, but this calibration was identified from several targets per pose: give a MeasurementSet of the same targets (read or built with targets)",
            )),
            (AnySet::Targets(_), false) => Err(InputError::new_err(
                "other: a set with targets, but this calibration was identified from one target per pose: give a MeasurementSet of one target (read or built without targets)",
            )),
        }
    }
}

/// The names, owned (for Python).
fn owned(names: Vec<&str>) -> Vec<String> {
    names.into_iter().map(String::from).collect()
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
    fn split_check(&self) -> Option<SplitCheckResult> {
        self.split
            .as_ref()
            .map(|check| SplitCheckResult::new(Arc::clone(check), &self.calibration.unknowns))
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

    /// Every unknown: robot parameters, `frame_*`, the target offsets
    /// (`target_*` for one target, `target.<name>.x|y|z` for several),
    /// then the elastic and joint terms of the elasto-geometric model.
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

    /// Number of unknowns in the model (robot + 6 frame + the targets' offsets, ...).
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
        owned(self.calibration.non_identifiable())
    }

    /// Unknowns kept at nominal because their standard error would exceed the limit.
    #[getter]
    fn poorly_identifiable(&self) -> Vec<String> {
        owned(self.calibration.poorly_identifiable())
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

    /// Repeated readings and suspect poses (or observations) of the
    /// identification set (errors above four times the RMS after the fit),
    /// in sentences; empty when the data pass both checks.
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

    /// Trial points of the final solve the model could not evaluate (a loop
    /// that cannot close, an equilibrium that does not converge), each
    /// refused as a step that raised the cost; 0 in a smooth fit.
    #[getter]
    fn refused_trials(&self) -> usize {
        self.calibration.solve.refused_trials
    }

    /// The model's error at the last refused trial point, or None.
    #[getter]
    fn last_refusal(&self) -> Option<String> {
        self.calibration.solve.last_refusal.clone()
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

    /// With `extrapolation=True`: the model's error growth outside the
    /// training range of each actuated coordinate, by name (m per rad, or
    /// m per m), as held-out-range folds measured it; None otherwise. Every
    /// predicted bound of this result includes it.
    #[getter]
    fn extrapolation_growth<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(growth) = &self.extrapolation else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        for (name, g) in self.calibration.actuated_names.iter().zip(&growth.growth) {
            d.set_item(name, g.growth)?;
        }
        Ok(Some(d))
    }

    /// With `extrapolation=True`, the growth in sentences (`model's error
    /// grows ... outside joint ...`); empty otherwise.
    #[getter]
    fn extrapolation_notes(&self) -> Vec<String> {
        self.extrapolation
            .as_ref()
            .map(|g| g.notes())
            .unwrap_or_default()
    }

    /// Errors on the identification set with the nominal robot (frames
    /// and offsets registered), over every observation.
    #[getter]
    fn before(&self) -> ErrorStatistics {
        (&self.calibration.training_before).into()
    }

    /// Errors on the identification set after identification.
    #[getter]
    fn after(&self) -> ErrorStatistics {
        (&self.calibration.training_after).into()
    }

    /// `{target: ErrorStatistics}` before identification (one entry, `tcp`,
    /// for one target per pose).
    #[getter]
    fn per_target_before<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.calibration.per_target_before)
    }

    /// `{target: ErrorStatistics}` after identification.
    #[getter]
    fn per_target_after<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.calibration.per_target_after)
    }

    /// With `hold_out_stations=True`: each station held out in turn,
    /// `(station, chosen groups or None, errors before, errors after)` on
    /// its poses with the robot identified on the other stations (empty
    /// otherwise).
    #[getter]
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

    /// Position error norm of every observation after identification,
    /// shape (n_observations,), m (one per pose for one target per pose).
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

    /// `([(pose, target)], errors (n_observations, 3) in m)` of the
    /// identification set after identification: measured minus predicted,
    /// in the measurement frame.
    #[getter]
    fn observation_errors<'py>(
        &self,
        py: Python<'py>,
    ) -> (Vec<(String, String)>, Bound<'py, PyArrayDyn<f64>>) {
        observation_errors(py, &self.calibration.observation_errors)
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
        let c = &self.calibration;
        c.measurement_frames()
            .iter()
            .zip(&c.station_names)
            .map(|(frame, name)| (name.clone(), matrix(py, frame)))
            .collect()
    }

    /// The identified pose of the (first) target in its frame,
    /// x_tcp_target for one target on the TCP (4 x 4, m).
    #[getter]
    fn target<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        matrix(py, &self.calibration.x_tcp_target())
    }

    /// `{target: offset (3,)}` in its frame, m: identified or fixed.
    #[getter]
    fn target_offsets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for t in &self.calibration.targets {
            d.set_item(&t.name, to_numpy(py, t.offset.as_slice().to_vec(), &[3]))?;
        }
        Ok(d)
    }

    /// Errors of the calibrated robot on `other`, a set of the kind it was
    /// identified from; the robot is frozen; a `ValidationResult` (overall
    /// and per target). One target per pose: the
    /// measurement frame is fitted again, and with `refit_target` the
    /// target position too. Several targets (a set with targets):
    /// with `refit_frame` (default) the measurement frame is fitted again
    /// (the instrument was moved).
    /// Releases the GIL; Ctrl-C interrupts the wait.
    #[pyo3(signature = (other, refit_target = false, refit_frame = true))]
    fn validate(
        &self,
        py: Python<'_>,
        other: &Bound<'_, PyAny>,
        refit_target: bool,
        refit_frame: bool,
    ) -> PyResult<Py<PyAny>> {
        let calibration = Arc::clone(&self.calibration);
        let model = Arc::clone(&self.nominal);
        match self.same_kind(other)? {
            AnySet::One(set, _) => {
                if !refit_frame {
                    return Err(InputError::new_err(
                        "refit_frame: a set of one target per pose is always validated with its measurement frame fitted again",
                    ));
                }
                let report = run_interruptible(py, move || {
                    Ok(calibration.validate(&model, &set, refit_target)?)
                })?;
                let result = ValidationResult {
                    report: Arc::new(report),
                };
                Ok(Bound::new(py, result)?.into_any().unbind())
            }
            AnySet::Targets(set) => {
                if refit_target {
                    return Err(InputError::new_err(
                        "refit_target: not available with several targets per pose (their offsets stay as identified)",
                    ));
                }
                let validation = run_interruptible(py, move || {
                    let refit = if refit_frame {
                        Refit::Frames
                    } else {
                        Refit::Nothing
                    };
                    Ok(calibration.validate(&model, &set, refit)?)
                })?;
                let result = ValidationResult {
                    report: Arc::new(validation),
                };
                Ok(Bound::new(py, result)?.into_any().unbind())
            }
        }
    }

    /// The cross-series check on `other` (a set of the same kind): the
    /// unknowns this identification identified, identified again on
    /// `other` (its measurement frame registered anew, everything else at
    /// its start) and compared in combined standard errors; with this
    /// result's split-half check, the other set gets one too (`z_split`).
    /// Runs without the GIL; Ctrl-C stops it within one solver iteration.
    fn cross_check(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<CrossCheckResult> {
        let calibration = Arc::clone(&self.calibration);
        let model = Arc::clone(&self.nominal);
        let set = self.same_kind(other)?;
        let split = self.split.clone();
        let (options, cancel) = cancellable(&self.options);
        let check = run_cancellable(py, Some(cancel), move || {
            let split = split.as_deref();
            Ok(match &set {
                AnySet::One(set, _) => CrossCheck::new(&model, set, &options, &calibration, split)?,
                AnySet::Targets(set) => {
                    CrossCheck::new(&model, set, &options, &calibration, split)?
                }
            })
        })?;
        Ok(CrossCheckResult::new(check, &self.calibration.unknowns))
    }

    /// Predicted 95 % bound of the position error at each configuration of
    /// `q` (rad or m; shape (dof,) or (n, dof)), one entry per
    /// configuration and target (`AccuracyResult.targets` names them with
    /// several): the identification's covariance, conditioned on the
    /// measurement frame, carried to each target's position, with the
    /// training residuals' scatter (and the error growth outside the
    /// training ranges with `extrapolation=True`).
    fn predicted_accuracy(
        &self,
        q: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    ) -> PyResult<AccuracyResult> {
        let q = crate::arrays::rows("q", &q, self.nominal.n_actuated())?;
        let map = self
            .calibration
            .predicted_accuracy(&self.nominal, &configurations(&q), self.split.as_deref())
            .map_err(|e| calib_error(&e))?;
        Ok(self.widened(map))
    }

    /// The predicted 95 % bounds at the poses (observations) of `other`, a
    /// set of the same kind, with their measured errors after calibration
    /// (the measurement frame fitted again, as `validate` does) and the
    /// share within the bound. Releases the GIL; Ctrl-C interrupts the wait.
    fn accuracy_coverage(
        &self,
        py: Python<'_>,
        other: &Bound<'_, PyAny>,
    ) -> PyResult<AccuracyResult> {
        let calibration = Arc::clone(&self.calibration);
        let model = Arc::clone(&self.nominal);
        let set = self.same_kind(other)?;
        let split = self.split.clone();
        let map = run_interruptible(py, move || {
            let split = split.as_deref();
            Ok(match &set {
                AnySet::One(set, _) => calibration.accuracy_coverage(&model, set, split)?,
                AnySet::Targets(set) => calibration.accuracy_coverage(&model, set, split)?,
            })
        })?;
        Ok(self.widened(map))
    }

    /// The JSON report, as `flexcal calibrate --report` writes it (mm and
    /// deg at this boundary; with several targets, as `flexcal calibrate
    /// --targets --report` writes it), with the validation when given (the
    /// result of this result's `validate`).
    #[pyo3(signature = (validation = None))]
    fn to_json(&self, validation: Option<&Bound<'_, PyAny>>) -> PyResult<String> {
        let wrong = |expected: &str| {
            InputError::new_err(format!(
                "validation: expected the {expected} of this result's validate()"
            ))
        };
        if let Some(data) = &self.targets_data {
            let validation = validation
                .map(|v| {
                    v.extract::<PyRef<'_, ValidationResult>>()
                        .ok()
                        .filter(|v| self.same_targets(&v.report))
                        .map(|v| (*v.report).clone())
                        .ok_or_else(|| wrong("ValidationResult"))
                })
                .transpose()?;
            let run = CalibrationRun {
                data: (**data).clone(),
                validation_set: None,
                exclusions: Vec::new(),
                selection: self.selection.as_deref().cloned(),
                options: (*self.options).clone(),
                calibration: (*self.calibration).clone(),
                validation,
                split: self.split.as_deref().cloned(),
                coverage: None,
                accuracy_map: None,
                cross: None,
                station_hold_out: (*self.station_hold_out).clone(),
                residual: None,
            };
            return run.to_json_string().map_err(|e| Failure::from(e).into());
        }
        let validation = validation
            .map(|v| {
                v.extract::<PyRef<'_, ValidationResult>>()
                    .ok()
                    .filter(|v| self.same_targets(&v.report))
                    .map(|v| Arc::clone(&v.report))
                    .ok_or_else(|| wrong("ValidationResult"))
            })
            .transpose()?;
        let mut report = CalibrationReportJson::new(
            self.nominal.name(),
            &self.calibration,
            validation.as_deref(),
        );
        report.selection = self.selection.as_deref().cloned();
        // As `calibrate --report` writes them: a later plan reads them as
        // its prior (`plan(..., prior=)`).
        report.split_check = self.split.as_deref().cloned();
        report.extrapolation = self.extrapolation.as_deref().cloned();
        report.station_hold_out = self
            .station_hold_out
            .iter()
            .map(flexcal::calib::StationHoldOutJson::from)
            .collect();
        report.to_json_string().map_err(|e| calib_error(&e))
    }

    fn __repr__(&self) -> String {
        let c = &self.calibration;
        let targets = if self.targets_data.is_some() {
            format!(", {} targets", c.targets.len())
        } else {
            String::new()
        };
        format!(
            "CalibrationResult(robot={:?}{targets}, rank {} of {}, identification mean {:.4} mm after, {:.4} mm before)",
            self.nominal.name(),
            c.rank(),
            c.unknowns.len(),
            c.training_after.position_mean * 1e3,
            c.training_before.position_mean * 1e3
        )
    }
}
