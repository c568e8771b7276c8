//! Campaign planning for the UR10 (goal <= 5 s on 2 cores): the
//! elasto-geometric model (joint compliances under gravity, the URDF's
//! mass table), 200 candidates drawn over the joint limits, a region of
//! 200 configurations, 50 poses planned (the curve up to 50, greedy then
//! exchange, the prediction by a calibration of the planned poses). The
//! figure measured is in docs/planning.md (Speed).

use criterion::{Criterion, criterion_group, criterion_main};
use flexcal::calib::{CalibrationOptions, GravityCompliance};
use flexcal::plan::{JointBox, PlanConfig, PoseSource, plan_campaign};

fn plan_ur10(c: &mut Criterion) {
    let model = flexcal::load_robot("ur10").unwrap();
    let mut options = CalibrationOptions::for_model(&model);
    options.gravity = Some(GravityCompliance::ur10_urdf(&model).unwrap());
    let source = |seed: u64| PoseSource::Box {
        joint_box: JointBox::of_limits(&model),
        count: 200,
        seed,
    };
    let mut config = PlanConfig::new(options, [0.02; 3], source(1), source(2));
    config.count = Some(50);
    config.max_poses = Some(50);
    let mut group = c.benchmark_group("plan");
    group.sample_size(10);
    group.bench_function("ur10 elasto-geometric, 200 candidates, 50 poses", |b| {
        b.iter(|| plan_campaign(&model, &config).unwrap())
    });
    group.finish();
}

criterion_group!(benches, plan_ur10);
criterion_main!(benches);
