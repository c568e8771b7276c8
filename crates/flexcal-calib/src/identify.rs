//! The fitted [`Calibration`] of one target, what it says of each unknown
//! ([`UnknownEstimate`], [`UnknownStatus`]) and of the identifiability, and
//! [`calibrate`], which runs [`crate::identification`] on one target.

use std::borrow::Cow;

use flexcal_kinematics::{Model, RobotDescription};
use flexcal_optim::{IdentifiabilityReport, SolveReport};
use nalgebra::Isometry3;
use serde::Serialize;

use crate::coverage::CoordinateCoverage;
use crate::deflection::Deflection;
use crate::equilibrium::{DeflectionChoice, DeflectionReport};
use crate::error::CalibError;
use crate::error_model::{ErrorModel, UnknownKind};
use crate::frames::TCP_FRAME;
use crate::gravity::GravityCompliance;
use crate::identification::{Identification, ResidualNorms, identify};
use crate::joint_law::JointTerms;
use crate::measurement::MeasurementSet;
use crate::metrics::{
    ErrorStatistics, ObservationError, PoseError, TargetErrors, error_statistics,
};
use crate::options::CalibrationOptions;
use crate::screen::DataChecks;
use crate::significance::{MIN_TORQUE_SHARE, NoiseSource, torque_magnitude};
use crate::spread::WEAK_SPREAD_RATIO;
use crate::targets::Target;
use crate::unknowns::{Combination, UnknownEstimate, UnknownStatus};

/// A fitted calibration of one target or several: the identified robot
/// parameters, frames and target offsets, the identifiability analysis,
/// the solver's report and the errors target by target.
#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    /// Identified robot parameters xi (m, rad).
    pub xi: Vec<f64>,
    /// Nominal robot parameters (m, rad).
    pub nominal_xi: Vec<f64>,
    /// Identified (or fixed) measurement frame `x_meas_base` (of the first
    /// station, when the set has several).
    pub x_meas_base: Isometry3<f64>,
    /// Starting measurement frame (registration of the nominal predictions
    /// onto the measurements, or the given value): the `frame_*` unknowns
    /// are increments on it (translation added, rotation vector on the left).
    pub x_meas_base_initial: Isometry3<f64>,
    /// Measurement frame fitted for the nominal robot (the "before").
    pub x_meas_base_nominal_robot: Isometry3<f64>,
    /// Identified (or fixed) measurement frames of the second and later
    /// stations ([`crate::MeasurementSet::pooled`]); empty for one station.
    pub station_frames: Vec<Isometry3<f64>>,
    /// Names of the stations, in order (one for a set from one file).
    pub station_names: Vec<String>,
    /// Errors after identification of each station's observations, in the
    /// order of `station_names` (one entry, equal to `training_after`, for
    /// one station; a station a subset left out has zero observations).
    pub station_errors: Vec<ErrorStatistics>,
    /// The targets with their identified (or fixed) offsets and rotations
    /// (one target `tcp` on the TCP for a set of one target per pose,
    /// [`crate::TCP_TARGET`]).
    pub targets: Vec<Target>,
    /// The targets with their offsets fitted for the nominal robot (the
    /// "before"; the starting ones when fixed or not identifiable).
    pub targets_nominal_robot: Vec<Target>,
    /// The targets where the identification started: their target
    /// unknowns are increments on these (translation added in the target's
    /// frame, rotation vector on the right; a rotation starts from the
    /// data where orientations are fitted).
    pub targets_initial: Vec<Target>,
    /// Whether the measurement frame was fixed.
    pub measurement_frame_fixed: bool,
    /// Whether orientations were fitted (for some target).
    pub use_orientation: bool,
    /// Every unknown, robot parameters first, then `frame_*`, then the
    /// targets' (`target_*` for one target, `target.<name>.*` for
    /// several), then the later stations' frames (`frame_s2_*`, ...), then
    /// (elasto-geometric) `compliance_*`, `payload_*` and, when on,
    /// `lateral_compliance_*`, then the joint terms.
    pub unknowns: Vec<UnknownEstimate>,
    /// The gravity loading when the model is elasto-geometric, with the
    /// identified elastic unknowns (compliances, payload mass, first moment,
    /// lateral compliances when on; order of
    /// [`GravityCompliance::elastic_unknown_names`]). Not serialised: the
    /// values are in `unknowns` by name.
    #[serde(skip)]
    pub elastic: Option<(GravityCompliance, Vec<f64>)>,
    /// The coupling groups' compliance matrices with their standard
    /// errors ([`crate::coupling`]; empty without
    /// [`GravityCompliance::coupling`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub coupling: Vec<crate::coupling::CouplingMatrix>,
    /// The joint error terms of the model ([`crate::joint_law`]).
    pub joint_terms: JointTerms,
    /// Their identified values, in the order of
    /// [`JointTerms::unknown_names`] (1/rad, rad). Not serialised: the
    /// values are in `unknowns` by name.
    #[serde(skip)]
    pub joint_term_values: Vec<f64>,
    /// Numerical identifiability analysis of the free unknowns (exact
    /// dependencies, at [`CalibrationOptions::rank_tolerance`]) at the start point.
    pub identifiability: IdentifiabilityReport,
    /// What each identified unknown stands for (C.1), linearised at the
    /// start point (nominal robot, fitted frames).
    pub combinations: Vec<Combination>,
    /// The same as text, one line per identified unknown that absorbs others
    /// (coefficients below 1e-3 dropped).
    pub combination_lines: Vec<String>,
    /// The final solver report (cost history = Figure 7 data, termination,
    /// rank, singular values, covariance).
    pub solve: SolveReport,
    /// Cost `1/2 ||W r||^2` history of every solver run, rounds in order.
    pub cost_history: Vec<f64>,
    /// The same iterates' unweighted position and orientation RMS errors
    /// (one entry per entry of `cost_history`).
    pub residual_history: Vec<ResidualNorms>,
    /// Errors of all observations with the nominal robot, its frames and
    /// offsets fitted (before).
    pub training_before: ErrorStatistics,
    /// Errors of all observations after identification.
    pub training_after: ErrorStatistics,
    /// Per-target errors before identification (nominal robot, frames fitted).
    pub per_target_before: Vec<TargetErrors>,
    /// Per-target errors after identification.
    pub per_target_after: Vec<TargetErrors>,
    /// The error of every observation after identification, pose by pose
    /// (target by target within a pose).
    pub observation_errors: Vec<ObservationError>,
    /// Repeated readings and suspect observations of the identification
    /// set (after the fit).
    pub data_checks: DataChecks,
    /// The noise the standard errors and identifiability judgements used
    /// ([`crate::significance`]).
    pub noise: NoiseSource,
    /// Number of poses used.
    pub n_poses: usize,
    /// Number of (pose, target) observations used (`n_poses` for one target).
    pub n_observations: usize,
    /// The degrees of freedom the position residuals keep when orientation
    /// rows were fitted too: `3 N - tr(H_pp)`, the trace of the weighted
    /// fit's hat matrix over the position rows (the orientation rows carry
    /// part of the fit); `None` without orientation rows, where it is
    /// `3 N - p` ([`Calibration::residual_scatter`]).
    pub position_residual_dof: Option<f64>,
    /// Names of the robot's actuated coordinates, in the order of
    /// [`Calibration::actuated_ranges`] and [`Calibration::torque_ranges`].
    pub actuated_names: Vec<String>,
    /// What the identification poses cover of each actuated coordinate: the
    /// interval from its smallest to its largest value (m), or for a
    /// revolute coordinate the arc of the circle (rad; the model is
    /// `2 pi`-periodic in it, see [`crate::coverage`]). Validation poses
    /// outside it are extrapolations.
    pub actuated_ranges: Vec<CoordinateCoverage>,
    /// Span of each actuated coordinate's gravity torque (N.m, or N for a
    /// prismatic one) over the identification poses, with the mass table's
    /// payload ([`GravityCompliance::joint_torques`]): the torques over which
    /// the compliances were identified. Empty for the geometric model.
    pub torque_ranges: Vec<CoordinateCoverage>,
    /// What the deflection model did ([`crate::equilibrium`]): which one
    /// the identified model uses, why, the one step's largest torque change
    /// and the difference between the one step and the equilibrium at the
    /// identified unknowns. `None` for the geometric model and for the
    /// default one step ([`crate::Deflection::OneStep`]), which is not
    /// compared (the comparison costs a few fits' time).
    pub deflection: Option<crate::equilibrium::DeflectionReport>,
}

impl Calibration {
    /// The identified pose of the first target in its frame (for a set of
    /// one target per pose: `x_tcp_target`, the target in the TCP frame).
    pub fn x_tcp_target(&self) -> Isometry3<f64> {
        self.targets[0].pose()
    }
    /// The first target's starting pose ([`Calibration::targets_initial`]).
    pub fn x_tcp_target_initial(&self) -> Isometry3<f64> {
        self.targets_initial[0].pose()
    }
    /// The first target's pose fitted for the nominal robot (the "before").
    pub fn x_tcp_target_nominal_robot(&self) -> Isometry3<f64> {
        self.targets_nominal_robot[0].pose()
    }
    /// The identified measurement frame of every station, the first's
    /// ([`Calibration::x_meas_base`]) first.
    pub fn measurement_frames(&self) -> Vec<Isometry3<f64>> {
        std::iter::once(self.x_meas_base)
            .chain(self.station_frames.iter().copied())
            .collect()
    }
    /// Whether the set was one of one target per pose ([`crate::MeasurementSet`]):
    /// its one target, `tcp` on the TCP, is not named in reports.
    pub fn has_implicit_target(&self) -> bool {
        self.targets.len() == 1 && self.targets[0].name == TCP_FRAME
    }
    /// Whether the set had several targets per pose.
    pub fn has_several_targets(&self) -> bool {
        self.targets.len() > 1
    }
}

impl Calibration {
    /// Indices of the actuated coordinates at which `q` (rad or m) lies
    /// outside [`Calibration::actuated_ranges`] (by more than 1e-9; a
    /// revolute coordinate a whole number of turns away from a covered
    /// angle is inside): where a prediction is an extrapolation from the
    /// identification poses.
    pub fn outside_training_range<'a>(&'a self, q: &'a [f64]) -> impl Iterator<Item = usize> + 'a {
        crate::coverage::outside(&self.actuated_ranges, q)
    }

    /// Names of the non-identifiable unknowns.
    pub fn non_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::NonIdentifiable)
    }
    /// Names of the poorly identifiable unknowns (kept at nominal).
    pub fn poorly_identifiable(&self) -> Vec<&str> {
        self.with_status(UnknownStatus::PoorlyIdentifiable)
    }
    fn with_status(&self, status: UnknownStatus) -> Vec<&str> {
        self.unknowns
            .iter()
            .filter(|u| u.status == status)
            .map(|u| u.name.as_str())
            .collect()
    }
    /// What the poses could not identify, in sentences for a report: robot
    /// parameters left at nominal, the target offsets and the measurement
    /// frame components not identified (their error then stays in every
    /// prediction away from these poses), each with the identified unknowns
    /// that absorb it when there are several targets, and,
    /// elasto-geometric, which joint compliances gravity loads enough to be
    /// identified.
    pub fn identifiability_notes(&self) -> Vec<String> {
        let several = self.has_several_targets();
        let np = self.xi.len();
        let robot = |status: UnknownStatus| -> Vec<&str> {
            self.unknowns[..np]
                .iter()
                .filter(|u| u.status == status)
                .map(|u| u.name.as_str())
                .collect()
        };
        let mut notes = Vec::new();
        let exact = robot(UnknownStatus::NonIdentifiable);
        if !exact.is_empty() {
            let names = if several {
                self.with_absorbers(&exact)
            } else {
                exact.join(", ")
            };
            notes.push(format!(
                "{} of {np} robot parameters are exactly dependent on others with these poses and stay at nominal ({names}); the identified ones stand for the combinations listed",
                exact.len(),
            ));
        }
        let poor = robot(UnknownStatus::PoorlyIdentifiable);
        if !poor.is_empty() {
            notes.push(format!(
                "{} more stay at nominal because these poses see them too weakly ({}): predictions far from these poses carry their errors",
                poor.len(),
                poor.join(", ")
            ));
        }
        notes.extend(weak_spread_note(
            self.unknowns
                .iter()
                .enumerate()
                .filter(|(j, u)| *j < np || u.name.starts_with("target"))
                .map(|(_, u)| u),
        ));
        notes.extend(self.target_notes());
        let frame = self.not_identified("frame_");
        if !frame.is_empty() && !self.measurement_frame_fixed {
            notes.push(format!(
                "measurement frame components not separable from the robot's base parameters: {} (absorbed by the base parameters, harmless for predictions)",
                frame.join(", ")
            ));
        }
        if self.elastic.is_some() {
            notes.extend(elastic_notes(
                &self.unknowns,
                &self.actuated_names,
                &self.torque_ranges,
                self.joint_terms.law.is_some(),
            ));
        }
        notes
    }

    /// The unknowns named `prefix*` that are not identified (dependent or
    /// seen too weakly).
    fn not_identified(&self, prefix: &str) -> Vec<&str> {
        self.unknowns
            .iter()
            .filter(|u| u.name.starts_with(prefix))
            .filter(|u| {
                matches!(
                    u.status,
                    UnknownStatus::NonIdentifiable | UnknownStatus::PoorlyIdentifiable
                )
            })
            .map(|u| u.name.as_str())
            .collect()
    }

    /// `names`, each with the identified unknowns whose combinations
    /// absorb it: `a (in b, c)`.
    fn with_absorbers(&self, names: &[&str]) -> String {
        names
            .iter()
            .map(|n| {
                let by: Vec<&str> = self
                    .combinations
                    .iter()
                    .filter(|c| c.terms.iter().any(|(m, k)| m == n && k.abs() >= 1e-3))
                    .map(|c| c.name.as_str())
                    .collect();
                if by.is_empty() {
                    n.to_string()
                } else {
                    format!("{n} (in {})", by.join(", "))
                }
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The targets' notes: for one target, the offset directions not
    /// identified; for several, each target's directions with what absorbs
    /// them, and what no measured target moves with (the other branch of a
    /// tree when its marker is missing).
    fn target_notes(&self) -> Vec<String> {
        let target = self.not_identified("target_");
        let mut notes: Vec<String> = (!target.is_empty()).then(|| format!(
            "the target (probe) offset is not identified along {}: it stays at its starting value, and its error goes into every prediction away from these poses (vary the tool orientation more to identify it, or start from an offset known from elsewhere)",
            target.join(", ")
        )).into_iter().collect();
        notes.extend(self.targets.iter().filter_map(|t| {
                let blind = self.not_identified(&format!("target.{}.", t.name));
                (!blind.is_empty()).then(|| {
                    format!(
                        "target `{}` on frame `{}`: offset not identified along {}; it stays at its starting value",
                        t.name,
                        t.frame,
                        self.with_absorbers(&blind)
                    )
                })
        }));
        // A seen target's rotation moves nothing without its orientations:
        // not worth a note; the elastic terms have their own sentences.
        let no_influence = self.with_status(UnknownStatus::NoInfluence);
        let seen_rotation = |n: &str| {
            n.strip_prefix("target.")
                .and_then(|rest| rest.rsplit_once(".r"))
                .is_some_and(|(target, _)| {
                    !no_influence.contains(&format!("target.{target}.x").as_str())
                })
        };
        let unseen: Vec<&str> = no_influence
            .iter()
            .copied()
            .filter(|n| !is_elastic_unknown(n) && !seen_rotation(n))
            .collect();
        if !unseen.is_empty() {
            notes.push(format!(
                "no measured target moves with these, they stay at nominal: {}",
                unseen.join(", ")
            ));
        }
        notes
    }

    /// The true value of each identified combination `x_B + K x_N` given a
    /// full vector of true unknowns (`truth`, indexed like
    /// [`Calibration::unknowns`]): `(name, true combination value,
    /// identified value, standard error)`. Absorbed unknowns stay at their
    /// starting values in the fit, so only their true deviation from there
    /// is absorbed (their starting values, or zero for a compliance held at
    /// its bound).
    pub fn combination_check(&self, truth: &[f64]) -> Vec<(String, f64, f64, Option<f64>)> {
        let index = |name: &str| self.unknowns.iter().position(|u| u.name == name);
        self.combinations
            .iter()
            .filter_map(|c| {
                let jb = index(&c.name)?;
                let mut value = *truth.get(jb)?;
                for (other, k) in &c.terms {
                    let jn = index(other)?;
                    value += k * (truth.get(jn)? - self.unknowns[jn].value);
                }
                let u = &self.unknowns[jb];
                Some((u.name.clone(), value, u.value, u.standard_error))
            })
            .collect()
    }

    /// Number of identified unknowns (the rank used).
    pub fn rank(&self) -> usize {
        self.unknowns
            .iter()
            .filter(|u| u.status == UnknownStatus::Identified)
            .count()
    }
    /// The calibrated robot description (mm, deg), which loads back with
    /// [`RobotDescription::build`].
    ///
    /// # Errors
    /// [`CalibError::Description`].
    pub fn description(&self, model: &Model) -> Result<RobotDescription, CalibError> {
        let mut d = model
            .description_with_params(&self.xi)
            .map_err(CalibError::Description)?;
        let targets = if self.has_several_targets() {
            format!(" of {} targets", self.targets.len())
        } else {
            String::new()
        };
        let note = format!(
            "Calibrated by flexcal from {} poses{targets}: {} of {} unknowns identified.",
            self.n_poses,
            self.rank(),
            self.unknowns.len()
        );
        d.notes = if d.notes.is_empty() {
            note
        } else {
            format!("{} {note}", d.notes)
        };
        Ok(d)
    }
}

/// Whether `name` is an unknown of the elastic and joint terms (the
/// compliances, payload, lateral compliances, joint law, cyclic errors).
pub(crate) fn is_elastic_unknown(name: &str) -> bool {
    [
        "compliance_",
        "payload_",
        "lateral_compliance_",
        "hardening_",
        "lost_motion_",
        "cyclic_",
    ]
    .iter()
    .any(|p| name.starts_with(p))
}

/// The sentences on the elastic and joint terms of an elasto-geometric
/// identification (one or several targets): which joint compliances
/// gravity loads enough to be identified, with the torques they were
/// identified over, and, with the joint `law`, the hardening and lost
/// motion identified; the lateral compliances and the payload.
pub(crate) fn elastic_notes(
    unknowns: &[UnknownEstimate],
    actuated_names: &[String],
    torque_ranges: &[CoordinateCoverage],
    law: bool,
) -> Vec<String> {
    let names = |prefix: &str| -> Vec<&str> {
        unknowns
            .iter()
            .filter(|u| u.name.starts_with(prefix))
            .filter(|u| {
                matches!(
                    u.status,
                    UnknownStatus::NonIdentifiable
                        | UnknownStatus::PoorlyIdentifiable
                        | UnknownStatus::NoInfluence
                )
            })
            .map(|u| u.name.as_str())
            .collect()
    };
    let mut notes = Vec::new();
    // The torque each joint's compliance was identified over, and the
    // largest of all ([`MIN_TORQUE_SHARE`]).
    let torque_of = |name: &str| {
        actuated_names
            .iter()
            .position(|a| name.strip_prefix("compliance_") == Some(a.as_str()))
            .and_then(|i| torque_ranges.get(i))
    };
    let largest = torque_ranges
        .iter()
        .map(torque_magnitude)
        .fold(0.0, f64::max);
    let joint: Vec<&UnknownEstimate> = unknowns
        .iter()
        .filter(|u| u.name.starts_with("compliance_"))
        .collect();
    notes.extend(compliance_sentence(
        "joint compliances",
        &joint,
        &|u| torque_of(&u.name).copied(),
        largest,
    ));
    if law {
        for (prefix, what) in [("hardening_", "hardening"), ("lost_motion_", "lost motion")] {
            let identified: Vec<&str> = unknowns
                .iter()
                .filter(|u| u.name.starts_with(prefix) && u.status == UnknownStatus::Identified)
                .map(|u| u.name.as_str())
                .collect();
            let held: Vec<&str> = unknowns
                .iter()
                .filter(|u| u.name.starts_with(prefix) && u.status == UnknownStatus::AtBound)
                .map(|u| u.name.as_str())
                .collect();
            notes.push(format!(
                    "non-linear joint law, {what} identified: {}; the others stay at zero (not separable from the compliances and offsets, or too weakly seen, with these torques){}",
                    if identified.is_empty() { "none".to_string() } else { identified.join(", ") },
                    if held.is_empty() { String::new() } else {
                        format!("; held at the bound that keeps the law monotone over the poses' torques (the fit softened the joint until it yielded): {}", held.join(", "))
                    }
                ));
        }
    }
    let lateral: Vec<&UnknownEstimate> = unknowns
        .iter()
        .filter(|u| u.name.starts_with("lateral_compliance_"))
        .collect();
    notes.extend(compliance_sentence(
        "lateral joint compliances",
        &lateral,
        &|_| None,
        largest,
    ));
    let coupling: Vec<&UnknownEstimate> = unknowns
        .iter()
        .filter(|u| crate::gravity::is_coupling_compliance(&u.name))
        .collect();
    notes.extend(compliance_sentence(
        "coupling compliances",
        &coupling,
        &|_| None,
        largest,
    ));
    let payload = names("payload_");
    if !payload.is_empty() {
        notes.push(format!(
            "payload not identified ({}): its mass and centre stay at their starting values",
            payload.join(", ")
        ));
    }
    notes
}

/// One sentence on a family of compliances (`what`): those identified,
/// with their standard errors as a share of their values and the torque
/// (`torque_of`, N.m) they were identified over, and for each one left out
/// the true reason: too little gravity torque (below
/// [`MIN_TORQUE_SHARE`] of the `largest` joint's), not separable from other unknowns, too large a
/// standard error for its value, or a fit below zero held at the bound.
fn compliance_sentence(
    what: &str,
    unknowns: &[&UnknownEstimate],
    torque_of: &dyn Fn(&UnknownEstimate) -> Option<CoordinateCoverage>,
    largest: f64,
) -> Option<String> {
    if unknowns.is_empty() {
        return None;
    }
    let (unit, factor) = UnknownKind::Compliance.display_unit();
    // One decimal, without a negative zero.
    let round = |v: f64| (v * 10.0).round() / 10.0 + 0.0;
    let torque_text =
        |r: &CoordinateCoverage| format!("torque {:.1} to {:.1} N.m", round(r.lo), round(r.hi));
    let mut kept = Vec::new();
    let mut left = Vec::new();
    for u in unknowns {
        let torque = torque_of(u);
        let judged = u.judgement.map(|j| {
            let scale = j.value.abs().max(u.initial.abs());
            format!(
                "standard error {:.3} {unit} is {:.0} % of its scale, the larger of the fitted {:.3} and the start {:.3} {unit}",
                j.standard_error * factor,
                100.0 * j.standard_error / scale,
                j.value * factor,
                u.initial * factor
            )
        });
        match u.status {
            UnknownStatus::Identified => {
                let mut parts = Vec::new();
                if let Some(se) = u.standard_error {
                    parts.push(format!(
                        "{:.3} +/- {:.3} {unit}, {:.0} %",
                        u.value * factor,
                        se * factor,
                        100.0 * se / u.value.abs().max(u.initial.abs())
                    ));
                }
                if let Some(r) = &torque {
                    parts.push(torque_text(r));
                }
                kept.push(if parts.is_empty() {
                    u.name.clone()
                } else {
                    format!("{} ({})", u.name, parts.join("; "))
                });
            }
            UnknownStatus::Fixed => {}
            UnknownStatus::AtBound if crate::gravity::is_coupling_compliance(&u.name) => {
                left.push(format!(
                    "{} (held at {:.3} {unit}, on the positive semi-definite boundary of its group's matrix: the fit gave {:.3} {unit}; a bound that binds says a term of the model is missing or the mass table is off)",
                    u.name,
                    u.value * factor,
                    u.judgement.map_or(f64::NAN, |j| j.value) * factor,
                ))
            }
            UnknownStatus::AtBound => left.push(format!(
                "{} (held at 0, the fit put it below zero: {}; a bound that binds says a term of the model is missing or the mass table is off)",
                u.name,
                judged.unwrap_or_default()
            )),
            status => {
                let span = torque.as_ref().map(torque_magnitude);
                let reason = match (status, span) {
                    (_, Some(t)) if t < MIN_TORQUE_SHARE * largest || t == 0.0 => format!(
                        "torque range +/-{:.1} N.m: too little gravity torque",
                        round(t)
                    ),
                    (UnknownStatus::NoInfluence, _) => {
                        "no influence on what is measured".to_string()
                    }
                    (UnknownStatus::NonIdentifiable, _) => {
                        "not separable from the geometry and the other terms with these poses"
                            .to_string()
                    }
                    _ => match judged {
                        Some(text) => format!("{text}: left at its start"),
                        None => "too weakly seen: its standard error would exceed the absolute limit (max_standard_error_compliance)".to_string(),
                    },
                };
                left.push(format!("{} ({reason})", u.name));
            }
        }
    }
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    Some(format!(
        "{what} identified from the gravity loads: {}; left out: {}",
        list(&kept),
        list(&left)
    ))
}

/// Identifies the robot parameters, the measurement frames (unless fixed)
/// and the offsets of the identified targets from every target on every
/// pose, positions and, where a target carries them, orientations, with
/// the elasto-geometric terms when `options.gravity` (and
/// `options.joint_terms`) ask for them: equations (7)-(12) and (49)-(53)
/// of the reference paper, with the frames of the note in the crate docs,
/// by the steps of [`crate::identification`]. A set of one target per
/// pose is one target `tcp` on the TCP ([`crate::TCP_TARGET`]), not
/// named in the report. `fixed` and
/// `deferred` take robot, `frame_*`, target and elastic names; a starting
/// offset (`target_value`) only for a set of one target.
///
/// # Errors
/// Mismatched coordinates, a target on an unknown frame, unknown names in
/// `fixed`/`deferred`, an unsupported option, too few observations, a
/// degenerate registration, a model failure at a pose, a solver failure,
/// [`CalibError::RankDeficient`] when `require_full_rank` is set,
/// [`CalibError::NothingToIdentify`].
pub fn calibrate(
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
) -> Result<Calibration, CalibError> {
    if options.target_value.is_some() && set.targets().len() > 1 {
        return Err(CalibError::InvalidOption {
            name: "target",
            reason: "with several targets each target's offset is given in the targets description"
                .into(),
        });
    }
    let found = identify(model, Cow::Borrowed(set), options)?;
    let (found, options, deflection) = settle(model, set, options, found)?;
    // The one target of a set of one target per pose is not named.
    let named = !set.is_one_target();
    let mut calibration = packed(model, set, found, &options, named)?;
    calibration.deflection = deflection;
    Ok(calibration)
}

/// The [`Calibration`] of what [`identify`] found on `set`.
fn packed(
    model: &Model,
    set: &MeasurementSet,
    found: Identification<'_>,
    options: &CalibrationOptions,
    named: bool,
) -> Result<Calibration, CalibError> {
    let problem = &found.problem;
    let x = found.report.x.clone();
    let with_offsets = |x: &[f64]| -> Vec<Target> {
        set.targets()
            .iter()
            .enumerate()
            .map(|(t, target)| {
                let pose = problem.target_frame(x, t);
                Target {
                    offset: pose.translation.vector,
                    rotation: pose.rotation,
                    ..target.clone()
                }
            })
            .collect()
    };
    let targets = with_offsets(&x);
    let targets_nominal_robot = with_offsets(&found.x_nominal_robot);
    let targets_initial = with_offsets(&problem.initial_unknowns());
    let frames = problem.station_frames(&x);
    let use_orientation = (0..set.targets().len()).any(|t| problem.uses_orientation(t));
    let fe = problem.frames_end();
    let joint_start = problem.joint_terms_offset().unwrap_or(x.len());
    let observation_errors = observation_errors(problem, &found.errors_after);
    let per_target_before = per_target(problem, &found.errors_before);
    let per_target_after = per_target(problem, &found.errors_after);
    let x_meas_base_nominal_robot = problem.station_frame(&found.x_nominal_robot, 0);
    let station_errors = (0..set.n_stations())
        .map(|s| {
            let of_station: Vec<PoseError> = (0..found.errors_after.len())
                .filter(|&i| set.station_of(problem.observation(i).0) == s)
                .map(|i| found.errors_after[i])
                .collect();
            error_statistics(&of_station)
        })
        .collect();
    let Identification {
        starts,
        frame_fixed,
        unknowns,
        identifiability,
        combinations,
        report,
        cost_history,
        residual_history,
        errors_before,
        errors_after,
        noise,
        actuated_ranges,
        torque_ranges,
        position_residual_dof,
        ..
    } = found;
    let norms: Vec<f64> = errors_after.iter().map(|e| e.position).collect();
    let coupling = options.gravity.as_ref().map_or_else(Vec::new, |g| {
        crate::coupling::CouplingMatrix::of_estimates(model, g, &unknowns)
    });
    Ok(Calibration {
        xi: x[..model.n_params()].to_vec(),
        nominal_xi: model.nominal_params().to_vec(),
        x_meas_base: frames[0],
        x_meas_base_initial: starts.stations[0],
        x_meas_base_nominal_robot,
        station_frames: frames[1..].to_vec(),
        station_names: set.station_names().to_vec(),
        station_errors,
        targets,
        targets_nominal_robot,
        targets_initial,
        measurement_frame_fixed: frame_fixed,
        use_orientation,
        unknowns,
        elastic: options
            .gravity
            .as_ref()
            .map(|g| (g.clone(), x[fe..joint_start].to_vec())),
        coupling,
        joint_terms: options.joint_terms,
        joint_term_values: x[joint_start..].to_vec(),
        identifiability,
        combination_lines: combination_lines(&combinations),
        combinations,
        solve: report,
        cost_history,
        residual_history,
        training_before: error_statistics(&errors_before),
        training_after: error_statistics(&errors_after),
        per_target_before,
        per_target_after,
        data_checks: DataChecks::of(set, &norms, named)?,
        observation_errors,
        noise,
        n_poses: set.len(),
        n_observations: errors_after.len(),
        position_residual_dof,
        actuated_names: model.actuated_names().to_vec(),
        actuated_ranges,
        torque_ranges,
        deflection: None,
    })
}

/// `errors` (one per observation of `problem`, in its order) labelled by
/// pose and target.
pub(crate) fn observation_errors(
    problem: &ErrorModel<'_>,
    errors: &[PoseError],
) -> Vec<ObservationError> {
    let set = problem.set();
    errors
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let (k, t) = problem.observation(i);
            ObservationError {
                pose: set.poses()[k].label(k),
                target: set.targets()[t].name.clone(),
                error: e.position_vector,
                orientation_error: e.orientation,
            }
        })
        .collect()
}

/// The statistics of `errors` (one per observation of `problem`) target by
/// target.
pub(crate) fn per_target(problem: &ErrorModel<'_>, errors: &[PoseError]) -> Vec<TargetErrors> {
    let set = problem.set();
    set.targets()
        .iter()
        .enumerate()
        .map(|(t, target)| {
            let mine: Vec<PoseError> = errors
                .iter()
                .enumerate()
                .filter(|(i, _)| problem.observation(*i).1 == t)
                .map(|(_, e)| *e)
                .collect();
            TargetErrors {
                target: target.name.clone(),
                frame: target.frame.clone(),
                statistics: error_statistics(&mine),
            }
        })
        .collect()
}

/// The combinations (C.1) as text, one line per identified unknown that
/// absorbs others (coefficients below 1e-3 dropped).
pub(crate) fn combination_lines(combinations: &[Combination]) -> Vec<String> {
    combinations
        .iter()
        .map(|c| c.to_text(1e-3))
        .filter(|l| !l.is_empty())
        .collect()
}

/// The sentence naming the unknowns of `unknowns` whose
/// [`UnknownEstimate::spread_ratio`] exceeds [`WEAK_SPREAD_RATIO`], if any.
pub(crate) fn weak_spread_note<'a>(
    unknowns: impl Iterator<Item = &'a UnknownEstimate>,
) -> Option<String> {
    let weak: Vec<String> = unknowns
        .filter_map(|u| {
            u.spread_ratio
                .filter(|r| *r > WEAK_SPREAD_RATIO)
                .map(|r| format!("{} x{r:.0}", u.name))
        })
        .collect();
    (!weak.is_empty()).then(|| {
        format!(
            "determined more than {WEAK_SPREAD_RATIO:.0} times less precisely than by as many poses spread over the joint ranges (standard error ratio): {}; these poses see them mostly in combinations that hold near them, so predictions for poses unlike them (other joint ranges) are extrapolations",
            weak.join(", ")
        )
    })
}

/// Step 8 of [`crate::calibrate`]: the deflection settled. With
/// [`Deflection::Auto`], measures the one-step fit's largest torque
/// change and, beyond the share, identifies again with the equilibrium;
/// then compares the one step and the equilibrium at the identified
/// unknowns. Returns the identification kept, the options it was made with
/// (the deflection resolved to the one it used) and the report (`None`
/// for the geometric model and the default one step).
///
/// # Errors
/// Those of the identification and of the comparison.
pub(crate) fn settle<'a>(
    model: &'a Model,
    set: &'a MeasurementSet,
    options: &CalibrationOptions,
    found: Identification<'a>,
) -> Result<
    (
        Identification<'a>,
        CalibrationOptions,
        Option<DeflectionReport>,
    ),
    CalibError,
> {
    let deflection = match &options.gravity {
        Some(gravity) if !gravity.deflection.is_one_step() => gravity.deflection,
        _ => return Ok((found, options.clone(), None)),
    };
    let Some(comparison) = found.problem.compare_deflections(&found.report.x)? else {
        return Ok((found, options.clone(), None));
    };
    let names = model.actuated_names();
    let resolved = |deflection: Deflection| {
        let mut resolved = options.clone();
        if let Some(gravity) = resolved.gravity.as_mut() {
            gravity.deflection = deflection;
        }
        resolved
    };
    match deflection {
        Deflection::Auto { share } => {
            let measured = comparison.largest().2;
            if measured > share {
                let switched = resolved(Deflection::equilibrium());
                let again = identify(model, Cow::Borrowed(set), &switched)?;
                let report = again
                    .problem
                    .compare_deflections(&again.report.x)?
                    .map(|c| {
                        c.report(
                            names,
                            Deflection::equilibrium(),
                            DeflectionChoice::AutoSwitchedOn,
                            Some((share, measured)),
                        )
                    });
                Ok((again, switched, report))
            } else {
                let report = comparison.report(
                    names,
                    Deflection::OneStep,
                    DeflectionChoice::AutoKeptOneStep,
                    Some((share, measured)),
                );
                Ok((found, resolved(Deflection::OneStep), Some(report)))
            }
        }
        asked => {
            let report = comparison.report(names, asked, DeflectionChoice::Asked, None);
            Ok((found, options.clone(), Some(report)))
        }
    }
}
