//! Joint compliances under gravity: the elastic part of the elasto-geometric
//! calibration model.
//!
//! The links are rigid and every actuated coordinate has a joint spring of
//! compliance `c_i` (rad/N.m for revolute joints, m/N for prismatic joints
//! and screws). Under the weights of the links (point masses with known mass
//! and centre of mass) and of the payload (a probe, a tool: mass and centre
//! unknown), the springs deflect the actuated coordinates by
//! `dq_i = c_i tau_i(q)`, where `tau = sum_k J_k^T m_k g` is the generalised
//! gravity force (virtual work, [`flexcal_kinematics::actuated_forces_into`]).
//! This is the static equilibrium of the joint-spring model of the paper's
//! section 2.2 (equations (13)-(16), rigid links, load = gravity) to first
//! order in the deflection; the calibration then predicts the pose at
//! `FK(q + dq, xi)`. A test (`tests/gravity_fem.rs`) checks the predicted
//! TCP deflection against flexcal-fem's frame model of the same robot (stiff
//! beams, joint springs, the weights as nodal loads): they agree to 0.2 %.
//!
//! The payload enters linearly through its mass `m` (kg) and first moment
//! `m c` (kg.m, centre `c` in the payload's frame: the TCP by default, or
//! any named frame, [`GravityCompliance::payload_frame`]), so that
//! `tau = tau_links + m a(q) + B(q) (m c)`; the torques are evaluated on the
//! nominal geometry (a geometric error of a millimetre changes them by about
//! 0.1 %, far below what gravity deflection can resolve).
//!
//! ## Several payloads
//! A robot with two hands, or a tool that carries several targets, has a
//! payload on each: [`GravityCompliance::payloads`] adds further ones, each
//! on its named frame ([`Payload`]). An identified one enters like the
//! first, linearly through its own mass and first moment (unknowns
//! `payload_<name>_mass`, `payload_<name>_mx..mz`, after the first
//! payload's), so that `tau = tau_links + sum_p (m_p a_p(q) + B_p(q) (m
//! c)_p)` and each lateral moment alike, and its derivatives are exact in
//! the same way. A known one (`identify = false`) is a weight like a link's
//! and adds no unknown. The first payload keeps its names and its place:
//! a table without further payloads gives the model it always gave.
//!
//! ## Lateral (transversal) joint compliances
//! A joint's bearing and gear also tilt under the bending moment they
//! carry: the structure outboard of joint j turns about axes other than
//! the joint's own. With [`GravityCompliance::lateral`] set to
//! [`LateralCompliance::AboutX`], every revolute joint j gets a lateral
//! compliance `cx_j` (rad/N.m, unknown `lateral_compliance_<joint>_x`): the
//! outboard structure turns by
//!
//! `delta_j = cx_j Mx_j`, `Mx_j = x_j . sum_k (p_k - o_j) x m_k g`
//!
//! about the x axis `x_j` of the joint's frame through its origin `o_j`
//! (the common normal to this joint's axis and the next one, the direction
//! of the next frame's `alpha`), where the sum runs over every weight the
//! joint carries: the links fixed to its frame or to frames after it in
//! the description's tree (both arms, for a torso that carries two) and the
//! payload. Like the joint torques, `Mx_j = Mx_links + m ax + bx . (m c)`
//! is linear in the payload, and the axes, origins and moments are
//! evaluated on the nominal geometry at the commanded configuration.
//!
//! The small rotations are composed to first order, as one rigid motion
//! applied to the robot evaluated at `q + dq`: `x_base_tcp' = G x_base_tcp`
//! with `G = (Exp(phi), t)`, `phi = sum_j delta_j x_j`, `t = -sum_j
//! delta_j x_j x o_j`. Each `delta_j` alone is the exact rotation of the
//! outboard structure about its axis; several compose with an error of
//! the order of the products `delta_i delta_j` (below 1e-7 rad for
//! deflections of 0.3 mrad), and axes taken on the nominal geometry
//! instead of the deflected one err by the product of a deflection and
//! a geometric error (0.1 um for 0.1 mrad and 1 mm). The derivatives of
//! this model are exact ([`crate::ErrorModel`]).
//!
//! The rotation about the joint frame's y axis is not modelled: for
//! perpendicular successive axes (`alpha = +-90 deg`) it is a rotation about
//! the next joint's axis, through the next origin when the frames share it,
//! and then the same motion, under the same moment, as that joint's own
//! compliance (not identifiable apart from it).
//!
//! Limitations of the lateral terms: linear springs only (no hardening
//! law); "outboard" follows the antecedents of the description's tree, so
//! on a closed loop the weights beyond the loop's cut joint count for the
//! branch that holds them in the tree; the rotation moves the TCP only for
//! joints on its path (a joint of another branch has no influence on it).

use flexcal_kinematics::{
    Data, LinkMass, Model, PointLoad, actuated_forces_into, frame_points_jacobians_into,
    joint_jacobian_into,
};
use nalgebra::{DMatrix, Isometry3, Matrix6xX, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::error::CalibError;

use crate::measurement::MeasurementSet;

/// Standard gravity (m/s^2).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// A link's mass concentrated at its centre of mass.
#[derive(Debug, Clone, PartialEq)]
pub struct PointMass {
    /// Name of the link (for reports).
    pub name: String,
    /// Name of the robot frame the link is fixed to.
    pub frame: String,
    /// Mass (kg, `>= 0`).
    pub mass: f64,
    /// Centre of mass in that frame (m).
    pub center: Vector3<f64>,
}

/// The gravity loading of a robot and the starting values of its elastic
/// unknowns: what [`crate::CalibrationOptions::gravity`] needs to make the
/// identification elasto-geometric.
#[derive(Debug, Clone, PartialEq)]
pub struct GravityCompliance {
    /// Gravity in the robot base frame R0 (m/s^2; default straight down
    /// along -z0 for a floor-mounted robot).
    pub gravity: Vector3<f64>,
    /// The links' masses (known, not identified).
    pub masses: Vec<PointMass>,
    /// Starting payload mass (kg).
    pub payload_mass: f64,
    /// Starting payload centre of mass (m) in the payload's frame.
    pub payload_center: Vector3<f64>,
    /// The frame the payload is fixed to (default `None`: the TCP, the end
    /// frame followed by the tool): a load carried by a link, a tool
    /// changer on a hand of a two-armed robot.
    pub payload_frame: Option<String>,
    /// Starting joint compliance (rad/N.m or m/N): a plausible value, not
    /// zero, so that the payload's influence (proportional to the
    /// compliances) is seen by the identifiability analysis.
    pub initial_compliance: f64,
    /// Lateral joint compliances under the gravity moment (module docs;
    /// default [`LateralCompliance::Off`]). Their unknowns start at zero
    /// (rad/N.m).
    pub lateral: LateralCompliance,
    /// Springs about the axes of named frames (module docs, "Springs on
    /// any frame"): a passive or coupled joint's own axis, a fixed
    /// mounting's two bending axes, a base on a pivot (default none).
    pub springs: Vec<Spring>,
    /// Further payloads beyond the one above, each on its named frame (one
    /// per hand or target of a robot with several), each identified or
    /// known (module docs, "Several payloads"; default none).
    pub payloads: Vec<Payload>,
    /// How the deflection is computed: one linear step on the commanded
    /// configuration (default), or the static equilibrium
    /// ([`crate::deflection`]).
    pub deflection: crate::deflection::Deflection,
    /// Coupled joint groups whose compliance is a symmetric matrix
    /// ([`CouplingGroup`]: unknowns `coupling_compliance_<A>_<B>`,
    /// rad/N.m, starting at zero; default none).
    pub coupling: Vec<CouplingGroup>,
}

/// A further payload ([`GravityCompliance::payloads`]): a load fixed to a
/// named frame, its mass and centre identified (unknowns
/// `payload_<name>_mass`, kg, and `payload_<name>_mx..mz`, its first moment
/// in that frame, kg.m) or known (then it loads the joints as a link of
/// the mass table does, without unknowns).
#[derive(Debug, Clone, PartialEq)]
pub struct Payload {
    /// Its name, in its unknowns' names (letters, digits, `-` and `_`).
    pub name: String,
    /// The frame it is fixed to: a frame of the robot, or `tcp` (the end
    /// frame followed by the tool).
    pub frame: String,
    /// Mass (kg, finite): the starting value when identified, the value
    /// when known.
    pub mass: f64,
    /// Centre of mass in its frame (m): starting value or value, as the
    /// mass.
    pub center: Vector3<f64>,
    /// Whether its mass and first moment are identified (`true`) or known.
    pub identify: bool,
}

impl Payload {
    /// Its unknowns' names: `payload_<name>_mass` (kg), then
    /// `payload_<name>_mx`, `_my`, `_mz` (kg.m).
    pub fn unknown_names(&self) -> [String; 4] {
        ["mass", "mx", "my", "mz"].map(|q| format!("payload_{}_{q}", self.name))
    }
}

/// Where an identified payload sits: the frame it is fixed to, its pose
/// in that frame, and whether it is the TCP.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PayloadSite {
    pub frame: usize,
    pub x_frame_payload: Isometry3<f64>,
    pub on_tcp: bool,
}

/// The frame a payload named to sit on `frame` is fixed to (`None` or
/// `tcp`: the end frame followed by the tool).
///
/// # Errors
/// [`CalibError::InvalidOption`] naming a frame the robot does not have.
fn payload_site(model: &Model, frame: Option<&str>) -> Result<PayloadSite, CalibError> {
    match frame {
        None | Some(crate::frames::TCP_FRAME) => Ok(PayloadSite {
            frame: model.end_frame(),
            x_frame_payload: model.tool(),
            on_tcp: true,
        }),
        Some(name) => model
            .frame_index(name)
            .map(|f| PayloadSite {
                frame: f,
                x_frame_payload: Isometry3::identity(),
                on_tcp: false,
            })
            .ok_or_else(|| CalibError::InvalidOption {
                name: "gravity",
                reason: format!(
                    "payload frame `{name}`: robot `{}` has no frame `{name}` (frames: {}, or `tcp`)",
                    model.name(),
                    model.frame_names().join(", ")
                ),
            }),
    }
}

/// An axis of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrameAxis {
    /// The frame's x axis.
    X,
    /// The frame's y axis.
    Y,
    /// The frame's z axis (a joint's own axis).
    Z,
}

impl FrameAxis {
    /// The axis as a unit vector of its frame.
    pub fn unit(self) -> Vector3<f64> {
        match self {
            FrameAxis::X => Vector3::x(),
            FrameAxis::Y => Vector3::y(),
            FrameAxis::Z => Vector3::z(),
        }
    }

    /// `x`, `y` or `z`.
    pub fn letter(self) -> &'static str {
        match self {
            FrameAxis::X => "x",
            FrameAxis::Y => "y",
            FrameAxis::Z => "z",
        }
    }
}

/// A linear rotational spring about one axis of a named frame: everything
/// that moves with the frame (the links fixed to it and to the frames after
/// it, and the payload when the end frame is among them) turns about the
/// axis, through `pivot`, by `c M`, with `M` the gravity moment of that
/// structure about the axis and `c` the unknown
/// `lateral_compliance_<frame>_<axis>` (rad/N.m, starts at zero).
#[derive(Debug, Clone, PartialEq)]
pub struct Spring {
    /// Name of the robot frame (a passive joint, a fixed mounting, the base).
    pub frame: String,
    /// The axis of that frame the structure turns about.
    pub axis: FrameAxis,
    /// The point of the axis, in the frame (m; default its origin).
    pub pivot: Vector3<f64>,
}

impl Spring {
    /// The unknown's name: `lateral_compliance_<frame>_<axis>`.
    pub fn unknown_name(&self) -> String {
        format!("lateral_compliance_{}_{}", self.frame, self.axis.letter())
    }
}

/// The prefix of the off-diagonal unknowns' names.
pub const COUPLING_PREFIX: &str = "coupling_compliance_";

/// A mass table's `[[coupling_compliance]]` entry: a passive joint and
/// drives it is coupled to, whose compliance is one symmetric matrix
/// (the coupling module's docs: the symmetric matrix, its bound).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingGroup {
    /// Frame names of the group's joints: exactly one passive (coupled)
    /// joint and one or more actuated joints it is coupled to, each once.
    pub joints: Vec<String>,
}

impl CouplingGroup {
    /// The off-diagonal unknowns' names, `coupling_compliance_<A>_<B>`
    /// (rad/N.m) for each pair of joints in the entry's order.
    pub fn unknown_names(&self) -> Vec<String> {
        let mut names = Vec::new();
        for (a, first) in self.joints.iter().enumerate() {
            for second in &self.joints[a + 1..] {
                names.push(format!("{COUPLING_PREFIX}{first}_{second}"));
            }
        }
        names
    }

    /// What is wrong with the entry on its own (too few joints, a joint
    /// listed twice), if anything.
    pub(crate) fn defect(&self) -> Option<String> {
        if self.joints.len() < 2 {
            return Some(
                "give the passive joint and one or more drives it is coupled to".to_string(),
            );
        }
        self.joints
            .iter()
            .enumerate()
            .find(|(k, j)| self.joints[..*k].contains(j))
            .map(|(_, j)| format!("joint `{j}` is listed twice"))
    }
}

/// Whether `name` is an off-diagonal coupling compliance (no non-negative
/// bound: its sign is free, the group's matrix is bounded instead).
pub fn is_coupling_compliance(name: &str) -> bool {
    name.starts_with(COUPLING_PREFIX)
}

/// Which lateral (transversal) joint compliances the elasto-geometric
/// model has (module docs, "Lateral joint compliances").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LateralCompliance {
    /// None: joints deflect about their own axes only (default).
    #[default]
    Off,
    /// Each revolute joint's outboard structure also turns about the x
    /// axis of the joint's frame (rad/N.m, `lateral_compliance_<joint>_x`)
    /// under the gravity moment about that axis.
    AboutX,
}

impl std::str::FromStr for LateralCompliance {
    type Err = String;
    /// `off` or `x`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "off" => Ok(Self::Off),
            "x" => Ok(Self::AboutX),
            other => Err(format!("`{other}`: expected off or x")),
        }
    }
}

/// Names of the lateral compliances about x of `model`
/// (`lateral_compliance_<joint>_x`, rad/N.m), one per [`lateral_joints`].
pub fn lateral_compliance_names(model: &Model) -> Vec<String> {
    lateral_joints(model)
        .iter()
        .map(|&i| format!("lateral_compliance_{}_x", model.actuated_names()[i]))
        .collect()
}

/// The revolute actuated coordinates that get a lateral compliance (their
/// indices in q): every revolute one with a frame.
pub fn lateral_joints(model: &Model) -> Vec<usize> {
    model
        .actuated_kinds()
        .iter()
        .enumerate()
        .filter(|(i, k)| {
            matches!(k, flexcal_kinematics::ActuatedKind::Revolute)
                && model.actuated_frame(*i).is_some()
        })
        .map(|(i, _)| i)
        .collect()
}

/// Names of the payload unknowns appended after the compliances: its mass
/// (kg) and its first moment in the TCP frame (kg.m).
pub const PAYLOAD_PARAMETER_NAMES: [&str; 4] =
    ["payload_mass", "payload_mx", "payload_my", "payload_mz"];

impl GravityCompliance {
    /// The UR10 of the built-in `ur10` description, with the link masses of
    /// the public UR10 URDF (shoulder 7.778, upper arm 12.93, forearm 3.87,
    /// wrist 1-3: 1.96, 1.96, 0.202 kg). Centres of mass: the upper arm and
    /// forearm at the middle of their links (between the joint axes), each
    /// wrist link at the origin of its joint frame, the shoulder on the
    /// axis of joint 1 (it loads no other joint). Payload start: 1 kg, 0.1 m
    /// along the flange's z axis (a measuring probe).
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] when `model` lacks the frames `2`-`6`
    /// of the built-in description.
    pub fn ur10_urdf(model: &Model) -> Result<Self, CalibError> {
        for frame in ["1", "2", "3", "4", "5", "6"] {
            if model.frame_index(frame).is_none() {
                return Err(CalibError::InvalidOption {
                    name: "gravity",
                    reason: format!(
                        "the UR10 mass table needs frame `{frame}` of the built-in ur10 description; robot `{}` has none",
                        model.name()
                    ),
                });
            }
        }
        let mass = |name: &str, frame: &str, mass: f64, center: [f64; 3]| PointMass {
            name: name.into(),
            frame: frame.into(),
            mass,
            center: Vector3::from(center),
        };
        // Nominal DH: a2 = -0.612 m, a3 = -0.5723 m along the x axes of
        // frames 2 and 3 (frame 4 sits d4 = 0.1639 m off the forearm's line).
        Ok(Self::with_probe_payload(vec![
            mass("shoulder", "1", 7.778, [0.0, 0.0, 0.0]),
            mass("upper arm", "2", 12.93, [-0.306, 0.0, 0.0]),
            mass("forearm", "3", 3.87, [-0.28615, 0.0, 0.0]),
            mass("wrist 1", "4", 1.96, [0.0, 0.0, 0.0]),
            mass("wrist 2", "5", 1.96, [0.0, 0.0, 0.0]),
            mass("wrist 3", "6", 0.202, [0.0, 0.0, 0.0]),
        ]))
    }

    /// The mass table of an imported robot: the link masses its file holds
    /// (a URDF's `<inertial>` elements, [`LinkMass`]), under standard
    /// gravity along -z0, with the payload start of
    /// [`GravityCompliance::ur10_urdf`] (1 kg, 0.1 m along the flange's z).
    /// Links fixed to the base frame R0 (`frame = "0"`) load no joint and
    /// are left out.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] when no link moves with a joint, or a
    /// link's frame is not a frame of `model`.
    pub fn from_link_masses(model: &Model, links: &[LinkMass]) -> Result<Self, CalibError> {
        let invalid = |reason: String| CalibError::InvalidOption {
            name: "gravity",
            reason,
        };
        let mut masses = Vec::with_capacity(links.len());
        for link in links.iter().filter(|l| l.frame != "0") {
            if model.frame_index(&link.frame).is_none() {
                return Err(invalid(format!(
                    "link `{}` is fixed to frame `{}`, which robot `{}` does not have",
                    link.link,
                    link.frame,
                    model.name()
                )));
            }
            masses.push(PointMass {
                name: link.link.clone(),
                frame: link.frame.clone(),
                mass: link.mass_kg,
                center: Vector3::from(link.center_m),
            });
        }
        if masses.is_empty() {
            return Err(invalid(format!(
                "robot `{}`: no link mass on a moving link (give a mass table file)",
                model.name()
            )));
        }
        Ok(Self::with_probe_payload(masses))
    }

    /// `masses` under standard gravity along -z0, with a measuring probe's
    /// payload start (1 kg, 0.1 m along the flange's z axis) and a starting
    /// compliance of 10 urad/N.m.
    fn with_probe_payload(masses: Vec<PointMass>) -> Self {
        Self {
            gravity: Vector3::new(0.0, 0.0, -STANDARD_GRAVITY),
            masses,
            payload_mass: 1.0,
            payload_center: Vector3::new(0.0, 0.0, 0.1),
            payload_frame: None,
            initial_compliance: 10e-6,
            lateral: LateralCompliance::Off,
            springs: Vec::new(),
            payloads: Vec::new(),
            deflection: crate::deflection::Deflection::OneStep,
            coupling: Vec::new(),
        }
    }

    /// Names of the lateral compliances of `model` this loading adds
    /// (`lateral_compliance_<joint>_x`, rad/N.m; none when
    /// [`GravityCompliance::lateral`] is off), after the payload's, then
    /// the [`GravityCompliance::springs`]' (`lateral_compliance_<frame>_<axis>`).
    pub fn lateral_unknown_names(&self, model: &Model) -> Vec<String> {
        let mut names = match self.lateral {
            LateralCompliance::Off => Vec::new(),
            LateralCompliance::AboutX => lateral_compliance_names(model),
        };
        names.extend(self.springs.iter().map(Spring::unknown_name));
        names
    }

    /// Every elastic unknown of this loading, in order: the compliances
    /// and payload of [`GravityCompliance::unknown_names`], the identified
    /// further payloads' ([`Payload::unknown_names`]), then
    /// [`GravityCompliance::lateral_unknown_names`], then the coupling
    /// groups' off-diagonal compliances ([`CouplingGroup::unknown_names`]).
    pub fn elastic_unknown_names(&self, model: &Model) -> Vec<String> {
        let mut names = Self::unknown_names(model);
        names.extend(self.identified_payloads().flat_map(Payload::unknown_names));
        names.extend(self.lateral_unknown_names(model));
        names.extend(self.coupling.iter().flat_map(CouplingGroup::unknown_names));
        names
    }

    /// The names of every payload unknown: [`PAYLOAD_PARAMETER_NAMES`],
    /// then each identified further payload's ([`Payload::unknown_names`]).
    pub fn payload_unknown_names(&self) -> Vec<String> {
        let mut names: Vec<String> = PAYLOAD_PARAMETER_NAMES.map(String::from).to_vec();
        names.extend(self.identified_payloads().flat_map(Payload::unknown_names));
        names
    }

    /// The further payloads whose mass and centre are identified.
    fn identified_payloads(&self) -> impl Iterator<Item = &Payload> {
        self.payloads.iter().filter(|p| p.identify)
    }

    /// The sites of the identified payloads, in the order of their
    /// unknowns: the first payload's, then each identified further one's.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] naming a payload frame the robot does
    /// not have.
    pub(crate) fn payload_sites(&self, model: &Model) -> Result<Vec<PayloadSite>, CalibError> {
        std::iter::once(self.payload_frame.as_deref())
            .chain(self.identified_payloads().map(|p| Some(p.frame.as_str())))
            .map(|frame| payload_site(model, frame))
            .collect()
    }

    /// Names of the elastic unknowns of `model`: `compliance_<joint>` per
    /// actuated coordinate, then [`PAYLOAD_PARAMETER_NAMES`] (without the
    /// lateral compliances: [`GravityCompliance::elastic_unknown_names`]).
    pub fn unknown_names(model: &Model) -> Vec<String> {
        let mut names: Vec<String> = model
            .actuated_names()
            .iter()
            .map(|n| format!("compliance_{n}"))
            .collect();
        names.extend(PAYLOAD_PARAMETER_NAMES.iter().map(|s| s.to_string()));
        names
    }

    /// Starting values of the elastic unknowns, in the order of
    /// [`GravityCompliance::elastic_unknown_names`] (compliances, each
    /// identified payload's mass and first moment, lateral and coupling
    /// compliances at zero).
    pub fn initial_unknowns(&self, model: &Model) -> Vec<f64> {
        let mut x = vec![self.initial_compliance; model.n_actuated()];
        x.extend(self.payload_unknowns());
        x.resize(self.elastic_unknown_names(model).len(), 0.0);
        x
    }

    /// Generalised gravity forces (N.m for a revolute coordinate, N for a
    /// prismatic one) of every pose of `set`, one row of `n_actuated` per
    /// pose: the links' weights and the starting payload
    /// ([`GravityCompliance::payload_mass`] at
    /// [`GravityCompliance::payload_center`]) on the nominal geometry at the
    /// commanded configuration. These are the torques that load the joint
    /// springs of the elasto-geometric model before identification adjusts
    /// the payload: which side of each joint's torque a campaign loads, and
    /// over what span, decides what it can tell of the joint's stiffness.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for a mass table that does not fit the
    /// model, [`CalibError::Kinematics`] naming the pose whose forward model
    /// fails.
    pub fn joint_torques(
        &self,
        model: &Model,
        set: &MeasurementSet,
    ) -> Result<Vec<Vec<f64>>, CalibError> {
        let label = |k: usize| set.poses()[k].label(k);
        let terms = GravityTerms::new(model, &Configurations::of_set(set, &label), self)?;
        let payload = self.payload_unknowns();
        Ok((0..set.len())
            .map(|k| {
                let mut tau = vec![0.0; model.n_actuated()];
                terms.forces(k, &payload, &mut tau);
                tau
            })
            .collect())
    }

    /// The starting identified payloads as unknowns: `[m, m c_x, m c_y,
    /// m c_z]` (kg, kg.m) of the first payload, then of each identified
    /// further one.
    fn payload_unknowns(&self) -> Vec<f64> {
        std::iter::once((self.payload_mass, self.payload_center))
            .chain(self.identified_payloads().map(|p| (p.mass, p.center)))
            .flat_map(|(mass, center)| {
                let first_moment = center * mass;
                [mass, first_moment.x, first_moment.y, first_moment.z]
            })
            .collect()
    }

    fn check(&self, model: &Model) -> Result<Vec<PointLoad>, CalibError> {
        let invalid = |reason: String| CalibError::InvalidOption {
            name: "gravity",
            reason,
        };
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err(invalid(format!(
                "gravity must be finite, found {:?}",
                self.gravity
            )));
        }
        if !(self.initial_compliance.is_finite() && self.payload_mass.is_finite()) {
            return Err(invalid(
                "initial compliance and payload mass must be finite".into(),
            ));
        }
        self.deflection.check()?;
        let mut loads = self.checked_payloads(model)?;
        let links = self
            .masses
            .iter()
            .map(|m| {
                let frame = model.frame_index(&m.frame).ok_or_else(|| {
                    invalid(format!(
                        "link `{}`: robot `{}` has no frame `{}` (frames: {})",
                        m.name,
                        model.name(),
                        m.frame,
                        model.frame_names().join(", ")
                    ))
                })?;
                if !(m.mass.is_finite() && m.mass >= 0.0 && m.center.iter().all(|c| c.is_finite()))
                {
                    return Err(invalid(format!(
                        "link `{}`: mass must be finite and >= 0 and the centre finite",
                        m.name
                    )));
                }
                Ok(PointLoad {
                    frame,
                    point: m.center,
                    force: self.gravity * m.mass,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        loads.splice(0..0, links);
        Ok(loads)
    }

    /// Checks the further payloads (names, frames, values) and returns the
    /// weights of the known ones, which load the joints as links do.
    fn checked_payloads(&self, model: &Model) -> Result<Vec<PointLoad>, CalibError> {
        let mut loads = Vec::new();
        for (k, payload) in self.payloads.iter().enumerate() {
            let invalid = |reason: String| CalibError::InvalidOption {
                name: "payloads",
                reason: format!("payload `{}`: {reason}", payload.name),
            };
            if let Some(what) = payload_defect(payload, &self.payloads[..k]) {
                return Err(invalid(what.into()));
            }
            let site =
                payload_site(model, Some(&payload.frame)).map_err(|e| invalid(e.to_string()))?;
            if !payload.identify {
                loads.push(PointLoad {
                    frame: site.frame,
                    point: site
                        .x_frame_payload
                        .transform_point(&payload.center.into())
                        .coords,
                    force: self.gravity * payload.mass,
                });
            }
        }
        Ok(loads)
    }
}

/// What is wrong with a further payload given after `earlier` (its name,
/// its values; its frame is checked against the robot), if anything.
fn payload_defect(payload: &Payload, earlier: &[Payload]) -> Option<&'static str> {
    let valid_name = !payload.name.is_empty()
        && payload
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if !valid_name {
        Some("a name is one or more letters, digits, `-` or `_`")
    } else if earlier.iter().any(|p| p.name == payload.name) {
        Some("the name is given twice")
    } else if !(payload.mass.is_finite() && payload.center.iter().all(|c| c.is_finite())) {
        Some("mass and centre must be finite")
    } else if !payload.identify && payload.mass < 0.0 {
        Some("a known mass must be >= 0")
    } else {
        None
    }
}

/// The gravity terms of every pose of a measurement set, evaluated once on
/// the nominal geometry: `tau = tau_links + sum_p (m_p a_p + B_p (m c)_p)`
/// per pose, over the identified payloads `p`.
#[derive(Debug, Clone)]
pub(crate) struct GravityTerms {
    n_actuated: usize,
    /// Number of payload unknowns (4 per identified payload).
    n_payload: usize,
    /// Per pose: `tau_links` (n), then per joint i the derivatives of
    /// `tau_i` by the payload unknowns (`n_payload`: `a_p`, `B_p` row).
    terms: Vec<f64>,
}

/// The commanded configurations of a set of poses, and each pose's label
/// for errors ([`crate::Measurement::label`]): what the gravity terms are
/// evaluated on.
pub(crate) struct Configurations<'a> {
    /// Actuated coordinates of each pose (rad or m).
    pub q: Vec<&'a [f64]>,
    /// The label of pose k.
    pub label: &'a dyn Fn(usize) -> String,
}

impl<'a> Configurations<'a> {
    /// The configurations of a measurement set.
    pub(crate) fn of_set(set: &'a MeasurementSet, label: &'a dyn Fn(usize) -> String) -> Self {
        Self {
            q: set.configurations(),
            label,
        }
    }

    /// The error of the forward model at pose `k`.
    pub(crate) fn kinematics_error(
        &self,
        k: usize,
    ) -> impl FnOnce(flexcal_kinematics::KinematicsError) -> CalibError + '_ {
        move |source| CalibError::Kinematics {
            pose: k,
            pose_id: (self.label)(k),
            source,
        }
    }
}

impl GravityTerms {
    pub(crate) fn new(
        model: &Model,
        poses: &Configurations<'_>,
        gravity: &GravityCompliance,
    ) -> Result<Self, CalibError> {
        let loads = gravity.check(model)?;
        let sites = gravity.payload_sites(model)?;
        let na = model.n_actuated();
        let n_payload = 4 * sites.len();
        let stride = na * (1 + n_payload);
        let mut terms = vec![0.0; poses.q.len() * stride];
        let mut data = Data::new(model);
        let mut jac = Matrix6xX::zeros(na);
        let xi = model.nominal_params();
        let g = gravity.gravity;
        let mut params = [DMatrix::zeros(6, model.n_params())];
        for (k, q) in poses.q.iter().enumerate() {
            let block = &mut terms[k * stride..(k + 1) * stride];
            actuated_forces_into(model, &mut data, q, xi, &loads, &mut block[..na])
                .map_err(poses.kinematics_error(k))?;
            for (p, site) in sites.iter().enumerate() {
                // The payload frame's joint Jacobian: the TCP's own, or
                // that of a point on a named frame.
                let x_base_payload = if site.on_tcp {
                    joint_jacobian_into(model, &mut data, q, xi, &mut jac)
                        .map_err(poses.kinematics_error(k))?
                } else {
                    let mut pose = [Isometry3::identity()];
                    frame_points_jacobians_into(
                        model,
                        &mut data,
                        q,
                        xi,
                        &[(site.frame, site.x_frame_payload)],
                        &mut params,
                        std::slice::from_mut(&mut jac),
                        &mut pose,
                    )
                    .map_err(poses.kinematics_error(k))?;
                    pose[0]
                };
                let r = x_base_payload.rotation.to_rotation_matrix().into_inner();
                for i in 0..na {
                    let v = Vector3::new(jac[(0, i)], jac[(1, i)], jac[(2, i)]);
                    let w = Vector3::new(jac[(3, i)], jac[(4, i)], jac[(5, i)]);
                    let d = &mut block[na + i * n_payload + 4 * p..][..4];
                    // Weight m g at the payload: work rate v . (m g).
                    d[0] = v.dot(&g);
                    // First moment: the force m g at p + R c adds the
                    // moment (R (m c)) x g about p, whose work rate is
                    // w . moment.
                    for l in 0..3 {
                        d[1 + l] = w.dot(&r.column(l).cross(&g));
                    }
                }
            }
        }
        Ok(Self {
            n_actuated: na,
            n_payload,
            terms,
        })
    }

    /// Number of payload unknowns (4 per identified payload).
    pub(crate) fn n_payload(&self) -> usize {
        self.n_payload
    }

    /// Generalised gravity forces of pose `k` for the payload unknowns
    /// `payload` (`[m, mc_x, mc_y, mc_z]` per identified payload), into
    /// `tau` (n_actuated).
    pub(crate) fn forces(&self, k: usize, payload: &[f64], tau: &mut [f64]) {
        let na = self.n_actuated;
        let stride = na * (1 + self.n_payload);
        let block = &self.terms[k * stride..(k + 1) * stride];
        for i in 0..na {
            let d = &block[na + i * self.n_payload..][..self.n_payload];
            tau[i] = block[i] + d.iter().zip(payload).map(|(d, p)| d * p).sum::<f64>();
        }
    }

    /// The generalised gravity force of joint `i` at pose `k` for the
    /// payload unknowns `payload` (one entry of [`GravityTerms::forces`]).
    pub(crate) fn force(&self, k: usize, i: usize, payload: &[f64]) -> f64 {
        let na = self.n_actuated;
        let stride = na * (1 + self.n_payload);
        self.terms[k * stride + i]
            + self
                .payload_derivatives(k, i)
                .iter()
                .zip(payload)
                .map(|(d, p)| d * p)
                .sum::<f64>()
    }

    /// `d tau_i / d payload` of pose `k`: `[a_p, B_p0, B_p1, B_p2]` per
    /// identified payload.
    pub(crate) fn payload_derivatives(&self, k: usize, i: usize) -> &[f64] {
        let na = self.n_actuated;
        let stride = na * (1 + self.n_payload);
        &self.terms[k * stride + na + i * self.n_payload..][..self.n_payload]
    }
}

/// Values per lateral joint and pose in [`LateralTerms`] before the
/// payload derivatives: axis (3), origin (3), `Mx_links`; then `ax`, `bx`
/// (3) per identified payload.
const LATERAL_HEAD: usize = 7;

/// One lateral joint at one pose: what its rotation and its derivatives
/// need (module docs, "Lateral joint compliances").
#[derive(Debug, Clone, Copy)]
pub(crate) struct LateralJoint<'a> {
    /// The x axis of the joint's frame in R0 (unit).
    pub axis: Vector3<f64>,
    /// The origin of the joint's frame in R0 (m).
    pub origin: Vector3<f64>,
    /// `d Mx / d [m, mc_x, mc_y, mc_z]` per identified payload: `[ax, bx]`
    /// (N.m/kg, N).
    pub payload_derivatives: &'a [f64],
    /// `Mx` of the links alone (N.m).
    links: f64,
}

impl LateralJoint<'_> {
    /// `Mx` for the payload unknowns `payload` (N.m).
    pub fn moment(&self, payload: &[f64]) -> f64 {
        self.links
            + self
                .payload_derivatives
                .iter()
                .zip(payload)
                .map(|(d, p)| d * p)
                .sum::<f64>()
    }
}

/// One axis the structure beyond a frame turns about: a lateral joint's
/// x axis or a [`Spring`]'s axis, in its frame, through `pivot`.
#[derive(Debug, Clone, Copy)]
struct Hinge {
    frame: usize,
    axis: Vector3<f64>,
    pivot: Vector3<f64>,
}

/// The lateral moments of every pose of a measurement set, evaluated once
/// on the nominal geometry at the commanded configurations.
#[derive(Debug, Clone)]
pub(crate) struct LateralTerms {
    /// The lateral joints' x axes, then the springs' axes.
    hinges: Vec<Hinge>,
    /// Values per hinge and pose ([`LATERAL_HEAD`] and the payloads').
    width: usize,
    terms: Vec<f64>,
}

impl LateralTerms {
    /// The hinges of `gravity` on `model`: the lateral joints' x axes,
    /// then the springs (a frame that does not exist or carries no weight
    /// is an error naming it).
    fn hinges(
        model: &Model,
        gravity: &GravityCompliance,
        loads: &[PointLoad],
    ) -> Result<Vec<Hinge>, CalibError> {
        let mut hinges: Vec<Hinge> = match gravity.lateral {
            LateralCompliance::Off => Vec::new(),
            LateralCompliance::AboutX => lateral_joints(model)
                .iter()
                .filter_map(|&i| model.actuated_frame(i))
                .map(|frame| Hinge {
                    frame,
                    axis: Vector3::x(),
                    pivot: Vector3::zeros(),
                })
                .collect(),
        };
        for spring in &gravity.springs {
            let invalid = |reason: String| CalibError::InvalidOption {
                name: "springs",
                reason: format!("spring on frame `{}`: {reason}", spring.frame),
            };
            let frame = model.frame_index(&spring.frame).ok_or_else(|| {
                invalid(format!(
                    "robot `{}` has no such frame (frames: {})",
                    model.name(),
                    model.frame_names().join(", ")
                ))
            })?;
            if lateral_compliance_names(model).contains(&spring.unknown_name())
                && gravity.lateral == LateralCompliance::AboutX
            {
                return Err(invalid(format!(
                    "`{}` is already a lateral compliance of `lateral = \"about-x\"`",
                    spring.unknown_name()
                )));
            }
            if !spring.pivot.iter().all(|v| v.is_finite()) {
                return Err(invalid("the pivot must be finite".into()));
            }
            let carries = loads.iter().any(|l| model.moves_with(l.frame, frame))
                || gravity
                    .payload_sites(model)?
                    .iter()
                    .any(|site| model.moves_with(site.frame, frame));
            if !carries {
                return Err(invalid(
                    "it carries no weight of the mass table and no payload: nothing loads it"
                        .into(),
                ));
            }
            hinges.push(Hinge {
                frame,
                axis: spring.axis.unit(),
                pivot: spring.pivot,
            });
        }
        Ok(hinges)
    }

    pub(crate) fn new(
        model: &Model,
        poses: &Configurations<'_>,
        gravity: &GravityCompliance,
    ) -> Result<Self, CalibError> {
        let loads = gravity.check(model)?;
        let hinges = Self::hinges(model, gravity, &loads)?;
        let sites = gravity.payload_sites(model)?;
        let width = LATERAL_HEAD + 4 * sites.len();
        let stride = width * hinges.len();
        let mut terms = vec![0.0; poses.q.len() * stride];
        let mut data = Data::new(model);
        let xi = model.nominal_params();
        let g = gravity.gravity;
        let mut at_payloads = vec![(Vector3::zeros(), nalgebra::Matrix3::zeros()); sites.len()];
        for (k, q) in poses.q.iter().enumerate() {
            let x_base_tcp = flexcal_kinematics::forward_pose(model, &mut data, q, xi)
                .map_err(poses.kinematics_error(k))?;
            for (site, at) in sites.iter().zip(&mut at_payloads) {
                let x_base_payload = if site.on_tcp {
                    x_base_tcp
                } else {
                    data.frame_pose(site.frame).expect("a checked frame") * site.x_frame_payload
                };
                *at = (
                    x_base_payload.translation.vector,
                    x_base_payload.rotation.to_rotation_matrix().into_inner(),
                );
            }
            for (s, hinge) in hinges.iter().enumerate() {
                let frame = hinge.frame;
                let pose = data.frame_pose(frame).expect("a frame of the model");
                let axis = pose.rotation * hinge.axis;
                let origin = pose.translation.vector + pose.rotation * hinge.pivot;
                let mut links = 0.0;
                for load in loads.iter().filter(|l| model.moves_with(l.frame, frame)) {
                    let at = data.frame_pose(load.frame).expect("a checked frame");
                    let point = at.translation.vector + at.rotation * load.point;
                    links += axis.dot(&(point - origin).cross(&load.force));
                }
                let block = &mut terms[k * stride + s * width..][..width];
                block[..3].copy_from_slice(axis.as_slice());
                block[3..6].copy_from_slice(origin.as_slice());
                block[6] = links;
                for (p, (site, (position, rotation))) in sites.iter().zip(&at_payloads).enumerate()
                {
                    let d = &mut block[LATERAL_HEAD + 4 * p..][..4];
                    if !model.moves_with(site.frame, frame) {
                        d.fill(0.0);
                        continue;
                    }
                    // The weight m g at p + R c: moment (p - o) x m g plus
                    // (R (m c)) x g.
                    d[0] = axis.dot(&(position - origin).cross(&g));
                    for l in 0..3 {
                        d[1 + l] = axis.dot(&rotation.column(l).cross(&g));
                    }
                }
            }
        }
        Ok(Self {
            hinges,
            width,
            terms,
        })
    }

    /// Number of lateral joints and springs.
    pub(crate) fn len(&self) -> usize {
        self.hinges.len()
    }

    /// Whether lateral joint `s` moves frame `frame` (it is on the path from
    /// the root to it): a joint of another branch turns nothing there.
    pub(crate) fn moves(&self, model: &Model, s: usize, frame: usize) -> bool {
        model.moves_with(frame, self.hinges[s].frame)
    }

    /// Lateral joint `s` at pose `k`.
    pub(crate) fn joint(&self, k: usize, s: usize) -> LateralJoint<'_> {
        let stride = self.width * self.hinges.len();
        let b = &self.terms[k * stride + s * self.width..][..self.width];
        LateralJoint {
            axis: Vector3::new(b[0], b[1], b[2]),
            origin: Vector3::new(b[3], b[4], b[5]),
            links: b[6],
            payload_derivatives: &b[LATERAL_HEAD..],
        }
    }
}

/// The mass-table file (TOML; kg, mm, m/s^2, urad/N.m):
///
/// ```toml
/// gravity_m_s2 = [0.0, 0.0, -9.80665]   # in the robot base frame R0 (optional)
/// payload_mass_kg = 1.0                 # starting value (optional; default 0)
/// payload_center_mm = [0.0, 0.0, 100.0] # starting value, TCP frame (optional; default origin)
/// initial_compliance_urad_per_nm = 1.0  # starting value, every joint (um/N for linear joints)
/// lateral = "about-x"                   # lateral compliances about each joint's x axis (optional; default "off")
///
/// [[spring]]                           # optional, any number: springs about frame axes
/// frame = "T4"                          # a passive joint, a fixed mounting, the base...
/// axes = ["z"]                          # "x", "y", "z": one unknown lateral_compliance_T4_z each
/// pivot_mm = [0.0, 0.0, 0.0]            # the axes' point in that frame (optional)
///
/// [[payload]]                          # optional, any number: further payloads
/// name = "left"                         # unknowns payload_left_mass, payload_left_mx..mz
/// frame = "LH"                          # a frame of the robot, or "tcp"
/// mass_kg = 1.5                         # starting value, or the value when known
/// center_mm = [0.0, 0.0, 80.0]          # in that frame
/// identify = true                       # optional; false: known, no unknowns
///
/// [deflection]                          # optional; default: one linear step
/// kind = "equilibrium"                  # "one-step", "equilibrium" (tolerance_rad, max_iterations) or "auto" (share)
/// tolerance_rad = 1e-9
/// max_iterations = 100
/// [[coupling_compliance]]              # optional: a coupled group's symmetric compliance
/// joints = ["T2", "T3", "T4"]           # a passive joint and drives it is coupled to
///
/// [[mass]]
/// name = "upper arm"
/// frame = "2"                           # a frame of the robot description
/// mass_kg = 12.93
/// center_mm = [-306.0, 0.0, 0.0]        # centre of mass in that frame
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MassTableFile {
    #[serde(default = "default_gravity")]
    gravity_m_s2: [f64; 3],
    #[serde(default)]
    payload_mass_kg: f64,
    #[serde(default)]
    payload_center_mm: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    payload_frame: Option<String>,
    initial_compliance_urad_per_nm: f64,
    #[serde(default, skip_serializing_if = "is_off")]
    lateral: LateralCompliance,
    #[serde(default)]
    mass: Vec<MassFile>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    spring: Vec<SpringFile>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    payload: Vec<PayloadFile>,
    #[serde(
        default,
        skip_serializing_if = "crate::deflection::Deflection::is_one_step"
    )]
    deflection: crate::deflection::Deflection,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    coupling_compliance: Vec<CouplingGroup>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PayloadFile {
    name: String,
    frame: String,
    mass_kg: f64,
    center_mm: [f64; 3],
    #[serde(default = "identified")]
    identify: bool,
}

fn identified() -> bool {
    true
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpringFile {
    frame: String,
    axes: Vec<FrameAxis>,
    #[serde(default, skip_serializing_if = "is_origin")]
    pivot_mm: [f64; 3],
}

fn is_origin(p: &[f64; 3]) -> bool {
    p.iter().all(|v| *v == 0.0)
}

fn is_off(lateral: &LateralCompliance) -> bool {
    *lateral == LateralCompliance::Off
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MassFile {
    name: String,
    frame: String,
    mass_kg: f64,
    center_mm: [f64; 3],
}

/// The springs of a mass table's `[[spring]]` entries, one per axis.
fn springs_of(
    files: &[SpringFile],
    bad: &dyn Fn(usize, String) -> CalibError,
) -> Result<Vec<Spring>, CalibError> {
    let mut springs = Vec::new();
    for file in files {
        if file.axes.is_empty() || !file.pivot_mm.iter().all(|v| v.is_finite()) {
            return Err(bad(
                0,
                format!(
                    "spring on frame `{}`: give one or more axes (\"x\", \"y\", \"z\") and a finite pivot_mm",
                    file.frame
                ),
            ));
        }
        for &axis in &file.axes {
            let spring = Spring {
                frame: file.frame.clone(),
                axis,
                pivot: Vector3::from(file.pivot_mm) * 1e-3,
            };
            if springs
                .iter()
                .any(|s: &Spring| s.unknown_name() == spring.unknown_name())
            {
                return Err(bad(
                    0,
                    format!("spring `{}` is given twice", spring.unknown_name()),
                ));
            }
            springs.push(spring);
        }
    }
    Ok(springs)
}

/// The further payloads of a mass table's `[[payload]]` entries: names
/// checked here, frames when the table meets a robot.
fn payloads_of(
    files: &[PayloadFile],
    bad: &dyn Fn(usize, String) -> CalibError,
) -> Result<Vec<Payload>, CalibError> {
    let mut payloads: Vec<Payload> = Vec::with_capacity(files.len());
    for file in files {
        let payload = Payload {
            name: file.name.clone(),
            frame: file.frame.clone(),
            mass: file.mass_kg,
            center: Vector3::from(file.center_mm) * 1e-3,
            identify: file.identify,
        };
        if let Some(what) = payload_defect(&payload, &payloads) {
            return Err(bad(0, format!("payload `{}`: {what}", file.name)));
        }
        payloads.push(payload);
    }
    Ok(payloads)
}

/// The coupling groups of a mass table's `[[coupling_compliance]]`
/// entries: each on its own checked here (two or more joints, none twice),
/// against the robot when the table meets one.
fn coupling_of(
    groups: Vec<CouplingGroup>,
    bad: &dyn Fn(usize, String) -> CalibError,
) -> Result<Vec<CouplingGroup>, CalibError> {
    for group in &groups {
        if let Some(defect) = group.defect() {
            return Err(bad(
                0,
                format!(
                    "coupling_compliance [{}]: {defect}",
                    group.joints.join(", ")
                ),
            ));
        }
    }
    Ok(groups)
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -STANDARD_GRAVITY]
}

impl GravityCompliance {
    /// The built-in mass table of a robot: `ur10` only
    /// ([`GravityCompliance::ur10_urdf`]).
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for a robot without one (give a mass
    /// table file instead).
    pub fn builtin(model: &Model) -> Result<Self, CalibError> {
        match model.name() {
            "ur10" => Self::ur10_urdf(model),
            other => Err(CalibError::InvalidOption {
                name: "gravity",
                reason: format!(
                    "robot `{other}` has no built-in mass table: give one in a file (see the README, mass table format)"
                ),
            }),
        }
    }

    /// Parses a mass table (format in the README and on this type's source:
    /// kg, mm, urad/N.m); `source_name` names it in errors.
    ///
    /// # Errors
    /// [`CalibError::BadMassTable`] with the line of a TOML error, a
    /// negative mass or a non-finite value.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self, CalibError> {
        let bad = |line: usize, what: String| CalibError::BadMassTable {
            source_name: source_name.to_string(),
            line,
            what,
        };
        let file: MassTableFile = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
                .unwrap_or(0);
            bad(line, e.message().to_string())
        })?;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !finite(&file.gravity_m_s2)
            || !finite(&file.payload_center_mm)
            || !file.payload_mass_kg.is_finite()
            || !file.initial_compliance_urad_per_nm.is_finite()
        {
            return Err(bad(
                0,
                "gravity, payload and initial compliance must be finite".into(),
            ));
        }
        let masses = file
            .mass
            .iter()
            .map(|m| {
                if !(m.mass_kg.is_finite() && m.mass_kg >= 0.0 && finite(&m.center_mm)) {
                    return Err(bad(
                        0,
                        format!(
                            "mass `{}`: mass_kg must be finite and >= 0, center_mm finite",
                            m.name
                        ),
                    ));
                }
                Ok(PointMass {
                    name: m.name.clone(),
                    frame: m.frame.clone(),
                    mass: m.mass_kg,
                    center: Vector3::from(m.center_mm) * 1e-3,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            gravity: Vector3::from(file.gravity_m_s2),
            masses,
            payload_mass: file.payload_mass_kg,
            payload_center: Vector3::from(file.payload_center_mm) * 1e-3,
            payload_frame: file.payload_frame.clone(),
            initial_compliance: file.initial_compliance_urad_per_nm * 1e-6,
            lateral: file.lateral,
            springs: springs_of(&file.spring, &bad)?,
            payloads: payloads_of(&file.payload, &bad)?,
            deflection: file.deflection,
            coupling: coupling_of(file.coupling_compliance, &bad)?,
        })
    }

    /// Reads a mass table file.
    ///
    /// # Errors
    /// As [`GravityCompliance::from_toml_str`], and the file's I/O error.
    pub fn from_toml_file(path: &Path) -> Result<Self, CalibError> {
        let text = flexcal_io::read_to_string(path)?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The mass table as TOML (the format of [`GravityCompliance::from_toml_str`]).
    ///
    /// # Errors
    /// [`CalibError::Serialise`].
    pub fn to_toml_string(&self) -> Result<String, CalibError> {
        let file = MassTableFile {
            gravity_m_s2: self.gravity.into(),
            payload_mass_kg: self.payload_mass,
            payload_center_mm: (self.payload_center * 1e3).into(),
            payload_frame: self.payload_frame.clone(),
            initial_compliance_urad_per_nm: self.initial_compliance * 1e6,
            lateral: self.lateral,
            mass: self
                .masses
                .iter()
                .map(|m| MassFile {
                    name: m.name.clone(),
                    frame: m.frame.clone(),
                    mass_kg: m.mass,
                    center_mm: (m.center * 1e3).into(),
                })
                .collect(),
            spring: self
                .springs
                .iter()
                .map(|spring| SpringFile {
                    frame: spring.frame.clone(),
                    axes: vec![spring.axis],
                    pivot_mm: (spring.pivot * 1e3).into(),
                })
                .collect(),
            payload: self
                .payloads
                .iter()
                .map(|p| PayloadFile {
                    name: p.name.clone(),
                    frame: p.frame.clone(),
                    mass_kg: p.mass,
                    center_mm: (p.center * 1e3).into(),
                    identify: p.identify,
                })
                .collect(),
            deflection: self.deflection,
            coupling_compliance: self.coupling.clone(),
        };
        toml::to_string(&file).map_err(|e| CalibError::Serialise {
            what: "mass table",
            message: e.to_string(),
        })
    }
}
