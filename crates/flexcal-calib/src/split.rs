//! Split-half check of the standard errors.
//!
//! The standard errors of [`crate::UnknownEstimate`] come from the
//! covariance of the linearised fit, which assumes independent measurement
//! noise. When what the model leaves is systematic (compliance it lacks,
//! thermal drift, a tracker that drifts), neighbouring poses share their
//! errors and those standard errors are too small. The check measures the
//! uncertainty another way: it identifies the same unknowns on complementary
//! halves of the poses (odd / even, first / second half in file order) and
//! compares. If the errors are independent, two complementary halves differ
//! by twice the full set's standard error on average (each half has twice
//! its variance), so `|difference| / 2` estimates it; the
//! split error is the RMS of that over the two splits. A ratio well above 1
//! (with two splits, above about 2.5 is beyond chance) says the standard
//! error understates the uncertainty by that factor. The first / second
//! split also sees drift over the campaign and regions of the workspace
//! visited at different times. With measurements from several stations
//! each station's poses are halved on their own, so that every half places
//! every station's measurement frame.

use flexcal_kinematics::Model;
use serde::Serialize;

use crate::error::CalibError;
use crate::identify::Calibration;
use crate::measurement::MeasurementSet;
use crate::options::CalibrationOptions;
use crate::prediction::prediction_variances;
use crate::unknowns::{UnknownEstimate, UnknownStatus};

/// A split error above this many standard errors is named in
/// [`SplitCheck::notes`]: with two splits and independent errors, the
/// squared ratio is a chi-square with 2 degrees of freedom over 2, which
/// exceeds 2.5^2 with a probability of 0.2 %.
pub const SPLIT_RATIO_WARNING: f64 = 2.5;

/// Options that identify again, on other poses, what `calibration`
/// identified with `options`: every unknown it did not identify stays at
/// its starting value; the measurement frame is registered anew (other
/// poses may come from another tracker position).
pub(crate) fn reidentification_options(
    options: &CalibrationOptions,
    unknowns: &[UnknownEstimate],
) -> CalibrationOptions {
    let mut reidentify = options.clone();
    reidentify.fixed = unknowns
        .iter()
        .filter(|u| u.status != UnknownStatus::Identified && !u.name.starts_with("frame_"))
        .filter(|u| u.status != UnknownStatus::NoInfluence)
        .map(|u| u.name.clone())
        .collect();
    reidentify
}

/// The unknowns a re-identification compares, with their index: those
/// `calibration` identified, the measurement frame's excepted.
pub(crate) fn compared_unknowns(
    unknowns: &[UnknownEstimate],
) -> impl Iterator<Item = (usize, &UnknownEstimate)> {
    unknowns
        .iter()
        .enumerate()
        .filter(|(_, u)| u.status == UnknownStatus::Identified && !u.name.starts_with("frame_"))
}

/// The median of `values` (the upper one of an even count), sorting them;
/// `None` when empty.
pub(crate) fn median(values: &mut [f64]) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

/// `not compared (why): names`, when there are names.
pub(crate) fn not_compared_note<'a>(
    why: &str,
    names: impl Iterator<Item = &'a str>,
) -> Option<String> {
    let names: Vec<&str> = names.collect();
    (!names.is_empty()).then(|| format!("not compared ({why}): {}", names.join(", ")))
}

/// One unknown compared over the halves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SplitEstimate {
    /// Name of the unknown.
    pub name: String,
    /// Display unit (`mm`, `deg`, `urad/N.m`, ...).
    pub unit: &'static str,
    /// Standard error of the full identification (display unit).
    pub standard_error: f64,
    /// Values identified on the odd, even, first-half and second-half poses
    /// (display unit); `None` where a half did not identify it.
    pub half_values: [Option<f64>; 4],
    /// RMS of half the differences of the two complementary pairs (display
    /// unit), when every half identified the unknown.
    pub split_error: Option<f64>,
    /// `split_error / standard_error`, when both are known and the standard
    /// error is not zero.
    pub ratio: Option<f64>,
}

/// The split-half check of a calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SplitCheck {
    /// The identified robot, target and elastic unknowns (the measurement
    /// frame is re-registered on each half, so its unknowns are not compared).
    pub unknowns: Vec<SplitEstimate>,
    /// The check in the prediction space: for each split, the two halves'
    /// calibrated target positions at every pose of the set (measurement
    /// frame) differ by `d_k`; the ratio is `sqrt(sum |d_k|^2 / 4 / sum
    /// tr(J_k Sigma J_k^T))` over the poses and the two splits, `Sigma`
    /// the full set's covariance of the identified unknowns. Each half has
    /// twice the full set's variance, so the ratio is about 1 when the
    /// standard errors hold; above 1 it is the factor by which they
    /// understate the uncertainty of what the model predicts, the
    /// correlations between unknowns kept ([`crate::AccuracyMap`] raises
    /// its bounds by it). `None` when the full set has no covariance.
    pub prediction_ratio: Option<f64>,
}

impl SplitCheck {
    /// Identifies the unknowns that `calibration` (made from `set` with
    /// `options`) identified again on four halves of `set`, every other
    /// unknown kept at its starting value, and compares.
    ///
    /// # Errors
    /// [`CalibError::TooFewPoses`] when a half has too few poses, or what
    /// [`crate::calibrate`] returns on a half.
    /// With several targets the halves are made of whole poses (every
    /// target seen at a pose goes with it), the prediction space that of
    /// every observation.
    pub fn new(
        model: &Model,
        set: &MeasurementSet,
        options: &CalibrationOptions,
        calibration: &Calibration,
    ) -> Result<Self, CalibError> {
        split_check(model, set, options, calibration)
    }

    /// What the check found, in sentences.
    pub fn notes(&self) -> Vec<String> {
        let mut ratios: Vec<f64> = self.unknowns.iter().filter_map(|u| u.ratio).collect();
        let mut notes = Vec::new();
        let Some(median) = median(&mut ratios) else {
            return notes;
        };
        let flagged: Vec<String> = self
            .unknowns
            .iter()
            .filter(|u| u.ratio.is_some_and(|r| r > SPLIT_RATIO_WARNING))
            .map(|u| format!("{} x{:.1}", u.name, u.ratio.unwrap_or_default()))
            .collect();
        notes.push(format!(
            "split-half check: the halves' estimates differ by {median:.1} times what the standard errors predict (median over {} unknowns)",
            ratios.len()
        ));
        if let Some(ratio) = self.prediction_ratio {
            notes.push(format!(
                "split-half check of the predicted target positions: the halves differ by {ratio:.1} times what the covariance predicts (predicted 95 % bounds are raised by that factor when above 1)"
            ));
        }
        if !flagged.is_empty() {
            notes.push(format!(
                "standard errors understated (split error above {SPLIT_RATIO_WARNING} standard errors): {}; what the model leaves is shared by neighbouring poses, not independent noise",
                flagged.join(", ")
            ));
        }
        notes.extend(not_compared_note(
            "some half does not identify them",
            self.unknowns
                .iter()
                .filter(|u| u.split_error.is_none())
                .map(|u| u.name.as_str()),
        ));
        notes
    }
}

/// [`SplitCheck::new`] on either kind of set.
pub(crate) fn split_check(
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
    calibration: &Calibration,
) -> Result<SplitCheck, CalibError> {
    let half_options = reidentification_options(options, &calibration.unknowns);
    // Odd, even, first-half and second-half poses; with several
    // stations, the halves of each station's poses (every half fit
    // then places every station).
    let n = set.len();
    let mut station_sizes = vec![0usize; set.n_stations()];
    let rank_in_station: Vec<usize> = (0..n)
        .map(|k| {
            let size = &mut station_sizes[set.station_of(k)];
            *size += 1;
            *size - 1
        })
        .collect();
    let in_half = |h: usize, k: usize| {
        let (r, size) = (rank_in_station[k], station_sizes[set.station_of(k)]);
        match h {
            0 => r % 2 == 1,
            1 => r % 2 == 0,
            2 => r < size / 2,
            _ => r >= size / 2,
        }
    };
    let fits = (0..4)
        .map(|h| {
            let poses: Vec<usize> = (0..n).filter(|&k| in_half(h, k)).collect();
            set.subset(&poses)?.fit(model, &half_options)
        })
        .collect::<Result<Vec<_>, CalibError>>()?;
    let unknowns = compared_unknowns(&calibration.unknowns)
        .map(|(j, u)| {
            let (unit, scale) = u.kind.display_unit();
            let half_values = [0, 1, 2, 3].map(|h| {
                let v = &fits[h].unknowns[j];
                debug_assert_eq!(v.name, u.name);
                (v.status == UnknownStatus::Identified).then_some(v.value * scale)
            });
            let split_error = match half_values {
                [Some(a), Some(b), Some(c), Some(d)] => {
                    Some((((a - b) / 2.0).powi(2) + ((c - d) / 2.0).powi(2)).sqrt() / 2f64.sqrt())
                }
                _ => None,
            };
            let standard_error = u.standard_error.unwrap_or(f64::NAN) * scale;
            SplitEstimate {
                name: u.name.clone(),
                unit,
                standard_error,
                half_values,
                split_error,
                // No ratio against a zero standard error (noise-free data).
                ratio: split_error
                    .filter(|_| standard_error > 0.0)
                    .map(|s| s / standard_error),
            }
        })
        .collect();
    let prediction_ratio = prediction_ratio(model, set, calibration, &fits)?;
    Ok(SplitCheck {
        unknowns,
        prediction_ratio,
    })
}

/// [`SplitCheck::prediction_ratio`] from the four half fits (odd, even,
/// first half, second half).
fn prediction_ratio(
    model: &Model,
    set: &MeasurementSet,
    calibration: &Calibration,
    fits: &[Calibration],
) -> Result<Option<f64>, CalibError> {
    if calibration.solve.covariance.is_none() {
        return Ok(None);
    }
    let variances = prediction_variances(calibration, model, set)?;
    let mut squared_half_differences = 0.0;
    for pair in fits.chunks(2) {
        let a = set.predicted_positions(&pair[0], model)?;
        let b = set.predicted_positions(&pair[1], model)?;
        squared_half_differences += a
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).norm_squared() / 4.0)
            .sum::<f64>();
    }
    let predicted_variance = 2.0 * variances.iter().sum::<f64>();
    Ok((predicted_variance > 0.0).then(|| (squared_half_differences / predicted_variance).sqrt()))
}
