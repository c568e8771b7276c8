//! Identification of the fuzzy compliance components from measured
//! deflections (section 2.2.2 steps i-iii, equations (38) and (70)).

use std::collections::BTreeMap;
use std::time::Instant;

use flexcal_fuzzy::{
    ConclusionReport, ErrorStats, FuzzyError, FuzzyModel, FuzzyParams, FuzzyStructure,
    LinearCombinationSet, SearchProgress, StructureScore, StructureSearchParams,
    StructureSearchReport, fit_joint_conclusions, joint_error_stats, search_structure,
};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::components::{Axis, ComplianceComponent, FIT_SCALE, InputSpec};
use super::error::{FuzzyComplianceError, Result};
use super::model::{FuzzyCompliance, check_inputs_and_components};
use super::samples::ComplianceSample;

/// Settings of [`identify_compliance`].
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `fuzzy.search.max_rules` | 12 | rule budget per component model (the paper's 4 x 3) |
/// | `fuzzy.search.patience` | 2 | growth steps without test improvement before stopping |
/// | `fuzzy.search.placement` | 200 evaluations, seed 0 | Solis-Wets placement of modal values |
/// | `fuzzy.ridge` | 1e-6 | relative pull of conclusions towards the best constant compliances |
/// | `shared_structure` | true | one partition grid for all components (paper), or one each |
/// | `test_fraction` | 0.286 | fraction of configurations held out to choose the structure (36 of 126) |
/// | `seed` | 1 | seed of the random train/test split |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplianceFitParams {
    /// Fuzzy learning settings (structure search, ridge). Conclusions are
    /// always solved by least squares (the joint fit).
    pub fuzzy: FuzzyParams,
    /// Whether all components share one partition grid (default true).
    pub shared_structure: bool,
    /// Fraction of the configurations put in the test set (default 0.286;
    /// range (0, 1)).
    pub test_fraction: f64,
    /// Seed of the train/test split (default 1).
    pub seed: u64,
}

impl Default for ComplianceFitParams {
    fn default() -> Self {
        Self {
            fuzzy: FuzzyParams {
                search: StructureSearchParams {
                    max_rules: 12,
                    patience: 2,
                    ..StructureSearchParams::default()
                },
                ..FuzzyParams::default()
            },
            shared_structure: true,
            test_fraction: 0.286,
            seed: 1,
        }
    }
}

/// How a compliance model was identified.
#[derive(Debug, Clone, PartialEq)]
pub struct ComplianceFitReport {
    /// The structure search (history, termination, evaluations). With a
    /// shared structure it holds one structure, used by every component.
    pub search: StructureSearchReport,
    /// The final joint least-squares solve of the conclusions.
    pub conclusions: ConclusionReport,
    /// Errors of the measured displacement components on the training set
    /// (mm).
    pub training_mm: ErrorStats,
    /// Errors of the measured displacement components on the test set (mm).
    pub test_mm: ErrorStats,
    /// Number of training configurations.
    pub training_configurations: usize,
    /// Number of test configurations.
    pub test_configurations: usize,
    /// Indices (into the samples given) of the training samples.
    pub training_samples: Vec<usize>,
    /// Indices (into the samples given) of the test samples.
    pub test_samples: Vec<usize>,
    /// Wall-clock time of the identification (s).
    pub elapsed_s: f64,
}

/// A fitted fuzzy compliance model and its report: the fitted type of
/// [`identify_compliance`].
#[derive(Debug, Clone, PartialEq)]
pub struct FittedCompliance {
    /// The model.
    pub compliance: FuzzyCompliance,
    /// How it was obtained.
    pub report: ComplianceFitReport,
}

/// Identifies the fuzzy compliance components from measured deflections
/// (section 2.2.2 steps i-iii, equations (38) and (70)).
///
/// The samples are grouped into configurations (equal input values) and
/// split at random (seeded) into training and test configurations; every
/// measured translation along a modelled displacement axis gives one
/// least-squares row, linear in the conclusions of all component models.
/// The structure grows from 2 membership functions per input within the
/// rule budget, each candidate placed by Solis-Wets on the training error
/// and judged by the test error; conclusions are solved jointly.
///
/// # Errors
/// Invalid settings, no inputs or components, rotational components, a
/// sample with a wrong or non-finite value, a constant input, a component
/// whose wrench axis no training sample loads, fewer training
/// configurations than rules, a singular conclusion system.
pub fn identify_compliance(
    inputs: &[InputSpec],
    components: &[ComplianceComponent],
    samples: &[ComplianceSample],
    params: &ComplianceFitParams,
    progress: &mut dyn FnMut(&SearchProgress),
) -> Result<FittedCompliance> {
    let started = Instant::now();
    params.fuzzy.validate()?;
    if !(params.test_fraction > 0.0 && params.test_fraction < 1.0) {
        return Err(FuzzyComplianceError::InvalidParameter {
            name: "test_fraction",
            value: params.test_fraction.to_string(),
            reason: "must be in (0, 1)",
        });
    }
    check_inputs_and_components(inputs, components)?;
    if let Some(c) = components.iter().find(|c| !c.displacement.is_linear()) {
        return Err(FuzzyComplianceError::RotationNotMeasured {
            component: c.name(),
        });
    }
    check_samples(inputs, samples)?;
    let configurations = configurations(samples);
    if configurations.len() < 2 {
        return Err(FuzzyComplianceError::TooFewSamples {
            component: components[0].name(),
            configurations: configurations.len(),
            rules: 1 << inputs.len(),
        });
    }
    let split = Split::new(&configurations, params);
    let minimum_rules = 1usize << inputs.len();
    let rule_cap = rule_budget(
        components,
        samples,
        (&configurations, &split),
        minimum_rules,
    )?
    .min(params.fuzzy.search.max_rules);
    let names: Vec<String> = inputs.iter().map(|i| i.name.clone()).collect();
    let train = combination_set(&names, components, samples, &split.training_samples)?;
    let test = combination_set(&names, components, samples, &split.test_samples)?;
    let domains = training_domains(inputs, samples, &split.training_samples)?;
    let initial = FuzzyStructure::initial(names.clone(), &domains)?;
    let mut search = params.fuzzy.search.clone();
    search.max_rules = rule_cap.max(minimum_rules);
    let ridge = params.fuzzy.ridge;
    let model_count = components.len();
    let expand = |s: &[FuzzyStructure]| -> Vec<FuzzyStructure> {
        if s.len() == 1 {
            vec![s[0].clone(); model_count]
        } else {
            s.to_vec()
        }
    };
    let evaluate = |s: &[FuzzyStructure]| -> std::result::Result<StructureScore, FuzzyError> {
        let structures = expand(s);
        let (conclusions, _) = fit_joint_conclusions(&structures, &train, ridge)?;
        let models = build_models(&structures, components, conclusions, 1.0)?;
        Ok(StructureScore {
            training_error: joint_error_stats(&models, &train)?.rmse,
            test_error: joint_error_stats(&models, &test)?.rmse,
        })
    };
    let start = if params.shared_structure {
        vec![initial]
    } else {
        vec![initial; model_count]
    };
    let report = search_structure(start, &search, evaluate, progress)?;
    let structures = expand(&report.structures);
    let (conclusions, conclusion_report) = fit_joint_conclusions(&structures, &train, ridge)?;
    let fitted = build_models(&structures, components, conclusions, 1.0)?;
    let training_mm = joint_error_stats(&fitted, &train)?;
    let test_mm = joint_error_stats(&fitted, &test)?;
    let si_models = fitted
        .iter()
        .map(|m| {
            FuzzyModel::new(
                m.structure().clone(),
                m.output_name().to_string(),
                m.conclusions().iter().map(|b| b / FIT_SCALE).collect(),
            )
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let compliance = FuzzyCompliance::new(inputs.to_vec(), components.to_vec(), si_models)?;
    Ok(FittedCompliance {
        compliance,
        report: ComplianceFitReport {
            search: report,
            conclusions: conclusion_report,
            training_mm,
            test_mm,
            training_configurations: split.train_configurations.len(),
            test_configurations: split.test_configurations.len(),
            training_samples: split.training_samples,
            test_samples: split.test_samples,
            elapsed_s: started.elapsed().as_secs_f64(),
        },
    })
}

/// The configurations of `samples`: the samples with identical inputs,
/// in order of appearance.
fn configurations(samples: &[ComplianceSample]) -> Vec<Vec<usize>> {
    let mut groups: BTreeMap<Vec<u64>, usize> = BTreeMap::new();
    let mut configurations: Vec<Vec<usize>> = Vec::new();
    for (k, s) in samples.iter().enumerate() {
        let key: Vec<u64> = s.inputs.iter().map(|v| v.to_bits()).collect();
        let next = configurations.len();
        let c = *groups.entry(key).or_insert(next);
        if c == next {
            configurations.push(Vec::new());
        }
        configurations[c].push(k);
    }
    configurations
}

/// The seeded split of the configurations into training and test ones
/// (at least one of each), and their samples in ascending order.
struct Split {
    train_configurations: Vec<usize>,
    test_configurations: Vec<usize>,
    training_samples: Vec<usize>,
    test_samples: Vec<usize>,
}

impl Split {
    fn new(configurations: &[Vec<usize>], params: &ComplianceFitParams) -> Self {
        let n_test = ((params.test_fraction * configurations.len() as f64).round() as usize)
            .clamp(1, configurations.len() - 1);
        let mut order: Vec<usize> = (0..configurations.len()).collect();
        order.shuffle(&mut ChaCha8Rng::seed_from_u64(params.seed));
        let (test, train) = order.split_at(n_test);
        let collect = |configs: &[usize]| {
            let mut indices: Vec<usize> = configs
                .iter()
                .flat_map(|&c| configurations[c].iter().copied())
                .collect();
            indices.sort_unstable();
            indices
        };
        Self {
            training_samples: collect(train),
            test_samples: collect(test),
            train_configurations: train.to_vec(),
            test_configurations: test.to_vec(),
        }
    }
}

/// The largest rule count the training data can determine: every
/// component must be loaded in at least `minimum_rules` training
/// configurations (the simplest model's rules), and no model may have
/// more rules than the configurations that load its component.
fn rule_budget(
    components: &[ComplianceComponent],
    samples: &[ComplianceSample],
    (configurations, split): (&[Vec<usize>], &Split),
    minimum_rules: usize,
) -> Result<usize> {
    let mut cap = usize::MAX;
    for c in components {
        let loaded = split
            .train_configurations
            .iter()
            .filter(|&&g| {
                configurations[g]
                    .iter()
                    .any(|&k| samples[k].wrench[c.wrench.index()] != 0.0)
            })
            .count();
        if loaded == 0 {
            return Err(FuzzyComplianceError::ComponentNotExcited {
                component: c.name(),
                wrench: c.wrench.wrench_name(),
            });
        }
        if loaded < minimum_rules {
            return Err(FuzzyComplianceError::TooFewSamples {
                component: c.name(),
                configurations: loaded,
                rules: minimum_rules,
            });
        }
        cap = cap.min(loaded);
    }
    Ok(cap)
}

/// The range of each input over the training samples; an input that does
/// not vary is an error naming it.
fn training_domains(
    inputs: &[InputSpec],
    samples: &[ComplianceSample],
    training_samples: &[usize],
) -> Result<Vec<(f64, f64)>> {
    let mut domains = vec![(f64::INFINITY, f64::NEG_INFINITY); inputs.len()];
    for &k in training_samples {
        for (d, &v) in domains.iter_mut().zip(&samples[k].inputs) {
            d.0 = d.0.min(v);
            d.1 = d.1.max(v);
        }
    }
    for (spec, &(lower, upper)) in inputs.iter().zip(&domains) {
        if lower >= upper {
            return Err(FuzzyComplianceError::ConstantInput {
                input: spec.name.clone(),
                value: lower,
            });
        }
    }
    Ok(domains)
}

fn check_samples(inputs: &[InputSpec], samples: &[ComplianceSample]) -> Result<()> {
    for (k, s) in samples.iter().enumerate() {
        if s.inputs.len() != inputs.len() {
            return Err(FuzzyComplianceError::InputCount {
                sample: k,
                pose_id: s.pose_id,
                expected: inputs.len(),
                found: s.inputs.len(),
            });
        }
        let non_finite = |field: String, value: f64| FuzzyComplianceError::NonFinite {
            sample: k,
            pose_id: s.pose_id,
            field,
            value,
        };
        for (spec, &v) in inputs.iter().zip(&s.inputs) {
            if !v.is_finite() {
                return Err(non_finite(format!("input '{}'", spec.name), v));
            }
        }
        for a in Axis::ALL {
            let v = s.wrench[a.index()];
            if !v.is_finite() {
                return Err(non_finite(format!("wrench {}", a.wrench_name()), v));
            }
        }
        for a in &Axis::ALL[..3] {
            let v = s.deflection[a.index()];
            if !v.is_finite() {
                return Err(non_finite(format!("deflection d{}", a.name()), v));
            }
        }
    }
    Ok(())
}

/// Least-squares rows of the samples at `indices`: one per sample and
/// modelled displacement axis, `d_axis = sum_w C_axis,w W_w`, in mm and kN.
fn combination_set(
    names: &[String],
    components: &[ComplianceComponent],
    samples: &[ComplianceSample],
    indices: &[usize],
) -> Result<LinearCombinationSet> {
    let mut axes: Vec<Axis> = components.iter().map(|c| c.displacement).collect();
    axes.sort();
    axes.dedup();
    let rows = indices.len() * axes.len();
    let mut input_columns = vec![Vec::with_capacity(rows); names.len()];
    let mut coefficient_columns = vec![Vec::with_capacity(rows); components.len()];
    let mut targets = Vec::with_capacity(rows);
    for &k in indices {
        let s = &samples[k];
        for &axis in &axes {
            for (column, &v) in input_columns.iter_mut().zip(&s.inputs) {
                column.push(v);
            }
            for (column, c) in coefficient_columns.iter_mut().zip(components) {
                // kN (or kN.m) so that conclusions come out in mm/kN.
                column.push(if c.displacement == axis {
                    s.wrench[c.wrench.index()] * 1e-3
                } else {
                    0.0
                });
            }
            targets.push(s.deflection[axis.index()] * 1e3);
        }
    }
    Ok(LinearCombinationSet::new(
        names.to_vec(),
        &input_columns,
        &coefficient_columns,
        targets,
    )?)
}

fn build_models(
    structures: &[FuzzyStructure],
    components: &[ComplianceComponent],
    conclusions: Vec<Vec<f64>>,
    scale: f64,
) -> std::result::Result<Vec<FuzzyModel>, FuzzyError> {
    structures
        .iter()
        .zip(components)
        .zip(conclusions)
        .map(|((s, c), b)| {
            FuzzyModel::new(
                s.clone(),
                c.name(),
                b.into_iter().map(|v| v * scale).collect(),
            )
        })
        .collect()
}
