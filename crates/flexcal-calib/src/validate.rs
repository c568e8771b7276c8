//! Validation metrics: position and orientation errors before and after
//! calibration, on the identification set or a separate validation set.

use std::borrow::Cow;

use flexcal_kinematics::Model;
use flexcal_optim::{
    ColumnScaling, Control, IterationState, LevenbergMarquardt, ProblemSetup, Residuals,
};
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
    joint_terms: (&JointTerms, &[f64]),
    x_tcp_target: &Isometry3<f64>,
    policy: FramePolicy,
    use_orientation: bool,
) -> Result<(Vec<PoseError>, Isometry3<f64>), CalibError> {
    let (problem, x) = one_target_model(
        model,
        set,
        xi,
        elastic,
        joint_terms,
        x_tcp_target,
        (policy, &[]),
        use_orientation,
    )?;
    Ok((problem.errors(&x)?, first_station_frame(&problem, &x)))
}

/// The model of [`evaluate_errors_with_terms`] with its unknowns: the
/// robot at `xi`, the target at `x_tcp_target`, the measurement frames
/// taken or re-fitted according to `policy` (a fixed first frame comes
/// with the fixed frames of the later stations of `set`: a calibration's
/// [`Calibration::station_frames`]).
#[allow(clippy::too_many_arguments)]
fn one_target_model<'a>(
    model: &'a Model,
    set: &MeasurementSet,
    xi: &[f64],
    elastic: Option<(&GravityCompliance, &[f64])>,
    (joint_terms, joint_values): (&JointTerms, &[f64]),
    x_tcp_target: &Isometry3<f64>,
    (policy, fixed_stations): (FramePolicy, &[Isometry3<f64>]),
    use_orientation: bool,
) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
    let use_orientation = use_orientation && set.has_orientation();
    let targets = set.clone();
    let mut starts = FrameStarts::nominal(&targets, Isometry3::identity(), Some(use_orientation))?;
    starts.targets[0] = *x_tcp_target;
    let refit_target = match policy {
        FramePolicy::Fixed(x_meas_base) => {
            if fixed_stations.len() + 1 < set.n_stations() {
                return Err(CalibError::InvalidOption {
                    name: "frame_policy",
                    reason: format!(
                        "one fixed measurement frame for the {} stations of {}: re-fit them",
                        set.n_stations(),
                        set.source
                    ),
                });
            }
            starts.stations = std::iter::once(x_meas_base)
                .chain(fixed_stations.iter().copied())
                .collect();
            None
        }
        FramePolicy::Refit { refit_target } => {
            // Each station's frame from its own poses; a station a subset
            // left without poses keeps a placeholder that moves nothing.
            let frames = target_frames(model, &targets, xi)?;
            let registered = register_stations(&targets, &frames, &starts.targets)?;
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
            Some((refit_target, registered))
        }
    };
    let problem = ErrorModel::new(model, Cow::Owned(targets), &starts)?
        .with_elastic(elastic.map(|(g, _)| g), joint_terms)?;
    let mut x = problem.initial_unknowns();
    x[..model.n_params()].copy_from_slice(xi);
    set_elastic_values(&problem, &mut x, elastic.map(|(_, v)| v), joint_values)?;
    if let Some((refit_target, registered)) = refit_target {
        let n = problem.n_unknowns();
        let to = problem.target_offset(0);
        let mut fixed = vec![true; n];
        for (s, start) in registered.iter().enumerate() {
            if start.is_some() {
                let o = problem.station_frame_offset(s);
                fixed[o..o + 6].fill(false);
            }
        }
        if refit_target {
            fixed[to..to + 3].fill(false);
            if use_orientation {
                fixed[to + 3..to + 6].fill(false);
            }
        }
        let mut weights = Vec::with_capacity(problem.n_residuals());
        for _ in 0..set.len() {
            weights.extend([1.0; 3]);
            if use_orientation {
                // 0.01 deg weighs like 50 um, as in the identification defaults.
                weights.extend([50e-6 / 0.01f64.to_radians(); 3]);
            }
        }
        let setup = ProblemSetup {
            row_weights: Some(weights),
            fixed,
            ..ProblemSetup::default()
        };
        // The robot is frozen: its parameter Jacobian is not needed.
        problem.set_robot_columns(false);
        x = LevenbergMarquardt::params()
            .solve(&problem, &x, &setup, &mut ())
            .map_err(CalibError::optim(
                "validation re-fit of the measurement frame",
            ))?
            .x;
    }
    Ok((problem, x))
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
    /// series. With one target per pose they stay fixed when the
    /// identification fixed them.
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

    /// The model of the calibrated robot on a set of one target per pose,
    /// the frames taken or re-fitted according to `policy`.
    fn after_model<'a>(
        &self,
        model: &'a Model,
        set: &MeasurementSet,
        policy: FramePolicy,
    ) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
        one_target_model(
            model,
            set,
            &self.xi,
            self.elastic.as_ref().map(|(g, v)| (g, v.as_slice())),
            (&self.joint_terms, &self.joint_term_values),
            &self.x_tcp_target(),
            (policy, &self.station_frames),
            self.use_orientation,
        )
    }

    /// How validation of a set of one target per pose treats the
    /// measurement frame, and that in words: the identification's frame
    /// when it was fixed or `refit` is [`Refit::Nothing`], else re-fitted
    /// (with the target position for [`Refit::FramesAndTarget`]). The
    /// policy of the "before" comes first, then that of the "after".
    pub(crate) fn validation_policy(&self, refit: Refit) -> ([FramePolicy; 2], String) {
        let refit_target = refit == Refit::FramesAndTarget;
        if self.measurement_frame_fixed {
            (
                [FramePolicy::Fixed(self.x_meas_base); 2],
                "measurement frame fixed (as in the identification); nothing re-fitted".to_string(),
            )
        } else if refit == Refit::Nothing {
            (
                [
                    FramePolicy::Fixed(self.x_meas_base_nominal_robot),
                    FramePolicy::Fixed(self.x_meas_base),
                ],
                "measurement frame as identified (same tracker placement); nothing re-fitted"
                    .to_string(),
            )
        } else {
            (
                [FramePolicy::Refit { refit_target }; 2],
                format!(
                    "measurement frame (tracker -> base){} re-fitted on the validation data; robot parameters{} frozen",
                    if refit_target {
                        " and target offset"
                    } else {
                        ""
                    },
                    if refit_target {
                        ""
                    } else {
                        " and target offset"
                    }
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
        let (before, after, frame_refitted, frame_note) =
            if set.is_one_target() && self.has_implicit_target() {
                self.validate_one_target(model, set, refit)?
            } else {
                self.validate_several(model, set, refit)?
            };
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

    /// [`Calibration::validate`] on a set of one target per pose: the
    /// measurement frame registered in closed form and refined, the target
    /// offset with it when asked. Before, after, whether the frame was
    /// re-fitted, and how in words.
    fn validate_one_target(
        &self,
        model: &Model,
        set: &MeasurementSet,
        refit: Refit,
    ) -> Result<(Evaluation, Evaluation, bool, String), CalibError> {
        let ([before_policy, after_policy], note) = self.validation_policy(refit);
        let (problem, x) = one_target_model(
            model,
            set,
            &self.nominal_xi,
            None,
            (&JointTerms::default(), &[]),
            &self.x_tcp_target_nominal_robot(),
            (before_policy, &[]),
            self.use_orientation,
        )?;
        let before = Evaluation::of(&problem, &x)?;
        let (problem, x) = self.after_model(model, set, after_policy)?;
        let after = Evaluation::of(&problem, &x)?;
        let refitted = matches!(after_policy, FramePolicy::Refit { .. });
        Ok((before, after, refitted, note))
    }

    /// [`Calibration::validate`] on a set of several targets: the target
    /// offsets kept, the measurement frames of every station fitted again
    /// unless `refit` is [`Refit::Nothing`].
    fn validate_several(
        &self,
        model: &Model,
        set: &MeasurementSet,
        refit: Refit,
    ) -> Result<(Evaluation, Evaluation, bool, String), CalibError> {
        if refit == Refit::FramesAndTarget {
            return Err(CalibError::InvalidOption {
                name: "refit",
                reason: format!(
                    "the target offsets are re-fitted on a set of one target per pose only; {} has {} targets",
                    set.source,
                    set.targets().len()
                ),
            });
        }
        let refit_frame = refit == Refit::Frames;
        let nominal = set.with_targets(fixed_offsets(&self.targets_nominal_robot))?;
        let calibrated = set.with_targets(fixed_offsets(&self.targets))?;
        let evaluate = |set: &MeasurementSet, robot: (&[f64], bool), x_meas_base| {
            let (problem, mut x) = fitted_model(model, self, set, robot, x_meas_base, true)?;
            if refit_frame {
                x = refit_frames(&problem, x)?;
            }
            Evaluation::of(&problem, &x)
        };
        let before = evaluate(
            &nominal,
            (&self.nominal_xi, false),
            self.x_meas_base_nominal_robot,
        )?;
        let after = evaluate(&calibrated, (&self.xi, true), self.x_meas_base)?;
        let note = if refit_frame {
            "measurement frames (tracker -> base) re-fitted on the validation data; robot parameters and target offsets frozen"
        } else {
            "measurement frames as identified (same tracker placement); nothing re-fitted"
        };
        Ok((before, after, refit_frame, note.to_string()))
    }
}

/// The unknowns `x` of `problem` with the measurement frame of every
/// station fitted again, everything else frozen.
///
/// # Errors
/// A failing solver.
fn refit_frames(problem: &ErrorModel<'_>, x: Vec<f64>) -> Result<Vec<f64>, CalibError> {
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
    Ok(LevenbergMarquardt::params()
        .max_iterations(100)
        .solve(problem, &x, &setup, &mut observer)
        .map_err(CalibError::optim("validation frame fit"))?
        .x)
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
    calibration: &Calibration,
    set: &'a MeasurementSet,
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
    calibration: &Calibration,
    set: &MeasurementSet,
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
