//! The folds of model selection (`selection`): which training
//! poses each fit leaves out to score a candidate model on.
//!
//! - **Ordinary folds** ([`crate::FoldScheme`]): k-means clusters in joint
//!   space, or blocks in acquisition order. Each held-out fold is a region
//!   inside the training poses' ranges, so its score measures how well a
//!   candidate *interpolates*.
//! - **Extrapolating folds** ([`ExtrapolationFold`]): one per actuated
//!   joint, holding out the poses at both ends of the joint's covered
//!   range and of its gravity-torque range (the torques of the nominal
//!   model under the mass table, as the identification computes them), so
//!   that every held-out pose lies outside the range of the fold's
//!   training part in the joint's angle or torque: what a calibrated robot
//!   meets when its work cell leaves the measured region. The ends are the
//!   outer [`EXTRAPOLATION_END_SHARE`] of each range at each side, a rule
//!   stated once and not tuned to a data set.
//!
//! The ends of a range are found by one function, `range_ends`, with the
//! share as its parameter: the error-growth estimate (the `extrapolation`
//! module, `Calibration::extrapolation`) holds out its folds' ends with
//! the same function.
//!
//! With several stations every fold, ordinary or extrapolating, leaves
//! each station poses in the training part: without them its measurement
//! frame, and so its held-out poses, could not be placed.

use flexcal_kinematics::{ActuatedKind, Model};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::coverage::CoordinateCoverage;
use crate::error::CalibError;
use crate::gravity::{Configurations, GravityCompliance, GravityTerms};

/// How the poses are split into folds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FoldScheme {
    /// k-means clusters in the actuated coordinates scaled by their ranges
    /// (default).
    #[default]
    JointClusters,
    /// Contiguous blocks in file (acquisition) order.
    AcquisitionBlocks,
}

/// Share of a range held out at each of its ends by an extrapolating fold
/// (0.1: the outer 10 % below and the outer 10 % above, 20 % of the range
/// in all). The training part then covers the middle 80 % and the held-out
/// poses lie up to an eighth of that span beyond it on either side, the
/// order by which a work cell commonly leaves a measured region.
pub const EXTRAPOLATION_END_SHARE: f64 = 0.1;

/// Fewest poses an extrapolating fold holds out: fewer make a score too
/// noisy to compare candidates on, and the joint gets no fold.
pub const MIN_EXTRAPOLATION_HELD_OUT: usize = 5;

/// The configurations and stations of a set of poses: what the folds are
/// built from.
pub(crate) struct FoldPoses<'a> {
    /// Actuated coordinates of each pose (rad or m).
    pub q: Vec<&'a [f64]>,
    /// Station (measurement frame) of each pose.
    pub station: Vec<usize>,
    /// Number of stations.
    pub n_stations: usize,
}

/// What one extrapolating fold holds out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtrapolationFold {
    /// The actuated joint (coordinate name).
    pub joint: String,
    /// Whether the ends of the joint's angle (or travel) range are held out.
    pub angle_ends: bool,
    /// Whether the ends of the joint's gravity-torque range are held out
    /// (only when the torque spans at least the identification's
    /// [`crate::CalibrationOptions::min_torque_share`] of the most loaded
    /// joint's span).
    pub torque_ends: bool,
    /// Number of poses held out.
    pub held_out: usize,
}

impl ExtrapolationFold {
    /// `theta2 (angle + torque ends, 412 poses)`.
    pub fn label(&self) -> String {
        let ends = match (self.angle_ends, self.torque_ends) {
            (true, true) => "angle + torque ends",
            (true, false) => "angle ends",
            (false, true) => "torque ends",
            (false, false) => "nothing",
        };
        format!("{} ({ends}, {} poses)", self.joint, self.held_out)
    }
}

/// Fold of each pose (`0..folds`). With several stations each station's
/// poses are shared out among the folds on their own: every training fold
/// then holds poses of every station, whose measurement frame it needs to
/// predict the held-out poses of that station.
pub(crate) fn fold_assignment(
    model: &Model,
    poses: &FoldPoses<'_>,
    folds: usize,
    scheme: FoldScheme,
    seed: u64,
) -> Vec<usize> {
    let n = poses.q.len();
    let mut assignment = vec![0; n];
    for s in 0..poses.n_stations {
        let indices: Vec<usize> = (0..n).filter(|&k| poses.station[k] == s).collect();
        let within = if indices.len() >= folds {
            station_folds(model, poses, &indices, folds, scheme, seed)
        } else {
            (0..indices.len()).map(|k| k % folds).collect()
        };
        for (k, f) in indices.into_iter().zip(within) {
            assignment[k] = f;
        }
    }
    assignment
}

/// Fold of each pose of `indices` (the poses of one station, at least
/// `folds` of them), in their order.
fn station_folds(
    model: &Model,
    poses: &FoldPoses<'_>,
    indices: &[usize],
    folds: usize,
    scheme: FoldScheme,
    seed: u64,
) -> Vec<usize> {
    let n = indices.len();
    match scheme {
        FoldScheme::AcquisitionBlocks => (0..n).map(|k| k * folds / n).collect(),
        FoldScheme::JointClusters => {
            let na = model.n_actuated();
            // Coordinates scaled by their range over the poses.
            let (lo, hi): (Vec<f64>, Vec<f64>) = (0..na)
                .map(|i| {
                    indices
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &k| {
                            let q = poses.q[k][i];
                            (a.min(q), b.max(q))
                        })
                })
                .unzip();
            let points: Vec<Vec<f64>> = indices
                .iter()
                .map(|&k| {
                    (0..na)
                        .map(|i| {
                            let span = hi[i] - lo[i];
                            if span > 0.0 {
                                (poses.q[k][i] - lo[i]) / span
                            } else {
                                0.0
                            }
                        })
                        .collect()
                })
                .collect();
            balanced_kmeans(&points, folds, seed)
        }
    }
}

/// k-means (Lloyd, k-means++ start, seeded), then balanced: clusters larger
/// than `ceil(n / k)` hand their poses farthest from their centre to the
/// nearest cluster with room, so that no fold is too small to validate or
/// too large to leave a training set.
pub(crate) fn balanced_kmeans(points: &[Vec<f64>], k: usize, seed: u64) -> Vec<usize> {
    let n = points.len();
    let distance =
        |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum() };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut centres: Vec<Vec<f64>> = vec![points[rng.random_range(0..n)].clone()];
    while centres.len() < k {
        let d: Vec<f64> = points
            .iter()
            .map(|p| {
                centres
                    .iter()
                    .map(|c| distance(p, c))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        let total: f64 = d.iter().sum();
        let mut pick = rng.random_range(0.0..total.max(f64::MIN_POSITIVE));
        let mut chosen = n - 1;
        for (i, v) in d.iter().enumerate() {
            if pick < *v {
                chosen = i;
                break;
            }
            pick -= v;
        }
        centres.push(points[chosen].clone());
    }
    let mut assignment = vec![0; n];
    for _ in 0..50 {
        let mut changed = false;
        for (i, p) in points.iter().enumerate() {
            let best = (0..k)
                .min_by(|&a, &b| distance(p, &centres[a]).total_cmp(&distance(p, &centres[b])))
                .unwrap_or(0);
            if best != assignment[i] {
                assignment[i] = best;
                changed = true;
            }
        }
        for (c, centre) in centres.iter_mut().enumerate() {
            let members: Vec<&Vec<f64>> = points
                .iter()
                .zip(&assignment)
                .filter(|(_, a)| **a == c)
                .map(|(p, _)| p)
                .collect();
            if members.is_empty() {
                continue;
            }
            for (d, v) in centre.iter_mut().enumerate() {
                *v = members.iter().map(|p| p[d]).sum::<f64>() / members.len() as f64;
            }
        }
        if !changed {
            break;
        }
    }
    // Balance: at most ceil(n / k) per fold.
    let cap = n.div_ceil(k);
    let mut counts = vec![0usize; k];
    for &a in &assignment {
        counts[a] += 1;
    }
    for c in 0..k {
        while counts[c] > cap {
            let (far, _) = points
                .iter()
                .enumerate()
                .filter(|(i, _)| assignment[*i] == c)
                .map(|(i, p)| (i, distance(p, &centres[c])))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .expect("a non-empty cluster");
            let target = (0..k)
                .filter(|&o| counts[o] < cap)
                .min_by(|&a, &b| {
                    distance(&points[far], &centres[a])
                        .total_cmp(&distance(&points[far], &centres[b]))
                })
                .expect("room in some fold");
            assignment[far] = target;
            counts[c] -= 1;
            counts[target] += 1;
        }
    }
    assignment
}

/// Gravity torque of every actuated coordinate at each of `q` (N.m or N,
/// one row per pose): the links' weights and the mass table's starting
/// payload on the nominal geometry at the commanded configuration, the
/// torques the identification loads the joint springs with.
///
/// # Errors
/// What the gravity terms return: a mass table that does not fit the model,
/// a configuration whose forward model fails.
pub(crate) fn gravity_torques(
    model: &Model,
    q: &[&[f64]],
    gravity: &GravityCompliance,
) -> Result<Vec<Vec<f64>>, CalibError> {
    let label = |k: usize| format!("#{k}");
    let poses = Configurations {
        q: q.to_vec(),
        label: &label,
    };
    let terms = GravityTerms::new(model, &poses, gravity)?;
    let na = model.n_actuated();
    let payload = gravity.initial_unknowns(model)[na..na + 4].to_vec();
    Ok((0..q.len())
        .map(|k| {
            let mut tau = vec![0.0; na];
            terms.forces(k, &payload, &mut tau);
            tau
        })
        .collect())
}

/// Which of `values` (rad or m) lie at the two ends of their covered
/// range `coverage`: `[low, high]`, each value's flag for the outer `share`
/// of the range's length at its start and at its end. Along a periodic
/// coordinate the position is measured on the arc from `coverage.lo`,
/// whichever turn a value is recorded in. No value is at an end of a
/// range without length.
///
/// The one construction of "hold out the end of a coordinate's range":
/// model selection's extrapolating folds hold out both ends of a joint's
/// angle and torque ranges at once, the outer [`EXTRAPOLATION_END_SHARE`]
/// ([`extrapolating_folds`]); the error-growth estimate of
/// the `extrapolation` module holds out each end of each coordinate's range
/// on its own, the outer fifth (its `HELD_OUT_FRACTION`).
pub(crate) fn range_ends(
    values: &[f64],
    coverage: &CoordinateCoverage,
    share: f64,
) -> [Vec<bool>; 2] {
    let length = coverage.length();
    if length.is_nan() || length <= 0.0 {
        return [vec![false; values.len()], vec![false; values.len()]];
    }
    // Position along the range from its start.
    let along: Vec<f64> = values
        .iter()
        .map(|v| match coverage.period {
            Some(p) => (v - coverage.lo).rem_euclid(p),
            None => v - coverage.lo,
        })
        .collect();
    let cut = share * length;
    [
        along.iter().map(|t| *t < cut).collect(),
        along.iter().map(|t| *t > length - cut).collect(),
    ]
}

/// Whether each value lies in the outer [`EXTRAPOLATION_END_SHARE`] of its
/// covered range at either end ([`range_ends`]).
fn at_ends(values: &[f64], period: Option<f64>) -> Vec<bool> {
    let coverage = CoordinateCoverage::of(values.iter().copied(), period);
    let [low, high] = range_ends(values, &coverage, EXTRAPOLATION_END_SHARE);
    low.iter().zip(&high).map(|(l, h)| *l || *h).collect()
}

/// The extrapolating folds of `poses` (module docs): for each actuated
/// joint, the poses at the ends of its angle range and, with a mass table
/// (`gravity`), of its gravity-torque range when that spans at least
/// `min_torque_share` of the largest joint's span. A joint whose fold
/// would hold out fewer than [`MIN_EXTRAPOLATION_HELD_OUT`] poses, or
/// every pose of some station, gets none. Returns each fold with its
/// held-out mask.
///
/// # Errors
/// What [`gravity_torques`] returns.
pub(crate) fn extrapolating_folds(
    model: &Model,
    poses: &FoldPoses<'_>,
    gravity: Option<&GravityCompliance>,
    min_torque_share: f64,
) -> Result<Vec<(ExtrapolationFold, Vec<bool>)>, CalibError> {
    let n = poses.q.len();
    let torques = gravity
        .map(|g| gravity_torques(model, &poses.q, g))
        .transpose()?;
    let torque_span = |i: usize| {
        torques.as_ref().map_or(0.0, |t| {
            CoordinateCoverage::of(t.iter().map(|row| row[i]), None).length()
        })
    };
    let na = model.n_actuated();
    let largest = (0..na).map(torque_span).fold(0.0, f64::max);
    let mut folds = Vec::new();
    for (i, kind) in model.actuated_kinds().iter().enumerate() {
        let period = (*kind == ActuatedKind::Revolute).then_some(std::f64::consts::TAU);
        let angles: Vec<f64> = poses.q.iter().map(|q| q[i]).collect();
        let angle_ends = at_ends(&angles, period);
        let loaded = largest > 0.0 && torque_span(i) >= min_torque_share * largest;
        let torque_ends = match (&torques, loaded) {
            (Some(t), true) => at_ends(&t.iter().map(|row| row[i]).collect::<Vec<_>>(), None),
            _ => vec![false; n],
        };
        let held_out: Vec<bool> = (0..n).map(|k| angle_ends[k] || torque_ends[k]).collect();
        let count = held_out.iter().filter(|h| **h).count();
        let station_kept =
            (0..poses.n_stations).all(|s| (0..n).any(|k| poses.station[k] == s && !held_out[k]));
        if count < MIN_EXTRAPOLATION_HELD_OUT || !station_kept {
            continue;
        }
        folds.push((
            ExtrapolationFold {
                joint: model.actuated_names()[i].clone(),
                angle_ends: angle_ends.contains(&true),
                torque_ends: torque_ends.contains(&true),
                held_out: count,
            },
            held_out,
        ));
    }
    Ok(folds)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurement::MeasurementSet;

    fn fold_poses(set: &MeasurementSet) -> FoldPoses<'_> {
        FoldPoses {
            q: set.configurations(),
            station: (0..set.len()).map(|k| set.station_of(k)).collect(),
            n_stations: set.n_stations(),
        }
    }

    #[test]
    fn balanced_clusters_cover_every_point_within_the_cap() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let points: Vec<Vec<f64>> = (0..103)
            .map(|i| {
                let centre = (i % 3) as f64 * 5.0;
                vec![
                    centre + rng.random_range(0.0..1.0),
                    rng.random_range(0.0..1.0),
                ]
            })
            .collect();
        let a = balanced_kmeans(&points, 5, 1);
        let mut counts = [0usize; 5];
        for f in &a {
            counts[*f] += 1;
        }
        assert!(counts.iter().all(|c| *c > 0 && *c <= 21), "{counts:?}");
        assert_eq!(a, balanced_kmeans(&points, 5, 1));
    }

    #[test]
    fn every_fold_holds_poses_of_every_station() {
        // Two stations seeing apart regions of joint space (as two tracker
        // placements do): clusters over the pooled poses would put each
        // station in folds of its own, and a training fold without a
        // station could not place its held-out poses.
        let model = flexcal_kinematics::RobotDescription::builtin("ur10")
            .unwrap()
            .build()
            .unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let station = |name: &str, centre: f64, n: usize, rng: &mut rand_chacha::ChaCha8Rng| {
            let poses = (0..n)
                .map(|_| {
                    let q = (0..6)
                        .map(|i| {
                            let c = if i == 0 { centre } else { 0.0 };
                            c + rng.random_range(-0.5..0.5)
                        })
                        .collect();
                    crate::measurement::Measurement::new(q, nalgebra::Vector3::zeros())
                })
                .collect();
            MeasurementSet::new(name, poses).unwrap()
        };
        let pooled = MeasurementSet::pooled(&[
            station("west", -2.0, 60, &mut rng),
            station("east", 2.0, 23, &mut rng),
        ])
        .unwrap();
        for scheme in [FoldScheme::JointClusters, FoldScheme::AcquisitionBlocks] {
            let folds = fold_assignment(&model, &fold_poses(&pooled), 5, scheme, 1);
            for f in 0..5 {
                for s in 0..2 {
                    let held_out = (0..pooled.len())
                        .filter(|&k| folds[k] == f && pooled.station_of(k) == s)
                        .count();
                    let of_station = (0..pooled.len())
                        .filter(|&k| pooled.station_of(k) == s)
                        .count();
                    assert!(
                        held_out > 0 && held_out < of_station / 2,
                        "{scheme:?}: fold {f} holds {held_out} of station {s}'s {of_station} poses"
                    );
                }
            }
        }
    }

    /// Seeded property: in every extrapolating fold each held-out pose lies
    /// outside the training part's range in the fold's joint angle (on the
    /// circle, whichever turn it is recorded in) or in its gravity torque,
    /// and the training part keeps every station. The poses spread over
    /// random ranges, some of them across the +/- pi seam or wider than a
    /// turn.
    #[test]
    fn every_held_out_pose_extrapolates_in_its_folds_coordinate() {
        let model = flexcal_kinematics::RobotDescription::builtin("ur10")
            .unwrap()
            .build()
            .unwrap();
        let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(33);
        let mut folds_seen = 0;
        for _ in 0..12 {
            let centres: Vec<f64> = (0..6).map(|_| rng.random_range(-4.0..4.0)).collect();
            let spreads: Vec<f64> = (0..6).map(|_| rng.random_range(0.0..4.0)).collect();
            let n = rng.random_range(40..160);
            let poses: Vec<crate::measurement::Measurement> = (0..n)
                .map(|_| {
                    let q = (0..6)
                        .map(|i| centres[i] + rng.random_range(-spreads[i]..=spreads[i]))
                        .collect();
                    crate::measurement::Measurement::new(q, nalgebra::Vector3::zeros())
                })
                .collect();
            let set = MeasurementSet::new("random", poses).unwrap();
            let fold_poses = fold_poses(&set);
            let torques = gravity_torques(&model, &fold_poses.q, &gravity).unwrap();
            let folds = extrapolating_folds(&model, &fold_poses, Some(&gravity), 0.05).unwrap();
            for (fold, held_out) in &folds {
                folds_seen += 1;
                let i = model
                    .actuated_names()
                    .iter()
                    .position(|name| *name == fold.joint)
                    .unwrap();
                let train: Vec<usize> = (0..n).filter(|&k| !held_out[k]).collect();
                assert!(!train.is_empty());
                let angle = CoordinateCoverage::of(
                    train.iter().map(|&k| fold_poses.q[k][i]),
                    Some(std::f64::consts::TAU),
                );
                let torque = CoordinateCoverage::of(train.iter().map(|&k| torques[k][i]), None);
                let mut count = 0;
                for k in (0..n).filter(|&k| held_out[k]) {
                    count += 1;
                    let outside_angle = fold.angle_ends && !angle.contains(fold_poses.q[k][i], 0.0);
                    let outside_torque = fold.torque_ends && !torque.contains(torques[k][i], 0.0);
                    assert!(
                        outside_angle || outside_torque,
                        "{}: held-out pose {k} at {} rad, {} N.m inside the training ranges {angle:?} {torque:?}",
                        fold.label(),
                        fold_poses.q[k][i],
                        torques[k][i]
                    );
                }
                assert_eq!(count, fold.held_out);
                assert!(count >= MIN_EXTRAPOLATION_HELD_OUT);
            }
        }
        assert!(folds_seen >= 40, "{folds_seen} folds");
    }

    /// Seeded property: on a periodic coordinate the ends are measured
    /// along the covered arc from its start, whichever turn each value is
    /// recorded in; the flags match the positions the values were drawn
    /// at, and a range without length has no ends.
    #[test]
    fn range_ends_measure_along_the_arc_whatever_the_turn() {
        use std::f64::consts::TAU;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
        for _ in 0..40 {
            let start = rng.random_range(-4.0..4.0);
            let length = rng.random_range(0.5..4.0);
            let share = rng.random_range(0.05..0.3);
            let t: Vec<f64> = (0..60).map(|_| rng.random_range(0.0..length)).collect();
            let values: Vec<f64> = t
                .iter()
                .map(|t| start + t + TAU * f64::from(rng.random_range(-2i32..=2)))
                .collect();
            let coverage = CoordinateCoverage::of(values.iter().copied(), Some(TAU));
            let t_min = t.iter().copied().fold(f64::INFINITY, f64::min);
            let t_max = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let cut = share * (t_max - t_min);
            let [low, high] = range_ends(&values, &coverage, share);
            for k in 0..values.len() {
                let from_start = t[k] - t_min;
                let to_end = t_max - t[k];
                // Values within round-off of a cut may fall either way.
                if (from_start - cut).abs() > 1e-9 {
                    assert_eq!(low[k], from_start < cut, "value {k} of {values:?}");
                }
                if (to_end - cut).abs() > 1e-9 {
                    assert_eq!(high[k], to_end < cut, "value {k} of {values:?}");
                }
            }
            assert!(low.contains(&true) && high.contains(&true));
        }
        let still = [0.7; 5];
        let coverage = CoordinateCoverage::of(still.iter().copied(), None);
        assert_eq!(
            range_ends(&still, &coverage, 0.2),
            [vec![false; 5], vec![false; 5]]
        );
    }

    /// A joint that does not move and carries no torque gets no fold; a
    /// joint that moves gets one holding out about the outer fifth of its
    /// uniformly spread poses.
    #[test]
    fn a_still_joint_gets_no_fold() {
        let model = flexcal_kinematics::RobotDescription::builtin("ur10")
            .unwrap()
            .build()
            .unwrap();
        let poses: Vec<crate::measurement::Measurement> = (0..101)
            .map(|k| {
                let mut q = vec![0.3, -1.2, 1.0, -0.5, 1.5, 0.0];
                q[1] += 0.01 * k as f64;
                crate::measurement::Measurement::new(q, nalgebra::Vector3::zeros())
            })
            .collect();
        let set = MeasurementSet::new("joint 2 only", poses).unwrap();
        let folds = extrapolating_folds(&model, &fold_poses(&set), None, 0.05).unwrap();
        assert_eq!(folds.len(), 1, "{folds:?}");
        let (fold, _) = &folds[0];
        assert_eq!(fold.joint, model.actuated_names()[1]);
        assert!(fold.angle_ends && !fold.torque_ends);
        // 10 % of the range at each end of 101 evenly spaced values: 10 or
        // 11 poses per end, rounding at the boundaries.
        assert!((18..=22).contains(&fold.held_out), "{}", fold.label());
    }
}
