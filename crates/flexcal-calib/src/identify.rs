//! Geometric identification: identifiability, iterative least squares,
//! standard errors, and the fitted [`Calibration`].

use faer::Mat;
use faer::prelude::SolveLstsq;
use flexcal_kinematics::{Model, RobotDescription};
use flexcal_optim::{
    CancelToken, ColumnScaling, Control, GaussNewton, IdentifiabilityOptions,
    IdentifiabilityReport, IterationState, LevenbergMarquardt, ProblemSetup, Residuals,
    SolveReport, Termination, analyze_identifiability,
};
use nalgebra::{Isometry3, Vector3};

use crate::coverage::CoordinateCoverage;
use crate::error_model::{
    GeometricErrorModel, UnknownKind, pose_errors, register_measurement_frame,
    register_target_rotation,
};
use crate::gravity::GravityCompliance;
use crate::joint_law::JointTerms;
use crate::metrics::{ErrorStatistics, PoseError, error_statistics};
use crate::screen::DataChecks;
use crate::significance::{
    InstrumentNoise, Judging, MIN_TORQUE_SHARE, NoiseSource, ScaleJudgement, ScaleOutcome, Solve,
    barely_loaded, judge_compliances, torque_magnitude,
};
use crate::{CalibError, MeasurementSet};

/// The iterative solver of the identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Levenberg-Marquardt (default): robust from a poor start.
    #[default]
    LevenbergMarquardt,
    /// The paper's Gauss-Newton re-linearisation (section 2.1.5, eq. (12)), with
    /// step halving.
    GaussNewton,
}

/// How residual rows are weighted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Weighting {
    /// `1/sigma` per axis from the file's standard deviations when it has them
    /// (then the weights are absolute: standard errors use sigma^2 = 1),
    /// otherwise the default standard deviations of [`CalibrationOptions`].
    #[default]
    FromFile,
    /// The default standard deviations of [`CalibrationOptions`] for every
    /// pose (relative weights; sigma^2 is estimated from the residual).
    Uniform,
}

/// Whether a frame (measurement frame or target offset) is identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum FrameTreatment {
    /// Identified together with the robot (default).
    #[default]
    Identify,
    /// Kept at its given (or nominal) value.
    Fixed,
}

/// Settings of [`calibrate`]. Defaults suit a laser tracker or photogrammetry
/// campaign of a few tens to thousands of poses.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationOptions {
    /// Solver (default Levenberg-Marquardt).
    pub method: Method,
    /// Use measured orientations (default `None`: when the set has them).
    pub use_orientation: Option<bool>,
    /// Row weighting (default [`Weighting::FromFile`]).
    pub weighting: Weighting,
    /// Standard deviation assumed for position axes without one (m; default
    /// 50e-6; `> 0`).
    pub default_position_std: f64,
    /// Standard deviation assumed for orientation axes without one (rad;
    /// default 0.01 deg; `> 0`). Its ratio to `default_position_std` sets the
    /// relative weight of orientation rows.
    pub default_orientation_std: f64,
    /// Names of unknowns kept at their starting value: robot parameters
    /// (`d3`, `theta1`, ...) or frame unknowns (`frame_x`, `target_z`, ...).
    pub fixed: Vec<String>,
    /// Names to leave out of the base set first when the data cannot separate
    /// them from others (lowest pivoting priority). Default: the paper's
    /// choice for the IR-663 (`kappa8 kappa2 r8p d9 r2 r7`) — see
    /// [`CalibrationOptions::for_model`].
    pub deferred: Vec<String>,
    /// Measurement frame treatment (default identified).
    pub measurement_frame: FrameTreatment,
    /// Measurement frame `x_meas_base`: the fixed value, or the starting
    /// value when identified (default `None`: identity when fixed, closed-form
    /// registration when identified).
    pub measurement_frame_value: Option<Isometry3<f64>>,
    /// Target offset treatment (default identified).
    pub target: FrameTreatment,
    /// Target offset `x_tcp_target`: fixed or starting value (default `None`:
    /// the set's nominal target, else identity).
    pub target_value: Option<Isometry3<f64>>,
    /// Relative rank tolerance of the pivoted QR of the stacked Jacobian, its
    /// columns scaled by their norms (default 1e-4: a column within 0.006 deg
    /// of the span of the others is taken as dependent; range (0, 1)).
    /// Unknowns beyond this rank are [`UnknownStatus::NonIdentifiable`].
    pub rank_tolerance: f64,
    /// Noise-aware rank: a length unknown that could only be identified with a
    /// standard error above this limit is not identified but kept at its
    /// starting value, [`UnknownStatus::PoorlyIdentifiable`] (m; default
    /// 5e-3, several times the geometric errors of a machined robot: above it
    /// the data say nothing about the parameter; `> 0`).
    pub max_standard_error_length: f64,
    /// Same for angles (rad; default 0.25 deg; `> 0`).
    pub max_standard_error_angle: f64,
    /// Absolute limit for joint compliances, lateral ones included
    /// (rad/N.m or m/N; default 1e-3 rad/N.m: a standard error that large
    /// says nothing about any robot joint; `> 0`). Compliances are judged
    /// first on their own scale ([`CalibrationOptions::min_compliance_z`]);
    /// a smaller limit here (the command line's `--max-se-compliance`)
    /// also leaves out every compliance less precise than it.
    pub max_standard_error_compliance: f64,
    /// A compliance is kept when the data determine it on its own scale
    /// (the larger of its fitted value and its start): that scale at least
    /// this many standard errors (default 2; `> 0`). Below, it goes back
    /// to its starting value, [`UnknownStatus::PoorlyIdentifiable`]; a
    /// determined compliance the fit puts below zero by more than its
    /// standard error is held at zero, [`UnknownStatus::AtBound`]
    /// ([`crate::significance`]).
    pub min_compliance_z: f64,
    /// A joint whose gravity torque spans less than this share of the most
    /// loaded joint's keeps its compliance at the start before any fit
    /// (default [`crate::significance::MIN_TORQUE_SHARE`], 0.05; range
    /// [0, 1); 0 lets every loaded joint's compliance in).
    pub min_torque_share: f64,
    /// The instrument's stated noise (default `None`: the file's standard
    /// deviations where it has them, else estimated from the fit's
    /// residual). Stated, it weighs every observation and makes the
    /// weights absolute: standard errors and every identifiability
    /// judgement use it instead of an estimate.
    pub instrument_noise: Option<InstrumentNoise>,
    /// Same for the payload mass (kg; default 1; `> 0`).
    pub max_standard_error_mass: f64,
    /// Same for the payload's first moment (kg.m; default 0.1; `> 0`).
    pub max_standard_error_first_moment: f64,
    /// Same for the hardening of a joint spring (1/rad; default 1000: a
    /// spring whose stiffness would be known only to within a doubling at
    /// 0.5 mrad of deflection is left linear; `> 0`).
    pub max_standard_error_hardening: f64,
    /// Compute each identified unknown's spread ratio
    /// ([`UnknownEstimate::spread_ratio`]; default true). Off, the ratios
    /// are `None` and the identification is faster (model selection's
    /// fold fits need no ratios).
    pub spread_reference: bool,
    /// Joint error terms beyond linear springs: the non-linear stiffness
    /// law (needs `gravity`) and cyclic joint errors (default none; see
    /// [`crate::joint_law`]).
    pub joint_terms: JointTerms,
    /// Elasto-geometric model: joint compliances under gravity and the
    /// payload are identified with the geometry (default `None`: geometric).
    /// Its [`GravityCompliance::lateral`] switches the lateral joint
    /// compliances on ([`crate::gravity`]; default off).
    pub gravity: Option<GravityCompliance>,
    /// Fail with [`CalibError::RankDeficient`] instead of reporting and
    /// freezing non-identifiable unknowns (default false).
    pub require_full_rank: bool,
    /// Maximum solver iterations (default 100; `>= 1`).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction
    /// (default 1e-6: far below what measurement noise can resolve, the
    /// cost of m residuals being uncertain by about sqrt(2/m) relative;
    /// `>= 0`).
    pub cost_tolerance: f64,
    /// Cancellation: once this token is cancelled (from any thread), the
    /// identification stops at the start of the solver's next iteration
    /// and returns [`CalibError::Cancelled`] (default `None`: runs to the
    /// end). Model selection passes it to every fit it runs.
    pub cancel: Option<CancelToken>,
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        Self {
            method: Method::LevenbergMarquardt,
            use_orientation: None,
            weighting: Weighting::FromFile,
            default_position_std: 50e-6,
            default_orientation_std: 0.01f64.to_radians(),
            fixed: Vec::new(),
            deferred: Vec::new(),
            measurement_frame: FrameTreatment::Identify,
            measurement_frame_value: None,
            target: FrameTreatment::Identify,
            target_value: None,
            rank_tolerance: 1e-4,
            max_standard_error_length: 5e-3,
            max_standard_error_angle: 0.25f64.to_radians(),
            max_standard_error_compliance: 1e-3,
            min_compliance_z: 2.0,
            min_torque_share: MIN_TORQUE_SHARE,
            instrument_noise: None,
            max_standard_error_mass: 1.0,
            max_standard_error_first_moment: 0.1,
            max_standard_error_hardening: 1000.0,
            joint_terms: JointTerms::default(),
            spread_reference: true,
            gravity: None,
            require_full_rank: false,
            max_iterations: 100,
            cost_tolerance: 1e-6,
            cancel: None,
        }
    }
}

/// Limit `2 ||a|| / ||v||` of the geodesic acceleration of the
/// Levenberg-Marquardt steps when the model has the non-linear joint law
/// ([`LevenbergMarquardt::geodesic_acceleration`]; GSL's default).
pub(crate) const GEODESIC_ACCELERATION_LIMIT: f64 = 0.75;

/// The paper's non-identifiable set for the IR-663 (section 3.2.3), used as
/// the default deferred names of that robot.
pub const IR663_PAPER_DEFERRED: [&str; 6] = ["kappa8", "kappa2", "r8p", "d9", "r2", "r7"];

impl CalibrationOptions {
    /// Defaults for `model`: for the built-in `ir663`, the paper's six
    /// non-identifiable parameters are deferred so that the base set matches
    /// Appendix C.
    pub fn for_model(model: &Model) -> Self {
        let mut options = Self::default();
        if model.name() == "ir663" {
            options.deferred = IR663_PAPER_DEFERRED.iter().map(|s| s.to_string()).collect();
        }
        options
    }

    /// The standard-error limit of an unknown of kind `kind`
    /// (`max_standard_error_*`, in the kind's SI unit).
    pub fn standard_error_limit(&self, kind: UnknownKind) -> f64 {
        match kind {
            UnknownKind::Length => self.max_standard_error_length,
            UnknownKind::Angle => self.max_standard_error_angle,
            UnknownKind::Compliance => self.max_standard_error_compliance,
            UnknownKind::Mass => self.max_standard_error_mass,
            UnknownKind::FirstMoment => self.max_standard_error_first_moment,
            UnknownKind::Hardening => self.max_standard_error_hardening,
        }
    }

    pub(crate) fn check(&self) -> Result<(), CalibError> {
        let positive = crate::error::require_positive;
        positive("default_position_std", self.default_position_std)?;
        positive("default_orientation_std", self.default_orientation_std)?;
        positive("max_standard_error_length", self.max_standard_error_length)?;
        positive("max_standard_error_angle", self.max_standard_error_angle)?;
        positive(
            "max_standard_error_compliance",
            self.max_standard_error_compliance,
        )?;
        positive("min_compliance_z", self.min_compliance_z)?;
        if !(self.min_torque_share >= 0.0 && self.min_torque_share < 1.0) {
            return Err(CalibError::InvalidOption {
                name: "min_torque_share",
                reason: format!("must be in [0, 1), found {}", self.min_torque_share),
            });
        }
        if let Some(noise) = &self.instrument_noise {
            noise.check()?;
        }
        positive("max_standard_error_mass", self.max_standard_error_mass)?;
        positive(
            "max_standard_error_first_moment",
            self.max_standard_error_first_moment,
        )?;
        positive(
            "max_standard_error_hardening",
            self.max_standard_error_hardening,
        )?;
        if self.joint_terms.law.is_some() && self.gravity.is_none() {
            return Err(CalibError::InvalidOption {
                name: "joint_terms",
                reason:
                    "the non-linear joint stiffness law needs the elasto-geometric model (gravity)"
                        .into(),
            });
        }
        if !(self.rank_tolerance > 0.0 && self.rank_tolerance < 1.0) {
            return Err(CalibError::InvalidOption {
                name: "rank_tolerance",
                reason: format!("must be in (0, 1), found {}", self.rank_tolerance),
            });
        }
        if !(self.cost_tolerance.is_finite() && self.cost_tolerance >= 0.0) {
            return Err(CalibError::InvalidOption {
                name: "cost_tolerance",
                reason: format!("must be finite and >= 0, found {}", self.cost_tolerance),
            });
        }
        if self.max_iterations == 0 {
            return Err(CalibError::InvalidOption {
                name: "max_iterations",
                reason: "must be >= 1".into(),
            });
        }
        Ok(())
    }
}

/// What became of one unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum UnknownStatus {
    /// Identified (in the base set).
    Identified,
    /// Fixed by the user or by the frame treatment.
    Fixed,
    /// Not identifiable from these poses (beyond the numerical rank); kept at
    /// its starting value, its effect absorbed by the identified combinations.
    NonIdentifiable,
    /// Identifiable in principle but its standard error would exceed the
    /// limit of [`CalibrationOptions`]; kept at its starting value.
    PoorlyIdentifiable,
    /// Has no influence on what is measured (e.g. target rotation without
    /// measured orientation); kept at its starting value.
    NoInfluence,
    /// Held at its physical bound (a compliance at zero): the
    /// unconstrained fit put it beyond, by more than its standard error
    /// ([`UnknownEstimate::judgement`] keeps what the fit gave).
    AtBound,
}

impl UnknownStatus {
    /// The status as reports and files write it (`identified`, `fixed`,
    /// `non-identifiable`, `poorly-identifiable`, `no-influence`,
    /// `at-bound`).
    pub fn name(self) -> &'static str {
        match self {
            UnknownStatus::Identified => "identified",
            UnknownStatus::Fixed => "fixed",
            UnknownStatus::NonIdentifiable => "non-identifiable",
            UnknownStatus::PoorlyIdentifiable => "poorly-identifiable",
            UnknownStatus::NoInfluence => "no-influence",
            UnknownStatus::AtBound => "at-bound",
        }
    }
}

/// One unknown of the identification, by name.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct UnknownEstimate {
    /// Name (`d3`, `frame_rx`, `target_z`, `compliance_2`, ...).
    pub name: String,
    /// Length (m), angle (rad), compliance (rad/N.m or m/N), mass (kg) or
    /// first moment (kg.m).
    pub kind: UnknownKind,
    /// Starting (nominal) value, in the unit of `kind` (0 for the frame
    /// increments).
    pub initial: f64,
    /// Identified value, in the unit of `kind`.
    pub value: f64,
    /// Standard error, in the unit of `kind`, when identified.
    pub standard_error: Option<f64>,
    /// When identified: its standard error divided by the one that as many
    /// poses drawn uniformly over the robot's joint ranges (revolute joints
    /// over their limits, prismatic ones over the identification range)
    /// would give with the same noise (dimensionless; 1 = as well determined
    /// as by a spread design, 10 = ten times worse). Poses clustered in a small region
    /// determine many parameters only in combinations that hold there: a
    /// large ratio warns that predictions elsewhere are extrapolations even
    /// when the standard error itself is small.
    pub spread_ratio: Option<f64>,
    /// What became of it.
    pub status: UnknownStatus,
    /// For a compliance: the fit that judged it on its own scale (value,
    /// standard error, outcome), also when it was left out or held at its
    /// bound ([`crate::significance`]); `None` for the other unknowns.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub judgement: Option<ScaleJudgement>,
}

/// Unweighted residual norms at one iterate of the identification (Figure 7
/// plots these, position and orientation separately).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualNorms {
    /// Cost `1/2 ||W r||^2` (weighted, dimensionless).
    pub cost: f64,
    /// RMS over the poses of the position error norm (m).
    pub position_rms: f64,
    /// RMS over the poses of the orientation error angle (rad), when
    /// orientations are used.
    pub orientation_rms: Option<f64>,
}

/// A fitted geometric calibration: the identified robot parameters, frames,
/// the identifiability analysis and the solver's report.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// Identified robot parameters xi (m, rad).
    pub xi: Vec<f64>,
    /// Nominal robot parameters (m, rad).
    pub nominal_xi: Vec<f64>,
    /// Identified (or fixed) measurement frame `x_meas_base` (of the first
    /// station, when the set has several).
    pub x_meas_base: Isometry3<f64>,
    /// Identified (or fixed) measurement frames of the second and later
    /// stations ([`MeasurementSet::pooled`]); empty for one station.
    pub station_frames: Vec<Isometry3<f64>>,
    /// Names of the stations, in order (one for a set from one file).
    pub station_names: Vec<String>,
    /// Errors after identification of each station's poses, in the order
    /// of `station_names` (one entry, equal to `training_after`, for one
    /// station; a station a subset left out has zero poses).
    pub station_errors: Vec<ErrorStatistics>,
    /// Identified (or fixed) target offset `x_tcp_target`.
    pub x_tcp_target: Isometry3<f64>,
    /// Starting target offset (nominal).
    pub x_tcp_target_initial: Isometry3<f64>,
    /// Target offset fitted together with the measurement frame for the
    /// nominal robot (the "before" of the comparisons; equal to the starting
    /// one when the target is fixed or not identifiable).
    pub x_tcp_target_nominal_robot: Isometry3<f64>,
    /// Whether the measurement frame was fixed.
    pub measurement_frame_fixed: bool,
    /// Whether orientations were used.
    pub use_orientation: bool,
    /// Every unknown, robot parameters first, then `frame_*`, then
    /// `target_*`, then the later stations' frames (`frame_s2_*`, ...), then
    /// (elasto-geometric) `compliance_*`, `payload_*` and,
    /// when on, `lateral_compliance_*`, then the joint terms.
    pub unknowns: Vec<UnknownEstimate>,
    /// The gravity loading when the model is elasto-geometric, with the
    /// identified elastic unknowns (compliances, payload mass, first moment,
    /// lateral compliances when on; order of
    /// [`GravityCompliance::elastic_unknown_names`]).
    pub elastic: Option<(GravityCompliance, Vec<f64>)>,
    /// The joint error terms of the model ([`crate::joint_law`]).
    pub joint_terms: JointTerms,
    /// Their identified values, in the order of
    /// [`JointTerms::unknown_names`] (1/rad, rad).
    pub joint_term_values: Vec<f64>,
    /// Numerical identifiability analysis of the free unknowns (exact
    /// dependencies, at [`CalibrationOptions::rank_tolerance`]) at the start point.
    pub identifiability: IdentifiabilityReport,
    /// What each identified unknown stands for (C.1), linearised at the
    /// start point (nominal robot, fitted frames).
    pub combinations: Vec<Combination>,
    /// The same as text, one line per identified unknown that absorbs others
    /// (coefficients below 1e-3 dropped).
    pub combination_lines: Vec<String>,
    /// The final solver report (cost history = Figure 7 data, termination,
    /// rank, singular values, covariance).
    pub solve: SolveReport,
    /// Cost `1/2 ||W r||^2` history of every solver run, rounds in order.
    pub cost_history: Vec<f64>,
    /// The same iterates' unweighted position and orientation RMS errors
    /// (one entry per entry of `cost_history`).
    pub residual_history: Vec<ResidualNorms>,
    /// Errors on the identification set with the nominal robot, its frames
    /// fitted (before).
    pub training_before: ErrorStatistics,
    /// Errors on the identification set after identification.
    pub training_after: ErrorStatistics,
    /// Per-pose errors on the identification set after identification.
    pub training_after_per_pose: Vec<PoseError>,
    /// Repeated readings and suspect poses of the identification set
    /// (after the fit).
    pub data_checks: DataChecks,
    /// The noise the standard errors and identifiability judgements used
    /// ([`crate::significance`]).
    pub noise: NoiseSource,
    /// Number of poses used.
    pub n_poses: usize,
    /// Names of the robot's actuated coordinates, in the order of
    /// [`Calibration::actuated_ranges`] and [`Calibration::torque_ranges`].
    pub actuated_names: Vec<String>,
    /// What the identification poses cover of each actuated coordinate: the
    /// interval from its smallest to its largest value (m), or for a
    /// revolute coordinate the arc of the circle (rad; the model is
    /// `2 pi`-periodic in it, see [`crate::coverage`]). Validation poses
    /// outside it are extrapolations.
    pub actuated_ranges: Vec<CoordinateCoverage>,
    /// Span of each actuated coordinate's gravity torque (N.m, or N for a
    /// prismatic one) over the identification poses, with the mass table's
    /// payload ([`GravityCompliance::joint_torques`]): the torques over which
    /// the compliances were identified. Empty for the geometric model.
    pub torque_ranges: Vec<CoordinateCoverage>,
}

impl Calibration {
    /// Indices of the actuated coordinates at which `q` (rad or m) lies
    /// outside [`Calibration::actuated_ranges`] (by more than 1e-9; a
    /// revolute coordinate a whole number of turns away from a covered
    /// angle is inside): where a prediction is an extrapolation from the
    /// identification poses.
    pub fn outside_training_range<'a>(&'a self, q: &'a [f64]) -> impl Iterator<Item = usize> + 'a {
        crate::coverage::outside(&self.actuated_ranges, q)
    }

    /// Names of the non-identifiable unknowns.
    pub fn non_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::NonIdentifiable)
    }
    /// Names of the poorly identifiable unknowns (kept at nominal).
    pub fn poorly_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::PoorlyIdentifiable)
    }
    fn with_status(&self, status: UnknownStatus) -> Vec<&str> {
        self.unknowns
            .iter()
            .filter(|u| u.status == status)
            .map(|u| u.name.as_str())
            .collect()
    }
    /// What the poses could not identify, in sentences for a report: robot
    /// parameters left at nominal, the target (probe) offset and the
    /// measurement frame components not identified (their error then stays
    /// in every prediction away from these poses), and, elasto-geometric,
    /// which joint compliances gravity loads enough to be identified.
    pub fn identifiability_notes(&self) -> Vec<String> {
        let not_identified = |u: &&UnknownEstimate| {
            matches!(
                u.status,
                UnknownStatus::NonIdentifiable | UnknownStatus::PoorlyIdentifiable
            )
        };
        let names = |prefix: &str| -> Vec<&str> {
            self.unknowns
                .iter()
                .filter(|u| u.name.starts_with(prefix))
                .filter(not_identified)
                .map(|u| u.name.as_str())
                .collect()
        };
        let mut notes = Vec::new();
        let np = self.xi.len();
        let robot = |status: UnknownStatus| -> Vec<&str> {
            self.unknowns[..np]
                .iter()
                .filter(|u| u.status == status)
                .map(|u| u.name.as_str())
                .collect()
        };
        let exact = robot(UnknownStatus::NonIdentifiable);
        if !exact.is_empty() {
            notes.push(format!(
                "{} of {np} robot parameters are exactly dependent on others with these poses and stay at nominal ({}); the identified ones stand for the combinations listed",
                exact.len(),
                exact.join(", ")
            ));
        }
        let poor = robot(UnknownStatus::PoorlyIdentifiable);
        if !poor.is_empty() {
            notes.push(format!(
                "{} more stay at nominal because these poses see them too weakly ({}): predictions far from these poses carry their errors",
                poor.len(),
                poor.join(", ")
            ));
        }
        notes.extend(weak_spread_note(
            self.unknowns
                .iter()
                .enumerate()
                .filter(|(j, u)| *j < np || u.name.starts_with("target_"))
                .map(|(_, u)| u),
        ));
        let target = names("target_");
        if !target.is_empty() {
            notes.push(format!(
                "the target (probe) offset is not identified along {}: it stays at its starting value, and its error goes into every prediction away from these poses (vary the tool orientation more to identify it, or start from an offset known from elsewhere)",
                target.join(", ")
            ));
        }
        let frame = names("frame_");
        if !frame.is_empty() && !self.measurement_frame_fixed {
            notes.push(format!(
                "measurement frame components not separable from the robot's base parameters: {} (absorbed by the base parameters, harmless for predictions)",
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

    /// Number of identified unknowns (the rank used).
    pub fn rank(&self) -> usize {
        self.unknowns
            .iter()
            .filter(|u| u.status == UnknownStatus::Identified)
            .count()
    }
    /// The calibrated robot description (mm, deg), which loads back with
    /// [`RobotDescription::build`].
    ///
    /// # Errors
    /// [`CalibError::Description`].
    pub fn description(&self, model: &Model) -> Result<RobotDescription, CalibError> {
        let mut d = model
            .description_with_params(&self.xi)
            .map_err(CalibError::Description)?;
        let note = format!(
            "Calibrated by flexcal from {} poses: {} of {} unknowns identified.",
            self.n_poses,
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

/// Whether `name` is an unknown of the elastic and joint terms (the
/// compliances, payload, lateral compliances, joint law, cyclic errors).
pub(crate) fn is_elastic_unknown(name: &str) -> bool {
    [
        "compliance_",
        "payload_",
        "lateral_compliance_",
        "hardening_",
        "lost_motion_",
        "cyclic_",
    ]
    .iter()
    .any(|p| name.starts_with(p))
}

/// The sentences on the elastic and joint terms of an elasto-geometric
/// identification (one or several targets): which joint compliances
/// gravity loads enough to be identified, with the torques they were
/// identified over, and, with the joint `law`, the hardening and lost
/// motion identified; the lateral compliances and the payload.
pub(crate) fn elastic_notes(
    unknowns: &[UnknownEstimate],
    actuated_names: &[String],
    torque_ranges: &[CoordinateCoverage],
    law: bool,
) -> Vec<String> {
    let names = |prefix: &str| -> Vec<&str> {
        unknowns
            .iter()
            .filter(|u| u.name.starts_with(prefix))
            .filter(|u| {
                matches!(
                    u.status,
                    UnknownStatus::NonIdentifiable
                        | UnknownStatus::PoorlyIdentifiable
                        | UnknownStatus::NoInfluence
                )
            })
            .map(|u| u.name.as_str())
            .collect()
    };
    let mut notes = Vec::new();
    // The torque each joint's compliance was identified over, and the
    // largest of all ([`MIN_TORQUE_SHARE`]).
    let torque_of = |name: &str| {
        actuated_names
            .iter()
            .position(|a| name.strip_prefix("compliance_") == Some(a.as_str()))
            .and_then(|i| torque_ranges.get(i))
    };
    let largest = torque_ranges
        .iter()
        .map(torque_magnitude)
        .fold(0.0, f64::max);
    let joint: Vec<&UnknownEstimate> = unknowns
        .iter()
        .filter(|u| u.name.starts_with("compliance_"))
        .collect();
    notes.extend(compliance_sentence(
        "joint compliances",
        &joint,
        &|u| torque_of(&u.name).copied(),
        largest,
    ));
    if law {
        for (prefix, what) in [("hardening_", "hardening"), ("lost_motion_", "lost motion")] {
            let identified: Vec<&str> = unknowns
                .iter()
                .filter(|u| u.name.starts_with(prefix) && u.status == UnknownStatus::Identified)
                .map(|u| u.name.as_str())
                .collect();
            notes.push(format!(
                    "non-linear joint law, {what} identified: {}; the others stay at zero (not separable from the compliances and offsets, or too weakly seen, with these torques)",
                    if identified.is_empty() { "none".to_string() } else { identified.join(", ") }
                ));
        }
    }
    let lateral: Vec<&UnknownEstimate> = unknowns
        .iter()
        .filter(|u| u.name.starts_with("lateral_compliance_"))
        .collect();
    notes.extend(compliance_sentence(
        "lateral joint compliances",
        &lateral,
        &|_| None,
        largest,
    ));
    let payload = names("payload_");
    if !payload.is_empty() {
        notes.push(format!(
            "payload not identified ({}): its mass and centre stay at their starting values",
            payload.join(", ")
        ));
    }
    notes
}

/// One sentence on a family of compliances (`what`): those identified,
/// with their standard errors as a share of their values and the torque
/// (`torque_of`, N.m) they were identified over, and for each one left out
/// the true reason: too little gravity torque (below
/// [`MIN_TORQUE_SHARE`] of the `largest` joint's), not separable from other unknowns, too large a
/// standard error for its value, or a fit below zero held at the bound.
fn compliance_sentence(
    what: &str,
    unknowns: &[&UnknownEstimate],
    torque_of: &dyn Fn(&UnknownEstimate) -> Option<CoordinateCoverage>,
    largest: f64,
) -> Option<String> {
    if unknowns.is_empty() {
        return None;
    }
    let (unit, factor) = UnknownKind::Compliance.display_unit();
    // One decimal, without a negative zero.
    let round = |v: f64| (v * 10.0).round() / 10.0 + 0.0;
    let torque_text =
        |r: &CoordinateCoverage| format!("torque {:.1} to {:.1} N.m", round(r.lo), round(r.hi));
    let mut kept = Vec::new();
    let mut left = Vec::new();
    for u in unknowns {
        let torque = torque_of(u);
        let judged = u.judgement.map(|j| {
            let scale = j.value.abs().max(u.initial.abs());
            format!(
                "standard error {:.3} {unit} is {:.0} % of its scale, the larger of the fitted {:.3} and the start {:.3} {unit}",
                j.standard_error * factor,
                100.0 * j.standard_error / scale,
                j.value * factor,
                u.initial * factor
            )
        });
        match u.status {
            UnknownStatus::Identified => {
                let mut parts = Vec::new();
                if let Some(se) = u.standard_error {
                    parts.push(format!(
                        "{:.3} +/- {:.3} {unit}, {:.0} %",
                        u.value * factor,
                        se * factor,
                        100.0 * se / u.value.abs().max(u.initial.abs())
                    ));
                }
                if let Some(r) = &torque {
                    parts.push(torque_text(r));
                }
                kept.push(if parts.is_empty() {
                    u.name.clone()
                } else {
                    format!("{} ({})", u.name, parts.join("; "))
                });
            }
            UnknownStatus::Fixed => {}
            UnknownStatus::AtBound => left.push(format!(
                "{} (held at 0, the fit put it below zero: {}; a bound that binds says a term of the model is missing or the mass table is off)",
                u.name,
                judged.unwrap_or_default()
            )),
            status => {
                let span = torque.as_ref().map(torque_magnitude);
                let reason = match (status, span) {
                    (_, Some(t)) if t < MIN_TORQUE_SHARE * largest || t == 0.0 => format!(
                        "torque range +/-{:.1} N.m: too little gravity torque",
                        round(t)
                    ),
                    (UnknownStatus::NoInfluence, _) => {
                        "no influence on what is measured".to_string()
                    }
                    (UnknownStatus::NonIdentifiable, _) => {
                        "not separable from the geometry and the other terms with these poses"
                            .to_string()
                    }
                    _ => match judged {
                        Some(text) => format!("{text}: left at its start"),
                        None => "too weakly seen: its standard error would exceed the absolute limit (max_standard_error_compliance)".to_string(),
                    },
                };
                left.push(format!("{} ({reason})", u.name));
            }
        }
    }
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    Some(format!(
        "{what} identified from the gravity loads: {}; left out: {}",
        list(&kept),
        list(&left)
    ))
}

/// Where the noise of an identification came from: the instrument when
/// stated, the file's deviations when the weights are absolute, else the
/// estimate `position_std` (m per axis) from the fit.
pub(crate) fn noise_source(
    options: &CalibrationOptions,
    absolute: bool,
    position_std: f64,
) -> NoiseSource {
    match (options.instrument_noise, absolute) {
        (Some(noise), _) => NoiseSource::Instrument(noise),
        (None, true) => NoiseSource::File,
        (None, false) => NoiseSource::Estimated { position_std },
    }
}

/// The standard deviations of one observation's position and orientation
/// axes (m, rad) under `options`: the instrument's stated noise, else the
/// file's (`from_file`) where it has them, else the defaults.
pub(crate) fn observation_std(
    options: &CalibrationOptions,
    position_std: Option<Vector3<f64>>,
    orientation_std: Option<Vector3<f64>>,
) -> (Vector3<f64>, Vector3<f64>) {
    if let Some(noise) = options.instrument_noise {
        let orientation = noise
            .orientation_std
            .unwrap_or(options.default_orientation_std);
        return (
            Vector3::repeat(noise.position_std),
            Vector3::repeat(orientation),
        );
    }
    let from_file = options.weighting == Weighting::FromFile;
    let pick = |file: Option<Vector3<f64>>, default: f64| match (from_file, file) {
        (true, Some(s)) => s,
        _ => Vector3::repeat(default),
    };
    (
        pick(position_std, options.default_position_std),
        pick(orientation_std, options.default_orientation_std),
    )
}

/// Per-row weights `1/sigma` and whether they are absolute.
fn row_weights(
    set: &MeasurementSet,
    use_orientation: bool,
    options: &CalibrationOptions,
) -> Result<(Vec<f64>, bool), CalibError> {
    let from_file = options.weighting == Weighting::FromFile;
    let mut absolute = from_file && set.has_position_std();
    if let Some(noise) = options.instrument_noise {
        if use_orientation {
            noise.orientation()?;
        }
        absolute = true;
    } else if use_orientation {
        absolute &= set.has_orientation_std();
    }
    let mut w = Vec::with_capacity(set.len() * 6);
    for m in set.measurements() {
        let (position, orientation) = observation_std(options, m.position_std, m.orientation_std);
        w.extend(position.iter().map(|s| 1.0 / s));
        if use_orientation {
            w.extend(orientation.iter().map(|s| 1.0 / s));
        }
    }
    Ok((w, absolute))
}

/// Identifies the robot parameters (and the measurement frame and target
/// offset unless fixed) from a measurement set: equations (7)-(12) and
/// (49)-(53) of the reference paper, with the frames of the note in the
/// crate docs.
///
/// Steps: the measurement frame starts from a closed-form registration; the
/// frames alone are fitted first; then, in rounds, the identifiability of the
/// free unknowns is decided by pivoted QR of the scaled, weighted stacked
/// Jacobian (deferred names last), the non-identifiable ones are frozen, the
/// rest solved by Levenberg-Marquardt or Gauss-Newton, and any unknown whose
/// standard error exceeds the limits is frozen at its starting value and the
/// round repeated (at most 5 rounds).
///
/// # Errors
/// Mismatched coordinates, unknown names in `fixed`/`deferred`, too few
/// poses, a degenerate registration, a model failure at a pose, a solver
/// failure, [`CalibError::RankDeficient`] when `require_full_rank` is set,
/// [`CalibError::NothingToIdentify`].
pub fn calibrate(
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
) -> Result<Calibration, CalibError> {
    options.check()?;
    let cancelled = || {
        options
            .cancel
            .as_ref()
            .is_some_and(CancelToken::is_cancelled)
    };
    if cancelled() {
        return Err(CalibError::Cancelled);
    }
    let use_orientation = options.use_orientation.unwrap_or(set.has_orientation());
    let x_tcp_target0 = options
        .target_value
        .or(set.nominal_target)
        .unwrap_or_else(Isometry3::identity);
    let frame_fixed = options.measurement_frame == FrameTreatment::Fixed;
    if set.n_actuated() != model.n_actuated() {
        return Err(CalibError::ActuatedCountMismatch {
            source_name: set.source.clone(),
            robot: model.name().to_string(),
            expected: model.n_actuated(),
            found: set.n_actuated(),
        });
    }
    // Too few poses is the first thing to tell (before a registration that
    // would fail on them for a less helpful reason).
    {
        let mut known: Vec<&str> = model.params().iter().map(|p| p.name.as_str()).collect();
        known.extend(crate::FRAME_PARAMETER_NAMES);
        known.extend(crate::TARGET_PARAMETER_NAMES);
        let station_names: Vec<String> = (1..set.n_stations())
            .flat_map(crate::error_model::station_frame_names)
            .collect();
        known.extend(station_names.iter().map(|s| s.as_str()));
        let elastic_names = options
            .gravity
            .as_ref()
            .map_or_else(Vec::new, |g| g.elastic_unknown_names(model));
        known.extend(elastic_names.iter().map(|s| s.as_str()));
        let joint_names = options.joint_terms.unknown_names(model);
        known.extend(joint_names.iter().map(|s| s.as_str()));
        let mut free = vec![true; known.len()];
        let np = model.n_params();
        if frame_fixed {
            free[np..np + 6].fill(false);
        }
        if options.target == FrameTreatment::Fixed || !use_orientation {
            free[np + 9..np + 12].fill(false);
        }
        if options.target == FrameTreatment::Fixed {
            free[np + 6..np + 9].fill(false);
        }
        if frame_fixed {
            free[np + 12..np + 12 + station_names.len()].fill(false);
        }
        for name in &options.fixed {
            let j = known.iter().position(|k| k == name).ok_or_else(|| {
                CalibError::UnknownParameter {
                    name: name.clone(),
                    known: known.join(", "),
                }
            })?;
            free[j] = false;
        }
        let unknowns = free.iter().filter(|f| **f).count();
        let rows = set.len() * if use_orientation { 6 } else { 3 };
        if rows < unknowns {
            return Err(CalibError::TooFewPoses {
                poses: set.len(),
                rows,
                unknowns,
            });
        }
    }
    // Each station's frame starts from the registration of its own poses
    // (a station that a subset of the set leaves out has nothing to
    // register: its frame has no influence).
    // Each station's poses, once (`None`: none in this set).
    let stations: Vec<Option<MeasurementSet>> = (0..set.n_stations())
        .map(|s| set.station_poses(s))
        .collect();
    let registered = stations
        .iter()
        .map(|poses| match poses {
            Some(poses) if !frame_fixed => Ok(Some(register_measurement_frame(
                model,
                poses,
                model.nominal_params(),
                &x_tcp_target0,
            )?)),
            _ => Ok(None),
        })
        .collect::<Result<Vec<_>, CalibError>>()?;
    let x_meas_base0 = match (frame_fixed, options.measurement_frame_value) {
        (_, Some(x)) => x,
        (true, None) => Isometry3::identity(),
        (false, None) => registered[0].unwrap_or_else(Isometry3::identity),
    };
    let station_frames0: Vec<Isometry3<f64>> = registered[1..]
        .iter()
        .map(|start| start.unwrap_or(x_meas_base0))
        .collect();
    let empty_stations: Vec<usize> = (0..set.n_stations())
        .filter(|&s| stations[s].is_none())
        .collect();
    // Measured orientations: the target's orientation starts where the data
    // put it (unless fixed or given), as the measurement frame does; from
    // the first station with poses, in its frame.
    let x_tcp_target0 = if use_orientation
        && options.target != FrameTreatment::Fixed
        && options.target_value.is_none()
    {
        let s = stations.iter().position(Option::is_some).unwrap_or(0);
        let frame = if s == 0 {
            x_meas_base0
        } else {
            station_frames0[s - 1]
        };
        let poses = stations[s].as_ref().unwrap_or(set);
        let rotation = register_target_rotation(model, poses, model.nominal_params(), &frame)?;
        Isometry3::from_parts(x_tcp_target0.translation, rotation)
    } else {
        x_tcp_target0
    };
    let mut problem =
        GeometricErrorModel::new(model, set, use_orientation, x_meas_base0, x_tcp_target0)?
            .with_station_frames(&station_frames0)?;
    if let Some(gravity) = &options.gravity {
        problem = problem.with_gravity(gravity)?;
    }
    if options.joint_terms.any() {
        problem = problem.with_joint_terms(&options.joint_terms)?;
    }
    let n = problem.n_unknowns();
    let names = problem.names().to_vec();
    let kinds = problem.kinds();
    let index_of = |name: &String| {
        names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| CalibError::UnknownParameter {
                name: name.clone(),
                known: names.join(", "),
            })
    };
    let mut fixed = vec![false; n];
    for name in &options.fixed {
        fixed[index_of(name)?] = true;
    }
    let mut priorities = vec![0i32; n];
    for name in &options.deferred {
        priorities[index_of(name)?] = -1;
    }
    let fo = problem.frame_offset();
    let to = problem.target_offset();
    let te = to + 6;
    // The frames of the later stations follow the target's unknowns; the
    // elastic ones (if any) begin where they end.
    let fe = problem.frames_end();
    // The frames take what they can from the robot's base and tool parameters.
    priorities[fo..to].fill(2);
    priorities[to..te].fill(1);
    priorities[te..fe].fill(2);
    let mut no_influence = vec![false; n];
    if frame_fixed {
        fixed[fo..to].fill(true);
        fixed[te..fe].fill(true);
    }
    for &s in &empty_stations {
        let o = problem.station_frame_offset(s);
        no_influence[o..o + 6].fill(true);
    }
    if options.target == FrameTreatment::Fixed {
        fixed[to..te].fill(true);
    }
    if !use_orientation {
        for (none, is_fixed) in no_influence[to + 3..te].iter_mut().zip(&fixed[to + 3..te]) {
            *none = !is_fixed;
        }
    }
    let rows = problem.n_residuals();
    let free_count = (0..n).filter(|&j| !fixed[j] && !no_influence[j]).count();
    if free_count == 0 {
        return Err(CalibError::NothingToIdentify);
    }
    if rows < free_count {
        return Err(CalibError::TooFewPoses {
            poses: set.len(),
            rows,
            unknowns: free_count,
        });
    }
    let (weights, absolute) = row_weights(set, use_orientation, options)?;
    let x_initial = problem.initial_unknowns();
    let rows_per_pose = problem.rows_per_pose();
    // Position and orientation RMS of (unweighted) residuals `r`.
    let norms_of = |r: &[f64], cost: f64| -> ResidualNorms {
        let (mut p2, mut o2) = (0.0, 0.0);
        for pose in r.chunks(rows_per_pose) {
            p2 += pose[..3].iter().map(|v| v * v).sum::<f64>();
            if use_orientation {
                o2 += pose[3..6].iter().map(|v| v * v).sum::<f64>();
            }
        }
        let n_poses = set.len().max(1) as f64;
        ResidualNorms {
            cost,
            position_rms: (p2 / n_poses).sqrt(),
            orientation_rms: use_orientation.then(|| (o2 / n_poses).sqrt()),
        }
    };
    let norms_at = |x: &[f64], cost: f64| -> ResidualNorms {
        let mut r = vec![0.0; rows];
        match problem.residuals(x, &mut r) {
            Ok(()) => norms_of(&r, cost),
            Err(_) => ResidualNorms {
                cost,
                position_rms: f64::NAN,
                orientation_rms: None,
            },
        }
    };
    let residual_history = std::cell::RefCell::new(Vec::<ResidualNorms>::new());
    let solve = |x0: &[f64], frozen: &[bool]| -> Result<SolveReport, CalibError> {
        // Between two solves (the rounds of the noise-aware rank).
        if cancelled() {
            return Err(CalibError::Cancelled);
        }
        // Frames-only fits skip the robot's parameter Jacobian.
        problem.set_robot_columns(frozen[..model.n_params()].iter().any(|f| !f));
        let setup = ProblemSetup {
            row_weights: Some(weights.clone()),
            weights_are_absolute: absolute,
            fixed: frozen.to_vec(),
            column_scaling: ColumnScaling::ColumnNorm,
        };
        // The iterates' position and orientation errors, for Figure 7.
        let mut iterates = Vec::new();
        let mut observer = |state: &IterationState| {
            let r: Vec<f64> = state
                .weighted_residuals
                .iter()
                .zip(&weights)
                .map(|(r, w)| r / w)
                .collect();
            iterates.push(norms_of(&r, state.cost));
            Control::Continue
        };
        let result = match options.method {
            Method::LevenbergMarquardt => {
                let mut solver =
                    LevenbergMarquardt::params().max_iterations(options.max_iterations);
                solver.options.max_evaluations = 20 * options.max_iterations;
                solver.options.cost_tolerance = options.cost_tolerance;
                solver.options.cancel = options.cancel.clone();
                // The law's hardening trades off against the compliance
                // along a long curved valley of the cost, which the plain
                // iteration walks down by many small steps (54 iterations
                // on IPA series C, 26 with the acceleration, to a slightly
                // lower cost). Models without the law converge in a few
                // iterations and keep the plain iteration.
                if options.joint_terms.law.is_some() {
                    solver.geodesic_acceleration = Some(GEODESIC_ACCELERATION_LIMIT);
                }
                solver.solve(&problem, x0, &setup, &mut observer)
            }
            Method::GaussNewton => {
                let mut solver = GaussNewton::params().max_iterations(options.max_iterations);
                solver.options.max_evaluations = 20 * options.max_iterations;
                solver.options.cost_tolerance = options.cost_tolerance;
                solver.options.cancel = options.cancel.clone();
                solver.solve(&problem, x0, &setup, &mut observer)
            }
        };
        problem.set_robot_columns(true);
        let report = result.map_err(CalibError::optim("identification"))?;
        if report.termination == Termination::Cancelled {
            return Err(CalibError::Cancelled);
        }
        let mut history = residual_history.borrow_mut();
        let before = history.len();
        let start_cost = report.cost_history.first().copied().unwrap_or(f64::NAN);
        history.push(norms_at(x0, start_cost));
        let last = iterates.last().copied();
        history.extend(iterates);
        // A solver that stops (no further decrease possible) records the
        // final cost once more, at the final x.
        for &cost in report.cost_history.iter().skip(history.len() - before) {
            let mut norms = last.unwrap_or_else(|| norms_at(&report.x, cost));
            norms.cost = cost;
            history.push(norms);
        }
        Ok(report)
    };
    let mut cost_history = Vec::new();
    let mut x_start = x_initial.clone();
    let limits: Vec<f64> = kinds
        .iter()
        .map(|&k| options.standard_error_limit(k))
        .collect();
    let context = AnalysisContext {
        problem: &problem,
        weights: &weights,
        names: &names,
        priorities: &priorities,
        limits: &limits,
        rank_tolerance: options.rank_tolerance,
    };
    let noise_at = |x: &[f64], free: usize| noise_level(&problem, &weights, absolute, x, free);
    // Frames alone first, from the registration: the robot's linearisation
    // point is then the nominal robot in the right place.
    let frame_unknowns: Vec<usize> = (fo..fe)
        .filter(|&j| !fixed[j] && !no_influence[j])
        .collect();
    if !frame_unknowns.is_empty() {
        let sigma = noise_at(&x_start, frame_unknowns.len())?;
        // Only the frame columns are analysed: skip the robot's.
        problem.set_robot_columns(false);
        let reduced = context.reduced(&x_start);
        problem.set_robot_columns(true);
        let analysis =
            context.analyse(&reduced?, Some(sigma), &|j| !frame_unknowns.contains(&j))?;
        let mut frozen = vec![true; n];
        for &j in &analysis.base {
            frozen[analysis_index(&analysis, j, &names)] = false;
        }
        if frozen.iter().any(|f| !f) {
            let report = solve(&x_start, &frozen)?;
            cost_history.extend(&report.cost_history);
            x_start = report.x;
        }
    }
    // The nominal robot with its frames fitted: the "before" of the report.
    let x_nominal_robot = x_start.clone();
    let (_, x_tcp_target_nominal) = problem.frames(&x_start);
    let excluded = |j: usize| fixed[j] || no_influence[j];
    // Cyclic errors of a joint whose poses do not cover their period: over
    // part of a period a harmonic is a smooth curve that geometry and the
    // frames imitate, and it extrapolates to the rest of the turn without
    // any data; they stay at zero (poorly identifiable).
    let partial_period = crate::joint_law::partial_period_mask(model, set, &names);
    // ... and the compliances of joints gravity barely loads.
    let partial_period = barely_loaded(
        partial_period,
        (&names, model.actuated_names()),
        &problem.torque_ranges(),
        options.min_torque_share,
    );
    let mut solve_logged = |x0: &[f64], frozen: &[bool]| -> Result<SolveReport, CalibError> {
        let report = solve(x0, frozen)?;
        cost_history.extend(&report.cost_history);
        Ok(report)
    };
    let reduced_start = context.reduced(&x_start)?;
    let RoundsOutcome {
        report,
        frozen,
        exactly_dependent,
        numerical,
        judgements,
    } = context.identify_in_rounds(
        &Rounds {
            reduced_start: &reduced_start,
            x_start: &x_start,
            excluded: &excluded,
            partial_period: &partial_period,
            absolute,
            require_full_rank: options.require_full_rank,
            free_count,
            joint_start: problem.joint_terms_offset().unwrap_or(n),
            kinds: &kinds,
            min_compliance_z: options.min_compliance_z,
        },
        &noise_at,
        &mut solve_logged,
    )?;
    let x = report.x.clone();
    let identified: Vec<usize> = (0..n).filter(|&j| !frozen[j]).collect();
    let absorbed: Vec<usize> = (0..n).filter(|&j| frozen[j] && !excluded(j)).collect();
    // Linearised at the start point (nominal robot, fitted frames): with
    // geometric errors of millimetres the difference from the solution is of
    // second order, and the start's factor is at hand.
    let combinations = context.combinations(&reduced_start, &identified, &absorbed)?;
    // What the poses cover of each actuated coordinate, and of its gravity
    // torque.
    let actuated_ranges = CoordinateCoverage::of_actuated(model, set);
    let torque_ranges = problem.torque_ranges();
    let spread_ratios = if !options.spread_reference {
        vec![None; n]
    } else {
        SpreadInputs {
            model,
            set,
            actuated_ranges: &actuated_ranges,
            options,
            use_orientation,
            frames: (x_meas_base0, x_tcp_target0),
            station_frames: &station_frames0,
            context: &context,
        }
        .ratios(&reduced_start, &x_start, &identified)?
    };
    let unknowns = unknown_estimates(
        (&names, &kinds),
        (&x_initial, &report),
        &UnknownFlags {
            fixed: &fixed,
            no_influence: &no_influence,
            frozen: &frozen,
            exactly_dependent: &exactly_dependent,
            judgements: &judgements,
        },
        &spread_ratios,
    );
    let noise = noise_source(
        options,
        absolute,
        noise_at(&x, identified.len())? * options.default_position_std,
    );
    let (x_meas_base, x_tcp_target) = problem.frames(&x);
    let station_frames = problem.station_frames(&x);
    let np = model.n_params();
    let xi = x[..np].to_vec();
    let joint_start = problem.joint_terms_offset().unwrap_or(n);
    let elastic = options
        .gravity
        .as_ref()
        .map(|g| (g.clone(), x[fe..joint_start].to_vec()));
    let joint_term_values = x[joint_start..].to_vec();
    // Before: the starting model (nominal geometry, and starting compliances)
    // with its frames fitted; after: the fit. Both on the same error model.
    let training_before = error_statistics(&pose_errors(&problem, &x_nominal_robot)?);
    let errors_after = pose_errors(&problem, &x)?;
    let training_after = error_statistics(&errors_after);
    let data_checks = DataChecks::new(set, &errors_after);
    let station_errors = (0..set.n_stations())
        .map(|s| {
            let of_station: Vec<PoseError> = (0..set.len())
                .filter(|&k| set.station_of(k) == s)
                .map(|k| errors_after[k])
                .collect();
            error_statistics(&of_station)
        })
        .collect();
    Ok(Calibration {
        xi,
        nominal_xi: model.nominal_params().to_vec(),
        x_meas_base,
        station_frames,
        station_names: set.station_names().to_vec(),
        station_errors,
        x_tcp_target,
        x_tcp_target_initial: x_tcp_target0,
        x_tcp_target_nominal_robot: x_tcp_target_nominal,
        measurement_frame_fixed: frame_fixed,
        use_orientation,
        unknowns,
        elastic,
        joint_terms: options.joint_terms,
        joint_term_values,
        identifiability: numerical,
        combination_lines: combinations
            .iter()
            .map(|c| c.to_text(1e-3))
            .filter(|l| !l.is_empty())
            .collect(),
        combinations,
        solve: report,
        cost_history,
        residual_history: residual_history.into_inner(),
        training_before,
        training_after,
        training_after_per_pose: errors_after,
        data_checks,
        noise,
        n_poses: set.len(),
        actuated_names: model.actuated_names().to_vec(),
        actuated_ranges,
        torque_ranges,
    })
}

/// Maps an index of an analysis over a subset of unknowns back to the full vector.
pub(crate) fn analysis_index(
    analysis: &IdentifiabilityReport,
    j: usize,
    names: &[String],
) -> usize {
    let name = &analysis.names[j];
    names.iter().position(|n| n == name).unwrap_or(0)
}

fn problem_error(e: flexcal_optim::ProblemError) -> CalibError {
    match e.downcast::<CalibError>() {
        Ok(calib) => *calib,
        Err(other) => CalibError::BadMeasurement {
            source_name: String::new(),
            line: 0,
            what: other.to_string(),
        },
    }
}

/// `name_id = name + sum_k coefficient_k * other_k`: what an identified
/// unknown stands for when others are not identified (the paper's (C.1)).
/// Coefficients are in physical units (m per m, m per rad, ...).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Combination {
    /// The identified unknown.
    pub name: String,
    /// `(absorbed unknown, coefficient)`, largest magnitude first.
    pub terms: Vec<(String, f64)>,
}

impl Combination {
    /// `d4_id = d4 + 0.82 d9 - r8p`; empty when no coefficient reaches `threshold`.
    pub fn to_text(&self, threshold: f64) -> String {
        let mut line = format!("{}_id = {}", self.name, self.name);
        let mut any = false;
        for (other, k) in &self.terms {
            if k.abs() < threshold {
                continue;
            }
            any = true;
            let sign = if *k < 0.0 { '-' } else { '+' };
            if (k.abs() - 1.0).abs() < 5e-4 {
                line.push_str(&format!(" {sign} {other}"));
            } else {
                line.push_str(&format!(" {sign} {:.3} {other}", k.abs()));
            }
        }
        if any { line } else { String::new() }
    }
}

/// A least-squares problem whose Jacobian comes in blocks of rows (a pose,
/// an observation of a target): what [`AnalysisContext::reduced`] streams.
pub(crate) trait StackedJacobian {
    /// Number of unknowns (columns).
    fn n_unknowns(&self) -> usize;
    /// Rows per block.
    fn rows_per_block(&self) -> usize;
    /// The Jacobian rows of the blocks `blocks` into `out` (row 0 is the
    /// first row of block `blocks.start`).
    fn jacobian_blocks(
        &self,
        x: &[f64],
        blocks: std::ops::Range<usize>,
        out: faer::MatMut<'_, f64>,
    ) -> Result<(), flexcal_optim::ProblemError>;
}

impl StackedJacobian for GeometricErrorModel<'_> {
    fn n_unknowns(&self) -> usize {
        GeometricErrorModel::n_unknowns(self)
    }
    fn rows_per_block(&self) -> usize {
        self.rows_per_pose()
    }
    fn jacobian_blocks(
        &self,
        x: &[f64],
        blocks: std::ops::Range<usize>,
        out: faer::MatMut<'_, f64>,
    ) -> Result<(), flexcal_optim::ProblemError> {
        self.jacobian_rows(x, blocks, out)
    }
}

/// What the identifiability analyses share.
pub(crate) struct AnalysisContext<'a> {
    pub problem: &'a dyn StackedJacobian,
    pub weights: &'a [f64],
    pub names: &'a [String],
    pub priorities: &'a [i32],
    pub limits: &'a [f64],
    pub rank_tolerance: f64,
}

impl AnalysisContext<'_> {
    /// The triangular factor `R` of the weighted Jacobian `W J = Q R` at `x`
    /// (min(m, n) x n). Column-pivoted QR, ranks, base sets and least-squares
    /// combinations of any subset of columns are the same on `R` as on `W J`
    /// (they differ by the orthogonal `Q`), at a fraction of the cost for
    /// thousands of poses.
    pub(crate) fn reduced(&self, x: &[f64]) -> Result<Mat<f64>, CalibError> {
        let n = self.problem.n_unknowns();
        let rows = self.problem.rows_per_block();
        let poses = self.weights.len() / rows;
        // Streamed by blocks of poses: R of [R_so_far; W J_block] (a few
        // hundred rows), so the whole stacked Jacobian is never held.
        let block = (320 / rows).max(1);
        let mut r = Mat::<f64>::zeros(0, n);
        let mut start = 0;
        while start < poses {
            let end = (start + block).min(poses);
            let m_block = (end - start) * rows;
            let top = r.nrows();
            let mut stacked = Mat::<f64>::zeros(top + m_block, n);
            for j in 0..n {
                for i in 0..top {
                    stacked[(i, j)] = r[(i, j)];
                }
            }
            self.problem
                .jacobian_blocks(x, start..end, stacked.as_mut().subrows_mut(top, m_block))
                .map_err(problem_error)?;
            for j in 0..n {
                for i in 0..m_block {
                    stacked[(top + i, j)] *= self.weights[start * rows + i];
                }
            }
            let qr = stacked.qr();
            let thin = qr.thin_R();
            r = Mat::<f64>::from_fn(
                thin.nrows(),
                n,
                |i, j| if i <= j { thin[(i, j)] } else { 0.0 },
            );
            start = end;
        }
        Ok(r)
    }

    /// `K` with `J_N = J_B K` (weighted least squares at `x`), so that
    /// `J (xi_B, xi_N) = J_B (xi_B + K xi_N)`.
    pub(crate) fn combinations(
        &self,
        reduced: &Mat<f64>,
        base: &[usize],
        absorbed: &[usize],
    ) -> Result<Vec<Combination>, CalibError> {
        let m = reduced.nrows();
        if absorbed.is_empty() || base.is_empty() {
            return Ok(base
                .iter()
                .map(|&b| Combination {
                    name: self.names[b].clone(),
                    terms: Vec::new(),
                })
                .collect());
        }
        let j_b = Mat::<f64>::from_fn(m, base.len(), |i, c| reduced[(i, base[c])]);
        let j_n = Mat::<f64>::from_fn(m, absorbed.len(), |i, c| reduced[(i, absorbed[c])]);
        // The base columns are independent by construction: plain QR least squares.
        let k = j_b.qr().solve_lstsq(&j_n);
        Ok(base
            .iter()
            .enumerate()
            .map(|(row, &b)| {
                let mut terms: Vec<(String, f64)> = absorbed
                    .iter()
                    .enumerate()
                    .map(|(col, &a)| (self.names[a].clone(), k[(row, col)]))
                    .filter(|(_, v)| v.is_finite() && *v != 0.0)
                    .collect();
                terms.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
                Combination {
                    name: self.names[b].clone(),
                    terms,
                }
            })
            .collect())
    }

    /// Identifiability of the unknowns not excluded, at `x`, on the weighted
    /// Jacobian (so a pose measured poorly counts less).
    ///
    /// Without `noise`, columns are scaled by their norms and the rank is the
    /// numerical one at `rank_tolerance`. With the noise level `sigma`
    /// (weighted units), column j is scaled by its standard-error limit
    /// `l_j` and a column enters the base set only if its part orthogonal to
    /// the columns already chosen, `|R_kk| l_j`, exceeds `sigma`: the
    /// identified value would otherwise carry a standard error above `l_j`
    /// (`se_k >= sigma / |R_kk|`).
    pub(crate) fn analyse(
        &self,
        reduced: &Mat<f64>,
        noise: Option<f64>,
        excluded: &dyn Fn(usize) -> bool,
    ) -> Result<IdentifiabilityReport, CalibError> {
        let n = reduced.ncols();
        let kept: Vec<usize> = (0..n).filter(|&j| !excluded(j)).collect();
        let sub = Mat::<f64>::from_fn(reduced.nrows(), kept.len(), |i, c| reduced[(i, kept[c])]);
        let sub_names: Vec<String> = kept.iter().map(|&j| self.names[j].clone()).collect();
        let mut options = IdentifiabilityOptions {
            rank_tolerance: self.rank_tolerance,
            priorities: kept.iter().map(|&j| self.priorities[j]).collect(),
            ..IdentifiabilityOptions::default()
        };
        if let Some(sigma) = noise {
            let limits: Vec<f64> = kept.iter().map(|&j| self.limits[j]).collect();
            let reference = (0..kept.len())
                .map(|c| sub.col(c).norm_l2() * limits[c])
                .fold(0.0, f64::max);
            if reference > 0.0 && sigma.is_finite() {
                options.rank_tolerance = (sigma / reference).clamp(1e-12, 0.999);
            }
            options.column_scaling = ColumnScaling::Fixed(limits.iter().map(|l| 1.0 / l).collect());
        }
        analyze_identifiability(sub.as_ref(), &sub_names, &options)
            .map_err(CalibError::optim("identifiability analysis"))
    }
}

/// Noise level in weighted units at `x` with `free` unknowns identified: 1
/// with absolute weights, else estimated from the weighted residual
/// `sqrt(sum (w r)^2 / (m - free))` (first at the start, then at each fit).
pub(crate) fn noise_level(
    problem: &impl Residuals,
    weights: &[f64],
    absolute: bool,
    x: &[f64],
    free: usize,
) -> Result<f64, CalibError> {
    if absolute {
        return Ok(1.0);
    }
    let rows = weights.len();
    let mut r = vec![0.0; rows];
    problem.residuals(x, &mut r).map_err(problem_error)?;
    let ssr: f64 = r.iter().zip(weights).map(|(r, w)| (r * w).powi(2)).sum();
    Ok((ssr / (rows.saturating_sub(free).max(1)) as f64).sqrt())
}

/// What an identification found of each unknown, by index.
pub(crate) struct UnknownFlags<'a> {
    /// Kept at its value by the options.
    pub fixed: &'a [bool],
    /// Its column is zero (a frame that no observation sees).
    pub no_influence: &'a [bool],
    /// Left at its starting value by the rank or noise-aware rank.
    pub frozen: &'a [bool],
    /// A combination of others whatever the noise.
    pub exactly_dependent: &'a [bool],
    /// Each compliance's judgement on its own scale.
    pub judgements: &'a [Option<ScaleJudgement>],
}

/// Every unknown `(names, kinds)` with its start and identified value
/// (`(x_initial, report)`, the report giving the values and standard
/// errors), its status from `flags` and its spread ratio: the one place
/// that decides [`UnknownStatus`] for one target and for several.
pub(crate) fn unknown_estimates(
    (names, kinds): (&[String], &[UnknownKind]),
    (x_initial, report): (&[f64], &SolveReport),
    flags: &UnknownFlags<'_>,
    spread_ratios: &[Option<f64>],
) -> Vec<UnknownEstimate> {
    (0..names.len())
        .map(|j| {
            let at_bound = flags.judgements[j]
                .is_some_and(|judgement| judgement.outcome == ScaleOutcome::AtBound);
            let status = if flags.fixed[j] {
                UnknownStatus::Fixed
            } else if at_bound {
                UnknownStatus::AtBound
            } else if flags.no_influence[j] {
                UnknownStatus::NoInfluence
            } else if flags.frozen[j] && flags.exactly_dependent[j] {
                UnknownStatus::NonIdentifiable
            } else if flags.frozen[j] {
                UnknownStatus::PoorlyIdentifiable
            } else {
                UnknownStatus::Identified
            };
            UnknownEstimate {
                name: names[j].clone(),
                kind: kinds[j],
                initial: x_initial[j],
                value: report.x[j],
                standard_error: if status == UnknownStatus::Identified {
                    report.standard_errors[j]
                } else {
                    None
                },
                spread_ratio: spread_ratios[j],
                status,
                judgement: flags.judgements[j],
            }
        })
        .collect()
}

/// The noise level (weighted units) at unknowns `x` with `free` unknowns
/// identified.
pub(crate) type NoiseAt<'a> = dyn Fn(&[f64], usize) -> Result<f64, CalibError> + 'a;

/// What the rounds of a noise-aware identification
/// ([`AnalysisContext::identify_in_rounds`]) start from.
pub(crate) struct Rounds<'a> {
    /// [`AnalysisContext::reduced`] at the start point.
    pub reduced_start: &'a Mat<f64>,
    /// The start point: nominal robot, frames fitted.
    pub x_start: &'a [f64],
    /// Fixed unknowns and those without influence.
    pub excluded: &'a dyn Fn(usize) -> bool,
    /// Left at their start before any fit: cyclic errors over less than
    /// their period, compliances of barely loaded joints.
    pub partial_period: &'a [bool],
    /// Whether the row weights are absolute (the noise level is then 1).
    pub absolute: bool,
    /// [`CalibrationOptions::require_full_rank`].
    pub require_full_rank: bool,
    /// Number of unknowns not excluded.
    pub free_count: usize,
    /// Index of the first joint-term unknown (the number of unknowns
    /// without joint terms).
    pub joint_start: usize,
    /// The kind of every unknown (the compliances are judged on their own
    /// scale, [`crate::significance`]).
    pub kinds: &'a [UnknownKind],
    /// [`CalibrationOptions::min_compliance_z`].
    pub min_compliance_z: f64,
}

/// What the rounds of [`AnalysisContext::identify_in_rounds`] found: the
/// final fit, the unknowns left at their start (or bound), those exactly
/// dependent on others, the numerical analysis (no noise) that found
/// them, and each compliance's judgement on its own scale.
pub(crate) struct RoundsOutcome {
    pub report: SolveReport,
    pub frozen: Vec<bool>,
    pub exactly_dependent: Vec<bool>,
    pub numerical: IdentifiabilityReport,
    pub judgements: Vec<Option<ScaleJudgement>>,
}

impl AnalysisContext<'_> {
    /// The identification's rounds: unknowns beyond the numerical rank are
    /// left out whatever the noise; then the base set at the noise level
    /// (estimated from the residual unless the weights are absolute) is
    /// solved, the noise estimated again from the fit, and the base set
    /// solved again only if it changes (at most 4 rounds). The joint terms
    /// are non-linear in their unknowns: their standard-error limits are
    /// checked again at the solution, and a term beyond them is put back
    /// to its starting value and the rest solved again. Last, the
    /// compliances are judged on their own scale
    /// ([`crate::significance`]).
    ///
    /// # Errors
    /// [`CalibError::NothingToIdentify`], [`CalibError::RankDeficient`]
    /// (with `require_full_rank`), and what `noise_at` and `solve` return.
    pub(crate) fn identify_in_rounds(
        &self,
        r: &Rounds<'_>,
        noise_at: &NoiseAt<'_>,
        solve: &mut Solve<'_>,
    ) -> Result<RoundsOutcome, CalibError> {
        let n = self.names.len();
        let excluded = r.excluded;
        // Unknowns beyond the numerical rank whatever the noise (exact
        // dependencies).
        let numerical = self.analyse(r.reduced_start, None, excluded)?;
        let mut exactly_dependent = vec![false; n];
        for &j in &numerical.non_identifiable {
            exactly_dependent[analysis_index(&numerical, j, self.names)] = true;
        }
        let mut sigma = noise_at(r.x_start, r.free_count)?;
        // Solve, re-estimate the noise from the fit, and solve again only if
        // the base set then changes (relative weights: the first estimate
        // includes the model error of the nominal robot).
        let mut previous: Option<(Vec<usize>, SolveReport, Vec<bool>)> = None;
        let mut round = 0;
        let (report, frozen) = loop {
            round += 1;
            let analysis = self.analyse(r.reduced_start, Some(sigma), &|j| {
                excluded(j) || exactly_dependent[j] || r.partial_period[j]
            })?;
            let mut base = analysis.base.clone();
            base.sort_unstable();
            // A later round starts from the previous fit, its newly frozen
            // unknowns put back at their starting values: the base set
            // changes by a few unknowns, so most of the way is already done.
            let mut warm: Option<(Vec<f64>, Vec<bool>)> = None;
            if let Some((previous_base, report, frozen)) = previous.take() {
                if previous_base == base || round > 4 {
                    break (report, frozen);
                }
                warm = Some((report.x, frozen));
            }
            let mut frozen = vec![true; n];
            for &b in &analysis.base {
                frozen[analysis_index(&analysis, b, self.names)] = false;
            }
            if frozen.iter().all(|f| *f) {
                return Err(CalibError::NothingToIdentify);
            }
            if r.require_full_rank && frozen.iter().enumerate().any(|(j, f)| *f && !excluded(j)) {
                return Err(CalibError::RankDeficient {
                    rank: analysis.rank,
                    unknowns: r.free_count,
                    non_identifiable: (0..n)
                        .filter(|&j| frozen[j] && !excluded(j))
                        .map(|j| self.names[j].clone())
                        .collect(),
                });
            }
            let mut x0 = r.x_start.to_vec();
            if let Some((x_previous, frozen_previous)) = &warm {
                for j in 0..n {
                    if !frozen[j] && !frozen_previous[j] {
                        x0[j] = x_previous[j];
                    }
                }
            }
            let report = solve(&x0, &frozen)?;
            if r.absolute {
                break (report, frozen);
            }
            sigma = noise_at(&report.x, analysis.rank)?;
            previous = Some((base, report, frozen));
        };
        let (mut report, mut frozen) = (report, frozen);
        for _ in 0..3 {
            let beyond: Vec<usize> = (r.joint_start..n)
                .filter(|&j| {
                    !frozen[j]
                        && report.standard_errors[j]
                            .is_none_or(|se| se.is_nan() || se > self.limits[j])
                })
                .collect();
            if beyond.is_empty() {
                break;
            }
            let mut x0 = report.x.clone();
            for &j in &beyond {
                frozen[j] = true;
                x0[j] = r.x_start[j];
            }
            report = solve(&x0, &frozen)?;
        }
        let compliance: Vec<bool> = r
            .kinds
            .iter()
            .map(|k| *k == UnknownKind::Compliance)
            .collect();
        let (report, frozen, judgements) = judge_compliances(
            &Judging {
                compliance: &compliance,
                limits: self.limits,
                z_min: r.min_compliance_z,
                x_start: r.x_start,
            },
            (report, frozen),
            solve,
        )?;
        Ok(RoundsOutcome {
            report,
            frozen,
            exactly_dependent,
            numerical,
            judgements,
        })
    }
}

/// The true value of each identified combination `xi_B + K xi_N` given a
/// full vector of true unknowns (`truth`, indexed like
/// [`Calibration::unknowns`]): `(name, true combination value, identified
/// value, standard error)`. Absorbed unknowns stay where the fit left them
/// (their starting values, or zero for a compliance held at its bound), so
/// only their true deviation from there is absorbed.
pub fn combination_check(
    calibration: &Calibration,
    truth: &[f64],
) -> Vec<(String, f64, f64, Option<f64>)> {
    let index = |name: &str| calibration.unknowns.iter().position(|u| u.name == name);
    calibration
        .combinations
        .iter()
        .filter_map(|c| {
            let jb = index(&c.name)?;
            let mut value = *truth.get(jb)?;
            for (other, k) in &c.terms {
                let jn = index(other)?;
                value += k * (truth.get(jn)? - calibration.unknowns[jn].value);
            }
            let u = &calibration.unknowns[jb];
            Some((u.name.clone(), value, u.value, u.standard_error))
        })
        .collect()
}

/// The sentence naming the unknowns of `unknowns` whose
/// [`UnknownEstimate::spread_ratio`] exceeds [`WEAK_SPREAD_RATIO`], if any.
pub(crate) fn weak_spread_note<'a>(
    unknowns: impl Iterator<Item = &'a UnknownEstimate>,
) -> Option<String> {
    let weak: Vec<String> = unknowns
        .filter_map(|u| {
            u.spread_ratio
                .filter(|r| *r > WEAK_SPREAD_RATIO)
                .map(|r| format!("{} x{r:.0}", u.name))
        })
        .collect();
    (!weak.is_empty()).then(|| {
        format!(
            "determined more than {WEAK_SPREAD_RATIO:.0} times less precisely than by as many poses spread over the joint ranges (standard error ratio): {}; these poses see them mostly in combinations that hold near them, so predictions for poses unlike them (other joint ranges) are extrapolations",
            weak.join(", ")
        )
    })
}

/// Most poses drawn for the spread reference of
/// [`UnknownEstimate::spread_ratio`] (its standard errors are rescaled to the
/// number of identification poses).
pub const SPREAD_REFERENCE_POSES: usize = 256;
/// Seed of the spread reference's draws: the same data give the same report.
const SPREAD_REFERENCE_SEED: u64 = 9283;
/// A robot parameter whose standard error is more than this many times the
/// one of the spread reference is reported as weakly determined by the poses.
pub const WEAK_SPREAD_RATIO: f64 = 10.0;

/// Diagonal of `(S^T S)^-1` for the columns `cols` of `s` (the unit-noise
/// covariance of those unknowns), or `None` when they are not independent.
pub(crate) fn unit_covariance_diagonal(s: &Mat<f64>, cols: &[usize]) -> Option<Vec<f64>> {
    let k = cols.len();
    let norms: Vec<f64> = cols.iter().map(|&j| s.col(j).norm_l2()).collect();
    if norms.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
        return None;
    }
    // Scaled columns: lengths and angles on the same footing for the factor.
    let mut normal = nalgebra::DMatrix::<f64>::zeros(k, k);
    for a in 0..k {
        for b in a..k {
            let dot: f64 = (0..s.nrows())
                .map(|i| s[(i, cols[a])] * s[(i, cols[b])])
                .sum::<f64>()
                / (norms[a] * norms[b]);
            normal[(a, b)] = dot;
            normal[(b, a)] = dot;
        }
    }
    let inverse = normal.cholesky()?.inverse();
    let diagonal: Vec<f64> = (0..k)
        .map(|a| inverse[(a, a)] / (norms[a] * norms[a]))
        .collect();
    diagonal
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
        .then_some(diagonal)
}

/// What the spread reference needs from the identification.
struct SpreadInputs<'a> {
    model: &'a Model,
    set: &'a MeasurementSet,
    /// What the identification poses cover of each actuated coordinate.
    actuated_ranges: &'a [CoordinateCoverage],
    options: &'a CalibrationOptions,
    use_orientation: bool,
    frames: (Isometry3<f64>, Isometry3<f64>),
    /// Starting frames of the later stations.
    station_frames: &'a [Isometry3<f64>],
    context: &'a AnalysisContext<'a>,
}

impl SpreadInputs<'_> {
    /// For each unknown of `identified`, its standard error with these poses
    /// divided by the one that as many poses spread over the robot's joint
    /// ranges would give, both with the same noise (see
    /// [`UnknownEstimate::spread_ratio`]). `None` everywhere when no
    /// reference can be drawn (a closed loop that rarely closes) or the
    /// reference cannot separate them either.
    fn ratios(
        &self,
        reduced: &Mat<f64>,
        x: &[f64],
        identified: &[usize],
    ) -> Result<Vec<Option<f64>>, CalibError> {
        let n = reduced.ncols();
        let out = vec![None; n];
        let Some(training) = unit_covariance_diagonal(reduced, identified) else {
            return Ok(out);
        };
        let rows = self.context.problem.rows_per_block();
        let poses = self.set.len();
        let weight = rms_row_weights(self.context.weights, rows);
        let count = poses.min(SPREAD_REFERENCE_POSES);
        let Some(configurations) =
            spread_configurations(self.model, self.actuated_ranges, count, x)
        else {
            return Ok(out);
        };
        let drawn: Vec<crate::Measurement> = configurations
            .into_iter()
            .map(|q| {
                let mut m = crate::Measurement::new(q, nalgebra::Vector3::zeros());
                if self.use_orientation {
                    m.orientation = Some(nalgebra::Vector3::zeros());
                }
                m
            })
            .collect();
        // The spread poses are shared out among the stations, each of
        // which then sees as many as its frame needs.
        let stations = self.set.n_stations();
        if count < stations {
            return Ok(out);
        }
        let reference = MeasurementSet::new("spread reference", drawn)?.with_stations(
            self.set.station_names().to_vec(),
            (0..count).map(|k| k % stations).collect(),
        )?;
        let mut problem = GeometricErrorModel::new(
            self.model,
            &reference,
            self.use_orientation,
            self.frames.0,
            self.frames.1,
        )?
        .with_station_frames(self.station_frames)?;
        if let Some(gravity) = &self.options.gravity {
            problem = problem.with_gravity(gravity)?;
        }
        if self.options.joint_terms.any() {
            problem = problem.with_joint_terms(&self.options.joint_terms)?;
        }
        let weights: Vec<f64> = (0..count * rows).map(|i| weight[i % rows]).collect();
        let context = AnalysisContext {
            problem: &problem,
            weights: &weights,
            ..*self.context
        };
        Ok(spread_ratio_values(
            &training,
            &context.reduced(x)?,
            identified,
            count as f64 / poses as f64,
        ))
    }
}

/// The RMS weight of each row kind (`rows` rows per block) over the blocks
/// of `weights`: what a reference row weighs.
pub(crate) fn rms_row_weights(weights: &[f64], rows: usize) -> Vec<f64> {
    let blocks = (weights.len() / rows).max(1) as f64;
    let mut weight = vec![0.0; rows];
    for block in weights.chunks(rows) {
        for (w, v) in weight.iter_mut().zip(block) {
            *w += v * v / blocks;
        }
    }
    weight.iter_mut().for_each(|w| *w = w.sqrt());
    weight
}

/// `count` configurations of the spread reference, drawn with a fixed seed:
/// revolute coordinates over their limits, prismatic ones (whose default
/// limits are not a workspace) over `actuated_ranges`, a closed loop's
/// drawn again where it cannot close at the robot parameters of `x`.
/// `None` when a loop rarely closes.
pub(crate) fn spread_configurations(
    model: &Model,
    actuated_ranges: &[CoordinateCoverage],
    count: usize,
    x: &[f64],
) -> Option<Vec<Vec<f64>>> {
    use rand::{Rng, SeedableRng};
    let ranges: Vec<(f64, f64)> = model
        .actuated_limits()
        .iter()
        .zip(model.actuated_kinds())
        .zip(actuated_ranges)
        .map(|((&limits, kind), &seen)| match kind {
            flexcal_kinematics::ActuatedKind::Revolute => limits,
            _ => (seen.lo, seen.hi),
        })
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SPREAD_REFERENCE_SEED);
    let mut data = flexcal_kinematics::Data::new(model);
    let mut drawn = Vec::with_capacity(count);
    let mut tries = 0;
    while drawn.len() < count && tries < 50 * count {
        tries += 1;
        let q: Vec<f64> = ranges
            .iter()
            .map(|&(lo, hi)| {
                if lo < hi {
                    rng.random_range(lo..hi)
                } else {
                    lo
                }
            })
            .collect();
        // A closed loop that cannot close at q: draw again.
        if !model.is_serial()
            && flexcal_kinematics::forward_pose(model, &mut data, &q, &x[..model.n_params()])
                .is_err()
        {
            continue;
        }
        drawn.push(q);
    }
    (drawn.len() == count).then_some(drawn)
}

/// [`UnknownEstimate::spread_ratio`] of each unknown of `identified`: the
/// square root of its unit-noise variance `training` over the one of the
/// reference's reduced factor `spread`, the reference's scaled by `scale`
/// (its poses over the identification's: covariances go as 1 / poses).
/// `None` everywhere when the reference cannot separate them.
pub(crate) fn spread_ratio_values(
    training: &[f64],
    spread: &Mat<f64>,
    identified: &[usize],
    scale: f64,
) -> Vec<Option<f64>> {
    let mut out = vec![None; spread.ncols()];
    let Some(spread) = unit_covariance_diagonal(spread, identified) else {
        return out;
    };
    for (c, &j) in identified.iter().enumerate() {
        out[j] = Some((training[c] / (spread[c] * scale)).sqrt());
    }
    out
}
