//! Python exceptions: one class per kind of library error, all under
//! `flexcal.FlexcalError`, carrying the library's one-line message.

use flexcal::calib::CalibError;
use flexcal::fem::FemError;
use flexcal::fuzzy::FuzzyError;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::{PyErr, create_exception};

create_exception!(
    flexcal,
    FlexcalError,
    PyException,
    "Base class of every error flexcal raises; the message is the library's one-line message."
);
create_exception!(
    flexcal,
    InputError,
    FlexcalError,
    "An argument is invalid before any computation (shape, value, option)."
);
create_exception!(
    flexcal,
    ShapeError,
    InputError,
    "An array has the wrong shape for the robot or the call."
);
create_exception!(
    flexcal,
    NotFiniteError,
    InputError,
    "An input value is NaN or infinite."
);
create_exception!(
    flexcal,
    UnknownRobotError,
    InputError,
    "A built-in robot was asked for by a name that does not exist."
);
create_exception!(
    flexcal,
    UnknownParameterError,
    InputError,
    "A parameter name (in fix, defer, ...) is not one of the model's unknowns."
);
create_exception!(
    flexcal,
    FileError,
    FlexcalError,
    "A file could not be read or written, or its content is malformed."
);
create_exception!(
    flexcal,
    KinematicsError,
    FlexcalError,
    "The robot description or one of its algorithms failed (invalid description, loop that cannot close, ...)."
);
create_exception!(
    flexcal,
    UnreachableError,
    KinematicsError,
    "The inverse model found no configuration within the joint limits that reaches the target."
);
create_exception!(
    flexcal,
    MeasurementError,
    FlexcalError,
    "A measurement set is invalid (file content, coordinates that do not match the robot)."
);
create_exception!(
    flexcal,
    CalibrationError,
    FlexcalError,
    "The identification failed (too few poses, degenerate registration, solver failure, ...)."
);
create_exception!(
    flexcal,
    RankDeficientError,
    CalibrationError,
    "The poses do not identify every free unknown and strict=True was asked for."
);
create_exception!(
    flexcal,
    FuzzyModelError,
    FlexcalError,
    "A fuzzy model could not be fitted or evaluated."
);
create_exception!(
    flexcal,
    StructureError,
    FlexcalError,
    "A frame finite-element structure is invalid or could not be solved."
);
create_exception!(
    flexcal,
    InternalError,
    FlexcalError,
    "A defect inside flexcal (a caught panic); please report it with the message."
);

/// Registers the exception classes on the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("FlexcalError", py.get_type::<FlexcalError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("ShapeError", py.get_type::<ShapeError>())?;
    m.add("NotFiniteError", py.get_type::<NotFiniteError>())?;
    m.add("UnknownRobotError", py.get_type::<UnknownRobotError>())?;
    m.add(
        "UnknownParameterError",
        py.get_type::<UnknownParameterError>(),
    )?;
    m.add("FileError", py.get_type::<FileError>())?;
    m.add("KinematicsError", py.get_type::<KinematicsError>())?;
    m.add("UnreachableError", py.get_type::<UnreachableError>())?;
    m.add("MeasurementError", py.get_type::<MeasurementError>())?;
    m.add("CalibrationError", py.get_type::<CalibrationError>())?;
    m.add("RankDeficientError", py.get_type::<RankDeficientError>())?;
    m.add("FuzzyModelError", py.get_type::<FuzzyModelError>())?;
    m.add("StructureError", py.get_type::<StructureError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    m.add("ArrayTypeError", array_type_error_class(py)?)?;
    Ok(())
}

/// `flexcal.ArrayTypeError`, an `InputError` and a `TypeError`: an array
/// argument holds strings or complex numbers where real numbers are
/// expected. Made with Python's `type` (an exception class of two bases).
fn array_type_error_class(py: Python<'_>) -> PyResult<&Bound<'_, pyo3::types::PyType>> {
    static CLASS: pyo3::sync::PyOnceLock<Py<pyo3::types::PyType>> = pyo3::sync::PyOnceLock::new();
    CLASS
        .get_or_try_init(py, || {
            let namespace = pyo3::types::PyDict::new(py);
            namespace.set_item("__module__", "flexcal")?;
            namespace.set_item(
                "__doc__",
                "An array argument holds strings or complex numbers where real numbers are expected.",
            )?;
            let bases = (
                py.get_type::<InputError>(),
                py.get_type::<pyo3::exceptions::PyTypeError>(),
            );
            Ok::<_, PyErr>(
                py.get_type::<pyo3::types::PyType>()
                    .call1(("ArrayTypeError", bases, namespace))?
                    .cast_into::<pyo3::types::PyType>()?
                    .unbind(),
            )
        })
        .map(|class| class.bind(py))
}

/// A `flexcal.ArrayTypeError` with `message`.
pub fn array_type_error(py: Python<'_>, message: String) -> PyErr {
    match array_type_error_class(py) {
        Ok(class) => PyErr::from_type(class.clone(), message),
        Err(e) => e,
    }
}

/// A failure of a computation that may run without the GIL (in a worker
/// thread): the library error itself, turned into a Python exception once
/// the GIL is held again.
#[derive(Debug)]
pub enum Failure {
    /// From flexcal-kinematics.
    Kinematics(KinError),
    /// From flexcal-calib.
    Calib(CalibError),
    /// From flexcal-fuzzy.
    Fuzzy(FuzzyError),
    /// From flexcal-fem.
    Fem(FemError),
    /// From the facade crate.
    Facade(Box<flexcal::Error>),
    /// From flexcal-kinematics at configuration (row) `.0` of a batch.
    KinematicsAt(usize, KinError),
    /// A panic caught at the boundary, with its message.
    Panic(String),
}

type KinError = flexcal::kinematics::KinematicsError;

impl From<KinError> for Failure {
    fn from(e: KinError) -> Self {
        Failure::Kinematics(e)
    }
}

impl From<flexcal::Error> for Failure {
    fn from(e: flexcal::Error) -> Self {
        Failure::Facade(Box::new(e))
    }
}

impl From<CalibError> for Failure {
    fn from(e: CalibError) -> Self {
        Failure::Calib(e)
    }
}

impl From<FuzzyError> for Failure {
    fn from(e: FuzzyError) -> Self {
        Failure::Fuzzy(e)
    }
}

impl From<FemError> for Failure {
    fn from(e: FemError) -> Self {
        Failure::Fem(e)
    }
}

/// The exception for a kinematics error.
pub fn kinematics_error(e: &KinError) -> PyErr {
    kinematics_error_with(e, e.to_string())
}

/// The exception class of a kinematics error with the message `message`.
pub fn kinematics_error_with(e: &KinError, message: String) -> PyErr {
    match e {
        KinError::UnknownRobot { .. } => UnknownRobotError::new_err(message),
        KinError::WrongLength { .. } => ShapeError::new_err(message),
        KinError::NotFinite { .. } => NotFiniteError::new_err(message),
        KinError::File { .. }
        | KinError::Toml { .. }
        | KinError::Urdf { .. }
        | KinError::Symoro { .. } => FileError::new_err(message),
        KinError::Unreachable { .. } => UnreachableError::new_err(message),
        _ => KinematicsError::new_err(message),
    }
}

/// The exception for a calibration error.
pub fn calib_error(e: &CalibError) -> PyErr {
    let message = e.to_string();
    match e {
        CalibError::Io(_) | CalibError::BadMassTable { .. } => FileError::new_err(message),
        CalibError::BadMeasurement { .. } | CalibError::ActuatedCountMismatch { .. } => {
            MeasurementError::new_err(message)
        }
        CalibError::UnknownParameter { .. } => UnknownParameterError::new_err(message),
        CalibError::RankDeficient { .. } => RankDeficientError::new_err(message),
        CalibError::Kinematics { .. } | CalibError::Description(_) => {
            KinematicsError::new_err(message)
        }
        CalibError::InvalidOption { .. } => InputError::new_err(message),
        CalibError::Serialise { .. } => InternalError::new_err(message),
        _ => CalibrationError::new_err(message),
    }
}

impl From<Failure> for PyErr {
    fn from(f: Failure) -> Self {
        match f {
            Failure::Kinematics(e) => kinematics_error(&e),
            Failure::KinematicsAt(row, e) => {
                kinematics_error_with(&e, format!("configuration {row}: {e}"))
            }
            Failure::Calib(e) => calib_error(&e),
            Failure::Facade(e) => facade_error(&e),
            Failure::Fuzzy(e) => FuzzyModelError::new_err(e.to_string()),
            Failure::Fem(e) => StructureError::new_err(e.to_string()),
            Failure::Panic(message) => {
                InternalError::new_err(format!("internal error (panic caught): {message}"))
            }
        }
    }
}

/// The exception for an error of the facade crate.
pub fn facade_error(e: &flexcal::Error) -> PyErr {
    let message = e.to_string();
    match e {
        flexcal::Error::UnknownRobot { .. } => UnknownRobotError::new_err(message),
        flexcal::Error::RobotFormat { .. }
        | flexcal::Error::Io(_)
        | flexcal::Error::Json { .. }
        | flexcal::Error::Campaign { .. } => FileError::new_err(message),
        flexcal::Error::RobotBuild { source, .. } => kinematics_error_with(source, message),
        flexcal::Error::InvalidParameter { .. } => InputError::new_err(message),
        flexcal::Error::Kinematics(e) => kinematics_error(e),
        flexcal::Error::Calib(e) => calib_error(e),
        _ => FlexcalError::new_err(message),
    }
}

/// The message of a caught panic payload.
pub fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}
