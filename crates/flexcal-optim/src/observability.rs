//! Observability indices of a pose set and pose selection (beyond the paper).

use faer::{Mat, MatRef};

use crate::error::{OptimError, Result, check_len, invalid};
use crate::identifiability::{check_finite, column_scales, sorted_singular_values};
use crate::problem::ColumnScaling;

/// The five classical observability indices of an identification Jacobian with `m`
/// rows and singular values `sigma_1 >= ... >= sigma_n` (Sun & Hollerbach 2008 review them).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ObservabilityIndices {
    /// O1 = (sigma_1 sigma_2 ... sigma_n)^(1/n) / sqrt(m) (Borm & Menq 1991): the
    /// volume of the error ellipsoid, D-optimality.
    pub o1: f64,
    /// O2 = sigma_min / sigma_max, the inverse condition number (Driels & Pathre 1990).
    pub o2: f64,
    /// O3 = sigma_min, the minimum singular value (Nahvi, Hollerbach & Hayward 1994).
    pub o3: f64,
    /// O4 = sigma_min^2 / sigma_max, the noise amplification index (Nahvi & Hollerbach 1996).
    pub o4: f64,
    /// O5 = 1 / (1/sigma_1 + ... + 1/sigma_n) (Sun & Hollerbach 2008), akin to A-optimality.
    pub o5: f64,
}

/// Which observability index to maximise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum ObservabilityIndex {
    /// [`ObservabilityIndices::o1`] (default).
    #[default]
    O1,
    /// [`ObservabilityIndices::o2`].
    O2,
    /// [`ObservabilityIndices::o3`].
    O3,
    /// [`ObservabilityIndices::o4`].
    O4,
    /// [`ObservabilityIndices::o5`].
    O5,
}

impl ObservabilityIndices {
    /// The indices from singular values (any order) of a matrix with `n_rows` rows.
    /// Any zero singular value makes every index 0.
    pub fn from_singular_values(singular_values: &[f64], n_rows: usize) -> Self {
        let n = singular_values.len();
        let smax = singular_values.iter().copied().fold(0.0, f64::max);
        let smin = singular_values
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        if n == 0 || n_rows == 0 || smin <= 0.0 {
            return Self {
                o1: 0.0,
                o2: 0.0,
                o3: 0.0,
                o4: 0.0,
                o5: 0.0,
            };
        }
        // Geometric mean through logarithms: the plain product under/overflows for
        // 40 parameters spanning several decades.
        let log_mean = singular_values.iter().map(|s| s.ln()).sum::<f64>() / n as f64;
        Self {
            o1: log_mean.exp() / (n_rows as f64).sqrt(),
            o2: smin / smax,
            o3: smin,
            o4: smin * smin / smax,
            o5: 1.0 / singular_values.iter().map(|s| 1.0 / s).sum::<f64>(),
        }
    }

    /// The value of one index.
    pub fn get(&self, index: ObservabilityIndex) -> f64 {
        match index {
            ObservabilityIndex::O1 => self.o1,
            ObservabilityIndex::O2 => self.o2,
            ObservabilityIndex::O3 => self.o3,
            ObservabilityIndex::O4 => self.o4,
            ObservabilityIndex::O5 => self.o5,
        }
    }
}

/// The indices of a Jacobian after column scaling (singular values by faer's SVD).
///
/// # Errors
/// Non-finite entries, invalid scales, an SVD that does not converge.
pub fn observability_indices(
    jacobian: MatRef<'_, f64>,
    scaling: &ColumnScaling,
) -> Result<ObservabilityIndices> {
    check_finite("jacobian", jacobian)?;
    let (scales, _) = column_scales(jacobian, scaling, 0.0)?;
    let scaled = Mat::<f64>::from_fn(jacobian.nrows(), jacobian.ncols(), |i, j| {
        jacobian[(i, j)] / scales[j]
    });
    let s = sorted_singular_values(scaled.as_ref())?;
    Ok(ObservabilityIndices::from_singular_values(
        &s,
        jacobian.nrows(),
    ))
}

/// Options of [`select_poses`].
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSelectionOptions {
    /// Number of poses to select (`1..=` pool size).
    pub count: usize,
    /// Index to maximise (default O1).
    pub index: ObservabilityIndex,
    /// Maximum exchange passes after the greedy construction (default 20; 0: greedy only).
    pub max_exchange_passes: usize,
    /// Column scaling, computed once over the whole pool so every subset is judged in
    /// the same units (default: column norms of the stacked pool).
    pub column_scaling: ColumnScaling,
}

impl PoseSelectionOptions {
    /// Options selecting `count` poses with the defaults.
    pub fn new(count: usize) -> Self {
        Self {
            count,
            index: ObservabilityIndex::O1,
            max_exchange_passes: 20,
            column_scaling: ColumnScaling::ColumnNorm,
        }
    }
}

/// Result of [`select_poses`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PoseSelection {
    /// Indices of the selected candidates, sorted.
    pub selected: Vec<usize>,
    /// All five indices of the selected set (scaled columns).
    pub indices: ObservabilityIndices,
    /// The chosen index after the greedy phase alone.
    pub greedy_value: f64,
    /// Exchanges performed.
    pub exchanges: usize,
    /// Subsets evaluated (each one SVD).
    pub evaluations: usize,
}

/// Chooses `count` poses out of a candidate pool maximising an observability index.
///
/// Each candidate is the Jacobian block (rows x n parameters, e.g. 6 x n) of one
/// pose. A greedy phase adds, one at a time, the candidate that most raises the
/// index; while the stack has fewer independent rows than parameters every index is
/// 0, so ties are broken by `sum_i ln(sigma_i^2 + 1e-12)` (a regularised
/// log-determinant). An exchange phase (in the spirit of Mitchell's DETMAX, 1974)
/// then swaps a selected pose for an unselected one whenever that raises the index,
/// until a full pass finds no improving swap. Each trial costs one SVD of the
/// stacked matrix: `O(count * pool * passes)` SVDs in all.
///
/// # Errors
/// Empty pool, blocks of differing column counts, `count` out of range, non-finite
/// entries, an SVD that does not converge.
pub fn select_poses(
    candidates: &[Mat<f64>],
    options: &PoseSelectionOptions,
) -> Result<PoseSelection> {
    let pool = candidates.len();
    if pool == 0 {
        return Err(invalid("candidates", 0, "the pool is empty"));
    }
    if options.count == 0 || options.count > pool {
        return Err(invalid(
            "count",
            options.count,
            "must be in 1..=number of candidates",
        ));
    }
    let n = candidates[0].ncols();
    for c in candidates {
        check_len("candidates[k].ncols()", n, c.ncols())?;
        check_finite("candidates", c.as_ref())?;
    }
    let total_rows: usize = candidates.iter().map(|c| c.nrows()).sum();
    let mut stacked = Mat::<f64>::zeros(total_rows, n);
    let mut offsets = Vec::with_capacity(pool + 1);
    let mut row = 0;
    for c in candidates {
        offsets.push(row);
        stacked.as_mut().subrows_mut(row, c.nrows()).copy_from(c);
        row += c.nrows();
    }
    offsets.push(row);
    let (scales, _) = column_scales(stacked.as_ref(), &options.column_scaling, 0.0)?;
    for j in 0..n {
        let inv = 1.0 / scales[j];
        for i in 0..total_rows {
            stacked[(i, j)] *= inv;
        }
    }
    let mut evaluations = 0usize;
    let mut evaluate = |subset: &[usize]| -> Result<(f64, f64, ObservabilityIndices)> {
        evaluations += 1;
        let rows: usize = subset.iter().map(|&k| offsets[k + 1] - offsets[k]).sum();
        let mut a = Mat::<f64>::zeros(rows, n);
        let mut r = 0;
        for &k in subset {
            let h = offsets[k + 1] - offsets[k];
            a.as_mut()
                .subrows_mut(r, h)
                .copy_from(stacked.as_ref().subrows(offsets[k], h));
            r += h;
        }
        let s = sorted_singular_values(a.as_ref())?;
        let indices = ObservabilityIndices::from_singular_values(&s, rows);
        let value = indices.get(options.index);
        // Values at rounding level mean "rank deficient" and must not outrank the tie-break.
        let value = if value > 1e-12 { value } else { 0.0 };
        let tie = s.iter().map(|v| (v * v + 1e-12).ln()).sum::<f64>();
        Ok((value, tie, indices))
    };
    let better = |a: (f64, f64), b: (f64, f64)| {
        a.0 > b.0 * (1.0 + 1e-12) || (a.0 == b.0 && a.1 > b.1 + 1e-12)
    };

    let mut selected: Vec<usize> = Vec::with_capacity(options.count);
    let mut in_set = vec![false; pool];
    let mut current = (0.0, f64::NEG_INFINITY);
    while selected.len() < options.count {
        let mut best: Option<(usize, (f64, f64))> = None;
        for k in (0..pool).filter(|&k| !in_set[k]) {
            selected.push(k);
            let (v, t, _) = evaluate(&selected)?;
            selected.pop();
            if best.is_none_or(|(_, b)| better((v, t), b)) {
                best = Some((k, (v, t)));
            }
        }
        let Some((k, score)) = best else {
            return Err(OptimError::Numerical {
                what: "pose selection found no candidate",
            });
        };
        selected.push(k);
        in_set[k] = true;
        current = score;
    }
    let greedy_value = current.0;
    let mut exchanges = 0;
    for _ in 0..options.max_exchange_passes {
        let mut improved = false;
        for position in 0..selected.len() {
            for k in 0..pool {
                if in_set[k] {
                    continue;
                }
                let old = selected[position];
                selected[position] = k;
                let (v, t, _) = evaluate(&selected)?;
                if better((v, t), current) {
                    in_set[old] = false;
                    in_set[k] = true;
                    current = (v, t);
                    exchanges += 1;
                    improved = true;
                } else {
                    selected[position] = old;
                }
            }
        }
        if !improved {
            break;
        }
    }
    selected.sort_unstable();
    let (_, _, indices) = evaluate(&selected)?;
    Ok(PoseSelection {
        selected,
        indices,
        greedy_value,
        exchanges,
        evaluations,
    })
}
