//! Errors of the twin's truth.

/// Errors of the twin's truth.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TruthError {
    /// The robot is not the built-in IR-663 the truth is written for.
    #[error("robot `{robot}` is not the IR-663 of the twin: it has no parameter `{missing}`")]
    NotTheIr663 {
        /// The robot's name.
        robot: String,
        /// The parameter or frame it lacks.
        missing: String,
    },
    /// The kinematic model failed (naming the step).
    #[error("twin truth, {step}: {source}")]
    Kinematics {
        /// What was being done.
        step: String,
        /// The model's error.
        #[source]
        source: flexcal_kinematics::KinematicsError,
    },
    /// The twin's structure failed.
    #[error("twin truth, structure: {0}")]
    Mechanics(#[from] super::mechanics::MechanicsError),
    /// An argument is out of range.
    #[error("twin truth: invalid `{name}`: {reason}")]
    Invalid {
        /// Argument name.
        name: &'static str,
        /// What is wrong.
        reason: String,
    },
}
