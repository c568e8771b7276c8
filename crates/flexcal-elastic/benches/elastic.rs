//! Speed of the IR-663 elastic model: placing the 60-DOF structure in a
//! configuration, assembling, factoring and condensing it onto the TCP
//! (goal: <= 20 us per configuration).

use criterion::{Criterion, criterion_group, criterion_main};
use flexcal_elastic::description::ElasticDescription;
use flexcal_elastic::model::{ElasticData, ElasticModel, tcp_condensation};
use flexcal_kinematics::{RobotDescription, actuated_from_joint_angles};

fn bench(c: &mut Criterion) {
    let robot = RobotDescription::builtin("ir663")
        .and_then(|d| d.build())
        .expect("built-in robot");
    let description = ElasticDescription::builtin("ir663").expect("built-in description");
    let model = ElasticModel::new(&robot, &description).expect("built-in model");
    let mut data = ElasticData::new(&model).expect("workspace");
    let xi = robot.nominal_params().to_vec();
    let gamma = model.nominal_gamma();
    let configurations: Vec<Vec<f64>> = [(-0.6, 0.3), (-0.2, 0.5), (0.1, 0.7), (-0.4, 0.6)]
        .iter()
        .map(|&(t2, t8)| {
            actuated_from_joint_angles(&robot, &[0.1, t2, t8, 0.8, 1.6, 0.0]).expect("in range")
        })
        .collect();
    let mut k = 0;
    c.bench_function(
        "ir663 place + assemble + condense onto the TCP (60 DOF)",
        |b| {
            b.iter(|| {
                k = (k + 1) % configurations.len();
                let t = tcp_condensation(&model, &mut data, &configurations[k], &xi, &gamma)
                    .expect("condensation");
                std::hint::black_box(t.c_eq[(2, 2)])
            })
        },
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
