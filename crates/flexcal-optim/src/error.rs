//! The error type of the crate.

use thiserror::Error;

/// Error returned by the callers' residual or Jacobian code, carried through unchanged.
pub type ProblemError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Everything that can go wrong in `flexcal-optim`.
///
/// Every variant says which argument, parameter or evaluation is at fault, so a
/// calibration report can point the user at the offending input.
#[derive(Debug, Error)]
pub enum OptimError {
    /// An argument does not have the size the problem requires.
    #[error("dimension mismatch in `{argument}`: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Name of the argument whose size is wrong.
        argument: &'static str,
        /// Size the problem requires.
        expected: usize,
        /// Size that was given.
        found: usize,
    },
    /// A residual evaluated to NaN or infinity.
    #[error("non-finite residual {value} in row {row} at residual evaluation {evaluation}")]
    NonFiniteResidual {
        /// 1-based index of the residual evaluation.
        evaluation: usize,
        /// Row of the first non-finite residual.
        row: usize,
        /// The offending value.
        value: f64,
    },
    /// A Jacobian entry evaluated to NaN or infinity.
    #[error(
        "non-finite Jacobian entry {value} at row {row}, parameter `{parameter}` at Jacobian evaluation {evaluation}"
    )]
    NonFiniteJacobian {
        /// 1-based index of the Jacobian evaluation.
        evaluation: usize,
        /// Row of the entry.
        row: usize,
        /// Name of the parameter (column) of the entry.
        parameter: String,
        /// The offending value.
        value: f64,
    },
    /// A non-finite value in user data (a Jacobian given for analysis, a weight, a bound).
    #[error("non-finite value in `{argument}` at index {index}")]
    NonFiniteInput {
        /// Name of the argument.
        argument: &'static str,
        /// Flat index (row-major for matrices: `row * ncols + col`) of the first bad entry.
        index: usize,
    },
    /// The caller's residual or Jacobian code failed.
    #[error("the problem failed at evaluation {evaluation}")]
    Problem {
        /// 1-based index of the residual or Jacobian evaluation that failed.
        evaluation: usize,
        /// The caller's error.
        #[source]
        source: ProblemError,
    },
    /// The problem is rank deficient and the caller asked to fail on it.
    #[error(
        "rank-deficient problem: numerical rank {rank} of {n_params} free parameters; not identifiable: {parameters:?}"
    )]
    RankDeficient {
        /// Numerical rank of the scaled Jacobian.
        rank: usize,
        /// Number of free parameters.
        n_params: usize,
        /// Names of the parameters beyond the numerical rank.
        parameters: Vec<String>,
    },
    /// An option has a value outside its valid range.
    #[error("invalid option `{name}` = {value}: {reason}")]
    InvalidOption {
        /// Name of the option.
        name: &'static str,
        /// The value given, printed.
        value: String,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A linear-algebra routine failed to converge (an SVD, on pathological input).
    #[error("numerical failure: {what}")]
    Numerical {
        /// What failed.
        what: &'static str,
    },
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, OptimError>;

pub(crate) fn invalid(
    name: &'static str,
    value: impl std::fmt::Display,
    reason: &'static str,
) -> OptimError {
    OptimError::InvalidOption {
        name,
        value: value.to_string(),
        reason,
    }
}

pub(crate) fn check_len(argument: &'static str, expected: usize, found: usize) -> Result<()> {
    if expected == found {
        Ok(())
    } else {
        Err(OptimError::DimensionMismatch {
            argument,
            expected,
            found,
        })
    }
}
