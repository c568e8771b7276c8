//! Export of a (calibrated) robot for controllers, ROS and simulators: a
//! URDF whose joint origins carry the geometry, a modified-DH table (CSV or
//! Markdown, mm and deg, with Hayati beta where used), or flexcal's TOML.
//!
//! A URDF joint per frame i carries, as its `<origin>`, the constant part of
//! (41) with the frame's constant theta and r folded in,
//! `rot(z,gamma) trans(z,b) rot(x,alpha) trans(x,d) rot(y,beta) rot(z,theta) trans(z,r)`,
//! and rotates (or slides) about its z axis: `<axis xyz="0 0 1"/>`. This is
//! exact because a rotation about z commutes with a translation along z. A
//! one-term coupling (theta6 = -theta5) becomes `<mimic>` with the leader's
//! constant folded into the offset. The tool transform is a fixed joint to a
//! link `tcp`; a base transform other than the identity a fixed joint from a
//! link `cell` to R0's link `frame_0`.
//!
//! Every URDF export is read back by [`crate::ImportedRobot::from_urdf`] and
//! its poses compared with the model's at configurations spread over the
//! joint limits: the largest TCP displacement is reported
//! ([`RobotExport::max_deviation_m`]) and an export whose displacement
//! exceeds the tolerance is refused ([`KinematicsError::ExportLoss`]).
//! Closed loops, slider cranks and couplings of several joints have no place
//! in a URDF: such exports are refused by name ([`KinematicsError::Inexpressible`]).

use std::fmt::Write as _;

use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::KinematicsError;
use crate::description::{JointType, TransformDescription, rpy_from_rotation};
use crate::error::check_vector;
use crate::forward::{Data, forward_pose};
use crate::import::{ImportOptions, ImportedRobot};
use crate::model::{JointSource, Model};
use crate::urdf::UrdfRobot;

/// Target format of [`export_robot`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExportFormat {
    /// URDF (m, rad).
    Urdf,
    /// Modified-DH table as CSV (mm, deg).
    MdhCsv,
    /// Modified-DH table as Markdown (mm, deg), with base and tool.
    MdhMarkdown,
    /// flexcal's robot description TOML (mm, deg).
    Toml,
    /// A UR-style kinematics YAML (m, rad), as the UR ROS drivers'
    /// calibration files hold it: per joint (`shoulder`, `upper_arm`,
    /// `forearm`, `wrist_1`, `wrist_2`, `wrist_3`) the origin of its URDF
    /// joint, `x y z roll pitch yaw`, each joint turning about its z axis.
    /// Only for serial arms of six directly actuated revolute joints.
    UrKinematicsYaml,
}

/// Options of [`export_robot`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExportOptions {
    /// Largest TCP displacement the export may cause (m) (default 1e-9).
    pub tolerance_m: f64,
    /// Configurations checked (default 64).
    pub checked_configurations: usize,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            tolerance_m: 1e-9,
            checked_configurations: 64,
        }
    }
}

/// An exported robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotExport {
    /// The format written.
    pub format: ExportFormat,
    /// The file's text.
    pub text: String,
    /// What the format does not hold, one sentence each.
    pub dropped: Vec<String>,
    /// Largest TCP displacement of the export read back, over the checked
    /// configurations (m); `None` for the DH table, which flexcal does not read.
    pub max_deviation_m: Option<f64>,
}

/// One row of a modified-DH table: the quantities of (41) of one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MdhRow {
    /// Frame name.
    pub frame: String,
    /// Antecedent frame a(i) (`"0"`: R0).
    pub antecedent: String,
    /// sigma: 0 revolute, 1 prismatic, 2 fixed.
    pub sigma: u8,
    /// How the joint is driven: the actuated coordinate's name, a coupling, a
    /// loop or a slider crank.
    pub driven_by: String,
    /// gamma (deg).
    pub gamma_deg: f64,
    /// b (mm).
    pub b_mm: f64,
    /// alpha (deg).
    pub alpha_deg: f64,
    /// d (mm).
    pub d_mm: f64,
    /// Hayati beta (deg), where the frame uses it.
    pub beta_deg: Option<f64>,
    /// theta: the constant offset (deg).
    pub theta_deg: f64,
    /// r: the constant offset (mm).
    pub r_mm: f64,
}

/// A robot's geometry as a modified-DH (Khalil-Kleinfinger) table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MdhTable {
    /// Robot name.
    pub robot: String,
    /// One row per frame, in the model's order.
    pub rows: Vec<MdhRow>,
    /// Base transform (cell to R0).
    pub base: TransformDescription,
    /// Tool transform (end frame to TCP).
    pub tool: TransformDescription,
    /// The end frame's name.
    pub end_frame: String,
}

/// Effective SI values of frame `i`'s seven quantities at `xi` (`same_as`
/// and `plus` applied).
fn quantities(model: &Model, i: usize, xi: &[f64]) -> [f64; 7] {
    [0, 1, 2, 3, 4, 5, 6].map(|k| model.frames[i].quantity[k].eval(xi))
}

fn driven_by(model: &Model, i: usize) -> String {
    let f = &model.frames[i];
    match f.source {
        JointSource::Fixed => "fixed".into(),
        JointSource::Actuated(k) => model.actuated_names[k].clone(),
        JointSource::SliderCrank(c) => format!(
            "slider crank {}",
            model.actuated_names[model.cranks[c].actuated]
        ),
        JointSource::Coupled(c) => model.couplings[c]
            .terms
            .iter()
            .map(|&(o, ratio)| format!("{ratio} * frame {}", model.frames[o].name))
            .collect::<Vec<_>>()
            .join(" + "),
        JointSource::Passive(l) => format!(
            "loop {}",
            model.loops.get(l).map(|l| l.name.as_str()).unwrap_or("?")
        ),
    }
}

impl MdhTable {
    /// The table of `model` at parameters `xi`.
    pub fn from_model(model: &Model, xi: &[f64]) -> Result<Self, KinematicsError> {
        check_vector("xi", xi, model.n_params())?;
        let rows = (0..model.n_frames())
            .map(|i| {
                let [gamma, b, alpha, d, beta, theta, r] = quantities(model, i, xi);
                let f = &model.frames[i];
                let beta_used = model.description.frames[i].beta_deg.is_some()
                    || !f.quantity[4].terms.is_empty();
                MdhRow {
                    frame: f.name.clone(),
                    antecedent: f
                        .parent
                        .map(|p| model.frames[p].name.clone())
                        .unwrap_or_else(|| "0".into()),
                    sigma: match f.joint {
                        JointType::Revolute => 0,
                        JointType::Prismatic => 1,
                        JointType::Fixed => 2,
                    },
                    driven_by: driven_by(model, i),
                    gamma_deg: gamma.to_degrees(),
                    b_mm: b * 1e3,
                    alpha_deg: alpha.to_degrees(),
                    d_mm: d * 1e3,
                    beta_deg: beta_used.then(|| beta.to_degrees()),
                    theta_deg: theta.to_degrees(),
                    r_mm: r * 1e3,
                }
            })
            .collect();
        Ok(MdhTable {
            robot: model.name.clone(),
            rows,
            base: TransformDescription::from_isometry(&model.base),
            tool: TransformDescription::from_isometry(&model.tool),
            end_frame: model.frames[model.end_frame].name.clone(),
        })
    }

    /// The table as CSV: one header line, one line per frame (mm, deg; an
    /// empty `beta_deg` where the frame has no Hayati angle).
    pub fn to_csv(&self) -> String {
        let mut out = String::from(
            "frame,antecedent,sigma,driven_by,gamma_deg,b_mm,alpha_deg,d_mm,beta_deg,theta_deg,r_mm\n",
        );
        for r in &self.rows {
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{},{},{},{},{}",
                csv_field(&r.frame),
                csv_field(&r.antecedent),
                r.sigma,
                csv_field(&r.driven_by),
                r.gamma_deg,
                r.b_mm,
                r.alpha_deg,
                r.d_mm,
                r.beta_deg.map(|b| b.to_string()).unwrap_or_default(),
                r.theta_deg,
                r.r_mm
            );
        }
        out
    }

    /// The table as Markdown (values to 1e-6 mm and deg), with the base and
    /// tool transforms below it.
    pub fn to_markdown(&self) -> String {
        let mut out = format!(
            "# {}: modified-DH (Khalil-Kleinfinger) parameters\n\n\
             `a(i)T_i = rot(z,gamma) trans(z,b) rot(x,alpha) trans(x,d) rot(y,beta) rot(z,theta + q) trans(z,r)` \
             (q added to r instead for prismatic joints).\n\n\
             | frame | a(i) | sigma | driven by | gamma (deg) | b (mm) | alpha (deg) | d (mm) | beta (deg) | theta (deg) | r (mm) |\n\
             |---|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
            self.robot
        );
        for r in &self.rows {
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {:.6} | {:.6} | {:.6} | {:.6} | {} | {:.6} | {:.6} |",
                r.frame,
                r.antecedent,
                r.sigma,
                r.driven_by,
                r.gamma_deg,
                r.b_mm,
                r.alpha_deg,
                r.d_mm,
                r.beta_deg
                    .map(|b| format!("{b:.6}"))
                    .unwrap_or_else(|| "-".into()),
                r.theta_deg,
                r.r_mm
            );
        }
        let transform = |t: &TransformDescription| {
            format!(
                "translation ({:.6}, {:.6}, {:.6}) mm, roll-pitch-yaw ({:.6}, {:.6}, {:.6}) deg",
                t.translation_mm[0],
                t.translation_mm[1],
                t.translation_mm[2],
                t.rpy_deg[0],
                t.rpy_deg[1],
                t.rpy_deg[2]
            )
        };
        let _ = write!(
            out,
            "\nBase (cell to R0): {}.\nTool (frame {} to TCP): {}; `R = Rz(yaw) Ry(pitch) Rx(roll)`.\n",
            transform(&self.base),
            self.end_frame,
            transform(&self.tool)
        );
        out
    }
}

fn csv_field(s: &str) -> String {
    if s.contains(',') || s.contains('"') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn origin_element(x: &Isometry3<f64>) -> String {
    let t = x.translation.vector;
    let rpy = rpy_from_rotation(x.rotation.to_rotation_matrix().matrix());
    format!(
        "<origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
        t.x, t.y, t.z, rpy[0], rpy[1], rpy[2]
    )
}

fn rotation_z(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a),
    )
}

/// The constant transform of frame `i` with its theta and r folded in.
fn joint_origin(model: &Model, i: usize, xi: &[f64]) -> Isometry3<f64> {
    let part = model.frames[i].constant_part(xi);
    let pre = Isometry3::from_parts(
        Translation3::from(part.pre.p),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(part.pre.r)),
    );
    pre * rotation_z(part.theta) * Translation3::new(0.0, 0.0, part.r)
}

/// The names a UR kinematics file gives its six joints, base to flange.
pub const UR_JOINTS: [&str; 6] = [
    "shoulder",
    "upper_arm",
    "forearm",
    "wrist_1",
    "wrist_2",
    "wrist_3",
];

/// The origins of the six joints of a UR-style arm at `xi`: each the
/// transform from the previous joint's frame (R0 for the first) to its own,
/// fixed frames on the way folded in; fixed frames after the sixth joint
/// belong with the tool (returned second: sixth joint's frame to the end
/// frame). Refused by name for another structure.
fn ur_joint_origins(model: &Model, xi: &[f64]) -> Result<UrJoints, KinematicsError> {
    let refuse = |what: String| KinematicsError::Inexpressible {
        format: "UR kinematics YAML".into(),
        what,
    };
    if !model.is_serial() {
        return Err(refuse(
            "a closed loop, coupling or slider crank: a UR kinematics file holds six revolute joints in series".into(),
        ));
    }
    let mut origins = Vec::with_capacity(6);
    let mut names = Vec::with_capacity(6);
    let mut pending = Isometry3::identity();
    for &i in &model.tcp_path {
        let f = &model.frames[i];
        pending *= joint_origin(model, i, xi);
        match (f.joint, f.source) {
            (JointType::Fixed, _) => {}
            (JointType::Revolute, JointSource::Actuated(_)) => {
                origins.push(pending);
                names.push(joint_name(model, i));
                pending = Isometry3::identity();
            }
            _ => {
                return Err(refuse(format!(
                    "joint `{}` is not a directly actuated revolute joint",
                    f.name
                )));
            }
        }
    }
    if origins.len() != 6 || model.n_actuated() != 6 {
        return Err(refuse(format!(
            "{} revolute joints on the path to the TCP ({} actuated): a UR kinematics file holds six",
            origins.len(),
            model.n_actuated()
        )));
    }
    Ok(UrJoints {
        origins,
        names,
        flange: pending,
    })
}

/// The six joints of a UR-style arm ([`ur_joint_origins`]).
struct UrJoints {
    /// Each joint's origin in the previous joint's frame (R0 for the first).
    origins: Vec<Isometry3<f64>>,
    /// The actuated coordinates' names, in the same order.
    names: Vec<String>,
    /// The sixth joint's frame to the end frame (fixed frames after it).
    flange: Isometry3<f64>,
}

/// The YAML text of six joint origins (written by hand: flat keys, full precision).
fn ur_yaml_text(name: &str, origins: &[Isometry3<f64>]) -> String {
    let mut out = format!(
        concat!(
            "# {}: UR-style kinematics exported by flexcal. Per joint the origin of its URDF joint\n",
            "# in the previous joint's frame: x, y, z (m), roll, pitch, yaw (rad, R = Rz(yaw) Ry(pitch) Rx(roll));\n",
            "# every joint turns about its own z axis.\nkinematics:\n"
        ),
        name.replace('\n', " ")
    );
    for (joint, x) in UR_JOINTS.iter().zip(origins) {
        let t = x.translation.vector;
        let [roll, pitch, yaw] = rpy_from_rotation(x.rotation.to_rotation_matrix().matrix());
        let _ = writeln!(out, "  {joint}:");
        for (key, value) in [
            ("x", t.x),
            ("y", t.y),
            ("z", t.z),
            ("roll", roll),
            ("pitch", pitch),
            ("yaw", yaw),
        ] {
            let _ = writeln!(out, "    {key}: {value:?}");
        }
    }
    out
}

/// The URDF a UR kinematics file stands for: links `base_link`, the six
/// joints' links and `tcp` (through `tool`), every joint about z and named
/// as the robot's actuated coordinate.
fn ur_urdf_text(joints: &UrJoints, tool: &Isometry3<f64>) -> String {
    let mut out = String::from("<robot name=\"ur\">\n  <link name=\"base_link\"/>\n");
    for joint in UR_JOINTS {
        let _ = writeln!(out, "  <link name=\"{joint}_link\"/>");
    }
    out.push_str("  <link name=\"tcp\"/>\n");
    let mut parent = "base_link".to_string();
    for ((joint, x), name) in UR_JOINTS.iter().zip(&joints.origins).zip(&joints.names) {
        let name = xml_escape(name);
        let _ = writeln!(
            out,
            "  <joint name=\"{name}\" type=\"revolute\">\n    <parent link=\"{parent}\"/>\n    <child link=\"{joint}_link\"/>\n    {}\n    <axis xyz=\"0 0 1\"/>\n    <limit lower=\"-6.3\" upper=\"6.3\" effort=\"0\" velocity=\"0\"/>\n  </joint>",
            origin_element(x)
        );
        parent = format!("{joint}_link");
    }
    let _ = writeln!(
        out,
        "  <joint name=\"tool\" type=\"fixed\">\n    <parent link=\"{parent}\"/>\n    <child link=\"tcp\"/>\n    {}\n  </joint>\n</robot>",
        origin_element(tool)
    );
    out
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Name of the URDF link of frame `i`.
fn link_name(model: &Model, i: usize) -> String {
    format!("frame_{}", model.frames[i].name)
}

/// Name of the URDF joint of frame `i`: the actuated coordinate's name for
/// a directly actuated joint, `joint_{frame}` otherwise.
fn joint_name(model: &Model, i: usize) -> String {
    match model.frames[i].source {
        JointSource::Actuated(k) => model.actuated_names[k].clone(),
        _ => format!("joint_{}", model.frames[i].name),
    }
}

/// The URDF text of `model` at `xi`, and what it leaves out.
fn urdf_text(model: &Model, xi: &[f64]) -> Result<(String, Vec<String>), KinematicsError> {
    let refuse = |what: String| KinematicsError::Inexpressible {
        format: "URDF".into(),
        what,
    };
    if let Some(l) = model.loops.first() {
        return Err(refuse(format!(
            "the closed loop `{}` (cut at frames `{}` and `{}`): a URDF holds trees only",
            l.name, model.frames[l.cut_a].name, model.frames[l.cut_b].name
        )));
    }
    if let Some(c) = model.cranks.first() {
        return Err(refuse(format!(
            "the slider crank driving `{}`: a URDF joint cannot be driven by a screw length",
            model.actuated_names[c.actuated]
        )));
    }
    let mut out = format!(
        "<?xml version=\"1.0\"?>\n<!-- {}: exported by flexcal; joint origins carry the geometry \
         (Khalil-Kleinfinger frames, every joint about or along its z axis). -->\n<robot name=\"{}\">\n",
        xml_escape(&model.name).replace("--", "- -"),
        xml_escape(&model.name)
    );
    let base_is_identity = model.base == Isometry3::identity();
    if !base_is_identity {
        out.push_str("  <link name=\"cell\"/>\n");
    }
    out.push_str("  <link name=\"frame_0\"/>\n");
    for i in 0..model.n_frames() {
        let _ = writeln!(
            out,
            "  <link name=\"{}\"/>",
            xml_escape(&link_name(model, i))
        );
    }
    out.push_str("  <link name=\"tcp\"/>\n");
    if !base_is_identity {
        let _ = writeln!(
            out,
            "  <joint name=\"cell_to_base\" type=\"fixed\">\n    <parent link=\"cell\"/>\n    <child link=\"frame_0\"/>\n    {}\n  </joint>",
            origin_element(&model.base)
        );
    }
    for i in 0..model.n_frames() {
        let f = &model.frames[i];
        let parent = f
            .parent
            .map(|p| link_name(model, p))
            .unwrap_or_else(|| "frame_0".into());
        let mut body = format!(
            "    <parent link=\"{}\"/>\n    <child link=\"{}\"/>\n    {}\n",
            xml_escape(&parent),
            xml_escape(&link_name(model, i)),
            origin_element(&joint_origin(model, i, xi))
        );
        let kind = match (f.joint, f.source) {
            (JointType::Fixed, _) => "fixed",
            (JointType::Prismatic, _) => "prismatic",
            (JointType::Revolute, JointSource::Coupled(_)) => "continuous",
            (JointType::Revolute, _) => "revolute",
        };
        if f.joint != JointType::Fixed {
            body.push_str("    <axis xyz=\"0 0 1\"/>\n");
        }
        match f.source {
            JointSource::Actuated(k) => {
                let (lower, upper) = model.actuated_limits[k];
                let _ = writeln!(
                    body,
                    "    <limit lower=\"{lower}\" upper=\"{upper}\" effort=\"0\" velocity=\"0\"/>"
                );
            }
            JointSource::Coupled(c) => {
                let terms = &model.couplings[c].terms;
                if terms.len() != 1 {
                    return Err(refuse(format!(
                        "the coupling of joint `{}` to {} joints: a URDF mimic follows one joint",
                        f.name,
                        terms.len()
                    )));
                }
                let (leader, ratio) = terms[0];
                let [_, _, _, _, _, theta, r] = quantities(model, leader, xi);
                let constant = if model.frames[leader].joint == JointType::Prismatic {
                    r
                } else {
                    theta
                };
                if f.joint == JointType::Prismatic {
                    body.push_str(
                        "    <limit lower=\"-1000\" upper=\"1000\" effort=\"0\" velocity=\"0\"/>\n",
                    );
                }
                let _ = writeln!(
                    body,
                    "    <mimic joint=\"{}\" multiplier=\"{ratio}\" offset=\"{}\"/>",
                    xml_escape(&joint_name(model, leader)),
                    ratio * constant
                );
            }
            _ => {}
        }
        let _ = writeln!(
            out,
            "  <joint name=\"{}\" type=\"{kind}\">\n{body}  </joint>",
            xml_escape(&joint_name(model, i))
        );
    }
    let _ = writeln!(
        out,
        "  <joint name=\"tool\" type=\"fixed\">\n    <parent link=\"{}\"/>\n    <child link=\"tcp\"/>\n    {}\n  </joint>\n</robot>",
        xml_escape(&link_name(model, model.end_frame)),
        origin_element(&model.tool)
    );
    let mut dropped = vec![
        "the parameter vector xi (which quantities are identified): URDF has no notion of it"
            .to_string(),
    ];
    if model.description.actuated_order.is_some() {
        dropped.push(
            "the order of the actuated coordinates (URDF joints are named, not ordered)".into(),
        );
    }
    Ok((out, dropped))
}

/// Configurations spread over the joint limits (a fixed low-discrepancy
/// sequence, the same on every run), limits capped at +-2 pi and +-2 m.
fn spread_configurations(model: &Model, count: usize) -> Vec<Vec<f64>> {
    // Additive recurrence with the square roots of primes as steps.
    const STEPS: [f64; 12] = [
        0.414_213_562_373_095,
        0.732_050_807_568_877,
        0.236_067_977_499_79,
        0.645_751_311_064_591,
        0.316_624_790_355_4,
        0.605_551_275_463_989,
        0.123_105_625_617_661,
        0.358_898_943_540_674,
        0.795_831_523_312_719,
        0.385_164_807_134_504,
        0.567_764_362_830_022,
        0.082_762_530_298_219,
    ];
    (0..count)
        .map(|n| {
            model
                .actuated_limits
                .iter()
                .enumerate()
                .map(|(k, &(lo, hi))| {
                    let cap = if model.actuated_kinds[k] == crate::ActuatedKind::Revolute {
                        std::f64::consts::TAU
                    } else {
                        2.0
                    };
                    let (lo, hi) = (lo.max(-cap), hi.min(cap));
                    let u = ((n as f64 + 0.5) * STEPS[k % STEPS.len()] + k as f64 * 0.1).fract();
                    lo + u * (hi - lo)
                })
                .collect()
        })
        .collect()
}

/// Largest TCP displacement between `model` at `xi` and `other` (nominal),
/// matching actuated coordinates by name.
fn max_deviation(
    model: &Model,
    xi: &[f64],
    other: &Model,
    count: usize,
) -> Result<f64, KinematicsError> {
    let mut order = Vec::with_capacity(other.n_actuated());
    for name in other.actuated_names() {
        let k = model
            .actuated_names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| KinematicsError::Invalid {
                what: format!(
                    "the export read back has an actuated coordinate `{name}` the robot lacks"
                ),
            })?;
        order.push(k);
    }
    let mut data = Data::new(model);
    let mut other_data = Data::new(other);
    let other_xi = other.nominal_params().to_vec();
    let mut worst = 0.0f64;
    for q in spread_configurations(model, count) {
        let x = forward_pose(model, &mut data, &q, xi)?;
        let q_other: Vec<f64> = order.iter().map(|&k| q[k]).collect();
        let y = forward_pose(other, &mut other_data, &q_other, &other_xi)?;
        worst = worst.max((x.translation.vector - y.translation.vector).norm());
        // An orientation error seen 1 m away.
        worst = worst.max(x.rotation.angle_to(&y.rotation));
    }
    Ok(worst)
}

/// Exports `model` at parameters `xi` (a calibrated robot: its identified
/// parameters) to `format`; see the module documentation.
pub fn export_robot(
    model: &Model,
    xi: &[f64],
    format: ExportFormat,
    options: &ExportOptions,
) -> Result<RobotExport, KinematicsError> {
    check_vector("xi", xi, model.n_params())?;
    if options.tolerance_m.is_nan() || options.tolerance_m < 0.0 {
        return Err(KinematicsError::NotFinite {
            what: "export tolerance".into(),
        });
    }
    let loss = |format: &str, what: String, deviation: f64| {
        if deviation > options.tolerance_m {
            Err(KinematicsError::ExportLoss {
                format: format.into(),
                what,
                loss: deviation,
                tolerance: options.tolerance_m,
            })
        } else {
            Ok(())
        }
    };
    match format {
        ExportFormat::Urdf => {
            let (text, dropped) = urdf_text(model, xi)?;
            let robot = UrdfRobot::parse(&text, "exported URDF")?;
            let read_back = ImportedRobot::from_urdf(
                &robot,
                &ImportOptions {
                    root: Some("frame_0".into()),
                    tip: Some("tcp".into()),
                    values: None,
                },
            )?
            .description
            .build()?;
            let deviation = max_deviation(model, xi, &read_back, options.checked_configurations)?;
            loss("URDF", "the URDF read back moves the TCP".into(), deviation)?;
            Ok(RobotExport {
                format,
                text,
                dropped,
                max_deviation_m: Some(deviation),
            })
        }
        ExportFormat::Toml => {
            let description = model.description_with_params(xi)?;
            let text = description.to_toml_string();
            let read_back =
                crate::RobotDescription::from_toml_str(&text, "exported TOML")?.build()?;
            let deviation = max_deviation(model, xi, &read_back, options.checked_configurations)?;
            loss("TOML", "the TOML read back moves the TCP".into(), deviation)?;
            Ok(RobotExport {
                format,
                text,
                dropped: Vec::new(),
                max_deviation_m: Some(deviation),
            })
        }
        ExportFormat::UrKinematicsYaml => {
            let joints = ur_joint_origins(model, xi)?;
            let text = ur_yaml_text(&model.name, &joints.origins);
            // Read back through the URDF the values stand for (the flange
            // and tool appended for the comparison only).
            let tool = joints.flange * model.tool;
            let robot = UrdfRobot::parse(&ur_urdf_text(&joints, &tool), "UR kinematics")?;
            let read_back = ImportedRobot::from_urdf(&robot, &ImportOptions::default())?
                .description
                .build()?;
            let deviation = max_deviation(model, xi, &read_back, options.checked_configurations)?;
            loss(
                "UR kinematics YAML",
                "its joints read back as a URDF move the TCP".into(),
                deviation,
            )?;
            let mut dropped = vec![
                "the fixed frames after the sixth joint, the tool transform (flange to TCP) and the base transform: a UR kinematics file holds the six joints only".to_string(),
                "the joint limits, the joint names and the parameter vector's choice of identified quantities".to_string(),
                "the `hash` a UR controller writes (its calibration checksum)".to_string(),
            ];
            if tool == Isometry3::identity() && model.base == Isometry3::identity() {
                dropped.remove(0);
            }
            Ok(RobotExport {
                format,
                text,
                dropped,
                max_deviation_m: Some(deviation),
            })
        }
        ExportFormat::MdhCsv | ExportFormat::MdhMarkdown => {
            let table = MdhTable::from_model(model, xi)?;
            let mut dropped = Vec::new();
            if !model.cranks.is_empty() {
                dropped.push(
                    "the slider cranks' geometry (kappa, lambda, l1, l3, screw offsets) has no column in a DH table"
                        .into(),
                );
            }
            if format == ExportFormat::MdhCsv {
                dropped.push(
                    "the base and tool transforms (in the Markdown table and the TOML)".into(),
                );
            }
            let text = if format == ExportFormat::MdhCsv {
                table.to_csv()
            } else {
                table.to_markdown()
            };
            Ok(RobotExport {
                format,
                text,
                dropped,
                max_deviation_m: None,
            })
        }
    }
}
