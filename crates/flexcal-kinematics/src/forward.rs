//! Forward model, loop closure, joint and parameter Jacobians.

use nalgebra::{DMatrix, Isometry3, Matrix3, Matrix6xX, Vector3};

use crate::KinematicsError;
use crate::description::{JointType, LoopSolver};
use crate::error::{LoopSingularity, check_vector};
use crate::model::{JointSource, LoopModel, Model};
use crate::pose::Pose;

/// `a * v` for a 3x3 matrix, written out: the generic product of the linear
/// algebra crate does not unroll as well for these tiny sizes.
#[inline(always)]
fn mat_vec(a: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    // Column-major storage: a[column][row].
    [
        a[0][0] * v[0] + a[1][0] * v[1] + a[2][0] * v[2],
        a[0][1] * v[0] + a[1][1] * v[1] + a[2][1] * v[2],
        a[0][2] * v[0] + a[1][2] * v[1] + a[2][2] * v[2],
    ]
}

/// Per-thread workspace of a [`Model`]: the frame poses of the last call,
/// the joint and passive values, derivative buffers and a cache of the
/// per-frame constant transforms keyed on xi.
#[derive(Debug, Clone)]
pub struct Data {
    pub(crate) poses: Vec<Pose>,
    pub(crate) joint: Vec<f64>,
    pub(crate) passive: Vec<f64>,
    cached_xi: Vec<f64>,
    cache_valid: bool,
    pre: Vec<Pose>,
    x1: Vec<Vector3<f64>>,
    y2: Vec<Vector3<f64>>,
    b_value: Vec<f64>,
    theta_const: Vec<f64>,
    r_const: Vec<f64>,
    crank_values: Vec<[f64; 5]>,
    /// d joint / d xi, one row of n_params per frame.
    djoint_dxi: Vec<f64>,
    /// d joint / d q, one row of n_actuated per frame.
    djoint_dq: Vec<f64>,
    pub(crate) tcp: Pose,
    /// The actuated configuration at which the loops were last assembled
    /// (the model's home for a fresh workspace): where the next call's
    /// continuation starts. `None`: close by Newton from the joint values alone.
    assembled_q: Option<Vec<f64>>,
}

impl Data {
    /// A workspace for `model`, with passive joints at their seeds.
    pub fn new(model: &Model) -> Self {
        let n = model.frames.len();
        let mut joint = vec![0.0; n];
        for (i, f) in model.frames.iter().enumerate() {
            if let JointSource::Passive(_) = f.source {
                joint[i] = f.seed;
            }
        }
        let mut data = Data {
            poses: vec![Pose::IDENTITY; n],
            joint,
            passive: vec![0.0; model.passive_names.len()],
            cached_xi: vec![f64::NAN; model.n_params()],
            cache_valid: false,
            pre: vec![Pose::IDENTITY; n],
            x1: vec![Vector3::x(); n],
            y2: vec![Vector3::y(); n],
            b_value: vec![0.0; n],
            theta_const: vec![0.0; n],
            r_const: vec![0.0; n],
            crank_values: vec![[0.0; 5]; model.cranks.len()],
            djoint_dxi: vec![0.0; n * model.n_params()],
            djoint_dq: vec![0.0; n * model.n_actuated()],
            tcp: Pose::IDENTITY,
            assembled_q: model.home.clone(),
        };
        data.collect_passive(model);
        data
    }

    /// Pose `x_base_frame` of frame `i` (base R0 to frame i) from the last
    /// forward call, or `None` for an index out of range.
    pub fn frame_pose(&self, i: usize) -> Option<Isometry3<f64>> {
        self.poses.get(i).map(|p| p.to_isometry())
    }

    /// Origin of frame `i` in the base frame (m) from the last forward call.
    pub fn frame_origin(&self, i: usize) -> Option<Vector3<f64>> {
        self.poses.get(i).map(|p| p.p)
    }

    /// Values of the passive loop joints (rad or m) from the last forward
    /// call, in the order of [`Model::passive_names`].
    pub fn passive_values(&self) -> &[f64] {
        &self.passive
    }

    /// Seeds the passive loop joints (rad or m, order of
    /// [`Model::passive_names`]): the next forward call assembles the loops
    /// by Newton's method from these values directly (no continuation from
    /// an earlier configuration), which selects the assembly branch the
    /// Newton solver follows.
    pub fn set_passive_values(
        &mut self,
        model: &Model,
        values: &[f64],
    ) -> Result<(), KinematicsError> {
        check_vector("passive values", values, model.passive_names.len())?;
        if self.joint.len() != model.frames.len() {
            return Err(KinematicsError::WrongLength {
                what: format!("Data (frames) used with model `{}`", model.name),
                expected: model.frames.len(),
                found: self.joint.len(),
            });
        }
        let mut k = 0;
        for l in &model.loops {
            for &f in &l.passive {
                self.joint[f] = values[k];
                k += 1;
            }
        }
        self.passive.copy_from_slice(values);
        self.assembled_q = None;
        Ok(())
    }

    /// Joint variable of every frame (rad or m) (0 for fixed frames), the
    /// value added to the constant theta (revolute) or r (prismatic).
    pub fn joint_values(&self) -> &[f64] {
        &self.joint
    }

    fn collect_passive(&mut self, model: &Model) {
        let mut k = 0;
        for l in &model.loops {
            for &f in &l.passive {
                self.passive[k] = self.joint[f];
                k += 1;
            }
        }
    }

    fn update_cache(&mut self, model: &Model, xi: &[f64]) {
        if self.cache_valid && self.cached_xi.as_slice() == xi {
            return;
        }
        for (i, f) in model.frames.iter().enumerate() {
            let part = f.constant_part(xi);
            self.pre[i] = part.pre;
            self.x1[i] = part.x1;
            self.y2[i] = part.y2;
            self.b_value[i] = part.b;
            self.theta_const[i] = part.theta;
            self.r_const[i] = part.r;
        }
        for (c, crank) in model.cranks.iter().enumerate() {
            self.crank_values[c] = [
                crank.screw_offset.eval(xi),
                crank.kappa.eval(xi),
                crank.lambda.eval(xi),
                crank.l1.eval(xi),
                crank.l3.eval(xi),
            ];
        }
        self.cached_xi.copy_from_slice(xi);
        self.cache_valid = true;
    }

    fn compute_poses(&mut self, model: &Model) {
        for (i, f) in model.frames.iter().enumerate() {
            let (theta, r) = match f.joint {
                JointType::Revolute => (self.theta_const[i] + self.joint[i], self.r_const[i]),
                JointType::Prismatic => (self.theta_const[i], self.r_const[i] + self.joint[i]),
                JointType::Fixed => (self.theta_const[i], self.r_const[i]),
            };
            let (s, c) = theta.sin_cos();
            let pre = &self.pre[i];
            let m = &pre.r.data.0;
            // Columns of R_pre Rz(theta): only the first two mix.
            let c0 = [
                c * m[0][0] + s * m[1][0],
                c * m[0][1] + s * m[1][1],
                c * m[0][2] + s * m[1][2],
            ];
            let c1 = [
                c * m[1][0] - s * m[0][0],
                c * m[1][1] - s * m[0][1],
                c * m[1][2] - s * m[0][2],
            ];
            let c2 = m[2];
            let p_local = [
                pre.p.x + r * c2[0],
                pre.p.y + r * c2[1],
                pre.p.z + r * c2[2],
            ];
            let (n0, n1, n2, p) = match f.parent {
                Some(parent) => {
                    let parent = &self.poses[parent];
                    let a = &parent.r.data.0;
                    let t = mat_vec(a, p_local);
                    (
                        mat_vec(a, c0),
                        mat_vec(a, c1),
                        mat_vec(a, c2),
                        [parent.p.x + t[0], parent.p.y + t[1], parent.p.z + t[2]],
                    )
                }
                None => (c0, c1, c2, p_local),
            };
            let pose = &mut self.poses[i];
            pose.r.data.0 = [n0, n1, n2];
            pose.p = Vector3::new(p[0], p[1], p[2]);
        }
    }

    /// Unit rate twist of quantity `k` of frame `f`: axis `u` and, for a
    /// rotation, a point `o` on the axis (None: a translation along `u`).
    #[inline]
    fn quantity_axis(
        &self,
        model: &Model,
        f: usize,
        k: usize,
    ) -> (Vector3<f64>, Option<Vector3<f64>>) {
        if k >= 5 {
            let pose = &self.poses[f];
            let z = pose.r.column(2).into_owned();
            return (z, if k == 5 { Some(pose.p) } else { None });
        }
        let parent = match model.frames[f].parent {
            Some(p) => &self.poses[p],
            None => &Pose::IDENTITY,
        };
        match k {
            0 => (parent.r.column(2).into_owned(), Some(parent.p)),
            1 => (parent.r.column(2).into_owned(), None),
            2 => (
                parent.r * self.x1[f],
                Some(parent.p + self.b_value[f] * parent.r.column(2)),
            ),
            3 => (parent.r * self.x1[f], None),
            _ => (
                parent.r * self.y2[f],
                Some(parent.p + parent.r * self.pre[f].p),
            ),
        }
    }
}

#[inline]
fn twist_at(u: &Vector3<f64>, o: &Option<Vector3<f64>>, point: &Vector3<f64>) -> [f64; 6] {
    match o {
        Some(o) => {
            let v = u.cross(&(point - o));
            [v.x, v.y, v.z, u.x, u.y, u.z]
        }
        None => [u.x, u.y, u.z, 0.0, 0.0, 0.0],
    }
}

const LOOP_TOLERANCE: f64 = 1e-9;
const NEWTON_STOP: f64 = 1e-13;
const NEWTON_MAX_ITERATIONS: usize = 50;

/// Residual components of a loop: [p_rel; e_rot] in the first cut frame.
fn loop_residual(data: &Data, l: &LoopModel) -> ([f64; 6], Matrix3<f64>, Matrix3<f64>) {
    let a = &data.poses[l.cut_a];
    let b = &data.poses[l.cut_b];
    let p_rel = a.r.transpose() * (b.p - a.p);
    let r_rel = a.r.transpose() * b.r;
    let e = [
        p_rel.x,
        p_rel.y,
        p_rel.z,
        0.5 * (r_rel[(2, 1)] - r_rel[(1, 2)]),
        0.5 * (r_rel[(0, 2)] - r_rel[(2, 0)]),
        0.5 * (r_rel[(1, 0)] - r_rel[(0, 1)]),
    ];
    (e, a.r, r_rel)
}

/// Derivative of the residual for a unit twist (axis `u`, point `o`) on the
/// side with sign `s` (+1: path to cut b, -1: path to cut a).
#[inline]
fn residual_derivative(
    u: &Vector3<f64>,
    o: &Option<Vector3<f64>>,
    s: f64,
    p_b: &Vector3<f64>,
    r_a: &Matrix3<f64>,
    r_rel: &Matrix3<f64>,
) -> [f64; 6] {
    let t = twist_at(u, o, p_b);
    let lin = s * (r_a.transpose() * Vector3::new(t[0], t[1], t[2]));
    let delta = s * (r_a.transpose() * Vector3::new(t[3], t[4], t[5]));
    let dr = delta.cross_matrix() * r_rel;
    [
        lin.x,
        lin.y,
        lin.z,
        0.5 * (dr[(2, 1)] - dr[(1, 2)]),
        0.5 * (dr[(0, 2)] - dr[(2, 0)]),
        0.5 * (dr[(1, 0)] - dr[(0, 1)]),
    ]
}

fn loop_cannot_close(l: &LoopModel, q: &[f64], residual: f64) -> KinematicsError {
    KinematicsError::LoopCannotClose {
        loop_name: l.name.clone(),
        q: q.to_vec(),
        residual,
    }
}

fn selected_norm(e: &[f64; 6], selection: &[usize]) -> f64 {
    selection.iter().map(|&k| e[k] * e[k]).sum::<f64>().sqrt()
}

/// Solves the least-squares system `g x = rhs` (columns of `rhs` at once).
fn least_squares(
    g: DMatrix<f64>,
    rhs: &DMatrix<f64>,
    what: &str,
) -> Result<DMatrix<f64>, KinematicsError> {
    let needed = g.ncols();
    let svd = g.svd(true, true);
    let smax = svd.singular_values.max();
    let tol = smax * 1e-12;
    let rank = svd.singular_values.iter().filter(|&&s| s > tol).count();
    if rank < needed || smax == 0.0 {
        return Err(KinematicsError::Singular {
            what: what.to_string(),
            rank,
            needed,
        });
    }
    svd.solve(rhs, tol).map_err(|_| KinematicsError::Singular {
        what: what.to_string(),
        rank,
        needed,
    })
}

/// Passive-joint Jacobian of the selected residual components.
fn passive_jacobian(model: &Model, data: &Data, l: &LoopModel) -> DMatrix<f64> {
    let (_, r_a, r_rel) = loop_residual(data, l);
    let p_b = data.poses[l.cut_b].p;
    let m = l.selection.len();
    let mut g = DMatrix::zeros(m, l.passive.len());
    for (c, &f) in l.passive.iter().enumerate() {
        let k = model.frames[f].joint_quantity().unwrap_or(5);
        let (u, o) = data.quantity_axis(model, f, k);
        let s = if l.path_b.contains(&f) { 1.0 } else { -1.0 };
        let d = residual_derivative(&u, &o, s, &p_b, &r_a, &r_rel);
        for (row, &comp) in l.selection.iter().enumerate() {
            g[(row, c)] = d[comp];
        }
    }
    g
}

fn newton(model: &Model, data: &mut Data, l: &LoopModel, q: &[f64]) -> Result<(), KinematicsError> {
    let mut norm = f64::INFINITY;
    for _ in 0..NEWTON_MAX_ITERATIONS {
        data.compute_poses(model);
        let (e, _, _) = loop_residual(data, l);
        norm = selected_norm(&e, &l.selection);
        if norm < NEWTON_STOP {
            break;
        }
        let g = passive_jacobian(model, data, l);
        let rhs = DMatrix::from_iterator(l.selection.len(), 1, l.selection.iter().map(|&k| -e[k]));
        let step = least_squares(g, &rhs, &format!("loop `{}`", l.name)).map_err(|e| match e {
            KinematicsError::Singular { .. } => {
                KinematicsError::LoopSingular(Box::new(LoopSingularity {
                    loop_name: l.name.clone(),
                    q: q.to_vec(),
                    from: q.to_vec(),
                    at: q.to_vec(),
                }))
            }
            other => other,
        })?;
        let mut step_norm = 0.0f64;
        for (c, &f) in l.passive.iter().enumerate() {
            data.joint[f] += step[c];
            step_norm = step_norm.max(step[c].abs());
        }
        if step_norm < 1e-15 {
            data.compute_poses(model);
            let (e, _, _) = loop_residual(data, l);
            norm = selected_norm(&e, &l.selection);
            break;
        }
    }
    if norm.is_nan() || norm > LOOP_TOLERANCE {
        return Err(loop_cannot_close(l, q, norm));
    }
    Ok(())
}

/// Closes every loop, in order, at the joint values already evaluated for `q`.
fn close_loops(model: &Model, data: &mut Data, q: &[f64]) -> Result<(), KinematicsError> {
    for l in &model.loops {
        if l.solver == LoopSolver::FourBar {
            four_bar_closed_form(model, data, l, q)?;
        }
        newton(model, data, l, q)?;
    }
    Ok(())
}

/// Largest step of a loop continuation (rad or m, on every actuated coordinate).
const CONTINUATION_STEP: f64 = 0.05;
/// Smallest share of the whole move a continuation step is halved down to.
const CONTINUATION_MIN_SHARE: f64 = 1e-6;

/// Where the continuation to `q` starts: the configuration of the last
/// assembly, when the loops are followed (a model with Newton loops) and
/// `q` is more than one step away from it.
fn continuation_start(model: &Model, data: &Data, q: &[f64]) -> Option<Vec<f64>> {
    if !model.follows_loops {
        return None;
    }
    let from = data.assembled_q.as_ref()?;
    let distance = from
        .iter()
        .zip(q)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    (distance > CONTINUATION_STEP).then(|| from.clone())
}

/// Follows the loops from `from` (where the passive joints of `data` close
/// them, or nearly) to `to` along the straight line in q, in steps of at
/// most [`CONTINUATION_STEP`], each predicted by the secant of the last two
/// and corrected by Newton's method; a step that does not converge is
/// halved. The passive joints then hold the assembly at `to` on the branch
/// of `from`. When the loops do not close at `from` itself (seeds that
/// do not describe the home configuration), the joints are left as they
/// were and the caller's Newton starts from them directly.
fn follow_loops(
    model: &Model,
    data: &mut Data,
    from: &[f64],
    to: &[f64],
) -> Result<(), KinematicsError> {
    let start = data.joint.clone();
    if evaluate_joints(model, data, from, false).is_err() || close_loops(model, data, from).is_err()
    {
        data.joint = start;
        return Ok(());
    }
    let distance = from
        .iter()
        .zip(to)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let full_step = CONTINUATION_STEP / distance;
    let (mut t, mut h) = (0.0, full_step);
    let mut previous: Option<(f64, Vec<f64>)> = None;
    let mut at = from.to_vec();
    while t < 1.0 {
        let t_next = (t + h).min(1.0);
        for (k, a) in at.iter_mut().enumerate() {
            *a = from[k] + t_next * (to[k] - from[k]);
        }
        let current = data.joint.clone();
        if let Some((t_previous, joints)) = &previous {
            let ratio = (t_next - t) / (t - t_previous);
            for l in &model.loops {
                for &f in &l.passive {
                    data.joint[f] += ratio * (current[f] - joints[f]);
                }
            }
        }
        evaluate_joints(model, data, &at, false)?;
        match close_loops(model, data, &at) {
            Ok(()) => {
                previous = Some((t, current));
                t = t_next;
                h = (2.0 * h).min(full_step);
            }
            Err(KinematicsError::LoopSingular(singular)) => {
                return Err(KinematicsError::LoopSingular(Box::new(LoopSingularity {
                    loop_name: singular.loop_name,
                    q: to.to_vec(),
                    from: from.to_vec(),
                    at,
                })));
            }
            Err(e) => {
                data.joint = current;
                h *= 0.5;
                if h < CONTINUATION_MIN_SHARE {
                    let reached: Vec<f64> =
                        from.iter().zip(to).map(|(a, b)| a + t * (b - a)).collect();
                    return Err(continuation_failure(model, data, e, [from, &reached, to]));
                }
            }
        }
    }
    Ok(())
}

/// Relative size of the smallest singular value of a loop Jacobian below
/// which a continuation that cannot go on is said to meet a singular one.
const SINGULAR_LOOP_JACOBIAN: f64 = 1e-3;

/// The error of a continuation that cannot go on at the configuration the
/// joints of `data` are assembled in: a singular loop Jacobian there
/// (by [`SINGULAR_LOOP_JACOBIAN`]), by name, or the loop that cannot close,
/// with the configuration asked for. `at` is the last configuration reached.
fn continuation_failure(
    model: &Model,
    data: &mut Data,
    error: KinematicsError,
    [from, at, to]: [&[f64]; 3],
) -> KinematicsError {
    data.compute_poses(model);
    for l in &model.loops {
        let svd = passive_jacobian(model, data, l).svd(false, false);
        let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
        if smin <= SINGULAR_LOOP_JACOBIAN * smax {
            return KinematicsError::LoopSingular(Box::new(LoopSingularity {
                loop_name: l.name.clone(),
                q: to.to_vec(),
                from: from.to_vec(),
                at: at.to_vec(),
            }));
        }
    }
    match error {
        KinematicsError::LoopCannotClose {
            loop_name,
            residual,
            ..
        } => KinematicsError::LoopCannotClose {
            loop_name,
            q: to.to_vec(),
            residual,
        },
        other => other,
    }
}

fn four_bar_closed_form(
    model: &Model,
    data: &mut Data,
    l: &LoopModel,
    q: &[f64],
) -> Result<(), KinematicsError> {
    let Some(fb) = l.four_bar else {
        return Ok(());
    };
    data.compute_poses(model);
    let pa = data.poses[fb.joint_a];
    let pb = data.poses[fb.joint_b];
    let (side_a_cut, side_b_cut) = (l.cut_a, l.cut_b);
    // joint_a lies on path a by construction; joint_b on path b.
    let u_a = pa.r.transpose() * (data.poses[side_a_cut].p - pa.p);
    let u_b = pb.r.transpose() * (data.poses[side_b_cut].p - pb.p);
    let c2 = pa.r.transpose() * (pb.p - pa.p);
    let m = pa.r.transpose() * pb.r;
    let rho_a = u_a.x.hypot(u_a.y);
    let rho_b = u_b.x.hypot(u_b.y);
    let dist = c2.x.hypot(c2.y);
    // The residual reported is how far the two circles miss each other.
    let gap = (dist - (rho_a + rho_b)).max((rho_a - rho_b).abs() - dist);
    if dist < 1e-12 || gap > 0.0 {
        return Err(loop_cannot_close(l, q, gap.max(0.0)));
    }
    let along = (rho_a * rho_a - rho_b * rho_b + dist * dist) / (2.0 * dist);
    let h = (rho_a * rho_a - along * along).max(0.0).sqrt();
    let (ex, ey) = (c2.x / dist, c2.y / dist);
    let px = along * ex - l.branch * h * ey;
    let py = along * ey + l.branch * h * ex;
    let delta_a = py.atan2(px) - u_a.y.atan2(u_a.x);
    let w = m.transpose() * Vector3::new(px - c2.x, py - c2.y, 0.0);
    let delta_b = w.y.atan2(w.x) - u_b.y.atan2(u_b.x);
    data.joint[fb.joint_a] = wrap_near(data.joint[fb.joint_a] + delta_a, data.joint[fb.joint_a]);
    data.joint[fb.joint_b] = wrap_near(data.joint[fb.joint_b] + delta_b, data.joint[fb.joint_b]);
    data.compute_poses(model);
    let (_, _, r_rel) = loop_residual(data, l);
    let psi = r_rel[(1, 0)].atan2(r_rel[(0, 0)]);
    let cut = fb.joint_cut;
    data.joint[cut] += if fb.cut_on_a { psi } else { -psi };
    Ok(())
}

/// Wraps `value` to within pi of `reference`.
fn wrap_near(value: f64, reference: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    value - tau * ((value - reference) / tau).round()
}

/// Slider-crank relation V: joint angle and its derivatives
/// (d/d screw length, d/d kappa, d/d lambda, d/d l1, d/d l3).
pub(crate) fn slider_crank_angle(
    name: &str,
    screw_length: f64,
    kappa: f64,
    lambda: f64,
    l1: f64,
    l3: f64,
    branch: f64,
) -> Result<(f64, [f64; 5]), KinematicsError> {
    let cosine = (l1 * l1 + l3 * l3 - screw_length * screw_length) / (2.0 * l1 * l3);
    if cosine.is_nan() || cosine.abs() >= 1.0 - 1e-12 || screw_length <= 0.0 {
        return Err(KinematicsError::SliderCrankOutOfRange {
            joint: name.to_string(),
            screw_length,
            cosine,
        });
    }
    let phi = cosine.acos();
    let sin_phi = phi.sin();
    let dphi_dc = -1.0 / sin_phi;
    let dc_dr = -screw_length / (l1 * l3);
    let dc_dl1 = (l1 * l1 - l3 * l3 + screw_length * screw_length) / (2.0 * l1 * l1 * l3);
    let dc_dl3 = (l3 * l3 - l1 * l1 + screw_length * screw_length) / (2.0 * l1 * l3 * l3);
    let angle = lambda - kappa + branch * phi;
    Ok((
        angle,
        [
            branch * dphi_dc * dc_dr,
            -1.0,
            1.0,
            branch * dphi_dc * dc_dl1,
            branch * dphi_dc * dc_dl3,
        ],
    ))
}

/// Joint values of the non-passive joints, optionally with their derivatives.
fn evaluate_joints(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    derivatives: bool,
) -> Result<(), KinematicsError> {
    let np = model.n_params();
    let na = model.n_actuated();
    for (i, f) in model.frames.iter().enumerate() {
        match f.source {
            JointSource::Fixed | JointSource::Passive(_) => {}
            JointSource::Actuated(k) => {
                data.joint[i] = q[k];
                if derivatives {
                    data.djoint_dq[i * na..(i + 1) * na].fill(0.0);
                    data.djoint_dq[i * na + k] = 1.0;
                }
            }
            JointSource::SliderCrank(c) => {
                let crank = &model.cranks[c];
                let [offset, kappa, lambda, l1, l3] = data.crank_values[c];
                let (angle, d) = slider_crank_angle(
                    &f.name,
                    q[crank.actuated] + offset,
                    kappa,
                    lambda,
                    l1,
                    l3,
                    crank.branch,
                )?;
                data.joint[i] = angle;
                if derivatives {
                    let row = &mut data.djoint_dq[i * na..(i + 1) * na];
                    row.fill(0.0);
                    row[crank.actuated] = d[0];
                    let row = &mut data.djoint_dxi[i * np..(i + 1) * np];
                    row.fill(0.0);
                    for (affine, dv) in [
                        (&crank.screw_offset, d[0]),
                        (&crank.kappa, d[1]),
                        (&crank.lambda, d[2]),
                        (&crank.l1, d[3]),
                        (&crank.l3, d[4]),
                    ] {
                        for &(j, coef) in &affine.terms {
                            row[j] += coef * dv;
                        }
                    }
                }
            }
            JointSource::Coupled(c) => {
                let coupling = &model.couplings[c];
                let mut value = 0.0;
                for &(src, ratio) in &coupling.terms {
                    let total = match model.frames[src].joint {
                        JointType::Prismatic => data.r_const[src],
                        _ => data.theta_const[src],
                    } + data.joint[src];
                    value += ratio * total;
                }
                data.joint[i] = value;
                if derivatives {
                    data.djoint_dq[i * na..(i + 1) * na].fill(0.0);
                    data.djoint_dxi[i * np..(i + 1) * np].fill(0.0);
                    for &(src, ratio) in &coupling.terms {
                        for k in 0..na {
                            data.djoint_dq[i * na + k] += ratio * data.djoint_dq[src * na + k];
                        }
                        if joint_depends_on_xi(model, src) {
                            for j in 0..np {
                                data.djoint_dxi[i * np + j] +=
                                    ratio * data.djoint_dxi[src * np + j];
                            }
                        }
                        let kq = model.frames[src].joint_quantity().unwrap_or(5);
                        for &(j, coef) in &model.frames[src].quantity[kq].terms {
                            data.djoint_dxi[i * np + j] += ratio * coef;
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

#[inline]
fn joint_depends_on_xi(model: &Model, f: usize) -> bool {
    matches!(
        model.frames[f].source,
        JointSource::SliderCrank(_) | JointSource::Coupled(_) | JointSource::Passive(_)
    )
}

/// Implicit differentiation of a closed loop (the a3..e3 coefficients of (51)).
fn loop_derivatives(model: &Model, data: &mut Data, l: &LoopModel) -> Result<(), KinematicsError> {
    let np = model.n_params();
    let na = model.n_actuated();
    let m = l.selection.len();
    let (_, r_a, r_rel) = loop_residual(data, l);
    let p_b = data.poses[l.cut_b].p;
    let g_p = passive_jacobian(model, data, l);
    let mut rhs = DMatrix::<f64>::zeros(m, np + na);
    for (s, path) in [(-1.0, &l.path_a), (1.0, &l.path_b)] {
        for &f in path.iter() {
            let frame = &model.frames[f];
            let jq = frame.joint_quantity();
            for k in 0..7 {
                let has_terms = !frame.quantity[k].terms.is_empty();
                let is_joint = jq == Some(k);
                if !has_terms && !is_joint {
                    continue;
                }
                let (u, o) = data.quantity_axis(model, f, k);
                let d = residual_derivative(&u, &o, s, &p_b, &r_a, &r_rel);
                for &(j, coef) in &frame.quantity[k].terms {
                    for (row, &comp) in l.selection.iter().enumerate() {
                        rhs[(row, j)] -= coef * d[comp];
                    }
                }
                if is_joint && !l.passive.contains(&f) && frame.source != JointSource::Fixed {
                    for (row, &comp) in l.selection.iter().enumerate() {
                        if joint_depends_on_xi(model, f) {
                            for j in 0..np {
                                rhs[(row, j)] -= d[comp] * data.djoint_dxi[f * np + j];
                            }
                        }
                        for k2 in 0..na {
                            rhs[(row, np + k2)] -= d[comp] * data.djoint_dq[f * na + k2];
                        }
                    }
                }
            }
        }
    }
    let sol = least_squares(g_p, &rhs, &format!("closure of loop `{}`", l.name))?;
    for (c, &f) in l.passive.iter().enumerate() {
        for j in 0..np {
            data.djoint_dxi[f * np + j] = sol[(c, j)];
        }
        for k in 0..na {
            data.djoint_dq[f * na + k] = sol[(c, np + k)];
        }
    }
    Ok(())
}

fn run_forward(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    derivatives: bool,
) -> Result<(), KinematicsError> {
    check_vector("q", q, model.n_actuated())?;
    // A cache hit means xi was checked when it was cached.
    if !(data.cache_valid && data.cached_xi.as_slice() == xi) {
        check_vector("xi", xi, model.n_params())?;
    }
    if data.joint.len() != model.frames.len() || data.cached_xi.len() != xi.len() {
        return Err(KinematicsError::WrongLength {
            what: format!(
                "Data (frames) used with model `{}`: it was built for another model",
                model.name
            ),
            expected: model.frames.len(),
            found: data.joint.len(),
        });
    }
    data.update_cache(model, xi);
    if model.loops.is_empty() {
        evaluate_joints(model, data, q, derivatives)?;
        data.compute_poses(model);
    } else {
        let saved: Vec<f64> = data.joint.clone();
        let result = (|| {
            if let Some(from) = continuation_start(model, data, q) {
                follow_loops(model, data, &from, q)?;
            }
            evaluate_joints(model, data, q, derivatives)?;
            close_loops(model, data, q)
        })();
        if let Err(e) = result {
            // Keep the previous (assembled) branch as the seed of the next call.
            data.joint = saved;
            data.compute_poses(model);
            return Err(e);
        }
        if model.follows_loops {
            match data.assembled_q.as_mut() {
                Some(a) => a.copy_from_slice(q),
                None => data.assembled_q = Some(q.to_vec()),
            }
        }
        data.collect_passive(model);
        if derivatives {
            for l in &model.loops {
                loop_derivatives(model, data, l)?;
            }
        }
    }
    data.tcp = data.poses[model.end_frame].compose(&model.tool_pose);
    Ok(())
}

/// Pose `x_base_tcp` of the TCP in the robot base frame R0 (tool transform
/// included, base transform not): the forward model (1), (42).
///
/// `q` holds the actuated coordinates (rad, m), `xi` the geometric parameters.
pub fn forward_pose(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
) -> Result<Isometry3<f64>, KinematicsError> {
    run_forward(model, data, q, xi, false)?;
    Ok(data.tcp.to_isometry())
}

/// Pose `x_base_frame` of the frame or named place `name` (a frame's name,
/// a link of [`Model::named_frames`], or `0` for the base R0) in the robot
/// base frame R0, at the actuated coordinates `q` and parameters `xi`.
///
/// # Errors
/// [`KinematicsError::UnknownFrame`] listing the names there are; the
/// errors of [`forward_frames`].
pub fn forward_named_pose(
    model: &Model,
    data: &mut Data,
    name: &str,
    q: &[f64],
    xi: &[f64],
) -> Result<Isometry3<f64>, KinematicsError> {
    let (frame, x_frame_place) = model.locate(name)?;
    run_forward(model, data, q, xi, false)?;
    Ok(match frame {
        Some(i) => data.poses[i].to_isometry() * x_frame_place,
        None => x_frame_place,
    })
}

/// Poses of all frames; afterwards [`Data::frame_pose`] gives `x_base_frame`
/// and [`Data::passive_values`] the assembled loop joints.
pub fn forward_frames(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
) -> Result<(), KinematicsError> {
    run_forward(model, data, q, xi, false)
}

/// Joint Jacobian into `out` (6 x n_actuated, rows `[linear; angular]` in the
/// base frame, linear part at the TCP point); returns the TCP pose.
pub fn joint_jacobian_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    out: &mut Matrix6xX<f64>,
) -> Result<Isometry3<f64>, KinematicsError> {
    check_joint_columns(model, out)?;
    run_forward(model, data, q, xi, true)?;
    joint_jacobian_from_forward(model, data, out);
    Ok(data.tcp.to_isometry())
}

/// Checks that a joint Jacobian has one column per actuated coordinate.
fn check_joint_columns(model: &Model, out: &Matrix6xX<f64>) -> Result<(), KinematicsError> {
    if out.ncols() != model.n_actuated() {
        return Err(KinematicsError::WrongLength {
            what: "joint Jacobian columns".into(),
            expected: model.n_actuated(),
            found: out.ncols(),
        });
    }
    Ok(())
}

/// The joint Jacobian from the forward pass (with derivatives) already in
/// `data`; `out` has `n_actuated` columns.
fn joint_jacobian_from_forward(model: &Model, data: &Data, out: &mut Matrix6xX<f64>) {
    joint_columns_at(
        model,
        data,
        model.tcp_path.iter().copied(),
        &data.tcp.p,
        out,
    );
}

/// The joint Jacobian of `point` (base frame) moved by the joints of
/// `frames` (the path from the root to the frame carrying the point), from
/// the forward pass with derivatives in `data`, into `out` (zeroed first).
fn joint_columns_at(
    model: &Model,
    data: &Data,
    frames: impl Iterator<Item = usize>,
    point: &Vector3<f64>,
    out: &mut Matrix6xX<f64>,
) {
    let na = model.n_actuated();
    out.fill(0.0);
    for f in frames {
        let Some(k) = model.frames[f].joint_quantity() else {
            continue;
        };
        if model.frames[f].source == JointSource::Fixed {
            continue;
        }
        let (u, o) = data.quantity_axis(model, f, k);
        let t = twist_at(&u, &o, point);
        for c in 0..na {
            let w = data.djoint_dq[f * na + c];
            if w != 0.0 {
                for r in 0..6 {
                    out[(r, c)] += w * t[r];
                }
            }
        }
    }
}

/// [`param_jacobian_into`] and [`joint_jacobian_into`] at the same `q` and
/// `xi` from one pass of the forward model (the pass is most of the cost of
/// either): what an elasto-geometric identification needs at every pose.
/// Returns the TCP pose `x_base_tcp`.
///
/// # Errors
/// As [`param_jacobian_into`] and [`joint_jacobian_into`].
pub fn param_and_joint_jacobians_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    params_out: &mut DMatrix<f64>,
    joints_out: &mut Matrix6xX<f64>,
) -> Result<Isometry3<f64>, KinematicsError> {
    check_joint_columns(model, joints_out)?;
    let x_base_tcp = param_jacobian_into(model, data, q, xi, params_out)?;
    joint_jacobian_from_forward(model, data, joints_out);
    Ok(x_base_tcp)
}

/// Joint Jacobian (6 x n_actuated): column k = d[p_tcp; phi]/d q_k, rows
/// `[linear; angular]` in the base frame, phi the small rotation vector with
/// `R(q + dq) = exp([dphi]x) R(q)`.
pub fn joint_jacobian(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
) -> Result<Matrix6xX<f64>, KinematicsError> {
    let mut out = Matrix6xX::zeros(model.n_actuated());
    joint_jacobian_into(model, data, q, xi, &mut out)?;
    Ok(out)
}

/// A force applied at a point fixed to a frame (a link's weight, a payload).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLoad {
    /// Index of the frame carrying the point ([`Model::frame_index`]).
    pub frame: usize,
    /// The point in that frame (m).
    pub point: Vector3<f64>,
    /// The force in the base frame R0 (N).
    pub force: Vector3<f64>,
}

/// Generalised forces on the actuated coordinates (N.m for angles, N for
/// lengths) of point forces, by virtual work: `tau = sum_k J_k^T f_k`, with
/// `J_k` the linear Jacobian of load k's point with respect to the actuated
/// coordinates (closed loops, slider cranks and couplings included, as in
/// [`joint_jacobian_into`]). A joint spring of compliance `c_i` then
/// deflects actuated coordinate i by `c_i tau_i`. Writes `out` (length
/// n_actuated) and returns nothing else.
///
/// # Errors
/// [`KinematicsError::WrongLength`] for `out` or a frame index out of range,
/// and the errors of the forward model.
pub fn actuated_forces_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    loads: &[PointLoad],
    out: &mut [f64],
) -> Result<(), KinematicsError> {
    let na = model.n_actuated();
    check_vector("generalised forces", out, na)?;
    if let Some(bad) = loads.iter().find(|l| l.frame >= model.frames.len()) {
        return Err(KinematicsError::WrongLength {
            what: "frame index of a point load (number of frames)".into(),
            expected: model.frames.len(),
            found: bad.frame,
        });
    }
    run_forward(model, data, q, xi, true)?;
    out.fill(0.0);
    for load in loads {
        let pose = &data.poses[load.frame];
        let point = pose.p + pose.r * load.point;
        let mut f = Some(load.frame);
        while let Some(frame) = f {
            f = model.frames[frame].parent;
            let Some(k) = model.frames[frame].joint_quantity() else {
                continue;
            };
            if model.frames[frame].source == JointSource::Fixed {
                continue;
            }
            let (u, o) = data.quantity_axis(model, frame, k);
            let t = twist_at(&u, &o, &point);
            let work = t[0] * load.force.x + t[1] * load.force.y + t[2] * load.force.z;
            for (c, tau) in out.iter_mut().enumerate() {
                let w = data.djoint_dq[frame * na + c];
                if w != 0.0 {
                    *tau += w * work;
                }
            }
        }
    }
    Ok(())
}

/// Parameter Jacobian (equations (49)-(52)) into `out` (6 x n_params): column
/// j = d[p_tcp; phi]/d xi_j, rows `[linear; angular]` in the base frame, with
/// `R(xi + dxi) = exp([dphi]x) R(xi)`. Returns the TCP pose `x_base_tcp`.
///
/// Passive loop joints enter through implicit differentiation of the
/// closure, slider cranks through the derivatives of V, couplings through
/// their ratios (Appendix B).
pub fn param_jacobian_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    out: &mut DMatrix<f64>,
) -> Result<Isometry3<f64>, KinematicsError> {
    let np = model.n_params();
    if out.nrows() != 6 || out.ncols() != np {
        return Err(KinematicsError::WrongLength {
            what: "parameter Jacobian (6 x n_params) columns".into(),
            expected: np,
            found: if out.nrows() == 6 {
                out.ncols()
            } else {
                out.len()
            },
        });
    }
    run_forward(model, data, q, xi, true)?;
    let point = data.tcp.p;
    let jac = out.as_mut_slice();
    jac.fill(0.0);
    // Terms come grouped by (frame, quantity): one twist per group.
    let mut group = (usize::MAX, usize::MAX);
    let mut t = [0.0; 6];
    for &(f, k, j, coef) in &model.tcp_terms {
        if (f, k) != group {
            let (u, o) = data.quantity_axis(model, f, k);
            t = twist_at(&u, &o, &point);
            group = (f, k);
        }
        let col = &mut jac[6 * j..6 * j + 6];
        for r in 0..6 {
            col[r] += coef * t[r];
        }
    }
    for &f in &model.tcp_xi_joints {
        let k = model.frames[f].joint_quantity().unwrap_or(5);
        let (u, o) = data.quantity_axis(model, f, k);
        let t = twist_at(&u, &o, &point);
        let row = &data.djoint_dxi[f * np..(f + 1) * np];
        for (j, &w) in row.iter().enumerate() {
            if w != 0.0 {
                let col = &mut jac[6 * j..6 * j + 6];
                for r in 0..6 {
                    col[r] += w * t[r];
                }
            }
        }
    }
    Ok(data.tcp.to_isometry())
}

/// Allocating twin of [`param_jacobian_into`]: the TCP pose and the 6 x
/// n_params parameter Jacobian.
pub fn param_jacobian(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
) -> Result<(Isometry3<f64>, DMatrix<f64>), KinematicsError> {
    let mut out = DMatrix::zeros(6, model.n_params());
    let pose = param_jacobian_into(model, data, q, xi, &mut out)?;
    Ok((pose, out))
}

/// Checks a frame index against the model.
fn check_frame(model: &Model, frame: usize) -> Result<(), KinematicsError> {
    if frame >= model.frames.len() {
        return Err(KinematicsError::WrongLength {
            what: format!(
                "frame index of model `{}` (number of frames; see Model::frame_index)",
                model.name
            ),
            expected: model.frames.len(),
            found: frame,
        });
    }
    Ok(())
}

/// Pose `x_base_point` of a point frame fixed to frame `frame` of the robot
/// (any frame of a serial chain, a tree or a closed loop: a marker on one
/// hand of a two-armed robot, a probe on a link), `x_frame_point` giving it
/// in that frame. The base transform is not included, as in
/// [`forward_pose`]; with `frame = model.end_frame()` and `x_frame_point =
/// model.tool()` this is the TCP.
///
/// # Errors
/// [`KinematicsError::WrongLength`] for a frame index out of range, and the
/// errors of the forward model.
pub fn forward_frame_pose(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    frame: usize,
    x_frame_point: &Isometry3<f64>,
) -> Result<Isometry3<f64>, KinematicsError> {
    check_frame(model, frame)?;
    run_forward(model, data, q, xi, false)?;
    Ok(data.poses[frame]
        .compose(&Pose::from_isometry(x_frame_point))
        .to_isometry())
}

/// Parameter Jacobian of a point frame fixed to any frame of the robot
/// (equations (49)-(52) with the path from R0 to `frame` in place of the
/// path to the end frame) into `out` (6 x n_params): column j =
/// d[p_point; phi]/d xi_j, rows `[linear; angular]` in the base frame, the
/// linear part at the point `x_base_frame * x_frame_point`. Returns that
/// pose `x_base_point`.
///
/// Only the frames on the path from the root to `frame` move the point:
/// on a tree the parameters of the other branches have zero columns; a
/// passive loop joint on the path enters through the implicit
/// differentiation of its loop's closure, as for the TCP.
///
/// # Errors
/// [`KinematicsError::WrongLength`] for `out` or a frame index out of
/// range, and the errors of the forward model.
pub fn frame_param_jacobian_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    frame: usize,
    x_frame_point: &Isometry3<f64>,
    out: &mut DMatrix<f64>,
) -> Result<Isometry3<f64>, KinematicsError> {
    check_frame(model, frame)?;
    let np = model.n_params();
    if out.nrows() != 6 || out.ncols() != np {
        return Err(KinematicsError::WrongLength {
            what: "parameter Jacobian (6 x n_params) columns".into(),
            expected: np,
            found: if out.nrows() == 6 {
                out.ncols()
            } else {
                out.len()
            },
        });
    }
    run_forward(model, data, q, xi, true)?;
    Ok(frame_param_columns(model, data, frame, x_frame_point, out))
}

/// The parameter Jacobian of a point on `frame` from the forward pass with
/// derivatives already in `data` (`out` checked 6 x n_params); returns the
/// point's pose.
fn frame_param_columns(
    model: &Model,
    data: &Data,
    frame: usize,
    x_frame_point: &Isometry3<f64>,
    out: &mut DMatrix<f64>,
) -> Isometry3<f64> {
    let np = model.n_params();
    let x_base_point = data.poses[frame].compose(&Pose::from_isometry(x_frame_point));
    let point = x_base_point.p;
    let jac = out.as_mut_slice();
    jac.fill(0.0);
    let mut add = |t: &[f64; 6], j: usize, w: f64| {
        let col = &mut jac[6 * j..6 * j + 6];
        for r in 0..6 {
            col[r] += w * t[r];
        }
    };
    let mut f = Some(frame);
    while let Some(i) = f {
        let frame_model = &model.frames[i];
        for k in 0..7 {
            if frame_model.quantity[k].terms.is_empty() {
                continue;
            }
            let (u, o) = data.quantity_axis(model, i, k);
            let t = twist_at(&u, &o, &point);
            for &(j, coef) in &frame_model.quantity[k].terms {
                add(&t, j, coef);
            }
        }
        if frame_model.joint != JointType::Fixed && joint_depends_on_xi(model, i) {
            let k = frame_model.joint_quantity().unwrap_or(5);
            let (u, o) = data.quantity_axis(model, i, k);
            let t = twist_at(&u, &o, &point);
            for j in 0..np {
                let w = data.djoint_dxi[i * np + j];
                if w != 0.0 {
                    add(&t, j, w);
                }
            }
        }
        f = frame_model.parent;
    }
    x_base_point.to_isometry()
}

/// [`frame_param_jacobian_into`] and the joint Jacobian of the same point
/// (6 x n_actuated into `joints_out`: column k = d[p_point; phi]/d q_k, rows
/// `[linear; angular]` in the base frame, linear part at the point) from one
/// pass of the forward model: what an elasto-geometric identification with
/// targets on several frames needs at every observation. Only the actuated
/// coordinates that move frames on the path from the root to `frame` have
/// non-zero columns (closed loops and couplings through their ratios, as in
/// [`joint_jacobian_into`]). Returns `x_base_point`.
///
/// # Errors
/// As [`frame_param_jacobian_into`], and
/// [`KinematicsError::WrongLength`] for `joints_out`.
#[allow(clippy::too_many_arguments)]
pub fn frame_param_and_joint_jacobians_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    frame: usize,
    x_frame_point: &Isometry3<f64>,
    params_out: &mut DMatrix<f64>,
    joints_out: &mut Matrix6xX<f64>,
) -> Result<Isometry3<f64>, KinematicsError> {
    let mut pose = [Isometry3::identity()];
    frame_points_jacobians_into(
        model,
        data,
        q,
        xi,
        &[(frame, *x_frame_point)],
        std::slice::from_mut(params_out),
        std::slice::from_mut(joints_out),
        &mut pose,
    )?;
    Ok(pose[0])
}

/// [`frame_param_and_joint_jacobians_into`] for several points at the same
/// configuration from one pass of the forward model (the pass is most of
/// the cost): point i is fixed to frame `points[i].0` at `points[i].1` in
/// it; its parameter Jacobian goes to `params_out[i]` (6 x n_params), its
/// joint Jacobian to `joints_out[i]` (6 x n_actuated) and its pose
/// `x_base_point` to `poses_out[i]`. The markers on both hands of a
/// two-armed robot at one pose. An empty `joints_out` skips the joint
/// Jacobians (a geometric identification needs none).
///
/// # Errors
/// [`KinematicsError::WrongLength`] for a frame index out of range, output
/// slices shorter than `points` or matrices of the wrong size, and the
/// errors of the forward model.
#[allow(clippy::too_many_arguments)]
pub fn frame_points_jacobians_into(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    points: &[(usize, Isometry3<f64>)],
    params_out: &mut [DMatrix<f64>],
    joints_out: &mut [Matrix6xX<f64>],
    poses_out: &mut [Isometry3<f64>],
) -> Result<(), KinematicsError> {
    let np = model.n_params();
    let with_joints = !joints_out.is_empty();
    let shortest = params_out.len().min(poses_out.len());
    let shortest = if with_joints {
        shortest.min(joints_out.len())
    } else {
        shortest
    };
    if shortest < points.len() {
        return Err(KinematicsError::WrongLength {
            what: "outputs of the points' Jacobians (one per point)".into(),
            expected: points.len(),
            found: shortest,
        });
    }
    for (i, (frame, _)) in points.iter().enumerate() {
        check_frame(model, *frame)?;
        if with_joints {
            check_joint_columns(model, &joints_out[i])?;
        }
        let params = &params_out[i];
        if params.nrows() != 6 || params.ncols() != np {
            return Err(KinematicsError::WrongLength {
                what: "parameter Jacobian (6 x n_params) columns".into(),
                expected: np,
                found: params.ncols(),
            });
        }
    }
    run_forward(model, data, q, xi, true)?;
    for (i, (frame, x_frame_point)) in points.iter().enumerate() {
        let x_base_point =
            frame_param_columns(model, data, *frame, x_frame_point, &mut params_out[i]);
        if with_joints {
            joint_columns_at(
                model,
                data,
                std::iter::successors(Some(*frame), |&f| model.frames[f].parent),
                &x_base_point.translation.vector,
                &mut joints_out[i],
            );
        }
        poses_out[i] = x_base_point;
    }
    Ok(())
}

/// Allocating twin of [`frame_param_jacobian_into`]: the pose `x_base_point`
/// and the 6 x n_params parameter Jacobian of the point.
///
/// # Errors
/// As [`frame_param_jacobian_into`].
pub fn frame_param_jacobian(
    model: &Model,
    data: &mut Data,
    q: &[f64],
    xi: &[f64],
    frame: usize,
    x_frame_point: &Isometry3<f64>,
) -> Result<(Isometry3<f64>, DMatrix<f64>), KinematicsError> {
    let mut out = DMatrix::zeros(6, model.n_params());
    let pose = frame_param_jacobian_into(model, data, q, xi, frame, x_frame_point, &mut out)?;
    Ok((pose, out))
}

#[cfg(test)]
mod tests {
    use super::{slider_crank_angle, wrap_near};
    use crate::KinematicsError;

    #[test]
    fn slider_crank_derivatives_match_central_differences() {
        let base = [0.9, 0.1, -1.2, 0.35, 0.85];
        let angle = |x: &[f64; 5]| {
            slider_crank_angle("2", x[0], x[1], x[2], x[3], x[4], -1.0)
                .map(|(a, _)| a)
                .unwrap_or(f64::NAN)
        };
        let (_, analytic) = slider_crank_angle("2", 0.9, 0.1, -1.2, 0.35, 0.85, -1.0).unwrap();
        let h = 1e-6;
        for k in 0..5 {
            let (mut plus, mut minus) = (base, base);
            plus[k] += h;
            minus[k] -= h;
            let numeric = (angle(&plus) - angle(&minus)) / (2.0 * h);
            assert!(
                (numeric - analytic[k]).abs() < 1e-7 * analytic[k].abs().max(1.0),
                "component {k}: {numeric} vs {}",
                analytic[k]
            );
        }
    }

    #[test]
    fn slider_crank_law_of_cosines_uses_the_squared_screw_length() {
        // Right angle between the pivots: r'^2 = l1^2 + l3^2.
        let (l1, l3) = (0.3, 0.4);
        let (angle, _) = slider_crank_angle("8", 0.5, 0.0, 0.0, l1, l3, 1.0).unwrap();
        assert!((angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let err = slider_crank_angle("8", 0.75, 0.0, 0.0, l1, l3, 1.0).unwrap_err();
        assert!(
            matches!(err, KinematicsError::SliderCrankOutOfRange { ref joint, .. } if joint == "8")
        );
    }

    #[test]
    fn wrapping_keeps_the_value_within_half_a_turn_of_the_reference() {
        let tau = std::f64::consts::TAU;
        assert!((wrap_near(0.1 + 3.0 * tau, 0.0) - 0.1).abs() < 1e-12);
        assert!((wrap_near(-3.0, 3.0) - (tau - 3.0)).abs() < 1e-12);
    }
}
