//! Measurement sets (targets seen at poses, grouped by station) and the
//! one-target file formats: flexcal's own CSV and the IPA laser-tracker
//! export. The format with several targets per pose is in
//! [`crate::targets`].

use std::fmt::Write as _;
use std::path::Path;

use flexcal_io::{CsvOptions, CsvTable, write_atomic};
use nalgebra::{Isometry3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6};

use serde::{Deserialize, Serialize};

use crate::error::CalibError;
use crate::frames::TCP_FRAME;
use crate::geometry::vector_from_rotation;
use crate::targets::{Target, TargetObservation, TargetPose, check_targets};

/// One measured pose: the actuated coordinates and what the measurement
/// system saw of the target on the tool, in the measurement frame M.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Identifier from the file (`pose_id` column), if any.
    pub pose_id: Option<String>,
    /// Actuated coordinates q (rad for revolute joints, m for prismatic
    /// joints and screws), in the robot's order.
    pub q: Vec<f64>,
    /// Measured target position `p_M_target` (m).
    pub position: Vector3<f64>,
    /// Measured target orientation as the rotation vector of `R_M_target`
    /// (rad), when the system measures orientation.
    pub orientation: Option<Vector3<f64>>,
    /// Standard deviation of each position axis (m).
    pub position_std: Option<Vector3<f64>>,
    /// Standard deviation of each orientation axis (rad).
    pub orientation_std: Option<Vector3<f64>>,
    /// Wrench applied to the tool during the measurement, `[force (N); moment (N.m)]`.
    pub wrench: Option<Vector6<f64>>,
    /// Temperature during the measurement (deg C).
    pub temperature_c: Option<f64>,
}

impl Measurement {
    /// A position-only measurement with nothing optional.
    pub fn new(q: Vec<f64>, position: Vector3<f64>) -> Self {
        Self {
            pose_id: None,
            q,
            position,
            orientation: None,
            position_std: None,
            orientation_std: None,
            wrench: None,
            temperature_c: None,
        }
    }

    /// The pose identifier, or `#k` from its index.
    pub fn label(&self, index: usize) -> String {
        self.pose_id.clone().unwrap_or_else(|| format!("#{index}"))
    }

    /// What the measurement system saw of the target.
    pub fn observation(&self) -> TargetObservation {
        TargetObservation {
            position: self.position,
            orientation: self.orientation,
            position_std: self.position_std,
            orientation_std: self.orientation_std,
        }
    }

    /// The pose of a one-target set this row is.
    fn into_pose(self) -> TargetPose {
        let observation = self.observation();
        TargetPose {
            pose_id: self.pose_id,
            q: self.q,
            observations: vec![Some(observation)],
            wrench: self.wrench,
            temperature_c: self.temperature_c,
        }
    }
}

/// The name of the one target of a set of one target per pose (a
/// one-target CSV, an IPA export, [`MeasurementSet::new`]): the target on
/// the TCP, not named in reports.
pub const TCP_TARGET: &str = "tcp";

/// A validated set of measurements: targets (named frames of the robot
/// with an offset) seen at poses, each pose with its actuated coordinates,
/// optionally the wrench on the tool and the temperature, and one optional
/// observation per target. One target per pose, on the TCP, is the case of
/// one target named [`TCP_TARGET`] ([`MeasurementSet::new`],
/// [`MeasurementSet::read_csv`], [`MeasurementSet::read_ipa`]); several
/// come from a targets description ([`MeasurementSet::read_targets_csv`],
/// [`MeasurementSet::from_poses`]).
///
/// Every pose has the same number of actuated coordinates and finite
/// values, and each target carries an orientation (and likewise standard
/// deviations) on all its observations or on none.
///
/// Each pose belongs to a *station*: one placement of the measurement
/// system, with its own measurement frame `x_meas_base` (a laser tracker
/// moved to see another part of the workspace, or a campaign of another
/// day). A set read from one file without a `station` column is one
/// station; [`MeasurementSet::pooled`] joins sets as stations of one
/// identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasurementSet {
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

/// Several targets per pose: the one measurement set type.
#[deprecated(note = "use `MeasurementSet`: one type holds one target per pose and several")]
pub type TargetMeasurementSet = MeasurementSet;

/// The joint columns of an IPA laser-tracker export
/// ([`MeasurementSet::read_ipa`]), in the UR10's joint order (rad).
pub const IPA_JOINT_COLUMNS: [&str; 6] = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
];

/// The stations of sets being pooled, and the pooled station of each pose
/// so far.
#[derive(Default)]
struct StationPool {
    /// Station names, unique (the CSV tells stations by name): a name met
    /// before gets its number, `markers.csv (s2)`.
    stations: Vec<String>,
    /// Pooled station of each pose added.
    station_of: Vec<usize>,
}

impl StationPool {
    /// Adds a set's stations; returns the pooled index of its first.
    fn add_stations(&mut self, names: &[String]) -> usize {
        let offset = self.stations.len();
        for name in names {
            let unique = if self.stations.contains(name) {
                format!("{name} (s{})", self.stations.len() + 1)
            } else {
                name.clone()
            };
            self.stations.push(unique);
        }
        offset
    }

    /// Adds a pose of pooled station `station`; returns its pooled label,
    /// `s2:line 534` for `label` `line 534` of the second station.
    fn add_pose(&mut self, station: usize, label: String) -> String {
        self.station_of.push(station);
        format!("s{}:{label}", station + 1)
    }
}

/// The index of station `name` in `names`, appended when new: stations by
/// name in the order they first appear (a `station` column).
pub(crate) fn station_index(names: &mut Vec<String>, name: &str) -> usize {
    names.iter().position(|n| n == name).unwrap_or_else(|| {
        names.push(name.to_string());
        names.len() - 1
    })
}

/// Checks poses of `targets`: same number of coordinates, one observation
/// per target and at least one seen, finite values, standard deviations
/// `> 0`, each target's optional groups on all its observations or none,
/// every target seen. Messages name the pose and, but for the one target
/// of a one-target set, the target.
fn check_poses(source: &str, targets: &[Target], poses: &[TargetPose]) -> Result<(), CalibError> {
    let bad = |k: usize, what: String| CalibError::BadMeasurement {
        source_name: source.to_string(),
        line: 0,
        what: format!("pose {k}: {what}"),
    };
    let one_target = targets.len() == 1 && targets[0].name == TCP_TARGET;
    let about = |t: usize, what: &str| {
        if one_target {
            what.to_string()
        } else {
            format!("target `{}`: {what}", targets[t].name)
        }
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
        let finite = pose.q.iter().all(|v| v.is_finite())
            && pose.wrench.is_none_or(|w| w.iter().all(|v| v.is_finite()))
            && pose.temperature_c.is_none_or(f64::is_finite);
        if !finite {
            return Err(bad(k, "a value is NaN or infinite".into()));
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
            let finite = o.position.iter().all(|v| v.is_finite())
                && o.orientation
                    .is_none_or(|r| r.iter().all(|v| v.is_finite()));
            if !finite {
                return Err(bad(k, about(t, "a value is NaN or infinite")));
            }
            for s in [o.position_std, o.orientation_std].into_iter().flatten() {
                if !s.iter().all(|v| v.is_finite() && *v > 0.0) {
                    let what = format!("standard deviations must be finite and > 0, found {s:?}");
                    return Err(bad(k, about(t, &what)));
                }
            }
            match pattern[t] {
                None => pattern[t] = Some(o.pattern()),
                Some(p) if p != o.pattern() => {
                    return Err(bad(
                        k,
                        about(
                            t,
                            "orientation and standard deviations must be given on all observations or none",
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
    Ok(())
}

impl MeasurementSet {
    /// Validates and wraps measurements of one target per pose: one target
    /// [`TCP_TARGET`] on the TCP, at the TCP (see
    /// [`MeasurementSet::set_nominal_target`]).
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] naming the pose: no measurement, differing
    /// numbers of coordinates, a non-finite value, orientation or standard
    /// deviations on some poses only, a standard deviation not `> 0`.
    pub fn new(source: &str, measurements: Vec<Measurement>) -> Result<Self, CalibError> {
        Self::from_poses(
            source,
            vec![Target::new(TCP_TARGET, TCP_FRAME, Vector3::zeros())],
            measurements
                .into_iter()
                .map(Measurement::into_pose)
                .collect(),
        )
    }

    /// Validates and wraps targets and the poses they were seen at.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] naming the target or pose: no target,
    /// a name that cannot prefix a column, a name twice, no pose, differing
    /// numbers of coordinates, a pose with the wrong number of observations
    /// or none at all, a target never observed, a non-finite value, a
    /// standard deviation not `> 0`, orientation or standard deviations on
    /// some observations of a target only.
    pub fn from_poses(
        source: &str,
        targets: Vec<Target>,
        poses: Vec<TargetPose>,
    ) -> Result<Self, CalibError> {
        check_targets(source, &targets)?;
        check_poses(source, &targets, &poses)?;
        Ok(Self {
            source: source.to_string(),
            targets,
            poses,
            stations: Vec::new(),
            station_of: Vec::new(),
        })
    }

    /// Whether this is a set of one target per pose on the TCP, named
    /// [`TCP_TARGET`]: what a one-target file reads into, written back in
    /// the one-target CSV and not named in reports.
    pub fn is_one_target(&self) -> bool {
        self.targets.len() == 1
            && self.targets[0].name == TCP_TARGET
            && self.targets[0].frame == TCP_FRAME
    }

    /// The nominal pose `x_tcp_target` of the one target of a one-target
    /// set when it is not the TCP itself (the IPA probe offset), `None`
    /// otherwise: the identification starts from it.
    pub fn nominal_target(&self) -> Option<Isometry3<f64>> {
        if !self.is_one_target() {
            return None;
        }
        let pose = self.targets[0].pose();
        (pose != Isometry3::identity()).then_some(pose)
    }

    /// Sets the nominal pose of the first target in its frame (of the one
    /// target of a one-target set, `x_tcp_target`: the IPA probe offset).
    pub fn set_nominal_target(&mut self, x_frame_target: Isometry3<f64>) {
        let target = &mut self.targets[0];
        target.offset = x_frame_target.translation.vector;
        target.rotation = x_frame_target.rotation;
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
        let bad = |what: String| self.error(what);
        if station_of.len() != self.len() {
            return Err(bad(format!(
                "{} station indices for {} poses",
                station_of.len(),
                self.len()
            )));
        }
        if let Some(k) = station_of.iter().position(|&s| s >= stations.len()) {
            return Err(bad(format!(
                "pose {k}: station {} of {}",
                station_of[k] + 1,
                stations.len()
            )));
        }
        if let Some(s) = (0..stations.len()).find(|s| !station_of.contains(s)) {
            return Err(bad(format!("station `{}` has no pose", stations[s])));
        }
        self.stations = stations;
        self.station_of = station_of;
        Ok(self)
    }

    /// Joins sets of the same targets (names, frames and offsets) of one
    /// robot measured from several stations: each set keeps its own
    /// measurement frame (its stations, when it has several), the robot
    /// and the targets' offsets are shared. With more than one station the
    /// pose labels are prefixed by the station's number, `s2:line 534`
    /// (pose `line 534` of the second); a station name met before is made
    /// unique with its number, `B.csv (s2)`.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] naming the set: no sets, a different
    /// number of actuated coordinates, orientations or standard deviations
    /// in some sets only, or targets that differ (a target remounted
    /// between stations is another target).
    pub fn pooled(sets: &[MeasurementSet]) -> Result<Self, CalibError> {
        let Some(first) = sets.first() else {
            return Err(CalibError::BadMeasurement {
                source_name: "pooled measurements".into(),
                line: 0,
                what: "no measurement sets to pool".into(),
            });
        };
        if sets.len() == 1 {
            return Ok(first.clone());
        }
        let mut pool = StationPool::default();
        let mut poses = Vec::new();
        for set in sets {
            set.check_poolable_with(first)?;
            let offset = pool.add_stations(set.station_names());
            for (k, pose) in set.poses.iter().enumerate() {
                let mut pose = pose.clone();
                pose.pose_id = Some(pool.add_pose(offset + set.station_of(k), pose.label(k)));
                poses.push(pose);
            }
        }
        let source: Vec<&str> = sets.iter().map(|s| s.source.as_str()).collect();
        Self::from_poses(&source.join(" + "), first.targets.clone(), poses)?
            .with_stations(pool.stations, pool.station_of)
    }

    /// An error about this set (no line): `what` is wrong.
    fn error(&self, what: String) -> CalibError {
        CalibError::BadMeasurement {
            source_name: self.source.clone(),
            line: 0,
            what,
        }
    }

    /// Checks that this set measures what `first` does, to pool them.
    fn check_poolable_with(&self, first: &MeasurementSet) -> Result<(), CalibError> {
        let bad = |what: String| self.error(what);
        if self.n_actuated() != first.n_actuated() {
            return Err(bad(format!(
                "{} actuated coordinates, {} has {}",
                self.n_actuated(),
                first.source,
                first.n_actuated()
            )));
        }
        let same = self.targets.len() == first.targets.len()
            && self.targets.iter().zip(&first.targets).all(|(a, b)| {
                a.name == b.name
                    && a.frame == b.frame
                    && a.treatment == b.treatment
                    && (a.offset - b.offset).norm() < 1e-9
                    && a.rotation.angle_to(&b.rotation) < 1e-9
            });
        if !same {
            return Err(bad(format!(
                "its targets differ from those of {} (names, frames, offsets): pooled sets must measure the same targets",
                first.source
            )));
        }
        let patterns = |set: &MeasurementSet| -> Vec<Option<(bool, bool, bool)>> {
            (0..set.targets.len())
                .map(|t| {
                    set.observations_of(t)
                        .next()
                        .map(TargetObservation::pattern)
                })
                .collect()
        };
        if patterns(self) != patterns(first) {
            return Err(bad(format!(
                "orientations or standard deviations are measured in {} and not here, or the reverse: pooled sets must measure the same",
                first.source
            )));
        }
        Ok(())
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
    /// Station (0-based index into [`MeasurementSet::station_names`]) of
    /// pose `k`.
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
        Self::from_poses(self.station_names().get(s)?, self.targets.clone(), poses).ok()
    }

    /// The rows of the set, one per observation (a target seen at a pose),
    /// pose by pose and target by target: for a one-target set, the
    /// measurement of each pose, as [`MeasurementSet::new`] took them.
    pub fn measurements(&self) -> Vec<Measurement> {
        self.poses
            .iter()
            .flat_map(|p| {
                p.observations.iter().flatten().map(|o| Measurement {
                    pose_id: p.pose_id.clone(),
                    q: p.q.clone(),
                    position: o.position,
                    orientation: o.orientation,
                    position_std: o.position_std,
                    orientation_std: o.orientation_std,
                    wrench: p.wrench,
                    temperature_c: p.temperature_c,
                })
            })
            .collect()
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
    pub fn n_observations(&self) -> usize {
        self.poses
            .iter()
            .map(|p| p.observations.iter().flatten().count())
            .sum()
    }
    /// Whether every target's observations carry orientations.
    pub fn has_orientation(&self) -> bool {
        (0..self.targets.len()).all(|t| self.target_has_orientation(t))
    }
    /// Whether every observation carries position standard deviations.
    pub fn has_position_std(&self) -> bool {
        self.has_standard_deviations(&[])
    }
    /// Whether every observation carries orientation standard deviations.
    pub fn has_orientation_std(&self) -> bool {
        self.has_standard_deviations(&vec![true; self.targets.len()])
    }
    /// Whether target `t`'s observations carry orientations (all of them
    /// or none, [`MeasurementSet::from_poses`]; false for a target no pose
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
    /// The label of every pose, in order ([`TargetPose::label`]): what
    /// reports print and [`MeasurementSet::excluding`] takes.
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

    /// The poses at `indices` with the same targets, for splitting a set
    /// (model selection's folds). A target that none of the picked poses
    /// observes stays in the set: its offset then has no influence on a
    /// fit. The subset keeps every station (so its unknowns keep their
    /// names), even one that none of the picked poses belongs to.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] when an index is out of range or the
    /// subset is empty.
    pub fn subset(&self, indices: &[usize]) -> Result<Self, CalibError> {
        let bad = |what: String| self.error(what);
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
        // The poses were checked when the set was made.
        Ok(Self {
            source: self.source.clone(),
            targets: self.targets.clone(),
            poses,
            stations: self.stations.clone(),
            station_of: if self.station_of.is_empty() {
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
    /// As [`MeasurementSet::from_poses`], and a target list that does not
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
        check_targets(&self.source, &targets)?;
        let mut set = self.clone();
        set.targets = targets;
        Ok(set)
    }

    /// Reads flexcal's own one-target CSV format (see the crate docs): one
    /// target [`TCP_TARGET`] on the TCP.
    ///
    /// # Errors
    /// File and CSV errors with line and column, missing columns, NaN,
    /// inconsistent optional columns.
    pub fn read_csv(path: &Path) -> Result<Self, CalibError> {
        let table = CsvTable::read(path, &CsvOptions::default())?;
        Self::from_table(&table)
    }

    /// Parses flexcal's own CSV format from text; `source` names it in errors.
    ///
    /// # Errors
    /// As [`MeasurementSet::read_csv`].
    pub fn from_csv_str(text: &str, source: &str) -> Result<Self, CalibError> {
        let table = CsvTable::from_str(text, source, &CsvOptions::default())?;
        Self::from_table(&table)
    }

    fn from_table(table: &CsvTable) -> Result<Self, CalibError> {
        table.require_rows()?;
        let source = table.path().display().to_string();
        let mut q_columns = Vec::new();
        while let Some(c) = table.find_column(&format!("q{}", q_columns.len() + 1)) {
            q_columns.push(c);
        }
        if q_columns.is_empty() {
            // Reported through the usual missing-column error.
            table.column_index("q1")?;
        }
        let required = |names: [&str; 3]| -> Result<[usize; 3], CalibError> {
            Ok([
                table.column_index(names[0])?,
                table.column_index(names[1])?,
                table.column_index(names[2])?,
            ])
        };
        let optional = |names: &[&str]| -> Result<Option<Vec<usize>>, CalibError> {
            let found: Vec<Option<usize>> = names.iter().map(|n| table.find_column(n)).collect();
            if found.iter().all(Option::is_none) {
                return Ok(None);
            }
            if found.iter().any(Option::is_none) {
                // Name the first missing one of a partially present group.
                for n in names {
                    table.column_index(n)?;
                }
            }
            Ok(Some(found.into_iter().flatten().collect()))
        };
        let position = required(["x_mm", "y_mm", "z_mm"])?;
        let orientation = optional(&["rx_deg", "ry_deg", "rz_deg"])?;
        let position_std = optional(&["sx_mm", "sy_mm", "sz_mm"])?;
        let orientation_std = optional(&["srx_deg", "sry_deg", "srz_deg"])?;
        let wrench = optional(&["fx_n", "fy_n", "fz_n", "mx_nm", "my_nm", "mz_nm"])?;
        let temperature = table.find_column("temperature_c");
        let pose_id = table.find_column("pose_id");
        let station = table.find_column("station");
        let vec3 = |row: usize, cols: &[usize], scale: f64| -> Result<Vector3<f64>, CalibError> {
            Ok(Vector3::new(
                table.f64_at(row, cols[0])? * scale,
                table.f64_at(row, cols[1])? * scale,
                table.f64_at(row, cols[2])? * scale,
            ))
        };
        let mut measurements = Vec::with_capacity(table.len());
        for row in 0..table.len() {
            let q = q_columns
                .iter()
                .map(|&c| table.f64_at(row, c))
                .collect::<Result<Vec<_>, _>>()?;
            let deg = 1f64.to_radians();
            let m = Measurement {
                pose_id: pose_id.map(|c| table.cell(row, c).to_string()),
                q,
                position: vec3(row, &position, 1e-3)?,
                orientation: orientation
                    .as_ref()
                    .map(|c| vec3(row, c, deg))
                    .transpose()?,
                position_std: position_std
                    .as_ref()
                    .map(|c| vec3(row, c, 1e-3))
                    .transpose()?,
                orientation_std: orientation_std
                    .as_ref()
                    .map(|c| vec3(row, c, deg))
                    .transpose()?,
                wrench: wrench
                    .as_ref()
                    .map(|c| -> Result<Vector6<f64>, CalibError> {
                        let mut w = Vector6::zeros();
                        for (i, &col) in c.iter().enumerate() {
                            w[i] = table.f64_at(row, col)?;
                        }
                        Ok(w)
                    })
                    .transpose()?,
                temperature_c: temperature.map(|c| table.f64_at(row, c)).transpose()?,
            };
            for s in [m.position_std, m.orientation_std].into_iter().flatten() {
                if s.iter().any(|v| *v <= 0.0) {
                    return Err(CalibError::BadMeasurement {
                        source_name: source.clone(),
                        line: table.line_of(row),
                        what: "standard deviations must be > 0".into(),
                    });
                }
            }
            measurements.push(m);
        }
        let set = Self::new(&source, measurements)?;
        let Some(column) = station else {
            return Ok(set);
        };
        // Stations by name, in the order they first appear.
        let mut names: Vec<String> = Vec::new();
        let mut station_of = Vec::with_capacity(table.len());
        for row in 0..table.len() {
            let name = table.cell(row, column).trim();
            if name.is_empty() {
                return Err(CalibError::BadMeasurement {
                    source_name: source.clone(),
                    line: table.line_of(row),
                    what: "empty `station` cell".into(),
                });
            }
            station_of.push(station_index(&mut names, name));
        }
        set.with_stations(names, station_of)
    }

    /// The set in flexcal's CSV format (mm and deg, full precision): the
    /// one-target format for a one-target set
    /// ([`MeasurementSet::is_one_target`]), the format with per-target
    /// columns otherwise ([`MeasurementSet::read_targets_csv`]).
    pub fn to_csv_string(&self) -> String {
        if !self.is_one_target() {
            return self.to_targets_csv_string();
        }
        let measurements = self.measurements();
        let with_ids = measurements.iter().any(|m| m.pose_id.is_some());
        let mut header: Vec<String> = if with_ids {
            vec!["pose_id".into()]
        } else {
            Vec::new()
        };
        let with_stations = self.n_stations() > 1;
        if with_stations {
            header.push("station".into());
        }
        header.extend((1..=self.n_actuated()).map(|i| format!("q{i}")));
        header.extend(["x_mm", "y_mm", "z_mm"].map(String::from));
        let first = &measurements[0];
        let groups: [(bool, &[&str]); 5] = [
            (first.orientation.is_some(), &["rx_deg", "ry_deg", "rz_deg"]),
            (first.position_std.is_some(), &["sx_mm", "sy_mm", "sz_mm"]),
            (
                first.orientation_std.is_some(),
                &["srx_deg", "sry_deg", "srz_deg"],
            ),
            (
                measurements.iter().all(|m| m.wrench.is_some()),
                &["fx_n", "fy_n", "fz_n", "mx_nm", "my_nm", "mz_nm"],
            ),
            (
                measurements.iter().all(|m| m.temperature_c.is_some()),
                &["temperature_c"],
            ),
        ];
        for (present, names) in groups {
            if present {
                header.extend(names.iter().map(|s| s.to_string()));
            }
        }
        let mut text = header.join(",");
        text.push('\n');
        for (k, m) in measurements.iter().enumerate() {
            let mut cells: Vec<String> = Vec::new();
            if with_ids {
                // A leading '#' would turn the row into a comment; commas would split it.
                let id = m
                    .pose_id
                    .clone()
                    .unwrap_or_else(|| format!("pose-{}", k + 1));
                cells.push(id.trim_start_matches('#').replace(',', ";"));
            }
            if with_stations {
                let name = &self.station_names()[self.station_of(k)];
                cells.push(name.trim_start_matches('#').replace(',', ";"));
            }
            cells.extend(m.q.iter().map(|v| v.to_string()));
            cells.extend(m.position.iter().map(|v| (v * 1e3).to_string()));
            if groups[0].0 {
                cells.extend(
                    m.orientation
                        .unwrap_or_default()
                        .iter()
                        .map(|v| v.to_degrees().to_string()),
                );
            }
            if groups[1].0 {
                cells.extend(
                    m.position_std
                        .unwrap_or_default()
                        .iter()
                        .map(|v| (v * 1e3).to_string()),
                );
            }
            if groups[2].0 {
                cells.extend(
                    m.orientation_std
                        .unwrap_or_default()
                        .iter()
                        .map(|v| v.to_degrees().to_string()),
                );
            }
            if groups[3].0 {
                cells.extend(m.wrench.unwrap_or_default().iter().map(|v| v.to_string()));
            }
            if groups[4].0 {
                cells.push(m.temperature_c.unwrap_or_default().to_string());
            }
            let _ = writeln!(text, "{}", cells.join(","));
        }
        text
    }

    /// Writes the set in flexcal's own CSV format (atomically).
    ///
    /// # Errors
    /// [`CalibError::Io`] naming the file.
    pub fn write_csv(&self, path: &Path) -> Result<(), CalibError> {
        write_atomic(path, self.to_csv_string())?;
        Ok(())
    }

    /// Imports an IPA laser-tracker export (`;`-separated, decimal comma): the
    /// six UR joint columns (rad), `measurement_x/y/z` (mm) of the T-Mac probe
    /// in the tracker frame, `measurement_rx/ry/rz` (deg, intrinsic XYZ Euler
    /// angles), their `measurement_std_*` columns and `measurement_temperature`.
    /// One target [`TCP_TARGET`] on the TCP: when `Trafo_TM_F_init.txt`
    /// lies beside the file, the probe's nominal offset (the inverse of that
    /// T-Mac-to-flange transform) is its nominal pose
    /// ([`MeasurementSet::nominal_target`]).
    ///
    /// # Errors
    /// File and CSV errors with line and column, missing columns, a malformed
    /// transform file.
    pub fn read_ipa(path: &Path) -> Result<Self, CalibError> {
        let table = CsvTable::read(path, &CsvOptions::semicolon_decimal_comma())?;
        table.require_rows()?;
        let q_columns = IPA_JOINT_COLUMNS
            .iter()
            .map(|n| table.column_index(n))
            .collect::<Result<Vec<_>, _>>()?;
        let col = |n: &str| table.column_index(n);
        let pos = [
            col("measurement_x")?,
            col("measurement_y")?,
            col("measurement_z")?,
        ];
        let rot = [
            col("measurement_rx")?,
            col("measurement_ry")?,
            col("measurement_rz")?,
        ];
        let std_names = ["x", "y", "z", "rx", "ry", "rz"].map(|a| format!("measurement_std_{a}"));
        let std_cols: Vec<Option<usize>> = std_names.iter().map(|n| table.find_column(n)).collect();
        let has_std = std_cols.iter().all(Option::is_some);
        let temperature = table.find_column("measurement_temperature");
        let mut measurements = Vec::with_capacity(table.len());
        for row in 0..table.len() {
            let q = q_columns
                .iter()
                .map(|&c| table.f64_at(row, c))
                .collect::<Result<Vec<_>, _>>()?;
            let get = |c: usize| table.f64_at(row, c);
            let position = Vector3::new(get(pos[0])?, get(pos[1])?, get(pos[2])?) * 1e-3;
            let (a, b, c) = (
                get(rot[0])?.to_radians(),
                get(rot[1])?.to_radians(),
                get(rot[2])?.to_radians(),
            );
            // Intrinsic XYZ: R = Rx(a) Ry(b) Rz(c).
            let r = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a)
                * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), b)
                * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), c);
            let (position_std, orientation_std) = if has_std {
                let s: Vec<f64> = std_cols
                    .iter()
                    .flatten()
                    .map(|&c| get(c))
                    .collect::<Result<_, _>>()?;
                // A zero sample spread would give an infinite weight: floor it
                // at the file's printed resolution (1e-7 mm, 1e-7 deg).
                let floor = 1e-7;
                (
                    Some(Vector3::new(s[0], s[1], s[2]).map(|v| v.max(floor) * 1e-3)),
                    Some(Vector3::new(s[3], s[4], s[5]).map(|v| v.max(floor).to_radians())),
                )
            } else {
                (None, None)
            };
            measurements.push(Measurement {
                pose_id: Some(format!("line {}", table.line_of(row))),
                q,
                position,
                orientation: Some(vector_from_rotation(&r)),
                position_std,
                orientation_std,
                wrench: None,
                temperature_c: temperature.map(get).transpose()?,
            });
        }
        let mut set = Self::new(&path.display().to_string(), measurements)?;
        let trafo = path.with_file_name("Trafo_TM_F_init.txt");
        if trafo.exists() {
            let x_probe_flange = read_transform_mm(&trafo)?;
            set.set_nominal_target(x_probe_flange.inverse());
        }
        Ok(set)
    }
}

/// Reads a whitespace-separated 4x4 homogeneous transform with its
/// translation in mm (the IPA `Trafo_TM_F_init.txt`), returned in m.
///
/// # Errors
/// [`CalibError::BadMeasurement`] naming the file when it does not hold 16
/// finite numbers forming a rigid transform.
pub fn read_transform_mm(path: &Path) -> Result<Isometry3<f64>, CalibError> {
    let text = flexcal_io::read_to_string(path)?;
    let bad = |what: String| CalibError::BadMeasurement {
        source_name: path.display().to_string(),
        line: 0,
        what,
    };
    let values: Vec<f64> = text
        .split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| bad(format!("`{t}` is not a number")))
        })
        .collect::<Result<_, _>>()?;
    if values.len() != 16 || values.iter().any(|v| !v.is_finite()) {
        return Err(bad(format!(
            "expected 16 finite numbers (4x4), found {}",
            values.len()
        )));
    }
    let m = Matrix4::from_row_slice(&values);
    let r = m.fixed_view::<3, 3>(0, 0).into_owned();
    if (r.transpose() * r - nalgebra::Matrix3::identity()).norm() > 1e-4 {
        return Err(bad("the 3x3 block is not a rotation".into()));
    }
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r));
    let t = Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]) * 1e-3;
    Ok(Isometry3::from_parts(Translation3::from(t), rotation))
}

/// Reads actuated configurations from a CSV file with columns `q1..qn`
/// (other columns are ignored): the candidate pool of pose selection.
///
/// # Errors
/// File and CSV errors with line and column, a missing `q1` column.
pub fn read_configurations(path: &Path) -> Result<Vec<Vec<f64>>, CalibError> {
    let table = CsvTable::read(path, &CsvOptions::default())?;
    table.require_rows()?;
    let mut q_columns = vec![table.column_index("q1")?];
    while let Some(c) = table.find_column(&format!("q{}", q_columns.len() + 1)) {
        q_columns.push(c);
    }
    (0..table.len())
        .map(|row| {
            q_columns
                .iter()
                .map(|&c| table.f64_at(row, c).map_err(CalibError::from))
                .collect()
        })
        .collect()
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
            poses.push(TargetPose::new(
                pose_id.map(|c| table.cell(row, c).to_string()),
                q,
                observations,
            ));
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
    /// to their own file ([`crate::targets_to_toml_string`]).
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
