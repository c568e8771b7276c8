//! The JSON report of a calibration (mm and deg at this boundary).

use std::path::Path;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use crate::error::CalibError;
use crate::identify::Calibration;
use crate::metrics::ErrorStatistics;
use crate::screen::DataChecks;
use crate::unknowns::UnknownStatus;
use crate::validate::ValidationReport;

/// Error figures in mm and deg.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct StatisticsJson {
    /// Number of poses.
    pub n_poses: usize,
    /// Number of observations (a target seen at a pose), with several
    /// targets; absent for one target (one observation per pose).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub n_observations: Option<usize>,
    /// Mean position error (mm).
    pub position_mean_mm: f64,
    /// RMS position error (mm).
    pub position_rms_mm: f64,
    /// Maximum position error (mm).
    pub position_max_mm: f64,
    /// Mean orientation error (deg), when measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_mean_deg: Option<f64>,
    /// RMS orientation error (deg), when measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_rms_deg: Option<f64>,
    /// Maximum orientation error (deg), when measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_max_deg: Option<f64>,
}

impl From<&ErrorStatistics> for StatisticsJson {
    fn from(s: &ErrorStatistics) -> Self {
        let o = s.orientation_mean_rms_max;
        Self {
            n_poses: s.n_poses,
            n_observations: None,
            position_mean_mm: s.position_mean * 1e3,
            position_rms_mm: s.position_rms * 1e3,
            position_max_mm: s.position_max * 1e3,
            orientation_mean_deg: o.map(|o| o.0.to_degrees()),
            orientation_rms_deg: o.map(|o| o.1.to_degrees()),
            orientation_max_deg: o.map(|o| o.2.to_degrees()),
        }
    }
}

impl StatisticsJson {
    /// The figures of statistics over observations (`s.n_poses` counts
    /// them) of `poses` poses.
    pub fn of_observations(s: &ErrorStatistics, poses: usize) -> Self {
        Self {
            n_poses: poses,
            n_observations: Some(s.n_poses),
            ..Self::from(s)
        }
    }
}

/// The figures of a multi-target run in the units and counts of the
/// one-target report: the `summary` object of the multi-target JSON
/// report, beside the run's own types (SI).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TargetSummaryJson {
    /// Errors of every observation of the identification set after
    /// identification (poses and observations counted apart), with
    /// `before`, the nominal robot's.
    pub identification: TargetStatisticsJson,
    /// The same on the validation set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation: Option<TargetStatisticsJson>,
    /// Where the noise of the judgements came from.
    pub noise: NoiseJson,
    /// What the deflection model did ([`crate::Calibration::deflection`]);
    /// absent for the geometric model and the default one step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deflection: Option<crate::equilibrium::DeflectionReport>,
    /// Every unknown, in display units.
    pub parameters: Vec<ParameterJson>,
    /// The identifiability notes.
    pub notes: Vec<String>,
}

/// Errors before and after, overall and per target (mm).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TargetStatisticsJson {
    /// After, over every observation.
    #[serde(flatten)]
    pub after: StatisticsJson,
    /// Before (nominal robot), over every observation.
    pub before: StatisticsJson,
    /// After, per target (its observations and the poses they are on).
    pub per_target: Vec<TargetStatisticsEntry>,
}

/// One target's errors after (mm).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TargetStatisticsEntry {
    /// Target name.
    pub target: String,
    /// Its errors.
    #[serde(flatten)]
    pub after: StatisticsJson,
}

impl TargetStatisticsJson {
    /// From the statistics of a set of `poses` poses: over every
    /// observation after and before, and each target's after.
    pub fn new(
        poses: usize,
        after: &ErrorStatistics,
        before: &ErrorStatistics,
        per_target: &[crate::metrics::TargetErrors],
    ) -> Self {
        Self {
            after: StatisticsJson::of_observations(after, poses),
            before: StatisticsJson::of_observations(before, poses),
            per_target: per_target
                .iter()
                .map(|t| TargetStatisticsEntry {
                    target: t.target.clone(),
                    after: StatisticsJson::from(&t.statistics),
                })
                .collect(),
        }
    }
}

impl TargetSummaryJson {
    /// The summary of a multi-target identification and its validation
    /// (with the number of poses of the validation set).
    pub fn new(
        calibration: &crate::identify::Calibration,
        validation: Option<(&crate::validate::ValidationReport, usize)>,
    ) -> Self {
        Self {
            identification: TargetStatisticsJson::new(
                calibration.n_poses,
                &calibration.training_after,
                &calibration.training_before,
                &calibration.per_target_after,
            ),
            validation: validation.map(|(v, poses)| {
                TargetStatisticsJson::new(poses, &v.after, &v.before, &v.per_target_after)
            }),
            noise: NoiseJson::from(&calibration.noise),
            deflection: calibration.deflection.clone(),
            parameters: parameters_json(&calibration.unknowns),
            notes: calibration.identifiability_notes(),
        }
    }
}

/// Every unknown in display units, for the reports.
pub fn parameters_json(unknowns: &[crate::unknowns::UnknownEstimate]) -> Vec<ParameterJson> {
    unknowns
        .iter()
        .map(|u| {
            let (unit, scale) = u.kind.display_unit();
            ParameterJson {
                name: u.name.clone(),
                unit,
                nominal: u.initial * scale,
                identified: u.value * scale,
                delta: (u.value - u.initial) * scale,
                standard_error: u.standard_error.map(|s| s * scale),
                spread_ratio: u.spread_ratio,
                status: UnknownStatus::name(u.status),
                judgement: u.judgement.map(|j| JudgementJson {
                    value: j.value * scale,
                    standard_error: Some(j.standard_error * scale).filter(|s| s.is_finite()),
                    outcome: j.outcome,
                }),
            }
        })
        .collect()
}

/// One unknown in the report.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParameterJson {
    /// Name.
    pub name: String,
    /// `mm` or `deg`.
    pub unit: &'static str,
    /// Starting value (nominal) in `unit`.
    pub nominal: f64,
    /// Identified value in `unit`.
    pub identified: f64,
    /// `identified - nominal` in `unit`.
    pub delta: f64,
    /// Standard error in `unit` (identified unknowns only).
    pub standard_error: Option<f64>,
    /// Standard error over the one of as many poses spread over the joint
    /// ranges (identified unknowns only; see
    /// [`crate::UnknownEstimate::spread_ratio`]).
    pub spread_ratio: Option<f64>,
    /// `identified`, `fixed`, `non-identifiable`, `poorly-identifiable`,
    /// `no-influence`, `at-bound` ([`UnknownStatus::name`]).
    pub status: &'static str,
    /// For a compliance: the fit that judged it on its own scale, in
    /// `unit` ([`crate::significance`]); absent for other unknowns.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub judgement: Option<JudgementJson>,
}

/// The noise of an identification in the report.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct NoiseJson {
    /// `instrument` (stated by the user), `file` (the file's standard
    /// deviations) or `estimated` (from the fit's residual).
    pub source: &'static str,
    /// Per position axis (mm); absent for `file`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_std_mm: Option<f64>,
    /// Per orientation axis (deg), when the instrument's is stated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_std_deg: Option<f64>,
}

impl From<&crate::significance::NoiseSource> for NoiseJson {
    fn from(noise: &crate::significance::NoiseSource) -> Self {
        use crate::significance::NoiseSource;
        match noise {
            NoiseSource::Instrument(i) => Self {
                source: "instrument",
                position_std_mm: Some(i.position_std * 1e3),
                orientation_std_deg: i.orientation_std.map(f64::to_degrees),
            },
            NoiseSource::File => Self {
                source: "file",
                position_std_mm: None,
                orientation_std_deg: None,
            },
            NoiseSource::Estimated { position_std } => Self {
                source: "estimated",
                position_std_mm: Some(position_std * 1e3),
                orientation_std_deg: None,
            },
        }
    }
}

/// How a compliance was judged on its own scale.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct JudgementJson {
    /// Its value in the fit that judged it (`unit` of the parameter).
    pub value: f64,
    /// Its standard error in that fit (`unit`; `null` when the fit gave none).
    pub standard_error: Option<f64>,
    /// `kept`, `left-out` or `at-bound`.
    pub outcome: crate::significance::ScaleOutcome,
}

/// The `identification` object.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct IdentificationJson {
    /// Errors on the identification set after identification (its fields
    /// `n_poses`, `position_mean_mm`, ... sit directly in this object).
    #[serde(flatten)]
    pub after: StatisticsJson,
    /// Same figures with the nominal robot (frames registered).
    pub before: StatisticsJson,
    /// Per-axis scatter of the training residuals, `s = sqrt(SSR / (3 N -
    /// p))` (mm; [`Calibration::residual_scatter`]): what the model leaves
    /// at the training poses, the floor a later plan of the same robot
    /// reads from this report (`flexcal plan --prior`).
    pub residual_scatter_mm: f64,
    /// Identified unknowns.
    pub rank: usize,
    /// Unknowns in the model (robot + 6 frame + 6 target, 6 more per further
    /// station, then the elastic and joint terms).
    pub n_unknowns: usize,
    /// Free unknowns considered (not fixed, with influence).
    pub n_free: usize,
    /// Non-identifiable unknowns (beyond the numerical rank).
    pub non_identifiable: Vec<String>,
    /// Unknowns kept at nominal because their standard error would exceed the limit.
    pub poorly_identifiable: Vec<String>,
    /// Combinations the identified unknowns stand for (like (C.1)).
    pub combinations: Vec<String>,
    /// What the poses could not identify, in sentences
    /// ([`Calibration::identifiability_notes`]).
    pub notes: Vec<String>,
    /// Where the noise of the standard errors and identifiability
    /// judgements came from ([`crate::NoiseSource`]).
    pub noise: NoiseJson,
    /// What the deflection model did ([`crate::Calibration::deflection`]);
    /// absent for the geometric model and the default one step.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deflection: Option<crate::equilibrium::DeflectionReport>,
    /// Condition number of the scaled base columns.
    pub condition_number: f64,
    /// Singular values of the scaled, weighted Jacobian of the identified unknowns.
    pub singular_values: Vec<f64>,
    /// Solver termination reason.
    pub termination: String,
    /// Whether the termination is a convergence test.
    pub converged: bool,
    /// Iterations of the final solve.
    pub iterations: usize,
    /// Trial points of the final solve the model could not evaluate (a
    /// loop that cannot close, an equilibrium that does not converge),
    /// each refused as a step that raised the cost; zero in a smooth fit.
    #[serde(default)]
    pub refused_trials: usize,
    /// The model's error at the last refused trial point, with its cause;
    /// absent when none was refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_refusal: Option<String>,
    /// Cost `1/2 ||W r||^2` at the start and after each iteration, every solve in order (Figure 7 data).
    pub cost_history: Vec<f64>,
    /// RMS position error (mm) at the same iterates.
    pub position_rms_history_mm: Vec<f64>,
    /// RMS orientation error (deg) at the same iterates, when measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_rms_history_deg: Option<Vec<f64>>,
    /// Every unknown.
    pub parameters: Vec<ParameterJson>,
    /// Repeated readings and suspect poses of the identification set.
    pub data_checks: DataChecks,
    /// What the identification poses cover of each actuated coordinate, and
    /// of its gravity torque (elasto-geometric): beyond them predictions
    /// extrapolate ([`Calibration::actuated_ranges`],
    /// [`Calibration::torque_ranges`]).
    pub coverage: Vec<CoverageJson>,
    /// The identified (or fixed) measurement frame `x_meas_base`: the
    /// robot base seen from the instrument. A part located by the instrument
    /// is carried into the calibrated robot's base through it.
    pub measurement_frame: FrameJson,
    /// With measurements from several stations: each station's name and
    /// identified measurement frame, the first station's being
    /// `measurement_frame` (absent for one station).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub stations: Vec<StationJson>,
    /// The coupling groups' compliance matrices (absent without
    /// `[[coupling_compliance]]` groups in the mass table).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub coupling_compliance: Vec<CouplingMatrixJson>,
}

/// One coupling group's compliance matrix ([`crate::CouplingMatrix`]) in
/// urad/N.m.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CouplingMatrixJson {
    /// The group's joints (frame names): the rows and columns in order.
    pub joints: Vec<String>,
    /// The matrix, row by row (urad/N.m).
    pub compliance_urad_per_nm: Vec<Vec<f64>>,
    /// Each entry's standard error (urad/N.m; `null` when not identified).
    pub standard_error_urad_per_nm: Vec<Vec<Option<f64>>>,
    /// The matrix's smallest eigenvalue (urad/N.m; `>= 0` up to round-off).
    pub smallest_eigenvalue_urad_per_nm: f64,
    /// The off-diagonal entries held at the positive semi-definite bound.
    pub held_at_bound: Vec<String>,
}

impl From<&crate::CouplingMatrix> for CouplingMatrixJson {
    fn from(m: &crate::CouplingMatrix) -> Self {
        let micro = |rows: &Vec<Vec<f64>>| -> Vec<Vec<f64>> {
            rows.iter()
                .map(|r| r.iter().map(|v| v * 1e6).collect())
                .collect()
        };
        Self {
            joints: m.joints.clone(),
            compliance_urad_per_nm: micro(&m.compliance),
            standard_error_urad_per_nm: m
                .standard_error
                .iter()
                .map(|r| r.iter().map(|s| s.map(|s| s * 1e6)).collect())
                .collect(),
            smallest_eigenvalue_urad_per_nm: m.smallest_eigenvalue * 1e6,
            held_at_bound: m.held_at_bound.clone(),
        }
    }
}

/// One station in the `stations` array.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct StationJson {
    /// Name of the station (its file, or its `station` column value).
    pub name: String,
    /// Its measurement frame `x_meas_base`.
    pub measurement_frame: FrameJson,
    /// Errors of its poses after identification (the fields `n_poses`,
    /// `position_mean_mm`, ... sit directly in this object).
    #[serde(flatten)]
    pub after: StatisticsJson,
}

/// One actuated coordinate in the `coverage` array.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CoverageJson {
    /// Name of the actuated coordinate.
    pub coordinate: String,
    /// `deg` for a revolute coordinate, `mm` otherwise.
    pub unit: &'static str,
    /// Start of the covered interval, or of the arc of the circle for a
    /// revolute coordinate (display unit).
    pub lo: f64,
    /// Its end (display unit): `hi - lo` is the covered length, at most
    /// 360 deg for a revolute coordinate.
    pub hi: f64,
    /// Whether the coordinate is periodic (revolute): a value a whole number
    /// of turns from a covered one is covered.
    pub periodic: bool,
    /// Span `[lo, hi]` of the coordinate's gravity torque (N.m, or N) over
    /// the identification poses, elasto-geometric model only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque: Option<[f64; 2]>,
}

/// The `validation` object.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ValidationJson {
    /// Errors on the validation set after calibration (its fields sit
    /// directly in this object).
    #[serde(flatten)]
    pub after: StatisticsJson,
    /// With the nominal robot.
    pub before: StatisticsJson,
    /// What was re-fitted on the validation data.
    pub note: String,
    /// Actuated coordinates that leave the identification poses' range on
    /// some validation poses.
    pub extrapolated_coordinates: Vec<ExtrapolationJson>,
    /// Repeated readings and suspect poses of the validation set.
    pub data_checks: DataChecks,
}

/// An actuated coordinate that the validation poses take outside the
/// identification poses' range.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ExtrapolationJson {
    /// Name of the actuated coordinate.
    pub coordinate: String,
    /// Fraction of the validation poses outside the range (0-1).
    pub fraction_outside: f64,
}

/// A rigid transform in a report: translation (mm) and unit quaternion
/// `[w, x, y, z]`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct FrameJson {
    /// Translation (mm).
    pub translation_mm: [f64; 3],
    /// Rotation as a unit quaternion `[w, x, y, z]`.
    pub quaternion_wxyz: [f64; 4],
}

impl From<&Isometry3<f64>> for FrameJson {
    fn from(x: &Isometry3<f64>) -> Self {
        let t = x.translation.vector * 1e3;
        let q = x.rotation.quaternion();
        Self {
            translation_mm: [t.x, t.y, t.z],
            quaternion_wxyz: [q.w, q.i, q.j, q.k],
        }
    }
}

impl FrameJson {
    /// The transform in SI (m); the quaternion is normalised.
    pub fn isometry(&self) -> Isometry3<f64> {
        let [x, y, z] = self.translation_mm;
        let [w, i, j, k] = self.quaternion_wxyz;
        Isometry3::from_parts(
            Translation3::new(x * 1e-3, y * 1e-3, z * 1e-3),
            UnitQuaternion::from_quaternion(Quaternion::new(w, i, j, k)),
        )
    }
}

/// Reads the identified measurement frame `x_meas_base` from a calibration
/// report written by `calibrate --report` ([`CalibrationReportJson`]).
///
/// # Errors
/// [`CalibError::Io`] for an unreadable file, [`CalibError::InvalidOption`]
/// naming the file when it is not such a report or its frame is not finite.
pub fn read_measurement_frame(path: &Path) -> Result<Isometry3<f64>, CalibError> {
    #[derive(Deserialize)]
    struct Report {
        identification: Identification,
    }
    #[derive(Deserialize)]
    struct Identification {
        measurement_frame: FrameJson,
    }
    let text = flexcal_io::read_to_string(path)?;
    let invalid = |reason: String| CalibError::InvalidOption {
        name: "calibration report",
        reason: format!("{}: {reason}", path.display()),
    };
    let report: Report = serde_json::from_str(&text).map_err(|e| invalid(e.to_string()))?;
    let frame = report.identification.measurement_frame;
    let q = frame.quaternion_wxyz;
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !frame
        .translation_mm
        .iter()
        .chain(q.iter())
        .all(|v| v.is_finite())
        || norm < 1e-9
    {
        return Err(invalid(
            "identification.measurement_frame is not a finite rigid transform".into(),
        ));
    }
    Ok(frame.isometry())
}

/// The whole report.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CalibrationReportJson {
    /// Robot name.
    pub robot: String,
    /// `geometric` or `elasto-geometric` (joint compliances under gravity).
    pub model: &'static str,
    /// Identification results.
    pub identification: IdentificationJson,
    /// Validation results, when a validation set was given.
    pub validation: Option<ValidationJson>,
    /// The fuzzy residual model, when one was fitted (reported apart from
    /// the calibration: it is not part of the robot model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_model: Option<ResidualModelJson>,
    /// The split-half check of the standard errors, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_check: Option<crate::split::SplitCheck>,
    /// The cross-series check against the validation set, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cross_check: Option<crate::cross::CrossCheck>,
    /// The model selection that chose the identified groups, when run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub selection: Option<crate::selection::SelectionReport>,
    /// Each station held out in turn ([`crate::hold_out_stations`]), when
    /// asked for.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub station_hold_out: Vec<StationHoldOutJson>,
    /// The model's error growth outside the training ranges that the
    /// predicted bounds include (`--extrapolation`,
    /// [`crate::ExtrapolationModel`]: growth per coordinate in m/rad or
    /// m/m, every fold), when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extrapolation: Option<crate::extrapolation::ExtrapolationModel>,
}

/// One station held out, in the report's units.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct StationHoldOutJson {
    /// Name of the held-out station.
    pub station: String,
    /// Groups the selection chose on the other stations (absent without
    /// selection).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chosen: Option<Vec<String>>,
    /// Its errors with the robot calibrated on the other stations.
    #[serde(flatten)]
    pub after: StatisticsJson,
    /// The same with the nominal robot.
    pub before: StatisticsJson,
}

impl From<&crate::holdout::StationHoldOut> for StationHoldOutJson {
    fn from(h: &crate::holdout::StationHoldOut) -> Self {
        Self {
            station: h.station.clone(),
            chosen: h.chosen.clone(),
            after: StatisticsJson::from(&h.after),
            before: StatisticsJson::from(&h.before),
        }
    }
}

/// The `residual_model` object.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ResidualModelJson {
    /// Actuated coordinates used as inputs.
    pub inputs: Vec<String>,
    /// Rules of the x, y and z models.
    pub rules: [usize; 3],
    /// RMS error of each axis model on its held-out identification poses (mm).
    pub held_out_rmse_mm: [f64; 3],
    /// Validation errors with the residual model added (validation given).
    pub validation: Option<StatisticsJson>,
}

impl ResidualModelJson {
    /// The object for `residual`, fitted on a model with actuated coordinates
    /// `names`, and its validation.
    pub fn new(
        names: &[String],
        residual: &crate::residual::ResidualModel,
        validation: Option<&ValidationReport>,
    ) -> Self {
        Self {
            inputs: residual.inputs.iter().map(|&i| names[i].clone()).collect(),
            rules: residual.rule_counts(),
            held_out_rmse_mm: [0, 1, 2].map(|a| residual.reports[a].test.rmse * 1e3),
            validation: validation.map(|v| StatisticsJson::from(&v.after)),
        }
    }
}

impl CalibrationReportJson {
    /// Builds the report.
    pub fn new(
        robot: &str,
        calibration: &Calibration,
        validation: Option<&ValidationReport>,
    ) -> Self {
        let after = StatisticsJson::from(&calibration.training_after);
        let parameters = parameters_json(&calibration.unknowns);
        let identification = IdentificationJson {
            after,
            before: StatisticsJson::from(&calibration.training_before),
            residual_scatter_mm: calibration.residual_scatter() * 1e3,
            rank: calibration.rank(),
            n_unknowns: calibration.unknowns.len(),
            n_free: calibration.identifiability.names.len(),
            non_identifiable: calibration
                .non_identifiable()
                .into_iter()
                .map(String::from)
                .collect(),
            poorly_identifiable: calibration
                .poorly_identifiable()
                .into_iter()
                .map(String::from)
                .collect(),
            combinations: calibration.combination_lines.clone(),
            notes: calibration.identifiability_notes(),
            noise: NoiseJson::from(&calibration.noise),
            deflection: calibration.deflection.clone(),
            condition_number: calibration.solve.condition_number,
            singular_values: calibration.solve.singular_values.clone(),
            termination: format!("{:?}", calibration.solve.termination),
            converged: calibration.solve.termination.is_converged(),
            iterations: calibration.solve.iterations,
            refused_trials: calibration.solve.refused_trials,
            last_refusal: calibration.solve.last_refusal.clone(),
            cost_history: calibration.cost_history.clone(),
            position_rms_history_mm: calibration
                .residual_history
                .iter()
                .map(|h| h.position_rms * 1e3)
                .collect(),
            orientation_rms_history_deg: calibration
                .residual_history
                .iter()
                .map(|h| h.orientation_rms.map(f64::to_degrees))
                .collect(),
            parameters,
            data_checks: calibration.data_checks.clone(),
            coverage: calibration
                .actuated_names
                .iter()
                .zip(&calibration.actuated_ranges)
                .enumerate()
                .map(|(i, (name, range))| {
                    let (unit, scale) = if range.period.is_some() {
                        ("deg", 180.0 / std::f64::consts::PI)
                    } else {
                        ("mm", 1e3)
                    };
                    CoverageJson {
                        coordinate: name.clone(),
                        unit,
                        lo: range.lo * scale,
                        hi: range.hi * scale,
                        periodic: range.period.is_some(),
                        torque: calibration.torque_ranges.get(i).map(|t| [t.lo, t.hi]),
                    }
                })
                .collect(),
            measurement_frame: FrameJson::from(&calibration.x_meas_base),
            stations: if calibration.station_frames.is_empty() {
                Vec::new()
            } else {
                std::iter::once(&calibration.x_meas_base)
                    .chain(&calibration.station_frames)
                    .zip(&calibration.station_names)
                    .zip(&calibration.station_errors)
                    .map(|((frame, name), errors)| StationJson {
                        name: name.clone(),
                        measurement_frame: FrameJson::from(frame),
                        after: StatisticsJson::from(errors),
                    })
                    .collect()
            },
            coupling_compliance: calibration
                .coupling
                .iter()
                .map(CouplingMatrixJson::from)
                .collect(),
        };
        let validation = validation.map(|v| ValidationJson {
            after: StatisticsJson::from(&v.after),
            before: StatisticsJson::from(&v.before),
            note: v.frame_note.clone(),
            extrapolated_coordinates: v
                .extrapolated_coordinates
                .iter()
                .map(|(coordinate, fraction)| ExtrapolationJson {
                    coordinate: coordinate.clone(),
                    fraction_outside: *fraction,
                })
                .collect(),
            data_checks: v.data_checks.clone(),
        });
        Self {
            robot: robot.to_string(),
            model: if calibration.elastic.is_some() {
                "elasto-geometric"
            } else {
                "geometric"
            },
            identification,
            validation,
            residual_model: None,
            split_check: None,
            cross_check: None,
            station_hold_out: Vec::new(),
            selection: None,
            extrapolation: None,
        }
    }

    /// Pretty JSON text. Non-finite numbers (an infinite condition number) are written as `null`.
    ///
    /// # Errors
    /// [`CalibError::Serialise`].
    pub fn to_json_string(&self) -> Result<String, CalibError> {
        serde_json::to_string_pretty(self).map_err(|e| CalibError::Serialise {
            what: "calibration report",
            message: e.to_string(),
        })
    }
}
