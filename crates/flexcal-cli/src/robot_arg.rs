//! A `--robot NAME|FILE` argument, resolved by the library's one rule
//! ([`flexcal::RobotSpec`]), with the options of URDF and SYMORO files.

use std::path::PathBuf;

use flexcal::kinematics::{ImportOptions, Model};

/// How to read a robot file that is not flexcal's TOML (flattened into
/// every command that takes a robot).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct RobotFileArgs {
    /// URDF robot: the tip link (default: the single leaf below the root).
    #[arg(long)]
    pub tip: Option<String>,
    /// URDF robot: the root link (default: the root of the tree).
    #[arg(long)]
    pub root: Option<String>,
    /// SYMORO `.par` robot: TOML file of the symbols' values (SI units).
    #[arg(long)]
    pub values: Option<PathBuf>,
}

impl RobotFileArgs {
    /// The reader options these flags give.
    pub fn options(&self) -> ImportOptions {
        ImportOptions {
            tip: self.tip.clone(),
            root: self.root.clone(),
            values: self.values.clone(),
        }
    }
}

/// Loads and builds a robot model: a built-in name (`ur10`, `ir663`, ...)
/// or a robot file (`.toml`, `.urdf`, `.par`).
pub fn load_model(spec: &str, file: &RobotFileArgs) -> anyhow::Result<Model> {
    Ok(flexcal::load_robot_with(spec, &file.options())?)
}
