//! `flexcal robot`: list the built-in robots, show a robot's parameters,
//! export a (calibrated) robot to URDF, a modified-DH table or TOML.

use std::path::PathBuf;

use crate::robot_arg::RobotFileArgs;
use anyhow::Context;
use flexcal::kinematics::{ExportFormat, ExportOptions, export_robot};

/// Formats of `flexcal robot export`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormatArg {
    /// URDF (joint origins carry the geometry).
    Urdf,
    /// Modified-DH table: Markdown on standard output or to a `.md` file, CSV otherwise.
    Mdh,
    /// flexcal's robot description TOML.
    Toml,
    /// UR-style kinematics YAML (per joint x y z roll pitch yaw; six-joint arms).
    UrYaml,
}

/// Subcommands of `flexcal robot`.
#[derive(clap::Subcommand, Debug)]
pub enum RobotCommand {
    /// List the built-in robots.
    List,
    /// Show a robot: actuated coordinates, parameter vector xi with units.
    Show {
        /// A built-in robot name or a robot file (`.toml`, `.urdf`, `.par`).
        robot: String,
        /// Print the robot description as TOML instead (write it to a file to start your own).
        #[arg(long)]
        toml: bool,
        #[command(flatten)]
        import: RobotFileArgs,
    },
    /// Export a robot (a calibrated robot file, or any robot) for controllers, ROS and simulators.
    Export {
        /// A built-in robot name or a robot file (`.toml`, `.urdf`, `.par`).
        robot: String,
        /// Target format.
        #[arg(long, value_enum)]
        format: ExportFormatArg,
        /// Output file (default: standard output).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Largest TCP displacement the export may cause when read back (mm).
        #[arg(long, default_value_t = 1e-6)]
        tolerance_mm: f64,
        #[command(flatten)]
        import: RobotFileArgs,
    },
}

/// Runs `flexcal robot ...`.
pub fn run(command: RobotCommand) -> anyhow::Result<()> {
    match command {
        RobotCommand::List => print!("{}", flexcal::robot::text::builtin_robots_text()?),
        RobotCommand::Show {
            robot,
            toml,
            import,
        } => {
            let imported = flexcal::RobotSpec::parse(&robot)?
                .import(&import.options())
                .with_context(|| format!("reading robot {robot}"))?;
            if toml {
                print!("{}", imported.description.to_toml_string());
            } else {
                print!("{}", flexcal::robot::text::robot_text(&imported)?);
            }
        }
        RobotCommand::Export {
            robot,
            format,
            out,
            tolerance_mm,
            import,
        } => export(&robot, format, out, tolerance_mm, &import)?,
    }
    Ok(())
}

fn export(
    robot: &str,
    format: ExportFormatArg,
    out: Option<PathBuf>,
    tolerance_mm: f64,
    import: &RobotFileArgs,
) -> anyhow::Result<()> {
    let model = crate::robot_arg::load_model(robot, import)?;
    let format = match format {
        ExportFormatArg::Urdf => ExportFormat::Urdf,
        ExportFormatArg::Toml => ExportFormat::Toml,
        ExportFormatArg::UrYaml => ExportFormat::UrKinematicsYaml,
        ExportFormatArg::Mdh => flexcal::robot::mdh_format_for(out.as_deref()),
    };
    let options = ExportOptions {
        tolerance_m: tolerance_mm / 1e3,
        ..ExportOptions::default()
    };
    let export = export_robot(&model, model.nominal_params(), format, &options)?;
    match &out {
        Some(path) => flexcal::robot::write_export(model.name(), &export, path)?
            .iter()
            .for_each(|line| println!("{line}")),
        None => {
            print!("{}", export.text);
            export
                .dropped
                .iter()
                .for_each(|d| eprintln!("not exported: {d}"));
        }
    }
    Ok(())
}
