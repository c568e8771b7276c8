//! Resolving a `--robot NAME|FILE` argument, shared by every command that
//! takes a robot.

use anyhow::Context;
use flexcal_kinematics::{ImportOptions, Model, RobotDescription, builtin_robot_names};
use std::path::Path;

/// Loads a robot description: a built-in name (`ur10`, `ir663`, ...) or a
/// path to a robot file (description TOML, URDF with its single leaf as the
/// tip, SYMORO `.par`).
pub fn load_description(spec: &str) -> anyhow::Result<RobotDescription> {
    load_description_with(spec, &ImportOptions::default())
}

/// [`load_description`] with the options of a URDF (tip, root) or `.par`
/// file (values).
pub fn load_description_with(
    spec: &str,
    options: &ImportOptions,
) -> anyhow::Result<RobotDescription> {
    if builtin_robot_names().contains(&spec) {
        return Ok(RobotDescription::builtin(spec)?);
    }
    let path = Path::new(spec);
    if path.exists() {
        return RobotDescription::read(path, options)
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
