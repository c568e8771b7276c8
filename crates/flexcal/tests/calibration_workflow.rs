//! `flexcal::calibration::run_calibration` on the virtual IR-663's
//! geometric campaign: the validation improves on the nominal robot, the
//! poses left out are counted, the report carries the checks asked for,
//! and configurations that cannot run are refused by name.

use flexcal::calib::{CalibrationOptions, FrameTreatment};
use flexcal::calibration::{CalibrationConfig, run_calibration};

#[test]
fn workflow_on_the_twin_campaign() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let campaign = flexcal::twin::geometric::geometric_campaign(&Default::default()).unwrap();
    flexcal::twin::geometric::write_geometric_campaign(&campaign, dir).unwrap();
    let robot = flexcal::load_robot("ir663").unwrap();
    let mut options = CalibrationOptions::for_model(&robot);
    // The twin's camera is not at the robot base: its frame is registered.
    options.measurement_frame = FrameTreatment::Identify;
    options.target = FrameTreatment::Fixed;
    let config = CalibrationConfig {
        validate: Some(dir.join("validation.csv")),
        exclude: vec!["identification-1".into(), "identification-2".into()],
        split_check: true,
        ..CalibrationConfig::new(dir.join("identification.csv"), options)
    };
    let run = run_calibration(&robot, &config).unwrap();
    assert_eq!(run.exclusions.len(), 1);
    assert_eq!(run.exclusions[0].left_out, 2);
    assert_eq!(run.data.len(), run.exclusions[0].total - 2);
    let validation = run.validation.as_ref().unwrap();
    assert!(
        validation.after.position_mean < 0.2 * validation.before.position_mean,
        "{} -> {} m",
        validation.before.position_mean,
        validation.after.position_mean
    );
    let (name, set, errors) = run.per_pose();
    assert_eq!(name, "validation");
    assert_eq!(set.len(), errors.len());
    let report = run.report(&robot);
    assert!(report.split_check.is_some());
    assert!(report.cross_check.is_none());

    // Refused by name: a cross-series check without a validation set, and
    // a label that names no pose.
    let no_validation = CalibrationConfig {
        validate: None,
        cross_check: true,
        ..config.clone()
    };
    let err = run_calibration(&robot, &no_validation)
        .unwrap_err()
        .to_string();
    assert!(err.contains("cross_check"), "{err}");
    let bad_label = CalibrationConfig {
        exclude: vec!["line 99999".into()],
        ..config
    };
    let err = run_calibration(&robot, &bad_label).unwrap_err().to_string();
    assert!(
        err.starts_with("--exclude") && err.contains("99999"),
        "{err}"
    );
}
