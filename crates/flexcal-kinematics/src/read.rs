//! Reading any robot file by its extension: the one place where robot file
//! formats are dispatched.

use std::path::Path;

use crate::KinematicsError;
use crate::description::RobotDescription;
use crate::import::{ImportOptions, ImportedRobot};

impl RobotDescription {
    /// Reads a robot file by its extension: `.toml` (flexcal's
    /// description), `.urdf` (with `options.tip` and `options.root`) or
    /// `.par` (SYMORO, with `options.values`).
    pub fn read(path: &Path, options: &ImportOptions) -> Result<Self, KinematicsError> {
        Ok(ImportedRobot::read(path, options)?.description)
    }
}

impl ImportedRobot {
    /// Reads a robot file by its extension (see [`RobotDescription::read`]).
    pub fn read(path: &Path, options: &ImportOptions) -> Result<Self, KinematicsError> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        match extension.as_str() {
            "urdf" => ImportedRobot::read_urdf(path, options),
            "par" => ImportedRobot::read_par(path, options),
            "xacro" => Err(KinematicsError::Urdf {
                source_name: path.display().to_string(),
                line: 0,
                message: "a xacro file: expand it first (`xacro FILE.urdf.xacro > FILE.urdf`)"
                    .into(),
            }),
            _ => Ok(ImportedRobot {
                description: RobotDescription::from_toml_file(path)?,
                masses: Vec::new(),
                notes: Vec::new(),
            }),
        }
    }
}
