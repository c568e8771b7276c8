//! Measurement sets and their file formats: flexcal's own CSV and the IPA
//! laser-tracker export.

use std::fmt::Write as _;
use std::path::Path;

use flexcal_io::{CsvOptions, CsvTable, write_atomic};
use nalgebra::{Isometry3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3, Vector6};

use crate::error::CalibError;
use crate::geometry::vector_from_rotation;

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
}

/// A set of measured poses, one target per pose ([`MeasurementSet`]) or
/// several ([`crate::TargetMeasurementSet`]): what the workflows that treat
/// both alike need (model selection, the checks, exclusions).
pub trait PoseSet: Sized {
    /// Number of poses.
    fn n_poses(&self) -> usize;
    /// Number of observations (a target seen at a pose) when a pose holds
    /// several targets; `None` for one target per pose.
    fn n_observations(&self) -> Option<usize> {
        None
    }
    /// Where the poses come from (a file name), as messages name it.
    fn source(&self) -> &str;
    /// The set without what `labels` name ([`MeasurementSet::excluding`],
    /// [`crate::TargetMeasurementSet::excluding`]).
    ///
    /// # Errors
    /// A label that names nothing in the set; nothing left.
    fn excluding(&self, labels: &[String]) -> Result<Self, CalibError>;
}

impl PoseSet for MeasurementSet {
    fn n_poses(&self) -> usize {
        self.len()
    }
    fn source(&self) -> &str {
        &self.source
    }
    fn excluding(&self, labels: &[String]) -> Result<Self, CalibError> {
        MeasurementSet::excluding(self, labels)
    }
}

/// A validated set of measurements: every pose has the same number of
/// actuated coordinates, finite values, and either all or none carry an
/// orientation (and likewise standard deviations).
///
/// Each pose belongs to a *station*: one placement of the measurement
/// system, with its own measurement frame `x_meas_base` (a laser tracker
/// moved to see another part of the workspace, or a campaign of another
/// day). A set read from one file without a `station` column is one
/// station; [`MeasurementSet::pooled`] joins sets as stations of one
/// identification.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementSet {
    /// Where the measurements come from (file name), used in messages.
    pub source: String,
    measurements: Vec<Measurement>,
    /// Name of each station, in order (at least one).
    stations: Vec<String>,
    /// Station (index into `stations`) of each pose.
    station_of: Vec<usize>,
    /// Nominal pose `x_tcp_target` of the target in the TCP frame when the
    /// file format knows it (the IPA probe offset); the identification starts
    /// from it.
    pub nominal_target: Option<Isometry3<f64>>,
}

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

/// Checks the stations of a set of `poses` poses from `source`: one
/// station index per pose, each naming one of `stations`, and every station
/// with a pose.
///
/// # Errors
/// [`CalibError::BadMeasurement`] naming the set and what is wrong.
pub(crate) fn check_stations(
    source: &str,
    stations: &[String],
    station_of: &[usize],
    poses: usize,
) -> Result<(), CalibError> {
    let bad = |what: String| CalibError::BadMeasurement {
        source_name: source.to_string(),
        line: 0,
        what,
    };
    if station_of.len() != poses {
        return Err(bad(format!(
            "{} station indices for {poses} poses",
            station_of.len()
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
    Ok(())
}

/// The first of the sets to pool.
///
/// # Errors
/// [`CalibError::BadMeasurement`] when there is none.
pub(crate) fn first_to_pool<T>(sets: &[T]) -> Result<&T, CalibError> {
    sets.first().ok_or_else(|| CalibError::BadMeasurement {
        source_name: "pooled measurements".into(),
        line: 0,
        what: "no measurement sets to pool".into(),
    })
}

/// Checks that a set to pool, `(source, actuated count)`, has as many
/// actuated coordinates as the first.
///
/// # Errors
/// [`CalibError::BadMeasurement`] naming the set.
pub(crate) fn check_same_actuated(
    set: (&str, usize),
    first: (&str, usize),
) -> Result<(), CalibError> {
    if set.1 == first.1 {
        return Ok(());
    }
    Err(CalibError::BadMeasurement {
        source_name: set.0.to_string(),
        line: 0,
        what: format!(
            "{} actuated coordinates, {} has {}",
            set.1, first.0, first.1
        ),
    })
}

/// The stations of sets being pooled, and the pooled station of each pose
/// so far.
#[derive(Default)]
pub(crate) struct StationPool {
    /// Station names, unique (the CSV tells stations by name): a name met
    /// before gets its number, `markers.csv (s2)`.
    pub stations: Vec<String>,
    /// Pooled station of each pose added.
    pub station_of: Vec<usize>,
}

impl StationPool {
    /// Adds a set's stations; returns the pooled index of its first.
    pub fn add_stations(&mut self, names: &[String]) -> usize {
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
    pub fn add_pose(&mut self, station: usize, label: String) -> String {
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

impl MeasurementSet {
    /// Validates and wraps measurements.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] naming the pose: no measurement, differing
    /// numbers of coordinates, a non-finite value, orientation or standard
    /// deviations on some poses only, a standard deviation not `> 0`.
    pub fn new(source: &str, measurements: Vec<Measurement>) -> Result<Self, CalibError> {
        let bad = |k: usize, what: String| CalibError::BadMeasurement {
            source_name: source.to_string(),
            line: 0,
            what: format!("pose {k}: {what}"),
        };
        let Some(first) = measurements.first() else {
            return Err(CalibError::BadMeasurement {
                source_name: source.to_string(),
                line: 0,
                what: "no measurements".into(),
            });
        };
        let n = first.q.len();
        let has = |m: &Measurement| {
            (
                m.orientation.is_some(),
                m.position_std.is_some(),
                m.orientation_std.is_some(),
            )
        };
        let pattern = has(first);
        for (k, m) in measurements.iter().enumerate() {
            if m.q.len() != n {
                return Err(bad(
                    k,
                    format!("{} actuated coordinates, the first pose has {n}", m.q.len()),
                ));
            }
            if has(m) != pattern {
                return Err(bad(
                    k,
                    "orientation and standard deviations must be given for all poses or none"
                        .into(),
                ));
            }
            let finite = m.q.iter().all(|v| v.is_finite())
                && m.position.iter().all(|v| v.is_finite())
                && m.orientation
                    .is_none_or(|o| o.iter().all(|v| v.is_finite()))
                && m.wrench.is_none_or(|w| w.iter().all(|v| v.is_finite()))
                && m.temperature_c.is_none_or(f64::is_finite);
            if !finite {
                return Err(bad(k, "a value is NaN or infinite".into()));
            }
            for s in [m.position_std, m.orientation_std].into_iter().flatten() {
                if !s.iter().all(|v| v.is_finite() && *v > 0.0) {
                    return Err(bad(
                        k,
                        format!("standard deviations must be finite and > 0, found {s:?}"),
                    ));
                }
            }
        }
        Ok(Self {
            source: source.to_string(),
            station_of: vec![0; measurements.len()],
            measurements,
            stations: vec![source.to_string()],
            nominal_target: None,
        })
    }

    /// The same poses as stations named `stations`, pose `k` measured from
    /// station `station_of[k]`.
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
        self.stations = stations;
        self.station_of = station_of;
        Ok(self)
    }

    /// Joins measurement sets of one robot and one target as the stations of
    /// one identification: each set keeps its own measurement frame (its
    /// stations, when it has several), the robot and the target offset are
    /// shared. With more than one station the pose labels are prefixed by
    /// the station's number, `s2:line 534` (pose `line 534` of the second);
    /// a station name met before is made unique with its number,
    /// `B.csv (s2)`.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] naming the set: no sets, a different
    /// number of actuated coordinates, orientations or standard deviations
    /// in some sets only, or nominal target offsets that differ (a target
    /// remounted between stations is not one target).
    pub fn pooled(sets: &[MeasurementSet]) -> Result<Self, CalibError> {
        let first = first_to_pool(sets)?;
        if sets.len() == 1 {
            return Ok(first.clone());
        }
        let pattern = |set: &MeasurementSet| {
            (
                set.has_orientation(),
                set.has_position_std(),
                set.has_orientation_std(),
            )
        };
        let mut pool = StationPool::default();
        let mut measurements = Vec::new();
        for set in sets {
            let bad = |what: String| CalibError::BadMeasurement {
                source_name: set.source.clone(),
                line: 0,
                what,
            };
            check_same_actuated(
                (&set.source, set.n_actuated()),
                (&first.source, first.n_actuated()),
            )?;
            if pattern(set) != pattern(first) {
                return Err(bad(format!(
                    "orientations or standard deviations are measured in {} and not here, or the reverse: pooled sets must measure the same",
                    first.source
                )));
            }
            let same_target = match (set.nominal_target, first.nominal_target) {
                (None, None) => true,
                (Some(a), Some(b)) => {
                    (a.translation.vector - b.translation.vector).norm() < 1e-9
                        && a.rotation.angle_to(&b.rotation) < 1e-9
                }
                _ => false,
            };
            if !same_target {
                return Err(bad(format!(
                    "its nominal target offset differs from that of {}: pooled sets must measure one target",
                    first.source
                )));
            }
            let offset = pool.add_stations(&set.stations);
            for (k, m) in set.measurements.iter().enumerate() {
                let mut m = m.clone();
                m.pose_id = Some(pool.add_pose(offset + set.station_of[k], m.label(k)));
                measurements.push(m);
            }
        }
        let source: Vec<&str> = sets.iter().map(|s| s.source.as_str()).collect();
        let mut set = Self::new(&source.join(" + "), measurements)?;
        set.nominal_target = first.nominal_target;
        set.with_stations(pool.stations, pool.station_of)
    }

    /// Number of stations (at least 1).
    pub fn n_stations(&self) -> usize {
        self.stations.len()
    }
    /// Names of the stations, in order (a file name, or the `station`
    /// column's values).
    pub fn station_names(&self) -> &[String] {
        &self.stations
    }
    /// Station (0-based index into [`MeasurementSet::station_names`]) of
    /// pose `k`.
    pub fn station_of(&self, k: usize) -> usize {
        self.station_of[k]
    }
    /// The poses of station `s` as a set of their own (one station), or
    /// `None` when this set has none of them (a subset can leave a station
    /// out).
    pub fn station_poses(&self, s: usize) -> Option<Self> {
        let indices: Vec<usize> = (0..self.len())
            .filter(|&k| self.station_of[k] == s)
            .collect();
        let mut set = Self::new(
            &self.stations[s],
            indices
                .iter()
                .map(|&k| self.measurements[k].clone())
                .collect(),
        )
        .ok()?;
        set.nominal_target = self.nominal_target;
        Some(set)
    }

    /// The measurements.
    pub fn measurements(&self) -> &[Measurement] {
        &self.measurements
    }
    /// Number of poses.
    pub fn len(&self) -> usize {
        self.measurements.len()
    }
    /// Always false: a set holds at least one pose.
    pub fn is_empty(&self) -> bool {
        self.measurements.is_empty()
    }
    /// Number of actuated coordinates per pose.
    pub fn n_actuated(&self) -> usize {
        self.measurements[0].q.len()
    }
    /// Whether orientations are measured.
    pub fn has_orientation(&self) -> bool {
        self.measurements[0].orientation.is_some()
    }
    /// Whether position standard deviations are given.
    pub fn has_position_std(&self) -> bool {
        self.measurements[0].position_std.is_some()
    }
    /// Whether orientation standard deviations are given.
    pub fn has_orientation_std(&self) -> bool {
        self.measurements[0].orientation_std.is_some()
    }
    /// The label of every pose, in order ([`Measurement::label`]): what
    /// reports print and [`MeasurementSet::excluding`] takes.
    pub fn labels(&self) -> Vec<String> {
        self.measurements
            .iter()
            .enumerate()
            .map(|(k, m)| m.label(k))
            .collect()
    }

    /// The same set with every pose's label written into its `pose_id`
    /// (`#k` for a pose without one), so that a subset keeps the labels of
    /// this set.
    pub(crate) fn labelled(&self) -> Self {
        let mut set = self.clone();
        for (k, m) in set.measurements.iter_mut().enumerate() {
            m.pose_id.get_or_insert_with(|| format!("#{k}"));
        }
        set
    }

    /// The subset at `indices` (same source and target), for splitting a set.
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] when an index is out of range or the subset is empty.
    pub fn subset(&self, indices: &[usize]) -> Result<Self, CalibError> {
        let mut picked = Vec::with_capacity(indices.len());
        for &i in indices {
            let m = self
                .measurements
                .get(i)
                .ok_or_else(|| CalibError::BadMeasurement {
                    source_name: self.source.clone(),
                    line: 0,
                    what: format!("pose index {i} out of range (set has {})", self.len()),
                })?;
            picked.push(m.clone());
        }
        let mut set = Self::new(&self.source, picked)?;
        set.nominal_target = self.nominal_target;
        // The subset keeps every station (so its unknowns keep their names),
        // even one that none of the picked poses belongs to.
        set.stations = self.stations.clone();
        set.station_of = indices.iter().map(|&i| self.station_of[i]).collect();
        Ok(set)
    }

    /// Reads flexcal's own CSV format (see the crate docs).
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

    /// The set in flexcal's own CSV format (mm and deg, full precision).
    pub fn to_csv_string(&self) -> String {
        let with_ids = self.measurements.iter().any(|m| m.pose_id.is_some());
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
        let first = &self.measurements[0];
        let groups: [(bool, &[&str]); 5] = [
            (first.orientation.is_some(), &["rx_deg", "ry_deg", "rz_deg"]),
            (first.position_std.is_some(), &["sx_mm", "sy_mm", "sz_mm"]),
            (
                first.orientation_std.is_some(),
                &["srx_deg", "sry_deg", "srz_deg"],
            ),
            (
                self.measurements.iter().all(|m| m.wrench.is_some()),
                &["fx_n", "fy_n", "fz_n", "mx_nm", "my_nm", "mz_nm"],
            ),
            (
                self.measurements.iter().all(|m| m.temperature_c.is_some()),
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
        for (k, m) in self.measurements.iter().enumerate() {
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
                let name = &self.stations[self.station_of[k]];
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
    /// When `Trafo_TM_F_init.txt` lies beside the file, the probe's nominal
    /// offset (the inverse of that T-Mac-to-flange transform) becomes
    /// [`MeasurementSet::nominal_target`].
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
            set.nominal_target = Some(x_probe_flange.inverse());
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
