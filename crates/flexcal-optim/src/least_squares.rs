//! Gauss-Newton and Levenberg-Marquardt on column-pivoted QR of the scaled Jacobian.

use faer::Mat;
use nalgebra::DMatrix;

use crate::cancel::CancelToken;
use crate::error::{OptimError, Result, check_len, invalid};
use crate::problem::{ColumnScaling, Jacobian, ProblemSetup};
use crate::qr::{PivotedQr, back_substitute, damped_solve};

/// Default relative tolerance on `|R_kk| / |R_00|` below which a column of the
/// scaled Jacobian is beyond the numerical rank.
///
/// `1e-10` suits analytic Jacobians of well-posed calibration problems (their
/// exactly collinear columns give ratios near `1e-15`); with finite-difference
/// Jacobians use about `1e-6`.
pub const DEFAULT_RANK_TOLERANCE: f64 = 1e-10;

/// Options shared by both solvers. Construct with `Default` and adjust fields.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SolverOptions {
    /// Maximum number of iterations (Jacobian evaluations after the first); default 100, `>= 1`.
    pub max_iterations: usize,
    /// Maximum number of residual evaluations; default 1000, `>= 1`.
    pub max_evaluations: usize,
    /// Stop when the scaled step satisfies `||dz|| <= step_tolerance * (||z|| + step_tolerance)`;
    /// default `1e-10`, `>= 0`.
    pub step_tolerance: f64,
    /// Stop when every column of the scaled Jacobian is nearly orthogonal to the
    /// residual: `max_j |J_j . r| / (||J_j|| ||r||) <= gradient_tolerance` (MINPACK's gtol);
    /// default `1e-10`, `>= 0`.
    pub gradient_tolerance: f64,
    /// Stop when an accepted step lowers the cost by less than `cost_tolerance * cost`;
    /// default `1e-12`, `>= 0`.
    pub cost_tolerance: f64,
    /// Relative tolerance on `|R_kk| / |R_00|` deciding the numerical rank (see
    /// [`DEFAULT_RANK_TOLERANCE`]); range `[0, 1)`.
    pub rank_tolerance: f64,
    /// Stop with [`Termination::RankDeficient`] at the first rank-deficient Jacobian
    /// instead of keeping the columns beyond the rank fixed; default `false`.
    pub fail_on_rank_deficiency: bool,
    /// Stop with [`Termination::Cancelled`] at the start of the first
    /// iteration after this token is cancelled (default `None`: never).
    #[serde(skip)]
    pub cancel: Option<CancelToken>,
    /// Compute [`SolveReport::singular_values`] and
    /// [`SolveReport::condition_number`] at the solution (one SVD of `R`;
    /// default `true`). `false` leaves them empty and NaN; the rank, the
    /// covariance and the standard errors do not depend on them.
    pub singular_values: bool,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            max_evaluations: 1000,
            step_tolerance: 1e-10,
            gradient_tolerance: 1e-10,
            cost_tolerance: 1e-12,
            rank_tolerance: DEFAULT_RANK_TOLERANCE,
            fail_on_rank_deficiency: false,
            cancel: None,
            singular_values: true,
        }
    }
}

impl SolverOptions {
    fn check(&self) -> Result<()> {
        if self.max_iterations == 0 {
            return Err(invalid("max_iterations", 0, "must be >= 1"));
        }
        if self.max_evaluations == 0 {
            return Err(invalid("max_evaluations", 0, "must be >= 1"));
        }
        for (name, v) in [
            ("step_tolerance", self.step_tolerance),
            ("gradient_tolerance", self.gradient_tolerance),
            ("cost_tolerance", self.cost_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(name, v, "must be finite and >= 0"));
            }
        }
        if !(0.0..1.0).contains(&self.rank_tolerance) {
            return Err(invalid(
                "rank_tolerance",
                self.rank_tolerance,
                "must be in [0, 1)",
            ));
        }
        Ok(())
    }
}

/// Why a solver stopped.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum Termination {
    /// The scaled step became smaller than `step_tolerance`.
    SmallStep,
    /// The scaled gradient (cosine between residual and Jacobian columns) fell below `gradient_tolerance`.
    SmallGradient,
    /// An accepted step lowered the cost by less than `cost_tolerance` relative.
    SmallCostDecrease,
    /// The residual is exactly zero.
    ZeroResidual,
    /// `max_iterations` reached.
    MaxIterations,
    /// `max_evaluations` reached.
    MaxEvaluations,
    /// No trial step lowered the cost: all step halvings (Gauss-Newton) or a damping
    /// grown to overflow (Levenberg-Marquardt) failed.
    NoDescent,
    /// The Jacobian was rank deficient and `fail_on_rank_deficiency` was set.
    RankDeficient {
        /// Names of the parameters beyond the numerical rank.
        parameters: Vec<String>,
    },
    /// The observer asked to stop.
    StoppedByObserver,
    /// The [`SolverOptions::cancel`] token was cancelled: the parameters
    /// are those of the last accepted step.
    Cancelled,
}

impl Termination {
    /// `true` for the reasons that mean a (local) minimum was reached.
    pub fn is_converged(&self) -> bool {
        matches!(
            self,
            Self::SmallStep | Self::SmallGradient | Self::SmallCostDecrease | Self::ZeroResidual
        )
    }
}

/// What the observer sees after each iteration.
#[derive(Debug, Clone)]
pub struct IterationState {
    /// Iteration number (1-based).
    pub iteration: usize,
    /// Cost `1/2 ||W r||^2` after the iteration.
    pub cost: f64,
    /// Norm of the accepted scaled step.
    pub step_norm: f64,
    /// Levenberg-Marquardt damping after the iteration (0 for Gauss-Newton).
    pub damping: f64,
    /// Numerical rank of the scaled Jacobian used for the step.
    pub rank: usize,
    /// Residual evaluations so far.
    pub evaluations: usize,
    /// Parameters after the iteration (all of them, fixed ones included):
    /// for observers that track quantities other than the cost.
    pub x: Vec<f64>,
    /// Weighted residuals `W r` at `x`.
    pub weighted_residuals: Vec<f64>,
}

/// Whether the solver should go on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Keep iterating.
    Continue,
    /// Stop now with [`Termination::StoppedByObserver`].
    Stop,
}

/// Called once per iteration (for progress bars, logs, cancellation).
pub trait Observer {
    /// Sees the state after an iteration and decides whether to continue.
    fn observe(&mut self, state: &IterationState) -> Control;
}

impl Observer for () {
    fn observe(&mut self, _state: &IterationState) -> Control {
        Control::Continue
    }
}

impl<F: FnMut(&IterationState) -> Control> Observer for F {
    fn observe(&mut self, state: &IterationState) -> Control {
        self(state)
    }
}

/// Result of a least-squares solve.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SolveReport {
    /// Parameters at the solution (all `n`, fixed ones unchanged).
    pub x: Vec<f64>,
    /// Names of the parameters, as given by [`crate::Residuals::parameter_name`].
    pub parameter_names: Vec<String>,
    /// Final cost `1/2 ||W r||^2`.
    pub cost: f64,
    /// Cost at the start and after each iteration (length `iterations + 1`).
    pub cost_history: Vec<f64>,
    /// Weighted residuals `W r` at the start (the `x0` given to the
    /// solver): with `cost_history[0]`, the start of a convergence plot
    /// without evaluating the model again.
    pub start_weighted_residuals: Vec<f64>,
    /// Iterations performed.
    pub iterations: usize,
    /// Residual evaluations.
    pub residual_evaluations: usize,
    /// Jacobian evaluations.
    pub jacobian_evaluations: usize,
    /// Trial points the problem could not evaluate (its error, or a
    /// non-finite residual), each refused as a step that raised the cost:
    /// a loop that cannot close or an equilibrium that does not converge far
    /// from the solution. Zero in a smooth fit.
    pub refused_trials: usize,
    /// The problem's error at the last refused trial point, with its cause
    /// (`None` when there was none).
    pub last_refusal: Option<String>,
    /// Why the solver stopped.
    pub termination: Termination,
    /// Number of free (not fixed) parameters.
    pub n_free: usize,
    /// Numerical rank of the scaled Jacobian at the solution.
    pub rank: usize,
    /// Free parameters beyond the numerical rank at the solution (not updated by the last step).
    pub not_identified: Vec<usize>,
    /// Singular values of the weighted, scaled Jacobian `W J S^-1` of the free
    /// parameters at the solution, non-increasing.
    pub singular_values: Vec<f64>,
    /// `sigma_max / sigma_min` of the same matrix (infinite when rank deficient).
    pub condition_number: f64,
    /// Column scales `s_j` in force at the end (1 for fixed parameters).
    pub column_scales: Vec<f64>,
    /// Variance factor: 1 with absolute weights, else `SSR / (m - rank)`.
    pub sigma2: f64,
    /// Covariance of all `n` parameters, `sigma2 (J^T W^2 J)^-1` over the identified
    /// free parameters (from `R` by triangular solves), zero rows/columns for the
    /// others. `None` when `m <= rank` and weights are relative.
    pub covariance: Option<DMatrix<f64>>,
    /// Standard error of each parameter; `None` for fixed or not identified ones.
    pub standard_errors: Vec<Option<f64>>,
}

/// Gauss-Newton: the paper's iterative re-linearisation (section 2.1.5, eq. (12)),
/// each step the basic least-squares solution of `J_s dz = -W r` by pivoted QR,
/// halved until the cost decreases.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussNewton {
    /// Shared options.
    pub options: SolverOptions,
    /// Maximum number of step halvings when a full step raises the cost (default 10;
    /// 0 gives the undamped iteration of the paper).
    pub max_halvings: usize,
}

impl Default for GaussNewton {
    fn default() -> Self {
        Self {
            options: SolverOptions::default(),
            max_halvings: 10,
        }
    }
}

impl GaussNewton {
    /// Default parameters, to be adjusted and then [`checked`](Self::check).
    pub fn params() -> Self {
        Self::default()
    }
    /// Sets `options.max_iterations`.
    pub fn max_iterations(mut self, n: usize) -> Self {
        self.options.max_iterations = n;
        self
    }
    /// Validates the options.
    ///
    /// # Errors
    /// [`OptimError::InvalidOption`] naming the option.
    pub fn check(self) -> Result<Self> {
        self.options.check()?;
        Ok(self)
    }
    /// Minimises `1/2 ||W r(x)||^2` from `x0`.
    ///
    /// # Errors
    /// Dimension mismatches, invalid setup, non-finite residuals or Jacobians, and
    /// failures of the caller's model.
    pub fn solve<P: Jacobian + ?Sized>(
        &self,
        problem: &P,
        x0: &[f64],
        setup: &ProblemSetup,
        observer: &mut dyn Observer,
    ) -> Result<SolveReport> {
        self.options.check()?;
        Solver::new(problem, x0, setup, &self.options)?
            .run(Method::GaussNewton(self.max_halvings), observer)
    }
}

/// Levenberg-Marquardt with Nielsen's damping update (Nielsen 1999; Madsen, Nielsen,
/// Tingleff 2004): each trial step solves `[J_s; sqrt(lambda) I] dz = [-W r; 0]` in
/// scaled parameters, through one pivoted QR of `J_s` per iteration and a small QR
/// of `[R11; sqrt(lambda) I]` per trial (Moré 1978).
#[derive(Debug, Clone, PartialEq)]
pub struct LevenbergMarquardt {
    /// Shared options.
    pub options: SolverOptions,
    /// Initial damping relative to `max_j ||J_s,j||^2` (Nielsen's tau), default `1e-3`, `> 0`.
    pub initial_damping: f64,
    /// Geodesic acceleration (Transtrum and Sethna 2012, as in GSL's
    /// `gsl_multifit_nlinear`): each trial step `v` gains half the
    /// second-order correction `a`, the damped least-squares solution for
    /// the residual's second directional derivative along `v` (by a finite
    /// difference: one more residual evaluation per trial); a trial whose
    /// `2 ||a|| / ||v||` exceeds this value is refused as too curved and the
    /// damping raised. For residuals curved along a narrow valley, where the
    /// plain iteration creeps by many small steps. Default `None` (plain
    /// Levenberg-Marquardt); GSL's choice is 0.75; `> 0`.
    pub geodesic_acceleration: Option<f64>,
}

impl Default for LevenbergMarquardt {
    fn default() -> Self {
        Self {
            options: SolverOptions::default(),
            initial_damping: 1e-3,
            geodesic_acceleration: None,
        }
    }
}

impl LevenbergMarquardt {
    /// Default parameters, to be adjusted and then [`checked`](Self::check).
    pub fn params() -> Self {
        Self::default()
    }
    /// Sets `options.max_iterations`.
    pub fn max_iterations(mut self, n: usize) -> Self {
        self.options.max_iterations = n;
        self
    }
    /// Validates the options.
    ///
    /// # Errors
    /// [`OptimError::InvalidOption`] naming the option.
    pub fn check(self) -> Result<Self> {
        self.options.check()?;
        if !(self.initial_damping.is_finite() && self.initial_damping > 0.0) {
            return Err(invalid(
                "initial_damping",
                self.initial_damping,
                "must be finite and > 0",
            ));
        }
        if let Some(alpha) = self.geodesic_acceleration {
            if !(alpha.is_finite() && alpha > 0.0) {
                return Err(invalid(
                    "geodesic_acceleration",
                    alpha,
                    "must be finite and > 0",
                ));
            }
        }
        Ok(self)
    }
    /// Minimises `1/2 ||W r(x)||^2` from `x0`.
    ///
    /// # Errors
    /// As [`GaussNewton::solve`].
    pub fn solve<P: Jacobian + ?Sized>(
        &self,
        problem: &P,
        x0: &[f64],
        setup: &ProblemSetup,
        observer: &mut dyn Observer,
    ) -> Result<SolveReport> {
        let checked = self.clone().check()?;
        Solver::new(problem, x0, setup, &checked.options)?.run(
            Method::LevenbergMarquardt(checked.initial_damping, checked.geodesic_acceleration),
            observer,
        )
    }
}

#[derive(Clone, Copy)]
enum Method {
    GaussNewton(usize),
    /// Initial damping, geodesic acceleration limit.
    LevenbergMarquardt(f64, Option<f64>),
}

/// All buffers of one solve, allocated once.
struct Solver<'a, P: ?Sized> {
    problem: &'a P,
    setup: &'a ProblemSetup,
    options: &'a SolverOptions,
    m: usize,
    n: usize,
    free: Vec<usize>,
    weights: Vec<f64>,
    scales: Vec<f64>,
    x: Vec<f64>,
    x_trial: Vec<f64>,
    residual: Vec<f64>,
    residual_trial: Vec<f64>,
    jacobian: Mat<f64>,
    qr: PivotedQr,
    /// Free columns (by position in `free`) found beyond the numerical rank at some
    /// iteration: never updated again, so that one of two collinear parameters does
    /// not take turns with the other.
    frozen: Vec<bool>,
    /// `Q^T W r`, then reused.
    qtr: Vec<f64>,
    step: Vec<f64>,
    /// Geodesic acceleration: the residual's second directional derivative
    /// (length m), then `Q^T` of it; and the acceleration (length nf).
    second_derivative: Vec<f64>,
    acceleration: Vec<f64>,
    work: Vec<f64>,
    work_rhs: Vec<f64>,
    residual_evaluations: usize,
    jacobian_evaluations: usize,
    /// The error of the last trial point that could not be evaluated, while
    /// no later trial was evaluated (see [`Self::trial_cost`]).
    failed_trial: Option<OptimError>,
    /// Trial points that could not be evaluated, and the last one's error
    /// with its cause.
    refusals: (usize, Option<String>),
}

impl<'a, P: Jacobian + ?Sized> Solver<'a, P> {
    fn new(
        problem: &'a P,
        x0: &[f64],
        setup: &'a ProblemSetup,
        options: &'a SolverOptions,
    ) -> Result<Self> {
        let m = problem.n_residuals();
        let n = problem.n_params();
        check_len("x0", n, x0.len())?;
        if let Some(j) = x0.iter().position(|v| !v.is_finite()) {
            return Err(OptimError::NonFiniteInput {
                argument: "x0",
                index: j,
            });
        }
        let free = setup.validate(m, n)?;
        let nf = free.len();
        let weights = setup.row_weights.clone().unwrap_or_else(|| vec![1.0; m]);
        let scales = match &setup.column_scaling {
            ColumnScaling::Fixed(s) => s.clone(),
            _ => vec![1.0; n],
        };
        Ok(Self {
            problem,
            setup,
            options,
            m,
            n,
            free,
            weights,
            scales,
            x: x0.to_vec(),
            x_trial: x0.to_vec(),
            residual: vec![0.0; m],
            residual_trial: vec![0.0; m],
            jacobian: Mat::zeros(m, n),
            qr: PivotedQr::new(m, nf),
            frozen: vec![false; nf],
            qtr: vec![0.0; m],
            step: vec![0.0; nf],
            second_derivative: Vec::new(),
            acceleration: vec![0.0; nf],
            work: vec![0.0; 2 * nf * nf],
            work_rhs: vec![0.0; 2 * nf],
            residual_evaluations: 0,
            jacobian_evaluations: 0,
            failed_trial: None,
            refusals: (0, None),
        })
    }

    /// Evaluates the weighted residual at `x_trial` into `residual_trial`; returns the cost.
    fn evaluate_trial(&mut self) -> Result<f64> {
        self.residual_evaluations += 1;
        let k = self.residual_evaluations;
        self.problem
            .residuals(&self.x_trial, &mut self.residual_trial)
            .map_err(|source| OptimError::Problem {
                evaluation: k,
                source,
            })?;
        let mut ssr = 0.0;
        for (i, (r, w)) in self
            .residual_trial
            .iter_mut()
            .zip(&self.weights)
            .enumerate()
        {
            if !r.is_finite() {
                return Err(OptimError::NonFiniteResidual {
                    evaluation: k,
                    row: i,
                    value: *r,
                });
            }
            *r *= w;
            ssr += *r * *r;
        }
        Ok(0.5 * ssr)
    }

    /// The cost at a trial point, or infinity when the problem cannot be
    /// evaluated there (its error, or a non-finite residual): the step is then
    /// refused as if the cost had risen, and shortened or damped further, as
    /// a trust region does. The error is kept until a later trial is
    /// evaluated; the solver returns it if it stops on it.
    fn trial_cost(&mut self) -> f64 {
        match self.evaluate_trial() {
            Ok(cost) => {
                self.failed_trial = None;
                cost
            }
            Err(error) => {
                let mut message = error.to_string();
                if let Some(cause) = std::error::Error::source(&error) {
                    message = format!("{message}: {cause}");
                }
                self.refusals = (self.refusals.0 + 1, Some(message));
                self.failed_trial = Some(error);
                f64::INFINITY
            }
        }
    }

    /// Evaluates J at `x` and updates the scales.
    fn linearise(&mut self) -> Result<()> {
        self.jacobian_evaluations += 1;
        let k = self.jacobian_evaluations;
        self.problem
            .jacobian(&self.x, self.jacobian.as_mut())
            .map_err(|source| OptimError::Problem {
                evaluation: k,
                source,
            })?;
        let adaptive = matches!(self.setup.column_scaling, ColumnScaling::ColumnNorm);
        for &j in &self.free {
            let column = self.jacobian.col_as_slice(j);
            let mut norm2 = 0.0;
            for (v, w) in column.iter().zip(&self.weights) {
                let wv = v * w;
                norm2 += wv * wv;
            }
            // One finiteness test per column; the offending row is searched only on failure.
            if !norm2.is_finite() {
                let i = column.iter().position(|v| !v.is_finite()).unwrap_or(0);
                return Err(OptimError::NonFiniteJacobian {
                    evaluation: k,
                    row: i,
                    parameter: self.problem.parameter_name(j),
                    value: column[i],
                });
            }
            if adaptive {
                let norm = norm2.sqrt();
                if norm > 0.0 && (k == 1 || norm > self.scales[j]) {
                    self.scales[j] = norm;
                }
            }
        }
        Ok(())
    }

    /// Factorises `W J S^-1` over the free columns (frozen ones zeroed when asked),
    /// sets `qtr = Q^T W r` and returns the numerical rank.
    fn factorize(&mut self, zero_frozen: bool) -> usize {
        let target = self.qr.matrix_mut();
        for (c, &j) in self.free.iter().enumerate() {
            let dst = target.col_as_slice_mut(c);
            if zero_frozen && self.frozen[c] {
                dst.fill(0.0);
                continue;
            }
            let inv_scale = 1.0 / self.scales[j];
            let src = self.jacobian.col_as_slice(j);
            for ((d, s), w) in dst.iter_mut().zip(src).zip(&self.weights) {
                *d = s * w * inv_scale;
            }
        }
        self.qr.factorize();
        self.qtr.copy_from_slice(&self.residual);
        self.qr.apply_qt(&mut self.qtr);
        self.qr.rank(self.options.rank_tolerance)
    }

    /// Factorises with the frozen columns zeroed, freezing any new column found beyond
    /// the rank, and refactorises if that happened; returns the rank.
    fn factorize_for_step(&mut self) -> usize {
        loop {
            let rank = self.factorize(true);
            let mut newly_frozen = false;
            for k in rank..self.free.len() {
                let c = self.qr.perm()[k];
                newly_frozen |= !self.frozen[c];
                self.frozen[c] = true;
            }
            if !newly_frozen {
                return rank;
            }
        }
    }

    fn frozen_names(&self) -> Vec<String> {
        (0..self.free.len())
            .filter(|&c| self.frozen[c])
            .map(|c| self.problem.parameter_name(self.free[c]))
            .collect()
    }

    /// Max cosine between the residual and the scaled Jacobian columns, from R and Q^T r.
    fn gradient_cosine(&self, residual_norm: f64) -> f64 {
        let r = self.qr.r();
        let size = self.qr.size();
        let mut worst: f64 = 0.0;
        for k in 0..self.free.len() {
            let top = size.min(k + 1);
            let dot: f64 = (0..top).map(|i| r[(i, k)] * self.qtr[i]).sum();
            let col_norm: f64 = (0..top).map(|i| r[(i, k)] * r[(i, k)]).sum::<f64>().sqrt();
            if col_norm > 0.0 {
                worst = worst.max(dot.abs() / (col_norm * residual_norm));
            }
        }
        worst
    }

    fn run(mut self, method: Method, observer: &mut dyn Observer) -> Result<SolveReport> {
        let opts = self.options;
        self.x_trial.copy_from_slice(&self.x);
        let mut cost = self.evaluate_trial()?;
        std::mem::swap(&mut self.residual, &mut self.residual_trial);
        let start = self.residual.clone();
        let mut history = vec![cost];
        let mut moved = false;
        let mut iterations = 0;
        let mut damping = 0.0;
        let mut nu = 2.0;
        let nf = self.free.len();
        let mut rank = 0;
        let mut linearised = false;
        let termination = loop {
            if opts.cancel.as_ref().is_some_and(CancelToken::is_cancelled) {
                break Termination::Cancelled;
            }
            if cost == 0.0 {
                break Termination::ZeroResidual;
            }
            if nf == 0 {
                break Termination::SmallStep;
            }
            self.linearise()?;
            linearised = true;
            rank = self.factorize_for_step();
            if opts.fail_on_rank_deficiency && rank < nf {
                break Termination::RankDeficient {
                    parameters: self.frozen_names(),
                };
            }
            if let (0, Method::LevenbergMarquardt(tau, _)) = (iterations, method) {
                let r = self.qr.r();
                let max_diag = (0..nf)
                    .map(|k| {
                        (0..self.qr.size().min(k + 1))
                            .map(|i| r[(i, k)] * r[(i, k)])
                            .sum::<f64>()
                    })
                    .fold(0.0, f64::max);
                damping = tau * max_diag.max(f64::MIN_POSITIVE);
            }
            if self.gradient_cosine((2.0 * cost).sqrt()) <= opts.gradient_tolerance {
                break Termination::SmallGradient;
            }
            if iterations >= opts.max_iterations {
                break Termination::MaxIterations;
            }
            iterations += 1;
            // Trial steps until one is accepted or a stopping rule fires.
            let outcome = match method {
                Method::GaussNewton(max_halvings) => {
                    self.gauss_newton_step(rank, cost, max_halvings)?
                }
                Method::LevenbergMarquardt(_, geodesic) => {
                    self.levenberg_marquardt_step(rank, cost, &mut damping, &mut nu, geodesic)?
                }
            };
            match outcome {
                StepOutcome::Accepted {
                    new_cost,
                    step_norm,
                    z_norm,
                } => {
                    std::mem::swap(&mut self.x, &mut self.x_trial);
                    std::mem::swap(&mut self.residual, &mut self.residual_trial);
                    moved = true;
                    let decrease = cost - new_cost;
                    cost = new_cost;
                    history.push(cost);
                    linearised = false;
                    let state = IterationState {
                        iteration: iterations,
                        cost,
                        step_norm,
                        damping,
                        rank,
                        evaluations: self.residual_evaluations,
                        x: self.x.clone(),
                        weighted_residuals: self.residual.clone(),
                    };
                    if observer.observe(&state) == Control::Stop {
                        break Termination::StoppedByObserver;
                    }
                    if step_norm <= opts.step_tolerance * (z_norm + opts.step_tolerance) {
                        break Termination::SmallStep;
                    }
                    if decrease <= opts.cost_tolerance * (cost + decrease) {
                        break Termination::SmallCostDecrease;
                    }
                }
                StepOutcome::Stop(t) => {
                    history.push(cost);
                    break t;
                }
            }
        };
        // Stuck at the start on trial points the problem could not evaluate
        // (no step accepted, none evaluated after them): the problem's error
        // says why better than a stop for lack of descent.
        if let (Some(error), false) = (self.failed_trial.take(), moved) {
            return Err(error);
        }
        if !linearised && nf > 0 {
            self.linearise()?;
        }
        // When the loop stopped right after factorising at the final x with nothing
        // frozen, that factorisation is the one the report needs.
        let current = (linearised && !self.frozen.contains(&true)).then_some(rank);
        self.finish(termination, cost, (history, start), iterations, current)
    }

    /// Writes `x_trial = x + t * S^-1 P dz` for the first `rank` permuted entries of `step`.
    fn set_trial(&mut self, rank: usize, t: f64) {
        self.x_trial.copy_from_slice(&self.x);
        for k in 0..rank {
            let j = self.free[self.qr.perm()[k]];
            self.x_trial[j] += t * self.step[k] / self.scales[j];
        }
    }

    fn z_norm(&self) -> f64 {
        self.free
            .iter()
            .map(|&j| (self.x[j] * self.scales[j]).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    fn gauss_newton_step(
        &mut self,
        rank: usize,
        cost: f64,
        max_halvings: usize,
    ) -> Result<StepOutcome> {
        for k in 0..rank {
            self.step[k] = -self.qtr[k];
        }
        back_substitute(self.qr.r(), rank, &mut self.step);
        let full_norm = self.step[..rank].iter().map(|v| v * v).sum::<f64>().sqrt();
        let z_norm = self.z_norm();
        let mut t = 1.0;
        for _ in 0..=max_halvings {
            if self.residual_evaluations >= self.options.max_evaluations {
                return Ok(StepOutcome::Stop(Termination::MaxEvaluations));
            }
            self.set_trial(rank, t);
            let new_cost = self.trial_cost();
            if new_cost <= cost {
                return Ok(StepOutcome::Accepted {
                    new_cost,
                    step_norm: t * full_norm,
                    z_norm,
                });
            }
            if t * full_norm <= self.options.step_tolerance * (z_norm + self.options.step_tolerance)
            {
                return Ok(StepOutcome::Stop(Termination::SmallStep));
            }
            t *= 0.5;
        }
        Ok(StepOutcome::Stop(Termination::NoDescent))
    }

    fn levenberg_marquardt_step(
        &mut self,
        rank: usize,
        cost: f64,
        damping: &mut f64,
        nu: &mut f64,
        geodesic: Option<f64>,
    ) -> Result<StepOutcome> {
        let z_norm = self.z_norm();
        loop {
            if self.residual_evaluations >= self.options.max_evaluations {
                return Ok(StepOutcome::Stop(Termination::MaxEvaluations));
            }
            for k in 0..rank {
                self.step[k] = -self.qtr[k];
            }
            damped_solve(
                self.qr.r(),
                rank,
                *damping,
                &mut self.step,
                &mut self.work,
                &mut self.work_rhs,
            );
            let step_norm = self.step[..rank].iter().map(|v| v * v).sum::<f64>().sqrt();
            // Predicted decrease of the linear model: -(c . R11 dz) - 1/2 ||R11 dz||^2.
            let r = self.qr.r();
            let mut predicted = 0.0;
            for i in 0..rank {
                let rdz: f64 = (i..rank).map(|j| r[(i, j)] * self.step[j]).sum();
                predicted -= self.qtr[i] * rdz + 0.5 * rdz * rdz;
            }
            // Refused when the acceleration says the residual bends too much
            // over the step (and counted as a failed trial).
            let shaped = match geodesic {
                Some(alpha) if rank > 0 => {
                    if self.residual_evaluations + 1 >= self.options.max_evaluations {
                        return Ok(StepOutcome::Stop(Termination::MaxEvaluations));
                    }
                    self.accelerate(rank, *damping, alpha)?
                }
                _ => true,
            };
            if shaped {
                self.set_trial(rank, 1.0);
                let new_cost = self.trial_cost();
                // The predicted decrease is the velocity's (the acceleration
                // is a second-order correction), as in GSL.
                let rho = if predicted > 0.0 {
                    (cost - new_cost) / predicted
                } else {
                    -1.0
                };
                if rho > 0.0 && new_cost <= cost {
                    *damping *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                    *nu = 2.0;
                    let step_norm = self.step[..rank].iter().map(|v| v * v).sum::<f64>().sqrt();
                    return Ok(StepOutcome::Accepted {
                        new_cost,
                        step_norm,
                        z_norm,
                    });
                }
            }
            if step_norm <= self.options.step_tolerance * (z_norm + self.options.step_tolerance) {
                return Ok(StepOutcome::Stop(Termination::SmallStep));
            }
            *damping *= *nu;
            *nu *= 2.0;
            // Only a step of zero length would be left; stop before the damping overflows.
            if !(*damping * *nu).is_finite() {
                return Ok(StepOutcome::Stop(Termination::NoDescent));
            }
        }
    }

    /// Geodesic acceleration of the velocity `v` in `step` (scaled, permuted,
    /// first `rank` entries): `r_vv = (2 / h) ((r(x + h v) - r(x)) / h - J v)`
    /// with `h = 0.1` (Transtrum and Sethna 2012), then `a` solves the same
    /// damped system as `v` with `r_vv` in place of `r`. Adds `a / 2` to the
    /// step and returns true, or leaves the step and returns false when
    /// `2 ||a|| > alpha ||v||`.
    fn accelerate(&mut self, rank: usize, damping: f64, alpha: f64) -> Result<bool> {
        const H: f64 = 0.1;
        self.set_trial(rank, H);
        if !self.trial_cost().is_finite() {
            // The bend cannot be measured: refuse the step, as for a bend
            // too strong.
            return Ok(false);
        }
        self.second_derivative.clear();
        self.second_derivative.resize(self.m, 0.0);
        // J v, unweighted, over the columns the step moves.
        for k in 0..rank {
            let j = self.free[self.qr.perm()[k]];
            let c = self.step[k] / self.scales[j];
            for (d, v) in self
                .second_derivative
                .iter_mut()
                .zip(self.jacobian.col_as_slice(j))
            {
                *d += v * c;
            }
        }
        for (((d, r_trial), r), w) in self
            .second_derivative
            .iter_mut()
            .zip(&self.residual_trial)
            .zip(&self.residual)
            .zip(&self.weights)
        {
            *d = 2.0 / H * ((r_trial - r) / H - w * *d);
        }
        self.qr.apply_qt(&mut self.second_derivative);
        for k in 0..rank {
            self.acceleration[k] = -self.second_derivative[k];
        }
        damped_solve(
            self.qr.r(),
            rank,
            damping,
            &mut self.acceleration,
            &mut self.work,
            &mut self.work_rhs,
        );
        let a_norm = self.acceleration[..rank]
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt();
        let v_norm = self.step[..rank].iter().map(|v| v * v).sum::<f64>().sqrt();
        // False as well for a non-finite acceleration.
        let within = 2.0 * a_norm <= alpha * v_norm;
        if !within {
            return Ok(false);
        }
        for k in 0..rank {
            self.step[k] += 0.5 * self.acceleration[k];
        }
        Ok(true)
    }

    fn finish(
        mut self,
        termination: Termination,
        cost: f64,
        (cost_history, start_weighted_residuals): (Vec<f64>, Vec<f64>),
        iterations: usize,
        current_rank: Option<usize>,
    ) -> Result<SolveReport> {
        let nf = self.free.len();
        let n = self.n;
        let parameter_names: Vec<String> = (0..n).map(|j| self.problem.parameter_name(j)).collect();
        let mut singular_values = Vec::new();
        let mut condition_number = f64::INFINITY;
        let mut covariance = None;
        let mut standard_errors = vec![None; n];
        let mut not_identified = Vec::new();
        let ssr = 2.0 * cost;
        // The reported rank and singular values are those of the whole scaled Jacobian;
        // the covariance is that of the parameters actually estimated.
        let rank = match current_rank {
            Some(rank) => rank,
            None if nf > 0 => self.factorize(false),
            None => 0,
        };
        let sigma2 = if self.setup.weights_are_absolute {
            1.0
        } else if self.m > rank {
            ssr / (self.m - rank) as f64
        } else {
            f64::NAN
        };
        if nf > 0 {
            let size = self.qr.size();
            let r = self.qr.r();
            if self.options.singular_values {
                let upper =
                    Mat::<f64>::from_fn(size, nf, |i, j| if i <= j { r[(i, j)] } else { 0.0 });
                singular_values = upper.singular_values().map_err(|_| OptimError::Numerical {
                    what: "singular values of R did not converge",
                })?;
                singular_values.resize(nf, 0.0);
                let smax = singular_values.first().copied().unwrap_or(0.0);
                let smin = singular_values.last().copied().unwrap_or(0.0);
                condition_number = if smin > 0.0 {
                    smax / smin
                } else {
                    f64::INFINITY
                };
            } else {
                condition_number = f64::NAN;
            }
            for k in rank..nf {
                let c = self.qr.perm()[k];
                self.frozen[c] = true;
            }
            not_identified = (0..nf)
                .filter(|&c| self.frozen[c])
                .map(|c| self.free[c])
                .collect();
            let rank = if not_identified.is_empty() {
                rank
            } else {
                self.factorize(true)
            };
            let r = self.qr.r();
            if sigma2.is_finite() {
                // Cov_z = R11^-1 R11^-T over the identified permuted columns; columns of
                // R11^-1 come from triangular solves of unit vectors, no normal matrix.
                let mut r_inv = Mat::<f64>::zeros(rank, rank);
                let mut e = vec![0.0; rank];
                for c in 0..rank {
                    e.fill(0.0);
                    e[c] = 1.0;
                    back_substitute(r, rank, &mut e);
                    for i in 0..rank {
                        r_inv[(i, c)] = e[i];
                    }
                }
                let mut cov = DMatrix::<f64>::zeros(n, n);
                for a in 0..rank {
                    let ja = self.free[self.qr.perm()[a]];
                    for b in 0..rank {
                        let jb = self.free[self.qr.perm()[b]];
                        let dot: f64 = (a.max(b)..rank)
                            .map(|k| r_inv[(a, k)] * r_inv[(b, k)])
                            .sum();
                        cov[(ja, jb)] = sigma2 * dot / (self.scales[ja] * self.scales[jb]);
                    }
                }
                for a in 0..rank {
                    let j = self.free[self.qr.perm()[a]];
                    standard_errors[j] = Some(cov[(j, j)].sqrt());
                }
                covariance = Some(cov);
            }
        }
        let mut column_scales = vec![1.0; n];
        for &j in &self.free {
            column_scales[j] = self.scales[j];
        }
        Ok(SolveReport {
            x: self.x,
            parameter_names,
            cost,
            cost_history,
            start_weighted_residuals,
            iterations,
            residual_evaluations: self.residual_evaluations,
            jacobian_evaluations: self.jacobian_evaluations,
            termination,
            n_free: nf,
            rank,
            not_identified,
            singular_values,
            condition_number,
            column_scales,
            sigma2,
            covariance,
            standard_errors,
            refused_trials: self.refusals.0,
            last_refusal: self.refusals.1,
        })
    }
}

enum StepOutcome {
    Accepted {
        new_cost: f64,
        step_norm: f64,
        z_norm: f64,
    },
    Stop(Termination),
}
