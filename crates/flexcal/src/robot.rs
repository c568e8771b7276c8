//! One rule for naming a robot: a built-in name or a description file.
//!
//! Every command and every library caller that takes a robot argument goes
//! through [`RobotSpec`]: a string that is the name of a built-in robot
//! ([`builtin_robot_names`]) is that robot; any other string is a path to a
//! description file, read by the reader its extension selects
//! ([`RobotFileFormat::from_path`], the one place where file formats are
//! dispatched): flexcal's TOML, URDF (with a tip and root link) or SYMORO
//! `.par` (with a values file), the last two through [`ImportOptions`]. A
//! file that happens to carry a built-in name must be given with a
//! directory (`./ur10`).

use std::fmt;
use std::path::{Path, PathBuf};

use flexcal_calib::GravityCompliance;
use flexcal_kinematics::{
    ExportFormat, ImportOptions, ImportedRobot, Model, RobotDescription, RobotExport,
    builtin_robot_names,
};

use crate::Error;

pub mod text;

/// A robot argument, resolved: a built-in robot or a description file.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum RobotSpec {
    /// A built-in robot by name (`ur10`, `ir663`, ...).
    Builtin(String),
    /// A robot description file, read according to its extension.
    File(PathBuf),
}

/// The description file formats flexcal reads, chosen by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum RobotFileFormat {
    /// flexcal's own TOML description (`.toml`, or a file without extension).
    Toml,
    /// URDF (`.urdf`; a `.xacro` file is refused with the advice to expand it).
    Urdf,
    /// SYMORO / OpenSYMORO geometric parameters (`.par`).
    Par,
}

impl RobotFileFormat {
    /// The extensions flexcal reads, for messages.
    pub const EXTENSIONS: &'static [&'static str] = &["toml", "urdf", "par"];

    /// The format of `path`, from its extension (case-insensitive).
    ///
    /// This is the single place where robot file formats are dispatched: a
    /// new reader adds a variant, its extension here, and an arm in
    /// [`RobotFileFormat::read`].
    pub fn from_path(path: &Path) -> Result<Self, Error> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            None | Some("toml") => Ok(Self::Toml),
            Some("urdf") | Some("xacro") => Ok(Self::Urdf),
            Some("par") => Ok(Self::Par),
            Some(other) => Err(Error::RobotFormat {
                path: path.to_path_buf(),
                extension: other.to_string(),
                known: Self::EXTENSIONS.join(", "),
            }),
        }
    }

    /// Reads a robot from `path` in this format; `options` choose a URDF's
    /// tip and root and give a `.par` file's symbol values. A TOML file
    /// takes a tip too ([`with_tip`]: a frame or link by name) and refuses
    /// a root by name.
    pub fn read(self, path: &Path, options: &ImportOptions) -> Result<ImportedRobot, Error> {
        Ok(match self {
            Self::Toml => with_tip(RobotDescription::from_toml_file(path)?, options)?,
            Self::Urdf => ImportedRobot::read_urdf(path, options)?,
            Self::Par => ImportedRobot::read_par(path, options)?,
        })
    }
}

/// A description that is not a URDF, with the import options applied: the
/// tip moved to the frame or link `options.tip` names
/// ([`RobotDescription::with_tip`], an unknown name refused by name), a
/// root refused (only a URDF tree can be re-rooted).
pub fn with_tip(
    description: RobotDescription,
    options: &ImportOptions,
) -> Result<ImportedRobot, Error> {
    if let Some(root) = &options.root {
        return Err(flexcal_kinematics::KinematicsError::Invalid {
            what: format!(
                "robot `{}`: a root (`{root}`) can only be chosen in a URDF file",
                description.name
            ),
        }
        .into());
    }
    let mut notes = Vec::new();
    let description = match &options.tip {
        Some(tip) => {
            notes.push(format!("tip moved to `{tip}`"));
            description.with_tip(tip)?
        }
        None => description,
    };
    Ok(ImportedRobot {
        description,
        masses: Vec::new(),
        notes,
    })
}

impl RobotSpec {
    /// Resolves a robot argument: a built-in name is that robot, anything
    /// else a file path (which must exist).
    pub fn parse(spec: &str) -> Result<Self, Error> {
        let spec = spec.trim();
        if builtin_robot_names().contains(&spec) {
            return Ok(Self::Builtin(spec.to_string()));
        }
        let path = Path::new(spec);
        if path.is_file() {
            return Ok(Self::File(path.to_path_buf()));
        }
        Err(Error::UnknownRobot {
            spec: spec.to_string(),
            known: builtin_robot_names().join(", "),
        })
    }

    /// Reads the robot's description (a URDF's single leaf as its tip).
    pub fn description(&self) -> Result<RobotDescription, Error> {
        self.description_with(&ImportOptions::default())
    }

    /// Reads the robot's description with the options of a URDF or `.par` file.
    pub fn description_with(&self, options: &ImportOptions) -> Result<RobotDescription, Error> {
        Ok(self.import(options)?.description)
    }

    /// Reads the robot with what its file holds besides the description
    /// (a URDF's link masses) and notes on the conversion.
    pub fn import(&self, options: &ImportOptions) -> Result<ImportedRobot, Error> {
        match self {
            Self::Builtin(name) => with_tip(RobotDescription::builtin(name)?, options),
            Self::File(path) => RobotFileFormat::from_path(path)?.read(path, options),
        }
    }

    /// The link masses of the elasto-geometric model of this robot (built
    /// as `model`): the mass table file `file` when given, else the masses
    /// the robot's file holds (a URDF's `<inertial>` elements,
    /// [`GravityCompliance::from_link_masses`]), else the built-in table of
    /// a built-in robot ([`GravityCompliance::builtin`]).
    pub fn mass_table(
        &self,
        options: &ImportOptions,
        model: &Model,
        file: Option<&Path>,
    ) -> Result<GravityCompliance, Error> {
        if let Some(path) = file {
            return Ok(GravityCompliance::from_toml_file(path)?);
        }
        let imported = self.import(options)?;
        Ok(if imported.masses.is_empty() {
            GravityCompliance::builtin(model)?
        } else {
            GravityCompliance::from_link_masses(model, &imported.masses)?
        })
    }

    /// Reads and builds the robot's model (validated once, then frozen).
    pub fn model(&self) -> Result<Model, Error> {
        self.model_with(&ImportOptions::default())
    }

    /// [`RobotSpec::model`] with the options of a URDF or `.par` file.
    pub fn model_with(&self, options: &ImportOptions) -> Result<Model, Error> {
        let description = self.description_with(options)?;
        description.build().map_err(|source| Error::RobotBuild {
            robot: self.to_string(),
            source,
        })
    }
}

impl fmt::Display for RobotSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Builtin(name) => write!(f, "{name}"),
            Self::File(path) => write!(f, "{}", path.display()),
        }
    }
}

impl std::str::FromStr for RobotSpec {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        Self::parse(s)
    }
}

/// Reads a robot description named by a robot argument (see [`RobotSpec`]).
pub fn load_description(spec: &str) -> Result<RobotDescription, Error> {
    RobotSpec::parse(spec)?.description()
}

/// Reads and builds the robot model named by a robot argument (see
/// [`RobotSpec`]).
pub fn load_robot(spec: &str) -> Result<Model, Error> {
    RobotSpec::parse(spec)?.model()
}

/// [`load_robot`] with the options of a URDF or `.par` file.
pub fn load_robot_with(spec: &str, options: &ImportOptions) -> Result<Model, Error> {
    RobotSpec::parse(spec)?.model_with(options)
}

/// The modified-DH table format for an output file: Markdown for a `.md`
/// file or for standard output (`None`), CSV for any other file.
pub fn mdh_format_for(out: Option<&Path>) -> ExportFormat {
    match out.and_then(Path::extension) {
        Some(e) if e != "md" => ExportFormat::MdhCsv,
        _ => ExportFormat::MdhMarkdown,
    }
}

/// Writes `export`, of the robot named `robot`, to the file `out`
/// (atomically) and returns what `flexcal robot export` prints about it, one
/// line each: the file written, the largest TCP displacement of the export
/// read back (mm) when it was checked, and what the format does not hold.
///
/// # Errors
/// The file that could not be written.
pub fn write_export(robot: &str, export: &RobotExport, out: &Path) -> Result<Vec<String>, Error> {
    flexcal_io::write_atomic(out, &export.text)?;
    let mut lines = vec![format!("{robot} written to {}", out.display())];
    if let Some(d) = export.max_deviation_m {
        lines.push(format!(
            "read back: largest TCP displacement {:.3e} mm",
            d * 1e3
        ));
    }
    lines.extend(export.dropped.iter().map(|d| format!("not exported: {d}")));
    Ok(lines)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_export_written_to_a_file_says_where_and_what_it_lost() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("robot.urdf");
        let export = RobotExport {
            format: ExportFormat::Urdf,
            text: "<robot/>".into(),
            dropped: vec!["the tool's mass".into()],
            max_deviation_m: Some(2e-9),
        };
        let lines = write_export("ur10", &export, &path).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "<robot/>");
        assert_eq!(
            lines,
            [
                format!("ur10 written to {}", path.display()),
                "read back: largest TCP displacement 2.000e-6 mm".to_string(),
                "not exported: the tool's mass".to_string(),
            ]
        );
    }

    #[test]
    fn an_mdh_table_is_markdown_unless_the_file_says_otherwise() {
        assert_eq!(mdh_format_for(None), ExportFormat::MdhMarkdown);
        assert_eq!(
            mdh_format_for(Some(Path::new("t.md"))),
            ExportFormat::MdhMarkdown
        );
        assert_eq!(
            mdh_format_for(Some(Path::new("t.csv"))),
            ExportFormat::MdhCsv
        );
    }

    #[test]
    fn builtin_names_resolve_to_builtin_robots() {
        for name in builtin_robot_names() {
            assert_eq!(
                RobotSpec::parse(name).unwrap(),
                RobotSpec::Builtin(name.to_string())
            );
            assert_eq!(load_robot(name).unwrap().name(), *name);
        }
    }

    #[test]
    fn a_file_is_read_by_its_extension_and_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("robot.toml");
        let ur10 = RobotDescription::builtin("ur10").unwrap();
        std::fs::write(&path, ur10.to_toml_string()).unwrap();
        let spec = RobotSpec::parse(path.to_str().unwrap()).unwrap();
        assert_eq!(spec, RobotSpec::File(path.clone()));
        let model = spec.model().unwrap();
        assert_eq!(model.n_params(), ur10.build().unwrap().n_params());
    }

    #[test]
    fn unknown_names_and_extensions_are_errors_that_say_what_is_known() {
        let err = RobotSpec::parse("no-such-robot").unwrap_err().to_string();
        assert!(
            err.contains("no-such-robot") && err.contains("ur10"),
            "{err}"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("robot.xyz");
        std::fs::write(&path, "x").unwrap();
        let err = load_robot(path.to_str().unwrap()).unwrap_err().to_string();
        assert!(err.contains("robot.xyz") && err.contains("toml"), "{err}");
    }

    #[test]
    fn a_urdf_file_is_read_with_its_tip() {
        let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../flexcal-kinematics/tests/data/urdf/edge_cases.urdf");
        let spec = RobotSpec::parse(path.to_str().unwrap()).unwrap();
        // Two leaves: the tip must be chosen.
        assert!(spec.model().is_err());
        let options = ImportOptions {
            tip: Some("tip".into()),
            ..ImportOptions::default()
        };
        let imported = spec.import(&options).unwrap();
        assert!(!imported.masses.is_empty());
        assert_eq!(spec.model_with(&options).unwrap().n_actuated(), 6);
    }
}
