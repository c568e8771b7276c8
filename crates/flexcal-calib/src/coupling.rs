//! The compliance of a coupling mechanism: a symmetric matrix over a group
//! of coupled joints.
//!
//! A passive joint coupled to drives (a description's `coupled_to`, e.g.
//! a torso's `T4 = -(T2 + T3)` kept level by a parallelogram) is held by a
//! mechanism (belts, rods, a parallelogram) that carries its load back
//! into those drives. The mechanism's own elasticity then couples the
//! deflections: a torque on the passive joint turns the drives a little,
//! and a drive's torque turns the passive joint beyond what the coupling
//! ratio says. The group's compliance is a symmetric matrix over its
//! joints (the passive joint `p` and the drives `a, b, ..` of the group):
//!
//! `[dq_a; dq_b; delta_p] = C [tau_a; tau_b; M_p]`, `C = C^T`, `C >= 0`
//! (positive semi-definite),
//!
//! where the torque of each joint is the one the elastic model already
//! loads it with ([`crate::gravity`], equations in its module docs):
//! - a drive's `tau_a` is its generalised gravity force (virtual work,
//!   N.m), which includes the passive joint's moment carried back through
//!   the coupling ratio; its deflection `dq_a` (rad) is added to its
//!   actuated coordinate, and so turns the passive joint too, by the ratio;
//! - the passive joint's `M_p` is the gravity moment (N.m) about its own z
//!   axis, through its spring's pivot, of every weight it carries; its
//!   deflection `delta_p` (rad) turns the structure beyond it about that
//!   axis, as its `[[spring]]` about `z` does.
//!
//! The diagonal of `C` is what the model already has: the drives'
//! compliances `compliance_<joint>` and the passive joint's spring
//! `lateral_compliance_<p>_z` (so a group needs that spring). The mass
//! table's `[[coupling_compliance]]` entry adds the off-diagonal entries as
//! unknowns `coupling_compliance_<A>_<B>` (rad/N.m, frame names in the
//! entry's order), starting at zero:
//!
//! `dq_a += c_ab tau_b + c_ap M_p`, `delta_p += c_ap tau_a + c_bp tau_b`.
//!
//! The entries are linear in the torques (a joint law's hardening applies
//! to the diagonal only), the torques are evaluated as the diagonal's are
//! (nominal geometry, commanded configuration), and every derivative is
//! exact: by `c_ab`, `tau_b` times the point's joint column of `a` plus
//! `tau_a` times that of `b` (the passive joint's: its rotation's twist);
//! by the payload unknowns, the entries times the torques' derivatives.
//!
//! ## The positive semi-definite bound
//! A coupling cannot create energy: `C` is positive semi-definite. After
//! each fit, a group whose matrix is not is brought back to the boundary
//! by scaling its free off-diagonal entries towards zero by the largest
//! common factor `s` in `[0, 1]` that makes `D + s O` positive
//! semi-definite (`D` the diagonal, `O` the off-diagonal part); those
//! entries are held there (status at-bound, [`crate::ScaleOutcome::AtBound`])
//! and the rest fitted again. The report says which entries are held.
//!
//! Limitations: a group has one passive joint and drives it is directly
//! coupled to; a drive of two groups is allowed but the two groups' matrices
//! are judged apart; the bound is an active set without Lagrange
//! multipliers (an entry held is not released again).

use flexcal_kinematics::Model;
use nalgebra::{DMatrix, SymmetricEigen};
use serde::Serialize;

use crate::error::CalibError;
use crate::gravity::{CouplingGroup, FrameAxis, GravityCompliance, lateral_joints};
use crate::significance::{Judged, Solve, hold_at_bounds};
use crate::unknowns::{UnknownEstimate, UnknownStatus};

/// A joint of a group in the elastic model: a drive (its actuated
/// coordinate) or the passive joint (its spring's hinge among the lateral
/// terms).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Member {
    Drive(usize),
    Passive(usize),
}

/// The groups' joints resolved on a robot: for each off-diagonal unknown,
/// in the order of the elastic unknowns' names, its two joints.
#[derive(Debug, Clone, Default)]
pub(crate) struct CouplingTerms {
    pub pairs: Vec<[Member; 2]>,
}

/// A group resolved on a robot: its joints as [`Member`]s in the entry's
/// order, and their frames.
struct Resolved {
    members: Vec<Member>,
}

fn resolve(
    model: &Model,
    gravity: &GravityCompliance,
    group: &CouplingGroup,
) -> Result<Resolved, CalibError> {
    let invalid = |reason: String| CalibError::InvalidOption {
        name: "coupling_compliance",
        reason: format!("group [{}]: {reason}", group.joints.join(", ")),
    };
    if let Some(defect) = group.defect() {
        return Err(invalid(defect));
    }
    let frames = group
        .joints
        .iter()
        .map(|j| {
            model.frame_index(j).ok_or_else(|| {
                invalid(format!(
                    "robot `{}` has no frame `{j}` (frames: {})",
                    model.name(),
                    model.frame_names().join(", ")
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let passive: Vec<usize> = (0..frames.len())
        .filter(|&k| model.coupled_to(frames[k]).is_some())
        .collect();
    let p = match passive.as_slice() {
        [p] => *p,
        [] => {
            return Err(invalid(
                "no passive joint: a group is one joint with `coupled_to` and drives it is coupled to"
                    .into(),
            ));
        }
        several => {
            return Err(invalid(format!(
                "{} passive joints ({}): give one group per passive joint",
                several.len(),
                several
                    .iter()
                    .map(|&k| group.joints[k].as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    };
    let sources = model.coupled_to(frames[p]).unwrap_or(&[]);
    let passive_name = &group.joints[p];
    let spring = gravity
        .springs
        .iter()
        .position(|s| s.frame == *passive_name && s.axis == FrameAxis::Z)
        .ok_or_else(|| {
            invalid(format!(
                "the passive joint `{passive_name}` needs its own spring, the matrix's diagonal entry: add [[spring]] frame = \"{passive_name}\" axes = [\"z\"]"
            ))
        })?;
    let hinge = match gravity.lateral {
        crate::gravity::LateralCompliance::Off => 0,
        crate::gravity::LateralCompliance::AboutX => lateral_joints(model).len(),
    } + spring;
    let mut members = Vec::with_capacity(frames.len());
    for (k, &f) in frames.iter().enumerate() {
        if k == p {
            members.push(Member::Passive(hinge));
            continue;
        }
        let drive = (0..model.n_actuated()).find(|&i| model.actuated_frame(i) == Some(f));
        match drive.filter(|_| sources.iter().any(|(s, _)| *s == f)) {
            Some(i) => members.push(Member::Drive(i)),
            None => {
                let coupled: Vec<&str> = sources
                    .iter()
                    .map(|(s, _)| model.frame_names()[*s].as_str())
                    .collect();
                return Err(invalid(format!(
                    "joint `{}` is not a drive `{passive_name}` is coupled to (it is coupled to {})",
                    group.joints[k],
                    coupled.join(", ")
                )));
            }
        }
    }
    Ok(Resolved { members })
}

impl CouplingTerms {
    /// The groups of `gravity` resolved on `model`.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] (`coupling_compliance`) naming the
    /// group and what is wrong: a frame the robot does not have, a joint
    /// listed twice or in two groups, no passive joint or several, a
    /// joint the passive one is not coupled to, a passive joint without
    /// its own spring about z.
    pub(crate) fn new(model: &Model, gravity: &GravityCompliance) -> Result<Self, CalibError> {
        let mut pairs = Vec::new();
        let mut seen: Vec<String> = Vec::new();
        for group in &gravity.coupling {
            let resolved = resolve(model, gravity, group)?;
            for name in group.unknown_names() {
                if seen.contains(&name) {
                    return Err(CalibError::InvalidOption {
                        name: "coupling_compliance",
                        reason: format!("`{name}` is given by two groups"),
                    });
                }
                seen.push(name);
            }
            let m = &resolved.members;
            for a in 0..m.len() {
                for b in a + 1..m.len() {
                    pairs.push([m[a], m[b]]);
                }
            }
        }
        Ok(Self { pairs })
    }

    /// Number of off-diagonal unknowns.
    pub(crate) fn len(&self) -> usize {
        self.pairs.len()
    }
}

/// A group's matrix in the unknown vector: the index of each diagonal
/// unknown (in the entry's order of joints) and of each off-diagonal one
/// with its row and column.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MatrixIndices {
    pub joints: Vec<String>,
    pub diagonal: Vec<usize>,
    pub off_diagonal: Vec<(usize, usize, usize)>,
}

/// The diagonal unknowns' names of `group` on `model`:
/// `compliance_<actuated>` for a drive, `lateral_compliance_<p>_z` for the
/// passive joint (`None` for a frame that is neither).
fn diagonal_names(model: &Model, group: &CouplingGroup) -> Option<Vec<String>> {
    group
        .joints
        .iter()
        .map(|j| {
            let f = model.frame_index(j)?;
            if model.coupled_to(f).is_some() {
                return Some(format!("lateral_compliance_{j}_z"));
            }
            (0..model.n_actuated())
                .find(|&i| model.actuated_frame(i) == Some(f))
                .map(|i| format!("compliance_{}", model.actuated_names()[i]))
        })
        .collect()
}

/// Where each group of `gravity` sits among the unknowns `names` (groups
/// whose unknowns are not all there are left out).
pub(crate) fn matrix_indices(
    model: &Model,
    gravity: &GravityCompliance,
    names: &[String],
) -> Vec<MatrixIndices> {
    let index = |name: &str| names.iter().position(|n| n == name);
    gravity
        .coupling
        .iter()
        .filter_map(|group| {
            let diagonal = diagonal_names(model, group)?
                .iter()
                .map(|n| index(n))
                .collect::<Option<Vec<_>>>()?;
            let n = group.joints.len();
            let mut off_diagonal = Vec::new();
            let mut names_of_pairs = group.unknown_names().into_iter();
            for a in 0..n {
                for b in a + 1..n {
                    off_diagonal.push((a, b, index(&names_of_pairs.next()?)?));
                }
            }
            Some(MatrixIndices {
                joints: group.joints.clone(),
                diagonal,
                off_diagonal,
            })
        })
        .collect()
}

/// The matrix `D + s O` of a group from the unknowns `x`.
fn matrix(indices: &MatrixIndices, x: &[f64], s: f64) -> DMatrix<f64> {
    let n = indices.diagonal.len();
    let mut c = DMatrix::zeros(n, n);
    for (k, &d) in indices.diagonal.iter().enumerate() {
        c[(k, k)] = x[d];
    }
    for &(a, b, j) in &indices.off_diagonal {
        c[(a, b)] = s * x[j];
        c[(b, a)] = s * x[j];
    }
    c
}

/// The smallest eigenvalue of a symmetric matrix.
fn smallest_eigenvalue(c: DMatrix<f64>) -> f64 {
    SymmetricEigen::new(c).eigenvalues.min()
}

/// Tolerance on the smallest eigenvalue (rad/N.m): a matrix above `-tol`
/// is positive semi-definite (round-off of compliances near 1e-4).
fn tolerance(c: &DMatrix<f64>) -> f64 {
    1e-9 * c.diagonal().iter().fold(1e-12_f64, |m, v| m.max(v.abs()))
}

/// The largest `s` in `[0, 1]` for which `D + s O` is positive
/// semi-definite (bisection; 0 when the diagonal itself is not).
pub(crate) fn psd_scale(indices: &MatrixIndices, x: &[f64]) -> f64 {
    let full = matrix(indices, x, 1.0);
    let tol = tolerance(&full);
    if smallest_eigenvalue(full) >= -tol {
        return 1.0;
    }
    if smallest_eigenvalue(matrix(indices, x, 0.0)) < -tol {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if smallest_eigenvalue(matrix(indices, x, mid)) >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Holds each group whose fitted matrix is not positive semi-definite at
/// the boundary (module docs): its free off-diagonal entries scaled by
/// [`psd_scale`] and frozen there, status at-bound, the rest fitted again
/// (at most three passes: the diagonal moves in the refit).
pub(crate) fn hold_positive_semidefinite(
    groups: &[MatrixIndices],
    judged: Judged,
    solve: &mut Solve<'_>,
) -> Result<Judged, CalibError> {
    hold_at_bounds(judged, solve, &|report, frozen| {
        let mut held = Vec::new();
        for group in groups {
            let s = psd_scale(group, &report.x);
            if s < 1.0 {
                held.extend(
                    group
                        .off_diagonal
                        .iter()
                        .filter(|e| !frozen[e.2])
                        .map(|e| (e.2, s * report.x[e.2])),
                );
            }
        }
        held
    })
}

/// A coupling group's identified compliance matrix (module docs), for
/// reports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CouplingMatrix {
    /// The group's joints (frame names), the rows and columns in order.
    pub joints: Vec<String>,
    /// The matrix `C` (rad/N.m), row by row: the diagonal entries are the
    /// joints' own compliances, the others `coupling_compliance_*`.
    pub compliance: Vec<Vec<f64>>,
    /// The standard error of each entry (rad/N.m; `None` for an entry not
    /// identified: fixed, left out or held).
    pub standard_error: Vec<Vec<Option<f64>>>,
    /// The smallest eigenvalue of `C` (rad/N.m): `>= 0` up to round-off.
    pub smallest_eigenvalue: f64,
    /// The off-diagonal entries held at the positive semi-definite
    /// boundary (their names; empty when the bound is not active).
    pub held_at_bound: Vec<String>,
}

impl CouplingMatrix {
    /// The matrices of `gravity`'s groups on `model` from the estimates
    /// `unknowns` (groups whose unknowns are missing are left out).
    pub fn of_estimates(
        model: &Model,
        gravity: &GravityCompliance,
        unknowns: &[UnknownEstimate],
    ) -> Vec<Self> {
        let names: Vec<String> = unknowns.iter().map(|u| u.name.clone()).collect();
        let x: Vec<f64> = unknowns.iter().map(|u| u.value).collect();
        matrix_indices(model, gravity, &names)
            .into_iter()
            .map(|indices| {
                let n = indices.diagonal.len();
                let c = matrix(&indices, &x, 1.0);
                let se_of = |j: usize| {
                    let u = &unknowns[j];
                    (u.status == UnknownStatus::Identified)
                        .then_some(u.standard_error)
                        .flatten()
                };
                let mut standard_error = vec![vec![None; n]; n];
                for (k, &d) in indices.diagonal.iter().enumerate() {
                    standard_error[k][k] = se_of(d);
                }
                for &(a, b, j) in &indices.off_diagonal {
                    standard_error[a][b] = se_of(j);
                    standard_error[b][a] = se_of(j);
                }
                Self {
                    joints: indices.joints.clone(),
                    compliance: c.row_iter().map(|r| r.iter().copied().collect()).collect(),
                    standard_error,
                    smallest_eigenvalue: smallest_eigenvalue(c),
                    held_at_bound: indices
                        .off_diagonal
                        .iter()
                        .filter(|e| unknowns[e.2].status == UnknownStatus::AtBound)
                        .map(|e| names[e.2].clone())
                        .collect(),
                }
            })
            .collect()
    }

    /// The matrix as text lines (urad/N.m, each entry with its standard
    /// error, or "not identified" for one fixed, left out or held).
    pub fn lines(&self) -> Vec<String> {
        let mut lines = vec![format!(
            "coupling compliance of [{}] (urad/N.m, +/- standard error; smallest eigenvalue {:.2}){}",
            self.joints.join(", "),
            self.smallest_eigenvalue * 1e6,
            if self.held_at_bound.is_empty() {
                String::new()
            } else {
                format!(
                    "; held at the positive semi-definite bound: {}",
                    self.held_at_bound.join(", ")
                )
            }
        )];
        for (k, (row, se)) in self.compliance.iter().zip(&self.standard_error).enumerate() {
            let cells: Vec<String> = row
                .iter()
                .zip(se)
                .map(|(v, s)| match s {
                    Some(s) => format!("{:9.2} +/- {:6.2}", v * 1e6, s * 1e6),
                    None => format!("{:9.2} (not identified)", v * 1e6),
                })
                .collect();
            lines.push(format!("  {:>6}: {}", self.joints[k], cells.join("  ")));
        }
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::significance::ScaleOutcome;

    fn indices() -> MatrixIndices {
        MatrixIndices {
            joints: ["a", "b", "p"].map(String::from).to_vec(),
            diagonal: vec![0, 1, 2],
            off_diagonal: vec![(0, 1, 3), (0, 2, 4), (1, 2, 5)],
        }
    }

    #[test]
    fn the_scale_puts_an_indefinite_matrix_on_the_boundary() {
        // Diagonal 100, 150, 140 urad/N.m; cross terms too large.
        let x = [100e-6, 150e-6, 140e-6, 90e-6, -130e-6, 20e-6];
        let s = psd_scale(&indices(), &x);
        assert!(s > 0.0 && s < 1.0, "{s}");
        let at = SymmetricEigen::new(matrix(&indices(), &x, s))
            .eigenvalues
            .min();
        assert!(at.abs() < 1e-12, "{at}");
        // Slightly beyond the boundary it is indefinite.
        let beyond = SymmetricEigen::new(matrix(&indices(), &x, s + 1e-6))
            .eigenvalues
            .min();
        assert!(beyond < 0.0);
        // A definite matrix keeps its entries; a negative diagonal drops
        // them all.
        let fine = [100e-6, 150e-6, 140e-6, 10e-6, -20e-6, 5e-6];
        assert_eq!(psd_scale(&indices(), &fine), 1.0);
        let negative = [-1e-6, 150e-6, 140e-6, 10e-6, -20e-6, 5e-6];
        assert_eq!(psd_scale(&indices(), &negative), 0.0);
    }

    #[test]
    fn an_indefinite_group_is_held_on_the_boundary_and_fitted_again() {
        // Cross terms too large for the diagonal; the refit leaves the
        // held entries where they were put.
        let x = vec![100e-6, 150e-6, 140e-6, 90e-6, -130e-6, 20e-6];
        let s = psd_scale(&indices(), &x);
        let mut calls = Vec::new();
        let mut solve = |x0: &[f64], frozen: &[bool]| {
            calls.push(frozen.to_vec());
            Ok(crate::significance::report(x0.to_vec()))
        };
        let first = crate::significance::report(x.clone());
        let (last, frozen, judgements) = hold_positive_semidefinite(
            &[indices()],
            (first, vec![false; 6], vec![None; 6]),
            &mut solve,
        )
        .unwrap();
        assert_eq!(calls.len(), 1);
        assert_eq!(frozen, [false, false, false, true, true, true]);
        for j in 3..6 {
            assert!((last.x[j] - s * x[j]).abs() < 1e-18);
            let judged = judgements[j].unwrap();
            assert_eq!(judged.outcome, ScaleOutcome::AtBound);
            assert_eq!(judged.value, x[j]);
        }
        assert!(smallest_eigenvalue(matrix(&indices(), &last.x, 1.0)) > -1e-12);
        // A definite group: nothing held, no refit.
        let fine = crate::significance::report(vec![100e-6, 150e-6, 140e-6, 10e-6, -20e-6, 5e-6]);
        let mut never = |_: &[f64], _: &[bool]| -> Result<flexcal_optim::SolveReport, CalibError> {
            panic!("nothing to hold")
        };
        let (_, frozen, _) = hold_positive_semidefinite(
            &[indices()],
            (fine, vec![false; 6], vec![None; 6]),
            &mut never,
        )
        .unwrap();
        assert!(frozen.iter().all(|f| !f));
    }

    #[test]
    fn entries_are_named_per_pair_and_defects_found() {
        let group = CouplingGroup {
            joints: ["T2", "T3", "T4"].map(String::from).to_vec(),
        };
        assert_eq!(
            group.unknown_names(),
            [
                "coupling_compliance_T2_T3",
                "coupling_compliance_T2_T4",
                "coupling_compliance_T3_T4"
            ]
        );
        assert!(group.defect().is_none());
        let twice = CouplingGroup {
            joints: ["T2", "T4", "T2"].map(String::from).to_vec(),
        };
        assert!(twice.defect().unwrap().contains("`T2` is listed twice"));
        let alone = CouplingGroup {
            joints: vec!["T4".into()],
        };
        assert!(alone.defect().is_some());
    }
}
