//! Test fixtures shared by the integration tests: small nonlinear problems with
//! analytic Jacobians and a central finite-difference checker.
#![allow(dead_code)]

use faer::{Mat, MatMut};
use flexcal_optim::{Jacobian, ProblemError, Residuals};

/// `y_i = a exp(b t_i) + c`, parameters `[a, b, c]`.
#[derive(Clone)]
pub struct ExponentialFit {
    pub t: Vec<f64>,
    pub y: Vec<f64>,
}

impl ExponentialFit {
    pub fn model(x: &[f64], t: f64) -> f64 {
        x[0] * (x[1] * t).exp() + x[2]
    }
}

impl Residuals for ExponentialFit {
    fn n_residuals(&self) -> usize {
        self.t.len()
    }
    fn n_params(&self) -> usize {
        3
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        for ((o, &t), &y) in out.iter_mut().zip(&self.t).zip(&self.y) {
            *o = Self::model(x, t) - y;
        }
        Ok(())
    }
    fn parameter_name(&self, j: usize) -> String {
        ["a", "b", "c"][j].to_string()
    }
}

impl Jacobian for ExponentialFit {
    fn jacobian(&self, x: &[f64], mut out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        for (i, &t) in self.t.iter().enumerate() {
            let e = (x[1] * t).exp();
            out[(i, 0)] = e;
            out[(i, 1)] = x[0] * t * e;
            out[(i, 2)] = 1.0;
        }
        Ok(())
    }
}

/// A planar serial arm, the kinematic-like test problem: parameters
/// `[base_x m, base_y m, l1 m, l2 m, l3 m, offset1 rad, offset2 rad, offset3 rad]`,
/// optionally followed by `offset1_bis rad` (a second offset on joint 1, collinear with
/// `offset1` by construction). Residuals: model TCP position minus measured, per pose.
pub struct PlanarArm {
    pub joints: Vec<[f64; 3]>,
    pub measured: Vec<[f64; 2]>,
    pub redundant_offset: bool,
}

pub const ARM_NAMES: [&str; 9] = [
    "base_x",
    "base_y",
    "l1",
    "l2",
    "l3",
    "offset1",
    "offset2",
    "offset3",
    "offset1_bis",
];

impl PlanarArm {
    pub fn tcp(x: &[f64], q: &[f64; 3], redundant: bool) -> [f64; 2] {
        let extra = if redundant { x[8] } else { 0.0 };
        let a1 = q[0] + x[5] + extra;
        let a2 = a1 + q[1] + x[6];
        let a3 = a2 + q[2] + x[7];
        [
            x[0] + x[2] * a1.cos() + x[3] * a2.cos() + x[4] * a3.cos(),
            x[1] + x[2] * a1.sin() + x[3] * a2.sin() + x[4] * a3.sin(),
        ]
    }

    /// Jacobian block (2 x n) of one pose.
    pub fn block(x: &[f64], q: &[f64; 3], redundant: bool) -> Mat<f64> {
        let n = if redundant { 9 } else { 8 };
        let extra = if redundant { x[8] } else { 0.0 };
        let a1 = q[0] + x[5] + extra;
        let a2 = a1 + q[1] + x[6];
        let a3 = a2 + q[2] + x[7];
        let (s1, c1, s2, c2, s3, c3) = (a1.sin(), a1.cos(), a2.sin(), a2.cos(), a3.sin(), a3.cos());
        let mut j = Mat::<f64>::zeros(2, n);
        j[(0, 0)] = 1.0;
        j[(1, 1)] = 1.0;
        j[(0, 2)] = c1;
        j[(1, 2)] = s1;
        j[(0, 3)] = c2;
        j[(1, 3)] = s2;
        j[(0, 4)] = c3;
        j[(1, 4)] = s3;
        // d/d offset_k: the rotation of every link from k on.
        let d3 = [-x[4] * s3, x[4] * c3];
        let d2 = [d3[0] - x[3] * s2, d3[1] + x[3] * c2];
        let d1 = [d2[0] - x[2] * s1, d2[1] + x[2] * c1];
        for r in 0..2 {
            j[(r, 5)] = d1[r];
            j[(r, 6)] = d2[r];
            j[(r, 7)] = d3[r];
            if redundant {
                j[(r, 8)] = d1[r];
            }
        }
        j
    }
}

impl Residuals for PlanarArm {
    fn n_residuals(&self) -> usize {
        2 * self.joints.len()
    }
    fn n_params(&self) -> usize {
        if self.redundant_offset { 9 } else { 8 }
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        for (k, (q, y)) in self.joints.iter().zip(&self.measured).enumerate() {
            let p = Self::tcp(x, q, self.redundant_offset);
            out[2 * k] = p[0] - y[0];
            out[2 * k + 1] = p[1] - y[1];
        }
        Ok(())
    }
    fn parameter_name(&self, j: usize) -> String {
        ARM_NAMES[j].to_string()
    }
}

impl Jacobian for PlanarArm {
    fn jacobian(&self, x: &[f64], mut out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        for (k, q) in self.joints.iter().enumerate() {
            let b = Self::block(x, q, self.redundant_offset);
            out.rb_mut().subrows_mut(2 * k, 2).copy_from(&b);
        }
        Ok(())
    }
}

use faer::reborrow::ReborrowMut;

/// Largest difference between the analytic Jacobian and central finite differences,
/// relative to the largest Jacobian entry.
pub fn max_jacobian_error<P: Jacobian>(problem: &P, x: &[f64], h: f64) -> f64 {
    let (m, n) = (problem.n_residuals(), problem.n_params());
    let mut jac = Mat::<f64>::zeros(m, n);
    problem.jacobian(x, jac.as_mut()).unwrap();
    let mut plus = vec![0.0; m];
    let mut minus = vec![0.0; m];
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for j in 0..n {
        let mut xp = x.to_vec();
        let mut xm = x.to_vec();
        xp[j] += h;
        xm[j] -= h;
        problem.residuals(&xp, &mut plus).unwrap();
        problem.residuals(&xm, &mut minus).unwrap();
        for i in 0..m {
            let fd = (plus[i] - minus[i]) / (2.0 * h);
            worst = worst.max((fd - jac[(i, j)]).abs());
            largest = largest.max(jac[(i, j)].abs());
        }
    }
    worst / largest.max(1e-300)
}

/// Seeded joint configurations spread over the arm's workspace.
pub fn arm_configurations(count: usize, seed: u64) -> Vec<[f64; 3]> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            [
                rng.random_range(-2.5..2.5),
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
            ]
        })
        .collect()
}

/// True parameters of the arm (m, rad) and nominal ones (the starting point).
pub const ARM_TRUE: [f64; 8] = [0.012, -0.008, 0.81, 0.62, 0.205, 0.011, -0.007, 0.015];
pub const ARM_NOMINAL: [f64; 8] = [0.0, 0.0, 0.8, 0.6, 0.2, 0.0, 0.0, 0.0];
