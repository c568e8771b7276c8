//! The least-squares problem abstraction: one capability per trait.

use faer::MatMut;

use crate::error::{ProblemError, Result, check_len, invalid};

/// Residuals `r(x)` of a least-squares problem: `m` rows, `n` parameters.
///
/// The solvers minimise `cost(x) = 1/2 * sum_i (w_i r_i(x))^2`, with `w_i` the
/// optional row weights of [`ProblemSetup`].
pub trait Residuals {
    /// Number of residual rows `m`.
    fn n_residuals(&self) -> usize;
    /// Number of parameters `n` (including those the setup keeps fixed).
    fn n_params(&self) -> usize;
    /// Writes `r(x)` into `out` (length `m`). `x` has length `n`.
    ///
    /// # Errors
    /// Whatever the model cannot evaluate (a loop that cannot close, ...).
    /// At the starting point the solver stops and returns it inside
    /// [`crate::OptimError::Problem`]. At a trial point it refuses the step
    /// (as if the cost had risen) and tries a shorter or more damped one
    /// (counted in [`crate::SolveReport::refused_trials`]); it returns the
    /// error only when it stops on such a failure without having moved from
    /// the start.
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> std::result::Result<(), ProblemError>;
    /// Name of parameter `j`, used in every report (default `x[j]`).
    fn parameter_name(&self, j: usize) -> String {
        format!("x[{j}]")
    }
}

/// Jacobian `J(x) = dr/dx` (m x n) of a [`Residuals`] problem.
pub trait Jacobian: Residuals {
    /// Writes `J(x)` into `out`, an `m x n` column-major buffer owned by the solver
    /// (it is not zeroed between calls: write every entry).
    ///
    /// # Errors
    /// As for [`Residuals::residuals`].
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> std::result::Result<(), ProblemError>;
}

/// How the columns of the Jacobian are scaled before each step.
///
/// Scaling makes lengths in m and angles in rad comparable: the solvers work in
/// scaled parameters `z_j = s_j x_j`, the rank decision and the reported singular
/// values refer to the scaled, weighted Jacobian `W J S^-1`.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum ColumnScaling {
    /// `s_j = 1`: no scaling (parameters already share a unit).
    Identity,
    /// `s_j` = Euclidean norm of column `j` of the weighted Jacobian, kept as the
    /// maximum seen over the iterations (Moré 1978, MINPACK) so the trust region
    /// does not shrink on columns that lose influence. Zero columns get `s_j = 1`.
    #[default]
    ColumnNorm,
    /// Fixed scales, one per parameter, all finite and `> 0` (e.g. a typical
    /// magnitude per parameter, `1/s_j` being its unit of length or angle).
    Fixed(Vec<f64>),
}

/// Problem-specific settings that are not part of the residual model itself.
#[derive(Debug, Clone, Default)]
pub struct ProblemSetup {
    /// Per-row weights `w_i = 1/sigma_i` (length `m`, finite, `>= 0`); `None`: all 1.
    pub row_weights: Option<Vec<f64>>,
    /// `true` when the weights are the true inverse standard deviations of the
    /// measurements: the covariance then uses `sigma^2 = 1`. `false` (default): the
    /// weights are relative and `sigma^2 = SSR / (m - rank)` is estimated.
    pub weights_are_absolute: bool,
    /// Fixed (masked) parameters: `fixed[j] == true` keeps `x_j` at its initial
    /// value. Empty (default): every parameter is free.
    pub fixed: Vec<bool>,
    /// Column scaling (default [`ColumnScaling::ColumnNorm`]).
    pub column_scaling: ColumnScaling,
}

impl ProblemSetup {
    /// Checks the setup against the problem dimensions and returns the indices of
    /// the free parameters.
    pub(crate) fn validate(&self, m: usize, n: usize) -> Result<Vec<usize>> {
        if let Some(w) = &self.row_weights {
            check_len("row_weights", m, w.len())?;
            if let Some(i) = w.iter().position(|v| !v.is_finite() || *v < 0.0) {
                return Err(invalid(
                    "row_weights",
                    format!("[{i}] = {}", w[i]),
                    "weights must be finite and >= 0",
                ));
            }
        }
        if !self.fixed.is_empty() {
            check_len("fixed", n, self.fixed.len())?;
        }
        if let ColumnScaling::Fixed(s) = &self.column_scaling {
            check_len("column_scaling", n, s.len())?;
            if let Some(j) = s.iter().position(|v| !v.is_finite() || *v <= 0.0) {
                return Err(invalid(
                    "column_scaling",
                    format!("[{j}] = {}", s[j]),
                    "scales must be finite and > 0",
                ));
            }
        }
        Ok((0..n)
            .filter(|&j| !self.fixed.get(j).copied().unwrap_or(false))
            .collect())
    }
}
