//! The validated, immutable robot model.

use std::collections::HashMap;

use nalgebra::Isometry3;

use crate::KinematicsError;
use crate::description::{
    JointType, LoopConstraint, LoopSolver, RobotDescription, TransformDescription,
};

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

impl FrameModel {
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
    pub(crate) tool_pose: crate::forward::Pose,
    /// Parameter terms of the frames on the TCP path, in path order:
    /// (frame, quantity, parameter index, coefficient).
    pub(crate) tcp_terms: Vec<(usize, usize, usize, f64)>,
    /// Frames on the TCP path whose joint value depends on xi.
    pub(crate) tcp_xi_joints: Vec<usize>,
    /// Where each parameter is written back in a description.
    pub(crate) param_owner: Vec<(usize, Quantity)>,
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
    /// Index of the antecedent of frame `i` (None: the base frame R0).
    pub fn antecedent(&self, i: usize) -> Option<usize> {
        self.frames.get(i).and_then(|f| f.parent)
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
        crate::forward::check_vector("xi", xi, self.n_params())?;
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

fn invalid(what: String) -> KinematicsError {
    KinematicsError::Invalid { what }
}

fn finite(what: &str, v: f64) -> Result<f64, KinematicsError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(KinematicsError::NotFinite {
            what: what.to_string(),
        })
    }
}

fn transform(what: &str, t: &TransformDescription) -> Result<Isometry3<f64>, KinematicsError> {
    for v in t.translation_mm.iter().chain(t.rpy_deg.iter()) {
        finite(what, *v)?;
    }
    Ok(t.to_isometry())
}

/// Own value of a frame quantity in SI, from the description.
fn own_value(f: &crate::description::FrameDescription, q: Quantity) -> f64 {
    match q {
        Quantity::Gamma => f.gamma_deg.to_radians(),
        Quantity::B => f.b_mm / 1000.0,
        Quantity::Alpha => f.alpha_deg.to_radians(),
        Quantity::D => f.d_mm / 1000.0,
        Quantity::Beta => f.beta_deg.unwrap_or(0.0).to_radians(),
        Quantity::Theta => f.theta_deg.to_radians(),
        Quantity::R => f.r_mm / 1000.0,
        _ => {
            let c = f.slider_crank.as_ref();
            match q {
                Quantity::ScrewOffset => c.map_or(0.0, |c| c.screw_offset_mm / 1000.0),
                Quantity::Kappa => c.map_or(0.0, |c| c.kappa_deg.to_radians()),
                Quantity::Lambda => c.map_or(0.0, |c| c.lambda_deg.to_radians()),
                Quantity::L1 => c.map_or(0.0, |c| c.l1_mm / 1000.0),
                _ => c.map_or(0.0, |c| c.l3_mm / 1000.0),
            }
        }
    }
}

pub(crate) fn build(desc: &RobotDescription) -> Result<Model, KinematicsError> {
    if desc.frames.is_empty() {
        return Err(invalid("the robot has no frame".into()));
    }
    let mut index: HashMap<&str, usize> = HashMap::new();
    for (i, f) in desc.frames.iter().enumerate() {
        if f.name.is_empty() || f.name == "0" {
            return Err(invalid(format!(
                "frame {} has the reserved name `{}`",
                i + 1,
                f.name
            )));
        }
        if index.insert(f.name.as_str(), i).is_some() {
            return Err(invalid(format!("frame `{}` is declared twice", f.name)));
        }
        let values = [
            f.gamma_deg,
            f.b_mm,
            f.alpha_deg,
            f.d_mm,
            f.beta_deg.unwrap_or(0.0),
            f.theta_deg,
            f.r_mm,
            f.seed_deg,
            f.seed_mm,
        ];
        for v in values {
            finite(&format!("a quantity of frame `{}`", f.name), v)?;
        }
        if let Some(c) = &f.slider_crank {
            for v in [
                c.screw_offset_mm,
                c.kappa_deg,
                c.lambda_deg,
                c.l1_mm,
                c.l3_mm,
            ] {
                finite(&format!("slider crank of frame `{}`", f.name), v)?;
            }
        }
    }
    // Parents.
    let mut parents = Vec::with_capacity(desc.frames.len());
    for (i, f) in desc.frames.iter().enumerate() {
        let parent = if f.antecedent == "0" {
            None
        } else {
            match index.get(f.antecedent.as_str()) {
                Some(&p) if p < i => Some(p),
                Some(_) => {
                    return Err(invalid(format!(
                        "frame `{}` must be declared after its antecedent `{}`",
                        f.name, f.antecedent
                    )));
                }
                None => {
                    return Err(invalid(format!(
                        "frame `{}` has an unknown antecedent `{}`",
                        f.name, f.antecedent
                    )));
                }
            }
        };
        parents.push(parent);
    }

    // Default parameter names.
    let mut candidates: Vec<(String, usize, Quantity)> = Vec::new();
    for (i, f) in desc.frames.iter().enumerate() {
        let same = |q: &str| f.same_as.contains_key(q);
        let mut push = |q: Quantity| candidates.push((q.param_name(&f.name), i, q));
        if f.gamma_deg != 0.0 && !same("gamma") {
            push(Quantity::Gamma);
        }
        if f.b_mm != 0.0 && !same("b") {
            push(Quantity::B);
        }
        if !same("alpha") {
            push(Quantity::Alpha);
        }
        if !same("d") {
            push(Quantity::D);
        }
        if f.beta_deg.is_some() && !same("beta") {
            push(Quantity::Beta);
        }
        let theta_param = match f.joint {
            JointType::Revolute => f.actuated && f.slider_crank.is_none(),
            JointType::Prismatic | JointType::Fixed => true,
        };
        if theta_param && !same("theta") {
            push(Quantity::Theta);
        }
        if f.beta_deg.is_none() && !same("r") {
            push(Quantity::R);
        }
        if f.slider_crank.is_some() {
            for q in [
                Quantity::ScrewOffset,
                Quantity::Kappa,
                Quantity::Lambda,
                Quantity::L1,
                Quantity::L3,
            ] {
                push(q);
            }
        }
    }
    // Every nameable parameter (for explicit lists).
    let mut nameable: HashMap<String, (usize, Quantity)> = HashMap::new();
    for (i, f) in desc.frames.iter().enumerate() {
        for q in Quantity::FRAME {
            nameable.insert(q.param_name(&f.name), (i, q));
        }
        if f.slider_crank.is_some() {
            for q in [
                Quantity::ScrewOffset,
                Quantity::Kappa,
                Quantity::Lambda,
                Quantity::L1,
                Quantity::L3,
            ] {
                nameable.insert(q.param_name(&f.name), (i, q));
            }
        }
    }
    let chosen: Vec<(String, usize, Quantity)> = match &desc.parameters {
        None => candidates,
        Some(list) => {
            let mut out = Vec::with_capacity(list.len());
            for name in list {
                match nameable.get(name) {
                    Some(&(i, q)) => {
                        if out.iter().any(|(n, _, _)| n == name) {
                            return Err(invalid(format!("parameter `{name}` is listed twice")));
                        }
                        let key = match q {
                            Quantity::Gamma => "gamma",
                            Quantity::B => "b",
                            Quantity::Alpha => "alpha",
                            Quantity::D => "d",
                            Quantity::Beta => "beta",
                            Quantity::Theta => "theta",
                            Quantity::R => "r",
                            _ => "",
                        };
                        if desc.frames[i].same_as.contains_key(key) {
                            return Err(invalid(format!(
                                "parameter `{name}` is taken `same_as` another frame"
                            )));
                        }
                        out.push((name.clone(), i, q));
                    }
                    None => {
                        return Err(invalid(format!(
                            "parameter `{name}` names no quantity of any frame (names are quantity + frame: alpha2, d3, r2p, kappa8, l18)"
                        )));
                    }
                }
            }
            out
        }
    };
    let mut params = Vec::with_capacity(chosen.len());
    let mut nominal = Vec::with_capacity(chosen.len());
    let mut param_owner = Vec::with_capacity(chosen.len());
    let mut param_of: HashMap<(usize, Quantity), usize> = HashMap::new();
    for (j, (name, i, q)) in chosen.iter().enumerate() {
        params.push(ParamInfo {
            name: name.clone(),
            kind: q.kind(),
            frame: desc.frames[*i].name.clone(),
            quantity: *q,
        });
        nominal.push(own_value(&desc.frames[*i], *q));
        param_owner.push((*i, *q));
        param_of.insert((*i, *q), j);
    }
    let param_by_name: HashMap<&str, usize> = params
        .iter()
        .enumerate()
        .map(|(j, p)| (p.name.as_str(), j))
        .collect();

    let affine_of = |i: usize, q: Quantity| -> Affine {
        match param_of.get(&(i, q)) {
            Some(&j) => Affine {
                constant: 0.0,
                terms: vec![(j, 1.0)],
            },
            None => Affine {
                constant: own_value(&desc.frames[i], q),
                terms: Vec::new(),
            },
        }
    };

    // Frames, actuated coordinates.
    let mut frames: Vec<FrameModel> = Vec::with_capacity(desc.frames.len());
    let mut cranks = Vec::new();
    let mut couplings = Vec::new();
    let mut actuated_names = Vec::new();
    let mut actuated_kinds = Vec::new();
    let mut actuated_limits = Vec::new();
    let mut actuated_frames = Vec::new();
    for (i, f) in desc.frames.iter().enumerate() {
        let mut quantity: [Affine; 7] = Default::default();
        for (k, q) in Quantity::FRAME.iter().enumerate() {
            quantity[k] = affine_of(i, *q);
        }
        for (key, other) in &f.same_as {
            let q = Quantity::from_key(key).ok_or_else(|| {
                invalid(format!(
                    "frame `{}`: same_as key `{key}` is not gamma, b, alpha, d, beta, theta or r",
                    f.name
                ))
            })?;
            let &o = index.get(other.as_str()).ok_or_else(|| {
                invalid(format!(
                    "frame `{}`: same_as names an unknown frame `{other}`",
                    f.name
                ))
            })?;
            if o >= i {
                return Err(invalid(format!(
                    "frame `{}`: same_as must name an earlier frame, not `{other}`",
                    f.name
                )));
            }
            let k = q.frame_index().unwrap_or(0);
            quantity[k] = frames[o].quantity[k].clone();
        }
        for (key, names) in &f.plus {
            let q = Quantity::from_key(key).ok_or_else(|| {
                invalid(format!(
                    "frame `{}`: plus key `{key}` is not gamma, b, alpha, d, beta, theta or r",
                    f.name
                ))
            })?;
            let k = q.frame_index().unwrap_or(0);
            for n in names {
                let &j = param_by_name.get(n.as_str()).ok_or_else(|| {
                    invalid(format!(
                        "frame `{}`: plus names `{n}`, which is not a parameter of xi",
                        f.name
                    ))
                })?;
                if params[j].kind != q.kind() {
                    return Err(invalid(format!(
                        "frame `{}`: plus adds `{n}` to `{key}` but their units differ",
                        f.name
                    )));
                }
                quantity[k].terms.push((j, 1.0));
            }
        }
        let source = if f.joint == JointType::Fixed {
            if f.actuated || f.slider_crank.is_some() || !f.coupled_to.is_empty() {
                return Err(invalid(format!(
                    "frame `{}` is fixed but declared actuated, coupled or crank-driven",
                    f.name
                )));
            }
            JointSource::Fixed
        } else if f.actuated {
            if !f.coupled_to.is_empty() {
                return Err(invalid(format!(
                    "frame `{}` is both actuated and coupled",
                    f.name
                )));
            }
            let k = actuated_names.len();
            let (kind, default_name) = match (&f.slider_crank, f.joint) {
                (Some(_), JointType::Revolute) => (ActuatedKind::Screw, format!("r{}p", f.name)),
                (Some(_), _) => {
                    return Err(invalid(format!(
                        "frame `{}`: a slider crank drives revolute joints only",
                        f.name
                    )));
                }
                (None, JointType::Revolute) => (ActuatedKind::Revolute, format!("theta{}", f.name)),
                (None, _) => (ActuatedKind::Prismatic, format!("r{}", f.name)),
            };
            let limits = match kind {
                ActuatedKind::Revolute => {
                    if f.limits_mm.is_some() {
                        return Err(invalid(format!(
                            "frame `{}`: a revolute joint takes limits_deg, not limits_mm",
                            f.name
                        )));
                    }
                    f.limits_deg
                        .map(|l| (l[0].to_radians(), l[1].to_radians()))
                        .unwrap_or((-std::f64::consts::TAU, std::f64::consts::TAU))
                }
                _ => {
                    if f.limits_deg.is_some() {
                        return Err(invalid(format!(
                            "frame `{}`: a prismatic joint or screw takes limits_mm, not limits_deg",
                            f.name
                        )));
                    }
                    f.limits_mm
                        .map(|l| (l[0] / 1000.0, l[1] / 1000.0))
                        .unwrap_or((-1e3, 1e3))
                }
            };
            if !(limits.0.is_finite() && limits.1.is_finite() && limits.0 < limits.1) {
                return Err(invalid(format!(
                    "frame `{}`: limits must be finite with min < max",
                    f.name
                )));
            }
            let actuated_name = f.actuated_name.clone().unwrap_or(default_name);
            if actuated_names.contains(&actuated_name) {
                return Err(invalid(format!(
                    "frame `{}`: actuated coordinate name `{actuated_name}` is used twice",
                    f.name
                )));
            }
            actuated_names.push(actuated_name);
            actuated_kinds.push(kind);
            actuated_limits.push(limits);
            actuated_frames.push(i);
            if let Some(c) = &f.slider_crank {
                if c.branch != 1 && c.branch != -1 {
                    return Err(invalid(format!(
                        "frame `{}`: slider crank branch must be +1 or -1",
                        f.name
                    )));
                }
                let m = SliderCrankModel {
                    actuated: k,
                    screw_offset: affine_of(i, Quantity::ScrewOffset),
                    kappa: affine_of(i, Quantity::Kappa),
                    lambda: affine_of(i, Quantity::Lambda),
                    l1: affine_of(i, Quantity::L1),
                    l3: affine_of(i, Quantity::L3),
                    branch: f64::from(c.branch),
                };
                if m.l1.eval(&nominal) <= 0.0 || m.l3.eval(&nominal) <= 0.0 {
                    return Err(invalid(format!(
                        "frame `{}`: slider crank l1 and l3 must be positive",
                        f.name
                    )));
                }
                cranks.push(m);
                JointSource::SliderCrank(cranks.len() - 1)
            } else {
                JointSource::Actuated(k)
            }
        } else if !f.coupled_to.is_empty() {
            let mut terms = Vec::new();
            for t in &f.coupled_to {
                finite(&format!("coupling ratio of frame `{}`", f.name), t.ratio)?;
                let &o = index.get(t.frame.as_str()).ok_or_else(|| {
                    invalid(format!(
                        "frame `{}` is coupled to an unknown frame `{}`",
                        f.name, t.frame
                    ))
                })?;
                let ok = o < i
                    && matches!(
                        frames[o].source,
                        JointSource::Actuated(_)
                            | JointSource::SliderCrank(_)
                            | JointSource::Coupled(_)
                    );
                if !ok {
                    return Err(invalid(format!(
                        "frame `{}` is coupled to `{}`, which must be an earlier actuated or coupled joint",
                        f.name, t.frame
                    )));
                }
                terms.push((o, t.ratio));
            }
            couplings.push(CouplingModel { terms });
            JointSource::Coupled(couplings.len() - 1)
        } else {
            // Passive: assigned to a loop below.
            JointSource::Passive(usize::MAX)
        };
        if f.slider_crank.is_some() && !f.actuated {
            return Err(invalid(format!(
                "frame `{}` has a slider crank but is not actuated",
                f.name
            )));
        }
        let seed = if f.joint == JointType::Prismatic {
            f.seed_mm / 1000.0
        } else {
            f.seed_deg.to_radians()
        };
        frames.push(FrameModel {
            name: f.name.clone(),
            parent: parents[i],
            joint: f.joint,
            quantity,
            source,
            seed,
        });
    }

    let ancestors = |mut i: usize| -> Vec<usize> {
        let mut v = vec![i];
        while let Some(p) = parents[i] {
            v.push(p);
            i = p;
        }
        v.reverse();
        v
    };

    // Loops.
    let mut loops = Vec::new();
    let mut passive_names = Vec::new();
    for (l, ld) in desc.loops.iter().enumerate() {
        let find = |n: &str| {
            index
                .get(n)
                .copied()
                .ok_or_else(|| invalid(format!("loop `{}` cuts an unknown frame `{n}`", ld.name)))
        };
        let a = find(&ld.cut[0])?;
        let b = find(&ld.cut[1])?;
        if a == b {
            return Err(invalid(format!(
                "loop `{}` cuts a frame with itself",
                ld.name
            )));
        }
        let pa = ancestors(a);
        let pb = ancestors(b);
        let common = pa.iter().zip(pb.iter()).take_while(|(x, y)| x == y).count();
        let path_a = pa[common..].to_vec();
        let path_b = pb[common..].to_vec();
        if path_a.is_empty() || path_b.is_empty() {
            return Err(invalid(format!(
                "loop `{}`: one cut frame is an ancestor of the other",
                ld.name
            )));
        }
        let mut passive = Vec::new();
        for &f in path_a.iter().chain(path_b.iter()) {
            if let JointSource::Passive(owner) = frames[f].source {
                if owner != usize::MAX {
                    return Err(invalid(format!(
                        "passive joint `{}` belongs to two loops",
                        frames[f].name
                    )));
                }
                frames[f].source = JointSource::Passive(l);
                passive.push(f);
                passive_names.push(frames[f].name.clone());
            }
        }
        let selection = match ld.constraint {
            LoopConstraint::Full => vec![0, 1, 2, 3, 4, 5],
            LoopConstraint::Planar => vec![0, 1, 5],
        };
        if passive.is_empty() || passive.len() > selection.len() {
            return Err(invalid(format!(
                "loop `{}` has {} passive joints for {} constraints",
                ld.name,
                passive.len(),
                selection.len()
            )));
        }
        if ld.branch != 1 && ld.branch != -1 {
            return Err(invalid(format!(
                "loop `{}`: branch must be +1 or -1",
                ld.name
            )));
        }
        let four_bar = if ld.solver == LoopSolver::FourBar {
            Some(four_bar_layout(
                &ld.name, &frames, &passive, &path_a, &path_b, a, b,
            )?)
        } else {
            None
        };
        loops.push(LoopModel {
            name: ld.name.clone(),
            cut_a: a,
            cut_b: b,
            selection,
            solver: ld.solver,
            branch: f64::from(ld.branch),
            passive,
            path_a,
            path_b,
            four_bar,
        });
    }
    if let Some(order) = &desc.actuated_order {
        if order.len() != actuated_names.len() {
            return Err(invalid(format!(
                "actuated_order lists {} names for {} actuated joints",
                order.len(),
                actuated_names.len()
            )));
        }
        let mut permutation = Vec::with_capacity(order.len());
        for name in order {
            let k = actuated_names
                .iter()
                .position(|n| n == name)
                .ok_or_else(|| {
                    invalid(format!(
                        "actuated_order names `{name}`, which is no actuated coordinate"
                    ))
                })?;
            if permutation.contains(&k) {
                return Err(invalid(format!("actuated_order lists `{name}` twice")));
            }
            permutation.push(k);
        }
        // new index of old coordinate k
        let mut new_index = vec![0; order.len()];
        for (new, &old) in permutation.iter().enumerate() {
            new_index[old] = new;
        }
        actuated_names = permutation
            .iter()
            .map(|&k| actuated_names[k].clone())
            .collect();
        actuated_kinds = permutation.iter().map(|&k| actuated_kinds[k]).collect();
        actuated_limits = permutation.iter().map(|&k| actuated_limits[k]).collect();
        actuated_frames = permutation.iter().map(|&k| actuated_frames[k]).collect();
        for f in frames.iter_mut() {
            if let JointSource::Actuated(k) = f.source {
                f.source = JointSource::Actuated(new_index[k]);
            }
        }
        for c in cranks.iter_mut() {
            c.actuated = new_index[c.actuated];
        }
    }
    for f in &frames {
        if f.source == JointSource::Passive(usize::MAX) {
            return Err(invalid(format!(
                "joint `{}` is neither actuated, coupled, fixed nor in a loop",
                f.name
            )));
        }
    }

    let end_frame = match &desc.end_frame {
        None => frames.len() - 1,
        Some(n) => *index
            .get(n.as_str())
            .ok_or_else(|| invalid(format!("end_frame `{n}` is not a frame")))?,
    };
    let tcp_path = ancestors(end_frame);
    let base = transform("base transform", &desc.base)?;
    let tool = transform("tool transform", &desc.tool)?;
    let mut tcp_terms = Vec::new();
    let mut tcp_xi_joints = Vec::new();
    for &f in &tcp_path {
        for k in 0..7 {
            for &(j, coef) in &frames[f].quantity[k].terms {
                tcp_terms.push((f, k, j, coef));
            }
        }
        if frames[f].joint != JointType::Fixed
            && matches!(
                frames[f].source,
                JointSource::SliderCrank(_) | JointSource::Coupled(_) | JointSource::Passive(_)
            )
        {
            tcp_xi_joints.push(f);
        }
    }
    Ok(Model {
        name: desc.name.clone(),
        description: desc.clone(),
        frame_names: frames.iter().map(|f| f.name.clone()).collect(),
        frames,
        cranks,
        couplings,
        loops,
        actuated_names,
        actuated_kinds,
        actuated_limits,
        actuated_frames,
        params,
        nominal,
        passive_names,
        end_frame,
        tcp_path,
        base,
        tool,
        tool_pose: crate::forward::Pose::from_isometry(&tool),
        tcp_terms,
        tcp_xi_joints,
        param_owner,
    })
}

fn four_bar_layout(
    name: &str,
    frames: &[FrameModel],
    passive: &[usize],
    path_a: &[usize],
    path_b: &[usize],
    a: usize,
    b: usize,
) -> Result<FourBar, KinematicsError> {
    let err = |why: &str| {
        invalid(format!(
            "loop `{name}` cannot use the four-bar closed form: {why}"
        ))
    };
    if passive.len() != 3
        || passive
            .iter()
            .any(|&f| frames[f].joint != JointType::Revolute)
    {
        return Err(err("it needs exactly three passive revolute joints"));
    }
    let (joint_cut, cut_on_a) = if passive.contains(&a) {
        (a, true)
    } else if passive.contains(&b) {
        (b, false)
    } else {
        return Err(err("one cut frame must be a passive revolute joint"));
    };
    let on_a: Vec<usize> = passive
        .iter()
        .copied()
        .filter(|f| path_a.contains(f) && *f != joint_cut)
        .collect();
    let on_b: Vec<usize> = passive
        .iter()
        .copied()
        .filter(|f| path_b.contains(f) && *f != joint_cut)
        .collect();
    if on_a.len() != 1 || on_b.len() != 1 {
        return Err(err(
            "each side needs one passive joint besides the cut joint",
        ));
    }
    // Between each side's passive joint and its cut frame only fixed frames
    // (or the cut joint itself) may move, or the radius would not be constant.
    for (path, j) in [(path_a, on_a[0]), (path_b, on_b[0])] {
        let start = path.iter().position(|&f| f == j).unwrap_or(0);
        for &f in &path[start + 1..] {
            if f != joint_cut && frames[f].joint != JointType::Fixed {
                return Err(err(
                    "a moving joint lies between a passive joint and the cut",
                ));
            }
        }
    }
    Ok(FourBar {
        joint_a: on_a[0],
        joint_b: on_b[0],
        joint_cut,
        cut_on_a,
    })
}
