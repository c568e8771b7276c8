//! # flexcal-py
//!
//! The Python package `flexcal`: flexcal's robots, measurement sets,
//! calibration, fuzzy models and frame structures on NumPy arrays, built
//! with maturin (`pip install ./crates/flexcal-py`). It stands on the
//! facade crate `flexcal` only. User documentation: `docs/python.md`;
//! type stubs with units: `python/flexcal/_flexcal.pyi`.
//!
//! ## Boundary rules
//! - SI units in every array (m, rad); mm and deg only in the JSON report
//!   and files, as in the library.
//! - Shapes, NaN and option values are checked before any library call;
//!   every library error becomes an exception under `flexcal.FlexcalError`
//!   with the library's one-line message ([`errors`]); panics are caught
//!   and raised as `flexcal.InternalError`.
//! - Long calls release the GIL and return on Ctrl-C ([`interrupt`]).
//!
//! ## Limitations
//! - On Ctrl-C every long call returns at once. An identification
//!   (`calibrate`) then stops within one solver iteration (the library's
//!   cancellation token); a validation, fuzzy fit or structure solve has no
//!   such hook and finishes in the background. Batched forward models and
//!   Jacobians stop between batches.

mod accuracy;
mod arrays;
mod calibrate;
mod calibration;
mod campaign;
mod checks;
mod compensation;
pub mod errors;
mod fem;
mod fuzzy;
pub mod interrupt;
mod measurement;
mod plan;
mod result;
mod robot;
mod targets;

use pyo3::prelude::*;

/// The extension module `flexcal._flexcal`, re-exported by the package
/// `flexcal`.
#[pymodule]
fn _flexcal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<robot::Robot>()?;
    m.add_class::<robot::Parameter>()?;
    m.add_class::<measurement::MeasurementSet>()?;
    m.add_class::<result::CalibrationResult>()?;
    m.add_class::<calibration::ValidationResult>()?;
    m.add_class::<calibration::ErrorStatistics>()?;
    m.add_class::<calibration::UnknownEstimate>()?;
    m.add_class::<calibration::SelectionResult>()?;
    m.add_class::<calibration::SelectionCandidate>()?;
    m.add_class::<accuracy::AccuracyResult>()?;
    m.add_class::<checks::SplitCheckResult>()?;
    m.add_class::<checks::CrossCheckResult>()?;
    m.add_class::<fuzzy::FuzzyModel>()?;
    m.add_class::<fem::Structure>()?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate, m)?)?;
    m.add_class::<campaign::Campaign>()?;
    m.add_class::<compensation::CommandedPath>()?;
    m.add_function(wrap_pyfunction!(compensation::compensate_path, m)?)?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
