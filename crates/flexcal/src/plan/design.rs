//! The numerics of campaign planning: the linearised identification of a
//! set of candidate poses, the predicted variance it leaves over the
//! region, greedy selection and an exchange pass on the I-optimal
//! criterion (the mean over the region of the predicted position variance).
//!
//! With `A_k` the weighted rows of candidate k (`J_k / sigma`, per axis:
//! 3 position rows, or 6 when the instrument measures full poses) over the unknowns the pool identifies (the measurement frame's
//! apart: the robot's accuracy is its uncertainty with the frame known,
//! which is the inverse of the robot block of the information matrix), the
//! information of a set S is `I_S = sum_{k in S} A_k^T A_k` and the
//! covariance `Sigma_S = I_S^-1`. At a region point r with position rows
//! `J_r` the predicted variance is `tr(J_r Sigma_S J_r^T)`, and the
//! criterion `c(S) = tr(Sigma_S M)` with `M = mean_r J_r^T J_r`.
//!
//! Adding candidate k lowers `c` by `tr((I + A_k Sigma A_k^T)^-1 A_k
//! Sigma M Sigma A_k^T)` (the Sherman-Morrison-Woodbury identity), which
//! is what greedy and exchange rank candidates by. While fewer poses than
//! unknowns are chosen, the information is regularised by `prior` times
//! the identity (columns scaled to unit mean information per candidate),
//! so that the first poses go to the directions nothing determines yet.
//! No explicit inverse is formed: every `Sigma x` is a Cholesky solve.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// Regularisation of the greedy start, relative to the mean information
/// of one candidate per (scaled) unknown.
pub(crate) const GREEDY_PRIOR: f64 = 1e-6;

/// Largest number of exchange passes over the selection.
const MAX_EXCHANGE_PASSES: usize = 10;

/// Relative tolerance of a Cholesky factor's pivots below which an
/// information matrix counts as singular (squared ratio of its smallest to
/// its largest diagonal entry): rounding level only. A nearly dependent
/// unknown that the pool's identification kept is predicted with its
/// large variance, as `calibrate` would.
const SINGULAR_PIVOT_RATIO: f64 = 1e-24;

/// The linearised campaign: weighted candidate rows and region rows over
/// the same scaled unknowns.
pub(crate) struct Design {
    /// Weighted rows of each candidate (3 or 6 x p, scaled columns).
    candidates: Vec<DMatrix<f64>>,
    /// Position rows of each region point (3 x p, scaled columns; m).
    region: Vec<DMatrix<f64>>,
    /// `M = mean_r J_r^T J_r` (p x p, scaled).
    moment: DMatrix<f64>,
}

impl Design {
    /// The design from the weighted candidate rows (3 or 6 x p) and the
    /// region's position rows (3 x p), SI, same unknowns. Columns are scaled so that the
    /// mean information of one candidate is 1 per unknown (zero columns
    /// keep scale 1).
    pub(crate) fn new(candidates: Vec<DMatrix<f64>>, region: Vec<DMatrix<f64>>) -> Self {
        let p = candidates.first().map_or(0, |a| a.ncols());
        let n = candidates.len().max(1) as f64;
        let scale = DVector::<f64>::from_fn(p, |j, _| {
            let sum: f64 = candidates.iter().map(|a| a.column(j).norm_squared()).sum();
            let s = (sum / n).sqrt();
            if s > 0.0 { 1.0 / s } else { 1.0 }
        });
        let scaled = |m: DMatrix<f64>| {
            let mut m = m;
            for (j, s) in scale.iter().enumerate() {
                m.column_mut(j).scale_mut(*s);
            }
            m
        };
        let candidates: Vec<DMatrix<f64>> = candidates.into_iter().map(scaled).collect();
        let region: Vec<DMatrix<f64>> = region.into_iter().map(scaled).collect();
        let mut moment = DMatrix::<f64>::zeros(p, p);
        for r in &region {
            moment += r.transpose() * r;
        }
        moment /= region.len().max(1) as f64;
        Self {
            candidates,
            region,
            moment,
        }
    }

    /// Number of unknowns.
    fn n_unknowns(&self) -> usize {
        self.moment.nrows()
    }

    /// Number of candidates.
    pub(crate) fn n_candidates(&self) -> usize {
        self.candidates.len()
    }

    /// The information of `selected` plus `prior` times the identity.
    pub(crate) fn information(&self, selected: &[usize], prior: f64) -> DMatrix<f64> {
        let p = self.n_unknowns();
        let mut info = DMatrix::<f64>::identity(p, p) * prior;
        for &k in selected {
            let a = &self.candidates[k];
            info += a.transpose() * a;
        }
        info
    }

    /// The criterion `tr(Sigma M)` of a factored information.
    fn criterion(&self, chol: &Cholesky<f64, Dyn>) -> f64 {
        chol.solve(&self.moment).trace()
    }

    /// How much adding candidate `k` lowers the criterion of the factored
    /// information `chol` (Woodbury; module docs).
    fn gain(&self, chol: &Cholesky<f64, Dyn>, k: usize) -> f64 {
        let a = &self.candidates[k];
        let g = chol.solve(&a.transpose());
        let s = DMatrix::<f64>::identity(a.nrows(), a.nrows()) + a * &g;
        let h = g.transpose() * &self.moment * &g;
        match s.cholesky() {
            Some(c) => c.solve(&h).trace(),
            None => 0.0,
        }
    }

    /// The candidate outside `taken` that lowers the criterion most, and
    /// by how much (`None` when every candidate is taken).
    fn best_addition(&self, chol: &Cholesky<f64, Dyn>, taken: &[bool]) -> Option<(usize, f64)> {
        (0..self.n_candidates())
            .filter(|&k| !taken[k])
            .map(|k| (k, self.gain(chol, k)))
            .fold(None, |best: Option<(usize, f64)>, (k, g)| match best {
                Some((_, bg)) if bg >= g => best,
                _ => Some((k, g)),
            })
    }

    /// `count` candidates chosen one at a time, each the one that lowers
    /// the (regularised) criterion most: the greedy order, so that its
    /// first n are the greedy campaign of n poses. `None` when the
    /// regularised information is not positive definite (not expected).
    pub(crate) fn greedy(&self, count: usize) -> Option<Vec<usize>> {
        let mut taken = vec![false; self.n_candidates()];
        let mut info = self.information(&[], GREEDY_PRIOR);
        let mut order = Vec::with_capacity(count);
        for _ in 0..count.min(self.n_candidates()) {
            let chol = info.clone().cholesky()?;
            let (k, _) = self.best_addition(&chol, &taken)?;
            taken[k] = true;
            order.push(k);
            let a = &self.candidates[k];
            info += a.transpose() * a;
        }
        Some(order)
    }

    /// Exchange passes over `selected`: each pose in turn is replaced by
    /// the candidate that lowers the (regularised) criterion most, when one
    /// does, until a pass changes nothing. Returns the number of
    /// exchanges made.
    pub(crate) fn exchange(&self, selected: &mut [usize]) -> usize {
        let mut exchanges = 0;
        for _ in 0..MAX_EXCHANGE_PASSES {
            let mut changed = false;
            for i in 0..selected.len() {
                let others: Vec<usize> = selected
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, &k)| k)
                    .collect();
                let Some(chol) = self.information(&others, GREEDY_PRIOR).cholesky() else {
                    continue;
                };
                let current = self.gain(&chol, selected[i]);
                let mut taken = vec![false; self.n_candidates()];
                selected.iter().for_each(|&k| taken[k] = true);
                if let Some((k, gain)) = self.best_addition(&chol, &taken)
                    && gain > current + 1e-9 * self.criterion(&chol).abs()
                {
                    selected[i] = k;
                    exchanges += 1;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        exchanges
    }

    /// The predicted position variance `tr(J_r Sigma J_r^T)` of each
    /// region point with the poses `selected` (m^2, no regularisation);
    /// `None` when their information is singular (fewer independent
    /// equations than unknowns).
    pub(crate) fn region_variances(&self, selected: &[usize]) -> Option<Vec<f64>> {
        let chol = self.information(selected, 0.0).cholesky()?;
        let l = chol.l_dirty();
        let diagonal = l.diagonal();
        let (lo, hi) = diagonal
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), d| {
                (lo.min(*d), hi.max(*d))
            });
        if !(lo > 0.0 && (lo / hi).powi(2) > SINGULAR_PIVOT_RATIO) {
            return None;
        }
        let l = chol.l();
        Some(
            self.region
                .iter()
                .map(|r| {
                    // tr(J Sigma J^T) = ||L^-1 J^T||_F^2 with Sigma = (L L^T)^-1.
                    l.solve_lower_triangular(&r.transpose())
                        .map_or(f64::INFINITY, |x| x.norm_squared())
                })
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_blocks(rng: &mut impl Rng, n: usize, rows: usize, p: usize) -> Vec<DMatrix<f64>> {
        (0..n)
            .map(|_| DMatrix::from_fn(rows, p, |_, j| rng.random_range(-1.0..1.0) * (j + 1) as f64))
            .collect()
    }

    /// The Woodbury gain equals the criterion recomputed from scratch with
    /// the candidate added, and the region variances equal
    /// `tr(J Sigma J^T)` with Sigma from an explicit inverse (test only).
    #[test]
    fn gains_and_variances_match_a_direct_evaluation() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        // Candidates measuring positions (3 rows) and full poses (6 rows).
        for (n, rows, p, r) in [
            (30, 3, 5, 7),
            (40, 3, 12, 3),
            (12, 3, 9, 20),
            (10, 6, 14, 9),
        ] {
            let design = Design::new(
                random_blocks(&mut rng, n, rows, p),
                random_blocks(&mut rng, r, 3, p),
            );
            let selected: Vec<usize> = (0..n / 2).collect();
            let info = design.information(&selected, 1e-3);
            let chol = info.clone().cholesky().unwrap();
            for k in n / 2..n {
                let mut with = selected.clone();
                with.push(k);
                let after = design.information(&with, 1e-3).try_inverse().unwrap();
                let direct = info.clone().try_inverse().unwrap() * &design.moment;
                let expected = direct.trace() - (after * &design.moment).trace();
                let gain = design.gain(&chol, k);
                assert!(
                    (gain - expected).abs() < 1e-8 * expected.abs().max(1e-12),
                    "{gain} vs {expected}"
                );
            }
            let sigma = design.information(&selected, 0.0).try_inverse().unwrap();
            let variances = design.region_variances(&selected).unwrap();
            for (v, j) in variances.iter().zip(&design.region) {
                let expected = (j * &sigma * j.transpose()).trace();
                assert!((v - expected).abs() < 1e-8 * expected, "{v} vs {expected}");
            }
        }
    }

    /// Exchange never makes the criterion worse than greedy's, and greedy's
    /// first choice is the best single candidate by a direct evaluation.
    #[test]
    fn exchange_improves_on_greedy_and_greedy_starts_with_the_best() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let design = Design::new(
            random_blocks(&mut rng, 40, 3, 6),
            random_blocks(&mut rng, 10, 3, 6),
        );
        let criterion = |s: &[usize]| {
            design.criterion(&design.information(s, GREEDY_PRIOR).cholesky().unwrap())
        };
        let mut selected = design.greedy(8).unwrap();
        let best_single = (0..40)
            .min_by(|&a, &b| criterion(&[a]).total_cmp(&criterion(&[b])))
            .unwrap();
        assert_eq!(selected[0], best_single);
        let greedy = criterion(&selected);
        design.exchange(&mut selected);
        let exchanged = criterion(&selected);
        assert!(
            exchanged <= greedy * (1.0 + 1e-12),
            "{exchanged} > {greedy}"
        );
        let mut unique = selected.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), 8);
    }

    /// Too few poses to determine the unknowns: no variances.
    #[test]
    fn a_singular_information_gives_no_variances() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let design = Design::new(
            random_blocks(&mut rng, 10, 3, 7),
            random_blocks(&mut rng, 4, 3, 7),
        );
        assert!(design.region_variances(&[0, 1]).is_none());
        assert!(design.region_variances(&[0, 1, 2]).is_some());
    }
}
