//! A fitted zero-order Takagi-Sugeno model and its evaluation
//! (equations (35)-(37), by multilinear interpolation).

use crate::data::Dataset;
use crate::error::FuzzyError;
use crate::partition::{FuzzyStructure, MAX_INPUTS, check_distinct};

/// A zero-order Takagi-Sugeno model with one output: a rule grid and one
/// constant conclusion `b^i` per rule (in the output's unit), in the rule
/// order of [`FuzzyStructure`]. Immutable; evaluation needs no workspace.
#[derive(Debug, Clone, PartialEq)]
pub struct FuzzyModel {
    structure: FuzzyStructure,
    output_name: String,
    conclusions: Vec<f64>,
}

/// Error statistics of a model over a data set (in the output's unit).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ErrorStats {
    /// Root mean square of the residuals.
    pub rmse: f64,
    /// Mean absolute residual.
    pub mae: f64,
    /// Largest absolute residual.
    pub max_abs: f64,
    /// Number of samples.
    pub n: usize,
}

impl ErrorStats {
    /// Statistics of a list of residuals (prediction minus measurement).
    /// All zero for an empty list.
    pub fn from_residuals(residuals: impl IntoIterator<Item = f64>) -> Self {
        let (mut sum_sq, mut sum_abs, mut max_abs, mut n) = (0.0, 0.0, 0.0f64, 0usize);
        for r in residuals {
            sum_sq += r * r;
            sum_abs += r.abs();
            max_abs = max_abs.max(r.abs());
            n += 1;
        }
        if n == 0 {
            return Self {
                rmse: 0.0,
                mae: 0.0,
                max_abs: 0.0,
                n: 0,
            };
        }
        Self {
            rmse: (sum_sq / n as f64).sqrt(),
            mae: sum_abs / n as f64,
            max_abs,
            n,
        }
    }
}

impl FuzzyModel {
    /// A model from its structure, output name and conclusions (one per
    /// rule, finite).
    pub fn new(
        structure: FuzzyStructure,
        output_name: String,
        conclusions: Vec<f64>,
    ) -> Result<Self, FuzzyError> {
        if conclusions.len() != structure.rule_count() {
            return Err(FuzzyError::ConclusionCount {
                expected: structure.rule_count(),
                found: conclusions.len(),
            });
        }
        if let Some((rule, &value)) = conclusions.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(FuzzyError::NonFiniteConclusion { rule, value });
        }
        let mut names = structure.input_names().to_vec();
        names.push(output_name.clone());
        check_distinct(&names)?;
        Ok(Self {
            structure,
            output_name,
            conclusions,
        })
    }

    /// The rule grid.
    pub fn structure(&self) -> &FuzzyStructure {
        &self.structure
    }

    /// Output name.
    pub fn output_name(&self) -> &str {
        &self.output_name
    }

    /// Input names.
    pub fn input_names(&self) -> &[String] {
        self.structure.input_names()
    }

    /// Conclusions `b^i`, in rule order.
    pub fn conclusions(&self) -> &[f64] {
        &self.conclusions
    }

    /// Output for one sample `x` (one value per input; inputs outside the
    /// outermost modal values are clamped to them).
    ///
    /// Equation (36) with the strengths of equation (37): since the
    /// strengths sum to one it is the multilinear interpolation of the
    /// conclusions over the grid of modal values, computed from the `2^n`
    /// rules of the cell holding `x`.
    pub fn evaluate(&self, x: &[f64]) -> Result<f64, FuzzyError> {
        self.structure.check_sample(0, x)?;
        Ok(self.evaluate_unchecked(x))
    }

    /// Outputs for a batch of samples stored row by row in `inputs`
    /// (`outputs.len()` samples of `n` values each), written to `outputs`.
    /// Lengths and finiteness are checked once for the batch; the loop
    /// itself neither allocates nor branches on the data beyond locating
    /// each input.
    pub fn evaluate_batch(&self, inputs: &[f64], outputs: &mut [f64]) -> Result<(), FuzzyError> {
        let n = self.structure.input_count();
        if inputs.len() != outputs.len() * n {
            return Err(FuzzyError::BufferLength {
                what: "batch inputs (samples x inputs)",
                expected: outputs.len() * n,
                found: inputs.len(),
            });
        }
        if let Some(position) = inputs.iter().position(|v| !v.is_finite()) {
            return Err(FuzzyError::NonFiniteInput {
                sample: position / n,
                input: self.structure.input_names()[position % n].clone(),
                value: inputs[position],
            });
        }
        if n == 2 {
            for (x, y) in inputs.chunks_exact(2).zip(outputs.iter_mut()) {
                *y = self.evaluate_two_inputs(x[0], x[1]);
            }
        } else {
            for (x, y) in inputs.chunks_exact(n).zip(outputs.iter_mut()) {
                *y = self.evaluate_unchecked(x);
            }
        }
        Ok(())
    }

    /// Outputs for every sample of a data set (its input names must match).
    pub fn evaluate_dataset(&self, data: &Dataset) -> Result<Vec<f64>, FuzzyError> {
        if data.input_names() != self.structure.input_names() {
            return Err(FuzzyError::InputNames {
                expected: self.structure.input_names().to_vec(),
                found: data.input_names().to_vec(),
            });
        }
        let mut out = vec![0.0; data.len()];
        self.evaluate_batch(data.inputs_row_major(), &mut out)?;
        Ok(out)
    }

    /// Error statistics over a data set (prediction minus its output).
    pub fn error_stats(&self, data: &Dataset) -> Result<ErrorStats, FuzzyError> {
        let predicted = self.evaluate_dataset(data)?;
        Ok(ErrorStats::from_residuals(
            predicted.iter().zip(data.outputs()).map(|(p, y)| p - y),
        ))
    }

    pub(crate) fn evaluate_unchecked(&self, x: &[f64]) -> f64 {
        let mut fractions = [0.0; MAX_INPUTS];
        let mut strides = [0usize; MAX_INPUTS];
        let n = self.structure.input_count();
        let base = self.structure.locate_all(x, &mut fractions, &mut strides);
        let mut sum = 0.0;
        for corner in 0..(1usize << n) {
            let mut strength = 1.0;
            let mut rule = base;
            for j in 0..n {
                if corner >> j & 1 == 1 {
                    strength *= fractions[j];
                    rule += strides[j];
                } else {
                    strength *= 1.0 - fractions[j];
                }
            }
            sum += strength * self.conclusions[rule];
        }
        sum
    }

    /// Bilinear interpolation, the common two-input case written out.
    #[inline]
    fn evaluate_two_inputs(&self, x0: f64, x1: f64) -> f64 {
        let partitions = self.structure.partitions();
        let (k0, t0) = partitions[0].locate(x0);
        let (k1, t1) = partitions[1].locate(x1);
        let stride = self.structure.strides()[0];
        let rule = k0 * stride + k1;
        let b = &self.conclusions[rule..rule + stride + 2];
        let low = b[0] + t1 * (b[1] - b[0]);
        let high = b[stride] + t1 * (b[stride + 1] - b[stride]);
        low + t0 * (high - low)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::partition::{Partition, RuleActivations};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_model(counts: &[usize], seed: u64) -> FuzzyModel {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let names: Vec<String> = (0..counts.len()).map(|j| format!("x{j}")).collect();
        let parts = counts
            .iter()
            .map(|&m| {
                let mut v = vec![0.0];
                for _ in 1..m {
                    v.push(v.last().unwrap() + rng.random_range(0.1..1.0));
                }
                Partition::new(v).unwrap()
            })
            .collect();
        let s = FuzzyStructure::new(names, parts).unwrap();
        let b = (0..s.rule_count())
            .map(|_| rng.random_range(-1.0..1.0))
            .collect();
        FuzzyModel::new(s, "y".into(), b).unwrap()
    }

    /// Equation (36) written literally over all rules, the reference the
    /// fast paths are checked against.
    fn dense_weighted_average(model: &FuzzyModel, x: &[f64]) -> f64 {
        let s = model.structure();
        let (mut num, mut den) = (0.0, 0.0);
        for rule in 0..s.rule_count() {
            let k = s.rule_memberships(rule).unwrap();
            let alpha: f64 = k
                .iter()
                .zip(s.partitions())
                .zip(x)
                .map(|((&kj, p), &xj)| p.membership(kj, xj))
                .product();
            num += alpha * model.conclusions()[rule];
            den += alpha;
        }
        num / den
    }

    #[test]
    fn conclusions_are_reproduced_at_the_grid_nodes() {
        let m = random_model(&[4, 3], 1);
        let s = m.structure();
        for rule in 0..s.rule_count() {
            let k = s.rule_memberships(rule).unwrap();
            let x: Vec<f64> = k
                .iter()
                .zip(s.partitions())
                .map(|(&kj, p)| p.modal_values()[kj])
                .collect();
            assert!((m.evaluate(&x).unwrap() - m.conclusions()[rule]).abs() < 1e-14);
        }
    }

    #[test]
    fn bad_models_and_samples_are_errors() {
        let s = random_model(&[2, 2], 2).structure().clone();
        assert!(matches!(
            FuzzyModel::new(s.clone(), "y".into(), vec![0.0; 3]),
            Err(FuzzyError::ConclusionCount {
                expected: 4,
                found: 3
            })
        ));
        assert!(matches!(
            FuzzyModel::new(s.clone(), "y".into(), vec![0.0, f64::INFINITY, 0.0, 0.0]),
            Err(FuzzyError::NonFiniteConclusion { rule: 1, .. })
        ));
        assert!(matches!(
            FuzzyModel::new(s.clone(), "x0".into(), vec![0.0; 4]),
            Err(FuzzyError::DuplicateName { .. })
        ));
        let m = FuzzyModel::new(s, "y".into(), vec![0.0; 4]).unwrap();
        assert!(matches!(
            m.evaluate(&[1.0]),
            Err(FuzzyError::InputCount { .. })
        ));
        let mut out = [0.0; 2];
        assert!(matches!(
            m.evaluate_batch(&[0.0, 0.0, f64::NAN, 0.0], &mut out),
            Err(FuzzyError::NonFiniteInput { sample: 1, .. })
        ));
        assert!(matches!(
            m.evaluate_batch(&[0.0; 3], &mut out),
            Err(FuzzyError::BufferLength { .. })
        ));
    }

    #[test]
    fn error_stats_of_known_residuals() {
        let e = ErrorStats::from_residuals([3.0, -4.0]);
        assert_eq!(e.n, 2);
        assert!((e.rmse - 12.5f64.sqrt()).abs() < 1e-15);
        assert_eq!((e.mae, e.max_abs), (3.5, 4.0));
    }

    proptest! {
        #![proptest_config(proptest::test_runner::Config {
            // Seeded: every run draws the same cases.
            rng_seed: proptest::test_runner::RngSeed::Fixed(20130003),
            failure_persistence: None,
            ..proptest::test_runner::Config::default()
        })]
        #[test]
        fn fast_paths_equal_the_weighted_average_of_equation_36(
            counts in proptest::collection::vec(2usize..5, 1..4),
            seed in 0u64..1000,
            unit in proptest::collection::vec(-0.3f64..1.3, 3),
        ) {
            let m = random_model(&counts, seed);
            let parts = m.structure().partitions();
            let x: Vec<f64> = unit.iter().zip(parts)
                .map(|(u, p)| p.lower() + u * (p.upper() - p.lower())).collect();
            let reference = dense_weighted_average(&m, &x);
            prop_assert!((m.evaluate(&x).unwrap() - reference).abs() < 1e-12);
            let mut out = [0.0];
            m.evaluate_batch(&x, &mut out).unwrap();
            prop_assert!((out[0] - reference).abs() < 1e-12);
            let mut a = RuleActivations::new();
            m.structure().activations(&x, &mut a).unwrap();
            let sparse: f64 = a.iter().map(|(r, w)| w * m.conclusions()[r]).sum();
            prop_assert!((sparse - reference).abs() < 1e-12);
        }
    }
}
