//! The plan's predictions checked on the IPA UR10 laser-tracker data
//! ([`ipa_plan_check`]): the bounds predicted from one series'
//! configurations alone (no measurement read), then the calibration on
//! that series' measurements validated on another series, and the share of
//! the other series' poses within their predicted bound, with the misses
//! sorted by the training ranges they leave ([`MissesByRange`]). The
//! plan's noise is stated: the tracker's, or the residual scatter of an
//! earlier campaign of the robot ([`prior_residual_scatter_mm`]), the
//! floor of what a calibration of this model leaves; or the plan takes
//! that earlier campaign's calibration as its prior ([`ipa_prior`],
//! [`ipa_prior_check`]: its model, floor, split-half inflation and
//! growth outside the training ranges, as `plan --prior`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{Instrument, Prior, predict_campaign};
use crate::calib::{self, CalibrationOptions, MeasurementSet, MissesByRange, Weighting};
use crate::kinematics::Model;
use crate::{Error, Result};

/// Result of [`ipa_plan_check`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IpaPlanCheck {
    /// `B -> C`, ...
    pub pair: String,
    /// The model identified by the plan and the calibration.
    pub model: String,
    /// The noise per axis the plan's bounds use (mm): the stated noise, or
    /// with a prior the floor.
    pub noise_mm: f64,
    /// Where that noise comes from (the tracker's stated noise, an earlier
    /// campaign's residual scatter).
    pub noise_source: String,
    /// The factor on the identification part of the bounds (1 without a
    /// prior).
    pub inflation: f64,
    /// The mean of each part of the predicted bounds over the validation
    /// poses (mm).
    pub mean_parts_mm: calib::BoundParts,
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
/// calibrates on `train`'s measurements (the geometric model, uniform
/// weights, as `calibrate --format ipa`), validates on `validate` (IPA
/// export files) and sorts the misses of the planned bounds by the
/// training ranges they leave.
///
/// # Errors
/// Unreadable files, planning and calibration errors.
pub fn ipa_plan_check(
    model: &Model,
    pair: &str,
    (train, validate): (&Path, &Path),
    noise_mm: f64,
    noise_source: &str,
) -> Result<IpaPlanCheck> {
    let sets = read_pair(train, validate)?;
    let options = ipa_options(model, &sets.0);
    let instrument = Instrument::positions([noise_mm; 3]);
    check_pair(
        model,
        pair,
        &sets,
        &options,
        (&instrument, noise_source),
        None,
    )
}

/// The training and validation series of a pair, read from their IPA
/// export files.
///
/// # Errors
/// Unreadable files.
fn read_pair(train: &Path, validate: &Path) -> Result<(MeasurementSet, MeasurementSet)> {
    Ok((
        MeasurementSet::read_ipa(train)?,
        MeasurementSet::read_ipa(validate)?,
    ))
}

/// The tracker's stated noise per axis on the IPA data (mm).
pub const TRACKER_NOISE_MM: f64 = 0.02;

/// The prior of the check: the IPA series `prior` calibrated as `flexcal
/// calibrate --robot ur10 --format ipa --model elasto-geometric
/// --select-on interpolation --split-check --extrapolation` writes its
/// report (positions only, uniform weights, the robot's built-in mass
/// table; the groups of unknowns chosen by cross-validation on its own
/// ordinary folds, the split-half check, the held-out-range growth from
/// its own set), read back through the report's JSON as `plan --prior`
/// reads it ([`Prior::from_report_str`]).
///
/// # Errors
/// An unreadable file, the robot's mass table, the calibration's and the
/// checks' errors.
pub fn ipa_prior(model: &Model, prior: &Path) -> Result<Prior> {
    let set = MeasurementSet::read_ipa(prior)?;
    let base = elastic_options(model, &set)?;
    let selection = calib::SelectionOptions {
        select_on: calib::SelectOn::Interpolation,
        ..Default::default()
    };
    let (calibration, chosen, options) = calib::calibrate_selected(model, &set, &base, &selection)?;
    let mut report = calib::CalibrationReportJson::new(model.name(), &calibration, None);
    report.split_check = Some(calib::SplitCheck::new(model, &set, &options, &calibration)?);
    report.selection = chosen;
    report.extrapolation = Some(calibration.extrapolation(model, &set, &options)?);
    let text = serde_json::to_string(&report).map_err(|source| Error::Json {
        context: format!("the report of {}", set.source),
        source,
    })?;
    Prior::from_report_str(&text, &set.source)
}

/// The elasto-geometric options of the check for the IPA series `set`:
/// [`ipa_options`] with the robot's mass table, as `calibrate --model
/// elasto-geometric` takes it.
fn elastic_options(model: &Model, set: &MeasurementSet) -> Result<CalibrationOptions> {
    let mut options = ipa_options(model, set);
    options.weighting = Weighting::Uniform;
    let spec = crate::RobotSpec::parse(model.name())?;
    options.gravity = Some(spec.mass_table(&Default::default(), model, None)?);
    Ok(options)
}

/// [`ipa_plan_check`] with `prior` ([`ipa_prior`]): the plan and the
/// calibration on `train` identify the prior's model (its chosen groups
/// of the elasto-geometric model: like with like), the plan states the
/// tracker's noise and takes its floor, inflation and extrapolation growth
/// from the prior, as `flexcal plan --prior` does; `noise_source` names
/// the row.
///
/// # Errors
/// As [`ipa_plan_check`].
pub fn ipa_prior_check(
    model: &Model,
    pair: &str,
    (train, validate): (&Path, &Path),
    prior: &Prior,
    noise_source: &str,
) -> Result<IpaPlanCheck> {
    let sets = read_pair(train, validate)?;
    let options = prior.options(model, &elastic_options(model, &sets.0)?);
    let instrument = Instrument::positions([TRACKER_NOISE_MM; 3]);
    check_pair(
        model,
        pair,
        &sets,
        &options,
        (&instrument, noise_source),
        Some(prior),
    )
}

/// The plan of `train`'s configurations with `options` and `instrument`
/// (and `prior`), its bounds at `validate`'s poses against the errors of
/// the calibration of `train` with `options` (uniform weights).
fn check_pair(
    model: &Model,
    pair: &str,
    (train, validate): &(MeasurementSet, MeasurementSet),
    options: &CalibrationOptions,
    (instrument, noise_source): (&Instrument, &str),
    prior: Option<&Prior>,
) -> Result<IpaPlanCheck> {
    let q = |set: &MeasurementSet| -> Vec<Vec<f64>> {
        set.poses().iter().map(|p| p.q.clone()).collect()
    };
    let mut predicted = predict_campaign(
        model,
        options,
        instrument,
        None,
        (&q(train), &q(validate)),
        prior,
    )?;
    let mut options = options.clone();
    options.weighting = Weighting::Uniform;
    let calibration = calib::calibrate(model, train, &options)?;
    let report = calibration.validate(model, validate, false)?;
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
    let poses = &predicted.map.poses;
    let mean = |f: fn(&calib::BoundParts) -> f64| {
        poses.iter().map(|p| f(&p.parts)).sum::<f64>() / poses.len().max(1) as f64
    };
    Ok(IpaPlanCheck {
        pair: pair.to_string(),
        model: model_label(&calibration, &options),
        noise_mm: predicted.map.residual_scatter_mm,
        noise_source: noise_source.to_string(),
        inflation: predicted.map.inflation,
        mean_parts_mm: calib::BoundParts {
            scatter_mm: mean(|p| p.scatter_mm),
            parameters_mm: mean(|p| p.parameters_mm),
            extrapolation_mm: mean(|p| p.extrapolation_mm),
        },
        predicted_mean_bound_95_mm: predicted.accuracy.mean_bound_95_mm,
        achieved_mean_error_mm: report.after.position_mean * 1e3,
        poses: report.after_per_pose.len(),
        coverage: 1.0 - misses.all.rate(),
        misses,
    })
}

/// `geometric`, or `elasto-geometric` with the compliances the
/// calibration kept, for the check's rows.
fn model_label(calibration: &calib::Calibration, options: &CalibrationOptions) -> String {
    if options.gravity.is_none() {
        return "geometric".into();
    }
    let compliances = calibration
        .unknowns
        .iter()
        .filter(|u| {
            u.status == calib::UnknownStatus::Identified && u.name.starts_with("compliance_")
        })
        .count();
    format!("elasto-geometric ({compliances} compliances identified)")
}
