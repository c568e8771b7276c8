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
//! or a change of the robot between them): it does not transfer. When the
//! split-half check ([`crate::SplitCheck`]) finds the standard errors
//! understated by a factor, `|z|` is overstated by about that factor.

use flexcal_kinematics::Model;
use serde::Serialize;

use crate::identify::{Calibration, CalibrationOptions, UnknownStatus, calibrate};
use crate::split::{compared_unknowns, median, reidentification_options};
use crate::{CalibError, MeasurementSet};

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
}

impl CrossCheck {
    /// Identifies the unknowns that `calibration` (made with `options`)
    /// identified again on `other`, every other unknown kept at its starting
    /// value and the measurement frame registered anew, and compares.
    ///
    /// # Errors
    /// What [`calibrate`] returns on `other` (too few poses, a kinematic
    /// failure naming the pose).
    pub fn new(
        model: &Model,
        other: &MeasurementSet,
        options: &CalibrationOptions,
        calibration: &Calibration,
    ) -> Result<Self, CalibError> {
        let refit = calibrate(
            model,
            other,
            &reidentification_options(options, calibration),
        )?;
        let unknowns = compared_unknowns(calibration)
            .map(|(_, u)| {
                let (unit, scale) = u.kind.display_unit();
                // The same unknowns in the same order; found by name all the same.
                let other = refit
                    .unknowns
                    .iter()
                    .find(|o| o.name == u.name && o.status == UnknownStatus::Identified);
                let standard_error = u.standard_error.unwrap_or(f64::NAN) * scale;
                let other_value = other.map(|o| o.value * scale);
                let other_standard_error = other.and_then(|o| o.standard_error).map(|s| s * scale);
                let z = match (other_value, other_standard_error) {
                    (Some(v), Some(s)) => {
                        let combined = standard_error.hypot(s);
                        (combined > 0.0).then(|| (v - u.value * scale) / combined)
                    }
                    _ => None,
                };
                CrossEstimate {
                    name: u.name.clone(),
                    unit,
                    value: u.value * scale,
                    standard_error,
                    other_value,
                    other_standard_error,
                    z,
                }
            })
            .collect();
        Ok(Self {
            other_set: other.source.clone(),
            other_poses: other.len(),
            unknowns,
        })
    }

    /// The unknowns whose `|z|` exceeds [`CROSS_Z_WARNING`].
    pub fn disagreeing(&self) -> impl Iterator<Item = &CrossEstimate> {
        self.unknowns
            .iter()
            .filter(|u| u.z.is_some_and(|z| z.abs() > CROSS_Z_WARNING))
    }

    /// What the check found, in sentences.
    pub fn notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        let mut magnitudes: Vec<f64> = self
            .unknowns
            .iter()
            .filter_map(|u| u.z.map(f64::abs))
            .collect();
        let Some(median) = median(&mut magnitudes) else {
            return notes;
        };
        notes.push(format!(
            "cross-series check on {}: the two identifications differ by {median:.1} combined standard errors (median |z| over {} unknowns; 0.67 when both sets hold the same robot and independent noise)",
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
                    u.z.unwrap_or(f64::NAN)
                )
            })
            .collect();
        if !disagreeing.is_empty() {
            notes.push(format!(
                "the sets disagree beyond {CROSS_Z_WARNING} combined standard errors on {}: these values stand for something that differs between the two pose sets (an effect the model lacks, weighted differently by each) and do not transfer from one to the other",
                disagreeing.join(", ")
            ));
        }
        let missing: Vec<&str> = self
            .unknowns
            .iter()
            .filter(|u| u.other_value.is_none())
            .map(|u| u.name.as_str())
            .collect();
        if !missing.is_empty() {
            notes.push(format!(
                "not compared (the other set does not identify them): {}",
                missing.join(", ")
            ));
        }
        notes
    }
}
