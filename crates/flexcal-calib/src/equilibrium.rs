//! The elastic deflection as the static equilibrium: the joint springs'
//! torques and the lateral springs' moments taken on the deflected robot,
//! not on the commanded one.
//!
//! By default ([`Deflection::OneStep`]) the elasto-geometric model of
//! [`crate::gravity`] takes one linear step: the gravity torques `tau(q)`
//! on the commanded configuration `q`, then `dq = C tau(q)` and the pose at
//! `q + dq`. A compliant robot (a few hundred urad/N.m, tens of N.m) sags
//! by centimetres and moves its own lever arms: its springs balance
//! `tau(q + dq)`, not `tau(q)`. With [`Deflection::Equilibrium`] the model
//! solves
//!
//! `dq = f(tau(q) + K(q) dq)`, `K = d tau / d q`
//!
//! by Newton's method to the stated tolerance (`f` the joint springs:
//! `c_i tau_i`, or the law of [`crate::joint_law`]), and each lateral
//! spring turns by `c_s (M_s(q) + L_s(q) dq)`, `L = d M / d q`. The gravity
//! stiffness `K` and `L` (linear in the payload unknowns, as `tau` and `M`
//! are) are the torques' and moments' derivatives by the actuated
//! coordinates on the nominal geometry at the commanded configuration,
//! computed once per pose by central differences of the same terms
//! ([`STIFFNESS_STEP`]): the torques are taken on the deflected
//! configuration to first order in the deflection. What that leaves out is
//! of second order: `f(tau'' dq^2 / 2)`. On the compliant torso of the
//! tests (joint compliances 100-400 urad/N.m) the one step misplaces the
//! markers by up to 1.69 mm against the exact fixed point (torques
//! re-evaluated on the deflected robot at every iteration), this
//! equilibrium by up to 0.037 mm (`tests/equilibrium.rs`, 40 poses).
//! With linear springs the equilibrium found must be stable: the springs stiffer than
//! gravity's own stiffness (`I - D^1/2 K D^1/2` positive definite, `D`
//! the springs' compliances); otherwise the robot would buckle under its
//! own weight, and the model stops with
//! [`crate::CalibError::EquilibriumNotConverged`] naming the pose, as it
//! does when the iterations do not converge (with how far the last one
//! still moved).
//!
//! A coupling group's compliance matrix ([`crate::coupling`]) enters the
//! same system: its entries turn a drive by the other joints' torques on
//! the deflected robot, `dq_a += c_ab (tau_b + K_b dq) + c_ap (M_p + L_p
//! dq)`, so the Newton system is `dq = f(tau + K dq) + X (T + S dq)` (`X`
//! the entries, `S` the rows of `K` and `L` of the joints they multiply),
//! and the passive joint turns by `c_p (M_p + L_p dq) + c_ap (tau_a + K_a
//! dq) + ..`. On the compliant torso with a coupled group (100-400
//! urad/N.m, cross terms -80 to 20) the one step misplaces the markers by
//! up to 2.75 mm against the exact fixed point, this equilibrium by up to
//! 0.10 mm (`tests/coupling_compliance.rs`, 40 poses, the passive rotation
//! applied as the lateral springs apply it); the error falls with the cube
//! of the compliances, the one step's with their square.
//!
//! The derivatives are exact for this model, by the implicit function
//! theorem: with `A = I - diag(f') K - X S`, `d dq / d theta = A^-1 b`,
//! `b` the unknown's source at fixed `dq` (`df/dtheta + diag(f')
//! d(tau + K dq)/dtheta + X d(T + S dq)/dtheta` for a compliance, a law
//! term, a payload unknown; the other joint's torque `T_o + S_o dq` for a
//! coupling entry that turns a drive), and a lateral rotation gains `h_s
//! d dq / d theta` besides its direct part, `h_s = c_s L_s + sum c_j S_o`
//! its derivative by the joint deflections ([`crate::ErrorModel`]'s
//! Jacobian, checked against central differences in `tests/equilibrium.rs`
//! and, with a group, `tests/coupling_compliance.rs`).
//!
//! [`Deflection::Auto`] fits the one step first and switches the
//! equilibrium on (and fits again) when the one step's deflection changes
//! some joint's torque by more than a share of that joint's torque span
//! over the poses ([`DeflectionReport`] says which and by how much).
//!
//! Limitations: the lateral rotations' own lever-arm changes, the axes of
//! the lateral springs and the cyclic joint errors stay on the commanded
//! configuration (their effect on the torques is of the order of the
//! product of two deflections); the torques are on the nominal geometry,
//! as in the one step. A passive joint's rotation is no unknown of the
//! Newton system: its lever arm does not load the torques (with the
//! group above, the markers turned about the deflected robot's axis,
//! exactly, differ from this model by up to 0.51 mm).

use nalgebra::{DMatrix, Dyn, LU};
use serde::{Deserialize, Serialize};

use crate::coupling::Member;
use crate::deflection::Deflection;
use crate::error::CalibError;
use crate::gravity::{Configurations, GravityCompliance, GravityTerms, LateralTerms};

/// Step of the central differences of the gravity stiffness (rad for a
/// revolute coordinate, m for a prismatic one): their truncation error
/// (`h^2 tau''' / 6`, about 1e-11 of the torque) and their rounding error
/// (`1e-16 tau / h`, about 1e-11 of the torque) balance near it.
pub const STIFFNESS_STEP: f64 = 1e-5;

/// The least torque span a joint is judged against in
/// [`Deflection::Auto`] and [`DeflectionReport`], as a share of the largest
/// joint's span (dimensionless): 1 %.
pub const SPAN_FLOOR: f64 = 0.01;

/// Why the calibration used the deflection it used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeflectionChoice {
    /// The options asked for it ([`Deflection::OneStep`] or
    /// [`Deflection::Equilibrium`]).
    Asked,
    /// [`Deflection::Auto`] kept the one step: the largest torque change
    /// stayed within the share.
    AutoKeptOneStep,
    /// [`Deflection::Auto`] switched the equilibrium on: the largest
    /// torque change exceeded the share, and the identification was
    /// repeated with it.
    AutoSwitchedOn,
}

/// What the deflection model did to an elasto-geometric calibration
/// (part of [`crate::Calibration`] and of the calibration report).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeflectionReport {
    /// The deflection the identified model uses: `one-step` or
    /// `equilibrium`.
    pub used: String,
    /// Why ([`DeflectionChoice`]).
    pub choice: DeflectionChoice,
    /// The share [`Deflection::Auto`] compared with (dimensionless), when
    /// auto.
    pub auto_share: Option<f64>,
    /// The largest torque change share Auto measured after the one-step
    /// fit (dimensionless; compared with `auto_share`), when auto.
    pub auto_measured_share: Option<f64>,
    /// The actuated coordinate whose gravity torque the one step's
    /// deflection changes most, relative to its torque span.
    pub largest_torque_change_joint: String,
    /// That change (N.m, N for a prismatic coordinate): `K dq` of the one
    /// step at the identified unknowns, largest over the poses.
    pub largest_torque_change_nm: f64,
    /// That change as a share of the joint's torque span over the poses
    /// (dimensionless).
    pub largest_torque_change_share: f64,
    /// RMS over the observations of the distance between the positions
    /// predicted with the one step and with the equilibrium, at the
    /// identified unknowns (mm).
    pub position_difference_rms_mm: f64,
    /// Largest such distance (mm).
    pub position_difference_max_mm: f64,
}

/// Why the equilibrium of one pose was not found.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NotConverged {
    pub iterations: usize,
    /// The largest change of a joint deflection in the last iteration.
    pub change: f64,
    /// Whether it converged to an unstable equilibrium (springs softer
    /// than gravity's stiffness).
    pub unstable: bool,
}

/// The gravity stiffness of every pose (module docs): `K = d tau / d q`
/// and, per lateral spring, `L_s = d M_s / d q`, each as the links' part
/// and one part per payload unknown, on the nominal geometry at the
/// commanded configurations.
#[derive(Debug, Clone)]
pub(crate) struct GravityStiffness {
    na: usize,
    n_payload: usize,
    n_hinges: usize,
    /// Per pose, `1 + n_payload` row-major `na x na` matrices.
    joints: Vec<f64>,
    /// Per pose and hinge, `1 + n_payload` rows of `na`.
    hinges: Vec<f64>,
}

impl GravityStiffness {
    /// Central differences ([`STIFFNESS_STEP`]) of the terms of
    /// [`crate::gravity`] over `poses`.
    ///
    /// # Errors
    /// Those of [`GravityTerms::new`] and [`LateralTerms::new`].
    pub(crate) fn new(
        model: &flexcal_kinematics::Model,
        poses: &Configurations<'_>,
        gravity: &GravityCompliance,
    ) -> Result<Self, CalibError> {
        let na = model.n_actuated();
        let n_poses = poses.q.len();
        let mut stiffness: Option<Self> = None;
        let h = STIFFNESS_STEP;
        for d in 0..na {
            let shifted = |sign: f64| -> Vec<Vec<f64>> {
                poses
                    .q
                    .iter()
                    .map(|q| {
                        let mut q = q.to_vec();
                        q[d] += sign * h;
                        q
                    })
                    .collect()
            };
            let (plus, minus) = (shifted(1.0), shifted(-1.0));
            let at = |q: &[Vec<f64>]| -> Result<(GravityTerms, LateralTerms), CalibError> {
                let configurations = Configurations {
                    q: q.iter().map(Vec::as_slice).collect(),
                    label: poses.label,
                };
                Ok((
                    GravityTerms::new(model, &configurations, gravity)?,
                    LateralTerms::new(model, &configurations, gravity)?,
                ))
            };
            let (gp, lp) = at(&plus)?;
            let (gm, lm) = at(&minus)?;
            let s = stiffness.get_or_insert_with(|| {
                let n_payload = gp.n_payload();
                let n_hinges = lp.len();
                Self {
                    na,
                    n_payload,
                    n_hinges,
                    joints: vec![0.0; n_poses * (1 + n_payload) * na * na],
                    hinges: vec![0.0; n_poses * n_hinges * (1 + n_payload) * na],
                }
            });
            s.difference(d, (&gp, &gm), (&lp, &lm), n_poses);
        }
        Ok(stiffness.unwrap_or(Self {
            na,
            n_payload: 0,
            n_hinges: 0,
            joints: Vec::new(),
            hinges: Vec::new(),
        }))
    }

    /// Column `d` of every matrix from the terms at `q + h e_d` and
    /// `q - h e_d`.
    fn difference(
        &mut self,
        d: usize,
        (gp, gm): (&GravityTerms, &GravityTerms),
        (lp, lm): (&LateralTerms, &LateralTerms),
        n_poses: usize,
    ) {
        let (na, np) = (self.na, self.n_payload);
        let scale = 0.5 / STIFFNESS_STEP;
        let zeros = vec![0.0; np];
        let (mut tp, mut tm) = (vec![0.0; na], vec![0.0; na]);
        for k in 0..n_poses {
            gp.forces(k, &zeros, &mut tp);
            gm.forces(k, &zeros, &mut tm);
            let block = &mut self.joints[k * (1 + np) * na * na..][..(1 + np) * na * na];
            for i in 0..na {
                block[i * na + d] = (tp[i] - tm[i]) * scale;
                let (ap, am) = (gp.payload_derivatives(k, i), gm.payload_derivatives(k, i));
                for l in 0..np {
                    block[(1 + l) * na * na + i * na + d] = (ap[l] - am[l]) * scale;
                }
            }
            for s in 0..self.n_hinges {
                let (jp, jm) = (lp.joint(k, s), lm.joint(k, s));
                let rows = &mut self.hinges[(k * self.n_hinges + s) * (1 + np) * na..];
                rows[d] = (jp.moment(&zeros) - jm.moment(&zeros)) * scale;
                for l in 0..np {
                    rows[(1 + l) * na + d] =
                        (jp.payload_derivatives[l] - jm.payload_derivatives[l]) * scale;
                }
            }
        }
    }

    /// `L_s` of every lateral spring at pose `k` for the payload unknowns
    /// `payload`, spring-major (`n_hinges x na`), into `out`.
    fn hinge_stiffness(&self, k: usize, payload: &[f64], out: &mut Vec<f64>) {
        out.clear();
        for s in 0..self.n_hinges {
            let start = out.len();
            out.extend_from_slice(self.hinge_row(k, s, 0));
            for (l, p) in payload.iter().enumerate().take(self.n_payload) {
                for (o, v) in out[start..].iter_mut().zip(self.hinge_row(k, s, 1 + l)) {
                    *o += p * v;
                }
            }
        }
    }

    /// `K` of pose `k` for the payload unknowns `payload`, into `out`
    /// (`na x na`).
    fn joint_stiffness(&self, k: usize, payload: &[f64], out: &mut DMatrix<f64>) {
        let (na, np) = (self.na, self.n_payload);
        let block = &self.joints[k * (1 + np) * na * na..][..(1 + np) * na * na];
        for i in 0..na {
            for d in 0..na {
                out[(i, d)] = block[i * na + d]
                    + (0..np)
                        .map(|l| payload[l] * block[(1 + l) * na * na + i * na + d])
                        .sum::<f64>();
            }
        }
    }

    /// `K_l dq` (row `i`) of payload unknown `l` at pose `k`.
    fn payload_stiffness_times(&self, k: usize, l: usize, dq: &[f64], out: &mut [f64]) {
        let na = self.na;
        let block = &self.joints[(k * (1 + self.n_payload) + 1 + l) * na * na..][..na * na];
        for (i, o) in out.iter_mut().enumerate() {
            *o = block[i * na..(i + 1) * na]
                .iter()
                .zip(dq)
                .map(|(a, b)| a * b)
                .sum();
        }
    }

    /// Row `l` (0: the links', `1 + p`: payload unknown p's) of `L_s` at
    /// pose `k`.
    fn hinge_row(&self, k: usize, s: usize, l: usize) -> &[f64] {
        let na = self.na;
        &self.hinges[((k * self.n_hinges + s) * (1 + self.n_payload) + l) * na..][..na]
    }
}

/// The equilibrium of one pose: what the deflection and its derivatives
/// need beyond the one step's elastic-terms state.
#[derive(Debug, Clone)]
pub(crate) struct PoseEquilibrium {
    /// The deflection `dq` (rad or m).
    pub dq: Vec<f64>,
    /// `K dq`: the torque change of the deflection (N.m or N).
    pub torque_change: Vec<f64>,
    /// `K_l dq` per payload unknown, `na` each.
    pub payload_torque_change: Vec<f64>,
    /// `L_s dq` per lateral spring: its moment change (N.m).
    pub moment_change: Vec<f64>,
    /// `L_l,s dq` per lateral spring, then per payload unknown.
    pub payload_moment_change: Vec<f64>,
    /// `L_s` per lateral spring with the payload unknowns, `na` each: its
    /// moment's derivative by the joint deflections (N.m/rad).
    pub hinge_stiffness: Vec<f64>,
    /// LU factors of `A^T`, `A = I - diag(f') K`.
    lu_transposed: Option<LU<f64, Dyn, Dyn>>,
    k: DMatrix<f64>,
}

impl PoseEquilibrium {
    pub(crate) fn new(na: usize) -> Self {
        Self {
            dq: vec![0.0; na],
            torque_change: vec![0.0; na],
            payload_torque_change: Vec::new(),
            moment_change: Vec::new(),
            payload_moment_change: Vec::new(),
            hinge_stiffness: Vec::new(),
            lu_transposed: None,
            k: DMatrix::zeros(na, na),
        }
    }

    /// Entry `d` of joint `member`'s row of the gravity stiffness: its
    /// torque's derivative by joint deflection `d` (`K` for a drive, the
    /// spring's `L_s` for a passive joint; N.m/rad).
    pub(crate) fn stiffness_entry(&self, member: Member, d: usize) -> f64 {
        Rows {
            k: &self.k,
            hinges: &self.hinge_stiffness,
        }
        .entry(member, d)
    }

    /// `M^T = A^-T jq^T` for a point's joint Jacobian `jq` (6 x na): the
    /// point's twist per unit source of the deflection, `jq A^-1`.
    pub(crate) fn response(&self, jq: &nalgebra::Matrix6xX<f64>) -> DMatrix<f64> {
        let rhs = DMatrix::from_fn(jq.ncols(), 6, |i, r| jq[(r, i)]);
        self.lu_transposed
            .as_ref()
            .and_then(|lu| lu.solve(&rhs))
            .unwrap_or(rhs)
    }
}

/// The spring law of one joint: its deflection under a torque, and the
/// derivative by the torque (`f`, `f'`), written into the caller's state.
pub(crate) trait SpringLaw {
    /// Deflects joint `i` under `torque`; returns `(dq_i, d dq_i / d tau_i)`.
    fn deflect(&mut self, i: usize, torque: f64) -> (f64, f64);
    /// Whether every spring is linear (then the stability of the
    /// equilibrium is checked: [`solve`]).
    fn is_linear(&self) -> bool;
}

/// A coupling group's entry in a drive's deflection ([`crate::coupling`]):
/// `compliance` times the other joint's torque on the deflected robot,
/// `T_o + S_o dq` (`S_o` its row of `K`, or its spring's `L_s`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CrossTerm {
    /// The actuated coordinate the entry deflects.
    pub drive: usize,
    /// The entry's compliance (rad/N.m).
    pub compliance: f64,
    /// The joint whose torque it multiplies.
    pub other: Member,
    /// That joint's torque on the commanded configuration, `T_o` (N.m).
    pub torque: f64,
}

/// The rows of `K` and of the lateral springs' `L` of one pose (payload
/// unknowns included): the torques' derivatives by the joint deflections.
struct Rows<'a> {
    k: &'a DMatrix<f64>,
    hinges: &'a [f64],
}

impl Rows<'_> {
    /// `S_o . dq`: the change of joint `o`'s torque (N.m).
    fn times(&self, member: Member, dq: &[f64]) -> f64 {
        match member {
            Member::Drive(b) => (0..dq.len()).map(|d| self.k[(b, d)] * dq[d]).sum(),
            Member::Passive(s) => {
                let row = &self.hinges[s * dq.len()..(s + 1) * dq.len()];
                row.iter().zip(dq).map(|(a, b)| a * b).sum()
            }
        }
    }

    /// Entry `d` of `S_o`.
    fn entry(&self, member: Member, d: usize) -> f64 {
        match member {
            Member::Drive(b) => self.k[(b, d)],
            Member::Passive(s) => self.hinges[s * self.k.ncols() + d],
        }
    }
}

/// Solves the equilibrium of pose `k` (module docs) from the one step's
/// torques `tau` (on the commanded configuration, with the payload unknowns
/// `payload`) by Newton's method on `r(dq) = dq - f(tau + K dq) - X (T +
/// S dq)` from `dq = 0`, `X (T + S dq)` the coupling groups' entries
/// `cross` in the drives' deflections (the first step is the linearised
/// solution, exact for linear springs; the law converges quadratically,
/// its steps halved when they do not reduce the residual), until no step
/// moves a joint by more than the tolerance; then, for linear springs,
/// checks that the equilibrium is stable (`I - D^1/2 K_sym D^1/2` positive
/// definite, `D = diag(c)`: the springs are stiffer than gravity's own
/// stiffness; with coupling entries also every eigenvalue of `A` with a
/// positive real part) and factors `A` for the derivatives. On return
/// `tau` holds `tau + K dq` and `law` has been called last at it.
///
/// # Errors
/// [`NotConverged`] when the steps do not fall below the tolerance within
/// the cap, `A` is singular, or the equilibrium is not stable.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve(
    stiffness: &GravityStiffness,
    k: usize,
    payload: &[f64],
    (tolerance, max_iterations): (f64, usize),
    cross: &[CrossTerm],
    tau: &mut [f64],
    law: &mut dyn SpringLaw,
    out: &mut PoseEquilibrium,
) -> Result<(), NotConverged> {
    let na = stiffness.na;
    let mut kmat = std::mem::replace(&mut out.k, DMatrix::zeros(0, 0));
    if kmat.nrows() != na {
        kmat = DMatrix::zeros(na, na);
    }
    stiffness.joint_stiffness(k, payload, &mut kmat);
    stiffness.hinge_stiffness(k, payload, &mut out.hinge_stiffness);
    let hinges = std::mem::take(&mut out.hinge_stiffness);
    let result = iterate(
        &Rows {
            k: &kmat,
            hinges: &hinges,
        },
        (tolerance, max_iterations),
        cross,
        tau,
        law,
        out,
    );
    out.hinge_stiffness = hinges;
    if result.is_ok() {
        let np = stiffness.n_payload;
        out.payload_torque_change.resize(np * na, 0.0);
        for l in 0..np {
            stiffness.payload_stiffness_times(
                k,
                l,
                &out.dq,
                &mut out.payload_torque_change[l * na..(l + 1) * na],
            );
        }
        hinge_changes(stiffness, k, out);
    }
    out.k = kmat;
    result
}

/// Newton's iterations of [`solve`] on the rows `rows`, then the stability
/// check and the factors of `A^T` into `out`.
fn iterate(
    rows: &Rows<'_>,
    (tolerance, max_iterations): (f64, usize),
    cross: &[CrossTerm],
    tau: &mut [f64],
    law: &mut dyn SpringLaw,
    out: &mut PoseEquilibrium,
) -> Result<(), NotConverged> {
    let tau0 = tau.to_vec();
    let na = tau0.len();
    let mut slopes = vec![0.0; na];
    out.dq.iter_mut().for_each(|d| *d = 0.0);
    let mut change = f64::INFINITY;
    let mut iterations = 0;
    let failed = |iterations, change, unstable| {
        Err(NotConverged {
            iterations,
            change,
            unstable,
        })
    };
    let mut value = evaluate(rows, cross, &tau0, out, tau, law, &mut slopes);
    // A NaN change ends the loop too (`NaN > tolerance` is false).
    while iterations < max_iterations && change > tolerance {
        iterations += 1;
        let residual: Vec<f64> = out.dq.iter().zip(&value).map(|(d, v)| d - v).collect();
        let Some(step) = system(&slopes, rows, cross)
            .lu()
            .solve(&nalgebra::DVector::from_vec(residual.clone()))
        else {
            return failed(iterations, f64::INFINITY, false);
        };
        // Backtracking: a step of a non-linear law that does not reduce
        // the residual is halved (down to a millionth).
        let start = out.dq.clone();
        let before = residual.iter().fold(0.0, |a: f64, r| a.max(r.abs()));
        let mut scale = 1.0;
        loop {
            for ((d, s0), st) in out.dq.iter_mut().zip(&start).zip(step.iter()) {
                *d = s0 - scale * st;
            }
            value = evaluate(rows, cross, &tau0, out, tau, law, &mut slopes);
            let after = largest_difference(&out.dq, &value);
            if law.is_linear() || after <= before || scale < 1e-6 {
                break;
            }
            scale *= 0.5;
        }
        change = scale * step.amax();
    }
    if change > tolerance || change.is_nan() {
        return failed(iterations, change, false);
    }
    out.dq = evaluate(rows, cross, &tau0, out, tau, law, &mut slopes);
    let a = system(&slopes, rows, cross);
    if law.is_linear() && !stable(&slopes, rows.k, (!cross.is_empty()).then_some(&a)) {
        return failed(iterations, change, true);
    }
    out.lu_transposed = Some(a.transpose().lu());
    Ok(())
}

/// Whether the springs of slopes `f'` are stiffer than the gravity
/// stiffness `K`: `I - D^1/2 K_sym D^1/2` positive definite, with `D` the
/// non-negative slopes (the potential's Hessian `C^-1 - K` scaled by
/// `C^1/2`); with coupling entries, also every eigenvalue of the system
/// `a` with a positive real part (a small disturbance of the deflection
/// decays).
fn stable(slopes: &[f64], kmat: &DMatrix<f64>, a: Option<&DMatrix<f64>>) -> bool {
    let root: Vec<f64> = slopes.iter().map(|s| s.max(0.0).sqrt()).collect();
    let na = slopes.len();
    let hessian = DMatrix::from_fn(na, na, |i, d| {
        f64::from(u8::from(i == d)) - root[i] * root[d] * 0.5 * (kmat[(i, d)] + kmat[(d, i)])
    });
    hessian.cholesky().is_some() && a.is_none_or(decays)
}

/// Whether every eigenvalue of `a` has a positive real part (real Schur
/// form, at most [`SCHUR_SWEEPS`] sweeps per row; a form that does not
/// converge leaves the decision to the springs' own check).
fn decays(a: &DMatrix<f64>) -> bool {
    nalgebra::linalg::Schur::try_new(a.clone(), f64::EPSILON, SCHUR_SWEEPS * a.nrows())
        .is_none_or(|schur| schur.complex_eigenvalues().iter().all(|e| e.re > 0.0))
}

/// Sweeps per row of the real Schur form of [`decays`] (a few per
/// eigenvalue converge; nalgebra's default has no cap).
const SCHUR_SWEEPS: usize = 30;

/// `f(tau0 + K dq) + X (T + S dq)` at `out.dq`: writes the torques into
/// `tau`, `K dq` into `out.torque_change` and each spring's `f'` into
/// `slopes`.
fn evaluate(
    rows: &Rows<'_>,
    cross: &[CrossTerm],
    tau0: &[f64],
    out: &mut PoseEquilibrium,
    tau: &mut [f64],
    law: &mut dyn SpringLaw,
    slopes: &mut [f64],
) -> Vec<f64> {
    let na = tau0.len();
    let mut value: Vec<f64> = (0..na)
        .map(|i| {
            let kdq: f64 = (0..na).map(|d| rows.k[(i, d)] * out.dq[d]).sum();
            tau[i] = tau0[i] + kdq;
            out.torque_change[i] = kdq;
            let (dq, slope) = law.deflect(i, tau[i]);
            slopes[i] = slope;
            dq
        })
        .collect();
    for term in cross {
        value[term.drive] += term.compliance * (term.torque + rows.times(term.other, &out.dq));
    }
    value
}

/// `A = I - diag(f') K - X S`.
fn system(slopes: &[f64], rows: &Rows<'_>, cross: &[CrossTerm]) -> DMatrix<f64> {
    let na = slopes.len();
    let mut a = DMatrix::from_fn(na, na, |i, d| {
        f64::from(u8::from(i == d)) - slopes[i] * rows.k[(i, d)]
    });
    for term in cross {
        for d in 0..na {
            a[(term.drive, d)] -= term.compliance * rows.entry(term.other, d);
        }
    }
    a
}
/// The largest `|a_i - b_i|`.
fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The one step's torque change at pose `k`: `K dq` for the one step's
/// deflection `dq` and the payload unknowns `payload` (N.m or N).
pub(crate) fn one_step_torque_change(
    stiffness: &GravityStiffness,
    k: usize,
    payload: &[f64],
    dq: &[f64],
) -> Vec<f64> {
    let na = stiffness.na;
    let mut kmat = DMatrix::zeros(na, na);
    stiffness.joint_stiffness(k, payload, &mut kmat);
    (0..na)
        .map(|i| (0..na).map(|d| kmat[(i, d)] * dq[d]).sum())
        .collect()
}

/// The lateral springs' moment changes `L_s dq` and their payload parts.
fn hinge_changes(stiffness: &GravityStiffness, k: usize, out: &mut PoseEquilibrium) {
    let (na, np, nh) = (stiffness.na, stiffness.n_payload, stiffness.n_hinges);
    out.moment_change.resize(nh, 0.0);
    out.payload_moment_change.resize(nh * np, 0.0);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    for s in 0..nh {
        for l in 0..np {
            out.payload_moment_change[s * np + l] = dot(stiffness.hinge_row(k, s, 1 + l), &out.dq);
        }
        out.moment_change[s] = dot(&out.hinge_stiffness[s * na..(s + 1) * na], &out.dq);
    }
}

/// The predictions of one calibration with the one step and with the
/// equilibrium, and the one step's torque changes
/// ([`crate::ErrorModel`]'s comparison at the identified unknowns).
pub(crate) struct DeflectionComparison {
    /// Predicted poses with the one step, one per observation.
    pub one_step: Vec<nalgebra::Isometry3<f64>>,
    /// Predicted poses with the equilibrium.
    pub equilibrium: Vec<nalgebra::Isometry3<f64>>,
    /// Per actuated coordinate, the largest `|K dq|` of the one step over
    /// the poses (N.m or N).
    pub torque_change: Vec<f64>,
    /// Per actuated coordinate, the span of its gravity torque over the
    /// poses (N.m or N).
    pub torque_span: Vec<f64>,
}

impl DeflectionComparison {
    /// The coordinate whose torque changes most relative to its span: its
    /// index, the change and the share. A span is taken as at least
    /// [`SPAN_FLOOR`] of the largest one: a joint that carries (almost)
    /// nothing, a wrist under weightless markers, has a span of rounding
    /// errors, and its compliance no influence to bias.
    pub(crate) fn largest(&self) -> (usize, f64, f64) {
        let floor = SPAN_FLOOR * self.torque_span.iter().fold(0.0, |a: f64, s| a.max(*s));
        self.torque_change
            .iter()
            .zip(&self.torque_span)
            .enumerate()
            .map(|(i, (&change, &span))| {
                let span = span.max(floor);
                let share = if span > 0.0 { change / span } else { 0.0 };
                (i, change, share)
            })
            .fold(
                (0, 0.0, 0.0),
                |best, this| {
                    if this.2 > best.2 { this } else { best }
                },
            )
    }

    /// The report of a calibration that used `used` for `choice`.
    pub(crate) fn report(
        &self,
        actuated_names: &[String],
        used: Deflection,
        choice: DeflectionChoice,
        auto: Option<(f64, f64)>,
    ) -> DeflectionReport {
        let (joint, change, share) = self.largest();
        let distances: Vec<f64> = self
            .one_step
            .iter()
            .zip(&self.equilibrium)
            .map(|(a, b)| (a.translation.vector - b.translation.vector).norm())
            .collect();
        let n = distances.len().max(1) as f64;
        DeflectionReport {
            used: used.name().to_string(),
            choice,
            auto_share: auto.map(|a| a.0),
            auto_measured_share: auto.map(|a| a.1),
            largest_torque_change_joint: actuated_names.get(joint).cloned().unwrap_or_default(),
            largest_torque_change_nm: change,
            largest_torque_change_share: share,
            position_difference_rms_mm: (distances.iter().map(|d| d * d).sum::<f64>() / n).sqrt()
                * 1e3,
            position_difference_max_mm: distances.iter().fold(0.0, |a: f64, d| a.max(*d)) * 1e3,
        }
    }
}
