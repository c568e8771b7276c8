//! What an earlier calibration of the same robot measured, read from its
//! JSON report (`flexcal calibrate --report`, [`calib::CalibrationReportJson`])
//! and carried into a plan ([`super::PlanConfig::prior`], `flexcal plan
//! --prior`):
//! - the model it identified: `model` (geometric or elasto-geometric) and,
//!   when model selection ran, the groups of unknowns it chose
//!   (`selection.chosen`), which the plan identifies too
//!   ([`Prior::options`]);
//! - its per-axis residual scatter (`identification.residual_scatter_mm`,
//!   [`calib::Calibration::residual_scatter`]): what this model leaves on
//!   this robot, the plan's floor in place of the instrument's noise where
//!   it is larger ([`Prior::floor`]);
//! - its split-half inflation (`split_check.prediction_ratio`, a report of
//!   `calibrate --split-check`): one factor on the identification part of
//!   every predicted bound, as `calibrate` raises its own
//!   ([`calib::AccuracyMap::inflation`]);
//! - optionally its held-out-range growth (`extrapolation`, a report of
//!   `calibrate --extrapolation`): the model's error growth per unit of
//!   distance outside the training ranges, applied to the region points
//!   outside the *planned* poses' ranges
//!   ([`calib::ExtrapolationModel::variance_at`] with the planned ranges).
//!
//! Everything here is known before the new campaign is measured.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::calib::{self, CalibrationOptions, ExtrapolationModel, TermGroup};
use crate::kinematics::Model;
use crate::{Error, Result};

/// An earlier calibration of the robot, as a plan uses it (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Prior {
    /// Where it was read from (the report's path).
    pub source: String,
    /// The robot it calibrated.
    pub robot: String,
    /// `geometric` or `elasto-geometric`: the model it identified.
    pub model: String,
    /// The groups of unknowns its model selection chose (`None`: no
    /// selection ran, every group its options allowed was identified).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chosen_groups: Option<Vec<TermGroup>>,
    /// Its per-axis residual scatter (mm): what the model left at its
    /// poses.
    pub residual_scatter_mm: f64,
    /// Its split-half check's ratio of the predicted positions' spread to
    /// the covariance's (`split_check.prediction_ratio`); the plan raises
    /// the identification part of every bound by it when above 1.
    pub prediction_ratio: f64,
    /// Its model's error growth outside its training ranges (`None`: the
    /// prior was calibrated without `--extrapolation`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extrapolation: Option<ExtrapolationModel>,
}

/// The parts of a calibration report a prior reads.
#[derive(Deserialize)]
struct ReportJson {
    robot: String,
    model: String,
    identification: IdentificationJson,
    #[serde(default)]
    split_check: Option<SplitJson>,
    #[serde(default)]
    selection: Option<SelectionJson>,
    #[serde(default)]
    extrapolation: Option<ExtrapolationModel>,
}

#[derive(Deserialize)]
struct IdentificationJson {
    #[serde(default)]
    residual_scatter_mm: Option<f64>,
}

#[derive(Deserialize)]
struct SplitJson {
    #[serde(default)]
    prediction_ratio: Option<f64>,
}

#[derive(Deserialize)]
struct SelectionJson {
    chosen: Vec<TermGroup>,
}

impl Prior {
    /// Reads the calibration report `path` (module docs).
    ///
    /// # Errors
    /// An unreadable file; [`Prior::from_report_str`]'s errors.
    pub fn read(path: &Path) -> Result<Self> {
        let text = flexcal_io::read_to_string(path)?;
        Self::from_report_str(&text, &path.display().to_string())
    }

    /// The prior of the calibration report `text` (JSON), named `source`
    /// in errors.
    ///
    /// # Errors
    /// [`Error::InvalidData`] naming `source`: not a calibration report,
    /// a report without the residual scatter (written by an older
    /// flexcal) or without the split-half check (calibrated without
    /// `--split-check`), a scatter or ratio that is not finite and
    /// positive.
    pub fn from_report_str(text: &str, source: &str) -> Result<Self> {
        let invalid = |message: String| Error::InvalidData {
            origin: source.to_string(),
            message,
        };
        let report: ReportJson = serde_json::from_str(text).map_err(|e| {
            invalid(format!(
                "not a calibration report (`flexcal calibrate --report`): {e}"
            ))
        })?;
        let scatter = report.identification.residual_scatter_mm.ok_or_else(|| {
            invalid("no identification.residual_scatter_mm: write the report again with this flexcal's `calibrate --report`".into())
        })?;
        let ratio = report
            .split_check
            .and_then(|s| s.prediction_ratio)
            .ok_or_else(|| {
                invalid(
                    "no split_check.prediction_ratio: calibrate the prior with --split-check"
                        .into(),
                )
            })?;
        for (name, v) in [
            ("identification.residual_scatter_mm", scatter),
            ("split_check.prediction_ratio", ratio),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(format!("{name} must be finite and > 0, found {v}")));
            }
        }
        Ok(Self {
            source: source.to_string(),
            robot: report.robot,
            model: report.model,
            chosen_groups: report.selection.map(|s| s.chosen),
            residual_scatter_mm: scatter,
            prediction_ratio: ratio,
            extrapolation: report.extrapolation,
        })
    }

    /// Checks that the prior calibrated `model`'s robot: the same name,
    /// and an extrapolation model over its actuated coordinates.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] `prior` naming both robots, or the
    /// coordinates' count.
    pub fn check(&self, model: &Model) -> Result<()> {
        let invalid = |message: String| Error::InvalidParameter {
            parameter: "prior".into(),
            message: format!("{}: {message}", self.source),
        };
        if self.robot != model.name() {
            return Err(invalid(format!(
                "a calibration of '{}', not of '{}'",
                self.robot,
                model.name()
            )));
        }
        if let Some(e) = &self.extrapolation
            && (e.growth.len() != model.n_actuated() || e.ranges.len() != model.n_actuated())
        {
            return Err(invalid(format!(
                "an extrapolation model of {} coordinates for the {} actuated coordinates of '{}'",
                e.growth.len(),
                model.n_actuated(),
                model.name()
            )));
        }
        Ok(())
    }

    /// The split-half inflation the plan applies: one factor on every
    /// standard deviation of the identification, the ratio when above 1
    /// (as [`calib::AccuracyMap::inflation`]).
    pub fn inflation(&self) -> f64 {
        self.prediction_ratio.max(1.0)
    }

    /// The floor of the plan's noise per axis (mm): the larger of the
    /// instrument's `noise_mm` and the prior's residual scatter, axis by
    /// axis, and whether the prior's is used on some axis.
    pub fn floor(&self, noise_mm: [f64; 3]) -> ([f64; 3], bool) {
        let floor = noise_mm.map(|s| s.max(self.residual_scatter_mm));
        (floor, floor != noise_mm)
    }

    /// `options` with the groups of unknowns the prior's model selection
    /// chose ([`calib::candidate_options`]); unchanged without selection.
    pub fn options(&self, model: &Model, options: &CalibrationOptions) -> CalibrationOptions {
        match &self.chosen_groups {
            Some(groups) => calib::candidate_options(model, options, groups),
            None => options.clone(),
        }
    }
}

/// How a plan used its prior, for its report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PriorUse {
    /// The prior.
    pub prior: Prior,
    /// The noise per axis the plan's bounds and weights use (mm): the
    /// instrument's, raised to the prior's residual scatter where that is
    /// larger.
    pub floor_mm: [f64; 3],
    /// Where the floor comes from: `the prior's residual scatter` or `the
    /// instrument's noise`.
    pub floor_source: String,
    /// The factor on the identification part of every bound.
    pub inflation: f64,
    /// Whether the region's bounds include the prior's growth outside the
    /// planned poses' ranges.
    pub extrapolation: bool,
}

impl PriorUse {
    /// One line for the plan's summary.
    pub fn describe(&self) -> String {
        let [x, y, z] = self.floor_mm;
        let groups = self.prior.chosen_groups.as_ref().map_or_else(
            || "no selection".to_string(),
            |g| g.iter().map(|g| g.label()).collect::<Vec<_>>().join(" + "),
        );
        format!(
            "prior {} ({} model, {groups}): floor {x:.4}/{y:.4}/{z:.4} mm per axis from {}, identification part raised {:.2} times by its split-half check, {}",
            self.prior.source,
            self.prior.model,
            self.floor_source,
            self.inflation,
            if self.extrapolation {
                "its growth outside the planned poses' ranges added"
            } else {
                "no extrapolation growth (the prior was calibrated without --extrapolation)"
            }
        )
    }
}
