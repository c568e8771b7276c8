//! Forward model and parameter Jacobian per configuration.

use criterion::{Criterion, criterion_group, criterion_main};
use flexcal_kinematics::{Data, RobotDescription, forward_pose, param_jacobian_into};
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

fn kinematics(c: &mut Criterion) {
    bench_robot(c, "ur10", &[0.1, -1.2, 1.0, -0.5, 1.3, 0.2]);
    bench_robot(c, "ir663", &[0.1, 0.9, 0.9, 0.2, 0.5, 0.3]);
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
