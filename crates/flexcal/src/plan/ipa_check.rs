//! The plan's predictions checked on the IPA UR10 laser-tracker data
//! ([`ipa_plan_check`]): the bounds predicted from one series'
//! configurations alone (no measurement read), then the calibration on
//! that series' measurements validated on another series, and the share of
//! the other series' poses within their predicted bound, with the misses
//! sorted by the training ranges they leave ([`MissesByRange`]). The
//! plan's noise is stated: the tracker's, or the residual scatter of an
//! earlier campaign of the robot ([`prior_residual_scatter_mm`]), the
//! floor of what a calibration of this model leaves.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{Instrument, predict_campaign};
use crate::calib::{self, CalibrationOptions, MeasurementSet, MissesByRange, Weighting};
use crate::kinematics::Model;
use crate::{Error, Result};

/// Result of [`ipa_plan_check`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IpaPlanCheck {
    /// `B -> C`, ...
    pub pair: String,
    /// The noise per axis the plan was given (mm).
    pub noise_mm: f64,
    /// Where that noise comes from (the tracker's stated noise, an earlier
    /// campaign's residual scatter).
    pub noise_source: String,
    /// Predicted mean 95 % bound over the validation poses (mm).
    pub predicted_mean_bound_95_mm: f64,
    /// Achieved mean error over the validation poses (mm).
    pub achieved_mean_error_mm: f64,
    /// Number of validation poses.
    pub poses: usize,
    /// Share of validation poses within their predicted bound.
    pub coverage: f64,
    /// The misses sorted by the training ranges they leave: per actuated
    /// coordinate those leaving its range may explain, and those inside
    /// every range, which it does not.
    pub misses: MissesByRange,
}

/// The calibration options of the check for the IPA series `set`: the
/// model's default, positions only, the probe offset of the file as the
/// target's start.
fn ipa_options(model: &Model, set: &MeasurementSet) -> CalibrationOptions {
    let mut options = CalibrationOptions::for_model(model);
    options.use_orientation = Some(false);
    options.target_value = set.nominal_target();
    options
}

/// The per-axis residual scatter (mm) of the calibration of the IPA series
/// `prior` with the check's options (uniform weights, as `calibrate
/// --format ipa`): what a calibration of this robot and model leaves, the
/// floor to state as a later plan's noise
/// ([`calib::Calibration::residual_scatter`]).
///
/// # Errors
/// An unreadable file, the calibration's errors.
pub fn prior_residual_scatter_mm(model: &Model, prior: &Path) -> Result<f64> {
    let prior = MeasurementSet::read_ipa(prior)?;
    let mut options = ipa_options(model, &prior);
    options.weighting = Weighting::Uniform;
    Ok(calib::calibrate(model, &prior, &options)?.residual_scatter() * 1e3)
}

/// Plans from `train`'s configurations alone with the dataset's protocol
/// (positions only, the probe offset of the file as the target's start)
/// and the stated `noise_mm` per axis (from `noise_source`: the tracker's
/// noise, or an earlier campaign's [`prior_residual_scatter_mm`]), then
/// calibrates on `train`'s measurements (uniform weights, as `calibrate
/// --format ipa`), validates on `validate` (IPA export files) and sorts
/// the misses of the planned bounds by the training ranges they leave.
///
/// # Errors
/// Unreadable files, planning and calibration errors.
pub fn ipa_plan_check(
    model: &Model,
    pair: &str,
    train: &Path,
    validate: &Path,
    noise_mm: f64,
    noise_source: &str,
) -> Result<IpaPlanCheck> {
    let train = MeasurementSet::read_ipa(train)?;
    let validate = MeasurementSet::read_ipa(validate)?;
    let mut options = ipa_options(model, &train);
    let q = |set: &MeasurementSet| -> Vec<Vec<f64>> {
        set.poses().iter().map(|p| p.q.clone()).collect()
    };
    let instrument = Instrument::positions([noise_mm; 3]);
    let mut predicted = predict_campaign(
        model,
        &options,
        &instrument,
        None,
        (&q(&train), &q(&validate)),
        None,
    )?;
    options.weighting = Weighting::Uniform;
    let calibration = calib::calibrate(model, &train, &options)?;
    let report = calibration.validate(model, &validate, false)?;
    for (p, error) in predicted.map.poses.iter_mut().zip(&report.after_per_pose) {
        p.actual_error_mm = Some(error.position * 1e3);
    }
    let misses = predicted
        .map
        .misses_by_range()
        .ok_or_else(|| Error::InvalidData {
            origin: validate.source.clone(),
            message: format!(
                "{} validation errors for {} poses",
                report.after_per_pose.len(),
                predicted.map.poses.len()
            ),
        })?;
    Ok(IpaPlanCheck {
        pair: pair.to_string(),
        noise_mm,
        noise_source: noise_source.to_string(),
        predicted_mean_bound_95_mm: predicted.accuracy.mean_bound_95_mm,
        achieved_mean_error_mm: report.after.position_mean * 1e3,
        poses: report.after_per_pose.len(),
        coverage: 1.0 - misses.all.rate(),
        misses,
    })
}
