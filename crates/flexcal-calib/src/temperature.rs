//! Whether temperature explains the error left after calibration, and the
//! per-pose error file (`flexcal calibrate --residuals`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::measurement::MeasurementSet;
use crate::metrics::PoseError;

/// The position error after calibration against the recorded temperature.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TemperatureCheck {
    /// Poses that carry a temperature.
    pub n_poses: usize,
    /// Lowest temperature (deg C).
    pub min_c: f64,
    /// Highest temperature (deg C).
    pub max_c: f64,
    /// Correlation coefficient of the position error with the temperature;
    /// none when either is constant.
    pub correlation: Option<f64>,
    /// Least-squares slope of the position error against the temperature
    /// (mm/K); none when either is constant.
    pub slope_mm_per_k: Option<f64>,
}

impl TemperatureCheck {
    /// Correlates the position errors `errors` (one per measurement of
    /// `set`) with the measurements' temperatures; none when fewer than 3
    /// poses carry a temperature.
    pub fn of(set: &MeasurementSet, errors: &[PoseError]) -> Option<Self> {
        let pairs: Vec<(f64, f64)> = set
            .poses()
            .iter()
            .zip(errors)
            .filter_map(|(m, e)| m.temperature_c.map(|t| (t, e.position * 1e3)))
            .collect();
        if pairs.len() < 3 {
            return None;
        }
        let n = pairs.len() as f64;
        let (mt, me) = pairs
            .iter()
            .fold((0.0, 0.0), |(a, b), (t, e)| (a + t / n, b + e / n));
        let (mut stt, mut see, mut ste) = (0.0, 0.0, 0.0);
        for (t, e) in &pairs {
            stt += (t - mt) * (t - mt);
            see += (e - me) * (e - me);
            ste += (t - mt) * (e - me);
        }
        let (min_c, max_c) = pairs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), (t, _)| {
                (l.min(*t), h.max(*t))
            });
        let varies = stt > 0.0 && see > 0.0;
        Some(Self {
            n_poses: pairs.len(),
            min_c,
            max_c,
            correlation: varies.then(|| ste / (stt * see).sqrt()),
            slope_mm_per_k: varies.then(|| ste / stt),
        })
    }
}

/// The per-pose error file: `pose,temperature_c,position_error_mm,
/// orientation_error_deg,dx_mm,dy_mm,dz_mm`, one row per measurement of `set`.
pub fn pose_errors_csv(set: &MeasurementSet, errors: &[PoseError]) -> String {
    let mut text = String::from(
        "pose,temperature_c,position_error_mm,orientation_error_deg,dx_mm,dy_mm,dz_mm\n",
    );
    for (k, (e, m)) in errors.iter().zip(set.poses()).enumerate() {
        let optional = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
        text.push_str(&format!(
            "{},{},{},{},{},{},{}\n",
            m.label(k).replace(',', ";"),
            optional(m.temperature_c),
            e.position * 1e3,
            optional(e.orientation.map(f64::to_degrees)),
            e.position_vector.x * 1e3,
            e.position_vector.y * 1e3,
            e.position_vector.z * 1e3
        ));
    }
    text
}

/// Writes [`pose_errors_csv`] to `path` (atomically).
pub fn write_pose_errors(
    path: impl AsRef<Path>,
    set: &MeasurementSet,
    errors: &[PoseError],
) -> Result<(), flexcal_io::IoError> {
    flexcal_io::write_atomic(path, pose_errors_csv(set, errors))
}
