//! A `--robot NAME|FILE` argument, resolved by the library's one rule
//! ([`flexcal::RobotSpec`]).

use flexcal_kinematics::{Model, RobotDescription};

/// Loads a robot description: a built-in name (`ur10`, `ir663`, ...) or a
/// description file.
pub fn load_description(spec: &str) -> anyhow::Result<RobotDescription> {
    Ok(flexcal::load_description(spec)?)
}

/// Loads and builds a robot model (see [`load_description`]).
pub fn load_model(spec: &str) -> anyhow::Result<Model> {
    Ok(flexcal::load_robot(spec)?)
}
