//! The facade's error type: every library error, plus the few the facade's
//! own workflows raise, each naming the file, robot or parameter at fault.

use std::path::PathBuf;

/// Everything that can go wrong in a facade call.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A robot argument that is neither a built-in robot nor an existing file.
    #[error("unknown robot '{spec}': not a built-in robot ({known}) and no such file")]
    UnknownRobot {
        /// The argument as given.
        spec: String,
        /// The built-in robot names, comma-separated.
        known: String,
    },
    /// A robot description file whose extension names no format flexcal reads.
    #[error("{}: robot description format '.{extension}' is not supported (supported: {known})", path.display())]
    RobotFormat {
        /// The file.
        path: PathBuf,
        /// Its extension.
        extension: String,
        /// The supported extensions, comma-separated.
        known: String,
    },
    /// A robot description that does not build into a valid model.
    #[error("building robot '{robot}': {source}")]
    RobotBuild {
        /// The robot argument.
        robot: String,
        /// Why the model is invalid.
        source: flexcal_kinematics::KinematicsError,
    },
    /// A parameter of a workflow is out of its allowed range.
    #[error("{parameter}: {message}")]
    InvalidParameter {
        /// The parameter, as the user spells it.
        parameter: String,
        /// What is wrong with it.
        message: String,
    },
    /// A value read from a file that cannot be used (the file's own format
    /// is respected, the value is not).
    #[error("{origin}: {message}")]
    InvalidData {
        /// Where the value is: `file:line`.
        origin: String,
        /// What is wrong with it.
        message: String,
    },
    /// A kinematic computation that failed for one row of input.
    #[error("{origin}: {source}")]
    KinematicsAt {
        /// Where the row came from: `file:line`, or the option that gave it.
        origin: String,
        /// Why it failed (an unreachable pose, a loop that cannot close).
        source: flexcal_kinematics::KinematicsError,
    },
    /// A fuzzy model's learning or evaluation.
    #[error(transparent)]
    Fuzzy(#[from] flexcal_fuzzy::FuzzyError),
    /// A dataset file a fuzzy model cannot take.
    #[error("{}: {source}", path.display())]
    FuzzyData {
        /// The dataset file.
        path: PathBuf,
        /// What is wrong.
        source: flexcal_fuzzy::FuzzyError,
    },
    /// Points of a path that could not be compensated, each named by its line.
    #[error("{failed} of {total} path points could not be compensated: {}", failures.join("; "))]
    PathPoints {
        /// Number of failed points.
        failed: usize,
        /// Number of points of the path.
        total: usize,
        /// One message per failed point (file, line, reason).
        failures: Vec<String>,
    },
    /// A step of the calibration workflow that failed, with its cause.
    #[error("{step}: {source}")]
    CalibrationStep {
        /// The step (`identification`, `validation`, `--exclude`, ...).
        step: &'static str,
        /// Why it failed.
        source: flexcal_calib::CalibError,
    },
    /// Kinematics (robot descriptions, forward and inverse models).
    #[error(transparent)]
    Kinematics(#[from] flexcal_kinematics::KinematicsError),
    /// Measurement sets and geometric calibration.
    #[error(transparent)]
    Calib(#[from] flexcal_calib::CalibError),
    /// Elastic models and their identification.
    #[error(transparent)]
    Elastic(#[from] flexcal_elastic::ElasticError),
    /// Identification workflows on a campaign directory.
    #[error(transparent)]
    Workflow(#[from] flexcal_elastic::workflow::WorkflowError),
    /// Fuzzy compliance models.
    #[error(transparent)]
    FuzzyCompliance(#[from] flexcal_elastic::fuzzy_compliance::FuzzyComplianceError),
    /// Compensation of tool paths.
    #[error(transparent)]
    Compensation(#[from] flexcal_compensate::compensation::CompensationError),
    /// Tool path files.
    #[error(transparent)]
    Path(#[from] flexcal_compensate::path::PathError),
    /// A commanded path could not be exported (RAPID, joint trajectory).
    #[error(transparent)]
    PathExport(#[from] flexcal_compensate::export::PathExportError),
    /// Process models.
    #[error(transparent)]
    Process(#[from] flexcal_compensate::process::ProcessError),
    /// The virtual robot's geometric campaign.
    #[error(transparent)]
    GeometricTwin(#[from] flexcal_twin::geometric::GeometricTwinError),
    /// The virtual robot's elastic campaign.
    #[error(transparent)]
    ElasticTwin(#[from] flexcal_twin::elastic::ElasticTwinError),
    /// The virtual forming experiment.
    #[error(transparent)]
    Forming(#[from] flexcal_twin::forming::FormingError),
    /// The virtual robot's truth.
    #[error(transparent)]
    Truth(#[from] flexcal_twin::truth::TruthError),
    /// Reading or writing files.
    #[error(transparent)]
    Io(#[from] flexcal_io::IoError),
    /// A campaign file (or a report's embedded campaign) that cannot be
    /// used: an unknown key, a value of the wrong type, an input file that
    /// does not exist, a setting out of its range.
    #[error("{origin}: {key}: {message}")]
    Campaign {
        /// The file, with `:line` when the parser knows it.
        origin: String,
        /// The key (`model.method`, `data.files[1]`).
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A JSON file that does not parse or a value that does not serialise.
    #[error("{context}: {source}")]
    Json {
        /// The file or value.
        context: String,
        /// The parser's message.
        source: serde_json::Error,
    },
}

impl Error {
    /// Whether the error rejects an argument before any work is done (a
    /// parameter out of its range, an unknown robot, a robot file format
    /// flexcal does not read): a usage error, which a command line reports
    /// with its own exit code.
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            Self::InvalidParameter { .. }
                | Self::UnknownRobot { .. }
                | Self::RobotFormat { .. }
                | Self::Campaign { .. }
        )
    }
}

/// The facade's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// An error and its causes on one line, as `flexcal` prints them: the first
/// message, then each cause that the line does not already end with (an
/// error naming a file often repeats its source's message), joined by `: `.
/// `causes` runs from the outermost context to the root cause, as
/// `anyhow::Error::chain` or repeated [`std::error::Error::source`] give it.
pub fn cause_chain_line<T: std::fmt::Display>(causes: impl IntoIterator<Item = T>) -> String {
    let mut line = String::new();
    for cause in causes.into_iter().map(|c| c.to_string()) {
        if line.is_empty() {
            line = cause;
        } else if !line.ends_with(&cause) {
            line = format!("{line}: {cause}");
        }
    }
    line
}

#[cfg(test)]
mod tests {
    use super::cause_chain_line;

    #[test]
    fn causes_already_spelled_out_are_not_repeated() {
        assert_eq!(
            cause_chain_line(["reading a.csv", "line 3: not a number", "not a number"]),
            "reading a.csv: line 3: not a number"
        );
        assert_eq!(cause_chain_line(["one", "two"]), "one: two");
        assert_eq!(cause_chain_line(Vec::<String>::new()), "");
    }
}
