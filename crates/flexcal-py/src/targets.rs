//! Several measured targets per pose (markers on the hands of a two-armed
//! robot, reflectors on a tool): `flexcal.TargetMeasurementSet`,
//! `flexcal.calibrate_targets` and their results.

use std::path::PathBuf;
use std::sync::Arc;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::calib::{
    CalibrationOptions, CancelToken, CrossCheck, FrameTreatment, SplitCheck, Target,
    TargetMeasurementSet as Set, TargetObservation, TargetPose, TargetValidation,
    calibrate_selected, read_targets, validate_targets,
};
use flexcal::kinematics::Model;
use flexcal::targets::TargetCalibrationRun;
use nalgebra::Vector3;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::accuracy::AccuracyResult;
use crate::arrays::{exact, to_numpy};
use crate::calibration::{
    ErrorStatistics, SelectionResult, UnknownEstimate, cancellable, gravity_option, matrix,
    selection_options, unknown_estimates,
};
use crate::checks::{CrossCheckResult, SplitCheckResult};
use crate::errors::{Failure, InputError, NotFiniteError, ShapeError, calib_error};
use crate::interrupt::{run_cancellable, run_interruptible};
use crate::robot::Robot;

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
            });
        }
        Ok(Self {
            set: Arc::new(Set::new(source, described, poses).map_err(|e| calib_error(&e))?),
        })
    }

    /// flexcal's CSV with per-target columns (mm), the targets described by
    /// the TOML file `targets` (docs/file-formats.md).
    #[staticmethod]
    fn read_csv(path: PathBuf, targets: PathBuf) -> PyResult<Self> {
        let targets = read_targets(&targets).map_err(|e| calib_error(&e))?;
        Ok(Self {
            set: Arc::new(Set::read_csv(&path, &targets).map_err(|e| calib_error(&e))?),
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

/// `{target name: ErrorStatistics}`.
fn per_target<'py>(
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
fn observation_errors<'py>(
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

/// Errors of a multi-target calibration on another set of the same targets.
#[pyclass(frozen, module = "flexcal", name = "TargetValidationResult")]
#[derive(Debug, Clone)]
pub struct TargetValidationResult {
    validation: Arc<TargetValidation>,
}

#[pymethods]
impl TargetValidationResult {
    /// Errors of every observation with the nominal robot (before).
    #[getter]
    fn before(&self) -> ErrorStatistics {
        ErrorStatistics::from(&self.validation.before)
    }

    /// Errors of every observation with the calibrated robot (after).
    #[getter]
    fn after(&self) -> ErrorStatistics {
        ErrorStatistics::from(&self.validation.after)
    }

    /// `{target: ErrorStatistics}` before.
    #[getter]
    fn per_target_before<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.validation.per_target_before)
    }

    /// `{target: ErrorStatistics}` after.
    #[getter]
    fn per_target_after<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.validation.per_target_after)
    }

    /// Whether the measurement frame was fitted again on the set.
    #[getter]
    fn frame_refitted(&self) -> bool {
        self.validation.frame_refitted
    }

    /// Repeated readings and suspect observations of the set (errors above
    /// four times the RMS after calibration), in sentences; empty when the
    /// data pass both checks.
    #[getter]
    fn data_checks(&self) -> Vec<String> {
        self.validation.data_checks.notes("validation")
    }

    /// Actuated coordinates that leave the identification poses' range on
    /// some poses: (name, fraction of the poses outside).
    #[getter]
    fn extrapolated_coordinates(&self) -> Vec<(String, f64)> {
        self.validation.extrapolated_coordinates.clone()
    }

    /// `([(pose, target)], errors (n_observations, 3) in m)` after
    /// calibration: measured minus predicted, in the measurement frame.
    #[getter]
    fn observation_errors<'py>(
        &self,
        py: Python<'py>,
    ) -> (Vec<(String, String)>, Bound<'py, PyArrayDyn<f64>>) {
        observation_errors(py, &self.validation.observation_errors)
    }

    fn __repr__(&self) -> String {
        format!(
            "TargetValidationResult(mean {:.4} mm after, {:.4} mm before)",
            self.validation.after.position_mean * 1e3,
            self.validation.before.position_mean * 1e3
        )
    }
}

/// The result of `calibrate_targets`: the identified unknowns, what the
/// targets could identify, per-target errors, the calibrated robot,
/// validation on another set and the JSON report.
#[pyclass(frozen, module = "flexcal", name = "TargetCalibrationResult")]
#[derive(Debug)]
pub struct TargetCalibrationResult {
    /// The run; its `split` raises the predicted bounds.
    run: Arc<TargetCalibrationRun>,
    /// The options of the identified (selected) model, for the checks that
    /// identify it again.
    options: Arc<CalibrationOptions>,
    nominal: Arc<Model>,
    calibrated: Robot,
}

#[pymethods]
impl TargetCalibrationResult {
    /// The calibrated robot (its nominal values are the identified ones).
    #[getter]
    fn robot(&self) -> Robot {
        self.calibrated.clone()
    }

    /// The model selection (`select="cv"` or `"bic"`), or None.
    #[getter]
    fn selection(&self) -> Option<SelectionResult> {
        self.run.selection.as_ref().map(|report| SelectionResult {
            report: Arc::new(report.clone()),
        })
    }

    /// `"geometric"` or `"elasto-geometric"`.
    #[getter]
    fn model(&self) -> &'static str {
        if self.run.calibration.elastic.is_some() {
            "elasto-geometric"
        } else {
            "geometric"
        }
    }

    /// Every unknown: robot parameters, `frame_*`, `target.<name>.x|y|z`,
    /// then the elastic and joint terms of the elasto-geometric model.
    #[getter]
    fn parameters(&self) -> Vec<UnknownEstimate> {
        unknown_estimates(&self.run.calibration.unknowns)
    }

    /// Identified value of every unknown by name (SI units).
    #[getter]
    fn identified<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for u in &self.run.calibration.unknowns {
            d.set_item(&u.name, u.value)?;
        }
        Ok(d)
    }

    /// Standard error of every identified unknown by name (SI units).
    #[getter]
    fn standard_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for u in &self.run.calibration.unknowns {
            if let Some(s) = u.standard_error {
                d.set_item(&u.name, s)?;
            }
        }
        Ok(d)
    }

    /// Span `(lo, hi)` of each actuated coordinate's gravity torque over the
    /// identification poses (N.m, or N), by name: the torques the joint
    /// compliances were identified over. Empty for the geometric model.
    #[getter]
    fn torque_ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = &self.run.calibration;
        let d = PyDict::new(py);
        for (name, r) in c.actuated_names.iter().zip(&c.torque_ranges) {
            d.set_item(name, (r.lo, r.hi))?;
        }
        Ok(d)
    }

    /// Number of identified unknowns.
    #[getter]
    fn rank(&self) -> usize {
        self.run.calibration.rank()
    }

    /// What each identified unknown stands for: identified name ->
    /// [(absorbed name, coefficient)], coefficients in SI units.
    #[getter]
    fn combination_terms<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for c in &self.run.calibration.combinations {
            d.set_item(&c.name, c.terms.clone())?;
        }
        Ok(d)
    }

    /// What the targets could not identify, in sentences.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.run.calibration.identifiability_notes()
    }

    /// Repeated readings and suspect observations of the identification
    /// set (errors above four times the RMS after the fit), in sentences;
    /// empty when the data pass both checks.
    #[getter]
    fn data_checks(&self) -> Vec<String> {
        self.run.calibration.data_checks.notes("identification")
    }

    /// Errors of every observation before (nominal robot, frame and
    /// offsets fitted) and after identification.
    #[getter]
    fn before(&self) -> ErrorStatistics {
        ErrorStatistics::from(&self.run.calibration.training_before)
    }

    /// Errors of every observation after identification.
    #[getter]
    fn after(&self) -> ErrorStatistics {
        ErrorStatistics::from(&self.run.calibration.training_after)
    }

    /// `{target: ErrorStatistics}` before identification.
    #[getter]
    fn per_target_before<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.run.calibration.per_target_before)
    }

    /// `{target: ErrorStatistics}` after identification.
    #[getter]
    fn per_target_after<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        per_target(py, &self.run.calibration.per_target_after)
    }

    /// `([(pose, target)], errors (n_observations, 3) in m)` of the
    /// identification set after identification: measured minus predicted,
    /// in the measurement frame.
    #[getter]
    fn observation_errors<'py>(
        &self,
        py: Python<'py>,
    ) -> (Vec<(String, String)>, Bound<'py, PyArrayDyn<f64>>) {
        observation_errors(py, &self.run.calibration.observation_errors)
    }

    /// `{target: offset (3,)}` in its frame, m: identified or fixed.
    #[getter]
    fn target_offsets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for t in &self.run.calibration.targets {
            d.set_item(&t.name, to_numpy(py, t.offset.as_slice().to_vec(), &[3]))?;
        }
        Ok(d)
    }

    /// The identified measurement frame x_meas_base (4 x 4, m).
    #[getter]
    fn measurement_frame<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        matrix(py, &self.run.calibration.x_meas_base)
    }

    /// The identified measurement frame of every station (4 x 4, m), by
    /// station name; one entry for a set of one station.
    #[getter]
    fn station_frames<'py>(&self, py: Python<'py>) -> Vec<(String, Bound<'py, PyArrayDyn<f64>>)> {
        let c = &self.run.calibration;
        c.measurement_frames()
            .iter()
            .zip(&c.station_names)
            .map(|(frame, name)| (name.clone(), matrix(py, frame)))
            .collect()
    }

    /// Errors of the calibrated robot on another set of the same targets;
    /// with `refit_frame` (default) the measurement frame is fitted again
    /// on it (the instrument was moved). Releases the GIL; Ctrl-C
    /// interrupts the wait.
    #[pyo3(signature = (other, refit_frame = true))]
    fn validate(
        &self,
        py: Python<'_>,
        other: &TargetMeasurementSet,
        refit_frame: bool,
    ) -> PyResult<TargetValidationResult> {
        let run = Arc::clone(&self.run);
        let model = Arc::clone(&self.nominal);
        let set = Arc::clone(&other.set);
        let validation = run_interruptible(py, move || {
            Ok(validate_targets(
                &model,
                &run.calibration,
                &set,
                refit_frame,
            )?)
        })?;
        Ok(TargetValidationResult {
            validation: Arc::new(validation),
        })
    }

    /// Predicted 95 % bound of each target's position error at each
    /// configuration of `q` (rad or m; shape (dof,) or (n, dof)): one entry
    /// per configuration and target, pose by pose (`AccuracyResult.targets`
    /// names them). The identification's covariance, conditioned on the
    /// measurement frame, carried to each target's position, with the
    /// training residuals' scatter.
    fn predicted_accuracy(
        &self,
        q: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    ) -> PyResult<AccuracyResult> {
        let q = crate::arrays::rows("q", &q, self.nominal.n_actuated())?;
        let map = self
            .run
            .calibration
            .predicted_accuracy(
                &self.nominal,
                &crate::accuracy::configurations(&q),
                self.run.split.as_ref(),
            )
            .map_err(|e| calib_error(&e))?;
        Ok(AccuracyResult::new(map))
    }

    /// The predicted 95 % bounds at the observations of `other` (same
    /// targets) with their measured errors after calibration (the
    /// measurement frame fitted again, as `validate` does by default) and
    /// the share within the bound. Releases the GIL; Ctrl-C interrupts the
    /// wait.
    fn accuracy_coverage(
        &self,
        py: Python<'_>,
        other: &TargetMeasurementSet,
    ) -> PyResult<AccuracyResult> {
        let run = Arc::clone(&self.run);
        let model = Arc::clone(&self.nominal);
        let set = Arc::clone(&other.set);
        run_interruptible(py, move || {
            Ok(AccuracyResult::new(run.calibration.accuracy_coverage(
                &model,
                &*set,
                run.split.as_ref(),
            )?))
        })
    }

    /// The cross-series check on `other` (same targets), as
    /// `CalibrationResult.cross_check`. Runs without the GIL; Ctrl-C stops
    /// it within one solver iteration.
    fn cross_check(
        &self,
        py: Python<'_>,
        other: &TargetMeasurementSet,
    ) -> PyResult<CrossCheckResult> {
        let run = Arc::clone(&self.run);
        let model = Arc::clone(&self.nominal);
        let set = Arc::clone(&other.set);
        let (options, cancel) = cancellable(&self.options);
        let check = run_cancellable(py, Some(cancel), move || {
            Ok(CrossCheck::new(
                &model,
                &*set,
                &options,
                &run.calibration,
                run.split.as_ref(),
            )?)
        })?;
        Ok(CrossCheckResult::new(check, &self.run.calibration.unknowns))
    }

    /// Each station held out (`hold_out_stations=True`): (station, groups
    /// chosen on the others or None without selection, errors before, errors
    /// after), errors over the held-out station's observations.
    #[getter]
    fn station_hold_out(&self) -> Vec<crate::calibration::HoldOutRow> {
        crate::calibration::hold_out_rows(&self.run.station_hold_out)
    }

    /// The split-half check (`split_check=True`), or None. Its prediction
    /// ratio raises the bounds of `predicted_accuracy` and
    /// `accuracy_coverage` where it is above 1.
    #[getter]
    fn split_check(&self) -> Option<SplitCheckResult> {
        self.run.split.as_ref().map(|check| {
            SplitCheckResult::new(Arc::new(check.clone()), &self.run.calibration.unknowns)
        })
    }

    /// The JSON report, as `flexcal calibrate --targets --report` writes it
    /// (SI units), with the validation when given.
    #[pyo3(signature = (validation = None))]
    fn to_json(&self, validation: Option<&TargetValidationResult>) -> PyResult<String> {
        let mut run = (*self.run).clone();
        run.validation = validation.map(|v| (*v.validation).clone());
        run.to_json_string().map_err(|e| Failure::from(e).into())
    }

    fn __repr__(&self) -> String {
        let c = &self.run.calibration;
        format!(
            "TargetCalibrationResult(robot={:?}, {} targets, rank {} of {}, mean {:.4} mm after, {:.4} mm before)",
            self.nominal.name(),
            c.targets.len(),
            c.rank(),
            c.unknowns.len(),
            c.training_after.position_mean * 1e3,
            c.training_before.position_mean * 1e3
        )
    }
}

/// Identifies the robot's parameters, the measurement frame and the offsets
/// of the targets (those not fixed) from every target on every pose; with
/// `model="elasto-geometric"` the joint compliances under gravity of every
/// branch (mass table built in for the UR10, else `masses`, a TOML file;
/// its `lateral = "about-x"` adds the lateral compliances). `fix` names
/// kept at their start; `select` the model selection (`"cv"`, `"bic"`,
/// `"none"`; by default `"cv"` from 100 poses), its report in
/// `result.selection`; `max_iterations`; `split_check`: identify again on
/// halves of the poses (four more identifications; `result.split_check`),
/// which raises the predicted 95 % bounds where the standard errors
/// understate; `hold_out_stations` (a set of several stations,
/// `TargetMeasurementSet.pooled`): also each station held out in turn,
/// identified on the others and validated on it (`result.station_hold_out`).
/// `max_se_compliance`, `min_compliance_z`, `noise`: as for `calibrate`.
/// Positions only.
///
/// Runs without the GIL; Ctrl-C returns at once with `KeyboardInterrupt`
/// and stops the identification within one solver iteration.
#[pyfunction]
#[pyo3(signature = (robot, data, model = "geometric", fix = Vec::new(), masses = None, select = None, max_iterations = None, split_check = false, hold_out_stations = false, max_se_compliance = None, min_compliance_z = None, noise = None))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate_targets(
    py: Python<'_>,
    robot: &Robot,
    data: &TargetMeasurementSet,
    model: &str,
    fix: Vec<String>,
    masses: Option<PathBuf>,
    select: Option<&str>,
    max_iterations: Option<usize>,
    split_check: bool,
    hold_out_stations: bool,
    max_se_compliance: Option<f64>,
    min_compliance_z: Option<f64>,
    noise: Option<f64>,
) -> PyResult<TargetCalibrationResult> {
    let nominal = Arc::clone(&robot.model);
    let selection = selection_options(select, data.set.len())?;
    let mut options = CalibrationOptions::for_model(&nominal);
    options.fixed = fix;
    options.gravity = gravity_option(model, masses, &nominal)?;
    crate::calibration::judgement_options(
        &mut options,
        max_se_compliance,
        min_compliance_z,
        noise,
    )?;
    if let Some(n) = max_iterations {
        options.max_iterations = n;
    }
    let cancel = CancelToken::new();
    options.cancel = Some(cancel.clone());
    let set = Arc::clone(&data.set);
    let model = Arc::clone(&nominal);
    let (run, calibrated, chosen) = run_cancellable(py, Some(cancel), move || {
        let (calibration, report, chosen) =
            calibrate_selected(&model, &*set, &options, &selection)?;
        let split = split_check
            .then(|| SplitCheck::new(&model, &*set, &chosen, &calibration))
            .transpose()?;
        let station_hold_out = if hold_out_stations {
            flexcal::calib::hold_out_stations(&model, &*set, &options, &selection)?
        } else {
            Vec::new()
        };
        let calibrated = calibration
            .description(&model)?
            .build()
            .map_err(Failure::Kinematics)?;
        let run = TargetCalibrationRun {
            data: (*set).clone(),
            validation_set: None,
            exclusions: Vec::new(),
            selection: report,
            calibration,
            validation: None,
            split,
            coverage: None,
            accuracy_map: None,
            cross: None,
            station_hold_out,
        };
        Ok((run, calibrated, chosen))
    })?;
    Ok(TargetCalibrationResult {
        run: Arc::new(run),
        options: Arc::new(chosen),
        nominal,
        calibrated: Robot::new(calibrated),
    })
}
