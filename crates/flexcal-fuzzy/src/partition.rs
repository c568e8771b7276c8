//! Strong triangular partitions (equations (33)-(34)), the rule grid and
//! rule activations (equation (37)).

use crate::error::{FuzzyError, PartitionError};

/// Most inputs a model may have: every sample touches `2^n` rules, and the
/// evaluation keeps per-input state on the stack.
pub const MAX_INPUTS: usize = 10;

/// A strong triangular fuzzy partition of one input, defined by its ordered
/// modal values `c_1 < ... < c_m` (equation (34)).
///
/// Membership function `k` is the triangle with feet at `c_{k-1}` and
/// `c_{k+1}` and apex 1 at `c_k`; the first and the last are shoulders
/// (equal to 1 beyond `c_1` and `c_m`). Memberships sum to one everywhere
/// (equation (33)), at most two are non-zero, and an input outside
/// `[c_1, c_m]` is treated as clamped to it.
#[derive(Debug, Clone, PartialEq)]
pub struct Partition {
    modal_values: Vec<f64>,
    // 1 / (c_{k+1} - c_k), kept so that locating a sample multiplies.
    inverse_widths: Vec<f64>,
}

impl Partition {
    /// A partition from its modal values (in the input's unit); at least
    /// two, finite, strictly increasing.
    pub fn new(modal_values: Vec<f64>) -> Result<Self, PartitionError> {
        if modal_values.len() < 2 {
            return Err(PartitionError::TooFewModalValues {
                count: modal_values.len(),
            });
        }
        for (index, &value) in modal_values.iter().enumerate() {
            if !value.is_finite() {
                return Err(PartitionError::NonFinite { index, value });
            }
            if index > 0 && value <= modal_values[index - 1] {
                return Err(PartitionError::NotIncreasing {
                    index,
                    previous: modal_values[index - 1],
                    value,
                });
            }
        }
        let inverse_widths = modal_values
            .windows(2)
            .map(|w| 1.0 / (w[1] - w[0]))
            .collect();
        Ok(Self {
            modal_values,
            inverse_widths,
        })
    }

    /// `count` evenly spaced modal values from `lower` to `upper` (the
    /// paper's initialisation, step i of section 2.2.2).
    pub fn uniform(lower: f64, upper: f64, count: usize) -> Result<Self, PartitionError> {
        if count < 2 {
            return Err(PartitionError::TooFewModalValues { count });
        }
        let last = (count - 1) as f64;
        let values = (0..count)
            .map(|k| {
                if k + 1 == count {
                    upper
                } else {
                    lower + (upper - lower) * k as f64 / last
                }
            })
            .collect();
        Self::new(values)
    }

    /// Number of membership functions `m`.
    pub fn len(&self) -> usize {
        self.modal_values.len()
    }

    /// Always false: a partition has at least two membership functions.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The modal values `c_1 < ... < c_m`.
    pub fn modal_values(&self) -> &[f64] {
        &self.modal_values
    }

    /// First modal value (inputs below it are clamped to it).
    pub fn lower(&self) -> f64 {
        self.modal_values[0]
    }

    /// Last modal value (inputs above it are clamped to it).
    pub fn upper(&self) -> f64 {
        self.modal_values[self.modal_values.len() - 1]
    }

    /// Locates `x`: returns `(k, t)` such that membership functions `k` and
    /// `k + 1` (0-based) have degrees `1 - t` and `t`, all others zero.
    /// `x` is clamped to `[c_1, c_m]`; a NaN `x` gives a NaN `t`.
    #[inline]
    pub fn locate(&self, x: f64) -> (usize, f64) {
        let c = &self.modal_values;
        let interior = &c[1..c.len() - 1];
        // The interval index is the number of interior modal values at or
        // below x. For the few membership functions of a typical input a
        // branch-free count beats a binary search, whose branches
        // mispredict on scattered inputs.
        let k = if interior.len() <= 16 {
            interior.iter().map(|&v| usize::from(v <= x)).sum()
        } else {
            interior.partition_point(|&v| v <= x)
        };
        let t = ((x - c[k]) * self.inverse_widths[k]).clamp(0.0, 1.0);
        (k, t)
    }

    /// Degree of membership of `x` to membership function `k` (0-based;
    /// zero for `k >= len()`).
    pub fn membership(&self, k: usize, x: f64) -> f64 {
        let (interval, t) = self.locate(x);
        if k == interval {
            1.0 - t
        } else if k == interval + 1 {
            t
        } else {
            0.0
        }
    }

    /// Degrees of membership of `x` to every membership function, written
    /// into `out` (length `len()`; other lengths are an error).
    pub fn memberships_into(&self, x: f64, out: &mut [f64]) -> Result<(), FuzzyError> {
        if out.len() != self.len() {
            return Err(FuzzyError::BufferLength {
                what: "memberships",
                expected: self.len(),
                found: out.len(),
            });
        }
        out.fill(0.0);
        let (k, t) = self.locate(x);
        out[k] = 1.0 - t;
        out[k + 1] = t;
        Ok(())
    }

    /// A copy with one more membership function, its modal value at the
    /// middle of the widest interval (used by structure growth, which keeps
    /// the placement already found for the others).
    pub fn split_widest(&self) -> Self {
        let (widest, _) = self.modal_values.windows(2).enumerate().fold(
            (0, f64::NEG_INFINITY),
            |best, (k, w)| {
                if w[1] - w[0] > best.1 {
                    (k, w[1] - w[0])
                } else {
                    best
                }
            },
        );
        let mut values = self.modal_values.clone();
        let middle = 0.5 * (values[widest] + values[widest + 1]);
        values.insert(widest + 1, middle);
        let inverse_widths = values.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect();
        Self {
            modal_values: values,
            inverse_widths,
        }
    }
}

/// The rule grid of a model: the partition of each named input. Rules are
/// all combinations of one membership function per input (equation (35)),
/// numbered with the last input varying fastest (as in the paper's
/// Table 4): rule `sum_j k_j * stride_j` with `stride_{n-1} = 1`.
#[derive(Debug, Clone, PartialEq)]
pub struct FuzzyStructure {
    input_names: Vec<String>,
    partitions: Vec<Partition>,
    strides: Vec<usize>,
    rule_count: usize,
}

impl FuzzyStructure {
    /// A structure from input names and their partitions (same length,
    /// 1 to [`MAX_INPUTS`] inputs, distinct names).
    pub fn new(input_names: Vec<String>, partitions: Vec<Partition>) -> Result<Self, FuzzyError> {
        if input_names.len() != partitions.len() {
            return Err(FuzzyError::NameCount {
                names: input_names.len(),
                items: partitions.len(),
                what: "partitions",
            });
        }
        if partitions.is_empty() {
            return Err(FuzzyError::NoInputs);
        }
        if partitions.len() > MAX_INPUTS {
            return Err(FuzzyError::TooManyInputs {
                count: partitions.len(),
                max: MAX_INPUTS,
            });
        }
        check_distinct(&input_names)?;
        let mut strides = vec![1; partitions.len()];
        for j in (0..partitions.len() - 1).rev() {
            strides[j] = strides[j + 1] * partitions[j + 1].len();
        }
        let rule_count = strides[0] * partitions[0].len();
        Ok(Self {
            input_names,
            partitions,
            strides,
            rule_count,
        })
    }

    /// The simplest structure: two membership functions per input at the
    /// ends of each `(lower, upper)` domain.
    pub fn initial(input_names: Vec<String>, domains: &[(f64, f64)]) -> Result<Self, FuzzyError> {
        let partitions = input_names
            .iter()
            .zip(domains)
            .map(|(name, &(lower, upper))| {
                Partition::uniform(lower, upper, 2).map_err(|source| FuzzyError::Partition {
                    input: name.clone(),
                    source,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::new(input_names, partitions)
    }

    /// Number of inputs `n`.
    pub fn input_count(&self) -> usize {
        self.partitions.len()
    }

    /// Number of rules `N = m_1 * ... * m_n`.
    pub fn rule_count(&self) -> usize {
        self.rule_count
    }

    /// Input names, in order.
    pub fn input_names(&self) -> &[String] {
        &self.input_names
    }

    /// Partitions, one per input.
    pub fn partitions(&self) -> &[Partition] {
        &self.partitions
    }

    /// Numbers of membership functions per input `(m_1, ..., m_n)`.
    pub fn membership_counts(&self) -> Vec<usize> {
        self.partitions.iter().map(Partition::len).collect()
    }

    /// A copy with the partition of input `input` replaced (same name).
    pub fn with_partition(&self, input: usize, partition: Partition) -> Result<Self, FuzzyError> {
        if input >= self.partitions.len() {
            return Err(FuzzyError::InputCount {
                expected: self.partitions.len(),
                found: input + 1,
            });
        }
        let mut partitions = self.partitions.clone();
        partitions[input] = partition;
        Self::new(self.input_names.clone(), partitions)
    }

    /// Rule index of the membership-function combination `k` (0-based per
    /// input), or `None` when `k` is out of the grid.
    pub fn rule_index(&self, k: &[usize]) -> Option<usize> {
        if k.len() != self.partitions.len() {
            return None;
        }
        let mut index = 0;
        for ((&kj, p), &stride) in k.iter().zip(&self.partitions).zip(&self.strides) {
            if kj >= p.len() {
                return None;
            }
            index += kj * stride;
        }
        Some(index)
    }

    /// Membership-function combination (0-based per input) of rule `rule`,
    /// or `None` when `rule >= rule_count()`.
    pub fn rule_memberships(&self, rule: usize) -> Option<Vec<usize>> {
        if rule >= self.rule_count {
            return None;
        }
        Some(
            self.strides
                .iter()
                .zip(&self.partitions)
                .map(|(&stride, p)| (rule / stride) % p.len())
                .collect(),
        )
    }

    /// Checks the length and finiteness of one sample.
    pub(crate) fn check_sample(&self, sample: usize, x: &[f64]) -> Result<(), FuzzyError> {
        if x.len() != self.partitions.len() {
            return Err(FuzzyError::InputCount {
                expected: self.partitions.len(),
                found: x.len(),
            });
        }
        for (j, &value) in x.iter().enumerate() {
            if !value.is_finite() {
                return Err(FuzzyError::NonFiniteInput {
                    sample,
                    input: self.input_names[j].clone(),
                    value,
                });
            }
        }
        Ok(())
    }

    /// Rule activations (firing strengths, equation (37)) of sample `x`:
    /// the `2^n` rules of the grid cell holding `x`, with their strengths.
    /// With strong partitions and the product, the strengths are those of
    /// multilinear interpolation and sum to one, so they are also the
    /// normalised weights of equation (36). At a modal value some listed
    /// strengths are exactly zero. `out` is reused: no allocation once it
    /// has grown to `2^n` entries.
    pub fn activations(&self, x: &[f64], out: &mut RuleActivations) -> Result<(), FuzzyError> {
        self.check_sample(0, x)?;
        self.activations_unchecked(x, out);
        Ok(())
    }

    pub(crate) fn activations_unchecked(&self, x: &[f64], out: &mut RuleActivations) {
        out.rules.clear();
        out.strengths.clear();
        out.rules.push(0);
        out.strengths.push(1.0);
        for ((p, &stride), &xj) in self.partitions.iter().zip(&self.strides).zip(x) {
            let (k, t) = p.locate(xj);
            let filled = out.rules.len();
            for c in 0..filled {
                let (rule, strength) = (out.rules[c], out.strengths[c]);
                out.rules[c] = rule + k * stride;
                out.strengths[c] = strength * (1.0 - t);
                out.rules.push(rule + (k + 1) * stride);
                out.strengths.push(strength * t);
            }
        }
    }

    /// Locates every input of `x` into `cells` (first `n` entries): the rule
    /// index of the cell's lowest corner and the interpolation fraction of
    /// each input. Internal to the fast evaluation.
    #[inline]
    pub(crate) fn locate_all(
        &self,
        x: &[f64],
        fractions: &mut [f64; MAX_INPUTS],
        strides: &mut [usize; MAX_INPUTS],
    ) -> usize {
        let mut base = 0;
        for (j, ((p, &stride), &xj)) in self.partitions.iter().zip(&self.strides).zip(x).enumerate()
        {
            let (k, t) = p.locate(xj);
            base += k * stride;
            fractions[j] = t;
            strides[j] = stride;
        }
        base
    }

    pub(crate) fn strides(&self) -> &[usize] {
        &self.strides
    }
}

pub(crate) fn check_distinct(names: &[String]) -> Result<(), FuzzyError> {
    for (i, name) in names.iter().enumerate() {
        if names[..i].contains(name) {
            return Err(FuzzyError::DuplicateName { name: name.clone() });
        }
    }
    Ok(())
}

/// Sparse rule activations of one sample: `2^n` rule indices and their
/// firing strengths (equation (37)), which sum to one.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RuleActivations {
    rules: Vec<usize>,
    strengths: Vec<f64>,
}

impl RuleActivations {
    /// An empty buffer, to be filled by [`FuzzyStructure::activations`].
    pub fn new() -> Self {
        Self::default()
    }

    /// Rule indices (distinct).
    pub fn rules(&self) -> &[usize] {
        &self.rules
    }

    /// Firing strengths, in the order of [`rules`](Self::rules).
    pub fn strengths(&self) -> &[f64] {
        &self.strengths
    }

    /// Pairs `(rule, strength)`.
    pub fn iter(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.rules
            .iter()
            .copied()
            .zip(self.strengths.iter().copied())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn structure(counts: &[usize]) -> FuzzyStructure {
        let names = (0..counts.len()).map(|j| format!("x{j}")).collect();
        let parts = counts
            .iter()
            .map(|&m| Partition::uniform(-1.0, 2.0, m).unwrap())
            .collect();
        FuzzyStructure::new(names, parts).unwrap()
    }

    #[test]
    fn partition_rejects_bad_modal_values() {
        assert_eq!(
            Partition::new(vec![1.0]),
            Err(PartitionError::TooFewModalValues { count: 1 })
        );
        assert!(matches!(
            Partition::new(vec![0.0, 1.0, 1.0]),
            Err(PartitionError::NotIncreasing { index: 2, .. })
        ));
        assert!(matches!(
            Partition::new(vec![0.0, f64::NAN]),
            Err(PartitionError::NonFinite { index: 1, .. })
        ));
    }

    #[test]
    fn triangles_have_apex_one_and_shoulders_clamp() {
        let p = Partition::new(vec![0.0, 1.0, 3.0]).unwrap();
        assert_eq!(p.membership(1, 1.0), 1.0);
        assert_eq!(p.membership(0, 0.5), 0.5);
        assert_eq!(p.membership(2, 2.0), 0.5);
        assert_eq!(p.membership(0, -5.0), 1.0);
        assert_eq!(p.membership(2, 9.0), 1.0);
        assert_eq!(p.membership(5, 1.0), 0.0);
    }

    #[test]
    fn rule_numbering_matches_table_4() {
        // 4 x 3: rule 5 (1-based) of Table 4 is (theta_2 MF 2, theta_8 MF 2).
        let s = structure(&[4, 3]);
        assert_eq!(s.rule_count(), 12);
        assert_eq!(s.rule_index(&[1, 1]), Some(4));
        assert_eq!(s.rule_memberships(4), Some(vec![1, 1]));
        assert_eq!(s.rule_index(&[4, 0]), None);
        for rule in 0..12 {
            let k = s.rule_memberships(rule).unwrap();
            assert_eq!(s.rule_index(&k), Some(rule));
        }
    }

    #[test]
    fn bad_structures_are_errors() {
        assert!(matches!(
            FuzzyStructure::new(vec![], vec![]),
            Err(FuzzyError::NoInputs)
        ));
        let p = Partition::uniform(0.0, 1.0, 2).unwrap();
        assert!(matches!(
            FuzzyStructure::new(vec!["a".into(), "a".into()], vec![p.clone(), p.clone()]),
            Err(FuzzyError::DuplicateName { .. })
        ));
        assert!(matches!(
            FuzzyStructure::new(vec!["a".into()], vec![p.clone(), p]),
            Err(FuzzyError::NameCount { .. })
        ));
        let s = structure(&[2, 2]);
        let mut a = RuleActivations::new();
        assert!(matches!(
            s.activations(&[0.0, f64::NAN], &mut a),
            Err(FuzzyError::NonFiniteInput { input, .. }) if input == "x1"
        ));
    }

    proptest! {
        #![proptest_config(proptest::test_runner::Config {
            // Seeded: every run draws the same cases.
            rng_seed: proptest::test_runner::RngSeed::Fixed(20130004),
            failure_persistence: None,
            ..proptest::test_runner::Config::default()
        })]
        #[test]
        fn memberships_sum_to_one(
            gaps in proptest::collection::vec(0.01f64..2.0, 1..7),
            start in -5.0f64..5.0,
            x in -10.0f64..10.0,
        ) {
            let mut values = vec![start];
            for g in &gaps {
                values.push(values.last().unwrap() + g);
            }
            let p = Partition::new(values).unwrap();
            let mut mu = vec![0.0; p.len()];
            p.memberships_into(x, &mut mu).unwrap();
            prop_assert!((mu.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            prop_assert!(mu.iter().all(|&m| (0.0..=1.0).contains(&m)));
            prop_assert!(mu.iter().filter(|&&m| m > 0.0).count() <= 2);
            for (k, &m) in mu.iter().enumerate() {
                prop_assert_eq!(m, p.membership(k, x));
            }
        }

        #[test]
        fn activations_are_the_product_of_memberships_and_sum_to_one(
            counts in proptest::collection::vec(2usize..5, 1..4),
            unit in proptest::collection::vec(-0.2f64..1.2, 3),
        ) {
            let s = structure(&counts);
            let x: Vec<f64> = unit.iter().take(counts.len()).map(|u| -1.0 + 3.0 * u).collect();
            let mut a = RuleActivations::new();
            s.activations(&x, &mut a).unwrap();
            prop_assert_eq!(a.rules().len(), 1 << counts.len());
            prop_assert!((a.strengths().iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // Dense check against equation (37) for every rule.
            for rule in 0..s.rule_count() {
                let k = s.rule_memberships(rule).unwrap();
                let dense: f64 = k.iter().zip(s.partitions()).zip(&x)
                    .map(|((&kj, p), &xj)| p.membership(kj, xj)).product();
                let sparse: f64 = a.iter().filter(|(r, _)| *r == rule).map(|(_, w)| w).sum();
                prop_assert!((dense - sparse).abs() < 1e-12);
            }
        }
    }
}
