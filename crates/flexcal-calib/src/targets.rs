//! Targets, the named frames of the robot a measurement system sees
//! (laser-tracker reflectors on a tool, markers on the two hands of a
//! two-armed robot, a probe on a link), their observations and poses, and
//! their targets description (TOML). A `MeasurementSet` of one
//! target per pose is the case of one target on the TCP
//! (`tcp`, the one-target files).
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
//! The measurements are flexcal's CSV (`MeasurementSet::read_targets_csv`, the conventions of the one-target CSV:
//! comma-separated, `#` comments, columns in any order) with `q1..qn`, an
//! optional `pose_id` and `station`, and per target `<name>_x_mm, <name>_y_mm,
//! <name>_z_mm` (position in the measurement frame), optionally
//! `<name>_rx_deg..` (rotation vector), `<name>_sx_mm..` (standard
//! deviations) and `<name>_srx_deg..`. A target not seen on a pose has empty
//! cells on that row (all of its cells).

use std::path::Path;

use flexcal_io::write_atomic;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::error::CalibError;
use crate::frames::FrameTreatment;
use crate::geometry::{rotation_from_vector, vector_from_rotation};

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
    /// The pose at the actuated coordinates `q` (rad, m) with one
    /// observation per target of its set (`None` where a target was not
    /// seen), named `pose_id`; no wrench and no temperature recorded.
    pub fn new(
        pose_id: Option<String>,
        q: Vec<f64>,
        observations: Vec<Option<TargetObservation>>,
    ) -> Self {
        Self {
            pose_id,
            q,
            observations,
            wrench: None,
            temperature_c: None,
        }
    }

    /// The pose identifier, or `#k` from its index.
    pub fn label(&self, index: usize) -> String {
        self.pose_id.clone().unwrap_or_else(|| format!("#{index}"))
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
