//! The forward and inverse models over files: the configuration file
//! (`q1..qn`) and the TCP pose file (`x_m,y_m,z_m,qw,qx,qy,qz`) of
//! `flexcal fk` and `flexcal ik`.
//!
//! A configuration file has a header `q1,...,qn`: the actuated coordinates
//! in the robot's actuated order, rad for revolute joints and m for
//! prismatic joints and screws (other columns are ignored). A pose file has
//! the columns [`POSE_COLUMNS`]: the TCP in the robot base frame, position
//! in metres, orientation as a unit quaternion (scalar first). The forward
//! model's pose file adds one column `passive_<frame>` per passive joint of
//! a closed loop (rad or m), which the reader ignores, so a forward model's
//! output is an inverse model's input.
//!
//! Every row keeps where it came from (`file:line`, or the option that gave
//! it), and every error names it.

use std::path::Path;

use flexcal_io::{CsvOptions, CsvTable, format_csv};
use flexcal_kinematics::{
    Data, InverseOptions, Model, forward_named_pose, forward_pose, inverse_pose,
};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use crate::compensation::parse_number_list;
use crate::{Error, Result};

/// The pose columns of a pose file.
pub const POSE_COLUMNS: [&str; 7] = ["x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"];

/// A row of input and where it came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Located<T> {
    /// The value.
    pub value: T,
    /// Where it came from: `file:line`, or the option that gave it.
    pub origin: String,
}

/// The actuated coordinates in `text` (comma-separated, rad or m), one per
/// actuated coordinate of `model`; `what` names the argument in errors.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `what`: a value that is not a finite
/// number, or a count other than the robot's number of actuated coordinates.
pub fn parse_configuration(text: &str, model: &Model, what: &str) -> Result<Vec<f64>> {
    let values = parse_number_list(text, what)?;
    if values.len() != model.n_actuated() {
        return Err(Error::InvalidParameter {
            parameter: what.to_string(),
            message: format!(
                "robot '{}' has {} actuated coordinates ({}), {} given",
                model.name(),
                model.n_actuated(),
                model.actuated_names().join(", "),
                values.len()
            ),
        });
    }
    Ok(values)
}

/// The header of a configuration file of `n` actuated coordinates: `q1..qn`.
pub fn configuration_header(n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("q{i}")).collect()
}

/// Reads the configurations of `model` from the CSV file `path` (columns
/// `q1..qn`, other columns ignored).
///
/// # Errors
/// File and CSV errors naming the file, line and column: no data rows, a
/// missing `qi` column, a cell that is not a finite number.
pub fn read_configurations(path: &Path, model: &Model) -> Result<Vec<Located<Vec<f64>>>> {
    let table = CsvTable::read(path, &CsvOptions::default())?;
    table.require_rows()?;
    let columns: Vec<Vec<f64>> = configuration_header(model.n_actuated())
        .iter()
        .map(|name| table.column_f64(name))
        .collect::<Result<_, _>>()?;
    Ok((0..table.len())
        .map(|r| Located {
            value: columns.iter().map(|c| c[r]).collect(),
            origin: format!("{}:{}", path.display(), table.line_of(r)),
        })
        .collect())
}

/// Configurations as CSV text: header `q1..qn`, full precision.
pub fn configurations_to_csv(n: usize, configurations: &[Vec<f64>]) -> String {
    let header = configuration_header(n);
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    format_csv(&header, configurations.iter().cloned())
}

/// Reads a pose file (columns [`POSE_COLUMNS`], others ignored).
///
/// # Errors
/// File and CSV errors naming the file, line and column, and
/// [`Error::InvalidData`] for a quaternion of zero norm.
pub fn read_poses(path: &Path) -> Result<Vec<Located<Isometry3<f64>>>> {
    let table = CsvTable::read(path, &CsvOptions::default())?;
    table.require_rows()?;
    let c: Vec<Vec<f64>> = POSE_COLUMNS
        .iter()
        .map(|name| table.column_f64(name))
        .collect::<Result<_, _>>()?;
    (0..table.len())
        .map(|r| {
            let origin = format!("{}:{}", path.display(), table.line_of(r));
            let q = Quaternion::new(c[3][r], c[4][r], c[5][r], c[6][r]);
            if q.norm() < 1e-9 {
                return Err(Error::InvalidData {
                    origin,
                    message: "the orientation quaternion has zero norm".into(),
                });
            }
            let value = Isometry3::from_parts(
                Translation3::new(c[0][r], c[1][r], c[2][r]),
                UnitQuaternion::from_quaternion(q),
            );
            Ok(Located { value, origin })
        })
        .collect()
}

/// The forward model of a set of configurations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForwardPoses {
    /// Names of the passive joints of the robot's closed loops.
    pub passive_names: Vec<String>,
    /// One pose per configuration: the TCP in the base frame.
    pub x_base_tcp: Vec<Isometry3<f64>>,
    /// The passive joint values of each configuration (rad or m), in the
    /// order of `passive_names`.
    pub passive: Vec<Vec<f64>>,
}

impl ForwardPoses {
    /// The pose file: [`POSE_COLUMNS`] then `passive_<name>` per passive
    /// joint, full precision.
    pub fn to_csv(&self) -> String {
        let mut header: Vec<String> = POSE_COLUMNS.iter().map(|s| s.to_string()).collect();
        header.extend(self.passive_names.iter().map(|n| format!("passive_{n}")));
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        let rows = self.x_base_tcp.iter().zip(&self.passive).map(|(x, p)| {
            let (t, r) = (x.translation.vector, x.rotation);
            let mut row = vec![t.x, t.y, t.z, r.w, r.i, r.j, r.k];
            row.extend(p);
            row
        });
        format_csv(&header, rows)
    }
}

/// The TCP poses (and passive joint values) of `configurations` with the
/// robot's nominal geometric parameters.
///
/// # Errors
/// [`Error::KinematicsAt`] naming the configuration's origin: a wrong
/// number of coordinates, a loop that cannot close.
pub fn forward_poses(model: &Model, configurations: &[Located<Vec<f64>>]) -> Result<ForwardPoses> {
    let xi = model.nominal_params();
    let mut data = Data::new(model);
    let mut out = ForwardPoses {
        passive_names: model.passive_names().to_vec(),
        x_base_tcp: Vec::with_capacity(configurations.len()),
        passive: Vec::with_capacity(configurations.len()),
    };
    for q in configurations {
        // forward_pose also assembles the loops, so the passive joint values
        // are in `data` afterwards.
        let x =
            forward_pose(model, &mut data, &q.value, xi).map_err(|source| Error::KinematicsAt {
                origin: q.origin.clone(),
                source,
            })?;
        out.x_base_tcp.push(x);
        out.passive.push(data.passive_values().to_vec());
    }
    Ok(out)
}

/// The poses of named frames over a set of configurations (`fk --frame`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FramePoses {
    /// The frames' names ([`Model::named_frames`]), in the order asked.
    pub frames: Vec<String>,
    /// Per configuration, the pose `x_base_frame` of each frame in the base
    /// frame R0 (m), in the order of `frames`.
    pub x_base_frame: Vec<Vec<Isometry3<f64>>>,
}

impl FramePoses {
    /// The pose file: for each frame the columns [`POSE_COLUMNS`] prefixed
    /// by its name and `.` (`wrist_2_link.x_m`, ..., `wrist_2_link.qz`),
    /// full precision.
    pub fn to_csv(&self) -> String {
        let header: Vec<String> = self
            .frames
            .iter()
            .flat_map(|f| POSE_COLUMNS.iter().map(move |c| format!("{f}.{c}")))
            .collect();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        let rows = self.x_base_frame.iter().map(|poses| {
            poses
                .iter()
                .flat_map(|x| {
                    let (t, r) = (x.translation.vector, x.rotation);
                    [t.x, t.y, t.z, r.w, r.i, r.j, r.k]
                })
                .collect::<Vec<f64>>()
        });
        format_csv(&header, rows)
    }
}

/// The poses of the frames or links named `frames` (any of
/// [`Model::named_frames`]) at each of `configurations`, with the robot's
/// nominal geometric parameters.
///
/// # Errors
/// [`Error::Kinematics`] with `UnknownFrame` for a name the robot does not
/// have (before any computation); [`Error::KinematicsAt`] naming the
/// configuration's origin otherwise.
pub fn forward_frame_poses(
    model: &Model,
    configurations: &[Located<Vec<f64>>],
    frames: &[String],
) -> Result<FramePoses> {
    for name in frames {
        model.locate(name)?;
    }
    let xi = model.nominal_params();
    let mut data = Data::new(model);
    let mut x_base_frame = Vec::with_capacity(configurations.len());
    for q in configurations {
        let poses = frames
            .iter()
            .map(|name| forward_named_pose(model, &mut data, name, &q.value, xi))
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|source| Error::KinematicsAt {
                origin: q.origin.clone(),
                source,
            })?;
        x_base_frame.push(poses);
    }
    Ok(FramePoses {
        frames: frames.to_vec(),
        x_base_frame,
    })
}

/// The middle of the joint limits: the default start of the inverse model.
pub fn middle_of_limits(model: &Model) -> Vec<f64> {
    model
        .actuated_limits()
        .iter()
        .map(|&(lo, hi)| 0.5 * (lo + hi))
        .collect()
}

/// Configurations reaching the TCP poses `targets` in order with the
/// robot's nominal geometric parameters: the first from `start`, each later
/// one from the previous solution, so that a path stays on one branch.
///
/// # Errors
/// [`Error::KinematicsAt`] naming the first target that cannot be reached.
pub fn inverse_path(
    model: &Model,
    targets: &[Located<Isometry3<f64>>],
    start: &[f64],
) -> Result<Vec<Vec<f64>>> {
    let xi = model.nominal_params();
    let mut data = Data::new(model);
    let options = InverseOptions::default();
    let mut seed = start.to_vec();
    let mut out = Vec::with_capacity(targets.len());
    for target in targets {
        let solution = inverse_pose(model, &mut data, &target.value, &seed, xi, &options).map_err(
            |source| Error::KinematicsAt {
                origin: target.origin.clone(),
                source,
            },
        )?;
        seed.clone_from(&solution.q);
        out.push(solution.q);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ur10() -> Model {
        crate::load_robot("ur10").unwrap()
    }

    #[test]
    fn forward_poses_round_trip_through_the_pose_file() {
        let model = ur10();
        let configurations: Vec<Located<Vec<f64>>> = (0..4)
            .map(|k| Located {
                value: vec![0.1 * k as f64, -1.0, 1.2, -0.3, 0.7, 0.05 * k as f64],
                origin: format!("row {k}"),
            })
            .collect();
        let poses = forward_poses(&model, &configurations).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("poses.csv");
        flexcal_io::write_atomic(&path, poses.to_csv()).unwrap();
        let read = read_poses(&path).unwrap();
        assert_eq!(read.len(), poses.x_base_tcp.len());
        for (k, (back, x)) in read.iter().zip(&poses.x_base_tcp).enumerate() {
            // Full precision: the shortest text that round-trips.
            assert_eq!(back.value.translation, x.translation);
            // Read back as written, up to the renormalisation of the quaternion.
            assert!((back.value.rotation.coords - x.rotation.coords).norm() < 1e-15);
            assert_eq!(back.origin, format!("{}:{}", path.display(), k + 2));
        }
    }

    #[test]
    fn configurations_round_trip_through_their_file() {
        let model = ur10();
        let q = vec![
            vec![0.0, -1.5, 1.0, 0.25, -0.125, 3.0],
            vec![1.0e-9, 2.5, -3.0, 0.1, 0.2, 0.3],
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("q.csv");
        flexcal_io::write_atomic(&path, configurations_to_csv(6, &q)).unwrap();
        let back: Vec<Vec<f64>> = read_configurations(&path, &model)
            .unwrap()
            .into_iter()
            .map(|c| c.value)
            .collect();
        assert_eq!(back, q);
    }

    #[test]
    fn inverse_path_reaches_the_forward_poses() {
        let model = ur10();
        let q = vec![0.2, -1.1, 1.3, -0.4, 0.8, 0.1];
        let x = forward_poses(
            &model,
            &[Located {
                value: q.clone(),
                origin: "q".into(),
            }],
        )
        .unwrap()
        .x_base_tcp[0];
        let start: Vec<f64> = q.iter().map(|v| v + 0.05).collect();
        let target = Located {
            value: x,
            origin: "x".into(),
        };
        let solution = inverse_path(&model, &[target], &start).unwrap();
        let back = forward_poses(
            &model,
            &[Located {
                value: solution[0].clone(),
                origin: "solution".into(),
            }],
        )
        .unwrap()
        .x_base_tcp[0];
        assert!((back.translation.vector - x.translation.vector).norm() < 1e-7);
        // q and -q are the same rotation.
        let (a, b) = (back.rotation.coords, x.rotation.coords);
        assert!((a - b).norm().min((a + b).norm()) < 1e-7);
    }

    #[test]
    fn bad_configurations_are_named() {
        let model = ur10();
        let err = parse_configuration("0,1", &model, "--joints").unwrap_err();
        assert!(
            err.to_string()
                .starts_with("--joints: robot 'ur10' has 6 actuated")
        );
        let err = parse_configuration("0,1,2,3,4,nan", &model, "--seed").unwrap_err();
        assert!(err.to_string().contains("'nan' is not a finite number"));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("zero.csv");
        std::fs::write(&path, "x_m,y_m,z_m,qw,qx,qy,qz\n1,0,0,0,0,0,0\n").unwrap();
        let err = read_poses(&path).unwrap_err().to_string();
        assert!(
            err.contains("zero.csv:2") && err.contains("zero norm"),
            "{err}"
        );
        let far = Located {
            value: Isometry3::translation(5.0, 0.0, 0.0),
            origin: "far.csv:2".into(),
        };
        let err = inverse_path(&model, &[far], &middle_of_limits(&model)).unwrap_err();
        assert!(err.to_string().starts_with("far.csv:2: "), "{err}");
    }
}
