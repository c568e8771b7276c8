//! Validation metrics: position and orientation errors before and after
//! calibration, on the identification set or a separate validation set.

use std::borrow::Cow;

use flexcal_kinematics::Model;
use flexcal_optim::{LevenbergMarquardt, ProblemSetup};
use nalgebra::Isometry3;
use serde::Serialize;

use crate::error::CalibError;
use crate::error_model::{ErrorModel, FrameStarts};
use crate::gravity::GravityCompliance;
use crate::identify::{Calibration, observation_errors, per_target};
use crate::joint_law::JointTerms;
use crate::measurement::MeasurementSet;
pub use crate::metrics::{ErrorStatistics, PoseError, error_statistics};
use crate::metrics::{ObservationError, TargetErrors};
use crate::options::FrameTreatment;
use crate::screen::DataChecks;
use crate::start::{register_stations, target_frames};
use crate::targets::Target;

/// How the measurement frame is obtained when errors are evaluated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FramePolicy {
    /// A known `x_meas_base` (measurements already in the robot base frame:
    /// identity; or the frame identified with the robot on the same series).
    Fixed(Isometry3<f64>),
    /// Re-fitted on the evaluated data with the robot frozen: closed-form
    /// registration then least squares on the 6 frame unknowns (6 per
    /// station when the data has several) and the 3 target position
    /// unknowns if `refit_target`. Used when the validation series was
    /// measured from another tracker position.
    Refit {
        /// Also re-fit the target position offset.
        refit_target: bool,
    },
}

/// Per-pose errors of the robot at `xi` with target `x_tcp_target` on `set`,
/// the measurement frame taken or re-fitted according to `policy`. With
/// `elastic`, the robot deflects under gravity with the given elastic
/// unknowns (compliances, payload mass, first moment: see
/// [`GravityCompliance::unknown_names`]). Also returns the measurement
/// frame `x_meas_base` used (the fixed one, or the re-fitted one).
///
/// # Errors
/// Mismatched coordinates, a model failure at a pose, a degenerate
/// registration, a failing re-fit.
pub fn evaluate_errors(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
    elastic: Option<(&GravityCompliance, &[f64])>,
    x_tcp_target: &Isometry3<f64>,
    policy: FramePolicy,
    use_orientation: bool,
) -> Result<(Vec<PoseError>, Isometry3<f64>), CalibError> {
    evaluate_errors_with_terms(
        model,
        set,
        xi,
        elastic,
        (&JointTerms::default(), &[]),
        x_tcp_target,
        policy,
        use_orientation,
    )
}

/// [`evaluate_errors`] with joint terms ([`crate::joint_law`]) and their
/// values (in the order of [`JointTerms::unknown_names`]).
///
/// # Errors
/// As [`evaluate_errors`]; [`CalibError::InvalidOption`] when the number of
/// values does not match the terms.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_errors_with_terms(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
    elastic: Option<(&GravityCompliance, &[f64])>,
    joint: (&JointTerms, &[f64]),
    x_tcp_target: &Isometry3<f64>,
    policy: FramePolicy,
    use_orientation: bool,
) -> Result<(Vec<PoseError>, Isometry3<f64>), CalibError> {
    let mut targets = set.targets().to_vec();
    if let Some(first) = targets.first_mut() {
        first.offset = x_tcp_target.translation.vector;
        first.rotation = x_tcp_target.rotation;
    }
    let robot = Robot {
        xi,
        elastic,
        joint,
        targets,
    };
    let (problem, x) = evaluation_model(model, set, robot, (policy, &[]), use_orientation)?;
    Ok((problem.errors(&x)?, first_station_frame(&problem, &x)))
}

/// The robot a set is evaluated with: its parameters, its elastic and
/// joint terms with their values, and its targets (the offsets to use).
struct Robot<'c> {
    /// Robot parameters.
    xi: &'c [f64],
    /// The gravity model and its unknowns' values, when the robot deflects.
    elastic: Option<(&'c GravityCompliance, &'c [f64])>,
    /// Joint terms and their values.
    joint: (&'c JointTerms, &'c [f64]),
    /// The targets, by the set's names, with their offsets.
    targets: Vec<Target>,
}

impl Calibration {
    /// The calibrated robot.
    fn calibrated(&self) -> Robot<'_> {
        Robot {
            xi: &self.xi,
            elastic: self.elastic.as_ref().map(|(g, v)| (g, v.as_slice())),
            joint: (&self.joint_terms, &self.joint_term_values),
            targets: self.targets.clone(),
        }
    }

    /// The nominal robot with the target offsets fitted for it (rigid, no
    /// joint terms): the "before" of a validation.
    fn nominal(&self) -> Robot<'_> {
        Robot {
            xi: &self.nominal_xi,
            elastic: None,
            joint: (&NO_JOINT_TERMS, &[]),
            targets: self.targets_nominal_robot.clone(),
        }
    }
}

/// No joint terms.
static NO_JOINT_TERMS: JointTerms = JointTerms {
    law: None,
    cyclic: false,
};

/// The model of `robot` on `set` with its unknowns: the targets at the
/// robot's offsets (re-fitted with the frames for
/// `FramePolicy::Refit { refit_target: true }`), the measurement frames
/// taken (`later_stations` after the first for a set of several stations)
/// or re-fitted according to `policy`; orientations fitted where
/// `orientation` and the targets carry them. The one model every
/// validation, fold score and loaded-pose check evaluates.
fn evaluation_model<'a>(
    model: &'a Model,
    set: &MeasurementSet,
    robot: Robot<'_>,
    (policy, later_stations): (FramePolicy, &[Isometry3<f64>]),
    orientation: bool,
) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
    let refit_target = matches!(policy, FramePolicy::Refit { refit_target: true });
    let treatment = if refit_target {
        FrameTreatment::Identify
    } else {
        FrameTreatment::Fixed
    };
    let targets = robot
        .targets
        .into_iter()
        .map(|t| Target { treatment, ..t })
        .collect();
    let set = set.with_targets(targets)?;
    let mut starts =
        FrameStarts::nominal(&set, Isometry3::identity(), (!orientation).then_some(false))?;
    let registered = match policy {
        FramePolicy::Fixed(first) => {
            starts.stations = fixed_stations(&set, first, later_stations)?;
            None
        }
        FramePolicy::Refit { .. } => {
            // Each station's frame from its own poses; a station a subset
            // left without poses keeps a placeholder that moves nothing.
            let frames = target_frames(model, &set, robot.xi)?;
            let registered = register_stations(&set, &frames, &starts.targets)?;
            let placeholder = registered
                .iter()
                .flatten()
                .next()
                .copied()
                .unwrap_or_else(Isometry3::identity);
            starts.stations = registered
                .iter()
                .map(|r| r.unwrap_or(placeholder))
                .collect();
            Some(registered)
        }
    };
    let problem = ErrorModel::new(model, Cow::Owned(set), &starts)?
        .with_elastic(robot.elastic.map(|(g, _)| g), robot.joint.0)?;
    let mut x = problem.initial_unknowns();
    x[..model.n_params()].copy_from_slice(robot.xi);
    set_elastic_values(
        &problem,
        &mut x,
        robot.elastic.map(|(_, v)| v),
        robot.joint.1,
    )?;
    if let Some(registered) = registered {
        let free_stations: Vec<bool> = registered.iter().map(Option::is_some).collect();
        x = refit_frames(&problem, x, &free_stations, refit_target)?;
    }
    Ok((problem, x))
}

/// The fixed measurement frame of every station of `set`: `first` for
/// the first, `later` for the next ones.
///
/// # Errors
/// [`CalibError::InvalidOption`] (`frame_policy`) when `set` has more
/// stations than frames are known.
fn fixed_stations(
    set: &MeasurementSet,
    first: Isometry3<f64>,
    later: &[Isometry3<f64>],
) -> Result<Vec<Isometry3<f64>>, CalibError> {
    let n = set.n_stations();
    if n > later.len() + 1 {
        return Err(CalibError::InvalidOption {
            name: "frame_policy",
            reason: format!(
                "{} measurement frames known for the {n} stations of {}: re-fit them",
                later.len() + 1,
                set.source
            ),
        });
    }
    Ok(std::iter::once(first)
        .chain(later.iter().copied())
        .take(n)
        .collect())
}

/// The unknowns `x` of `problem` with the measurement frame of every
/// station where `free_stations` fitted again (and the first target's
/// offset when `refit_target`), everything else frozen. Orientation rows
/// weigh 0.01 deg like 50 um, as in the identification defaults.
///
/// # Errors
/// A failing solver.
fn refit_frames(
    problem: &ErrorModel<'_>,
    x: Vec<f64>,
    free_stations: &[bool],
    refit_target: bool,
) -> Result<Vec<f64>, CalibError> {
    let mut fixed = vec![true; x.len()];
    for (s, _) in free_stations.iter().enumerate().filter(|(_, free)| **free) {
        let o = problem.station_frame_offset(s);
        fixed[o..o + 6].fill(false);
    }
    if refit_target {
        let to = problem.target_offset(0);
        let n = if problem.uses_orientation(0) {
            problem.target_unknowns(0)
        } else {
            3
        };
        fixed[to..to + n].fill(false);
    }
    let weights = (0..problem.n_observations())
        .flat_map(|i| {
            problem.block_rows(i).enumerate().map(|(r, _)| {
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
        fixed,
        ..ProblemSetup::default()
    };
    // The robot is frozen: its parameter Jacobian is not needed.
    problem.set_robot_columns(false);
    Ok(LevenbergMarquardt::params()
        .solve(problem, &x, &setup, &mut ())
        .map_err(CalibError::optim(
            "validation re-fit of the measurement frame",
        ))?
        .x)
}

/// The measurement frame `x_meas_base` at `x` of the first station the
/// poses of `problem` come from.
fn first_station_frame(problem: &ErrorModel<'_>, x: &[f64]) -> Isometry3<f64> {
    let set = problem.set();
    let first = (0..set.len()).map(|k| set.station_of(k)).min().unwrap_or(0);
    problem.station_frame(x, first)
}

/// Writes the elastic unknowns `elastic` and the joint terms' `joint`
/// into `x` at their places in `problem`.
///
/// # Errors
/// [`CalibError::InvalidOption`] when their numbers do not match the model.
fn set_elastic_values(
    problem: &ErrorModel<'_>,
    x: &mut [f64],
    elastic: Option<&[f64]>,
    joint: &[f64],
) -> Result<(), CalibError> {
    let joint_start = problem.joint_terms_offset().unwrap_or(x.len());
    if joint.len() != x.len() - joint_start {
        return Err(CalibError::InvalidOption {
            name: "joint_terms",
            reason: format!(
                "{} joint-term values given, the model has {}",
                joint.len(),
                x.len() - joint_start
            ),
        });
    }
    x[joint_start..].copy_from_slice(joint);
    if let (Some(values), Some(eo)) = (elastic, problem.elastic_offset()) {
        if values.len() != joint_start - eo {
            return Err(CalibError::InvalidOption {
                name: "elastic",
                reason: format!(
                    "{} elastic values given, the model has {}",
                    values.len(),
                    joint_start - eo
                ),
            });
        }
        x[eo..joint_start].copy_from_slice(values);
    }
    Ok(())
}

/// What validation fits again on the validation set, the robot frozen
/// ([`Calibration::validate`]). `false` and `true` convert to
/// [`Refit::Frames`] and [`Refit::FramesAndTarget`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Refit {
    /// Nothing: the calibration's measurement frames (the frames fitted
    /// with the nominal robot for the "before") and target offsets, as
    /// for a validation set measured from the same tracker placement.
    Nothing,
    /// The measurement frames, as when the tracker was moved between the
    /// series. They stay fixed when the identification fixed them.
    Frames,
    /// The measurement frames and the offset of the one target of a set of
    /// one target per pose (not offered with several targets).
    FramesAndTarget,
}

impl From<bool> for Refit {
    /// `refit_target`: the frames, and the target offset when `true`.
    fn from(refit_target: bool) -> Self {
        if refit_target {
            Self::FramesAndTarget
        } else {
            Self::Frames
        }
    }
}

/// Errors on a validation set before (nominal robot with the frames and
/// target offsets fitted for it) and after (identified robot and targets)
/// calibration, overall and target by target.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidationReport {
    /// Nominal robot.
    pub before: ErrorStatistics,
    /// Calibrated robot.
    pub after: ErrorStatistics,
    /// Errors before, target by target (one entry, the whole set, for one
    /// target per pose).
    pub per_target_before: Vec<TargetErrors>,
    /// Errors after, target by target.
    pub per_target_after: Vec<TargetErrors>,
    /// Errors after calibration of every observation, in the set's order
    /// (pose by pose, target by target; one per pose for one target).
    pub after_per_pose: Vec<PoseError>,
    /// The same errors labelled with their pose and target.
    pub observation_errors: Vec<ObservationError>,
    /// Measurement frame `x_meas_base` of the "after" errors: re-fitted on
    /// the validation data, or the identification's when it was kept.
    pub measurement_frame: Isometry3<f64>,
    /// Whether the measurement frames were fitted again on this set.
    pub frame_refitted: bool,
    /// How the measurement frame was obtained, in words.
    pub frame_note: String,
    /// Per actuated coordinate outside the identification range on some
    /// validation poses: `(name, fraction of the validation poses outside)`.
    pub extrapolated_coordinates: Vec<(String, f64)>,
    /// Repeated readings and suspect observations of the validation set
    /// (with the calibrated robot).
    pub data_checks: DataChecks,
}

/// The errors of a model on a set: per observation, labelled, per target,
/// and the measurement frame they were taken in.
struct Evaluation {
    errors: Vec<PoseError>,
    observations: Vec<ObservationError>,
    per_target: Vec<TargetErrors>,
    frame: Isometry3<f64>,
}

impl Evaluation {
    /// The errors of `problem` at its unknowns `x`.
    fn of(problem: &ErrorModel<'_>, x: &[f64]) -> Result<Self, CalibError> {
        let errors = problem.errors(x)?;
        Ok(Self {
            observations: observation_errors(problem, &errors),
            per_target: per_target(problem, &errors),
            frame: first_station_frame(problem, x),
            errors,
        })
    }
}

impl ValidationReport {
    /// Replaces the errors after calibration by `errors` (one per
    /// observation, in the same order, in the measurement frame
    /// `frame`) and updates every figure drawn from them.
    ///
    /// # Errors
    /// As [`DataChecks::new`].
    pub(crate) fn set_after(
        &mut self,
        set: &MeasurementSet,
        errors: Vec<PoseError>,
        frame: Isometry3<f64>,
    ) -> Result<(), CalibError> {
        for (o, e) in self.observation_errors.iter_mut().zip(&errors) {
            o.error = e.position_vector;
            o.orientation_error = e.orientation;
        }
        for t in &mut self.per_target_after {
            let mine: Vec<PoseError> = errors
                .iter()
                .zip(&self.observation_errors)
                .filter(|(_, o)| o.target == t.target)
                .map(|(e, _)| *e)
                .collect();
            t.statistics = error_statistics(&mine);
        }
        self.after = error_statistics(&errors);
        let norms: Vec<f64> = errors.iter().map(|e| e.position).collect();
        self.data_checks = DataChecks::new(set, &norms)?;
        self.after_per_pose = errors;
        self.measurement_frame = frame;
        Ok(())
    }
}

impl Calibration {
    /// Per-pose errors after calibration on the identification set `set`
    /// (the one given to [`crate::calibrate`]), with the identified frames.
    ///
    /// # Errors
    /// As [`evaluate_errors`].
    pub fn training_errors(
        &self,
        model: &Model,
        set: &MeasurementSet,
    ) -> Result<Vec<PoseError>, CalibError> {
        self.errors_after(model, set, FramePolicy::Fixed(self.x_meas_base))
            .map(|(errors, _)| errors)
    }

    /// Per-pose errors of the calibrated robot on `set` and the measurement
    /// frame used, taken or re-fitted according to `policy`.
    pub(crate) fn errors_after(
        &self,
        model: &Model,
        set: &MeasurementSet,
        policy: FramePolicy,
    ) -> Result<(Vec<PoseError>, Isometry3<f64>), CalibError> {
        let (problem, x) = self.after_model(model, set, policy)?;
        Ok((problem.errors(&x)?, first_station_frame(&problem, &x)))
    }

    /// The model of the calibrated robot on `set`, the frames taken or
    /// re-fitted according to `policy`.
    fn after_model<'a>(
        &self,
        model: &'a Model,
        set: &MeasurementSet,
        policy: FramePolicy,
    ) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
        evaluation_model(
            model,
            set,
            self.calibrated(),
            (policy, &self.station_frames),
            self.use_orientation,
        )
    }

    /// How validation treats the measurement frames, and that in words:
    /// the identification's frames when they were fixed or `refit` is
    /// [`Refit::Nothing`], else re-fitted (with the target position for
    /// [`Refit::FramesAndTarget`]). The policy of the "before" comes first,
    /// then that of the "after".
    pub(crate) fn validation_policy(&self, refit: Refit) -> ([FramePolicy; 2], String) {
        let refit_target = refit == Refit::FramesAndTarget;
        // A calibration of several targets speaks of its frames and
        // offsets in the plural.
        let s = if self.targets.len() > 1 { "s" } else { "" };
        if self.measurement_frame_fixed {
            (
                [FramePolicy::Fixed(self.x_meas_base); 2],
                format!("measurement frame{s} fixed (as in the identification); nothing re-fitted"),
            )
        } else if refit == Refit::Nothing {
            (
                [
                    FramePolicy::Fixed(self.x_meas_base_nominal_robot),
                    FramePolicy::Fixed(self.x_meas_base),
                ],
                format!(
                    "measurement frame{s} as identified (same tracker placement); nothing re-fitted"
                ),
            )
        } else {
            let (with, frozen) = if refit_target {
                (" and target offset", "")
            } else {
                ("", " and target offset")
            };
            (
                [FramePolicy::Refit { refit_target }; 2],
                format!(
                    "measurement frame{s} (tracker -> base){with} re-fitted on the validation data; robot parameters{frozen}{s} frozen"
                ),
            )
        }
    }

    /// Validates on a separate set `set` of the same targets: the errors of
    /// the nominal robot (with the frames and offsets fitted for it) and of
    /// the calibrated robot, overall and target by target, with what
    /// `refit` says fitted again on `set`, the robot frozen (`false`: the
    /// measurement frames, `true`: also the offset of the one target of a
    /// set of one target per pose; see [`Refit`]).
    ///
    /// # Errors
    /// Targets that differ from the calibration's by name, mismatched
    /// coordinates, a model failure at a pose, a degenerate registration,
    /// a failing re-fit; [`CalibError::InvalidOption`] (`refit`) for
    /// [`Refit::FramesAndTarget`] with several targets.
    pub fn validate(
        &self,
        model: &Model,
        set: &MeasurementSet,
        refit: impl Into<Refit>,
    ) -> Result<ValidationReport, CalibError> {
        let refit = refit.into();
        if refit == Refit::FramesAndTarget && self.targets.len() > 1 {
            return Err(CalibError::InvalidOption {
                name: "refit",
                reason: format!(
                    "the target offsets are re-fitted on a set of one target per pose only; {} has {} targets",
                    set.source,
                    set.targets().len()
                ),
            });
        }
        let ([before_policy, after_policy], frame_note) = self.validation_policy(refit);
        let (problem, x) = evaluation_model(
            model,
            set,
            self.nominal(),
            (before_policy, &self.station_frames),
            self.use_orientation,
        )?;
        let before = Evaluation::of(&problem, &x)?;
        let (problem, x) = self.after_model(model, set, after_policy)?;
        let after = Evaluation::of(&problem, &x)?;
        let frame_refitted = matches!(after_policy, FramePolicy::Refit { .. });
        Ok(ValidationReport {
            before: error_statistics(&before.errors),
            after: error_statistics(&after.errors),
            per_target_before: before.per_target,
            per_target_after: after.per_target,
            data_checks: DataChecks::new(
                set,
                &after.errors.iter().map(|e| e.position).collect::<Vec<_>>(),
            )?,
            after_per_pose: after.errors,
            observation_errors: after.observations,
            measurement_frame: after.frame,
            frame_refitted,
            frame_note,
            // Which coordinates of the validation poses leave the
            // identification poses' ranges (a joint whose motion does not
            // change the errors, like a vertical first axis, may do so
            // harmlessly).
            extrapolated_coordinates: crate::coverage::extrapolated_coordinates(
                model.actuated_names(),
                &self.actuated_ranges,
                set.poses().iter().map(|p| p.q.as_slice()),
            ),
        })
    }
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
    calibration: &Calibration,
    set: &MeasurementSet,
) -> Result<Vec<f64>, CalibError> {
    let (problem, x) = evaluation_model(
        model,
        set,
        calibration.calibrated(),
        (
            FramePolicy::Fixed(calibration.x_meas_base),
            &calibration.station_frames,
        ),
        false,
    )?;
    Ok(problem.errors(&x)?.iter().map(|e| e.position).collect())
}
