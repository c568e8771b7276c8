//! Predicted accuracy with confidence: how far from the truth the
//! calibrated model's prediction of the target position is likely to be at
//! any pose, and a check of that claim on measured poses.
//!
//! At a pose q the prediction error has two parts:
//! - the identification's own uncertainty, `Sigma_pred = J_S Sigma J_S^T`,
//!   with `J_S` the position rows of the error model's Jacobian at q (the
//!   robot, target, elastic and joint-term columns: the measurement frame
//!   is not part of the robot's accuracy) and `Sigma` the covariance of the
//!   identified unknowns ([`flexcal_optim::SolveReport::covariance`]). The
//!   linearised covariance assumes independent errors; where the split-half
//!   check ([`crate::SplitCheck`]) finds an unknown's split error larger
//!   than its standard error, that unknown's rows and columns of `Sigma`
//!   are scaled by the ratio (the standard error raised to the split error);
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
}

/// Predicted accuracy over a set of poses (a workspace grid or a
/// validation series).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AccuracyMap {
    /// Per pose.
    pub poses: Vec<PoseAccuracy>,
    /// Per-axis scatter of the training residuals, `s` (mm).
    pub residual_scatter_mm: f64,
    /// Unknowns whose covariance was inflated by the split-half check, with
    /// the factor.
    pub inflated: Vec<(String, f64)>,
    /// Share of the measured poses whose error lies within the bound
    /// (validation series only).
    pub coverage: Option<f64>,
    /// Mean of the bounds (mm).
    pub mean_bound_95_mm: f64,
}

impl AccuracyMap {
    /// The map as CSV:
    /// `pose,q1..qn,model_uncertainty_mm,bound_95_mm,actual_error_mm,x_mm,y_mm,z_mm`
    /// (the last three: [`PoseAccuracy::position_mm`]).
    pub fn to_csv_string(&self) -> String {
        let n = self.poses.first().map_or(0, |p| p.q.len());
        let mut out = String::from("pose");
        for i in 1..=n {
            out.push_str(&format!(",q{i}"));
        }
        out.push_str(",model_uncertainty_mm,bound_95_mm,actual_error_mm,x_mm,y_mm,z_mm\n");
        for p in &self.poses {
            out.push_str(&p.pose.replace(',', ";"));
            for q in &p.q {
                out.push_str(&format!(",{q:.9}"));
            }
            let [x, y, z] = p.position_mm;
            out.push_str(&format!(
                ",{:.6},{:.6},{},{x:.4},{y:.4},{z:.4}\n",
                p.model_uncertainty_mm,
                p.bound_95_mm,
                p.actual_error_mm
                    .map_or(String::new(), |e| format!("{e:.6}"))
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
    /// m), the covariance inflated by `split` where it understates (module
    /// docs).
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

    fn accuracy_at(
        &self,
        model: &Model,
        set: &MeasurementSet,
        labels: Vec<String>,
        actual: Option<&[f64]>,
        split: Option<&SplitCheck>,
    ) -> Result<AccuracyMap, CalibError> {
        let covariance = self
            .solve
            .covariance
            .as_ref()
            .ok_or(CalibError::InvalidOption {
                name: "accuracy",
                reason: "the identification has no covariance (no more equations than unknowns)"
                    .into(),
            })?;
        // The error model at the identified unknowns: frames at the
        // identified values (zero increments), orientations not used.
        let mut problem =
            GeometricErrorModel::new(model, set, false, self.x_meas_base, self.x_tcp_target)?;
        if let Some((gravity, _)) = &self.elastic {
            problem = problem.with_gravity(gravity)?;
        }
        if self.joint_terms.any() {
            problem = problem.with_joint_terms(&self.joint_terms)?;
        }
        let n = problem.n_unknowns();
        if n != covariance.nrows() || n != self.unknowns.len() {
            return Err(CalibError::InvalidOption {
                name: "accuracy",
                reason: format!(
                    "the error model has {n} unknowns, the identification {}",
                    covariance.nrows()
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
        // Inflation per unknown by the split-half check.
        let mut factor = vec![1.0; n];
        let mut inflated = Vec::new();
        if let Some(split) = split {
            for s in &split.unknowns {
                if let (Some(ratio), Some(j)) =
                    (s.ratio, self.unknowns.iter().position(|u| u.name == s.name))
                {
                    if ratio > 1.0 {
                        factor[j] = ratio;
                        inflated.push((s.name.clone(), ratio));
                    }
                }
            }
        }
        // The identified unknowns, the measurement frame's excepted.
        let columns: Vec<usize> = (0..n)
            .filter(|&j| {
                self.unknowns[j].status == UnknownStatus::Identified
                    && !self.unknowns[j].name.starts_with("frame_")
            })
            .collect();
        let sigma = DMatrix::<f64>::from_fn(columns.len(), columns.len(), |a, b| {
            let (ja, jb) = (columns[a], columns[b]);
            covariance[(ja, jb)] * factor[ja] * factor[jb]
        });
        let mut jac = faer::Mat::<f64>::zeros(3 * set.len(), n);
        problem
            .jacobian(&x, jac.as_mut())
            .map_err(|e| CalibError::InvalidOption {
                name: "accuracy",
                reason: e.to_string(),
            })?;
        // The predicted target positions: the residuals against the set's
        // measured positions, carried back to the base frame.
        let mut predicted = vec![0.0; problem.n_residuals()];
        problem
            .residuals(&x, &mut predicted)
            .map_err(|e| CalibError::InvalidOption {
                name: "accuracy",
                reason: e.to_string(),
            })?;
        let base_from_meas = self.x_meas_base.inverse();
        // Residual scatter per axis, positions, with the degrees of freedom.
        let rows = 3 * self.n_poses;
        let p = self.rank();
        let ssr = self.training_after.position_rms.powi(2) * self.n_poses as f64;
        let s2 = ssr / (rows.saturating_sub(p).max(1)) as f64;
        let mut poses = Vec::with_capacity(set.len());
        let mut within = 0usize;
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
            poses.push(PoseAccuracy {
                pose: label,
                q: set.measurements()[k].q.clone(),
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
            inflated,
            mean_bound_95_mm,
        })
    }
}
