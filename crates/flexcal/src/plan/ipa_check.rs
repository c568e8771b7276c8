//! The plan's predictions checked on the IPA UR10 laser-tracker data
//! ([`ipa_plan_check`]): the bounds predicted from one series'
//! configurations alone (no measurement read), then the calibration on
//! that series' measurements validated on another series, and the share of
//! the other series' poses within their predicted bound, with the
//! actuated coordinates the misses lie outside the training range of.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{Instrument, predict_campaign};
use crate::Result;
use crate::calib::{self, CalibrationOptions, MeasurementSet, Weighting};
use crate::kinematics::Model;

/// Result of [`ipa_plan_check`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IpaPlanCheck {
    /// `B -> C`, ...
    pub pair: String,
    /// The stated instrument noise per axis (mm).
    pub noise_mm: f64,
    /// Predicted mean 95 % bound over the validation poses (mm).
    pub predicted_mean_bound_95_mm: f64,
    /// Achieved mean error over the validation poses (mm).
    pub achieved_mean_error_mm: f64,
    /// Number of validation poses.
    pub poses: usize,
    /// Share of validation poses within their predicted bound.
    pub coverage: f64,
    /// Misses (poses outside their bound) per actuated coordinate outside
    /// whose training range they lie (`(name, misses)`), and the misses
    /// inside every range.
    pub misses_outside: Vec<(String, usize)>,
    /// Misses inside every training range.
    pub misses_inside: usize,
}

/// Plans from `train`'s configurations alone with the dataset's protocol
/// (positions only, the probe offset of the file as the target's start)
/// and the instrument's stated `noise_mm`, then calibrates on `train`'s
/// measurements (uniform weights, as `calibrate --format ipa`) and
/// validates on `validate` (IPA export files).
///
/// # Errors
/// Unreadable files, planning and calibration errors.
pub fn ipa_plan_check(
    model: &Model,
    pair: &str,
    train: &Path,
    validate: &Path,
    noise_mm: f64,
) -> Result<IpaPlanCheck> {
    let train = MeasurementSet::read_ipa(train)?;
    let validate = MeasurementSet::read_ipa(validate)?;
    let mut options = CalibrationOptions::for_model(model);
    options.use_orientation = Some(false);
    options.target_value = train.nominal_target;
    let q = |set: &MeasurementSet| -> Vec<Vec<f64>> {
        set.measurements().iter().map(|m| m.q.clone()).collect()
    };
    let instrument = Instrument::positions([noise_mm; 3]);
    let predicted = predict_campaign(model, &options, &instrument, &q(&train), &q(&validate))?;
    options.weighting = Weighting::Uniform;
    let calibration = calib::calibrate(model, &train, &options)?;
    let report = calibration.validate(model, &validate, false)?;
    let names = model.actuated_names();
    let mut misses_outside = vec![0usize; names.len()];
    let mut misses_inside = 0;
    let mut within = 0;
    for (error, p) in report.after_per_pose.iter().zip(&predicted.map.poses) {
        if error.position * 1e3 <= p.bound_95_mm {
            within += 1;
            continue;
        }
        let outside: Vec<usize> = calibration.outside_training_range(&p.q).collect();
        if outside.is_empty() {
            misses_inside += 1;
        }
        outside.into_iter().for_each(|i| misses_outside[i] += 1);
    }
    Ok(IpaPlanCheck {
        pair: pair.to_string(),
        noise_mm,
        predicted_mean_bound_95_mm: predicted.accuracy.mean_bound_95_mm,
        achieved_mean_error_mm: report.after.position_mean * 1e3,
        poses: report.after_per_pose.len(),
        coverage: within as f64 / report.after_per_pose.len().max(1) as f64,
        misses_outside: names
            .iter()
            .cloned()
            .zip(misses_outside)
            .filter(|(_, n)| *n > 0)
            .collect(),
        misses_inside,
    })
}
