//! Cross-series table on the IPA UR10 data (the dataset README's baseline
//! protocol): calibrate on one series, validate on another, re-fitting only
//! the tracker -> base transform on the validation series.
//!
//! `cargo run --release -p flexcal-calib --example ipa_table`

use std::path::PathBuf;
use std::time::Instant;

use flexcal_calib::{CalibrationOptions, MeasurementSet, Weighting, calibrate};
use flexcal_kinematics::RobotDescription;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets/ipa-ur10");
    if !root.exists() {
        println!("IPA UR10 data absent ({}): nothing to do", root.display());
        return Ok(());
    }
    let files = [
        ("B", "Series_B/measurements_joint_configurations.csv"),
        ("C", "Series_C/measurements_random_poses.csv"),
        ("D", "Series_D/measurements_iso_cubes.csv"),
    ];
    let model = RobotDescription::builtin("ur10")?.build()?;
    let sets: Vec<(&str, MeasurementSet)> = files
        .iter()
        .map(|(name, file)| Ok((*name, MeasurementSet::read_ipa(&root.join(file))?)))
        .collect::<Result<_, flexcal_calib::CalibError>>()?;
    let mut options = CalibrationOptions::for_model(&model);
    options.use_orientation = Some(false);
    options.weighting = Weighting::Uniform;
    if let Ok(v) = std::env::var("FLEXCAL_SE_ANGLE_DEG") {
        options.max_standard_error_angle = v.parse::<f64>()?.to_radians();
    }
    if let Ok(v) = std::env::var("FLEXCAL_SE_LENGTH_MM") {
        options.max_standard_error_length = v.parse::<f64>()? * 1e-3;
    }
    println!(
        "| train -> validate | nominal (mean / max mm) | flexcal geometric (mean / max mm) | rank | kept at nominal |"
    );
    println!("|---|---|---|---|---|");
    for (train_name, train) in &sets {
        let start = Instant::now();
        let calibration = calibrate(&model, train, &options)?;
        let elapsed = start.elapsed();
        let mut kept: Vec<&str> = calibration.non_identifiable();
        kept.extend(calibration.poorly_identifiable());
        for (validate_name, validate) in &sets {
            if validate_name == train_name {
                continue;
            }
            let report = calibration.validate(&model, validate, false)?;
            println!(
                "| {train_name} -> {validate_name} | {:.3} / {:.2} | {:.3} / {:.2} | {} | {} |",
                report.before.position_mean * 1e3,
                report.before.position_max * 1e3,
                report.after.position_mean * 1e3,
                report.after.position_max * 1e3,
                calibration.rank(),
                kept.join(" ")
            );
        }
        eprintln!(
            "trained on {train_name}: {:.3} mm mean on the training set, {:?}, {:.1} ms",
            calibration.training_after.position_mean * 1e3,
            calibration.solve.termination,
            elapsed.as_secs_f64() * 1e3
        );
    }
    Ok(())
}
