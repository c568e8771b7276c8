//! Identification from several targets on different frames of a robot (a
//! tree's branches, links of a chain, the tool): one measurement frame per
//! station, one offset per target, the robot's parameters, all from the
//! residuals of every target on every pose stacked together; with the
//! elasto-geometric terms of the one-target model when asked.
//!
//! For target t on frame f(t) and pose k the model is
//! `p_M = x_meas_base(tau) * x_base_f(q_k, xi) * x_f_target(o_t)`, the
//! paper's (7)-(10) with the parameter Jacobian (49)-(52) of frame f(t)
//! instead of the TCP ([`flexcal_kinematics::frame_param_jacobian`]). The
//! unknowns are `[xi; tau; o_t for each identified target; tau_s for each
//! later station]`, the offsets named `target.<name>.x|y|z` (m, added to
//! the nominal offset in the target's frame), the later stations' frames
//! `frame_s2_x` ... ([`crate::station_frame_names`]; a pose is predicted in
//! its station's frame, [`TargetMeasurementSet::pooled`]). Rows are
//! positions only (m), weighted `1/sigma`.
//!
//! Identifiability is decided as for one target, by the same code
//! ([`crate::calibrate`]): pivoted QR of the weighted stacked Jacobian at
//! the nominal robot with its frames fitted (the measurement frame first,
//! then the target offsets, then the robot's parameters and the elastic
//! terms, names in [`CalibrationOptions::deferred`] last). Unknowns beyond
//! the numerical rank are exactly dependent on others
//! ([`UnknownStatus::NonIdentifiable`]); the base set is then chosen at the
//! noise level, each column scaled by its standard-error limit, so that an
//! unknown whose standard error would exceed the limits of
//! [`CalibrationOptions`] stays at its starting value
//! ([`UnknownStatus::PoorlyIdentifiable`]); what is left out is named, with
//! the combinations the identified unknowns stand for.
//!
//! ## Elasto-geometric terms
//! With [`CalibrationOptions::gravity`] (and
//! [`CalibrationOptions::joint_terms`]) the robot is evaluated at `q_k +
//! dq_k`, the joint deflections under gravity of [`crate::gravity`] (and
//! the joint law and cyclic errors of [`crate::joint_law`]), the unknowns
//! of the one-target model appended after the targets' in its order
//! (compliances, payload, lateral compliances, then the joint terms). The
//! torque of each joint comes from every weight it carries, both arms for
//! a torso; the joint Jacobian of each target's point
//! ([`flexcal_kinematics::frame_param_and_joint_jacobians_into`]) carries
//! the deflections to it, so a joint of one branch moves that branch's
//! targets only. A lateral rotation moves the targets on frames after its
//! joint: the torso's tilt moves both hands. Cyclic errors of a joint
//! whose poses cover less than 90 % of their period stay at zero. The
//! derivatives are exact (checked against central differences in this
//! module's tests).

use std::cell::RefCell;

use faer::MatMut;
use flexcal_kinematics::{
    Data, Model, ParamKind, RobotDescription, forward_frames, frame_points_jacobians_into,
};
use flexcal_optim::{
    ColumnScaling, Control, Diagnosis, IdentifiabilityReport, IterationState, Jacobian,
    LevenbergMarquardt, ProblemError, ProblemSetup, Residuals, SolveReport, Termination,
};
use nalgebra::{DMatrix, Isometry3, Matrix3, Matrix6xX, Translation3, Vector3};
use serde::Serialize;

use crate::CalibError;
use crate::coverage::CoordinateCoverage;
use crate::elastic_terms::{ElasticTerms, JointState};
use crate::error_model::{FRAME_PARAMETER_NAMES, UnknownKind, station_frame_names};
use crate::geometry::{left_jacobian, register_points, rotation_from_vector, skew};
use crate::gravity::{Configurations, GravityCompliance};
use crate::identify::{
    AnalysisContext, CalibrationOptions, Combination, FrameTreatment, GEODESIC_ACCELERATION_LIMIT,
    Method, Rounds, RoundsOutcome, SPREAD_REFERENCE_POSES, StackedJacobian, UnknownEstimate,
    UnknownFlags, UnknownStatus, Weighting, analysis_index, elastic_notes, is_elastic_unknown,
    noise_level, noise_source, observation_std, rms_row_weights, spread_configurations,
    spread_ratio_values, unit_covariance_diagonal, unknown_estimates, weak_spread_note,
};
use crate::joint_law::JointTerms;
use crate::metrics::{ErrorStatistics, PoseError, error_statistics};
use crate::prediction::{
    Linearised, Observed, Predicting, jacobian_and_residuals, residual_variance,
};
use crate::screen::DataChecks;
use crate::significance::NoiseSource;
use crate::targets::{
    TCP_FRAME, Target, TargetMeasurementSet, TargetObservation, TargetPose, target_point,
};

/// Names of the three unknowns of a target's offset: `target.<name>.x`,
/// `.y`, `.z` (m, in the target's frame).
pub fn target_unknown_names(target: &str) -> [String; 3] {
    ["x", "y", "z"].map(|a| format!("target.{target}.{a}"))
}

/// Errors of one target over the poses where it was seen.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetErrors {
    /// Target name.
    pub target: String,
    /// Frame it is fixed to.
    pub frame: String,
    /// Mean, RMS and maximum position error (m) over its observations.
    pub statistics: ErrorStatistics,
}

/// The error of one observation: a target at a pose.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObservationError {
    /// The pose's label (`pose_id`, or `#k` from its index).
    pub pose: String,
    /// The target's name.
    pub target: String,
    /// Measured minus predicted position, in the measurement frame (m).
    pub error: Vector3<f64>,
}

/// `pose,target,position_error_mm,dx_mm,dy_mm,dz_mm`, one row per
/// observation (mm; a comma in a pose label written as `;`): the
/// per-observation error file of `flexcal calibrate --targets --residuals`,
/// as [`crate::temperature::pose_errors_csv`] is for one target.
pub fn observation_errors_csv(errors: &[ObservationError]) -> String {
    let mut out = String::from("pose,target,position_error_mm,dx_mm,dy_mm,dz_mm\n");
    for e in errors {
        let mm = e.error * 1e3;
        out.push_str(&format!(
            "{},{},{},{},{},{}\n",
            e.pose.replace(',', ";"),
            e.target,
            mm.norm(),
            mm.x,
            mm.y,
            mm.z
        ));
    }
    out
}

/// A fitted multi-target calibration.
#[derive(Debug, Clone, Serialize)]
pub struct TargetCalibration {
    /// Identified robot parameters xi (m, rad).
    pub xi: Vec<f64>,
    /// Nominal robot parameters (m, rad).
    pub nominal_xi: Vec<f64>,
    /// Identified (or fixed) measurement frame `x_meas_base`.
    pub x_meas_base: Isometry3<f64>,
    /// Starting measurement frame (registration of the nominal predictions
    /// onto the measurements, or the given value): the `frame_*` unknowns
    /// are increments on it (translation added, rotation vector on the left).
    pub x_meas_base_initial: Isometry3<f64>,
    /// Measurement frame fitted for the nominal robot (the "before").
    pub x_meas_base_nominal_robot: Isometry3<f64>,
    /// Whether the measurement frame was fixed.
    pub measurement_frame_fixed: bool,
    /// The targets with their identified (or fixed) offsets.
    pub targets: Vec<Target>,
    /// The targets with their offsets fitted for the nominal robot (the "before").
    pub targets_nominal_robot: Vec<Target>,
    /// Every unknown: robot parameters, then `frame_*`, then `target.*`.
    pub unknowns: Vec<UnknownEstimate>,
    /// Identifiability of the free unknowns at the start point (nominal
    /// robot, frames fitted), at [`CalibrationOptions::rank_tolerance`].
    pub identifiability: IdentifiabilityReport,
    /// What each identified unknown stands for (C.1), linearised at the start point.
    pub combinations: Vec<Combination>,
    /// The same as text (coefficients below 1e-3 dropped).
    pub combination_lines: Vec<String>,
    /// The final solver report.
    pub solve: SolveReport,
    /// Errors of all observations with the nominal robot, frames and offsets fitted (before).
    pub training_before: ErrorStatistics,
    /// Errors of all observations after identification.
    pub training_after: ErrorStatistics,
    /// Per-target errors before identification (nominal robot, frames fitted).
    pub per_target_before: Vec<TargetErrors>,
    /// Per-target errors after identification.
    pub per_target_after: Vec<TargetErrors>,
    /// Number of poses used.
    pub n_poses: usize,
    /// Number of (pose, target) observations used.
    pub n_observations: usize,
    /// The error of every observation after identification, pose by pose.
    pub observation_errors: Vec<ObservationError>,
    /// Repeated readings and suspect observations of the identification
    /// set ([`DataChecks::for_targets`]).
    pub data_checks: DataChecks,
    /// The noise the standard errors and identifiability judgements used
    /// ([`crate::significance`]).
    pub noise: NoiseSource,
    /// The gravity loading when the model is elasto-geometric, with the
    /// identified elastic unknowns (compliances, payload mass, first moment,
    /// lateral compliances when on; order of
    /// [`GravityCompliance::elastic_unknown_names`]). Not serialised: the
    /// values are in `unknowns` by name.
    #[serde(skip)]
    pub elastic: Option<(GravityCompliance, Vec<f64>)>,
    /// The joint error terms of the model ([`crate::joint_law`]).
    pub joint_terms: JointTerms,
    /// Their identified values, in the order of
    /// [`JointTerms::unknown_names`] (1/rad, rad). Not serialised: the
    /// values are in `unknowns` by name.
    #[serde(skip)]
    pub joint_term_values: Vec<f64>,
    /// Span of each actuated coordinate's gravity torque (N.m, or N for a
    /// prismatic one) over the identification poses, with the mass table's
    /// payload: the torques over which the compliances were identified.
    /// Empty for the geometric model.
    pub torque_ranges: Vec<CoordinateCoverage>,
    /// Names of the actuated coordinates, in the order of q, of
    /// `torque_ranges` and of `actuated_ranges`.
    pub actuated_names: Vec<String>,
    /// What the identification poses cover of each actuated coordinate
    /// (rad or m; [`crate::Calibration::actuated_ranges`]): poses outside
    /// it are extrapolations.
    pub actuated_ranges: Vec<CoordinateCoverage>,
    /// Names of the stations (placements of the instrument) of the
    /// identification set, in order ([`TargetMeasurementSet::pooled`]).
    pub station_names: Vec<String>,
    /// Identified measurement frames of the second and later stations
    /// (`x_meas_base` is the first's); empty with one station.
    pub station_frames: Vec<Isometry3<f64>>,
}

impl TargetCalibration {
    /// The identified measurement frame of every station, the first's
    /// ([`TargetCalibration::x_meas_base`]) first.
    pub fn measurement_frames(&self) -> Vec<Isometry3<f64>> {
        std::iter::once(self.x_meas_base)
            .chain(self.station_frames.iter().copied())
            .collect()
    }
}

impl TargetCalibration {
    fn with_status(&self, status: UnknownStatus) -> Vec<&str> {
        self.unknowns
            .iter()
            .filter(|u| u.status == status)
            .map(|u| u.name.as_str())
            .collect()
    }
    /// Names of the unknowns the data cannot separate from others (exact dependencies).
    pub fn non_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::NonIdentifiable)
    }
    /// Names of the unknowns seen too weakly (standard error beyond its limit).
    pub fn poorly_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::PoorlyIdentifiable)
    }
    /// Number of identified unknowns.
    pub fn rank(&self) -> usize {
        self.with_status(UnknownStatus::Identified).len()
    }

    /// Indices of the actuated coordinates at which `q` (rad or m) lies
    /// outside [`TargetCalibration::actuated_ranges`], as
    /// [`crate::Calibration::outside_training_range`].
    pub fn outside_training_range<'a>(&'a self, q: &'a [f64]) -> impl Iterator<Item = usize> + 'a {
        crate::coverage::outside(&self.actuated_ranges, q)
    }

    /// What the targets could not identify, in sentences for a report:
    /// robot parameters and target offsets left at their starting values,
    /// each with the identified unknowns that absorb it.
    pub fn identifiability_notes<'a>(&'a self) -> Vec<String> {
        let mut notes = Vec::new();
        let absorbed_by = |name: &str| -> Vec<String> {
            self.combinations
                .iter()
                .filter(|c| c.terms.iter().any(|(n, k)| n == name && k.abs() >= 1e-3))
                .map(|c| c.name.clone())
                .collect()
        };
        let describe = |names: &[&str]| -> String {
            names
                .iter()
                .map(|n| {
                    let by = absorbed_by(n);
                    if by.is_empty() {
                        n.to_string()
                    } else {
                        format!("{n} (in {})", by.join(", "))
                    }
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let np = self.xi.len();
        let robot: Vec<&str> = self.unknowns[..np]
            .iter()
            .filter(|u| u.status == UnknownStatus::NonIdentifiable)
            .map(|u| u.name.as_str())
            .collect();
        if !robot.is_empty() {
            notes.push(format!(
                "{} of {np} robot parameters cannot be told apart from others by these targets and stay at nominal: {}",
                robot.len(),
                describe(&robot)
            ));
        }
        for t in &self.targets {
            let prefix = format!("target.{}.", t.name);
            let blind: Vec<&str> = self
                .unknowns
                .iter()
                .filter(|u| u.name.starts_with(&prefix))
                .filter(|u| u.status == UnknownStatus::NonIdentifiable)
                .map(|u| u.name.as_str())
                .collect();
            if !blind.is_empty() {
                notes.push(format!(
                    "target `{}` on frame `{}`: offset not separable from the robot along {}; it stays at its nominal value",
                    t.name,
                    t.frame,
                    describe(&blind)
                ));
            }
        }
        // The elastic and joint terms have their own sentences below.
        let geometric = |names: Vec<&'a str>| -> Vec<&'a str> {
            names
                .into_iter()
                .filter(|n| !is_elastic_unknown(n))
                .collect()
        };
        let unseen = geometric(self.with_status(UnknownStatus::NoInfluence));
        if !unseen.is_empty() {
            notes.push(format!(
                "no measured target moves with these, they stay at nominal: {}",
                unseen.join(", ")
            ));
        }
        let poor = geometric(self.poorly_identifiable());
        if !poor.is_empty() {
            notes.push(format!(
                "seen too weakly by these poses (standard error beyond its limit), kept at the starting value: {}",
                poor.join(", ")
            ));
        }
        notes.extend(weak_spread_note(
            self.unknowns
                .iter()
                .enumerate()
                .filter(|(j, u)| *j < np || u.name.starts_with("target."))
                .map(|(_, u)| u),
        ));
        let frame: Vec<&str> = self.unknowns[np..np + 6]
            .iter()
            .filter(|u| u.status == UnknownStatus::NonIdentifiable)
            .map(|u| u.name.as_str())
            .collect();
        if !frame.is_empty() {
            notes.push(format!(
                "measurement frame components absorbed by the robot's base parameters: {}",
                frame.join(", ")
            ));
        }
        if self.elastic.is_some() {
            notes.extend(elastic_notes(
                &self.unknowns,
                &self.actuated_names,
                &self.torque_ranges,
                self.joint_terms.law.is_some(),
            ));
        }
        notes
    }

    /// The true value of each identified combination `x_B + K x_N` given a
    /// full vector of true unknowns (`truth`, indexed like
    /// [`TargetCalibration::unknowns`]): `(name, true combination value,
    /// identified value, standard error)`. Absorbed unknowns stay at their
    /// starting values in the fit, so only their true deviation from there
    /// is absorbed.
    pub fn combination_check(&self, truth: &[f64]) -> Vec<(String, f64, f64, Option<f64>)> {
        let index = |name: &str| self.unknowns.iter().position(|u| u.name == name);
        self.combinations
            .iter()
            .filter_map(|c| {
                let jb = index(&c.name)?;
                let mut value = *truth.get(jb)?;
                for (other, k) in &c.terms {
                    let jn = index(other)?;
                    value += k * (truth.get(jn)? - self.unknowns[jn].value);
                }
                let u = &self.unknowns[jb];
                Some((u.name.clone(), value, u.value, u.standard_error))
            })
            .collect()
    }

    /// The calibrated robot description (mm, deg).
    ///
    /// # Errors
    /// [`CalibError::Description`].
    pub fn description(&self, model: &Model) -> Result<RobotDescription, CalibError> {
        let mut d = model
            .description_with_params(&self.xi)
            .map_err(CalibError::Description)?;
        let note = format!(
            "Calibrated by flexcal from {} poses of {} targets: {} of {} unknowns identified.",
            self.n_poses,
            self.targets.len(),
            self.rank(),
            self.unknowns.len()
        );
        d.notes = if d.notes.is_empty() {
            note
        } else {
            format!("{} {note}", d.notes)
        };
        Ok(d)
    }
}

/// The Jacobians of the targets of one pose
/// ([`frame_points_jacobians_into`]), one entry per target of the set.
struct PointJacobians {
    params: Vec<DMatrix<f64>>,
    joints: Vec<Matrix6xX<f64>>,
    poses: Vec<Isometry3<f64>>,
}

impl PointJacobians {
    fn new(model: &Model, targets: usize) -> Self {
        Self {
            params: vec![DMatrix::zeros(6, model.n_params()); targets],
            joints: vec![Matrix6xX::zeros(model.n_actuated()); targets],
            poses: vec![Isometry3::identity(); targets],
        }
    }
}

/// The stacked position residuals of every observation.
struct TargetErrorModel<'a> {
    model: &'a Model,
    set: &'a TargetMeasurementSet,
    /// Per target: frame index, on the TCP, first unknown of its offset.
    frames: Vec<(usize, bool, Option<usize>)>,
    /// (pose, target) of each block of three rows.
    rows: Vec<(usize, usize)>,
    /// Starting measurement frame of each station (at least the set's
    /// stations; more give the unknowns of a calibration with that many,
    /// with zero columns).
    x_meas_base0: Vec<Isometry3<f64>>,
    /// First unknown of the second station's frame (after the targets').
    stations_offset: usize,
    names: Vec<String>,
    data: RefCell<Data>,
    /// Per target of a pose: parameter and joint Jacobians, pose.
    jacobians: RefCell<PointJacobians>,
    /// Where the elastic and joint-term unknowns start (after the targets').
    elastic_offset: usize,
    /// The elastic and joint terms (none when geometric).
    elastic: ElasticTerms,
    /// Per target, the lateral joints that move it
    /// ([`ElasticTerms::lateral_mask`] of its frame).
    lateral_masks: Vec<Vec<bool>>,
    deflection: RefCell<JointState>,
    twists: RefCell<Matrix6xX<f64>>,
}

impl<'a> TargetErrorModel<'a> {
    fn new(
        model: &'a Model,
        set: &'a TargetMeasurementSet,
        x_meas_base0: &[Isometry3<f64>],
    ) -> Result<Self, CalibError> {
        if x_meas_base0.len() < set.n_stations() {
            return Err(CalibError::InvalidOption {
                name: "station_frames",
                reason: format!(
                    "{} measurement frames for the {} stations of {}",
                    x_meas_base0.len(),
                    set.n_stations(),
                    set.source
                ),
            });
        }
        let mut names: Vec<String> = model.params().iter().map(|p| p.name.clone()).collect();
        names.extend(FRAME_PARAMETER_NAMES.iter().map(|s| s.to_string()));
        let mut frames = Vec::with_capacity(set.targets().len());
        for t in set.targets() {
            let on_tcp = t.frame == TCP_FRAME;
            let index = if on_tcp {
                model.end_frame()
            } else {
                model
                    .frame_index(&t.frame)
                    .ok_or_else(|| CalibError::BadMeasurement {
                        source_name: set.source.clone(),
                        line: 0,
                        what: format!(
                            "target `{}`: robot `{}` has no frame `{}` (frames: {}, or `{TCP_FRAME}`)",
                            t.name,
                            model.name(),
                            t.frame,
                            model.frame_names().join(", ")
                        ),
                    })?
            };
            let offset = (t.treatment == FrameTreatment::Identify).then(|| {
                let start = names.len();
                names.extend(target_unknown_names(&t.name));
                start
            });
            frames.push((index, on_tcp, offset));
        }
        let rows = set
            .poses()
            .iter()
            .enumerate()
            .flat_map(|(k, p)| {
                p.observations
                    .iter()
                    .enumerate()
                    .filter(|(_, o)| o.is_some())
                    .map(move |(t, _)| (k, t))
            })
            .collect();
        // The frames of the second and later stations follow the targets'
        // offsets, as for one target ([`crate::error_model::station_frame_names`]).
        let stations_offset = names.len();
        for s in 1..x_meas_base0.len() {
            names.extend(station_frame_names(s));
        }
        Ok(Self {
            model,
            set,
            frames,
            rows,
            x_meas_base0: x_meas_base0.to_vec(),
            stations_offset,
            elastic_offset: names.len(),
            names,
            data: RefCell::new(Data::new(model)),
            jacobians: RefCell::new(PointJacobians::new(model, set.targets().len())),
            elastic: ElasticTerms::none(model),
            lateral_masks: Vec::new(),
            deflection: RefCell::new(JointState::new(model.n_actuated())),
            twists: RefCell::new(Matrix6xX::zeros(0)),
        })
    }

    /// Makes the model elasto-geometric: joint springs under `gravity` and
    /// the joint terms, their unknowns after the targets' in the order of
    /// the one-target model ([`crate::GeometricErrorModel::with_gravity`],
    /// [`crate::GeometricErrorModel::with_joint_terms`]).
    fn with_elastic(
        mut self,
        gravity: Option<&GravityCompliance>,
        terms: &JointTerms,
    ) -> Result<Self, CalibError> {
        let label = |k: usize| self.set.poses()[k].label(k);
        let poses = Configurations {
            q: self.set.poses().iter().map(|p| p.q.as_slice()).collect(),
            label: &label,
        };
        if let Some(gravity) = gravity {
            self.elastic.add_gravity(self.model, &poses, gravity)?;
            self.lateral_masks = self
                .frames
                .iter()
                .map(|&(frame, _, _)| self.elastic.lateral_mask(self.model, frame))
                .collect();
            self.names.extend(gravity.elastic_unknown_names(self.model));
        }
        if terms.any() {
            self.elastic.add_joint_terms(self.model, &poses, terms)?;
            self.names.extend(terms.unknown_names(self.model));
        }
        self.twists = RefCell::new(Matrix6xX::zeros(self.elastic.len()));
        Ok(self)
    }

    /// The lateral joints that move target `t` (empty without lateral
    /// terms).
    fn lateral_mask(&self, t: usize) -> &[bool] {
        self.lateral_masks.get(t).map_or(&[], Vec::as_slice)
    }

    /// The actuated coordinates at which the robot is evaluated for pose
    /// `k`, with their derivatives, into `state`: the measured ones, moved
    /// by the joint deflections and errors.
    fn deflect(&self, x: &[f64], k: usize, state: &mut JointState) {
        self.elastic
            .deflect(&x[self.elastic_offset..], k, &self.set.poses()[k].q, state);
    }

    /// The pose `x_base_point` of target `t` at pose `k` from the robot
    /// evaluated at `q` (the deflected coordinates), moved by the lateral
    /// rotations that reach it.
    fn moved_point(
        &self,
        x: &[f64],
        k: usize,
        t: usize,
        x_base_point: Isometry3<f64>,
    ) -> Isometry3<f64> {
        match self
            .elastic
            .lateral_motion(&x[self.elastic_offset..], k, self.lateral_mask(t))
        {
            Some(motion) => {
                Isometry3::from_parts(Translation3::from(motion.translation), motion.rotation)
                    * x_base_point
            }
            None => x_base_point,
        }
    }

    fn frame_offset(&self) -> usize {
        self.model.n_params()
    }

    /// Index of the first measurement-frame unknown of station `s`.
    fn station_frame_offset(&self, s: usize) -> usize {
        if s == 0 {
            self.frame_offset()
        } else {
            self.stations_offset + 6 * (s - 1)
        }
    }

    /// Every measurement-frame unknown, station by station.
    fn frame_columns(&self) -> Vec<usize> {
        (0..self.x_meas_base0.len())
            .flat_map(|s| {
                let o = self.station_frame_offset(s);
                o..o + 6
            })
            .collect()
    }

    /// The station of observation row `row`.
    fn station_of_row(&self, row: usize) -> usize {
        self.set.station_of(self.rows[row].0)
    }

    fn kinds(&self) -> Vec<UnknownKind> {
        let mut kinds: Vec<UnknownKind> = self
            .model
            .params()
            .iter()
            .map(|p| match p.kind {
                ParamKind::Length => UnknownKind::Length,
                ParamKind::Angle => UnknownKind::Angle,
            })
            .collect();
        kinds.extend([UnknownKind::Length; 3]);
        kinds.extend([UnknownKind::Angle; 3]);
        // The targets' offsets (lengths), then the later stations' frames.
        kinds.resize(self.stations_offset, UnknownKind::Length);
        for _ in 1..self.x_meas_base0.len() {
            kinds.extend([UnknownKind::Length; 3]);
            kinds.extend([UnknownKind::Angle; 3]);
        }
        kinds.extend(self.elastic.kinds());
        kinds
    }

    fn initial_unknowns(&self) -> Vec<f64> {
        let mut x = self.model.nominal_params().to_vec();
        x.resize(self.elastic_offset, 0.0);
        x.extend(self.elastic.initial());
        x
    }

    /// The measurement frame of station `s` at `x`.
    fn x_meas_base(&self, x: &[f64], s: usize) -> Isometry3<f64> {
        let f = self.station_frame_offset(s);
        let start = &self.x_meas_base0[s];
        Isometry3::from_parts(
            Translation3::from(start.translation.vector + Vector3::new(x[f], x[f + 1], x[f + 2])),
            rotation_from_vector(&Vector3::new(x[f + 3], x[f + 4], x[f + 5])) * start.rotation,
        )
    }

    /// The measurement frame of every station at `x`.
    fn station_frames(&self, x: &[f64]) -> Vec<Isometry3<f64>> {
        (0..self.x_meas_base0.len())
            .map(|s| self.x_meas_base(x, s))
            .collect()
    }

    /// The offset of target `t` at `x` (m).
    fn offset(&self, x: &[f64], t: usize) -> Vector3<f64> {
        let nominal = self.set.targets()[t].offset;
        match self.frames[t].2 {
            Some(o) => nominal + Vector3::new(x[o], x[o + 1], x[o + 2]),
            None => nominal,
        }
    }

    fn point(&self, x: &[f64], t: usize) -> Isometry3<f64> {
        target_point(&self.model.tool(), self.frames[t].1, &self.offset(x, t))
    }

    fn kinematics_error(
        &self,
        k: usize,
    ) -> impl FnOnce(flexcal_kinematics::KinematicsError) -> CalibError {
        let pose_id = self.set.poses()[k].label(k);
        move |source| CalibError::Kinematics {
            pose: k,
            pose_id,
            source,
        }
    }

    /// Predicted position of every observation in M (m), in row order.
    fn predict(&self, x: &[f64]) -> Result<Vec<Vector3<f64>>, CalibError> {
        let xi = &x[..self.model.n_params()];
        let frames = self.station_frames(x);
        let mut data = self.data.borrow_mut();
        let mut state = self.deflection.borrow_mut();
        let mut evaluated = None;
        self.rows
            .iter()
            .map(|&(k, t)| {
                // One pass of the forward model per pose, for all its targets.
                if evaluated != Some(k) {
                    self.deflect(x, k, &mut state);
                    forward_frames(self.model, &mut data, &state.q, xi)
                        .map_err(self.kinematics_error(k))?;
                    evaluated = Some(k);
                }
                let x_base_target =
                    data.frame_pose(self.frames[t].0).expect("a checked frame") * self.point(x, t);
                let x_base_target = self.moved_point(x, k, t, x_base_target);
                Ok((frames[self.set.station_of(k)] * x_base_target)
                    .translation
                    .vector)
            })
            .collect()
    }

    fn measured(&self, row: usize) -> &crate::targets::TargetObservation {
        let (k, t) = self.rows[row];
        self.set.poses()[k].observations[t]
            .as_ref()
            .expect("rows hold observed targets only")
    }

    fn errors(&self, x: &[f64]) -> Result<Vec<PoseError>, CalibError> {
        Ok(self
            .predict(x)?
            .iter()
            .enumerate()
            .map(|(row, p)| {
                let position_vector = self.measured(row).position - p;
                PoseError {
                    position: position_vector.norm(),
                    position_vector,
                    orientation: None,
                }
            })
            .collect())
    }

    /// `errors` (in row order) labelled by pose and target.
    fn observation_errors(&self, errors: &[PoseError]) -> Vec<ObservationError> {
        self.rows
            .iter()
            .zip(errors)
            .map(|(&(k, t), e)| ObservationError {
                pose: self.set.poses()[k].label(k),
                target: self.set.targets()[t].name.clone(),
                error: e.position_vector,
            })
            .collect()
    }

    fn per_target(&self, errors: &[PoseError]) -> Vec<TargetErrors> {
        self.set
            .targets()
            .iter()
            .enumerate()
            .map(|(t, target)| {
                let mine: Vec<PoseError> = self
                    .rows
                    .iter()
                    .zip(errors)
                    .filter(|((_, rt), _)| *rt == t)
                    .map(|(_, e)| *e)
                    .collect();
                TargetErrors {
                    target: target.name.clone(),
                    frame: target.frame.clone(),
                    statistics: error_statistics(&mine),
                }
            })
            .collect()
    }
}

impl Residuals for TargetErrorModel<'_> {
    fn n_residuals(&self) -> usize {
        3 * self.rows.len()
    }
    fn n_params(&self) -> usize {
        self.names.len()
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        for (row, p) in self.predict(x)?.iter().enumerate() {
            let r = p - self.measured(row).position;
            out[3 * row..3 * row + 3].copy_from_slice(r.as_slice());
        }
        Ok(())
    }
    fn parameter_name(&self, j: usize) -> String {
        self.names[j].clone()
    }
}

impl Jacobian for TargetErrorModel<'_> {
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        self.jacobian_blocks(x, 0..self.rows.len(), out)
    }
}

impl StackedJacobian for TargetErrorModel<'_> {
    fn n_unknowns(&self) -> usize {
        self.names.len()
    }
    fn rows_per_block(&self) -> usize {
        3
    }
    /// The rows of the observations `blocks` (three each).
    fn jacobian_blocks(
        &self,
        x: &[f64],
        blocks: std::ops::Range<usize>,
        mut out: MatMut<'_, f64>,
    ) -> Result<(), ProblemError> {
        let np = self.model.n_params();
        let xi = &x[..np];
        // Per station: first frame unknown, rotation into M, and the left
        // Jacobian of its rotation vector.
        let stations: Vec<(usize, Matrix3<f64>, Matrix3<f64>)> = (0..self.x_meas_base0.len())
            .map(|s| {
                let fo = self.station_frame_offset(s);
                let r_mb = self
                    .x_meas_base(x, s)
                    .rotation
                    .to_rotation_matrix()
                    .into_inner();
                let jl_phi = left_jacobian(&Vector3::new(x[fo + 3], x[fo + 4], x[fo + 5]));
                (fo, r_mb, jl_phi)
            })
            .collect();
        let mut data = self.data.borrow_mut();
        let mut jacobians = self.jacobians.borrow_mut();
        let PointJacobians {
            params: jacs,
            joints: jqs,
            poses,
        } = &mut *jacobians;
        let mut state = self.deflection.borrow_mut();
        let mut twists = self.twists.borrow_mut();
        let eo = self.elastic_offset;
        let n_elastic = self.elastic.len();
        for j in 0..self.names.len() {
            for i in 0..out.nrows() {
                out[(i, j)] = 0.0;
            }
        }
        let first = blocks.start;
        let mut points: Vec<(usize, Isometry3<f64>)> = Vec::with_capacity(jacs.len());
        let mut start = first;
        // The rows come pose by pose: one pass of the forward model for all
        // the targets of a pose.
        while start < blocks.end {
            let k = self.rows[start].0;
            let end = (start..blocks.end)
                .find(|&r| self.rows[r].0 != k)
                .unwrap_or(blocks.end);
            self.deflect(x, k, &mut state);
            points.clear();
            points.extend(
                self.rows[start..end]
                    .iter()
                    .map(|&(_, t)| (self.frames[t].0, self.point(x, t))),
            );
            frame_points_jacobians_into(
                self.model, &mut data, &state.q, xi, &points, jacs, jqs, poses,
            )
            .map_err(self.kinematics_error(k))?;
            let (fo, r_mb, jl_phi) = stations[self.set.station_of(k)];
            for (i, row) in (start..end).enumerate() {
                let t = self.rows[row].1;
                let row = row - first;
                let (jac, jq, x_base_target) = (&jacs[i], &jqs[i], poses[i]);
                let motion = self
                    .elastic
                    .lateral_motion(&x[eo..], k, self.lateral_mask(t));
                if n_elastic > 0 {
                    self.elastic.twists(
                        &x[eo..],
                        k,
                        self.lateral_mask(t),
                        &state,
                        jq,
                        motion.as_ref(),
                        &x_base_target.translation.vector,
                        &mut twists,
                    );
                }
                // Motions before the lateral rotation G move the point by R_G
                // times their motion.
                let (r_g, p_base) = match &motion {
                    Some(m) => (
                        m.rotation.to_rotation_matrix().into_inner(),
                        m.apply(&x_base_target.translation.vector),
                    ),
                    None => (Matrix3::identity(), x_base_target.translation.vector),
                };
                let r_mbg = r_mb * r_g;
                let r0 = 3 * row;
                // Robot parameters: the linear rows of the point's Jacobian, into M.
                for j in 0..np {
                    let dp = r_mbg * Vector3::new(jac[(0, j)], jac[(1, j)], jac[(2, j)]);
                    for i in 0..3 {
                        out[(r0 + i, j)] = dp[i];
                    }
                }
                // Elastic and joint terms: the linear rows of their twists at
                // the point.
                for e in 0..n_elastic {
                    let c = twists.column(e);
                    let dp = r_mbg * Vector3::new(c[0], c[1], c[2]);
                    for i in 0..3 {
                        out[(r0 + i, eo + e)] = dp[i];
                    }
                }
                // Measurement frame: translation, then the left rotation vector.
                let d_rot = -skew(&(r_mb * p_base)) * jl_phi;
                // Target offset: along the axes of the target's frame.
                let d_offset = r_mbg * x_base_target.rotation.to_rotation_matrix().into_inner();
                for i in 0..3 {
                    for c in 0..3 {
                        out[(r0 + i, fo + c)] = if i == c { 1.0 } else { 0.0 };
                        out[(r0 + i, fo + 3 + c)] = d_rot[(i, c)];
                        if let Some(o) = self.frames[t].2 {
                            out[(r0 + i, o + c)] = d_offset[(i, c)];
                        }
                    }
                }
            }
            start = end;
        }
        Ok(())
    }
}

/// What the spread reference of a multi-target identification needs.
struct SpreadReference<'a> {
    model: &'a Model,
    set: &'a TargetMeasurementSet,
    options: &'a CalibrationOptions,
    /// What the identification poses cover of each actuated coordinate.
    actuated_ranges: &'a [CoordinateCoverage],
    /// Starting measurement frame of each station.
    x_meas_base0: &'a [Isometry3<f64>],
    context: &'a AnalysisContext<'a>,
}

/// [`UnknownEstimate::spread_ratio`] of each unknown of `identified`, as
/// for one target ([`crate::calibrate`]): its standard error with these
/// observations over the one that as many poses spread over the joint
/// ranges, every target seen at each, would give with the same noise
/// (`reduced`: the identification's factor at `x`). `None` everywhere when
/// no reference can be drawn or it cannot separate them either.
fn spread_ratios(
    reference: &SpreadReference<'_>,
    reduced: &faer::Mat<f64>,
    x: &[f64],
    identified: &[usize],
) -> Result<Vec<Option<f64>>, CalibError> {
    let SpreadReference {
        model,
        set,
        options,
        actuated_ranges,
        x_meas_base0,
        context,
    } = *reference;
    let none = vec![None; reduced.ncols()];
    let Some(training) = unit_covariance_diagonal(reduced, identified) else {
        return Ok(none);
    };
    let weight = rms_row_weights(context.weights, 3);
    let count = set.len().min(SPREAD_REFERENCE_POSES);
    let Some(configurations) = spread_configurations(model, actuated_ranges, count, x) else {
        return Ok(none);
    };
    let poses = configurations
        .into_iter()
        .map(|q| TargetPose {
            pose_id: None,
            q,
            observations: vec![Some(TargetObservation::new(Vector3::zeros())); set.targets().len()],
        })
        .collect();
    // The spread poses are shared out among the stations, each of which
    // then sees as many as its frame needs.
    let stations = set.n_stations();
    if count < stations {
        return Ok(none);
    }
    let spread = TargetMeasurementSet::new("spread reference", set.targets().to_vec(), poses)?
        .with_stations(
            set.station_names().to_vec(),
            (0..count).map(|k| k % stations).collect(),
        )?;
    let problem = TargetErrorModel::new(model, &spread, x_meas_base0)?
        .with_elastic(options.gravity.as_ref(), &options.joint_terms)?;
    let weights: Vec<f64> = (0..problem.n_residuals()).map(|i| weight[i % 3]).collect();
    let spread_context = AnalysisContext {
        problem: &problem,
        weights: &weights,
        ..*context
    };
    Ok(spread_ratio_values(
        &training,
        &spread_context.reduced(x)?,
        identified,
        count as f64 / set.len() as f64,
    ))
}

/// Options of [`CalibrationOptions`] that the multi-target identification
/// does not take (it fits positions only, by Levenberg-Marquardt).
fn check_supported(options: &CalibrationOptions) -> Result<(), CalibError> {
    options.check()?;
    let unsupported = |name: &'static str| CalibError::InvalidOption {
        name,
        reason: "not available with several targets (positions only, Levenberg-Marquardt)".into(),
    };
    if options.use_orientation == Some(true) {
        return Err(unsupported("use_orientation"));
    }
    if options.method != Method::LevenbergMarquardt {
        return Err(unsupported("method"));
    }
    if options.target_value.is_some() || options.target == FrameTreatment::Fixed {
        return Err(CalibError::InvalidOption {
            name: "target",
            reason: "with several targets each target's offset is fixed or identified in the targets description".into(),
        });
    }
    Ok(())
}

/// Identifies the robot parameters, the measurement frame (unless fixed)
/// and the offsets of the identified targets from every target on every
/// pose, with the elasto-geometric terms when `options.gravity` (and
/// `options.joint_terms`) ask for them (see the module docs). The options
/// are those of [`crate::calibrate`]: `fixed` and `deferred` take robot,
/// `frame_*`, `target.<name>.*` and elastic names; orientation and
/// Gauss-Newton are refused with a named error (positions only).
///
/// # Errors
/// Mismatched coordinates, a target on an unknown frame, unknown names in
/// `fixed`/`deferred`, an unsupported option, too few observations, a
/// degenerate registration, a model failure at a pose, a solver failure,
/// [`CalibError::RankDeficient`] when `require_full_rank` is set,
/// [`CalibError::NothingToIdentify`].
pub fn calibrate_targets(
    model: &Model,
    set: &TargetMeasurementSet,
    options: &CalibrationOptions,
) -> Result<TargetCalibration, CalibError> {
    check_supported(options)?;
    check_coordinates(model, set)?;
    let frame_fixed = options.measurement_frame == FrameTreatment::Fixed;
    // Each station's measurement frame starts from the registration of the
    // nominal predictions onto its measurements (the first station's from
    // `measurement_frame_value` when given; the identity when fixed).
    let stations = set.n_stations();
    let identity = TargetErrorModel::new(model, set, &vec![Isometry3::identity(); stations])?;
    // The nominal predictions, only when some frame is registered.
    let predicted = if frame_fixed {
        Vec::new()
    } else {
        identity.predict(&identity.initial_unknowns())?
    };
    // A station without observations (a subset of the poses, as the
    // selection's folds and each station held out make) has zero columns;
    // its frame starts where the first registered one does.
    let registered = (0..stations)
        .map(|s| match (frame_fixed, options.measurement_frame_value) {
            (_, Some(x)) if s == 0 => Ok(Some(x)),
            (true, _) => Ok(Some(Isometry3::identity())),
            (false, _) => {
                let rows: Vec<usize> = (0..identity.rows.len())
                    .filter(|&r| identity.station_of_row(r) == s)
                    .collect();
                if rows.is_empty() {
                    return Ok(None);
                }
                let measured: Vec<Vector3<f64>> = rows
                    .iter()
                    .map(|&r| identity.measured(r).position)
                    .collect();
                let predicted: Vec<Vector3<f64>> = rows.iter().map(|&r| predicted[r]).collect();
                register_points(&measured, &predicted).map(Some)
            }
        })
        .collect::<Result<Vec<_>, CalibError>>()?;
    let fallback = registered
        .iter()
        .flatten()
        .next()
        .copied()
        .unwrap_or_else(Isometry3::identity);
    let x_meas_base0: Vec<Isometry3<f64>> = registered
        .into_iter()
        .map(|x| x.unwrap_or(fallback))
        .collect();
    let problem = TargetErrorModel::new(model, set, &x_meas_base0)?
        .with_elastic(options.gravity.as_ref(), &options.joint_terms)?;
    let frame_columns = problem.frame_columns();
    let n = problem.names.len();
    let names = problem.names.clone();
    let kinds = problem.kinds();
    let np = model.n_params();
    let fo = problem.frame_offset();
    let eo = problem.elastic_offset;
    let index_of = |name: &String| {
        names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| CalibError::UnknownParameter {
                name: name.clone(),
                known: names.join(", "),
            })
    };
    let mut fixed = vec![false; n];
    for name in &options.fixed {
        fixed[index_of(name)?] = true;
    }
    let mut priorities = vec![0i32; n];
    priorities[fo + 6..eo].fill(1);
    for &j in &frame_columns {
        fixed[j] |= frame_fixed;
        priorities[j] = 2;
    }
    for name in &options.deferred {
        priorities[index_of(name)?] = -1;
    }
    let rows = problem.n_residuals();
    let free_count = fixed.iter().filter(|f| !**f).count();
    if free_count == 0 {
        return Err(CalibError::NothingToIdentify);
    }
    if rows < free_count {
        return Err(CalibError::TooFewPoses {
            poses: set.len(),
            rows,
            unknowns: free_count,
        });
    }
    // Row weights 1/sigma; absolute when the instrument's noise is stated
    // or every observation has its own.
    let from_file = options.weighting == Weighting::FromFile;
    let absolute = options.instrument_noise.is_some()
        || from_file && (0..problem.rows.len()).all(|r| problem.measured(r).position_std.is_some());
    let weights: Vec<f64> = (0..problem.rows.len())
        .flat_map(|r| {
            let (s, _) = observation_std(options, problem.measured(r).position_std, None);
            [1.0 / s.x, 1.0 / s.y, 1.0 / s.z]
        })
        .collect();
    let solve = |x0: &[f64], frozen: &[bool]| -> Result<SolveReport, CalibError> {
        let setup = ProblemSetup {
            row_weights: Some(weights.clone()),
            weights_are_absolute: absolute,
            fixed: frozen.to_vec(),
            column_scaling: ColumnScaling::ColumnNorm,
        };
        let mut solver = LevenbergMarquardt::params().max_iterations(options.max_iterations);
        solver.options.max_evaluations = 20 * options.max_iterations;
        solver.options.cost_tolerance = options.cost_tolerance;
        solver.options.cancel = options.cancel.clone();
        // The law's hardening trades off against the compliance along a
        // curved valley of the cost ([`crate::calibrate`]).
        if options.joint_terms.law.is_some() {
            solver.geodesic_acceleration = Some(GEODESIC_ACCELERATION_LIMIT);
        }
        let mut observer = |_: &IterationState| Control::Continue;
        let report = solver
            .solve(&problem, x0, &setup, &mut observer)
            .map_err(CalibError::optim("multi-target identification"))?;
        if report.termination == Termination::Cancelled {
            return Err(CalibError::Cancelled);
        }
        Ok(report)
    };
    // Frames (measurement frame and offsets) alone first, on the nominal
    // robot (with the starting compliances when elasto-geometric).
    let x_initial = problem.initial_unknowns();
    let mut x_start = x_initial.clone();
    let mut frames_only = vec![true; n];
    frames_only[fo..eo].copy_from_slice(&fixed[fo..eo]);
    if frames_only.iter().any(|f| !f) {
        // Offsets that the nominal robot's own parameters would take over
        // are still separable here: the robot is held at nominal.
        x_start = solve(&x_start, &frames_only)?.x;
    }
    let x_nominal_robot = x_start.clone();
    // Identifiability at the start point and the rounds of the
    // identification, as for one target ([`crate::calibrate`]): unknowns
    // exactly dependent on others whatever the noise, then the base set at
    // the noise level (an unknown whose standard error would exceed its
    // limit stays at its start), the joint terms' limits checked again at
    // the solution.
    let limits: Vec<f64> = kinds
        .iter()
        .map(|&k| options.standard_error_limit(k))
        .collect();
    let context = AnalysisContext {
        problem: &problem,
        weights: &weights,
        names: &names,
        priorities: &priorities,
        limits: &limits,
        rank_tolerance: options.rank_tolerance,
    };
    let reduced_start = context.reduced(&x_start)?;
    // Cyclic errors of a joint whose poses do not cover their period stay
    // at zero ([`crate::calibrate`]).
    let q: Vec<&[f64]> = set.poses().iter().map(|p| p.q.as_slice()).collect();
    let partial_period = crate::joint_law::partial_period_mask_of(model, &q, &names);
    // ... and the compliances of joints gravity barely loads.
    let partial_period = crate::significance::barely_loaded(
        partial_period,
        (&names, model.actuated_names()),
        &problem.elastic.torque_ranges(set.len()),
        options.min_torque_share,
    );
    let noise_at = |x: &[f64], free: usize| noise_level(&problem, &weights, absolute, x, free);
    let excluded = |j: usize| fixed[j];
    let mut solve_rounds = |x0: &[f64], frozen: &[bool]| solve(x0, frozen);
    let RoundsOutcome {
        report,
        frozen,
        exactly_dependent,
        numerical: identifiability,
        judgements,
    } = context.identify_in_rounds(
        &Rounds {
            reduced_start: &reduced_start,
            x_start: &x_start,
            excluded: &excluded,
            partial_period: &partial_period,
            absolute,
            require_full_rank: options.require_full_rank,
            free_count,
            joint_start: eo + problem.elastic.joint_terms_offset().unwrap_or(n - eo),
            kinds: &kinds,
            min_compliance_z: options.min_compliance_z,
        },
        &noise_at,
        &mut solve_rounds,
    )?;
    // What no target moves with (a branch without a marker): its columns
    // are zero.
    let mut no_influence = vec![false; n];
    for &j in &identifiability.non_identifiable {
        no_influence[analysis_index(&identifiability, j, &names)] =
            identifiability.diagnoses[j] == Diagnosis::NoInfluence;
    }
    let x = report.x.clone();
    let identified: Vec<usize> = (0..n).filter(|&j| !frozen[j]).collect();
    let absorbed: Vec<usize> = (0..n)
        .filter(|&j| frozen[j] && !fixed[j] && !no_influence[j])
        .collect();
    let combinations = context.combinations(&reduced_start, &identified, &absorbed)?;
    let actuated_ranges = CoordinateCoverage::of_configurations(model, &q);
    let spread_ratios = if options.spread_reference {
        spread_ratios(
            &SpreadReference {
                model,
                set,
                options,
                actuated_ranges: &actuated_ranges,
                x_meas_base0: &x_meas_base0,
                context: &context,
            },
            &reduced_start,
            &x_start,
            &identified,
        )?
    } else {
        vec![None; n]
    };
    let unknowns = unknown_estimates(
        (&names, &kinds),
        (&x_initial, &report),
        &UnknownFlags {
            fixed: &fixed,
            no_influence: &no_influence,
            frozen: &frozen,
            exactly_dependent: &exactly_dependent,
            judgements: &judgements,
        },
        &spread_ratios,
    );
    let identified_count = frozen.iter().filter(|f| !**f).count();
    let noise = noise_source(
        options,
        absolute,
        noise_at(&x, identified_count)? * options.default_position_std,
    );
    let targets: Vec<Target> = set
        .targets()
        .iter()
        .enumerate()
        .map(|(t, target)| Target {
            offset: problem.offset(&x, t),
            ..target.clone()
        })
        .collect();
    let targets_nominal_robot: Vec<Target> = set
        .targets()
        .iter()
        .enumerate()
        .map(|(t, target)| Target {
            offset: problem.offset(&x_nominal_robot, t),
            ..target.clone()
        })
        .collect();
    let errors_before = problem.errors(&x_nominal_robot)?;
    let errors_after = problem.errors(&x)?;
    let joint_start = eo + problem.elastic.joint_terms_offset().unwrap_or(n - eo);
    let elastic = options
        .gravity
        .as_ref()
        .map(|g| (g.clone(), x[eo..joint_start].to_vec()));
    let observation_errors = problem.observation_errors(&errors_after);
    Ok(TargetCalibration {
        xi: x[..np].to_vec(),
        nominal_xi: model.nominal_params().to_vec(),
        x_meas_base: problem.x_meas_base(&x, 0),
        x_meas_base_initial: x_meas_base0[0],
        x_meas_base_nominal_robot: problem.x_meas_base(&x_nominal_robot, 0),
        station_names: set.station_names().to_vec(),
        station_frames: problem.station_frames(&x)[1..].to_vec(),
        measurement_frame_fixed: frame_fixed,
        targets,
        targets_nominal_robot,
        unknowns,
        identifiability,
        combination_lines: combinations
            .iter()
            .map(|c| c.to_text(1e-3))
            .filter(|l| !l.is_empty())
            .collect(),
        combinations,
        solve: report,
        training_before: error_statistics(&errors_before),
        training_after: error_statistics(&errors_after),
        per_target_before: problem.per_target(&errors_before),
        per_target_after: problem.per_target(&errors_after),
        n_poses: set.len(),
        n_observations: problem.rows.len(),
        data_checks: DataChecks::for_targets(set, &observation_errors),
        noise,
        observation_errors,
        elastic,
        joint_terms: options.joint_terms,
        joint_term_values: x[joint_start..].to_vec(),
        torque_ranges: problem.elastic.torque_ranges(set.len()),
        actuated_names: model.actuated_names().to_vec(),
        actuated_ranges,
    })
}

/// Validation of a multi-target calibration on another set of the same
/// targets: per-target errors of the nominal robot (frames and offsets as
/// fitted for it) and of the calibrated robot and offsets. With
/// `refit_frame` the measurement frame is fitted again on the set (the
/// instrument was moved between the series), for the nominal robot and for
/// the calibrated one alike; otherwise the calibration's frame is used for
/// both (each its own: the one fitted with the nominal robot for the
/// "before").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetValidation {
    /// Errors of all observations with the nominal robot and offsets (before).
    pub before: ErrorStatistics,
    /// Errors of all observations with the calibrated robot and offsets (after).
    pub after: ErrorStatistics,
    /// Per-target errors before.
    pub per_target_before: Vec<TargetErrors>,
    /// Per-target errors after.
    pub per_target_after: Vec<TargetErrors>,
    /// Whether the measurement frame was fitted again on this set.
    pub frame_refitted: bool,
    /// The error of every observation after calibration, pose by pose.
    pub observation_errors: Vec<ObservationError>,
    /// Repeated readings and suspect observations of the validation set
    /// (with the calibrated robot).
    pub data_checks: DataChecks,
    /// Actuated coordinates at which some validation poses leave the
    /// identification poses' range, with the fraction of the poses that do
    /// (the prediction there is an extrapolation), as for one target.
    pub extrapolated_coordinates: Vec<(String, f64)>,
}

/// The multi-target model of `calibration` on `set` (whose targets carry
/// the offsets to use), with the unknowns of the robot `xi`, the
/// measurement frames (`first` for the first station: the calibration's
/// other stations' frames when `set` has its stations, else `first` for
/// every station of `set`) and the identified elastic and joint unknowns
/// (`identified`), or their starting values (the model the identification
/// started from).
fn fitted_model<'a>(
    model: &'a Model,
    calibration: &TargetCalibration,
    set: &'a TargetMeasurementSet,
    xi: &[f64],
    identified: bool,
    first: Isometry3<f64>,
) -> Result<(TargetErrorModel<'a>, Vec<f64>), CalibError> {
    let gravity = calibration.elastic.as_ref().map(|(g, _)| g);
    let frames: Vec<Isometry3<f64>> = if set.n_stations() == 1 + calibration.station_frames.len() {
        std::iter::once(first)
            .chain(calibration.station_frames.iter().copied())
            .collect()
    } else {
        vec![first; set.n_stations()]
    };
    let problem = TargetErrorModel::new(model, set, &frames)?
        .with_elastic(gravity, &calibration.joint_terms)?;
    let mut x = xi.to_vec();
    x.resize(problem.elastic_offset, 0.0);
    if identified {
        if let Some((_, values)) = &calibration.elastic {
            x.extend(values);
        }
        x.extend(&calibration.joint_term_values);
    } else {
        x.extend(problem.elastic.initial());
    }
    Ok((problem, x))
}

/// The position error (m) of every observation of `set` (same targets by
/// name as `calibration`'s, in row order: pose by pose, target by target)
/// predicted by `calibration`: its robot, elastic terms, target offsets and
/// measurement frame (the same instrument, not fitted again). What model
/// selection scores a held-out fold by.
///
/// # Errors
/// Targets that differ from the calibration's by name, mismatched
/// coordinates, a model failure at a pose.
pub fn target_position_errors(
    model: &Model,
    calibration: &TargetCalibration,
    set: &TargetMeasurementSet,
) -> Result<Vec<f64>, CalibError> {
    check_coordinates(model, set)?;
    let calibrated = set.with_targets(fixed_offsets(&calibration.targets))?;
    let (problem, x) = fitted_model(
        model,
        calibration,
        &calibrated,
        &calibration.xi,
        true,
        calibration.x_meas_base,
    )?;
    Ok(problem.errors(&x)?.iter().map(|e| e.position).collect())
}

/// A set with as many coordinates per pose as the robot has actuated.
pub(crate) fn check_coordinates(
    model: &Model,
    set: &TargetMeasurementSet,
) -> Result<(), CalibError> {
    if set.n_actuated() != model.n_actuated() {
        return Err(CalibError::ActuatedCountMismatch {
            source_name: set.source.clone(),
            robot: model.name().to_string(),
            expected: model.n_actuated(),
            found: set.n_actuated(),
        });
    }
    Ok(())
}

/// The targets with their offsets fixed at their values.
fn fixed_offsets(targets: &[Target]) -> Vec<Target> {
    targets
        .iter()
        .map(|t| Target {
            treatment: FrameTreatment::Fixed,
            ..t.clone()
        })
        .collect()
}

/// Evaluates `calibration` on `set` (same targets by name; see
/// [`TargetValidation`]).
///
/// # Errors
/// Targets that differ from the calibration's by name, mismatched
/// coordinates, a model failure at a pose, a solver failure of the frame fit.
pub fn validate_targets(
    model: &Model,
    calibration: &TargetCalibration,
    set: &TargetMeasurementSet,
    refit_frame: bool,
) -> Result<TargetValidation, CalibError> {
    check_coordinates(model, set)?;
    let nominal = set.with_targets(fixed_offsets(&calibration.targets_nominal_robot))?;
    let calibrated = set.with_targets(fixed_offsets(&calibration.targets))?;
    let evaluate = |set: &TargetMeasurementSet,
                    xi: &[f64],
                    identified: bool,
                    x_meas_base: Isometry3<f64>|
     -> Result<
        (ErrorStatistics, Vec<TargetErrors>, Vec<ObservationError>),
        CalibError,
    > {
        let (problem, mut x) = fitted_model(model, calibration, set, xi, identified, x_meas_base)?;
        if refit_frame {
            let mut frozen = vec![true; x.len()];
            for j in problem.frame_columns() {
                frozen[j] = false;
            }
            let setup = ProblemSetup {
                row_weights: None,
                weights_are_absolute: false,
                fixed: frozen,
                column_scaling: ColumnScaling::ColumnNorm,
            };
            let mut observer = |_: &IterationState| Control::Continue;
            x = LevenbergMarquardt::params()
                .max_iterations(100)
                .solve(&problem, &x, &setup, &mut observer)
                .map_err(CalibError::optim("validation frame fit"))?
                .x;
        }
        let errors = problem.errors(&x)?;
        Ok((
            error_statistics(&errors),
            problem.per_target(&errors),
            problem.observation_errors(&errors),
        ))
    };
    let (before, per_target_before, _) = evaluate(
        &nominal,
        &calibration.nominal_xi,
        false,
        calibration.x_meas_base_nominal_robot,
    )?;
    let (after, per_target_after, observation_errors) =
        evaluate(&calibrated, &calibration.xi, true, calibration.x_meas_base)?;
    Ok(TargetValidation {
        before,
        after,
        per_target_before,
        per_target_after,
        frame_refitted: refit_frame,
        data_checks: DataChecks::for_targets(set, &observation_errors),
        observation_errors,
        extrapolated_coordinates: crate::coverage::extrapolated_coordinates(
            model.actuated_names(),
            &calibration.actuated_ranges,
            set.poses().iter().map(|p| p.q.as_slice()),
        ),
    })
}

impl TargetCalibration {
    /// `set` with this identification's targets (their identified offsets,
    /// treated as they were), after checking its coordinates.
    fn with_calibrated_targets(
        &self,
        model: &Model,
        set: &TargetMeasurementSet,
    ) -> Result<TargetMeasurementSet, CalibError> {
        check_coordinates(model, set)?;
        set.with_targets(self.targets.clone())
    }

    /// The model of the identification on `calibrated`
    /// ([`TargetCalibration::with_calibrated_targets`]) and its unknowns:
    /// the offsets' and the measurement frames' at zero increments from
    /// the identified ones, every frame of the identification's stations
    /// (a set of fewer stations gives the others zero columns).
    fn model_on<'a>(
        &self,
        model: &'a Model,
        calibrated: &'a TargetMeasurementSet,
    ) -> Result<(TargetErrorModel<'a>, Vec<f64>), CalibError> {
        let gravity = self.elastic.as_ref().map(|(g, _)| g);
        let problem = TargetErrorModel::new(model, calibrated, &self.measurement_frames())?
            .with_elastic(gravity, &self.joint_terms)?;
        let mut x = self.xi.clone();
        x.resize(problem.elastic_offset, 0.0);
        if let Some((_, values)) = &self.elastic {
            x.extend(values);
        }
        x.extend(&self.joint_term_values);
        if x.len() != self.unknowns.len() {
            return Err(CalibError::InvalidOption {
                name: "accuracy",
                reason: format!(
                    "the error model has {} unknowns, the identification {}",
                    x.len(),
                    self.unknowns.len()
                ),
            });
        }
        Ok((problem, x))
    }
}

impl Predicting for TargetCalibration {
    type Set = TargetMeasurementSet;
    fn configuration(set: &TargetMeasurementSet, k: usize) -> &[f64] {
        &set.poses()[k].q
    }
    fn estimates(&self) -> &[UnknownEstimate] {
        &self.unknowns
    }
    fn covariance(&self) -> Option<&DMatrix<f64>> {
        self.solve.covariance.as_ref()
    }
    fn linearise(
        &self,
        model: &Model,
        set: &TargetMeasurementSet,
    ) -> Result<Linearised, CalibError> {
        let calibrated = self.with_calibrated_targets(model, set)?;
        let (problem, x) = self.model_on(model, &calibrated)?;
        let (jacobian, residuals) = jacobian_and_residuals(&problem, &x)?;
        Ok(Linearised {
            jacobian,
            predicted: (0..problem.rows.len())
                .map(|r| {
                    problem.measured(r).position + Vector3::from_fn(|i, _| residuals[3 * r + i])
                })
                .collect(),
            observed: problem
                .rows
                .iter()
                .map(|&(pose, t)| Observed {
                    pose,
                    target: Some(calibrated.targets()[t].name.clone()),
                })
                .collect(),
        })
    }
    fn predicted_positions(
        &self,
        model: &Model,
        set: &TargetMeasurementSet,
    ) -> Result<Vec<Vector3<f64>>, CalibError> {
        let calibrated = self.with_calibrated_targets(model, set)?;
        let (problem, x) = self.model_on(model, &calibrated)?;
        problem.predict(&x)
    }
    fn residual_variance(&self) -> f64 {
        residual_variance(
            self.training_after.position_rms,
            self.n_observations,
            self.rank(),
        )
    }
    fn measurement_frame(&self) -> Isometry3<f64> {
        self.x_meas_base
    }
    fn training_ranges(&self) -> &[CoordinateCoverage] {
        &self.actuated_ranges
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gravity::LateralCompliance;
    use crate::joint_law::JointLaw;
    use crate::targets::{TargetObservation, TargetPose, read_targets};
    use faer::Mat;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn data_file(name: &str) -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name)
    }

    /// Every column of the multi-target model with the elastic and joint
    /// terms (compliances, payload, lateral compliances of the torso and
    /// both arms, the joint law, cyclic errors) and two stations against
    /// central differences, on the two-armed tree with a marker on each
    /// hand, at unknowns away from the start.
    #[test]
    fn elastic_columns_of_markers_on_two_branches_match_central_differences() {
        let model = RobotDescription::from_toml_file(&data_file("two_arms.toml"))
            .unwrap()
            .build()
            .unwrap();
        let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
        let mut gravity =
            GravityCompliance::from_toml_file(&data_file("two_arms_masses.toml")).unwrap();
        gravity.lateral = LateralCompliance::AboutX;
        let mut rng = ChaCha8Rng::seed_from_u64(0x6664);
        let poses: Vec<TargetPose> = (0..6)
            .map(|k| TargetPose {
                pose_id: Some(format!("p{k}")),
                q: (0..model.n_actuated())
                    .map(|_| rng.random_range(-1.5..1.5))
                    .collect(),
                observations: (0..targets.len())
                    .map(|_| {
                        Some(TargetObservation::new(Vector3::from_fn(|_, _| {
                            rng.random_range(-1.0..1.0)
                        })))
                    })
                    .collect(),
            })
            .collect();
        // Two stations (the later one's frame columns after the offsets).
        let set = TargetMeasurementSet::new("fd", targets, poses)
            .unwrap()
            .with_stations(vec!["a".into(), "b".into()], vec![0, 0, 0, 1, 1, 1])
            .unwrap();
        let terms = JointTerms {
            law: Some(JointLaw::default()),
            cyclic: true,
        };
        let frame = Isometry3::from_parts(
            Translation3::new(2.0, -0.3, 0.4),
            rotation_from_vector(&Vector3::new(0.2, -0.1, 1.9)),
        );
        let second = Isometry3::from_parts(
            Translation3::new(-1.5, 2.0, 0.3),
            rotation_from_vector(&Vector3::new(-0.1, 0.3, -1.1)),
        );
        let problem = TargetErrorModel::new(&model, &set, &[frame, second])
            .unwrap()
            .with_elastic(Some(&gravity), &terms)
            .unwrap();
        let kinds = problem.kinds();
        let n = problem.names.len();
        assert_eq!(kinds.len(), n);
        assert_eq!(problem.initial_unknowns().len(), n);
        // Away from the start, by kind.
        let x: Vec<f64> = problem
            .initial_unknowns()
            .iter()
            .zip(&kinds)
            .map(|(v, kind)| {
                v + match kind {
                    UnknownKind::Length => rng.random_range(-1e-3..1e-3),
                    UnknownKind::Angle => rng.random_range(-1e-3..1e-3),
                    UnknownKind::Compliance => rng.random_range(2e-6..20e-6),
                    UnknownKind::Mass => 0.3,
                    UnknownKind::FirstMoment => rng.random_range(-0.02..0.02),
                    UnknownKind::Hardening => rng.random_range(100.0..500.0),
                }
            })
            .collect();
        let rows = problem.n_residuals();
        let mut analytic = Mat::<f64>::zeros(rows, n);
        problem.jacobian(&x, analytic.as_mut()).unwrap();
        let (mut plus, mut minus) = (vec![0.0; rows], vec![0.0; rows]);
        let mut lateral_seen = vec![false; 2];
        for j in 0..n {
            let h = match kinds[j] {
                UnknownKind::Compliance => 1e-8,
                UnknownKind::Hardening => 1e-2,
                UnknownKind::Mass => 1e-3,
                UnknownKind::FirstMoment => 1e-4,
                _ => 1e-7,
            };
            let mut xp = x.clone();
            xp[j] += h;
            problem.residuals(&xp, &mut plus).unwrap();
            xp[j] -= 2.0 * h;
            problem.residuals(&xp, &mut minus).unwrap();
            let scale = (0..rows)
                .map(|i| analytic[(i, j)].abs())
                .fold(1e-12, f64::max);
            for i in 0..rows {
                let numeric = (plus[i] - minus[i]) / (2.0 * h);
                assert!(
                    (analytic[(i, j)] - numeric).abs() < 1e-6 * scale + 1e-9,
                    "{}: row {i}, analytic {:e}, central difference {numeric:e}",
                    problem.names[j],
                    analytic[(i, j)]
                );
            }
            // The torso's lateral compliance moves both hands; a left-arm
            // one moves the left marker only.
            let moves = |target: usize| {
                problem
                    .rows
                    .iter()
                    .enumerate()
                    .filter(|(_, (_, t))| *t == target)
                    .any(|(row, _)| (0..3).any(|i| analytic[(3 * row + i, j)] != 0.0))
            };
            match problem.names[j].as_str() {
                "lateral_compliance_theta1_x" => {
                    assert!(moves(0) && moves(1));
                    lateral_seen[0] = true;
                }
                "lateral_compliance_thetaL2_x" => {
                    assert!(moves(0) && !moves(1));
                    lateral_seen[1] = true;
                }
                _ => {}
            }
        }
        assert_eq!(lateral_seen, [true, true], "names: {:?}", problem.names);
        // Each frame moves its own station's observations only.
        let frame_rows = |first: usize| -> Vec<usize> {
            (0..rows)
                .filter(|&i| (first..first + 6).any(|j| analytic[(i, j)] != 0.0))
                .map(|i| problem.set.station_of(problem.rows[i / 3].0))
                .collect()
        };
        assert!(
            frame_rows(problem.station_frame_offset(0))
                .iter()
                .all(|&s| s == 0)
        );
        let s2 = problem.station_frame_offset(1);
        assert_eq!(problem.names[s2], "frame_s2_x");
        let seen = frame_rows(s2);
        assert!(!seen.is_empty() && seen.iter().all(|&s| s == 1));
    }
}
