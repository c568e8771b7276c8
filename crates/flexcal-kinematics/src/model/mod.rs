//! The validated, immutable robot model.

use nalgebra::{Isometry3, Matrix3, Vector3};

use crate::KinematicsError;
use crate::description::{JointType, LoopSolver, RobotDescription};
use crate::error::check_vector;
use crate::pose::Pose;

mod build;

/// Geometric quantity of (41), or a slider-crank quantity, that a parameter sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Quantity {
    /// gamma: rotation about the antecedent's z (rad).
    Gamma,
    /// b: translation along the antecedent's z (m).
    B,
    /// alpha: rotation about x (rad).
    Alpha,
    /// d: translation along x (m).
    D,
    /// Hayati beta: rotation about y, after d, before theta (rad).
    Beta,
    /// theta: rotation about the joint axis z (offset for revolute joints) (rad).
    Theta,
    /// r: translation along the joint axis z (offset for prismatic joints) (m).
    R,
    /// Slider crank: screw length offset r' (m).
    ScrewOffset,
    /// Slider crank: angle kappa of the driven pivot (rad).
    Kappa,
    /// Slider crank: angle lambda of the ground pivot (rad).
    Lambda,
    /// Slider crank: distance l1 of the driven pivot from the axis (m).
    L1,
    /// Slider crank: distance l3 of the ground pivot from the axis (m).
    L3,
}

impl Quantity {
    /// The seven frame quantities of (41) in the order they are applied.
    pub const FRAME: [Quantity; 7] = [
        Quantity::Gamma,
        Quantity::B,
        Quantity::Alpha,
        Quantity::D,
        Quantity::Beta,
        Quantity::Theta,
        Quantity::R,
    ];

    /// The parameters of a slider-crank actuator, on the frame of the joint
    /// it drives.
    pub const SLIDER_CRANK: [Quantity; 5] = [
        Quantity::ScrewOffset,
        Quantity::Kappa,
        Quantity::Lambda,
        Quantity::L1,
        Quantity::L3,
    ];

    /// Whether the quantity is a length or an angle.
    pub fn kind(self) -> ParamKind {
        match self {
            Quantity::B
            | Quantity::D
            | Quantity::R
            | Quantity::ScrewOffset
            | Quantity::L1
            | Quantity::L3 => ParamKind::Length,
            _ => ParamKind::Angle,
        }
    }

    /// The name of the parameter of this quantity for frame `frame`
    /// (`alpha2`, `r2p`, `l18`, ...).
    pub fn param_name(self, frame: &str) -> String {
        match self {
            Quantity::Gamma => format!("gamma{frame}"),
            Quantity::B => format!("b{frame}"),
            Quantity::Alpha => format!("alpha{frame}"),
            Quantity::D => format!("d{frame}"),
            Quantity::Beta => format!("beta{frame}"),
            Quantity::Theta => format!("theta{frame}"),
            Quantity::R => format!("r{frame}"),
            Quantity::ScrewOffset => format!("r{frame}p"),
            Quantity::Kappa => format!("kappa{frame}"),
            Quantity::Lambda => format!("lambda{frame}"),
            Quantity::L1 => format!("l1{frame}"),
            Quantity::L3 => format!("l3{frame}"),
        }
    }

    fn frame_index(self) -> Option<usize> {
        Quantity::FRAME.iter().position(|q| *q == self)
    }

    fn from_key(key: &str) -> Option<Quantity> {
        Some(match key {
            "gamma" => Quantity::Gamma,
            "b" => Quantity::B,
            "alpha" => Quantity::Alpha,
            "d" => Quantity::D,
            "beta" => Quantity::Beta,
            "theta" => Quantity::Theta,
            "r" => Quantity::R,
            _ => return None,
        })
    }
}

/// Unit family of a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamKind {
    /// Metres.
    Length,
    /// Radians.
    Angle,
}

/// One entry of the parameter vector xi.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamInfo {
    /// Name (`d3`, `alpha2`, `kappa8`, `beta3`, `theta1`, `r2p`, ...).
    pub name: String,
    /// Length (m) or angle (rad).
    pub kind: ParamKind,
    /// Frame owning the parameter.
    pub frame: String,
    /// The quantity it sets.
    pub quantity: Quantity,
}

/// Kind and unit of an actuated coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ActuatedKind {
    /// Revolute joint angle (rad).
    Revolute,
    /// Prismatic joint displacement (m).
    Prismatic,
    /// Screw length of a slider crank driving a revolute joint (m).
    Screw,
}

/// `constant + sum(coefficient * xi[index])`.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Affine {
    pub constant: f64,
    pub terms: Vec<(usize, f64)>,
}

impl Affine {
    pub fn eval(&self, xi: &[f64]) -> f64 {
        self.terms
            .iter()
            .fold(self.constant, |acc, &(j, c)| acc + c * xi[j])
    }
}

/// Where a joint's value comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum JointSource {
    Fixed,
    Actuated(usize),
    SliderCrank(usize),
    Coupled(usize),
    Passive(usize),
}

#[derive(Debug, Clone)]
pub(crate) struct FrameModel {
    pub name: String,
    pub parent: Option<usize>,
    pub joint: JointType,
    /// gamma, b, alpha, d, beta, theta, r.
    pub quantity: [Affine; 7],
    pub source: JointSource,
    pub seed: f64,
}

/// The part of a frame transform (41) that does not depend on the joint
/// variable, at one parameter vector xi.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ConstantPart {
    /// `Rz(gamma) Tz(b) Rx(alpha) Tx(d) Ry(beta)`.
    pub pre: Pose,
    /// x axis after `Rz(gamma)`, in the antecedent frame.
    pub x1: Vector3<f64>,
    /// y axis after `Rz(gamma) Rx(alpha)`, in the antecedent frame.
    pub y2: Vector3<f64>,
    /// b (m).
    pub b: f64,
    /// theta: constant part (rad).
    pub theta: f64,
    /// r: constant part (m).
    pub r: f64,
}

impl FrameModel {
    /// The constant part of this frame's transform at `xi`.
    pub fn constant_part(&self, xi: &[f64]) -> ConstantPart {
        let [gamma, b, alpha, d, beta, theta, r] =
            [0, 1, 2, 3, 4, 5, 6].map(|k| self.quantity[k].eval(xi));
        let (sg, cg) = gamma.sin_cos();
        let (sa, ca) = alpha.sin_cos();
        let (sb, cb) = beta.sin_cos();
        // Rz(gamma) Rx(alpha) Ry(beta), then the translation of
        // Rz(gamma) Tz(b) Rx(alpha) Tx(d).
        let rz = Matrix3::new(cg, -sg, 0.0, sg, cg, 0.0, 0.0, 0.0, 1.0);
        let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, ca, -sa, 0.0, sa, ca);
        let ry = Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
        let x1 = Vector3::new(cg, sg, 0.0);
        ConstantPart {
            pre: Pose {
                r: rz * rx * ry,
                p: Vector3::new(0.0, 0.0, b) + d * x1,
            },
            x1,
            y2: rz * Vector3::new(0.0, ca, sa),
            b,
            theta,
            r,
        }
    }

    /// Index in `quantity` of the joint variable's quantity.
    pub fn joint_quantity(&self) -> Option<usize> {
        match self.joint {
            JointType::Revolute => Some(5),
            JointType::Prismatic => Some(6),
            JointType::Fixed => None,
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) struct SliderCrankModel {
    pub actuated: usize,
    pub screw_offset: Affine,
    pub kappa: Affine,
    pub lambda: Affine,
    pub l1: Affine,
    pub l3: Affine,
    pub branch: f64,
}

#[derive(Debug, Clone)]
pub(crate) struct CouplingModel {
    pub terms: Vec<(usize, f64)>,
}

#[derive(Debug, Clone)]
pub(crate) struct LoopModel {
    pub name: String,
    pub cut_a: usize,
    pub cut_b: usize,
    /// Components of [p_rel; e_rot] that are constrained.
    pub selection: Vec<usize>,
    pub solver: LoopSolver,
    pub branch: f64,
    /// Passive frames of the loop, in order.
    pub passive: Vec<usize>,
    /// Frames exclusive to the path to `cut_a` (root to leaf order).
    pub path_a: Vec<usize>,
    /// Frames exclusive to the path to `cut_b`.
    pub path_b: Vec<usize>,
    /// For the four-bar closed form: (passive on side a or b, its side is a?, cut joint frame, cut joint on side a?)
    pub four_bar: Option<FourBar>,
}

#[derive(Debug, Clone, Copy)]
pub(crate) struct FourBar {
    pub joint_a: usize,
    pub joint_b: usize,
    pub joint_cut: usize,
    pub cut_on_a: bool,
}

/// A validated robot: immutable, shared by threads; each thread owns a
/// [`crate::Data`].
#[derive(Debug, Clone)]
pub struct Model {
    pub(crate) name: String,
    pub(crate) description: RobotDescription,
    pub(crate) frames: Vec<FrameModel>,
    pub(crate) cranks: Vec<SliderCrankModel>,
    pub(crate) couplings: Vec<CouplingModel>,
    pub(crate) loops: Vec<LoopModel>,
    pub(crate) actuated_names: Vec<String>,
    pub(crate) actuated_kinds: Vec<ActuatedKind>,
    pub(crate) actuated_limits: Vec<(f64, f64)>,
    /// Frame of each actuated coordinate.
    pub(crate) actuated_frames: Vec<usize>,
    pub(crate) params: Vec<ParamInfo>,
    pub(crate) nominal: Vec<f64>,
    pub(crate) frame_names: Vec<String>,
    pub(crate) passive_names: Vec<String>,
    pub(crate) end_frame: usize,
    /// Frames from the root to the end frame.
    pub(crate) tcp_path: Vec<usize>,
    pub(crate) base: Isometry3<f64>,
    pub(crate) tool: Isometry3<f64>,
    /// The tool transform as a rotation matrix and translation.
    pub(crate) tool_pose: Pose,
    /// Parameter terms of the frames on the TCP path, in path order:
    /// (frame, quantity, parameter index, coefficient).
    pub(crate) tcp_terms: Vec<(usize, usize, usize, f64)>,
    /// Frames on the TCP path whose joint value depends on xi.
    pub(crate) tcp_xi_joints: Vec<usize>,
    /// Where each parameter is written back in a description.
    pub(crate) param_owner: Vec<(usize, Quantity)>,
    /// The home configuration (the actuated frames' seeds, rad or m) from
    /// which loops solved by Newton's method are followed to the first
    /// configuration; `None` when no loop is or no seed is declared.
    pub(crate) home: Option<Vec<f64>>,
    /// Whether a loop is solved by Newton's method, and so followed by
    /// continuation from one call to the next.
    pub(crate) follows_loops: bool,
    /// Named places: (name, frame index or None for R0, pose in that frame).
    pub(crate) links: Vec<(String, Option<usize>, Isometry3<f64>)>,
}

impl Model {
    /// Robot name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Number of actuated coordinates: the length of q.
    pub fn n_actuated(&self) -> usize {
        self.actuated_names.len()
    }
    /// Names of the actuated coordinates, in the order of q.
    pub fn actuated_names(&self) -> &[String] {
        &self.actuated_names
    }
    /// Kind (and so unit: rad or m) of each actuated coordinate.
    pub fn actuated_kinds(&self) -> &[ActuatedKind] {
        &self.actuated_kinds
    }
    /// Limits (min, max) of each actuated coordinate (rad or m).
    pub fn actuated_limits(&self) -> &[(f64, f64)] {
        &self.actuated_limits
    }
    /// Index of the frame whose joint actuated coordinate `i` drives
    /// ([`Model::frame_index`] numbering), or `None` for `i` out of range:
    /// the frame whose z axis is that joint's axis.
    pub fn actuated_frame(&self, i: usize) -> Option<usize> {
        self.actuated_frames.get(i).copied()
    }
    /// Number of geometric parameters: the length of xi.
    pub fn n_params(&self) -> usize {
        self.params.len()
    }
    /// Description of each entry of xi.
    pub fn params(&self) -> &[ParamInfo] {
        &self.params
    }
    /// Position of a parameter in xi by name.
    pub fn param_index(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }
    /// Nominal parameter vector xi0 (m, rad).
    pub fn nominal_params(&self) -> &[f64] {
        &self.nominal
    }
    /// Number of frames (R0 excluded).
    pub fn n_frames(&self) -> usize {
        self.frames.len()
    }
    /// Index of a frame by name.
    pub fn frame_index(&self, name: &str) -> Option<usize> {
        self.frame_names.iter().position(|n| n == name)
    }
    /// Frame names in index order.
    pub fn frame_names(&self) -> &[String] {
        &self.frame_names
    }
    /// Names of the named places attached to frames (a URDF's links, see
    /// [`crate::LinkDescription`]), in the description's order.
    pub fn link_names(&self) -> impl Iterator<Item = &str> {
        self.links.iter().map(|(name, _, _)| name.as_str())
    }
    /// Every name [`crate::forward_named_pose`] takes: `0` (the base frame
    /// R0), the frames in index order, then the links. A URDF's links keep
    /// their own names here (`wrist_2_link`, `tool0`) beside the
    /// Khalil-Kleinfinger frames `1..n` they move with: a KK frame sits on
    /// its joint's common normal, not where the URDF puts the link's frame,
    /// so the two are different places and keep different names.
    pub fn named_frames(&self) -> Vec<String> {
        std::iter::once("0".to_string())
            .chain(self.frame_names.iter().cloned())
            .chain(self.link_names().map(str::to_string))
            .collect()
    }
    /// Where the named frame or link `name` is: the frame it moves with
    /// (`None`: the base R0) and its pose in that frame (SI).
    ///
    /// # Errors
    /// [`KinematicsError::UnknownFrame`] for a name that is neither,
    /// listing [`Model::named_frames`].
    pub fn locate(&self, name: &str) -> Result<(Option<usize>, Isometry3<f64>), KinematicsError> {
        if name == "0" {
            return Ok((None, Isometry3::identity()));
        }
        if let Some(i) = self.frame_index(name) {
            return Ok((Some(i), Isometry3::identity()));
        }
        self.links
            .iter()
            .find(|(n, _, _)| n == name)
            .map(|(_, frame, x)| (*frame, *x))
            .ok_or_else(|| KinematicsError::UnknownFrame {
                robot: self.name.as_str().into(),
                name: name.to_string(),
                known: self.named_frames().join(", "),
            })
    }
    /// Index of the antecedent of frame `i` (None: the base frame R0).
    pub fn antecedent(&self, i: usize) -> Option<usize> {
        self.frames.get(i).and_then(|f| f.parent)
    }
    /// Whether frame `frame` is `joint_frame` or comes after it in the
    /// description's tree: whether it moves when the joint of
    /// `joint_frame` turns (the loads a joint carries).
    pub fn moves_with(&self, frame: usize, joint_frame: usize) -> bool {
        let mut current = Some(frame);
        while let Some(c) = current {
            if c == joint_frame {
                return true;
            }
            current = self.antecedent(c);
        }
        false
    }
    /// The frames a coupled joint's value is made of, for frame `frame`
    /// coupled to others (a description's `coupled_to`: `q_frame = sum
    /// ratio * q_source`): `(source frame index, ratio)` pairs; `None` for
    /// a frame that is not coupled (or out of range).
    pub fn coupled_to(&self, frame: usize) -> Option<&[(usize, f64)]> {
        match self.frames.get(frame)?.source {
            JointSource::Coupled(c) => Some(self.couplings[c].terms.as_slice()),
            _ => None,
        }
    }
    /// Index of the end frame (the frame the tool transform is attached to).
    pub fn end_frame(&self) -> usize {
        self.end_frame
    }
    /// Names of the passive loop joints, in the order of
    /// [`crate::Data::passive_values`].
    pub fn passive_names(&self) -> &[String] {
        &self.passive_names
    }
    /// The home configuration (rad or m, order of q) from which the loops
    /// solved by Newton's method are followed by continuation to the first
    /// configuration asked of a fresh [`crate::Data`] (the actuated frames'
    /// `seed_deg` / `seed_mm`), or `None` for a robot without such loops or
    /// whose actuated seeds are all zero (its first call closes the loops
    /// by Newton's method from the passive seeds directly).
    pub fn home_configuration(&self) -> Option<&[f64]> {
        self.home.as_deref()
    }
    /// Cell frame R-1 to base frame R0 (not in xi).
    pub fn base(&self) -> Isometry3<f64> {
        self.base
    }
    /// End frame to TCP (not in xi).
    pub fn tool(&self) -> Isometry3<f64> {
        self.tool
    }
    /// True for a serial chain without loops, couplings or slider cranks.
    pub fn is_serial(&self) -> bool {
        self.loops.is_empty() && self.cranks.is_empty() && self.couplings.is_empty()
    }

    /// The description of this robot with parameters `xi` written back in
    /// (mm, degrees): how a calibrated robot is saved.
    pub fn description_with_params(&self, xi: &[f64]) -> Result<RobotDescription, KinematicsError> {
        check_vector("xi", xi, self.n_params())?;
        let mut d = self.description.clone();
        for (j, &(frame, quantity)) in self.param_owner.iter().enumerate() {
            let f = &mut d.frames[frame];
            let v = xi[j];
            let mm = v * 1000.0;
            let deg = v.to_degrees();
            match quantity {
                Quantity::Gamma => f.gamma_deg = deg,
                Quantity::B => f.b_mm = mm,
                Quantity::Alpha => f.alpha_deg = deg,
                Quantity::D => f.d_mm = mm,
                Quantity::Beta => f.beta_deg = Some(deg),
                Quantity::Theta => f.theta_deg = deg,
                Quantity::R => f.r_mm = mm,
                _ => {
                    if let Some(c) = f.slider_crank.as_mut() {
                        match quantity {
                            Quantity::ScrewOffset => c.screw_offset_mm = mm,
                            Quantity::Kappa => c.kappa_deg = deg,
                            Quantity::Lambda => c.lambda_deg = deg,
                            Quantity::L1 => c.l1_mm = mm,
                            _ => c.l3_mm = mm,
                        }
                    }
                }
            }
        }
        Ok(d)
    }
}
