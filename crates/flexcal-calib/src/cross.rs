//! Cross-series check: do two measurement campaigns agree on the robot?
//!
//! Validating on another series (the paper's 16 other poses, or an IPA
//! series measured from another tracker position) says how well the
//! identified model predicts there. It does not say which identified values
//! the other series would have given. The check identifies the same unknowns
//! again on the validation poses (the measurement frame registered anew,
//! every unknown the first identification did not identify kept at its
//! starting value) and compares each with its first value:
//!
//! `z = (other - first) / sqrt(se_first^2 + se_other^2)`.
//!
//! With independent errors and a model that holds on both pose sets, `z` is
//! standard normal: `|z|` has a median of 0.67 and exceeds
//! [`CROSS_Z_WARNING`] = 3 with a probability of 0.27 %. A value with a
//! larger `|z|` stands for something that differs between the two pose sets
//! (an effect the model lacks, which the two campaigns weight differently,
//! or a change of the robot between them): it does not transfer.
//!
//! The standard errors assume independent errors. When the split-half check
//! ([`crate::SplitCheck`]) finds them understated by a factor, `|z|` is
//! overstated by about that factor; given the identification's split check,
//! the check runs one on the other set too and also reports `z_split`, with
//! each standard error raised to its split error where that is larger, and
//! judges by it.

use flexcal_kinematics::Model;
use serde::Serialize;

use crate::error::CalibError;
use crate::identify::Calibration;
use crate::measurement::MeasurementSet;
use crate::options::CalibrationOptions;
use crate::split::{
    SplitCheck, compared_unknowns, median, not_compared_note, reidentification_options, split_check,
};
use crate::unknowns::UnknownStatus;

/// A `|z|` above this is named in [`CrossCheck::notes`]: for a standard
/// normal `z` the probability is 0.27 %.
pub const CROSS_Z_WARNING: f64 = 3.0;

/// One unknown identified on both sets.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossEstimate {
    /// Name of the unknown.
    pub name: String,
    /// Display unit (`mm`, `deg`, `urad/N.m`, ...).
    pub unit: &'static str,
    /// Value identified on the identification set (display unit).
    pub value: f64,
    /// Its standard error (display unit).
    pub standard_error: f64,
    /// Value identified on the other set (display unit), `None` when that
    /// set does not identify it.
    pub other_value: Option<f64>,
    /// Its standard error (display unit).
    pub other_standard_error: Option<f64>,
    /// `(other - value) / sqrt(se^2 + se_other^2)` (dimensionless), when
    /// both are identified with a non-zero combined standard error.
    pub z: Option<f64>,
    /// Split error of `value` (display unit), with the split checks.
    pub split_error: Option<f64>,
    /// Split error of `other_value` (display unit), with the split checks.
    pub other_split_error: Option<f64>,
    /// `z` with each standard error raised to its split error where that is
    /// larger (dimensionless), when both split errors are known.
    pub z_split: Option<f64>,
}

impl CrossEstimate {
    /// The `z` the check judges by: `z_split` when known, else `z`.
    pub fn judged_z(&self) -> Option<f64> {
        self.z_split.or(self.z)
    }
}

/// The cross-series check of a calibration against another measurement set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossCheck {
    /// Name of the other set (its file).
    pub other_set: String,
    /// Poses of the other set.
    pub other_poses: usize,
    /// The robot, target and elastic unknowns the identification identified
    /// (the measurement frames are each set's own and not compared).
    pub unknowns: Vec<CrossEstimate>,
    /// Why the other set has no split-half check when one was asked for
    /// (too few poses to halve); `z_split` is then unknown.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub other_split_failure: Option<String>,
}

impl CrossCheck {
    /// Identifies the unknowns that `calibration` (made with `options`)
    /// identified again on `other`, every other unknown kept at its starting
    /// value and the measurement frame registered anew, and compares. With
    /// `split`, the split-half check of `calibration`, the other set gets a
    /// split check of its own and the estimates their `z_split`.
    ///
    /// # Errors
    /// What [`crate::calibrate`] returns on `other` (too few poses, a
    /// kinematic failure naming the pose) or on its halves (but too few
    /// poses there, which leaves `z_split` unknown and says why in
    /// [`CrossCheck::other_split_failure`]).
    pub fn new(
        model: &Model,
        other: &MeasurementSet,
        options: &CalibrationOptions,
        calibration: &Calibration,
        split: Option<&SplitCheck>,
    ) -> Result<Self, CalibError> {
        cross_check(model, other, options, calibration, split)
    }

    /// The unknowns whose `|z|` exceeds [`CROSS_Z_WARNING`].
    pub fn disagreeing(&self) -> impl Iterator<Item = &CrossEstimate> {
        self.unknowns
            .iter()
            .filter(|u| u.judged_z().is_some_and(|z| z.abs() > CROSS_Z_WARNING))
    }

    /// What the check found, in sentences.
    pub fn notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        let with_split = self.unknowns.iter().any(|u| u.z_split.is_some());
        let mut magnitudes: Vec<f64> = self
            .unknowns
            .iter()
            .filter_map(|u| u.judged_z().map(f64::abs))
            .collect();
        let Some(median) = median(&mut magnitudes) else {
            return notes;
        };
        let errors = if with_split {
            "combined standard errors, each raised to its split error where larger"
        } else {
            "combined standard errors"
        };
        notes.push(format!(
            "cross-series check on {}: the two identifications differ by {median:.1} {errors} (median |z| over {} unknowns; 0.67 when both sets hold the same robot and independent noise)",
            self.other_set,
            magnitudes.len()
        ));
        let disagreeing: Vec<String> = self
            .disagreeing()
            .map(|u| {
                format!(
                    "{} ({:.4} here, {:.4} {} there, z {:+.1})",
                    u.name,
                    u.value,
                    u.other_value.unwrap_or(f64::NAN),
                    u.unit,
                    u.judged_z().unwrap_or(f64::NAN)
                )
            })
            .collect();
        if !disagreeing.is_empty() {
            notes.push(format!(
                "the sets disagree beyond {CROSS_Z_WARNING} {errors} on {}: these values stand for something that differs between the two pose sets (an effect the model lacks, weighted differently by each) and do not transfer from one to the other",
                disagreeing.join(", ")
            ));
        }
        notes.extend(not_compared_note(
            "the other set does not identify them",
            self.unknowns
                .iter()
                .filter(|u| u.other_value.is_none())
                .map(|u| u.name.as_str()),
        ));
        if let Some(why) = &self.other_split_failure {
            notes.push(format!(
                "no split-half check on the other set ({why}): judged by the plain standard errors"
            ));
        }
        notes
    }
}

/// [`CrossCheck::new`] on either kind of set.
fn cross_check(
    model: &Model,
    other: &MeasurementSet,
    options: &CalibrationOptions,
    calibration: &Calibration,
    split: Option<&SplitCheck>,
) -> Result<CrossCheck, CalibError> {
    let other_options = reidentification_options(options, &calibration.unknowns);
    let refit = other.fit(model, &other_options)?;
    // A set too small to halve gets no split check: z alone, and a note.
    let (other_split, other_split_failure) =
        match split.map(|_| split_check(model, other, &other_options, &refit)) {
            Some(Ok(check)) => (Some(check), None),
            Some(Err(e @ CalibError::TooFewPoses { .. })) => (None, Some(e.to_string())),
            Some(Err(e)) => return Err(e),
            None => (None, None),
        };
    let split_error = |check: Option<&SplitCheck>, name: &str| {
        check
            .and_then(|c| c.unknowns.iter().find(|u| u.name == name))
            .and_then(|u| u.split_error)
    };
    let unknowns = compared_unknowns(&calibration.unknowns)
        .map(|(_, u)| {
            let (unit, scale) = u.kind.display_unit();
            // The same unknowns in the same order; found by name all the same.
            let other = refit
                .unknowns
                .iter()
                .find(|o| o.name == u.name && o.status == UnknownStatus::Identified);
            let value = u.value * scale;
            let standard_error = u.standard_error.unwrap_or(f64::NAN) * scale;
            let other_value = other.map(|o| o.value * scale);
            let other_standard_error = other.and_then(|o| o.standard_error).map(|s| s * scale);
            let z = |se: f64, other_se: f64| {
                let combined = se.hypot(other_se);
                other_value
                    .filter(|_| combined > 0.0)
                    .map(|v| (v - value) / combined)
            };
            let (first_split, second_split) = (
                split_error(split, &u.name),
                split_error(other_split.as_ref(), &u.name),
            );
            CrossEstimate {
                name: u.name.clone(),
                unit,
                value,
                standard_error,
                other_value,
                other_standard_error,
                z: other_standard_error.and_then(|s| z(standard_error, s)),
                split_error: first_split,
                other_split_error: second_split,
                z_split: match (first_split, second_split, other_standard_error) {
                    (Some(a), Some(b), Some(s)) => z(standard_error.max(a), s.max(b)),
                    _ => None,
                },
            }
        })
        .collect();
    Ok(CrossCheck {
        other_set: other.source.clone(),
        other_poses: other.len(),
        unknowns,
        other_split_failure,
    })
}
