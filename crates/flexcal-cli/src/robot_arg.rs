//! Resolving a `--robot NAME|FILE` argument, shared by every command that
//! takes a robot.

use anyhow::Context;
use flexcal_kinematics::{Model, RobotDescription, builtin_robot_names};
use std::path::Path;

/// Loads a robot description: a built-in name (`ur10`, `ir663`, ...) or a
/// path to a description TOML file.
pub fn load_description(spec: &str) -> anyhow::Result<RobotDescription> {
    if builtin_robot_names().contains(&spec) {
        return Ok(RobotDescription::builtin(spec)?);
    }
    let path = Path::new(spec);
    if path.exists() {
        return RobotDescription::from_toml_file(path)
            .with_context(|| format!("reading robot description {}", path.display()));
    }
    anyhow::bail!(
        "unknown robot '{spec}': not a built-in robot ({}) and no such file",
        builtin_robot_names().join(", ")
    )
}

/// Loads and builds a robot model (see [`load_description`]).
pub fn load_model(spec: &str) -> anyhow::Result<Model> {
    let description = load_description(spec)?;
    description
        .build()
        .with_context(|| format!("building robot '{spec}'"))
}
