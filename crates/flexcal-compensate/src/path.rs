//! Tool paths: reading target paths from CSV and exporting commanded paths as
//! a KUKA KRL program.
//!
//! # Target path CSV
//! One header line, one row per path point, in the part frame R_p:
//!
//! | column | unit | meaning |
//! |---|---|---|
//! | `x_mm`, `y_mm`, `z_mm` | mm | TCP position |
//! | `qw`, `qx`, `qy`, `qz` (optional) | - | TCP orientation as a unit quaternion |
//! | `a_deg`, `b_deg`, `c_deg` (optional, instead of the quaternion) | deg | TCP orientation as KUKA A, B, C angles: `Rz(A) Ry(B) Rx(C)` |
//!
//! Without orientation columns every point takes the orientation given by
//! the caller (for example "tool pointing down"). Quaternions are normalised;
//! one of zero norm is an error naming its line.

use std::fmt::Write as _;
use std::path::Path as FilePath;

use flexcal_io::{CsvOptions, CsvTable, IoError};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

/// Errors of path files.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PathError {
    /// The file could not be read, or a cell is malformed (names file, line, column).
    #[error(transparent)]
    Io(#[from] IoError),
    /// A quaternion of (near) zero norm.
    #[error("{file}:{line}: the orientation quaternion has zero norm")]
    ZeroQuaternion {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
    },
    /// Only some of the orientation columns are present.
    #[error("{file}: orientation needs all of {needed} (found only {found})")]
    PartialOrientation {
        /// The file.
        file: String,
        /// The full set of columns.
        needed: &'static str,
        /// The columns found.
        found: String,
    },
}

/// One target point: the TCP pose in the part frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// 1-based line of the point in its file (0 when built in memory).
    pub line: usize,
    /// TCP pose in the part frame (`x_part_tcp`), metres.
    pub x_part_tcp: Isometry3<f64>,
}

/// Rotation from KUKA A, B, C angles (rad): `Rz(A) Ry(B) Rx(C)`.
pub fn rotation_from_abc(a: f64, b: f64, c: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(c, b, a)
}

/// KUKA A, B, C angles (rad) of a rotation (inverse of [`rotation_from_abc`]).
pub fn abc_from_rotation(rotation: &UnitQuaternion<f64>) -> (f64, f64, f64) {
    let (roll, pitch, yaw) = rotation.euler_angles();
    (yaw, pitch, roll)
}

/// Reads a target path; points without orientation get `default_orientation`.
pub fn read_target_path(
    file: &FilePath,
    default_orientation: UnitQuaternion<f64>,
) -> Result<Vec<PathPoint>, PathError> {
    let table = CsvTable::read(file, &CsvOptions::default())?;
    target_path_from_table(&table, default_orientation)
}

/// Builds a target path from an already read table (see [`read_target_path`]).
pub fn target_path_from_table(
    table: &CsvTable,
    default_orientation: UnitQuaternion<f64>,
) -> Result<Vec<PathPoint>, PathError> {
    table.require_rows()?;
    let file = table.path().display().to_string();
    let x = table.column_f64("x_mm")?;
    let y = table.column_f64("y_mm")?;
    let z = table.column_f64("z_mm")?;
    let present = |names: &[&str]| -> Vec<String> {
        names
            .iter()
            .filter(|n| table.find_column(n).is_some())
            .map(|n| n.to_string())
            .collect()
    };
    let quaternion_columns = ["qw", "qx", "qy", "qz"];
    let abc_columns = ["a_deg", "b_deg", "c_deg"];
    let found_q = present(&quaternion_columns);
    let found_abc = present(&abc_columns);
    if !found_q.is_empty() && found_q.len() < 4 {
        return Err(PathError::PartialOrientation {
            file,
            needed: "qw, qx, qy, qz",
            found: found_q.join(", "),
        });
    }
    if !found_abc.is_empty() && found_abc.len() < 3 {
        return Err(PathError::PartialOrientation {
            file,
            needed: "a_deg, b_deg, c_deg",
            found: found_abc.join(", "),
        });
    }
    let mut orientations = vec![default_orientation; table.len()];
    if found_q.len() == 4 {
        let q: Vec<Vec<f64>> = quaternion_columns
            .iter()
            .map(|c| table.column_f64(c))
            .collect::<Result<_, _>>()?;
        for (row, o) in orientations.iter_mut().enumerate() {
            let raw = nalgebra::Quaternion::new(q[0][row], q[1][row], q[2][row], q[3][row]);
            if raw.norm() < 1e-9 {
                return Err(PathError::ZeroQuaternion {
                    file: file.clone(),
                    line: table.line_of(row),
                });
            }
            *o = UnitQuaternion::from_quaternion(raw);
        }
    } else if found_abc.len() == 3 {
        let abc: Vec<Vec<f64>> = abc_columns
            .iter()
            .map(|c| table.column_f64(c))
            .collect::<Result<_, _>>()?;
        for (row, o) in orientations.iter_mut().enumerate() {
            *o = rotation_from_abc(
                abc[0][row].to_radians(),
                abc[1][row].to_radians(),
                abc[2][row].to_radians(),
            );
        }
    }
    Ok((0..table.len())
        .map(|row| PathPoint {
            line: table.line_of(row),
            x_part_tcp: Isometry3::from_parts(
                Translation3::new(x[row] * 1e-3, y[row] * 1e-3, z[row] * 1e-3),
                orientations[row],
            ),
        })
        .collect())
}

/// Writes a target path as CSV text (positions in mm, quaternion orientation).
pub fn target_path_to_csv(points: &[PathPoint]) -> String {
    flexcal_io::format_csv(
        &["x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz"],
        points.iter().map(|p| {
            let t = p.x_part_tcp.translation.vector * 1e3;
            let q = p.x_part_tcp.rotation;
            vec![t.x, t.y, t.z, q.w, q.i, q.j, q.k]
        }),
    )
}

/// Options of the KRL export.
#[derive(Debug, Clone, PartialEq)]
pub struct KrlOptions {
    /// Program name (the `DEF` name; letters, digits and `_`, at most 24 characters).
    pub program_name: String,
    /// Cartesian velocity of the LIN moves (m/s).
    pub velocity_m_s: f64,
    /// Use approximate positioning (`C_DIS`) between points.
    pub blend: bool,
}

impl Default for KrlOptions {
    fn default() -> Self {
        Self {
            program_name: "flexcal_path".into(),
            velocity_m_s: 0.01,
            blend: true,
        }
    }
}

/// A KRL program that moves linearly through `commanded` poses (TCP in the
/// robot's BASE frame, metres), in order. The first point is reached with a
/// PTP move. BASE and TOOL data must be set on the controller to match the
/// frames the poses were computed in; the program says so in its header.
pub fn krl_program(
    commanded: &[Isometry3<f64>],
    options: &KrlOptions,
) -> Result<String, PathError> {
    let name: String = options
        .program_name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .take(24)
        .collect();
    let mut out = String::new();
    let _ = writeln!(out, "DEF {name}()");
    let _ = writeln!(
        out,
        ";FLEXCAL compensated path: {} points, poses in mm and deg (A, B, C = Rz Ry Rx)",
        commanded.len()
    );
    let _ = writeln!(
        out,
        ";Set $BASE and $TOOL to the frames used for the compensation before running."
    );
    let _ = writeln!(out, "  BAS(#INITMOV, 0)");
    let _ = writeln!(
        out,
        "  $VEL.CP = {:.4}",
        options.velocity_m_s.clamp(1e-4, 3.0)
    );
    let _ = writeln!(out, "  $APO.CDIS = 0.1");
    let pose = |x: &Isometry3<f64>| {
        let t = x.translation.vector * 1e3;
        let (a, b, c) = abc_from_rotation(&x.rotation);
        format!(
            "{{X {:.4}, Y {:.4}, Z {:.4}, A {:.5}, B {:.5}, C {:.5}}}",
            t.x,
            t.y,
            t.z,
            a.to_degrees(),
            b.to_degrees(),
            c.to_degrees()
        )
    };
    for (i, x) in commanded.iter().enumerate() {
        let _ = if i == 0 {
            writeln!(out, "  PTP {}", pose(x))
        } else if options.blend && i + 1 < commanded.len() {
            writeln!(out, "  LIN {} C_DIS", pose(x))
        } else {
            writeln!(out, "  LIN {}", pose(x))
        };
    }
    let _ = writeln!(out, "END");
    Ok(out)
}

/// A test path: `count` points 50 mm apart along -x of the part frame
/// from `x0` (m), 25 mm below it, the tool pointing down (file lines 2..).
#[cfg(test)]
pub(crate) fn tool_down_line(x0: f64, count: usize) -> Vec<PathPoint> {
    let down = UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), std::f64::consts::PI);
    (0..count)
        .map(|i| PathPoint {
            line: i + 2,
            x_part_tcp: Isometry3::from_parts(
                Translation3::new(x0 - 0.05 * i as f64, 0.0, -0.025),
                down,
            ),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Vector3;

    #[test]
    fn abc_round_trips() {
        for (a, b, c) in [(0.3, -0.2, 2.9), (-1.0, 0.5, 0.1), (3.0, 1.2, -2.0)] {
            let r = rotation_from_abc(a, b, c);
            let (a2, b2, c2) = abc_from_rotation(&r);
            assert_relative_eq!(rotation_from_abc(a2, b2, c2), r, epsilon = 1e-12);
            // A is about z first: a pure A rotates x towards y.
            let rz = rotation_from_abc(a, 0.0, 0.0);
            assert_relative_eq!(
                rz * Vector3::x(),
                Vector3::new(a.cos(), a.sin(), 0.0),
                epsilon = 1e-12
            );
        }
    }

    #[test]
    fn path_csv_round_trips_and_reports_bad_lines() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("path.csv");
        let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
        let points = tool_down_line(0.585, 5);
        flexcal_io::write_atomic(&file, target_path_to_csv(&points)).unwrap();
        let back = read_target_path(&file, UnitQuaternion::identity()).unwrap();
        for (p, q) in points.iter().zip(&back) {
            assert_eq!(p.line, q.line);
            assert_relative_eq!(p.x_part_tcp, q.x_part_tcp, epsilon = 1e-12);
        }
        flexcal_io::write_atomic(&file, "x_mm,y_mm,z_mm,a_deg,b_deg\n1,2,3,4,5\n").unwrap();
        let err = read_target_path(&file, down).unwrap_err().to_string();
        assert!(err.contains("a_deg, b_deg, c_deg"), "{err}");
        flexcal_io::write_atomic(&file, "x_mm,y_mm,z_mm\n1,2,3\n1,x,3\n").unwrap();
        let err = read_target_path(&file, down).unwrap_err().to_string();
        assert!(err.contains(":3") && err.contains("y_mm"), "{err}");
        flexcal_io::write_atomic(&file, "x_mm,y_mm,z_mm,qw,qx,qy,qz\n1,2,3,0,0,0,0\n").unwrap();
        let err = read_target_path(&file, down).unwrap_err().to_string();
        assert!(err.contains("zero norm") && err.contains(":2"), "{err}");
        flexcal_io::write_atomic(&file, "x_mm,y_mm,z_mm\n").unwrap();
        assert!(read_target_path(&file, down).is_err());
    }

    #[test]
    fn krl_program_lists_every_point() {
        let poses: Vec<Isometry3<f64>> = (0..4)
            .map(|i| Isometry3::translation(1.5 + 0.01 * i as f64, 0.0, 1.0))
            .collect();
        let krl = krl_program(&poses, &KrlOptions::default()).unwrap();
        assert!(krl.starts_with("DEF flexcal_path()"));
        assert_eq!(krl.matches("PTP {X 1500.0000").count(), 1);
        assert_eq!(krl.matches("LIN {").count(), 3);
        assert_eq!(krl.matches("C_DIS").count(), 2);
        assert!(krl.trim_end().ends_with("END"));
    }
}
