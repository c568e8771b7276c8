//! The one-call learner of a single-output model: settings
//! ([`FuzzyParams`]), fit and report.

use crate::data::Dataset;
use crate::error::FuzzyError;
use crate::model::{ErrorStats, FuzzyModel};
use crate::partition::FuzzyStructure;

use super::conclusions::{ConclusionMethod, check_ridge, fit_conclusions};
use super::joint::{JointFit, LinearCombinationSet, fit_joint_conclusions, joint_stats};
use super::report::FitReport;
use super::search::{SearchProgress, StructureScore, StructureSearchParams, search_structure};

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

/// The checks both fits make before their structure search: the test set
/// has the training set's inputs and is not empty; then the initial
/// structure over the training inputs' `domains`.
fn initial_structure(
    train_inputs: &[String],
    test_inputs: &[String],
    test_is_empty: bool,
    domains: impl FnOnce() -> Result<Vec<(f64, f64)>, FuzzyError>,
) -> Result<FuzzyStructure, FuzzyError> {
    if train_inputs != test_inputs {
        return Err(FuzzyError::InputNames {
            expected: train_inputs.to_vec(),
            found: test_inputs.to_vec(),
        });
    }
    if test_is_empty {
        return Err(FuzzyError::EmptySet { set: "test set" });
    }
    FuzzyStructure::initial(train_inputs.to_vec(), &domains()?)
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
        let initial = initial_structure(
            train.input_names(),
            test.input_names(),
            test.is_empty(),
            || train.input_domains("training set"),
        )?;
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
        let initial = initial_structure(
            train.input_names(),
            test.input_names(),
            test.is_empty(),
            || train.input_domains("training set"),
        )?;
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
