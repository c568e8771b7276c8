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
//!   errors of 0.027 mm; conditioned, 0.050 mm). The linearised covariance
//!   assumes independent errors; where the split-half check
//!   ([`crate::SplitCheck::prediction_ratio`]) finds the halves' predicted
//!   positions further apart than the covariance says, every standard
//!   deviation is raised by that one ratio ([`AccuracyMap::inflation`]).
//!   Scaling each unknown by its own split ratio would break the
//!   correlations that make combinations of unknowns well known;
//! - what the model leaves: the scatter of the training residuals, per
//!   axis `s^2 = SSR / (3 N - p)` (positions; p identified unknowns), which
//!   holds measurement noise and every effect the model lacks, taken as
//!   isotropic and the same at every pose.
//!
//! The 95 % bound on the position error is `sqrt(chi2_3(0.95) (tr
//! Sigma_pred / 3 + s^2))` with `chi2_3(0.95) = 7.815`: exact for an
//! isotropic Gaussian error, an approximation otherwise. On a validation
//! series [`AccuracyMap::coverage`] is the share of poses whose measured
//! error lies within its bound; it should be near 95 %. It falls short
//! where the other series' poses see effects the training poses did not
//! (extrapolation, another day's temperature), which no statistic of the
//! training data can know.

use flexcal_kinematics::Model;
use nalgebra::{DMatrix, Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::error_model::GeometricErrorModel;
use crate::identify::{Calibration, UnknownStatus};
use crate::split::SplitCheck;
use crate::{CalibError, Measurement, MeasurementSet};
use flexcal_optim::{Jacobian, Residuals};

/// `chi2` quantile of 3 degrees of freedom at 95 %.
pub const CHI2_3_95: f64 = 7.814_727_903_251_178;

/// Predicted accuracy at one pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseAccuracy {
    /// Pose label (`line N`, the pose id, or the row of a grid file).
    pub pose: String,
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
    /// The actuated coordinates (by name) at which this pose lies outside
    /// the identification poses' range: there the bound assumes that the
    /// model holds beyond the data, which no statistic of the training
    /// poses can check (empty: inside every range).
    #[serde(default)]
    pub outside_training_range: Vec<String>,
}

/// Predicted accuracy over a set of poses (a workspace grid or a
/// validation series).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AccuracyMap {
    /// Per pose.
    pub poses: Vec<PoseAccuracy>,
    /// Per-axis scatter of the training residuals, `s` (mm).
    pub residual_scatter_mm: f64,
    /// Factor on every standard deviation of the identification from the
    /// split-half check ([`SplitCheck::prediction_ratio`], at least 1; 1
    /// without the check).
    pub inflation: f64,
    /// Share of the measured poses whose error lies within the bound
    /// (validation series only).
    pub coverage: Option<f64>,
    /// Mean of the bounds (mm).
    pub mean_bound_95_mm: f64,
    /// Number of poses outside the identification poses' range of at least
    /// one actuated coordinate ([`PoseAccuracy::outside_training_range`]).
    #[serde(default)]
    pub extrapolated_poses: usize,
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
    /// `pose,q1..qn,model_uncertainty_mm,bound_95_mm,actual_error_mm,x_mm,y_mm,z_mm,outside_training_range`
    /// (`x_mm,y_mm,z_mm`: [`PoseAccuracy::position_mm`]; the last column:
    /// [`PoseAccuracy::outside_training_range`], names separated by `;`).
    pub fn to_csv_string(&self) -> String {
        let n = self.poses.first().map_or(0, |p| p.q.len());
        let mut out = String::from("pose");
        for i in 1..=n {
            out.push_str(&format!(",q{i}"));
        }
        out.push_str(
            ",model_uncertainty_mm,bound_95_mm,actual_error_mm,x_mm,y_mm,z_mm,outside_training_range\n",
        );
        for p in &self.poses {
            out.push_str(&p.pose.replace(',', ";"));
            for q in &p.q {
                out.push_str(&format!(",{q:.9}"));
            }
            let [x, y, z] = p.position_mm;
            out.push_str(&format!(
                ",{:.6},{:.6},{},{x:.4},{y:.4},{z:.4},{}\n",
                p.model_uncertainty_mm,
                p.bound_95_mm,
                p.actual_error_mm
                    .map_or(String::new(), |e| format!("{e:.6}")),
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
    /// Predicted accuracy at the configurations `configurations` (rad or
    /// m), the covariance raised by `split`'s prediction ratio where it
    /// understates (module docs).
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
        let measurements: Vec<Measurement> = configurations
            .iter()
            .map(|q| Measurement::new(q.clone(), Vector3::zeros()))
            .collect();
        let set = MeasurementSet::new("accuracy grid", measurements)?;
        let labels: Vec<String> = (0..set.len()).map(|k| format!("row {}", k + 1)).collect();
        self.accuracy_at(model, &set, labels, None, split)
    }

    /// Predicted accuracy at the poses of the measured set `validation`,
    /// with their measured errors after calibration (the measurement frame
    /// re-fitted as in [`Calibration::validate`]) and the share within the
    /// bound.
    ///
    /// # Errors
    /// As [`Calibration::predicted_accuracy`] and [`Calibration::validate`].
    pub fn accuracy_coverage(
        &self,
        model: &Model,
        validation: &MeasurementSet,
        split: Option<&SplitCheck>,
    ) -> Result<AccuracyMap, CalibError> {
        let report = self.validate(model, validation, false)?;
        let actual: Vec<f64> = report.after_per_pose.iter().map(|e| e.position).collect();
        let labels = validation
            .measurements()
            .iter()
            .enumerate()
            .map(|(k, m)| m.label(k))
            .collect();
        self.accuracy_at(model, validation, labels, Some(&actual), split)
    }

    /// The identification's covariance (m, rad).
    fn covariance(&self) -> Result<&DMatrix<f64>, CalibError> {
        self.solve
            .covariance
            .as_ref()
            .ok_or(CalibError::InvalidOption {
                name: "accuracy",
                reason: "the identification has no covariance (no more equations than unknowns)"
                    .into(),
            })
    }

    /// The error model at the identified unknowns (frames at their
    /// identified values, zero increments; positions only) and those
    /// unknowns.
    fn error_model_at<'a>(
        &self,
        model: &'a Model,
        set: &'a MeasurementSet,
    ) -> Result<(GeometricErrorModel<'a>, Vec<f64>), CalibError> {
        // The later stations' frames are unknowns of the identification
        // (their covariance is part of it), with no pose of `set`.
        let mut problem =
            GeometricErrorModel::new(model, set, false, self.x_meas_base, self.x_tcp_target)?
                .with_station_frames(&self.station_frames)?;
        if let Some((gravity, _)) = &self.elastic {
            problem = problem.with_gravity(gravity)?;
        }
        if self.joint_terms.any() {
            problem = problem.with_joint_terms(&self.joint_terms)?;
        }
        let n = problem.n_unknowns();
        if n != self.unknowns.len() {
            return Err(CalibError::InvalidOption {
                name: "accuracy",
                reason: format!(
                    "the error model has {n} unknowns, the identification {}",
                    self.unknowns.len()
                ),
            });
        }
        let mut x = problem.initial_unknowns();
        let np = model.n_params();
        x[..np].copy_from_slice(&self.xi);
        if let (Some((_, values)), Some(eo)) = (&self.elastic, problem.elastic_offset()) {
            x[eo..eo + values.len()].copy_from_slice(values);
        }
        if let Some(jo) = problem.joint_terms_offset() {
            x[jo..].copy_from_slice(&self.joint_term_values);
        }
        Ok((problem, x))
    }

    /// The variance of the calibrated model's target position at each pose
    /// of `set` under the identification's covariance, every identified
    /// unknown with the frame's: `tr(J_k Sigma J_k^T)` (m^2, measurement
    /// frame). What the split-half check compares in the prediction space.
    pub(crate) fn prediction_variances(
        &self,
        model: &Model,
        set: &MeasurementSet,
    ) -> Result<Vec<f64>, CalibError> {
        let covariance = self.covariance()?;
        let (problem, x) = self.error_model_at(model, set)?;
        if covariance.nrows() != x.len() {
            return Err(covariance_size(covariance, x.len()));
        }
        let columns: Vec<usize> = (0..x.len())
            .filter(|&j| self.unknowns[j].status == UnknownStatus::Identified)
            .collect();
        let sigma = DMatrix::<f64>::from_fn(columns.len(), columns.len(), |a, b| {
            covariance[(columns[a], columns[b])]
        });
        let (jac, _) = jacobian_and_residuals(&problem, &x)?;
        Ok((0..set.len())
            .map(|k| {
                let rows =
                    DMatrix::<f64>::from_fn(3, columns.len(), |i, c| jac[(3 * k + i, columns[c])]);
                (&rows * &sigma * rows.transpose()).trace().max(0.0)
            })
            .collect())
    }

    /// The calibrated model's target positions at the poses of `set`, in
    /// the measurement frame (m).
    pub(crate) fn predicted_positions(
        &self,
        model: &Model,
        set: &MeasurementSet,
    ) -> Result<Vec<Vector3<f64>>, CalibError> {
        let (problem, x) = self.error_model_at(model, set)?;
        let mut residuals = vec![0.0; problem.n_residuals()];
        problem
            .residuals(&x, &mut residuals)
            .map_err(model_failure)?;
        Ok(set
            .measurements()
            .iter()
            .enumerate()
            .map(|(k, m)| m.position + Vector3::from_fn(|i, _| residuals[3 * k + i]))
            .collect())
    }

    fn accuracy_at(
        &self,
        model: &Model,
        set: &MeasurementSet,
        labels: Vec<String>,
        actual: Option<&[f64]>,
        split: Option<&SplitCheck>,
    ) -> Result<AccuracyMap, CalibError> {
        let covariance = self.covariance()?;
        let (problem, x) = self.error_model_at(model, set)?;
        let n = x.len();
        if covariance.nrows() != n {
            return Err(covariance_size(covariance, n));
        }
        // The split-half check's inflation, one factor on every standard
        // deviation: scaling unknowns apart would break the correlations
        // that make combinations of them well known.
        let inflation = split
            .and_then(|s| s.prediction_ratio)
            .map_or(1.0, |r| r.max(1.0));
        // The identified unknowns, the measurement frame's apart: the robot's
        // accuracy is its uncertainty with the frame known (conditioned on it).
        let identified = |j: &usize| self.unknowns[*j].status == UnknownStatus::Identified;
        let is_frame = |j: &usize| self.unknowns[*j].name.starts_with("frame_");
        let columns: Vec<usize> = (0..n).filter(|j| identified(j) && !is_frame(j)).collect();
        let frame_columns: Vec<usize> = (0..n).filter(|j| identified(j) && is_frame(j)).collect();
        let block = |rows: &[usize], cols: &[usize]| {
            DMatrix::<f64>::from_fn(rows.len(), cols.len(), |a, b| {
                let (ja, jb) = (rows[a], cols[b]);
                covariance[(ja, jb)] * inflation * inflation
            })
        };
        let sigma = conditioned_on(
            block(&columns, &columns),
            &block(&columns, &frame_columns),
            &block(&frame_columns, &frame_columns),
        );
        let (jac, predicted) = jacobian_and_residuals(&problem, &x)?;
        let base_from_meas = self.x_meas_base.inverse();
        // Residual scatter per axis, positions, with the degrees of freedom.
        let rows = 3 * self.n_poses;
        let p = self.rank();
        let ssr = self.training_after.position_rms.powi(2) * self.n_poses as f64;
        let s2 = ssr / (rows.saturating_sub(p).max(1)) as f64;
        let mut poses = Vec::with_capacity(set.len());
        let mut within = 0usize;
        let mut extrapolated_poses = 0usize;
        for (k, label) in labels.into_iter().enumerate() {
            let rows_k =
                DMatrix::<f64>::from_fn(3, columns.len(), |i, c| jac[(3 * k + i, columns[c])]);
            let pred = &rows_k * &sigma * rows_k.transpose();
            let trace = pred.trace().max(0.0);
            let bound = (CHI2_3_95 * (trace / 3.0 + s2)).sqrt();
            let actual_error = actual.map(|a| a[k]);
            let measured = set.measurements()[k].position;
            let in_meas = Point3::new(
                measured.x + predicted[3 * k],
                measured.y + predicted[3 * k + 1],
                measured.z + predicted[3 * k + 2],
            );
            let position = base_from_meas * in_meas;
            if actual_error.is_some_and(|e| e <= bound) {
                within += 1;
            }
            let q = &set.measurements()[k].q;
            let outside_training_range: Vec<String> = self
                .outside_training_range(q)
                .map(|i| model.actuated_names()[i].clone())
                .collect();
            extrapolated_poses += usize::from(!outside_training_range.is_empty());
            poses.push(PoseAccuracy {
                outside_training_range,
                pose: label,
                q: q.clone(),
                model_uncertainty_mm: trace.sqrt() * 1e3,
                bound_95_mm: bound * 1e3,
                actual_error_mm: actual_error.map(|e| e * 1e3),
                position_mm: [position.x * 1e3, position.y * 1e3, position.z * 1e3],
            });
        }
        let mean_bound_95_mm =
            poses.iter().map(|p| p.bound_95_mm).sum::<f64>() / poses.len().max(1) as f64;
        Ok(AccuracyMap {
            coverage: actual.map(|_| within as f64 / set.len().max(1) as f64),
            poses,
            residual_scatter_mm: s2.sqrt() * 1e3,
            inflation,
            mean_bound_95_mm,
            extrapolated_poses,
        })
    }
}

/// The covariance does not match the error model's unknowns.
fn covariance_size(covariance: &DMatrix<f64>, n: usize) -> CalibError {
    CalibError::InvalidOption {
        name: "accuracy",
        reason: format!(
            "the error model has {n} unknowns, the identification's covariance {}",
            covariance.nrows()
        ),
    }
}

/// A model failure at a pose, as the accuracy's error.
fn model_failure(e: flexcal_optim::ProblemError) -> CalibError {
    CalibError::InvalidOption {
        name: "accuracy",
        reason: e.to_string(),
    }
}

/// The error model's Jacobian and residuals at `x`.
fn jacobian_and_residuals(
    problem: &GeometricErrorModel<'_>,
    x: &[f64],
) -> Result<(faer::Mat<f64>, Vec<f64>), CalibError> {
    let mut jac = faer::Mat::<f64>::zeros(problem.n_residuals(), x.len());
    problem.jacobian(x, jac.as_mut()).map_err(model_failure)?;
    let mut residuals = vec![0.0; problem.n_residuals()];
    problem
        .residuals(x, &mut residuals)
        .map_err(model_failure)?;
    Ok((jac, residuals))
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
