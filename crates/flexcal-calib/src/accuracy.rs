//! Predicted accuracy with confidence: how far from the truth the
//! calibrated model's prediction of the target position is likely to be at
//! any pose, and a check of that claim on measured poses.
//!
//! At a pose q the prediction error has two parts:
//! - the identification's own uncertainty, `Sigma_pred = J_S Sigma J_S^T`,
//!   with `J_S` the position rows of the error model's Jacobian at q (the
//!   robot, target, elastic and joint-term columns) and `Sigma` the
//!   covariance of those identified unknowns
//!   ([`flexcal_optim::SolveReport::covariance`]) conditioned on the
//!   measurement frame: `Sigma = S_rr - S_rf S_ff^-1 S_fr`, the robot's
//!   uncertainty with the frame known. The frame is not part of the
//!   robot's accuracy, and the marginal block `S_rr` would count as robot
//!   error what is only the frame's: the lengths next to the base trade off
//!   with the frame's translation (on the virtual IR-663 their marginal
//!   errors are 1 to 4 mm, which made mean 95 % bounds of 1.76 mm for
//!   errors of 0.027 mm; conditioned, 0.050 mm). That holds where the
//!   frame is registered again ([`FrameUncertainty::Registered`], what a
//!   validation on another series does); where the poses are measured
//!   through the identified frame, the frame's uncertainty is counted with
//!   the robot's ([`FrameUncertainty::AsIdentified`],
//!   [`Calibration::predicted_accuracy_with_frame`]). The linearised covariance
//!   assumes independent errors; where the split-half check
//!   ([`crate::SplitCheck::prediction_ratio`]) finds the halves' predicted
//!   positions further apart than the covariance says, every standard
//!   deviation is raised by that one ratio ([`AccuracyMap::inflation`]).
//!   Scaling each unknown by its own split ratio would break the
//!   correlations that make combinations of unknowns well known;
//! - what the model leaves: the scatter of the training residuals, per
//!   axis `s^2 = SSR / (3 N - p)` (positions; p identified unknowns; with
//!   orientation rows fitted too, `SSR / (3 N - tr(H_pp))`, the degrees of
//!   freedom the position rows keep: [`Calibration::position_residual_dof`]),
//!   which holds measurement noise and every effect the model lacks, taken
//!   as isotropic and the same at every pose.
//!
//! The 95 % bound on the position error is `sqrt(chi2_3(0.95) (tr
//! Sigma_pred / 3 + s^2))` with `chi2_3(0.95) = 7.815`: exact for an
//! isotropic Gaussian error, an approximation otherwise. On a validation
//! series [`AccuracyMap::coverage`] is the share of poses whose measured
//! error lies within its bound; it should be near 95 %. It falls short
//! where the other series' poses see effects the training poses did not
//! (extrapolation, another day's temperature), which no statistic of the
//! training data can know.
//!
//! With several targets per pose ([`crate::MeasurementSet`]) the same
//! holds for each target: `J_S` holds the position rows of that target's
//! point (its offset's columns among them), N counts observations, and the
//! map has one entry per pose and target ([`PoseAccuracy::target`]).

use flexcal_kinematics::Model;
use nalgebra::{DMatrix, Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::error::CalibError;
use crate::identify::Calibration;
use crate::measurement::MeasurementSet;
use crate::prediction::{covariance_of, covariance_size};
use crate::split::SplitCheck;
use crate::targets::{TargetObservation, TargetPose};
use crate::unknowns::UnknownStatus;
use crate::validate::ValidationReport;

/// `chi2` quantile of 3 degrees of freedom at 95 %.
pub const CHI2_3_95: f64 = 7.814_727_903_251_178;

/// The 95 % bound on a position error (m) whose identification part has
/// the covariance trace `prediction_trace` (`tr Sigma_pred`, m^2) and whose
/// remaining part is isotropic with per-axis variance `scatter_variance`
/// (`s^2`, m^2): `sqrt(chi2_3(0.95) (tr Sigma_pred / 3 + s^2))` (module docs).
pub fn bound_95(prediction_trace: f64, scatter_variance: f64) -> f64 {
    (CHI2_3_95 * (prediction_trace / 3.0 + scatter_variance)).sqrt()
}

/// How the measurement frame's uncertainty enters a predicted bound.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrameUncertainty {
    /// The frame is registered again where the prediction is checked or
    /// used (a validation on another series re-fits it, a new tracker
    /// placement): the robot's unknowns conditioned on the frame's,
    /// `S_rr - S_rf S_ff^-1 S_fr` (module docs). The default.
    #[default]
    Registered,
    /// The frame stays as identified (the same instrument placement as the
    /// identification measures the predicted poses): every identified
    /// unknown with the frame's, `[J_r J_f] S [J_r J_f]^T`. On the
    /// virtual IR-663 (seed 3, 15 full poses, the geometric errors alone)
    /// this is what the calibrated model's errors through the identified
    /// frame spread by: 0.029 mm RMS predicted, 0.029 mm achieved over 100
    /// noise draws, where the conditioned covariance says 0.024 mm.
    AsIdentified,
}

impl std::str::FromStr for FrameUncertainty {
    type Err = String;
    /// `registered` or `as-identified`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "registered" => Ok(Self::Registered),
            "as-identified" => Ok(Self::AsIdentified),
            other => Err(format!("`{other}`: expected registered or as-identified")),
        }
    }
}

/// Predicted accuracy at one pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseAccuracy {
    /// Pose label (`line N`, the pose id, or the row of a grid file).
    pub pose: String,
    /// The target this entry predicts, with several targets per pose
    /// ([`crate::Calibration::predicted_accuracy`]: one entry per
    /// pose and target); `None` for the one target of a [`Calibration`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<String>,
    /// Actuated coordinates (rad or m).
    pub q: Vec<f64>,
    /// RMS over the axes of the identification's own uncertainty times
    /// sqrt(3): `sqrt(tr Sigma_pred)` (mm).
    pub model_uncertainty_mm: f64,
    /// 95 % bound on the position error (mm).
    pub bound_95_mm: f64,
    /// The measured error after calibration, on a measured set (mm).
    pub actual_error_mm: Option<f64>,
    /// The calibrated model's target position at this pose, in the robot
    /// base frame (mm): where on the workspace the bound applies.
    pub position_mm: [f64; 3],
    /// The 95 % bound's parts (mm): `bound_95_mm` is the root of the sum
    /// of their squares.
    #[serde(default)]
    pub parts: BoundParts,
    /// The actuated coordinates (by name) at which this pose lies outside
    /// the identification poses' range: there the bound assumes that the
    /// model holds beyond the data, which no statistic of the training
    /// poses can check (empty: inside every range).
    #[serde(default)]
    pub outside_training_range: Vec<String>,
}

/// Where a pose's 95 % bound comes from, each part the 95 % bound it
/// would be alone (mm): `bound_95_mm^2 = scatter^2 + parameters^2 +
/// extrapolation^2`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct BoundParts {
    /// What the model leaves at the training poses, the same at every pose:
    /// measurement noise and every effect the model lacks,
    /// `sqrt(chi2_3(0.95)) s` (mm).
    pub scatter_mm: f64,
    /// The identified unknowns' uncertainty at this pose (the split-half
    /// inflation included), `sqrt(chi2_3(0.95) tr Sigma_pred / 3)` (mm).
    pub parameters_mm: f64,
    /// The model's own error beyond the training poses' ranges, grown with
    /// the distance outside them as the held-out-range folds measured
    /// ([`crate::ExtrapolationModel`]; 0 inside every range or without
    /// that model) (mm).
    pub extrapolation_mm: f64,
}

impl BoundParts {
    /// The 95 % bound of the three parts together (mm).
    pub fn bound_mm(&self) -> f64 {
        (self.scatter_mm.powi(2) + self.parameters_mm.powi(2) + self.extrapolation_mm.powi(2))
            .sqrt()
    }

    /// The part that dominates the bound: `scatter`, `parameters` or
    /// `extrapolation`.
    pub fn dominant(&self) -> &'static str {
        if self.extrapolation_mm >= self.scatter_mm.max(self.parameters_mm) {
            "extrapolation"
        } else if self.parameters_mm >= self.scatter_mm {
            "parameters"
        } else {
            "scatter"
        }
    }
}

/// Predicted accuracy over a set of poses (a workspace grid or a
/// validation series): one entry per pose, or with several targets one per
/// pose and target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AccuracyMap {
    /// Per pose (per pose and target with several targets).
    pub poses: Vec<PoseAccuracy>,
    /// Per-axis scatter of the training residuals, `s` (mm).
    pub residual_scatter_mm: f64,
    /// Factor on every standard deviation of the identification from the
    /// split-half check ([`SplitCheck::prediction_ratio`], at least 1; 1
    /// without the check).
    pub inflation: f64,
    /// Share of the measured entries (poses, or observations of a target)
    /// whose error lies within the bound (validation series only).
    pub coverage: Option<f64>,
    /// Mean of the bounds (mm).
    pub mean_bound_95_mm: f64,
    /// Number of poses outside the identification poses' range of at least
    /// one actuated coordinate ([`PoseAccuracy::outside_training_range`];
    /// with several targets, each pose counted once).
    #[serde(default)]
    pub extrapolated_poses: usize,
    /// The growth of the model's error outside the training ranges whose
    /// part the bounds include ([`AccuracyMap::with_extrapolation`];
    /// `None`: the bounds assume that the model holds beyond the data).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extrapolation: Option<crate::ExtrapolationModel>,
}

impl AccuracyMap {
    /// `standard errors raised X times by the split-half check ...` when
    /// [`AccuracyMap::inflation`] is above 1, for reports.
    pub fn inflation_note(&self) -> Option<String> {
        (self.inflation > 1.0).then(|| {
            format!(
                "standard errors raised {:.2} times by the split-half check of the predicted positions",
                self.inflation
            )
        })
    }

    /// The map as CSV:
    /// `pose,q1..qn,model_uncertainty_mm,bound_95_mm,actual_error_mm,scatter_95_mm,parameters_95_mm,extrapolation_95_mm,x_mm,y_mm,z_mm,outside_training_range`
    /// (the three parts of the bound: [`PoseAccuracy::parts`];
    /// `x_mm,y_mm,z_mm`: [`PoseAccuracy::position_mm`]; the last column:
    /// [`PoseAccuracy::outside_training_range`], names separated by `;`).
    /// With several targets a `target` column follows `pose`.
    pub fn to_csv_string(&self) -> String {
        let n = self.poses.first().map_or(0, |p| p.q.len());
        let with_targets = self.poses.iter().any(|p| p.target.is_some());
        let mut out = String::from(if with_targets { "pose,target" } else { "pose" });
        for i in 1..=n {
            out.push_str(&format!(",q{i}"));
        }
        out.push_str(
            ",model_uncertainty_mm,bound_95_mm,actual_error_mm,scatter_95_mm,parameters_95_mm,extrapolation_95_mm,x_mm,y_mm,z_mm,outside_training_range\n",
        );
        for p in &self.poses {
            out.push_str(&p.pose.replace(',', ";"));
            if with_targets {
                out.push(',');
                out.push_str(&p.target.as_deref().unwrap_or("").replace(',', ";"));
            }
            for q in &p.q {
                out.push_str(&format!(",{q:.9}"));
            }
            let [x, y, z] = p.position_mm;
            out.push_str(&format!(
                ",{:.6},{:.6},{},{:.6},{:.6},{:.6},{x:.4},{y:.4},{z:.4},{}\n",
                p.model_uncertainty_mm,
                p.bound_95_mm,
                p.actual_error_mm
                    .map_or(String::new(), |e| format!("{e:.6}")),
                p.parts.scatter_mm,
                p.parts.parameters_mm,
                p.parts.extrapolation_mm,
                p.outside_training_range.join(";").replace(',', ";")
            ));
        }
        out
    }

    /// Writes [`AccuracyMap::to_csv_string`] to `path` (a temporary file
    /// renamed into place).
    ///
    /// # Errors
    /// The file's I/O error.
    pub fn write_csv(&self, path: &Path) -> Result<(), CalibError> {
        flexcal_io::write_atomic(path, self.to_csv_string())?;
        Ok(())
    }
}

impl Calibration {
    /// Predicted accuracy of every target at the configurations
    /// `configurations` (rad or m): one entry per configuration and
    /// target, in that order, the covariance raised by `split`'s
    /// prediction ratio where it understates (module docs).
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] when the identification has no
    /// covariance (as many equations as unknowns), a configuration of the
    /// wrong size, a model failure at a pose.
    pub fn predicted_accuracy(
        &self,
        model: &Model,
        configurations: &[Vec<f64>],
        split: Option<&SplitCheck>,
    ) -> Result<AccuracyMap, CalibError> {
        self.predicted_accuracy_with_frame(
            model,
            configurations,
            split,
            FrameUncertainty::Registered,
        )
    }

    /// [`Calibration::predicted_accuracy`] with the measurement frame's
    /// uncertainty treated as `frame` says.
    ///
    /// # Errors
    /// As [`Calibration::predicted_accuracy`].
    pub fn predicted_accuracy_with_frame(
        &self,
        model: &Model,
        configurations: &[Vec<f64>],
        split: Option<&SplitCheck>,
        frame: FrameUncertainty,
    ) -> Result<AccuracyMap, CalibError> {
        let poses = configurations
            .iter()
            .map(|q| TargetPose {
                pose_id: None,
                q: q.clone(),
                observations: vec![
                    Some(TargetObservation::new(Vector3::zeros()));
                    self.targets.len()
                ],
                wrench: None,
                temperature_c: None,
            })
            .collect();
        let set = MeasurementSet::from_poses("accuracy grid", self.targets.clone(), poses)?;
        if self.has_implicit_target() {
            // The one target of a set of one target per pose is not named.
            let mut map = accuracy_in_frame(self, model, &set, &grid_row, None, (split, frame))?;
            map.poses.iter_mut().for_each(|p| p.target = None);
            return Ok(map);
        }
        accuracy_in_frame(self, model, &set, &grid_row, None, (split, frame))
    }

    /// Predicted accuracy at the observations of the measured set
    /// `validation`, with their measured errors after calibration (the
    /// measurement frame fitted again: [`Calibration::validate`])
    /// and the share within the bound.
    ///
    /// # Errors
    /// As [`Calibration::predicted_accuracy`] and the validation.
    pub fn accuracy_coverage(
        &self,
        model: &Model,
        validation: &MeasurementSet,
        split: Option<&SplitCheck>,
    ) -> Result<AccuracyMap, CalibError> {
        let report = self.validate(model, validation, false)?;
        self.accuracy_coverage_of(model, validation, &report, split)
    }

    /// [`Calibration::accuracy_coverage`] from the validation `report` of
    /// `validation` already made, instead of validating again.
    ///
    /// # Errors
    /// As [`Calibration::predicted_accuracy`], and a report that is not
    /// of `validation` (another number of observations).
    pub fn accuracy_coverage_of(
        &self,
        model: &Model,
        validation: &MeasurementSet,
        report: &ValidationReport,
        split: Option<&SplitCheck>,
    ) -> Result<AccuracyMap, CalibError> {
        let actual: Vec<f64> = report.after_per_pose.iter().map(|e| e.position).collect();
        let set = validation;
        check_report_size(actual.len(), set.n_observations(), &set.source)?;
        let label = |k: usize| set.poses()[k].label(k);
        accuracy_at(self, model, set, &label, Some(&actual), split)
    }
}

/// A validation report of `n` entries for a set of `expected`.
fn check_report_size(n: usize, expected: usize, source: &str) -> Result<(), CalibError> {
    if n == expected {
        return Ok(());
    }
    Err(CalibError::InvalidOption {
        name: "accuracy",
        reason: format!("a validation report of {n} errors for the {expected} of {source}"),
    })
}

/// The label of row `k` of an accuracy grid.
pub(crate) fn grid_row(k: usize) -> String {
    format!("row {}", k + 1)
}

/// The accuracy map of `calibration` at the observations of `set`, pose `k`
/// labelled `label(k)`, with the measured errors `actual` (m, one per
/// observation) when `set` is measured; the frame registered again (as a
/// validation re-fits it).
pub(crate) fn accuracy_at(
    calibration: &Calibration,
    model: &Model,
    set: &MeasurementSet,
    label: &dyn Fn(usize) -> String,
    actual: Option<&[f64]>,
    split: Option<&SplitCheck>,
) -> Result<AccuracyMap, CalibError> {
    let frame = FrameUncertainty::Registered;
    accuracy_in_frame(calibration, model, set, label, actual, (split, frame))
}

/// [`accuracy_at`] with the split-half check's inflation and the frame's
/// uncertainty as `frame` says.
fn accuracy_in_frame(
    calibration: &Calibration,
    model: &Model,
    set: &MeasurementSet,
    label: &dyn Fn(usize) -> String,
    actual: Option<&[f64]>,
    (split, frame): (Option<&SplitCheck>, FrameUncertainty),
) -> Result<AccuracyMap, CalibError> {
    let covariance = covariance_of(calibration)?;
    let linearised = set.linearise(calibration, model)?;
    let jac = &linearised.jacobian;
    let n = jac.ncols();
    if covariance.nrows() != n {
        return Err(covariance_size(covariance, n));
    }
    if let Some(actual) = actual
        && actual.len() != linearised.observed.len()
    {
        return Err(CalibError::InvalidOption {
            name: "accuracy",
            reason: format!(
                "{} measured errors for {} observations",
                actual.len(),
                linearised.observed.len()
            ),
        });
    }
    // The split-half check's inflation, one factor on every standard
    // deviation: scaling unknowns apart would break the correlations
    // that make combinations of them well known.
    let inflation = split
        .and_then(|s| s.prediction_ratio)
        .map_or(1.0, |r| r.max(1.0));
    let (columns, sigma) = prediction_covariance(calibration, covariance, n, frame);
    let sigma = sigma * (inflation * inflation);
    let base_from_meas = calibration.x_meas_base.inverse();
    let s2 = calibration.residual_variance();
    let mut poses = Vec::with_capacity(linearised.observed.len());
    let mut within = 0usize;
    // Poses outside the training range (with several targets, each pose
    // counted once).
    let mut extrapolated = std::collections::BTreeSet::new();
    for (k, observed) in linearised.observed.into_iter().enumerate() {
        let rows_k = DMatrix::<f64>::from_fn(3, columns.len(), |i, c| jac[(3 * k + i, columns[c])]);
        let pred = &rows_k * &sigma * rows_k.transpose();
        let trace = pred.trace().max(0.0);
        let bound = bound_95(trace, s2);
        let actual_error = actual.map(|a| a[k]);
        let position = base_from_meas * Point3::from(linearised.predicted[k]);
        if actual_error.is_some_and(|e| e <= bound) {
            within += 1;
        }
        let q = set.configuration(observed.pose);
        let outside_training_range: Vec<String> =
            crate::coverage::outside(&calibration.actuated_ranges, q)
                .map(|i| model.actuated_names()[i].clone())
                .collect();
        if !outside_training_range.is_empty() {
            extrapolated.insert(observed.pose);
        }
        poses.push(PoseAccuracy {
            parts: BoundParts {
                scatter_mm: bound_95(0.0, s2) * 1e3,
                parameters_mm: bound_95(trace, 0.0) * 1e3,
                extrapolation_mm: 0.0,
            },
            outside_training_range,
            pose: label(observed.pose),
            target: observed.target,
            q: q.to_vec(),
            model_uncertainty_mm: trace.sqrt() * 1e3,
            bound_95_mm: bound * 1e3,
            actual_error_mm: actual_error.map(|e| e * 1e3),
            position_mm: [position.x * 1e3, position.y * 1e3, position.z * 1e3],
        });
    }
    let mean_bound_95_mm =
        poses.iter().map(|p| p.bound_95_mm).sum::<f64>() / poses.len().max(1) as f64;
    Ok(AccuracyMap {
        coverage: actual.map(|_| within as f64 / poses.len().max(1) as f64),
        poses,
        residual_scatter_mm: s2.sqrt() * 1e3,
        inflation,
        mean_bound_95_mm,
        extrapolated_poses: extrapolated.len(),
        extrapolation: None,
    })
}

/// The columns of the identified unknowns a prediction's uncertainty comes
/// from and their covariance (m, rad): the robot's conditioned on the
/// measurement frame's when the frame is registered again, every
/// identified unknown with the frame's when it stays as identified.
fn prediction_covariance(
    calibration: &Calibration,
    covariance: &DMatrix<f64>,
    n: usize,
    frame: FrameUncertainty,
) -> (Vec<usize>, DMatrix<f64>) {
    let unknowns = &calibration.unknowns;
    let identified = |j: &usize| unknowns[*j].status == UnknownStatus::Identified;
    let is_frame = |j: &usize| unknowns[*j].name.starts_with("frame_");
    let block = |rows: &[usize], cols: &[usize]| {
        DMatrix::<f64>::from_fn(rows.len(), cols.len(), |a, b| {
            covariance[(rows[a], cols[b])]
        })
    };
    if frame == FrameUncertainty::AsIdentified {
        let columns: Vec<usize> = (0..n).filter(identified).collect();
        let sigma = block(&columns, &columns);
        return (columns, sigma);
    }
    let columns: Vec<usize> = (0..n).filter(|j| identified(j) && !is_frame(j)).collect();
    let frame_columns: Vec<usize> = (0..n).filter(|j| identified(j) && is_frame(j)).collect();
    let sigma = conditioned_on(
        block(&columns, &columns),
        &block(&columns, &frame_columns),
        &block(&frame_columns, &frame_columns),
    );
    (columns, sigma)
}

/// The covariance of the robot's unknowns with the measurement frame known:
/// the Schur complement `S_rr - S_rf S_ff^+ S_fr` (m, rad; the frame block's
/// pseudo-inverse, its singular values below `1e-12` times the largest
/// taken as zero). It equals the inverse of the robot block of the
/// information matrix: the uncertainty of the robot's geometry that a
/// change of the measurement frame cannot explain. The marginal block
/// `S_rr` is not the robot's accuracy: lengths next to the base trade off
/// with the frame's translation, so their marginal errors can be
/// millimetres while the robot's shape is known to micrometres.
fn conditioned_on(rr: DMatrix<f64>, rf: &DMatrix<f64>, ff: &DMatrix<f64>) -> DMatrix<f64> {
    if ff.nrows() == 0 {
        return rr;
    }
    let svd = ff.clone().svd(true, true);
    let largest = svd.singular_values.max();
    let Ok(ff_pinv) = svd.pseudo_inverse(1e-12 * largest.max(f64::MIN_POSITIVE)) else {
        return rr;
    };
    let conditioned = rr - rf * ff_pinv * rf.transpose();
    // Symmetric, positive semi-definite up to rounding.
    (&conditioned + conditioned.transpose()) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The Schur complement is the inverse of the robot block of the
    /// information matrix, for random covariances with strong correlations
    /// between the robot's unknowns and the frame's.
    #[test]
    fn conditioning_on_the_frame_inverts_the_information_block() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for (nr, nf) in [(5, 3), (8, 6), (1, 1), (4, 0)] {
            let n = nr + nf;
            // A x A^T with A nearly rank-deficient: large, correlated entries.
            let a = DMatrix::<f64>::from_fn(n, n + 2, |_, _| rng.random_range(-1.0..1.0));
            let mut sigma = &a * a.transpose();
            for i in 0..n {
                sigma[(i, i)] += 1e-3;
            }
            let rr = sigma.view((0, 0), (nr, nr)).into_owned();
            let rf = sigma.view((0, nr), (nr, nf)).into_owned();
            let ff = sigma.view((nr, nr), (nf, nf)).into_owned();
            let conditioned = conditioned_on(rr, &rf, &ff);
            let information = sigma.clone().try_inverse().unwrap();
            let expected = information
                .view((0, 0), (nr, nr))
                .into_owned()
                .try_inverse()
                .unwrap();
            let scale = expected.amax();
            assert!(
                (&conditioned - &expected).amax() < 1e-8 * scale.max(1.0),
                "{nr}+{nf}: {conditioned} against {expected}"
            );
        }
    }
}
