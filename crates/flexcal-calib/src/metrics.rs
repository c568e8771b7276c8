//! Error metrics of a model on a measurement set: the errors of each pose
//! and their mean, RMS and maximum. Shared by the identification (training
//! errors), the data checks and validation.

use nalgebra::Vector3;
use serde::Serialize;

/// Errors of one pose: position error norm (m) and orientation error angle
/// (rad) when orientations are used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PoseError {
    /// `|p_predicted - p_measured|` (m).
    pub position: f64,
    /// `p_measured - p_predicted` in the measurement frame (m): what the
    /// model misses, component by component.
    pub position_vector: Vector3<f64>,
    /// Angle of `R_predicted R_measured^T` (rad), when used.
    pub orientation: Option<f64>,
}

/// Mean, RMS and maximum of the pose errors of a set.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ErrorStatistics {
    /// Number of poses.
    pub n_poses: usize,
    /// Mean position error (m).
    pub position_mean: f64,
    /// RMS position error (m).
    pub position_rms: f64,
    /// Maximum position error (m).
    pub position_max: f64,
    /// Mean, RMS and maximum orientation error (rad), when used.
    pub orientation_mean_rms_max: Option<(f64, f64, f64)>,
}

/// Mean / RMS / max of pose errors.
pub fn error_statistics(errors: &[PoseError]) -> ErrorStatistics {
    let n = errors.len().max(1) as f64;
    let stats = |v: &mut dyn Iterator<Item = f64>| {
        let (mut sum, mut sum2, mut max) = (0.0, 0.0, 0.0f64);
        for e in v {
            sum += e;
            sum2 += e * e;
            max = max.max(e);
        }
        (sum / n, (sum2 / n).sqrt(), max)
    };
    let (position_mean, position_rms, position_max) = stats(&mut errors.iter().map(|e| e.position));
    let orientation_mean_rms_max =
        if !errors.is_empty() && errors.iter().all(|e| e.orientation.is_some()) {
            Some(stats(&mut errors.iter().filter_map(|e| e.orientation)))
        } else {
            None
        };
    ErrorStatistics {
        n_poses: errors.len(),
        position_mean,
        position_rms,
        position_max,
        orientation_mean_rms_max,
    }
}

/// The error of one observation: a target at a pose.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObservationError {
    /// The pose's label (`pose_id`, or `#k` from its index).
    pub pose: String,
    /// The target's name.
    pub target: String,
    /// Measured minus predicted position, in the measurement frame (m).
    pub error: Vector3<f64>,
    /// Angle of the orientation error (rad), for a target whose
    /// orientations are fitted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_error: Option<f64>,
}

/// Errors of one target over the poses where it was seen.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetErrors {
    /// Target name.
    pub target: String,
    /// Frame it is fixed to.
    pub frame: String,
    /// Mean, RMS and maximum position error (m) over its observations.
    pub statistics: ErrorStatistics,
}

/// `pose,target,position_error_mm,dx_mm,dy_mm,dz_mm`, one row per
/// observation (mm; a comma in a pose label written as `;`), and
/// `orientation_error_deg` when some target's orientations are fitted: the
/// per-observation error file of `flexcal calibrate --targets --residuals`,
/// as `temperature::pose_errors_csv` is for one target
/// without its target column.
pub fn observation_errors_csv(errors: &[ObservationError]) -> String {
    let oriented = errors.iter().any(|e| e.orientation_error.is_some());
    let mut out = String::from("pose,target,position_error_mm,dx_mm,dy_mm,dz_mm");
    out.push_str(if oriented {
        ",orientation_error_deg\n"
    } else {
        "\n"
    });
    for e in errors {
        let mm = e.error * 1e3;
        out.push_str(&format!(
            "{},{},{},{},{},{}",
            e.pose.replace(',', ";"),
            e.target,
            mm.norm(),
            mm.x,
            mm.y,
            mm.z
        ));
        if oriented {
            out.push_str(&format!(
                ",{}",
                e.orientation_error
                    .map_or(String::new(), |a| a.to_degrees().to_string())
            ));
        }
        out.push('\n');
    }
    out
}

impl From<&ObservationError> for PoseError {
    fn from(e: &ObservationError) -> Self {
        Self {
            position: e.error.norm(),
            position_vector: e.error,
            orientation: e.orientation_error,
        }
    }
}
