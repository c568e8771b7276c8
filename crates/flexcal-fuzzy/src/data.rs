//! Data sets: named input columns and one output, and their splits.

use crate::error::FuzzyError;
use crate::partition::check_distinct;
use flexcal_io::CsvTable;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Samples of named inputs and one named output, all finite. Inputs are
/// stored row by row (sample-major), the layout of
/// [`FuzzyModel::evaluate_batch`](crate::FuzzyModel::evaluate_batch).
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    input_names: Vec<String>,
    output_name: String,
    inputs: Vec<f64>,
    outputs: Vec<f64>,
}

impl Dataset {
    /// A data set from input columns (one per name, equal lengths) and the
    /// output column. Every value must be finite, names distinct.
    pub fn new(
        input_names: Vec<String>,
        output_name: String,
        input_columns: &[Vec<f64>],
        outputs: Vec<f64>,
    ) -> Result<Self, FuzzyError> {
        if input_names.len() != input_columns.len() {
            return Err(FuzzyError::NameCount {
                names: input_names.len(),
                items: input_columns.len(),
                what: "input columns",
            });
        }
        if input_names.is_empty() {
            return Err(FuzzyError::NoInputs);
        }
        let mut all = input_names.clone();
        all.push(output_name.clone());
        check_distinct(&all)?;
        let n_samples = outputs.len();
        for (name, column) in input_names.iter().zip(input_columns) {
            if column.len() != n_samples {
                return Err(FuzzyError::ColumnLength {
                    column: name.clone(),
                    expected: n_samples,
                    found: column.len(),
                });
            }
            if let Some(sample) = column.iter().position(|v| !v.is_finite()) {
                return Err(FuzzyError::NonFiniteInput {
                    sample,
                    input: name.clone(),
                    value: column[sample],
                });
            }
        }
        if let Some(sample) = outputs.iter().position(|v| !v.is_finite()) {
            return Err(FuzzyError::NonFiniteOutput {
                sample,
                column: output_name,
                value: outputs[sample],
            });
        }
        let mut inputs = Vec::with_capacity(n_samples * input_names.len());
        for k in 0..n_samples {
            inputs.extend(input_columns.iter().map(|c| c[k]));
        }
        Ok(Self {
            input_names,
            output_name,
            inputs,
            outputs,
        })
    }

    /// Reads the named columns of a CSV table (unknown names and bad cells
    /// are errors naming the file, line and column).
    pub fn from_csv(table: &CsvTable, inputs: &[&str], output: &str) -> Result<Self, FuzzyError> {
        table.require_rows()?;
        let columns = inputs
            .iter()
            .map(|name| table.column_f64(name))
            .collect::<Result<Vec<_>, _>>()?;
        let outputs = table.column_f64(output)?;
        Self::new(
            inputs.iter().map(|s| s.to_string()).collect(),
            output.to_string(),
            &columns,
            outputs,
        )
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.outputs.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.outputs.is_empty()
    }

    /// Input names.
    pub fn input_names(&self) -> &[String] {
        &self.input_names
    }

    /// Output name.
    pub fn output_name(&self) -> &str {
        &self.output_name
    }

    /// Number of inputs.
    pub fn input_count(&self) -> usize {
        self.input_names.len()
    }

    /// Inputs of sample `k` (panics if `k >= len()`, like slice indexing).
    pub fn sample(&self, k: usize) -> &[f64] {
        let n = self.input_count();
        &self.inputs[k * n..(k + 1) * n]
    }

    /// All inputs, sample after sample.
    pub fn inputs_row_major(&self) -> &[f64] {
        &self.inputs
    }

    /// Outputs.
    pub fn outputs(&self) -> &[f64] {
        &self.outputs
    }

    /// Smallest and largest value of each input; an input with a single
    /// value is a [`FuzzyError::ConstantInput`] error (`set` names the data
    /// set in it), an empty set a [`FuzzyError::EmptySet`] error.
    pub fn input_domains(&self, set: &'static str) -> Result<Vec<(f64, f64)>, FuzzyError> {
        if self.is_empty() {
            return Err(FuzzyError::EmptySet { set });
        }
        let n = self.input_count();
        let mut domains = vec![(f64::INFINITY, f64::NEG_INFINITY); n];
        for row in self.inputs.chunks_exact(n) {
            for (d, &v) in domains.iter_mut().zip(row) {
                d.0 = d.0.min(v);
                d.1 = d.1.max(v);
            }
        }
        for (name, &(lower, upper)) in self.input_names.iter().zip(&domains) {
            if lower >= upper {
                return Err(FuzzyError::ConstantInput {
                    input: name.clone(),
                    value: lower,
                    set,
                });
            }
        }
        Ok(domains)
    }

    /// The samples at `indices`, in that order.
    pub fn subset(&self, indices: &[usize]) -> Self {
        let mut inputs = Vec::with_capacity(indices.len() * self.input_count());
        for &k in indices {
            inputs.extend_from_slice(self.sample(k));
        }
        Self {
            input_names: self.input_names.clone(),
            output_name: self.output_name.clone(),
            inputs,
            outputs: indices.iter().map(|&k| self.outputs[k]).collect(),
        }
    }

    /// Random split into a training set and a test set holding
    /// `round(test_fraction * len())` samples (at least one of each),
    /// reproducible from `seed`.
    pub fn split_random(&self, test_fraction: f64, seed: u64) -> Result<(Self, Self), FuzzyError> {
        if !(test_fraction > 0.0 && test_fraction < 1.0) {
            return Err(FuzzyError::InvalidParameter {
                name: "test_fraction",
                value: test_fraction.to_string(),
                reason: "must be in (0, 1)",
            });
        }
        if self.len() < 2 {
            return Err(FuzzyError::TooFewSamples {
                set: "data set to split",
                samples: self.len(),
                rules: 2,
            });
        }
        let n_test =
            ((test_fraction * self.len() as f64).round() as usize).clamp(1, self.len() - 1);
        let mut order: Vec<usize> = (0..self.len()).collect();
        order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        let (test, train) = order.split_at(n_test);
        let (mut train, mut test) = (train.to_vec(), test.to_vec());
        // Keep the file order inside each set: easier to read and compare.
        train.sort_unstable();
        test.sort_unstable();
        Ok((self.subset(&train), self.subset(&test)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexcal_io::CsvOptions;

    #[test]
    fn csv_columns_and_errors() {
        let text = "a,b,y\n0,1,2\n1,1,3\n2,1,4\n";
        let t = CsvTable::from_str(text, "d.csv", &CsvOptions::default()).unwrap();
        let d = Dataset::from_csv(&t, &["a", "b"], "y").unwrap();
        assert_eq!(d.sample(1), &[1.0, 1.0]);
        assert_eq!(d.outputs(), &[2.0, 3.0, 4.0]);
        let err = d.input_domains("training set").unwrap_err().to_string();
        assert!(err.contains("'b'") && err.contains("constant"), "{err}");
        let err = Dataset::from_csv(&t, &["a", "c"], "y")
            .unwrap_err()
            .to_string();
        assert!(err.contains("'c'") && err.contains("d.csv"), "{err}");
        let nan = CsvTable::from_str("a,y\nNaN,1\n", "n.csv", &CsvOptions::default()).unwrap();
        let err = Dataset::from_csv(&nan, &["a"], "y")
            .unwrap_err()
            .to_string();
        assert!(err.contains("n.csv:2"), "{err}");
        assert!(matches!(
            Dataset::new(vec!["a".into()], "y".into(), &[vec![f64::NAN]], vec![1.0]),
            Err(FuzzyError::NonFiniteInput { .. })
        ));
    }

    #[test]
    fn random_split_is_a_seeded_partition_of_the_samples() {
        let x: Vec<f64> = (0..20).map(f64::from).collect();
        let d = Dataset::new(
            vec!["x".into()],
            "y".into(),
            std::slice::from_ref(&x),
            x.clone(),
        )
        .unwrap();
        let (train, test) = d.split_random(0.25, 4).unwrap();
        assert_eq!((train.len(), test.len()), (15, 5));
        let mut all: Vec<f64> = train
            .outputs()
            .iter()
            .chain(test.outputs())
            .copied()
            .collect();
        all.sort_by(f64::total_cmp);
        assert_eq!(all, x);
        assert_eq!(
            d.split_random(0.25, 4).unwrap(),
            (train.clone(), test.clone())
        );
        assert_ne!(d.split_random(0.25, 5).unwrap().1, test);
        assert!(d.split_random(1.0, 4).is_err());
    }
}
