//! Differential evolution on classical test functions, seeded.

use flexcal_optim::*;

fn rosenbrock(x: &[f64]) -> f64 {
    x.windows(2)
        .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
        .sum()
}

fn rastrigin(x: &[f64]) -> f64 {
    10.0 * x.len() as f64
        + x.iter()
            .map(|v| v * v - 10.0 * (2.0 * std::f64::consts::PI * v).cos())
            .sum::<f64>()
}

#[test]
fn finds_rosenbrock_minimum() {
    for d in [2usize, 4] {
        let de = DifferentialEvolution {
            seed: 42,
            max_generations: 3000,
            ..Default::default()
        };
        let report = de
            .minimize(rosenbrock, &vec![-2.0; d], &vec![2.0; d])
            .unwrap();
        assert!(report.best_value < 1e-8, "d = {d}: {report:?}");
        for v in &report.best_x {
            assert!((v - 1.0).abs() < 1e-3, "{:?}", report.best_x);
        }
        assert!(report.best_value_history.windows(2).all(|w| w[1] <= w[0]));
        assert_eq!(report.best_value_history.len(), report.generations + 1);
    }
}

#[test]
fn finds_rastrigin_global_minimum_among_many_local_ones() {
    let de = DifferentialEvolution {
        seed: 7,
        target: Some(1e-10),
        ..Default::default()
    };
    let report = de
        .minimize(rastrigin, &[-5.12, -5.12, -5.12], &[5.12, 5.12, 5.12])
        .unwrap();
    assert_eq!(report.termination, SearchTermination::TargetReached);
    assert!(
        report.best_x.iter().all(|v| v.abs() < 1e-5),
        "{:?}",
        report.best_x
    );
}

#[test]
fn same_seed_same_run_and_box_respected() {
    let de = DifferentialEvolution {
        seed: 3,
        max_generations: 30,
        ..Default::default()
    };
    let mut outside = 0;
    let lower = [0.5, -1.0];
    let upper = [1.5, 0.2];
    let a = de
        .minimize(
            |x: &[f64]| {
                if x.iter()
                    .zip(&lower)
                    .zip(&upper)
                    .any(|((v, l), u)| v < l || v > u)
                {
                    outside += 1;
                }
                rosenbrock(x)
            },
            &lower,
            &upper,
        )
        .unwrap();
    assert_eq!(outside, 0);
    let b = de.minimize(rosenbrock, &lower, &upper).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.termination, SearchTermination::MaxGenerations);
    assert_eq!(a.evaluations, 20 * 31);
    let limited = DifferentialEvolution {
        seed: 3,
        max_evaluations: 100,
        ..Default::default()
    };
    let c = limited.minimize(rosenbrock, &lower, &upper).unwrap();
    assert_eq!(c.termination, SearchTermination::MaxEvaluations);
    assert!(c.evaluations <= 100);
}

#[test]
fn non_finite_values_are_never_kept() {
    let de = DifferentialEvolution {
        seed: 1,
        max_generations: 50,
        ..Default::default()
    };
    let report = de
        .minimize(
            |x: &[f64]| {
                if x[0] < 0.0 {
                    f64::NAN
                } else {
                    (x[0] - 0.3).powi(2) + x[1] * x[1]
                }
            },
            &[-1.0, -1.0],
            &[1.0, 1.0],
        )
        .unwrap();
    assert!(report.best_value.is_finite() && report.best_value < 1e-6);
}

#[test]
fn invalid_options_and_boxes_are_errors() {
    let bad = DifferentialEvolution {
        crossover_probability: 1.5,
        ..Default::default()
    };
    assert!(matches!(
        bad.minimize(rosenbrock, &[0.0], &[1.0]),
        Err(OptimError::InvalidOption {
            name: "crossover_probability",
            ..
        })
    ));
    let de = DifferentialEvolution::default();
    assert!(matches!(
        de.minimize(rosenbrock, &[0.0, 0.0], &[1.0]),
        Err(OptimError::DimensionMismatch {
            argument: "upper",
            ..
        })
    ));
    assert!(matches!(
        de.minimize(rosenbrock, &[2.0], &[1.0]),
        Err(OptimError::InvalidOption { name: "lower", .. })
    ));
    assert!(matches!(
        de.minimize(rosenbrock, &[f64::NAN], &[1.0]),
        Err(OptimError::NonFiniteInput {
            argument: "lower",
            index: 0
        })
    ));
}
