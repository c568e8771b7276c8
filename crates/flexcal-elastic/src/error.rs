//! The error type of flexcal-elastic.

use std::path::PathBuf;

/// Everything that can go wrong when building a robot's elastic model,
/// evaluating it, reading deflection data or identifying stiffness.
///
/// Every variant names what it is about (node, element, parameter, file and
/// line) so that the message alone points at the faulty input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ElasticError {
    /// A value of the elastic description is out of its allowed range.
    #[error("{owner}: field '{field}': {message}")]
    InvalidValue {
        /// The node, element or parameter, e.g. `beam '23'`.
        owner: String,
        /// The field, as spelled in the description file.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A node name that the description does not define.
    #[error("{owner}: field '{field}': unknown node '{node}' (known: {known})")]
    UnknownNode {
        /// Where the name was used.
        owner: String,
        /// The field holding the name.
        field: String,
        /// The name that was not found.
        node: String,
        /// The node names that exist, comma-separated.
        known: String,
    },
    /// A frame name that the robot does not have.
    #[error(
        "{owner}: field '{field}': robot '{robot}' has no frame '{frame}' (frames: 0, {known})"
    )]
    UnknownFrame {
        /// Where the name was used.
        owner: String,
        /// The field holding the name.
        field: String,
        /// The robot's name.
        robot: String,
        /// The name that was not found.
        frame: String,
        /// The frame names that exist, comma-separated.
        known: String,
    },
    /// Two nodes, elements or parameters share a name.
    #[error("duplicate {kind} name '{name}'")]
    DuplicateName {
        /// `node`, `element` or `stiffness parameter`.
        kind: &'static str,
        /// The repeated name.
        name: String,
    },
    /// A built-in elastic description was asked for by a name that does not exist.
    #[error("unknown built-in elastic description '{name}' (known: {known})")]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
        /// The built-in names.
        known: String,
    },
    /// The description file could not be parsed.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message (with line and column).
        message: String,
    },
    /// A stiffness vector does not match the model's parameters.
    #[error("stiffness vector has {found} values, the model has {expected} parameters ({names})")]
    StiffnessLength {
        /// Number of parameters of the model.
        expected: usize,
        /// Number of values given.
        found: usize,
        /// Parameter names.
        names: String,
    },
    /// A stiffness parameter value is not positive and finite.
    #[error("stiffness parameter '{name}' = {value}: must be positive and finite")]
    InvalidStiffness {
        /// Parameter name.
        name: String,
        /// The value given.
        value: f64,
    },
    /// The robot's geometry could not be evaluated (loop that cannot close,
    /// wrong vector length, ...).
    #[error("robot geometry: {0}")]
    Kinematics(#[from] flexcal_kinematics::KinematicsError),
    /// The finite-element structure failed (zero-length beam in this
    /// configuration, singular structure, ...).
    #[error("{context}: {source}")]
    Fem {
        /// What was being done (configuration, element).
        context: String,
        /// The finite-element error.
        #[source]
        source: flexcal_fem::FemError,
    },
    /// A data file could not be read or written.
    #[error(transparent)]
    Io(#[from] flexcal_io::IoError),
    /// A data file is readable but its content is inconsistent.
    #[error("{path}:{line}: {message}")]
    Data {
        /// The file.
        path: PathBuf,
        /// 1-based line (the header is line 1; 0 when it concerns the whole file).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A data folder holds no deflection set, or none with the requested load.
    #[error("{what}")]
    NoData {
        /// What was missing.
        what: String,
    },
    /// No stiffness parameter has a measurable effect on the data: the
    /// identification has nothing it can determine.
    #[error(
        "none of the stiffness parameters ({parameters}) moves the fit by {threshold} standard deviation(s) per factor e: the data cannot identify them"
    )]
    NotIdentifiable {
        /// Parameter names.
        parameters: String,
        /// The practical threshold in force.
        threshold: f64,
    },
    /// The numerical solvers failed.
    #[error("stiffness identification: {0}")]
    Optim(#[from] flexcal_optim::OptimError),
}

impl ElasticError {
    pub(crate) fn fem(context: impl Into<String>, source: flexcal_fem::FemError) -> Self {
        ElasticError::Fem {
            context: context.into(),
            source,
        }
    }

    pub(crate) fn invalid(
        owner: impl Into<String>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        ElasticError::InvalidValue {
            owner: owner.into(),
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, ElasticError>;
