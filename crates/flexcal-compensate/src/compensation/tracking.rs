//! Compensation of whole paths: each point predicted from the last solved
//! points and corrected with a stored joint Jacobian; long paths split
//! into stretches compensated in parallel threads.

use std::collections::VecDeque;
use std::ops::Range;

use flexcal_elastic::tcp::TcpDeflection;
use flexcal_kinematics::{InverseTarget, inverse_pose};
use nalgebra::{Isometry3, Vector3, Vector6};
use rayon::prelude::*;

use super::error::CompensationError;
use super::jacobian::JACOBIAN_REFRESH_RATIO;
use super::model::{CompensationOptions, ElastoGeometricModel};
use super::point::{CompensatedPoint, CompensationMethod, Solved, converged, inverse_converged};
use super::pose::{path_distance, pose_difference};
use super::workspace::CompensationData;
use crate::path::PathPoint;

/// Outcome of one path point: its 1-based line in the path file and the
/// result or the reason it failed.
#[derive(Debug)]
pub struct PointOutcome {
    /// Line of the point in its file (0 for points built in memory).
    pub line: usize,
    /// The result.
    pub result: Result<CompensatedPoint, CompensationError>,
}

/// Correction steps allowed to a predicted path point before it is solved
/// from scratch.
const MAX_TRACKING_STEPS: usize = 6;

/// Fewest points of a stretch compensated by one thread: each stretch
/// starts with a point solved from scratch and a few points of warm-up, so
/// short stretches would waste what parallelism gains.
const MIN_STRETCH_POINTS: usize = 256;

/// Inverse-model solves that carry the seed from one stretch start to the
/// next along the path, so every stretch starts on the path's branch.
const SEED_WALK_STEPS: usize = 16;

impl<E: ?Sized + TcpDeflection> ElastoGeometricModel<'_, E> {
    /// Compensates a whole path given in the part frame, in this thread.
    /// Each point starts from the previous point's command (so the path
    /// stays on one branch); the first from `seed`. Every point is
    /// reported, failed ones with their reason, so a caller can list all
    /// bad points at once.
    ///
    /// Paths are continuous, so each point is first predicted from the last
    /// points (commands, correction and deflections extrapolated along the
    /// path length) and then corrected: Newton steps on the inverse
    /// geometric model and fixed-point steps on the command, both with a
    /// stored joint Jacobian, until the same tolerances as
    /// [`compensate_pose`](Self::compensate_pose) are met. On a finely
    /// sampled path the prediction usually meets them at once, so a point
    /// costs one geometric and one elastic evaluation for the uncompensated
    /// command and as many for the compensated one. A point whose
    /// prediction does not converge quickly (a corner, a jump) is solved
    /// from scratch by [`compensate_pose`](Self::compensate_pose); the
    /// results agree within the tolerances. Apart from the results
    /// themselves, nothing is allocated per point.
    pub fn compensate_path(
        &self,
        data: &mut CompensationData<E::Workspace>,
        path: &[PathPoint],
        seed: &[f64],
        options: &CompensationOptions,
    ) -> Vec<PointOutcome> {
        let targets = self.targets(path);
        self.track(data, path, &targets, 0..path.len(), seed, options)
    }

    /// [`compensate_path`](Self::compensate_path) in parallel threads (the
    /// rayon pool) sharing this model, each with its own workspace. The
    /// path is cut into stretches of at least 256 points, one or more per
    /// thread; the seed of each stretch is carried from `seed` along the
    /// path by the inverse geometric model, so every stretch starts on the
    /// path's branch, and each stretch is then tracked as in
    /// [`compensate_path`](Self::compensate_path). The results agree with
    /// it within the solver tolerances.
    ///
    /// # Errors
    /// [`CompensationError::Elastic`] when a thread's workspace cannot be
    /// created; failures of single points are reported per point.
    pub fn compensate_path_parallel(
        &self,
        path: &[PathPoint],
        seed: &[f64],
        options: &CompensationOptions,
    ) -> Result<Vec<PointOutcome>, CompensationError> {
        let n = path.len();
        let stretches = rayon::current_num_threads()
            .min(n / MIN_STRETCH_POINTS)
            .max(1);
        let mut data = self.data()?;
        let targets = self.targets(path);
        if stretches == 1 {
            return Ok(self.track(&mut data, path, &targets, 0..n, seed, options));
        }
        let bounds: Vec<usize> = (0..=stretches).map(|k| k * n / stretches).collect();
        let seeds = self.stretch_seeds(&mut data, &targets, &bounds, seed, options);
        let results: Vec<Result<Vec<PointOutcome>, CompensationError>> = (0..stretches)
            .into_par_iter()
            .map_init(
                || self.data().map_err(|e| e.to_string()),
                |data, k| {
                    let data = data
                        .as_mut()
                        .map_err(|e| CompensationError::Elastic(e.clone()))?;
                    Ok(self.track(
                        data,
                        path,
                        &targets,
                        bounds[k]..bounds[k + 1],
                        &seeds[k],
                        options,
                    ))
                },
            )
            .collect();
        let mut outcomes = Vec::with_capacity(n);
        for stretch in results {
            outcomes.extend(stretch?);
        }
        Ok(outcomes)
    }

    /// The path's targets in the base frame.
    fn targets(&self, path: &[PathPoint]) -> Vec<Isometry3<f64>> {
        path.iter()
            .map(|p| self.cell.x_base_part * p.x_part_tcp)
            .collect()
    }

    /// Seeds of the stretches starting at `bounds[k]`: the first is `seed`,
    /// each next one the inverse geometric model walked along the path from
    /// the previous one. A target the walk cannot reach keeps the last seed
    /// (the point itself then reports its failure when tracked).
    fn stretch_seeds(
        &self,
        data: &mut CompensationData<E::Workspace>,
        targets: &[Isometry3<f64>],
        bounds: &[usize],
        seed: &[f64],
        options: &CompensationOptions,
    ) -> Vec<Vec<f64>> {
        let mut current = seed.to_vec();
        let mut seeds = vec![current.clone()];
        for k in 1..bounds.len() - 1 {
            let (from, to) = (bounds[k - 1], bounds[k]);
            let stride = ((to - from) / SEED_WALK_STEPS).max(1);
            for i in (from..to).step_by(stride).skip(1).chain([to]) {
                if let Ok(solution) = inverse_pose(
                    self.model,
                    &mut data.kinematics,
                    &targets[i],
                    &current,
                    &self.xi,
                    &options.inverse,
                ) {
                    current = solution.q;
                }
            }
            seeds.push(current.clone());
        }
        seeds
    }

    /// Tracks the points `range` of `path` (base-frame `targets`), the
    /// first seeded by `seed`.
    fn track(
        &self,
        data: &mut CompensationData<E::Workspace>,
        path: &[PathPoint],
        targets: &[Isometry3<f64>],
        range: Range<usize>,
        seed: &[f64],
        options: &CompensationOptions,
    ) -> Vec<PointOutcome> {
        let mut seed = seed.to_vec();
        let mut tracker = PathTracker::new();
        let mut length = 0.0;
        let mut outcomes = Vec::with_capacity(range.len());
        let start = range.start;
        for i in range {
            let target = &targets[i];
            let motion = if i + 1 < targets.len() {
                targets[i + 1].translation.vector - target.translation.vector
            } else if i > 0 {
                target.translation.vector - targets[i - 1].translation.vector
            } else {
                Vector3::zeros()
            };
            if i > start {
                length += path_distance(&targets[i - 1], target);
            }
            let tracked = if tracker.samples.is_empty() {
                None
            } else {
                self.compensate_tracked(data, target, length, &motion, options, &mut tracker)
                    .ok()
                    .flatten()
            };
            let result = match tracked {
                Some(found) => Ok(found),
                None => self.compensate_pose_with(data, target, &seed, &motion, options),
            };
            let result = match result {
                Ok(solved) => {
                    seed.clone_from(&solved.point.q_commanded);
                    tracker.push(data, length, &solved);
                    Ok(solved.point)
                }
                Err(e) => {
                    tracker.samples.clear();
                    Err(e)
                }
            };
            outcomes.push(PointOutcome {
                line: path[i].line,
                result,
            });
        }
        outcomes
    }

    /// One path point predicted from the tracker's samples and corrected.
    /// `Ok(None)` when the prediction does not converge in a few steps.
    fn compensate_tracked(
        &self,
        data: &mut CompensationData<E::Workspace>,
        target_base: &Isometry3<f64>,
        length: f64,
        motion_base: &Vector3<f64>,
        options: &CompensationOptions,
        tracker: &mut PathTracker,
    ) -> Result<Option<Solved>, CompensationError> {
        let model = self.model;
        let limits = model.actuated_limits();
        tracker.set_weights(length);
        // Uncompensated command: Newton on the inverse geometric model from
        // the extrapolated command.
        let mut q0 = tracker.extrapolate(|s| &s.q_uncompensated);
        for (v, &(lo, hi)) in q0.iter_mut().zip(limits) {
            *v = v.clamp(lo, hi);
        }
        let mut inverse_error = Vector6::zeros();
        let pose0 = if options.inverse.target == InverseTarget::Pose {
            let mut found = None;
            let mut previous = f64::INFINITY;
            let mut refreshed_here = false;
            for step in 0..=MAX_TRACKING_STEPS {
                let pose =
                    flexcal_kinematics::forward_pose(model, &mut data.kinematics, &q0, &self.xi)?;
                let error = pose_difference(&pose, target_base);
                if inverse_converged(&error, &options.inverse) {
                    inverse_error = error;
                    found = Some(pose);
                    break;
                }
                if step == MAX_TRACKING_STEPS {
                    break;
                }
                let size = error.norm();
                if data.jacobian.is_empty()
                    || (size > JACOBIAN_REFRESH_RATIO * previous && !refreshed_here)
                {
                    data.jacobian
                        .refresh(model, &mut data.kinematics, &q0, &self.xi)?;
                    refreshed_here = true;
                } else {
                    refreshed_here = false;
                }
                data.jacobian.correct(&mut q0, &error, Some(limits))?;
                previous = size;
            }
            match found {
                Some(pose) => pose,
                None => return Ok(None),
            }
        } else {
            // Other targets leave freedoms to the inverse model's own solver.
            let solution = inverse_pose(
                model,
                &mut data.kinematics,
                target_base,
                &q0,
                &self.xi,
                &options.inverse,
            )?;
            q0 = solution.q;
            solution.pose
        };
        let guess0 = tracker.extrapolate_vector(|s| &s.deflection_uncompensated);
        let actual0 = self.actual_from_geometric(
            &mut data.elastic,
            &mut data.process,
            &q0,
            pose0,
            motion_base,
            options,
            Some(&guess0),
        )?;
        let uncompensated_error = pose_difference(&actual0.x_base_tcp, target_base);
        let deflection0 = actual0.deflection;
        // Compensated command: the extrapolated correction added to this
        // point's uncompensated command (the correction varies more slowly
        // than the command itself).
        let mut q = q0.clone();
        let mut moved = false;
        for (k, (v, &(lo, hi))) in q.iter_mut().zip(limits).enumerate() {
            let corrected = (*v + tracker.correction(k)).clamp(lo, hi);
            moved |= corrected != *v;
            *v = corrected;
        }
        let mut actual = if moved {
            let guess = tracker.extrapolate_vector(|s| &s.deflection_commanded);
            self.actual_pose_from_guess(data, &q, motion_base, options, Some(&guess))?
        } else {
            actual0
        };
        let result = self.correct_command(
            data,
            target_base,
            &mut q,
            &mut actual,
            motion_base,
            options,
            MAX_TRACKING_STEPS,
        )?;
        if !converged(&result.error, options) {
            return Ok(None);
        }
        Ok(Some(Solved {
            point: CompensatedPoint {
                target_base: *target_base,
                q_uncompensated: q0,
                uncompensated_error,
                q_commanded: q,
                commanded_base: actual.x_base_geometric,
                residual: result.error,
                wrench_base: actual.wrench_base,
                iterations: result.iterations,
                method: CompensationMethod::FixedPoint,
            },
            deflection_uncompensated: deflection0,
            deflection_commanded: actual.deflection,
            inverse_error,
        }))
    }
}

/// The last solved points of a path, for prediction.
struct TrackSample {
    length: f64,
    q_uncompensated: Vec<f64>,
    q_commanded: Vec<f64>,
    deflection_uncompensated: Vector6<f64>,
    deflection_commanded: Vector6<f64>,
}

/// Samples kept for extrapolation: quadratic, its error of the third order
/// in the point spacing.
const SAMPLES: usize = 3;

/// Path-following state of [`ElastoGeometricModel::compensate_path`]: the
/// last three solved points and the Lagrange weights of the next point.
/// Its buffers are reused from point to point.
struct PathTracker {
    samples: VecDeque<TrackSample>,
    /// Lagrange weights of the samples (oldest first) for the next point.
    weights: [f64; SAMPLES],
}

impl PathTracker {
    fn new() -> Self {
        Self {
            samples: VecDeque::with_capacity(SAMPLES),
            weights: [0.0; SAMPLES],
        }
    }

    /// Stores a solved point. Its commands met the tolerances but may sit
    /// anywhere within them, and extrapolation amplifies such scatter (up
    /// to 7 times for three points), which would make the next prediction
    /// miss the tolerance it has to meet. So the stored commands are first
    /// polished by one step on their known remaining errors with the stored
    /// Jacobian: linear algebra only, no model evaluation.
    fn push<W>(&mut self, data: &mut CompensationData<W>, length: f64, solved: &Solved) {
        let mut sample = if self.samples.len() == SAMPLES {
            self.samples.pop_front()
        } else {
            None
        }
        .unwrap_or_else(|| TrackSample {
            length,
            q_uncompensated: Vec::new(),
            q_commanded: Vec::new(),
            deflection_uncompensated: Vector6::zeros(),
            deflection_commanded: Vector6::zeros(),
        });
        let point = &solved.point;
        sample.length = length;
        sample.q_uncompensated.clone_from(&point.q_uncompensated);
        sample.q_commanded.clone_from(&point.q_commanded);
        sample.deflection_uncompensated = solved.deflection_uncompensated;
        sample.deflection_commanded = solved.deflection_commanded;
        if !data.jacobian.is_empty() {
            // Polishing is an improvement only: a failed solve keeps the
            // commands as they are.
            let _ = data
                .jacobian
                .correct(&mut sample.q_uncompensated, &solved.inverse_error, None);
            let _ = data
                .jacobian
                .correct(&mut sample.q_commanded, &point.residual, None);
        }
        self.samples.push_back(sample);
    }

    /// Sets the Lagrange weights of the stored samples (oldest first) for
    /// the path length `length`. Fewer samples are used when they would
    /// extrapolate too far (a jump in the path) or when two share a length.
    fn set_weights(&mut self, length: f64) {
        let n = self.samples.len();
        let mut nodes = [0.0; SAMPLES];
        for (node, sample) in nodes.iter_mut().zip(&self.samples) {
            *node = sample.length;
        }
        let mut used = n;
        while used > 1 {
            let used_nodes = &nodes[n - used..n];
            let increasing = used_nodes.windows(2).all(|w| w[1] > w[0]);
            let span = used_nodes[used - 1] - used_nodes[0];
            let ahead = length - used_nodes[used - 1];
            if increasing && ahead >= 0.0 && ahead <= 1.5 * span {
                break;
            }
            used -= 1;
        }
        self.weights = [0.0; SAMPLES];
        let used_nodes = &nodes[n - used..n];
        for (i, &xi) in used_nodes.iter().enumerate() {
            let mut w = 1.0;
            for (j, &xj) in used_nodes.iter().enumerate() {
                if i != j {
                    w *= (length - xj) / (xi - xj);
                }
            }
            self.weights[n - used + i] = w;
        }
    }

    /// A command extrapolated with the current weights.
    fn extrapolate(&self, field: impl Fn(&TrackSample) -> &Vec<f64>) -> Vec<f64> {
        let first = self.samples.front().map_or(0, |s| field(s).len());
        let mut out = vec![0.0; first];
        for (s, &w) in self.samples.iter().zip(&self.weights) {
            if w != 0.0 {
                for (o, v) in out.iter_mut().zip(field(s)) {
                    *o += w * v;
                }
            }
        }
        out
    }

    fn extrapolate_vector(&self, field: impl Fn(&TrackSample) -> &Vector6<f64>) -> Vector6<f64> {
        self.samples
            .iter()
            .zip(&self.weights)
            .fold(Vector6::zeros(), |acc, (s, &w)| acc + field(s) * w)
    }

    /// Correction (commanded minus uncompensated) of coordinate `k`,
    /// extrapolated with the current weights.
    fn correction(&self, k: usize) -> f64 {
        self.samples
            .iter()
            .zip(&self.weights)
            .filter(|(_, w)| **w != 0.0)
            .map(|(s, &w)| w * (s.q_commanded[k] - s.q_uncompensated[k]))
            .sum()
    }
}
