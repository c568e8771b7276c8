//! Learning: rapid prototyping, least-squares (or gradient-descent)
//! conclusions, Solis-Wets placement of modal values and structure growth
//! (section 2.2.2, steps i-iii), for one output or for several outputs
//! observed through linear combinations (equations (38), (70)).

use std::cell::Cell;

use flexcal_optim::solis_wets::{self, SolisWetsParams};
use nalgebra::{DMatrix, DVector};

use crate::data::Dataset;
use crate::error::FuzzyError;
use crate::model::{ErrorStats, FuzzyModel};
use crate::partition::{FuzzyStructure, Partition, RuleActivations};

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

fn check_ridge(ridge: f64) -> Result<(), FuzzyError> {
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

/// Settings of the structure search (steps i and iii).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StructureSearchParams {
    /// Largest number of rules of each model (default 64; at least `2^n`).
    /// Single-output fitting also caps it at the number of training samples.
    pub max_rules: usize,
    /// Minimum gap between neighbouring modal values, as a fraction of the
    /// input's domain width (default 0.02; range (0, 0.5)).
    pub min_gap_fraction: f64,
    /// Solis-Wets settings for placing the interior modal values; the step
    /// is relative to the current spacing of each input's modal values.
    /// Each placement run uses `seed + run index`. Default: initial step
    /// 0.2, minimum step 1e-3, at most 200 evaluations, seed 0.
    pub placement: SolisWetsParams,
    /// Growth steps without improvement of the test error tolerated before
    /// stopping (default 1: stop at the first step that does not improve).
    pub patience: usize,
    /// A step improves when the test error drops below
    /// `(1 - min_relative_improvement)` times the best so far (default 1e-3;
    /// range [0, 1)).
    pub min_relative_improvement: f64,
}

impl Default for StructureSearchParams {
    fn default() -> Self {
        Self {
            max_rules: 64,
            min_gap_fraction: 0.02,
            placement: SolisWetsParams {
                initial_step: 0.2,
                min_step: 1e-3,
                max_step: 1.0,
                max_evaluations: 200,
                ..SolisWetsParams::default()
            },
            patience: 1,
            min_relative_improvement: 1e-3,
        }
    }
}

impl StructureSearchParams {
    /// Checks every setting against its documented range.
    pub fn validate(&self) -> Result<(), FuzzyError> {
        let bad = |name, value: String, reason| {
            Err(FuzzyError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if !(self.min_gap_fraction > 0.0 && self.min_gap_fraction < 0.5) {
            return bad(
                "min_gap_fraction",
                self.min_gap_fraction.to_string(),
                "must be in (0, 0.5)",
            );
        }
        if self.patience == 0 {
            return bad("patience", "0".into(), "must be at least 1");
        }
        if !(self.min_relative_improvement >= 0.0 && self.min_relative_improvement < 1.0) {
            return bad(
                "min_relative_improvement",
                self.min_relative_improvement.to_string(),
                "must be in [0, 1)",
            );
        }
        self.placement.validate()?;
        Ok(())
    }
}

/// Errors of a candidate structure, as returned by the caller's closure:
/// the placement minimises the training error, growth compares test errors.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StructureScore {
    /// Error on the training set (any consistent measure, e.g. RMSE).
    pub training_error: f64,
    /// Error on the test set, same measure.
    pub test_error: f64,
}

/// What the search is doing, for progress display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SearchPhase {
    /// Placing the modal values of the initial structure.
    Initial,
    /// Trying one more membership function on `input` of model `model`.
    Candidate {
        /// Model index.
        model: usize,
        /// Input index.
        input: usize,
    },
    /// A growth step finished.
    StepDone,
}

/// Progress of a structure search, passed to the caller's callback.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchProgress {
    /// Growth steps completed.
    pub growth_step: usize,
    /// What is being done.
    pub phase: SearchPhase,
    /// Membership functions per input of each model of the accepted
    /// structure so far.
    pub memberships: Vec<Vec<usize>>,
    /// Closure evaluations so far.
    pub evaluations: usize,
    /// Best test error so far (infinite before the first evaluation).
    pub best_test_error: f64,
}

/// One growth step of the search history.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GrowthStep {
    /// `(model, input)` that received a membership function (`None` for the
    /// initial structure).
    pub grown: Option<(usize, usize)>,
    /// Membership functions per input of each model after the step.
    pub memberships: Vec<Vec<usize>>,
    /// Errors after placement.
    pub score: StructureScore,
    /// Whether the step improved the test error enough to be kept.
    pub improved: bool,
}

/// Why the structure growth stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum GrowthTermination {
    /// `patience` steps in a row did not improve the test error.
    TestErrorStoppedImproving,
    /// No input can take one more membership function within the rule
    /// budget and the minimum gap.
    RuleBudgetReached,
}

/// Result of [`search_structure`].
#[derive(Debug, Clone, PartialEq)]
pub struct StructureSearchReport {
    /// Best structures found (one per model).
    pub structures: Vec<FuzzyStructure>,
    /// Their errors.
    pub score: StructureScore,
    /// Every growth step, the initial structure first.
    pub history: Vec<GrowthStep>,
    /// Closure evaluations.
    pub evaluations: usize,
    /// Solis-Wets runs.
    pub placement_runs: usize,
    /// Why the growth stopped.
    pub termination: GrowthTermination,
}

/// Generic structure search (steps i and iii) over one or several models
/// that share a fitting procedure.
///
/// `evaluate` fits the conclusions of all models for the given structures
/// and returns their training and test errors. Starting from `initial`, the
/// interior modal values of all models are placed by Solis-Wets
/// (minimising the training error, modal values kept ordered with the
/// minimum gap and the outermost ones fixed); then, step after step, every
/// input of every model that can take one more membership function (inside
/// `max_rules` and the gap) is tried (the new modal value splits the widest
/// interval, then all interior values are placed again) and the candidate
/// with the lowest test error becomes the next structure. The search stops
/// when the test error stops improving or the rule budget is reached and
/// returns the best structures seen.
///
/// Closure errors during a placement count as infinitely bad candidates;
/// an error at a start point is returned.
pub fn search_structure<F>(
    initial: Vec<FuzzyStructure>,
    params: &StructureSearchParams,
    mut evaluate: F,
    progress: &mut dyn FnMut(&SearchProgress),
) -> Result<StructureSearchReport, FuzzyError>
where
    F: FnMut(&[FuzzyStructure]) -> Result<StructureScore, FuzzyError>,
{
    params.validate()?;
    if initial.is_empty() {
        return Err(FuzzyError::NoInputs);
    }
    if let Some(s) = initial.iter().find(|s| s.rule_count() > params.max_rules) {
        return Err(FuzzyError::InvalidParameter {
            name: "max_rules",
            value: params.max_rules.to_string(),
            reason: if s.rule_count() == 1 << s.input_count() {
                "must be at least 2^n, the rules of the initial structure"
            } else {
                "is below the rules of a starting structure"
            },
        });
    }
    let evaluations = Cell::new(0usize);
    let mut runs = 0usize;
    let memberships = |s: &[FuzzyStructure]| {
        s.iter()
            .map(FuzzyStructure::membership_counts)
            .collect::<Vec<_>>()
    };

    progress(&SearchProgress {
        growth_step: 0,
        phase: SearchPhase::Initial,
        memberships: memberships(&initial),
        evaluations: 0,
        best_test_error: f64::INFINITY,
    });
    let (mut best, mut best_score) = place_modal_values(
        &initial,
        params,
        &mut runs,
        &evaluations,
        &mut evaluate,
        &mut |_| {},
    )?;
    let mut history = vec![GrowthStep {
        grown: None,
        memberships: memberships(&best),
        score: best_score,
        improved: true,
    }];
    let mut current = best.clone();
    let mut stalled = 0;
    let termination = loop {
        let step = history.len();
        let mut best_candidate: Option<(Vec<FuzzyStructure>, StructureScore, (usize, usize))> =
            None;
        for (model, structure) in current.iter().enumerate() {
            for (input, partition) in structure.partitions().iter().enumerate() {
                let m = partition.len();
                let grown_rules = structure.rule_count() / m * (m + 1);
                let width = partition.upper() - partition.lower();
                if grown_rules > params.max_rules
                    || !solis_wets::ordering_is_feasible(
                        m + 1,
                        0.0,
                        width,
                        params.min_gap_fraction * width,
                    )
                {
                    continue;
                }
                let mut candidate = current.clone();
                candidate[model] = structure.with_partition(input, partition.split_widest())?;
                let progress_state = SearchProgress {
                    growth_step: step,
                    phase: SearchPhase::Candidate { model, input },
                    memberships: memberships(&best),
                    evaluations: evaluations.get(),
                    best_test_error: best_score.test_error,
                };
                progress(&progress_state);
                let (placed, score) = place_modal_values(
                    &candidate,
                    params,
                    &mut runs,
                    &evaluations,
                    &mut evaluate,
                    &mut |e| {
                        progress(&SearchProgress {
                            evaluations: e,
                            ..progress_state.clone()
                        })
                    },
                )?;
                let better = match &best_candidate {
                    None => true,
                    Some((_, s, _)) => {
                        (score.test_error, score.training_error) < (s.test_error, s.training_error)
                    }
                };
                if better {
                    best_candidate = Some((placed, score, (model, input)));
                }
            }
        }
        let Some((candidate, score, grown)) = best_candidate else {
            break GrowthTermination::RuleBudgetReached;
        };
        let improved =
            score.test_error < best_score.test_error * (1.0 - params.min_relative_improvement);
        history.push(GrowthStep {
            grown: Some(grown),
            memberships: memberships(&candidate),
            score,
            improved,
        });
        if improved {
            best = candidate.clone();
            best_score = score;
            stalled = 0;
        } else {
            stalled += 1;
        }
        current = candidate;
        progress(&SearchProgress {
            growth_step: history.len() - 1,
            phase: SearchPhase::StepDone,
            memberships: memberships(&best),
            evaluations: evaluations.get(),
            best_test_error: best_score.test_error,
        });
        if stalled >= params.patience {
            break GrowthTermination::TestErrorStoppedImproving;
        }
    };
    Ok(StructureSearchReport {
        structures: best,
        score: best_score,
        history,
        evaluations: evaluations.get(),
        placement_runs: runs,
        termination,
    })
}

/// One block of interior modal values in the search vector.
struct Segment {
    model: usize,
    input: usize,
    start: usize,
    len: usize,
    lower: f64,
    upper: f64,
    gap: f64,
}

fn rebuild(
    structures: &[FuzzyStructure],
    segments: &[Segment],
    x: &[f64],
) -> Option<Vec<FuzzyStructure>> {
    let mut out = structures.to_vec();
    for s in segments {
        let mut values = Vec::with_capacity(s.len + 2);
        values.push(s.lower);
        values.extend_from_slice(&x[s.start..s.start + s.len]);
        values.push(s.upper);
        let partition = Partition::new(values).ok()?;
        out[s.model] = out[s.model].with_partition(s.input, partition).ok()?;
    }
    Some(out)
}

/// Step i's placement: Solis-Wets over the interior modal values of all
/// models, outermost values fixed, training error minimised.
fn place_modal_values<F>(
    structures: &[FuzzyStructure],
    params: &StructureSearchParams,
    runs: &mut usize,
    evaluations: &Cell<usize>,
    evaluate: &mut F,
    on_evaluation: &mut dyn FnMut(usize),
) -> Result<(Vec<FuzzyStructure>, StructureScore), FuzzyError>
where
    F: FnMut(&[FuzzyStructure]) -> Result<StructureScore, FuzzyError>,
{
    let mut segments = Vec::new();
    let (mut start, mut scales) = (Vec::new(), Vec::new());
    for (model, structure) in structures.iter().enumerate() {
        for (input, p) in structure.partitions().iter().enumerate() {
            let c = p.modal_values();
            if c.len() < 3 {
                continue;
            }
            let width = p.upper() - p.lower();
            segments.push(Segment {
                model,
                input,
                start: start.len(),
                len: c.len() - 2,
                lower: p.lower(),
                upper: p.upper(),
                gap: params.min_gap_fraction * width,
            });
            start.extend_from_slice(&c[1..c.len() - 1]);
            scales.extend(std::iter::repeat_n(
                width / (c.len() - 1) as f64,
                c.len() - 2,
            ));
        }
    }
    let project = |x: &mut [f64]| {
        for s in &segments {
            // Feasibility was checked when the structure grew; an
            // infeasible block stays sorted and its structure is rejected.
            let _ = solis_wets::project_ordered_with_gap(
                &mut x[s.start..s.start + s.len],
                s.lower + s.gap,
                s.upper - s.gap,
                s.gap,
            );
        }
    };
    let mut projected = start.clone();
    project(&mut projected);
    let first = rebuild(structures, &segments, &projected).unwrap_or_else(|| structures.to_vec());
    evaluations.set(evaluations.get() + 1);
    let first_score = evaluate(&first)?;
    if segments.is_empty() {
        return Ok((first, first_score));
    }
    let placement = SolisWetsParams {
        seed: params.placement.seed.wrapping_add(*runs as u64),
        ..params.placement.clone()
    };
    *runs += 1;
    let mut best_seen = (first.clone(), first_score);
    let report = solis_wets::minimize(
        &placement,
        &projected,
        &scales,
        |x| {
            let Some(candidate) = rebuild(structures, &segments, x) else {
                return f64::INFINITY;
            };
            evaluations.set(evaluations.get() + 1);
            match evaluate(&candidate) {
                Ok(score) if score.training_error.is_finite() => {
                    if score.training_error < best_seen.1.training_error {
                        best_seen = (candidate, score);
                    }
                    score.training_error
                }
                _ => f64::INFINITY,
            }
        },
        project,
        &mut |_| on_evaluation(evaluations.get()),
    )?;
    debug_assert!(report.best_value <= first_score.training_error);
    Ok(best_seen)
}

/// Settings of single-output and joint fitting (see the crate docs for the
/// procedure).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FuzzyParams {
    /// Structure search settings.
    pub search: StructureSearchParams,
    /// Relative ridge weight pulling conclusions towards their prior
    /// (rapid-prototyping values for one output, best constants for a joint
    /// fit); default 1e-6, range [0, inf). Zero gives plain least squares
    /// and an error when a rule has no data.
    pub ridge: f64,
    /// How conclusions are fitted (default least squares; single-output
    /// fitting only, joint fitting always uses least squares).
    pub conclusions: ConclusionMethod,
}

impl Default for FuzzyParams {
    fn default() -> Self {
        Self {
            search: StructureSearchParams::default(),
            ridge: 1e-6,
            conclusions: ConclusionMethod::LeastSquares,
        }
    }
}

/// Report of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// The structure search.
    pub search: StructureSearchReport,
    /// The final conclusions' solve.
    pub conclusions: ConclusionReport,
    /// Errors on the training set.
    pub training: ErrorStats,
    /// Errors on the test set.
    pub test: ErrorStats,
}

/// A fitted single-output model and how it was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct FuzzyFit {
    /// The model.
    pub model: FuzzyModel,
    /// The report.
    pub report: FitReport,
}

fn rmse(residuals: impl IntoIterator<Item = f64>) -> f64 {
    ErrorStats::from_residuals(residuals).rmse
}

impl FuzzyParams {
    /// Checks every setting.
    pub fn validate(&self) -> Result<(), FuzzyError> {
        check_ridge(self.ridge)?;
        self.search.validate()
    }

    /// Fits a single-output model on `train`, choosing its structure by the
    /// error on `test` (section 2.2.2). Both sets must have the same inputs
    /// and output; the partitions span the training inputs' ranges.
    pub fn fit(
        &self,
        train: &Dataset,
        test: &Dataset,
        progress: &mut dyn FnMut(&SearchProgress),
    ) -> Result<FuzzyFit, FuzzyError> {
        self.validate()?;
        if train.input_names() != test.input_names() {
            return Err(FuzzyError::InputNames {
                expected: train.input_names().to_vec(),
                found: test.input_names().to_vec(),
            });
        }
        if test.is_empty() {
            return Err(FuzzyError::EmptySet { set: "test set" });
        }
        let domains = train.input_domains("training set")?;
        let initial = FuzzyStructure::initial(train.input_names().to_vec(), &domains)?;
        if train.len() < initial.rule_count() {
            return Err(FuzzyError::TooFewSamples {
                set: "training set",
                samples: train.len(),
                rules: initial.rule_count(),
            });
        }
        let mut search = self.search.clone();
        search.max_rules = search.max_rules.min(train.len());
        let evaluate = |s: &[FuzzyStructure]| -> Result<StructureScore, FuzzyError> {
            let (model, _) = fit_conclusions(&s[0], train, self.ridge, self.conclusions)?;
            let predicted_train = model.evaluate_dataset(train)?;
            let predicted_test = model.evaluate_dataset(test)?;
            Ok(StructureScore {
                training_error: rmse(
                    predicted_train
                        .iter()
                        .zip(train.outputs())
                        .map(|(p, y)| p - y),
                ),
                test_error: rmse(
                    predicted_test
                        .iter()
                        .zip(test.outputs())
                        .map(|(p, y)| p - y),
                ),
            })
        };
        let search_report = search_structure(vec![initial], &search, evaluate, progress)?;
        let (model, conclusions) = fit_conclusions(
            &search_report.structures[0],
            train,
            self.ridge,
            self.conclusions,
        )?;
        let training = model.error_stats(train)?;
        let test_stats = model.error_stats(test)?;
        Ok(FuzzyFit {
            model,
            report: FitReport {
                search: search_report,
                conclusions,
                training,
                test: test_stats,
            },
        })
    }

    /// Fits one model per output jointly from measured linear combinations
    /// of the outputs (equation (70): `d = C(theta) F` is linear in the
    /// conclusions of all models). `output_names` names the models (one per
    /// coefficient column of the sets).
    pub fn fit_joint(
        &self,
        output_names: &[String],
        train: &LinearCombinationSet,
        test: &LinearCombinationSet,
        progress: &mut dyn FnMut(&SearchProgress),
    ) -> Result<JointFit, FuzzyError> {
        self.validate()?;
        if output_names.len() != train.model_count() || output_names.len() != test.model_count() {
            return Err(FuzzyError::NameCount {
                names: output_names.len(),
                items: train.model_count(),
                what: "coefficient columns (models)",
            });
        }
        if train.input_names() != test.input_names() {
            return Err(FuzzyError::InputNames {
                expected: train.input_names().to_vec(),
                found: test.input_names().to_vec(),
            });
        }
        if test.is_empty() {
            return Err(FuzzyError::EmptySet { set: "test set" });
        }
        let domains = train.input_domains("training set")?;
        let initial = FuzzyStructure::initial(train.input_names().to_vec(), &domains)?;
        let total_rules = initial.rule_count() * output_names.len();
        if train.len() < total_rules {
            return Err(FuzzyError::TooFewSamples {
                set: "training set",
                samples: train.len(),
                rules: total_rules,
            });
        }
        let evaluate = |s: &[FuzzyStructure]| -> Result<StructureScore, FuzzyError> {
            let (conclusions, _) = fit_joint_conclusions(s, train, self.ridge)?;
            Ok(StructureScore {
                training_error: joint_stats(s, &conclusions, train).rmse,
                test_error: joint_stats(s, &conclusions, test).rmse,
            })
        };
        let search_report = search_structure(
            vec![initial; output_names.len()],
            &self.search,
            evaluate,
            progress,
        )?;
        let (conclusions, report) =
            fit_joint_conclusions(&search_report.structures, train, self.ridge)?;
        let training = joint_stats(&search_report.structures, &conclusions, train);
        let test_stats = joint_stats(&search_report.structures, &conclusions, test);
        let models = search_report
            .structures
            .iter()
            .zip(conclusions)
            .zip(output_names)
            .map(|((s, b), name)| FuzzyModel::new(s.clone(), name.clone(), b))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(JointFit {
            models,
            report: FitReport {
                search: search_report,
                conclusions: report,
                training,
                test: test_stats,
            },
        })
    }
}

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

    fn input_domains(&self, set: &'static str) -> Result<Vec<(f64, f64)>, FuzzyError> {
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

fn joint_stats(
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
