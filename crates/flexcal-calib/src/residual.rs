//! A data-driven model of what a calibration leaves: zero-order
//! Takagi-Sugeno fuzzy models (the paper's section 2.2.2 idea, here applied
//! to the remaining position errors instead of the compliance) of the
//! error vector in the robot base frame as a function of chosen actuated
//! coordinates, fitted on the identification poses only.
//!
//! The correction lives in the base frame so that it carries over to a
//! series measured from another tracker position: on validation the
//! measurement frame is re-fitted with the corrected predictions.

use flexcal_fuzzy::{Dataset, FitReport, FuzzyModel, FuzzyParams};
use flexcal_kinematics::Model;
use nalgebra::Vector3;

use crate::error::CalibError;
use crate::identify::Calibration;
use crate::measurement::{Measurement, MeasurementSet};
use crate::validate::ValidationReport;

/// Share of the identification poses held out (seeded) to choose the fuzzy
/// structures; the conclusions are then fitted on the rest.
pub const RESIDUAL_TEST_FRACTION: f64 = 0.25;

/// Residual position model `delta(q)` (m, robot base frame): one fuzzy model
/// per axis over the chosen actuated coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualModel {
    /// Indices of the actuated coordinates used as inputs.
    pub inputs: Vec<usize>,
    /// The x, y and z models (outputs in m).
    pub models: [FuzzyModel; 3],
    /// How each was fitted (errors in m).
    pub reports: [FitReport; 3],
}

fn fuzzy_error(what: &str) -> impl Fn(flexcal_fuzzy::FuzzyError) -> CalibError + '_ {
    move |e| CalibError::InvalidOption {
        name: "residual model",
        reason: format!("{what}: {e}"),
    }
}

impl ResidualModel {
    /// Fits the residual model of `calibration` on its identification set
    /// `set`, over the actuated coordinates named `inputs`; `seed` draws the
    /// held-out poses of the structure search.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for an input that is not an actuated
    /// coordinate, or when the fuzzy fit fails (too few poses for the rules,
    /// a constant input).
    pub fn fit(
        model: &Model,
        calibration: &Calibration,
        set: &MeasurementSet,
        inputs: &[&str],
        params: &FuzzyParams,
        seed: u64,
    ) -> Result<Self, CalibError> {
        let names = model.actuated_names();
        let indices = inputs
            .iter()
            .map(|name| {
                names
                    .iter()
                    .position(|n| n == name)
                    .ok_or_else(|| CalibError::InvalidOption {
                        name: "residual model",
                        reason: format!(
                            "`{name}` is not an actuated coordinate of `{}` (those are {})",
                            model.name(),
                            names.join(", ")
                        ),
                    })
            })
            .collect::<Result<Vec<usize>, CalibError>>()?;
        if indices.is_empty() {
            return Err(CalibError::InvalidOption {
                name: "residual model",
                reason: "give at least one actuated coordinate as input".into(),
            });
        }
        // What the model misses, in the base frame.
        let errors = calibration.training_errors(model, set)?;
        // Each pose's error into the base frame through its station's frame.
        let residuals: Vec<Vector3<f64>> = errors
            .iter()
            .enumerate()
            .map(|(k, e)| {
                let frame = match set.station_of(k) {
                    0 => &calibration.x_meas_base,
                    s => &calibration.station_frames[s - 1],
                };
                frame.rotation.inverse() * e.position_vector
            })
            .collect();
        let columns: Vec<Vec<f64>> = indices
            .iter()
            .map(|&i| set.poses().iter().map(|p| p.q[i]).collect())
            .collect();
        let input_names: Vec<String> = indices.iter().map(|&i| names[i].clone()).collect();
        let fit_axis = |axis: usize| -> Result<(FuzzyModel, FitReport), CalibError> {
            let label = ["dx", "dy", "dz"][axis];
            let data = Dataset::new(
                input_names.clone(),
                label.to_string(),
                &columns,
                residuals.iter().map(|r| r[axis]).collect(),
            )
            .map_err(fuzzy_error(label))?;
            let (train, test) = data
                .split_random(RESIDUAL_TEST_FRACTION, seed)
                .map_err(fuzzy_error(label))?;
            let fit = params
                .fit(&train, &test, &mut |_| {})
                .map_err(fuzzy_error(label))?;
            Ok((fit.model, fit.report))
        };
        let (mx, rx) = fit_axis(0)?;
        let (my, ry) = fit_axis(1)?;
        let (mz, rz) = fit_axis(2)?;
        Ok(Self {
            inputs: indices,
            models: [mx, my, mz],
            reports: [rx, ry, rz],
        })
    }

    /// `delta(q)` (m, base frame): the error the calibrated model is expected
    /// to leave at `q` (inputs outside the training range are clamped).
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] for a `q` too short or not finite.
    pub fn correction(&self, q: &[f64]) -> Result<Vector3<f64>, CalibError> {
        let x = self
            .inputs
            .iter()
            .map(|&i| {
                q.get(i).copied().ok_or_else(|| CalibError::InvalidOption {
                    name: "residual model",
                    reason: format!("pose has {} coordinates, input {i} missing", q.len()),
                })
            })
            .collect::<Result<Vec<f64>, CalibError>>()?;
        let mut out = Vector3::zeros();
        for (axis, m) in self.models.iter().enumerate() {
            out[axis] = m.evaluate(&x).map_err(fuzzy_error("evaluation"))?;
        }
        Ok(out)
    }

    /// Number of rules of the x, y and z models.
    pub fn rule_counts(&self) -> [usize; 3] {
        [0, 1, 2].map(|a| self.models[a].conclusions().len())
    }
}

impl Calibration {
    /// Validation with a residual model added to the calibrated predictions:
    /// as [`Calibration::validate`], the measurement frame re-fitted (when it
    /// was identified) with the corrected predictions. The correction is in
    /// the base frame, so each measurement is moved by it expressed in the
    /// current frame estimate and the frame re-fitted, until the frame stops
    /// moving (three rounds reach well below a micrometre).
    ///
    /// # Errors
    /// As [`Calibration::validate`] and [`ResidualModel::correction`].
    pub fn validate_with_residual_model(
        &self,
        model: &Model,
        set: &MeasurementSet,
        residual: &ResidualModel,
        refit_target: bool,
    ) -> Result<ValidationReport, CalibError> {
        let corrections = set
            .measurements()
            .iter()
            .map(|m| residual.correction(&m.q))
            .collect::<Result<Vec<_>, _>>()?;
        // Before, notes and extrapolation as without the model; the "after"
        // is then recomputed with the corrections.
        let mut report = self.validate(model, set, refit_target)?;
        let ([_, policy], _) = self.validation_policy(refit_target.into());
        let rounds = if self.measurement_frame_fixed { 1 } else { 3 };
        for _ in 0..rounds {
            let rotation = report.measurement_frame.rotation;
            // measured = frame * (predicted + delta)  <=>
            // measured - R delta = frame * predicted.
            let moved: Vec<Measurement> = set
                .measurements()
                .iter()
                .zip(&corrections)
                .map(|(m, d)| {
                    let mut m = m.clone();
                    m.position -= rotation * d;
                    m
                })
                .collect();
            let mut corrected = MeasurementSet::new(&set.source, moved)?;
            if let Some(x_tcp_target) = set.nominal_target() {
                corrected.set_nominal_target(x_tcp_target);
            }
            let (errors, frame) = self.errors_after(model, &corrected, policy)?;
            report.set_after(set, errors, frame)?;
        }
        Ok(report)
    }
}
