//! Errors of the fuzzy compliance model.

use flexcal_fuzzy::FuzzyError;
use flexcal_kinematics::KinematicsError;

/// Errors of the fuzzy compliance model. Every variant names what it is
/// about (input, component, sample, setting, file).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FuzzyComplianceError {
    /// The fuzzy learner failed (too few samples, singular conclusions,
    /// invalid settings...).
    #[error("fuzzy model: {0}")]
    Fuzzy(#[from] FuzzyError),
    /// The robot geometry failed (slider crank out of range, wrong q).
    #[error("robot geometry: {0}")]
    Kinematics(#[from] KinematicsError),
    /// A file could not be read or written.
    #[error(transparent)]
    Io(#[from] flexcal_io::IoError),
    /// An input name is neither an actuated coordinate nor a joint angle of
    /// the robot.
    #[error("unknown input '{name}' for robot '{robot}' (known: {known})")]
    UnknownInput {
        /// The name asked for.
        name: String,
        /// The robot.
        robot: String,
        /// The names that exist, comma-separated.
        known: String,
    },
    /// The model needs at least one input.
    #[error("a fuzzy compliance model needs at least one input")]
    NoInputs,
    /// The model needs at least one compliance component.
    #[error("a fuzzy compliance model needs at least one compliance component")]
    NoComponents,
    /// An input or a component is listed twice.
    #[error("'{name}' is listed twice")]
    Duplicate {
        /// The repeated input or component name.
        name: String,
    },
    /// An input takes a single value over the training configurations: it
    /// cannot be partitioned.
    #[error(
        "input '{input}' is constant ({value}) over the training configurations: it cannot be partitioned"
    )]
    ConstantInput {
        /// Input name.
        input: String,
        /// Its only value (SI).
        value: f64,
    },
    /// A sample holds a NaN or infinite value.
    #[error("sample {sample} (pose {pose_id}): {field} = {value} is not a finite number")]
    NonFinite {
        /// 0-based sample index.
        sample: usize,
        /// Pose identifier of the sample.
        pose_id: u64,
        /// Which value (input name, wrench or deflection component).
        field: String,
        /// The value.
        value: f64,
    },
    /// A sample has the wrong number of input values.
    #[error(
        "sample {sample} (pose {pose_id}) has {found} input value(s), the model has {expected}"
    )]
    InputCount {
        /// 0-based sample index.
        sample: usize,
        /// Pose identifier of the sample.
        pose_id: u64,
        /// Inputs of the model.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// A rotational displacement component cannot be identified from TCP
    /// position measurements.
    #[error(
        "component '{component}': rotations are not measured, only translational components can be identified"
    )]
    RotationNotMeasured {
        /// The component.
        component: String,
    },
    /// No training sample loads the wrench axis of a component: its model
    /// is not determined.
    #[error(
        "component '{component}': no training sample has a non-zero {wrench} load, so it cannot be identified"
    )]
    ComponentNotExcited {
        /// The component.
        component: String,
        /// The wrench axis (`fx`, `mz`, ...).
        wrench: &'static str,
    },
    /// Fewer training configurations than rules: the conclusions are not
    /// determined.
    #[error(
        "component '{component}': {configurations} training configuration(s) load it, fewer than the {rules} rules of the simplest model"
    )]
    TooFewSamples {
        /// The component.
        component: String,
        /// Training configurations loading its wrench axis.
        configurations: usize,
        /// Rules of the simplest model (`2^n`).
        rules: usize,
    },
    /// A setting is out of its documented range.
    #[error("setting '{name}' = {value}: {reason}")]
    InvalidParameter {
        /// Setting name.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// The range it must respect.
        reason: &'static str,
    },
    /// The parts of a model do not fit together (a component model with
    /// other inputs, a vector of the wrong length...).
    #[error("inconsistent fuzzy compliance model: {message}")]
    Inconsistent {
        /// What is wrong.
        message: String,
    },
    /// A compliance file has wrong content.
    #[error("{path}: {message}")]
    File {
        /// The file (or `inline`).
        path: String,
        /// What is wrong.
        message: String,
    },
}

/// Shorthand for results of this module.
pub type Result<T> = std::result::Result<T, FuzzyComplianceError>;
