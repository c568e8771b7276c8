//! Targets, the named frames of the robot a measurement system sees
//! (laser-tracker reflectors on a tool, markers on the two hands of a
//! two-armed robot, a probe on a link), their observations and poses, and
//! the files of several targets per pose. A [`MeasurementSet`] of one
//! target per pose is the case of one target on the TCP
//! ([`crate::measurement::TCP_TARGET`]).
//!
//! ## Files
//! A targets description (TOML) names each target, the frame it is fixed
//! to and its nominal offset in that frame, and whether the offset is
//! identified:
//!
//! ```toml
//! [[target]]
//! name = "left"             # letters, digits, '-' and '_'
//! frame = "LH"              # a frame of the robot, or "tcp" (end frame + tool)
//! offset_mm = [30, 0, 40]   # nominal offset in that frame (mm)
//! rotation_deg = [0, 0, 90] # optional: nominal orientation in that frame,
//!                           # a rotation vector (deg); default none
//! identify = true           # default true; false keeps the offset fixed
//! ```
//!
//! The measurements are flexcal's CSV ([`MeasurementSet`]'s conventions:
//! comma-separated, `#` comments, columns in any order) with `q1..qn`, an
//! optional `pose_id` and `station`, and per target `<name>_x_mm, <name>_y_mm,
//! <name>_z_mm` (position in the measurement frame), optionally
//! `<name>_rx_deg..` (rotation vector), `<name>_sx_mm..` (standard
//! deviations) and `<name>_srx_deg..`. A target not seen on a pose has empty
//! cells on that row (all of its cells).

use std::fmt::Write as _;
use std::path::Path;

use flexcal_io::{CsvOptions, CsvTable, write_atomic};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::error::CalibError;
use crate::geometry::{rotation_from_vector, vector_from_rotation};
use crate::measurement::{MeasurementSet, station_index};
use crate::options::FrameTreatment;

/// A measured target fixed to a frame of the robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// Name, used as the prefix of its CSV columns and in the names of its
    /// unknowns (`target.<name>.x`).
    pub name: String,
    /// Frame it is fixed to: a frame name of the robot, or [`crate::TCP_FRAME`].
    pub frame: String,
    /// Nominal offset of the target in that frame (m).
    pub offset: Vector3<f64>,
    /// Nominal orientation of the target in that frame (identity by
    /// default): what its measured orientations are relative to.
    #[serde(default = "UnitQuaternion::identity")]
    pub rotation: UnitQuaternion<f64>,
    /// Whether the offset is identified (default) or kept at its nominal value.
    pub treatment: FrameTreatment,
}

impl Target {
    /// A target on `frame` at `offset` (m), identified, its orientation
    /// that of the frame.
    pub fn new(name: &str, frame: &str, offset: Vector3<f64>) -> Self {
        Self {
            name: name.to_string(),
            frame: frame.to_string(),
            offset,
            rotation: UnitQuaternion::identity(),
            treatment: FrameTreatment::Identify,
        }
    }

    /// The nominal pose `x_frame_target` of the target in its frame.
    pub fn pose(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.offset), self.rotation)
    }
}

/// What the measurement system saw of one target on one pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetObservation {
    /// Measured position `p_M_target` (m).
    pub position: Vector3<f64>,
    /// Measured orientation as a rotation vector of `R_M_target` (rad).
    pub orientation: Option<Vector3<f64>>,
    /// Standard deviation of each position axis (m).
    pub position_std: Option<Vector3<f64>>,
    /// Standard deviation of each orientation axis (rad).
    pub orientation_std: Option<Vector3<f64>>,
}

impl TargetObservation {
    /// A position-only observation.
    pub fn new(position: Vector3<f64>) -> Self {
        Self {
            position,
            orientation: None,
            position_std: None,
            orientation_std: None,
        }
    }

    /// Which optional groups it carries: (orientation, position standard
    /// deviations, orientation standard deviations).
    pub(crate) fn pattern(&self) -> (bool, bool, bool) {
        (
            self.orientation.is_some(),
            self.position_std.is_some(),
            self.orientation_std.is_some(),
        )
    }
}

/// One pose: the actuated coordinates, what acted on the robot, and the
/// observation of each target (`None` where a target was not seen).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetPose {
    /// Identifier from the file (`pose_id` column), if any.
    pub pose_id: Option<String>,
    /// Actuated coordinates q (rad, m), in the robot's order.
    pub q: Vec<f64>,
    /// One entry per target of the set, in its order.
    pub observations: Vec<Option<TargetObservation>>,
    /// Wrench applied to the tool during the measurement, `[force (N); moment (N.m)]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrench: Option<Vector6<f64>>,
    /// Temperature during the measurement (deg C).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_c: Option<f64>,
}

impl TargetPose {
    /// The pose identifier, or `#k` from its index.
    pub fn label(&self, index: usize) -> String {
        self.pose_id.clone().unwrap_or_else(|| format!("#{index}"))
    }
}

/// Every `<name>_x_mm` column of `table` names a target of `targets`.
fn check_target_columns(
    table: &CsvTable,
    source: &str,
    targets: &[Target],
) -> Result<(), CalibError> {
    for h in table.header() {
        let Some(prefix) = h.strip_suffix("_x_mm") else {
            continue;
        };
        if !targets.iter().any(|t| t.name == prefix) {
            return Err(CalibError::BadMeasurement {
                source_name: source.to_string(),
                line: 1,
                what: format!(
                    "column `{h}`: no target `{prefix}` in the targets description (targets: {})",
                    targets
                        .iter()
                        .map(|t| t.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        }
    }
    Ok(())
}

/// The columns of one target in the CSV format: position (required),
/// orientation, position and orientation standard deviations (optional,
/// each all three or none).
struct TargetColumns {
    position: [usize; 3],
    orientation: Option<[usize; 3]>,
    position_std: Option<[usize; 3]>,
    orientation_std: Option<[usize; 3]>,
}

/// A cell error of the table (`Ok`), or what is wrong with a target's
/// cells on a row (`Err`, for the caller to name the target and line).
type CellProblem = Result<CalibError, String>;

impl TargetColumns {
    /// The columns of `target` in `table`.
    fn find(table: &CsvTable, target: &Target) -> Result<Self, CalibError> {
        let names = |suffixes: [&str; 3]| suffixes.map(|s| format!("{}_{s}", target.name));
        let required = |suffixes: [&str; 3]| -> Result<[usize; 3], CalibError> {
            let names = names(suffixes);
            let mut out = [0; 3];
            for (i, n) in names.iter().enumerate() {
                out[i] = table.column_index(n)?;
            }
            Ok(out)
        };
        let optional = |suffixes: [&str; 3]| -> Result<Option<[usize; 3]>, CalibError> {
            if names(suffixes)
                .iter()
                .all(|n| table.find_column(n).is_none())
            {
                return Ok(None);
            }
            required(suffixes).map(Some)
        };
        Ok(Self {
            position: required(["x_mm", "y_mm", "z_mm"])?,
            orientation: optional(["rx_deg", "ry_deg", "rz_deg"])?,
            position_std: optional(["sx_mm", "sy_mm", "sz_mm"])?,
            orientation_std: optional(["srx_deg", "sry_deg", "srz_deg"])?,
        })
    }

    /// The target's observation on `row` (SI units), `None` when all its
    /// cells are empty (not seen).
    fn observation(
        &self,
        table: &CsvTable,
        row: usize,
    ) -> Result<Option<TargetObservation>, CellProblem> {
        let all: Vec<usize> = std::iter::once(&self.position)
            .chain(&self.orientation)
            .chain(&self.position_std)
            .chain(&self.orientation_std)
            .flatten()
            .copied()
            .collect();
        let empty = all
            .iter()
            .filter(|&&c| table.cell(row, c).is_empty())
            .count();
        if empty == all.len() {
            return Ok(None);
        }
        if empty > 0 {
            return Err(Err(
                "some of its cells are empty (leave all of them empty when it is not seen)".into(),
            ));
        }
        let deg = 1f64.to_radians();
        let vec3 = |cols: &[usize; 3], scale: f64| -> Result<Vector3<f64>, CellProblem> {
            let at = |c: usize| table.f64_at(row, c).map_err(|e| Ok(CalibError::from(e)));
            Ok(Vector3::new(at(cols[0])?, at(cols[1])?, at(cols[2])?) * scale)
        };
        let o = TargetObservation {
            position: vec3(&self.position, 1e-3)?,
            orientation: self
                .orientation
                .as_ref()
                .map(|c| vec3(c, deg))
                .transpose()?,
            position_std: self
                .position_std
                .as_ref()
                .map(|c| vec3(c, 1e-3))
                .transpose()?,
            orientation_std: self
                .orientation_std
                .as_ref()
                .map(|c| vec3(c, deg))
                .transpose()?,
        };
        for s in [o.position_std, o.orientation_std].into_iter().flatten() {
            if s.iter().any(|v| *v <= 0.0) {
                return Err(Err("standard deviations must be > 0".into()));
            }
        }
        Ok(Some(o))
    }
}

fn valid_target_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

/// Checks names and offsets of a targets description.
pub(crate) fn check_targets(source: &str, targets: &[Target]) -> Result<(), CalibError> {
    let bad = |what: String| CalibError::BadMeasurement {
        source_name: source.to_string(),
        line: 0,
        what,
    };
    if targets.is_empty() {
        return Err(bad("no targets".into()));
    }
    for (i, t) in targets.iter().enumerate() {
        if !valid_target_name(&t.name) {
            return Err(bad(format!(
                "target name `{}`: use letters, digits, '-' and '_' only",
                t.name
            )));
        }
        if targets[..i].iter().any(|o| o.name == t.name) {
            return Err(bad(format!("target `{}` is declared twice", t.name)));
        }
        if t.frame.is_empty() {
            return Err(bad(format!("target `{}`: empty frame name", t.name)));
        }
        if !t.offset.iter().all(|v| v.is_finite()) {
            return Err(bad(format!("target `{}`: offset is not finite", t.name)));
        }
        if !t.rotation.coords.iter().all(|v| v.is_finite()) {
            return Err(bad(format!("target `{}`: rotation is not finite", t.name)));
        }
    }
    Ok(())
}

impl MeasurementSet {
    /// Reads flexcal's CSV with per-target columns (see the module docs),
    /// the targets given by their description.
    ///
    /// # Errors
    /// File and CSV errors with line and column, a target without its
    /// position columns, position columns of a target the description does
    /// not know, partly empty cells, and the checks of
    /// [`MeasurementSet::from_poses`].
    pub fn read_targets_csv(path: &Path, targets: &[Target]) -> Result<Self, CalibError> {
        let table = CsvTable::read(path, &CsvOptions::default())?;
        Self::from_targets_table(&table, targets)
    }

    /// Parses the CSV format from text; `source` names it in errors.
    ///
    /// # Errors
    /// As [`MeasurementSet::read_targets_csv`].
    pub fn from_targets_csv_str(
        text: &str,
        source: &str,
        targets: &[Target],
    ) -> Result<Self, CalibError> {
        let table = CsvTable::from_str(text, source, &CsvOptions::default())?;
        Self::from_targets_table(&table, targets)
    }

    fn from_targets_table(table: &CsvTable, targets: &[Target]) -> Result<Self, CalibError> {
        let source = table.path().display().to_string();
        check_targets(&source, targets)?;
        table.require_rows()?;
        let mut q_columns = Vec::new();
        while let Some(c) = table.find_column(&format!("q{}", q_columns.len() + 1)) {
            q_columns.push(c);
        }
        if q_columns.is_empty() {
            table.column_index("q1")?;
        }
        check_target_columns(table, &source, targets)?;
        let groups = targets
            .iter()
            .map(|t| TargetColumns::find(table, t))
            .collect::<Result<Vec<_>, _>>()?;
        let pose_id = table.find_column("pose_id");
        let station = table.find_column("station");
        let mut stations: Vec<String> = Vec::new();
        let mut station_of = Vec::with_capacity(table.len());
        let mut poses = Vec::with_capacity(table.len());
        for row in 0..table.len() {
            let line = table.line_of(row);
            let bad = |what: String| CalibError::BadMeasurement {
                source_name: source.clone(),
                line,
                what,
            };
            let q = q_columns
                .iter()
                .map(|&c| table.f64_at(row, c))
                .collect::<Result<Vec<_>, _>>()?;
            let observations = groups
                .iter()
                .zip(targets)
                .map(|(columns, target)| {
                    columns.observation(table, row).map_err(|e| {
                        e.unwrap_or_else(|what| bad(format!("target `{}`: {what}", target.name)))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            if observations.iter().all(Option::is_none) {
                return Err(bad("no target observed on this pose".into()));
            }
            if let Some(column) = station {
                // Stations by name, in the order they first appear.
                let name = table.cell(row, column).trim();
                if name.is_empty() {
                    return Err(bad("empty `station` cell".into()));
                }
                station_of.push(station_index(&mut stations, name));
            }
            poses.push(TargetPose {
                pose_id: pose_id.map(|c| table.cell(row, c).to_string()),
                q,
                observations,
                wrench: None,
                temperature_c: None,
            });
        }
        let set = Self::from_poses(&source, targets.to_vec(), poses)?;
        if station.is_some() {
            set.with_stations(stations, station_of)
        } else {
            Ok(set)
        }
    }

    /// The set in the CSV format with per-target columns (mm and deg, full
    /// precision; empty cells where a target was not seen). The targets go
    /// to their own file ([`targets_to_toml_string`]).
    pub(crate) fn to_targets_csv_string(&self) -> String {
        let with_ids = self.poses().iter().any(|p| p.pose_id.is_some());
        let mut header: Vec<String> = if with_ids {
            vec!["pose_id".into()]
        } else {
            Vec::new()
        };
        header.extend((1..=self.n_actuated()).map(|i| format!("q{i}")));
        // Which optional groups each target has (from any observation: they
        // are all alike, see `new`).
        let has: Vec<[bool; 3]> = (0..self.targets().len())
            .map(|t| {
                // Every target is observed somewhere (`from_poses`); a subset
                // can leave one unseen: no optional groups then.
                let (o, p, s) = self
                    .observations_of(t)
                    .next()
                    .map_or((false, false, false), TargetObservation::pattern);
                [o, p, s]
            })
            .collect();
        let suffixes: [[&str; 3]; 4] = [
            ["x_mm", "y_mm", "z_mm"],
            ["rx_deg", "ry_deg", "rz_deg"],
            ["sx_mm", "sy_mm", "sz_mm"],
            ["srx_deg", "sry_deg", "srz_deg"],
        ];
        for (t, target) in self.targets().iter().enumerate() {
            for (g, group) in suffixes.iter().enumerate() {
                if g == 0 || has[t][g - 1] {
                    header.extend(group.iter().map(|s| format!("{}_{s}", target.name)));
                }
            }
        }
        let with_stations = self.n_stations() > 1;
        if with_stations {
            header.push("station".into());
        }
        let mut text = header.join(",");
        text.push('\n');
        for (k, pose) in self.poses().iter().enumerate() {
            let mut cells: Vec<String> = Vec::new();
            if with_ids {
                let id = pose
                    .pose_id
                    .clone()
                    .unwrap_or_else(|| format!("pose-{}", k + 1));
                cells.push(id.trim_start_matches('#').replace(',', ";"));
            }
            cells.extend(pose.q.iter().map(|v| v.to_string()));
            for (t, o) in pose.observations.iter().enumerate() {
                let values: [Option<Vector3<f64>>; 4] = match o {
                    Some(o) => [
                        Some(o.position * 1e3),
                        o.orientation.map(|v| v.map(f64::to_degrees)),
                        o.position_std.map(|v| v * 1e3),
                        o.orientation_std.map(|v| v.map(f64::to_degrees)),
                    ],
                    None => [None; 4],
                };
                for (g, v) in values.iter().enumerate() {
                    if g == 0 || has[t][g - 1] {
                        match v {
                            Some(v) => cells.extend(v.iter().map(|x| x.to_string())),
                            None => cells.extend(std::iter::repeat_n(String::new(), 3)),
                        }
                    }
                }
            }
            if with_stations {
                cells.push(self.station_names()[self.station_of(k)].replace(',', ";"));
            }
            let _ = writeln!(text, "{}", cells.join(","));
        }
        text
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetsFile {
    target: Vec<TargetFile>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetFile {
    name: String,
    frame: String,
    offset_mm: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rotation_deg: Option<[f64; 3]>,
    #[serde(default = "identify_by_default")]
    identify: bool,
}

fn identify_by_default() -> bool {
    true
}

/// Parses a targets description (TOML, see the module docs); `source`
/// names it in errors.
///
/// # Errors
/// [`CalibError::BadMeasurement`] with the line of a TOML error, a bad or
/// repeated name, a non-finite offset.
pub fn targets_from_toml_str(text: &str, source: &str) -> Result<Vec<Target>, CalibError> {
    let file: TargetsFile = toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
            .unwrap_or(0);
        CalibError::BadMeasurement {
            source_name: source.to_string(),
            line,
            what: e.message().to_string(),
        }
    })?;
    let targets: Vec<Target> = file
        .target
        .into_iter()
        .map(|t| Target {
            name: t.name,
            frame: t.frame,
            offset: Vector3::from(t.offset_mm) * 1e-3,
            rotation: rotation_from_vector(
                &Vector3::from(t.rotation_deg.unwrap_or_default()).map(f64::to_radians),
            ),
            treatment: if t.identify {
                FrameTreatment::Identify
            } else {
                FrameTreatment::Fixed
            },
        })
        .collect();
    check_targets(source, &targets)?;
    Ok(targets)
}

/// Reads a targets description file (TOML, see the module docs).
///
/// # Errors
/// As [`targets_from_toml_str`], and the file's I/O error.
pub fn read_targets(path: &Path) -> Result<Vec<Target>, CalibError> {
    let text = flexcal_io::read_to_string(path)?;
    targets_from_toml_str(&text, &path.display().to_string())
}

/// The targets description as TOML (mm).
///
/// # Errors
/// [`CalibError::Serialise`].
pub fn targets_to_toml_string(targets: &[Target]) -> Result<String, CalibError> {
    let file = TargetsFile {
        target: targets
            .iter()
            .map(|t| TargetFile {
                name: t.name.clone(),
                frame: t.frame.clone(),
                offset_mm: (t.offset * 1e3).into(),
                rotation_deg: (t.rotation != UnitQuaternion::identity()).then(|| {
                    vector_from_rotation(&t.rotation)
                        .map(f64::to_degrees)
                        .into()
                }),
                identify: t.treatment == FrameTreatment::Identify,
            })
            .collect(),
    };
    toml::to_string(&file).map_err(|e| CalibError::Serialise {
        what: "targets description",
        message: e.to_string(),
    })
}

/// Writes a targets description file (atomically).
///
/// # Errors
/// [`CalibError::Io`] naming the file, [`CalibError::Serialise`].
pub fn write_targets(path: &Path, targets: &[Target]) -> Result<(), CalibError> {
    write_atomic(path, targets_to_toml_string(targets)?)?;
    Ok(())
}
