//! Identifiability analysis of a Jacobian: numerical rank, base set, the linear
//! combinations the identified parameters stand for, and a per-parameter diagnosis.

use std::fmt::Write as _;

use faer::prelude::SolveLstsq;
use faer::{Mat, MatRef};
use nalgebra::DMatrix;

use crate::error::{OptimError, Result, check_len, invalid};
use crate::least_squares::DEFAULT_RANK_TOLERANCE;
use crate::problem::ColumnScaling;

/// Coefficients of the scaled combination (unit-norm columns) at or below this are
/// rounding noise and left out of [`Diagnosis::Collinear`].
pub const COLLINEAR_COEFFICIENT_FLOOR: f64 = 1e-8;

/// Options of [`analyze_identifiability`].
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifiabilityOptions {
    /// Relative tolerance on `|R_kk|` against the largest scaled column norm below which
    /// a column is beyond the numerical rank (default [`DEFAULT_RANK_TOLERANCE`]; range `[0, 1)`).
    pub rank_tolerance: f64,
    /// A column whose norm is at most `zero_column_tolerance` times the largest column
    /// norm has no influence (default `1e-12`; range `[0, 1)`).
    pub zero_column_tolerance: f64,
    /// Column scaling before the rank decision (default: each column by its norm, so
    /// m and rad columns compare).
    pub column_scaling: ColumnScaling,
    /// Preference of each parameter for the base set: the base set is filled from the
    /// highest priority down, pivoting within a priority level (e.g. give joint
    /// offsets 1 and everything else 0). Empty (default): all equal.
    pub priorities: Vec<i32>,
    /// Whether the report carries the singular values and the base
    /// condition number (two singular value decompositions; default
    /// `true`). `false` leaves [`IdentifiabilityReport::singular_values`]
    /// empty and [`IdentifiabilityReport::base_condition_number`] NaN, for
    /// callers that need the base set and the rank alone; nothing else in
    /// the report changes.
    pub singular_values: bool,
}

impl Default for IdentifiabilityOptions {
    fn default() -> Self {
        Self {
            rank_tolerance: DEFAULT_RANK_TOLERANCE,
            zero_column_tolerance: 1e-12,
            column_scaling: ColumnScaling::ColumnNorm,
            priorities: Vec::new(),
            singular_values: true,
        }
    }
}

/// Why a parameter is, or is not, identifiable.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum Diagnosis {
    /// In the base set.
    Identifiable,
    /// Its Jacobian column is (numerically) zero: it does not influence the measurements.
    NoInfluence,
    /// Its column is (within the rank tolerance) the combination `sum_b coef_b J_b` of
    /// base columns; the pairs are `(base parameter index, coef)` in physical units,
    /// leaving out coefficients whose scaled value is below [`COLLINEAR_COEFFICIENT_FLOOR`].
    Collinear {
        /// `(base parameter index, coefficient)`, largest scaled magnitude first.
        with: Vec<(usize, f64)>,
    },
}

/// Result of [`analyze_identifiability`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct IdentifiabilityReport {
    /// Parameter names, as given.
    pub names: Vec<String>,
    /// Numerical rank of the scaled Jacobian (= size of the base set).
    pub rank: usize,
    /// Base (identifiable) parameters, in the order the pivoting chose them.
    pub base: Vec<usize>,
    /// Non-identifiable parameters, in index order.
    pub non_identifiable: Vec<usize>,
    /// `K` (rank x non-identifiable count), physical units: `xi_B_identified = xi_B + K xi_N`,
    /// rows in the order of `base`, columns in the order of `non_identifiable`
    /// (`K = R11^-1 R12`, computed as the least-squares fit `J_B K = J_N`).
    pub combination_matrix: DMatrix<f64>,
    /// Per-parameter diagnosis, indexed like `names`.
    pub diagnoses: Vec<Diagnosis>,
    /// Singular values of the scaled Jacobian (all columns), non-increasing.
    pub singular_values: Vec<f64>,
    /// Condition number of the scaled base columns `J_B S_B^-1`.
    pub base_condition_number: f64,
    /// Column scales used.
    pub column_scales: Vec<f64>,
}

impl IdentifiabilityReport {
    /// Names of the base parameters.
    pub fn base_names(&self) -> Vec<&str> {
        self.base.iter().map(|&j| self.names[j].as_str()).collect()
    }

    /// Names of the non-identifiable parameters.
    pub fn non_identifiable_names(&self) -> Vec<&str> {
        self.non_identifiable
            .iter()
            .map(|&j| self.names[j].as_str())
            .collect()
    }

    /// The combinations as text, one line per base parameter that absorbs at least one
    /// non-identifiable parameter, like the paper's (C.1):
    /// `dr2_id = dr2 + 0.003 dd9 - 0.011 dr'8`. Coefficients with magnitude below
    /// `threshold` are dropped; coefficients are printed with 3 significant digits.
    pub fn format_combinations(&self, threshold: f64) -> Vec<String> {
        let mut lines = Vec::new();
        for (row, &b) in self.base.iter().enumerate() {
            let mut line = format!("{}_id = {}", self.names[b], self.names[b]);
            let mut any = false;
            for (col, &j) in self.non_identifiable.iter().enumerate() {
                let k = self.combination_matrix[(row, col)];
                if k.abs() < threshold || k == 0.0 {
                    continue;
                }
                any = true;
                let sign = if k < 0.0 { '-' } else { '+' };
                if (k.abs() - 1.0).abs() < 5e-4 {
                    let _ = write!(line, " {sign} {}", self.names[j]);
                } else {
                    let _ = write!(
                        line,
                        " {sign} {} {}",
                        significant(k.abs(), 3),
                        self.names[j]
                    );
                }
            }
            if any {
                lines.push(line);
            }
        }
        lines
    }

    /// `Ok` when every parameter is identifiable.
    ///
    /// # Errors
    /// [`OptimError::RankDeficient`] naming the non-identifiable parameters.
    pub fn ensure_full_rank(&self) -> Result<()> {
        if self.non_identifiable.is_empty() {
            Ok(())
        } else {
            Err(OptimError::RankDeficient {
                rank: self.rank,
                n_params: self.names.len(),
                parameters: self
                    .non_identifiable_names()
                    .into_iter()
                    .map(String::from)
                    .collect(),
            })
        }
    }
}

/// Formats `v > 0` with `digits` significant digits, without exponent for usual magnitudes.
fn significant(v: f64, digits: i32) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let magnitude = v.log10().floor() as i32;
    if !(-5..=6).contains(&magnitude) {
        return format!("{:.*e}", (digits - 1) as usize, v);
    }
    let decimals = (digits - 1 - magnitude).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Column scales following `scaling`, and which columns carry no influence.
pub(crate) fn column_scales(
    jacobian: MatRef<'_, f64>,
    scaling: &ColumnScaling,
    zero_tolerance: f64,
) -> Result<(Vec<f64>, Vec<bool>)> {
    let n = jacobian.ncols();
    let norms: Vec<f64> = (0..n).map(|j| jacobian.col(j).norm_l2()).collect();
    let max_norm = norms.iter().copied().fold(0.0, f64::max);
    let zero: Vec<bool> = norms
        .iter()
        .map(|&v| v <= zero_tolerance * max_norm)
        .collect();
    let scales = match scaling {
        ColumnScaling::Identity => vec![1.0; n],
        ColumnScaling::ColumnNorm => norms
            .iter()
            .zip(&zero)
            .map(|(&v, &z)| if z { 1.0 } else { v })
            .collect(),
        ColumnScaling::Fixed(s) => {
            check_len("column_scaling", n, s.len())?;
            if let Some(j) = s.iter().position(|v| !v.is_finite() || *v <= 0.0) {
                return Err(invalid(
                    "column_scaling",
                    format!("[{j}] = {}", s[j]),
                    "scales must be finite and > 0",
                ));
            }
            s.clone()
        }
    };
    Ok((scales, zero))
}

pub(crate) fn check_finite(argument: &'static str, a: MatRef<'_, f64>) -> Result<()> {
    for i in 0..a.nrows() {
        for j in 0..a.ncols() {
            if !a[(i, j)].is_finite() {
                return Err(OptimError::NonFiniteInput {
                    argument,
                    index: i * a.ncols() + j,
                });
            }
        }
    }
    Ok(())
}

/// Analyses which parameters a Jacobian identifies (Khalil & Gautier 1991, the
/// paper's section 3.2.3 and Appendix C).
///
/// The columns are scaled, zero columns set aside, and the base set chosen by
/// column-pivoted QR (faer), priority level by priority level: within a level the
/// column with the largest part orthogonal to the columns already chosen enters,
/// while that part exceeds `rank_tolerance` times the largest scaled column norm.
/// The remaining parameters are then expressed on the base: `J_N = J_B K`, so that
/// `J xi = J_B (xi_B + K xi_N)`.
///
/// A nalgebra `DMatrix` (column-major) converts without copy:
/// `faer::MatRef::from_column_major_slice(m.as_slice(), m.nrows(), m.ncols())`.
///
/// # Errors
/// Dimension mismatch of `names` or `priorities`, non-finite entries, invalid options,
/// an SVD that does not converge.
pub fn analyze_identifiability(
    jacobian: MatRef<'_, f64>,
    names: &[String],
    options: &IdentifiabilityOptions,
) -> Result<IdentifiabilityReport> {
    let (m, n) = (jacobian.nrows(), jacobian.ncols());
    check_len("names", n, names.len())?;
    if !options.priorities.is_empty() {
        check_len("priorities", n, options.priorities.len())?;
    }
    for (name, v) in [
        ("rank_tolerance", options.rank_tolerance),
        ("zero_column_tolerance", options.zero_column_tolerance),
    ] {
        if !(0.0..1.0).contains(&v) {
            return Err(invalid(name, v, "must be in [0, 1)"));
        }
    }
    check_finite("jacobian", jacobian)?;
    let (scales, zero) = column_scales(
        jacobian,
        &options.column_scaling,
        options.zero_column_tolerance,
    )?;
    let scaled = Mat::<f64>::from_fn(m, n, |i, j| {
        if zero[j] {
            0.0
        } else {
            jacobian[(i, j)] / scales[j]
        }
    });
    let reference = (0..n).map(|j| scaled.col(j).norm_l2()).fold(0.0, f64::max);
    let priority = |j: usize| options.priorities.get(j).copied().unwrap_or(0);
    let mut levels: Vec<i32> = (0..n).filter(|&j| !zero[j]).map(priority).collect();
    levels.sort_unstable_by(|a, b| b.cmp(a));
    levels.dedup();

    let mut base: Vec<usize> = Vec::new();
    let mut basis = Mat::<f64>::zeros(m, 0);
    for level in levels {
        let columns: Vec<usize> = (0..n)
            .filter(|&j| !zero[j] && priority(j) == level)
            .collect();
        let mut block = Mat::<f64>::from_fn(m, columns.len(), |i, c| scaled[(i, columns[c])]);
        // Project out the chosen columns twice: one pass loses orthogonality when a
        // column is nearly in their span, which is exactly the case that matters here.
        for _ in 0..2 {
            if basis.ncols() > 0 {
                let coefficients = basis.transpose() * &block;
                block -= &basis * &coefficients;
            }
        }
        if m == 0 || columns.is_empty() {
            continue;
        }
        let qr = block.col_piv_qr();
        let r = qr.R();
        let perm = qr.P().arrays().0;
        let size = m.min(columns.len());
        let level_rank = (0..size)
            .position(|k| r[(k, k)].abs() <= options.rank_tolerance * reference)
            .unwrap_or(size);
        base.extend(perm[..level_rank].iter().map(|&c| columns[c]));
        let chosen = Mat::<f64>::from_fn(m, base.len(), |i, c| scaled[(i, base[c])]);
        basis = if base.is_empty() {
            Mat::zeros(m, 0)
        } else {
            chosen.qr().compute_thin_Q()
        };
    }
    let rank = base.len();
    let mut non_identifiable: Vec<usize> = (0..n).filter(|j| !base.contains(j)).collect();
    non_identifiable.sort_unstable();

    let mut combination_matrix = DMatrix::<f64>::zeros(rank, non_identifiable.len());
    let mut scaled_combination = DMatrix::<f64>::zeros(rank, non_identifiable.len());
    let base_block = Mat::<f64>::from_fn(m, rank, |i, c| scaled[(i, base[c])]);
    if rank > 0 && !non_identifiable.is_empty() {
        let rhs = Mat::<f64>::from_fn(m, non_identifiable.len(), |i, c| {
            scaled[(i, non_identifiable[c])]
        });
        let k_scaled = base_block.qr().solve_lstsq(&rhs);
        for (row, &b) in base.iter().enumerate() {
            for (col, &j) in non_identifiable.iter().enumerate() {
                combination_matrix[(row, col)] = k_scaled[(row, col)] * scales[j] / scales[b];
                scaled_combination[(row, col)] = k_scaled[(row, col)];
            }
        }
    }
    let diagnoses = (0..n)
        .map(|j| {
            if zero[j] {
                Diagnosis::NoInfluence
            } else if let Some(col) = non_identifiable.iter().position(|&x| x == j) {
                let mut rows: Vec<usize> = (0..rank)
                    .filter(|&row| {
                        scaled_combination[(row, col)].abs() > COLLINEAR_COEFFICIENT_FLOOR
                    })
                    .collect();
                // Order by the scaled coefficient: physical ones mix units.
                rows.sort_by(|&a, &b| {
                    scaled_combination[(b, col)]
                        .abs()
                        .total_cmp(&scaled_combination[(a, col)].abs())
                });
                let with = rows
                    .iter()
                    .map(|&row| (base[row], combination_matrix[(row, col)]))
                    .collect();
                Diagnosis::Collinear { with }
            } else {
                Diagnosis::Identifiable
            }
        })
        .collect();
    let (singular_values, base_condition_number) = if options.singular_values {
        let base_singular = sorted_singular_values(base_block.as_ref())?;
        let condition = match (base_singular.first(), base_singular.last()) {
            (Some(&hi), Some(&lo)) if lo > 0.0 => hi / lo,
            _ => f64::INFINITY,
        };
        (sorted_singular_values(scaled.as_ref())?, condition)
    } else {
        (Vec::new(), f64::NAN)
    };
    Ok(IdentifiabilityReport {
        names: names.to_vec(),
        rank,
        base,
        non_identifiable,
        combination_matrix,
        diagnoses,
        singular_values,
        base_condition_number,
        column_scales: scales,
    })
}

/// Singular values, non-increasing, padded with zeros to the number of columns.
pub(crate) fn sorted_singular_values(a: MatRef<'_, f64>) -> Result<Vec<f64>> {
    if a.ncols() == 0 {
        return Ok(Vec::new());
    }
    let mut s = if a.nrows() == 0 {
        Vec::new()
    } else {
        a.singular_values().map_err(|_| OptimError::Numerical {
            what: "singular value decomposition did not converge",
        })?
    };
    s.sort_by(|x, y| y.total_cmp(x));
    s.resize(a.ncols(), 0.0);
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::significant;

    #[test]
    fn significant_digits() {
        assert_eq!(significant(0.0030, 3), "0.003");
        assert_eq!(significant(0.01123, 3), "0.0112");
        assert_eq!(significant(12.345, 3), "12.3");
        assert_eq!(significant(0.78, 3), "0.78");
    }
}
