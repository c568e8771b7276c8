//! How much the model's error grows where a pose leaves the training
//! poses' ranges: the part of the predicted 95 % bound
//! ([`crate::AccuracyMap`]) that no statistic of the training fit holds.
//!
//! The bound's other two parts are measured at the training poses: the
//! residual scatter and the identified unknowns' uncertainty. Outside the
//! range of an actuated coordinate the model meets configurations it was
//! never fitted to, and an effect it lacks (a non-linear stiffness, an
//! elastic term the gravity torques of the training poses did not excite)
//! grows with the distance out. That growth is measured from the training
//! series itself, by folds that hold out the ends of each coordinate's
//! range:
//!
//! 1. **Folds**: for each actuated coordinate j and each end of its range
//!    (the interval, or the arc of a revolute coordinate,
//!    [`crate::CoordinateCoverage`]), the poses in the outer
//!    [`HELD_OUT_FRACTION`] of the range's length are held out; the same
//!    model (the same options, the selected groups of unknowns) is
//!    identified on the rest. The ends are found as model selection's
//!    extrapolating folds find theirs ([`crate::folds`], one function
//!    with the share as its parameter); the two rules differ in what they
//!    ask of the folds: here each end on its own (the growth is fitted to
//!    the distance outside one end) and a wider share, so that the held-out
//!    poses reach far enough beyond the rest to measure a growth; there
//!    both ends of a joint's angle and gravity-torque ranges at once, a
//!    narrower share, to score candidate models.
//! 2. **Held-out errors**: each held-out observation's position error `e`
//!    with the fold's model (its measurement frame as identified: the same
//!    instrument), its in-model variance per axis `v = tr Sigma_pred / 3 +
//!    s^2` (the fold's own bound, [`crate::bound_95`]), and its distance
//!    `d_i` outside the fold's training range of every coordinate i (rad or
//!    m).
//! 3. **Growth**: the excess of the error over the in-model variance,
//!    `e^2 / 3 - v` per axis, fitted by non-negative least squares to
//!    `sum_i g_i^2 d_i^2` over every held-out observation of every fold:
//!    `g_i` is the standard deviation per axis of the model's own error per
//!    unit of distance outside coordinate i's range (m/rad or m/m), zero
//!    where the folds found the model to hold.
//! 4. **Bound**: at a pose at distances `d_i` outside the full training
//!    ranges the bound gains the per-axis variance `sum_i g_i^2 d_i^2`
//!    ([`crate::AccuracyMap::with_extrapolation`]); inside every range it
//!    is unchanged.
//!
//! Limitations: the growth is linear in the distance, measured over the
//! outer fifth of each range and extended beyond it; a pose far outside
//! (further than the folds reached, [`CoordinateGrowth::max_distance`])
//! relies on that extension. Coordinates are taken as adding up: an effect
//! that appears only where two coordinates leave their ranges together is
//! not seen. A coordinate whose range is a single value gives no fold.

use flexcal_kinematics::Model;
use serde::{Deserialize, Serialize};

use crate::accuracy::{AccuracyMap, CHI2_3_95, accuracy_at, grid_row};
use crate::coverage::CoordinateCoverage;
use crate::error::CalibError;
use crate::folds::range_ends;
use crate::identify::Calibration;
use crate::measurement::MeasurementSet;
use crate::options::CalibrationOptions;

/// Share of a coordinate's covered length held out at each end (0.2: the
/// outer fifth).
pub const HELD_OUT_FRACTION: f64 = 0.2;

/// Fewest poses a fold holds out; an end with fewer is not a fold.
pub const MIN_HELD_OUT_POSES: usize = 3;

/// One end of one coordinate's range held out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GrowthFold {
    /// The actuated coordinate whose end is held out.
    pub coordinate: String,
    /// `low` or `high`: the end of the range (for a revolute coordinate,
    /// the start or the end of the covered arc).
    pub end: String,
    /// Number of poses held out.
    pub held_out_poses: usize,
    /// Largest distance of a held-out pose outside the fold's training
    /// range of this coordinate (rad or m).
    pub max_distance: f64,
    /// RMS of the held-out position errors (mm).
    pub held_out_rms_mm: f64,
    /// RMS of the held-out observations' in-model 95 % bounds divided by
    /// `sqrt(chi2_3(0.95) / 3)`: the RMS error the fold's own bound
    /// expected (mm).
    pub expected_rms_mm: f64,
    /// Why the fold was not used (too few poses left, an identification
    /// that failed), `None` when it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skipped: Option<String>,
}

/// The measured growth of the model's error outside one coordinate's range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoordinateGrowth {
    /// The actuated coordinate.
    pub coordinate: String,
    /// Standard deviation per axis of the model's own error per unit of
    /// distance outside the range, `g` (m/rad for a revolute coordinate,
    /// m/m for a prismatic one; 0: the folds found the model to hold).
    pub growth: f64,
    /// Largest distance outside the range that the folds measured (rad or
    /// m): beyond it the growth is extended, not measured.
    pub max_distance: f64,
}

/// The model's own uncertainty outside the training poses' ranges, from
/// held-out-range folds (module docs): the third part of the predicted
/// 95 % bound.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtrapolationModel {
    /// What the training poses cover of each actuated coordinate.
    pub ranges: Vec<CoordinateCoverage>,
    /// Per actuated coordinate, in the model's order.
    pub growth: Vec<CoordinateGrowth>,
    /// Every fold, used or skipped.
    pub folds: Vec<GrowthFold>,
    /// Number of held-out observations the growth was fitted to.
    pub n_observations: usize,
}

impl ExtrapolationModel {
    /// Per-axis variance of the model's own error at the configuration `q`
    /// (rad or m): `sum_i g_i^2 d_i^2` with `d_i` the distance outside the
    /// training range of coordinate i (m^2; 0 inside every range).
    pub fn variance_at(&self, q: &[f64]) -> f64 {
        self.ranges
            .iter()
            .zip(&self.growth)
            .zip(q)
            .map(|((range, g), q)| (g.growth * range.distance_outside(*q)).powi(2))
            .sum()
    }

    /// `model's error grows X mm/deg outside joint ...` for the
    /// coordinates whose growth is not zero, for reports; revolute growths
    /// per degree, prismatic per mm.
    pub fn notes(&self) -> Vec<String> {
        self.growth
            .iter()
            .zip(&self.ranges)
            .filter(|(g, _)| g.growth > 0.0)
            .map(|(g, range)| {
                let (per, scale, reach) = if range.period.is_some() {
                    ("deg", std::f64::consts::PI / 180.0, g.max_distance.to_degrees())
                } else {
                    ("mm", 1e-3, g.max_distance * 1e3)
                };
                format!(
                    "outside the training range of {}, the model's error grows {:.4} mm per {per} (per axis, 1 sigma; measured to {reach:.1} {per} out by held-out-range folds)",
                    g.coordinate,
                    g.growth * scale * 1e3
                )
            })
            .collect()
    }
}

impl AccuracyMap {
    /// The map with the extrapolation part of every bound
    /// ([`ExtrapolationModel::variance_at`]) added to the other two
    /// ([`crate::BoundParts`]), the coverage and mean bound recomputed, and
    /// `extrapolation` kept in the map. Inside every training range a
    /// bound is unchanged.
    pub fn with_extrapolation(mut self, extrapolation: &ExtrapolationModel) -> Self {
        let mut within = 0usize;
        let mut measured = 0usize;
        for p in &mut self.poses {
            p.parts.extrapolation_mm = (CHI2_3_95 * extrapolation.variance_at(&p.q)).sqrt() * 1e3;
            p.bound_95_mm = p.parts.bound_mm();
            if let Some(e) = p.actual_error_mm {
                measured += 1;
                within += usize::from(e <= p.bound_95_mm);
            }
        }
        if self.coverage.is_some() {
            self.coverage = Some(within as f64 / measured.max(1) as f64);
        }
        self.mean_bound_95_mm =
            self.poses.iter().map(|p| p.bound_95_mm).sum::<f64>() / self.poses.len().max(1) as f64;
        self.extrapolation = Some(extrapolation.clone());
        self
    }
}

impl Calibration {
    /// The growth of this calibration's error outside its training poses'
    /// ranges, from folds that hold out the ends of each coordinate's range
    /// of `training` (the set it was identified on) and identify again with
    /// `options` (those it was identified with: after model selection, the
    /// chosen ones); module docs. With several targets per pose every
    /// observation of a held-out pose counts.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] when `training` has another number of
    /// poses than the calibration; a model failure at a held-out pose. A
    /// fold whose identification fails is skipped and says why.
    pub fn extrapolation(
        &self,
        model: &Model,
        training: &MeasurementSet,
        options: &CalibrationOptions,
    ) -> Result<ExtrapolationModel, CalibError> {
        check_training(self.n_poses, training.len())?;
        extrapolation_model(model, training, options)
    }
}

/// A training set of `n` poses for a calibration of `expected`.
fn check_training(expected: usize, n: usize) -> Result<(), CalibError> {
    if n == expected {
        return Ok(());
    }
    Err(CalibError::InvalidOption {
        name: "extrapolation",
        reason: format!("a training set of {n} poses for a calibration identified on {expected}"),
    })
}

/// The held-out observations of the folds, as the growth fit reads them.
#[derive(Default)]
struct Excess {
    /// Per observation, the squared distances outside each coordinate's
    /// fold range (rad^2 or m^2).
    distances2: Vec<Vec<f64>>,
    /// Per observation, `e^2 / 3 - v` (m^2).
    excess: Vec<f64>,
}

/// The folds of every coordinate's ends, the held-out errors and the
/// growth fitted to them (module docs, steps 1 to 3).
fn extrapolation_model(
    model: &Model,
    training: &MeasurementSet,
    options: &CalibrationOptions,
) -> Result<ExtrapolationModel, CalibError> {
    let configurations: Vec<&[f64]> = (0..training.len())
        .map(|k| training.configuration(k))
        .collect();
    let ranges = CoordinateCoverage::of_configurations(model, &configurations);
    let names = model.actuated_names();
    let mut folds = Vec::new();
    let mut excess = Excess::default();
    let mut reach = vec![0.0f64; ranges.len()];
    for (j, range) in ranges.iter().enumerate() {
        if range.length() <= 0.0 {
            continue;
        }
        let values: Vec<f64> = configurations.iter().map(|q| q[j]).collect();
        let ends = range_ends(&values, range, HELD_OUT_FRACTION);
        for (end, at_end) in ["low", "high"].into_iter().zip(&ends) {
            let held: Vec<usize> = (0..values.len()).filter(|&k| at_end[k]).collect();
            let fold = run_fold(
                model,
                training,
                options,
                &held,
                (j, &names[j], end),
                &mut excess,
            )?;
            if fold.skipped.is_none() {
                reach[j] = reach[j].max(fold.max_distance);
            }
            folds.push(fold);
        }
    }
    let gamma = non_negative_least_squares(&excess.distances2, &excess.excess, ranges.len());
    let growth = names
        .iter()
        .zip(&gamma)
        .zip(&reach)
        .map(|((name, g2), reach)| CoordinateGrowth {
            coordinate: name.clone(),
            growth: g2.max(0.0).sqrt(),
            max_distance: *reach,
        })
        .collect();
    Ok(ExtrapolationModel {
        ranges,
        growth,
        folds,
        n_observations: excess.excess.len(),
    })
}

/// One fold: the poses `held` of `training` held out at `end` of
/// coordinate `j` (named `name`), the rest identified with `options`; the
/// held-out observations appended to `excess`.
fn run_fold(
    model: &Model,
    training: &MeasurementSet,
    options: &CalibrationOptions,
    held: &[usize],
    (j, name, end): (usize, &str, &str),
    excess: &mut Excess,
) -> Result<GrowthFold, CalibError> {
    let mut fold = GrowthFold {
        coordinate: name.to_string(),
        end: end.to_string(),
        held_out_poses: held.len(),
        max_distance: 0.0,
        held_out_rms_mm: 0.0,
        expected_rms_mm: 0.0,
        skipped: None,
    };
    if held.len() < MIN_HELD_OUT_POSES {
        fold.skipped = Some(format!(
            "{} poses at this end, fewer than {MIN_HELD_OUT_POSES}",
            held.len()
        ));
        return Ok(fold);
    }
    let kept: Vec<usize> = (0..training.len()).filter(|k| !held.contains(k)).collect();
    let fitted = training
        .subset(&kept)
        .and_then(|rest| rest.fit(model, options));
    let fitted = match fitted {
        Ok(fitted) => fitted,
        Err(e) => {
            fold.skipped = Some(format!("identification on the other poses failed: {e}"));
            return Ok(fold);
        }
    };
    let held_out = training.subset(held)?;
    let errors = MeasurementSet::held_out_errors(model, &fitted, &held_out)?;
    let map = match accuracy_at(&fitted, model, &held_out, &grid_row, None, None) {
        Ok(map) => map,
        Err(e) => {
            fold.skipped = Some(format!("no bound on the held-out poses: {e}"));
            return Ok(fold);
        }
    };
    if map.poses.len() != errors.len() {
        return Err(CalibError::InvalidOption {
            name: "extrapolation",
            reason: format!(
                "{} held-out errors for {} observations",
                errors.len(),
                map.poses.len()
            ),
        });
    }
    let kept_q: Vec<&[f64]> = kept.iter().map(|&k| training.configuration(k)).collect();
    let fold_ranges = CoordinateCoverage::of_configurations(model, &kept_q);
    let (mut sum_e2, mut sum_v) = (0.0, 0.0);
    for (p, e) in map.poses.iter().zip(&errors) {
        let v = (p.bound_95_mm * 1e-3).powi(2) / CHI2_3_95;
        let d2: Vec<f64> = fold_ranges
            .iter()
            .zip(&p.q)
            .map(|(r, q)| r.distance_outside(*q).powi(2))
            .collect();
        fold.max_distance = fold.max_distance.max(d2[j].sqrt());
        excess.excess.push(e * e / 3.0 - v);
        excess.distances2.push(d2);
        sum_e2 += e * e;
        sum_v += 3.0 * v;
    }
    let n = errors.len().max(1) as f64;
    fold.held_out_rms_mm = (sum_e2 / n).sqrt() * 1e3;
    fold.expected_rms_mm = (sum_v / n).sqrt() * 1e3;
    Ok(fold)
}

/// The non-negative `gamma` (n of them) minimising `sum_k (y_k - sum_i
/// gamma_i a_ki)^2`, by active sets (Lawson and Hanson): the
/// coordinates whose unconstrained value would be negative are set to
/// zero in turn, the others solved again by SVD. Columns that are zero
/// everywhere give 0.
fn non_negative_least_squares(a: &[Vec<f64>], y: &[f64], n: usize) -> Vec<f64> {
    let mut free: Vec<usize> = (0..n)
        .filter(|&i| a.iter().any(|row| row[i] > 0.0))
        .collect();
    let mut gamma = vec![0.0; n];
    while !free.is_empty() {
        let m = nalgebra::DMatrix::<f64>::from_fn(a.len(), free.len(), |k, c| a[k][free[c]]);
        let rhs = nalgebra::DVector::<f64>::from_column_slice(y);
        let Ok(solution) = m.svd(true, true).solve(&rhs, 1e-12) else {
            break;
        };
        let most_negative = (0..free.len())
            .filter(|&c| solution[c] < 0.0)
            .min_by(|&a, &b| solution[a].total_cmp(&solution[b]));
        match most_negative {
            Some(c) => {
                free.remove(c);
            }
            None => {
                for (c, &i) in free.iter().enumerate() {
                    gamma[i] = solution[c];
                }
                break;
            }
        }
    }
    gamma
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Seeded property: with non-negative true coefficients and noise-free
    /// data, the fit recovers them; a coefficient whose column pulls the
    /// other way is zero, and the rest is the least-squares fit of the
    /// remaining columns (checked against the normal equations solved
    /// here).
    #[test]
    fn non_negative_least_squares_recovers_and_clips() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..50 {
            let n = rng.random_range(1..5);
            let rows: Vec<Vec<f64>> = (0..30)
                .map(|_| (0..n).map(|_| rng.random_range(0.0..2.0)).collect())
                .collect();
            let truth: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..3.0)).collect();
            let y: Vec<f64> = rows
                .iter()
                .map(|r| r.iter().zip(&truth).map(|(a, t)| a * t).sum())
                .collect();
            let fitted = non_negative_least_squares(&rows, &y, n);
            for (f, t) in fitted.iter().zip(&truth) {
                assert!((f - t).abs() < 1e-9, "{fitted:?} {truth:?}");
            }
        }
        // y = 2 a0 - 5 a1: the second coefficient is clipped, the first is
        // the one-column fit sum(a0 y) / sum(a0^2).
        let rows: Vec<Vec<f64>> = (0..20)
            .map(|k| vec![1.0 + k as f64 * 0.1, 0.5 + (k % 3) as f64])
            .collect();
        let y: Vec<f64> = rows.iter().map(|r| 2.0 * r[0] - 5.0 * r[1]).collect();
        let fitted = non_negative_least_squares(&rows, &y, 2);
        let expected = rows.iter().zip(&y).map(|(r, y)| r[0] * y).sum::<f64>()
            / rows.iter().map(|r| r[0] * r[0]).sum::<f64>();
        assert_eq!(fitted[1], 0.0);
        assert!(
            (fitted[0] - expected.max(0.0)).abs() < 1e-9,
            "{fitted:?} {expected}"
        );
        // A column that is zero everywhere gives zero.
        let zero = non_negative_least_squares(&[vec![0.0, 1.0], vec![0.0, 2.0]], &[1.0, 2.0], 2);
        assert_eq!(zero[0], 0.0);
        assert!((zero[1] - 1.0).abs() < 1e-12);
    }
}
