//! Robots as text for people: the list of built-in robots and a robot's
//! description (`flexcal robot list`, `flexcal robot show`). Lengths in mm
//! and angles in deg.

use std::fmt::Write as _;

use flexcal_kinematics::{
    ActuatedKind, ImportedRobot, ParamKind, RobotDescription, builtin_robot_names,
};

use crate::Error;

/// The built-in robots, one line each: name, number of actuated
/// coordinates and of geometric parameters, serial or with closed loops.
///
/// # Errors
/// A built-in description that does not build (a defect of flexcal).
pub fn builtin_robots_text() -> Result<String, Error> {
    let mut out = String::new();
    for name in builtin_robot_names() {
        let model = RobotDescription::builtin(name)?.build()?;
        let _ = writeln!(
            out,
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
    Ok(out)
}

/// A robot for people: its name and notes, the notes of its import, the
/// actuated coordinates with kinds and limits (deg, mm), the passive joints,
/// the parameter vector xi with nominal values (mm, deg) and the link
/// masses its file carries.
///
/// # Errors
/// A description that does not build into a valid model.
pub fn robot_text(imported: &ImportedRobot) -> Result<String, Error> {
    let description = &imported.description;
    let model = description.build()?;
    let mut out = String::new();
    let _ = writeln!(out, "robot {}", model.name());
    if !description.notes.is_empty() {
        let _ = writeln!(out, "{}", description.notes.trim());
    }
    for note in &imported.notes {
        let _ = writeln!(out, "note: {note}");
    }
    let _ = writeln!(out, "\nactuated coordinates (q, in this order):");
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
        let _ = writeln!(
            out,
            "  {name:<10} {:<10} limits [{:.3}, {:.3}] {unit}",
            format!("{kind:?}").to_lowercase(),
            lo * scale,
            hi * scale
        );
    }
    if !model.passive_names().is_empty() {
        let _ = writeln!(out, "passive joints: {}", model.passive_names().join(", "));
    }
    let _ = writeln!(
        out,
        "frames (fk --frame NAME; 0 is the base): {}",
        model.named_frames().join(", ")
    );
    let _ = writeln!(
        out,
        "\nparameter vector xi ({} parameters):",
        model.n_params()
    );
    let _ = writeln!(
        out,
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
        let _ = writeln!(
            out,
            "  {:>3}  {:<10} {:<6} {:>14.6}  {unit}",
            i + 1,
            p.name,
            p.frame,
            value
        );
    }
    if !imported.masses.is_empty() {
        let _ = writeln!(out, "\nlink masses (from <inertial>):");
        for m in &imported.masses {
            let _ = writeln!(
                out,
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
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_robot_has_one_line() {
        let text = builtin_robots_text().unwrap();
        assert_eq!(text.lines().count(), builtin_robot_names().len());
        assert!(
            text.lines()
                .any(|l| l.starts_with("ir663") && l.ends_with("closed loops"))
        );
    }

    #[test]
    fn a_robot_shows_each_coordinate_and_parameter_in_mm_and_deg() {
        let description = RobotDescription::builtin("ur10").unwrap();
        let model = description.build().unwrap();
        let imported = ImportedRobot {
            description,
            masses: Vec::new(),
            notes: vec!["converted".into()],
        };
        let text = robot_text(&imported).unwrap();
        assert!(text.starts_with("robot ur10\n"), "{text}");
        assert!(text.contains("note: converted\n"));
        assert!(text.contains(&format!("({} parameters)", model.n_params())));
        for name in model.actuated_names() {
            assert!(text.contains(&format!("  {name:<10} revolute")), "{text}");
        }
        let rows = text
            .lines()
            .filter(|l| l.ends_with(" mm") || l.ends_with(" deg"));
        assert_eq!(rows.count(), model.n_params() + model.n_actuated());
    }
}
