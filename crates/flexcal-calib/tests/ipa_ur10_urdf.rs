//! A UR10 imported from its public URDF calibrates on the IPA laser-tracker
//! data (series B, validated on C) to the same figures as the built-in
//! `ur10` (within 1 %): the URDF conversion gives a calibratable
//! parameterisation. Needs ../shared/ (the dataset and the URDF); says on
//! stderr that it skipped when they are absent.

use std::io::Write;
use std::path::PathBuf;

use flexcal_calib::{CalibrationOptions, MeasurementSet, Weighting, calibrate};
use flexcal_kinematics::{ImportOptions, ImportedRobot, Model, RobotDescription};

/// `path` under ../shared/, or `None` after saying on stderr (written
/// directly, so that the test harness's capture does not hide it) that the
/// test skipped.
fn shared(path: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(path);
    if p.exists() {
        return Some(p);
    }
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED urdf_ur10_calibrates_like_the_builtin_ur10: {} absent",
        p.display()
    );
    None
}

fn validation_mean_mm(
    model: &Model,
    train: &MeasurementSet,
    validate: &MeasurementSet,
) -> (f64, f64) {
    let mut options = CalibrationOptions::for_model(model);
    options.use_orientation = Some(false);
    options.weighting = Weighting::Uniform;
    let calibration = calibrate(model, train, &options).unwrap();
    assert!(calibration.solve.termination.is_converged());
    let report = calibration.validate(model, validate, false).unwrap();
    (
        report.after.position_mean * 1e3,
        report.after.position_max * 1e3,
    )
}

#[test]
fn urdf_ur10_calibrates_like_the_builtin_ur10() {
    let (Some(train), Some(validate), Some(urdf)) = (
        shared("datasets/ipa-ur10/Series_B/measurements_joint_configurations.csv"),
        shared("datasets/ipa-ur10/Series_C/measurements_random_poses.csv"),
        shared("robots/urdf/ur10_robot.urdf"),
    ) else {
        return;
    };
    let train = MeasurementSet::read_ipa(&train).unwrap();
    let validate = MeasurementSet::read_ipa(&validate).unwrap();
    let builtin = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let options = ImportOptions {
        tip: Some("tool0".into()),
        ..ImportOptions::default()
    };
    let imported = ImportedRobot::read_urdf(&urdf, &options)
        .unwrap()
        .description
        .build()
        .unwrap();
    let (builtin_mean, builtin_max) = validation_mean_mm(&builtin, &train, &validate);
    let (urdf_mean, urdf_max) = validation_mean_mm(&imported, &train, &validate);
    println!(
        "B -> C validation: built-in ur10 {builtin_mean:.4} / {builtin_max:.4} mm, URDF ur10 {urdf_mean:.4} / {urdf_max:.4} mm (mean / max)"
    );
    assert!((urdf_mean - builtin_mean).abs() <= 0.01 * builtin_mean);
}
