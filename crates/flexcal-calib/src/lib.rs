//! # flexcal-calib
//!
//! Geometric and elasto-geometric calibration of any robot flexcal can
//! describe: measurement sets
//! and their files, the stacked error model, identifiability (which
//! parameters the poses identify, and which combinations the identified ones
//! stand for), iterative identification with standard errors, validation
//! before/after, and pose selection. It is sections 2.1.5 and 3.2 of the
//! reference paper, on real (laser tracker) and simulated measurements.
//!
//! ```
//! use flexcal_calib::{CalibrationOptions, FrameTreatment, Measurement, MeasurementSet, calibrate};
//! use flexcal_kinematics::{Data, RobotDescription, forward_pose};
//!
//! let model = RobotDescription::builtin("ur10")?.build()?;
//! // A "true" robot: nominal with d3 1 mm longer; measurements in the base frame.
//! let mut truth = model.nominal_params().to_vec();
//! truth[model.param_index("d3").unwrap()] += 1e-3;
//! let mut data = Data::new(&model);
//! let mut poses = Vec::new();
//! for k in 0..30 {
//!     let t = k as f64;
//!     let q = vec![0.1 * t, -1.0 + 0.05 * t, 1.0 - 0.03 * t, 0.2 * t.sin(), 0.7 + 0.1 * t.cos(), 0.3 * t];
//!     let x = forward_pose(&model, &mut data, &q, &truth)?;
//!     poses.push(Measurement::new(q, x.translation.vector));
//! }
//! let set = MeasurementSet::new("example", poses)?;
//! let mut options = CalibrationOptions::for_model(&model);
//! options.measurement_frame = FrameTreatment::Fixed; // already in R0
//! options.target = FrameTreatment::Fixed;            // the TCP itself
//! let calibration = calibrate(&model, &set, &options)?;
//! assert!(calibration.training_after.position_max < 1e-7);
//! println!("rank {}, not identifiable: {:?}", calibration.rank(), calibration.non_identifiable());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## The pipeline
//! One identification, for one target and for several
//! ([`identification`]); each step in the module named for it:
//!
//! 1. **Settings** ([`options`]): [`CalibrationOptions`], checked by name.
//! 2. **Measurements** ([`targets`], [`measurement`]): an observation is a
//!    target (a named frame of the robot with an offset) seen at a pose,
//!    with its position and, where the target carries one, its
//!    orientation, each with its standard deviation; observations are
//!    grouped by pose and by station, each pose with its actuated
//!    coordinates and, when known, the wrench on the tool and the
//!    temperature: one type, [`MeasurementSet`]. The one-target files
//!    (flexcal's CSV, the IPA export) read into it as one target
//!    [`TCP_TARGET`] on the TCP (the IPA probe offset its nominal pose),
//!    and [`Measurement`] is the convenient row of such a set
//!    ([`MeasurementSet::new`], [`MeasurementSet::measurements`]); the CSV
//!    with per-target columns and its targets description read into the
//!    same type ([`MeasurementSet::read_targets_csv`]).
//!    `TargetMeasurementSet` remains one release as a deprecated alias of
//!    [`MeasurementSet`].
//! 3. **Measurement model** ([`error_model`]): [`ErrorModel`], the stacked
//!    residuals and their exact Jacobian, with the elasto-geometric terms
//!    ([`gravity`], [`joint_law`]). Both are evaluated over the poses on
//!    [`CalibrationOptions::threads`] threads ([`ErrorModel::with_threads`]):
//!    contiguous chunks of whole poses, each thread with its own
//!    workspace, the same numbers to the bit as on one.
//! 4. **Starting frames** ([`start`]): each station's measurement frame
//!    registered in closed form, each target's orientation from the data.
//! 5. **Identification** ([`identification`]): the unknowns laid out, the
//!    rows weighted, the frames fitted on the nominal robot, then the
//!    rank-revealing analysis and the solver rounds ([`mod@analysis`]:
//!    pivoted QR, noise-aware base set, joint-term limits,
//!    compliances on their own scale, [`significance`]), the statistics
//!    ([`unknowns`], [`spread`]).
//! 6. **Results**: [`calibrate`] packs what it found into one
//!    [`Calibration`] ([`identify`]), target by target, the one target of
//!    a one-target set unnamed.
//! 7. **Checks and reports**: validation ([`validate`]:
//!    [`Calibration::validate`], overall and target by target), data checks ([`screen`]), split-half
//!    ([`split`]), cross-series ([`cross`]), station hold-out ([`holdout`]),
//!    predicted accuracy ([`accuracy`]), model selection ([`selection`]),
//!    the JSON report ([`report`]).
//!
//! ## Measurement model
//! For pose k the target point (or frame) on the tool is seen in the
//! measurement frame M: `x_meas_target = x_meas_base(tau) * FK(q_k, xi) *
//! x_tcp_target(t)`. The unknowns are the robot parameters xi
//! ([`flexcal_kinematics::Model::params`]), the measurement frame tau (6:
//! `frame_x..frame_rz`, a translation increment and a left rotation vector
//! about a closed-form registration of nominal positions onto measured
//! ones — Kabsch/Horn by SVD) and the target offset t (6: `target_x..target_rz`;
//! the rotation only when orientations are measured). Either frame may be
//! fixed ([`FrameTreatment`]), any parameter masked ([`CalibrationOptions::fixed`]).
//! With orientations used and the target free, the target's rotation starts
//! from the data, the mean over the poses of the rotation each implies
//! ([`start`]), as the measurement frame starts from a registration of the
//! positions.
//! Residuals are `predicted - measured` positions (m) and rotation vectors
//! `log(R_pred R_meas^T)` (rad), weighted by `1/sigma` per axis.
//!
//! ## Several stations
//! A tracker moved to see another part of the workspace, or a campaign of
//! another day, sees the same robot and target from another measurement
//! frame. [`MeasurementSet::pooled`] (or a `station` column) makes each a
//! station; the model then has one measurement frame per station
//! (`frame_s2_x..`, [`station_frame_names`]), each started from the
//! registration of its own poses, with the robot and the target shared:
//! pose k is predicted as `x_meas_base(s_k) * FK(q_k, xi) *
//! x_tcp_target`. Folds of the model selection and halves of the
//! split-half check take every station's poses in turn, validation
//! re-fits one frame per station, and [`hold_out_stations`] identifies on
//! all stations but one and validates on it, for each.
//!
//! ## Several targets, tree-structured robots
//! A [`MeasurementSet`] holds several targets per pose, each fixed to a
//! named frame of the robot (markers on the two hands of a two-armed robot,
//! reflectors on a tool, a probe on a link), possibly occluded on some
//! poses; its files are the CSV above with `<target>_x_mm..` columns and a
//! TOML targets description ([`targets`]). [`calibrate`] stacks the
//! residuals of every target on every pose, positions and, for a target
//! with orientations (`<target>_rx_deg..`), rotations, each with the
//! parameter Jacobian of its own frame
//! ([`flexcal_kinematics::frame_param_jacobian`]), and identifies the robot,
//! the measurement frame and the offsets `target.<name>.x|y|z` (and `.rx|ry|rz` where orientations are measured) in
//! one identification (the same as for one target), with the identifiability analysis below
//! ([`Calibration::identifiability_notes`] names what the targets
//! cannot see: the other branch of a tree when its marker is missing, a
//! marker's offset along its hand's axis against the hand frame's `r`).
//! Reports give per-target figures ([`TargetErrors`], in [`Calibration`]
//! and [`ValidationReport`]).
//! The elasto-geometric terms below work with several targets too: the
//! joint springs of each target's branch deflect it, and a torso's
//! lateral tilt under both arms moves both hands. The checks and the
//! predicted accuracy are those of one target, target by target: spread
//! ratios, [`SplitCheck::new`], [`CrossCheck::new`],
//! [`Calibration::predicted_accuracy`] and
//! [`Calibration::accuracy_coverage`] (one entry per pose and target).
//! A set of one target per pose is the case of one target on the TCP
//! ([`TCP_TARGET`]).
//!
//! ## Elasto-geometric model
//! With [`CalibrationOptions::gravity`] (a [`GravityCompliance`]: the link
//! masses, gravity, payload start) the robot is evaluated at `q + dq`, where
//! `dq_i = c_i tau_i` is the deflection of a joint spring of compliance `c_i`
//! under the generalised gravity force `tau = sum_k J_k^T m_k g` of the links
//! and of the payload ([`gravity`]): the joint-spring part of the paper's
//! elastic model (13)-(16) with gravity as the load. The unknowns gain
//! `compliance_<joint>` (rad/N.m, or m/N for linear joints), `payload_mass`
//! (kg) and `payload_mx..mz` (first moment, kg.m, in the payload's frame),
//! and `payload_<name>_mass`, `_mx..mz` for each further identified payload
//! on a named frame ([`GravityCompliance::payloads`], one per hand); the same
//! identifiability analysis says which of them gravity alone identifies (a
//! vertical joint axis never is loaded). With
//! [`GravityCompliance::lateral`] each revolute joint also tilts about its
//! frame's x axis under the gravity moment of everything it carries
//! (`lateral_compliance_<joint>_x`, rad/N.m; [`gravity`], "Lateral joint
//! compliances"). With [`GravityCompliance::coupling`] a coupled joint
//! group's compliance is a symmetric, positive semi-definite matrix over
//! the passive joint and its drives (`coupling_compliance_<A>_<B>`,
//! rad/N.m; [`coupling`]). The built-in table
//! [`GravityCompliance::ur10_urdf`] holds the UR10's URDF masses; other robots
//! give a mass-table file ([`GravityCompliance::from_toml_file`]).
//!
//! ## Beyond linear joint springs, model selection, predicted accuracy
//! - [`joint_law`]: a joint stiffness law with a lost-motion zone about
//!   zero torque and a hardening spring solved at its equilibrium, and cyclic
//!   (non-geometric) joint errors, first and second harmonics of the joint
//!   angle; switched on by [`CalibrationOptions::joint_terms`].
//! - [`selection`]: which groups of unknowns (offsets, tilts, compliances,
//!   the law, cyclic errors) to identify, decided from the training poses
//!   alone by k-fold cross-validation over joint-space clusters or by BIC
//!   (the paper's removal of "parameters with little influence" before
//!   (11), by evidence): [`calibrate_selected`], `calibrate --select`.
//! - [`accuracy`]: the identification covariance, conditioned on the
//!   measurement frame and raised by the split-half check's prediction
//!   ratio where above 1, carried to the target position of any pose, with
//!   the training scatter, as a 95 % bound; its coverage on a validation
//!   series, and its misses sorted by the training ranges they leave
//!   ([`misses`]).
//!
//! ## Equations (Marie, Courteille, Maurine 2013)
//! - Pose error and linear error model (7)-(8), (49): `dS^k = J^k dxi`, with
//!   `J^k` the parameter Jacobian (50)-(52) of `flexcal-kinematics`, carried
//!   to the target and into M.
//! - Global model (9)-(10): stacked over the poses, rows weighted by
//!   `1/sigma`, columns scaled by their norms (m vs rad).
//! - Base parameters (11): pivoted QR of the scaled stacked Jacobian decides
//!   the rank; the others are reported by name with the combinations the
//!   identified ones stand for, `xi_B^id = xi_B + K xi_N`, like (C.1). The
//!   pivoting order can be steered ([`CalibrationOptions::deferred`]); for the
//!   IR-663 the default defers the paper's six non-identifiable parameters
//!   `kappa8 kappa2 r8p d9 r2 r7` (section 3.2.3).
//! - Beyond the paper, each identified unknown gets a spread ratio
//!   ([`UnknownEstimate::spread_ratio`]): its standard error over the one
//!   that as many poses drawn uniformly over the joint ranges would give
//!   (seeded, at most [`SPREAD_REFERENCE_POSES`] poses). Poses clustered in
//!   part of the joint space can identify a parameter with a small standard
//!   error yet only in a combination that holds there; ratios above
//!   [`WEAK_SPREAD_RATIO`] are named in [`Calibration::identifiability_notes`].
//! - Beyond the paper, data checks ([`DataChecks`], in
//!   [`Calibration::data_checks`] and [`ValidationReport::data_checks`]):
//!   pairs of poses at different joint coordinates with the identical
//!   measurement (a stale reading), and poses whose error after the fit
//!   exceeds [`SUSPECT_ERROR_RATIO`] times the RMS error; poses are left out
//!   by label with [`MeasurementSet::excluding`]. With several targets the
//!   same checks run per observation ([`DataChecks::new`], in
//!   [`Calibration::data_checks`] and [`ValidationReport::data_checks`]),
//!   and [`MeasurementSet::excluding`] also leaves one observation out.
//! - Beyond the paper, a split-half check of the standard errors
//!   ([`SplitCheck`]): the identified unknowns again on odd / even and first /
//!   second halves of the poses; where the halves differ by more than the
//!   standard errors allow, what the model leaves is not independent noise
//!   and the standard errors understate the uncertainty.
//! - Beyond the paper, a cross-series check ([`CrossCheck`]): the identified
//!   unknowns again on the validation set, compared in combined standard
//!   errors; values the two campaigns disagree on do not transfer.
//! - Beyond the paper, its zero-order Takagi-Sugeno models (33)-(37) of
//!   section 2.2.2 applied to what a calibration leaves: [`ResidualModel`]
//!   maps chosen actuated coordinates to a position correction in the base
//!   frame, fitted on the identification poses, validated with
//!   [`Calibration::validate_with_residual_model`].
//! - Iterative identification (12): Gauss-Newton re-linearisation or
//!   Levenberg-Marquardt ([`Method`]); the cost history is Figure 7's data.
//! - Sensitivity indices (55)-(58) are in `flexcal-kinematics`; observability
//!   indices O1-O5 and pose selection ([`select_calibration_poses`]) go beyond
//!   the paper (Sun & Hollerbach 2008).
//!
//! ## flexcal's measurement CSV format
//! Comma-separated, one header line, `#` comment lines allowed, columns in
//! any order:
//!
//! | column | unit | required |
//! |---|---|---|
//! | `pose_id` | text | no |
//! | `station` | text, the placement of the measurement system (one measurement frame each) | no |
//! | `q1` .. `qn` | rad (revolute), m (prismatic, screw) | yes |
//! | `x_mm, y_mm, z_mm` | mm, target position in the measurement frame | yes |
//! | `rx_deg, ry_deg, rz_deg` | deg, rotation vector of the target orientation | no |
//! | `sx_mm, sy_mm, sz_mm` | mm, standard deviation per position axis | no |
//! | `srx_deg, sry_deg, srz_deg` | deg, standard deviation per orientation axis | no |
//! | `fx_n, fy_n, fz_n, mx_nm, my_nm, mz_nm` | N, N.m, applied wrench | no |
//! | `temperature_c` | deg C | no |
//!
//! A group of optional columns is all present or all absent. Without a
//! `station` column the file is one station. The IPA UR10
//! laser-tracker export is read by [`MeasurementSet::read_ipa`].
//!
//! ## Identifiability in practice
//! Two decisions, both by pivoted QR of the weighted stacked Jacobian
//! (deferred names pivoted last):
//! - exact dependencies: columns scaled by their norms, relative tolerance
//!   [`CalibrationOptions::rank_tolerance`]; the unknowns beyond that rank are
//!   [`UnknownStatus::NonIdentifiable`];
//! - noise: columns scaled by a standard-error limit per unknown
//!   ([`CalibrationOptions::max_standard_error_length`], `_angle`); an unknown
//!   enters the base set only if its part orthogonal to the unknowns already
//!   chosen moves the residual by more than the noise level (1 with absolute
//!   weights, else estimated from the fit), i.e. only if it would be
//!   identified with a standard error below its limit. The others are
//!   [`UnknownStatus::PoorlyIdentifiable`].
//!
//! - compliances, last: on their own scale ([`significance`]): after the
//!   fit, a compliance is kept when its value is at least
//!   [`CalibrationOptions::min_compliance_z`] standard errors, one the fit
//!   puts below zero by as much is held at zero
//!   ([`UnknownStatus::AtBound`]); the noise is the instrument's when
//!   stated ([`CalibrationOptions::instrument_noise`]), else the file's or
//!   the fit's ([`NoiseSource`], in [`Calibration::noise`]).
//!
//! Both kinds stay at their starting (nominal) values — data that cannot
//! identify a parameter leave it alone instead of letting it wander — and
//! [`Calibration::combinations`] says what the identified ones then stand for.
//! On the virtual IR-663 (27 poses of box (59), 21 um / 0.01 deg noise) this
//! gives rank 37 of 43: `kappa2 kappa8 r2 r7 r8p` exactly dependent, `l32`
//! poorly identifiable (the paper's set has `d9` in place of `l32`; the
//! slider-crank geometry, which the paper does not publish, decides which).
//!
//! ## Limitations
//! - The elasto-geometric model has rigid links and joint springs (linear,
//!   or the law of [`joint_law`]) about the joint axes, and optionally
//!   linear lateral springs about each revolute joint frame's x axis
//!   (composed to first order; not about y, which for perpendicular
//!   successive axes is the next joint's own compliance); gravity torques are evaluated
//!   on the nominal geometry at the commanded configuration (second-order
//!   effects), and process forces are not part of it (see
//!   `flexcal-elastic` for loaded campaigns).
//! - The combinations (C.1) come from the linearised model at the solution;
//!   with errors of millimetres they hold to second order only.
//! - Standard errors are the linearised ones and ignore model error (joint
//!   compliance, thermal drift); with relative weights sigma^2 is estimated
//!   from the residual, which then includes that model error.
//! - Springs on any frame ([`gravity::Spring`]: a passive or coupled
//!   joint's own axis, a fixed mounting, a base on a pivot) are linear and
//!   composed like the lateral compliances. The deflection is by default
//!   one linear step on the commanded geometry; the equilibrium on the
//!   deflected one ([`equilibrium`], opt-in or automatic) takes the
//!   torques to first order in the deflection (on a robot of 100-400
//!   urad/N.m it leaves 0.037 mm of the one step's 1.69 mm against the
//!   exact fixed point), takes a coupling group's entries into its Newton
//!   system, and keeps the lateral springs' axes and the lateral
//!   rotations' own lever arms (a passive joint's too) on the commanded
//!   configuration.
//! - The noise-aware rank decision depends on the standard-error limits; they
//!   are judgement, not physics (see the options' defaults).
//! - The IPA standard-deviation columns are sample spreads, not accuracies:
//!   weighting by them ([`Weighting::FromFile`]) over-trusts some poses; the
//!   command line uses uniform weights for that format.
//! - The whole stacked Jacobian is dense (fine for thousands of poses).
//! - Several stations share one target offset: a probe remounted between
//!   campaigns is refused, not modelled; with the frames fixed
//!   ([`FrameTreatment::Fixed`]) every station's frame is the identity.
//! - The spread ratio compares with poses drawn over the joint limits, not
//!   over a collision-free or task workspace; a robot whose useful workspace
//!   is a small part of its joint ranges scores high everywhere.
//! - The fuzzy residual model ([`ResidualModel`], section 2.2.2's models
//!   applied to what a calibration leaves) maps a few actuated coordinates
//!   to a position correction; it is clamped outside the training range and
//!   knows nothing of loads, temperature or the measurement system, so it
//!   only carries over to poses like the training ones.

#![deny(missing_docs)]

pub mod accuracy;
pub mod analysis;
pub mod coupling;
pub mod coverage;
pub mod cross;
pub mod deflection;
mod elastic_terms;
pub mod equilibrium;
mod error;
pub mod error_model;
pub mod extrapolation;
pub mod folds;
pub mod frames;
pub mod geometry;
pub mod gravity;
pub mod holdout;
pub mod identification;
pub mod identify;
pub mod joint_law;
pub mod measurement;
pub mod metrics;
pub mod misses;
pub mod options;
mod prediction;
pub mod report;
pub mod residual;
pub mod screen;
pub mod select;
pub mod selection;
pub mod significance;
pub mod split;
pub mod spread;
pub mod start;
pub mod targets;
pub mod temperature;
mod unknown_kind;
pub mod unknowns;
pub mod validate;

pub use accuracy::{AccuracyMap, BoundParts, CHI2_3_95, FrameUncertainty, PoseAccuracy, bound_95};
pub use coupling::CouplingMatrix;
pub use coverage::CoordinateCoverage;
pub use cross::{CROSS_Z_WARNING, CrossCheck, CrossEstimate};
pub use deflection::Deflection;
pub use equilibrium::{DeflectionChoice, DeflectionReport};
pub use error::CalibError;
pub use error_model::{
    ErrorModel, FRAME_PARAMETER_NAMES, FrameStarts, TARGET_PARAMETER_NAMES, UnknownKind,
    station_frame_names, target_unknown_names,
};
/// The cancellation token of [`CalibrationOptions::cancel`].
pub use extrapolation::{
    CoordinateGrowth, ExtrapolationModel, GrowthFold, HELD_OUT_FRACTION, MIN_HELD_OUT_POSES,
};
pub use flexcal_optim::CancelToken;
pub use folds::{
    EXTRAPOLATION_END_SHARE, ExtrapolationFold, FoldScheme, MIN_EXTRAPOLATION_HELD_OUT,
};
pub use frames::TCP_FRAME;
pub use geometry::{register_points, rotation_from_vector, vector_from_rotation};
pub use gravity::{
    COUPLING_PREFIX, CouplingGroup, FrameAxis, GravityCompliance, LateralCompliance,
    PAYLOAD_PARAMETER_NAMES, Payload, PointMass, Spring, is_coupling_compliance,
};
pub use holdout::{StationHoldOut, hold_out_stations};
pub use identification::ResidualNorms;
pub use identify::{Calibration, calibrate};
pub use joint_law::{JointLaw, JointTerms};
#[allow(deprecated)]
pub use measurement::TargetMeasurementSet;
pub use measurement::{
    IPA_JOINT_COLUMNS, Measurement, MeasurementSet, TCP_TARGET, read_configurations,
    read_transform_mm,
};
pub use metrics::{
    ErrorStatistics, ObservationError, PoseError, TargetErrors, error_statistics,
    observation_errors_csv,
};
pub use misses::{CoordinateMisses, Misses, MissesByRange};
pub use options::{CalibrationOptions, FrameTreatment, IR663_PAPER_DEFERRED, Method, Weighting};
pub use report::{
    CalibrationReportJson, FrameJson, JudgementJson, NoiseJson, ParameterJson, ResidualModelJson,
    StationHoldOutJson, StationJson, StatisticsJson, TargetStatisticsEntry, TargetStatisticsJson,
    TargetSummaryJson, parameters_json, read_measurement_frame,
};
pub use residual::{RESIDUAL_TEST_FRACTION, ResidualModel};
pub use screen::{
    DataChecks, RepeatedReading, SUSPECT_ERROR_RATIO, SuspectPose, repeated_readings,
};
pub use select::{CalibrationPoseSelection, select_calibration_poses};
pub use selection::{
    CandidateScore, MIN_POSES_FOR_CROSS_VALIDATION, SelectOn, SelectionMethod, SelectionOptions,
    SelectionReport, TermGroup, calibrate_selected, candidate_options, default_method,
    default_method_for, select_model,
};
pub use significance::{InstrumentNoise, NoiseSource, ScaleJudgement, ScaleOutcome};
pub use split::{SPLIT_RATIO_WARNING, SplitCheck, SplitEstimate};
pub use spread::{SPREAD_REFERENCE_POSES, WEAK_SPREAD_RATIO};
pub use targets::{
    Target, TargetObservation, TargetPose, read_targets, targets_from_toml_str,
    targets_to_toml_string, write_targets,
};
pub use unknowns::{Combination, UnknownEstimate, UnknownStatus};
pub use validate::{
    FramePolicy, Refit, ValidationReport, evaluate_errors, evaluate_errors_with_terms,
    target_position_errors,
};
