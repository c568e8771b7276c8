//! Whether a plan's predicted bounds are short by a bias or by the spread
//! of one noise draw ([`twin_noise_check`]): on the virtual IR-663 with
//! every term the identified model lacks turned off (its geometric errors
//! alone, the camera frame at the base or where the twin puts it), the
//! planned poses and the region
//! are measured without noise, then the camera's noise
//! ([`crate::twin::truth::Photogrammetry::measure`], its own model) is
//! drawn again and again on the same poses and the same truth; each draw
//! is calibrated and validated over the region (the frame as identified,
//! as [`super::twin_check`] validates). What the draws measure:
//! - the coverage of the plan's 95 % bounds per draw, and its mean over the
//!   draws (one draw's estimate is shared by every region point, so the
//!   coverage of one campaign spreads from draw to draw);
//! - the calibrated model's own error at the region points, against the
//!   noise-free region: the estimation's error alone, to compare with the
//!   identification part of the bound (`model_uncertainty_mm`);
//! - the calibration's own predicted bounds over the region (its
//!   covariance at the identified robot, its residual scatter) and which
//!   unknowns it leaves unestimated against the plan's.

use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use super::RegionAccuracy;
use super::twin_check::{TwinData, mean, measuring, twin_data};
use crate::calib::{self, CalibrationOptions, FrameTreatment, MeasurementSet, TargetPose};
use crate::twin::truth::{Photogrammetry, TruthSwitches};
use crate::{Error, Result};

/// One noise draw of [`twin_noise_check`] (or none: the noise-free
/// measurements).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DrawOutcome {
    /// Share of region points whose error (against the noisy region) lies
    /// within the plan's 95 % bound there.
    pub coverage: f64,
    /// Mean error over the region against the noisy region (mm).
    pub achieved_mean_error_mm: f64,
    /// RMS over the region of the calibrated model's error against the
    /// noise-free region (the frame as identified): the estimation's own
    /// error (mm).
    pub estimation_rms_mm: f64,
    /// Mean of the calibration's own 95 % bounds over the region, the
    /// frame's uncertainty counted as the plan's
    /// ([`calib::Calibration::predicted_accuracy_with_frame`],
    /// [`calib::FrameUncertainty::AsIdentified`]) (mm).
    pub calibration_mean_bound_95_mm: f64,
    /// Share of region points within the calibration's own bound.
    pub calibration_coverage: f64,
    /// [`DrawOutcome::estimation_rms_mm`] with the frame re-fitted on the
    /// noise-free region (positions and orientations) (mm).
    pub estimation_rms_refitted_mm: f64,
    /// [`estimation_rms_variants`] of this calibration over the region (mm).
    pub predicted_variants_mm: [f64; 4],
    /// Unknowns the calibration leaves at their start (non-identifiable or
    /// poorly identifiable) that the plan identifies, and the other way
    /// round (`name: plan -> calibration`).
    pub status_differences: Vec<String>,
}

/// Result of [`twin_noise_check`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseDrawCheck {
    /// Seed of the twin's campaign.
    pub seed: u64,
    /// Number of planned poses (full poses measured).
    pub poses: usize,
    /// The plan's predicted accuracy over the region.
    pub predicted: RegionAccuracy,
    /// RMS over the region of the plan's identification part,
    /// `sqrt(mean tr Sigma_pred)` (mm): what
    /// [`DrawOutcome::estimation_rms_mm`] should be on average.
    pub predicted_estimation_rms_mm: f64,
    /// The calibration of the noise-free measurements.
    pub noise_free: DrawOutcome,
    /// One entry per noise draw.
    pub draws: Vec<DrawOutcome>,
}

impl NoiseDrawCheck {
    /// Mean and standard deviation over the draws of `f`.
    pub fn spread(&self, f: impl Fn(&DrawOutcome) -> f64) -> (f64, f64) {
        let v: Vec<f64> = self.draws.iter().map(f).collect();
        let m = mean(&v);
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len().max(2) - 1) as f64;
        (m, var.sqrt())
    }

    /// The check as one Markdown table row: seed, N, the noise-free
    /// calibration's coverage and estimation RMS, then over the draws the
    /// mean (standard deviation) of the coverage, the share of draws
    /// covering 85-99 %, the predicted against the mean achieved error, the
    /// estimation's RMS error against the predicted, the calibration's own
    /// mean bound and coverage, and how many draws leave other unknowns
    /// unestimated than the plan.
    pub fn to_markdown_row(&self) -> String {
        let (coverage, coverage_sd) = self.spread(|d| d.coverage);
        let (achieved, _) = self.spread(|d| d.achieved_mean_error_mm);
        let rms = self.spread(|d| d.estimation_rms_mm.powi(2)).0.sqrt();
        let (own_bound, _) = self.spread(|d| d.calibration_mean_bound_95_mm);
        let (own_coverage, _) = self.spread(|d| d.calibration_coverage);
        let differing = self
            .draws
            .iter()
            .filter(|d| !d.status_differences.is_empty())
            .count();
        format!(
            "| {} | {} | {} | {:.0} % / {:.4} | {:.1} % ({:.1}) | {:.0} % | {:.4} / {:.4} ({:.2}) | {:.4} / {:.4} ({:.2}) | {:.4} / {:.1} % | {differing} of {} |\n",
            self.seed,
            self.poses,
            self.draws.len(),
            100.0 * self.noise_free.coverage,
            self.noise_free.estimation_rms_mm,
            100.0 * coverage,
            100.0 * coverage_sd,
            100.0 * self.share_of_draws_covering(0.85, 0.99),
            self.predicted.predicted_mean_error_mm,
            achieved,
            self.predicted.predicted_mean_error_mm / achieved,
            self.predicted_estimation_rms_mm,
            rms,
            self.predicted_estimation_rms_mm / rms,
            own_bound,
            100.0 * own_coverage,
            self.draws.len()
        )
    }

    /// The header of [`NoiseDrawCheck::to_markdown_row`]'s table.
    pub const MARKDOWN_HEADER: &'static str = "| seed | N | draws | noise-free: coverage / estimation RMS (mm) | coverage, mean over draws (sd) | draws covering 85-99 % | predicted / mean achieved mean error (mm) (ratio) | estimation RMS error predicted / achieved (mm) (ratio) | calibration's own mean bound (mm) / coverage | draws with other unknowns unestimated |\n|---|---|---|---|---|---|---|---|---|---|\n";

    /// The header and the row, then each draw's status differences.
    pub fn to_markdown(&self) -> String {
        let mut out = format!("{}{}", Self::MARKDOWN_HEADER, self.to_markdown_row());
        let v = |i: usize| self.spread(|d| d.predicted_variants_mm[i].powi(2)).0.sqrt();
        let a = self
            .spread(|d| d.estimation_rms_refitted_mm.powi(2))
            .0
            .sqrt();
        let nf = self.noise_free.predicted_variants_mm;
        out.push_str(&format!(
            "estimation RMS (mm) predicted by the calibrations' covariance: conditioned {:.4}, marginal robot {:.4}, with the frame {:.4}, frame re-fitted {:.4} (noise-free calibration: {:.4} {:.4} {:.4} {:.4}); achieved with the frame re-fitted on the region {a:.4}\n",
            v(0), v(1), v(2), v(3), nf[0], nf[1], nf[2], nf[3]
        ));
        for (k, d) in self.draws.iter().enumerate() {
            if !d.status_differences.is_empty() {
                out.push_str(&format!("draw {k}: {}\n", d.status_differences.join(", ")));
            }
        }
        out
    }

    /// Share of the draws whose coverage lies within `[low, high]`.
    pub fn share_of_draws_covering(&self, low: f64, high: f64) -> f64 {
        let n = self
            .draws
            .iter()
            .filter(|d| (low..=high).contains(&d.coverage))
            .count();
        n as f64 / self.draws.len().max(1) as f64
    }
}

/// `set` measured again with the camera's noise: each observation's
/// noise-free pose (the camera frame at the base) read by `camera` with
/// noise from `rng`; the standard deviations kept.
fn with_noise(
    set: &MeasurementSet,
    camera: &Photogrammetry,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<MeasurementSet> {
    let poses: Vec<TargetPose> = set
        .poses()
        .iter()
        .map(|pose| {
            let mut pose = pose.clone();
            for o in pose.observations.iter_mut().flatten() {
                let rotation = nalgebra::UnitQuaternion::from_scaled_axis(
                    o.orientation.unwrap_or_else(nalgebra::Vector3::zeros),
                );
                let truth = nalgebra::Isometry3::from_parts(o.position.into(), rotation);
                let measured = camera.measure(&truth, true, false, rng);
                o.position = measured.translation.vector;
                if o.orientation.is_some() {
                    o.orientation = Some(measured.rotation.scaled_axis());
                }
            }
            pose
        })
        .collect();
    Ok(MeasurementSet::from_poses(
        &set.source,
        set.targets().to_vec(),
        poses,
    )?)
}

/// RMS over the points of `set` (positions) of the calibrated model's
/// error under `calibration`'s covariance, four ways (mm): the robot's
/// unknowns conditioned on the frame's (what the bounds use), the robot's
/// marginal, every unknown with the frame's (the frame as identified), and
/// every unknown with the frame re-fitted on `set` (the part of the
/// prediction's error a rigid motion of the frame cannot absorb over the
/// points, the linearised least-squares re-fit of positions).
pub fn estimation_rms_variants(
    calibration: &calib::Calibration,
    model: &crate::kinematics::Model,
    set: &MeasurementSet,
) -> Result<[f64; 4]> {
    use crate::optim::{Jacobian, Residuals};
    use nalgebra::DMatrix;
    let fail = |reason: String| Error::InvalidParameter {
        parameter: "calibration".into(),
        message: reason,
    };
    let (problem, x) = calibration.error_model_at(model, set, false)?;
    let mut jac = faer::Mat::<f64>::zeros(problem.n_residuals(), x.len());
    problem
        .jacobian(&x, jac.as_mut())
        .map_err(|e| fail(e.to_string()))?;
    let j = DMatrix::<f64>::from_fn(jac.nrows(), jac.ncols(), |r, c| jac[(r, c)]);
    let cov = calibration
        .solve
        .covariance
        .as_ref()
        .ok_or_else(|| fail("no covariance".into()))?;
    let identified = |frame: bool| -> Vec<usize> {
        (0..x.len())
            .filter(|&c| {
                let u = &calibration.unknowns[c];
                u.status == calib::UnknownStatus::Identified
                    && u.name.starts_with("frame_") == frame
            })
            .collect()
    };
    let (r, f) = (identified(false), identified(true));
    let all: Vec<usize> = r.iter().chain(&f).copied().collect();
    let block =
        |a: &[usize], b: &[usize]| DMatrix::from_fn(a.len(), b.len(), |i, k| cov[(a[i], b[k])]);
    let columns =
        |m: &DMatrix<f64>, c: &[usize]| DMatrix::from_fn(m.nrows(), c.len(), |i, k| m[(i, c[k])]);
    let s_ff_inv = block(&f, &f)
        .try_inverse()
        .ok_or_else(|| fail("singular frame covariance".into()))?;
    let conditioned = block(&r, &r) - block(&r, &f) * s_ff_inv * block(&f, &r);
    let j_f = columns(&j, &f);
    let p = &j_f
        * (j_f.transpose() * &j_f)
            .try_inverse()
            .ok_or_else(|| fail("singular frame Jacobian".into()))?
        * j_f.transpose();
    let refitted = (DMatrix::identity(j.nrows(), j.nrows()) - p) * columns(&j, &all);
    let rms = |m: DMatrix<f64>, s: DMatrix<f64>| {
        let c = &m * s * m.transpose();
        (c.trace() / (j.nrows() / 3) as f64).sqrt() * 1e3
    };
    Ok([
        rms(columns(&j, &r), conditioned),
        rms(columns(&j, &r), block(&r, &r)),
        rms(columns(&j, &all), block(&all, &all)),
        rms(refitted, block(&all, &all)),
    ])
}

/// The unknowns a calibration leaves at their start for want of data.
fn unestimated<S: AsRef<str>>(non: &[S], poor: &[S]) -> Vec<String> {
    non.iter()
        .chain(poor)
        .map(|s| s.as_ref().to_string())
        .collect()
}

/// Calibrates on `training`, validates on the noisy and the noise-free
/// region, compares with the plan's `bounds_mm` and unestimated unknowns.
fn outcome(
    data: &TwinData,
    options: &CalibrationOptions,
    training: &MeasurementSet,
    region: &MeasurementSet,
    (bounds_mm, plan_unestimated): (&[f64], &[String]),
) -> Result<DrawOutcome> {
    let calibration = calib::calibrate(&data.model, training, options)?;
    let errors_refit = |set: &MeasurementSet, refit: calib::Refit| -> Result<Vec<f64>> {
        Ok(calibration
            .validate(&data.model, set, refit)?
            .after_per_pose
            .iter()
            .map(|e| e.position * 1e3)
            .collect())
    };
    let errors_mm = |set: &MeasurementSet| errors_refit(set, calib::Refit::Nothing);
    let errors = errors_mm(region)?;
    let estimation = errors_mm(&data.region)?;
    let refitted = errors_refit(&data.region, calib::Refit::Frames)?;
    let rms = |v: &[f64]| mean(&v.iter().map(|e| e * e).collect::<Vec<_>>()).sqrt();
    let within = |bounds: &[f64]| {
        let n = errors.iter().zip(bounds).filter(|(e, b)| e <= b).count();
        n as f64 / errors.len().max(1) as f64
    };
    let region_q: Vec<Vec<f64>> = region.poses().iter().map(|p| p.q.clone()).collect();
    // The region is measured through the identified frame, as the plan's
    // bound counts it: the calibration's own bound counts it too.
    let own = calibration.predicted_accuracy_with_frame(
        &data.model,
        &region_q,
        None,
        calib::FrameUncertainty::AsIdentified,
    )?;
    let own_bounds: Vec<f64> = own.poses.iter().map(|p| p.bound_95_mm).collect();
    let calibrated = unestimated(
        &calibration.non_identifiable(),
        &calibration.poorly_identifiable(),
    );
    let mut status_differences: Vec<String> = plan_unestimated
        .iter()
        .filter(|n| !calibrated.contains(n))
        .map(|n| format!("{n}: unestimated -> identified"))
        .collect();
    status_differences.extend(
        calibrated
            .iter()
            .filter(|n| !plan_unestimated.contains(n))
            .map(|n| format!("{n}: identified -> unestimated")),
    );
    Ok(DrawOutcome {
        coverage: within(bounds_mm),
        achieved_mean_error_mm: mean(&errors),
        estimation_rms_mm: rms(&estimation),
        estimation_rms_refitted_mm: rms(&refitted),
        predicted_variants_mm: estimation_rms_variants(&calibration, &data.model, &data.region)?,
        calibration_mean_bound_95_mm: own.mean_bound_95_mm,
        calibration_coverage: within(&own_bounds),
        status_differences,
    })
}

/// Runs the check (module docs) on the twin of `seed`: `n` planned full
/// poses, calibrated on the noise-free measurements and on `draws` noise
/// draws (seeded by `seed` and the draw's index), the identified model
/// `calibrate`'s default for the IR-663 with the target fixed at the TCP;
/// with `camera_frame` the camera stands where the twin's frame term puts
/// it (3.5 m from the base, turned 155 deg) instead of at the base.
///
/// # Errors
/// The twin's, planning's and calibration's errors; no draw asked.
pub fn twin_noise_check(
    seed: u64,
    n: usize,
    draws: usize,
    camera_frame: bool,
) -> Result<NoiseDrawCheck> {
    if draws == 0 {
        return Err(Error::InvalidParameter {
            parameter: "draws".into(),
            message: "at least one noise draw is needed".into(),
        });
    }
    let switches = TruthSwitches {
        measurement_noise: false,
        measurement_frame: camera_frame,
        ..super::twin_check::switches_without("all")?
    };
    let data = twin_data(seed, switches)?;
    let mut options = CalibrationOptions::for_model(&data.model);
    options.target = FrameTreatment::Fixed;
    let options = measuring(&options, true);
    let plan = data.plan(&options, n, true)?;
    let prediction = &plan.prediction;
    let bounds: Vec<f64> = prediction.map.poses.iter().map(|p| p.bound_95_mm).collect();
    let plan_unestimated = unestimated(
        &prediction.non_identifiable,
        &prediction.poorly_identifiable,
    );
    let training = data.candidates.subset(&plan.selected)?;
    let camera = Photogrammetry {
        x_meas_base: nalgebra::Isometry3::identity(),
        ..Photogrammetry::default()
    };
    let plan_parts = (bounds.as_slice(), plan_unestimated.as_slice());
    let noise_free = outcome(&data, &options, &training, &data.region, plan_parts)?;
    let draws = (0..draws as u64)
        .map(|d| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1_000_003) + d);
            let training = with_noise(&training, &camera, &mut rng)?;
            let region = with_noise(&data.region, &camera, &mut rng)?;
            outcome(&data, &options, &training, &region, plan_parts)
        })
        .collect::<Result<Vec<_>>>()?;
    let traces: Vec<f64> = prediction
        .map
        .poses
        .iter()
        .map(|p| p.model_uncertainty_mm.powi(2))
        .collect();
    Ok(NoiseDrawCheck {
        seed,
        poses: n,
        predicted: prediction.accuracy,
        predicted_estimation_rms_mm: mean(&traces).sqrt(),
        noise_free,
        draws,
    })
}
