//! The examples of `examples/` run here, on the virtual robot's files, and
//! their results are checked: they are part of the test suite.

#[path = "../examples/calibrate_and_validate.rs"]
mod calibrate_and_validate;
#[path = "../examples/compensate_path.rs"]
mod compensate_path;
#[path = "../examples/identify_fuzzy_compliance.rs"]
mod identify_fuzzy_compliance;

#[test]
fn calibrate_and_validate_improves_the_validation_error() {
    let dir = tempfile::tempdir().unwrap();
    calibrate_and_validate::write_campaign(dir.path()).unwrap();
    let report = calibrate_and_validate::calibrate_and_validate(dir.path()).unwrap();
    assert!(
        report.after.position_mean < 0.2 * report.before.position_mean,
        "{} -> {}",
        report.before.position_mean,
        report.after.position_mean
    );
}

#[test]
fn identify_fuzzy_compliance_reaches_near_the_noise_floor() {
    let dir = tempfile::tempdir().unwrap();
    identify_fuzzy_compliance::write_campaign(dir.path()).unwrap();
    let outcome = identify_fuzzy_compliance::identify_fuzzy_compliance(dir.path()).unwrap();
    // Within a few noise floors on every load, trained on 900 N only.
    assert!(
        outcome.table.overall_rms_mm < 3.0 * outcome.noise_floor_mm,
        "{} mm vs floor {} mm",
        outcome.table.overall_rms_mm,
        outcome.noise_floor_mm
    );
    let text = outcome.summary_text(&Default::default());
    assert!(text.starts_with("fuzzy compliance (C_xx, C_xz, C_zx, C_zz) of (theta2, theta8)"));
    assert!(text.contains("rule base of C_xx (Table 4):\n"), "{text}");
    let floor = format!("noise in the x-z plane): {:.4} mm", outcome.noise_floor_mm);
    assert!(text.contains(&floor), "{text}");
}

#[test]
fn compensate_path_with_each_model_closes_the_predicted_error() {
    let dir = tempfile::tempdir().unwrap();
    compensate_path::write_inputs(dir.path()).unwrap();
    let (fe, fuzzy) = compensate_path::compensate_with_each_model(
        &dir.path().join("elastic"),
        &dir.path().join("path.csv"),
        dir.path(),
    )
    .unwrap();
    for commanded in [&fe, &fuzzy] {
        assert_eq!(commanded.points.len(), 4);
        // Under 920 N the loaded robot deviates by tenths of a millimetre or
        // more; the commanded path cancels the model's prediction.
        assert!(
            commanded.max_predicted_deviation_m() > 1e-4,
            "{}",
            commanded.elastic
        );
        assert!(commanded.max_residual_m() < 1e-6, "{}", commanded.elastic);
    }
    assert!(dir.path().join("commanded_fe.csv").is_file());
    assert!(dir.path().join("commanded_fuzzy.src").is_file());
    let csv = std::fs::read_to_string(dir.path().join("commanded_fuzzy.csv")).unwrap();
    assert_eq!(csv, fuzzy.to_csv(6));
}
