//! The reference study: the paper's whole method on the virtual IR-663, as
//! one library call ([`run_study`]) that writes the files a real campaign
//! produces and returns typed results ([`Study`], whose [`Summary`] is the
//! `summary.json` of `flexcal demo`).
//!
//! Every step reads back the files the previous one wrote and calls the
//! same library functions a user calls on real data, so the study exercises
//! exactly the code path of a real calibration:
//! 1. geometric campaign, calibration and validation (section 3.2);
//! 2. elastic campaign, stiffness identification of the beam model
//!    (section 3.3.1) and the fuzzy compliance model (section 3.3.2);
//! 3. the forming experiment with and without compensation (section 4).
//!
//! Everything a figure of the report shows is computed here; the report
//! ([`study_report`]) only lays it out.

pub mod loaded;
pub mod masses;
pub mod model_class;
mod sections;
mod seeds;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::forming::FormingResult;
use flexcal_calib::{
    Calibration, CalibrationOptions, ErrorStatistics, FrameTreatment, MeasurementSet,
    UnknownStatus, ValidationReport, calibrate,
};
use flexcal_elastic::campaign::DeflectionSet;
use flexcal_elastic::description::ElasticDescription;
use flexcal_elastic::fuzzy_compliance::{RobotFuzzyCompliance, RobotInputs, compliance_samples};
use flexcal_elastic::grid::{GridValues, TcpGrid};
use flexcal_elastic::workflow::{
    ComplianceOutcome, ComplianceWorkflowOptions, StiffnessOutcome, StiffnessWorkflowOptions,
    identify_compliance_in_dir, identify_stiffness_in_dir,
};
use flexcal_kinematics::{Data, Model, SensitivityTable, sensitivity_indices};
use flexcal_twin::elastic::{ElasticCampaignOptions, ElasticCampaignSummary};
use flexcal_twin::geometric::{
    GeometricCampaignOptions, geometric_campaign, write_geometric_campaign,
};
use flexcal_twin::truth::{TruthSwitches, TwinTerm};
use serde::{Deserialize, Serialize};

pub use loaded::{LOADED_PAYLOAD_SOURCE, LoadedFigures, loaded_figures};
pub use masses::{MASS_SCALES, MassEntry, ir663_mass_estimate, ir663_mass_table};
pub use sections::study_report;
pub use seeds::{
    LoadComparison, MassScaleSpread, MeanMax, MultiSeedSummary, Spread, multi_seed_study,
};

use crate::{Error, Result};

/// Settings of [`run_study`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyOptions {
    /// Output folder (created if missing; files in it are replaced atomically).
    pub out: PathBuf,
    /// Seed of every random draw (measurement noise, pose jitter, data
    /// splits, searches); default 1.
    pub seed: u64,
}

impl Default for StudyOptions {
    fn default() -> Self {
        Self {
            out: PathBuf::from("flexcal-demo"),
            seed: 1,
        }
    }
}

/// Told when a step of the study starts and when it ends (a terminal shows
/// a spinner, a notebook a line).
pub trait StudyObserver {
    /// A step starts: what it does.
    fn started(&mut self, _what: &str) {}
    /// The running step has a new stage.
    fn stage(&mut self, _what: &str) {}
    /// The running step ended: its one-line result.
    fn finished(&mut self, _line: &str) {}
}

/// An observer that ignores everything.
impl StudyObserver for () {}

/// Position and orientation error statistics in report units.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ValidationFigures {
    /// Mean position error (mm).
    pub position_mean_mm: f64,
    /// Maximum position error (mm).
    pub position_max_mm: f64,
    /// Mean orientation error (deg).
    pub orientation_mean_deg: f64,
    /// Maximum orientation error (deg).
    pub orientation_max_deg: f64,
}

impl From<&ErrorStatistics> for ValidationFigures {
    fn from(s: &ErrorStatistics) -> Self {
        let (o_mean, _, o_max) = s
            .orientation_mean_rms_max
            .unwrap_or((f64::NAN, 0.0, f64::NAN));
        Self {
            position_mean_mm: s.position_mean * 1e3,
            position_max_mm: s.position_max * 1e3,
            orientation_mean_deg: o_mean.to_degrees(),
            orientation_max_deg: o_max.to_degrees(),
        }
    }
}

/// The geometric part of the summary.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct GeometricSummary {
    /// Number of identified parameters.
    pub rank: usize,
    /// Number of robot parameters.
    pub parameters: usize,
    /// Parameters the poses cannot identify, by name.
    pub non_identifiable: Vec<String>,
    /// Validation errors with the nominal robot.
    pub validation_before: ValidationFigures,
    /// Validation errors with the calibrated robot (geometric model).
    pub validation_after: ValidationFigures,
    /// Validation errors with the elasto-geometric model (geometry and
    /// joint compliances under gravity, identified on the same poses).
    pub elasto_geometric: ValidationFigures,
    /// Mean position error a perfect model would show on the validation
    /// poses: the measurement noise (mm), `2 sqrt(2 / pi) sigma` for a
    /// Gaussian of `sigma` per axis.
    pub noise_floor_position_mean_mm: f64,
    /// The measurement noise per axis the campaign's files state and the
    /// twin draws (um): one LED's, the LEDs' errors taken as correlated.
    pub noise_position_std_per_axis_um: f64,
    /// The same if the LEDs' errors were independent (um): the optimistic
    /// derivation, published, not used.
    pub noise_position_std_per_axis_independent_leds_um: f64,
    /// Validation on the poses outside box (59), where the robot's own
    /// weight loads the joints unlike any identification pose.
    pub outside_box: OutsideBoxFigures,
    /// Validation on poses of box (59) measured with a known payload at
    /// the TCP, a load no identification pose carried.
    pub loaded: LoadedFigures,
    /// The mass table the elasto-geometric calibration starts from, each
    /// figure with its source and assumed uncertainty.
    pub mass_estimate: Vec<MassEntry>,
    /// The elasto-geometric calibration again with every estimated mass
    /// scaled (by [`MASS_SCALES`]), validated inside and outside box (59).
    pub mass_scaled: Vec<MassScaleFigures>,
}

/// The geometric step's validation on the poses outside box (59).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct OutsideBoxFigures {
    /// Number of validation poses.
    pub poses: usize,
    /// With the nominal robot (camera frame registered).
    pub before: ValidationFigures,
    /// With the geometric calibration.
    pub geometric: ValidationFigures,
    /// With the elasto-geometric calibration.
    pub elasto_geometric: ValidationFigures,
}

/// The elasto-geometric calibration with every estimated mass scaled.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct MassScaleFigures {
    /// The factor applied to every mass of the estimate.
    pub scale: f64,
    /// Validation inside box (59).
    pub inside: ValidationFigures,
    /// Validation outside box (59).
    pub outside: ValidationFigures,
    /// Validation on the loaded poses, told the weighed payload.
    pub loaded: ValidationFigures,
}

/// Table 5 figures of one load (mm).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LoadFigures {
    /// RMS of the residual norm (mm).
    pub rms_mm: f64,
    /// Largest residual norm (mm).
    pub max_norm_mm: f64,
    /// Largest |x| residual (mm).
    pub max_x_mm: f64,
    /// Largest |z| residual (mm).
    pub max_z_mm: f64,
}

/// Overall RMS of an elastic model (mm).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct OverallFigures {
    /// RMS of the residual norm over every load (mm).
    pub rms_mm: f64,
}

/// Table 5 of one elastic model: one entry per load, keyed by the load in
/// whole newtons (`"300"`, `"600"`, ...), and `"all"`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Table5 {
    /// Figures per load, keyed by the load in N.
    #[serde(flatten)]
    pub loads: BTreeMap<String, LoadFigures>,
    /// Figures over every load.
    pub all: OverallFigures,
}

impl From<&flexcal_elastic::metrics::LoadMetricsTable> for Table5 {
    fn from(table: &flexcal_elastic::metrics::LoadMetricsTable) -> Self {
        let loads = table
            .rows
            .iter()
            .map(|row| {
                (
                    format!("{:.0}", row.load_n),
                    LoadFigures {
                        rms_mm: row.rms_mm,
                        max_norm_mm: row.max_norm_mm,
                        max_x_mm: row.max_abs_x_mm,
                        max_z_mm: row.max_abs_z_mm,
                    },
                )
            })
            .collect();
        Self {
            loads,
            all: OverallFigures {
                rms_mm: table.overall_rms_mm,
            },
        }
    }
}

/// Table 5 of both elastic models on one metric, and its noise floor.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SameMetric {
    /// The parametric (FE beam) model.
    pub parametric: Table5,
    /// The fuzzy compliance model (it predicts x and z only: in 3-D its
    /// residual along y is the measured y deflection).
    pub fuzzy: Table5,
    /// RMS norm of the deflection noise on this metric (mm): no model can
    /// get below it on these data.
    pub noise_floor_mm: f64,
}

/// The elastic models compared on the same metric: residuals in the x-z
/// plane, and in 3-D.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Table5Comparison {
    /// Residual norm in the x-z plane (the paper's metric).
    pub plane_xz: SameMetric,
    /// Residual norm in 3-D.
    pub three_d: SameMetric,
}

/// The elastic part of the summary.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ElasticSummary {
    /// Table 5 of the parametric (FE beam) model (3-D residuals).
    pub parametric: Table5,
    /// Table 5 of the fuzzy compliance model (x-z plane).
    pub fuzzy: Table5,
    /// Stiffness parameters that the campaign cannot identify separately.
    pub stiffness_non_identifiable: Vec<String>,
    /// Both models on the same metric, each with its noise floor, on the
    /// campaign's own 63 poses (the 900 N sets trained them).
    pub same_metric: Table5Comparison,
    /// Both models on configurations they never saw: random poses off the
    /// grid (y up to +-0.4 m, the tool tilted up to 20 deg), 650 N in the
    /// x-z plane at random angles ([`flexcal_twin::elastic::simulate_held_out_campaign`]).
    pub held_out: Table5Comparison,
}

/// The twin's part of the summary: what its truth contains.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TwinSummary {
    /// Every truth term with its magnitude, source and switch.
    pub terms: Vec<TwinTerm>,
}

/// The forming figures of one compensation, over the contact points and
/// over the whole path.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CompensationFigures {
    /// The elastic model the path was compensated with.
    pub model: String,
    /// Largest |deviation| along z_p over the contact points (mm).
    pub max_deviation_contact_mm: f64,
    /// Largest |deviation| along z_p over the whole path (mm).
    pub max_deviation_path_mm: f64,
    /// `100 (1 - compensated / uncompensated)` over the contact points (%).
    pub improvement_contact_percent: f64,
    /// `100 (1 - compensated / uncompensated)` over the whole path (%).
    pub improvement_path_percent: f64,
    /// Whether every contact point is within +-0.15 mm along z_p (the
    /// paper's bar).
    pub within_tolerance_contact: bool,
}

/// The forming part of the summary: both compensations side by side.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FormingSummary {
    /// The dead weight as weighed (N).
    pub dead_weight_n: f64,
    /// Why that weight: how it differs from the training loads.
    pub dead_weight_source: String,
    /// Points where the tool presses on the bar (the process load acts).
    pub contact_points: usize,
    /// Points of the whole path.
    pub path_points: usize,
    /// Largest |deviation| along z_p without compensation, contact points (mm).
    pub uncompensated_contact_mm: f64,
    /// Largest |deviation| along z_p without compensation, whole path (mm).
    pub uncompensated_path_mm: f64,
    /// One entry per elastic model, in the order they were run (fuzzy, FE
    /// beam model); no entry is singled out.
    pub compensations: Vec<CompensationFigures>,
    /// RMS residual of the part's location fit over its reference points (mm).
    pub part_fit_rms_mm: f64,
}

impl FormingSummary {
    /// The figures of a forming result.
    pub fn of(result: &crate::forming::FormingResult) -> Self {
        let unc = &result.uncompensated;
        let better = |after: f64, before: f64| 100.0 * (1.0 - after / before);
        Self {
            dead_weight_n: result.dead_weight_n,
            dead_weight_source: DEAD_WEIGHT_SOURCE.into(),
            contact_points: result.contact.iter().filter(|c| **c).count(),
            path_points: result.contact.len(),
            uncompensated_contact_mm: unc.max_abs_deviation_z_contact_mm,
            uncompensated_path_mm: unc.max_abs_deviation_z_mm,
            compensations: result
                .compensated
                .iter()
                .map(|c| CompensationFigures {
                    model: c.label.trim_start_matches("compensated, ").to_string(),
                    max_deviation_contact_mm: c.max_abs_deviation_z_contact_mm,
                    max_deviation_path_mm: c.max_abs_deviation_z_mm,
                    improvement_contact_percent: better(
                        c.max_abs_deviation_z_contact_mm,
                        unc.max_abs_deviation_z_contact_mm,
                    ),
                    improvement_path_percent: better(
                        c.max_abs_deviation_z_mm,
                        unc.max_abs_deviation_z_mm,
                    ),
                    within_tolerance_contact: c.max_abs_deviation_z_contact_mm
                        <= crate::forming::PAPER_TOLERANCE_MM,
                })
                .collect(),
            part_fit_rms_mm: result.part_fit_rms_mm,
        }
    }
}

/// Where the study's dead weight comes from.
pub const DEAD_WEIGHT_SOURCE: &str = "a 66 kg forming head (650 N), chosen unlike every load of the elastic campaign (300, 600, 900, 1100 N; the models are trained on 900 N); the paper's 920 N sits next to the training load";

/// The study's figures: `summary.json` of `flexcal demo`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Summary {
    /// Geometric calibration.
    pub geometric: GeometricSummary,
    /// Elastic models.
    pub elastic: ElasticSummary,
    /// Forming path compensation.
    pub forming: FormingSummary,
    /// The virtual robot's truth (a simulation, not a real IR-663).
    pub twin: TwinSummary,
    /// Seed used.
    pub seed: u64,
    /// Wall-clock time of the whole study (s).
    pub runtime_s: f64,
}

impl Summary {
    /// Writes the summary (pretty JSON, atomically).
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        flexcal_io::write_atomic(path, to_json(self, "summary")? + "\n")?;
        Ok(())
    }

    /// Reads a summary written by [`Summary::write`].
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = flexcal_io::read_to_string(path)?;
        serde_json::from_str(&text).map_err(|source| Error::Json {
            context: path.display().to_string(),
            source,
        })
    }
}

fn to_json<T: Serialize>(value: &T, what: &str) -> Result<String> {
    serde_json::to_string_pretty(value).map_err(|source| Error::Json {
        context: what.to_string(),
        source,
    })
}

/// Everything the geometric step produced.
#[derive(Debug, Clone)]
pub struct GeometricResults {
    /// The nominal robot.
    pub model: Model,
    /// The twin's true parameters (SI).
    pub true_xi: Vec<f64>,
    /// The calibration (geometric model).
    pub calibration: Calibration,
    /// Its validation on the other poses.
    pub validation: ValidationReport,
    /// The elasto-geometric calibration on the same poses.
    pub elasto_geometric: Calibration,
    /// Its validation on the other poses.
    pub elasto_geometric_validation: ValidationReport,
    /// Sensitivity indices (55), (56) over the identification poses
    /// (Figs. C.21-C.24).
    pub sensitivity: SensitivityTable,
    /// The summary figures.
    pub summary: GeometricSummary,
}

/// The figures of the largest vertical load (Figs. 9, 10, 14, 15).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VerticalLoadFigures {
    /// The load (N).
    pub load_n: f64,
    /// Measured deflection along z, pose by pose (mm).
    pub measured_z_mm: Vec<f64>,
    /// The beam model's predicted deflection along z (mm).
    pub parametric_z_mm: Vec<f64>,
    /// The fuzzy model's predicted deflection along z (mm).
    pub fuzzy_z_mm: Vec<f64>,
    /// Measured deflection norm over the grid (mm).
    pub deflection_norm_mm: GridValues,
    /// Residual norm of the beam model relative to the measured deflection (%).
    pub parametric_error_percent: GridValues,
    /// Residual norm of the fuzzy model relative to the measured deflection (%).
    pub fuzzy_error_percent: GridValues,
}

/// The fuzzy model of C_xx over its two inputs (Fig. 13).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplianceSurface {
    /// First input's values (deg).
    pub xs_deg: Vec<f64>,
    /// Second input's values (deg).
    pub ys_deg: Vec<f64>,
    /// `c_xx[row of y][column of x]` (mm/kN).
    pub c_xx_mm_per_kn: Vec<Vec<f64>>,
}

/// Everything the elastic steps produced.
#[derive(Debug, Clone)]
pub struct ElasticResults {
    /// The twin's campaign.
    pub campaign: ElasticCampaignSummary,
    /// The stiffness identification.
    pub stiffness: StiffnessOutcome,
    /// The fuzzy compliance identification.
    pub compliance: ComplianceOutcome,
    /// Figures of the largest vertical load (none if the campaign has no vertical load).
    pub vertical: Option<VerticalLoadFigures>,
    /// The C_xx surface (none unless the model has two inputs).
    pub surface: Option<ComplianceSurface>,
    /// The summary figures.
    pub summary: ElasticSummary,
}

/// The forming step's results.
#[derive(Debug, Clone)]
pub struct FormingResults {
    /// The measured paths.
    pub result: FormingResult,
    /// The summary figures.
    pub summary: FormingSummary,
}

/// The whole study.
#[derive(Debug, Clone)]
pub struct Study {
    /// Options it ran with.
    pub options: StudyOptions,
    /// Geometric calibration.
    pub geometric: GeometricResults,
    /// Elastic models.
    pub elastic: ElasticResults,
    /// Forming path compensation.
    pub forming: FormingResults,
    /// The figures of `summary.json`.
    pub summary: Summary,
}

/// Runs the study, writing the campaign files, the models and the results
/// under `options.out` (`geometric/`, `elastic/`, `forming/`); the summary
/// and the report are written by [`write_study`].
///
/// # Errors
/// Any step's failure, with the file or parameter concerned.
pub fn run_study(options: &StudyOptions, observer: &mut dyn StudyObserver) -> Result<Study> {
    let start = Instant::now();
    std::fs::create_dir_all(&options.out).map_err(|source| flexcal_io::IoError::Io {
        path: options.out.clone(),
        source,
    })?;
    let geometric = geometric_step(&options.out, options.seed, observer)?;
    let elastic = elastic_step(&options.out, options.seed, observer)?;
    let forming = forming_step(&options.out, options.seed, &geometric, &elastic, observer)?;
    let terms = flexcal_twin::forming::TwinCell::new(TruthSwitches::default())?
        .terms()
        .terms;
    let summary = Summary {
        geometric: geometric.summary.clone(),
        elastic: elastic.summary.clone(),
        forming: forming.summary.clone(),
        twin: TwinSummary { terms },
        seed: options.seed,
        runtime_s: start.elapsed().as_secs_f64(),
    };
    Ok(Study {
        options: options.clone(),
        geometric,
        elastic,
        forming,
        summary,
    })
}

/// Writes `summary.json` and the self-contained `report.html` of a study
/// into its output folder; returns the number of figures of the report.
pub fn write_study(study: &Study) -> Result<usize> {
    let report = study_report(study)?;
    study
        .summary
        .write(study.options.out.join("summary.json"))?;
    flexcal_io::write_atomic(study.options.out.join("report.html"), report.to_html())?;
    Ok(report.figure_count())
}

fn geometric_step(
    out: &Path,
    seed: u64,
    observer: &mut dyn StudyObserver,
) -> Result<GeometricResults> {
    let dir = out.join("geometric");
    observer.started("geometric campaign on the virtual IR-663 (27 + 16 + 16 + 16 loaded poses)");
    let campaign_options = GeometricCampaignOptions {
        seed,
        ..GeometricCampaignOptions::default()
    };
    let camera = campaign_options.camera.clone();
    let campaign = geometric_campaign(&campaign_options)?;
    write_geometric_campaign(&campaign, &dir)?;
    // Read back what was written, as a user's own campaign would be.
    let identification = MeasurementSet::read_csv(&dir.join("identification.csv"))?;
    let validation_set = MeasurementSet::read_csv(&dir.join("validation.csv"))?;
    let outside_set = MeasurementSet::read_csv(&dir.join("validation_outside.csv"))?;
    let loaded_set = MeasurementSet::read_csv(&dir.join("validation_loaded.csv"))?;
    let payload = loaded::tcp_payload(campaign.payload_weighed_n);
    let model = campaign.model;
    observer.stage("geometric identification (Levenberg-Marquardt)");
    let mut calibration_options = CalibrationOptions::for_model(&model);
    // The camera's frame is registered with the robot (section 3.1): it is
    // identified; the target is the TCP.
    calibration_options.measurement_frame = FrameTreatment::Identify;
    calibration_options.target = FrameTreatment::Fixed;
    let calibration = calibrate(&model, &identification, &calibration_options)?;
    let validation = calibration.validate(&model, &validation_set, false)?;
    let validation_outside = calibration.validate(&model, &outside_set, false)?;
    observer.stage("elasto-geometric identification (geometry + joint compliances under gravity)");
    let mut elastic_options = calibration_options.clone();
    elastic_options.gravity = Some(ir663_mass_table(&model, 1.0)?);
    let elasto_geometric = calibrate(&model, &identification, &elastic_options)?;
    let elasto_geometric_validation = elasto_geometric.validate(&model, &validation_set, false)?;
    let elasto_geometric_outside = elasto_geometric.validate(&model, &outside_set, false)?;
    observer.stage("elasto-geometric identification with the masses 25 % off");
    let mut mass_scaled = Vec::with_capacity(MASS_SCALES.len());
    for scale in MASS_SCALES {
        elastic_options.gravity = Some(ir663_mass_table(&model, scale)?);
        let scaled = calibrate(&model, &identification, &elastic_options)?;
        mass_scaled.push(MassScaleFigures {
            scale,
            inside: (&scaled.validate(&model, &validation_set, false)?.after).into(),
            outside: (&scaled.validate(&model, &outside_set, false)?.after).into(),
            loaded: loaded::loaded_errors(&model, &scaled, &loaded_set, &payload)?,
        });
    }
    let elasto_description = elasto_geometric.description(&model)?;
    flexcal_io::write_atomic(
        dir.join("calibrated_elasto_geometric.toml"),
        elasto_description.to_toml_string(),
    )?;
    let noise_floor_position_mean_mm = {
        let sigmas: Vec<f64> = validation_set
            .measurements()
            .iter()
            .filter_map(|m| m.position_std.map(|s| s.norm() / 3f64.sqrt()))
            .collect();
        let sigma = sigmas.iter().sum::<f64>() / sigmas.len().max(1) as f64;
        2.0 * (2.0 / std::f64::consts::PI).sqrt() * sigma * 1e3
    };
    let calibrated = calibration.description(&model)?;
    flexcal_io::write_atomic(dir.join("calibrated.toml"), calibrated.to_toml_string())?;
    let report =
        flexcal_calib::CalibrationReportJson::new(model.name(), &calibration, Some(&validation));
    flexcal_io::write_atomic(dir.join("report.json"), report.to_json_string()?)?;
    let non_identifiable: Vec<String> = calibration
        .unknowns
        .iter()
        .take(model.n_params())
        .filter(|u| u.status == UnknownStatus::NonIdentifiable)
        .map(|u| u.name.clone())
        .collect();
    let summary = GeometricSummary {
        rank: calibration.rank(),
        parameters: model.n_params(),
        non_identifiable,
        validation_before: (&validation.before).into(),
        validation_after: (&validation.after).into(),
        elasto_geometric: (&elasto_geometric_validation.after).into(),
        noise_floor_position_mean_mm,
        noise_position_std_per_axis_um: camera.position_std_per_axis() * 1e6,
        noise_position_std_per_axis_independent_leds_um: camera
            .position_std_per_axis_independent_leds()
            * 1e6,
        outside_box: OutsideBoxFigures {
            poses: outside_set.len(),
            before: (&validation_outside.before).into(),
            geometric: (&validation_outside.after).into(),
            elasto_geometric: (&elasto_geometric_outside.after).into(),
        },
        loaded: loaded_figures(
            &model,
            (&calibration, &elasto_geometric),
            &loaded_set,
            campaign.payload_weighed_n,
        )?,
        mass_estimate: ir663_mass_estimate(),
        mass_scaled,
    };
    observer.finished(&format!(
        "geometric calibration: rank {} of {}, validation mean {:.3} mm / {:.3} deg -> geometric {:.3} mm / {:.3} deg, elasto-geometric {:.3} mm / {:.3} deg (noise floor {:.3} mm); outside box (59) {:.3} -> geometric {:.3} mm, elasto-geometric {:.3} mm; with {:.0} N at the TCP {:.3} -> geometric {:.3} mm, elasto-geometric {:.3} mm",
        summary.rank,
        summary.parameters,
        summary.validation_before.position_mean_mm,
        summary.validation_before.orientation_mean_deg,
        summary.validation_after.position_mean_mm,
        summary.validation_after.orientation_mean_deg,
        summary.elasto_geometric.position_mean_mm,
        summary.elasto_geometric.orientation_mean_deg,
        summary.noise_floor_position_mean_mm,
        summary.outside_box.before.position_mean_mm,
        summary.outside_box.geometric.position_mean_mm,
        summary.outside_box.elasto_geometric.position_mean_mm,
        summary.loaded.payload_weighed_n,
        summary.loaded.before.position_mean_mm,
        summary.loaded.geometric.position_mean_mm,
        summary.loaded.elasto_geometric.position_mean_mm
    ));
    let identification_q: Vec<Vec<f64>> =
        identification.poses().iter().map(|p| p.q.clone()).collect();
    let mut data = Data::new(&model);
    let sensitivity =
        sensitivity_indices(&model, &mut data, &identification_q, model.nominal_params())?;
    Ok(GeometricResults {
        model,
        true_xi: campaign.true_xi,
        calibration,
        validation,
        elasto_geometric,
        elasto_geometric_validation,
        sensitivity,
        summary,
    })
}

fn elastic_step(out: &Path, seed: u64, observer: &mut dyn StudyObserver) -> Result<ElasticResults> {
    let dir = out.join("elastic");
    observer.started("elastic campaign on the virtual IR-663 (63 poses x 8 load sets)");
    let campaign = flexcal_twin::elastic::write_elastic_campaign(
        &dir,
        &ElasticCampaignOptions {
            seed,
            ..Default::default()
        },
    )?;
    observer.finished(&format!(
        "elastic campaign: {} load sets written, true deflection under 1100 N vertical {:.2}-{:.2} mm over the grid",
        campaign.data_files.len(),
        campaign.deflection_norm_1100n_z_mm[0],
        campaign.deflection_norm_1100n_z_mm[1]
    ));
    observer.started(
        "parametric stiffness identification (differential evolution + Levenberg-Marquardt)",
    );
    let robot = crate::load_robot("ir663")?;
    let description = ElasticDescription::builtin("ir663")?;
    let stiffness = identify_stiffness_in_dir(
        &robot,
        &description,
        &dir,
        &StiffnessWorkflowOptions {
            seed,
            ..StiffnessWorkflowOptions::default()
        },
    )?;
    stiffness.report.write(dir.join("stiffness_report.json"))?;
    let identifiability = &stiffness.fitted.identifiability;
    let mut not_separable: Vec<String> = identifiability
        .groups
        .iter()
        .flat_map(|g| g.members.iter().cloned())
        .collect();
    not_separable.extend(identifiability.undetermined.iter().cloned());
    observer.finished(&format!(
        "stiffness identification: structural rank {} of {}, Table 5 overall RMS {:.3} mm (noise floor {:.3} mm)",
        identifiability.structural_rank,
        identifiability.names.len(),
        stiffness.table.overall_rms_mm,
        stiffness.noise_floor_mm
    ));
    observer.started(
        "fuzzy compliance model (joint fit of C_xx, C_xz, C_zx, C_zz; Solis-Wets placement, structure growth)",
    );
    let compliance = identify_compliance_in_dir(
        &robot,
        &dir,
        &ComplianceWorkflowOptions {
            seed,
            ..ComplianceWorkflowOptions::default()
        },
    )?;
    compliance
        .fitted
        .compliance
        .write(dir.join("fuzzy_compliance.toml"))?;
    let grid: Vec<String> = compliance.fitted.compliance.models()[0]
        .structure()
        .membership_counts()
        .iter()
        .map(usize::to_string)
        .collect();
    observer.finished(&format!(
        "fuzzy compliance: {} membership functions per input, Table 5 overall RMS {:.3} mm in the x-z plane (noise floor {:.3} mm)",
        grid.join(" x "),
        compliance.table.overall_rms_mm,
        compliance.noise_floor_mm
    ));
    let campaign_measurements: Vec<flexcal_elastic::campaign::DeflectionMeasurement> = stiffness
        .sets
        .iter()
        .flat_map(|s| s.measurements.clone())
        .collect();
    let on_grid = same_metric(&robot, &campaign_measurements, &stiffness, &compliance)?;
    let held_out_dir = dir.join("held_out");
    flexcal_twin::elastic::write_held_out_campaign(
        &held_out_dir,
        &ElasticCampaignOptions {
            seed,
            ..Default::default()
        },
    )?;
    let held_out_measurements: Vec<flexcal_elastic::campaign::DeflectionMeasurement> =
        flexcal_elastic::campaign::read_campaign_dir(&held_out_dir, robot.n_actuated())?
            .into_iter()
            .flat_map(|s| s.measurements)
            .collect();
    let held_out = same_metric(&robot, &held_out_measurements, &stiffness, &compliance)?;
    observer.finished(&format!(
        "held out ({} poses off the grid, 650 N at angles): RMS parametric {:.3} mm, fuzzy {:.3} mm in the x-z plane (noise floor {:.3} mm)",
        held_out_measurements.len(),
        held_out.plane_xz.parametric.all.rms_mm,
        held_out.plane_xz.fuzzy.all.rms_mm,
        held_out.plane_xz.noise_floor_mm
    ));
    let summary = ElasticSummary {
        parametric: (&stiffness.table).into(),
        fuzzy: (&compliance.table).into(),
        stiffness_non_identifiable: not_separable,
        same_metric: on_grid,
        held_out,
    };
    let vertical = match largest_vertical_set(&stiffness.sets) {
        Some(set) => Some(vertical_figures(&robot, set, &stiffness, &compliance)?),
        None => None,
    };
    let surface = compliance_surface(&compliance)?;
    Ok(ElasticResults {
        campaign,
        stiffness,
        compliance,
        vertical,
        surface,
        summary,
    })
}

/// Both elastic models' residuals on the measurements `all`, on the same
/// metrics: the x-z plane and 3-D (the fuzzy model predicts no y
/// deflection).
fn same_metric(
    robot: &Model,
    all: &[flexcal_elastic::campaign::DeflectionMeasurement],
    stiffness: &StiffnessOutcome,
    compliance: &ComplianceOutcome,
) -> Result<Table5Comparison> {
    use flexcal_elastic::metrics::{ResidualSample, per_load_metrics};
    let fe = flexcal_elastic::identify::residual_samples(
        &stiffness.model,
        all,
        robot.nominal_params(),
        &stiffness.fitted.gamma,
    )?;
    let inputs = RobotInputs::resolve(robot, &["theta2", "theta8"])?;
    let samples = compliance_samples(robot, &inputs, all)?;
    let fuzzy_xz = compliance.fitted.compliance.residual_samples(&samples)?;
    // The fuzzy model's prediction along y is zero: its 3-D residual there
    // is minus the measured y deflection.
    let fuzzy_3d: Vec<ResidualSample> = fuzzy_xz
        .iter()
        .zip(all)
        .map(|(r, m)| {
            let mut residual = r.residual;
            residual.y = -m.deflection.y;
            ResidualSample {
                load_n: r.load_n,
                residual,
            }
        })
        .collect();
    let plane = |samples: &[ResidualSample]| -> Vec<ResidualSample> {
        samples
            .iter()
            .map(|r| {
                let mut residual = r.residual;
                residual.y = 0.0;
                ResidualSample {
                    load_n: r.load_n,
                    residual,
                }
            })
            .collect()
    };
    let floor = |axes: &[usize]| -> f64 {
        let sum: f64 = all
            .iter()
            .map(|m| axes.iter().map(|&a| m.sigma[a] * m.sigma[a]).sum::<f64>())
            .sum();
        (sum / all.len().max(1) as f64).sqrt() * 1e3
    };
    Ok(Table5Comparison {
        plane_xz: SameMetric {
            parametric: (&per_load_metrics(&plane(&fe))).into(),
            fuzzy: (&per_load_metrics(&plane(&fuzzy_xz))).into(),
            noise_floor_mm: floor(&[0, 2]),
        },
        three_d: SameMetric {
            parametric: (&per_load_metrics(&fe)).into(),
            fuzzy: (&per_load_metrics(&fuzzy_3d)).into(),
            noise_floor_mm: floor(&[0, 1, 2]),
        },
    })
}

/// The deflection set with the largest vertical load (Figs. 9, 10, 14, 15).
fn largest_vertical_set(sets: &[DeflectionSet]) -> Option<&DeflectionSet> {
    sets.iter()
        .filter(|set| {
            set.measurements
                .first()
                .is_some_and(|m| m.wrench[2].abs() > m.wrench[0].abs())
        })
        .max_by(|a, b| a.load_n().total_cmp(&b.load_n()))
}

fn vertical_figures(
    robot: &Model,
    set: &DeflectionSet,
    stiffness: &StiffnessOutcome,
    compliance: &ComplianceOutcome,
) -> Result<VerticalLoadFigures> {
    let m = &set.measurements;
    let fe = flexcal_elastic::identify::residual_samples(
        &stiffness.model,
        m,
        robot.nominal_params(),
        &stiffness.fitted.gamma,
    )?;
    let inputs = RobotInputs::resolve(robot, &["theta2", "theta8"])?;
    let samples = compliance_samples(robot, &inputs, m)?;
    let fuzzy = compliance.fitted.compliance.residual_samples(&samples)?;
    let grid = TcpGrid::of_measurements(robot, m)?;
    let relative = |residuals: &[flexcal_elastic::metrics::ResidualSample]| {
        grid.lay_out(|k| 100.0 * residuals[k].residual.norm() / m[k].deflection.norm().max(1e-12))
    };
    Ok(VerticalLoadFigures {
        load_n: set.load_n(),
        measured_z_mm: m.iter().map(|x| x.deflection.z * 1e3).collect(),
        parametric_z_mm: m
            .iter()
            .zip(&fe)
            .map(|(x, r)| (x.deflection.z + r.residual.z) * 1e3)
            .collect(),
        fuzzy_z_mm: m
            .iter()
            .zip(&fuzzy)
            .map(|(x, r)| (x.deflection.z + r.residual.z) * 1e3)
            .collect(),
        deflection_norm_mm: grid.lay_out(|k| m[k].deflection.norm() * 1e3),
        parametric_error_percent: relative(&fe),
        fuzzy_error_percent: relative(&fuzzy),
    })
}

fn compliance_surface(compliance: &ComplianceOutcome) -> Result<Option<ComplianceSurface>> {
    let model = &compliance.fitted.compliance;
    let c_xx = &model.models()[0];
    let partitions = c_xx.structure().partitions();
    if partitions.len() != 2 {
        return Ok(None);
    }
    let n = 25;
    let axis = |p: &flexcal_fuzzy::Partition| -> Vec<f64> {
        let (lo, hi) = (p.lower(), p.upper());
        (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect()
    };
    let xs = axis(&partitions[0]);
    let ys = axis(&partitions[1]);
    let mut grid = vec![vec![f64::NAN; n]; n];
    for (r, y) in ys.iter().enumerate() {
        for (c, x) in xs.iter().enumerate() {
            grid[r][c] = model.compliance_matrix(&[*x, *y])?[(0, 0)] * 1e6;
        }
    }
    Ok(Some(ComplianceSurface {
        xs_deg: xs.iter().map(|x| x.to_degrees()).collect(),
        ys_deg: ys.iter().map(|y| y.to_degrees()).collect(),
        c_xx_mm_per_kn: grid,
    }))
}

fn forming_step(
    out: &Path,
    seed: u64,
    geometric: &GeometricResults,
    elastic: &ElasticResults,
    observer: &mut dyn StudyObserver,
) -> Result<FormingResults> {
    use crate::forming::{UserCell, run_forming, user_beam};
    use flexcal_twin::forming::{FormingOptions, TwinCell, forming_path};
    let options = FormingOptions {
        seed,
        ..FormingOptions::default()
    };
    observer.started(&format!(
        "forming experiment: plunge 25 mm, travel 200 mm, {:.0} N dead weight",
        options.dead_weight_n
    ));
    let robot = &geometric.model;
    // The twin's truth (its own robot, bar, contact and weight); the user's
    // side below has the identified models only.
    let twin = TwinCell::new(TruthSwitches::default())?;
    let s = &elastic.stiffness;
    let identified_model = flexcal_elastic::model::ElasticModel::new(robot, s.model.description())?;
    let fe = flexcal_elastic::tcp::FeTcpModel::new(
        identified_model,
        geometric.calibration.xi.clone(),
        s.fitted.gamma.clone(),
        "identified FE beam model",
    )?;
    let dir = out.join("forming");
    flexcal_io::write_atomic(
        dir.join("target_path.csv"),
        flexcal_compensate::path::target_path_to_csv(&forming_path(&options)),
    )?;
    let fuzzy =
        RobotFuzzyCompliance::new(elastic.compliance.fitted.compliance.clone(), robot.clone())?;
    // The part is located by the camera; the user carries its pose into the
    // calibrated robot's base frame through the registered camera frame.
    let user = UserCell {
        robot,
        calibrated_xi: &geometric.calibration.xi,
        x_meas_base: Some(geometric.calibration.x_meas_base),
        beam: user_beam(),
    };
    let result = run_forming(
        &twin,
        &user,
        &[
            ("compensated, fuzzy model", &fuzzy),
            ("compensated, FE beam model", &fe),
        ],
        &options,
    )?;
    flexcal_io::write_atomic(
        dir.join("forming_result.json"),
        to_json(&result, "forming result")? + "\n",
    )?;
    let summary = FormingSummary::of(&result);
    let models: Vec<String> = summary
        .compensations
        .iter()
        .map(|c| {
            format!(
                "{} {:.3} mm ({:.0} %; whole path {:.3} mm)",
                c.model,
                c.max_deviation_contact_mm,
                c.improvement_contact_percent,
                c.max_deviation_path_mm
            )
        })
        .collect();
    observer.finished(&format!(
        "forming, {} contact points: max deviation along z_p {:.3} mm uncompensated (whole path {:.3} mm) -> {}",
        summary.contact_points,
        summary.uncompensated_contact_mm,
        summary.uncompensated_path_mm,
        models.join(", ")
    ));
    Ok(FormingResults { result, summary })
}
