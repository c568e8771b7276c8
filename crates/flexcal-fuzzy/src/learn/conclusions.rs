//! Rule conclusions: rapid prototyping (step i) and least squares on the
//! normal equations (step iii), or gradient descent, for one output.

use nalgebra::{DMatrix, DVector};

use crate::data::Dataset;
use crate::error::FuzzyError;
use crate::model::FuzzyModel;
use crate::partition::{FuzzyStructure, RuleActivations};

/// Normal equations `(A^T A) b = A^T y` of a linear least-squares problem in
/// the rule conclusions, accumulated row by row from sparse rows.
///
/// This is what a caller fitting several models jointly builds: a measured
/// value `d = sum_m w_m y_m(x)` gives one row whose non-zeros are
/// `w_m * alpha_i(x)` at the (offset) rule indices of every model. Rows are
/// sparse (`2^n` rules per model), so accumulating the normal matrix costs
/// `(2^n)^2` per row; the system is then solved by Cholesky, never inverted.
#[derive(Debug, Clone)]
pub struct NormalEquations {
    matrix: DMatrix<f64>,
    rhs: DVector<f64>,
    rows: usize,
}

/// How a set of conclusions was solved.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConclusionReport {
    /// Number of conclusions solved for.
    pub unknowns: usize,
    /// Number of least-squares rows (samples or measured values).
    pub rows: usize,
    /// Absolute ridge weight used: the relative `ridge` setting times the
    /// mean diagonal of `A^T A`.
    pub ridge_weight: f64,
    /// `(max L_ii / min L_ii)^2` of the Cholesky factor of the regularised
    /// normal matrix: a cheap lower bound of its condition number (`None`
    /// for gradient descent).
    pub condition_lower_bound: Option<f64>,
    /// Conclusions whose rules no row activates (they follow the prior).
    pub unsupported: Vec<usize>,
    /// Gradient-descent epochs run (0 for least squares).
    pub epochs: usize,
}

impl NormalEquations {
    /// Empty normal equations for `unknowns` conclusions.
    pub fn new(unknowns: usize) -> Self {
        Self {
            matrix: DMatrix::zeros(unknowns, unknowns),
            rhs: DVector::zeros(unknowns),
            rows: 0,
        }
    }

    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.rhs.len()
    }

    /// Number of rows added.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Adds the row `sum_p coefficients[p] * b[indices[p]] = target`
    /// (repeated indices add up). Indices must be below
    /// [`unknowns`](Self::unknowns), values finite.
    pub fn add_row(
        &mut self,
        indices: &[usize],
        coefficients: &[f64],
        target: f64,
    ) -> Result<(), FuzzyError> {
        if indices.len() != coefficients.len() {
            return Err(FuzzyError::BufferLength {
                what: "row coefficients",
                expected: indices.len(),
                found: coefficients.len(),
            });
        }
        let size = self.unknowns();
        if let Some(&index) = indices.iter().find(|&&i| i >= size) {
            return Err(FuzzyError::UnknownIndex { index, size });
        }
        if let Some(&value) = coefficients
            .iter()
            .chain([&target])
            .find(|v| !v.is_finite())
        {
            return Err(FuzzyError::NonFiniteOutput {
                sample: self.rows,
                column: "least-squares row".into(),
                value,
            });
        }
        for (&i, &a_i) in indices.iter().zip(coefficients) {
            self.rhs[i] += a_i * target;
            for (&j, &a_j) in indices.iter().zip(coefficients) {
                self.matrix[(i, j)] += a_i * a_j;
            }
        }
        self.rows += 1;
        Ok(())
    }

    /// Solves `min |A b - y|^2 + lambda |b - prior|^2` with
    /// `lambda = ridge * mean(diag(A^T A))` by Cholesky.
    ///
    /// `ridge` is relative (dimensionless, >= 0): it pulls conclusions with
    /// little data towards `prior` and leaves well-supported ones almost
    /// untouched. With `ridge = 0` a rule without data makes the system
    /// singular: a [`FuzzyError::SingularConclusions`] error naming them.
    pub fn solve(
        &self,
        ridge: f64,
        prior: &[f64],
    ) -> Result<(Vec<f64>, ConclusionReport), FuzzyError> {
        let size = self.unknowns();
        check_ridge(ridge)?;
        if prior.len() != size {
            return Err(FuzzyError::BufferLength {
                what: "prior conclusions",
                expected: size,
                found: prior.len(),
            });
        }
        let diagonal = self.matrix.diagonal();
        let max_diagonal = diagonal.max();
        let mean_diagonal = if size == 0 {
            0.0
        } else {
            diagonal.sum() / size as f64
        };
        let unsupported: Vec<usize> = (0..size)
            .filter(|&i| diagonal[i] <= 1e-14 * max_diagonal.max(f64::MIN_POSITIVE))
            .collect();
        let ridge_weight = if mean_diagonal > 0.0 {
            ridge * mean_diagonal
        } else {
            ridge
        };
        let mut matrix = self.matrix.clone();
        let mut rhs = self.rhs.clone();
        for i in 0..size {
            matrix[(i, i)] += ridge_weight;
            rhs[i] += ridge_weight * prior[i];
        }
        let singular = || FuzzyError::SingularConclusions {
            unsupported_rules: unsupported.clone(),
        };
        let cholesky = matrix.cholesky().ok_or_else(singular)?;
        let l_diagonal = cholesky.l_dirty().diagonal();
        let (l_min, l_max) = (l_diagonal.min(), l_diagonal.max());
        // Pivots this small mean the normal matrix is numerically singular
        // even though the factorisation went through.
        if l_min.is_nan() || l_min <= 1e-10 * l_max {
            return Err(singular());
        }
        let solution = cholesky.solve(&rhs);
        Ok((
            solution.iter().copied().collect(),
            ConclusionReport {
                unknowns: size,
                rows: self.rows,
                ridge_weight,
                condition_lower_bound: Some((l_max / l_min).powi(2)),
                unsupported,
                epochs: 0,
            },
        ))
    }
}

pub(crate) fn check_ridge(ridge: f64) -> Result<(), FuzzyError> {
    if ridge.is_finite() && ridge >= 0.0 {
        Ok(())
    } else {
        Err(FuzzyError::InvalidParameter {
            name: "ridge",
            value: ridge.to_string(),
            reason: "must be finite and >= 0",
        })
    }
}

/// Activations of every sample, `2^n` per sample, flattened.
struct ActivationTable {
    width: usize,
    rules: Vec<usize>,
    strengths: Vec<f64>,
}

impl ActivationTable {
    fn new(structure: &FuzzyStructure, data: &Dataset) -> Self {
        let width = 1usize << structure.input_count();
        let mut rules = Vec::with_capacity(width * data.len());
        let mut strengths = Vec::with_capacity(width * data.len());
        let mut buffer = RuleActivations::new();
        for k in 0..data.len() {
            structure.activations_unchecked(data.sample(k), &mut buffer);
            rules.extend_from_slice(buffer.rules());
            strengths.extend_from_slice(buffer.strengths());
        }
        Self {
            width,
            rules,
            strengths,
        }
    }

    fn sample(&self, k: usize) -> (&[usize], &[f64]) {
        let range = k * self.width..(k + 1) * self.width;
        (&self.rules[range.clone()], &self.strengths[range])
    }
}

fn check_inputs(structure: &FuzzyStructure, data: &Dataset) -> Result<(), FuzzyError> {
    if data.input_names() != structure.input_names() {
        return Err(FuzzyError::InputNames {
            expected: structure.input_names().to_vec(),
            found: data.input_names().to_vec(),
        });
    }
    Ok(())
}

/// Rapid-prototyping conclusions (step i): each conclusion is the
/// membership-weighted mean of the outputs its rule covers,
/// `b^i = sum_k alpha_i(x_k) y_k / sum_k alpha_i(x_k)`. A rule no sample
/// activates takes the mean of all outputs.
pub fn rapid_prototyping(
    structure: &FuzzyStructure,
    data: &Dataset,
) -> Result<Vec<f64>, FuzzyError> {
    check_inputs(structure, data)?;
    if data.is_empty() {
        return Err(FuzzyError::EmptySet {
            set: "training set",
        });
    }
    let table = ActivationTable::new(structure, data);
    Ok(rapid_prototyping_from(
        structure.rule_count(),
        &table,
        data.outputs(),
    ))
}

fn rapid_prototyping_from(rule_count: usize, table: &ActivationTable, outputs: &[f64]) -> Vec<f64> {
    let mut weighted = vec![0.0; rule_count];
    let mut mass = vec![0.0; rule_count];
    for (k, &y) in outputs.iter().enumerate() {
        let (rules, strengths) = table.sample(k);
        for (&r, &w) in rules.iter().zip(strengths) {
            weighted[r] += w * y;
            mass[r] += w;
        }
    }
    let mean = outputs.iter().sum::<f64>() / outputs.len() as f64;
    weighted
        .iter()
        .zip(&mass)
        .map(|(&s, &m)| if m > 0.0 { s / m } else { mean })
        .collect()
}

/// How conclusions are fitted for a fixed structure (step ii).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum ConclusionMethod {
    /// Exact ridge-regularised least squares towards the rapid-prototyping
    /// values (the output is linear in the conclusions). Default.
    LeastSquares,
    /// The paper's batch gradient descent on half the mean squared error,
    /// started from the rapid-prototyping values. The step is stable for
    /// `learning_rate` in (0, 2) because the activations of a sample sum to
    /// one; convergence of rules with little data is slow.
    GradientDescent {
        /// Step length (dimensionless; default 1.0).
        learning_rate: f64,
        /// Number of passes over the training set (default 500).
        epochs: usize,
    },
}

/// Fits the conclusions of `structure` on `data` (step ii) and returns the
/// model with a report. `ridge` is the relative weight of the pull towards
/// the rapid-prototyping values (see [`NormalEquations::solve`]).
pub fn fit_conclusions(
    structure: &FuzzyStructure,
    data: &Dataset,
    ridge: f64,
    method: ConclusionMethod,
) -> Result<(FuzzyModel, ConclusionReport), FuzzyError> {
    check_inputs(structure, data)?;
    check_ridge(ridge)?;
    if data.is_empty() {
        return Err(FuzzyError::EmptySet {
            set: "training set",
        });
    }
    let table = ActivationTable::new(structure, data);
    let (conclusions, report) = conclusions_from_table(
        structure.rule_count(),
        &table,
        data.outputs(),
        ridge,
        method,
    )?;
    let model = FuzzyModel::new(
        structure.clone(),
        data.output_name().to_string(),
        conclusions,
    )?;
    Ok((model, report))
}

fn conclusions_from_table(
    rule_count: usize,
    table: &ActivationTable,
    outputs: &[f64],
    ridge: f64,
    method: ConclusionMethod,
) -> Result<(Vec<f64>, ConclusionReport), FuzzyError> {
    let prior = rapid_prototyping_from(rule_count, table, outputs);
    match method {
        ConclusionMethod::LeastSquares => {
            let mut normal = NormalEquations::new(rule_count);
            for (k, &y) in outputs.iter().enumerate() {
                let (rules, strengths) = table.sample(k);
                normal.add_row(rules, strengths, y)?;
            }
            normal.solve(ridge, &prior)
        }
        ConclusionMethod::GradientDescent {
            learning_rate,
            epochs,
        } => {
            if !(learning_rate > 0.0 && learning_rate < 2.0) {
                return Err(FuzzyError::InvalidParameter {
                    name: "learning_rate",
                    value: learning_rate.to_string(),
                    reason: "must be in (0, 2)",
                });
            }
            let mut b = prior;
            let mut gradient = vec![0.0; rule_count];
            let scale = learning_rate / outputs.len() as f64;
            for _ in 0..epochs {
                gradient.fill(0.0);
                for (k, &y) in outputs.iter().enumerate() {
                    let (rules, strengths) = table.sample(k);
                    let residual: f64 = rules
                        .iter()
                        .zip(strengths)
                        .map(|(&r, &w)| w * b[r])
                        .sum::<f64>()
                        - y;
                    for (&r, &w) in rules.iter().zip(strengths) {
                        gradient[r] += w * residual;
                    }
                }
                for (bi, gi) in b.iter_mut().zip(&gradient) {
                    *bi -= scale * gi;
                }
            }
            let mut mass = vec![0.0; rule_count];
            for (r, w) in table.rules.iter().zip(&table.strengths) {
                mass[*r] += w;
            }
            Ok((
                b,
                ConclusionReport {
                    unknowns: rule_count,
                    rows: outputs.len(),
                    ridge_weight: 0.0,
                    condition_lower_bound: None,
                    unsupported: (0..rule_count).filter(|&r| mass[r] == 0.0).collect(),
                    epochs,
                },
            ))
        }
    }
}
