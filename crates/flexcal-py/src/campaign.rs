//! `flexcal.Campaign`: a campaign file (everything `flexcal calibrate`
//! takes, `docs/file-formats.md`) read and run from Python, with the
//! result `flexcal.calibrate` returns.

use std::path::PathBuf;
use std::sync::Arc;

use flexcal::calib::CancelToken;
use flexcal::campaign::{Campaign as Inner, CampaignRun};
use pyo3::prelude::*;

use crate::errors::{Failure, facade_error};
use crate::interrupt::run_cancellable;
use crate::result::CalibrationResult;
use crate::robot::Robot;

/// A calibration campaign: the robot, measurement files, model, checks and
/// outputs of one `flexcal calibrate` run, read from a campaign file
/// (`Campaign.read`) or from the `config` section of a JSON report
/// (`Campaign.from_report`).
#[pyclass(frozen, module = "flexcal", name = "Campaign")]
#[derive(Debug, Clone)]
pub struct Campaign {
    inner: Arc<Inner>,
}

#[pymethods]
impl Campaign {
    /// Reads a campaign file (TOML): paths relative to its folder, every
    /// input file checked to exist. Raises `FileError` naming the file and
    /// the key (unknown key, wrong type, missing file).
    #[staticmethod]
    fn read(path: PathBuf) -> PyResult<Self> {
        Inner::read(&path)
            .map(|inner| Self {
                inner: Arc::new(inner),
            })
            .map_err(|e| facade_error(&e))
    }

    /// Reads the campaign a JSON report (`flexcal calibrate --report`)
    /// carries in its `config` section, paths relative to the report.
    #[staticmethod]
    fn from_report(path: PathBuf) -> PyResult<Self> {
        Inner::from_report(&path)
            .map(|inner| Self {
                inner: Arc::new(inner),
            })
            .map_err(|e| facade_error(&e))
    }

    /// The campaign as campaign-file TOML, paths relative to `folder`
    /// (default: the working directory).
    #[pyo3(signature = (folder = None))]
    fn to_toml(&self, folder: Option<PathBuf>) -> String {
        self.inner
            .to_toml_string(&folder.unwrap_or_else(|| PathBuf::from(".")))
    }

    /// Writes the campaign file `path` (atomically), paths relative to its
    /// folder.
    fn write(&self, path: PathBuf) -> PyResult<()> {
        self.inner.write(&path).map_err(|e| facade_error(&e))
    }

    /// The measurement files of the campaign (one per station), as paths
    /// the program opens.
    #[getter]
    fn data(&self) -> Vec<PathBuf> {
        self.inner.data.files.clone()
    }

    /// Runs the campaign as `flexcal calibrate --config` does and returns
    /// the result `flexcal.calibrate` returns (for one target per pose or,
    /// with `[data] targets`, several); with `write_outputs` (the default)
    /// the files of its `[outputs]` table are written too (the report and
    /// page with the campaign in them). Ctrl-C stops it within one solver
    /// iteration.
    #[pyo3(signature = (write_outputs = true))]
    fn run(&self, py: Python<'_>, write_outputs: bool) -> PyResult<CalibrationResult> {
        let campaign = Arc::clone(&self.inner);
        let cancel = CancelToken::new();
        let token = cancel.clone();
        let (result, robot, calibrated) = run_cancellable(py, Some(cancel), move || {
            let run = campaign.run_cancellable(Some(token))?;
            if write_outputs {
                run.write_outputs()?;
            }
            let CampaignRun { robot, result, .. } = run;
            let calibrated = result
                .calibration
                .description(&robot)?
                .build()
                .map_err(Failure::Kinematics)?;
            Ok((result, robot, calibrated))
        })?;
        let (robot, calibrated) = (Arc::new(robot), Robot::new(calibrated));
        Ok(CalibrationResult::from_run(result, robot, calibrated))
    }

    fn __repr__(&self) -> String {
        let c = &self.inner;
        let robot = c
            .robot_spec()
            .map_or_else(|_| "?".to_string(), |spec| spec.to_string());
        format!(
            "Campaign(robot={robot:?}, data={:?}, source={:?})",
            c.data.files, c.source
        )
    }
}
