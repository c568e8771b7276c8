//! Levenberg-Marquardt on a synthetic calibration-sized problem: 8 300 rows x 40
//! parameters (about 1 400 six-dimensional poses), mildly nonlinear, columns in
//! mixed units. `lm_8300x40/solver_only` excludes the time spent in the problem's
//! residual and Jacobian code, which is the caller's.

use std::cell::Cell;
use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use faer::{Mat, MatMut};
use flexcal_optim::{Jacobian, LevenbergMarquardt, ProblemError, ProblemSetup, Residuals};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `r_i(x) = sum_j A_ij (x_j + 0.1 x_j^2) - y_i`.
struct Synthetic {
    a: Mat<f64>,
    y: Vec<f64>,
    callback_time: Cell<Duration>,
}

impl Synthetic {
    fn new(m: usize, n: usize) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(2013);
        // Alternate "length" (~1) and "angle" (~1e-3) columns.
        let a = Mat::<f64>::from_fn(m, n, |_, j| {
            rng.random_range(-1.0..1.0) * if j % 2 == 0 { 1.0 } else { 1e-3 }
        });
        let truth: Vec<f64> = (0..n).map(|j| 0.05 * ((j as f64) * 0.7).sin()).collect();
        let mut problem = Self {
            a,
            y: vec![0.0; m],
            callback_time: Cell::new(Duration::ZERO),
        };
        let mut y = vec![0.0; m];
        problem.residuals(&truth, &mut y).unwrap();
        for (yi, i) in y.iter_mut().zip(0..) {
            *yi += 1e-5 * (((i * 7919) % 1000) as f64 / 500.0 - 1.0);
        }
        problem.y = y;
        problem
    }
}

impl Residuals for Synthetic {
    fn n_residuals(&self) -> usize {
        self.a.nrows()
    }
    fn n_params(&self) -> usize {
        self.a.ncols()
    }
    fn residuals(&self, x: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
        let start = Instant::now();
        for (o, y) in out.iter_mut().zip(&self.y) {
            *o = -y;
        }
        for (j, &xj) in x.iter().enumerate() {
            let f = xj + 0.1 * xj * xj;
            let col = self.a.col(j);
            for (i, o) in out.iter_mut().enumerate() {
                *o += col[i] * f;
            }
        }
        self.callback_time
            .set(self.callback_time.get() + start.elapsed());
        Ok(())
    }
}

impl Jacobian for Synthetic {
    fn jacobian(&self, x: &[f64], mut out: MatMut<'_, f64>) -> Result<(), ProblemError> {
        let start = Instant::now();
        for (j, &xj) in x.iter().enumerate() {
            let d = 1.0 + 0.2 * xj;
            let col = self.a.col(j);
            let mut dst = out.rb_mut().col_mut(j);
            for i in 0..col.nrows() {
                dst[i] = col[i] * d;
            }
        }
        self.callback_time
            .set(self.callback_time.get() + start.elapsed());
        Ok(())
    }
}

use faer::reborrow::ReborrowMut;

/// CPU time consumed by the calling thread so far, where Linux exposes it.
fn thread_cpu_time() -> Option<Duration> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let nanoseconds: u64 = text.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(nanoseconds))
}

fn bench(c: &mut Criterion) {
    let problem = Synthetic::new(8300, 40);
    let solver = LevenbergMarquardt::params().check().unwrap();
    let setup = ProblemSetup::default();
    let x0 = vec![0.0; 40];
    let report = solver.solve(&problem, &x0, &setup, &mut ()).unwrap();
    eprintln!(
        "lm_8300x40: {:?} after {} iterations, {} residual / {} Jacobian evaluations, rank {}, cond {:.2e}",
        report.termination,
        report.iterations,
        report.residual_evaluations,
        report.jacobian_evaluations,
        report.rank,
        report.condition_number
    );
    // The machine running the benches is often shared, which inflates wall-clock
    // figures; the thread's own CPU time (Linux schedstat) is not inflated by waiting.
    if thread_cpu_time().is_some() {
        let mut samples = Vec::new();
        for _ in 0..20 {
            let before = thread_cpu_time().unwrap_or_default();
            let report = solver.solve(&problem, &x0, &setup, &mut ()).unwrap();
            let after = thread_cpu_time().unwrap_or_default();
            black_box(report);
            samples.push(after.saturating_sub(before));
        }
        samples.sort();
        // Callbacks measured alone, in CPU time too.
        let mut residual = vec![0.0; 8300];
        let mut jac = Mat::<f64>::zeros(8300, 40);
        let before = thread_cpu_time().unwrap_or_default();
        for _ in 0..100 {
            problem.residuals(&x0, &mut residual).unwrap();
            problem.jacobian(&x0, jac.as_mut()).unwrap();
        }
        let per_pair = thread_cpu_time().unwrap_or_default().saturating_sub(before) / 100;
        eprintln!(
            "lm_8300x40 CPU time per solve: min {:.2} ms, median {:.2} ms; one residual + Jacobian evaluation {:.2} ms",
            samples[0].as_secs_f64() * 1e3,
            samples[10].as_secs_f64() * 1e3,
            per_pair.as_secs_f64() * 1e3
        );
    }
    let mut group = c.benchmark_group("lm_8300x40");
    group.sample_size(30);
    group.bench_function("total", |b| {
        b.iter(|| {
            solver
                .solve(&problem, black_box(&x0), &setup, &mut ())
                .unwrap()
        })
    });
    group.bench_function("solver_only", |b| {
        b.iter_custom(|iterations| {
            let mut solver_time = Duration::ZERO;
            for _ in 0..iterations {
                problem.callback_time.set(Duration::ZERO);
                let start = Instant::now();
                black_box(
                    solver
                        .solve(&problem, black_box(&x0), &setup, &mut ())
                        .unwrap(),
                );
                solver_time += start.elapsed().saturating_sub(problem.callback_time.get());
            }
            solver_time
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
