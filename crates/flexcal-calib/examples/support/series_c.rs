//! IPA UR10 series C and the calibration benchmark's elasto-geometric
//! options for it, shared by the speed examples.

use std::path::PathBuf;

use flexcal_calib::{CalibrationOptions, GravityCompliance, MeasurementSet, Weighting};
use flexcal_kinematics::{Model, RobotDescription};

/// A robot, a measurement set and the options to identify it with.
pub type Case = (Model, MeasurementSet, CalibrationOptions);

/// The UR10, series C (2 773 poses, positions only) and the benchmark's
/// elasto-geometric options (compliances under gravity and the payload,
/// uniform weights); `None`, with a message naming `what` is skipped, when
/// the data is absent.
pub fn series_c(what: &str) -> Result<Option<Case>, Box<dyn std::error::Error>> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ipa-ur10/Series_C/measurements_random_poses.csv");
    if !path.exists() {
        println!("IPA UR10 data absent ({}): {what}", path.display());
        return Ok(None);
    }
    let model = RobotDescription::builtin("ur10")?.build()?;
    let set = MeasurementSet::read_ipa(&path)?;
    let mut options = CalibrationOptions::for_model(&model);
    options.use_orientation = Some(false);
    options.weighting = Weighting::Uniform;
    options.gravity = Some(GravityCompliance::ur10_urdf(&model)?);
    Ok(Some((model, set, options)))
}
