//! The measurement model (7)-(10), (49)-(52) of every identification: each
//! observation is a target, fixed to a frame of the robot, seen at a pose
//! from a station's measurement frame, with its position and, where the
//! target carries one, its orientation.
//!
//! For target t on frame f(t), pose k, station s(k):
//! `x_meas_target = x_meas_base(tau_s) * G_k * x_base_f(q_k + dq_k, xi) *
//! x_f_target(o_t)`, with `G_k` the rigid motion of the lateral
//! compliances that reach f(t) and `dq_k` the joint deflections of
//! [`crate::gravity`] and [`crate::joint_law`] (both the identity without
//! the elasto-geometric terms). A target on [`crate::TCP_FRAME`] sits after
//! the robot's tool transform.
//!
//! ## Threads
//! The residuals, the predictions and the Jacobian run pose by pose, one
//! forward pass (and one deflection, the equilibrium's iteration included)
//! per pose for all its targets. [`ErrorModel::with_threads`] shares the
//! poses between threads: the observations are cut at pose boundaries into
//! contiguous chunks of at least [`MIN_POSES_PER_THREAD`] poses, no more
//! chunks than threads, each written by its own thread into its own rows
//! with its own workspace (the calling thread takes the first chunk, rayon's
//! pool the others). A pose's rows read nothing a previous pose left in a
//! workspace, so every number is the serial evaluation's to the bit. On a
//! machine busier than its cores, waiting for the other threads at every
//! evaluation can cost more than it saves: `Some(1)` there, and wherever
//! several identifications already run side by side.

use std::borrow::Cow;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError, RwLock};

use faer::MatMut;
use flexcal_kinematics::{Data, Model, ParamKind, forward_frames, frame_points_jacobians_into};
use flexcal_optim::{Jacobian, ProblemError, Residuals};
use nalgebra::{DMatrix, Isometry3, Matrix3, Matrix6xX, Translation3, UnitQuaternion, Vector3};

use crate::deflection::Deflection;
use crate::elastic_terms::{ElasticTerms, JointState};
use crate::equilibrium::DeflectionComparison;
use crate::error::CalibError;
use crate::frames::resolve_frame;
use crate::geometry::{
    left_jacobian, left_jacobian_inverse, rotation_from_vector, skew, vector_from_rotation,
};
use crate::gravity::{Configurations, GravityCompliance};
use crate::joint_law::JointTerms;
use crate::measurement::MeasurementSet;
use crate::metrics::PoseError;
use crate::targets::TargetObservation;

/// Names of the six unknowns of the measurement frame `x_meas_base`: a
/// translation (m) added to the starting estimate and a rotation vector (rad)
/// applied on the left of the starting rotation.
pub const FRAME_PARAMETER_NAMES: [&str; 6] = [
    "frame_x", "frame_y", "frame_z", "frame_rx", "frame_ry", "frame_rz",
];

/// Names of the six unknowns of the offset `x_frame_target` of a set's only
/// target: a translation (m, in the target's frame) added to the starting
/// offset and a rotation vector (rad) applied on the right of the starting
/// rotation (identified only when orientations are measured). With several
/// targets each has its own ([`target_unknown_names`]).
pub const TARGET_PARAMETER_NAMES: [&str; 6] = [
    "target_x",
    "target_y",
    "target_z",
    "target_rx",
    "target_ry",
    "target_rz",
];

/// Names of the six offset unknowns of target `name` of a set of `count`
/// targets: [`TARGET_PARAMETER_NAMES`] for a set's only target, else
/// `target.<name>.x|y|z|rx|ry|rz` (m in the target's frame, rad).
pub fn target_unknown_names(name: &str, count: usize) -> [String; 6] {
    if count == 1 {
        TARGET_PARAMETER_NAMES.map(str::to_string)
    } else {
        ["x", "y", "z", "rx", "ry", "rz"].map(|a| format!("target.{name}.{a}"))
    }
}

/// Names of the six measurement-frame unknowns of station `station`
/// (0-based) of a set with several stations: `frame_x..frame_rz` for the
/// first, `frame_s2_x..frame_s2_rz` for the second, and so on.
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

/// Where the frames of an [`ErrorModel`] start: its unknowns are
/// increments on these.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameStarts {
    /// Starting measurement frame `x_meas_base` of each station (at least
    /// the set's stations; more give the model the unknowns of a
    /// calibration with that many, with zero columns).
    pub stations: Vec<Isometry3<f64>>,
    /// Starting pose `x_frame_target` of each target of the set in its
    /// frame (after the tool for a target on [`crate::TCP_FRAME`]).
    pub targets: Vec<Isometry3<f64>>,
    /// Whether each target's orientation rows are fitted (every
    /// observation of the target then carries an orientation).
    pub orientation: Vec<bool>,
    /// Whether each target has rotation unknowns: where its orientation
    /// rows are fitted, and for a set's only target (`target_rx..`, which
    /// one-target reports have always listed); without rows they move
    /// nothing.
    pub rotation: Vec<bool>,
}

impl FrameStarts {
    /// The targets' nominal offsets and rotations from `set`, every
    /// station's frame at `x_meas_base`, and orientations fitted for the
    /// targets that carry them (`use_orientation` `None`), for none
    /// (`Some(false)`) or for all (`Some(true)`).
    ///
    /// # Errors
    /// [`CalibError::BadMeasurement`] when orientations are asked for and a
    /// target carries none.
    pub fn nominal(
        set: &MeasurementSet,
        x_meas_base: Isometry3<f64>,
        use_orientation: Option<bool>,
    ) -> Result<Self, CalibError> {
        let orientation = (0..set.targets().len())
            .map(|t| {
                let carried = set.target_has_orientation(t);
                match use_orientation {
                    Some(true) if !carried => Err(CalibError::BadMeasurement {
                        source_name: set.source.clone(),
                        line: 0,
                        what: format!(
                            "orientation asked for but target `{}` has none (no rx_deg, ry_deg, rz_deg columns)",
                            set.targets()[t].name
                        ),
                    }),
                    Some(used) => Ok(used),
                    None => Ok(carried),
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let single = set.targets().len() == 1;
        Ok(Self {
            stations: vec![x_meas_base; set.n_stations()],
            targets: set.targets().iter().map(|t| t.pose()).collect(),
            rotation: orientation.iter().map(|o| *o || single).collect(),
            orientation,
        })
    }
}

/// What the model keeps of one target.
#[derive(Debug, Clone)]
struct TargetTerms {
    /// Index of its frame in the model.
    frame: usize,
    /// Whether it sits after the tool ([`TCP_FRAME`]).
    on_tcp: bool,
    /// First of its unknowns: 3 for its position, then 3 for its rotation
    /// when it has them.
    unknowns: usize,
    /// Whether it has rotation unknowns.
    rotation: bool,
    /// Starting `x_frame_target`.
    start: Isometry3<f64>,
    /// Whether its orientation rows are fitted.
    orientation: bool,
}

/// One observation: the residual block of a target at a pose.
#[derive(Debug, Clone, Copy)]
struct Block {
    pose: usize,
    target: usize,
}

/// The Jacobians of the targets of one pose
/// ([`frame_points_jacobians_into`]), one entry per target of the set.
struct PointJacobians {
    params: Vec<DMatrix<f64>>,
    joints: Vec<Matrix6xX<f64>>,
    poses: Vec<Isometry3<f64>>,
}

/// What one thread of an evaluation writes into: the kinematics, the
/// targets' Jacobians, the deflected joints and the elastic twists of the
/// pose at hand. Every pose overwrites what it reads, so an observation's
/// rows do not depend on which workspace computed them, nor on the poses
/// it computed before.
struct Workspace {
    data: Data,
    jacobians: PointJacobians,
    deflection: JointState,
    twists: Matrix6xX<f64>,
}

impl Workspace {
    /// A workspace for `count` targets on `model` with `n_elastic`
    /// elastic and joint-term unknowns.
    fn new(model: &Model, count: usize, n_elastic: usize) -> Self {
        Self {
            data: Data::new(model),
            jacobians: PointJacobians {
                params: vec![DMatrix::zeros(6, model.n_params()); count],
                joints: vec![Matrix6xX::zeros(model.n_actuated()); count],
                poses: vec![Isometry3::identity(); count],
            },
            deflection: JointState::new(model.n_actuated()),
            twists: Matrix6xX::zeros(n_elastic),
        }
    }
}

/// Fewest poses per thread of an evaluation: below, handing a share of the
/// poses to another thread costs more than evaluating them (measured on
/// the two-armed robot of the tests, docs/model-selection.md, Speed).
pub const MIN_POSES_PER_THREAD: usize = 25;

/// The stacked measurement model of a set of observations, as a
/// least-squares problem in the unknowns
/// `x = [xi; tau_1; o_1 .. o_T; tau_2 .. tau_S; elastic and joint terms]`:
/// the robot's parameters, the first station's measurement frame (6), each
/// target's offset (3, its translation in its frame, then, where its
/// orientations are fitted and for a set's only target, 3 for a rotation
/// vector on the right of its starting rotation), the later stations' frames
/// ([`station_frame_names`]) and, elasto-geometric
/// ([`ErrorModel::with_elastic`]), the compliances, the payload, the
/// lateral compliances and the joint terms.
///
/// Residual rows per observation: `predicted - measured` position (m) in
/// the station's frame, then, where the target's orientation is fitted,
/// the rotation vector `log(R_pred R_meas^T)` (rad). The Jacobian is exact:
/// the robot part is the parameter Jacobian of `flexcal-kinematics` at the
/// target point ([`frame_points_jacobians_into`]) carried into the
/// measurement frame; the frame parts use the SO(3) left Jacobian; the
/// elastic part carries the joint deflections through the point's joint
/// Jacobian.
pub struct ErrorModel<'a> {
    model: &'a Model,
    set: Cow<'a, MeasurementSet>,
    targets: Vec<TargetTerms>,
    blocks: Vec<Block>,
    /// First residual row of each block, and the number of rows last.
    block_rows: Vec<usize>,
    x_meas_base0: Vec<Isometry3<f64>>,
    /// First unknown of the second station's frame (after the targets').
    stations_offset: usize,
    /// Where the elastic and joint-term unknowns start.
    elastic_offset: usize,
    names: Vec<String>,
    elastic: ElasticTerms,
    /// The loading and joint terms the elastic terms were built from
    /// ([`ErrorModel::with_elastic`]).
    elastic_source: Option<(GravityCompliance, JointTerms)>,
    /// Per target, the lateral joints that move it.
    lateral_masks: Vec<Vec<bool>>,
    robot_columns: AtomicBool,
    /// Per unknown, whether the Jacobian skips its robot or elastic column
    /// (left zero); empty: none skipped.
    frozen_columns: RwLock<Vec<bool>>,
    /// One workspace per thread of an evaluation ([`ErrorModel::with_threads`]):
    /// chunk `c` of the poses uses workspace `c`.
    workspaces: Vec<Mutex<Workspace>>,
}

impl<'a> ErrorModel<'a> {
    /// The model of `set` measured on `model`, its frames starting at
    /// `starts`.
    ///
    /// # Errors
    /// [`CalibError::ActuatedCountMismatch`]; [`CalibError::BadMeasurement`]
    /// for a target on a frame the robot does not have, or orientation rows
    /// for a target without orientations; [`CalibError::InvalidOption`] for
    /// starts that do not match the set.
    pub fn new(
        model: &'a Model,
        set: Cow<'a, MeasurementSet>,
        starts: &FrameStarts,
    ) -> Result<Self, CalibError> {
        check_starts(model, &set, starts)?;
        let mut names: Vec<String> = model.params().iter().map(|p| p.name.clone()).collect();
        names.extend(station_frame_names(0));
        let count = set.targets().len();
        let mut targets = Vec::with_capacity(count);
        for (t, target) in set.targets().iter().enumerate() {
            let (frame, on_tcp) = resolve_frame(
                model,
                &set.source,
                &format!("target `{}`", target.name),
                &target.frame,
            )?;
            let rotation = starts.rotation[t];
            targets.push(TargetTerms {
                frame,
                on_tcp,
                unknowns: names.len(),
                rotation,
                start: starts.targets[t],
                orientation: starts.orientation[t],
            });
            let target_names = target_unknown_names(&target.name, count);
            names.extend_from_slice(&target_names[..if rotation { 6 } else { 3 }]);
        }
        let stations_offset = names.len();
        for s in 1..starts.stations.len() {
            names.extend(station_frame_names(s));
        }
        let mut blocks = Vec::with_capacity(set.n_observations());
        let mut block_rows = vec![0];
        for (k, pose) in set.poses().iter().enumerate() {
            for (t, observation) in pose.observations.iter().enumerate() {
                if observation.is_some() {
                    blocks.push(Block { pose: k, target: t });
                    let rows = if targets[t].orientation { 6 } else { 3 };
                    block_rows.push(block_rows.last().copied().unwrap_or(0) + rows);
                }
            }
        }
        Ok(Self {
            model,
            targets,
            blocks,
            block_rows,
            x_meas_base0: starts.stations.clone(),
            stations_offset,
            elastic_offset: names.len(),
            names,
            elastic: ElasticTerms::none(model),
            elastic_source: None,
            lateral_masks: Vec::new(),
            robot_columns: AtomicBool::new(true),
            frozen_columns: RwLock::new(Vec::new()),
            workspaces: vec![Mutex::new(Workspace::new(model, count, 0))],
            set,
        })
    }

    /// The same model started from other frames (`starts` as for
    /// [`ErrorModel::new`], with the same orientation and rotation flags):
    /// the layout and the elastic terms are kept.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for starts of another layout.
    pub fn restarted(mut self, starts: &FrameStarts) -> Result<Self, CalibError> {
        let same = starts.stations.len() == self.x_meas_base0.len()
            && starts.targets.len() == self.targets.len()
            && self.targets.iter().enumerate().all(|(t, terms)| {
                terms.orientation == starts.orientation[t] && terms.rotation == starts.rotation[t]
            });
        if !same {
            return Err(CalibError::InvalidOption {
                name: "frame_starts",
                reason: "the new starts do not match the model's stations and targets".into(),
            });
        }
        self.x_meas_base0.clone_from(&starts.stations);
        for (terms, start) in self.targets.iter_mut().zip(&starts.targets) {
            terms.start = *start;
        }
        Ok(self)
    }

    /// The model of a one-target set ([`crate::MeasurementSet`]): its
    /// target on the TCP starting at `x_tcp_target`, every station's
    /// measurement frame at `x_meas_base`, orientations fitted when
    /// `use_orientation`.
    ///
    /// # Errors
    /// As [`ErrorModel::new`].
    pub fn one_target(
        model: &'a Model,
        set: &'a MeasurementSet,
        use_orientation: bool,
        x_meas_base: Isometry3<f64>,
        x_tcp_target: Isometry3<f64>,
    ) -> Result<Self, CalibError> {
        let mut starts = FrameStarts::nominal(set, x_meas_base, Some(use_orientation))?;
        starts.targets[0] = x_tcp_target;
        Self::new(model, Cow::Borrowed(set), &starts)
    }

    /// The starting measurement frames of the second and later stations
    /// (without this, as given to [`ErrorModel::new`]). More frames than
    /// the set has stations give the model the unknowns of a calibration
    /// with that many stations (the extra ones have no observation: zero
    /// columns), so that its unknowns line up with that calibration's.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] with fewer frames than the set's
    /// stations beyond the first, or after the elastic terms (their
    /// unknowns come after the frames).
    pub fn with_station_frames(mut self, frames: &[Isometry3<f64>]) -> Result<Self, CalibError> {
        if self.elastic_offset != self.names.len() {
            return Err(CalibError::InvalidOption {
                name: "station_frames",
                reason: "the station frames go before the elastic terms".into(),
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
        self.x_meas_base0.truncate(1);
        self.x_meas_base0.extend_from_slice(frames);
        self.names.truncate(self.stations_offset);
        for s in 1..=frames.len() {
            self.names.extend(station_frame_names(s));
        }
        self.elastic_offset = self.names.len();
        Ok(self)
    }

    /// Makes the model elasto-geometric: joint springs under `gravity`
    /// ([`crate::gravity`]) and the joint terms of [`crate::joint_law`],
    /// their unknowns after the frames' (the compliances, the payload, the
    /// lateral compliances, then the joint terms). The torque of each joint
    /// comes from every weight it carries; each target's joint Jacobian
    /// carries the deflections to it, so a joint of one branch moves that
    /// branch's targets only, and a lateral rotation moves the targets on
    /// frames after its joint.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for a mass on a missing frame,
    /// non-finite values, the stiffness law without gravity;
    /// [`CalibError::Kinematics`] naming a pose.
    pub fn with_elastic(
        mut self,
        gravity: Option<&GravityCompliance>,
        terms: &JointTerms,
    ) -> Result<Self, CalibError> {
        let elastic = self.elastic_terms(gravity, terms)?;
        let mut names = Vec::new();
        if let Some(gravity) = gravity {
            names.extend(gravity.elastic_unknown_names(self.model));
        }
        if terms.any() {
            names.extend(terms.unknown_names(self.model));
        }
        self.lateral_masks = self
            .targets
            .iter()
            .map(|t| elastic.lateral_mask(self.model, t.frame))
            .collect();
        self.elastic = elastic;
        self.elastic_source = gravity.map(|g| (g.clone(), *terms));
        self.names.extend(names);
        let threads = self.threads();
        Ok(self.with_workspaces(threads))
    }

    /// Evaluates the residuals, the predictions and the Jacobian on up to
    /// `threads` threads (`None`: [`std::thread::available_parallelism`];
    /// `Some(0)` counts as 1; default 1, on the calling thread). The
    /// observations are split at pose boundaries into contiguous chunks of
    /// at least [`MIN_POSES_PER_THREAD`] poses, never more chunks than
    /// threads; each chunk runs on its own thread with its own workspace
    /// (the calling thread takes the first). Each observation's rows are
    /// computed by the same code from the same inputs whatever the thread,
    /// so the results are bit-identical to the serial evaluation.
    pub fn with_threads(self, threads: Option<usize>) -> Self {
        let threads = threads
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
            .max(1);
        self.with_workspaces(threads)
    }

    /// The number of threads an evaluation may use
    /// ([`ErrorModel::with_threads`]).
    pub fn threads(&self) -> usize {
        self.workspaces.len()
    }

    /// This model with `count` fresh workspaces.
    fn with_workspaces(mut self, count: usize) -> Self {
        let targets = self.targets.len();
        self.workspaces = (0..count)
            .map(|_| Mutex::new(Workspace::new(self.model, targets, self.elastic.len())))
            .collect();
        self
    }

    /// The observations `blocks` split at pose boundaries into at most
    /// [`ErrorModel::threads`] contiguous chunks of at least
    /// [`MIN_POSES_PER_THREAD`] poses each (one chunk below that).
    fn chunks(&self, blocks: Range<usize>) -> Vec<Range<usize>> {
        if blocks.is_empty() {
            return vec![blocks];
        }
        let first_pose = self.blocks[blocks.start].pose;
        let poses = self.blocks[blocks.end - 1].pose + 1 - first_pose;
        let count = (poses / MIN_POSES_PER_THREAD).clamp(1, self.threads());
        let mut chunks = Vec::with_capacity(count);
        let mut start = blocks.start;
        for c in 1..count {
            // The first observation of the chunk's first pose.
            let pose = first_pose + c * poses / count;
            let end = start + self.blocks[start..blocks.end].partition_point(|b| b.pose < pose);
            chunks.push(start..end);
            start = end;
        }
        chunks.push(start..blocks.end);
        chunks
    }

    /// Runs `work(chunk, workspace, out)` for each chunk of
    /// [`ErrorModel::chunks`] with its output `outs[c]`: the first on the
    /// calling thread, the others as tasks of rayon's pool, each with its
    /// own workspace. The results in chunk order, or the first chunk's
    /// error (that of the first failing pose, as in a serial evaluation).
    fn on_chunks<O: Send, R: Send>(
        &self,
        chunks: &[Range<usize>],
        outs: Vec<O>,
        work: impl Fn(Range<usize>, &mut Workspace, O) -> Result<R, CalibError> + Sync,
    ) -> Result<Vec<R>, CalibError> {
        let run = |c: usize, out: O| {
            let mut workspace = self.workspaces[c]
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            work(chunks[c].clone(), &mut workspace, out)
        };
        let mut outs = outs.into_iter();
        let Some(first) = outs.next() else {
            return Ok(Vec::new());
        };
        if chunks.len() == 1 {
            return Ok(vec![run(0, first)?]);
        }
        let mut results: Vec<Option<Result<R, CalibError>>> =
            std::iter::repeat_with(|| None).take(chunks.len()).collect();
        let (head, tail) = results.split_at_mut(1);
        rayon::in_place_scope(|scope| {
            for ((c, out), slot) in outs.enumerate().zip(tail) {
                let run = &run;
                scope.spawn(move |_| *slot = Some(run(c + 1, out)));
            }
            head[0] = Some(run(0, first));
        });
        results
            .into_iter()
            .map(|r| r.expect("every chunk ran"))
            .collect()
    }

    /// The elastic terms of this model's loading with the deflection
    /// `deflection` instead of its own.
    fn elastic_with(&self, deflection: Deflection) -> Result<Option<ElasticTerms>, CalibError> {
        let Some((gravity, terms)) = &self.elastic_source else {
            return Ok(None);
        };
        let gravity = GravityCompliance {
            deflection,
            ..gravity.clone()
        };
        self.elastic_terms(Some(&gravity), terms).map(Some)
    }

    /// The elastic terms of `gravity` (when elasto-geometric) and `terms`
    /// at this model's poses.
    fn elastic_terms(
        &self,
        gravity: Option<&GravityCompliance>,
        terms: &JointTerms,
    ) -> Result<ElasticTerms, CalibError> {
        let set = &*self.set;
        let label = |k: usize| set.poses()[k].label(k);
        let poses = Configurations {
            q: set.configurations(),
            label: &label,
        };
        let mut elastic = ElasticTerms::none(self.model);
        if let Some(gravity) = gravity {
            elastic.add_gravity(self.model, &poses, gravity)?;
        }
        if terms.any() {
            elastic.add_joint_terms(self.model, &poses, terms)?;
        }
        Ok(elastic)
    }

    /// What the equilibrium changes at the unknowns `x`
    /// ([`crate::equilibrium`]): the predictions with the one step and with
    /// the equilibrium (this model's when it solves it, else the default
    /// tolerance and cap), in the order of the residuals, and per
    /// actuated coordinate the largest torque change of the one step over
    /// the poses with the span of its torque (N.m or N). `None` for a
    /// geometric model.
    ///
    /// # Errors
    /// [`CalibError::EquilibriumNotConverged`] and
    /// [`CalibError::Kinematics`] naming the pose.
    pub(crate) fn compare_deflections(
        &self,
        x: &[f64],
    ) -> Result<Option<DeflectionComparison>, CalibError> {
        let Some((gravity, _)) = &self.elastic_source else {
            return Ok(None);
        };
        let equilibrium = match gravity.deflection {
            d @ Deflection::Equilibrium { .. } => d,
            _ => Deflection::equilibrium(),
        };
        let (Some(one_step), Some(solved)) = (
            self.elastic_with(Deflection::OneStep)?,
            self.elastic_with(equilibrium)?,
        ) else {
            return Ok(None);
        };
        let xb = &x[self.elastic_offset..];
        let na = self.model.n_actuated();
        let mut change = vec![0.0_f64; na];
        let mut span = vec![(f64::INFINITY, f64::NEG_INFINITY); na];
        for k in 0..self.set.len() {
            let (tau, torque_change) = solved.one_step_torque_change(xb, k);
            for i in 0..na {
                change[i] = change[i].max(torque_change[i].abs());
                span[i] = (span[i].0.min(tau[i]), span[i].1.max(tau[i]));
            }
        }
        Ok(Some(DeflectionComparison {
            one_step: self.predict_with(&one_step, x)?,
            equilibrium: self.predict_with(&solved, x)?,
            torque_change: change,
            torque_span: span.iter().map(|(lo, hi)| hi - lo).collect(),
        }))
    }

    /// The measurement set the model predicts.
    pub fn set(&self) -> &MeasurementSet {
        &self.set
    }
    /// Names of all unknowns.
    pub fn names(&self) -> &[String] {
        &self.names
    }
    /// Number of unknowns.
    pub fn n_unknowns(&self) -> usize {
        self.names.len()
    }
    /// Number of observations (residual blocks).
    pub fn n_observations(&self) -> usize {
        self.blocks.len()
    }
    /// `(pose, target)` of observation `i`, in the order of the residuals.
    pub fn observation(&self, i: usize) -> (usize, usize) {
        (self.blocks[i].pose, self.blocks[i].target)
    }
    /// The measured observation `i`.
    pub fn measured(&self, i: usize) -> &TargetObservation {
        let Block { pose, target } = self.blocks[i];
        self.set.poses()[pose].observations[target]
            .as_ref()
            .expect("blocks hold observed targets only")
    }
    /// Residual rows of observation `i` (3, or 6 with its orientation).
    pub fn block_rows(&self, i: usize) -> std::ops::Range<usize> {
        self.block_rows[i]..self.block_rows[i + 1]
    }
    /// Whether target `t`'s orientation rows are fitted.
    pub fn uses_orientation(&self, t: usize) -> bool {
        self.targets[t].orientation
    }
    /// Length, angle, compliance, ... per unknown.
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
        // Measurement frames and target offsets alike: 3 lengths, then 3
        // angles (none for a target without rotation unknowns).
        kinds.resize(self.elastic_offset, UnknownKind::Length);
        for o in (0..self.n_stations()).map(|s| self.station_frame_offset(s)) {
            kinds[o + 3..o + 6].fill(UnknownKind::Angle);
        }
        for target in self.targets.iter().filter(|t| t.rotation) {
            kinds[target.unknowns + 3..target.unknowns + 6].fill(UnknownKind::Angle);
        }
        kinds.extend(self.elastic.kinds());
        kinds
    }
    /// The starting vector: nominal xi, zero frame and offset increments,
    /// the starting elastic unknowns.
    pub fn initial_unknowns(&self) -> Vec<f64> {
        let mut x = self.model.nominal_params().to_vec();
        x.resize(self.elastic_offset, 0.0);
        x.extend(self.elastic.initial());
        x
    }
    /// Index of the first measurement-frame unknown of the first station.
    pub fn frame_offset(&self) -> usize {
        self.model.n_params()
    }
    /// Index of the first measurement-frame unknown of station `s`.
    pub fn station_frame_offset(&self, s: usize) -> usize {
        if s == 0 {
            self.frame_offset()
        } else {
            self.stations_offset + 6 * (s - 1)
        }
    }
    /// Number of measurement frames of the model.
    pub fn n_stations(&self) -> usize {
        self.x_meas_base0.len()
    }
    /// Index of the first offset unknown of target `t`.
    pub fn target_offset(&self, t: usize) -> usize {
        self.targets[t].unknowns
    }
    /// Index one past the last frame unknown: where the elastic and
    /// joint-term unknowns start.
    pub fn frames_end(&self) -> usize {
        self.elastic_offset
    }
    /// Index of the first elastic unknown (the compliances), when the model
    /// has gravity.
    pub fn elastic_offset(&self) -> Option<usize> {
        self.elastic.has_gravity().then_some(self.elastic_offset)
    }
    /// Index of the first lateral compliance, when the model has them.
    pub fn lateral_offset(&self) -> Option<usize> {
        self.elastic
            .lateral_offset()
            .map(|o| self.elastic_offset + o)
    }
    /// Index of the first unknown of the joint terms, when there are any.
    pub fn joint_terms_offset(&self) -> Option<usize> {
        self.elastic
            .joint_terms_offset()
            .map(|o| self.elastic_offset + o)
    }
    /// Span of each actuated coordinate's gravity torque over the poses,
    /// with the starting payload (N.m or N); empty when geometric.
    pub fn torque_ranges(&self) -> Vec<crate::coverage::CoordinateCoverage> {
        self.elastic.torque_ranges(self.set.len())
    }
    /// Whether [`Jacobian::jacobian`] computes the robot-parameter and
    /// elastic columns (default true). With `false` they are zeros and only
    /// the forward model runs per pose: for fits of the frames alone.
    pub fn set_robot_columns(&self, on: bool) {
        self.robot_columns.store(on, Ordering::Relaxed);
    }
    /// The unknowns whose robot-parameter or elastic column
    /// [`Jacobian::jacobian`] may leave at zero (a solver holding them
    /// fixed never reads them); empty (default): every column computed.
    /// The other columns are the same either way.
    pub fn set_frozen_columns(&self, frozen: &[bool]) {
        let mut columns = self
            .frozen_columns
            .write()
            .unwrap_or_else(PoisonError::into_inner);
        columns.clear();
        columns.extend_from_slice(frozen);
    }

    /// The measurement frame `x_meas_base` of station `s` at `x`.
    pub fn station_frame(&self, x: &[f64], s: usize) -> Isometry3<f64> {
        let f = self.station_frame_offset(s);
        let start = &self.x_meas_base0[s];
        Isometry3::from_parts(
            Translation3::from(start.translation.vector + Vector3::new(x[f], x[f + 1], x[f + 2])),
            rotation_from_vector(&Vector3::new(x[f + 3], x[f + 4], x[f + 5])) * start.rotation,
        )
    }
    /// Every station's measurement frame at `x`.
    pub fn station_frames(&self, x: &[f64]) -> Vec<Isometry3<f64>> {
        (0..self.n_stations())
            .map(|s| self.station_frame(x, s))
            .collect()
    }
    /// The pose `x_frame_target` of target `t` in its frame at `x` (after
    /// the tool for a target on the TCP).
    pub fn target_frame(&self, x: &[f64], t: usize) -> Isometry3<f64> {
        let TargetTerms {
            unknowns: o,
            rotation,
            start,
            ..
        } = &self.targets[t];
        let o = *o;
        let turn = if *rotation {
            rotation_from_vector(&Vector3::new(x[o + 3], x[o + 4], x[o + 5]))
        } else {
            UnitQuaternion::identity()
        };
        Isometry3::from_parts(
            Translation3::from(start.translation.vector + Vector3::new(x[o], x[o + 1], x[o + 2])),
            start.rotation * turn,
        )
    }
    /// Number of offset unknowns of target `t`: 3 for its position, 6 with
    /// its rotation (where its orientations are fitted, and for a set's
    /// only target).
    pub fn target_unknowns(&self, t: usize) -> usize {
        if self.targets[t].rotation { 6 } else { 3 }
    }

    /// Each target's point on its frame at `x`: the offset, after the
    /// tool on the TCP.
    fn points(&self, x: &[f64]) -> Vec<Isometry3<f64>> {
        (0..self.targets.len())
            .map(|t| {
                let offset = self.target_frame(x, t);
                if self.targets[t].on_tcp {
                    self.model.tool() * offset
                } else {
                    offset
                }
            })
            .collect()
    }

    fn kinematics_error(
        &self,
        k: usize,
    ) -> impl FnOnce(flexcal_kinematics::KinematicsError) -> CalibError + '_ {
        // The label only when there is an error to name.
        move |source| CalibError::Kinematics {
            pose: k,
            pose_id: self.set.poses()[k].label(k),
            source,
        }
    }

    /// The actuated coordinates of pose `k` moved by the joint deflections
    /// of `elastic`.
    ///
    /// # Errors
    /// [`CalibError::EquilibriumNotConverged`] naming the pose.
    fn deflect(
        &self,
        elastic: &ElasticTerms,
        x: &[f64],
        k: usize,
        state: &mut JointState,
    ) -> Result<(), CalibError> {
        elastic
            .deflect(&x[self.elastic_offset..], k, &self.set.poses()[k].q, state)
            .map_err(|failure| CalibError::EquilibriumNotConverged {
                pose: k,
                pose_id: self.set.poses()[k].label(k),
                iterations: failure.iterations,
                change: failure.change,
                unstable: failure.unstable,
            })
    }

    /// Predicted pose `x_meas_target` of every observation at `x`, in the
    /// order of the residuals.
    ///
    /// # Errors
    /// [`CalibError::Kinematics`] naming the pose.
    pub fn predict(&self, x: &[f64]) -> Result<Vec<Isometry3<f64>>, CalibError> {
        self.predict_with(&self.elastic, x)
    }

    /// [`ErrorModel::predict`] with the elastic terms `elastic`.
    fn predict_with(
        &self,
        elastic: &ElasticTerms,
        x: &[f64],
    ) -> Result<Vec<Isometry3<f64>>, CalibError> {
        let frames = (self.station_frames(x), self.points(x));
        let chunks = self.chunks(0..self.blocks.len());
        let predicted =
            self.on_chunks(&chunks, vec![(); chunks.len()], |blocks, workspace, ()| {
                let mut predicted = Vec::with_capacity(blocks.len());
                self.predict_blocks(elastic, x, &frames, blocks, workspace, |_, p| {
                    predicted.push(p);
                })?;
                Ok(predicted)
            })?;
        Ok(predicted.concat())
    }

    /// The predicted pose `x_meas_target` of the observations `blocks` at
    /// `x`, with the elastic terms `elastic`, each station's frame and each
    /// target's point on its frame (`frames`), handed to `sink` with the
    /// observation's index, in order.
    fn predict_blocks(
        &self,
        elastic: &ElasticTerms,
        x: &[f64],
        (stations, points): &(Vec<Isometry3<f64>>, Vec<Isometry3<f64>>),
        blocks: Range<usize>,
        workspace: &mut Workspace,
        mut sink: impl FnMut(usize, Isometry3<f64>),
    ) -> Result<(), CalibError> {
        let xi = &x[..self.model.n_params()];
        let Workspace {
            data,
            deflection: state,
            ..
        } = workspace;
        let mut evaluated = None;
        for b in blocks {
            let Block { pose: k, target: t } = self.blocks[b];
            // One pass of the forward model per pose, for all its targets.
            if evaluated != Some(k) {
                self.deflect(elastic, x, k, state)?;
                forward_frames(self.model, data, &state.q, xi).map_err(self.kinematics_error(k))?;
                evaluated = Some(k);
            }
            let frame = data
                .frame_pose(self.targets[t].frame)
                .expect("a checked frame");
            let x_base_target = frame * points[t];
            let moved = match elastic.lateral_motion(
                &x[self.elastic_offset..],
                k,
                self.lateral_mask(t),
                state,
            ) {
                Some(m) => {
                    Isometry3::from_parts(Translation3::from(m.translation), m.rotation)
                        * x_base_target
                }
                None => x_base_target,
            };
            sink(b, stations[self.set.station_of(k)] * moved);
        }
        Ok(())
    }

    /// The error `measured - predicted` of every observation at `x`, in the
    /// order of the residuals (the orientation error where fitted).
    ///
    /// # Errors
    /// [`CalibError::Kinematics`] naming the pose.
    pub fn errors(&self, x: &[f64]) -> Result<Vec<PoseError>, CalibError> {
        Ok(self
            .predict(x)?
            .iter()
            .enumerate()
            .map(|(i, predicted)| {
                let measured = self.measured(i);
                let position_vector = measured.position - predicted.translation.vector;
                let orientation = self.targets[self.blocks[i].target]
                    .orientation
                    .then(|| rotation_error(predicted, measured).norm());
                PoseError {
                    position: position_vector.norm(),
                    position_vector,
                    orientation,
                }
            })
            .collect())
    }

    /// The lateral joints that move target `t` (empty without them).
    fn lateral_mask(&self, t: usize) -> &[bool] {
        self.lateral_masks.get(t).map_or(&[], Vec::as_slice)
    }
}

/// `log(R_pred R_meas^T)` (rad) of an observation with an orientation.
fn rotation_error(predicted: &Isometry3<f64>, measured: &TargetObservation) -> Vector3<f64> {
    let r_meas = rotation_from_vector(&measured.orientation.unwrap_or_default());
    vector_from_rotation(&(predicted.rotation * r_meas.inverse()))
}

/// Checks that `starts` match `set` and that `set` matches `model`.
fn check_starts(
    model: &Model,
    set: &MeasurementSet,
    starts: &FrameStarts,
) -> Result<(), CalibError> {
    if set.n_actuated() != model.n_actuated() {
        return Err(CalibError::ActuatedCountMismatch {
            source_name: set.source.clone(),
            robot: model.name().to_string(),
            expected: model.n_actuated(),
            found: set.n_actuated(),
        });
    }
    let count = set.targets().len();
    if starts.stations.len() < set.n_stations()
        || starts.targets.len() != count
        || starts.orientation.len() != count
    {
        return Err(CalibError::InvalidOption {
            name: "frame_starts",
            reason: format!(
                "{} station frames, {} target starts and {} orientation flags for the {} stations and {count} targets of {}",
                starts.stations.len(),
                starts.targets.len(),
                starts.orientation.len(),
                set.n_stations(),
                set.source
            ),
        });
    }
    if starts.rotation.len() != count
        || starts
            .orientation
            .iter()
            .zip(&starts.rotation)
            .any(|(o, r)| *o && !*r)
    {
        return Err(CalibError::InvalidOption {
            name: "frame_starts",
            reason: "every target whose orientations are fitted needs its rotation unknowns".into(),
        });
    }
    for (t, &used) in starts.orientation.iter().enumerate() {
        if used && !set.target_has_orientation(t) {
            return Err(CalibError::BadMeasurement {
                source_name: set.source.clone(),
                line: 0,
                what: format!(
                    "orientation asked for but target `{}` has none",
                    set.targets()[t].name
                ),
            });
        }
    }
    Ok(())
}

impl Residuals for ErrorModel<'_> {
    fn n_residuals(&self) -> usize {
        self.block_rows.last().copied().unwrap_or(0)
    }
    fn n_params(&self) -> usize {
        self.names.len()
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        let frames = (self.station_frames(x), self.points(x));
        let chunks = self.chunks(0..self.blocks.len());
        let mut outs = Vec::with_capacity(chunks.len());
        let mut rest = out;
        for chunk in &chunks {
            let rows = self.block_rows[chunk.end] - self.block_rows[chunk.start];
            let (head, tail) = rest.split_at_mut(rows);
            outs.push(head);
            rest = tail;
        }
        self.on_chunks(&chunks, outs, |blocks, workspace, out| {
            let row0 = self.block_rows[blocks.start];
            self.predict_blocks(
                &self.elastic,
                x,
                &frames,
                blocks,
                workspace,
                |i, predicted| {
                    let measured = self.measured(i);
                    let r0 = self.block_rows[i] - row0;
                    let dp = predicted.translation.vector - measured.position;
                    out[r0..r0 + 3].copy_from_slice(dp.as_slice());
                    if self.targets[self.blocks[i].target].orientation {
                        out[r0 + 3..r0 + 6]
                            .copy_from_slice(rotation_error(&predicted, measured).as_slice());
                    }
                },
            )
        })?;
        Ok(())
    }
    fn parameter_name(&self, j: usize) -> String {
        self.names[j].clone()
    }
}

impl Jacobian for ErrorModel<'_> {
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        self.jacobian_blocks(x, 0..self.blocks.len(), out)
    }
}

/// What the Jacobian needs of one station's measurement frame at the
/// unknowns: its first unknown, its rotation and the left Jacobian of its
/// rotation vector.
#[derive(Clone, Copy)]
struct StationTerms {
    offset: usize,
    quaternion: UnitQuaternion<f64>,
    rotation: Matrix3<f64>,
    jl_phi: Matrix3<f64>,
}

/// What the Jacobian rows of every observation of an evaluation share.
struct JacobianSetup {
    /// Each station's frame terms.
    stations: Vec<StationTerms>,
    /// Each target's point on its frame (after the tool on the TCP).
    points: Vec<Isometry3<f64>>,
    /// Each target's rotation in its frame.
    rotations: Vec<UnitQuaternion<f64>>,
    /// Whether the robot-parameter and elastic columns are computed.
    robot_columns: bool,
    /// Whether the joint Jacobians and elastic twists are computed.
    with_joints: bool,
    /// The twists whose columns are wanted (robot parameters `0..np`,
    /// then elastic unknowns).
    wanted: Vec<usize>,
}

/// What the Jacobian rows of one observation need beyond the model.
struct BlockTerms<'b> {
    /// The target point's parameter and joint Jacobians and pose (before
    /// the lateral motion G).
    jac: &'b DMatrix<f64>,
    twists: &'b Matrix6xX<f64>,
    x_base_point: Isometry3<f64>,
    /// Rotation of the target's frame (after the tool on the TCP), before G.
    r_frame: Matrix3<f64>,
    station: StationTerms,
}

impl ErrorModel<'_> {
    /// The Jacobian rows of the observations `blocks` (row 0 of `out` is
    /// the first row of observation `blocks.start`): for factorisations
    /// that stream the stacked Jacobian instead of holding it whole. On
    /// [`ErrorModel::threads`] threads when `blocks` spans enough poses,
    /// with the same rows to the bit.
    ///
    /// # Errors
    /// [`CalibError::Kinematics`] naming the pose.
    pub fn jacobian_blocks(
        &self,
        x: &[f64],
        blocks: Range<usize>,
        out: MatMut<'_, f64>,
    ) -> Result<(), ProblemError> {
        let setup = self.jacobian_setup(x);
        let chunks = self.chunks(blocks);
        let mut outs = Vec::with_capacity(chunks.len());
        let mut rest = out;
        for chunk in &chunks {
            let rows = self.block_rows[chunk.end] - self.block_rows[chunk.start];
            let (head, tail) = rest.split_at_row_mut(rows);
            outs.push(head);
            rest = tail;
        }
        rest.fill(0.0);
        self.on_chunks(&chunks, outs, |blocks, workspace, out| {
            self.jacobian_chunk(x, &setup, blocks, workspace, out)
        })?;
        Ok(())
    }

    /// What the Jacobian rows of every observation share at `x`.
    fn jacobian_setup(&self, x: &[f64]) -> JacobianSetup {
        let np = self.model.n_params();
        let stations: Vec<StationTerms> = (0..self.n_stations())
            .map(|s| {
                let offset = self.station_frame_offset(s);
                let quaternion = self.station_frame(x, s).rotation;
                StationTerms {
                    offset,
                    quaternion,
                    rotation: quaternion.to_rotation_matrix().into_inner(),
                    jl_phi: left_jacobian(&Vector3::new(
                        x[offset + 3],
                        x[offset + 4],
                        x[offset + 5],
                    )),
                }
            })
            .collect();
        let robot_columns = self.robot_columns.load(Ordering::Relaxed);
        let eo = self.elastic_offset;
        let frozen = self
            .frozen_columns
            .read()
            .unwrap_or_else(PoisonError::into_inner);
        let mut elastic_columns = eo..eo + self.elastic.len();
        // Joint Jacobians and twists only when an elastic column is wanted.
        let with_joints = robot_columns
            && self.elastic.len() > 0
            && (frozen.is_empty() || elastic_columns.any(|j| !frozen[j]));
        // The twists (robot parameters, then elastic unknowns) whose columns
        // are wanted, once for every block.
        let n_twists = if robot_columns {
            np + self.elastic.len()
        } else {
            0
        };
        let wanted: Vec<usize> = (0..n_twists)
            .filter(|&j| frozen.is_empty() || !frozen[if j < np { j } else { eo + j - np }])
            .collect();
        JacobianSetup {
            stations,
            points: self.points(x),
            // Each target's rotation in its frame: the frame's rotation is
            // the point's times its inverse.
            rotations: (0..self.targets.len())
                .map(|t| self.target_frame(x, t).rotation)
                .collect(),
            robot_columns,
            with_joints,
            wanted,
        }
    }

    /// The Jacobian rows of the observations `blocks` into `out` (its row 0
    /// the first row of `blocks.start`), in `workspace`.
    fn jacobian_chunk(
        &self,
        x: &[f64],
        setup: &JacobianSetup,
        blocks: Range<usize>,
        workspace: &mut Workspace,
        mut out: MatMut<'_, f64>,
    ) -> Result<(), CalibError> {
        out.fill(0.0);
        let xi = &x[..self.model.n_params()];
        let Workspace {
            data,
            jacobians:
                PointJacobians {
                    params,
                    joints,
                    poses,
                },
            deflection: state,
            twists,
        } = workspace;
        let eo = self.elastic_offset;
        let row0 = self.block_rows[blocks.start];
        let mut points: Vec<(usize, Isometry3<f64>)> = Vec::with_capacity(params.len());
        let mut start = blocks.start;
        // The blocks come pose by pose: one pass of the forward model for
        // all the targets of a pose.
        while start < blocks.end {
            let k = self.blocks[start].pose;
            let end = (start..blocks.end)
                .find(|&b| self.blocks[b].pose != k)
                .unwrap_or(blocks.end);
            self.deflect(&self.elastic, x, k, state)?;
            points.clear();
            points.extend(
                self.blocks[start..end]
                    .iter()
                    .map(|b| (self.targets[b.target].frame, setup.points[b.target])),
            );
            if setup.robot_columns {
                // Joint Jacobians only for the elastic terms.
                let joints: &mut [Matrix6xX<f64>] =
                    if setup.with_joints { joints } else { &mut [] };
                frame_points_jacobians_into(
                    self.model, data, &state.q, xi, &points, params, joints, poses,
                )
                .map_err(self.kinematics_error(k))?;
            } else {
                forward_frames(self.model, data, &state.q, xi).map_err(self.kinematics_error(k))?;
                for (i, (frame, point)) in points.iter().enumerate() {
                    poses[i] = data.frame_pose(*frame).expect("a checked frame") * point;
                }
            }
            let station = setup.stations[self.set.station_of(k)];
            for (i, b) in (start..end).enumerate() {
                let t = self.blocks[b].target;
                let motion = self
                    .elastic
                    .lateral_motion(&x[eo..], k, self.lateral_mask(t), state);
                if setup.with_joints {
                    self.elastic.twists(
                        &x[eo..],
                        k,
                        self.lateral_mask(t),
                        state,
                        &joints[i],
                        motion.as_ref(),
                        &poses[i].translation.vector,
                        twists,
                    );
                }
                let r_frame = poses[i].rotation * setup.rotations[t].inverse();
                let terms = BlockTerms {
                    jac: &params[i],
                    twists,
                    x_base_point: poses[i],
                    r_frame: r_frame.to_rotation_matrix().into_inner(),
                    station,
                };
                let rows = self.block_rows(b);
                let r0 = rows.start - row0;
                self.block_jacobian(
                    x,
                    (b, &setup.wanted),
                    &terms,
                    motion.as_ref(),
                    out.as_mut().subrows_mut(r0, rows.len()),
                );
            }
            start = end;
        }
        Ok(())
    }

    /// The rows of observation `b` (3 or 6) into `out`, zero on entry: the
    /// robot and elastic columns of the twists `wanted` (robot parameters
    /// `0..np`, then elastic unknowns), the others left at zero.
    fn block_jacobian(
        &self,
        x: &[f64],
        (b, wanted): (usize, &[usize]),
        terms: &BlockTerms<'_>,
        motion: Option<&crate::elastic_terms::LateralMotion>,
        mut out: MatMut<'_, f64>,
    ) {
        let np = self.model.n_params();
        let eo = self.elastic_offset;
        let t = self.blocks[b].target;
        let StationTerms {
            offset: fo,
            quaternion: q_mb,
            rotation: r_mb,
            jl_phi,
        } = terms.station;
        // Motions before the lateral rotation G move the point by R_G times
        // their motion.
        let (r_g, p_base, q_point) = match motion {
            Some(m) => (
                m.rotation.to_rotation_matrix().into_inner(),
                m.apply(&terms.x_base_point.translation.vector),
                m.rotation * terms.x_base_point.rotation,
            ),
            None => (
                Matrix3::identity(),
                terms.x_base_point.translation.vector,
                terms.x_base_point.rotation,
            ),
        };
        let r_mbg = r_mb * r_g;
        // The twist (v at the point, w) of robot parameter or elastic unknown j.
        let twist = |j: usize| -> (usize, Vector3<f64>, Vector3<f64>) {
            if j < np {
                let c = terms.jac.column(j);
                (
                    j,
                    Vector3::new(c[0], c[1], c[2]),
                    Vector3::new(c[3], c[4], c[5]),
                )
            } else {
                let c = terms.twists.column(j - np);
                (
                    eo + j - np,
                    Vector3::new(c[0], c[1], c[2]),
                    Vector3::new(c[3], c[4], c[5]),
                )
            }
        };
        for &j in wanted {
            let (col, v, _) = twist(j);
            let dp = r_mbg * v;
            for i in 0..3 {
                out[(i, col)] = dp[i];
            }
        }
        // Measurement frame: translation, then the left rotation vector.
        let d_rot = -skew(&(r_mb * p_base)) * jl_phi;
        // Target offset: along the axes of the target's frame.
        let to = self.targets[t].unknowns;
        let d_offset = r_mbg * terms.r_frame;
        for i in 0..3 {
            out[(i, fo + i)] = 1.0;
            for c in 0..3 {
                out[(i, fo + 3 + c)] = d_rot[(i, c)];
                out[(i, to + c)] = d_offset[(i, c)];
            }
        }
        if !self.targets[t].orientation {
            return;
        }
        let q_pred = q_mb * q_point;
        let r_pred = q_pred.to_rotation_matrix().into_inner();
        let measured = self.measured(b);
        let residual = vector_from_rotation(
            &(q_pred * rotation_from_vector(&measured.orientation.unwrap_or_default()).inverse()),
        );
        let jinv = left_jacobian_inverse(&residual);
        let map = jinv * r_mbg;
        for &j in wanted {
            let (col, _, w) = twist(j);
            let dr = map * w;
            for i in 0..3 {
                out[(3 + i, col)] = dr[i];
            }
        }
        let d_phi = jinv * jl_phi;
        let psi = Vector3::new(x[to + 3], x[to + 4], x[to + 5]);
        let d_psi = jinv * r_pred * left_jacobian(&psi).transpose();
        for i in 0..3 {
            for c in 0..3 {
                out[(3 + i, fo + 3 + c)] = d_phi[(i, c)];
                out[(3 + i, to + 3 + c)] = d_psi[(i, c)];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gravity::LateralCompliance;
    use crate::joint_law::JointLaw;
    use crate::targets::{TargetPose, read_targets};
    use faer::Mat;
    use flexcal_kinematics::RobotDescription;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn data_file(name: &str) -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name)
    }

    /// Every column of the model of several targets with every elastic and
    /// joint term (compliances, a payload on a link of the right arm, a
    /// further one identified on the left arm and a known one,
    /// lateral compliances of the torso and both arms, the joint law,
    /// cyclic errors), two stations and the left marker's orientations,
    /// against central differences, at unknowns away from the start.
    #[test]
    fn columns_of_oriented_markers_on_two_branches_match_central_differences() {
        let model = RobotDescription::from_toml_file(&data_file("two_arms.toml"))
            .unwrap()
            .build()
            .unwrap();
        let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
        let mut gravity =
            GravityCompliance::from_toml_file(&data_file("two_arms_masses.toml")).unwrap();
        gravity.lateral = LateralCompliance::AboutX;
        gravity.payload_frame = Some("R3".into());
        gravity.payload_center = Vector3::new(0.02, -0.01, 0.05);
        // A further payload on the left arm, identified, and a known one.
        gravity.payloads = vec![
            crate::gravity::Payload {
                name: "left".into(),
                frame: "L3".into(),
                mass: 1.5,
                center: Vector3::new(-0.01, 0.03, 0.07),
                identify: true,
            },
            crate::gravity::Payload {
                name: "tool".into(),
                frame: "tcp".into(),
                mass: 0.7,
                center: Vector3::new(0.0, 0.0, 0.05),
                identify: false,
            },
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(0x6664);
        let poses = random_poses(&model, targets.len(), &mut rng);
        let set = MeasurementSet::from_poses("fd", targets, poses)
            .unwrap()
            .with_stations(vec!["a".into(), "b".into()], vec![0, 0, 0, 1, 1, 1])
            .unwrap();
        let terms = JointTerms {
            law: Some(JointLaw::default()),
            cyclic: true,
        };
        let mut starts = FrameStarts::nominal(&set, Isometry3::identity(), None).unwrap();
        assert_eq!(starts.orientation, [true, false]);
        starts.stations = vec![
            Isometry3::from_parts(
                Translation3::new(2.0, -0.3, 0.4),
                rotation_from_vector(&Vector3::new(0.2, -0.1, 1.9)),
            ),
            Isometry3::from_parts(
                Translation3::new(-1.5, 2.0, 0.3),
                rotation_from_vector(&Vector3::new(-0.1, 0.3, -1.1)),
            ),
        ];
        let problem = ErrorModel::new(&model, Cow::Borrowed(&set), &starts)
            .unwrap()
            .with_elastic(Some(&gravity), &terms)
            .unwrap();
        let kinds = problem.kinds();
        let n = problem.n_unknowns();
        assert_eq!(kinds.len(), n);
        assert!(problem.names().contains(&"target.left.rz".to_string()));
        assert!(!problem.names().contains(&"target.right.rx".to_string()));
        // Away from the start, by kind.
        let x: Vec<f64> = problem
            .initial_unknowns()
            .iter()
            .zip(&kinds)
            .map(|(v, kind)| {
                v + match kind {
                    UnknownKind::Length => rng.random_range(-1e-3..1e-3),
                    UnknownKind::Angle => rng.random_range(-1e-2..1e-2),
                    UnknownKind::Compliance => rng.random_range(2e-6..20e-6),
                    UnknownKind::Mass => 0.3,
                    UnknownKind::FirstMoment => rng.random_range(-0.02..0.02),
                    UnknownKind::Hardening => rng.random_range(100.0..500.0),
                }
            })
            .collect();
        let rows = problem.n_residuals();
        // Six poses: the left marker six rows each, the right one three.
        assert_eq!(rows, 6 * 6 + 6 * 3);
        let mut analytic = Mat::<f64>::zeros(rows, n);
        problem.jacobian(&x, analytic.as_mut()).unwrap();
        let (mut plus, mut minus) = (vec![0.0; rows], vec![0.0; rows]);
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
                    problem.names()[j],
                    analytic[(i, j)]
                );
            }
        }
        frozen_columns_are_skipped(&problem, &x, &analytic);
        frames_move_their_own_station(&problem, &set, &analytic);
    }

    /// The chunks of a threaded evaluation: contiguous, covering the
    /// observations, cut at pose boundaries (a pose whose second target is
    /// missing included), as many as the threads when every chunk keeps
    /// [`MIN_POSES_PER_THREAD`] poses, one below.
    #[test]
    fn chunks_cut_at_pose_boundaries_and_keep_enough_poses() {
        let model = RobotDescription::from_toml_file(&data_file("two_arms.toml"))
            .unwrap()
            .build()
            .unwrap();
        let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let poses: Vec<TargetPose> = (0..17)
            .flat_map(|_| random_poses(&model, targets.len(), &mut rng))
            .take(100)
            .enumerate()
            .map(|(k, mut pose)| {
                if k % 7 == 3 {
                    pose.observations[1] = None;
                }
                pose
            })
            .collect();
        let set = MeasurementSet::from_poses("chunks", targets, poses).unwrap();
        let starts = FrameStarts::nominal(&set, Isometry3::identity(), None).unwrap();
        let problem = |threads| {
            ErrorModel::new(&model, Cow::Borrowed(&set), &starts)
                .unwrap()
                .with_threads(Some(threads))
        };
        let n = problem(1).n_observations();
        for (threads, range, poses_per_chunk) in [
            (1, 0..n, vec![100]),
            (3, 0..n, vec![33, 33, 34]),
            (8, 0..n, vec![25, 25, 25, 25]),
        ] {
            let problem = problem(threads);
            let chunks = problem.chunks(range.clone());
            assert_eq!(chunks.first().unwrap().start, range.start);
            assert_eq!(chunks.last().unwrap().end, range.end);
            for pair in chunks.windows(2) {
                assert_eq!(pair[0].end, pair[1].start);
                assert_ne!(
                    problem.observation(pair[0].end - 1).0,
                    problem.observation(pair[1].start).0
                );
            }
            let counts: Vec<usize> = chunks
                .iter()
                .map(|c| problem.observation(c.end - 1).0 + 1 - problem.observation(c.start).0)
                .collect();
            assert_eq!(counts, poses_per_chunk, "{threads} threads over {range:?}");
        }
        // Part of the observations, starting inside a pose: the poses
        // spanned, shared as evenly as whole poses allow.
        for (threads, range) in [(3, 11..60), (2, 11..n - 3), (3, 11..n - 3)] {
            let problem = problem(threads);
            let mut spanned: Vec<usize> = range.clone().map(|i| problem.observation(i).0).collect();
            spanned.dedup();
            let chunks = problem.chunks(range.clone());
            let expected = (spanned.len() / MIN_POSES_PER_THREAD).clamp(1, threads);
            assert_eq!(chunks.len(), expected, "{threads} threads over {range:?}");
            let counts: Vec<usize> = chunks
                .iter()
                .map(|c| problem.observation(c.end - 1).0 + 1 - problem.observation(c.start).0)
                .collect();
            assert_eq!(counts.iter().sum::<usize>(), spanned.len());
            assert!(counts.iter().max().unwrap() - counts.iter().min().unwrap() <= 1);
        }
    }

    /// Six random poses of `model`, `n_targets` observations each, the
    /// first target's with an orientation.
    fn random_poses(model: &Model, n_targets: usize, rng: &mut ChaCha8Rng) -> Vec<TargetPose> {
        (0..6)
            .map(|k| TargetPose {
                pose_id: Some(format!("p{k}")),
                q: (0..model.n_actuated())
                    .map(|_| rng.random_range(-1.5..1.5))
                    .collect(),
                observations: (0..n_targets)
                    .map(|t| {
                        let mut seen = TargetObservation::new(Vector3::from_fn(|_, _| {
                            rng.random_range(-1.0..1.0)
                        }));
                        if t == 0 {
                            seen.orientation =
                                Some(Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0)));
                        }
                        Some(seen)
                    })
                    .collect(),
                wrench: None,
                temperature_c: None,
            })
            .collect()
    }

    /// With columns frozen (every third unknown; then every elastic and
    /// joint-term one, which skips the joint Jacobians), the other columns
    /// are those of `analytic` to the bit, the frozen robot and elastic ones
    /// zero (frame columns are always computed).
    fn frozen_columns_are_skipped(problem: &ErrorModel<'_>, x: &[f64], analytic: &Mat<f64>) {
        let (rows, n) = (problem.n_residuals(), problem.n_unknowns());
        let frames = problem.frame_offset()..problem.frames_end();
        for frozen in [
            (0..n).map(|j| j % 3 == 1).collect::<Vec<bool>>(),
            (0..n).map(|j| j >= problem.frames_end()).collect(),
        ] {
            problem.set_frozen_columns(&frozen);
            let mut lean = Mat::<f64>::zeros(rows, n);
            problem.jacobian(x, lean.as_mut()).unwrap();
            problem.set_frozen_columns(&[]);
            for j in 0..n {
                let skipped = frozen[j] && !frames.contains(&j);
                for i in 0..rows {
                    let expected = if skipped { 0.0 } else { analytic[(i, j)] };
                    assert_eq!(lean[(i, j)], expected, "{}: row {i}", problem.names()[j]);
                }
            }
        }
    }

    /// Each frame moves its own station's observations only.
    fn frames_move_their_own_station(
        problem: &ErrorModel<'_>,
        set: &MeasurementSet,
        analytic: &Mat<f64>,
    ) {
        let rows = problem.n_residuals();
        let station_of_row = |row: usize| {
            let i = (0..problem.n_observations())
                .find(|&i| problem.block_rows(i).contains(&row))
                .unwrap();
            set.station_of(problem.observation(i).0)
        };
        for s in 0..2 {
            let o = problem.station_frame_offset(s);
            let moved: Vec<usize> = (0..rows)
                .filter(|&i| (o..o + 6).any(|j| analytic[(i, j)] != 0.0))
                .map(station_of_row)
                .collect();
            assert!(
                !moved.is_empty() && moved.iter().all(|&m| m == s),
                "station {s}"
            );
        }
    }
}
