//! Identification workflows on a campaign directory: the steps a user runs
//! after a deflection campaign, as library calls with typed reports.
//!
//! - [`identify_stiffness_in_dir`]: the joint stiffness Gamma of a robot's
//!   beam model (section 3.3.1 of the reference paper), trained on the sets
//!   of one load and validated on all of them (Table 5), with its
//!   [`StiffnessReport`] that writes and reads its own JSON file.
//! - [`identify_compliance_in_dir`]: the fuzzy compliance model
//!   (section 3.3.2, equations (38), (70)) on the same split.
//! - [`split_by_load`] and [`deflection_noise_floor_mm`]: the load split and
//!   the noise floor both workflows share.
//!
//! Default seeds and budgets are those of the CLI's defaults
//! ([`StiffnessWorkflowOptions::default`], [`ComplianceWorkflowOptions::default`]).

use std::path::{Path, PathBuf};

use flexcal_kinematics::Model;
use serde::{Deserialize, Serialize};

use crate::campaign::{DeflectionMeasurement, DeflectionSet, read_campaign_dir};
use crate::description::ElasticDescription;
use crate::error::ElasticError;
use crate::fuzzy_compliance::{
    ComplianceComponent, ComplianceFitParams, FittedCompliance, FuzzyComplianceError, RobotInputs,
    compliance_samples, identify_compliance, noise_floor_rms,
};
use crate::identify::{
    IdentifiedStiffness, StiffnessIdentifiability, StiffnessIdentificationOptions,
    identify_stiffness, residual_samples,
};
use crate::metrics::{LoadMetricsTable, per_load_metrics};
use crate::model::ElasticModel;

mod text;

/// Errors of the identification workflows.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WorkflowError {
    /// Elastic model, data files or stiffness identification.
    #[error(transparent)]
    Elastic(#[from] ElasticError),
    /// The fuzzy compliance model.
    #[error(transparent)]
    Compliance(#[from] FuzzyComplianceError),
    /// A deflection file that the compliance model cannot use.
    #[error("{}: {source}", path.display())]
    ComplianceFile {
        /// The deflection file.
        path: PathBuf,
        /// Why.
        source: FuzzyComplianceError,
    },
    /// A stiffness report that does not parse or does not match the model.
    #[error("{}: {message}", path.display())]
    Report {
        /// The report file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// A campaign split by load: what trains and what is evaluated.
#[derive(Debug, Clone)]
pub struct LoadSplit<T> {
    /// Items of the training sets (load within 0.5 N of the training load).
    pub train: Vec<T>,
    /// Items of every set (the training sets included).
    pub all: Vec<T>,
    /// Names of the training sets.
    pub train_sets: Vec<String>,
}

/// Splits a campaign's sets into the items of the training sets (those whose
/// load is `train_load_n` N, within 0.5 N) and the items of every set.
/// `items` turns one set into what is fitted.
///
/// # Errors
/// A non-positive training load, no set with the training load (the message
/// lists the sets and their loads), or an error of `items`.
pub fn split_by_load<T: Clone, E: From<ElasticError>>(
    sets: &[DeflectionSet],
    train_load_n: f64,
    dir: &Path,
    items: impl Fn(&DeflectionSet) -> Result<Vec<T>, E>,
) -> Result<LoadSplit<T>, E> {
    check_train_load(train_load_n)?;
    let mut split = LoadSplit {
        train: Vec::new(),
        all: Vec::new(),
        train_sets: Vec::new(),
    };
    for set in sets {
        let set_items = items(set)?;
        if (set.load_n() - train_load_n).abs() <= 0.5 {
            split.train.extend(set_items.iter().cloned());
            split.train_sets.push(set.name.clone());
        }
        split.all.extend(set_items);
    }
    if split.train.is_empty() {
        let loads: Vec<String> = sets
            .iter()
            .map(|s| format!("{} ({:.0} N)", s.name, s.load_n()))
            .collect();
        return Err(ElasticError::NoData {
            what: format!(
                "no deflection set in {} has the training load {} N (sets: {})",
                dir.display(),
                train_load_n,
                loads.join(", ")
            ),
        }
        .into());
    }
    Ok(split)
}

fn check_train_load(train_load_n: f64) -> Result<(), ElasticError> {
    if train_load_n.is_finite() && train_load_n > 0.0 {
        Ok(())
    } else {
        Err(ElasticError::invalid(
            "identification",
            "train_load_n",
            format!("must be a positive load in N, got {train_load_n}"),
        ))
    }
}

/// What a perfect model would still show: the RMS norm of the deflection
/// noise stated in the files (standard deviations per axis), in mm.
pub fn deflection_noise_floor_mm(measurements: &[DeflectionMeasurement]) -> f64 {
    if measurements.is_empty() {
        return 0.0;
    }
    (measurements
        .iter()
        .map(|m| m.sigma.norm_squared())
        .sum::<f64>()
        / measurements.len() as f64)
        .sqrt()
        * 1e3
}

/// Settings of [`identify_stiffness_in_dir`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StiffnessWorkflowOptions {
    /// Load magnitude (N) whose sets train the model; the others validate it (default 900).
    pub train_load_n: f64,
    /// Seed of the global search (default 1).
    pub seed: u64,
    /// Objective evaluations of the global search (default 2500; 0: start from the nominal values).
    pub search_evaluations: usize,
}

impl Default for StiffnessWorkflowOptions {
    fn default() -> Self {
        Self {
            train_load_n: 900.0,
            seed: 1,
            search_evaluations: 2500,
        }
    }
}

/// Everything the stiffness workflow computes.
#[derive(Debug, Clone)]
pub struct StiffnessOutcome {
    /// The elastic model that was identified.
    pub model: ElasticModel,
    /// The identified Gamma with the solver and identifiability reports.
    pub fitted: IdentifiedStiffness,
    /// The campaign's deflection sets, as read.
    pub sets: Vec<DeflectionSet>,
    /// Names of the training sets.
    pub train_sets: Vec<String>,
    /// Residuals of the identified model on every set (Table 5).
    pub table: LoadMetricsTable,
    /// RMS norm of the deflection noise stated in the files (mm).
    pub noise_floor_mm: f64,
    /// The report, as written by [`StiffnessReport::write`].
    pub report: StiffnessReport,
}

/// Identifies the stiffness parameters of `description` on `robot` from the
/// deflection files of the campaign directory `data`.
///
/// # Errors
/// Unreadable or inconsistent files, no set with the training load, an
/// invalid elastic description, identification failures.
pub fn identify_stiffness_in_dir(
    robot: &Model,
    description: &ElasticDescription,
    data: &Path,
    options: &StiffnessWorkflowOptions,
) -> Result<StiffnessOutcome, WorkflowError> {
    check_train_load(options.train_load_n)?;
    let model = ElasticModel::new(robot, description)?;
    let sets = read_campaign_dir(data, robot.n_actuated())?;
    let split = split_by_load::<_, ElasticError>(&sets, options.train_load_n, data, |set| {
        Ok(set.measurements.clone())
    })?;
    let xi = robot.nominal_params().to_vec();
    let identification = StiffnessIdentificationOptions {
        seed: options.seed,
        global_search_evaluations: options.search_evaluations,
        ..StiffnessIdentificationOptions::default()
    };
    let fitted = identify_stiffness(&model, &split.train, &xi, &identification)?;
    let samples = residual_samples(&model, &split.all, &xi, &fitted.gamma)?;
    let table = per_load_metrics(&samples);
    let noise_floor_mm = deflection_noise_floor_mm(&split.all);
    let report = StiffnessReport::new(
        robot.name(),
        &description.name,
        options,
        &split.train_sets,
        &fitted,
        &table,
        noise_floor_mm,
    );
    Ok(StiffnessOutcome {
        model,
        fitted,
        sets,
        train_sets: split.train_sets,
        table,
        noise_floor_mm,
        report,
    })
}

/// One identified stiffness parameter of a [`StiffnessReport`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StiffnessParameterReport {
    /// Parameter name.
    pub name: String,
    /// Identified value (SI, in `unit`).
    pub value: f64,
    /// Unit (`N.m/rad`, `N/m`, ...).
    pub unit: String,
    /// Value after the global search (SI).
    pub after_global_search: f64,
    /// Weighted column norm at the solution (standard deviations per unit of log stiffness).
    pub sensitivity_sigma_per_ln: f64,
}

/// The Levenberg-Marquardt part of a [`StiffnessReport`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StiffnessSolverReport {
    /// Why the solver stopped.
    pub termination: String,
    /// Iterations.
    pub iterations: usize,
    /// Residual evaluations.
    pub residual_evaluations: usize,
    /// Jacobian evaluations.
    pub jacobian_evaluations: usize,
    /// Numerical rank of the Jacobian at the solution.
    pub rank: usize,
    /// Number of free parameters.
    pub n_free: usize,
    /// Singular values of the scaled Jacobian.
    pub singular_values: Vec<f64>,
    /// Condition number (none when infinite).
    pub condition_number: Option<f64>,
    /// Cost at each iteration.
    pub cost_history: Vec<f64>,
}

/// The global-search part of a [`StiffnessReport`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GlobalSearchReport {
    /// Objective evaluations.
    pub evaluations: usize,
    /// Best mean squared weighted residual (none when no search ran).
    pub best_value: Option<f64>,
}

/// The report of a stiffness identification: the file
/// `flexcal identify stiffness --report` writes and `flexcal compensate
/// --gamma-report` reads. The same type writes and reads it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StiffnessReport {
    /// Robot name.
    pub robot: String,
    /// Elastic description name.
    pub elastic: String,
    /// Training load (N).
    pub train_load_n: f64,
    /// Names of the training sets.
    pub train_sets: Vec<String>,
    /// Seed of the global search.
    pub seed: u64,
    /// Identified parameters, in the model's order.
    pub parameters: Vec<StiffnessParameterReport>,
    /// Identifiability of Gamma.
    pub identifiability: StiffnessIdentifiability,
    /// The identifiability findings as sentences.
    pub identifiability_text: Vec<String>,
    /// The Levenberg-Marquardt solve.
    pub solver: StiffnessSolverReport,
    /// The global search.
    pub global_search: GlobalSearchReport,
    /// Criterion (67) on the training sets (mm^2).
    pub criterion_mm2: f64,
    /// Residuals per load (Table 5).
    pub per_load: LoadMetricsTable,
    /// RMS norm of the stated deflection noise (mm).
    pub noise_floor_rms_mm: f64,
}

/// A report as pretty-printed JSON (an `error` object if it cannot be).
fn report_json(report: &impl Serialize) -> String {
    serde_json::to_string_pretty(report).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
}

/// Writes a report as pretty JSON, atomically.
fn write_report(report: &impl Serialize, path: &Path) -> Result<(), WorkflowError> {
    flexcal_io::write_atomic(path, report_json(report)).map_err(ElasticError::from)?;
    Ok(())
}

/// Reads a report (`what` names its kind in the error) written by
/// [`write_report`].
fn read_report<T: serde::de::DeserializeOwned>(
    path: &Path,
    what: &str,
) -> Result<T, WorkflowError> {
    let text = flexcal_io::read_to_string(path).map_err(ElasticError::from)?;
    serde_json::from_str(&text).map_err(|e| WorkflowError::Report {
        path: path.to_path_buf(),
        message: format!("not a {what}: {e}"),
    })
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

impl StiffnessReport {
    /// The report of an identification.
    pub fn new(
        robot: &str,
        elastic: &str,
        options: &StiffnessWorkflowOptions,
        train_sets: &[String],
        fitted: &IdentifiedStiffness,
        table: &LoadMetricsTable,
        noise_floor_mm: f64,
    ) -> Self {
        let s = &fitted.solve;
        Self {
            robot: robot.to_string(),
            elastic: elastic.to_string(),
            train_load_n: options.train_load_n,
            train_sets: train_sets.to_vec(),
            seed: options.seed,
            parameters: fitted
                .names
                .iter()
                .enumerate()
                .map(|(j, name)| StiffnessParameterReport {
                    name: name.clone(),
                    value: fitted.gamma[j],
                    unit: fitted.units[j].clone(),
                    after_global_search: fitted.gamma_global_search[j],
                    sensitivity_sigma_per_ln: fitted.identifiability.sensitivity[j],
                })
                .collect(),
            identifiability: fitted.identifiability.clone(),
            identifiability_text: fitted.identifiability.describe(),
            solver: StiffnessSolverReport {
                termination: format!("{:?}", s.termination),
                iterations: s.iterations,
                residual_evaluations: s.residual_evaluations,
                jacobian_evaluations: s.jacobian_evaluations,
                rank: s.rank,
                n_free: s.n_free,
                singular_values: s.singular_values.clone(),
                condition_number: finite(s.condition_number),
                cost_history: s.cost_history.clone(),
            },
            global_search: GlobalSearchReport {
                evaluations: fitted.global_search_evaluations,
                best_value: finite(fitted.global_search_value),
            },
            criterion_mm2: fitted.criterion_mm2,
            per_load: table.clone(),
            noise_floor_rms_mm: noise_floor_mm,
        }
    }

    /// The report as pretty-printed JSON.
    pub fn to_json_string(&self) -> String {
        report_json(self)
    }

    /// Writes the report (JSON, atomically).
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), WorkflowError> {
        write_report(self, path.as_ref())
    }

    /// Reads a report written by [`StiffnessReport::write`].
    pub fn read(path: impl AsRef<Path>) -> Result<Self, WorkflowError> {
        read_report(path.as_ref(), "stiffness report")
    }

    /// The identified Gamma, checked by name against `model`'s parameters
    /// (`path` names the report in messages).
    pub fn gamma_for(&self, model: &ElasticModel, path: &Path) -> Result<Vec<f64>, WorkflowError> {
        let names = model.parameter_names();
        let err = |message: String| WorkflowError::Report {
            path: path.to_path_buf(),
            message,
        };
        if self.parameters.len() != names.len() {
            return Err(err(format!(
                "{} stiffness parameters, the elastic model '{}' has {}",
                self.parameters.len(),
                model.description().name,
                names.len()
            )));
        }
        self.parameters
            .iter()
            .zip(&names)
            .enumerate()
            .map(|(j, (p, expected))| {
                if &p.name != expected {
                    Err(err(format!(
                        "parameter {j} is '{}', the elastic model expects '{expected}'",
                        p.name
                    )))
                } else if !(p.value.is_finite() && p.value > 0.0) {
                    Err(err(format!(
                        "parameter '{}' = {}: must be positive and finite",
                        p.name, p.value
                    )))
                } else {
                    Ok(p.value)
                }
            })
            .collect()
    }
}

/// Whether the compliance components share one partition grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ComplianceStructure {
    /// One grid for every component (default).
    Shared,
    /// Each component its own grid.
    Separate,
}

/// Settings of [`identify_compliance_in_dir`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplianceWorkflowOptions {
    /// Model inputs: actuated coordinates or joint angles of slider-crank
    /// joints (default `theta2`, `theta8`).
    pub inputs: Vec<String>,
    /// Load magnitude (N) whose sets train the model (default 900).
    pub train_load_n: f64,
    /// Fraction of the training configurations held out to choose the
    /// structure (default 0.286: 36 of the paper's 126).
    pub test_fraction: f64,
    /// Seed of the train/test split (default 1).
    pub seed: u64,
    /// Rule budget of each component model (default 12, the paper's 4 x 3).
    pub max_rules: usize,
    /// Shared or separate partition grids (default shared).
    pub structure: ComplianceStructure,
}

impl Default for ComplianceWorkflowOptions {
    fn default() -> Self {
        Self {
            inputs: vec!["theta2".into(), "theta8".into()],
            train_load_n: 900.0,
            test_fraction: 0.286,
            seed: 1,
            max_rules: 12,
            structure: ComplianceStructure::Shared,
        }
    }
}

/// Everything the compliance workflow computes.
#[derive(Debug, Clone)]
pub struct ComplianceOutcome {
    /// The fitted compliance model and its report.
    pub fitted: FittedCompliance,
    /// Names of the training sets.
    pub train_sets: Vec<String>,
    /// Number of training deflections.
    pub training_samples: usize,
    /// Residuals on every set in the x-z plane (Table 5).
    pub table: LoadMetricsTable,
    /// RMS norm of the stated deflection noise in the x-z plane (mm).
    pub noise_floor_mm: f64,
}

/// Identifies the fuzzy compliance model (C_xx, C_xz, C_zx, C_zz) of
/// `robot` from the deflection files of the campaign directory `data`.
///
/// # Errors
/// Unknown inputs, unreadable files, no set with the training load, fit failures.
pub fn identify_compliance_in_dir(
    robot: &Model,
    data: &Path,
    options: &ComplianceWorkflowOptions,
) -> Result<ComplianceOutcome, WorkflowError> {
    check_train_load(options.train_load_n)?;
    let names: Vec<&str> = options.inputs.iter().map(|s| s.trim()).collect();
    let inputs = RobotInputs::resolve(robot, &names)?;
    let sets = read_campaign_dir(data, robot.n_actuated())?;
    let split = split_by_load::<_, WorkflowError>(&sets, options.train_load_n, data, |set| {
        compliance_samples(robot, &inputs, &set.measurements).map_err(|source| {
            WorkflowError::ComplianceFile {
                path: set.path.clone(),
                source,
            }
        })
    })?;
    let components = ComplianceComponent::plane_xz();
    let mut params = ComplianceFitParams {
        shared_structure: options.structure == ComplianceStructure::Shared,
        test_fraction: options.test_fraction,
        seed: options.seed,
        ..ComplianceFitParams::default()
    };
    params.fuzzy.search.max_rules = options.max_rules;
    let fitted = identify_compliance(
        inputs.specs(),
        &components,
        &split.train,
        &params,
        &mut |_| {},
    )?;
    let residuals = fitted.compliance.residual_samples(&split.all)?;
    let table = per_load_metrics(&residuals);
    let noise_floor_mm = noise_floor_rms(&split.all, &fitted.compliance.displacement_axes()) * 1e3;
    Ok(ComplianceOutcome {
        fitted,
        train_sets: split.train_sets,
        training_samples: split.train.len(),
        table,
        noise_floor_mm,
    })
}

/// Modal values of one input of a component model, in table units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalValuesReport {
    /// Input name.
    pub input: String,
    /// Unit of the values (`deg`, `mm`).
    pub unit: String,
    /// Modal values, increasing.
    pub values: Vec<f64>,
}

/// One compliance component of a [`ComplianceReport`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplianceComponentReport {
    /// Component name (`C_xx`, ...).
    pub name: String,
    /// Unit of the conclusions (`mm/kN`, ...).
    pub unit: String,
    /// Modal values of each input.
    pub modal_values: Vec<ModalValuesReport>,
    /// Rule conclusions, in `unit`.
    pub conclusions: Vec<f64>,
}

/// The report of a compliance identification: the file `flexcal identify
/// compliance --report` writes. The same type writes and reads it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplianceReport {
    /// Robot name.
    pub robot: String,
    /// Model inputs.
    pub inputs: Vec<crate::fuzzy_compliance::InputSpec>,
    /// Training load (N).
    pub train_load_n: f64,
    /// Names of the training sets.
    pub train_sets: Vec<String>,
    /// Seed of the train/test split.
    pub seed: u64,
    /// Fraction of the training configurations held out.
    pub test_fraction: f64,
    /// Whether the components share one structure.
    pub shared_structure: bool,
    /// Training configurations.
    pub training_configurations: usize,
    /// Test configurations.
    pub test_configurations: usize,
    /// RMSE per displacement component on the training configurations (mm).
    pub training_rmse_mm: f64,
    /// RMSE per displacement component on the test configurations (mm).
    pub test_rmse_mm: f64,
    /// Why structure growth stopped.
    pub termination: String,
    /// Fits evaluated by the search.
    pub evaluations: usize,
    /// Wall-clock time of the fit (s).
    pub elapsed_s: f64,
    /// Every growth step, the initial structure first.
    pub history: Vec<flexcal_fuzzy::GrowthStep>,
    /// The component models.
    pub components: Vec<ComplianceComponentReport>,
    /// Residuals per load in the x-z plane (Table 5).
    pub per_load: LoadMetricsTable,
    /// RMS norm of the stated deflection noise in the x-z plane (mm).
    pub noise_floor_mm: f64,
}

impl ComplianceReport {
    /// The report of a compliance identification of `robot`.
    pub fn new(
        robot: &str,
        options: &ComplianceWorkflowOptions,
        outcome: &ComplianceOutcome,
    ) -> Self {
        let model = &outcome.fitted.compliance;
        let r = &outcome.fitted.report;
        let components = model
            .components()
            .iter()
            .zip(model.models())
            .map(|(c, m)| ComplianceComponentReport {
                name: c.name(),
                unit: c.table_unit().to_string(),
                modal_values: m
                    .structure()
                    .partitions()
                    .iter()
                    .zip(model.inputs())
                    .map(|(p, spec)| {
                        let (factor, unit) = spec.unit.table_unit();
                        ModalValuesReport {
                            input: spec.name.clone(),
                            unit: unit.to_string(),
                            values: p.modal_values().iter().map(|v| v * factor).collect(),
                        }
                    })
                    .collect(),
                conclusions: m.conclusions().iter().map(|b| b * 1e6).collect(),
            })
            .collect();
        Self {
            robot: robot.to_string(),
            inputs: model.inputs().to_vec(),
            train_load_n: options.train_load_n,
            train_sets: outcome.train_sets.clone(),
            seed: options.seed,
            test_fraction: options.test_fraction,
            shared_structure: options.structure == ComplianceStructure::Shared,
            training_configurations: r.training_configurations,
            test_configurations: r.test_configurations,
            training_rmse_mm: r.training_mm.rmse,
            test_rmse_mm: r.test_mm.rmse,
            termination: format!("{:?}", r.search.termination),
            evaluations: r.search.evaluations,
            elapsed_s: r.elapsed_s,
            history: r.search.history.clone(),
            components,
            per_load: outcome.table.clone(),
            noise_floor_mm: outcome.noise_floor_mm,
        }
    }

    /// Writes the report (pretty JSON, atomically).
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), WorkflowError> {
        write_report(self, path.as_ref())
    }

    /// Reads a report written by [`ComplianceReport::write`].
    pub fn read(path: impl AsRef<Path>) -> Result<Self, WorkflowError> {
        read_report(path.as_ref(), "compliance report")
    }
}
