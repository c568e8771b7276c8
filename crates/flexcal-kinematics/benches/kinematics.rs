//! Forward model and parameter Jacobian per configuration.

use criterion::{Criterion, criterion_group, criterion_main};
use flexcal_kinematics::{Data, RobotDescription, SerialChain, forward_pose, param_jacobian_into};
use nalgebra::DMatrix;
use std::hint::black_box;

fn bench_robot(c: &mut Criterion, name: &str, q: &[f64]) {
    let model = RobotDescription::builtin(name)
        .and_then(|d| d.build())
        .expect("built-in robot");
    let mut data = Data::new(&model);
    let xi = model.nominal_params().to_vec();
    c.bench_function(&format!("{name}/forward_pose"), |b| {
        b.iter(|| forward_pose(&model, &mut data, black_box(q), black_box(&xi)).expect("fk"))
    });
    let mut jac = DMatrix::zeros(6, model.n_params());
    c.bench_function(&format!("{name}/forward_pose+param_jacobian"), |b| {
        b.iter(|| {
            param_jacobian_into(&model, &mut data, black_box(q), black_box(&xi), &mut jac)
                .expect("jacobian")
        })
    });
}

/// The precomputed serial chain against `forward_pose` on the same robot:
/// one configuration, and a batch of 1 000 into a caller's buffer.
fn bench_serial_chain(c: &mut Criterion, name: &str, q: &[f64]) {
    let model = RobotDescription::builtin(name)
        .and_then(|d| d.build())
        .expect("built-in robot");
    let chain = SerialChain::new(&model, model.nominal_params()).expect("serial chain");
    c.bench_function(&format!("{name}/serial_chain_matrix"), |b| {
        b.iter(|| chain.matrix(black_box(q)).expect("fk"))
    });
    let rows = 1_000;
    let batch: Vec<f64> = (0..rows)
        .flat_map(|k| q.iter().map(move |v| v + 1e-3 * k as f64))
        .collect();
    let mut out = vec![0.0; 16 * rows];
    c.bench_function(&format!("{name}/serial_chain_matrices_into_x1000"), |b| {
        b.iter(|| {
            chain
                .matrices_into(black_box(&batch), &mut out)
                .expect("fk")
        })
    });
}

fn kinematics(c: &mut Criterion) {
    bench_serial_chain(c, "ur10", &[0.1, -1.2, 1.0, -0.5, 1.3, 0.2]);
    bench_robot(c, "ur10", &[0.1, -1.2, 1.0, -0.5, 1.3, 0.2]);
    bench_robot(c, "ir663", &[0.1, 0.9, 0.9, 0.2, 0.5, 0.3]);
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
