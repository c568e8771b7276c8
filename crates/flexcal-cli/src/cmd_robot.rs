//! `flexcal robot`: list the built-in robots, show a robot's parameters.

use crate::robot_arg::load_description;
use flexcal::kinematics::{ActuatedKind, ParamKind, builtin_robot_names};

/// Subcommands of `flexcal robot`.
#[derive(clap::Subcommand, Debug)]
pub enum RobotCommand {
    /// List the built-in robots.
    List,
    /// Show a robot: actuated coordinates, parameter vector xi with units.
    Show {
        /// A built-in robot name or a robot description TOML file.
        robot: String,
        /// Print the robot description as TOML instead (write it to a file to start your own).
        #[arg(long)]
        toml: bool,
    },
}

/// Runs `flexcal robot ...`.
pub fn run(command: RobotCommand) -> anyhow::Result<()> {
    match command {
        RobotCommand::List => {
            for name in builtin_robot_names() {
                let description = flexcal::kinematics::RobotDescription::builtin(name)?;
                let model = description.build()?;
                println!(
                    "{name:<10} {} actuated, {} parameters{}",
                    model.n_actuated(),
                    model.n_params(),
                    if model.is_serial() {
                        ", serial"
                    } else {
                        ", closed loops"
                    }
                );
            }
            Ok(())
        }
        RobotCommand::Show { robot, toml } => {
            let description = load_description(&robot)?;
            if toml {
                print!("{}", description.to_toml_string());
                return Ok(());
            }
            let model = description.build()?;
            println!("robot {}", model.name());
            if !description.notes.is_empty() {
                println!("{}", description.notes.trim());
            }
            println!("\nactuated coordinates (q, in this order):");
            for ((name, kind), (lo, hi)) in model
                .actuated_names()
                .iter()
                .zip(model.actuated_kinds())
                .zip(model.actuated_limits())
            {
                let (unit, scale) = match kind {
                    ActuatedKind::Revolute => ("deg", 180.0 / std::f64::consts::PI),
                    ActuatedKind::Prismatic | ActuatedKind::Screw => ("mm", 1e3),
                };
                println!(
                    "  {name:<10} {:<10} limits [{:.3}, {:.3}] {unit}",
                    format!("{kind:?}").to_lowercase(),
                    lo * scale,
                    hi * scale
                );
            }
            if !model.passive_names().is_empty() {
                println!("passive joints: {}", model.passive_names().join(", "));
            }
            println!("\nparameter vector xi ({} parameters):", model.n_params());
            println!(
                "  {:>3}  {:<10} {:<6} {:>14}  unit",
                "#", "name", "frame", "nominal"
            );
            for (i, (p, v)) in model
                .params()
                .iter()
                .zip(model.nominal_params())
                .enumerate()
            {
                let (value, unit) = match p.kind {
                    ParamKind::Length => (v * 1e3, "mm"),
                    ParamKind::Angle => (v.to_degrees(), "deg"),
                };
                println!(
                    "  {:>3}  {:<10} {:<6} {:>14.6}  {unit}",
                    i + 1,
                    p.name,
                    p.frame,
                    value
                );
            }
            Ok(())
        }
    }
}
