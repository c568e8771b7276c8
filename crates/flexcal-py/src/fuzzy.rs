//! `flexcal.FuzzyModel`: zero-order Takagi-Sugeno models (equations
//! (33)-(37) of Marie, Courteille, Maurine 2013) fitted on arrays.

use std::sync::Arc;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::fuzzy::{Dataset, FuzzyModel as Model, FuzzyParams};
use numpy::PyArrayDyn;
use pyo3::prelude::*;

use crate::arrays::{exact, to_numpy};
use crate::errors::{InputError, ShapeError};
use crate::interrupt::{run_here, run_interruptible};

/// A fitted fuzzy model y = f(x) over named inputs: grid partitions with
/// triangular membership functions, one constant conclusion per rule.
#[pyclass(frozen, module = "flexcal", name = "FuzzyModel")]
#[derive(Debug, Clone)]
pub struct FuzzyModel {
    model: Arc<Model>,
    training_rmse: f64,
    test_rmse: f64,
}

#[pymethods]
impl FuzzyModel {
    /// Fits a model on samples `x` (n, k) and outputs `y` (n,) (any units;
    /// the model keeps them): the structure (membership functions per input)
    /// grows while the error on a held-out `test_fraction` of the samples
    /// (drawn with `seed`) improves, up to `max_rules` rules; the
    /// conclusions are least squares with `ridge`. `input_names` default to
    /// x1..xk. Runs without the GIL; Ctrl-C returns at once (the fit
    /// finishes in the background and is dropped).
    #[staticmethod]
    #[pyo3(signature = (x, y, input_names = None, output_name = "y", test_fraction = 0.25, seed = 0, max_rules = None, ridge = None))]
    #[allow(clippy::too_many_arguments)]
    fn fit<'py>(
        py: Python<'py>,
        x: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        y: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        input_names: Option<Vec<String>>,
        output_name: &str,
        test_fraction: f64,
        seed: u64,
        max_rules: Option<usize>,
        ridge: Option<f64>,
    ) -> PyResult<Self> {
        let (x, shape) = exact("x", &x, &[None, None])?;
        let (n, k) = (shape[0], shape[1]);
        let (y, _) = exact("y", &y, &[Some(n)])?;
        let names = input_names.unwrap_or_else(|| (1..=k).map(|i| format!("x{i}")).collect());
        if names.len() != k {
            return Err(ShapeError::new_err(format!(
                "input_names: expected {k} names (one per column of x), got {}",
                names.len()
            )));
        }
        let mut params = FuzzyParams::default();
        if let Some(m) = max_rules {
            params.search.max_rules = m;
        }
        if let Some(r) = ridge {
            params.ridge = r;
        }
        if !(test_fraction > 0.0 && test_fraction < 1.0) {
            return Err(InputError::new_err(format!(
                "test_fraction: must be in (0, 1), got {test_fraction}"
            )));
        }
        let columns: Vec<Vec<f64>> = (0..k)
            .map(|c| (0..n).map(|r| x[r * k + c]).collect())
            .collect();
        let output_name = output_name.to_string();
        let fit = run_interruptible(py, move || {
            let data = Dataset::new(names, output_name, &columns, y)?;
            let (train, test) = data.split_random(test_fraction, seed)?;
            Ok(params.fit(&train, &test, &mut |_| {})?)
        })?;
        Ok(Self {
            model: Arc::new(fit.model),
            training_rmse: fit.report.training.rmse,
            test_rmse: fit.report.test.rmse,
        })
    }

    /// Outputs for samples `x` (n, k) or one sample (k,); inputs outside the
    /// training range are clamped to it.
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let k = self.model.input_names().len();
        let rows = crate::arrays::rows("x", &x, k)?;
        let model = &self.model;
        let out = run_here(|| {
            let mut out = vec![0.0; rows.n];
            model.evaluate_batch(&rows.data, &mut out)?;
            Ok(out)
        })?;
        if rows.batched {
            let n = out.len();
            Ok(to_numpy(py, out, &[n]))
        } else {
            Ok(to_numpy(py, out, &[]))
        }
    }

    /// The model in the Fuzzy Logic Toolbox `.fis` text format.
    #[pyo3(signature = (name = "flexcal"))]
    fn to_fis(&self, name: &str) -> String {
        self.model.to_fis_string(name)
    }

    /// The input names, in the order of the columns of x.
    #[getter]
    fn input_names(&self) -> Vec<String> {
        self.model.input_names().to_vec()
    }

    /// Number of rules.
    #[getter]
    fn n_rules(&self) -> usize {
        self.model.structure().rule_count()
    }

    /// The rule conclusions (units of y), shape (n_rules,).
    #[getter]
    fn conclusions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let c = self.model.conclusions().to_vec();
        let n = c.len();
        to_numpy(py, c, &[n])
    }

    /// RMS error on the training samples (units of y).
    #[getter]
    fn training_rmse(&self) -> f64 {
        self.training_rmse
    }

    /// RMS error on the held-out test samples (units of y).
    #[getter]
    fn test_rmse(&self) -> f64 {
        self.test_rmse
    }

    fn __repr__(&self) -> String {
        format!(
            "FuzzyModel(inputs={:?}, rules={}, test_rmse={})",
            self.model.input_names(),
            self.model.structure().rule_count(),
            self.test_rmse
        )
    }
}
