//! Structure growth and Solis-Wets placement of the modal values (section
//! 2.2.2, step ii), judged by the error on a test set.

use std::cell::Cell;

use crate::error::FuzzyError;
use crate::partition::{FuzzyStructure, Partition};
use flexcal_optim::solis_wets::{self, SolisWetsParams};

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
