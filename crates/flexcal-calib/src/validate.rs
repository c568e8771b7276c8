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
    evaluate_errors_at_stations(
        model,
        set,
        xi,
        elastic,
        joint_terms,
        x_tcp_target,
        (policy, &[]),
        use_orientation,
    )
}

/// [`evaluate_errors_with_terms`] where a fixed measurement frame comes
/// with the fixed frames of the later stations of `set` (a calibration's
/// [`Calibration::station_frames`]).
#[allow(clippy::too_many_arguments)]
fn evaluate_errors_at_stations(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
    elastic: Option<(&GravityCompliance, &[f64])>,
    (joint_terms, joint_values): (&JointTerms, &[f64]),
    x_tcp_target: &Isometry3<f64>,
    (policy, fixed_stations): (FramePolicy, &[Isometry3<f64>]),
    use_orientation: bool,
) -> Result<(Vec<PoseError>, Isometry3<f64>), CalibError> {
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
    // The frame of the first station the poses come from.
    let first = (0..set.len()).map(|k| set.station_of(k)).min().unwrap_or(0);
    let x_meas_base = problem.station_frame(&x, first);
    Ok((problem.errors(&x)?, x_meas_base))
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

/// Errors on a validation set before (nominal robot with the target offset
/// fitted for it) and after (identified robot and target) calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationReport {
    /// Nominal robot.
    pub before: ErrorStatistics,
    /// Calibrated robot.
    pub after: ErrorStatistics,
    /// Per-pose errors after calibration.
    pub after_per_pose: Vec<PoseError>,
    /// Measurement frame `x_meas_base` of the "after" errors: re-fitted on
    /// the validation data, or the identification's when it was fixed.
    pub measurement_frame: Isometry3<f64>,
    /// How the measurement frame was obtained, in words.
    pub frame_note: String,
    /// Per actuated coordinate outside the identification range on some
    /// validation poses: `(name, fraction of the validation poses outside)`.
    pub extrapolated_coordinates: Vec<(String, f64)>,
    /// Repeated readings and suspect poses of the validation set (with the
    /// calibrated robot).
    pub data_checks: DataChecks,
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
        evaluate_errors_at_stations(
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

    /// How validation treats the measurement frame, and that in words: the
    /// identification's frame when it was fixed, else re-fitted (with the
    /// target position when `refit_target`).
    pub(crate) fn validation_policy(&self, refit_target: bool) -> (FramePolicy, String) {
        if self.measurement_frame_fixed {
            (
                FramePolicy::Fixed(self.x_meas_base),
                "measurement frame fixed (as in the identification); nothing re-fitted".to_string(),
            )
        } else {
            (
                FramePolicy::Refit { refit_target },
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

    /// Validates on a separate set. If the identification kept the
    /// measurement frame fixed, the same frame is used; otherwise only the
    /// measurement frame (and, with `refit_target`, the target position) is
    /// re-fitted on the validation data, robot parameters frozen.
    ///
    /// # Errors
    /// As [`evaluate_errors`].
    pub fn validate(
        &self,
        model: &Model,
        set: &MeasurementSet,
        refit_target: bool,
    ) -> Result<ValidationReport, CalibError> {
        let (policy, frame_note) = self.validation_policy(refit_target);
        let (before, _) = evaluate_errors(
            model,
            set,
            &self.nominal_xi,
            None,
            &self.x_tcp_target_nominal_robot(),
            policy,
            self.use_orientation,
        )?;
        let before = error_statistics(&before);
        let (after_per_pose, measurement_frame) = self.errors_after(model, set, policy)?;
        // Extrapolation: which coordinates of the validation poses leave the
        // identification poses' ranges (a joint whose motion does not change
        // the errors, like a vertical first axis, may do so harmlessly).
        let extrapolated_coordinates = crate::coverage::extrapolated_coordinates(
            model.actuated_names(),
            &self.actuated_ranges,
            set.poses().iter().map(|p| p.q.as_slice()),
        );
        Ok(ValidationReport {
            before,
            after: error_statistics(&after_per_pose),
            data_checks: DataChecks::new(
                set,
                &after_per_pose
                    .iter()
                    .map(|e| e.position)
                    .collect::<Vec<_>>(),
            )?,
            after_per_pose,
            measurement_frame,
            frame_note,
            extrapolated_coordinates,
        })
    }
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

/// Evaluates `calibration` on `set` (same targets by name; see
/// [`TargetValidation`]).
///
/// # Errors
/// Targets that differ from the calibration's by name, mismatched
/// coordinates, a model failure at a pose, a solver failure of the frame fit.
pub fn validate_targets(
    model: &Model,
    calibration: &Calibration,
    set: &MeasurementSet,
    refit_frame: bool,
) -> Result<TargetValidation, CalibError> {
    let nominal = set.with_targets(fixed_offsets(&calibration.targets_nominal_robot))?;
    let calibrated = set.with_targets(fixed_offsets(&calibration.targets))?;
    let evaluate = |set: &MeasurementSet,
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
        data_checks: DataChecks::new(
            set,
            &observation_errors
                .iter()
                .map(|e| e.error.norm())
                .collect::<Vec<_>>(),
        )?,
        observation_errors,
        extrapolated_coordinates: crate::coverage::extrapolated_coordinates(
            model.actuated_names(),
            &calibration.actuated_ranges,
            set.poses().iter().map(|p| p.q.as_slice()),
        ),
    })
}
