//! Zero-order Takagi-Sugeno models from CSV files (`flexcal fuzzy`): read a
//! dataset by column names, fit a model with a held-out test set, evaluate.
//!
//! A dataset file has a header naming its columns; the inputs and the
//! output are chosen by name, other columns are ignored. Values are in the
//! units of the file; the model keeps them.

use std::path::{Path, PathBuf};

use flexcal_fuzzy::{
    Dataset, ErrorStats, FuzzyError, FuzzyFit, FuzzyModel, FuzzyParams, SearchPhase,
    SearchProgress, StructureSearchParams,
};
use flexcal_io::{CsvOptions, CsvTable};
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Reads the columns `inputs` and `output` of the CSV file `path`.
///
/// # Errors
/// File and CSV errors naming the file, line and column; a dataset the
/// model cannot take (repeated names, too many inputs), named by file.
pub fn read_dataset(path: &Path, inputs: &[&str], output: &str) -> Result<Dataset> {
    let table = CsvTable::read(path, &CsvOptions::default())?;
    Dataset::from_csv(&table, inputs, output).map_err(|source| match source {
        // File errors already name the file, line and column.
        FuzzyError::Io(e) => Error::Io(e),
        source => Error::FuzzyData {
            path: path.to_path_buf(),
            source,
        },
    })
}

/// Where the test set of a fit comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum TestSet {
    /// A file with the same columns.
    File(PathBuf),
    /// A random part of the training file held out (fraction in (0, 1)).
    HeldOut(f64),
}

/// A fit of a fuzzy model to a CSV file.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvFitConfig {
    /// Training data.
    pub data: PathBuf,
    /// Input columns.
    pub inputs: Vec<String>,
    /// Output column.
    pub output: String,
    /// The test set (default: a quarter of `data` held out).
    pub test: TestSet,
    /// Largest number of rules (default 64).
    pub max_rules: usize,
    /// Seed of the split and of the modal-value search (default 1).
    pub seed: u64,
    /// Relative ridge weight towards the rapid-prototyping conclusions
    /// (default 1e-6).
    pub ridge: f64,
}

impl CsvFitConfig {
    /// A fit of `output` over `inputs` in `data` with the defaults.
    pub fn new(data: impl Into<PathBuf>, inputs: Vec<String>, output: impl Into<String>) -> Self {
        Self {
            data: data.into(),
            inputs,
            output: output.into(),
            test: TestSet::HeldOut(0.25),
            max_rules: 64,
            seed: 1,
            ridge: 1e-6,
        }
    }
}

/// A fitted model and the sizes of its training and test sets.
#[derive(Debug, Clone)]
pub struct CsvFit {
    /// The model and its report.
    pub fit: FuzzyFit,
    /// Training samples.
    pub training_samples: usize,
    /// Test samples.
    pub test_samples: usize,
}

impl CsvFit {
    /// One line: rules, memberships per input, sample counts, training and
    /// test errors (units of the output) and the search's end.
    pub fn summary_line(&self) -> String {
        let (structure, report) = (self.fit.model.structure(), &self.fit.report);
        format!(
            "{} rules {:?}, {} training / {} test samples, train rmse {:.6e}, test rmse {:.6e}, test max |error| {:.6e} ({:?} after {} evaluations)",
            structure.rule_count(),
            structure.membership_counts(),
            self.training_samples,
            self.test_samples,
            report.training.rmse,
            report.test.rmse,
            report.test.max_abs,
            report.search.termination,
            report.search.evaluations,
        )
    }
}

/// One line on a step of the structure search: the growth step, the
/// membership counts, the best test error so far, the evaluations and what
/// the step does (`inputs` name the inputs).
pub fn progress_line(p: &SearchProgress, inputs: &[String]) -> String {
    let doing = match p.phase {
        SearchPhase::Initial => "initial placement".to_string(),
        SearchPhase::Candidate { input, .. } => {
            let name = inputs.get(input).map_or("?", String::as_str);
            format!("trying one more MF on '{name}'")
        }
        SearchPhase::StepDone => "step done".to_string(),
    };
    format!(
        "growth step {}, MFs {:?}, best test rmse {:.4e}, {} evaluations: {doing}",
        p.growth_step, p.memberships[0], p.best_test_error, p.evaluations
    )
}

/// Fits a fuzzy model as `config` says; `progress` sees every step of the
/// structure search.
///
/// # Errors
/// Unreadable files, an invalid split or parameter, a failed fit.
pub fn fit_csv(config: &CsvFitConfig, progress: &mut dyn FnMut(&SearchProgress)) -> Result<CsvFit> {
    let inputs: Vec<&str> = config.inputs.iter().map(String::as_str).collect();
    let data = read_dataset(&config.data, &inputs, &config.output)?;
    let (train, test) = match &config.test {
        TestSet::File(path) => (data, read_dataset(path, &inputs, &config.output)?),
        TestSet::HeldOut(fraction) => data.split_random(*fraction, config.seed)?,
    };
    let defaults = StructureSearchParams::default();
    let params = FuzzyParams {
        search: StructureSearchParams {
            max_rules: config.max_rules,
            placement: flexcal_optim::solis_wets::SolisWetsParams {
                seed: config.seed,
                ..defaults.placement.clone()
            },
            ..defaults
        },
        ridge: config.ridge,
        ..FuzzyParams::default()
    };
    let fit = params.fit(&train, &test, progress)?;
    Ok(CsvFit {
        fit,
        training_samples: train.len(),
        test_samples: test.len(),
    })
}

/// The errors of a model on a dataset file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CsvEvaluation {
    /// The model's output column.
    pub output: String,
    /// The error statistics (units of the output).
    pub stats: ErrorStats,
}

impl CsvEvaluation {
    /// One line: samples, RMSE, MAE, largest absolute error, output name.
    pub fn summary_line(&self) -> String {
        let s = &self.stats;
        format!(
            "{} samples: rmse {:.6e}, mae {:.6e}, max |error| {:.6e} (output '{}')",
            s.n, s.rmse, s.mae, s.max_abs, self.output
        )
    }
}

/// Evaluates the model file `model` (TOML) on the dataset file `data`,
/// which holds the model's input columns and its output column.
///
/// # Errors
/// Unreadable files, missing columns, named by file.
pub fn evaluate_csv(model: &Path, data: &Path) -> Result<CsvEvaluation> {
    let model = FuzzyModel::read(model)?;
    let inputs: Vec<&str> = model.input_names().iter().map(String::as_str).collect();
    let dataset = read_dataset(data, &inputs, model.output_name())?;
    Ok(CsvEvaluation {
        output: model.output_name().to_string(),
        stats: model.error_stats(&dataset)?,
    })
}

/// Writes the model file `model` (TOML) as a `.fis` file, the format of
/// classic fuzzy toolboxes, named after the model file's stem.
///
/// # Errors
/// Unreadable model file, unwritable `.fis` file.
pub fn export_fis(model: &Path, fis: &Path) -> Result<()> {
    let fuzzy = FuzzyModel::read(model)?;
    let name = model
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| fuzzy.output_name().to_string());
    Ok(fuzzy.write_fis(fis, &name)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_smooth_function_is_learnt_from_a_file_and_named_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("data.csv");
        let mut text = String::from("x,ignored,y\n");
        for k in 0..200 {
            let x = k as f64 / 199.0;
            text += &format!("{x},{k},{}\n", (3.0 * x).sin());
        }
        std::fs::write(&path, text).unwrap();
        let config = CsvFitConfig {
            max_rules: 12,
            ..CsvFitConfig::new(&path, vec!["x".into()], "y")
        };
        let mut lines = Vec::new();
        let fitted = fit_csv(&config, &mut |p| {
            lines.push(progress_line(p, &config.inputs))
        })
        .unwrap();
        assert!(lines[0].starts_with("growth step "), "{lines:?}");
        assert!(
            lines
                .iter()
                .any(|l| l.ends_with("trying one more MF on 'x'")),
            "{lines:?}"
        );
        assert_eq!(fitted.training_samples + fitted.test_samples, 200);
        assert!(
            fitted.fit.report.test.rmse < 0.02,
            "{}",
            fitted.summary_line()
        );
        assert!(fitted.summary_line().contains(" training / "));
        let model_path = dir.path().join("sine.toml");
        fitted.fit.model.write(&model_path).unwrap();
        let evaluation = evaluate_csv(&model_path, &path).unwrap();
        assert_eq!(evaluation.stats.n, 200);
        assert_eq!(evaluation.output, "y");
        assert!(
            evaluation.stats.rmse < 0.02,
            "{}",
            evaluation.summary_line()
        );
        let fis = dir.path().join("sine.fis");
        export_fis(&model_path, &fis).unwrap();
        let fis_text = std::fs::read_to_string(&fis).unwrap();
        assert!(fis_text.contains("Name='sine'"), "{fis_text}");
        let err = read_dataset(&path, &["x", "x"], "y")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with(&path.display().to_string()), "{err}");
        let err = read_dataset(&path, &["z"], "y").unwrap_err().to_string();
        assert!(err.contains("missing column 'z'"), "{err}");
    }
}
