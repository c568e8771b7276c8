//! The stacked geometric error model (7)-(10), (49)-(52), extended with the
//! measurement frame and the target offset.

use std::cell::{Cell, RefCell};

use faer::MatMut;
use flexcal_kinematics::{
    Data, Model, ParamKind, forward_pose, param_and_joint_jacobians_into, param_jacobian_into,
};
use flexcal_optim::{Jacobian, ProblemError, Residuals};
use nalgebra::{
    DMatrix, Isometry3, Matrix3, Matrix6xX, Point3, Translation3, UnitQuaternion, Vector3,
};

use crate::elastic_terms::{ElasticTerms, JointState, LateralMotion};
use crate::geometry::{
    left_jacobian, left_jacobian_inverse, rotation_from_vector, skew, vector_from_rotation,
};
use crate::gravity::{Configurations, GravityCompliance};
use crate::joint_law::JointTerms;
use crate::metrics::PoseError;
use crate::{CalibError, MeasurementSet};

/// Names of the six unknowns of the measurement frame `x_meas_base`: a
/// translation (m) added to the starting estimate and a rotation vector (rad)
/// applied on the left of the starting rotation.
pub const FRAME_PARAMETER_NAMES: [&str; 6] = [
    "frame_x", "frame_y", "frame_z", "frame_rx", "frame_ry", "frame_rz",
];

/// Names of the six unknowns of the target offset `x_tcp_target`: a
/// translation (m) added to the starting offset and a rotation vector (rad)
/// applied on the right of the starting rotation (used only when orientations
/// are measured).
pub const TARGET_PARAMETER_NAMES: [&str; 6] = [
    "target_x",
    "target_y",
    "target_z",
    "target_rx",
    "target_ry",
    "target_rz",
];

/// Names of the six measurement-frame unknowns of station `station`
/// (0-based) of a set with several stations ([`MeasurementSet::pooled`]):
/// `frame_x..frame_rz` for the first, `frame_s2_x..frame_s2_rz` for the
/// second, and so on.
pub fn station_frame_names(station: usize) -> [String; 6] {
    FRAME_PARAMETER_NAMES.map(|name| {
        if station == 0 {
            name.to_string()
        } else {
            name.replacen("frame_", &format!("frame_s{}_", station + 1), 1)
        }
    })
}

pub use crate::unknown_kind::UnknownKind;

/// The measurement model of one pose k,
/// `x_meas_target = x_meas_base(tau) * FK(q_k, xi) * x_tcp_target(t)`,
/// stacked over a measurement set, as a least-squares problem in the
/// unknowns `x = [xi; tau; t]` (n_params + 6 + 6).
///
/// A set with several stations ([`MeasurementSet::pooled`]) has one
/// measurement frame per station: the frames of the second and later
/// stations follow the target's unknowns (`frame_s2_x`, ...;
/// [`station_frame_names`]), and each pose is predicted in its station's
/// frame.
///
/// Residual rows per pose: `predicted - measured` position (m), then, when
/// orientations are used, the rotation vector `log(R_pred R_meas^T)` (rad).
/// The Jacobian is exact: the robot part is the parameter Jacobian of
/// `flexcal-kinematics` carried to the target point and into the measurement
/// frame; the frame parts use the SO(3) left Jacobian.
///
/// With [`GeometricErrorModel::with_gravity`] the model is elasto-geometric:
/// the robot is evaluated at `q_k + dq_k`, the joint-spring deflection under
/// gravity of [`crate::gravity`], and the unknowns gain the compliances and
/// the payload (`[xi; tau; t; c; m; m c]`), and, with
/// [`GravityCompliance::lateral`], the lateral compliances after them: the
/// robot's pose is then moved by the rigid motion `G` of
/// [`crate::gravity`]'s lateral rotations, `x_base_tcp' = G FK(q_k + dq_k,
/// xi)`, with exact derivatives of that model.
pub struct GeometricErrorModel<'a> {
    model: &'a Model,
    set: &'a MeasurementSet,
    use_orientation: bool,
    x_meas_base0: Isometry3<f64>,
    x_tcp_target0: Isometry3<f64>,
    /// Starting measurement frames of the second and later stations.
    station_frames0: Vec<Isometry3<f64>>,
    names: Vec<String>,
    data: RefCell<Data>,
    pose_jacobian: RefCell<DMatrix<f64>>,
    robot_columns: Cell<bool>,
    /// The elastic and joint terms (none when geometric).
    elastic: ElasticTerms,
    /// The lateral joints that move the TCP ([`ElasticTerms::lateral_mask`]).
    lateral_mask: Vec<bool>,
    joint_jacobian: RefCell<Matrix6xX<f64>>,
    deflection: RefCell<JointState>,
}

impl<'a> GeometricErrorModel<'a> {
    /// The model of `set` measured on `model`, linearised around the starting
    /// frame estimates `x_meas_base0` and `x_tcp_target0`.
    ///
    /// # Errors
    /// [`CalibError::ActuatedCountMismatch`]; [`CalibError::BadMeasurement`]
    /// when orientations are asked for but not measured.
    pub fn new(
        model: &'a Model,
        set: &'a MeasurementSet,
        use_orientation: bool,
        x_meas_base0: Isometry3<f64>,
        x_tcp_target0: Isometry3<f64>,
    ) -> Result<Self, CalibError> {
        if set.n_actuated() != model.n_actuated() {
            return Err(CalibError::ActuatedCountMismatch {
                source_name: set.source.clone(),
                robot: model.name().to_string(),
                expected: model.n_actuated(),
                found: set.n_actuated(),
            });
        }
        if use_orientation && !set.has_orientation() {
            return Err(CalibError::BadMeasurement {
                source_name: set.source.clone(),
                line: 0,
                what: "orientation asked for but the file has no rx_deg, ry_deg, rz_deg columns"
                    .into(),
            });
        }
        let station_frames0 = vec![x_meas_base0; set.n_stations() - 1];
        let mut names: Vec<String> = model.params().iter().map(|p| p.name.clone()).collect();
        names.extend(FRAME_PARAMETER_NAMES.iter().map(|s| s.to_string()));
        names.extend(TARGET_PARAMETER_NAMES.iter().map(|s| s.to_string()));
        for s in 1..set.n_stations() {
            names.extend(station_frame_names(s));
        }
        Ok(Self {
            model,
            set,
            use_orientation,
            x_meas_base0,
            x_tcp_target0,
            station_frames0,
            names,
            data: RefCell::new(Data::new(model)),
            pose_jacobian: RefCell::new(DMatrix::zeros(6, model.n_params())),
            robot_columns: Cell::new(true),
            elastic: ElasticTerms::none(model),
            lateral_mask: Vec::new(),
            joint_jacobian: RefCell::new(Matrix6xX::zeros(model.n_actuated())),
            deflection: RefCell::new(JointState::new(model.n_actuated())),
        })
    }

    /// The starting measurement frames of the second and later stations
    /// (without this, each starts at the first station's). More frames than
    /// the set has stations give the model the unknowns of a calibration
    /// with that many stations (the extra ones have no pose: zero columns),
    /// so that its unknowns line up with that calibration's.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] with fewer frames than the set's
    /// stations beyond the first, or after the gravity model or the joint
    /// terms (their unknowns come after the frames).
    pub fn with_station_frames(mut self, frames: &[Isometry3<f64>]) -> Result<Self, CalibError> {
        if self.elastic.len() > 0 {
            return Err(CalibError::InvalidOption {
                name: "station_frames",
                reason: "the station frames go before the gravity model and the joint terms".into(),
            });
        }
        if frames.len() + 1 < self.set.n_stations() {
            return Err(CalibError::InvalidOption {
                name: "station_frames",
                reason: format!(
                    "{} starting frames for the {} stations after the first of {}",
                    frames.len(),
                    self.set.n_stations() - 1,
                    self.set.source
                ),
            });
        }
        self.station_frames0 = frames.to_vec();
        self.names.truncate(self.model.n_params() + 12);
        for s in 1..=frames.len() {
            self.names.extend(station_frame_names(s));
        }
        Ok(self)
    }

    /// Number of measurement frames (stations) of the model.
    pub fn n_stations(&self) -> usize {
        self.station_frames0.len() + 1
    }

    /// Index of the first measurement-frame unknown of station `s`
    /// (0-based).
    pub fn station_frame_offset(&self, s: usize) -> usize {
        if s == 0 {
            self.frame_offset()
        } else {
            self.model.n_params() + 12 + 6 * (s - 1)
        }
    }

    /// Index one past the last frame unknown (measurement frames and target
    /// offset): where the elastic and joint-term unknowns start.
    pub fn frames_end(&self) -> usize {
        self.model.n_params() + 12 + 6 * self.station_frames0.len()
    }

    /// Makes the model elasto-geometric: joint compliances under gravity
    /// ([`crate::gravity`]), their unknowns appended after the target's
    /// (the compliances, the payload, then the lateral compliances when
    /// [`GravityCompliance::lateral`] is on).
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for a mass on a missing frame or
    /// non-finite values, [`CalibError::Kinematics`] naming a pose.
    pub fn with_gravity(mut self, gravity: &GravityCompliance) -> Result<Self, CalibError> {
        let label = |k: usize| self.set.measurements()[k].label(k);
        let poses = Configurations::of_set(self.set, &label);
        self.elastic.add_gravity(self.model, &poses, gravity)?;
        self.lateral_mask = self
            .elastic
            .lateral_mask(self.model, self.model.end_frame());
        self.names.extend(gravity.elastic_unknown_names(self.model));
        Ok(self)
    }

    /// Adds the joint terms of [`crate::joint_law`] (their unknowns appended
    /// after all others, starting at zero: linear springs, no cyclic error).
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for the stiffness law without the
    /// gravity model, or a lost-motion torque that is not `> 0`.
    pub fn with_joint_terms(mut self, terms: &JointTerms) -> Result<Self, CalibError> {
        let label = |k: usize| self.set.measurements()[k].label(k);
        let poses = Configurations::of_set(self.set, &label);
        self.elastic.add_joint_terms(self.model, &poses, terms)?;
        self.names.extend(terms.unknown_names(self.model));
        Ok(self)
    }

    /// Span of each actuated coordinate's gravity torque over the poses, with
    /// the starting payload (N.m or N;
    /// [`crate::GravityCompliance::joint_torques`]); empty when geometric.
    pub fn torque_ranges(&self) -> Vec<crate::CoordinateCoverage> {
        self.elastic.torque_ranges(self.set.len())
    }

    /// Index of the first unknown of the joint terms (the law's, then the
    /// cyclic ones), when there are any.
    pub fn joint_terms_offset(&self) -> Option<usize> {
        self.elastic
            .joint_terms_offset()
            .map(|o| self.frames_end() + o)
    }

    /// Index of the first lateral compliance, when the model has them.
    pub fn lateral_offset(&self) -> Option<usize> {
        self.elastic.lateral_offset().map(|o| self.frames_end() + o)
    }

    /// Index of the first elastic unknown (the compliances), when the model
    /// is elasto-geometric.
    pub fn elastic_offset(&self) -> Option<usize> {
        self.elastic.has_gravity().then(|| self.frames_end())
    }

    /// The rigid motion of the lateral rotations of pose `k` at `x`, which
    /// moves the TCP ([`ElasticTerms::lateral_motion`]).
    fn lateral_motion(&self, x: &[f64], k: usize) -> Option<LateralMotion> {
        self.elastic
            .lateral_motion(&x[self.frames_end()..], k, &self.lateral_mask)
    }

    /// The actuated coordinates at which the robot is evaluated for pose `k`
    /// ([`ElasticTerms::deflect`]).
    fn deflect(&self, x: &[f64], k: usize, state: &mut JointState) {
        let q = &self.set.measurements()[k].q;
        self.elastic.deflect(&x[self.frames_end()..], k, q, state);
    }

    /// Whether [`Jacobian::jacobian`] computes the robot-parameter columns
    /// (default true). With `false` they are written as zeros and only the
    /// forward model runs per pose: for fits of the frames alone, where the
    /// parameter Jacobian would be most of the cost.
    pub fn set_robot_columns(&self, on: bool) {
        self.robot_columns.set(on);
    }

    /// Number of unknowns: `n_params + 12`, plus 6 per station after the
    /// first, plus `n_actuated + 4` (and the lateral compliances) when
    /// elasto-geometric, plus the joint terms.
    pub fn n_unknowns(&self) -> usize {
        self.names.len()
    }
    /// Index of the first measurement-frame unknown (the first 6 after xi).
    pub fn frame_offset(&self) -> usize {
        self.model.n_params()
    }
    /// Index of the first target unknown.
    pub fn target_offset(&self) -> usize {
        self.model.n_params() + 6
    }
    /// Names of all unknowns.
    pub fn names(&self) -> &[String] {
        &self.names
    }
    /// Length or angle, per unknown.
    pub fn kinds(&self) -> Vec<UnknownKind> {
        let mut kinds: Vec<UnknownKind> = self
            .model
            .params()
            .iter()
            .map(|p| match p.kind {
                ParamKind::Length => UnknownKind::Length,
                ParamKind::Angle => UnknownKind::Angle,
            })
            .collect();
        for _ in 0..2 + self.station_frames0.len() {
            kinds.extend([UnknownKind::Length; 3]);
            kinds.extend([UnknownKind::Angle; 3]);
        }
        kinds.extend(self.elastic.kinds());
        kinds
    }
    /// The measurements the model predicts.
    pub fn measurements(&self) -> &[crate::Measurement] {
        self.set.measurements()
    }
    /// Rows per pose: 3 (position) or 6 (position and orientation).
    pub fn rows_per_pose(&self) -> usize {
        if self.use_orientation { 6 } else { 3 }
    }
    /// The starting vector: nominal xi, zero frame and target increments,
    /// and the starting elastic unknowns when elasto-geometric.
    pub fn initial_unknowns(&self) -> Vec<f64> {
        let mut x = self.model.nominal_params().to_vec();
        x.extend(vec![0.0; 12 + 6 * self.station_frames0.len()]);
        x.extend(self.elastic.initial());
        x
    }

    /// The measurement frame `x_meas_base` of station `s` (0-based) at `x`.
    pub fn station_frame(&self, x: &[f64], s: usize) -> Isometry3<f64> {
        let f = self.station_frame_offset(s);
        let start = if s == 0 {
            &self.x_meas_base0
        } else {
            &self.station_frames0[s - 1]
        };
        Isometry3::from_parts(
            Translation3::from(start.translation.vector + Vector3::new(x[f], x[f + 1], x[f + 2])),
            rotation_from_vector(&Vector3::new(x[f + 3], x[f + 4], x[f + 5])) * start.rotation,
        )
    }

    /// The measurement frames of the second and later stations at `x`.
    pub fn station_frames(&self, x: &[f64]) -> Vec<Isometry3<f64>> {
        (1..self.n_stations())
            .map(|s| self.station_frame(x, s))
            .collect()
    }

    /// The measurement frame `x_meas_base` (of the first station) and target
    /// offset `x_tcp_target` at `x`.
    pub fn frames(&self, x: &[f64]) -> (Isometry3<f64>, Isometry3<f64>) {
        let t = self.target_offset();
        let x_meas_base = self.station_frame(x, 0);
        let x_tcp_target = Isometry3::from_parts(
            Translation3::from(
                self.x_tcp_target0.translation.vector + Vector3::new(x[t], x[t + 1], x[t + 2]),
            ),
            self.x_tcp_target0.rotation
                * rotation_from_vector(&Vector3::new(x[t + 3], x[t + 4], x[t + 5])),
        );
        (x_meas_base, x_tcp_target)
    }

    /// Predicted target pose `x_meas_target` of pose `k` at unknowns `x`.
    ///
    /// # Errors
    /// [`CalibError::Kinematics`] naming the pose.
    pub fn predict(&self, x: &[f64], k: usize) -> Result<Isometry3<f64>, CalibError> {
        self.predict_in(&self.all_frames(x), x, k)
    }

    /// Every station's measurement frame and the target offset at `x`.
    fn all_frames(&self, x: &[f64]) -> (Vec<Isometry3<f64>>, Isometry3<f64>) {
        let (first, target) = self.frames(x);
        let mut frames = vec![first];
        frames.extend(self.station_frames(x));
        (frames, target)
    }

    /// [`GeometricErrorModel::predict`] with the frames of `x` already at
    /// hand (they cost two exponential maps each: once per evaluation, not
    /// per pose).
    fn predict_in(
        &self,
        (stations, x_tcp_target): &(Vec<Isometry3<f64>>, Isometry3<f64>),
        x: &[f64],
        k: usize,
    ) -> Result<Isometry3<f64>, CalibError> {
        let x_meas_base = &stations[self.set.station_of(k)];
        let m = &self.set.measurements()[k];
        let xi = &x[..self.model.n_params()];
        let mut buffers = self.deflection.borrow_mut();
        self.deflect(x, k, &mut buffers);
        let x_base_tcp = forward_pose(self.model, &mut self.data.borrow_mut(), &buffers.q, xi)
            .map_err(|source| CalibError::Kinematics {
                pose: k,
                pose_id: m.label(k),
                source,
            })?;
        let x_base_tcp = match self.lateral_motion(x, k) {
            Some(motion) => lateral_isometry(&motion.rotation, &motion.translation) * x_base_tcp,
            None => x_base_tcp,
        };
        Ok(x_meas_base * x_base_tcp * x_tcp_target)
    }

    fn write_residual(&self, k: usize, predicted: &Isometry3<f64>, out: &mut [f64]) {
        let m = &self.set.measurements()[k];
        let dp = predicted.translation.vector - m.position;
        out[..3].copy_from_slice(dp.as_slice());
        if self.use_orientation {
            let measured = rotation_from_vector(&m.orientation.unwrap_or_default());
            let dr = vector_from_rotation(&(predicted.rotation * measured.inverse()));
            out[3..6].copy_from_slice(dr.as_slice());
        }
    }
}

impl Residuals for GeometricErrorModel<'_> {
    fn n_residuals(&self) -> usize {
        self.set.len() * self.rows_per_pose()
    }
    fn n_params(&self) -> usize {
        self.names.len()
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        let rows = self.rows_per_pose();
        let frames = self.all_frames(x);
        for k in 0..self.set.len() {
            let predicted = self.predict_in(&frames, x, k)?;
            self.write_residual(k, &predicted, &mut out[k * rows..(k + 1) * rows]);
        }
        Ok(())
    }
    fn parameter_name(&self, j: usize) -> String {
        self.names[j].clone()
    }
}

impl Jacobian for GeometricErrorModel<'_> {
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        self.jacobian_rows(x, 0..self.set.len(), out)
    }
}

impl GeometricErrorModel<'_> {
    /// The Jacobian rows of the poses `poses` only (row 0 of `out` is the
    /// first row of pose `poses.start`): for factorisations that stream the
    /// stacked Jacobian block by block instead of holding it whole.
    ///
    /// # Errors
    /// [`CalibError::Kinematics`] naming the pose.
    pub fn jacobian_rows(
        &self,
        x: &[f64],
        poses: std::ops::Range<usize>,
        mut out: MatMut<'_, f64>,
    ) -> Result<(), ProblemError> {
        let np = self.model.n_params();
        let xi = &x[..np];
        let (stations, x_tcp_target) = self.all_frames(x);
        let to = self.target_offset();
        let psi = Vector3::new(x[to + 3], x[to + 4], x[to + 5]);
        let jr_psi = left_jacobian(&psi).transpose();
        let station_terms: Vec<StationTerms> = stations
            .iter()
            .enumerate()
            .map(|(s, frame)| {
                let offset = self.station_frame_offset(s);
                let phi = Vector3::new(x[offset + 3], x[offset + 4], x[offset + 5]);
                StationTerms {
                    frame: *frame,
                    offset,
                    jl_phi: left_jacobian(&phi),
                    rotation: frame.rotation.to_rotation_matrix().into_inner(),
                }
            })
            .collect();
        let rows = self.rows_per_pose();
        let mut data = self.data.borrow_mut();
        let mut jac = self.pose_jacobian.borrow_mut();
        let mut jq = self.joint_jacobian.borrow_mut();
        let mut buffers = self.deflection.borrow_mut();
        let robot_columns = self.robot_columns.get();
        if !robot_columns {
            jac.fill(0.0);
        }
        let eo = self.frames_end();
        // Elastic and joint-term unknowns: every unknown after the target's.
        let n_elastic = self.names.len() - eo;
        // TCP twists of the elastic unknowns, one column each (before the
        // lateral motion G, which the robot's columns share).
        let mut elastic = Matrix6xX::<f64>::zeros(n_elastic);
        let first = poses.start;
        for k in poses {
            let m = &self.set.measurements()[k];
            let station = self.set.station_of(k);
            let StationTerms {
                frame: x_meas_base,
                offset: fo,
                jl_phi,
                rotation: r_mb,
            } = station_terms[station];
            let kinematics_error = |source| CalibError::Kinematics {
                pose: k,
                pose_id: m.label(k),
                source,
            };
            self.deflect(x, k, &mut buffers);
            let q = &buffers.q;
            let x_base_tcp = if robot_columns && n_elastic > 0 {
                param_and_joint_jacobians_into(self.model, &mut data, q, xi, &mut jac, &mut jq)
                    .map_err(kinematics_error)?
            } else if robot_columns {
                param_jacobian_into(self.model, &mut data, q, xi, &mut jac)
                    .map_err(kinematics_error)?
            } else {
                forward_pose(self.model, &mut data, q, xi).map_err(kinematics_error)?
            };
            let motion = self.lateral_motion(x, k);
            if robot_columns && n_elastic > 0 {
                self.elastic.twists(
                    &x[eo..],
                    k,
                    &self.lateral_mask,
                    &buffers,
                    &jq,
                    motion.as_ref(),
                    &x_base_tcp.translation.vector,
                    &mut elastic,
                );
            }
            // Twists before G move the target by R_G times their motion.
            let (x_base_tcp, r_mbg, offset_base) = match &motion {
                Some(motion) => {
                    let offset = x_base_tcp.rotation * x_tcp_target.translation.vector;
                    (
                        lateral_isometry(&motion.rotation, &motion.translation) * x_base_tcp,
                        r_mb * motion.rotation.to_rotation_matrix().into_inner(),
                        offset,
                    )
                }
                None => (
                    x_base_tcp,
                    r_mb,
                    x_base_tcp.rotation * x_tcp_target.translation.vector,
                ),
            };
            let r_bt = x_base_tcp.rotation.to_rotation_matrix().into_inner();
            let target_base =
                x_base_tcp.translation.vector + r_bt * x_tcp_target.translation.vector;
            let r0 = (k - first) * rows;
            // Other stations' frames do not move this pose.
            for (s, other) in station_terms.iter().enumerate() {
                if s != station {
                    for i in 0..rows {
                        for c in 0..6 {
                            out[(r0 + i, other.offset + c)] = 0.0;
                        }
                    }
                }
            }
            // Robot parameters and elastic unknowns: moving the TCP by
            // (v, w) moves the target by v + w x offset.
            let lever = skew(&offset_base);
            let twist = |j: usize| -> (usize, Vector3<f64>, Vector3<f64>) {
                if j < np {
                    let v = Vector3::new(jac[(0, j)], jac[(1, j)], jac[(2, j)]);
                    let w = Vector3::new(jac[(3, j)], jac[(4, j)], jac[(5, j)]);
                    (j, v, w)
                } else {
                    let e = j - np;
                    let c = elastic.column(e);
                    (
                        eo + e,
                        Vector3::new(c[0], c[1], c[2]),
                        Vector3::new(c[3], c[4], c[5]),
                    )
                }
            };
            for j in 0..np + n_elastic {
                let (col, v, w) = twist(j);
                let dp = r_mbg * (v - lever * w);
                for i in 0..3 {
                    out[(r0 + i, col)] = dp[i];
                }
            }
            // Measurement frame.
            let d_rot = -skew(&(r_mb * target_base)) * jl_phi;
            // Target offset.
            let d_target = r_mb * r_bt;
            for i in 0..3 {
                for c in 0..3 {
                    out[(r0 + i, fo + c)] = if i == c { 1.0 } else { 0.0 };
                    out[(r0 + i, fo + 3 + c)] = d_rot[(i, c)];
                    out[(r0 + i, to + c)] = d_target[(i, c)];
                    out[(r0 + i, to + 3 + c)] = 0.0;
                }
            }
            if self.use_orientation {
                let predicted = x_meas_base * x_base_tcp * x_tcp_target;
                let measured = rotation_from_vector(&m.orientation.unwrap_or_default());
                let residual = vector_from_rotation(&(predicted.rotation * measured.inverse()));
                let jinv = left_jacobian_inverse(&residual);
                let map = jinv * r_mbg;
                for j in 0..np + n_elastic {
                    let (col, _, w) = twist(j);
                    let dr = map * w;
                    for i in 0..3 {
                        out[(r0 + 3 + i, col)] = dr[i];
                    }
                }
                let d_phi = jinv * jl_phi;
                let r_pred = predicted.rotation.to_rotation_matrix().into_inner();
                let d_psi = jinv * r_pred * jr_psi;
                let zero = Matrix3::<f64>::zeros();
                for i in 0..3 {
                    for c in 0..3 {
                        out[(r0 + 3 + i, fo + c)] = zero[(i, c)];
                        out[(r0 + 3 + i, fo + 3 + c)] = d_phi[(i, c)];
                        out[(r0 + 3 + i, to + c)] = 0.0;
                        out[(r0 + 3 + i, to + 3 + c)] = d_psi[(i, c)];
                    }
                }
            }
        }
        Ok(())
    }
}

/// What the Jacobian needs of one station's measurement frame at the
/// unknowns: the frame, the column of its first unknown, the left Jacobian
/// of its rotation vector and its rotation matrix.
#[derive(Clone, Copy)]
struct StationTerms {
    frame: Isometry3<f64>,
    offset: usize,
    jl_phi: Matrix3<f64>,
    rotation: Matrix3<f64>,
}

/// The rigid motion `p -> rotation p + translation` as an isometry.
fn lateral_isometry(rotation: &UnitQuaternion<f64>, translation: &Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(*translation), *rotation)
}

/// Target positions `p_base_target` of the poses of `set` predicted by the
/// robot at `xi` with target offset `x_tcp_target`: the points registered
/// onto the measurements to start the measurement frame.
///
/// # Errors
/// [`CalibError::Kinematics`] naming the pose.
pub fn predicted_target_positions(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
    x_tcp_target: &Isometry3<f64>,
) -> Result<Vec<Vector3<f64>>, CalibError> {
    Ok(tcp_poses(model, set, xi)?
        .iter()
        .map(|x_base_tcp| (x_base_tcp * x_tcp_target * Point3::origin()).coords)
        .collect())
}

/// The TCP pose `x_base_tcp` of every pose of `set` with the robot at `xi`.
///
/// # Errors
/// [`CalibError::Kinematics`] naming the pose.
fn tcp_poses(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
) -> Result<Vec<Isometry3<f64>>, CalibError> {
    let mut data = Data::new(model);
    set.measurements()
        .iter()
        .enumerate()
        .map(|(k, m)| {
            forward_pose(model, &mut data, &m.q, xi).map_err(|source| CalibError::Kinematics {
                pose: k,
                pose_id: m.label(k),
                source,
            })
        })
        .collect()
}

/// Closed-form start of the target's orientation on the tool when
/// orientations are measured: with the measurement frame `x_meas_base` and
/// the robot at `xi`, each pose gives `R_tcp_target = (R_meas_base
/// R_base_tcp)^T R_meas_target`; their mean rotation
/// ([`crate::geometry::mean_rotation`]). A probe whose frame is turned
/// against the one its nominal offset assumes (a quarter turn about the
/// tool axis, say) then starts where the data put it.
///
/// # Errors
/// [`CalibError::BadMeasurement`] when the set has no orientations, a model
/// failure at a pose, a degenerate mean.
pub fn register_target_rotation(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
    x_meas_base: &Isometry3<f64>,
) -> Result<UnitQuaternion<f64>, CalibError> {
    let rotations = set
        .measurements()
        .iter()
        .zip(tcp_poses(model, set, xi)?)
        .enumerate()
        .map(|(k, (m, x_base_tcp))| {
            let orientation = m.orientation.ok_or_else(|| CalibError::BadMeasurement {
                source_name: set.source.clone(),
                line: 0,
                what: format!(
                    "pose {}: no orientation to register the target's",
                    m.label(k)
                ),
            })?;
            Ok((x_meas_base.rotation * x_base_tcp.rotation).inverse()
                * rotation_from_vector(&orientation))
        })
        .collect::<Result<Vec<_>, CalibError>>()?;
    crate::geometry::mean_rotation(&rotations)
}

/// Closed-form start of the measurement frame: the rigid registration of the
/// predicted target positions onto the measured ones.
///
/// # Errors
/// [`CalibError::Kinematics`], [`CalibError::DegenerateRegistration`].
pub fn register_measurement_frame(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
    x_tcp_target: &Isometry3<f64>,
) -> Result<Isometry3<f64>, CalibError> {
    let predicted = predicted_target_positions(model, set, xi, x_tcp_target)?;
    let measured: Vec<Vector3<f64>> = set.measurements().iter().map(|m| m.position).collect();
    crate::geometry::register_points(&measured, &predicted)
}

/// Per-pose errors of the error model `problem` at unknowns `x` (its frames
/// included).
///
/// # Errors
/// [`CalibError::Kinematics`] naming the pose.
pub(crate) fn pose_errors(
    problem: &GeometricErrorModel<'_>,
    x: &[f64],
) -> Result<Vec<PoseError>, CalibError> {
    debug_assert_eq!(x.len(), problem.n_params());
    // Every station's frame once, not once per pose.
    let frames = problem.all_frames(x);
    problem
        .measurements()
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let predicted = problem.predict_in(&frames, x, k)?;
            let position_vector = m.position - predicted.translation.vector;
            let orientation = if problem.rows_per_pose() == 6 {
                let measured = rotation_from_vector(&m.orientation.unwrap_or_default());
                Some(vector_from_rotation(&(predicted.rotation * measured.inverse())).norm())
            } else {
                None
            };
            Ok(PoseError {
                position: position_vector.norm(),
                position_vector,
                orientation,
            })
        })
        .collect()
}
