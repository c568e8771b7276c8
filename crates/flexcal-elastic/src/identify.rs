//! Stiffness identification (section 3.3.1): Gamma in log space, a global
//! search by differential evolution (manufacturers give no starting values,
//! which is why the paper used a genetic algorithm), then Levenberg-Marquardt
//! on criterion (67), with the identifiability of Gamma analysed by name.

use std::cell::RefCell;

use faer::MatMut;
use flexcal_fem::{Factorization, SolverOptions as FemOptions, Structure, assemble_and_factor};
use flexcal_optim::{
    ColumnScaling, Diagnosis, DifferentialEvolution, IdentifiabilityOptions, IdentifiabilityReport,
    Jacobian, LevenbergMarquardt, ProblemError, ProblemSetup, Residuals, SolveReport,
    analyze_identifiability,
};
use nalgebra::{DMatrix, Vector3};
use serde::{Deserialize, Serialize};

use crate::campaign::DeflectionMeasurement;
use crate::error::{ElasticError, Result};
use crate::metrics::ResidualSample;
use crate::model::{ElasticModel, apply_stiffness, configure_structure, sensitivity_in};

/// The residuals `predicted - measured` TCP position deflections (m) of a
/// set of measurements, as a function of log Gamma, with their exact
/// Jacobian. The structure of each distinct configuration is placed once.
pub struct StiffnessProblem<'a> {
    model: &'a ElasticModel,
    measurements: &'a [DeflectionMeasurement],
    /// One placed structure per distinct configuration, with the indices of
    /// its measurements.
    configurations: RefCell<Vec<(Structure, Vec<usize>)>>,
    factorization: RefCell<Factorization>,
}

impl std::fmt::Debug for StiffnessProblem<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StiffnessProblem")
            .field("measurements", &self.measurements.len())
            .field("configurations", &self.configurations.borrow().len())
            .finish()
    }
}

impl<'a> StiffnessProblem<'a> {
    /// Places the structure in every configuration of `measurements` (robot
    /// parameters `xi`).
    ///
    /// # Errors
    /// [`ElasticError::NoData`] without measurements; kinematic failures;
    /// a wrong number of actuated coordinates.
    pub fn new(
        model: &'a ElasticModel,
        measurements: &'a [DeflectionMeasurement],
        xi: &[f64],
    ) -> Result<Self> {
        if measurements.is_empty() {
            return Err(ElasticError::NoData {
                what: "no deflection measurement to identify stiffness from".into(),
            });
        }
        let mut kinematics = flexcal_kinematics::Data::new(model.robot());
        let mut configurations: Vec<(Structure, Vec<usize>)> = Vec::new();
        let mut qs: Vec<&[f64]> = Vec::new();
        for (k, m) in measurements.iter().enumerate() {
            if let Some(c) = qs.iter().position(|q| *q == m.q.as_slice()) {
                configurations[c].1.push(k);
                continue;
            }
            let mut structure = model.template().clone();
            configure_structure(model, &mut kinematics, &mut structure, &m.q, xi)?;
            qs.push(&m.q);
            configurations.push((structure, vec![k]));
        }
        let factorization = Factorization::new(model.template(), &FemOptions::default())
            .map_err(|e| ElasticError::fem("stiffness problem", e))?;
        Ok(Self {
            model,
            measurements,
            configurations: RefCell::new(configurations),
            factorization: RefCell::new(factorization),
        })
    }

    /// Number of distinct configurations.
    pub fn n_configurations(&self) -> usize {
        self.configurations.borrow().len()
    }

    /// Predicted TCP position deflections (m) for Gamma, and optionally
    /// their derivatives with respect to log Gamma (3 rows per measurement).
    fn evaluate(
        &self,
        gamma: &[f64],
        mut residuals: Option<&mut [f64]>,
        mut jacobian: Option<MatMut<'_, f64>>,
        predictions: Option<&mut Vec<Vector3<f64>>>,
    ) -> Result<()> {
        let model = self.model;
        let tcp = model.tcp_node();
        let mut configurations = self.configurations.borrow_mut();
        let mut factorization = self.factorization.borrow_mut();
        let mut predicted = vec![Vector3::zeros(); self.measurements.len()];
        for (structure, members) in configurations.iter_mut() {
            apply_stiffness(model, structure, gamma)?;
            assemble_and_factor(structure, &mut factorization).map_err(|e| {
                ElasticError::fem(
                    format!("configuration q = {:?}", self.measurements[members[0]].q),
                    e,
                )
            })?;
            let mut loads = vec![0.0; structure.dof_count()];
            for &k in members.iter() {
                let m = &self.measurements[k];
                loads.iter_mut().for_each(|v| *v = 0.0);
                for c in 0..6 {
                    loads[6 * tcp + c] = m.wrench[c];
                }
                let u = factorization
                    .solve(&loads)
                    .map_err(|e| ElasticError::fem("solve", e))?;
                let p = Vector3::new(u[6 * tcp], u[6 * tcp + 1], u[6 * tcp + 2]);
                predicted[k] = p;
                if let Some(r) = residuals.as_deref_mut() {
                    for c in 0..3 {
                        r[3 * k + c] = p[c] - m.deflection[c];
                    }
                }
                if let Some(jac) = jacobian.as_mut() {
                    for (j, g) in gamma.iter().enumerate() {
                        let du = sensitivity_in(model, structure, &mut factorization, j, &u)
                            .map_err(|e| {
                                ElasticError::fem(
                                    format!("sensitivity to '{}'", model.parameters()[j].name),
                                    e,
                                )
                            })?;
                        for c in 0..3 {
                            jac[(3 * k + c, j)] = du[6 * tcp + c] * g;
                        }
                    }
                }
            }
        }
        if let Some(out) = predictions {
            *out = predicted;
        }
        Ok(())
    }

    /// Predicted TCP position deflections (m) for Gamma, one per measurement.
    ///
    /// # Errors
    /// An invalid Gamma, a singular structure.
    pub fn predict(&self, gamma: &[f64]) -> Result<Vec<Vector3<f64>>> {
        let mut out = Vec::new();
        self.evaluate(gamma, None, None, Some(&mut out))?;
        Ok(out)
    }

    /// Jacobian (3 rows per measurement, m per unit of log gamma) at Gamma.
    ///
    /// # Errors
    /// An invalid Gamma, a singular structure.
    pub fn log_jacobian(&self, gamma: &[f64]) -> Result<DMatrix<f64>> {
        let mut jac = DMatrix::zeros(3 * self.measurements.len(), gamma.len());
        let (rows, cols) = (jac.nrows(), jac.ncols());
        let view = MatMut::from_column_major_slice_mut(jac.as_mut_slice(), rows, cols);
        self.evaluate(gamma, None, Some(view), None)?;
        Ok(jac)
    }

    /// Row weights `1 / sigma` of the residuals (3 per measurement), or
    /// `None` when some standard deviation is missing (zero).
    pub fn row_weights(&self) -> Option<Vec<f64>> {
        let w: Vec<f64> = self
            .measurements
            .iter()
            .flat_map(|m| m.sigma.iter().map(|s| 1.0 / s).collect::<Vec<_>>())
            .collect();
        w.iter().all(|v| v.is_finite()).then_some(w)
    }
}

impl Residuals for StiffnessProblem<'_> {
    fn n_residuals(&self) -> usize {
        3 * self.measurements.len()
    }
    fn n_params(&self) -> usize {
        self.model.n_parameters()
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> std::result::Result<(), ProblemError> {
        let gamma: Vec<f64> = x.iter().map(|v| v.exp()).collect();
        self.evaluate(&gamma, Some(out), None, None)?;
        Ok(())
    }
    fn parameter_name(&self, j: usize) -> String {
        format!("ln {}", self.model.parameters()[j].name)
    }
}

impl Jacobian for StiffnessProblem<'_> {
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> std::result::Result<(), ProblemError> {
        let gamma: Vec<f64> = x.iter().map(|v| v.exp()).collect();
        self.evaluate(&gamma, None, Some(out), None)?;
        Ok(())
    }
}

/// Settings of [`identify_stiffness`].
#[derive(Debug, Clone, PartialEq)]
pub struct StiffnessIdentificationOptions {
    /// Seed of the global search (default 1).
    pub seed: u64,
    /// Objective evaluations of the global search (default 2500; 0 skips
    /// it and starts from the nominal Gamma).
    pub global_search_evaluations: usize,
    /// Search bounds per parameter (SI); `None` (default): 1e4-1e9 N.m/rad
    /// for rotational and 1e6-1e14 N/m for translational stiffness.
    pub bounds: Option<Vec<(f64, f64)>>,
    /// Relative tolerance deciding that log-stiffness columns are collinear
    /// (default 1e-5): the structural (exact) dependencies such as springs in series.
    pub structural_tolerance: f64,
    /// A parameter whose factor-e change moves the weighted fit by less than
    /// this many standard deviations in total is "not determined by the data"
    /// (default 1.0).
    pub practical_threshold: f64,
    /// Levenberg-Marquardt iterations (default 100).
    pub max_iterations: usize,
}

impl Default for StiffnessIdentificationOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            global_search_evaluations: 2500,
            bounds: None,
            structural_tolerance: 1e-5,
            practical_threshold: 1.0,
            max_iterations: 100,
        }
    }
}

/// How the members of a non-separable group combine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GroupKind {
    /// Springs in series: only `K_req = (sum 1/k_i)^-1` is identifiable ((68)-(69)).
    Series,
    /// Springs in parallel: only `K_req = sum k_i` is identifiable.
    Parallel,
    /// Another linear dependency of the log-stiffness columns.
    Other,
}

/// Stiffness parameters that the data cannot separate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StiffnessGroup {
    /// Member names.
    pub members: Vec<String>,
    /// How they combine.
    pub kind: GroupKind,
    /// The identifiable equivalent stiffness at the identified Gamma (SI),
    /// for series and parallel groups.
    pub equivalent: Option<f64>,
    /// Unit of the members.
    pub unit: String,
    /// The member kept free during the fit (the others are held).
    pub representative: String,
    /// Whether the equivalent stiffness is determined by the data (its
    /// factor-e change moves the fit by at least the practical threshold).
    pub determined: bool,
}

/// Identifiability of Gamma.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StiffnessIdentifiability {
    /// Parameter names.
    pub names: Vec<String>,
    /// Structural rank of the log-stiffness Jacobian (columns normalised).
    pub structural_rank: usize,
    /// Singular values of the column-normalised Jacobian (structural).
    pub structural_singular_values: Vec<f64>,
    /// Singular values of the noise-weighted Jacobian with respect to log
    /// Gamma at the solution (standard deviations per unit of log stiffness).
    pub weighted_singular_values: Vec<f64>,
    /// Per parameter: weighted column norm at the solution (standard
    /// deviations per unit of log stiffness).
    pub sensitivity: Vec<f64>,
    /// Non-separable groups (springs in series and the like).
    pub groups: Vec<StiffnessGroup>,
    /// Parameters identified on their own (not in a group, determined by the data).
    pub identifiable: Vec<String>,
    /// Parameters (outside groups) whose effect is below the practical threshold.
    pub undetermined: Vec<String>,
}

impl StiffnessIdentifiability {
    /// Human-readable lines: which parameters are separately identifiable,
    /// which are not, and what is.
    pub fn describe(&self) -> Vec<String> {
        let mut lines = Vec::new();
        lines.push(format!(
            "structural rank {} of {} stiffness parameters",
            self.structural_rank,
            self.names.len()
        ));
        if !self.identifiable.is_empty() {
            lines.push(format!(
                "identifiable on their own: {}",
                self.identifiable.join(", ")
            ));
        }
        for g in &self.groups {
            let what = match (g.kind, g.equivalent) {
                (GroupKind::Series, Some(k)) => format!(
                    "springs in series: only K_req = 1/({}) = {:.4e} {} is identifiable (eq. (68)-(69))",
                    g.members
                        .iter()
                        .map(|m| format!("1/{m}"))
                        .collect::<Vec<_>>()
                        .join(" + "),
                    k,
                    g.unit
                ),
                (GroupKind::Parallel, Some(k)) => format!(
                    "springs in parallel: only K_req = {} = {:.4e} {} is identifiable",
                    g.members.join(" + "),
                    k,
                    g.unit
                ),
                _ => "linearly dependent effects: only a combination is identifiable".to_string(),
            };
            lines.push(format!(
                "not separately identifiable: {} -- {}{}",
                g.members.join(", "),
                what,
                if g.determined {
                    String::new()
                } else {
                    "; even that combination is below the measurement noise (the data only say it is stiff)".to_string()
                }
            ));
        }
        if !self.undetermined.is_empty() {
            lines.push(format!(
                "not determined by these data (effect below the noise): {}",
                self.undetermined.join(", ")
            ));
        }
        lines
    }
}

/// The identified stiffness: the fitted type of [`identify_stiffness`].
#[derive(Debug, Clone)]
pub struct IdentifiedStiffness {
    /// Parameter names.
    pub names: Vec<String>,
    /// Units.
    pub units: Vec<String>,
    /// Identified Gamma (SI). Members of a non-separable group other than its
    /// representative are held at a search bound; only the group's
    /// equivalent stiffness is meaningful.
    pub gamma: Vec<f64>,
    /// Gamma after the global search (SI).
    pub gamma_global_search: Vec<f64>,
    /// Best value of the global search objective (mean squared weighted residual).
    pub global_search_value: f64,
    /// Objective evaluations of the global search.
    pub global_search_evaluations: usize,
    /// The Levenberg-Marquardt report (parameters are log Gamma).
    pub solve: SolveReport,
    /// Criterion (67) `C = 1/n_m sum |e_k|^2` at the solution (mm^2).
    pub criterion_mm2: f64,
    /// Identifiability of Gamma.
    pub identifiability: StiffnessIdentifiability,
}

fn default_bounds(model: &ElasticModel) -> Vec<(f64, f64)> {
    model
        .parameters()
        .iter()
        .map(|p| {
            if p.unit == "N.m/rad" {
                (1e4, 1e9)
            } else {
                (1e6, 1e14)
            }
        })
        .collect()
}

/// The bounds of Gamma (N/m or N.m/rad): the options' or
/// [`default_bounds`], one pair per parameter, `0 < lower < upper < inf`.
fn checked_bounds(
    model: &ElasticModel,
    options: &StiffnessIdentificationOptions,
) -> Result<Vec<(f64, f64)>> {
    let n = model.n_parameters();
    if n == 0 {
        return Err(ElasticError::invalid(
            format!("elastic description '{}'", model.description().name),
            "identify",
            "no stiffness parameter is marked for identification",
        ));
    }
    let bounds = options
        .bounds
        .clone()
        .unwrap_or_else(|| default_bounds(model));
    if bounds.len() != n {
        return Err(ElasticError::StiffnessLength {
            expected: n,
            found: bounds.len(),
            names: model.parameter_names().join(", "),
        });
    }
    for (p, &(lo, hi)) in model.parameters().iter().zip(&bounds) {
        if !(lo > 0.0 && hi > lo && hi.is_finite()) {
            return Err(ElasticError::invalid(
                format!("parameter '{}'", p.name),
                "bounds",
                format!("need 0 < lower < upper < inf, got [{lo}, {hi}]"),
            ));
        }
    }
    Ok(bounds)
}

/// What the global search found: the start in log space, the weighted
/// mean squared residual there and the evaluations it took (NaN and 0
/// without a search: the nominal values).
struct GlobalStart {
    log_gamma: Vec<f64>,
    value: f64,
    evaluations: usize,
}

/// Differential evolution in log space within `(lower, upper)` (logs of
/// the bounds), from the nominal Gamma when the options ask for no search.
fn global_search(
    problem: &StiffnessProblem,
    (lower, upper): (&[f64], &[f64]),
    weight: &dyn Fn(usize) -> f64,
    options: &StiffnessIdentificationOptions,
) -> Result<GlobalStart> {
    let start = problem
        .model
        .nominal_gamma()
        .iter()
        .map(|v| v.ln())
        .collect();
    if options.global_search_evaluations == 0 {
        return Ok(GlobalStart {
            log_gamma: start,
            value: f64::NAN,
            evaluations: 0,
        });
    }
    let m = problem.n_residuals();
    let mut residuals = vec![0.0; m];
    let objective = |x: &[f64]| -> f64 {
        match problem.residuals(x, &mut residuals) {
            Ok(()) => {
                residuals
                    .iter()
                    .enumerate()
                    .map(|(i, r)| (r * weight(i)).powi(2))
                    .sum::<f64>()
                    / m as f64
            }
            Err(_) => f64::INFINITY,
        }
    };
    let search = DifferentialEvolution {
        max_evaluations: options.global_search_evaluations,
        seed: options.seed,
        ..DifferentialEvolution::default()
    }
    .check()?;
    let report = search.minimize(objective, lower, upper)?;
    Ok(GlobalStart {
        log_gamma: report.best_x,
        value: report.best_value,
        evaluations: report.evaluations,
    })
}

/// The structural analysis, at a reference point where every parameter
/// is soft enough (ten times its lower bound) for its sensitivity to be
/// computed accurately: the report, the collinear groups, and each
/// group's kind (series `J_i ~ 1/k_i` or parallel `J_i ~ k_i`, from the
/// ratios of the log-stiffness columns there).
fn structural_groups(
    problem: &StiffnessProblem,
    bounds: &[(f64, f64)],
    names: &[String],
    options: &StiffnessIdentificationOptions,
) -> Result<(IdentifiabilityReport, Vec<Vec<usize>>, Vec<GroupKind>)> {
    let reference: Vec<f64> = bounds.iter().map(|b| b.0 * 10.0).collect();
    let jac_ref = problem.log_jacobian(&reference)?;
    let structural = analyze_identifiability(
        faer::MatRef::from_column_major_slice(jac_ref.as_slice(), jac_ref.nrows(), jac_ref.ncols()),
        names,
        &IdentifiabilityOptions {
            rank_tolerance: options.structural_tolerance,
            column_scaling: ColumnScaling::ColumnNorm,
            ..IdentifiabilityOptions::default()
        },
    )?;
    let groups = collinear_groups(&structural.diagnoses, names.len());
    let kinds = groups
        .iter()
        .map(|g| classify_group(&jac_ref, &reference, g))
        .collect();
    Ok((structural, groups, kinds))
}

/// Holds all but one member of each collinear group (in `fixed`, moving
/// `start`, log space): a series group keeps its softest member free and
/// the others at their upper bound (rigid), preserving the equivalent
/// stiffness found by the search; a parallel group the stiffest, the
/// others at the lower bound. Returns each group's free member.
fn hold_groups(
    (groups, kinds): (&[Vec<usize>], &[GroupKind]),
    bounds: &[(f64, f64)],
    start: &mut [f64],
    fixed: &mut [bool],
) -> Vec<usize> {
    let mut representatives = Vec::new();
    for (g, kind) in groups.iter().zip(kinds) {
        let values: Vec<f64> = g.iter().map(|&j| start[j].exp()).collect();
        let rep = match kind {
            GroupKind::Series | GroupKind::Other => g[argmin(&values)],
            GroupKind::Parallel => g[argmax(&values)],
        };
        representatives.push(rep);
        let others = g.iter().copied().filter(|&j| j != rep);
        match kind {
            GroupKind::Series => {
                let k_req = 1.0 / values.iter().map(|v| 1.0 / v).sum::<f64>();
                let mut compliance = 0.0;
                for j in others {
                    start[j] = bounds[j].1.ln();
                    compliance += 1.0 / bounds[j].1;
                    fixed[j] = true;
                }
                let inv = 1.0 / k_req - compliance;
                let upper = bounds[rep].1.ln();
                start[rep] = if inv > 0.0 {
                    (1.0 / inv).ln().min(upper)
                } else {
                    upper
                };
            }
            GroupKind::Parallel => {
                let k_sum: f64 = values.iter().sum();
                let mut stiffness = 0.0;
                for j in others {
                    start[j] = bounds[j].0.ln();
                    stiffness += bounds[j].0;
                    fixed[j] = true;
                }
                start[rep] = (k_sum - stiffness).max(bounds[rep].0).ln();
            }
            GroupKind::Other => {
                for j in others {
                    fixed[j] = true;
                }
            }
        }
    }
    representatives
}

/// The identifiability report at the solution `gamma`: sensitivities,
/// weighted singular values, the groups with their equivalent stiffness,
/// and the parameters determined or not.
fn identifiability_at(
    problem: &StiffnessProblem,
    gamma: &[f64],
    weight: &dyn Fn(usize) -> f64,
    (structural, groups, kinds, representatives): (
        &IdentifiabilityReport,
        &[Vec<usize>],
        &[GroupKind],
        &[usize],
    ),
    options: &StiffnessIdentificationOptions,
) -> Result<StiffnessIdentifiability> {
    let model = problem.model;
    let n = gamma.len();
    let names = model.parameter_names();
    let jac = problem.log_jacobian(gamma)?;
    let sensitivity = weighted_column_norms(&jac, weight);
    let weighted = DMatrix::from_fn(jac.nrows(), jac.ncols(), |i, j| jac[(i, j)] * weight(i));
    let mut weighted_singular_values = weighted
        .singular_values()
        .iter()
        .copied()
        .collect::<Vec<_>>();
    weighted_singular_values.sort_by(|a, b| b.total_cmp(a));
    let in_group: Vec<bool> = (0..n)
        .map(|j| groups.iter().any(|g| g.contains(&j)))
        .collect();
    let mut group_reports = Vec::new();
    for ((g, kind), &rep) in groups.iter().zip(kinds).zip(representatives) {
        let equivalent = match kind {
            GroupKind::Series => Some(1.0 / g.iter().map(|&j| 1.0 / gamma[j]).sum::<f64>()),
            GroupKind::Parallel => Some(g.iter().map(|&j| gamma[j]).sum()),
            GroupKind::Other => None,
        };
        group_reports.push(StiffnessGroup {
            members: g.iter().map(|&j| names[j].clone()).collect(),
            kind: *kind,
            equivalent,
            unit: model.parameters()[g[0]].unit.to_string(),
            representative: names[rep].clone(),
            determined: sensitivity[rep] >= options.practical_threshold,
        });
    }
    let free = |determined: bool| -> Vec<String> {
        (0..n)
            .filter(|&j| {
                !in_group[j] && (sensitivity[j] >= options.practical_threshold) == determined
            })
            .map(|j| names[j].clone())
            .collect()
    };
    let (identifiable, undetermined) = (free(true), free(false));
    Ok(StiffnessIdentifiability {
        names,
        structural_rank: structural.rank,
        structural_singular_values: structural.singular_values.clone(),
        weighted_singular_values,
        sensitivity,
        groups: group_reports,
        identifiable,
        undetermined,
    })
}

/// Identifies Gamma from deflection measurements: differential evolution in
/// log space within the bounds (`global_search`), then the structural
/// identifiability analysis (`structural_groups`, `hold_groups`), then
/// Levenberg-Marquardt on the separable parameters, and the
/// identifiability report at the solution (`identifiability_at`).
///
/// # Errors
/// No measurement, invalid options, a singular structure, solver failures.
pub fn identify_stiffness(
    model: &ElasticModel,
    measurements: &[DeflectionMeasurement],
    xi: &[f64],
    options: &StiffnessIdentificationOptions,
) -> Result<IdentifiedStiffness> {
    let n = model.n_parameters();
    let bounds = checked_bounds(model, options)?;
    let problem = StiffnessProblem::new(model, measurements, xi)?;
    let weights = problem.row_weights();
    let weight = |i: usize| weights.as_ref().map_or(1.0, |w| w[i]);
    let lower: Vec<f64> = bounds.iter().map(|b| b.0.ln()).collect();
    let upper: Vec<f64> = bounds.iter().map(|b| b.1.ln()).collect();
    let global = global_search(&problem, (&lower, &upper), &weight, options)?;
    let gamma_global: Vec<f64> = global.log_gamma.iter().map(|v| v.exp()).collect();
    let mut start = global.log_gamma;
    let names = model.parameter_names();
    let (structural, groups, kinds) = structural_groups(&problem, &bounds, &names, options)?;
    let mut fixed = vec![false; n];
    let representatives = hold_groups((&groups, &kinds), &bounds, &mut start, &mut fixed);
    // Parameters the data cannot see at the start are held too.
    let gamma_start: Vec<f64> = start.iter().map(|v| v.exp()).collect();
    let jac_start = problem.log_jacobian(&gamma_start)?;
    let sens_start = weighted_column_norms(&jac_start, &weight);
    for j in 0..n {
        if sens_start[j] < options.practical_threshold {
            fixed[j] = true;
        }
    }
    let lm = LevenbergMarquardt {
        options: flexcal_optim::SolverOptions {
            max_iterations: options.max_iterations,
            ..flexcal_optim::SolverOptions::default()
        },
        ..LevenbergMarquardt::default()
    }
    .check()?;
    let setup = ProblemSetup {
        row_weights: weights.clone(),
        weights_are_absolute: weights.is_some(),
        fixed: fixed.clone(),
        column_scaling: ColumnScaling::Identity,
    };
    if fixed.iter().all(|&f| f) {
        return Err(ElasticError::NotIdentifiable {
            parameters: names_of(model),
            threshold: options.practical_threshold,
        });
    }
    let solve = lm.solve(&problem, &start, &setup, &mut ())?;
    let gamma: Vec<f64> = solve.x.iter().map(|v| v.exp()).collect();
    let identifiability = identifiability_at(
        &problem,
        &gamma,
        &weight,
        (&structural, &groups, &kinds, &representatives),
        options,
    )?;
    let predictions = problem.predict(&gamma)?;
    let criterion_mm2 = measurements
        .iter()
        .zip(&predictions)
        .map(|(meas, p)| ((p - meas.deflection) * 1e3).norm_squared())
        .sum::<f64>()
        / measurements.len() as f64;
    Ok(IdentifiedStiffness {
        names,
        units: model
            .parameters()
            .iter()
            .map(|p| p.unit.to_string())
            .collect(),
        gamma,
        gamma_global_search: gamma_global,
        global_search_value: global.value,
        global_search_evaluations: global.evaluations,
        solve,
        criterion_mm2,
        identifiability,
    })
}

fn names_of(model: &ElasticModel) -> String {
    model.parameter_names().join(", ")
}

fn argmin(v: &[f64]) -> usize {
    (0..v.len())
        .min_by(|&a, &b| v[a].total_cmp(&v[b]))
        .unwrap_or(0)
}

fn argmax(v: &[f64]) -> usize {
    (0..v.len())
        .max_by(|&a, &b| v[a].total_cmp(&v[b]))
        .unwrap_or(0)
}

fn weighted_column_norms(jac: &DMatrix<f64>, weight: &dyn Fn(usize) -> f64) -> Vec<f64> {
    (0..jac.ncols())
        .map(|j| {
            (0..jac.nrows())
                .map(|i| (jac[(i, j)] * weight(i)).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

/// Groups of parameters tied by collinearity: each non-identifiable
/// parameter joins the base parameters it is a combination of.
fn collinear_groups(diagnoses: &[Diagnosis], n: usize) -> Vec<Vec<usize>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (j, d) in diagnoses.iter().enumerate().take(n) {
        if let Diagnosis::Collinear { with } = d {
            let mut members: Vec<usize> = vec![j];
            members.extend(with.iter().map(|(b, _)| *b));
            // Merge with every group sharing a member.
            let mut merged: Vec<usize> = members.clone();
            groups.retain(|g| {
                if g.iter().any(|x| members.contains(x)) {
                    merged.extend(g);
                    false
                } else {
                    true
                }
            });
            merged.sort_unstable();
            merged.dedup();
            groups.push(merged);
        }
    }
    groups.sort();
    groups
}

/// Series when each pair of columns satisfies `J_i k_i = J_j k_j`,
/// parallel when `J_i / k_i = J_j / k_j`.
fn classify_group(jac: &DMatrix<f64>, gamma: &[f64], group: &[usize]) -> GroupKind {
    let close = |a: &nalgebra::DVector<f64>, b: &nalgebra::DVector<f64>| {
        (a - b).norm() <= 1e-4 * a.norm().max(b.norm())
    };
    let first = group[0];
    let series = group.iter().all(|&j| {
        close(
            &(jac.column(j) * gamma[j]).into_owned(),
            &(jac.column(first) * gamma[first]).into_owned(),
        )
    });
    if series {
        return GroupKind::Series;
    }
    let parallel = group.iter().all(|&j| {
        close(
            &(jac.column(j) / gamma[j]).into_owned(),
            &(jac.column(first) / gamma[first]).into_owned(),
        )
    });
    if parallel {
        GroupKind::Parallel
    } else {
        GroupKind::Other
    }
}

/// Residual samples `predicted - measured` (m) with their load magnitudes,
/// for [`crate::metrics::per_load_metrics`].
///
/// # Errors
/// As [`StiffnessProblem::predict`].
pub fn residual_samples(
    model: &ElasticModel,
    measurements: &[DeflectionMeasurement],
    xi: &[f64],
    gamma: &[f64],
) -> Result<Vec<ResidualSample>> {
    let problem = StiffnessProblem::new(model, measurements, xi)?;
    let predicted = problem.predict(gamma)?;
    Ok(measurements
        .iter()
        .zip(predicted)
        .map(|(m, p)| ResidualSample {
            load_n: m.load_n(),
            residual: p - m.deflection,
        })
        .collect())
}
