//! Data checks: measurements that look like recording faults, found before
//! and after a fit, reported by pose label and never dropped silently.
//!
//! - A *repeated reading*: two poses whose actuated coordinates differ but
//!   whose measured positions (and orientations, when measured) are equal to
//!   the last bit. A real robot in two configurations is never measured at
//!   the very same place to the tracker's resolution, so one pose carries the
//!   other's measurement (a stale value logged again). Series B of the IPA
//!   UR10 data has two such pairs. With several targets per pose each
//!   target's readings are compared with its own.
//! - A *suspect pose*: after a fit, a pose whose position error exceeds
//!   [`SUSPECT_ERROR_RATIO`] times the set's RMS position error. For
//!   isotropic Gaussian errors that happens with probability below 1e-9 per
//!   pose (the norm would exceed 6.9 standard deviations per axis), so such
//!   a pose is a measurement fault or an effect the model lacks (unless the
//!   fit is exact to round-off: [`ROUND_OFF_RMS`]). With several targets
//!   the unit is one observation (a target at a pose) and the RMS is over
//!   all observations.
//!
//! Poses can then be left out by label ([`MeasurementSet::excluding`],
//! [`MeasurementSet::excluding`]).

use std::collections::HashMap;

use serde::Serialize;

use crate::error::CalibError;
use crate::measurement::MeasurementSet;

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
    /// With several targets per pose, the target whose reading repeats.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<String>,
}

/// A pose (with several targets, an observation) with an unusually large
/// error after a fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuspectPose {
    /// Label of the pose ([`crate::Measurement::label`]).
    pub pose: String,
    /// With several targets per pose, the target observed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<String>,
    /// Its position error (mm).
    pub position_error_mm: f64,
    /// Its position error over the set's RMS position error.
    pub ratio_to_rms: f64,
}

/// `pose`, or `target at pose` with several targets.
fn shown(pose: &str, target: Option<&str>) -> String {
    match target {
        Some(t) => format!("{t} at {pose}"),
        None => pose.to_string(),
    }
}

/// The data checks of one measurement set.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct DataChecks {
    /// Pairs of poses that carry the identical measurement.
    pub repeated_readings: Vec<RepeatedReading>,
    /// Poses (observations) whose position error after the fit exceeds
    /// [`SUSPECT_ERROR_RATIO`] times the RMS position error.
    pub suspect_poses: Vec<SuspectPose>,
    /// RMS position error of the set after the fit (mm).
    pub position_rms_mm: f64,
}

impl DataChecks {
    /// Both checks on `set`, with `errors`
    /// the position error (m) of each of its observations after a fit, in
    /// its order (pose by pose, target by target): a suspect is one
    /// observation, judged against the RMS over all observations, named
    /// by its pose and, with several targets, its target.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`]
    /// when `errors` has another length than the observations.
    pub fn new(set: &MeasurementSet, errors: &[f64]) -> Result<Self, CalibError> {
        // The one target of a set of one target per pose is not named.
        Self::of(set, errors, !set.is_one_target())
    }

    /// [`DataChecks::new`] on `set`, its targets `named` in the findings or
    /// not.
    pub(crate) fn of(
        set: &MeasurementSet,
        errors: &[f64],
        named: bool,
    ) -> Result<Self, CalibError> {
        let labels: Vec<(String, Option<String>)> = set
            .poses()
            .iter()
            .enumerate()
            .flat_map(|(k, p)| {
                p.observations
                    .iter()
                    .enumerate()
                    .filter(|(_, o)| o.is_some())
                    .map(move |(t, _)| (k, t))
            })
            .map(|(k, t)| {
                let target = named.then(|| set.targets()[t].name.clone());
                (set.poses()[k].label(k), target)
            })
            .collect();
        if labels.len() != errors.len() {
            return Err(CalibError::InvalidOption {
                name: "data_checks",
                reason: format!(
                    "{} errors for the {} observations of {}",
                    errors.len(),
                    labels.len(),
                    set.source
                ),
            });
        }
        let label = |i: usize| labels[i].clone();
        let mut repeated = repeated_readings(set);
        if !named {
            repeated.iter_mut().for_each(|r| r.target = None);
        }
        Ok(Self::from_errors(errors, &label, repeated))
    }

    /// The checks from the position error (m) of every observation, the
    /// label and target of observation `i` from `label(i)` (asked of the
    /// suspects only), and the repeated readings found in the set.
    fn from_errors(
        errors: &[f64],
        label: &dyn Fn(usize) -> (String, Option<String>),
        repeated_readings: Vec<RepeatedReading>,
    ) -> Self {
        let rms = if errors.is_empty() {
            0.0
        } else {
            (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt()
        };
        let suspect_poses = errors
            .iter()
            .enumerate()
            .filter(|(_, e)| rms > ROUND_OFF_RMS && **e > SUSPECT_ERROR_RATIO * rms)
            .map(|(i, e)| {
                let (pose, target) = label(i);
                SuspectPose {
                    pose,
                    target,
                    position_error_mm: e * 1e3,
                    ratio_to_rms: e / rms,
                }
            })
            .collect();
        Self {
            repeated_readings,
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
                .filter(|p| {
                    self.suspect_poses
                        .iter()
                        .any(|s| &s.pose == *p && s.target == r.target)
                })
                .map(String::as_str)
                .collect();
            notes.push(format!(
                "{what} set: {} and {} carry the identical measurement{} to the last digit though their joint coordinates differ: one of them is a stale reading{}",
                r.poses[0],
                r.poses[1],
                r.target
                    .as_deref()
                    .map(|t| format!(" of target {t}"))
                    .unwrap_or_default(),
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
                .map(|s| {
                    format!(
                        "{} ({:.2} mm)",
                        shown(&s.pose, s.target.as_deref()),
                        s.position_error_mm
                    )
                })
                .collect();
            let unit = if self.suspect_poses[0].target.is_some() {
                "observation"
            } else {
                "pose"
            };
            notes.push(format!(
                "{what} set: {} {unit}{} with a position error above {SUSPECT_ERROR_RATIO} times the RMS error ({:.3} mm), which Gaussian noise practically never gives: {}; a measurement fault or an effect the model lacks; the figures include {}",
                list.len(),
                if list.len() == 1 { "" } else { "s" },
                self.position_rms_mm,
                list.join(", "),
                if list.len() == 1 { "it" } else { "them" }
            ));
        }
        notes
    }

    /// The sentence that tells how to run again without the suspects,
    /// `option` naming the option that leaves them out (`--exclude`,
    /// `--exclude-validation`): each pose once, IPA lines by their number;
    /// with several targets each observation (`right at p7`), the pose's
    /// other targets kept. `None` without suspects.
    pub fn exclude_hint(&self, option: &str) -> Option<String> {
        let mut labels: Vec<String> = Vec::new();
        for s in &self.suspect_poses {
            let pose = s.pose.strip_prefix("line ").unwrap_or(&s.pose);
            let label = match &s.target {
                Some(_) => shown(&s.pose, s.target.as_deref()),
                None => pose.to_string(),
            };
            if !labels.contains(&label) {
                labels.push(label);
            }
        }
        let what = if self.suspect_poses.iter().any(|s| s.target.is_some()) {
            "observations"
        } else {
            "poses"
        };
        (!labels.is_empty()).then(|| {
            format!(
                "to compare without the suspect {what}, run again with {option} '{}'",
                labels.join(",")
            )
        })
    }
}

/// Pairs of poses, among those `keyed` gives (index, coordinates, bits of
/// the measured reading), whose coordinates differ but whose readings are
/// bit-identical, labelled by `label`.
fn repeated_pairs<'a>(
    keyed: impl Iterator<Item = (usize, &'a [f64], Vec<u64>)>,
    label: impl Fn(usize) -> String,
    target: Option<&str>,
) -> Vec<RepeatedReading> {
    let mut first_with: HashMap<Vec<u64>, Vec<(usize, &[f64])>> = HashMap::new();
    let mut pairs = Vec::new();
    for (k, q, key) in keyed {
        let earlier = first_with.entry(key).or_default();
        for &(j, qj) in earlier.iter() {
            if qj != q {
                pairs.push(RepeatedReading {
                    poses: [label(j), label(k)],
                    target: target.map(str::to_string),
                });
            }
        }
        earlier.push((k, q));
    }
    pairs
}

/// The bits of a position and, when measured, an orientation.
fn reading_bits(
    position: &nalgebra::Vector3<f64>,
    orientation: Option<&nalgebra::Vector3<f64>>,
) -> Vec<u64> {
    position
        .iter()
        .chain(orientation.into_iter().flatten())
        .map(|v| v.to_bits())
        .collect()
}

/// Pairs of poses of `set` whose actuated coordinates differ but whose
/// measured position (and orientation, when measured) of one target is
/// bit-identical (a stale reading), target by target.
pub fn repeated_readings(set: &MeasurementSet) -> Vec<RepeatedReading> {
    let poses = set.poses();
    set.targets()
        .iter()
        .enumerate()
        .flat_map(|(t, target)| {
            repeated_pairs(
                poses.iter().enumerate().filter_map(|(k, p)| {
                    p.observations[t].as_ref().map(|o| {
                        (
                            k,
                            p.q.as_slice(),
                            reading_bits(&o.position, o.orientation.as_ref()),
                        )
                    })
                }),
                |k| poses[k].label(k),
                Some(target.name.as_str()),
            )
        })
        .collect()
}

/// The indices of the poses labelled `labels_now` that remain when those
/// labelled `labels` are left out (a bare number `N` stands for `line N`).
///
/// # Errors
/// [`CalibError::InvalidOption`] (`exclude`) naming a label that matches no
/// pose of `source`.
fn kept_poses(
    labels_now: &[String],
    labels: &[impl AsRef<str>],
    source: &str,
) -> Result<Vec<usize>, CalibError> {
    let mut drop = vec![false; labels_now.len()];
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
                    "no pose `{wanted}` in {source} (its poses are labelled like `{}`)",
                    labels_now.first().map_or("", String::as_str)
                ),
            });
        }
        for k in hits {
            drop[k] = true;
        }
    }
    Ok((0..labels_now.len()).filter(|&k| !drop[k]).collect())
}

impl MeasurementSet {
    /// The set without what `labels` name: a pose by its label
    /// ([`crate::TargetPose::label`]: `line 534` for the IPA format, the
    /// `pose_id` or `#k` for flexcal's CSV, `s2:` before the label of a
    /// second station's pose), every target of it left out
    /// with it; or one observation as the data checks print it, `<target>
    /// at <pose>` (`right at p7`), the pose's other targets kept. A pose
    /// left without observations goes too. A bare number `N` stands for
    /// `line N`. The poses kept keep their labels: `#7` stays `#7` after
    /// `#3` is left out.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] (`exclude`) naming a label that matches
    /// no pose of the set or a target not observed at that pose;
    /// [`CalibError::BadMeasurement`] when nothing is left.
    pub fn excluding(&self, labels: &[impl AsRef<str>]) -> Result<Self, CalibError> {
        let labels_now = self.labels();
        let mut poses = Vec::new();
        let mut observations = Vec::new();
        for raw in labels {
            let raw = raw.as_ref().trim();
            match self.observation_labelled(raw, &labels_now)? {
                Some(kt) => observations.push(kt),
                None => poses.push(raw),
            }
        }
        let mut set = self.labelled();
        set.hide_observations(&observations);
        let kept: Vec<usize> = kept_poses(&labels_now, &poses, &self.source)?
            .into_iter()
            .filter(|&k| set.poses()[k].observations.iter().any(Option::is_some))
            .collect();
        set.subset(&kept)
    }

    /// The (pose, target) that `raw` names in the form `<target> at
    /// <pose>`, or `None` when `raw` is a pose's label or not of that form.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] (`exclude`) when the target is not
    /// observed at that pose.
    fn observation_labelled(
        &self,
        raw: &str,
        labels_now: &[String],
    ) -> Result<Option<(usize, usize)>, CalibError> {
        if labels_now.iter().any(|l| l == raw) {
            return Ok(None);
        }
        let Some((target, pose)) = raw.split_once(" at ") else {
            return Ok(None);
        };
        let (Some(t), Some(k)) = (
            self.target_index(target.trim()),
            labels_now.iter().position(|l| l == pose.trim()),
        ) else {
            return Ok(None);
        };
        if self.poses()[k].observations[t].is_none() {
            return Err(CalibError::InvalidOption {
                name: "exclude",
                reason: format!(
                    "`{raw}`: target {} is not observed at {} in {}",
                    target.trim(),
                    pose.trim(),
                    self.source
                ),
            });
        }
        Ok(Some((k, t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurement::Measurement;
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
                poses: ["line 2".into(), "line 3".into()],
                target: Some(crate::frames::TCP_FRAME.into()),
            }]
        );
        // The data checks of a set of one target per pose do not name it.
        let checks = DataChecks::new(&set(), &[1e-3; 4]).unwrap();
        assert_eq!(checks.repeated_readings[0].target, None);
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
        let error = |mm: f64| mm * 1e-3;
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
        let checks = DataChecks::new(&set, &errors).unwrap();
        assert_eq!(checks.suspect_poses.len(), 1);
        assert_eq!(checks.suspect_poses[0].pose, "#19");
        assert_eq!(checks.suspect_poses[0].target, None);
        assert!((checks.suspect_poses[0].ratio_to_rms - 2.0 / 0.209_5f64.sqrt()).abs() < 1e-9);
        let notes = checks.notes("validation");
        assert_eq!(notes.len(), 1);
        assert!(notes[0].contains("#19 (2.00 mm)"), "{notes:?}");
        // Errors of round-off size are never suspect.
        let mut tiny = vec![error(1e-10); 19];
        tiny.push(error(1e-8));
        assert!(
            DataChecks::new(&set, &tiny)
                .unwrap()
                .suspect_poses
                .is_empty()
        );
        // At 0.7 mm the outlier is 3.8 times the RMS: nothing to report.
        errors[19] = error(0.7);
        assert!(
            DataChecks::new(&set, &errors)
                .unwrap()
                .suspect_poses
                .is_empty()
        );
        // One error per observation, or a named error.
        let err = DataChecks::new(&set, &errors[..3]).unwrap_err().to_string();
        assert!(
            err.contains("3 errors for the 20 observations of u"),
            "{err}"
        );
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

    /// Two targets, four unlabelled poses: target `a` reads the same at
    /// poses 0 and 2 (other coordinates), target `b` never repeats.
    fn target_set() -> MeasurementSet {
        targets_at(4)
    }

    /// Two targets at `n` poses: target `a` reads the same at poses 0 and
    /// 2 (other coordinates), target `b` never repeats.
    fn targets_at(n: usize) -> MeasurementSet {
        use crate::targets::{Target, TargetObservation, TargetPose};
        let o = |p: [f64; 3]| Some(TargetObservation::new(Vector3::from(p)));
        let pose = |k: usize| {
            let a = if k == 2 { 0.0 } else { k as f64 };
            TargetPose::new(
                None,
                vec![0.1 * k as f64, 0.0],
                vec![o([1.0 + a, 0.0, 0.0]), o([2.0 + k as f64, 0.0, 0.0])],
            )
        };
        MeasurementSet::from_poses(
            "m.csv",
            vec![
                Target::new("a", "tcp", Vector3::zeros()),
                Target::new("b", "tcp", Vector3::zeros()),
            ],
            (0..n).map(pose).collect(),
        )
        .unwrap()
    }

    #[test]
    fn each_target_is_compared_with_its_own_readings() {
        let set = targets_at(10);
        assert_eq!(
            repeated_readings(&set),
            vec![RepeatedReading {
                poses: ["#0".into(), "#2".into()],
                target: Some("a".into()),
            }]
        );
        // 19 observations at 0.1 mm and one at 2 mm (target a at pose 2,
        // the fifth observation): as for one target, the 2 mm one is 4.37
        // times the RMS; it is named with its target.
        let mut errors = vec![0.1e-3; 20];
        errors[4] = 2e-3;
        let checks = DataChecks::new(&set, &errors).unwrap();
        assert_eq!(checks.suspect_poses.len(), 1);
        assert_eq!(checks.suspect_poses[0].pose, "#2");
        assert_eq!(checks.suspect_poses[0].target.as_deref(), Some("a"));
        let notes = checks.notes("identification");
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(
            notes[0].contains("#0 and #2 carry the identical measurement of target a")
                && notes[0].ends_with("stale reading (#2, by its error after the fit)"),
            "{notes:?}"
        );
        assert!(
            notes[1].contains("1 observation with") && notes[1].contains("a at #2 (2.00 mm)"),
            "{notes:?}"
        );
        assert_eq!(
            checks.exclude_hint("--exclude").as_deref(),
            Some("to compare without the suspect observations, run again with --exclude 'a at #2'")
        );
        errors[4] = 0.1e-3;
        assert_eq!(
            DataChecks::new(&set, &errors)
                .unwrap()
                .exclude_hint("--exclude"),
            None
        );
    }

    #[test]
    fn the_poses_kept_keep_their_labels() {
        let set = target_set();
        let kept = set.excluding(&["#1"]).unwrap();
        assert_eq!(kept.labels(), ["#0", "#2", "#3"]);
        assert_eq!(kept.n_observations(), 6);
        let err = set.excluding(&["#9"]).unwrap_err().to_string();
        assert!(
            err.contains("no pose `#9` in m.csv") && err.contains("`#0`"),
            "{err}"
        );
        assert!(set.excluding(&["#0", "#1", "#2", "#3"]).is_err());
        // One observation: the pose's other target stays; a pose left
        // without observations goes.
        let kept = set.excluding(&["b at #1"]).unwrap();
        assert_eq!(kept.len(), 4);
        assert_eq!(kept.n_observations(), 7);
        assert!(kept.poses()[1].observations[1].is_none());
        assert!(kept.poses()[1].observations[0].is_some());
        let kept = set.excluding(&["a at #1", "b at #1", "#3"]).unwrap();
        assert_eq!(kept.labels(), ["#0", "#2"]);
        let err = set
            .excluding(&["a at #1"])
            .unwrap()
            .excluding(&["a at #1"])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("target a is not observed at #1 in m.csv"),
            "{err}"
        );
        let err = set.excluding(&["c at #1"]).unwrap_err().to_string();
        assert!(err.contains("no pose `c at #1`"), "{err}");
        // One target per pose: the same.
        let one = MeasurementSet::new(
            "n",
            (0..4)
                .map(|k| Measurement::new(vec![k as f64], Vector3::new(k as f64, 0.0, 0.0)))
                .collect(),
        )
        .unwrap();
        let kept = one.excluding(&["#1"]).unwrap();
        assert_eq!(kept.labels(), ["#0", "#2", "#3"]);
        // Pooled stations: labels carry the station's number.
        let pooled = MeasurementSet::pooled(&[set.clone(), set]).unwrap();
        let kept = pooled.excluding(&["s2:#0"]).unwrap();
        assert_eq!(kept.len(), 7);
        assert_eq!(kept.n_stations(), 2);
        assert!(pooled.excluding(&["#0"]).is_err());
    }
}
