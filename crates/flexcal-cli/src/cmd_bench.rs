//! `flexcal bench`: times the core operations on this machine, so a user can
//! see whether model-based compensation fits a controller cycle.
//!
//! Each operation runs in batches after a warm-up; the figure is the median
//! over batches of the time per operation. The operations and fixtures are
//! the ones of the criterion benchmarks (`cargo bench`), which give the same
//! figures with confidence intervals; the IR-663 compensation fixtures (one
//! point solved from scratch, the 10 000-point forming travel with the fuzzy
//! and the FE model, with and without the cantilever beam) are those of
//! `cargo bench -p flexcal-twin --bench compensation`
//! ([`flexcal_twin::bench_fixtures`]).

use std::hint::black_box;
use std::time::{Duration, Instant};

use flexcal_compensate::compensation::{Cell, ConstantCompliance, ElastoGeometricModel};
use flexcal_fuzzy::FuzzyModel;
use flexcal_kinematics::{Data, RobotDescription, forward_pose, param_jacobian_into};
use nalgebra::{DMatrix, Isometry3, Matrix6, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::Serialize;

use flexcal_twin::bench_fixtures::{self as compensation_fixtures, Elastic, PATH_POINTS};

/// Arguments of `flexcal bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Print JSON (`{"operations": [{"name", "ns_per_op", "iterations"}]}`).
    #[arg(long)]
    pub json: bool,
    /// Time budget per operation (ms).
    #[arg(long, default_value_t = 300)]
    pub budget_ms: u64,
}

/// One timed operation.
#[derive(Debug, Serialize)]
pub struct Timing {
    /// What was timed.
    pub name: String,
    /// Median time per operation (ns).
    pub ns_per_op: f64,
    /// Operations run in total.
    pub iterations: u64,
}

/// Times `op` (which performs `per_call` operations per call).
fn time(name: &str, budget: Duration, per_call: u64, mut op: impl FnMut()) -> Timing {
    // Warm up and size the batches to ~1/10 of the budget.
    let start = Instant::now();
    let mut calls = 0u64;
    while start.elapsed() < budget / 20 || calls < 2 {
        op();
        calls += 1;
    }
    let per_call_time = start.elapsed().as_secs_f64() / calls as f64;
    let batch = ((budget.as_secs_f64() / 10.0) / per_call_time).max(1.0) as u64;
    // Operations longer than the budget (whole paths with the FE model) are
    // sampled 3 times rather than 9, so the command stays short.
    let batches = if per_call_time > budget.as_secs_f64() {
        3
    } else {
        9
    };
    let mut samples = Vec::new();
    let mut total = 0;
    for _ in 0..batches {
        let t = Instant::now();
        for _ in 0..batch {
            op();
        }
        samples.push(t.elapsed().as_secs_f64() / (batch * per_call) as f64);
        total += batch * per_call;
    }
    samples.sort_by(f64::total_cmp);
    Timing {
        name: name.to_string(),
        ns_per_op: samples[samples.len() / 2] * 1e9,
        iterations: total,
    }
}

/// A 2-input model with 4 x 3 = 12 rules, like the paper's compliance models.
pub fn twelve_rule_model() -> anyhow::Result<FuzzyModel> {
    // Modal values in rad over the IR-663's joint 2 and 8 ranges; conclusions
    // of the order of the robot's compliance (m/N).
    let structure = compensation_fixtures::paper_structure().map_err(|e| anyhow::anyhow!(e))?;
    let conclusions: Vec<f64> = (0..12).map(|i| 1e-6 * (1.0 + 0.1 * i as f64)).collect();
    Ok(FuzzyModel::new(structure, "C_xx".into(), conclusions)?)
}

/// Runs `flexcal bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let budget = Duration::from_millis(args.budget_ms.max(10));
    let mut timings = Vec::new();
    for robot in ["ur10", "ir663"] {
        let model = RobotDescription::builtin(robot)?.build()?;
        let mut data = Data::new(&model);
        let xi = model.nominal_params().to_vec();
        // A reachable configuration in the middle of the limits.
        let q: Vec<f64> = model
            .actuated_limits()
            .iter()
            .map(|(lo, hi)| lo + 0.45 * (hi - lo))
            .collect();
        forward_pose(&model, &mut data, &q, &xi)?;
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
    let fuzzy = twelve_rule_model()?;
    let n = 4096;
    let inputs: Vec<f64> = (0..n)
        .flat_map(|i| {
            let t = i as f64 / n as f64;
            [-1.2 + 1.7 * t, -0.5 + 1.8 * ((7.0 * t) % 1.0)]
        })
        .collect();
    let mut outputs = vec![0.0; n];
    timings.push(time(
        "fuzzy model, 2 inputs, 12 rules: one evaluation",
        budget,
        n as u64,
        || {
            fuzzy
                .evaluate_batch(black_box(&inputs), &mut outputs)
                .expect("inputs are finite");
            black_box(&outputs);
        },
    ));
    // FE assembly + condensation of the IR-663 beam model (60 DOF).
    let robot = RobotDescription::builtin("ir663")?.build()?;
    let description = flexcal_elastic::description::ElasticDescription::builtin("ir663")?;
    let fe_model = flexcal_elastic::model::ElasticModel::new(&robot, &description)?;
    let gamma = fe_model.nominal_gamma();
    let xi = robot.nominal_params().to_vec();
    let mut fe_data = flexcal_elastic::model::ElasticData::new(&fe_model)?;
    let q_ir =
        flexcal_kinematics::actuated_from_joint_angles(&robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0])?;
    flexcal_elastic::model::tcp_condensation(&fe_model, &mut fe_data, &q_ir, &xi, &gamma)?;
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
    // Compensation on the IR-663 with each elastic model: one point solved
    // from scratch, and the 10 000-point path of the criterion bench.
    let fixture = compensation_fixtures::CompensationFixture::new(PATH_POINTS)
        .map_err(|e| anyhow::anyhow!("compensation fixture: {e}"))?;
    let mut ir_data = Data::new(&fixture.robot);
    for elastic in [Elastic::Fuzzy, Elastic::Fe] {
        let egm = fixture.model(elastic, false);
        timings.push(time(
            &format!(
                "ir663: compensation of one path point from scratch, {}, 920 N",
                elastic.label()
            ),
            budget,
            1,
            || {
                black_box(
                    egm.compensate_pose(
                        &mut ir_data,
                        black_box(&fixture.middle_target),
                        &fixture.middle_seed,
                        &Vector3::zeros(),
                        &fixture.options,
                    )
                    .ok(),
                );
            },
        ));
        for with_beam in [false, true] {
            let egm = fixture.model(elastic, with_beam);
            let load = compensation_fixtures::load_label(with_beam);
            let path = time(
                &format!(
                    "ir663: compensation of a {PATH_POINTS}-point path, {}, {load}",
                    elastic.label()
                ),
                budget,
                1,
                || {
                    black_box(egm.compensate_path(
                        &mut ir_data,
                        black_box(&fixture.path),
                        &fixture.seed,
                        &fixture.options,
                    ));
                },
            );
            timings.push(Timing {
                name: format!(
                    "ir663: compensation per point of the {PATH_POINTS}-point path, {}, {load}",
                    elastic.label()
                ),
                ns_per_op: path.ns_per_op / PATH_POINTS as f64,
                iterations: path.iterations * PATH_POINTS as u64,
            });
            timings.push(path);
        }
    }
    // Compensation of one path point (payload only) with a constant compliance.
    let model = RobotDescription::builtin("ur10")?.build()?;
    let mut data = Data::new(&model);
    let elastic = ConstantCompliance {
        compliance: Matrix6::from_diagonal(&Vector6::new(1.5e-6, 1.5e-6, 1.5e-6, 2e-7, 2e-7, 2e-7)),
    };
    let egm = ElastoGeometricModel::with_nominal_geometry(
        &model,
        &elastic,
        None,
        Cell::payload_only(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
    );
    let target = Isometry3::from_parts(
        Translation3::new(0.6, 0.3, 0.4),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
    );
    let seed = egm
        .compensate_pose(
            &mut data,
            &target,
            &[0.3, -1.2, 1.5, -1.9, -1.57, 0.0],
            &Vector3::zeros(),
            &Default::default(),
        )?
        .q_uncompensated;
    let options = Default::default();
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
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({ "operations": timings }))?
        );
    } else {
        let width = timings.iter().map(|t| t.name.len()).max().unwrap_or(0);
        println!("{:<width$} {:>14}", "operation", "ns/op");
        for t in &timings {
            println!("{:<width$} {:>14.1}", t.name, t.ns_per_op);
        }
    }
    Ok(())
}
