//! Step 1 of the identification: its settings,
//! [`CalibrationOptions`], with the solver ([`Method`]), the weighting
//! ([`Weighting`]) and whether each frame is identified
//! ([`FrameTreatment`]); their check refuses values out
//! of range by name.

use flexcal_kinematics::Model;
use nalgebra::Isometry3;

use crate::error::CalibError;
use crate::gravity::GravityCompliance;
use crate::joint_law::JointTerms;
use crate::significance::{InstrumentNoise, MIN_TORQUE_SHARE};
use crate::unknown_kind::UnknownKind;
use flexcal_optim::CancelToken;
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

pub use crate::frames::FrameTreatment;

/// Settings of [`crate::calibrate`]. Defaults suit a laser tracker or photogrammetry
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
    /// Unknowns beyond this rank are [`crate::UnknownStatus::NonIdentifiable`].
    pub rank_tolerance: f64,
    /// Noise-aware rank: a length unknown that could only be identified with a
    /// standard error above this limit is not identified but kept at its
    /// starting value, [`crate::UnknownStatus::PoorlyIdentifiable`] (m; default
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
    /// to its starting value, [`crate::UnknownStatus::PoorlyIdentifiable`]; a
    /// determined compliance the fit puts below zero by more than its
    /// standard error is held at zero, [`crate::UnknownStatus::AtBound`]
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
    /// ([`crate::UnknownEstimate::spread_ratio`]; default true). Off, the ratios
    /// are `None` and the identification is faster (model selection's
    /// fold fits need no ratios).
    pub spread_reference: bool,
    /// The fit serves its predictions only (default false): model
    /// selection's fold fits set it, scored by their predictions of
    /// held-out poses and most of the selection's solves. Two things
    /// change. The compliances are judged ([`crate::significance`]) on
    /// linearised updates of the fit: after a compliance is left out (or
    /// held at zero) the others move by the Gauss-Newton step of the fit's
    /// quadratic model and their standard errors follow its covariance,
    /// instead of a solve; solved again only when a judgement made so lies
    /// within 10 % of its threshold. The fit's values are then that step's,
    /// not a converged solve's: its predictions differ far below the
    /// noise. And the singular values and condition numbers of the
    /// reports (the solver's, the numerical identifiability analysis') are
    /// not computed: empty and NaN.
    pub prediction_only: bool,
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
    /// Threads that evaluate the residuals and the Jacobian over the poses
    /// ([`crate::ErrorModel::with_threads`]; default `None`:
    /// [`std::thread::available_parallelism`]; `Some(1)`: serial, on the
    /// calling thread; `>= 1`). Fewer are used for small sets (at least
    /// [`crate::error_model::MIN_POSES_PER_THREAD`] poses per thread). The
    /// results are the same to the bit whatever the count; callers that
    /// run several identifications at once on their own threads (model
    /// selection's folds) pass `Some(1)`.
    pub threads: Option<usize>,
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
            prediction_only: false,
            gravity: None,
            require_full_rank: false,
            max_iterations: 100,
            cost_tolerance: 1e-6,
            cancel: None,
            threads: None,
        }
    }
}

/// Limit `2 ||a|| / ||v||` of the geodesic acceleration of the
/// Levenberg-Marquardt steps when the model has the non-linear joint law
/// ([`flexcal_optim::LevenbergMarquardt::geodesic_acceleration`]; GSL's default).
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
        if self.threads == Some(0) {
            return Err(CalibError::InvalidOption {
                name: "threads",
                reason: "must be >= 1 (or unset: as many as the machine has)".into(),
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
