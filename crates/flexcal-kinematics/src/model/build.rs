//! Validation of a [`RobotDescription`] into a [`Model`], one step per
//! function in the order [`build`] calls them: frame names, antecedents,
//! the parameter vector xi, each frame's quantities and joint source, the
//! loops, the order of q, and the path to the TCP.

use std::collections::HashMap;

use nalgebra::Isometry3;

use super::{
    ActuatedKind, Affine, CouplingModel, FourBar, FrameModel, JointSource, LoopModel, Model,
    ParamInfo, Quantity, SliderCrankModel,
};
use crate::KinematicsError;
use crate::description::{
    FrameDescription, JointType, LoopConstraint, LoopSolver, RobotDescription, TransformDescription,
};
use crate::pose::Pose;

impl RobotDescription {
    /// Validates the description and freezes it into a [`Model`].
    pub fn build(&self) -> Result<Model, KinematicsError> {
        build(self)
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
fn own_value(f: &FrameDescription, q: Quantity) -> f64 {
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

/// The parameter vector xi: each entry's description, nominal value and owner.
struct ParameterVector {
    params: Vec<ParamInfo>,
    nominal: Vec<f64>,
    /// Frame and quantity of each parameter.
    owner: Vec<(usize, Quantity)>,
    /// Index in xi of a frame's quantity, when it is a parameter.
    of: HashMap<(usize, Quantity), usize>,
}

impl ParameterVector {
    /// The affine form of a frame quantity: a parameter, or its constant.
    fn affine_of(&self, desc: &RobotDescription, i: usize, q: Quantity) -> Affine {
        match self.of.get(&(i, q)) {
            Some(&j) => Affine {
                constant: 0.0,
                terms: vec![(j, 1.0)],
            },
            None => Affine {
                constant: own_value(&desc.frames[i], q),
                terms: Vec::new(),
            },
        }
    }

    fn index_by_name(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }
}

/// The actuated coordinates (the entries of q) and the joints they drive.
#[derive(Default)]
struct Actuation {
    names: Vec<String>,
    kinds: Vec<ActuatedKind>,
    limits: Vec<(f64, f64)>,
    frames: Vec<usize>,
    cranks: Vec<SliderCrankModel>,
    couplings: Vec<CouplingModel>,
}

fn build(desc: &RobotDescription) -> Result<Model, KinematicsError> {
    let index = frame_index(desc)?;
    let parents = antecedents(desc, &index)?;
    let xi = parameter_vector(desc)?;
    let mut actuation = Actuation::default();
    let mut frames: Vec<FrameModel> = Vec::with_capacity(desc.frames.len());
    for (i, f) in desc.frames.iter().enumerate() {
        let quantity = frame_quantities(desc, i, &index, &frames, &xi)?;
        let source = joint_source(desc, i, &index, &frames, &xi, &mut actuation)?;
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

    let (loops, passive_names) = loop_models(desc, &index, &parents, &mut frames)?;
    if let Some(order) = &desc.actuated_order {
        actuation.reorder(order, &mut frames)?;
    }
    for f in &frames {
        if f.source == JointSource::Passive(usize::MAX) {
            return Err(invalid(format!(
                "joint `{}` is neither actuated, coupled, fixed nor in a loop",
                f.name
            )));
        }
    }
    let follows_loops = loops.iter().any(|l| l.solver == LoopSolver::Newton);
    let home = Some(home_configuration(desc, &actuation))
        .filter(|h| follows_loops && h.iter().any(|&v| v != 0.0));
    let end_frame = match &desc.end_frame {
        None => frames.len() - 1,
        Some(n) => *index
            .get(n.as_str())
            .ok_or_else(|| invalid(format!("end_frame `{n}` is not a frame")))?,
    };
    let tcp_path = ancestors(&parents, end_frame);
    let base = transform("base transform", &desc.base)?;
    let tool = transform("tool transform", &desc.tool)?;
    let (tcp_terms, tcp_xi_joints) = tcp_path_terms(&frames, &tcp_path);
    Ok(Model {
        name: desc.name.clone(),
        description: desc.clone(),
        frame_names: frames.iter().map(|f| f.name.clone()).collect(),
        frames,
        cranks: actuation.cranks,
        couplings: actuation.couplings,
        loops,
        actuated_names: actuation.names,
        actuated_kinds: actuation.kinds,
        actuated_limits: actuation.limits,
        actuated_frames: actuation.frames,
        params: xi.params,
        nominal: xi.nominal,
        passive_names,
        end_frame,
        tcp_path,
        base,
        tool,
        tool_pose: Pose::from_isometry(&tool),
        tcp_terms,
        tcp_xi_joints,
        param_owner: xi.owner,
        home,
        follows_loops,
        links: links(desc, &index)?,
    })
}

/// The named places: each name unique among frames and links, on a
/// frame that exists, at a finite pose.
#[allow(clippy::type_complexity)]
fn links(
    desc: &RobotDescription,
    index: &HashMap<&str, usize>,
) -> Result<Vec<(String, Option<usize>, Isometry3<f64>)>, KinematicsError> {
    let mut out: Vec<(String, Option<usize>, Isometry3<f64>)> = Vec::new();
    for l in &desc.links {
        if l.name.is_empty() || l.name == "0" || index.contains_key(l.name.as_str()) {
            return Err(invalid(format!(
                "link `{}` has the name of a frame (or of the base `0`)",
                l.name
            )));
        }
        if out.iter().any(|(n, _, _)| *n == l.name) {
            return Err(invalid(format!("link `{}` is declared twice", l.name)));
        }
        let frame = if l.frame == "0" {
            None
        } else {
            Some(*index.get(l.frame.as_str()).ok_or_else(|| {
                invalid(format!(
                    "link `{}` is attached to `{}`, which is not a frame",
                    l.name, l.frame
                ))
            })?)
        };
        let x = transform(
            &format!("link `{}`", l.name),
            &TransformDescription {
                translation_mm: l.translation_mm,
                rpy_deg: l.rpy_deg,
            },
        )?;
        out.push((l.name.clone(), frame, x));
    }
    Ok(out)
}

/// The actuated coordinates' seeds (rad for a revolute joint, m for a
/// prismatic joint or a screw length): where the loops are assembled first.
fn home_configuration(desc: &RobotDescription, actuation: &Actuation) -> Vec<f64> {
    actuation
        .frames
        .iter()
        .zip(&actuation.kinds)
        .map(|(&i, kind)| match kind {
            ActuatedKind::Revolute => desc.frames[i].seed_deg.to_radians(),
            _ => desc.frames[i].seed_mm / 1000.0,
        })
        .collect()
}

/// Index of each frame by name; names unique and not reserved, every
/// quantity finite.
fn frame_index(desc: &RobotDescription) -> Result<HashMap<&str, usize>, KinematicsError> {
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
    Ok(index)
}

/// The antecedent of each frame (None: R0); each declared before its frames.
fn antecedents(
    desc: &RobotDescription,
    index: &HashMap<&str, usize>,
) -> Result<Vec<Option<usize>>, KinematicsError> {
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

    Ok(parents)
}

/// Frames from the root to frame `i`, root first.
fn ancestors(parents: &[Option<usize>], mut i: usize) -> Vec<usize> {
    let mut v = vec![i];
    while let Some(p) = parents[i] {
        v.push(p);
        i = p;
    }
    v.reverse();
    v
}

/// The parameters of the default rule (see [`RobotDescription::parameters`]).
fn default_parameters(desc: &RobotDescription) -> Vec<(String, usize, Quantity)> {
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
            for q in Quantity::SLIDER_CRANK {
                push(q);
            }
        }
    }
    candidates
}

/// The parameter vector xi: the explicit list, or the default rule.
fn parameter_vector(desc: &RobotDescription) -> Result<ParameterVector, KinematicsError> {
    let mut nameable: HashMap<String, (usize, Quantity)> = HashMap::new();
    for (i, f) in desc.frames.iter().enumerate() {
        for q in Quantity::FRAME {
            nameable.insert(q.param_name(&f.name), (i, q));
        }
        if f.slider_crank.is_some() {
            for q in Quantity::SLIDER_CRANK {
                nameable.insert(q.param_name(&f.name), (i, q));
            }
        }
    }
    let chosen: Vec<(String, usize, Quantity)> = match &desc.parameters {
        None => default_parameters(desc),
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
    let mut owner = Vec::with_capacity(chosen.len());
    let mut of: HashMap<(usize, Quantity), usize> = HashMap::new();
    for (j, (name, i, q)) in chosen.iter().enumerate() {
        params.push(ParamInfo {
            name: name.clone(),
            kind: q.kind(),
            frame: desc.frames[*i].name.clone(),
            quantity: *q,
        });
        nominal.push(own_value(&desc.frames[*i], *q));
        owner.push((*i, *q));
        of.insert((*i, *q), j);
    }
    Ok(ParameterVector {
        params,
        nominal,
        owner,
        of,
    })
}

/// The seven quantities of frame `i` as affine forms of xi, with `same_as`
/// and `plus` applied.
fn frame_quantities(
    desc: &RobotDescription,
    i: usize,
    index: &HashMap<&str, usize>,
    frames: &[FrameModel],
    xi: &ParameterVector,
) -> Result<[Affine; 7], KinematicsError> {
    let f = &desc.frames[i];
    let mut quantity: [Affine; 7] = Default::default();
    for (k, q) in Quantity::FRAME.iter().enumerate() {
        quantity[k] = xi.affine_of(desc, i, *q);
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
            let j = xi.index_by_name(n).ok_or_else(|| {
                invalid(format!(
                    "frame `{}`: plus names `{n}`, which is not a parameter of xi",
                    f.name
                ))
            })?;
            if xi.params[j].kind != q.kind() {
                return Err(invalid(format!(
                    "frame `{}`: plus adds `{n}` to `{key}` but their units differ",
                    f.name
                )));
            }
            quantity[k].terms.push((j, 1.0));
        }
    }
    Ok(quantity)
}

/// Where the joint of frame `i` takes its value from: fixed, an actuated
/// coordinate (directly or through a slider crank), a coupling, or a loop
/// (passive, assigned by [`loop_models`]).
fn joint_source(
    desc: &RobotDescription,
    i: usize,
    index: &HashMap<&str, usize>,
    frames: &[FrameModel],
    xi: &ParameterVector,
    actuation: &mut Actuation,
) -> Result<JointSource, KinematicsError> {
    let f = &desc.frames[i];
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
        let k = actuation.names.len();
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
        if actuation.names.contains(&actuated_name) {
            return Err(invalid(format!(
                "frame `{}`: actuated coordinate name `{actuated_name}` is used twice",
                f.name
            )));
        }
        actuation.names.push(actuated_name);
        actuation.kinds.push(kind);
        actuation.limits.push(limits);
        actuation.frames.push(i);
        if let Some(c) = &f.slider_crank {
            if c.branch != 1 && c.branch != -1 {
                return Err(invalid(format!(
                    "frame `{}`: slider crank branch must be +1 or -1",
                    f.name
                )));
            }
            let m = SliderCrankModel {
                actuated: k,
                screw_offset: xi.affine_of(desc, i, Quantity::ScrewOffset),
                kappa: xi.affine_of(desc, i, Quantity::Kappa),
                lambda: xi.affine_of(desc, i, Quantity::Lambda),
                l1: xi.affine_of(desc, i, Quantity::L1),
                l3: xi.affine_of(desc, i, Quantity::L3),
                branch: f64::from(c.branch),
            };
            if m.l1.eval(&xi.nominal) <= 0.0 || m.l3.eval(&xi.nominal) <= 0.0 {
                return Err(invalid(format!(
                    "frame `{}`: slider crank l1 and l3 must be positive",
                    f.name
                )));
            }
            actuation.cranks.push(m);
            JointSource::SliderCrank(actuation.cranks.len() - 1)
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
        actuation.couplings.push(CouplingModel { terms });
        JointSource::Coupled(actuation.couplings.len() - 1)
    } else {
        // Passive: assigned to a loop below.
        JointSource::Passive(usize::MAX)
    };
    Ok(source)
}

/// The loops, each with its passive joints (assigned to it in `frames`)
/// and the two paths from the common ancestor to the cut frames.
fn loop_models(
    desc: &RobotDescription,
    index: &HashMap<&str, usize>,
    parents: &[Option<usize>],
    frames: &mut [FrameModel],
) -> Result<(Vec<LoopModel>, Vec<String>), KinematicsError> {
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
        let pa = ancestors(parents, a);
        let pb = ancestors(parents, b);
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
            // A passive joint shared with an earlier loop (nested
            // parallelograms) is that loop's unknown: loops close in order,
            // so here it is already assembled and enters like an actuated joint.
            if let JointSource::Passive(usize::MAX) = frames[f].source {
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
                &ld.name, frames, &passive, &path_a, &path_b, a, b,
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
    Ok((loops, passive_names))
}

impl Actuation {
    /// Puts the actuated coordinates in the order `order` names them.
    fn reorder(
        &mut self,
        order: &[String],
        frames: &mut [FrameModel],
    ) -> Result<(), KinematicsError> {
        if order.len() != self.names.len() {
            return Err(invalid(format!(
                "actuated_order lists {} names for {} actuated joints",
                order.len(),
                self.names.len()
            )));
        }
        let mut permutation = Vec::with_capacity(order.len());
        for name in order {
            let k = self.names.iter().position(|n| n == name).ok_or_else(|| {
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
        self.names = permutation.iter().map(|&k| self.names[k].clone()).collect();
        self.kinds = permutation.iter().map(|&k| self.kinds[k]).collect();
        self.limits = permutation.iter().map(|&k| self.limits[k]).collect();
        self.frames = permutation.iter().map(|&k| self.frames[k]).collect();
        for f in frames.iter_mut() {
            if let JointSource::Actuated(k) = f.source {
                f.source = JointSource::Actuated(new_index[k]);
            }
        }
        for c in self.cranks.iter_mut() {
            c.actuated = new_index[c.actuated];
        }
        Ok(())
    }
}

/// Parameter terms of the frames on the TCP path (frame, quantity,
/// parameter, coefficient) and the path's joints whose value depends on xi.
#[allow(clippy::type_complexity)]
fn tcp_path_terms(
    frames: &[FrameModel],
    tcp_path: &[usize],
) -> (Vec<(usize, usize, usize, f64)>, Vec<usize>) {
    let mut tcp_terms = Vec::new();
    let mut tcp_xi_joints = Vec::new();
    for &f in tcp_path {
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
    (tcp_terms, tcp_xi_joints)
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
