//! Full iterative identification of the UR10 from the 2 773 poses of IPA
//! series C: geometric (goal <= 50 ms) and elasto-geometric (joint
//! compliances under gravity, goal <= 0.5 s; the richer model with the
//! non-linear joint law and cyclic errors, goal <= 0.5 s), model selection
//! by 5-fold cross-validation (goal <= 5 s), and reading that file (1 MB,
//! CRLF line ends: the line numbers of the rows are counted once through
//! the text). Skipped with a message when the data is absent.
//!
//! The figures measured, with the load of the machine and the CPU time per
//! call (`examples/ipa_speed.rs`), are in `docs/model-selection.md`
//! (Speed). On a quiet machine both goals hold (241 ms, 3.2 s). With other
//! jobs loading the two cores, the selection takes longer than 5 s.

use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use flexcal_calib::{
    CalibrationOptions, GravityCompliance, JointLaw, JointTerms, MeasurementSet, SelectionOptions,
    Weighting, calibrate, select_model,
};
use flexcal_kinematics::RobotDescription;

fn series_c() -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ipa-ur10/Series_C/measurements_random_poses.csv");
    path.exists().then_some(path)
}

fn bench(c: &mut Criterion) {
    let Some(path) = series_c() else {
        eprintln!("IPA UR10 data absent: calibration benchmark skipped");
        return;
    };
    let model = RobotDescription::builtin("ur10")
        .and_then(|d| d.build())
        .expect("built-in ur10");
    let set = MeasurementSet::read_ipa(&path).expect("series C reads");
    let mut options = CalibrationOptions::for_model(&model);
    options.use_orientation = Some(false);
    options.weighting = Weighting::Uniform;
    let mut group = c.benchmark_group("calibrate");
    group.sample_size(10);
    group.bench_function("ur10_series_c_2773_poses", |b| {
        b.iter(|| calibrate(&model, &set, &options).expect("calibration succeeds"))
    });
    let mut elastic = options.clone();
    elastic.gravity = Some(GravityCompliance::ur10_urdf(&model).expect("ur10 mass table"));
    group.bench_function("ur10_series_c_2773_poses_elasto_geometric", |b| {
        b.iter(|| calibrate(&model, &set, &elastic).expect("calibration succeeds"))
    });
    let mut richer = elastic.clone();
    richer.joint_terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    group.bench_function("ur10_series_c_2773_poses_joint_law_and_cyclic", |b| {
        b.iter(|| calibrate(&model, &set, &richer).expect("calibration succeeds"))
    });
    group.bench_function("ur10_series_c_2773_poses_select_cv", |b| {
        b.iter(|| {
            select_model(&model, &set, &richer, &SelectionOptions::default())
                .expect("selection succeeds")
        })
    });
    group.finish();
    let mut group = c.benchmark_group("read");
    group.sample_size(10);
    group.bench_function("ipa_series_c_2773_poses", |b| {
        b.iter(|| MeasurementSet::read_ipa(&path).expect("series C reads"))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
