//! Robots from other formats: a URDF tree converted into a Khalil-Kleinfinger
//! [`RobotDescription`] that reproduces the file's poses exactly (and the
//! types shared with the SYMORO reader).
//!
//! ## How a URDF becomes a KK description
//! 1. The path from the root link (default: the tree's root) to the tip link
//!    (default: the single leaf below the root) is extracted; fixed joints on
//!    it fold into constant transforms.
//! 2. Each revolute, continuous or prismatic joint on the path becomes a KK
//!    frame `1..n` whose z axis is the joint axis (in the direction of the
//!    URDF axis, normalised). Frame k's x axis lies along the common normal
//!    of axes k and k+1 and its origin at the foot of that normal on axis k
//!    (modified DH), so that frames 2..n have gamma = b = 0. Where two
//!    consecutive axes are parallel (angle below about 2.9 deg) the frame gets a
//!    Hayati angle beta instead (frame k's origin stays where frame k
//!    arrives, r(k) = 0, and beta(k+1) replaces r(k+1) in xi). Frame 1 is
//!    placed relative to the root link's frame with gamma, b, alpha, d as
//!    needed (R0 is the root link's frame, so [`crate::forward_pose`] gives
//!    poses in the URDF root frame). Frame n is where it arrives; the
//!    constant tool transform (end frame n to the tip link) absorbs the rest.
//! 3. A joint value of 0 in the URDF is a joint value of 0 in flexcal: the
//!    constant theta (or r) of each frame holds the URDF's zero offset.
//! 4. A mimic joint (`value = multiplier * leader + offset`) becomes a linear
//!    coupling; mimic chains resolve to their first leader. A leader off the
//!    path (or after its follower) gets a frame of its own, `m1`, `m2`, ...,
//!    attached to R0 with zero geometry: it carries the actuated coordinate
//!    only, and its quantities are not in xi.
//! 5. The parameter vector follows the default rule of
//!    [`RobotDescription::parameters`] (listed by name as for built-in robots).
//!
//! The actuated coordinates keep the URDF joint names and limits
//! (continuous joints: the default range of +-360 deg, no wrapping).
//! Masses come from the links' `<inertial>` ([`LinkMass`]).

use std::collections::HashMap;
use std::path::PathBuf;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::KinematicsError;
use crate::description::{
    CouplingTerm, FrameDescription, JointType, LinkDescription, RobotDescription,
    TransformDescription,
};
use crate::urdf::{UrdfJoint, UrdfJointKind, UrdfRobot};

/// Below this sine of the angle between consecutive axes (about 2.9 deg),
/// they are treated as parallel (Hayati beta): their common normal would lie
/// more than 20 times the axes' distance away, and a calibrated tilt of a
/// nominally parallel axis (a few mrad) would throw it kilometres off.
const PARALLEL_SINE: f64 = 0.05;

/// Below this distance (m) two axes are taken to intersect.
const INTERSECT_DISTANCE: f64 = 1e-12;

/// Options for reading a robot file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ImportOptions {
    /// Tip link of a URDF (default: the single leaf below the root).
    pub tip: Option<String>,
    /// Root link of a URDF (default: the root of the tree).
    pub root: Option<String>,
    /// Values of the symbols of a SYMORO `.par` file (TOML, SI units).
    pub values: Option<PathBuf>,
}

/// A link's mass from a URDF `<inertial>`, attached to a frame of the
/// imported description: the input of gravity-loaded (elasto-geometric) models.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinkMass {
    /// URDF link name.
    pub link: String,
    /// Name of the description frame the link is fixed to (`"0"`: R0).
    pub frame: String,
    /// Mass (kg).
    pub mass_kg: f64,
    /// Centre of mass in that frame (m).
    pub center_m: [f64; 3],
}

/// A robot read from a file: its description, the link masses the file
/// holds, and notes on what the conversion did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImportedRobot {
    /// The robot in flexcal's description.
    pub description: RobotDescription,
    /// Link masses (URDF `<inertial>`), empty for other formats.
    pub masses: Vec<LinkMass>,
    /// What the conversion chose or left out, one sentence each.
    pub notes: Vec<String>,
}

impl ImportedRobot {
    /// Reads a `.urdf` file and converts the path `options.root` to
    /// `options.tip` (see [`ImportedRobot::from_urdf`]).
    pub fn read_urdf(
        path: &std::path::Path,
        options: &ImportOptions,
    ) -> Result<Self, KinematicsError> {
        Self::from_urdf(&UrdfRobot::read(path)?, options)
    }

    /// Converts a URDF tree (see the module documentation for how).
    pub fn from_urdf(robot: &UrdfRobot, options: &ImportOptions) -> Result<Self, KinematicsError> {
        let chain = Chain::extract(robot, options)?;
        let geometry = kk_frames(&chain.lines(), &robot.source_name)?;
        assemble(robot, &chain, &geometry)
    }
}

/// The root-to-tip path of a URDF tree at the zero configuration.
struct Chain<'a> {
    root: String,
    tip: String,
    /// Joints on the path, root first.
    path: Vec<&'a UrdfJoint>,
    /// Moving joints on the path with their axis line in the root frame
    /// at the zero configuration: (joint, point, unit direction).
    moving: Vec<(&'a UrdfJoint, Vector3<f64>, Vector3<f64>)>,
    /// Pose of the tip link in the root frame at zero.
    x_root_tip: Isometry3<f64>,
    /// Pose of every link in the root frame at the zero configuration.
    x_root_link: HashMap<&'a str, Isometry3<f64>>,
}

impl<'a> Chain<'a> {
    fn extract(robot: &'a UrdfRobot, options: &ImportOptions) -> Result<Self, KinematicsError> {
        let source = robot.source_name.as_str();
        let known = || {
            robot
                .links
                .iter()
                .map(|l| l.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let unknown = |what: String| KinematicsError::UnknownLink {
            source_name: source.to_string(),
            what,
            known: known(),
        };
        let root = match &options.root {
            Some(r) => {
                if robot.link(r).is_none() {
                    return Err(unknown(format!("no link `{r}` to take as the root")));
                }
                r.clone()
            }
            None => robot.root_link().to_string(),
        };
        let below_root = |link: &str| -> bool {
            let mut l = link;
            loop {
                if l == root {
                    return true;
                }
                match robot.parent_joint(l) {
                    Some(j) => l = j.parent.as_str(),
                    None => return false,
                }
            }
        };
        let tip = match &options.tip {
            Some(t) => {
                if robot.link(t).is_none() {
                    return Err(unknown(format!("no link `{t}` to take as the tip")));
                }
                if !below_root(t) {
                    return Err(unknown(format!(
                        "the tip `{t}` is not below the root `{root}`"
                    )));
                }
                t.clone()
            }
            None => {
                let leaves: Vec<&str> = robot
                    .leaves()
                    .into_iter()
                    .filter(|l| *l != root && below_root(l))
                    .collect();
                match leaves.as_slice() {
                    [single] => single.to_string(),
                    [] => return Err(unknown(format!("no link below the root `{root}`"))),
                    _ => {
                        return Err(KinematicsError::AmbiguousTip {
                            source_name: source.to_string(),
                            candidates: leaves.join(", "),
                        });
                    }
                }
            }
        };
        let mut path = Vec::new();
        let mut link = tip.as_str();
        while link != root {
            match robot.parent_joint(link) {
                Some(j) => {
                    path.push(j);
                    link = j.parent.as_str();
                }
                None => break,
            }
        }
        path.reverse();
        // Every link's pose in the tree root's frame at zero, then relative to the chosen root.
        let mut x_tree_link: HashMap<&str, Isometry3<f64>> = HashMap::new();
        x_tree_link.insert(robot.root_link(), Isometry3::identity());
        let mut pending: Vec<&UrdfJoint> = robot.joints.iter().collect();
        while !pending.is_empty() {
            let before = pending.len();
            pending.retain(|j| match x_tree_link.get(j.parent.as_str()).copied() {
                Some(x) => {
                    x_tree_link.insert(j.child.as_str(), x * j.origin);
                    false
                }
                None => true,
            });
            if pending.len() == before {
                break; // unreachable: the reader checked the tree
            }
        }
        let x_tree_root = x_tree_link
            .get(root.as_str())
            .copied()
            .unwrap_or_else(Isometry3::identity);
        let x_root_tree = x_tree_root.inverse();
        let x_root_link: HashMap<&str, Isometry3<f64>> = x_tree_link
            .iter()
            .map(|(l, x)| (*l, x_root_tree * x))
            .collect();
        let mut moving = Vec::new();
        let mut x = Isometry3::identity();
        for j in &path {
            x *= j.origin;
            match j.kind {
                UrdfJointKind::Fixed => {}
                UrdfJointKind::Floating | UrdfJointKind::Planar => {
                    return Err(KinematicsError::Urdf {
                        source_name: source.to_string(),
                        line: j.line,
                        message: format!(
                            "joint `{}` on the path from `{root}` to `{tip}` is {}: flexcal imports revolute, continuous, prismatic and fixed joints",
                            j.name,
                            if j.kind == UrdfJointKind::Floating {
                                "floating"
                            } else {
                                "planar"
                            }
                        ),
                    });
                }
                _ => moving.push((*j, x.translation.vector, x.rotation * j.axis)),
            }
        }
        if moving.is_empty() {
            return Err(KinematicsError::Urdf {
                source_name: source.to_string(),
                line: 0,
                message: format!(
                    "no revolute, continuous or prismatic joint between `{root}` and `{tip}`"
                ),
            });
        }
        Ok(Chain {
            root,
            tip,
            path,
            moving,
            x_root_tip: x,
            x_root_link,
        })
    }

    fn lines(&self) -> Vec<(Vector3<f64>, Vector3<f64>)> {
        self.moving.iter().map(|(_, p, z)| (*p, *z)).collect()
    }
}

/// The KK quantities of one frame (SI) and the frame's pose at zero.
#[derive(Debug, Clone, Copy)]
struct KkFrame {
    gamma: f64,
    b: f64,
    alpha: f64,
    d: f64,
    beta: Option<f64>,
    theta: f64,
    r: f64,
    /// Pose of the frame in R0 at the zero configuration.
    x_root_frame: Isometry3<f64>,
}

fn rot_x(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a),
    )
}
fn rot_y(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), a),
    )
}
fn rot_z(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a),
    )
}
fn shift(v: Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(v), UnitQuaternion::identity())
}

/// `rot(z,gamma) trans(z,b) rot(x,alpha) trans(x,d) rot(y,beta)`: the
/// constant part of (41) before the joint.
fn arrival(gamma: f64, b: f64, alpha: f64, d: f64, beta: f64) -> Isometry3<f64> {
    rot_z(gamma)
        * shift(Vector3::new(0.0, 0.0, b))
        * rot_x(alpha)
        * shift(Vector3::new(d, 0.0, 0.0))
        * rot_y(beta)
}

/// A frame with origin `o`, z axis `z` and x axis `x` (made orthogonal to z).
fn frame_from(o: Vector3<f64>, x: Vector3<f64>, z: Vector3<f64>) -> Isometry3<f64> {
    let z = z.normalize();
    let x = (x - z * x.dot(&z)).normalize();
    let y = z.cross(&x);
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    Isometry3::from_parts(
        Translation3::from(o),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
}

/// Closest points of the lines (p1, z1) and (p2, z2), not parallel.
fn common_normal(
    p1: &Vector3<f64>,
    z1: &Vector3<f64>,
    p2: &Vector3<f64>,
    z2: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let w0 = p1 - p2;
    let b = z1.dot(z2);
    let d = z1.dot(&w0);
    let e = z2.dot(&w0);
    let denominator = 1.0 - b * b;
    let t1 = (b * e - d) / denominator;
    let t2 = (e - b * d) / denominator;
    (p1 + t1 * z1, p2 + t2 * z2)
}

fn is_parallel(z1: &Vector3<f64>, z2: &Vector3<f64>) -> bool {
    z1.cross(z2).norm() < PARALLEL_SINE
}

/// The KK frames of a chain of joint axes (root frame = R0), built as the
/// module documentation describes, each checked by reconstruction.
fn kk_frames(
    lines: &[(Vector3<f64>, Vector3<f64>)],
    source: &str,
) -> Result<Vec<KkFrame>, KinematicsError> {
    let n = lines.len();
    let mut frames: Vec<KkFrame> = Vec::with_capacity(n);
    let mut previous = Isometry3::identity();
    for k in 0..n {
        let (p, z) = lines[k];
        // Arrival on axis k from the previous frame: gamma, b, alpha, d, beta.
        let p_local = previous.inverse_transform_point(&p.into()).coords;
        let z_local = previous.inverse_transform_vector(&z);
        let first = k == 0;
        let (gamma, b, landing, parallel) = if !is_parallel(&Vector3::z(), &z_local) {
            let (foot0, foot1) =
                common_normal(&Vector3::zeros(), &Vector3::z(), &p_local, &z_local);
            if first {
                let normal = foot1 - foot0;
                let direction = if normal.norm() > INTERSECT_DISTANCE {
                    normal
                } else {
                    Vector3::z().cross(&z_local)
                };
                (direction.y.atan2(direction.x), foot0.z, foot1, false)
            } else {
                (0.0, 0.0, foot1, false)
            }
        } else {
            // The axis meets the plane z = 0 of the previous frame at `landing`.
            let landing = p_local - z_local * (p_local.z / z_local.z);
            let gamma = if first && landing.norm() > INTERSECT_DISTANCE {
                landing.y.atan2(landing.x)
            } else {
                0.0
            };
            (gamma, 0.0, landing, true)
        };
        let z_turned = rot_z(-gamma) * z_local;
        let landing_turned = rot_z(-gamma) * (landing - Vector3::new(0.0, 0.0, b));
        let d = landing_turned.x;
        let (alpha, beta) = if parallel {
            let beta = z_turned.x.clamp(-1.0, 1.0).asin();
            let alpha = (-z_turned.y).atan2(z_turned.z);
            let declared = !first || beta != 0.0;
            (alpha, declared.then_some(beta))
        } else {
            ((-z_turned.y).atan2(z_turned.z), None)
        };
        let x_previous_arrival = arrival(gamma, b, alpha, d, beta.unwrap_or(0.0));
        let x_root_arrival = previous * x_previous_arrival;
        // Frame k: on the common normal with axis k+1, or where it arrives.
        let x_root_frame = if k + 1 < n {
            let (p_next, z_next) = lines[k + 1];
            let o_arrival = x_root_arrival.translation.vector;
            let x_arrival = x_root_arrival.rotation * Vector3::x();
            if !is_parallel(&z, &z_next) {
                let (foot, foot_next) = common_normal(&o_arrival, &z, &p_next, &z_next);
                let normal = foot_next - foot;
                let x = if normal.norm() > INTERSECT_DISTANCE {
                    normal
                } else {
                    z.cross(&z_next)
                };
                frame_from(foot, x, z)
            } else {
                let landing_next =
                    p_next + z_next * ((o_arrival - p_next).dot(&z) / z_next.dot(&z));
                let v = landing_next - o_arrival;
                let x = if (v - z * v.dot(&z)).norm() > INTERSECT_DISTANCE {
                    v
                } else {
                    x_arrival
                };
                frame_from(o_arrival, x, z)
            }
        } else {
            x_root_arrival
        };
        let x_arrival_frame = x_root_arrival.inverse() * x_root_frame;
        let m = x_arrival_frame.rotation.to_rotation_matrix();
        let theta = m[(1, 0)].atan2(m[(0, 0)]);
        let r = x_arrival_frame.translation.vector.z;
        let frame = KkFrame {
            gamma,
            b,
            alpha,
            d,
            beta,
            theta,
            r,
            x_root_frame,
        };
        // Reconstruction check: the KK transform must give frame k.
        let rebuilt =
            previous * x_previous_arrival * rot_z(theta) * shift(Vector3::new(0.0, 0.0, r));
        let position_error = (rebuilt.translation.vector - x_root_frame.translation.vector).norm();
        let angle_error = rebuilt.rotation.angle_to(&x_root_frame.rotation);
        let axis_error = (rebuilt.rotation * Vector3::z() - z.normalize()).norm();
        let tolerance = 1e-10;
        let errors = [position_error, angle_error, axis_error];
        if errors.iter().any(|e| e.is_nan() || *e > tolerance) {
            return Err(KinematicsError::Urdf {
                source_name: source.to_string(),
                line: 0,
                message: format!(
                    "joint axis {} could not be placed in Khalil-Kleinfinger form (error {position_error:.1e} m, {angle_error:.1e} rad)",
                    k + 1
                ),
            });
        }
        // Continue from the frame as the KK transform rebuilds it, so that
        // rounding does not accumulate along the chain.
        previous = rebuilt;
        frames.push(KkFrame {
            x_root_frame: rebuilt,
            ..frame
        });
    }
    Ok(frames)
}

/// Resolves a mimic chain to its first leader: (leader, multiplier, offset).
fn resolve_mimic<'a>(
    robot: &'a UrdfRobot,
    joint: &'a UrdfJoint,
) -> Result<Option<(&'a UrdfJoint, f64, f64)>, KinematicsError> {
    let Some(first) = &joint.mimic else {
        return Ok(None);
    };
    let mut multiplier = first.multiplier;
    let mut offset = first.offset;
    let mut leader = robot.joint(&first.joint);
    for _ in 0..=robot.joints.len() {
        let Some(l) = leader else { break };
        match &l.mimic {
            None => return Ok(Some((l, multiplier, offset))),
            Some(m) => {
                // value = multiplier * (m.multiplier * next + m.offset) + offset
                offset += multiplier * m.offset;
                multiplier *= m.multiplier;
                leader = robot.joint(&m.joint);
            }
        }
    }
    Err(KinematicsError::Urdf {
        source_name: robot.source_name.clone(),
        line: joint.line,
        message: format!(
            "joint `{}`: its mimic relations form a cycle or name an unknown joint",
            joint.name
        ),
    })
}

fn joint_type(kind: UrdfJointKind) -> JointType {
    if kind == UrdfJointKind::Prismatic {
        JointType::Prismatic
    } else {
        JointType::Revolute
    }
}

fn set_limits(frame: &mut FrameDescription, joint: &UrdfJoint) {
    if let Some((lower, upper)) = joint.limits {
        if lower < upper {
            match joint.kind {
                UrdfJointKind::Revolute => {
                    frame.limits_deg = Some([lower.to_degrees(), upper.to_degrees()]);
                }
                UrdfJointKind::Prismatic => {
                    frame.limits_mm = Some([lower * 1e3, upper * 1e3]);
                }
                _ => {}
            }
        }
    }
}

/// The mimic relations of a chain's moving joints: each one's leader,
/// multiplier and offset, and the leaders that need a frame of their own
/// (`m1`, `m2`, ...: off the path, or after their follower on it).
struct Mimics<'a> {
    /// Position of each moving joint on the path, by name.
    path_index: HashMap<&'a str, usize>,
    /// The mimic relation of each moving joint of the path.
    of_path: Vec<Option<(&'a UrdfJoint, f64, f64)>>,
    /// The leaders with a side frame, in the order of their frames.
    side_leaders: Vec<&'a UrdfJoint>,
}

impl<'a> Mimics<'a> {
    fn new(robot: &'a UrdfRobot, chain: &Chain<'a>) -> Result<Self, KinematicsError> {
        let path_index: HashMap<&str, usize> = chain
            .moving
            .iter()
            .enumerate()
            .map(|(k, (j, _, _))| (j.name.as_str(), k))
            .collect();
        let mut of_path = Vec::new();
        let mut side_leaders: Vec<&UrdfJoint> = Vec::new();
        for (k, (j, _, _)) in chain.moving.iter().enumerate() {
            let mimic = resolve_mimic(robot, j)?;
            if let Some((leader, _, _)) = mimic {
                let on_path_before = path_index.get(leader.name.as_str()).is_some_and(|&i| i < k);
                if !on_path_before && !side_leaders.iter().any(|l| l.name == leader.name) {
                    side_leaders.push(leader);
                }
            }
            of_path.push(mimic);
        }
        Ok(Self {
            path_index,
            of_path,
            side_leaders,
        })
    }

    /// The side frame (`m<i>`) of the leader named `leader`, if it has one.
    fn side_name(&self, leader: &str) -> Option<String> {
        self.side_leaders
            .iter()
            .position(|l| l.name == leader)
            .map(|i| format!("m{}", i + 1))
    }

    /// The side leaders' frames (actuated, no geometry), with a note each.
    fn side_frames(&self, notes: &mut Vec<String>) -> Vec<FrameDescription> {
        let mut frames = Vec::new();
        for (i, leader) in self.side_leaders.iter().enumerate() {
            let mut f = FrameDescription::new(&format!("m{}", i + 1), "0", joint_type(leader.kind));
            f.actuated = true;
            f.actuated_name = Some(leader.name.clone());
            set_limits(&mut f, leader);
            frames.push(f);
            notes.push(format!(
                "mimic leader `{}` is {}: frame m{} carries its coordinate (no geometry, not in xi)",
                leader.name,
                if self.path_index.contains_key(leader.name.as_str()) {
                    "after its follower on the path"
                } else {
                    "off the path"
                },
                i + 1
            ));
        }
        frames
    }
}

/// The frames of the chain's moving joints (`1..n`), coupled to their
/// mimic leaders or actuated, and the actuated coordinates in order.
fn path_frames(
    chain: &Chain,
    geometry: &[KkFrame],
    mimics: &Mimics,
) -> (Vec<FrameDescription>, Vec<String>) {
    // Constant joint offset (theta or r) of each path frame, SI.
    let joint_constant = |k: usize| -> f64 {
        if chain.moving[k].0.kind == UrdfJointKind::Prismatic {
            geometry[k].r
        } else {
            geometry[k].theta
        }
    };
    let mut frames = Vec::new();
    let mut actuated_order = Vec::new();
    for (k, ((j, _, _), g)) in chain.moving.iter().zip(geometry).enumerate() {
        let name = (k + 1).to_string();
        let antecedent = if k == 0 {
            "0".to_string()
        } else {
            k.to_string()
        };
        let mut f = FrameDescription::new(&name, &antecedent, joint_type(j.kind));
        f.gamma_deg = g.gamma.to_degrees();
        f.b_mm = g.b * 1e3;
        f.alpha_deg = g.alpha.to_degrees();
        f.d_mm = g.d * 1e3;
        f.beta_deg = g.beta.map(f64::to_degrees);
        let mut constant = joint_constant(k);
        let coupling = match mimics.of_path[k] {
            Some((leader, multiplier, offset)) => match mimics.side_name(&leader.name) {
                Some(side) => {
                    constant += offset;
                    Some((side, multiplier))
                }
                None => {
                    let i = mimics.path_index[leader.name.as_str()];
                    constant += offset - multiplier * joint_constant(i);
                    Some(((i + 1).to_string(), multiplier))
                }
            },
            None => mimics.side_name(&j.name).map(|side| (side, 1.0)),
        };
        match coupling {
            Some((leader_frame, ratio)) => {
                f.coupled_to = vec![CouplingTerm {
                    frame: leader_frame,
                    ratio,
                }];
                if mimics.of_path[k].is_none() {
                    actuated_order.push(j.name.clone());
                }
            }
            None => {
                f.actuated = true;
                f.actuated_name = Some(j.name.clone());
                set_limits(&mut f, j);
                actuated_order.push(j.name.clone());
            }
        }
        if j.kind == UrdfJointKind::Prismatic {
            f.theta_deg = g.theta.to_degrees();
            f.r_mm = constant * 1e3;
        } else {
            f.theta_deg = constant.to_degrees();
            f.r_mm = g.r * 1e3;
        }
        frames.push(f);
    }
    for leader in &mimics.side_leaders {
        if !actuated_order.contains(&leader.name) {
            actuated_order.push(leader.name.clone());
        }
    }
    (frames, actuated_order)
}

/// The description, masses and notes of a converted chain: the mimic
/// leaders' side frames ([`Mimics::side_frames`]), the path's frames
/// ([`path_frames`]), the tool, the attached links and the masses.
fn assemble(
    robot: &UrdfRobot,
    chain: &Chain,
    geometry: &[KkFrame],
) -> Result<ImportedRobot, KinematicsError> {
    let mut notes = Vec::new();
    let mimics = Mimics::new(robot, chain)?;
    let mut frames = mimics.side_frames(&mut notes);
    let (path, actuated_order) = path_frames(chain, geometry, &mimics);
    frames.extend(path);
    let n = geometry.len();
    let x_root_end = geometry[n - 1].x_root_frame;
    let tool = x_root_end.inverse() * chain.x_root_tip;
    let fixed_count = chain
        .path
        .iter()
        .filter(|j| j.kind == UrdfJointKind::Fixed)
        .count();
    let mut description = RobotDescription {
        name: if robot.name.is_empty() {
            "urdf".into()
        } else {
            robot.name.clone()
        },
        notes: format!(
            "Imported from {} (root `{}`, tip `{}`): {} moving joints as Khalil-Kleinfinger frames 1-{n}, {} fixed joints folded into constant transforms; R0 is the root link's frame, the tool transform goes from frame {n} to the tip link.",
            robot.source_name, chain.root, chain.tip, n, fixed_count
        ),
        end_frame: Some(n.to_string()),
        parameters: None,
        actuated_order: Some(actuated_order),
        base: TransformDescription::default(),
        tool: TransformDescription::from_isometry(&tool),
        frames,
        loops: Vec::new(),
        links: Vec::new(),
    };
    description.links = attached_links(robot, chain, geometry, &description, &mut notes);
    if !mimics.side_leaders.is_empty() {
        // Side frames carry a coordinate only: their quantities leave xi.
        let side_frames: Vec<String> = (1..=mimics.side_leaders.len())
            .map(|i| format!("m{i}"))
            .collect();
        let model = description.build()?;
        let parameters = model
            .params()
            .iter()
            .filter(|p| !side_frames.contains(&p.frame))
            .map(|p| p.name.clone())
            .collect();
        description.parameters = Some(parameters);
    }
    let masses = link_masses(robot, chain, geometry, &mut notes);
    Ok(ImportedRobot {
        description,
        masses,
        notes,
    })
}

/// The frame carrying each link of the path (0: R0, else the frame number):
/// the last moving joint above it.
fn path_carriers<'a>(chain: &'a Chain<'a>) -> HashMap<&'a str, usize> {
    let mut carrier: HashMap<&str, usize> = HashMap::new();
    carrier.insert(chain.root.as_str(), 0);
    let mut current = 0;
    for j in &chain.path {
        if let Some(k) = chain.moving.iter().position(|(m, _, _)| m.name == j.name) {
            current = k + 1;
        }
        carrier.insert(j.child.as_str(), current);
    }
    carrier
}

/// Every link rigidly attached to the path (only fixed joints between it
/// and a link of the path), as a named place on the frame that carries it:
/// the root on R0 (`"0"`), `wrist_2_link` on its joint's frame, a flange
/// or `tool0` on the end frame. A link whose name is a frame's is left out
/// (and said so).
fn attached_links(
    robot: &UrdfRobot,
    chain: &Chain,
    geometry: &[KkFrame],
    description: &RobotDescription,
    notes: &mut Vec<String>,
) -> Vec<LinkDescription> {
    let carrier = path_carriers(chain);
    let mut links = Vec::new();
    for link in &robot.links {
        let mut l = link.name.as_str();
        let frame = loop {
            if let Some(&k) = carrier.get(l) {
                break Some(k);
            }
            match robot.parent_joint(l) {
                Some(j) if j.kind == UrdfJointKind::Fixed => l = j.parent.as_str(),
                _ => break None,
            }
        };
        let (Some(frame), Some(x_root_link)) = (frame, chain.x_root_link.get(link.name.as_str()))
        else {
            continue;
        };
        if description.frames.iter().any(|f| f.name == link.name) {
            notes.push(format!(
                "link `{}` has a frame's name: use the frame, or rename the link",
                link.name
            ));
            continue;
        }
        let x_frame_link = if frame == 0 {
            *x_root_link
        } else {
            geometry[frame - 1].x_root_frame.inverse() * x_root_link
        };
        links.push(LinkDescription::new(
            &link.name,
            &frame.to_string(),
            &x_frame_link,
        ));
    }
    links
}

/// The links' masses, each attached to the frame that carries the link.
fn link_masses(
    robot: &UrdfRobot,
    chain: &Chain,
    geometry: &[KkFrame],
    notes: &mut Vec<String>,
) -> Vec<LinkMass> {
    let carrier = path_carriers(chain);
    let mut off_path_moving = Vec::new();
    let mut masses = Vec::new();
    for link in &robot.links {
        let Some(inertial) = &link.inertial else {
            continue;
        };
        // Walk up to a link of the path (or the tree root, above the chosen root).
        let mut l = link.name.as_str();
        let mut crosses_moving = false;
        let frame = loop {
            if let Some(&k) = carrier.get(l) {
                break k;
            }
            match robot.parent_joint(l) {
                Some(j) => {
                    if j.kind != UrdfJointKind::Fixed {
                        crosses_moving = true;
                    }
                    l = j.parent.as_str();
                }
                None => break 0,
            }
        };
        if crosses_moving {
            off_path_moving.push(link.name.clone());
        }
        let Some(x_root_link) = chain.x_root_link.get(link.name.as_str()) else {
            continue;
        };
        let center_root = x_root_link * nalgebra::Point3::from(inertial.center_m);
        let center = if frame == 0 {
            center_root.coords
        } else {
            geometry[frame - 1]
                .x_root_frame
                .inverse_transform_point(&center_root)
                .coords
        };
        masses.push(LinkMass {
            link: link.name.clone(),
            frame: frame.to_string(),
            mass_kg: inertial.mass_kg,
            center_m: [center.x, center.y, center.z],
        });
    }
    if !off_path_moving.is_empty() {
        notes.push(format!(
            "links moved by joints off the path ({}) have their masses placed at those joints' zero",
            off_path_moving.join(", ")
        ));
    }
    masses
}
