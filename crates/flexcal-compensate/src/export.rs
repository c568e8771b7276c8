//! Compensated paths for controllers besides KUKA KRL
//! ([`crate::path::krl_program`]): an ABB RAPID module moving linearly
//! through `robtarget`s, and a plain joint-trajectory CSV for any controller
//! or simulator that replays joint values.

use std::fmt::Write as _;

use flexcal_kinematics::{ActuatedKind, Model};
use nalgebra::Isometry3;

/// Errors of the path exports.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PathExportError {
    /// A pose or joint value is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which value (point and component).
        what: String,
    },
    /// A joint configuration or the time column has the wrong length.
    #[error("{what}: expected length {expected}, found {found}")]
    WrongLength {
        /// Which argument.
        what: String,
        /// The length required.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// An option is out of its range.
    #[error("{0}")]
    InvalidOption(String),
}

/// Options of the RAPID export.
#[derive(Debug, Clone, PartialEq)]
pub struct RapidOptions {
    /// Module name (letters, digits and `_`, at most 32 characters; others become `_`).
    pub module_name: String,
    /// TCP speed of the `MoveL` instructions (mm/s) (default 10; range (0, 7000]).
    pub speed_mm_s: f64,
    /// Corner zone between points (mm); `None` stops at every point (`fine`) (default 0.1).
    pub zone_mm: Option<f64>,
    /// Tool data name on the controller (default `tool0`).
    pub tool: String,
    /// Work object name on the controller (default `wobj0`).
    pub work_object: String,
}

impl Default for RapidOptions {
    fn default() -> Self {
        Self {
            module_name: "flexcal_path".into(),
            speed_mm_s: 10.0,
            zone_mm: Some(0.1),
            tool: "tool0".into(),
            work_object: "wobj0".into(),
        }
    }
}

fn identifier(name: &str, max: usize) -> String {
    let mut s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .take(max)
        .collect();
    if !s.starts_with(|c: char| c.is_ascii_alphabetic()) {
        s.insert(0, 'm');
        s.truncate(max);
    }
    s
}

fn check_pose(k: usize, x: &Isometry3<f64>) -> Result<(), PathExportError> {
    let q = x.rotation;
    let values = [
        x.translation.vector.x,
        x.translation.vector.y,
        x.translation.vector.z,
        q.w,
        q.i,
        q.j,
        q.k,
    ];
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(PathExportError::NotFinite {
            what: format!("commanded pose {}", k + 1),
        })
    }
}

/// An ABB RAPID module with one `robtarget` per commanded pose (TCP in the
/// work object's frame, metres in, mm and a unit quaternion `[q1, q2, q3,
/// q4] = [w, x, y, z]` out) and a procedure `main` that reaches the first
/// with `MoveJ` and runs through the others with `MoveL`. The arm
/// configuration is left to the controller (`ConfL \Off`): the poses come
/// from a compensation that followed the target's own branch.
pub fn rapid_module(
    commanded: &[Isometry3<f64>],
    options: &RapidOptions,
) -> Result<String, PathExportError> {
    let v = options.speed_mm_s;
    if v.is_nan() || v <= 0.0 || v > 7000.0 {
        return Err(PathExportError::InvalidOption(format!(
            "RAPID speed {} mm/s is outside (0, 7000]",
            options.speed_mm_s
        )));
    }
    if let Some(z) = options.zone_mm {
        if z.is_nan() || z <= 0.0 || z > 1000.0 {
            return Err(PathExportError::InvalidOption(format!(
                "RAPID zone {z} mm is outside (0, 1000]"
            )));
        }
    }
    for (k, x) in commanded.iter().enumerate() {
        check_pose(k, x)?;
    }
    let module = identifier(&options.module_name, 32);
    let tool = identifier(&options.tool, 32);
    let work_object = identifier(&options.work_object, 32);
    let mut out = String::new();
    let _ = writeln!(out, "MODULE {module}");
    let _ = writeln!(
        out,
        "  ! flexcal compensated path: {} points; positions in mm, orientations as quaternions [w, x, y, z].",
        commanded.len()
    );
    let _ = writeln!(
        out,
        "  ! Define {tool} and {work_object} on the controller as the frames used for the compensation."
    );
    let v = options.speed_mm_s;
    let _ = writeln!(out, "  CONST speeddata vflexcal := [{v}, 500, 5000, 1000];");
    let zone = match options.zone_mm {
        Some(z) => {
            let _ = writeln!(
                out,
                "  CONST zonedata zflexcal := [FALSE, {z}, {}, {}, {}, {}, {}];",
                1.5 * z,
                1.5 * z,
                0.15 * z,
                1.5 * z,
                0.15 * z
            );
            "zflexcal"
        }
        None => "fine",
    };
    for (k, x) in commanded.iter().enumerate() {
        let t = x.translation.vector * 1e3;
        let q = x.rotation;
        let _ = writeln!(
            out,
            "  CONST robtarget p{}:=[[{:.4},{:.4},{:.4}],[{:.9},{:.9},{:.9},{:.9}],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
            k + 1,
            t.x,
            t.y,
            t.z,
            q.w,
            q.i,
            q.j,
            q.k
        );
    }
    let _ = writeln!(out, "  PROC main()");
    let _ = writeln!(out, "    ConfL \\Off;");
    for k in 0..commanded.len() {
        let last = k + 1 == commanded.len();
        let _ = if k == 0 {
            writeln!(
                out,
                "    MoveJ p1, v100, fine, {tool} \\WObj:={work_object};"
            )
        } else {
            writeln!(
                out,
                "    MoveL p{}, vflexcal, {}, {tool} \\WObj:={work_object};",
                k + 1,
                if last { "fine" } else { zone }
            )
        };
    }
    let _ = writeln!(out, "    ConfL \\On;");
    let _ = writeln!(out, "  ENDPROC");
    let _ = writeln!(out, "ENDMODULE");
    Ok(out)
}

/// A joint trajectory as CSV: one row per configuration, a column per
/// actuated coordinate named `{name}_deg` (revolute) or `{name}_mm`
/// (prismatic joint or screw length), after a `t_s` column when `times_s`
/// is given. `q` holds configurations in SI units (rad, m), in the order of
/// [`Model::actuated_names`].
pub fn joint_trajectory_csv(
    model: &Model,
    q: &[Vec<f64>],
    times_s: Option<&[f64]>,
) -> Result<String, PathExportError> {
    let n = model.n_actuated();
    if let Some(t) = times_s {
        if t.len() != q.len() {
            return Err(PathExportError::WrongLength {
                what: "time column".into(),
                expected: q.len(),
                found: t.len(),
            });
        }
    }
    let mut header: Vec<String> = Vec::with_capacity(n + 1);
    if times_s.is_some() {
        header.push("t_s".into());
    }
    for (name, kind) in model.actuated_names().iter().zip(model.actuated_kinds()) {
        header.push(match kind {
            ActuatedKind::Revolute => format!("{name}_deg"),
            _ => format!("{name}_mm"),
        });
    }
    let mut out = header.join(",");
    out.push('\n');
    for (k, row) in q.iter().enumerate() {
        if row.len() != n {
            return Err(PathExportError::WrongLength {
                what: format!("configuration {}", k + 1),
                expected: n,
                found: row.len(),
            });
        }
        let mut cells: Vec<String> = Vec::with_capacity(n + 1);
        if let Some(t) = times_s {
            if !t[k].is_finite() {
                return Err(PathExportError::NotFinite {
                    what: format!("time of configuration {}", k + 1),
                });
            }
            cells.push(t[k].to_string());
        }
        for (j, (&v, kind)) in row.iter().zip(model.actuated_kinds()).enumerate() {
            if !v.is_finite() {
                return Err(PathExportError::NotFinite {
                    what: format!("joint {} of configuration {}", j + 1, k + 1),
                });
            }
            cells.push(match kind {
                ActuatedKind::Revolute => v.to_degrees().to_string(),
                _ => (v * 1e3).to_string(),
            });
        }
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexcal_kinematics::RobotDescription;
    use nalgebra::{Translation3, UnitQuaternion};

    fn poses() -> Vec<Isometry3<f64>> {
        (0..3)
            .map(|k| {
                Isometry3::from_parts(
                    Translation3::new(1.0 + 0.01 * k as f64, -0.2, 0.5),
                    UnitQuaternion::from_euler_angles(3.0, 0.1 * k as f64, -0.4),
                )
            })
            .collect()
    }

    #[test]
    fn rapid_module_holds_one_robtarget_per_pose_and_reads_back() {
        let p = poses();
        let text = rapid_module(&p, &RapidOptions::default()).unwrap();
        assert!(text.starts_with("MODULE flexcal_path\n"));
        assert!(text.trim_end().ends_with("ENDMODULE"));
        assert_eq!(text.matches("CONST robtarget").count(), 3);
        assert_eq!(text.matches("MoveL").count(), 2);
        // The last move stops; the others blend.
        assert!(text.contains("MoveL p3, vflexcal, fine"));
        assert!(text.contains("MoveL p2, vflexcal, zflexcal"));
        // Parse p2 back: position (mm) and quaternion reproduce the pose.
        let line = text.lines().find(|l| l.contains("robtarget p2:=")).unwrap();
        let inner = &line[line.find(":=[[").unwrap() + 4..];
        let numbers: Vec<f64> = inner
            .split(['[', ']', ','])
            .filter(|s| !s.is_empty() && !s.contains(';'))
            .take(7)
            .map(|s| s.parse().unwrap())
            .collect();
        let t = p[1].translation.vector * 1e3;
        assert!((numbers[0] - t.x).abs() < 1e-4 && (numbers[2] - t.z).abs() < 1e-4);
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            numbers[3], numbers[4], numbers[5], numbers[6],
        ));
        assert!(q.angle_to(&p[1].rotation) < 1e-8);
    }

    #[test]
    fn bad_options_and_poses_are_named_errors() {
        let mut p = poses();
        let options = RapidOptions {
            speed_mm_s: 0.0,
            ..RapidOptions::default()
        };
        assert!(matches!(
            rapid_module(&p, &options),
            Err(PathExportError::InvalidOption(_))
        ));
        p[1].translation.vector.x = f64::NAN;
        let e = rapid_module(&p, &RapidOptions::default()).unwrap_err();
        assert_eq!(e.to_string(), "commanded pose 2 is not finite");
    }

    #[test]
    fn joint_trajectory_has_units_in_its_header_and_checks_lengths() {
        let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
        let q = vec![vec![0.0, -1.0, 1.0, 0.5, 0.25, std::f64::consts::PI]; 2];
        let text = joint_trajectory_csv(&model, &q, Some(&[0.0, 0.5])).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "t_s,theta1_deg,theta2_deg,theta3_deg,theta4_deg,theta5_deg,theta6_deg"
        );
        let row: Vec<f64> = lines
            .next()
            .unwrap()
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(row[0], 0.0);
        assert!((row[6] - 180.0).abs() < 1e-12);
        let e = joint_trajectory_csv(&model, &[vec![0.0; 5]], None).unwrap_err();
        assert!(matches!(
            e,
            PathExportError::WrongLength {
                expected: 6,
                found: 5,
                ..
            }
        ));
    }
}
