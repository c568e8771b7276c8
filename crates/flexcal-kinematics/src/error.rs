//! The error type of the crate.

use thiserror::Error;

/// Everything that can go wrong while reading a robot description, building a
/// [`crate::Model`] or running one of its algorithms.
///
/// Each variant names what was wrong and where (file and line, frame,
/// parameter, loop, configuration), so that a message can be shown to a user
/// as it is.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum KinematicsError {
    /// A built-in robot was asked for by a name that does not exist.
    #[error("unknown built-in robot `{name}` (known: {known})")]
    UnknownRobot {
        /// The name asked for.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },
    /// The robot description file is not valid TOML or does not match the
    /// description format.
    #[error("{source_name}:{line}: {message}")]
    Toml {
        /// The file (or other source) the text came from.
        source_name: String,
        /// 1-based line of the error (0 when the parser could not tell).
        line: usize,
        /// What the parser reported.
        message: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The path concerned.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The description is inconsistent (unknown frame, cycle, bad coupling, ...).
    #[error("invalid robot description: {what}")]
    Invalid {
        /// What is wrong, naming the frame, parameter or loop concerned.
        what: String,
    },
    /// A slice argument has the wrong length.
    #[error("{what}: expected length {expected}, found {found}")]
    WrongLength {
        /// Which argument.
        what: String,
        /// The length the model requires.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// An input value is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which value (argument and index).
        what: String,
    },
    /// A closed loop could not be assembled at this configuration: the
    /// cut-joint frames do not meet.
    #[error("loop `{loop_name}` cannot close at q = {q:?}: residual {residual:.3e}")]
    LoopCannotClose {
        /// The loop's name.
        loop_name: String,
        /// The actuated configuration (SI units).
        q: Vec<f64>,
        /// Norm of the remaining cut-joint residual (m and rad mixed).
        residual: f64,
    },
    /// The inverse model found no configuration within the joint limits that
    /// reaches the target.
    #[error(
        "target unreachable: best position error {position_error:.3e} m, orientation error {orientation_error:.3e} rad after {iterations} iterations"
    )]
    Unreachable {
        /// Remaining position error of the best configuration found (m).
        position_error: f64,
        /// Remaining orientation error of the best configuration found (rad).
        orientation_error: f64,
        /// Iterations spent.
        iterations: usize,
    },
    /// A slider-crank actuator was given a screw length its triangle cannot
    /// form (or a joint angle it cannot reach).
    #[error(
        "slider crank of joint `{joint}`: screw length {screw_length:.6} m cannot close the triangle (cosine {cosine:.6})"
    )]
    SliderCrankOutOfRange {
        /// The frame (joint) the slider crank drives.
        joint: String,
        /// Screw length including its offset (m).
        screw_length: f64,
        /// The cosine of the crank angle the law of cosines asked for (outside (-1, 1)).
        cosine: f64,
    },
    /// A linear system met in an algorithm is singular (rank deficient).
    #[error("singular system in {what}: rank {rank} of {needed}")]
    Singular {
        /// Which system.
        what: String,
        /// Numerical rank found.
        rank: usize,
        /// Rank needed.
        needed: usize,
    },
}

/// Checks the length of a slice argument and that every entry is finite.
pub(crate) fn check_vector(what: &str, v: &[f64], expected: usize) -> Result<(), KinematicsError> {
    if v.len() != expected {
        return Err(KinematicsError::WrongLength {
            what: what.to_string(),
            expected,
            found: v.len(),
        });
    }
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(KinematicsError::NotFinite {
            what: format!("{what}[{k}]"),
        });
    }
    Ok(())
}
