//! The plan's predictions checked on the virtual IR-663
//! ([`twin_plan_check`]): the twin measures 300 candidate and 100 region
//! poses of box (59) with its own truth (geometric errors, its own weight
//! through its FE structure, drives' lost motion and hardening,
//! transmission errors, the camera's frame and noise; none of them the
//! identified model); plans of N poses are calibrated on the twin's
//! measurements of the planned poses and validated over the region, and
//! the achieved errors compared with the plan's predicted bounds. Each
//! count is planned and calibrated twice: with the camera's positions
//! only, and with its full poses (the orientations the twin measures,
//! weighted by the camera's orientation noise), planning and calibration
//! always measuring the same. Then a planned full-pose campaign against
//! random draws and the O1-selected set of the same size, calibrated on
//! full poses too.

use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use super::{CampaignPlan, Instrument, PlanConfig, PoseSource, plan_campaign, predict_campaign};
use crate::calib::{self, CalibrationOptions, FrameTreatment, MeasurementSet, MissesByRange};
use crate::kinematics::Model;
use crate::pose_file::Located;
use crate::twin::geometric::{GeometricCampaignOptions, geometric_campaign};
use crate::twin::truth::TruthSwitches;
use crate::{Error, Result};

/// Number of candidate poses the twin measures.
pub const TWIN_CANDIDATES: usize = 300;
/// Number of region poses the twin measures.
pub const TWIN_REGION: usize = 100;

/// One planned campaign of the check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlannedCampaignCheck {
    /// Number of planned poses.
    pub poses: usize,
    /// Whether the campaign measures full poses (else positions only),
    /// both in the plan and in the calibration.
    pub full_poses: bool,
    /// Why the campaign could not be planned or calibrated (then the
    /// figures are zero).
    pub refused: Option<String>,
    /// Predicted accuracy over the region.
    pub predicted: Option<super::RegionAccuracy>,
    /// Share of region poses whose achieved error is within the plan's
    /// 95 % bound there.
    pub coverage: f64,
    /// Mean achieved error over the region after calibration (mm).
    pub achieved_mean_error_mm: f64,
    /// Region poses outside the planned poses' joint ranges.
    pub extrapolated: usize,
    /// The misses of the planned bounds sorted by the planned poses'
    /// ranges they leave (`None` when refused).
    pub misses: Option<MissesByRange>,
}

/// Result of [`twin_plan_check`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwinPlanCheck {
    /// Seed of the twin's campaign.
    pub seed: u64,
    /// The camera's noise per axis (mm).
    pub noise_mm: f64,
    /// The camera's orientation noise about x, y, z of its frame (deg).
    pub orientation_noise_deg: [f64; 3],
    /// One entry per count asked and per instrument mode (positions
    /// only, then full poses).
    pub planned: Vec<PlannedCampaignCheck>,
    /// Number of poses of the comparison (full poses measured).
    pub compared_poses: usize,
    /// Achieved mean error of the planned campaign of that size (mm).
    pub planned_mean_error_mm: f64,
    /// Achieved mean error of each random draw of that size (mm), sorted.
    pub random_mean_errors_mm: Vec<f64>,
    /// Achieved mean error of the O1-selected set (mm).
    pub o1_mean_error_mm: f64,
    /// Predicted mean error of the O1-selected set (mm).
    pub o1_predicted_mean_error_mm: f64,
}

impl TwinPlanCheck {
    /// Median of [`TwinPlanCheck::random_mean_errors_mm`] (mm).
    pub fn random_median_mm(&self) -> f64 {
        let v = &self.random_mean_errors_mm;
        match v.len() {
            0 => 0.0,
            n if n % 2 == 1 => v[n / 2],
            n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
        }
    }
}

/// The twin's measurements: candidates, region, the model and the noise.
pub(super) struct TwinData {
    pub(super) model: Model,
    pub(super) candidates: MeasurementSet,
    pub(super) region: MeasurementSet,
    pub(super) noise_mm: f64,
    pub(super) orientation_noise_deg: [f64; 3],
}

pub(super) fn twin_data(seed: u64, switches: TruthSwitches) -> Result<TwinData> {
    let options = GeometricCampaignOptions {
        seed,
        n_validation: TWIN_CANDIDATES + TWIN_REGION,
        switches,
        ..Default::default()
    };
    let campaign = geometric_campaign(&options)?;
    let all = &campaign.validation;
    let rows = |r: std::ops::Range<usize>| all.subset(&r.collect::<Vec<_>>());
    Ok(TwinData {
        candidates: rows(0..TWIN_CANDIDATES)?,
        region: rows(TWIN_CANDIDATES..TWIN_CANDIDATES + TWIN_REGION)?,
        noise_mm: options.camera.position_std_per_axis() * 1e3,
        // Per axis of the camera frame, as the files carry it (the in-plane
        // value about x and y, the tool axis's about z, the tool down).
        orientation_noise_deg: options
            .camera
            .orientation_std_target()
            .map(f64::to_degrees)
            .into(),
        model: campaign.model,
    })
}

fn located(set: &MeasurementSet) -> Vec<Located<Vec<f64>>> {
    set.poses()
        .iter()
        .enumerate()
        .map(|(k, m)| Located {
            value: m.q.clone(),
            origin: format!("{} {}", set.source, k + 1),
        })
        .collect()
}

impl TwinData {
    /// The camera as a plan's instrument: positions only, or full poses;
    /// the region measured from the campaign's placement (the frame's
    /// uncertainty counted).
    fn instrument(&self, full_poses: bool) -> Instrument {
        Instrument {
            noise_mm: [self.noise_mm; 3],
            orientation_noise_deg: full_poses.then_some(self.orientation_noise_deg),
            frame: calib::FrameUncertainty::AsIdentified,
            ..Instrument::positions([self.noise_mm; 3])
        }
    }

    /// The errors over the region (mm) after calibrating on the measured
    /// candidates `rows`, the region's measurements compared with the
    /// calibrated model through the identified camera frame (the camera
    /// has not moved: [`calib::Refit::Nothing`]).
    pub(super) fn achieved(
        &self,
        options: &CalibrationOptions,
        rows: &[usize],
    ) -> Result<Vec<f64>> {
        let set = self.candidates.subset(rows)?;
        let calibration = calib::calibrate(&self.model, &set, options)?;
        let report = calibration.validate(&self.model, &self.region, calib::Refit::Nothing)?;
        Ok(report
            .after_per_pose
            .iter()
            .map(|e| e.position * 1e3)
            .collect())
    }

    /// Plans `n` of the candidates for calibrating with `options`
    /// ([`measuring`] the same), the instrument measuring full poses or
    /// positions only; the region's points as the region.
    pub(super) fn plan(
        &self,
        options: &CalibrationOptions,
        n: usize,
        full_poses: bool,
    ) -> Result<CampaignPlan> {
        let mut config = PlanConfig::new(
            options.clone(),
            [self.noise_mm; 3],
            PoseSource::Configurations(located(&self.candidates)),
            PoseSource::Configurations(located(&self.region)),
        );
        config.instrument = self.instrument(full_poses);
        config.count = Some(n);
        config.max_poses = Some(n);
        plan_campaign(&self.model, &config)
    }

    /// Plans `n` poses measuring full poses or positions only, calibrates
    /// on their measurements (the same kind; `options`' orientation choice
    /// overridden), validates.
    pub(super) fn check(
        &self,
        options: &CalibrationOptions,
        n: usize,
        full_poses: bool,
    ) -> Result<(PlannedCampaignCheck, Vec<usize>)> {
        let options = &measuring(options, full_poses);
        let plan = match self.plan(options, n, full_poses) {
            Ok(plan) => plan,
            Err(e) => {
                let refused = PlannedCampaignCheck {
                    poses: n,
                    full_poses,
                    refused: Some(e.to_string()),
                    predicted: None,
                    coverage: 0.0,
                    achieved_mean_error_mm: 0.0,
                    extrapolated: 0,
                    misses: None,
                };
                return Ok((refused, Vec::new()));
            }
        };
        let errors = self.achieved(options, &plan.selected)?;
        let mut map = plan.prediction.map.clone();
        for (p, e) in map.poses.iter_mut().zip(&errors) {
            p.actual_error_mm = Some(*e);
        }
        let misses = map.misses_by_range();
        let check = PlannedCampaignCheck {
            poses: n,
            full_poses,
            refused: None,
            predicted: Some(plan.prediction.accuracy),
            coverage: 1.0 - misses.as_ref().map_or(1.0, |m| m.all.rate()),
            achieved_mean_error_mm: mean(&errors),
            extrapolated: plan.prediction.map.extrapolated_poses,
            misses,
        };
        Ok((check, plan.selected))
    }
}

/// `options` calibrating on full poses or positions only, as the plan's
/// instrument measures.
pub(super) fn measuring(options: &CalibrationOptions, full_poses: bool) -> CalibrationOptions {
    CalibrationOptions {
        use_orientation: Some(full_poses),
        ..options.clone()
    }
}

pub(super) fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Runs the check (module docs) on the twin's campaign of `seed`: plans of
/// each of `counts` poses, positions only then full poses, then `compared`
/// planned full-pose poses against `random_draws` random draws (seeded by
/// `seed`) and the O1-selected set (O1 on full poses). The identified
/// model is `calibrate`'s default for the IR-663 with the target fixed at
/// the TCP (the twin's target), the measurement frame identified.
///
/// # Errors
/// The twin's, planning's and calibration's errors; `compared` not among
/// `counts` or refused.
pub fn twin_plan_check(
    seed: u64,
    counts: &[usize],
    compared: usize,
    random_draws: usize,
) -> Result<TwinPlanCheck> {
    let data = twin_data(seed, TruthSwitches::default())?;
    let mut options = CalibrationOptions::for_model(&data.model);
    options.target = FrameTreatment::Fixed;
    let mut planned = Vec::with_capacity(2 * counts.len());
    let mut compared_rows = None;
    for full_poses in [false, true] {
        for &n in counts {
            let (check, rows) = data.check(&options, n, full_poses)?;
            if full_poses && n == compared && check.refused.is_none() {
                compared_rows = Some((check.achieved_mean_error_mm, rows));
            }
            planned.push(check);
        }
    }
    options.use_orientation = Some(true);
    let (planned_mean_error_mm, _) = compared_rows.ok_or_else(|| Error::InvalidParameter {
        parameter: "compared".into(),
        message: format!("{compared} poses are not among the counts planned ({counts:?})"),
    })?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut random_mean_errors_mm = (0..random_draws)
        .map(|_| {
            let rows = rand::seq::index::sample(&mut rng, TWIN_CANDIDATES, compared).into_vec();
            Ok(mean(&data.achieved(&options, &rows)?))
        })
        .collect::<Result<Vec<f64>>>()?;
    random_mean_errors_mm.sort_by(f64::total_cmp);
    let q: Vec<Vec<f64>> = data
        .candidates
        .poses()
        .iter()
        .map(|p| p.q.clone())
        .collect();
    let o1 = calib::select_calibration_poses(
        &data.model,
        &q,
        compared,
        crate::optim::ObservabilityIndex::O1,
        true,
        &[],
    )?;
    let o1_rows = o1.selection.selected;
    let region_q: Vec<Vec<f64>> = data.region.poses().iter().map(|p| p.q.clone()).collect();
    let o1_q: Vec<Vec<f64>> = o1_rows.iter().map(|&k| q[k].clone()).collect();
    let o1_predicted = predict_campaign(
        &data.model,
        &options,
        &data.instrument(true),
        None,
        (&o1_q, &region_q),
        None,
    )?;
    Ok(TwinPlanCheck {
        seed,
        noise_mm: data.noise_mm,
        orientation_noise_deg: data.orientation_noise_deg,
        planned,
        compared_poses: compared,
        planned_mean_error_mm,
        random_mean_errors_mm,
        o1_mean_error_mm: mean(&data.achieved(&options, &o1_rows)?),
        o1_predicted_mean_error_mm: o1_predicted.accuracy.predicted_mean_error_mm,
    })
}

impl TwinPlanCheck {
    /// The check as two Markdown tables (the docs' tables).
    pub fn to_markdown(&self) -> String {
        let o = self.orientation_noise_deg;
        let mut out = format!(
            "virtual IR-663, seed {}: {TWIN_CANDIDATES} candidates and {TWIN_REGION} region poses of box (59), noise {:.4} mm per axis, orientation {:.4}/{:.4}/{:.4} deg\n\n",
            self.seed, self.noise_mm, o[0], o[1], o[2]
        );
        out.push_str("| measured | N | predicted mean bound (mm) | coverage of the 95 % bound | predicted mean error (mm) | achieved mean error (mm) | predicted / achieved | region poses outside the planned ranges | misses outside a range / inside every range |\n|---|---|---|---|---|---|---|---|---|\n");
        for c in &self.planned {
            let measured = if c.full_poses {
                "full poses"
            } else {
                "positions"
            };
            match (&c.refused, c.predicted) {
                (None, Some(a)) => out.push_str(&format!(
                    "| {measured} | {} | {:.4} | {:.1} % | {:.4} | {:.4} | {:.2} | {} | {} |\n",
                    c.poses,
                    a.mean_bound_95_mm,
                    100.0 * c.coverage,
                    a.predicted_mean_error_mm,
                    c.achieved_mean_error_mm,
                    a.predicted_mean_error_mm / c.achieved_mean_error_mm,
                    c.extrapolated,
                    c.misses.as_ref().map_or(String::new(), |m| format!(
                        "{} / {}",
                        m.explained(),
                        m.inside.misses
                    ))
                )),
                (reason, _) => out.push_str(&format!(
                    "| {measured} | {} | refused: {} | | | | | | |\n",
                    c.poses,
                    reason.as_deref().unwrap_or("no prediction")
                )),
            }
        }
        let r = &self.random_mean_errors_mm;
        out.push_str(&format!(
            "\n| {} full poses | achieved mean error over the region (mm) |\n|---|---|\n| planned (I-optimal on the region) | {:.4} |\n| random, median of {} draws | {:.4} (from {:.4} to {:.4}) |\n| O1-selected | {:.4} (predicted {:.4}) |\n",
            self.compared_poses,
            self.planned_mean_error_mm,
            r.len(),
            self.random_median_mm(),
            r.first().copied().unwrap_or(0.0),
            r.last().copied().unwrap_or(0.0),
            self.o1_mean_error_mm,
            self.o1_predicted_mean_error_mm
        ));
        out
    }
}

/// The twin's terms a term check turns off one at a time (the geometric
/// errors and the camera's noise stay on: they are what the model and the
/// bound hold), by name.
pub const TWIN_TERMS: [&str; 4] = [
    "gravity",
    "drive_nonlinearity",
    "transmission_errors",
    "measurement_frame",
];

/// The twin's default switches with the term `term` of [`TWIN_TERMS`]
/// off; `all` turns every one of them off (the geometric errors and the
/// noise alone: what is left is the estimation's own); `none` turns none
/// off.
///
/// # Errors
/// [`Error::InvalidParameter`] naming an unknown term.
pub fn switches_without(term: &str) -> Result<TruthSwitches> {
    let mut s = TruthSwitches::default();
    let all = term == "all";
    for name in TWIN_TERMS {
        if all || name == term {
            match name {
                "gravity" => s.gravity = false,
                "drive_nonlinearity" => s.drive_nonlinearity = false,
                "transmission_errors" => s.transmission_errors = false,
                _ => s.measurement_frame = false,
            }
        }
    }
    if !(all || term == "none" || TWIN_TERMS.contains(&term)) {
        return Err(Error::InvalidParameter {
            parameter: "term".into(),
            message: format!("'{term}' is none of {TWIN_TERMS:?}, all or none"),
        });
    }
    Ok(s)
}

/// One planned campaign of [`twin_plan_check`] (`n` poses, full poses or
/// positions) on the twin of `seed` measuring with `switches`: where the
/// published check's misses come from, one term turned off at a time
/// ([`switches_without`]). The plan's prediction does not depend on the
/// twin's terms; the achieved errors do.
///
/// # Errors
/// The twin's and calibration's errors.
pub fn twin_term_check(
    seed: u64,
    n: usize,
    full_poses: bool,
    switches: TruthSwitches,
) -> Result<PlannedCampaignCheck> {
    let data = twin_data(seed, switches)?;
    let mut options = CalibrationOptions::for_model(&data.model);
    options.target = FrameTreatment::Fixed;
    Ok(data.check(&options, n, full_poses)?.0)
}
