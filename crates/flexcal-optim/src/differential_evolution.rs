//! Differential evolution (rand/1/bin) over a box, for initial values when no
//! prior is available (the paper used a genetic algorithm for the joint stiffness, section 3.3.1).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{OptimError, Result, check_len, invalid};

/// Differential evolution, strategy rand/1/bin (Storn & Price 1997).
///
/// For each member `x_i` of the population, three distinct other members `a, b, c`
/// give the mutant `v = a + F (b - c)`; binomial crossover takes each coordinate from
/// `v` with probability `CR` (and one random coordinate always), and the trial
/// replaces `x_i` when its value is not worse. Coordinates leaving the box are put
/// halfway between the base `a` and the violated bound.
#[derive(Debug, Clone, PartialEq)]
pub struct DifferentialEvolution {
    /// Population size; 0 (default) means `max(10 d, 8)` for `d` dimensions; else `>= 4`.
    pub population_size: usize,
    /// Differential weight `F` (default 0.7; range `(0, 2]`).
    pub differential_weight: f64,
    /// Crossover probability `CR` (default 0.9; range `[0, 1]`).
    pub crossover_probability: f64,
    /// Maximum generations (default 1000, `>= 1`).
    pub max_generations: usize,
    /// Maximum objective evaluations, including the initial population (default 200 000).
    pub max_evaluations: usize,
    /// Stop when `max - min` of the population's values is at most
    /// `value_tolerance * (|best| + value_tolerance)` (default `1e-12`, `>= 0`).
    pub value_tolerance: f64,
    /// Stop as soon as a value `<= target` is found (default: none).
    pub target: Option<f64>,
    /// Seed of the ChaCha8 generator (default 0): the same seed gives the same run.
    pub seed: u64,
}

impl Default for DifferentialEvolution {
    fn default() -> Self {
        Self {
            population_size: 0,
            differential_weight: 0.7,
            crossover_probability: 0.9,
            max_generations: 1000,
            max_evaluations: 200_000,
            value_tolerance: 1e-12,
            target: None,
            seed: 0,
        }
    }
}

/// Why the search stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum SearchTermination {
    /// The population's values agree within `value_tolerance`.
    Converged,
    /// A value at or below the target was found.
    TargetReached,
    /// `max_generations` reached.
    MaxGenerations,
    /// `max_evaluations` reached.
    MaxEvaluations,
}

/// Result of a global search.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GlobalSearchReport {
    /// Best point found.
    pub best_x: Vec<f64>,
    /// Objective at `best_x`.
    pub best_value: f64,
    /// Best value after the initial population and after each generation.
    pub best_value_history: Vec<f64>,
    /// Generations completed.
    pub generations: usize,
    /// Objective evaluations.
    pub evaluations: usize,
    /// Why the search stopped.
    pub termination: SearchTermination,
}

impl DifferentialEvolution {
    /// Validates the options.
    ///
    /// # Errors
    /// [`OptimError::InvalidOption`] naming the option.
    pub fn check(self) -> Result<Self> {
        if self.population_size != 0 && self.population_size < 4 {
            return Err(invalid(
                "population_size",
                self.population_size,
                "must be 0 (automatic) or >= 4",
            ));
        }
        if !(self.differential_weight > 0.0 && self.differential_weight <= 2.0) {
            return Err(invalid(
                "differential_weight",
                self.differential_weight,
                "must be in (0, 2]",
            ));
        }
        if !(0.0..=1.0).contains(&self.crossover_probability) {
            return Err(invalid(
                "crossover_probability",
                self.crossover_probability,
                "must be in [0, 1]",
            ));
        }
        if self.max_generations == 0 {
            return Err(invalid("max_generations", 0, "must be >= 1"));
        }
        if !(self.value_tolerance.is_finite() && self.value_tolerance >= 0.0) {
            return Err(invalid(
                "value_tolerance",
                self.value_tolerance,
                "must be finite and >= 0",
            ));
        }
        Ok(self)
    }

    /// Minimises `objective` over the box `lower <= x <= upper`.
    ///
    /// A non-finite objective value counts as `+inf` (the point is never kept), so a
    /// model that fails for some parameters does not stop the search.
    ///
    /// # Errors
    /// Invalid options, bounds of different lengths, empty, non-finite or with
    /// `lower > upper`.
    pub fn minimize<F: FnMut(&[f64]) -> f64>(
        &self,
        mut objective: F,
        lower: &[f64],
        upper: &[f64],
    ) -> Result<GlobalSearchReport> {
        let opts = self.clone().check()?;
        let d = lower.len();
        check_len("upper", d, upper.len())?;
        if d == 0 {
            return Err(invalid(
                "lower",
                "[]",
                "the box needs at least one dimension",
            ));
        }
        for j in 0..d {
            if !lower[j].is_finite() {
                return Err(OptimError::NonFiniteInput {
                    argument: "lower",
                    index: j,
                });
            }
            if !upper[j].is_finite() {
                return Err(OptimError::NonFiniteInput {
                    argument: "upper",
                    index: j,
                });
            }
            if lower[j] > upper[j] {
                return Err(invalid(
                    "lower",
                    format!("[{j}] = {} > upper = {}", lower[j], upper[j]),
                    "lower must be <= upper",
                ));
            }
        }
        let np = if opts.population_size == 0 {
            (10 * d).max(8)
        } else {
            opts.population_size
        };
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        let mut evaluations = 0usize;
        let mut eval = |x: &[f64], evaluations: &mut usize| {
            *evaluations += 1;
            let v = objective(x);
            if v.is_finite() { v } else { f64::INFINITY }
        };
        let mut population: Vec<Vec<f64>> = (0..np)
            .map(|_| {
                (0..d)
                    .map(|j| lower[j] + rng.random::<f64>() * (upper[j] - lower[j]))
                    .collect()
            })
            .collect();
        let mut values: Vec<f64> = Vec::with_capacity(np);
        for x in &population {
            values.push(eval(x, &mut evaluations));
        }
        let best_of = |values: &[f64]| {
            (0..values.len())
                .min_by(|&a, &b| values[a].total_cmp(&values[b]))
                .unwrap_or(0)
        };
        let mut best = best_of(&values);
        let mut history = vec![values[best]];
        let mut trial = vec![0.0; d];
        let mut generations = 0;
        let termination = loop {
            if opts.target.is_some_and(|t| values[best] <= t) {
                break SearchTermination::TargetReached;
            }
            let worst = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if worst - values[best]
                <= opts.value_tolerance * (values[best].abs() + opts.value_tolerance)
            {
                break SearchTermination::Converged;
            }
            if generations >= opts.max_generations {
                break SearchTermination::MaxGenerations;
            }
            if evaluations + np > opts.max_evaluations {
                break SearchTermination::MaxEvaluations;
            }
            for i in 0..np {
                let (a, b, c) = three_distinct(&mut rng, np, i);
                let forced = rng.random_range(0..d);
                for j in 0..d {
                    trial[j] = if j == forced || rng.random::<f64>() < opts.crossover_probability {
                        let v = population[a][j]
                            + opts.differential_weight * (population[b][j] - population[c][j]);
                        if v < lower[j] {
                            0.5 * (population[a][j] + lower[j])
                        } else if v > upper[j] {
                            0.5 * (population[a][j] + upper[j])
                        } else {
                            v
                        }
                    } else {
                        population[i][j]
                    };
                }
                let v = eval(&trial, &mut evaluations);
                if v <= values[i] {
                    population[i].copy_from_slice(&trial);
                    values[i] = v;
                }
            }
            generations += 1;
            best = best_of(&values);
            history.push(values[best]);
        };
        Ok(GlobalSearchReport {
            best_x: population[best].clone(),
            best_value: values[best],
            best_value_history: history,
            generations,
            evaluations,
            termination,
        })
    }
}

/// Three distinct indices in `0..np`, all different from `i` (np >= 4).
fn three_distinct(rng: &mut ChaCha8Rng, np: usize, i: usize) -> (usize, usize, usize) {
    let mut pick = |exclude: &[usize]| loop {
        let k = rng.random_range(0..np);
        if !exclude.contains(&k) {
            break k;
        }
    };
    let a = pick(&[i]);
    let b = pick(&[i, a]);
    let c = pick(&[i, a, b]);
    (a, b, c)
}
