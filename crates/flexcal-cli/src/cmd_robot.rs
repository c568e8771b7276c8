//! `flexcal robot`: list the built-in robots, show a robot's parameters,
//! export a (calibrated) robot to URDF, a modified-DH table or TOML.

use std::path::PathBuf;

use crate::robot_arg::{RobotFileArgs, load_description_with};
use anyhow::Context;
use flexcal::kinematics::{
    ActuatedKind, ExportFormat, ExportOptions, ParamKind, builtin_robot_names, export_robot,
};

/// Formats of `flexcal robot export`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormatArg {
    /// URDF (joint origins carry the geometry).
    Urdf,
    /// Modified-DH table: Markdown on standard output or to a `.md` file, CSV otherwise.
    Mdh,
    /// flexcal's robot description TOML.
    Toml,
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
        RobotCommand::Show {
            robot,
            toml,
            import,
        } => show(&robot, toml, &import),
        RobotCommand::Export {
            robot,
            format,
            out,
            tolerance_mm,
            import,
        } => export(&robot, format, out, tolerance_mm, &import),
    }
}

fn show(robot: &str, toml: bool, import: &RobotFileArgs) -> anyhow::Result<()> {
    let imported = flexcal::RobotSpec::parse(robot)?
        .import(&import.options())
        .with_context(|| format!("reading robot {robot}"))?;
    let description = imported.description.clone();
    if toml {
        print!("{}", description.to_toml_string());
        return Ok(());
    }
    let model = description.build()?;
    println!("robot {}", model.name());
    if !description.notes.is_empty() {
        println!("{}", description.notes.trim());
    }
    for note in &imported.notes {
        println!("note: {note}");
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
    if !imported.masses.is_empty() {
        println!("\nlink masses (from <inertial>):");
        for m in &imported.masses {
            println!(
                "  {:<16} {:>10.3} kg on frame {:<4} centre ({:.1}, {:.1}, {:.1}) mm",
                m.link,
                m.mass_kg,
                m.frame,
                m.center_m[0] * 1e3,
                m.center_m[1] * 1e3,
                m.center_m[2] * 1e3
            );
        }
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
    let model = load_description_with(robot, &import.options())?
        .build()
        .with_context(|| format!("building robot '{robot}'"))?;
    let format = match format {
        ExportFormatArg::Urdf => ExportFormat::Urdf,
        ExportFormatArg::Toml => ExportFormat::Toml,
        ExportFormatArg::Mdh => match out.as_ref().and_then(|p| p.extension()) {
            Some(e) if e != "md" => ExportFormat::MdhCsv,
            _ => ExportFormat::MdhMarkdown,
        },
    };
    let options = ExportOptions {
        tolerance_m: tolerance_mm / 1e3,
        ..ExportOptions::default()
    };
    let export = export_robot(&model, model.nominal_params(), format, &options)?;
    match &out {
        Some(path) => {
            flexcal::io::write_atomic(path, &export.text)?;
            println!("{} written to {}", model.name(), path.display());
            if let Some(d) = export.max_deviation_m {
                println!("read back: largest TCP displacement {:.3e} mm", d * 1e3);
            }
            for d in &export.dropped {
                println!("not exported: {d}");
            }
        }
        None => {
            print!("{}", export.text);
            for d in &export.dropped {
                eprintln!("not exported: {d}");
            }
        }
    }
    Ok(())
}
