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
    /// A URDF file is malformed, uses something flexcal cannot import (a
    /// xacro macro, a kinematic loop, a floating joint on the path), or
    /// names an unknown link or joint.
    #[error("{source_name}:{line}: {message}")]
    Urdf {
        /// The file (or other source) the text came from.
        source_name: String,
        /// 1-based line of the element concerned (0 when the whole file is).
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// A robot file's tree has several leaves and no tip was chosen.
    #[error("{source_name}: the tree has several end links ({candidates}): choose one as the tip")]
    AmbiguousTip {
        /// The file the tree came from.
        source_name: String,
        /// The candidate tip links, comma-separated.
        candidates: String,
    },
    /// A link asked for as the root or the tip does not exist, or the tip
    /// is not below the root.
    #[error("{source_name}: {what} (links: {known})")]
    UnknownLink {
        /// The file the tree came from.
        source_name: String,
        /// What was asked and why it fails.
        what: String,
        /// The links of the file, comma-separated.
        known: String,
    },
    /// A SYMORO `.par` file is malformed or inconsistent (NF against the
    /// rows given, an unknown keyword, a value that is no number).
    #[error("{source_name}:{line}: {message}")]
    Symoro {
        /// The file the text came from.
        source_name: String,
        /// 1-based line (0 when the whole file is concerned).
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// Symbolic entries of a `.par` file have no value in the values file.
    #[error(
        "{source_name}: no value for the symbols {symbols} (give them in a values file, SI units)"
    )]
    MissingSymbols {
        /// The `.par` file.
        source_name: String,
        /// The symbols without a value, comma-separated.
        symbols: String,
    },
    /// Part of a robot has no place in an export format (a closed loop or a
    /// slider crank in a URDF).
    #[error("cannot export to {format}: {what}")]
    Inexpressible {
        /// The target format.
        format: String,
        /// What the format cannot express, by name.
        what: String,
    },
    /// An export would change the robot's poses by more than the tolerance.
    #[error(
        "export to {format} would move the TCP by {loss:.3e} m (tolerance {tolerance:.3e} m): {what}"
    )]
    ExportLoss {
        /// The target format.
        format: String,
        /// What is dropped.
        what: String,
        /// Largest TCP displacement caused, over the configurations checked (m).
        loss: f64,
        /// The tolerance given (m).
        tolerance: f64,
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
    /// A frame asked for by name is neither a frame nor a named place of
    /// the robot.
    #[error("robot `{robot}` has no frame `{name}` (frames: {known})")]
    UnknownFrame {
        /// The robot's name.
        robot: Box<str>,
        /// The name asked for.
        name: String,
        /// The names it has, comma-separated ([`crate::Model::named_frames`]).
        known: String,
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
    /// Following a closed loop from the configuration where it was last
    /// assembled (the home configuration of a fresh [`crate::Data`], else
    /// the previous call) to the one asked for, a step met a singular loop
    /// Jacobian: the mechanism passes through a singular configuration
    /// (a cylinder in line with its lever, a crank and coupler aligned),
    /// where the assembly branch cannot be followed.
    #[error(
        "loop `{}`: singular loop Jacobian at q = {:?} on the way from q = {:?} to q = {:?} (a singular configuration of the mechanism: the assembly branch cannot be followed through it)",
        .0.loop_name, .0.at, .0.from, .0.q
    )]
    LoopSingular(Box<LoopSingularity>),
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
    /// A serial-chain evaluator ([`crate::SerialChain`]) was asked for a
    /// robot that is not a serial chain from R0 to its TCP.
    #[error(
        "robot `{robot}` is not a serial chain: {reason} (the general forward model handles it)"
    )]
    NotSerial {
        /// The robot's name.
        robot: String,
        /// What makes it not serial, naming the loop or frame.
        reason: String,
    },
}

/// Where a loop continuation met a singular loop Jacobian
/// ([`KinematicsError::LoopSingular`]); configurations in SI units, order of q.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopSingularity {
    /// The loop's name.
    pub loop_name: String,
    /// The actuated configuration asked for.
    pub q: Vec<f64>,
    /// Where the continuation started.
    pub from: Vec<f64>,
    /// The step's configuration where the Jacobian is singular.
    pub at: Vec<f64>,
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
