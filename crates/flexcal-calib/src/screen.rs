//! Data checks: measurements that look like recording faults, found before
//! and after a fit, reported by pose label and never dropped silently.
//!
//! - A *repeated reading*: two poses whose actuated coordinates differ but
//!   whose measured positions (and orientations, when measured) are equal to
//!   the last bit. A real robot in two configurations is never measured at
//!   the very same place to the tracker's resolution, so one pose carries the
//!   other's measurement (a stale value logged again). Series B of the IPA
//!   UR10 data has two such pairs.
//! - A *suspect pose*: after a fit, a pose whose position error exceeds
//!   [`SUSPECT_ERROR_RATIO`] times the set's RMS position error. For
//!   isotropic Gaussian errors that happens with probability below 1e-9 per
//!   pose (the norm would exceed 6.9 standard deviations per axis), so such
//!   a pose is a measurement fault or an effect the model lacks (unless the
//!   fit is exact to round-off: [`ROUND_OFF_RMS`]).
//!
//! Poses can then be left out by label ([`MeasurementSet::excluding`]).

use serde::Serialize;

use crate::metrics::{PoseError, error_statistics};
use crate::{CalibError, MeasurementSet};

/// A pose whose position error exceeds this many times the set's RMS
/// position error is reported as suspect.
pub const SUSPECT_ERROR_RATIO: f64 = 4.0;

/// Below this RMS position error (m) a fit is exact to round-off (simulated
/// data without noise) and no pose is called suspect.
pub const ROUND_OFF_RMS: f64 = 1e-9;

/// Two poses with different actuated coordinates and the identical
/// measurement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RepeatedReading {
    /// Labels of the two poses ([`crate::Measurement::label`]), in file order.
    pub poses: [String; 2],
}

/// A pose with an unusually large error after a fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuspectPose {
    /// Label of the pose ([`crate::Measurement::label`]).
    pub pose: String,
    /// Its position error (mm).
    pub position_error_mm: f64,
    /// Its position error over the set's RMS position error.
    pub ratio_to_rms: f64,
}

/// The data checks of one measurement set.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct DataChecks {
    /// Pairs of poses that carry the identical measurement.
    pub repeated_readings: Vec<RepeatedReading>,
    /// Poses whose position error after the fit exceeds
    /// [`SUSPECT_ERROR_RATIO`] times the RMS position error.
    pub suspect_poses: Vec<SuspectPose>,
    /// RMS position error of the set after the fit (mm).
    pub position_rms_mm: f64,
}

impl DataChecks {
    /// Both checks on `set`, with `errors` its per-pose errors after a fit
    /// (in the order of the set).
    pub fn new(set: &MeasurementSet, errors: &[PoseError]) -> Self {
        debug_assert_eq!(set.len(), errors.len());
        let rms = error_statistics(errors).position_rms;
        let suspect_poses = errors
            .iter()
            .enumerate()
            .filter(|(_, e)| rms > ROUND_OFF_RMS && e.position > SUSPECT_ERROR_RATIO * rms)
            .map(|(k, e)| SuspectPose {
                pose: set.measurements()[k].label(k),
                position_error_mm: e.position * 1e3,
                ratio_to_rms: e.position / rms,
            })
            .collect();
        Self {
            repeated_readings: repeated_readings(set),
            suspect_poses,
            position_rms_mm: rms * 1e3,
        }
    }

    /// The findings in sentences (none when the data pass both checks);
    /// `what` names the set ("identification", "validation").
    pub fn notes(&self, what: &str) -> Vec<String> {
        let mut notes = Vec::new();
        for r in &self.repeated_readings {
            let suspect: Vec<&str> = r
                .poses
                .iter()
                .filter(|p| self.suspect_poses.iter().any(|s| &s.pose == *p))
                .map(String::as_str)
                .collect();
            notes.push(format!(
                "{what} set: {} and {} carry the identical measurement to the last digit though their joint coordinates differ: one of them is a stale reading{}",
                r.poses[0],
                r.poses[1],
                match suspect.as_slice() {
                    [one] => format!(" ({one}, by its error after the fit)"),
                    _ => String::new(),
                }
            ));
        }
        if !self.suspect_poses.is_empty() {
            let list: Vec<String> = self
                .suspect_poses
                .iter()
                .map(|s| format!("{} ({:.2} mm)", s.pose, s.position_error_mm))
                .collect();
            notes.push(format!(
                "{what} set: {} pose{} with a position error above {SUSPECT_ERROR_RATIO} times the RMS error ({:.3} mm), which Gaussian noise practically never gives: {}; a measurement fault or an effect the model lacks; the figures include {}",
                list.len(),
                if list.len() == 1 { "" } else { "s" },
                self.position_rms_mm,
                list.join(", "),
                if list.len() == 1 { "it" } else { "them" }
            ));
        }
        notes
    }
}

/// Pairs of poses of `set` whose actuated coordinates differ but whose
/// measured position (and orientation, when measured) is bit-identical.
pub fn repeated_readings(set: &MeasurementSet) -> Vec<RepeatedReading> {
    let key = |k: usize| {
        let m = &set.measurements()[k];
        let mut bits: Vec<u64> = m.position.iter().map(|v| v.to_bits()).collect();
        if let Some(o) = m.orientation {
            bits.extend(o.iter().map(|v| v.to_bits()));
        }
        bits
    };
    let mut first_with: std::collections::HashMap<Vec<u64>, Vec<usize>> =
        std::collections::HashMap::new();
    let mut pairs = Vec::new();
    for k in 0..set.len() {
        let earlier = first_with.entry(key(k)).or_default();
        for &j in earlier.iter() {
            if set.measurements()[j].q != set.measurements()[k].q {
                pairs.push(RepeatedReading {
                    poses: [
                        set.measurements()[j].label(j),
                        set.measurements()[k].label(k),
                    ],
                });
            }
        }
        earlier.push(k);
    }
    pairs
}

impl MeasurementSet {
    /// The set without the poses labelled `labels` ([`crate::Measurement::label`]:
    /// `line 534` for the IPA format, the `pose_id` or `#k` for flexcal's own).
    /// A bare number `N` stands for `line N`.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] (`exclude`) naming a label that matches
    /// no pose of the set; [`CalibError::BadMeasurement`] when nothing is left.
    pub fn excluding(&self, labels: &[impl AsRef<str>]) -> Result<Self, CalibError> {
        let labels_now: Vec<String> = (0..self.len())
            .map(|k| self.measurements()[k].label(k))
            .collect();
        let mut drop = vec![false; self.len()];
        for raw in labels {
            let raw = raw.as_ref().trim();
            let wanted = if raw.chars().all(|c| c.is_ascii_digit()) && !raw.is_empty() {
                format!("line {raw}")
            } else {
                raw.to_string()
            };
            let hits: Vec<usize> = labels_now
                .iter()
                .enumerate()
                .filter(|(_, l)| **l == wanted || (**l == raw && raw != wanted))
                .map(|(k, _)| k)
                .collect();
            if hits.is_empty() {
                return Err(CalibError::InvalidOption {
                    name: "exclude",
                    reason: format!(
                        "no pose `{wanted}` in {} (its poses are labelled like `{}`)",
                        self.source, labels_now[0]
                    ),
                });
            }
            for k in hits {
                drop[k] = true;
            }
        }
        let kept: Vec<usize> = (0..self.len()).filter(|&k| !drop[k]).collect();
        self.subset(&kept)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Measurement;
    use nalgebra::Vector3;

    fn set() -> MeasurementSet {
        let m = |id: &str, q: f64, p: [f64; 3]| Measurement {
            pose_id: Some(id.into()),
            ..Measurement::new(vec![q, 0.0], Vector3::from(p))
        };
        MeasurementSet::new(
            "s.csv",
            vec![
                m("line 2", 0.1, [1.0, 2.0, 3.0]),
                m("line 3", 0.2, [1.0, 2.0, 3.0]),
                m("line 4", 0.1, [1.0, 2.0, 3.0 + 1e-12]),
                m("line 5", 0.3, [1.5, 2.0, 3.0]),
            ],
        )
        .unwrap()
    }

    #[test]
    fn identical_readings_at_other_coordinates_are_found() {
        let pairs = repeated_readings(&set());
        assert_eq!(
            pairs,
            vec![RepeatedReading {
                poses: ["line 2".into(), "line 3".into()]
            }]
        );
        // The same coordinates measured twice are not a repeated reading.
        let same = MeasurementSet::new(
            "t",
            vec![
                Measurement::new(vec![0.1], Vector3::new(1.0, 0.0, 0.0)),
                Measurement::new(vec![0.1], Vector3::new(1.0, 0.0, 0.0)),
            ],
        )
        .unwrap();
        assert!(repeated_readings(&same).is_empty());
    }

    #[test]
    fn suspects_exceed_four_times_the_rms() {
        let error = |mm: f64| PoseError {
            position: mm * 1e-3,
            position_vector: Vector3::new(mm * 1e-3, 0.0, 0.0),
            orientation: None,
        };
        // 19 poses at 0.1 mm and one at 2 mm: RMS = sqrt((19 * 0.01 + 4) / 20)
        // = 0.4577 mm, 2 mm is 4.37 times that.
        let mut errors = vec![error(0.1); 19];
        errors.push(error(2.0));
        let set = MeasurementSet::new(
            "u",
            (0..20)
                .map(|k| Measurement::new(vec![k as f64], Vector3::new(k as f64, 0.0, 0.0)))
                .collect(),
        )
        .unwrap();
        let checks = DataChecks::new(&set, &errors);
        assert_eq!(checks.suspect_poses.len(), 1);
        assert_eq!(checks.suspect_poses[0].pose, "#19");
        assert!((checks.suspect_poses[0].ratio_to_rms - 2.0 / 0.209_5f64.sqrt()).abs() < 1e-9);
        let notes = checks.notes("validation");
        assert_eq!(notes.len(), 1);
        assert!(notes[0].contains("#19 (2.00 mm)"), "{notes:?}");
        // Errors of round-off size are never suspect.
        let mut tiny = vec![error(1e-10); 19];
        tiny.push(error(1e-8));
        assert!(DataChecks::new(&set, &tiny).suspect_poses.is_empty());
        // At 0.7 mm the outlier is 3.8 times the RMS: nothing to report.
        errors[19] = error(0.7);
        assert!(DataChecks::new(&set, &errors).suspect_poses.is_empty());
    }

    #[test]
    fn excluding_by_label_or_line_number() {
        let s = set();
        let kept = s
            .excluding(&["3".to_string(), "line 5".to_string()])
            .unwrap();
        let ids: Vec<_> = kept
            .measurements()
            .iter()
            .map(|m| m.pose_id.clone().unwrap())
            .collect();
        assert_eq!(ids, ["line 2", "line 4"]);
        let err = s
            .excluding(&["line 99".to_string()])
            .unwrap_err()
            .to_string();
        assert!(err.contains("line 99") && err.contains("s.csv"), "{err}");
        let all: Vec<String> = (2..6).map(|n| n.to_string()).collect();
        assert!(s.excluding(&all).is_err());
    }
}
