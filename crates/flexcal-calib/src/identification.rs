//! The one identification behind [`crate::calibrate`] and
//! [`crate::calibrate`], in the order it runs:
//!
//! 1. settings checked ([`crate::options`]);
//! 2. frames started ([`crate::start`]): each station's measurement frame
//!    registered, each target's orientation from the data;
//! 3. the unknowns laid out (`Layout`): which are fixed, which cannot
//!    move anything (a station or target without observations, a rotation
//!    without orientations), their pivoting priorities;
//! 4. the rows weighted (`row_weights`): `1/sigma` per axis from the
//!    instrument's stated noise, the file's deviations or the defaults;
//! 5. the frames alone fitted on the nominal robot (the "before");
//! 6. the rank-revealing analysis and the solver rounds
//!    ([`crate::analysis`]): exact dependencies, the base set at the noise
//!    level, the joint terms' limits, the compliances on their own scale
//!    ([`crate::significance`]);
//! 7. the statistics (`Identification`): combinations (C.1), spread
//!    ratios ([`crate::spread`]), every unknown's status, the noise used,
//!    the errors before and after.

use std::borrow::Cow;
use std::cell::RefCell;

use flexcal_kinematics::Model;
use flexcal_optim::{
    CancelToken, ColumnScaling, Control, Diagnosis, GaussNewton, IdentifiabilityReport,
    IterationState, Jacobian, LevenbergMarquardt, ProblemSetup, Residuals, SolveReport,
    Termination,
};
use nalgebra::Vector3;

use crate::analysis::{
    AnalysisContext, NoiseAt, Rounds, RoundsOutcome, UnknownFlags, analysis_index, noise_level,
    problem_error, unknown_estimates,
};
use crate::coverage::CoordinateCoverage;
use crate::error::CalibError;
use crate::error_model::{ErrorModel, FrameStarts, UnknownKind};
use crate::measurement::MeasurementSet;
use crate::metrics::PoseError;
use crate::options::{
    CalibrationOptions, FrameTreatment, GEODESIC_ACCELERATION_LIMIT, Method, Weighting,
};
use crate::significance::{JudgeUpdate, NoiseSource, barely_loaded};
use crate::spread::{SpreadReference, spread_ratios};
use crate::start::frame_starts;
use crate::unknowns::{Combination, UnknownEstimate, UnknownStatus};

/// Unweighted residual norms at one iterate of the identification (Figure 7
/// plots these, position and orientation separately).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ResidualNorms {
    /// Cost `1/2 ||W r||^2` (weighted, dimensionless).
    pub cost: f64,
    /// RMS over the poses of the position error norm (m).
    pub position_rms: f64,
    /// RMS over the poses of the orientation error angle (rad), when
    /// orientations are used.
    pub orientation_rms: Option<f64>,
}

/// What an identification found, before a result type packs it.
pub(crate) struct Identification<'a> {
    /// The error model (its frames' starts, its unknowns' layout).
    pub problem: ErrorModel<'a>,
    /// Where the frames started.
    pub starts: FrameStarts,
    /// Whether the measurement frames were fixed.
    pub frame_fixed: bool,
    /// The nominal robot with its frames fitted (the "before").
    pub x_nominal_robot: Vec<f64>,
    /// Every unknown with its status.
    pub unknowns: Vec<UnknownEstimate>,
    /// The exact-rank analysis at the start point.
    pub identifiability: IdentifiabilityReport,
    /// What the identified unknowns stand for (C.1).
    pub combinations: Vec<Combination>,
    /// The final fit (`report.x` the identified unknowns).
    pub report: SolveReport,
    /// Cost history of every solver run, rounds in order.
    pub cost_history: Vec<f64>,
    /// Position and orientation RMS of the same iterates.
    pub residual_history: Vec<ResidualNorms>,
    /// Errors per observation before and after.
    pub errors_before: Vec<PoseError>,
    /// Errors per observation after identification.
    pub errors_after: Vec<PoseError>,
    /// The noise used.
    pub noise: NoiseSource,
    /// What the poses cover of each actuated coordinate.
    pub actuated_ranges: Vec<CoordinateCoverage>,
    /// Span of each actuated coordinate's gravity torque.
    pub torque_ranges: Vec<CoordinateCoverage>,
    /// The degrees of freedom of the position residuals when orientation
    /// rows were fitted too ([`position_residual_dof`]).
    pub position_residual_dof: Option<f64>,
}

/// Step 3: the layout of the unknowns of `problem` under `options`.
pub(crate) struct Layout {
    pub names: Vec<String>,
    pub kinds: Vec<UnknownKind>,
    /// Kept at their start by the options.
    pub fixed: Vec<bool>,
    /// Known to move nothing: a station or target no observation sees, a
    /// target's rotation without orientations.
    pub no_influence: Vec<bool>,
    /// Pivoting priorities: the frames first (2), the targets' offsets
    /// (1), the robot and the elastic terms (0), deferred names last (-1).
    pub priorities: Vec<i32>,
}

impl Layout {
    /// # Errors
    /// [`CalibError::UnknownParameter`] for a name of `fixed` or `deferred`
    /// that is not an unknown.
    pub(crate) fn new(
        problem: &ErrorModel<'_>,
        options: &CalibrationOptions,
    ) -> Result<Self, CalibError> {
        let names = problem.names().to_vec();
        let n = names.len();
        let index_of = |name: &String| {
            names
                .iter()
                .position(|n| n == name)
                .ok_or_else(|| CalibError::UnknownParameter {
                    name: name.clone(),
                    known: names.join(", "),
                })
        };
        let mut fixed = vec![false; n];
        for name in &options.fixed {
            fixed[index_of(name)?] = true;
        }
        let mut priorities = vec![0i32; n];
        for name in &options.deferred {
            priorities[index_of(name)?] = -1;
        }
        let mut no_influence = vec![false; n];
        let set = problem.set();
        let frame_fixed = options.measurement_frame == FrameTreatment::Fixed;
        for s in 0..problem.n_stations() {
            let o = problem.station_frame_offset(s);
            priorities[o..o + 6].fill(2);
            if frame_fixed {
                fixed[o..o + 6].fill(true);
            } else if s >= set.n_stations() || !(0..set.len()).any(|k| set.station_of(k) == s) {
                no_influence[o..o + 6].fill(true);
            }
        }
        for (t, target) in set.targets().iter().enumerate() {
            let o = problem.target_offset(t);
            let own = o..o + problem.target_unknowns(t);
            priorities[own.clone()].fill(1);
            if options.target == FrameTreatment::Fixed || target.treatment == FrameTreatment::Fixed
            {
                fixed[own.clone()].fill(true);
            }
            let seen = set.observations_of(t).next().is_some();
            let moves = |j: usize| seen && (j < o + 3 || problem.uses_orientation(t));
            for j in own {
                no_influence[j] = !fixed[j] && !moves(j);
            }
        }
        Ok(Self {
            kinds: problem.kinds(),
            names,
            fixed,
            no_influence,
            priorities,
        })
    }

    /// Left out of every analysis and fit.
    pub(crate) fn excluded(&self, j: usize) -> bool {
        self.fixed[j] || self.no_influence[j]
    }
}

/// Step 4: per-row weights `1/sigma` of `problem`'s observations and
/// whether they are absolute (the instrument's stated noise, or the file's
/// deviations on every observation).
///
/// # Errors
/// [`CalibError::InvalidOption`] for an instrument noise without the
/// orientation figure when orientations are fitted.
pub(crate) fn row_weights(
    problem: &ErrorModel<'_>,
    options: &CalibrationOptions,
) -> Result<(Vec<f64>, bool), CalibError> {
    let set = problem.set();
    let orientation: Vec<bool> = (0..set.targets().len())
        .map(|t| problem.uses_orientation(t))
        .collect();
    let absolute = match options.instrument_noise {
        Some(noise) => {
            if orientation.iter().any(|o| *o) {
                noise.orientation()?;
            }
            true
        }
        None => {
            options.weighting == Weighting::FromFile && set.has_standard_deviations(&orientation)
        }
    };
    let mut weights = Vec::with_capacity(problem.n_residuals());
    for i in 0..problem.n_observations() {
        let o = problem.measured(i);
        let (position, rotation) = observation_std(options, o.position_std, o.orientation_std);
        weights.extend(position.iter().map(|s| 1.0 / s));
        if problem.uses_orientation(problem.observation(i).1) {
            weights.extend(rotation.iter().map(|s| 1.0 / s));
        }
    }
    Ok((weights, absolute))
}

/// Position and orientation RMS over the observations of the unweighted
/// residuals `r` of `problem`.
fn residual_norms(problem: &ErrorModel<'_>, r: &[f64], cost: f64) -> ResidualNorms {
    let (mut p2, mut o2, mut oriented) = (0.0, 0.0, 0usize);
    for i in 0..problem.n_observations() {
        let rows = &r[problem.block_rows(i)];
        p2 += rows[..3].iter().map(|v| v * v).sum::<f64>();
        if rows.len() == 6 {
            o2 += rows[3..].iter().map(|v| v * v).sum::<f64>();
            oriented += 1;
        }
    }
    ResidualNorms {
        cost,
        position_rms: (p2 / problem.n_observations().max(1) as f64).sqrt(),
        orientation_rms: (oriented > 0).then(|| (o2 / oriented as f64).sqrt()),
    }
}

/// The solver runs of one identification, with their cost and residual
/// histories (Figure 7's data).
struct Solver<'p, 'a> {
    problem: &'p ErrorModel<'a>,
    options: &'p CalibrationOptions,
    weights: &'p [f64],
    absolute: bool,
    cost_history: RefCell<Vec<f64>>,
    residual_history: RefCell<Vec<ResidualNorms>>,
}

impl Solver<'_, '_> {
    fn cancelled(&self) -> bool {
        self.options
            .cancel
            .as_ref()
            .is_some_and(CancelToken::is_cancelled)
    }

    fn norms_at(&self, x: &[f64], cost: f64) -> ResidualNorms {
        let mut r = vec![0.0; self.problem.n_residuals()];
        match self.problem.residuals(x, &mut r) {
            Ok(()) => residual_norms(self.problem, &r, cost),
            Err(_) => ResidualNorms {
                cost,
                position_rms: f64::NAN,
                orientation_rms: None,
            },
        }
    }

    /// Solves for the unknowns not `frozen`, from `x0`, by the options'
    /// method; records the histories.
    fn solve(&self, x0: &[f64], frozen: &[bool]) -> Result<SolveReport, CalibError> {
        // Between two solves (the rounds of the noise-aware rank).
        if self.cancelled() {
            return Err(CalibError::Cancelled);
        }
        let problem = self.problem;
        let options = self.options;
        // Frames-only fits skip the robot's parameter Jacobian.
        let np = problem.frame_offset();
        problem.set_robot_columns(frozen[..np].iter().any(|f| !f));
        // The solver reads the columns of its free unknowns only.
        problem.set_frozen_columns(frozen);
        let setup = ProblemSetup {
            row_weights: Some(self.weights.to_vec()),
            weights_are_absolute: self.absolute,
            fixed: frozen.to_vec(),
            column_scaling: ColumnScaling::ColumnNorm,
        };
        let mut iterates = Vec::new();
        let mut observer = |state: &IterationState| {
            let r: Vec<f64> = state
                .weighted_residuals
                .iter()
                .zip(self.weights)
                .map(|(r, w)| r / w)
                .collect();
            iterates.push(residual_norms(problem, &r, state.cost));
            Control::Continue
        };
        let result = match options.method {
            Method::LevenbergMarquardt => {
                let mut solver =
                    LevenbergMarquardt::params().max_iterations(options.max_iterations);
                solver.options.max_evaluations = 20 * options.max_iterations;
                solver.options.cost_tolerance = options.cost_tolerance;
                solver.options.cancel = options.cancel.clone();
                solver.options.singular_values = !options.prediction_only;
                // The law's hardening trades off against the compliance
                // along a long curved valley of the cost, which the plain
                // iteration walks down by many small steps (54 iterations
                // on IPA series C, 26 with the acceleration, to a slightly
                // lower cost). Models without the law converge in a few
                // iterations and keep the plain iteration.
                if options.joint_terms.law.is_some() {
                    solver.geodesic_acceleration = Some(GEODESIC_ACCELERATION_LIMIT);
                }
                solver.solve(problem, x0, &setup, &mut observer)
            }
            Method::GaussNewton => {
                let mut solver = GaussNewton::params().max_iterations(options.max_iterations);
                solver.options.max_evaluations = 20 * options.max_iterations;
                solver.options.cost_tolerance = options.cost_tolerance;
                solver.options.cancel = options.cancel.clone();
                solver.options.singular_values = !options.prediction_only;
                solver.solve(problem, x0, &setup, &mut observer)
            }
        };
        problem.set_robot_columns(true);
        problem.set_frozen_columns(&[]);
        let report = result.map_err(CalibError::optim("identification"))?;
        if report.termination == Termination::Cancelled {
            return Err(CalibError::Cancelled);
        }
        self.record(x0, &report, iterates);
        Ok(report)
    }

    fn record(&self, x0: &[f64], report: &SolveReport, iterates: Vec<ResidualNorms>) {
        self.cost_history.borrow_mut().extend(&report.cost_history);
        let mut history = self.residual_history.borrow_mut();
        let before = history.len();
        let start_cost = report.cost_history.first().copied().unwrap_or(f64::NAN);
        // The start's norms from the residuals the solver evaluated there.
        let start: Vec<f64> = report
            .start_weighted_residuals
            .iter()
            .zip(self.weights)
            .map(|(r, w)| r / w)
            .collect();
        history.push(if start.len() == self.problem.n_residuals() {
            residual_norms(self.problem, &start, start_cost)
        } else {
            self.norms_at(x0, start_cost)
        });
        let last = iterates.last().copied();
        history.extend(iterates);
        // A solver that stops (no further decrease possible) records the
        // final cost once more, at the final x.
        for &cost in report.cost_history.iter().skip(history.len() - before) {
            let mut norms = last.unwrap_or_else(|| self.norms_at(&report.x, cost));
            norms.cost = cost;
            history.push(norms);
        }
    }
}

/// Step 1 beyond the options: nothing to identify, or fewer rows than
/// free unknowns, is refused by name before any registration.
fn check_counts(problem: &ErrorModel<'_>, layout: &Layout) -> Result<usize, CalibError> {
    let n = layout.names.len();
    let free_count = (0..n).filter(|&j| !layout.excluded(j)).count();
    if free_count == 0 {
        return Err(CalibError::NothingToIdentify);
    }
    let rows = problem.n_residuals();
    if rows < free_count {
        return Err(CalibError::TooFewPoses {
            poses: problem.set().len(),
            rows,
            unknowns: free_count,
        });
    }
    Ok(free_count)
}

/// The error model of `set` from `starts`, with the options' elastic terms.
fn error_model<'a>(
    model: &'a Model,
    set: Cow<'a, MeasurementSet>,
    starts: &FrameStarts,
    options: &CalibrationOptions,
) -> Result<ErrorModel<'a>, CalibError> {
    Ok(ErrorModel::new(model, set, starts)?
        .with_elastic(options.gravity.as_ref(), &options.joint_terms)?
        .with_threads(options.threads))
}

/// Steps 1 to 4: the options checked, the unknowns laid out on the model
/// of the nominal starts (too few poses told before a registration that
/// would fail on them for a less helpful reason), then the model started
/// where the registration puts its frames. The model, its layout, the
/// number of free unknowns and the frames' starts.
///
/// # Errors
/// As [`identify`].
fn set_up<'a>(
    model: &'a Model,
    set: Cow<'a, MeasurementSet>,
    options: &CalibrationOptions,
) -> Result<(ErrorModel<'a>, Layout, usize, FrameStarts), CalibError> {
    options.check()?;
    if options
        .cancel
        .as_ref()
        .is_some_and(CancelToken::is_cancelled)
    {
        return Err(CalibError::Cancelled);
    }
    let nominal = FrameStarts::nominal(
        &set,
        nalgebra::Isometry3::identity(),
        options.use_orientation,
    )?;
    let laid_out = error_model(model, set, &nominal, options)?;
    let layout = Layout::new(&laid_out, options)?;
    let free_count = check_counts(&laid_out, &layout)?;
    let starts = frame_starts(model, laid_out.set(), options)?;
    let problem = laid_out.restarted(&starts)?;
    Ok((problem, layout, free_count, starts))
}

/// Identifies `model` from `set` under `options`: the steps of the module
/// docs.
///
/// # Errors
/// As [`crate::calibrate`].
pub(crate) fn identify<'a>(
    model: &'a Model,
    set: Cow<'a, MeasurementSet>,
    options: &CalibrationOptions,
) -> Result<Identification<'a>, CalibError> {
    let (problem, layout, free_count, starts) = set_up(model, set, options)?;
    let (weights, absolute) = row_weights(&problem, options)?;
    let limits: Vec<f64> = layout
        .kinds
        .iter()
        .map(|&k| options.standard_error_limit(k))
        .collect();
    let context = AnalysisContext {
        problem: &problem,
        weights: &weights,
        names: &layout.names,
        priorities: &layout.priorities,
        limits: &limits,
        rank_tolerance: options.rank_tolerance,
        singular_values: !options.prediction_only,
    };
    let solver = Solver {
        problem: &problem,
        options,
        weights: &weights,
        absolute,
        cost_history: RefCell::new(Vec::new()),
        residual_history: RefCell::new(Vec::new()),
    };
    let noise_at = |x: &[f64], free: usize| noise_level(&problem, &weights, absolute, x, free);
    let x_initial = problem.initial_unknowns();
    let x_start = fit_frames(&context, &layout, &solver, &noise_at, x_initial.clone())?;
    let excluded = |j: usize| layout.excluded(j);
    // What the poses cover of each coordinate and of its gravity torque,
    // once: the masks below, the spread reference and the report use them.
    let q = problem.set().configurations();
    let actuated_ranges = CoordinateCoverage::of_configurations(model, &q);
    let torque_ranges = problem.torque_ranges();
    let partial_period = left_at_start(model, (&q, &torque_ranges), &layout.names, options);
    let reduced_start = context.reduced(&x_start)?;
    let n = layout.names.len();
    let mut solve = |x0: &[f64], frozen: &[bool]| solver.solve(x0, frozen);
    let outcome = context.identify_in_rounds(
        &Rounds {
            reduced_start: &reduced_start,
            x_start: &x_start,
            excluded: &excluded,
            partial_period: &partial_period,
            absolute,
            require_full_rank: options.require_full_rank,
            free_count,
            joint_start: problem.joint_terms_offset().unwrap_or(n),
            kinds: &layout.kinds,
            min_compliance_z: options.min_compliance_z,
            hardening_floors: &crate::significance::hardening_floors(
                &layout.names,
                model.actuated_names(),
                &torque_ranges,
            ),
            coupling_matrices: &options.gravity.as_ref().map_or_else(Vec::new, |gravity| {
                crate::coupling::matrix_indices(model, gravity, &layout.names)
            }),
            judge_update: if options.prediction_only {
                JudgeUpdate::Linearised
            } else {
                JudgeUpdate::Solve
            },
        },
        &noise_at,
        &mut solve,
    )?;
    let statistics = Statistics {
        context: &context,
        layout: &layout,
        options,
        reduced_start: &reduced_start,
        x_start: &x_start,
        x_initial: &x_initial,
        starts: &starts,
        actuated_ranges: &actuated_ranges,
        absolute,
    };
    let (unknowns, combinations, noise) = statistics.of(model, &outcome, &noise_at)?;
    let errors_before = problem.errors(&x_start)?;
    let errors_after = problem.errors(&outcome.report.x)?;
    let position_residual_dof =
        position_residual_dof(&problem, &outcome.report.x, &weights, &unknowns)?;
    let Solver {
        cost_history,
        residual_history,
        ..
    } = solver;
    Ok(Identification {
        starts,
        frame_fixed: options.measurement_frame == FrameTreatment::Fixed,
        x_nominal_robot: x_start,
        unknowns,
        identifiability: outcome.numerical,
        combinations,
        report: outcome.report,
        cost_history: cost_history.into_inner(),
        residual_history: residual_history.into_inner(),
        errors_before,
        errors_after,
        noise,
        actuated_ranges,
        torque_ranges,
        position_residual_dof,
        problem,
    })
}

/// The degrees of freedom the position rows of the weighted fit of
/// `problem` at `x` keep when it fits orientation rows too, `3 N -
/// tr(H_pp)`; `None` without orientation rows (`3 N - p` then). `H = J_w
/// (J_w^T J_w)^-1 J_w^T` is the hat matrix of the fit on its identified
/// columns (`J_w` the Jacobian's rows scaled by `weights`), `H_pp` its
/// block of the position rows; its diagonal is the squared row norms of
/// the thin `Q` of `J_w`. The orientation rows carry part of the fit, so
/// the position residuals keep more than `3 N - p`.
///
/// # Errors
/// A model failure at a pose.
fn position_residual_dof(
    problem: &ErrorModel<'_>,
    x: &[f64],
    weights: &[f64],
    unknowns: &[UnknownEstimate],
) -> Result<Option<f64>, CalibError> {
    let n = problem.n_observations();
    if problem.n_residuals() == 3 * n {
        return Ok(None);
    }
    let identified: Vec<usize> = (0..unknowns.len())
        .filter(|&j| unknowns[j].status == UnknownStatus::Identified)
        .collect();
    let m = problem.n_residuals();
    let mut jacobian = faer::Mat::<f64>::zeros(m, x.len());
    problem
        .jacobian(x, jacobian.as_mut())
        .map_err(problem_error)?;
    let mut weighted = nalgebra::DMatrix::<f64>::zeros(m, identified.len());
    for (c, &j) in identified.iter().enumerate() {
        for i in 0..m {
            weighted[(i, c)] = weights[i] * jacobian[(i, j)];
        }
        // Unit columns: lengths and angles on one footing for the factor
        // (the hat matrix does not change).
        let norm = weighted.column(c).norm();
        if norm > 0.0 {
            weighted.column_mut(c).unscale_mut(norm);
        }
    }
    let q = weighted.qr().q();
    let trace: f64 = (0..n)
        .flat_map(|i| problem.block_rows(i).take(3))
        .map(|r| q.row(r).norm_squared())
        .sum();
    Ok(Some(3.0 * n as f64 - trace))
}

/// Step 5: the frames alone (the measurement frames and the targets'
/// offsets the data determine at the noise level), from the registration,
/// on the nominal robot: the robot's linearisation point is then the
/// nominal robot in the right place, and its errors the "before".
fn fit_frames(
    context: &AnalysisContext<'_>,
    layout: &Layout,
    solver: &Solver<'_, '_>,
    noise_at: &NoiseAt<'_>,
    x_start: Vec<f64>,
) -> Result<Vec<f64>, CalibError> {
    let problem = solver.problem;
    let frame_unknowns: Vec<usize> = (problem.frame_offset()..problem.frames_end())
        .filter(|&j| !layout.excluded(j))
        .collect();
    if frame_unknowns.is_empty() {
        return Ok(x_start);
    }
    let sigma = noise_at(&x_start, frame_unknowns.len())?;
    // Only the frame columns are analysed: skip the robot's.
    problem.set_robot_columns(false);
    let reduced = context.reduced(&x_start);
    problem.set_robot_columns(true);
    let reduced = reduced?;
    let outside = |j: usize| !frame_unknowns.contains(&j);
    let mut analysis = context.analyse(&reduced, Some(sigma), &outside)?;
    // A start far from the data (a tool offset not given) inflates the
    // residual scatter the noise level is taken from, and with it every
    // frame unknown's standard error, so that the frames would stay where
    // the poor start put them. When the noise level keeps out frame
    // unknowns the exact rank identifies, those are fitted first and the
    // noise level taken again where that fit ends.
    let exact = context.analyse(&reduced, None, &outside)?;
    if analysis.base.len() < exact.base.len() {
        let fitted = solver
            .solve(&x_start, &frozen_outside(&exact, &layout.names))?
            .x;
        let sigma = noise_at(&fitted, frame_unknowns.len())?;
        analysis = context.analyse(&reduced, Some(sigma), &outside)?;
    }
    let frozen = frozen_outside(&analysis, &layout.names);
    if frozen.iter().all(|f| *f) {
        return Ok(x_start);
    }
    Ok(solver.solve(&x_start, &frozen)?.x)
}

/// Every unknown of `names` frozen but those of the base set of `analysis`.
fn frozen_outside(analysis: &IdentifiabilityReport, names: &[String]) -> Vec<bool> {
    let mut frozen = vec![true; names.len()];
    for &j in &analysis.base {
        frozen[analysis_index(analysis, j, names)] = false;
    }
    frozen
}

/// The unknowns left at their start before any fit: cyclic errors of a
/// joint whose poses do not cover their period (over part of a period a
/// harmonic is a smooth curve that geometry and the frames imitate, and it
/// extrapolates to the rest of the turn without any data), and the
/// compliances of joints gravity barely loads
/// ([`CalibrationOptions::min_torque_share`]).
fn left_at_start(
    model: &Model,
    (q, torque_ranges): (&[&[f64]], &[CoordinateCoverage]),
    names: &[String],
    options: &CalibrationOptions,
) -> Vec<bool> {
    barely_loaded(
        crate::joint_law::partial_period_mask_of(model, q, names),
        (names, model.actuated_names()),
        torque_ranges,
        options.min_torque_share,
    )
}

/// Step 7's inputs.
struct Statistics<'s> {
    context: &'s AnalysisContext<'s>,
    layout: &'s Layout,
    options: &'s CalibrationOptions,
    reduced_start: &'s faer::Mat<f64>,
    x_start: &'s [f64],
    x_initial: &'s [f64],
    starts: &'s FrameStarts,
    /// What the poses cover of each actuated coordinate.
    actuated_ranges: &'s [CoordinateCoverage],
    absolute: bool,
}

impl Statistics<'_> {
    /// Every unknown's estimate and status, the combinations the
    /// identified ones stand for (linearised at the start point: with
    /// geometric errors of millimetres the difference from the solution is
    /// of second order, and the start's factor is at hand), and the noise
    /// used.
    fn of(
        &self,
        model: &Model,
        outcome: &RoundsOutcome,
        noise_at: &NoiseAt<'_>,
    ) -> Result<(Vec<UnknownEstimate>, Vec<Combination>, NoiseSource), CalibError> {
        let layout = self.layout;
        let n = layout.names.len();
        let frozen = &outcome.frozen;
        // What no observation moves with (a branch without a marker): its
        // columns are zero.
        let mut no_influence = layout.no_influence.clone();
        let numerical = &outcome.numerical;
        for &j in &numerical.non_identifiable {
            if numerical.diagnoses[j] == Diagnosis::NoInfluence {
                no_influence[analysis_index(numerical, j, &layout.names)] = true;
            }
        }
        let identified: Vec<usize> = (0..n).filter(|&j| !frozen[j]).collect();
        let absorbed: Vec<usize> = (0..n)
            .filter(|&j| frozen[j] && !layout.fixed[j] && !no_influence[j])
            .collect();
        let combinations = self
            .context
            .combinations(self.reduced_start, &identified, &absorbed)?;
        let problem = self.context.problem;
        let spread = if self.options.spread_reference {
            spread_ratios(
                &SpreadReference {
                    model,
                    set: problem.set(),
                    options: self.options,
                    actuated_ranges: self.actuated_ranges,
                    starts: self.starts,
                    context: self.context,
                },
                self.reduced_start,
                self.x_start,
                &identified,
            )?
        } else {
            vec![None; n]
        };
        let unknowns = unknown_estimates(
            (&layout.names, &layout.kinds),
            (self.x_initial, &outcome.report),
            &UnknownFlags {
                fixed: &layout.fixed,
                no_influence: &no_influence,
                frozen,
                exactly_dependent: &outcome.exactly_dependent,
                judgements: &outcome.judgements,
            },
            &spread,
        );
        let noise = noise_source(
            self.options,
            self.absolute,
            noise_at(&outcome.report.x, identified.len())? * self.options.default_position_std,
        );
        Ok((unknowns, combinations, noise))
    }
}

/// Where the noise of an identification came from: the instrument when
/// stated, the file's deviations when the weights are absolute, else the
/// estimate `position_std` (m per axis) from the fit.
fn noise_source(options: &CalibrationOptions, absolute: bool, position_std: f64) -> NoiseSource {
    match (options.instrument_noise, absolute) {
        (Some(noise), _) => NoiseSource::Instrument(noise),
        (None, true) => NoiseSource::File,
        (None, false) => NoiseSource::Estimated { position_std },
    }
}

/// The standard deviations of one observation's position and orientation
/// axes (m, rad) under `options`: the instrument's stated noise, else the
/// file's (`from_file`) where it has them, else the defaults.
fn observation_std(
    options: &CalibrationOptions,
    position_std: Option<Vector3<f64>>,
    orientation_std: Option<Vector3<f64>>,
) -> (Vector3<f64>, Vector3<f64>) {
    if let Some(noise) = options.instrument_noise {
        let orientation = noise
            .orientation_std
            .unwrap_or(options.default_orientation_std);
        return (
            Vector3::repeat(noise.position_std),
            Vector3::repeat(orientation),
        );
    }
    let from_file = options.weighting == Weighting::FromFile;
    let pick = |file: Option<Vector3<f64>>, default: f64| match (from_file, file) {
        (true, Some(s)) => s,
        _ => Vector3::repeat(default),
    };
    (
        pick(position_std, options.default_position_std),
        pick(orientation_std, options.default_orientation_std),
    )
}
