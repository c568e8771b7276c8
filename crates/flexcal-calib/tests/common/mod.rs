//! Shared checks and draws of the integration tests (each test file uses
//! part of them).
#![allow(dead_code)]

use faer::Mat;
use flexcal_calib::GeometricErrorModel;
use flexcal_calib::rotation_from_vector;
use flexcal_optim::{Jacobian, Residuals};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Asserts that the analytic Jacobian of `problem` at `x` matches central
/// differences with step `step(j)` per unknown: entry by entry within
/// `tolerance(analytic column, central difference)`. Returns the Jacobian.
pub fn assert_jacobian_matches(
    label: &str,
    problem: &GeometricErrorModel<'_>,
    x: &[f64],
    step: &dyn Fn(usize) -> f64,
    tolerance: &dyn Fn(&[f64], f64) -> f64,
) -> Mat<f64> {
    let (m, n) = (problem.n_residuals(), problem.n_unknowns());
    let mut jac = Mat::<f64>::zeros(m, n);
    problem.jacobian(x, jac.as_mut()).unwrap();
    let (mut plus, mut minus) = (vec![0.0; m], vec![0.0; m]);
    for j in 0..n {
        let h = step(j);
        let mut xp = x.to_vec();
        xp[j] += h;
        let mut xm = x.to_vec();
        xm[j] -= h;
        problem.residuals(&xp, &mut plus).unwrap();
        problem.residuals(&xm, &mut minus).unwrap();
        let column: Vec<f64> = (0..m).map(|i| jac[(i, j)]).collect();
        for i in 0..m {
            let fd = (plus[i] - minus[i]) / (2.0 * h);
            assert!(
                (fd - jac[(i, j)]).abs() < tolerance(&column, fd),
                "{label}: row {i}, unknown {}: analytic {} vs central difference {fd}",
                problem.names()[j],
                jac[(i, j)]
            );
        }
    }
    jac
}

/// A UR10 configuration (rad) drawn over a working range: shoulder from
/// -2.6 to -0.5 rad (arm above the base), elbow within +-2.2 rad, the other
/// joints within +-2.5 rad.
pub fn ur10_configuration(rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..6)
        .map(|k| match k {
            1 => rng.random_range(-2.6..-0.5),
            2 => rng.random_range(-2.2..2.2),
            _ => rng.random_range(-2.5..2.5),
        })
        .collect()
}

/// A measurement frame (tracker 3 m away, turned) and a target offset
/// (turned, off the TCP) generic enough that no Jacobian entry vanishes by
/// symmetry.
pub fn generic_frame_and_target() -> (Isometry3<f64>, Isometry3<f64>) {
    (
        Isometry3::from_parts(
            Translation3::new(0.3, -3.1, 0.2),
            rotation_from_vector(&Vector3::new(0.1, -0.2, 2.0)),
        ),
        Isometry3::from_parts(
            Translation3::new(0.01, 0.02, 0.11),
            rotation_from_vector(&Vector3::new(0.3, 0.1, -1.2)),
        ),
    )
}
