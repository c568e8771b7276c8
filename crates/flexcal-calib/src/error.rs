//! The error type of the crate.

use flexcal_io::IoError;
use flexcal_kinematics::KinematicsError;
use flexcal_optim::OptimError;
use thiserror::Error;

/// Everything that can go wrong while reading measurements, identifying a
/// robot or validating it. Each variant names the file, pose, parameter or
/// step concerned so that the message can be shown to a user as it is.
#[derive(Debug, Error)]
pub enum CalibError {
    /// A file could not be read or written, or a CSV cell is malformed (the
    /// error names the file, line and column).
    #[error(transparent)]
    Io(#[from] IoError),
    /// A mass table (elasto-geometric model) is malformed or inconsistent.
    #[error("{source_name}:{line}: {what}")]
    BadMassTable {
        /// File of the mass table.
        source_name: String,
        /// 1-based line in the file (0 when the whole file is concerned).
        line: usize,
        /// What is wrong.
        what: String,
    },
    /// A measurement file has consistent syntax but unusable contents
    /// (`source:line: what`, or `source: what` for the whole set).
    #[error("{source_name}{}: {what}", if *line > 0 { format!(":{line}") } else { String::new() })]
    BadMeasurement {
        /// File (or other source) of the measurements.
        source_name: String,
        /// 1-based line in the file (0 when not from a file).
        line: usize,
        /// What is wrong.
        what: String,
    },
    /// The measurement set and the robot disagree on the number of actuated
    /// coordinates.
    #[error(
        "{source_name}: the measurements have {found} actuated coordinates, robot `{robot}` has {expected}"
    )]
    ActuatedCountMismatch {
        /// File of the measurements.
        source_name: String,
        /// Robot name.
        robot: String,
        /// Number of actuated coordinates of the robot.
        expected: usize,
        /// Number found in the measurements.
        found: usize,
    },
    /// Fewer measurement rows than unknowns: the problem cannot be determined.
    #[error(
        "too few measurements: {poses} poses give {rows} equations for {unknowns} free unknowns; measure more poses or fix parameters"
    )]
    TooFewPoses {
        /// Number of poses.
        poses: usize,
        /// Number of scalar equations (3 or 6 per pose).
        rows: usize,
        /// Number of free unknowns.
        unknowns: usize,
    },
    /// A parameter name given by the user is unknown.
    #[error("unknown parameter `{name}` (known: {known})")]
    UnknownParameter {
        /// The name given.
        name: String,
        /// Known names, comma-separated.
        known: String,
    },
    /// The problem is rank deficient and the caller asked for full rank.
    #[error(
        "rank-deficient problem: rank {rank} of {unknowns} free unknowns; not identifiable: {non_identifiable:?}; fix them (--fix) or measure other poses"
    )]
    RankDeficient {
        /// Numerical rank of the scaled stacked Jacobian.
        rank: usize,
        /// Number of free unknowns.
        unknowns: usize,
        /// Names of the non-identifiable unknowns.
        non_identifiable: Vec<String>,
    },
    /// Nothing is left to identify (every unknown fixed or non-identifiable).
    #[error("nothing to identify: every unknown is fixed or non-identifiable")]
    NothingToIdentify,
    /// The closed-form registration of the measurement frame is impossible
    /// (the measured points are collinear or coincide).
    #[error("cannot register the measurement frame: {what}")]
    DegenerateRegistration {
        /// Why.
        what: String,
    },
    /// The elastic deflection's equilibrium (the equilibrium module) did
    /// not converge at a pose: the springs are too soft for gravity's own
    /// stiffness there (the robot would buckle), or the iteration cap is
    /// too low.
    #[error(
        "the elastic equilibrium at pose {pose} ({pose_id}) {}",
        if *unstable {
            "is unstable: the joint springs are softer than gravity's own stiffness there (the robot would buckle under its weight)".to_string()
        } else {
            format!("did not converge: after {iterations} iterations a joint deflection still changed by {change:e} rad (raise max_iterations or the tolerance)")
        }
    )]
    EquilibriumNotConverged {
        /// 0-based pose index.
        pose: usize,
        /// The pose identifier of the file, or its index.
        pose_id: String,
        /// Iterations made.
        iterations: usize,
        /// The largest change of a joint deflection in the last iteration
        /// (rad or m).
        change: f64,
        /// Whether an equilibrium was found but is unstable.
        unstable: bool,
    },
    /// The robot model failed at a pose.
    #[error("robot model at pose {pose} ({pose_id}): {source}")]
    Kinematics {
        /// 0-based pose index.
        pose: usize,
        /// The pose identifier of the file, or its index.
        pose_id: String,
        /// The model's error.
        #[source]
        source: KinematicsError,
    },
    /// The robot description could not be built or written.
    #[error("robot description: {0}")]
    Description(#[source] KinematicsError),
    /// The least-squares machinery failed (naming the step).
    #[error("{step}: {source}")]
    Optim {
        /// Which step (identification, validation re-fit, pose selection).
        step: &'static str,
        /// The solver's error.
        #[source]
        source: OptimError,
    },
    /// An option is outside its valid range.
    #[error("invalid option `{name}`: {reason}")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The identification was cancelled through
    /// [`crate::CalibrationOptions::cancel`] before it finished.
    #[error("identification cancelled on request")]
    Cancelled,
    /// A report could not be serialised.
    #[error("cannot serialise {what}: {message}")]
    Serialise {
        /// What was being serialised.
        what: &'static str,
        /// The serialiser's message.
        message: String,
    },
}

impl CalibError {
    pub(crate) fn optim(step: &'static str) -> impl FnOnce(OptimError) -> CalibError {
        move |source| CalibError::Optim { step, source }
    }
}

/// `Ok` when option `name`'s value `v` is finite and `> 0`, else
/// [`CalibError::InvalidOption`] naming it.
pub(crate) fn require_positive(name: &'static str, v: f64) -> Result<(), CalibError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(CalibError::InvalidOption {
            name,
            reason: format!("must be finite and > 0, found {v}"),
        })
    }
}
