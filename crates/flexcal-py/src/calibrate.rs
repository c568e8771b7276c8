//! `flexcal.calibrate`: the identification of a robot from a measurement
//! set of either kind, its keywords checked by name, and the checks asked
//! for, in one call that returns a `CalibrationResult`.

use std::path::PathBuf;
use std::sync::Arc;

use flexcal::calib::{
    Calibration, CalibrationOptions, FrameTreatment, MeasurementSet, Method, SelectionOptions,
    SelectionReport, SplitCheck, Weighting, calibrate_selected,
};
use flexcal::kinematics::Model;
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use pyo3::prelude::*;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn, exact};
use crate::calibration::{cancellable, gravity_option, judgement_options, selection_options};
use crate::errors::{Failure, InputError};
use crate::interrupt::run_cancellable;
use crate::measurement::Origin;
use crate::result::{AnySet, CalibrationResult};
use crate::robot::Robot;

/// Identifies the robot's parameters, the measurement frame and the target
/// offsets (those not fixed) from a measurement set of either kind:
/// equations (7)-(12) and (49)-(53) of Marie, Courteille, Maurine 2013.
/// `data` is a `MeasurementSet`: one target per pose, on the TCP, or
/// several targets per pose, each on a named frame (read or built with a
/// targets description; positions and, where given, orientations); the
/// result is a `CalibrationResult` either way.
///
/// Options (SI units): `model` `"geometric"` or `"elasto-geometric"` (joint
/// compliances under gravity of every branch and the payloads; mass table
/// built in for the UR10, else `masses`, a TOML file); `fix` names kept at
/// nominal; `defer` names left out of the base set first; `method` `"lm"`
/// or `"gn"`; `weights` `"file"` or `"uniform"` (default: uniform for the
/// IPA format, else file); `use_orientation` (default: the data's,
/// positions only for the IPA format); `fixed_frame`; `fixed_target` and
/// `target` (3,), the starting target position in the end frame (m), for
/// one target per pose only (several targets are fixed or identified by
/// their description); `max_se_length` (m, default 5e-3) and `max_se_angle`
/// (rad, default 0.25 deg) for the noise-aware rank; `strict` fails on rank
/// deficiency; `max_iterations`; `select` the model selection of `flexcal
/// calibrate --select`: `"cv"` (cross-validation over the poses), `"bic"`
/// or `"none"` (every group of unknowns the options allow, the
/// identifiability analysis alone deciding); by default, as on the command
/// line, `"cv"` from 100 poses and `"none"` below; its report in
/// `result.selection`. `hold_out_stations` (a set of several stations,
/// `MeasurementSet.pooled`): also each
/// station held out in turn, identified on the others and validated on it
/// (`result.station_hold_out`). `select_on`: which cross-validated score
/// the selection chooses on, `"interpolation"`, `"extrapolation"` or
/// `"auto"` (default: the extrapolating folds when `region`, configurations
/// (n, n_actuated) in rad or m where the calibrated robot is to be used,
/// leaves the training poses' range; without `region`, the ordinary folds).
/// `every_extrapolation_score`: every candidate scored on the extrapolating
/// folds also when the ordinary ones choose (default: the models the search
/// moved through only).
/// `split_check`: identify again on odd / even and first / second halves of
/// the poses (four more identifications; `result.split_check`), which
/// raises the predicted 95 % bounds where the standard errors understate.
/// `extrapolation`: measure how the model's error grows outside the
/// training range of each joint (two more identifications per joint;
/// `result.extrapolation_growth`) and add it to every predicted bound, as
/// `flexcal calibrate --extrapolation` does. `max_se_compliance`
/// (rad/N.m, default 1e-3), `min_compliance_z` (default 2) and `noise`
/// (the instrument's, m per position axis; default: from the file or the
/// fit): see `judgement_options`.
///
/// `deflection` (elasto-geometric): `"one-step"` (the torques on the
/// commanded configuration), `"equilibrium"` (on the deflected one) or
/// `"auto"` (the equilibrium when the one step changes a joint's torque by
/// more than 5 % of its span); default the mass table's, else one step.
/// The report of `result.to_json()` then says which was used and why
/// (`deflection`).
///
/// Runs without the GIL; Ctrl-C returns at once with `KeyboardInterrupt`
/// and stops the identification within one solver iteration.
#[pyfunction]
#[pyo3(signature = (robot, data, model = "geometric", fix = Vec::new(), defer = None, method = "lm", weights = None, use_orientation = None, fixed_frame = false, fixed_target = false, target = None, max_se_length = None, max_se_angle = None, strict = false, masses = None, max_iterations = None, select = None, hold_out_stations = false, split_check = false, max_se_compliance = None, min_compliance_z = None, noise = None, select_on = None, region = None, extrapolation = false, deflection = None, every_extrapolation_score = false))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate<'py>(
    py: Python<'py>,
    robot: &Robot,
    data: &Bound<'py, PyAny>,
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
    extrapolation: bool,
    deflection: Option<&str>,
    every_extrapolation_score: bool,
) -> PyResult<CalibrationResult> {
    let data = AnySet::extract("data", data)?;
    let nominal = Arc::clone(&robot.model);
    let mut selection = selection_keywords(select, select_on, region, data.len(), &nominal)?;
    selection.every_extrapolation_score = every_extrapolation_score;
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
    let origin = match &data {
        AnySet::One(_, origin) => *origin,
        AnySet::Targets(_) => Origin::Own,
    };
    options.weighting = match weights.unwrap_or(match origin {
        Origin::Own | Origin::Targets => "file",
        Origin::Ipa => "uniform",
    }) {
        "file" => Weighting::FromFile,
        "uniform" => Weighting::Uniform,
        other => {
            return Err(InputError::new_err(format!(
                "weights: expected \"file\" or \"uniform\", got {other:?}"
            )));
        }
    };
    options.use_orientation = match (use_orientation, origin) {
        (Some(u), _) => Some(u),
        (None, Origin::Ipa) => Some(false),
        (None, Origin::Own | Origin::Targets) => None,
    };
    options.fixed = fix;
    if let Some(defer) = defer {
        options.deferred = defer;
    }
    if fixed_frame {
        options.measurement_frame = FrameTreatment::Fixed;
    }
    target_keywords(&mut options, &data, fixed_target, target)?;
    rank_keywords(&mut options, max_se_length, max_se_angle, strict)?;
    if let Some(n) = max_iterations {
        options.max_iterations = n;
    }
    options.gravity = gravity_option(model, masses, &nominal)?;
    deflection_keyword(&mut options, deflection)?;
    judgement_options(&mut options, max_se_compliance, min_compliance_z, noise)?;
    let checks = Checks {
        split_check,
        hold_out_stations,
        extrapolation,
    };
    let (options, cancel) = cancellable(&options);
    let model = Arc::clone(&nominal);
    let (identified, targets_data) = match data {
        AnySet::One(set, _) => (
            run_cancellable(py, Some(cancel), move || {
                identify(&model, &set, &options, &selection, checks)
            })?,
            None,
        ),
        AnySet::Targets(set) => {
            let data = Arc::clone(&set);
            (
                run_cancellable(py, Some(cancel), move || {
                    identify(&model, &set, &options, &selection, checks)
                })?,
                Some(data),
            )
        }
    };
    Ok(CalibrationResult {
        calibration: Arc::new(identified.calibration),
        nominal,
        calibrated: Robot::new(identified.calibrated),
        selection: identified.selection.map(Arc::new),
        station_hold_out: Arc::new(identified.held),
        split: identified.split.map(Arc::new),
        options: Arc::new(identified.chosen),
        targets_data,
        extrapolation: identified.extrapolation.map(Arc::new),
    })
}

/// The checks `calibrate` runs after the identification, on request.
#[derive(Debug, Clone, Copy)]
struct Checks {
    split_check: bool,
    hold_out_stations: bool,
    extrapolation: bool,
}

/// What `identify` returns to `calibrate`.
struct Identified {
    calibration: Calibration,
    selection: Option<SelectionReport>,
    calibrated: Model,
    held: Vec<flexcal::calib::StationHoldOut>,
    split: Option<SplitCheck>,
    chosen: CalibrationOptions,
    extrapolation: Option<flexcal::calib::ExtrapolationModel>,
}

/// The selected model identified on `set` (either kind), the calibrated
/// robot, and the checks asked for.
fn identify(
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
    selection: &SelectionOptions,
    checks: Checks,
) -> Result<Identified, Failure> {
    let (calibration, report, chosen) = calibrate_selected(model, set, options, selection)?;
    let split = checks
        .split_check
        .then(|| SplitCheck::new(model, set, &chosen, &calibration))
        .transpose()?;
    let calibrated = calibration
        .description(model)?
        .build()
        .map_err(Failure::Kinematics)?;
    let held = if checks.hold_out_stations {
        flexcal::calib::hold_out_stations(model, set, options, selection)?
    } else {
        Vec::new()
    };
    let extrapolation = checks
        .extrapolation
        .then(|| calibration.extrapolation(model, set, &chosen))
        .transpose()?;
    Ok(Identified {
        calibration,
        selection: report,
        calibrated,
        held,
        split,
        chosen,
        extrapolation,
    })
}

/// The selection options of `select`, `select_on` and `region` (checked
/// against the robot's actuated coordinates).
fn selection_keywords(
    select: Option<&str>,
    select_on: Option<&str>,
    region: Option<Vec<Vec<f64>>>,
    poses: usize,
    robot: &Model,
) -> PyResult<SelectionOptions> {
    let mut selection = selection_options(select, poses)?;
    if let Some(name) = select_on {
        selection.select_on = name
            .parse()
            .map_err(|e: String| InputError::new_err(format!("select_on: {e}")))?;
    }
    if let Some(region) = region {
        let na = robot.n_actuated();
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
    Ok(selection)
}

/// `fixed_target` and `target`: the one target's treatment and start; a
/// named error for a set of several targets (described by their file).
fn target_keywords(
    options: &mut CalibrationOptions,
    data: &AnySet,
    fixed_target: bool,
    target: Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
) -> PyResult<()> {
    let set = match data {
        AnySet::One(set, _) => set,
        AnySet::Targets(_) => {
            let name = if fixed_target {
                "fixed_target"
            } else {
                "target"
            };
            if fixed_target || target.is_some() {
                return Err(InputError::new_err(format!(
                    "{name}: not available with several targets per pose (each target is fixed or identified by the `fixed` list of the set's targets)"
                )));
            }
            return Ok(());
        }
    };
    if fixed_target {
        options.target = FrameTreatment::Fixed;
    }
    if let Some(target) = target {
        let (t, _) = exact("target", &target, &[Some(3)])?;
        let rotation = set
            .nominal_target()
            .map(|t| t.rotation)
            .unwrap_or_else(UnitQuaternion::identity);
        options.target_value = Some(Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            rotation,
        ));
    }
    Ok(())
}

/// `max_se_length`, `max_se_angle` (finite and > 0) and `strict`.
fn rank_keywords(
    options: &mut CalibrationOptions,
    max_se_length: Option<f64>,
    max_se_angle: Option<f64>,
    strict: bool,
) -> PyResult<()> {
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
    options.require_full_rank = strict;
    Ok(())
}

/// Applies the `deflection` keyword to the elasto-geometric model.
fn deflection_keyword(options: &mut CalibrationOptions, deflection: Option<&str>) -> PyResult<()> {
    let Some(name) = deflection else {
        return Ok(());
    };
    let parsed: flexcal::calib::Deflection = name
        .parse()
        .map_err(|e: String| InputError::new_err(format!("deflection: {e}")))?;
    match options.gravity.as_mut() {
        Some(gravity) => {
            gravity.deflection = parsed;
            Ok(())
        }
        None => Err(InputError::new_err(
            "deflection: only for model=\"elasto-geometric\"",
        )),
    }
}
