//! Gauss-Newton and Levenberg-Marquardt: recovery of known parameters, covariance
//! against closed forms, masks, weights, observers and errors.

mod common;

use approx::assert_relative_eq;
use common::*;
use faer::MatMut;
use flexcal_optim::*;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn exponential(noise: f64, seed: u64) -> (ExponentialFit, [f64; 3]) {
    let truth = [2.5, -1.3, 0.4];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, noise.max(1e-300)).unwrap();
    let t: Vec<f64> = (0..60).map(|i| i as f64 * 0.05).collect();
    let y = t
        .iter()
        .map(|&t| {
            ExponentialFit::model(&truth, t)
                + if noise > 0.0 {
                    normal.sample(&mut rng)
                } else {
                    0.0
                }
        })
        .collect();
    (ExponentialFit { t, y }, truth)
}

fn arm(redundant: bool, poses: usize) -> PlanarArm {
    let joints = arm_configurations(poses, 11);
    let mut truth = ARM_TRUE.to_vec();
    if redundant {
        truth.push(0.0);
    }
    let measured = joints
        .iter()
        .map(|q| PlanarArm::tcp(&truth, q, redundant))
        .collect();
    PlanarArm {
        joints,
        measured,
        redundant_offset: redundant,
    }
}

#[test]
fn test_problems_have_correct_analytic_jacobians() {
    let (exp, _) = exponential(0.0, 1);
    assert!(max_jacobian_error(&exp, &[1.7, -0.9, 0.2], 1e-6) < 1e-8);
    let arm = arm(true, 10);
    let mut x = ARM_NOMINAL.to_vec();
    x.push(0.02);
    assert!(max_jacobian_error(&arm, &x, 1e-6) < 1e-8);
}

#[test]
fn both_solvers_recover_exponential_parameters_from_exact_data() {
    let (problem, truth) = exponential(0.0, 1);
    let x0 = [1.0, -0.5, 0.0];
    let setup = ProblemSetup::default();
    let lm = LevenbergMarquardt::params()
        .check()
        .unwrap()
        .solve(&problem, &x0, &setup, &mut ())
        .unwrap();
    let gn = GaussNewton::params()
        .check()
        .unwrap()
        .solve(&problem, &x0, &setup, &mut ())
        .unwrap();
    for report in [&lm, &gn] {
        assert!(
            report.termination.is_converged(),
            "{:?}",
            report.termination
        );
        for (estimate, expected) in report.x.iter().zip(truth) {
            assert_relative_eq!(*estimate, expected, epsilon = 1e-8);
        }
        assert_eq!(report.rank, 3);
        assert_eq!(report.cost_history.len(), report.iterations + 1);
        assert!(report.cost_history.windows(2).all(|w| w[1] <= w[0]));
    }
}

#[test]
fn noisy_exponential_estimate_lies_within_its_standard_errors() {
    let (problem, truth) = exponential(0.01, 5);
    let report = LevenbergMarquardt::params()
        .check()
        .unwrap()
        .solve(
            &problem,
            &[1.0, -0.5, 0.0],
            &ProblemSetup::default(),
            &mut (),
        )
        .unwrap();
    assert!(report.termination.is_converged());
    // sigma^2 estimates the noise variance (0.01^2) within sampling error for m - n = 57.
    assert!(
        (report.sigma2.sqrt() - 0.01).abs() < 0.003,
        "sigma {}",
        report.sigma2.sqrt()
    );
    for (j, expected) in truth.iter().enumerate() {
        let se = report.standard_errors[j].unwrap();
        assert!(
            (report.x[j] - expected).abs() < 4.0 * se,
            "param {j}: {} vs {expected} (se {se})",
            report.x[j]
        );
    }
}

#[test]
fn levenberg_marquardt_calibrates_planar_arm() {
    let problem = arm(false, 20);
    let report = LevenbergMarquardt::params()
        .check()
        .unwrap()
        .solve(&problem, &ARM_NOMINAL, &ProblemSetup::default(), &mut ())
        .unwrap();
    assert!(
        report.termination.is_converged(),
        "{:?}",
        report.termination
    );
    for (estimate, expected) in report.x.iter().zip(ARM_TRUE) {
        assert_relative_eq!(*estimate, expected, epsilon = 1e-9);
    }
    assert_eq!(report.rank, 8);
    assert!(report.condition_number.is_finite() && report.condition_number > 1.0);
}

#[test]
fn redundant_parameter_is_left_unchanged_and_named() {
    let problem = arm(true, 20);
    let mut x0 = ARM_NOMINAL.to_vec();
    x0.push(0.0);
    let gauss_newton = GaussNewton::params().check().unwrap().solve(
        &problem,
        &x0,
        &ProblemSetup::default(),
        &mut (),
    );
    let levenberg_marquardt = LevenbergMarquardt::params().check().unwrap().solve(
        &problem,
        &x0,
        &ProblemSetup::default(),
        &mut (),
    );
    for report in [gauss_newton.unwrap(), levenberg_marquardt.unwrap()] {
        check_redundant_fit(&report);
    }

    let mut strict = GaussNewton::params();
    strict.options.fail_on_rank_deficiency = true;
    let report = strict
        .check()
        .unwrap()
        .solve(&problem, &x0, &ProblemSetup::default(), &mut ())
        .unwrap();
    match report.termination {
        Termination::RankDeficient { parameters } => {
            assert!(
                parameters == ["offset1"] || parameters == ["offset1_bis"],
                "{parameters:?}"
            )
        }
        other => panic!("expected rank deficiency, got {other:?}"),
    }
}

fn check_redundant_fit(report: &SolveReport) {
    assert!(
        report.termination.is_converged(),
        "{:?}",
        report.termination
    );
    assert_eq!(report.rank, 8);
    assert_eq!(report.not_identified.len(), 1);
    let skipped = report.not_identified[0];
    assert!(skipped == 5 || skipped == 8);
    assert_eq!(report.x[skipped], 0.0);
    // The fit is exact: the two offsets together carry the true offset.
    assert_relative_eq!(report.x[5] + report.x[8], ARM_TRUE[5], epsilon = 1e-9);
    assert!(report.condition_number.is_infinite() || report.condition_number > 1e12);
    assert!(report.standard_errors[skipped].is_none());
    let kept = 13 - skipped;
    assert!(report.standard_errors[kept].is_some());
}

/// `r = X beta - y`, a linear regression.
struct Linear {
    x: DMatrix<f64>,
    y: DVector<f64>,
}

impl Residuals for Linear {
    fn n_residuals(&self) -> usize {
        self.x.nrows()
    }
    fn n_params(&self) -> usize {
        self.x.ncols()
    }
    fn residuals(&self, beta: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        let r = &self.x * DVector::from_column_slice(beta) - &self.y;
        out.copy_from_slice(r.as_slice());
        Ok(())
    }
}

impl Jacobian for Linear {
    fn jacobian(&self, _beta: &[f64], mut out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        for i in 0..self.x.nrows() {
            for j in 0..self.x.ncols() {
                out[(i, j)] = self.x[(i, j)];
            }
        }
        Ok(())
    }
}

fn regression(m: usize, n: usize, seed: u64) -> Linear {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Columns of very different magnitudes, as lengths and angles would be.
    let x = DMatrix::from_fn(m, n, |_, j| {
        rng.random_range(-1.0..1.0) * 10f64.powi(j as i32 - 1)
    });
    let y = DVector::from_fn(m, |_, _| rng.random_range(-1.0..1.0));
    Linear { x, y }
}

#[test]
fn covariance_matches_closed_form_of_linear_regression() {
    let problem = regression(40, 4, 3);
    let report = GaussNewton::params()
        .check()
        .unwrap()
        .solve(&problem, &[0.0; 4], &ProblemSetup::default(), &mut ())
        .unwrap();
    // Closed form: beta = (X^T X)^-1 X^T y, Cov = s^2 (X^T X)^-1, s^2 = SSR / (m - n).
    let xtx = problem.x.transpose() * &problem.x;
    let xtx_inv = xtx.clone().try_inverse().unwrap();
    let beta = &xtx_inv * problem.x.transpose() * &problem.y;
    let ssr = (&problem.x * &beta - &problem.y).norm_squared();
    let s2 = ssr / 36.0;
    assert_relative_eq!(report.sigma2, s2, max_relative = 1e-10);
    let cov = report.covariance.as_ref().unwrap();
    for i in 0..4 {
        assert_relative_eq!(report.x[i], beta[i], max_relative = 1e-9);
        for j in 0..4 {
            assert_relative_eq!(
                cov[(i, j)],
                s2 * xtx_inv[(i, j)],
                max_relative = 1e-8,
                epsilon = 1e-14
            );
        }
        assert_relative_eq!(
            report.standard_errors[i].unwrap(),
            (s2 * xtx_inv[(i, i)]).sqrt(),
            max_relative = 1e-9
        );
    }
}

#[test]
fn absolute_weights_give_inverse_weighted_normal_matrix() {
    let problem = regression(30, 3, 4);
    let weights: Vec<f64> = (0..30).map(|i| 1.0 + (i % 3) as f64).collect();
    let setup = ProblemSetup {
        row_weights: Some(weights.clone()),
        weights_are_absolute: true,
        ..Default::default()
    };
    let report = LevenbergMarquardt::params()
        .check()
        .unwrap()
        .solve(&problem, &[0.0; 3], &setup, &mut ())
        .unwrap();
    assert_eq!(report.sigma2, 1.0);
    let w = DMatrix::from_diagonal(&DVector::from_vec(weights));
    let wx = &w * &problem.x;
    let expected = (wx.transpose() * &wx).try_inverse().unwrap();
    let cov = report.covariance.unwrap();
    for i in 0..3 {
        for j in 0..3 {
            assert_relative_eq!(
                cov[(i, j)],
                expected[(i, j)],
                max_relative = 1e-8,
                epsilon = 1e-14
            );
        }
    }
}

#[test]
fn fixed_parameters_keep_their_value() {
    let (problem, truth) = exponential(0.0, 1);
    let setup = ProblemSetup {
        fixed: vec![false, false, true],
        ..Default::default()
    };
    let x0 = [1.0, -0.5, truth[2]];
    let report = LevenbergMarquardt::params()
        .check()
        .unwrap()
        .solve(&problem, &x0, &setup, &mut ())
        .unwrap();
    assert_eq!(report.x[2], truth[2]);
    assert_relative_eq!(report.x[0], truth[0], epsilon = 1e-8);
    assert_relative_eq!(report.x[1], truth[1], epsilon = 1e-8);
    assert_eq!(report.n_free, 2);
    assert!(report.standard_errors[2].is_none());
    assert_eq!(report.covariance.unwrap()[(2, 2)], 0.0);
}

#[test]
fn observer_sees_every_iteration_and_can_stop() {
    let problem = arm(false, 20);
    let mut seen = Vec::new();
    let mut observer = |state: &IterationState| {
        seen.push(state.iteration);
        if state.iteration == 2 {
            Control::Stop
        } else {
            Control::Continue
        }
    };
    let report = LevenbergMarquardt::params()
        .check()
        .unwrap()
        .solve(
            &problem,
            &ARM_NOMINAL,
            &ProblemSetup::default(),
            &mut observer,
        )
        .unwrap();
    assert_eq!(report.termination, Termination::StoppedByObserver);
    assert_eq!(report.iterations, 2);
    assert_eq!(seen, [1, 2]);
}

/// The arm problem, cancelling a token at its `after`-th Jacobian
/// evaluation (the start of iteration `after`), as a user would from
/// another thread during that iteration.
struct CancelledDuringIteration {
    arm: PlanarArm,
    token: CancelToken,
    after: usize,
    jacobians: std::cell::Cell<usize>,
}

impl Residuals for CancelledDuringIteration {
    fn n_residuals(&self) -> usize {
        self.arm.n_residuals()
    }
    fn n_params(&self) -> usize {
        self.arm.n_params()
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        self.arm.residuals(x, out)
    }
}

impl Jacobian for CancelledDuringIteration {
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        self.jacobians.set(self.jacobians.get() + 1);
        if self.jacobians.get() == self.after {
            self.token.cancel();
        }
        self.arm.jacobian(x, out)
    }
}

#[test]
fn a_cancelled_token_ends_the_solve_within_the_iteration_under_way() {
    for gauss_newton in [false, true] {
        let token = CancelToken::new();
        let problem = CancelledDuringIteration {
            arm: arm(false, 20),
            token: token.clone(),
            after: 2,
            jacobians: Default::default(),
        };
        let solve = |options: SolverOptions| {
            if gauss_newton {
                GaussNewton {
                    options,
                    ..GaussNewton::params()
                }
                .solve(&problem, &ARM_NOMINAL, &ProblemSetup::default(), &mut ())
            } else {
                LevenbergMarquardt {
                    options,
                    ..LevenbergMarquardt::params()
                }
                .solve(&problem, &ARM_NOMINAL, &ProblemSetup::default(), &mut ())
            }
        };
        let cancelled = solve(SolverOptions {
            cancel: Some(token.clone()),
            ..SolverOptions::default()
        })
        .unwrap();
        assert_eq!(cancelled.termination, Termination::Cancelled);
        // Iteration 2 was under way when the token was cancelled: it ends,
        // and no third one starts.
        assert_eq!(cancelled.iterations, 2);
        // Its parameters are those of two full iterations.
        let two = solve(SolverOptions {
            max_iterations: 2,
            ..SolverOptions::default()
        })
        .unwrap();
        assert_eq!(two.termination, Termination::MaxIterations);
        assert_eq!(cancelled.x, two.x);
        // A token cancelled before the start stops before the first step.
        let before = solve(SolverOptions {
            cancel: Some(token),
            ..SolverOptions::default()
        })
        .unwrap();
        assert_eq!(
            (before.termination, before.iterations),
            (Termination::Cancelled, 0)
        );
        assert_eq!(before.x, ARM_NOMINAL.to_vec());
    }
}

#[test]
fn iteration_and_evaluation_limits_are_reported() {
    let problem = arm(false, 20);
    let report = LevenbergMarquardt::params()
        .max_iterations(1)
        .check()
        .unwrap()
        .solve(&problem, &ARM_NOMINAL, &ProblemSetup::default(), &mut ())
        .unwrap();
    assert_eq!(report.termination, Termination::MaxIterations);
    assert_eq!(report.iterations, 1);
    let mut limited = LevenbergMarquardt::params();
    limited.options.max_evaluations = 2;
    let report = limited
        .check()
        .unwrap()
        .solve(&problem, &ARM_NOMINAL, &ProblemSetup::default(), &mut ())
        .unwrap();
    assert_eq!(report.termination, Termination::MaxEvaluations);
    assert_eq!(report.residual_evaluations, 2);
}

struct NanAfter(ExponentialFit);

impl Residuals for NanAfter {
    fn n_residuals(&self) -> usize {
        self.0.n_residuals()
    }
    fn n_params(&self) -> usize {
        3
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        self.0.residuals(x, out)?;
        if x[0] != 1.0 {
            out[7] = f64::NAN;
        }
        Ok(())
    }
}

impl Jacobian for NanAfter {
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        self.0.jacobian(x, out)
    }
}

/// The exponential fit that cannot be evaluated outside a box (as a model
/// whose loop cannot close far from the solution), counting its refusals.
struct Walled {
    inner: ExponentialFit,
    low: [f64; 3],
    high: [f64; 3],
    refused: std::cell::Cell<usize>,
}

impl Residuals for Walled {
    fn n_residuals(&self) -> usize {
        self.inner.n_residuals()
    }
    fn n_params(&self) -> usize {
        3
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        if (0..3).any(|k| x[k] < self.low[k] || x[k] > self.high[k]) {
            self.refused.set(self.refused.get() + 1);
            return Err(format!("no value at {x:?}").into());
        }
        self.inner.residuals(x, out)
    }
}

impl Jacobian for Walled {
    fn jacobian(&self, x: &[f64], out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        self.inner.jacobian(x, out)
    }
}

#[test]
fn trial_points_the_problem_cannot_evaluate_are_refused_steps() {
    let (problem, truth) = exponential(0.0, 1);
    let x0 = [1.0, -0.5, 0.0];
    let setup = ProblemSetup::default();
    for solver in ["Levenberg-Marquardt", "Gauss-Newton"] {
        let solve = |p: &dyn Jacobian, observer: &mut dyn Observer| match solver {
            "Gauss-Newton" => GaussNewton::params()
                .check()
                .unwrap()
                .solve(p, &x0, &setup, observer),
            _ => LevenbergMarquardt::params()
                .check()
                .unwrap()
                .solve(p, &x0, &setup, observer),
        };
        // The box of the points the solver accepts on its own, with a 10 %
        // margin: the model has no value outside, as a loop that cannot
        // close far from the solution. Trials beyond it are refused.
        let mut low = x0;
        let mut high = x0;
        let mut widen = |state: &IterationState| {
            for k in 0..3 {
                low[k] = low[k].min(state.x[k]);
                high[k] = high[k].max(state.x[k]);
            }
            Control::Continue
        };
        let free = solve(&problem, &mut widen).unwrap();
        let margin: Vec<f64> = (0..3).map(|k| 0.1 * (high[k] - low[k])).collect();
        let walled = Walled {
            low: std::array::from_fn(|k| low[k] - margin[k]),
            high: std::array::from_fn(|k| high[k] + margin[k]),
            inner: problem.clone(),
            refused: std::cell::Cell::new(0),
        };
        let report = solve(&walled, &mut ())
            .unwrap_or_else(|e| panic!("{solver}: {e} after {} refusals", walled.refused.get()));
        assert!(walled.refused.get() > 0, "{solver}: no trial left the box");
        assert_eq!(report.refused_trials, walled.refused.get(), "{solver}");
        assert!(
            report
                .last_refusal
                .as_deref()
                .is_some_and(|m| m.contains("no value at")),
            "{solver}: {:?}",
            report.last_refusal
        );
        assert_eq!(free.refused_trials, 0);
        assert!(
            report.termination.is_converged(),
            "{solver}: {:?}",
            report.termination
        );
        for (k, t) in truth.iter().enumerate() {
            assert_relative_eq!(report.x[k], t, epsilon = 1e-8);
            assert_relative_eq!(free.x[k], t, epsilon = 1e-8);
        }
        // At the start the error stops the solver.
        let outside = [x0[0], x0[1], walled.high[2] + 1.0];
        let solver_at = LevenbergMarquardt::params().check().unwrap();
        assert!(matches!(
            solver_at.solve(&walled, &outside, &setup, &mut ()),
            Err(OptimError::Problem { evaluation: 1, .. })
        ));
    }
}

#[test]
fn errors_name_their_cause() {
    let (problem, _) = exponential(0.0, 1);
    let lm = LevenbergMarquardt::params().check().unwrap();
    match lm.solve(&problem, &[1.0, 2.0], &ProblemSetup::default(), &mut ()) {
        Err(OptimError::DimensionMismatch {
            argument: "x0",
            expected: 3,
            found: 2,
        }) => {}
        other => panic!("{other:?}"),
    }
    let bad = ProblemSetup {
        row_weights: Some(vec![1.0; 5]),
        ..Default::default()
    };
    assert!(matches!(
        lm.solve(&problem, &[1.0, 2.0, 0.0], &bad, &mut ()),
        Err(OptimError::DimensionMismatch {
            argument: "row_weights",
            ..
        })
    ));
    match lm.solve(
        &NanAfter(problem),
        &[1.0, -0.5, 0.0],
        &ProblemSetup::default(),
        &mut (),
    ) {
        // Every trial point has the NaN: each is refused, the damping grows
        // until no step is left, and the solver returns the last one's error.
        Err(OptimError::NonFiniteResidual {
            evaluation, row: 7, ..
        }) if evaluation >= 2 => {}
        other => panic!("{other:?}"),
    }
    let mut invalid = LevenbergMarquardt::params();
    invalid.initial_damping = -1.0;
    assert!(matches!(
        invalid.check(),
        Err(OptimError::InvalidOption {
            name: "initial_damping",
            ..
        })
    ));
}

proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: 24,
        // Seeded: every run draws the same cases.
        rng_seed: proptest::test_runner::RngSeed::Fixed(20130012),
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    })]
    /// On a full-rank linear problem one Gauss-Newton step reaches the least-squares
    /// solution: the residual is orthogonal to every column (normal equations hold).
    #[test]
    fn gauss_newton_solves_linear_least_squares(seed in 0u64..1000, m in 6usize..30, n in 1usize..5) {
        let problem = regression(m, n, seed);
        let report = GaussNewton::params().check().unwrap().solve(&problem, &vec![0.0; n], &ProblemSetup::default(), &mut ()).unwrap();
        let r = &problem.x * DVector::from_column_slice(&report.x) - &problem.y;
        for j in 0..n {
            let col = problem.x.column(j);
            prop_assert!(col.dot(&r).abs() <= 1e-9 * col.norm() * problem.y.norm().max(1.0));
        }
        prop_assert!(report.iterations <= 2);
    }
}

/// Rosenbrock's function as least squares, `r = [10 (x1 - x0^2); 1 - x0]`:
/// a narrow curved valley down to `(1, 1)`.
struct Rosenbrock;

impl Residuals for Rosenbrock {
    fn n_residuals(&self) -> usize {
        2
    }
    fn n_params(&self) -> usize {
        2
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        out[0] = 10.0 * (x[1] - x[0] * x[0]);
        out[1] = 1.0 - x[0];
        Ok(())
    }
}

impl Jacobian for Rosenbrock {
    fn jacobian(&self, x: &[f64], mut out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        out[(0, 0)] = -20.0 * x[0];
        out[(0, 1)] = 10.0;
        out[(1, 0)] = -1.0;
        out[(1, 1)] = 0.0;
        Ok(())
    }
}

#[test]
fn geodesic_acceleration_reaches_the_same_minimum_in_fewer_iterations() {
    let solve = |geodesic: Option<f64>| {
        let mut solver = LevenbergMarquardt::params();
        solver.geodesic_acceleration = geodesic;
        solver
            .check()
            .unwrap()
            .solve(&Rosenbrock, &[-1.2, 1.0], &ProblemSetup::default(), &mut ())
            .unwrap()
    };
    let plain = solve(None);
    let accelerated = solve(Some(0.75));
    for report in [&plain, &accelerated] {
        assert!(
            report.termination.is_converged(),
            "{:?}",
            report.termination
        );
        assert_relative_eq!(report.x[0], 1.0, epsilon = 1e-6);
        assert_relative_eq!(report.x[1], 1.0, epsilon = 1e-6);
    }
    assert!(
        accelerated.iterations < plain.iterations,
        "{} accelerated against {} plain",
        accelerated.iterations,
        plain.iterations
    );
    let mut invalid = LevenbergMarquardt::params();
    invalid.geodesic_acceleration = Some(0.0);
    assert!(invalid.check().is_err());
}
