//! Measured deflections expressed with a model's inputs, and their noise
//! floor.

use flexcal_kinematics::Model;
use nalgebra::{Vector3, Vector6};

use super::components::Axis;
use super::error::Result;
use super::inputs::RobotInputs;
use crate::campaign::DeflectionMeasurement;

/// One measured deflection expressed with the model's inputs.
#[derive(Debug, Clone, PartialEq)]
pub struct ComplianceSample {
    /// Pose identifier (for messages; configurations are grouped by their
    /// input values).
    pub pose_id: u64,
    /// Input values (SI), in the order of the model's inputs.
    pub inputs: Vec<f64>,
    /// Wrench applied at the TCP `[N; N.m]`, base axes.
    pub wrench: Vector6<f64>,
    /// Measured TCP displacement (m), base axes.
    pub deflection: Vector3<f64>,
    /// Standard deviation of each deflection component (m; zero when
    /// unknown).
    pub sigma: Vector3<f64>,
}

impl ComplianceSample {
    /// Magnitude of the applied force (N).
    pub fn load_n(&self) -> f64 {
        self.wrench.fixed_rows::<3>(0).norm()
    }
}

/// Converts deflection measurements to samples of the model's inputs.
///
/// # Errors
/// As [`RobotInputs::values`], for the first failing measurement.
pub fn compliance_samples(
    robot: &Model,
    inputs: &RobotInputs,
    measurements: &[DeflectionMeasurement],
) -> Result<Vec<ComplianceSample>> {
    measurements
        .iter()
        .map(|m| {
            Ok(ComplianceSample {
                pose_id: m.pose_id,
                inputs: inputs.values(robot, &m.q)?,
                wrench: m.wrench,
                deflection: m.deflection,
                sigma: m.sigma,
            })
        })
        .collect()
}

/// The measurement-noise floor of a set of samples along `axes`: the RMS
/// over samples of the norm of the deflection noise restricted to those
/// axes, `sqrt(mean_k sum_axis sigma_k,axis^2)` (m), from the standard
/// deviations the samples carry. A model that predicts perfectly still
/// shows this RMS residual. Zero for no samples.
pub fn noise_floor_rms(samples: &[ComplianceSample], axes: &[Axis]) -> f64 {
    if samples.is_empty() {
        return 0.0;
    }
    let sum: f64 = samples
        .iter()
        .map(|s| {
            axes.iter()
                .filter(|a| a.is_linear())
                .map(|a| s.sigma[a.index()].powi(2))
                .sum::<f64>()
        })
        .sum();
    (sum / samples.len() as f64).sqrt()
}
