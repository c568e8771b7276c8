//! Calibrate a robot's geometry from a measurement file and validate it on
//! another: the files here are those of the virtual IR-663's campaign, in
//! the format a real campaign writes (`identification.csv`, `validation.csv`).
//!
//! Run with `cargo run -p flexcal --example calibrate_and_validate`.

use std::error::Error;
use std::path::Path;

use flexcal::calib::{
    CalibrationOptions, FrameTreatment, MeasurementSet, ValidationReport, calibrate,
};

/// Calibrates on `dir/identification.csv`, validates on `dir/validation.csv`.
pub fn calibrate_and_validate(dir: &Path) -> Result<ValidationReport, Box<dyn Error>> {
    let robot = flexcal::load_robot("ir663")?;
    let identification = MeasurementSet::read_csv(&dir.join("identification.csv"))?;
    let validation = MeasurementSet::read_csv(&dir.join("validation.csv"))?;
    let mut options = CalibrationOptions::for_model(&robot);
    // These measurements are in the camera's frame, which the calibration
    // registers with the robot; the target is the TCP.
    options.measurement_frame = FrameTreatment::Identify;
    options.target = FrameTreatment::Fixed;
    let calibration = calibrate(&robot, &identification, &options)?;
    println!(
        "identified {} of {} parameters",
        calibration.rank(),
        robot.n_params()
    );
    let report = calibration.validate(&robot, &validation, false)?;
    println!(
        "validation: mean position error {:.3} mm nominal -> {:.3} mm calibrated",
        report.before.position_mean * 1e3,
        report.after.position_mean * 1e3
    );
    Ok(report)
}

/// Writes the virtual robot's geometric campaign into `dir`.
pub fn write_campaign(dir: &Path) -> Result<(), Box<dyn Error>> {
    let campaign = flexcal::twin::geometric::geometric_campaign(&Default::default())?;
    flexcal::twin::geometric::write_geometric_campaign(&campaign, dir)?;
    Ok(())
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    write_campaign(dir.path())?;
    calibrate_and_validate(dir.path())?;
    Ok(())
}
