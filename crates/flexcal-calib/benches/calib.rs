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
//!
//! Several targets (figures in `docs/robots.md`): the two-armed robot of
//! the tests with a marker per hand, 300 poses, the elasto-geometric model
//! with the lateral compliances of its mass table (80 unknowns), and model
//! selection by cross-validation from it; the compliant two-armed torso
//! robot of `tests/compliant_torso.rs` (two 7-joint arms on a torso with a
//! passive coupled joint, springs on the passive joint and the arm
//! mountings), 400 poses: identification goal <= 0.5 s, cross-validated
//! selection goal <= 8 s; and its identification with the deflection as
//! the static equilibrium (`compliant_torso_400_poses_equilibrium`).

use std::path::PathBuf;

#[path = "support/target_set.rs"]
mod target_set;
use target_set::target_set;

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
    // The same on one thread: what the threaded evaluation gains.
    let serial = CalibrationOptions {
        threads: Some(1),
        ..elastic.clone()
    };
    group.bench_function(
        "ur10_series_c_2773_poses_elasto_geometric_one_thread",
        |b| b.iter(|| calibrate(&model, &set, &serial).expect("calibration succeeds")),
    );
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

/// Identification and model selection with two markers on the two-armed
/// robot of the tests: 300 poses within the joint limits of a robot whose
/// parameters are off by up to 0.3 mm and 0.5 mrad, seen by a tracker 2.5 m
/// away with 20 um of noise per axis.
fn bench_targets(c: &mut Criterion) {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let mut group = c.benchmark_group("calibrate");
    group.sample_size(10);
    for (robot, poses, compliance, noise) in [
        ("two_arms", 300, 0.0, 20e-6),
        ("compliant_torso", 400, 250e-6, 0.5e-3),
    ] {
        let gravity = GravityCompliance::from_toml_file(&data.join(format!("{robot}_masses.toml")))
            .expect("mass table");
        let (model, set) = target_set(robot, &gravity, poses, compliance, noise);
        let options = CalibrationOptions {
            gravity: Some(gravity),
            ..CalibrationOptions::default()
        };
        group.bench_function(format!("{robot}_{poses}_poses_elasto_geometric"), |b| {
            b.iter(|| calibrate(&model, &set, &options).expect("identification succeeds"))
        });
        // The same on one thread: what the threaded evaluation gains.
        let serial = CalibrationOptions {
            threads: Some(1),
            ..options.clone()
        };
        group.bench_function(
            format!("{robot}_{poses}_poses_elasto_geometric_one_thread"),
            |b| b.iter(|| calibrate(&model, &set, &serial).expect("identification succeeds")),
        );
        group.bench_function(format!("{robot}_{poses}_poses_select_cv"), |b| {
            b.iter(|| {
                select_model(&model, &set, &options, &SelectionOptions::default())
                    .expect("selection succeeds")
            })
        });
        if compliance > 0.0 {
            // The same identification with the deflection as the static
            // equilibrium (the gravity stiffness, the iteration per pose
            // and the report's comparison included).
            let mut equilibrium = options.clone();
            if let Some(gravity) = equilibrium.gravity.as_mut() {
                gravity.deflection = flexcal_calib::Deflection::equilibrium();
            }
            group.bench_function(format!("{robot}_{poses}_poses_equilibrium"), |b| {
                b.iter(|| calibrate(&model, &set, &equilibrium).expect("identification succeeds"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench, bench_targets);
criterion_main!(benches);
