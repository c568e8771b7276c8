//! The terms of the elasto-geometric model beyond geometry, shared by the
//! measurement model ([`crate::ErrorModel`]) of one target and of several
//! alike: joint springs under gravity
//! ([`crate::gravity`]), the payload, the lateral compliances, the joint
//! law and the cyclic joint errors ([`crate::joint_law`]).
//!
//! Their unknowns form one block `x_b`, in this order: the compliances
//! (`n_actuated`), the payloads (4 per identified payload), the lateral
//! compliances, the coupling groups' off-diagonal compliances
//! ([`crate::coupling`]), then the
//! law's hardening and lost motion (`n_actuated` each) and the cyclic
//! amplitudes (4 per cyclic joint). A model puts the block after its
//! frames; the offsets here are relative to the block's start.

use flexcal_kinematics::Model;
use nalgebra::{Matrix6xX, UnitQuaternion, Vector3, Vector6};

use crate::coupling::{CouplingTerms, Member};
use crate::equilibrium::{CrossTerm, GravityStiffness, NotConverged, PoseEquilibrium, SpringLaw};
use crate::error::CalibError;
use crate::geometry::{left_jacobian, rotation_from_vector};
use crate::gravity::{Configurations, GravityCompliance, GravityTerms, LateralTerms};
use crate::joint_law::{JointLaw, JointTerms, cyclic_basis, cyclic_joints, joint_deflection};
use crate::unknown_kind::UnknownKind;

/// The actuated coordinates at which the robot is evaluated for one pose,
/// and what their derivatives by the elastic and joint unknowns need.
#[derive(Debug, Clone)]
pub(crate) struct JointState {
    /// `q + dq` (rad or m).
    pub q: Vec<f64>,
    /// Generalised gravity forces (N.m or N).
    tau: Vec<f64>,
    /// `d dq_i / d tau_i`.
    by_torque: Vec<f64>,
    /// `d dq_i / d c_i`.
    by_compliance: Vec<f64>,
    /// `d dq_i / d eta_i`.
    by_hardening: Vec<f64>,
    /// `d dq_i / d beta_i`.
    by_lost_motion: Vec<f64>,
    /// The equilibrium's terms ([`crate::equilibrium`]), when the model
    /// solves it.
    equilibrium: Option<PoseEquilibrium>,
}

impl JointState {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            q: vec![0.0; n],
            tau: vec![0.0; n],
            by_torque: vec![0.0; n],
            by_compliance: vec![0.0; n],
            by_hardening: vec![0.0; n],
            by_lost_motion: vec![0.0; n],
            equilibrium: None,
        }
    }

    /// The joint springs (with `law` at its offset, or linear), recording
    /// their derivatives in this state, and beside them the state's
    /// configuration, torques and equilibrium terms.
    #[allow(clippy::type_complexity)]
    fn springs<'a>(
        &'a mut self,
        xb: &'a [f64],
        law: Option<(&'a JointLaw, usize)>,
    ) -> (
        Springs<'a>,
        &'a mut Vec<f64>,
        &'a mut Vec<f64>,
        &'a mut Option<PoseEquilibrium>,
    ) {
        let JointState {
            q,
            tau,
            by_torque,
            by_compliance,
            by_hardening,
            by_lost_motion,
            equilibrium,
        } = self;
        let springs = Springs {
            xb,
            law,
            by_torque,
            by_compliance,
            by_hardening,
            by_lost_motion,
        };
        (springs, q, tau, equilibrium)
    }
}

/// The joint springs of [`ElasticTerms::deflect`] at one pose: linear, or
/// the law of [`crate::joint_law`]; they record their derivatives in the
/// pose's state.
struct Springs<'a> {
    xb: &'a [f64],
    law: Option<(&'a JointLaw, usize)>,
    by_torque: &'a mut [f64],
    by_compliance: &'a mut [f64],
    by_hardening: &'a mut [f64],
    by_lost_motion: &'a mut [f64],
}

impl SpringLaw for Springs<'_> {
    fn deflect(&mut self, i: usize, torque: f64) -> (f64, f64) {
        let na = self.by_torque.len();
        let (dq, slope) = match self.law {
            Some((law, lo)) => {
                let d = joint_deflection(
                    torque,
                    self.xb[i],
                    self.xb[lo + i],
                    self.xb[lo + na + i],
                    law.lost_motion_torque,
                );
                self.by_compliance[i] = d.by_compliance;
                self.by_hardening[i] = d.by_hardening;
                self.by_lost_motion[i] = d.by_lost_motion;
                (d.deflection, d.by_torque)
            }
            None => {
                self.by_compliance[i] = torque;
                (self.xb[i] * torque, self.xb[i])
            }
        };
        self.by_torque[i] = slope;
        (dq, slope)
    }

    fn is_linear(&self) -> bool {
        self.law.is_none()
    }
}

/// The rigid motion `G` of the lateral rotations at one pose: its rotation,
/// its translation (m) and its rotation vector `phi` (rad), with each
/// lateral joint's rotation `delta_j` (rad) and moment `Mx_j` (N.m), both
/// zero for a joint that does not move the point.
pub(crate) struct LateralMotion {
    pub rotation: UnitQuaternion<f64>,
    pub translation: Vector3<f64>,
    phi: Vector3<f64>,
    deltas: Vec<(f64, f64)>,
}

impl LateralMotion {
    /// `G p` for a point `p` of the base frame (m).
    pub(crate) fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p + self.translation
    }
}

/// The elastic and joint terms of a model over a set of poses (see the
/// module docs); empty for the geometric model.
pub(crate) struct ElasticTerms {
    na: usize,
    /// Number of payload unknowns (4 per identified payload).
    n_payload: usize,
    gravity: Option<(GravityTerms, Vec<f64>)>,
    lateral: Option<LateralTerms>,
    /// The coupling groups' off-diagonal compliances (none by default).
    coupling: CouplingTerms,
    /// The gravity stiffness and the iteration's tolerance and cap, when
    /// the deflection is the equilibrium ([`crate::equilibrium`]).
    stiffness: Option<(GravityStiffness, (f64, usize))>,
    joint_terms: JointTerms,
    cyclic_joints: Vec<usize>,
    /// [`cyclic_basis`] of each cyclic joint at each pose (pose-major): the
    /// measured angles do not change between evaluations.
    cyclic_bases: Vec<[f64; 4]>,
}

impl ElasticTerms {
    /// No terms: the geometric model of `model`.
    pub(crate) fn none(model: &Model) -> Self {
        Self {
            na: model.n_actuated(),
            n_payload: 0,
            gravity: None,
            lateral: None,
            coupling: CouplingTerms::default(),
            stiffness: None,
            joint_terms: JointTerms::default(),
            cyclic_joints: Vec::new(),
            cyclic_bases: Vec::new(),
        }
    }

    /// Adds the joint springs under `gravity` (and the lateral compliances
    /// when it has them) over `poses`.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] after the joint terms, for a mass on a
    /// missing frame or non-finite values; [`CalibError::Kinematics`]
    /// naming a pose.
    pub(crate) fn add_gravity(
        &mut self,
        model: &Model,
        poses: &Configurations<'_>,
        gravity: &GravityCompliance,
    ) -> Result<(), CalibError> {
        if self.joint_terms.any() {
            return Err(CalibError::InvalidOption {
                name: "joint_terms",
                reason: "the gravity model goes before the joint terms".into(),
            });
        }
        let terms = GravityTerms::new(model, poses, gravity)?;
        self.n_payload = terms.n_payload();
        self.gravity = Some((terms, gravity.initial_unknowns(model)));
        let lateral = LateralTerms::new(model, poses, gravity)?;
        self.lateral = (lateral.len() > 0).then_some(lateral);
        self.coupling = CouplingTerms::new(model, gravity)?;
        self.stiffness = match gravity.deflection.iteration() {
            Some(iteration) => Some((GravityStiffness::new(model, poses, gravity)?, iteration)),
            None => None,
        };
        Ok(())
    }

    /// Adds the joint terms of [`crate::joint_law`] over `poses`.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for the stiffness law without the
    /// gravity model, or a lost-motion torque that is not `> 0`.
    pub(crate) fn add_joint_terms(
        &mut self,
        model: &Model,
        poses: &Configurations<'_>,
        terms: &JointTerms,
    ) -> Result<(), CalibError> {
        if let Some(law) = &terms.law {
            if self.gravity.is_none() {
                return Err(CalibError::InvalidOption {
                    name: "joint_law",
                    reason: "the non-linear joint stiffness law needs the elasto-geometric model (gravity loading)".into(),
                });
            }
            if !(law.lost_motion_torque.is_finite() && law.lost_motion_torque > 0.0) {
                return Err(CalibError::InvalidOption {
                    name: "lost_motion_torque",
                    reason: format!("must be finite and > 0, found {}", law.lost_motion_torque),
                });
            }
        }
        self.joint_terms = *terms;
        self.cyclic_joints = if terms.cyclic {
            cyclic_joints(model)
        } else {
            Vec::new()
        };
        self.cyclic_bases = poses
            .q
            .iter()
            .flat_map(|q| self.cyclic_joints.iter().map(|&i| cyclic_basis(q[i])))
            .collect();
        Ok(())
    }

    /// Whether the model has the joint springs under gravity.
    pub(crate) fn has_gravity(&self) -> bool {
        self.gravity.is_some()
    }

    /// Unknowns of the elastic part: compliances, payloads, lateral and
    /// coupling compliances (none when geometric).
    fn n_elastic(&self) -> usize {
        match &self.gravity {
            Some(_) => {
                self.na
                    + self.n_payload
                    + self.lateral.as_ref().map_or(0, LateralTerms::len)
                    + self.coupling.len()
            }
            None => 0,
        }
    }

    /// Number of unknowns of the block.
    pub(crate) fn len(&self) -> usize {
        self.n_elastic()
            + if self.joint_terms.law.is_some() {
                2 * self.na
            } else {
                0
            }
            + 4 * self.cyclic_joints.len()
    }

    /// The kind of each unknown of the block.
    pub(crate) fn kinds(&self) -> Vec<UnknownKind> {
        let mut kinds = Vec::with_capacity(self.len());
        if self.gravity.is_some() {
            kinds.extend(std::iter::repeat_n(UnknownKind::Compliance, self.na));
            for _ in 0..self.n_payload / 4 {
                kinds.push(UnknownKind::Mass);
                kinds.extend([UnknownKind::FirstMoment; 3]);
            }
            kinds.extend(std::iter::repeat_n(
                UnknownKind::Compliance,
                self.lateral.as_ref().map_or(0, LateralTerms::len) + self.coupling.len(),
            ));
        }
        if self.joint_terms.law.is_some() {
            kinds.extend(std::iter::repeat_n(UnknownKind::Hardening, self.na));
            kinds.extend(std::iter::repeat_n(UnknownKind::Angle, self.na));
        }
        kinds.extend(std::iter::repeat_n(
            UnknownKind::Angle,
            4 * self.cyclic_joints.len(),
        ));
        kinds
    }

    /// Starting values of the block: the loading's starting compliances and
    /// payload, zero for the rest (linear springs, no cyclic error).
    pub(crate) fn initial(&self) -> Vec<f64> {
        let mut x = match &self.gravity {
            Some((_, initial)) => initial.clone(),
            None => Vec::new(),
        };
        x.resize(self.len(), 0.0);
        x
    }

    /// Offset of the first lateral compliance in the block.
    pub(crate) fn lateral_offset(&self) -> Option<usize> {
        self.lateral.as_ref().map(|_| self.na + self.n_payload)
    }

    /// Offset of the first coupling compliance in the block (`None`
    /// without coupling groups).
    fn coupling_offset(&self) -> Option<usize> {
        (self.coupling.len() > 0)
            .then(|| self.na + self.n_payload + self.lateral.as_ref().map_or(0, LateralTerms::len))
    }

    /// The gravity torque (N.m) of a coupling group's joint at pose `k`
    /// for the payload unknowns `payload`: a drive's generalised force, the
    /// passive joint's moment about its spring's axis ([`crate::coupling`]).
    fn member_torque(&self, k: usize, member: Member, payload: &[f64]) -> f64 {
        match (member, &self.gravity, &self.lateral) {
            (Member::Drive(i), Some((terms, _)), _) => terms.force(k, i, payload),
            (Member::Passive(s), _, Some(lateral)) => lateral.joint(k, s).moment(payload),
            _ => 0.0,
        }
    }

    /// [`ElasticTerms::member_torque`] on the deflected robot: plus its
    /// change through the deflection (`K dq` or `L_s dq`) when `state`
    /// holds the equilibrium.
    fn member_torque_at(
        &self,
        k: usize,
        member: Member,
        payload: &[f64],
        equilibrium: Option<&PoseEquilibrium>,
    ) -> f64 {
        self.member_torque(k, member, payload)
            + equilibrium.map_or(0.0, |e| match member {
                Member::Drive(i) => e.torque_change[i],
                Member::Passive(s) => e.moment_change[s],
            })
    }

    /// The derivative of [`ElasticTerms::member_torque_at`] by payload
    /// unknown `l` on the equilibrium `equilibrium`.
    fn member_payload_derivative(
        &self,
        k: usize,
        member: Member,
        l: usize,
        equilibrium: &PoseEquilibrium,
    ) -> f64 {
        let np = self.n_payload;
        self.member_torque_derivatives(k, member)[l]
            + match member {
                Member::Drive(i) => equilibrium.payload_torque_change[l * self.na + i],
                Member::Passive(s) => equilibrium.payload_moment_change[s * np + l],
            }
    }

    /// The derivatives of [`ElasticTerms::member_torque`] by the payload
    /// unknowns.
    fn member_torque_derivatives(&self, k: usize, member: Member) -> &[f64] {
        match (member, &self.gravity, &self.lateral) {
            (Member::Drive(i), Some((terms, _)), _) => terms.payload_derivatives(k, i),
            (Member::Passive(s), _, Some(lateral)) => lateral.joint(k, s).payload_derivatives,
            _ => &[],
        }
    }

    /// Each coupling compliance with its two joints, the joint first whose
    /// deflection it adds to and the joint whose torque it multiplies:
    /// `(unknown index in the block, own, other)`, both ways per entry.
    fn coupling_entries(&self) -> impl Iterator<Item = (usize, Member, Member)> + '_ {
        let co = self.coupling_offset().unwrap_or(0);
        self.coupling
            .pairs
            .iter()
            .enumerate()
            .flat_map(move |(e, &[a, b])| [(co + e, a, b), (co + e, b, a)])
    }

    /// Offset of the first joint-term unknown in the block.
    pub(crate) fn joint_terms_offset(&self) -> Option<usize> {
        self.joint_terms.any().then(|| self.n_elastic())
    }

    /// Offset of the law's first unknown (the hardening) in the block.
    fn law_offset(&self) -> Option<usize> {
        self.joint_terms.law.and_then(|_| self.joint_terms_offset())
    }

    /// Offset of the first cyclic amplitude in the block.
    fn cyclic_offset(&self) -> Option<usize> {
        self.joint_terms_offset().map(|o| {
            o + if self.joint_terms.law.is_some() {
                2 * self.na
            } else {
                0
            }
        })
    }

    /// Span of each actuated coordinate's gravity torque over the `n_poses`
    /// poses, with the starting payload (N.m or N); empty when geometric.
    pub(crate) fn torque_ranges(&self, n_poses: usize) -> Vec<crate::coverage::CoordinateCoverage> {
        let Some((terms, initial)) = &self.gravity else {
            return Vec::new();
        };
        let na = self.na;
        let payload = &initial[na..na + self.n_payload];
        let mut tau = vec![0.0; na];
        let mut ranges = vec![(f64::INFINITY, f64::NEG_INFINITY); na];
        for k in 0..n_poses {
            terms.forces(k, payload, &mut tau);
            for (r, t) in ranges.iter_mut().zip(&tau) {
                *r = (r.0.min(*t), r.1.max(*t));
            }
        }
        ranges
            .into_iter()
            .map(|(lo, hi)| crate::coverage::CoordinateCoverage {
                lo,
                hi,
                period: None,
            })
            .collect()
    }

    /// The actuated coordinates at which the robot is evaluated for pose
    /// `k` measured at `q`: `q`, plus the gravity deflection (`c_i tau_i`,
    /// or the non-linear law of [`crate::joint_law`]) when elasto-geometric,
    /// plus the cyclic errors when on; with the derivatives the Jacobian
    /// needs. `xb` is the block of unknowns. With the equilibrium
    /// ([`crate::equilibrium`]) the torques are `tau + K dq`.
    ///
    /// # Errors
    /// [`NotConverged`] when the equilibrium iteration does not converge.
    pub(crate) fn deflect(
        &self,
        xb: &[f64],
        k: usize,
        q: &[f64],
        state: &mut JointState,
    ) -> Result<(), NotConverged> {
        state.q.copy_from_slice(q);
        let na = self.na;
        if let (Some((terms, _)), Some((stiffness, iteration))) = (&self.gravity, &self.stiffness) {
            let payload = &xb[na..na + self.n_payload];
            terms.forces(k, payload, &mut state.tau);
            let cross: Vec<CrossTerm> = self
                .coupling_entries()
                .filter_map(|(j, own, other)| match own {
                    Member::Drive(drive) => Some(CrossTerm {
                        drive,
                        compliance: xb[j],
                        other,
                        torque: self.member_torque(k, other, payload),
                    }),
                    Member::Passive(_) => None,
                })
                .collect();
            let law = self.joint_terms.law.as_ref().zip(self.law_offset());
            let (mut springs, q, tau, equilibrium) = state.springs(xb, law);
            let equilibrium = equilibrium.get_or_insert_with(|| PoseEquilibrium::new(na));
            crate::equilibrium::solve(
                stiffness,
                k,
                payload,
                *iteration,
                &cross,
                tau,
                &mut springs,
                equilibrium,
            )?;
            for (q, dq) in q.iter_mut().zip(&equilibrium.dq) {
                *q += dq;
            }
        } else if let Some((terms, _)) = &self.gravity {
            terms.forces(k, &xb[na..na + self.n_payload], &mut state.tau);
            match (&self.joint_terms.law, self.law_offset()) {
                (Some(law), Some(lo)) => {
                    for i in 0..na {
                        let d = joint_deflection(
                            state.tau[i],
                            xb[i],
                            xb[lo + i],
                            xb[lo + na + i],
                            law.lost_motion_torque,
                        );
                        state.q[i] += d.deflection;
                        state.by_torque[i] = d.by_torque;
                        state.by_compliance[i] = d.by_compliance;
                        state.by_hardening[i] = d.by_hardening;
                        state.by_lost_motion[i] = d.by_lost_motion;
                    }
                }
                _ => {
                    for (i, &c) in xb[..na].iter().enumerate() {
                        state.q[i] += c * state.tau[i];
                        state.by_torque[i] = c;
                        state.by_compliance[i] = state.tau[i];
                    }
                }
            }
            let payload = &xb[na..na + self.n_payload];
            for (j, own, other) in self.coupling_entries() {
                if let Member::Drive(i) = own {
                    state.q[i] += xb[j] * self.member_torque(k, other, payload);
                }
            }
        }
        if let Some(co) = self.cyclic_offset().filter(|_| self.joint_terms.cyclic) {
            let bases = &self.cyclic_bases[k * self.cyclic_joints.len()..];
            for (s, &i) in self.cyclic_joints.iter().enumerate() {
                // cyclic_error(q[i], ..) with the basis computed once.
                let amplitudes = &xb[co + 4 * s..co + 4 * s + 4];
                state.q[i] += bases[s]
                    .iter()
                    .zip(amplitudes)
                    .map(|(b, a)| a * b)
                    .sum::<f64>();
            }
        }
        Ok(())
    }

    /// The gravity torques of pose `k` on the commanded configuration
    /// (N.m or N) and the change `K dq` the one step's deflection `dq`
    /// makes to them, at the block of unknowns `xb`; zeros without the
    /// equilibrium's gravity stiffness.
    pub(crate) fn one_step_torque_change(&self, xb: &[f64], k: usize) -> (Vec<f64>, Vec<f64>) {
        let na = self.na;
        let mut state = JointState::new(na);
        let (Some((terms, _)), Some((stiffness, _))) = (&self.gravity, &self.stiffness) else {
            return (vec![0.0; na], vec![0.0; na]);
        };
        let payload = &xb[na..na + self.n_payload];
        let mut tau = vec![0.0; na];
        terms.forces(k, payload, &mut tau);
        let law = self.joint_terms.law.as_ref().zip(self.law_offset());
        let (mut springs, ..) = state.springs(xb, law);
        let mut dq: Vec<f64> = (0..na).map(|i| springs.deflect(i, tau[i]).0).collect();
        for (j, own, other) in self.coupling_entries() {
            if let Member::Drive(i) = own {
                dq[i] += xb[j] * self.member_torque(k, other, payload);
            }
        }
        let change = crate::equilibrium::one_step_torque_change(stiffness, k, payload, &dq);
        (tau, change)
    }

    /// Which lateral joints move frame `frame` of `model` (those on the
    /// path to it; a joint of another branch turns nothing there): the
    /// `carried` mask of [`ElasticTerms::lateral_motion`] and
    /// [`ElasticTerms::twists`] for points on that frame, computed once.
    pub(crate) fn lateral_mask(&self, model: &Model, frame: usize) -> Vec<bool> {
        self.lateral.as_ref().map_or_else(Vec::new, |lateral| {
            (0..lateral.len())
                .map(|s| lateral.moves(model, s, frame))
                .collect()
        })
    }

    /// The rigid motion `G` of the lateral rotations of pose `k` that move
    /// a point ([`crate::gravity`]): `phi = sum_j delta_j x_j` over the
    /// lateral joints `carried` marks ([`ElasticTerms::lateral_mask`] of the
    /// point's frame). `None` without lateral terms. With the equilibrium
    /// the moments are `M + L dq` of `state` ([`ElasticTerms::deflect`]'s).
    pub(crate) fn lateral_motion(
        &self,
        xb: &[f64],
        k: usize,
        carried: &[bool],
        state: &JointState,
    ) -> Option<LateralMotion> {
        let lateral = self.lateral.as_ref()?;
        let lo = self.lateral_offset()?;
        let payload = &xb[self.na..self.na + self.n_payload];
        let equilibrium = state
            .equilibrium
            .as_ref()
            .filter(|_| self.stiffness.is_some());
        let mut deltas = Vec::with_capacity(lateral.len());
        let (mut phi, mut t) = (Vector3::zeros(), Vector3::zeros());
        for (s, &moves) in carried.iter().enumerate().take(lateral.len()) {
            if !moves {
                deltas.push((0.0, 0.0));
                continue;
            }
            let joint = lateral.joint(k, s);
            let moment = joint.moment(payload) + equilibrium.map_or(0.0, |e| e.moment_change[s]);
            // The coupling entries turn the passive joint by the other
            // joints' torques, on the deflected robot with the equilibrium.
            let coupled: f64 = self
                .coupling_entries()
                .filter(|(_, own, _)| *own == Member::Passive(s))
                .map(|(j, _, other)| xb[j] * self.member_torque_at(k, other, payload, equilibrium))
                .sum();
            let delta = xb[lo + s] * moment + coupled;
            phi += delta * joint.axis;
            t -= delta * joint.axis.cross(&joint.origin);
            deltas.push((delta, moment));
        }
        Some(LateralMotion {
            rotation: rotation_from_vector(&phi),
            translation: t,
            phi,
            deltas,
        })
    }

    /// The twists `[v; w]` (base frame, `v` at the point `p` of the robot
    /// evaluated at `q + dq`, before `G`) that each unknown of the block
    /// gives the point at pose `k`, into `out` (one column per unknown):
    /// through the joint Jacobian `jq` of the point for the joint
    /// deflections, and through `G` for the lateral compliances (written
    /// before `G`, `R_G^T` times their motion, as the other columns are).
    /// `state` is [`ElasticTerms::deflect`]'s for the pose; `carried` the
    /// lateral joints that move the point ([`ElasticTerms::lateral_mask`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn twists(
        &self,
        xb: &[f64],
        k: usize,
        carried: &[bool],
        state: &JointState,
        jq: &Matrix6xX<f64>,
        motion: Option<&LateralMotion>,
        p: &Vector3<f64>,
        out: &mut Matrix6xX<f64>,
    ) {
        // One memset over the storage (nalgebra's element-wise fill walks
        // the 6-row matrix by strides).
        out.as_mut_slice().fill(0.0);
        let equilibrium = state
            .equilibrium
            .as_ref()
            .filter(|_| self.stiffness.is_some());
        // The unit twist of each lateral rotation that moves the point
        // (per rad).
        let units = self.lateral_units(k, carried, motion, p);
        if let (Some((terms, _)), Some(equilibrium)) = (&self.gravity, equilibrium) {
            let sources = EquilibriumSources {
                terms,
                k,
                state,
                equilibrium,
                units: &units,
            };
            self.equilibrium_twists(xb, &sources, jq, motion, out);
        } else if let Some((terms, _)) = &self.gravity {
            self.one_step_twists(terms, xb, k, state, jq, motion, &units, out);
            self.coupling_twists(xb, k, jq, &units, out);
        }
        if let Some(co) = self.cyclic_offset().filter(|_| self.joint_terms.cyclic) {
            let bases = &self.cyclic_bases[k * self.cyclic_joints.len()..];
            for (s, &i) in self.cyclic_joints.iter().enumerate() {
                for (h, b) in bases[s].iter().enumerate() {
                    out.column_mut(co + 4 * s + h).axpy(*b, &jq.column(i), 0.0);
                }
            }
        }
    }

    /// The unit twist of each lateral rotation of pose `k` that moves the
    /// point `p` (`carried`), per radian, written before `G`: `d G(p) / d
    /// delta_j = (Jl(phi) x_j) x (R_G p) - x_j x o_j`, turning with
    /// `Jl(phi) x_j`; `None` for a joint that does not move it.
    fn lateral_units(
        &self,
        k: usize,
        carried: &[bool],
        motion: Option<&LateralMotion>,
        p: &Vector3<f64>,
    ) -> Vec<Option<Vector6<f64>>> {
        let n = self.lateral.as_ref().map_or(0, LateralTerms::len);
        let mut units = vec![None; n];
        let (Some(motion), Some(lateral)) = (motion, &self.lateral) else {
            return units;
        };
        let r_g = motion.rotation.to_rotation_matrix().into_inner();
        let jl = left_jacobian(&motion.phi);
        let p_turned = r_g * p;
        let r_g_t = r_g.transpose();
        for (s, unit) in units.iter_mut().enumerate() {
            if !carried[s] {
                continue;
            }
            let joint = lateral.joint(k, s);
            let turn = jl * joint.axis;
            let v = r_g_t * (turn.cross(&p_turned) - joint.axis.cross(&joint.origin));
            let w = r_g_t * turn;
            *unit = Some(Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z));
        }
        units
    }

    /// The joint and lateral columns of [`ElasticTerms::twists`] with the
    /// one step.
    #[allow(clippy::too_many_arguments)]
    fn one_step_twists(
        &self,
        terms: &GravityTerms,
        xb: &[f64],
        k: usize,
        state: &JointState,
        jq: &Matrix6xX<f64>,
        motion: Option<&LateralMotion>,
        units: &[Option<Vector6<f64>>],
        out: &mut Matrix6xX<f64>,
    ) {
        let na = self.na;
        let law_offset = self.law_offset();
        for i in 0..na {
            let column = jq.column(i);
            // dq_i = f(tau_i(payload); c_i, ...): by c_i, df/dc_i; by the
            // payload, df/dtau_i dtau_i/dpayload.
            out.column_mut(i).axpy(state.by_compliance[i], &column, 0.0);
            let d = terms.payload_derivatives(k, i);
            for (p, dp) in d.iter().enumerate() {
                out.column_mut(na + p)
                    .axpy(state.by_torque[i] * dp, &column, 1.0);
            }
            if let Some(lo) = law_offset {
                out.column_mut(lo + i)
                    .axpy(state.by_hardening[i], &column, 0.0);
                out.column_mut(lo + na + i)
                    .axpy(state.by_lost_motion[i], &column, 0.0);
            }
        }
        let (Some(motion), Some(lateral), Some(lc)) =
            (motion, &self.lateral, self.lateral_offset())
        else {
            return;
        };
        for (s, &(_, moment)) in motion.deltas.iter().enumerate() {
            let Some(unit) = units[s] else {
                continue;
            };
            out.column_mut(lc + s).axpy(moment, &unit, 0.0);
            let compliance = xb[lc + s];
            for (p, dp) in lateral.joint(k, s).payload_derivatives.iter().enumerate() {
                out.column_mut(na + p).axpy(compliance * dp, &unit, 1.0);
            }
        }
    }

    /// The coupling compliances' columns of [`ElasticTerms::twists`], and
    /// what they add to the payload columns: an entry turns each of its
    /// joints by the other's torque (a drive through its column of `jq`,
    /// the passive joint through its rotation's unit twist
    /// `lateral_units`, `None` where it does not move the point).
    fn coupling_twists(
        &self,
        xb: &[f64],
        k: usize,
        jq: &Matrix6xX<f64>,
        lateral_units: &[Option<Vector6<f64>>],
        out: &mut Matrix6xX<f64>,
    ) {
        let na = self.na;
        let payload = &xb[na..na + self.n_payload];
        for (j, own, other) in self.coupling_entries() {
            let unit: Vector6<f64> = match own {
                Member::Drive(i) => jq.column(i).into_owned(),
                Member::Passive(s) => match lateral_units.get(s).copied().flatten() {
                    Some(unit) => unit,
                    None => continue,
                },
            };
            let torque = self.member_torque(k, other, payload);
            out.column_mut(j).axpy(torque, &unit, 1.0);
            for (p, dp) in self.member_torque_derivatives(k, other).iter().enumerate() {
                out.column_mut(na + p).axpy(xb[j] * dp, &unit, 1.0);
            }
        }
    }
}

/// What the equilibrium's columns of [`ElasticTerms::twists`] read at one
/// pose and point.
struct EquilibriumSources<'a> {
    terms: &'a GravityTerms,
    k: usize,
    state: &'a JointState,
    equilibrium: &'a PoseEquilibrium,
    /// [`ElasticTerms::lateral_units`] of the point.
    units: &'a [Option<Vector6<f64>>],
}

impl ElasticTerms {
    /// The elastic columns of [`ElasticTerms::twists`] with the equilibrium
    /// (module docs of [`crate::equilibrium`]): an unknown's source `b` in
    /// the joint deflections (`dq = A^-1 b`) and its direct part `e` in the
    /// lateral rotations give the point `R b + sum_s u_s e_s`, where `u_s`
    /// is lateral rotation `s`'s unit twist, `R = (jq + sum_s u_s h_s^T)
    /// A^-1`, and `h_s = c_s L_s + sum c_j S_o` the rotation's derivative by
    /// the joint deflections (its own spring and the coupling entries that
    /// turn it by another joint's torque).
    fn equilibrium_twists(
        &self,
        xb: &[f64],
        sources: &EquilibriumSources<'_>,
        jq: &Matrix6xX<f64>,
        motion: Option<&LateralMotion>,
        out: &mut Matrix6xX<f64>,
    ) {
        let (na, np) = (self.na, self.n_payload);
        let EquilibriumSources {
            terms,
            k,
            state,
            equilibrium,
            units,
        } = *sources;
        let payload = &xb[na..na + np];
        let mut through = jq.clone();
        if let Some(lc) = self.lateral_offset() {
            for (s, unit) in units.iter().enumerate() {
                let Some(unit) = unit else { continue };
                for d in 0..na {
                    let own = xb[lc + s] * equilibrium.hinge_stiffness[s * na + d];
                    let coupled: f64 = self
                        .coupling_entries()
                        .filter(|(_, own, _)| *own == Member::Passive(s))
                        .map(|(j, _, other)| xb[j] * equilibrium.stiffness_entry(other, d))
                        .sum();
                    through.column_mut(d).axpy(own + coupled, unit, 1.0);
                }
            }
        }
        let response = equilibrium.response(&through);
        let column = |i: usize| Vector6::from_fn(|r, _| response[(i, r)]);
        for i in 0..na {
            let twist = column(i);
            out.column_mut(i).axpy(state.by_compliance[i], &twist, 1.0);
            for l in 0..np {
                let source = state.by_torque[i]
                    * (terms.payload_derivatives(k, i)[l]
                        + equilibrium.payload_torque_change[l * na + i]);
                out.column_mut(na + l).axpy(source, &twist, 1.0);
            }
            if let Some(lo) = self.law_offset() {
                out.column_mut(lo + i)
                    .axpy(state.by_hardening[i], &twist, 1.0);
                out.column_mut(lo + na + i)
                    .axpy(state.by_lost_motion[i], &twist, 1.0);
            }
        }
        for (j, own, other) in self.coupling_entries() {
            let unit = match own {
                Member::Drive(i) => column(i),
                Member::Passive(s) => match units.get(s).copied().flatten() {
                    Some(unit) => unit,
                    None => continue,
                },
            };
            let torque = self.member_torque_at(k, other, payload, Some(equilibrium));
            out.column_mut(j).axpy(torque, &unit, 1.0);
            for l in 0..np {
                let dp = self.member_payload_derivative(k, other, l, equilibrium);
                out.column_mut(na + l).axpy(xb[j] * dp, &unit, 1.0);
            }
        }
        let (Some(motion), Some(lateral), Some(lc)) =
            (motion, &self.lateral, self.lateral_offset())
        else {
            return;
        };
        for (s, &(_, moment)) in motion.deltas.iter().enumerate() {
            let Some(unit) = units[s] else { continue };
            out.column_mut(lc + s).axpy(moment, &unit, 1.0);
            let joint = lateral.joint(k, s);
            for l in 0..np {
                let dp =
                    joint.payload_derivatives[l] + equilibrium.payload_moment_change[s * np + l];
                out.column_mut(na + l).axpy(xb[lc + s] * dp, &unit, 1.0);
            }
        }
    }
}
