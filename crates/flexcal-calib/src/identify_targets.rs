//! Identification from several targets on different frames of a robot (a
//! tree's branches, links of a chain, the tool): [`calibrate_targets`]
//! runs the one identification of [`crate::identification`] on every
//! target of every pose, and [`TargetCalibration`] reports it target by
//! target; [`validate_targets`] evaluates it on another set of the same
//! targets.
//!
//! For target t on frame f(t) and pose k the model is
//! `x_M = x_meas_base(tau) * x_base_f(q_k, xi) * x_f_target(o_t)`
//! ([`crate::ErrorModel`]), the paper's (7)-(10) with the parameter
//! Jacobian (49)-(52) of frame f(t) instead of the TCP. Each target has
//! offset unknowns `target.<name>.x|y|z` (m, in the target's frame) and,
//! where its orientations are measured, `target.<name>.rx|ry|rz` (rad, on
//! the right of its nominal rotation). Rows are positions (m) and, for a target with orientations,
//! rotation vectors (rad), each weighted `1/sigma`.
//!
//! Identifiability is decided as for one target, by the same code:
//! unknowns beyond the numerical rank are exactly dependent on others
//! ([`UnknownStatus::NonIdentifiable`]), those whose standard error would
//! exceed the limits of [`CalibrationOptions`] stay at their starting
//! values ([`UnknownStatus::PoorlyIdentifiable`]), and what no target
//! moves with (the other branch of a tree when its marker is missing) has
//! no influence ([`UnknownStatus::NoInfluence`]).
//!
//! ## Elasto-geometric terms
//! With [`CalibrationOptions::gravity`] (and
//! [`CalibrationOptions::joint_terms`]) the torque of each joint comes from
//! every weight it carries, both arms for a torso; the joint Jacobian of
//! each target's point carries the deflections to it, so a joint of one
//! branch moves that branch's targets only. A lateral rotation moves the
//! targets on frames after its joint: the torso's tilt moves both hands.

use std::borrow::Cow;

use flexcal_kinematics::{Model, RobotDescription};
use flexcal_optim::{
    ColumnScaling, Control, IdentifiabilityReport, IterationState, LevenbergMarquardt,
    ProblemSetup, SolveReport,
};
use nalgebra::{DMatrix, Isometry3, Vector3};
use serde::Serialize;

use crate::coverage::CoordinateCoverage;
use crate::error::CalibError;
use crate::error_model::{ErrorModel, FrameStarts, target_unknown_names};
use crate::gravity::GravityCompliance;
use crate::identification::{Identification, identify};
use crate::identify::{combination_lines, elastic_notes, is_elastic_unknown, weak_spread_note};
use crate::joint_law::JointTerms;
use crate::metrics::{ErrorStatistics, ObservationError, PoseError, error_statistics};
use crate::options::{CalibrationOptions, FrameTreatment};
use crate::prediction::{
    Linearised, Observed, Predicting, jacobian_and_residuals, residual_variance,
};
use crate::screen::DataChecks;
use crate::significance::NoiseSource;
use crate::targets::{Target, TargetMeasurementSet};
use crate::unknowns::{Combination, UnknownEstimate, UnknownStatus};

/// Errors of one target over the poses where it was seen.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetErrors {
    /// Target name.
    pub target: String,
    /// Frame it is fixed to.
    pub frame: String,
    /// Mean, RMS and maximum position error (m) over its observations.
    pub statistics: ErrorStatistics,
}

/// `pose,target,position_error_mm,dx_mm,dy_mm,dz_mm`, one row per
/// observation (mm; a comma in a pose label written as `;`), and
/// `orientation_error_deg` when some target's orientations are fitted: the
/// per-observation error file of `flexcal calibrate --targets --residuals`,
/// as [`crate::temperature::pose_errors_csv`] is for one target.
pub fn observation_errors_csv(errors: &[ObservationError]) -> String {
    let oriented = errors.iter().any(|e| e.orientation_error.is_some());
    let mut out = String::from("pose,target,position_error_mm,dx_mm,dy_mm,dz_mm");
    out.push_str(if oriented {
        ",orientation_error_deg\n"
    } else {
        "\n"
    });
    for e in errors {
        let mm = e.error * 1e3;
        out.push_str(&format!(
            "{},{},{},{},{},{}",
            e.pose.replace(',', ";"),
            e.target,
            mm.norm(),
            mm.x,
            mm.y,
            mm.z
        ));
        if oriented {
            out.push_str(&format!(
                ",{}",
                e.orientation_error
                    .map_or(String::new(), |a| a.to_degrees().to_string())
            ));
        }
        out.push('\n');
    }
    out
}

/// A fitted multi-target calibration.
#[derive(Debug, Clone, Serialize)]
pub struct TargetCalibration {
    /// Identified robot parameters xi (m, rad).
    pub xi: Vec<f64>,
    /// Nominal robot parameters (m, rad).
    pub nominal_xi: Vec<f64>,
    /// Identified (or fixed) measurement frame `x_meas_base`.
    pub x_meas_base: Isometry3<f64>,
    /// Starting measurement frame (registration of the nominal predictions
    /// onto the measurements, or the given value): the `frame_*` unknowns
    /// are increments on it (translation added, rotation vector on the left).
    pub x_meas_base_initial: Isometry3<f64>,
    /// Measurement frame fitted for the nominal robot (the "before").
    pub x_meas_base_nominal_robot: Isometry3<f64>,
    /// Whether the measurement frame was fixed.
    pub measurement_frame_fixed: bool,
    /// The targets with their identified (or fixed) offsets.
    pub targets: Vec<Target>,
    /// The targets with their offsets fitted for the nominal robot (the "before").
    pub targets_nominal_robot: Vec<Target>,
    /// The targets where the identification started: their `target.*`
    /// unknowns are increments on these (translation added in the target's
    /// frame, rotation vector on the right; a rotation starts from the
    /// data where orientations are fitted).
    pub targets_initial: Vec<Target>,
    /// Every unknown: robot parameters, then `frame_*`, then `target.*`.
    pub unknowns: Vec<UnknownEstimate>,
    /// Identifiability of the free unknowns at the start point (nominal
    /// robot, frames fitted), at [`CalibrationOptions::rank_tolerance`].
    pub identifiability: IdentifiabilityReport,
    /// What each identified unknown stands for (C.1), linearised at the start point.
    pub combinations: Vec<Combination>,
    /// The same as text (coefficients below 1e-3 dropped).
    pub combination_lines: Vec<String>,
    /// The final solver report.
    pub solve: SolveReport,
    /// Errors of all observations with the nominal robot, frames and offsets fitted (before).
    pub training_before: ErrorStatistics,
    /// Errors of all observations after identification.
    pub training_after: ErrorStatistics,
    /// Per-target errors before identification (nominal robot, frames fitted).
    pub per_target_before: Vec<TargetErrors>,
    /// Per-target errors after identification.
    pub per_target_after: Vec<TargetErrors>,
    /// Number of poses used.
    pub n_poses: usize,
    /// Number of (pose, target) observations used.
    pub n_observations: usize,
    /// The error of every observation after identification, pose by pose.
    pub observation_errors: Vec<ObservationError>,
    /// Repeated readings and suspect observations of the identification
    /// set ([`DataChecks::for_targets`]).
    pub data_checks: DataChecks,
    /// The noise the standard errors and identifiability judgements used
    /// ([`crate::significance`]).
    pub noise: NoiseSource,
    /// The gravity loading when the model is elasto-geometric, with the
    /// identified elastic unknowns (compliances, payload mass, first moment,
    /// lateral compliances when on; order of
    /// [`GravityCompliance::elastic_unknown_names`]). Not serialised: the
    /// values are in `unknowns` by name.
    #[serde(skip)]
    pub elastic: Option<(GravityCompliance, Vec<f64>)>,
    /// The joint error terms of the model ([`crate::joint_law`]).
    pub joint_terms: JointTerms,
    /// Their identified values, in the order of
    /// [`JointTerms::unknown_names`] (1/rad, rad). Not serialised: the
    /// values are in `unknowns` by name.
    #[serde(skip)]
    pub joint_term_values: Vec<f64>,
    /// Span of each actuated coordinate's gravity torque (N.m, or N for a
    /// prismatic one) over the identification poses, with the mass table's
    /// payload: the torques over which the compliances were identified.
    /// Empty for the geometric model.
    pub torque_ranges: Vec<CoordinateCoverage>,
    /// Names of the actuated coordinates, in the order of q, of
    /// `torque_ranges` and of `actuated_ranges`.
    pub actuated_names: Vec<String>,
    /// What the identification poses cover of each actuated coordinate
    /// (rad or m; [`crate::Calibration::actuated_ranges`]): poses outside
    /// it are extrapolations.
    pub actuated_ranges: Vec<CoordinateCoverage>,
    /// Names of the stations (placements of the instrument) of the
    /// identification set, in order ([`TargetMeasurementSet::pooled`]).
    pub station_names: Vec<String>,
    /// Identified measurement frames of the second and later stations
    /// (`x_meas_base` is the first's); empty with one station.
    pub station_frames: Vec<Isometry3<f64>>,
}

impl TargetCalibration {
    /// The identified measurement frame of every station, the first's
    /// ([`TargetCalibration::x_meas_base`]) first.
    pub fn measurement_frames(&self) -> Vec<Isometry3<f64>> {
        std::iter::once(self.x_meas_base)
            .chain(self.station_frames.iter().copied())
            .collect()
    }
}

impl TargetCalibration {
    fn with_status(&self, status: UnknownStatus) -> Vec<&str> {
        self.unknowns
            .iter()
            .filter(|u| u.status == status)
            .map(|u| u.name.as_str())
            .collect()
    }
    /// Names of the unknowns the data cannot separate from others (exact dependencies).
    pub fn non_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::NonIdentifiable)
    }
    /// Names of the unknowns seen too weakly (standard error beyond its limit).
    pub fn poorly_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::PoorlyIdentifiable)
    }
    /// Number of identified unknowns.
    pub fn rank(&self) -> usize {
        self.with_status(UnknownStatus::Identified).len()
    }

    /// Indices of the actuated coordinates at which `q` (rad or m) lies
    /// outside [`TargetCalibration::actuated_ranges`], as
    /// [`crate::Calibration::outside_training_range`].
    pub fn outside_training_range<'a>(&'a self, q: &'a [f64]) -> impl Iterator<Item = usize> + 'a {
        crate::coverage::outside(&self.actuated_ranges, q)
    }

    /// What the targets could not identify, in sentences for a report:
    /// robot parameters and target offsets left at their starting values,
    /// each with the identified unknowns that absorb it.
    pub fn identifiability_notes<'a>(&'a self) -> Vec<String> {
        let mut notes = Vec::new();
        let absorbed_by = |name: &str| -> Vec<String> {
            self.combinations
                .iter()
                .filter(|c| c.terms.iter().any(|(n, k)| n == name && k.abs() >= 1e-3))
                .map(|c| c.name.clone())
                .collect()
        };
        let describe = |names: &[&str]| -> String {
            names
                .iter()
                .map(|n| {
                    let by = absorbed_by(n);
                    if by.is_empty() {
                        n.to_string()
                    } else {
                        format!("{n} (in {})", by.join(", "))
                    }
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let np = self.xi.len();
        let robot: Vec<&str> = self.unknowns[..np]
            .iter()
            .filter(|u| u.status == UnknownStatus::NonIdentifiable)
            .map(|u| u.name.as_str())
            .collect();
        if !robot.is_empty() {
            notes.push(format!(
                "{} of {np} robot parameters cannot be told apart from others by these targets and stay at nominal: {}",
                robot.len(),
                describe(&robot)
            ));
        }
        for t in &self.targets {
            let prefix = format!("target.{}.", t.name);
            let blind: Vec<&str> = self
                .unknowns
                .iter()
                .filter(|u| u.name.starts_with(&prefix))
                .filter(|u| u.status == UnknownStatus::NonIdentifiable)
                .map(|u| u.name.as_str())
                .collect();
            if !blind.is_empty() {
                notes.push(format!(
                    "target `{}` on frame `{}`: offset not separable from the robot along {}; it stays at its nominal value",
                    t.name,
                    t.frame,
                    describe(&blind)
                ));
            }
        }
        // The elastic and joint terms have their own sentences below.
        let geometric = |names: Vec<&'a str>| -> Vec<&'a str> {
            names
                .into_iter()
                .filter(|n| !is_elastic_unknown(n))
                .collect()
        };
        // A seen target's rotation moves nothing without its orientations:
        // not worth a note.
        let seen_rotation = |n: &str| {
            n.strip_prefix("target.")
                .and_then(|rest| rest.rsplit_once(".r"))
                .is_some_and(|(target, _)| {
                    !self
                        .with_status(UnknownStatus::NoInfluence)
                        .contains(&format!("target.{target}.x").as_str())
                })
        };
        let unseen: Vec<&str> = geometric(self.with_status(UnknownStatus::NoInfluence))
            .into_iter()
            .filter(|n| !seen_rotation(n))
            .collect();
        if !unseen.is_empty() {
            notes.push(format!(
                "no measured target moves with these, they stay at nominal: {}",
                unseen.join(", ")
            ));
        }
        let poor = geometric(self.poorly_identifiable());
        if !poor.is_empty() {
            notes.push(format!(
                "seen too weakly by these poses (standard error beyond its limit), kept at the starting value: {}",
                poor.join(", ")
            ));
        }
        notes.extend(weak_spread_note(
            self.unknowns
                .iter()
                .enumerate()
                .filter(|(j, u)| *j < np || u.name.starts_with("target."))
                .map(|(_, u)| u),
        ));
        let frame: Vec<&str> = self.unknowns[np..np + 6]
            .iter()
            .filter(|u| u.status == UnknownStatus::NonIdentifiable)
            .map(|u| u.name.as_str())
            .collect();
        if !frame.is_empty() {
            notes.push(format!(
                "measurement frame components absorbed by the robot's base parameters: {}",
                frame.join(", ")
            ));
        }
        if self.elastic.is_some() {
            notes.extend(elastic_notes(
                &self.unknowns,
                &self.actuated_names,
                &self.torque_ranges,
                self.joint_terms.law.is_some(),
            ));
        }
        notes
    }

    /// The true value of each identified combination `x_B + K x_N` given a
    /// full vector of true unknowns (`truth`, indexed like
    /// [`TargetCalibration::unknowns`]): `(name, true combination value,
    /// identified value, standard error)`. Absorbed unknowns stay at their
    /// starting values in the fit, so only their true deviation from there
    /// is absorbed.
    pub fn combination_check(&self, truth: &[f64]) -> Vec<(String, f64, f64, Option<f64>)> {
        let index = |name: &str| self.unknowns.iter().position(|u| u.name == name);
        self.combinations
            .iter()
            .filter_map(|c| {
                let jb = index(&c.name)?;
                let mut value = *truth.get(jb)?;
                for (other, k) in &c.terms {
                    let jn = index(other)?;
                    value += k * (truth.get(jn)? - self.unknowns[jn].value);
                }
                let u = &self.unknowns[jb];
                Some((u.name.clone(), value, u.value, u.standard_error))
            })
            .collect()
    }

    /// The calibrated robot description (mm, deg).
    ///
    /// # Errors
    /// [`CalibError::Description`].
    pub fn description(&self, model: &Model) -> Result<RobotDescription, CalibError> {
        let mut d = model
            .description_with_params(&self.xi)
            .map_err(CalibError::Description)?;
        let note = format!(
            "Calibrated by flexcal from {} poses of {} targets: {} of {} unknowns identified.",
            self.n_poses,
            self.targets.len(),
            self.rank(),
            self.unknowns.len()
        );
        d.notes = if d.notes.is_empty() {
            note
        } else {
            format!("{} {note}", d.notes)
        };
        Ok(d)
    }
}

/// Options of [`CalibrationOptions`] that several targets do not take: one
/// starting offset for all of them.
fn check_supported(
    options: &CalibrationOptions,
    set: &TargetMeasurementSet,
) -> Result<(), CalibError> {
    if options.target_value.is_some() && set.targets().len() > 1 {
        return Err(CalibError::InvalidOption {
            name: "target",
            reason: "with several targets each target's offset is given in the targets description"
                .into(),
        });
    }
    Ok(())
}

/// Identifies the robot parameters, the measurement frame (unless fixed)
/// and the offsets of the identified targets from every target on every
/// pose, positions and, where a target carries them, orientations, with
/// the elasto-geometric terms when `options.gravity` (and
/// `options.joint_terms`) ask for them: the identification of
/// [`crate::identification`], as [`crate::calibrate`] for one target. The
/// options are those of [`crate::calibrate`]: `fixed` and `deferred` take
/// robot, `frame_*`, `target.<name>.*` and elastic names; a starting
/// offset (`target_value`) only for a set of one target.
///
/// # Errors
/// Mismatched coordinates, a target on an unknown frame, unknown names in
/// `fixed`/`deferred`, an unsupported option, too few observations, a
/// degenerate registration, a model failure at a pose, a solver failure,
/// [`CalibError::RankDeficient`] when `require_full_rank` is set,
/// [`CalibError::NothingToIdentify`].
pub fn calibrate_targets(
    model: &Model,
    set: &TargetMeasurementSet,
    options: &CalibrationOptions,
) -> Result<TargetCalibration, CalibError> {
    check_supported(options, set)?;
    let found = identify(model, Cow::Borrowed(set), options)?;
    let problem = &found.problem;
    let x = found.report.x.clone();
    let with_offsets = |x: &[f64]| -> Vec<Target> {
        set.targets()
            .iter()
            .enumerate()
            .map(|(t, target)| {
                let pose = problem.target_frame(x, t);
                Target {
                    offset: pose.translation.vector,
                    rotation: pose.rotation,
                    ..target.clone()
                }
            })
            .collect()
    };
    let targets = with_offsets(&x);
    let targets_nominal_robot = with_offsets(&found.x_nominal_robot);
    let targets_initial = with_offsets(&problem.initial_unknowns());
    let frames = problem.station_frames(&x);
    let fe = problem.frames_end();
    let joint_start = problem.joint_terms_offset().unwrap_or(x.len());
    let observation_errors = observation_errors(problem, &found.errors_after);
    let per_target_before = per_target(problem, &found.errors_before);
    let per_target_after = per_target(problem, &found.errors_after);
    let x_meas_base_nominal_robot = problem.station_frame(&found.x_nominal_robot, 0);
    let Identification {
        starts,
        frame_fixed,
        unknowns,
        identifiability,
        combinations,
        report,
        errors_before,
        errors_after,
        noise,
        actuated_ranges,
        torque_ranges,
        ..
    } = found;
    Ok(TargetCalibration {
        xi: x[..model.n_params()].to_vec(),
        nominal_xi: model.nominal_params().to_vec(),
        x_meas_base: frames[0],
        x_meas_base_initial: starts.stations[0],
        x_meas_base_nominal_robot,
        station_names: set.station_names().to_vec(),
        station_frames: frames[1..].to_vec(),
        measurement_frame_fixed: frame_fixed,
        targets,
        targets_nominal_robot,
        targets_initial,
        unknowns,
        identifiability,
        combination_lines: combination_lines(&combinations),
        combinations,
        solve: report,
        training_before: error_statistics(&errors_before),
        training_after: error_statistics(&errors_after),
        per_target_before,
        per_target_after,
        n_poses: set.len(),
        n_observations: errors_after.len(),
        data_checks: DataChecks::for_targets(set, &observation_errors),
        noise,
        observation_errors,
        elastic: options
            .gravity
            .as_ref()
            .map(|g| (g.clone(), x[fe..joint_start].to_vec())),
        joint_terms: options.joint_terms,
        joint_term_values: x[joint_start..].to_vec(),
        torque_ranges,
        actuated_names: model.actuated_names().to_vec(),
        actuated_ranges,
    })
}

/// `errors` (one per observation of `problem`, in its order) labelled by
/// pose and target.
fn observation_errors(problem: &ErrorModel<'_>, errors: &[PoseError]) -> Vec<ObservationError> {
    let set = problem.set();
    errors
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let (k, t) = problem.observation(i);
            ObservationError {
                pose: set.poses()[k].label(k),
                target: set.targets()[t].name.clone(),
                error: e.position_vector,
                orientation_error: e.orientation,
            }
        })
        .collect()
}

/// The statistics of `errors` (one per observation of `problem`) target by
/// target.
fn per_target(problem: &ErrorModel<'_>, errors: &[PoseError]) -> Vec<TargetErrors> {
    let set = problem.set();
    set.targets()
        .iter()
        .enumerate()
        .map(|(t, target)| {
            let mine: Vec<PoseError> = errors
                .iter()
                .enumerate()
                .filter(|(i, _)| problem.observation(*i).1 == t)
                .map(|(_, e)| *e)
                .collect();
            TargetErrors {
                target: target.name.clone(),
                frame: target.frame.clone(),
                statistics: error_statistics(&mine),
            }
        })
        .collect()
}

/// Validation of a multi-target calibration on another set of the same
/// targets: per-target errors of the nominal robot (frames and offsets as
/// fitted for it) and of the calibrated robot and offsets. With
/// `refit_frame` the measurement frame is fitted again on the set (the
/// instrument was moved between the series), for the nominal robot and for
/// the calibrated one alike; otherwise the calibration's frame is used for
/// both (each its own: the one fitted with the nominal robot for the
/// "before").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetValidation {
    /// Errors of all observations with the nominal robot and offsets (before).
    pub before: ErrorStatistics,
    /// Errors of all observations with the calibrated robot and offsets (after).
    pub after: ErrorStatistics,
    /// Per-target errors before.
    pub per_target_before: Vec<TargetErrors>,
    /// Per-target errors after.
    pub per_target_after: Vec<TargetErrors>,
    /// Whether the measurement frame was fitted again on this set.
    pub frame_refitted: bool,
    /// The error of every observation after calibration, pose by pose.
    pub observation_errors: Vec<ObservationError>,
    /// Repeated readings and suspect observations of the validation set
    /// (with the calibrated robot).
    pub data_checks: DataChecks,
    /// Actuated coordinates at which some validation poses leave the
    /// identification poses' range, with the fraction of the poses that do
    /// (the prediction there is an extrapolation), as for one target.
    pub extrapolated_coordinates: Vec<(String, f64)>,
}

/// The model of `calibration` on `set` (whose targets carry the offsets to
/// use), with the unknowns of the robot `xi`, the measurement frames
/// (`first` for the first station: the calibration's other stations'
/// frames when `set` has its stations, else `first` for every station of
/// `set`) and the identified elastic and joint unknowns (`identified`), or
/// their starting values (the model the identification started from).
/// Orientations are fitted where `orientation` and the targets carry them.
fn fitted_model<'a>(
    model: &'a Model,
    calibration: &TargetCalibration,
    set: &'a TargetMeasurementSet,
    (xi, identified): (&[f64], bool),
    first: Isometry3<f64>,
    orientation: bool,
) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
    let gravity = calibration.elastic.as_ref().map(|(g, _)| g);
    let mut starts = FrameStarts::nominal(set, first, (!orientation).then_some(false))?;
    if set.n_stations() == 1 + calibration.station_frames.len() {
        starts.stations[1..].copy_from_slice(&calibration.station_frames);
    }
    let problem = ErrorModel::new(model, Cow::Borrowed(set), &starts)?
        .with_elastic(gravity, &calibration.joint_terms)?;
    let mut x = problem.initial_unknowns();
    x[..xi.len()].copy_from_slice(xi);
    if identified {
        let mut values = calibration
            .elastic
            .as_ref()
            .map_or_else(Vec::new, |(_, v)| v.clone());
        values.extend(&calibration.joint_term_values);
        x[problem.frames_end()..].copy_from_slice(&values);
    }
    Ok((problem, x))
}

/// The position error (m) of every observation of `set` (same targets by
/// name as `calibration`'s, in row order: pose by pose, target by target)
/// predicted by `calibration`: its robot, elastic terms, target offsets and
/// measurement frame (the same instrument, not fitted again). What model
/// selection scores a held-out fold by.
///
/// # Errors
/// Targets that differ from the calibration's by name, mismatched
/// coordinates, a model failure at a pose.
pub fn target_position_errors(
    model: &Model,
    calibration: &TargetCalibration,
    set: &TargetMeasurementSet,
) -> Result<Vec<f64>, CalibError> {
    let calibrated = set.with_targets(fixed_offsets(&calibration.targets))?;
    let (problem, x) = fitted_model(
        model,
        calibration,
        &calibrated,
        (&calibration.xi, true),
        calibration.x_meas_base,
        false,
    )?;
    Ok(problem.errors(&x)?.iter().map(|e| e.position).collect())
}

/// The targets with their offsets fixed at their values.
fn fixed_offsets(targets: &[Target]) -> Vec<Target> {
    targets
        .iter()
        .map(|t| Target {
            treatment: FrameTreatment::Fixed,
            ..t.clone()
        })
        .collect()
}

/// Evaluates `calibration` on `set` (same targets by name; see
/// [`TargetValidation`]).
///
/// # Errors
/// Targets that differ from the calibration's by name, mismatched
/// coordinates, a model failure at a pose, a solver failure of the frame fit.
pub fn validate_targets(
    model: &Model,
    calibration: &TargetCalibration,
    set: &TargetMeasurementSet,
    refit_frame: bool,
) -> Result<TargetValidation, CalibError> {
    let nominal = set.with_targets(fixed_offsets(&calibration.targets_nominal_robot))?;
    let calibrated = set.with_targets(fixed_offsets(&calibration.targets))?;
    let evaluate = |set: &TargetMeasurementSet,
                    robot: (&[f64], bool),
                    x_meas_base: Isometry3<f64>|
     -> Result<
        (ErrorStatistics, Vec<TargetErrors>, Vec<ObservationError>),
        CalibError,
    > {
        let (problem, mut x) = fitted_model(model, calibration, set, robot, x_meas_base, true)?;
        if refit_frame {
            let mut frozen = vec![true; x.len()];
            for s in 0..problem.n_stations() {
                let o = problem.station_frame_offset(s);
                frozen[o..o + 6].fill(false);
            }
            // 0.01 deg weighs like 50 um, as in the identification defaults.
            let weights = (0..problem.n_observations())
                .flat_map(|i| {
                    let rows = problem.block_rows(i).len();
                    (0..rows).map(|r| {
                        if r < 3 {
                            1.0
                        } else {
                            50e-6 / 0.01f64.to_radians()
                        }
                    })
                })
                .collect();
            let setup = ProblemSetup {
                row_weights: Some(weights),
                weights_are_absolute: false,
                fixed: frozen,
                column_scaling: ColumnScaling::ColumnNorm,
            };
            let mut observer = |_: &IterationState| Control::Continue;
            problem.set_robot_columns(false);
            x = LevenbergMarquardt::params()
                .max_iterations(100)
                .solve(&problem, &x, &setup, &mut observer)
                .map_err(CalibError::optim("validation frame fit"))?
                .x;
        }
        let errors = problem.errors(&x)?;
        Ok((
            error_statistics(&errors),
            per_target(&problem, &errors),
            observation_errors(&problem, &errors),
        ))
    };
    let (before, per_target_before, _) = evaluate(
        &nominal,
        (&calibration.nominal_xi, false),
        calibration.x_meas_base_nominal_robot,
    )?;
    let (after, per_target_after, observation_errors) = evaluate(
        &calibrated,
        (&calibration.xi, true),
        calibration.x_meas_base,
    )?;
    Ok(TargetValidation {
        before,
        after,
        per_target_before,
        per_target_after,
        frame_refitted: refit_frame,
        data_checks: DataChecks::for_targets(set, &observation_errors),
        observation_errors,
        extrapolated_coordinates: crate::coverage::extrapolated_coordinates(
            model.actuated_names(),
            &calibration.actuated_ranges,
            set.poses().iter().map(|p| p.q.as_slice()),
        ),
    })
}

impl TargetCalibration {
    /// The model of the identification on `set` with this
    /// identification's targets (their identified offsets, treated as they
    /// were) and its unknowns: the offsets' and the measurement frames' at
    /// zero increments from the identified ones, every frame of the
    /// identification's stations (a set of fewer stations gives the others
    /// zero columns); positions only.
    fn model_on<'a>(
        &self,
        model: &'a Model,
        set: &TargetMeasurementSet,
    ) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
        let calibrated = set.with_targets(self.targets.clone())?;
        let mut starts = FrameStarts::nominal(&calibrated, self.x_meas_base, Some(false))?;
        starts.stations = self.measurement_frames();
        // The identification's rotation unknowns, without their rows.
        let count = calibrated.targets().len();
        starts.rotation = calibrated
            .targets()
            .iter()
            .map(|t| {
                let rx = &target_unknown_names(&t.name, count)[3];
                self.unknowns.iter().any(|u| &u.name == rx)
            })
            .collect();
        let gravity = self.elastic.as_ref().map(|(g, _)| g);
        let problem = ErrorModel::new(model, Cow::Owned(calibrated), &starts)?
            .with_elastic(gravity, &self.joint_terms)?;
        let mut x = self.xi.clone();
        x.resize(problem.frames_end(), 0.0);
        if let Some((_, values)) = &self.elastic {
            x.extend(values);
        }
        x.extend(&self.joint_term_values);
        if x.len() != self.unknowns.len() {
            return Err(CalibError::InvalidOption {
                name: "accuracy",
                reason: format!(
                    "the error model has {} unknowns, the identification {}",
                    x.len(),
                    self.unknowns.len()
                ),
            });
        }
        Ok((problem, x))
    }
}

impl Predicting for TargetCalibration {
    type Set = TargetMeasurementSet;
    fn configuration(set: &TargetMeasurementSet, k: usize) -> &[f64] {
        &set.poses()[k].q
    }
    fn estimates(&self) -> &[UnknownEstimate] {
        &self.unknowns
    }
    fn covariance(&self) -> Option<&DMatrix<f64>> {
        self.solve.covariance.as_ref()
    }
    fn linearise(
        &self,
        model: &Model,
        set: &TargetMeasurementSet,
    ) -> Result<Linearised, CalibError> {
        let (problem, x) = self.model_on(model, set)?;
        let (jacobian, residuals) = jacobian_and_residuals(&problem, &x)?;
        let calibrated = problem.set();
        Ok(Linearised {
            jacobian,
            predicted: (0..problem.n_observations())
                .map(|r| {
                    problem.measured(r).position + Vector3::from_fn(|i, _| residuals[3 * r + i])
                })
                .collect(),
            observed: (0..problem.n_observations())
                .map(|i| {
                    let (pose, t) = problem.observation(i);
                    Observed {
                        pose,
                        target: Some(calibrated.targets()[t].name.clone()),
                    }
                })
                .collect(),
        })
    }
    fn predicted_positions(
        &self,
        model: &Model,
        set: &TargetMeasurementSet,
    ) -> Result<Vec<Vector3<f64>>, CalibError> {
        let (problem, x) = self.model_on(model, set)?;
        Ok(problem
            .predict(&x)?
            .iter()
            .map(|p| p.translation.vector)
            .collect())
    }
    fn residual_variance(&self) -> f64 {
        residual_variance(
            self.training_after.position_rms,
            self.n_observations,
            self.rank(),
        )
    }
    fn measurement_frame(&self) -> Isometry3<f64> {
        self.x_meas_base
    }
    fn training_ranges(&self) -> &[CoordinateCoverage] {
        &self.actuated_ranges
    }
}
