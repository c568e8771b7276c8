//! Step 7 of the identification, beyond the
//! paper: each identified unknown's spread ratio
//! ([`crate::UnknownEstimate::spread_ratio`]), its standard error over the
//! one that as many poses drawn uniformly over the joint ranges would give
//! (seeded, at most [`SPREAD_REFERENCE_POSES`] poses).

use std::borrow::Cow;

use faer::Mat;
use flexcal_kinematics::Model;
use nalgebra::Vector3;

use crate::analysis::AnalysisContext;
use crate::coverage::CoordinateCoverage;
use crate::error::CalibError;
use crate::error_model::{ErrorModel, FrameStarts};
use crate::measurement::MeasurementSet;
use crate::options::CalibrationOptions;
use crate::targets::{TargetObservation, TargetPose};

/// Most poses drawn for the spread reference of
/// [`crate::UnknownEstimate::spread_ratio`] (its standard errors are rescaled to the
/// number of identification poses).
pub const SPREAD_REFERENCE_POSES: usize = 256;
/// Seed of the spread reference's draws: the same data give the same report.
const SPREAD_REFERENCE_SEED: u64 = 9283;
/// A robot parameter whose standard error is more than this many times the
/// one of the spread reference is reported as weakly determined by the poses.
pub const WEAK_SPREAD_RATIO: f64 = 10.0;

/// Diagonal of `(S^T S)^-1` for the columns `cols` of `s` (the unit-noise
/// covariance of those unknowns), or `None` when they are not independent.
pub(crate) fn unit_covariance_diagonal(s: &Mat<f64>, cols: &[usize]) -> Option<Vec<f64>> {
    let k = cols.len();
    let norms: Vec<f64> = cols.iter().map(|&j| s.col(j).norm_l2()).collect();
    if norms.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
        return None;
    }
    // Scaled columns: lengths and angles on the same footing for the factor.
    let mut normal = nalgebra::DMatrix::<f64>::zeros(k, k);
    for a in 0..k {
        for b in a..k {
            let dot: f64 = (0..s.nrows())
                .map(|i| s[(i, cols[a])] * s[(i, cols[b])])
                .sum::<f64>()
                / (norms[a] * norms[b]);
            normal[(a, b)] = dot;
            normal[(b, a)] = dot;
        }
    }
    let inverse = normal.cholesky()?.inverse();
    let diagonal: Vec<f64> = (0..k)
        .map(|a| inverse[(a, a)] / (norms[a] * norms[a]))
        .collect();
    diagonal
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
        .then_some(diagonal)
}

/// What the spread reference needs from the identification.
pub(crate) struct SpreadReference<'a> {
    pub model: &'a Model,
    pub set: &'a MeasurementSet,
    pub options: &'a CalibrationOptions,
    /// What the identification poses cover of each actuated coordinate.
    pub actuated_ranges: &'a [CoordinateCoverage],
    /// Where the identification's frames started.
    pub starts: &'a FrameStarts,
    pub context: &'a AnalysisContext<'a>,
}

/// For each unknown of `identified`, its standard error with these
/// observations divided by the one that as many poses spread over the
/// robot's joint ranges, every target seen at each, would give, both with
/// the same noise (see [`crate::UnknownEstimate::spread_ratio`];
/// `reduced`: the identification's factor at `x`). `None` everywhere when
/// no reference can be drawn (a closed loop that rarely closes) or the
/// reference cannot separate them either.
///
/// # Errors
/// A model failure on the reference poses.
pub(crate) fn spread_ratios(
    reference: &SpreadReference<'_>,
    reduced: &Mat<f64>,
    x: &[f64],
    identified: &[usize],
) -> Result<Vec<Option<f64>>, CalibError> {
    let SpreadReference {
        model,
        set,
        options,
        actuated_ranges,
        starts,
        context,
    } = *reference;
    let out = vec![None; reduced.ncols()];
    let Some(training) = unit_covariance_diagonal(reduced, identified) else {
        return Ok(out);
    };
    let weight = rms_row_weights(context.problem, context.weights);
    let count = set.len().min(SPREAD_REFERENCE_POSES);
    let Some(configurations) = spread_configurations(model, actuated_ranges, count, x) else {
        return Ok(out);
    };
    // The spread poses are shared out among the stations, each of which
    // then sees as many as its frame needs.
    let stations = set.n_stations();
    if count < stations {
        return Ok(out);
    }
    let observation = |t: usize| TargetObservation {
        orientation: starts.orientation[t].then(Vector3::zeros),
        ..TargetObservation::new(Vector3::zeros())
    };
    let poses = configurations
        .into_iter()
        .map(|q| TargetPose {
            pose_id: None,
            q,
            observations: (0..set.targets().len())
                .map(|t| Some(observation(t)))
                .collect(),
            wrench: None,
            temperature_c: None,
        })
        .collect();
    let spread = MeasurementSet::from_poses("spread reference", set.targets().to_vec(), poses)?
        .with_stations(
            set.station_names().to_vec(),
            (0..count).map(|k| k % stations).collect(),
        )?;
    let problem = ErrorModel::new(model, Cow::Owned(spread), starts)?
        .with_elastic(options.gravity.as_ref(), &options.joint_terms)?
        .with_threads(options.threads);
    let weights: Vec<f64> = (0..problem.n_observations())
        .flat_map(|i| weight[..problem.block_rows(i).len()].to_vec())
        .collect();
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

/// The RMS weight of each row kind (position x, y, z, orientation x, y,
/// z) over the observations of `problem` that have it: what a reference
/// row weighs.
fn rms_row_weights(problem: &ErrorModel<'_>, weights: &[f64]) -> [f64; 6] {
    let mut sum = [0.0; 6];
    let mut count = [0usize; 6];
    for i in 0..problem.n_observations() {
        for (kind, row) in problem.block_rows(i).enumerate() {
            sum[kind] += weights[row] * weights[row];
            count[kind] += 1;
        }
    }
    std::array::from_fn(|kind| (sum[kind] / count[kind].max(1) as f64).sqrt())
}

/// `count` configurations of the spread reference, drawn with a fixed seed:
/// revolute coordinates over their limits, prismatic ones (whose default
/// limits are not a workspace) over `actuated_ranges`, a closed loop's
/// drawn again where it cannot close at the robot parameters of `x`.
/// `None` when a loop rarely closes.
pub(crate) fn spread_configurations(
    model: &Model,
    actuated_ranges: &[CoordinateCoverage],
    count: usize,
    x: &[f64],
) -> Option<Vec<Vec<f64>>> {
    use rand::{Rng, SeedableRng};
    let ranges: Vec<(f64, f64)> = model
        .actuated_limits()
        .iter()
        .zip(model.actuated_kinds())
        .zip(actuated_ranges)
        .map(|((&limits, kind), &seen)| match kind {
            flexcal_kinematics::ActuatedKind::Revolute => limits,
            _ => (seen.lo, seen.hi),
        })
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SPREAD_REFERENCE_SEED);
    let mut data = flexcal_kinematics::Data::new(model);
    let mut drawn = Vec::with_capacity(count);
    let mut tries = 0;
    while drawn.len() < count && tries < 50 * count {
        tries += 1;
        let q: Vec<f64> = ranges
            .iter()
            .map(|&(lo, hi)| {
                if lo < hi {
                    rng.random_range(lo..hi)
                } else {
                    lo
                }
            })
            .collect();
        // A closed loop that cannot close at q: draw again.
        if !model.is_serial()
            && flexcal_kinematics::forward_pose(model, &mut data, &q, &x[..model.n_params()])
                .is_err()
        {
            continue;
        }
        drawn.push(q);
    }
    (drawn.len() == count).then_some(drawn)
}

/// [`crate::UnknownEstimate::spread_ratio`] of each unknown of `identified`: the
/// square root of its unit-noise variance `training` over the one of the
/// reference's reduced factor `spread`, the reference's scaled by `scale`
/// (its poses over the identification's: covariances go as 1 / poses).
/// `None` everywhere when the reference cannot separate them.
pub(crate) fn spread_ratio_values(
    training: &[f64],
    spread: &Mat<f64>,
    identified: &[usize],
    scale: f64,
) -> Vec<Option<f64>> {
    let mut out = vec![None; spread.ncols()];
    let Some(spread) = unit_covariance_diagonal(spread, identified) else {
        return out;
    };
    for (c, &j) in identified.iter().enumerate() {
        out[j] = Some((training[c] / (spread[c] * scale)).sqrt());
    }
    out
}
