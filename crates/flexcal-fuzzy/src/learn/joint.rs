//! Several models observed through linear combinations of their outputs
//! (equations (38), (70)): conclusions fitted jointly.

use crate::data::Dataset;
use crate::error::FuzzyError;
use crate::model::{ErrorStats, FuzzyModel};
use crate::partition::{FuzzyStructure, RuleActivations};

use super::conclusions::{ConclusionReport, NormalEquations, check_ridge};
use super::report::FitReport;

/// Measured linear combinations of several model outputs: row `k` says
/// `target_k = sum_m coefficient_{k,m} * y_m(x_k)`, e.g. a displacement
/// `d_x = C_xx f_x + C_xz f_z` (equation (70)) with the forces as
/// coefficients and the compliances as outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearCombinationSet {
    input_names: Vec<String>,
    model_count: usize,
    inputs: Vec<f64>,
    coefficients: Vec<f64>,
    targets: Vec<f64>,
}

impl LinearCombinationSet {
    /// A set from input columns, one coefficient column per model, and the
    /// measured targets (equal lengths, all finite).
    pub fn new(
        input_names: Vec<String>,
        input_columns: &[Vec<f64>],
        coefficient_columns: &[Vec<f64>],
        targets: Vec<f64>,
    ) -> Result<Self, FuzzyError> {
        // Reuse the data set checks for the inputs and targets.
        let checked = Dataset::new(input_names, "target".into(), input_columns, targets)?;
        if coefficient_columns.is_empty() {
            return Err(FuzzyError::NameCount {
                names: 0,
                items: 0,
                what: "coefficient columns (at least one model)",
            });
        }
        let n_rows = checked.len();
        let mut coefficients = Vec::with_capacity(n_rows * coefficient_columns.len());
        for (m, column) in coefficient_columns.iter().enumerate() {
            if column.len() != n_rows {
                return Err(FuzzyError::ColumnLength {
                    column: format!("coefficient {m}"),
                    expected: n_rows,
                    found: column.len(),
                });
            }
            if let Some(sample) = column.iter().position(|v| !v.is_finite()) {
                return Err(FuzzyError::NonFiniteOutput {
                    sample,
                    column: format!("coefficient {m}"),
                    value: column[sample],
                });
            }
        }
        for k in 0..n_rows {
            coefficients.extend(coefficient_columns.iter().map(|c| c[k]));
        }
        Ok(Self {
            input_names: checked.input_names().to_vec(),
            model_count: coefficient_columns.len(),
            inputs: checked.inputs_row_major().to_vec(),
            coefficients,
            targets: checked.outputs().to_vec(),
        })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.targets.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// Input names.
    pub fn input_names(&self) -> &[String] {
        &self.input_names
    }

    /// Number of models (coefficient columns).
    pub fn model_count(&self) -> usize {
        self.model_count
    }

    /// Inputs of row `k`.
    pub fn sample(&self, k: usize) -> &[f64] {
        let n = self.input_names.len();
        &self.inputs[k * n..(k + 1) * n]
    }

    /// Coefficients of row `k`, one per model.
    pub fn coefficients(&self, k: usize) -> &[f64] {
        &self.coefficients[k * self.model_count..(k + 1) * self.model_count]
    }

    /// Measured targets.
    pub fn targets(&self) -> &[f64] {
        &self.targets
    }

    /// The rows at `indices` (split by pose so that rows of one pose stay
    /// together).
    pub fn subset(&self, indices: &[usize]) -> Self {
        let mut out = Self {
            input_names: self.input_names.clone(),
            model_count: self.model_count,
            inputs: Vec::new(),
            coefficients: Vec::new(),
            targets: Vec::new(),
        };
        for &k in indices {
            out.inputs.extend_from_slice(self.sample(k));
            out.coefficients.extend_from_slice(self.coefficients(k));
            out.targets.push(self.targets[k]);
        }
        out
    }

    pub(crate) fn input_domains(&self, set: &'static str) -> Result<Vec<(f64, f64)>, FuzzyError> {
        let columns: Vec<Vec<f64>> = (0..self.input_names.len())
            .map(|j| (0..self.len()).map(|k| self.sample(k)[j]).collect())
            .collect();
        Dataset::new(
            self.input_names.clone(),
            "target".into(),
            &columns,
            self.targets.clone(),
        )?
        .input_domains(set)
    }
}

/// A jointly fitted set of models.
#[derive(Debug, Clone, PartialEq)]
pub struct JointFit {
    /// One model per output, in the order of the coefficient columns.
    pub models: Vec<FuzzyModel>,
    /// The report; errors are those of the measured targets.
    pub report: FitReport,
}

/// Joint least-squares conclusions of several models (one structure per
/// coefficient column of `data`), ridge-regularised towards the best
/// constant models. Returns one conclusion vector per model.
pub fn fit_joint_conclusions(
    structures: &[FuzzyStructure],
    data: &LinearCombinationSet,
    ridge: f64,
) -> Result<(Vec<Vec<f64>>, ConclusionReport), FuzzyError> {
    check_ridge(ridge)?;
    if structures.len() != data.model_count() {
        return Err(FuzzyError::NameCount {
            names: structures.len(),
            items: data.model_count(),
            what: "coefficient columns (models)",
        });
    }
    for s in structures {
        if s.input_names() != data.input_names() {
            return Err(FuzzyError::InputNames {
                expected: s.input_names().to_vec(),
                found: data.input_names().to_vec(),
            });
        }
    }
    if data.is_empty() {
        return Err(FuzzyError::EmptySet {
            set: "training set",
        });
    }
    let model_count = structures.len();
    // Prior: the constants c_m minimising |sum_m w_m c_m - d|^2, slightly
    // regularised so that a model never excited still gets a value (zero).
    let mut constants = NormalEquations::new(model_count);
    let all_models: Vec<usize> = (0..model_count).collect();
    for k in 0..data.len() {
        constants.add_row(&all_models, data.coefficients(k), data.targets()[k])?;
    }
    let (constant_values, _) = constants.solve(1e-9, &vec![0.0; model_count])?;

    let mut offsets = Vec::with_capacity(model_count);
    let mut total = 0;
    for s in structures {
        offsets.push(total);
        total += s.rule_count();
    }
    let mut prior = Vec::with_capacity(total);
    for (s, &c) in structures.iter().zip(&constant_values) {
        prior.extend(std::iter::repeat_n(c, s.rule_count()));
    }
    let mut normal = NormalEquations::new(total);
    let mut activations = RuleActivations::new();
    let (mut indices, mut coefficients) = (Vec::new(), Vec::new());
    for k in 0..data.len() {
        indices.clear();
        coefficients.clear();
        for ((s, &offset), &w) in structures.iter().zip(&offsets).zip(data.coefficients(k)) {
            s.activations_unchecked(data.sample(k), &mut activations);
            for (rule, strength) in activations.iter() {
                indices.push(offset + rule);
                coefficients.push(w * strength);
            }
        }
        normal.add_row(&indices, &coefficients, data.targets()[k])?;
    }
    let (solution, report) = normal.solve(ridge, &prior)?;
    let split = offsets
        .iter()
        .zip(structures)
        .map(|(&o, s)| solution[o..o + s.rule_count()].to_vec())
        .collect();
    Ok((split, report))
}

/// Error statistics of the predicted targets of jointly fitted models.
pub fn joint_error_stats(
    models: &[FuzzyModel],
    data: &LinearCombinationSet,
) -> Result<ErrorStats, FuzzyError> {
    if models.len() != data.model_count() {
        return Err(FuzzyError::NameCount {
            names: models.len(),
            items: data.model_count(),
            what: "coefficient columns (models)",
        });
    }
    let mut residuals = Vec::with_capacity(data.len());
    for k in 0..data.len() {
        let mut predicted = 0.0;
        for (model, &w) in models.iter().zip(data.coefficients(k)) {
            predicted += w * model.evaluate(data.sample(k))?;
        }
        residuals.push(predicted - data.targets()[k]);
    }
    Ok(ErrorStats::from_residuals(residuals))
}

pub(crate) fn joint_stats(
    structures: &[FuzzyStructure],
    conclusions: &[Vec<f64>],
    data: &LinearCombinationSet,
) -> ErrorStats {
    let mut activations = RuleActivations::new();
    let residuals = (0..data.len()).map(|k| {
        let mut predicted = 0.0;
        for ((s, b), &w) in structures.iter().zip(conclusions).zip(data.coefficients(k)) {
            s.activations_unchecked(data.sample(k), &mut activations);
            predicted += w * activations.iter().map(|(r, a)| a * b[r]).sum::<f64>();
        }
        predicted - data.targets()[k]
    });
    ErrorStats::from_residuals(residuals.collect::<Vec<_>>())
}
