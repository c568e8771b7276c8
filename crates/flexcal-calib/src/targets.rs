//! Several measured targets per pose, each on a named frame of the robot:
//! laser-tracker reflectors on a tool, markers on the two hands of a
//! two-armed robot, a probe on a link. The one-target
//! [`MeasurementSet`] is the special case of one target on the TCP
//! ([`TargetMeasurementSet::from_measurement_set`]).
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
//! optional `pose_id`, and per target `<name>_x_mm, <name>_y_mm,
//! <name>_z_mm` (position in the measurement frame), optionally
//! `<name>_rx_deg..` (rotation vector), `<name>_sx_mm..` (standard
//! deviations) and `<name>_srx_deg..`. A target not seen on a pose has empty
//! cells on that row (all of its cells).

use std::borrow::Cow;
use std::fmt::Write as _;
use std::path::Path;

use flexcal_io::{CsvOptions, CsvTable, write_atomic};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::CalibError;
use crate::frames::TCP_FRAME;
use crate::geometry::{rotation_from_vector, vector_from_rotation};
use crate::measurement::MeasurementSet;
use crate::measurement::{
    PoseSet, StationPool, check_same_actuated, check_stations, first_to_pool, station_index,
};
use crate::options::FrameTreatment;

/// A measured target fixed to a frame of the robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Target {
    /// Name, used as the prefix of its CSV columns and in the names of its
    /// unknowns (`target.<name>.x`).
    pub name: String,
    /// Frame it is fixed to: a frame name of the robot, or [`TCP_FRAME`].
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
}

/// One pose: the actuated coordinates and the observation of each target
/// (`None` where a target was not seen).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetPose {
    /// Identifier from the file (`pose_id` column), if any.
    pub pose_id: Option<String>,
    /// Actuated coordinates q (rad, m), in the robot's order.
    pub q: Vec<f64>,
    /// One entry per target of the set, in its order.
    pub observations: Vec<Option<TargetObservation>>,
}

impl TargetPose {
    /// The pose identifier, or `#k` from its index.
    pub fn label(&self, index: usize) -> String {
        self.pose_id.clone().unwrap_or_else(|| format!("#{index}"))
    }
}

impl PoseSet for TargetMeasurementSet {
    fn n_poses(&self) -> usize {
        self.len()
    }
    fn n_observations(&self) -> Option<usize> {
        Some(TargetMeasurementSet::n_observations(self))
    }
    fn source(&self) -> &str {
        &self.source
    }
    fn excluding(&self, labels: &[String]) -> Result<Self, CalibError> {
        TargetMeasurementSet::excluding(self, labels)
    }
}

/// A validated set of poses measured on several targets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetMeasurementSet {
    /// Where the measurements come from (file name), used in messages.
    pub source: String,
    targets: Vec<Target>,
    poses: Vec<TargetPose>,
    /// Name of each station (placement of the instrument), in order; empty
    /// for one station named after the source.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    stations: Vec<String>,
    /// Station of each pose (index into `stations`); empty for one station.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    station_of: Vec<usize>,
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
fn check_targets(source: &str, targets: &[Target]) -> Result<(), CalibError> {
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

impl TargetMeasurementSet {
    /// Validates and wraps targets and poses.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] naming the target or pose: no target,
    /// a name that cannot prefix a column, a name twice, no pose, differing
    /// numbers of coordinates, a pose with the wrong number of observations
    /// or none at all, a target never observed, a non-finite value, a
    /// standard deviation not `> 0`, orientation or standard deviations on
    /// some observations of a target only.
    pub fn new(
        source: &str,
        targets: Vec<Target>,
        poses: Vec<TargetPose>,
    ) -> Result<Self, CalibError> {
        check_targets(source, &targets)?;
        let bad = |k: usize, what: String| CalibError::BadMeasurement {
            source_name: source.to_string(),
            line: 0,
            what: format!("pose {k}: {what}"),
        };
        let Some(first) = poses.first() else {
            return Err(CalibError::BadMeasurement {
                source_name: source.to_string(),
                line: 0,
                what: "no measurements".into(),
            });
        };
        let n = first.q.len();
        let mut pattern: Vec<Option<(bool, bool, bool)>> = vec![None; targets.len()];
        for (k, pose) in poses.iter().enumerate() {
            if pose.q.len() != n {
                return Err(bad(
                    k,
                    format!(
                        "{} actuated coordinates, the first pose has {n}",
                        pose.q.len()
                    ),
                ));
            }
            if !pose.q.iter().all(|v| v.is_finite()) {
                return Err(bad(k, "an actuated coordinate is NaN or infinite".into()));
            }
            if pose.observations.len() != targets.len() {
                return Err(bad(
                    k,
                    format!(
                        "{} observations for {} targets",
                        pose.observations.len(),
                        targets.len()
                    ),
                ));
            }
            if pose.observations.iter().all(Option::is_none) {
                return Err(bad(k, "no target observed".into()));
            }
            for (t, o) in pose.observations.iter().enumerate() {
                let Some(o) = o else { continue };
                let name = &targets[t].name;
                let finite = o.position.iter().all(|v| v.is_finite())
                    && o.orientation
                        .is_none_or(|r| r.iter().all(|v| v.is_finite()));
                if !finite {
                    return Err(bad(
                        k,
                        format!("target `{name}`: a value is NaN or infinite"),
                    ));
                }
                for s in [o.position_std, o.orientation_std].into_iter().flatten() {
                    if !s.iter().all(|v| v.is_finite() && *v > 0.0) {
                        return Err(bad(
                            k,
                            format!(
                                "target `{name}`: standard deviations must be finite and > 0, found {s:?}"
                            ),
                        ));
                    }
                }
                let has = (
                    o.orientation.is_some(),
                    o.position_std.is_some(),
                    o.orientation_std.is_some(),
                );
                match pattern[t] {
                    None => pattern[t] = Some(has),
                    Some(p) if p != has => {
                        return Err(bad(
                            k,
                            format!(
                                "target `{name}`: orientation and standard deviations must be given on all its observations or none"
                            ),
                        ));
                    }
                    Some(_) => {}
                }
            }
        }
        if let Some(t) = pattern.iter().position(Option::is_none) {
            return Err(CalibError::BadMeasurement {
                source_name: source.to_string(),
                line: 0,
                what: format!("target `{}` is observed on no pose", targets[t].name),
            });
        }
        Ok(Self {
            source: source.to_string(),
            targets,
            poses,
            stations: Vec::new(),
            station_of: Vec::new(),
        })
    }

    /// The same poses as stations named `stations` (placements of the
    /// instrument, each with its own measurement frame), pose `k` measured
    /// from station `station_of[k]`.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] when `station_of` does not have one
    /// entry per pose, names a station that does not exist, or a station
    /// has no pose.
    pub fn with_stations(
        mut self,
        stations: Vec<String>,
        station_of: Vec<usize>,
    ) -> Result<Self, CalibError> {
        check_stations(&self.source, &stations, &station_of, self.len())?;
        if stations.len() <= 1 {
            self.stations.clear();
            self.station_of.clear();
        } else {
            self.stations = stations;
            self.station_of = station_of;
        }
        Ok(self)
    }

    /// Joins sets of the same targets (names, frames and offsets) measured
    /// from several stations: each set keeps its own measurement frame (its
    /// stations, when it has several), the robot and the targets' offsets
    /// are shared. With more than one station the pose labels are prefixed
    /// by the station's number, `s2:p17` (pose `p17` of the second), as
    /// [`crate::MeasurementSet::pooled`] does; a station name met before is
    /// made unique with its number, `markers.csv (s2)`.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] naming the set: no sets, a different
    /// number of actuated coordinates, or targets that differ (a marker
    /// glued elsewhere between stations is another target).
    pub fn pooled(sets: &[TargetMeasurementSet]) -> Result<Self, CalibError> {
        let first = first_to_pool(sets)?;
        if sets.len() == 1 {
            return Ok(first.clone());
        }
        let mut pool = StationPool::default();
        let mut poses = Vec::new();
        for set in sets {
            check_same_actuated(
                (&set.source, set.n_actuated()),
                (&first.source, first.n_actuated()),
            )?;
            let same = set.targets.len() == first.targets.len()
                && set.targets.iter().zip(&first.targets).all(|(a, b)| {
                    a.name == b.name
                        && a.frame == b.frame
                        && a.treatment == b.treatment
                        && (a.offset - b.offset).norm() < 1e-12
                });
            if !same {
                return Err(CalibError::BadMeasurement {
                    source_name: set.source.clone(),
                    line: 0,
                    what: format!(
                        "its targets differ from those of {} (names, frames, offsets): pooled sets must measure the same targets",
                        first.source
                    ),
                });
            }
            let offset = pool.add_stations(set.station_names());
            for (k, pose) in set.poses.iter().enumerate() {
                let mut pose = pose.clone();
                pose.pose_id = Some(pool.add_pose(offset + set.station_of(k), pose.label(k)));
                poses.push(pose);
            }
        }
        let source: Vec<&str> = sets.iter().map(|s| s.source.as_str()).collect();
        Self::new(&source.join(" + "), first.targets.clone(), poses)?
            .with_stations(pool.stations, pool.station_of)
    }

    /// Number of stations (at least 1).
    pub fn n_stations(&self) -> usize {
        self.stations.len().max(1)
    }
    /// Names of the stations, in order (a file name, or the `station`
    /// column's values).
    pub fn station_names(&self) -> &[String] {
        if self.stations.is_empty() {
            std::slice::from_ref(&self.source)
        } else {
            &self.stations
        }
    }
    /// Station (0-based index into [`TargetMeasurementSet::station_names`])
    /// of pose `k`.
    pub fn station_of(&self, k: usize) -> usize {
        self.station_of.get(k).copied().unwrap_or(0)
    }

    /// The poses of station `s` as a set of their own (one station, named
    /// after it), or `None` when this set has none of them (a subset can
    /// leave a station without poses).
    pub fn station_poses(&self, s: usize) -> Option<Self> {
        let poses: Vec<TargetPose> = (0..self.len())
            .filter(|&k| self.station_of(k) == s)
            .map(|k| self.poses[k].clone())
            .collect();
        Self::new(self.station_names().get(s)?, self.targets.clone(), poses).ok()
    }

    /// The one-target set as a set of one target named `name` on the TCP
    /// ([`TCP_FRAME`]), its nominal pose the set's nominal target (the
    /// identity without one), with the set's stations.
    ///
    /// # Errors
    /// As [`TargetMeasurementSet::new`] (a bad name).
    pub fn from_measurement_set(set: &MeasurementSet, name: &str) -> Result<Self, CalibError> {
        let nominal = set.nominal_target.unwrap_or_else(Isometry3::identity);
        let poses = set
            .measurements()
            .iter()
            .map(|m| TargetPose {
                pose_id: m.pose_id.clone(),
                q: m.q.clone(),
                observations: vec![Some(TargetObservation {
                    position: m.position,
                    orientation: m.orientation,
                    position_std: m.position_std,
                    orientation_std: m.orientation_std,
                })],
            })
            .collect();
        let target = Target {
            rotation: nominal.rotation,
            ..Target::new(name, TCP_FRAME, nominal.translation.vector)
        };
        let mut converted = Self::new(&set.source, vec![target], poses)?;
        // The stations as they are, also one a subset left without poses
        // (its unknowns keep their names).
        if set.n_stations() > 1 {
            converted.stations = set.station_names().to_vec();
            converted.station_of = (0..set.len()).map(|k| set.station_of(k)).collect();
        }
        Ok(converted)
    }

    /// The label of every pose, in order ([`TargetPose::label`]): what
    /// reports print and [`TargetMeasurementSet::excluding`] takes.
    pub fn labels(&self) -> Vec<String> {
        self.poses
            .iter()
            .enumerate()
            .map(|(k, p)| p.label(k))
            .collect()
    }

    /// The same set without the observations `which` (pose, target): each
    /// becomes unseen.
    pub(crate) fn hide_observations(&mut self, which: &[(usize, usize)]) {
        for &(k, t) in which {
            self.poses[k].observations[t] = None;
        }
    }

    /// The same set with every pose's label written into its `pose_id`
    /// (`#k` for a pose without one), so that a subset keeps the labels of
    /// this set.
    pub(crate) fn labelled(&self) -> Self {
        let mut set = self.clone();
        for (k, p) in set.poses.iter_mut().enumerate() {
            p.pose_id.get_or_insert_with(|| format!("#{k}"));
        }
        set
    }

    /// The targets, in the order of [`TargetPose::observations`].
    pub fn targets(&self) -> &[Target] {
        &self.targets
    }
    /// The poses.
    pub fn poses(&self) -> &[TargetPose] {
        &self.poses
    }
    /// Number of poses.
    pub fn len(&self) -> usize {
        self.poses.len()
    }
    /// Always false: a set holds at least one pose.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }
    /// Number of actuated coordinates per pose.
    pub fn n_actuated(&self) -> usize {
        self.poses[0].q.len()
    }
    /// Index of a target by name.
    pub fn target_index(&self, name: &str) -> Option<usize> {
        self.targets.iter().position(|t| t.name == name)
    }
    /// Number of observations (pose, target) in the set.
    /// Whether target `t`'s observations carry orientations (all of them
    /// or none, [`TargetMeasurementSet::new`]; false for a target no pose
    /// sees).
    pub fn target_has_orientation(&self, t: usize) -> bool {
        self.observations_of(t).next().is_some()
            && self.observations_of(t).all(|o| o.orientation.is_some())
    }

    /// Whether every observation carries position standard deviations
    /// and, where `orientation[t]`, orientation ones: whether weights from
    /// the file are absolute.
    pub fn has_standard_deviations(&self, orientation: &[bool]) -> bool {
        (0..self.targets.len()).all(|t| {
            self.observations_of(t).all(|o| {
                o.position_std.is_some()
                    && (!orientation.get(t).copied().unwrap_or(false)
                        || o.orientation_std.is_some())
            })
        })
    }

    /// The observations of target `t`, pose by pose where seen.
    pub fn observations_of(&self, t: usize) -> impl Iterator<Item = &TargetObservation> + '_ {
        self.poses
            .iter()
            .filter_map(move |p| p.observations.get(t).and_then(Option::as_ref))
    }

    /// The actuated coordinates of every pose (rad or m), in order.
    pub fn configurations(&self) -> Vec<&[f64]> {
        self.poses.iter().map(|p| p.q.as_slice()).collect()
    }

    /// Number of (pose, target) observations.
    pub fn n_observations(&self) -> usize {
        self.poses
            .iter()
            .map(|p| p.observations.iter().flatten().count())
            .sum()
    }
    /// The poses at `indices` with the same targets, for splitting a set
    /// (model selection's folds). A target that none of the picked poses
    /// observes stays in the set: its offset then has no influence on a
    /// fit.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] when an index is out of range or the
    /// subset is empty.
    pub fn subset(&self, indices: &[usize]) -> Result<Self, CalibError> {
        let bad = |what: String| CalibError::BadMeasurement {
            source_name: self.source.clone(),
            line: 0,
            what,
        };
        if indices.is_empty() {
            return Err(bad("no measurements".into()));
        }
        let poses = indices
            .iter()
            .map(|&i| {
                self.poses.get(i).cloned().ok_or_else(|| {
                    bad(format!(
                        "pose index {i} out of range (set has {})",
                        self.len()
                    ))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        // The poses were checked when the set was made. The subset keeps
        // every station (so its unknowns keep their names), even one that
        // none of the picked poses belongs to.
        Ok(Self {
            source: self.source.clone(),
            targets: self.targets.clone(),
            poses,
            stations: self.stations.clone(),
            station_of: if self.stations.is_empty() {
                Vec::new()
            } else {
                indices.iter().map(|&i| self.station_of[i]).collect()
            },
        })
    }

    /// The same poses with other targets (same names and order of
    /// observations): another frame or offset, or a fixed offset.
    ///
    /// # Errors
    /// As [`TargetMeasurementSet::new`], and a target list that does not
    /// match the set's names.
    pub fn with_targets(&self, targets: Vec<Target>) -> Result<Self, CalibError> {
        let same = targets.len() == self.targets.len()
            && targets
                .iter()
                .zip(&self.targets)
                .all(|(a, b)| a.name == b.name);
        if !same {
            return Err(CalibError::BadMeasurement {
                source_name: self.source.clone(),
                line: 0,
                what: "the new targets must have the names of the set's, in its order".into(),
            });
        }
        let mut set = Self::new(&self.source, targets, self.poses.clone())?;
        set.stations = self.stations.clone();
        set.station_of = self.station_of.clone();
        Ok(set)
    }

    /// Reads flexcal's CSV with per-target columns (see the module docs),
    /// the targets given by their description.
    ///
    /// # Errors
    /// File and CSV errors with line and column, a target without its
    /// position columns, position columns of a target the description does
    /// not know, partly empty cells, and the checks of
    /// [`TargetMeasurementSet::new`].
    pub fn read_csv(path: &Path, targets: &[Target]) -> Result<Self, CalibError> {
        let table = CsvTable::read(path, &CsvOptions::default())?;
        Self::from_table(&table, targets)
    }

    /// Parses the CSV format from text; `source` names it in errors.
    ///
    /// # Errors
    /// As [`TargetMeasurementSet::read_csv`].
    pub fn from_csv_str(text: &str, source: &str, targets: &[Target]) -> Result<Self, CalibError> {
        let table = CsvTable::from_str(text, source, &CsvOptions::default())?;
        Self::from_table(&table, targets)
    }

    fn from_table(table: &CsvTable, targets: &[Target]) -> Result<Self, CalibError> {
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
            });
        }
        let set = Self::new(&source, targets.to_vec(), poses)?;
        if station.is_some() {
            set.with_stations(stations, station_of)
        } else {
            Ok(set)
        }
    }

    /// The set in the CSV format (mm and deg, full precision; empty cells
    /// where a target was not seen). The targets go to their own file
    /// ([`targets_to_toml_string`]).
    pub fn to_csv_string(&self) -> String {
        let with_ids = self.poses.iter().any(|p| p.pose_id.is_some());
        let mut header: Vec<String> = if with_ids {
            vec!["pose_id".into()]
        } else {
            Vec::new()
        };
        header.extend((1..=self.n_actuated()).map(|i| format!("q{i}")));
        // Which optional groups each target has (from any observation: they
        // are all alike, see `new`).
        let has: Vec<[bool; 3]> = (0..self.targets.len())
            .map(|t| {
                let o = self
                    .poses
                    .iter()
                    .find_map(|p| p.observations[t].as_ref())
                    .expect("every target is observed somewhere");
                [
                    o.orientation.is_some(),
                    o.position_std.is_some(),
                    o.orientation_std.is_some(),
                ]
            })
            .collect();
        let suffixes: [[&str; 3]; 4] = [
            ["x_mm", "y_mm", "z_mm"],
            ["rx_deg", "ry_deg", "rz_deg"],
            ["sx_mm", "sy_mm", "sz_mm"],
            ["srx_deg", "sry_deg", "srz_deg"],
        ];
        for (t, target) in self.targets.iter().enumerate() {
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
        for (k, pose) in self.poses.iter().enumerate() {
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

    /// Writes the set in the CSV format (atomically).
    ///
    /// # Errors
    /// [`CalibError::Io`] naming the file.
    pub fn write_csv(&self, path: &Path) -> Result<(), CalibError> {
        write_atomic(path, self.to_csv_string())?;
        Ok(())
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

/// The kind of a measurement set, as the checks that read it by pose need it.
#[derive(Debug, Clone, Copy)]
pub enum SetKind<'a> {
    /// One target per pose, on the TCP.
    OneTarget(&'a MeasurementSet),
    /// Several targets per pose.
    Targets(&'a TargetMeasurementSet),
}

/// A set of measurements `calibrate` and the checks take: one target per
/// pose ([`MeasurementSet`], read as one target `tcp` on the TCP) or
/// several ([`TargetMeasurementSet`]).
pub trait Observations {
    /// The observations as targets seen at poses.
    ///
    /// # Errors
    /// As [`TargetMeasurementSet::from_measurement_set`].
    fn observations(&self) -> Result<Cow<'_, TargetMeasurementSet>, CalibError>;
    /// Which kind of set it is.
    fn kind(&self) -> SetKind<'_>;
}

impl Observations for MeasurementSet {
    fn observations(&self) -> Result<Cow<'_, TargetMeasurementSet>, CalibError> {
        TargetMeasurementSet::from_measurement_set(self, TCP_FRAME).map(Cow::Owned)
    }
    fn kind(&self) -> SetKind<'_> {
        SetKind::OneTarget(self)
    }
}

impl Observations for TargetMeasurementSet {
    fn observations(&self) -> Result<Cow<'_, TargetMeasurementSet>, CalibError> {
        Ok(Cow::Borrowed(self))
    }
    fn kind(&self) -> SetKind<'_> {
        SetKind::Targets(self)
    }
}
