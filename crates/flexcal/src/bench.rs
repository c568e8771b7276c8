//! Timing of flexcal's core operations on this machine, so a user can see
//! whether model-based compensation fits a controller cycle: the library
//! behind `flexcal bench`.
//!
//! Each operation is warmed up, then run in samples (batches sized to a
//! tenth of the time budget); a [`Timing`] reports the minimum and the
//! median time per operation over the samples and the sample count. The
//! minimum is the machine's speed; a median well above it means the
//! machine was busy (other processes competing for the cores). The report
//! says so twice more: the load average, and (Linux) the processor time
//! the timing thread received per operation, which stays at the machine's
//! speed while the wall-clock time grows with the load.
//!
//! The operations and fixtures are those of the criterion benchmarks, which
//! give the same figures with confidence intervals: the IR-663
//! compensation fixtures (one point solved from scratch, the 10 000-point
//! forming travel with the fuzzy and the FE model, with and without the
//! cantilever beam, in one thread and in parallel threads) are those of
//! `cargo bench -p flexcal --bench compensation`
//! ([`crate::bench_fixtures`]).
//!
//! ```no_run
//! let report = flexcal::bench::run(&flexcal::bench::BenchOptions::default())?;
//! for t in &report.operations {
//!     println!("{}: min {:.0} ns, median {:.0} ns over {} samples", t.name, t.min_ns, t.ns_per_op, t.samples);
//! }
//! # Ok::<(), flexcal::bench::BenchError>(())
//! ```

use std::hint::black_box;
use std::time::{Duration, Instant};

use crate::bench_fixtures::{self as fixtures, CompensationFixture, Elastic, Load, PATH_POINTS};
use flexcal_compensate::compensation::{Cell, ConstantCompliance, ElastoGeometricModel};
use flexcal_fuzzy::FuzzyModel;
use flexcal_kinematics::{Data, RobotDescription, forward_pose, param_jacobian_into};
use nalgebra::{DMatrix, Isometry3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

/// Settings of [`run`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BenchOptions {
    /// Time budget per operation (ms) (default 300; at least 10).
    pub budget_ms: u64,
}

impl Default for BenchOptions {
    fn default() -> Self {
        Self { budget_ms: 300 }
    }
}

/// One timed operation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// What was timed.
    pub name: String,
    /// Median over the samples of the time per operation (ns).
    pub ns_per_op: f64,
    /// Fastest sample's time per operation (ns).
    pub min_ns: f64,
    /// Samples taken (each a batch of operations).
    pub samples: usize,
    /// Median over the samples of the processor time the timing thread
    /// spent per operation (ns; Linux only, `None` elsewhere, for
    /// operations that run in several threads, and when a sample saw no
    /// processor time, as on kernels that account a thread's time only when
    /// it is scheduled out). Well below
    /// [`ns_per_op`](Self::ns_per_op), the thread was waiting for a core:
    /// the machine was busy.
    pub cpu_ns_per_op: Option<f64>,
    /// Operations run in total.
    pub iterations: u64,
}

impl Timing {
    /// Median over minimum: 1 on a quiet machine, well above on a busy one.
    pub fn spread(&self) -> f64 {
        self.ns_per_op / self.min_ns
    }
}

/// What [`run`] measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BenchReport {
    /// The timed operations, in order.
    pub operations: Vec<Timing>,
    /// Threads of the pool that compensates paths in parallel.
    pub threads: usize,
    /// Load average over 1, 5 and 15 minutes when the run started (Linux
    /// `/proc/loadavg`; `None` elsewhere). Above the core count, the
    /// machine was busy and the medians are slower than the machine.
    pub load_average: Option<[f64; 3]>,
    /// Cores available to this process.
    pub cores: usize,
}

impl BenchReport {
    /// The report as a table for people: per operation the minimum and
    /// median ns per operation, the samples and the processor time, then
    /// the load average (flagged busy above 0.75 per core) and the threads.
    pub fn table_text(&self) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        let width = self
            .operations
            .iter()
            .map(|t| t.name.len())
            .max()
            .unwrap_or(0);
        let _ = writeln!(
            out,
            "{:<width$} {:>14} {:>14} {:>8} {:>14}",
            "operation", "min ns/op", "median ns/op", "samples", "cpu ns/op"
        );
        for t in &self.operations {
            let cpu = t
                .cpu_ns_per_op
                .map_or_else(|| "-".to_string(), |ns| format!("{ns:.1}"));
            let _ = writeln!(
                out,
                "{:<width$} {:>14.1} {:>14.1} {:>8} {:>14}",
                t.name, t.min_ns, t.ns_per_op, t.samples, cpu
            );
        }
        let _ = match self.load_average {
            Some([one, five, fifteen]) => {
                let busy = if one > self.cores as f64 * 0.75 {
                    " (busy: other work competes for the cores; medians above the minimum show it)"
                } else {
                    ""
                };
                writeln!(
                    out,
                    "load average {one:.2} {five:.2} {fifteen:.2} on {} cores, {} compensation threads{busy}",
                    self.cores, self.threads
                )
            }
            None => writeln!(
                out,
                "{} cores, {} compensation threads",
                self.cores, self.threads
            ),
        };
        out
    }
}

/// Errors of [`run`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// A built-in robot or elastic model failed to build, or a fixture
    /// failed (a bug: the fixtures are constants).
    #[error("benchmark fixture '{what}': {message}")]
    Fixture {
        /// Which fixture.
        what: &'static str,
        /// Why.
        message: String,
    },
}

fn fixture_error(what: &'static str) -> impl Fn(&dyn std::fmt::Display) -> BenchError {
    move |e| BenchError::Fixture {
        what,
        message: e.to_string(),
    }
}

/// Times `op`, which performs `per_call` operations per call, within
/// about `budget`: a warm-up of a twentieth of the budget sizes batches to
/// a tenth of it; 9 samples are taken (3 when one call exceeds the budget,
/// so a slow operation keeps the run short).
pub fn time(name: &str, budget: Duration, per_call: u64, mut op: impl FnMut()) -> Timing {
    let start = Instant::now();
    let mut calls = 0u64;
    while start.elapsed() < budget / 20 || calls < 2 {
        op();
        calls += 1;
    }
    let per_call_time = start.elapsed().as_secs_f64() / calls as f64;
    let batch = ((budget.as_secs_f64() / 10.0) / per_call_time).max(1.0) as u64;
    let batches = if per_call_time > budget.as_secs_f64() {
        3
    } else {
        9
    };
    let mut samples = Vec::with_capacity(batches);
    let mut cpu_samples = Vec::with_capacity(batches);
    let mut total = 0;
    for _ in 0..batches {
        let cpu = thread_cpu_ns();
        let t = Instant::now();
        for _ in 0..batch {
            op();
        }
        let operations = (batch * per_call) as f64;
        samples.push(t.elapsed().as_secs_f64() * 1e9 / operations);
        if let (Some(before), Some(after)) = (cpu, thread_cpu_ns()) {
            cpu_samples.push((after - before) / operations);
        }
        total += batch * per_call;
    }
    samples.sort_by(f64::total_cmp);
    cpu_samples.sort_by(f64::total_cmp);
    Timing {
        name: name.to_string(),
        ns_per_op: samples[samples.len() / 2],
        min_ns: samples[0],
        samples: samples.len(),
        // Some kernels account a running thread's time only when it is
        // scheduled out: a sample that saw none says nothing.
        cpu_ns_per_op: (cpu_samples.len() == samples.len() && cpu_samples[0] > 0.0)
            .then(|| cpu_samples[cpu_samples.len() / 2]),
        iterations: total,
    }
}

/// Processor time this thread has run (ns), from Linux's
/// `/proc/thread-self/schedstat`; `None` elsewhere.
fn thread_cpu_ns() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// The load average of the machine (Linux), `None` where unknown.
pub fn load_average() -> Option<[f64; 3]> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    let mut fields = text.split_whitespace().map(str::parse::<f64>);
    Some([
        fields.next()?.ok()?,
        fields.next()?.ok()?,
        fields.next()?.ok()?,
    ])
}

/// A 2-input model with 4 x 3 = 12 rules, like the paper's compliance
/// models: modal values in rad over the IR-663's joint 2 and 8 ranges,
/// conclusions of the order of the robot's compliance (m/N).
///
/// # Errors
/// Never for these constants.
pub fn twelve_rule_model() -> Result<FuzzyModel, BenchError> {
    let structure = fixtures::paper_structure().map_err(|e| fixture_error("fuzzy")(&e))?;
    let conclusions: Vec<f64> = (0..12).map(|i| 1e-6 * (1.0 + 0.1 * i as f64)).collect();
    FuzzyModel::new(structure, "C_xx".into(), conclusions).map_err(|e| fixture_error("fuzzy")(&e))
}

/// Times every core operation: forward model and parameter Jacobian of
/// the UR10 and the IR-663, one fuzzy evaluation, the FE condensation,
/// compensation of one point and of the 10 000-point path with each
/// elastic model, in one thread and in parallel threads.
///
/// # Errors
/// [`BenchError::Fixture`] when a built-in fixture fails to build.
pub fn run(options: &BenchOptions) -> Result<BenchReport, BenchError> {
    let load = load_average();
    let budget = Duration::from_millis(options.budget_ms.max(10));
    let mut timings = Vec::new();
    kinematics(budget, &mut timings)?;
    fuzzy_and_fe(budget, &mut timings)?;
    compensation(budget, &mut timings)?;
    Ok(BenchReport {
        operations: timings,
        threads: rayon::current_num_threads(),
        load_average: load,
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
    })
}

fn kinematics(budget: Duration, timings: &mut Vec<Timing>) -> Result<(), BenchError> {
    let robot_error = fixture_error("robot");
    for robot in ["ur10", "ir663"] {
        let model = RobotDescription::builtin(robot)
            .and_then(|d| d.build())
            .map_err(|e| robot_error(&e))?;
        let mut data = Data::new(&model);
        let xi = model.nominal_params().to_vec();
        // A reachable configuration in the middle of the limits.
        let q: Vec<f64> = model
            .actuated_limits()
            .iter()
            .map(|(lo, hi)| lo + 0.45 * (hi - lo))
            .collect();
        forward_pose(&model, &mut data, &q, &xi).map_err(|e| robot_error(&e))?;
        timings.push(time(&format!("{robot}: forward model"), budget, 1, || {
            black_box(forward_pose(&model, &mut data, black_box(&q), &xi).ok());
        }));
        let mut jac = DMatrix::zeros(6, model.n_params());
        timings.push(time(
            &format!(
                "{robot}: forward model + parameter Jacobian (6 x {})",
                model.n_params()
            ),
            budget,
            1,
            || {
                black_box(
                    param_jacobian_into(&model, &mut data, black_box(&q), &xi, &mut jac).ok(),
                );
            },
        ));
    }
    Ok(())
}

fn fuzzy_and_fe(budget: Duration, timings: &mut Vec<Timing>) -> Result<(), BenchError> {
    let fuzzy = twelve_rule_model()?;
    let n = 4096;
    let inputs: Vec<f64> = (0..n)
        .flat_map(|i| {
            let t = i as f64 / n as f64;
            [-1.2 + 1.7 * t, -0.5 + 1.8 * ((7.0 * t) % 1.0)]
        })
        .collect();
    let mut outputs = vec![0.0; n];
    fuzzy
        .evaluate_batch(&inputs, &mut outputs)
        .map_err(|e| fixture_error("fuzzy")(&e))?;
    timings.push(time(
        "fuzzy model, 2 inputs, 12 rules: one evaluation",
        budget,
        n as u64,
        || {
            black_box(fuzzy.evaluate_batch(black_box(&inputs), &mut outputs).ok());
            black_box(&outputs);
        },
    ));
    // FE assembly + condensation of the IR-663 beam model (60 DOF).
    let fe_error = fixture_error("FE model");
    let robot = RobotDescription::builtin("ir663")
        .and_then(|d| d.build())
        .map_err(|e| fe_error(&e))?;
    let description = flexcal_elastic::description::ElasticDescription::builtin("ir663")
        .map_err(|e| fe_error(&e))?;
    let fe_model = flexcal_elastic::model::ElasticModel::new(&robot, &description)
        .map_err(|e| fe_error(&e))?;
    let gamma = fe_model.nominal_gamma();
    let xi = robot.nominal_params().to_vec();
    let mut fe_data =
        flexcal_elastic::model::ElasticData::new(&fe_model).map_err(|e| fe_error(&e))?;
    let q_ir =
        flexcal_kinematics::actuated_from_joint_angles(&robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0])
            .map_err(|e| fe_error(&e))?;
    flexcal_elastic::model::tcp_condensation(&fe_model, &mut fe_data, &q_ir, &xi, &gamma)
        .map_err(|e| fe_error(&e))?;
    timings.push(time(
        "ir663: FE assembly + condensation onto the TCP (60 DOF)",
        budget,
        1,
        || {
            black_box(
                flexcal_elastic::model::tcp_condensation(
                    &fe_model,
                    &mut fe_data,
                    black_box(&q_ir),
                    &xi,
                    &gamma,
                )
                .ok(),
            );
        },
    ));
    Ok(())
}

fn compensation(budget: Duration, timings: &mut Vec<Timing>) -> Result<(), BenchError> {
    let fixture_failed = fixture_error("compensation");
    let fixture = CompensationFixture::new(PATH_POINTS).map_err(|e| fixture_failed(&e))?;
    for elastic in [Elastic::Fuzzy, Elastic::Fe] {
        let egm = fixture.model(elastic, Load::DeadWeight);
        let mut data = egm.data().map_err(|e| fixture_failed(&e))?;
        timings.push(time(
            &format!(
                "ir663: compensation of one path point from scratch, {}, 920 N",
                elastic.label()
            ),
            budget,
            1,
            || {
                black_box(fixture.compensate_middle_point(&egm, &mut data).ok());
            },
        ));
        for load in Load::ALL {
            let egm = fixture.model(elastic, load);
            let mut data = egm.data().map_err(|e| fixture_failed(&e))?;
            let load = load.label();
            let serial = time(
                &format!(
                    "ir663: compensation of a {PATH_POINTS}-point path, one thread, {}, {load}",
                    elastic.label()
                ),
                budget,
                1,
                || {
                    black_box(egm.compensate_path(
                        &mut data,
                        black_box(&fixture.path),
                        &fixture.seed,
                        &fixture.options,
                    ));
                },
            );
            timings.push(Timing {
                name: format!(
                    "ir663: compensation per point of the {PATH_POINTS}-point path, one thread, {}, {load}",
                    elastic.label()
                ),
                ns_per_op: serial.ns_per_op / PATH_POINTS as f64,
                min_ns: serial.min_ns / PATH_POINTS as f64,
                samples: serial.samples,
                cpu_ns_per_op: serial.cpu_ns_per_op.map(|ns| ns / PATH_POINTS as f64),
                iterations: serial.iterations * PATH_POINTS as u64,
            });
            timings.push(serial);
            let mut parallel = time(
                &format!(
                    "ir663: compensation of a {PATH_POINTS}-point path, parallel threads, {}, {load}",
                    elastic.label()
                ),
                budget,
                1,
                || {
                    black_box(
                        egm.compensate_path_parallel(
                            black_box(&fixture.path),
                            &fixture.seed,
                            &fixture.options,
                        )
                        .ok(),
                    );
                },
            );
            // The timing thread's processor time misses the other threads.
            parallel.cpu_ns_per_op = None;
            timings.push(parallel);
        }
    }
    // Compensation of one path point (payload only) with a constant compliance.
    let robot_error = fixture_error("ur10");
    let model = RobotDescription::builtin("ur10")
        .and_then(|d| d.build())
        .map_err(|e| robot_error(&e))?;
    let elastic = ConstantCompliance {
        compliance: Matrix6::from_diagonal(&Vector6::new(1.5e-6, 1.5e-6, 1.5e-6, 2e-7, 2e-7, 2e-7)),
    };
    let egm = ElastoGeometricModel::with_nominal_geometry(
        &model,
        &elastic,
        None,
        Cell::payload_only(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
    );
    let mut data = egm.data().map_err(|e| robot_error(&e))?;
    let target = Isometry3::from_parts(
        Translation3::new(0.6, 0.3, 0.4),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
    );
    let options = Default::default();
    let seed = egm
        .compensate_pose(
            &mut data,
            &target,
            &[0.3, -1.2, 1.5, -1.9, -1.57, 0.0],
            &Vector3::zeros(),
            &options,
        )
        .map_err(|e| robot_error(&e))?
        .q_uncompensated;
    timings.push(time(
        "ur10: compensation of one path point (constant compliance, 920 N)",
        budget,
        1,
        || {
            black_box(
                egm.compensate_pose(&mut data, &target, &seed, &Vector3::zeros(), &options)
                    .ok(),
            );
        },
    ));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_has_a_row_per_operation_and_flags_a_busy_machine() {
        let timing = |name: &str, cpu| Timing {
            name: name.into(),
            ns_per_op: 12.0,
            min_ns: 10.0,
            samples: 9,
            cpu_ns_per_op: cpu,
            iterations: 1000,
        };
        let mut report = BenchReport {
            operations: vec![timing("forward pose", Some(11.0)), timing("a path", None)],
            threads: 2,
            load_average: Some([3.0, 2.0, 1.0]),
            cores: 2,
        };
        let text = report.table_text();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 4, "{text}");
        let row: Vec<&str> = lines[1].split_whitespace().collect();
        assert_eq!(row, ["forward", "pose", "10.0", "12.0", "9", "11.0"]);
        assert!(lines[2].ends_with(" -"), "{text}");
        assert!(lines[3].contains("(busy"), "{text}");
        report.load_average = Some([0.5, 0.5, 0.5]);
        assert!(!report.table_text().contains("busy"));
    }
}
