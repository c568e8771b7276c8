//! The robot description: what a user writes in a TOML file (mm and degrees),
//! before it is validated and frozen into a [`Model`](crate::Model).

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use crate::KinematicsError;

/// Kind of the joint at the origin of a frame (the KK symbol sigma).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointType {
    /// Rotation about z by theta (sigma = 0).
    Revolute,
    /// Translation along z by r (sigma = 1).
    Prismatic,
    /// No joint: theta and r are constant (sigma = 2).
    Fixed,
}

/// A rigid transform in a description file: translation in mm, rotation as
/// roll, pitch, yaw in degrees with `R = Rz(yaw) Ry(pitch) Rx(roll)`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDescription {
    /// Translation (mm).
    #[serde(default)]
    pub translation_mm: [f64; 3],
    /// Roll, pitch, yaw (deg): `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    #[serde(default)]
    pub rpy_deg: [f64; 3],
}

impl TransformDescription {
    /// True when both translation and rotation are exactly zero.
    pub fn is_identity(&self) -> bool {
        self.translation_mm == [0.0; 3] && self.rpy_deg == [0.0; 3]
    }

    /// The transform in SI units.
    pub fn to_isometry(&self) -> Isometry3<f64> {
        let t = self.translation_mm;
        let r = self.rpy_deg;
        Isometry3::from_parts(
            Translation3::new(t[0] / 1000.0, t[1] / 1000.0, t[2] / 1000.0),
            UnitQuaternion::from_euler_angles(
                r[0].to_radians(),
                r[1].to_radians(),
                r[2].to_radians(),
            ),
        )
    }

    /// The description of an SI transform (mm, degrees), with roll, pitch
    /// and yaw extracted by [`rpy_from_rotation`]: the rotation read back
    /// equals the one given to rounding (1e-15) at every pitch, +-90 deg
    /// included.
    pub fn from_isometry(x: &Isometry3<f64>) -> Self {
        let [roll, pitch, yaw] = rpy_from_rotation(x.rotation.to_rotation_matrix().matrix());
        let t = x.translation.vector * 1000.0;
        Self {
            translation_mm: [t.x, t.y, t.z],
            rpy_deg: [roll.to_degrees(), pitch.to_degrees(), yaw.to_degrees()],
        }
    }
}

/// Roll, pitch, yaw (rad) of a rotation matrix with `R = Rz(yaw) Ry(pitch) Rx(roll)`,
/// pitch in \[-pi/2, pi/2\].
///
/// Extracted so that the three angles give `R` back to rounding at every
/// pitch: yaw from the first column, then pitch and roll from
/// `Rz(-yaw) R = Ry(pitch) Rx(roll)`, whose entries do not shrink with
/// cos(pitch) (an `asin` of one entry, or roll from the third row, loses
/// half the digits near pitch +-pi/2). At pitch +-pi/2 exactly only roll -/+
/// yaw is defined: yaw is then whatever the rounding of the first column
/// gives, and roll takes the rest.
pub fn rpy_from_rotation(r: &Matrix3<f64>) -> [f64; 3] {
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    let (sy, cy) = yaw.sin_cos();
    // Rows 0 and 1 of Rz(-yaw) R; its row 2 is R's.
    let r00 = cy * r[(0, 0)] + sy * r[(1, 0)];
    let r11 = -sy * r[(0, 1)] + cy * r[(1, 1)];
    let r12 = -sy * r[(0, 2)] + cy * r[(1, 2)];
    let pitch = (-r[(2, 0)]).atan2(r00);
    let roll = (-r12).atan2(r11);
    [roll, pitch, yaw]
}

/// The 1-based line of `key` in the `index`-th `[[frame]]` table of `text`
/// (0 when it is not written on a line of its own, as in an inline table).
fn frame_key_line(text: &str, index: usize, key: &str) -> usize {
    // The `[[frame]]` table a line is in (None under any other header).
    let (mut frame, mut count) = (None, 0);
    for (k, line) in text.lines().enumerate() {
        let line = line.trim_start();
        if line.starts_with("[[frame]]") {
            frame = Some(count);
            count += 1;
        } else if line.starts_with('[') {
            frame = None;
        } else if frame == Some(index)
            && line
                .strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        {
            return k + 1;
        }
    }
    0
}

/// A slider-crank (ball screw) actuator driving a revolute joint: the
/// actuated coordinate is the screw length r'.
///
/// The screw joins a pivot A on the driven body, at distance `l1` from the
/// joint axis and at angle `kappa` from its x axis, to a pivot B on the
/// antecedent body, at distance `l3` from the axis and angle `lambda` from the
/// antecedent's x axis (after the constant part of theta). The law of cosines
/// (the relation V of the paper's Appendix A, written with r'^2) gives
/// `theta_joint = lambda - kappa + branch * acos((l1^2 + l3^2 - r'^2) / (2 l1 l3))`
/// with `r' = q + screw_offset`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SliderCrankDescription {
    /// Offset added to the actuated screw length (mm) (default 0; the parameter `r{frame}p`).
    #[serde(default)]
    pub screw_offset_mm: f64,
    /// Angle of the driven pivot A from the frame's x axis (deg) (`kappa{frame}`).
    pub kappa_deg: f64,
    /// Angle of the ground pivot B from the antecedent's x axis (deg) (`lambda{frame}`).
    pub lambda_deg: f64,
    /// Distance of pivot A from the joint axis (mm) (`l1{frame}`).
    pub l1_mm: f64,
    /// Distance of pivot B from the joint axis (mm) (`l3{frame}`).
    pub l3_mm: f64,
    /// Assembly branch, +1 or -1 (default +1): sign in front of the acos.
    #[serde(default = "default_branch")]
    pub branch: i8,
}

fn default_branch() -> i8 {
    1
}

/// One term of a linear joint coupling.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingTerm {
    /// Frame whose joint drives this one.
    pub frame: String,
    /// Ratio (dimensionless when both joints are of the same kind).
    pub ratio: f64,
}

/// A frame (body and the joint at its origin) in Khalil-Kleinfinger notation:
/// `a(i)T_i = rot(z,gamma) trans(z,b) rot(x,alpha) trans(x,d) rot(y,beta) rot(z,theta) trans(z,r)`.
///
/// The Hayati angle beta, when declared, sits after `trans(x,d)` and before
/// `rot(z,theta)`: it tilts the joint axis about the common normal's
/// perpendicular, for axes (nearly) parallel to the antecedent's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameDescription {
    /// Frame name, unique ("1", "E", "wrist").
    pub name: String,
    /// Name of the antecedent frame a(i); "0" (the default) is the base frame R0.
    #[serde(default = "base_name")]
    pub antecedent: String,
    /// Joint kind (sigma).
    pub joint: JointType,
    /// True when the joint is motorised (mu = 1): its value (or its screw
    /// length, with `slider_crank`) is an entry of q.
    #[serde(default, skip_serializing_if = "is_false")]
    pub actuated: bool,
    /// Name of the actuated coordinate (default `theta{name}`, `r{name}` or `r{name}p`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actuated_name: Option<String>,
    /// gamma (deg).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gamma_deg: f64,
    /// b (mm).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub b_mm: f64,
    /// alpha (deg).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub alpha_deg: f64,
    /// d (mm).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub d_mm: f64,
    /// Hayati beta (deg); declaring it (even as 0) makes it a parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta_deg: Option<f64>,
    /// theta (deg): constant offset added to the joint value for revolute joints.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub theta_deg: f64,
    /// r (mm): constant offset added to the joint value for prismatic joints.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub r_mm: f64,
    /// Limits of the actuated coordinate of a revolute joint (deg).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits_deg: Option<[f64; 2]>,
    /// Limits of the actuated coordinate of a prismatic joint or screw (mm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits_mm: Option<[f64; 2]>,
    /// Quantities (`gamma`, `b`, `alpha`, `d`, `beta`, `theta`, `r`) taken
    /// from another frame, e.g. `{ alpha = "2" }` for a joint coaxial with joint 2.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub same_as: BTreeMap<String, String>,
    /// Parameters added to a quantity, e.g. `{ r = ["d10"] }` for `r = r4 + d10`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub plus: BTreeMap<String, Vec<String>>,
    /// Slider-crank actuator (needs `actuated = true`, `joint = "revolute"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slider_crank: Option<SliderCrankDescription>,
    /// Linear coupling: joint value = sum of ratio times the other frames'
    /// total theta (or r), e.g. theta6 = -theta5.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub coupled_to: Vec<CouplingTerm>,
    /// Initial guess of a passive loop joint (deg) (revolute) — the assembly
    /// seed; on an actuated revolute joint of a robot with loops, its value
    /// in the home configuration from which the loops are followed
    /// ([`crate::Model::home_configuration`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub seed_deg: f64,
    /// Initial guess of a passive loop joint (mm) (prismatic); on an actuated
    /// prismatic joint or slider crank of a robot with loops, its value (the
    /// screw length) in the home configuration.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub seed_mm: f64,
}

fn base_name() -> String {
    "0".to_string()
}
fn is_false(b: &bool) -> bool {
    !*b
}
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl FrameDescription {
    /// A frame with every quantity zero.
    pub fn new(name: &str, antecedent: &str, joint: JointType) -> Self {
        Self {
            name: name.to_string(),
            antecedent: antecedent.to_string(),
            joint,
            actuated: false,
            actuated_name: None,
            gamma_deg: 0.0,
            b_mm: 0.0,
            alpha_deg: 0.0,
            d_mm: 0.0,
            beta_deg: None,
            theta_deg: 0.0,
            r_mm: 0.0,
            limits_deg: None,
            limits_mm: None,
            same_as: BTreeMap::new(),
            plus: BTreeMap::new(),
            slider_crank: None,
            coupled_to: Vec::new(),
            seed_deg: 0.0,
            seed_mm: 0.0,
        }
    }
}

/// Which components of the cut-joint error a loop closes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LoopConstraint {
    /// All six components (position and orientation): the cut frames coincide.
    #[default]
    Full,
    /// In-plane position (x, y) and rotation about z of the first cut frame:
    /// a planar loop whose out-of-plane errors are taken by the mechanism's clearances.
    Planar,
}

/// How a loop is assembled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LoopSolver {
    /// Gauss-Newton least squares on the cut-joint constraint, seeded from
    /// the previous solution kept in [`crate::Data`].
    #[default]
    Newton,
    /// Closed form for a planar four-bar (two circles), then Newton polish.
    FourBar,
}

/// A closed loop: cut at a joint, the two frames `cut` must coincide.
///
/// Loops close in the order listed; a passive joint on several loops (nested
/// parallelograms) is an unknown of the first of them, and later loops take
/// its assembled value as given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoopDescription {
    /// Loop name used in messages.
    pub name: String,
    /// The two frames that must coincide (the cut joint's two halves).
    pub cut: [String; 2],
    /// Components closed (default `full`).
    #[serde(default)]
    pub constraint: LoopConstraint,
    /// Solver (default `newton`).
    #[serde(default)]
    pub solver: LoopSolver,
    /// Assembly branch for the closed form, +1 or -1 (default +1).
    #[serde(default = "default_branch")]
    pub branch: i8,
}

/// A named place rigidly attached to a frame (or to the base R0): a URDF
/// link, a marker, a hand. `forward_named_pose` and `fk --frame` take its
/// name like a frame's.
///
/// ```toml
/// [[link]]
/// name = "wrist_2_link"
/// frame = "5"                  # the frame it moves with ("0": the base R0)
/// translation_mm = [0, 0, 0]   # its pose in that frame
/// rpy_deg = [90, 0, 0]
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkDescription {
    /// The link's name, unique among frames and links.
    pub name: String,
    /// The frame it is attached to (`"0"`: the base frame R0).
    pub frame: String,
    /// Its translation in that frame (mm).
    #[serde(default)]
    pub translation_mm: [f64; 3],
    /// Its roll, pitch, yaw in that frame (deg): `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    #[serde(default)]
    pub rpy_deg: [f64; 3],
}

impl LinkDescription {
    /// A link `name` at the SI pose `x_frame_link` in frame `frame`.
    pub fn new(name: &str, frame: &str, x_frame_link: &Isometry3<f64>) -> Self {
        let t = TransformDescription::from_isometry(x_frame_link);
        Self {
            name: name.to_string(),
            frame: frame.to_string(),
            translation_mm: t.translation_mm,
            rpy_deg: t.rpy_deg,
        }
    }

    /// Its pose in its frame (SI).
    pub fn to_isometry(&self) -> Isometry3<f64> {
        TransformDescription {
            translation_mm: self.translation_mm,
            rpy_deg: self.rpy_deg,
        }
        .to_isometry()
    }
}

/// A robot as written in a description file (lengths in mm, angles in
/// degrees); [`RobotDescription::build`] validates it into a
/// [`Model`](crate::Model).
///
/// ```toml
/// name = "two-link"
/// [(frame)]
/// name = "1"
/// joint = "revolute"
/// actuated = true
/// limits_deg = [-170, 170]
/// [(frame)]
/// name = "2"
/// antecedent = "1"
/// joint = "revolute"
/// actuated = true
/// d_mm = 400
/// [(frame)]
/// name = "E"
/// antecedent = "2"
/// joint = "fixed"
/// d_mm = 300
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotDescription {
    /// Robot name.
    pub name: String,
    /// Free text: origin of the values, conventions.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub notes: String,
    /// Frame carrying the tool transform (default: the last frame declared).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_frame: Option<String>,
    /// Names of the parameters forming xi, in order. Default rule when absent,
    /// frame by frame: gamma and b when non-zero; alpha; d; beta when declared;
    /// theta for directly actuated revolute joints (the joint offset), for
    /// prismatic joints and for fixed frames (not for passive, coupled or
    /// crank-driven joints, whose offset is not separable); r unless beta is
    /// declared (for parallel axes the z offsets of consecutive frames are one
    /// and the same translation); then the five slider-crank parameters
    /// `r{f}p kappa{f} lambda{f} l1{f} l3{f}`. Quantities taken `same_as`
    /// another frame are never parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameters: Option<Vec<String>>,
    /// Names of the actuated coordinates in the order of q (default: the
    /// order of the actuated frames).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actuated_order: Option<Vec<String>>,
    /// Cell R-1 to base R0 (not in xi).
    #[serde(default, skip_serializing_if = "TransformDescription::is_identity")]
    pub base: TransformDescription,
    /// End frame to TCP (not in xi).
    #[serde(default, skip_serializing_if = "TransformDescription::is_identity")]
    pub tool: TransformDescription,
    /// Frames, each after its antecedent.
    #[serde(rename = "frame")]
    pub frames: Vec<FrameDescription>,
    /// Closed loops.
    #[serde(default, rename = "loop", skip_serializing_if = "Vec::is_empty")]
    pub loops: Vec<LoopDescription>,
    /// Named places attached to frames (a URDF's links).
    #[serde(default, rename = "link", skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<LinkDescription>,
}

impl RobotDescription {
    /// Parses a description from TOML text; `source` names the text in errors
    /// (usually the file name). Errors carry the 1-based line.
    pub fn from_toml_str(text: &str, source: &str) -> Result<Self, KinematicsError> {
        let description = toml::from_str::<RobotDescription>(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1)
                .unwrap_or(0);
            KinematicsError::Toml {
                source_name: source.to_string(),
                line,
                message: e.message().to_string(),
            }
        })?;
        description.check_limits(text, source)?;
        Ok(description)
    }

    /// Refuses limits that are not finite or inverted (min above max), with
    /// the frame and the line of its `limits_deg` / `limits_mm` in `text`.
    fn check_limits(&self, text: &str, source: &str) -> Result<(), KinematicsError> {
        for (i, f) in self.frames.iter().enumerate() {
            for (key, limits) in [("limits_deg", f.limits_deg), ("limits_mm", f.limits_mm)] {
                let Some([min, max]) = limits else {
                    continue;
                };
                let problem = if !(min.is_finite() && max.is_finite()) {
                    "not finite"
                } else if min > max {
                    "inverted (min above max)"
                } else {
                    continue;
                };
                return Err(KinematicsError::Toml {
                    source_name: source.to_string(),
                    line: frame_key_line(text, i, key),
                    message: format!("frame `{}`: {key} = [{min}, {max}] is {problem}", f.name),
                });
            }
        }
        Ok(())
    }

    /// Reads a description file.
    pub fn from_toml_file(path: &Path) -> Result<Self, KinematicsError> {
        let text = std::fs::read_to_string(path).map_err(|e| KinematicsError::File {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The same robot with its tool point moved to `tip`: a frame's name
    /// (its end frame then, the tool transform dropped unless `tip` already
    /// is the end frame) or a link's (its frame, the link's pose as the tool
    /// transform) — what `--tip` means for a description that is not a URDF.
    ///
    /// # Errors
    /// [`KinematicsError::UnknownFrame`] for a name that is neither (or the
    /// base `0`), listing the frames and links there are.
    pub fn with_tip(&self, tip: &str) -> Result<Self, KinematicsError> {
        let mut out = self.clone();
        let end = self
            .end_frame
            .clone()
            .or_else(|| self.frames.last().map(|f| f.name.clone()));
        if end.as_deref() == Some(tip) {
            return Ok(out);
        }
        if self.frames.iter().any(|f| f.name == tip) {
            out.end_frame = Some(tip.to_string());
            out.tool = TransformDescription::default();
            return Ok(out);
        }
        match self.links.iter().find(|l| l.name == tip && l.frame != "0") {
            Some(link) => {
                out.end_frame = Some(link.frame.clone());
                out.tool = TransformDescription {
                    translation_mm: link.translation_mm,
                    rpy_deg: link.rpy_deg,
                };
                Ok(out)
            }
            None => Err(KinematicsError::UnknownFrame {
                robot: self.name.as_str().into(),
                name: tip.to_string(),
                known: self
                    .frames
                    .iter()
                    .map(|f| f.name.as_str())
                    .chain(
                        self.links
                            .iter()
                            .filter(|l| l.frame != "0")
                            .map(|l| l.name.as_str()),
                    )
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
        }
    }

    /// The description as TOML text; [`RobotDescription::from_toml_str`] reads it back identically.
    pub fn to_toml_string(&self) -> String {
        // Serialising plain data structures to TOML cannot fail: every field is
        // a string, number, array or table with string keys.
        toml::to_string(self).unwrap_or_else(|e| format!("# serialisation failed: {e}\n"))
    }
}
