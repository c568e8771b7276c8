//! The calibration workflow behind `flexcal calibrate`: read the
//! identification (and validation) measurements, leave out the poses the
//! user names, identify (geometric or elasto-geometric model, paper section
//! 3), validate on the second set, and run the optional checks (split-half,
//! cross-series, fuzzy residual model), in one call that returns every
//! typed result; [`CalibrationRun::report`] gathers them into the JSON
//! report ([`calib::CalibrationReportJson`]).
//!
//! The options of the identification itself are a
//! [`calib::CalibrationOptions`] inside [`CalibrationConfig`]; the workflow
//! adds what needs the measurement files (the target's starting position
//! keeps the files' nominal orientation).
//!
//! [`CalibrationRun::summary_text`] is the human-readable summary of a run
//! (the text `flexcal calibrate` prints); [`text`] has its pieces.
//! [`CalibrationRun::html_report`] is the same run as an HTML page with its
//! charts ([`html`]).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use crate::calib::{
    self, Calibration, CalibrationOptions, CalibrationReportJson, CrossCheck, MeasurementSet,
    PoseError, ResidualModel, ResidualModelJson, SplitCheck, ValidationReport,
};
use crate::{Error, Result};

pub mod html;
pub mod targets;
pub mod text;

/// Format of a measurement file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum MeasurementFormat {
    /// flexcal's CSV (`q1..qn, x_mm, y_mm, z_mm, ...`, `docs/file-formats.md`).
    #[default]
    Own,
    /// The IPA laser-tracker export (`;`, decimal comma, T-Mac probe pose).
    Ipa,
}

impl MeasurementFormat {
    /// Reads the measurement file `path` in this format.
    ///
    /// # Errors
    /// The file's read or parse error, naming the file and line.
    pub fn read(self, path: &Path) -> Result<MeasurementSet> {
        Ok(match self {
            Self::Own => MeasurementSet::read_csv(path)?,
            Self::Ipa => MeasurementSet::read_ipa(path)?,
        })
    }

    /// The row weighting that suits the format: 1/sigma from the file's
    /// standard deviations for flexcal's own files, uniform for the IPA
    /// export (whose std columns are sample spreads, not uncertainties).
    pub fn default_weighting(self) -> calib::Weighting {
        match self {
            Self::Own => calib::Weighting::FromFile,
            Self::Ipa => calib::Weighting::Uniform,
        }
    }

    /// Whether measured orientations are used unless asked otherwise:
    /// flexcal's own files use their orientation columns when present; the
    /// IPA dataset's protocol uses the probe's positions only.
    pub fn uses_orientation_by_default(self) -> bool {
        self == Self::Own
    }
}

/// Everything a calibration run needs besides the robot.
#[derive(Debug, Clone)]
pub struct CalibrationConfig {
    /// Identification measurements.
    pub data: PathBuf,
    /// Identification measurements of further stations (same format):
    /// pooled with `data` ([`MeasurementSet::pooled`]), each file with its
    /// own measurement frame, the robot and the target shared. Pose labels
    /// then carry the station's number (`s2:line 534`), `exclude` included.
    pub station_data: Vec<PathBuf>,
    /// Format of both measurement files.
    pub format: MeasurementFormat,
    /// Validation measurements (same format), ideally other poses.
    pub validate: Option<PathBuf>,
    /// Identification poses to leave out, by label (`line 534`, a
    /// `pose_id`, `#k`; a bare number N stands for `line N`).
    pub exclude: Vec<String>,
    /// Validation poses to leave out, by label.
    pub exclude_validation: Vec<String>,
    /// Options of the identification (model, unknowns, solver, weighting).
    pub options: CalibrationOptions,
    /// Starting position of the target in the end frame (mm), instead of
    /// the file's nominal or the TCP; the orientation stays the file's.
    pub target_mm: Option<[f64; 3]>,
    /// On validation, re-fit the target offset too (not only the
    /// measurement frame).
    pub refit_target: bool,
    /// Run the split-half check of the standard errors.
    pub split_check: bool,
    /// With several stations: hold each out in turn, identify on the
    /// others (model selection included) and validate on it
    /// ([`calib::hold_out_stations`]).
    pub hold_out_stations: bool,
    /// Identify again on the validation set and compare (needs `validate`).
    pub cross_check: bool,
    /// Actuated coordinates of the fuzzy residual model (none: no model).
    pub residual_inputs: Vec<String>,
    /// Model selection on the identification poses (`None`: cross-validation
    /// from [`calib::MIN_POSES_FOR_CROSS_VALIDATION`] poses, else none; see
    /// [`calib::default_method`]).
    pub selection: Option<calib::SelectionMethod>,
    /// Which cross-validated score the selection chooses on (default
    /// [`calib::SelectOn::Auto`]: the extrapolating folds when the
    /// accuracy map's grid, where the robot is to be used, leaves the
    /// training poses' range, [`calib::SelectionOptions::region`]; the
    /// validation poses never choose the model).
    pub select_on: calib::SelectOn,
    /// Score every candidate on the extrapolating folds even when the
    /// ordinary scores choose
    /// ([`calib::SelectionOptions::every_extrapolation_score`]; default
    /// `false`: the models the search moved through only).
    pub every_extrapolation_score: bool,
    /// Configurations (CSV `q1..qn`) at which to predict the accuracy of the
    /// calibrated robot ([`CalibrationRun::accuracy_map`]).
    pub accuracy_grid: Option<PathBuf>,
    /// Add to the predicted bounds (validation coverage and accuracy map)
    /// the model's error growth outside the training ranges, from folds
    /// that hold out the ends of each coordinate's range
    /// ([`calib::Calibration::extrapolation`]: two more identifications
    /// per actuated coordinate).
    pub extrapolation: bool,
    /// Targets description (TOML) of measurement files with several
    /// targets per pose (`docs/file-formats.md`): [`run_calibration`] then
    /// reads them with it (own CSV format only; no target start, target
    /// re-fit or residual model).
    pub targets: Option<PathBuf>,
}

impl CalibrationConfig {
    /// A geometric calibration of `data` with `options` and no checks.
    pub fn new(data: impl Into<PathBuf>, options: CalibrationOptions) -> Self {
        Self {
            data: data.into(),
            station_data: Vec::new(),
            format: MeasurementFormat::Own,
            validate: None,
            exclude: Vec::new(),
            exclude_validation: Vec::new(),
            options,
            target_mm: None,
            refit_target: false,
            split_check: false,
            hold_out_stations: false,
            cross_check: false,
            residual_inputs: Vec::new(),
            selection: None,
            select_on: calib::SelectOn::Auto,
            every_extrapolation_score: false,
            accuracy_grid: None,
            extrapolation: false,
            targets: None,
        }
    }
}

/// Poses left out of a set on the user's request.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Exclusion {
    /// The configuration field (`--exclude` or `--exclude-validation`).
    pub option: String,
    /// Number of poses left out.
    pub left_out: usize,
    /// Number of poses of the set before.
    pub total: usize,
    /// The set's file.
    pub source: String,
    /// With several targets per pose: the observations left out (those of
    /// the poses left out included) and the set's observations before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observations: Option<(usize, usize)>,
}

impl std::fmt::Display for Exclusion {
    /// `--exclude: 3 of the 1495 poses of B.csv left out`, with several
    /// targets `--exclude: 1 of the 60 poses (2 of the 120 observations) of
    /// markers.csv left out`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} of the {} poses{} of {} left out",
            self.option,
            self.left_out,
            self.total,
            self.observations
                .map(|(o, total)| format!(" ({o} of the {total} observations)"))
                .unwrap_or_default(),
            self.source
        )
    }
}

/// The fuzzy residual model and its validation.
#[derive(Debug, Clone)]
pub struct ResidualFit {
    /// The inputs (actuated coordinates).
    pub inputs: Vec<String>,
    /// The model, fitted on the identification poses.
    pub model: ResidualModel,
    /// The validation with the model's correction added.
    pub validation: Option<ValidationReport>,
}

/// Every result of a calibration run, of one target per pose or of
/// several ([`CalibrationRun::several_targets`]).
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationRun {
    /// The identification set (exclusions applied).
    pub data: MeasurementSet,
    /// The validation set (exclusions applied).
    pub validation_set: Option<MeasurementSet>,
    /// What was left out of each set ([`CalibrationConfig::exclude`],
    /// [`CalibrationConfig::exclude_validation`]): whole poses, or, with
    /// several targets, single observations named `<target> at <pose>`
    /// ([`MeasurementSet::excluding`]).
    pub exclusions: Vec<Exclusion>,
    /// The model selection, when one ran (`config.selection`; by default
    /// cross-validation from [`calib::MIN_POSES_FOR_CROSS_VALIDATION`]
    /// poses).
    pub selection: Option<calib::SelectionReport>,
    /// The identification options actually used (those of the selected
    /// model; not in the JSON: the campaign holds the options asked for,
    /// the selection what it chose).
    #[serde(skip)]
    pub options: CalibrationOptions,
    /// The identification (of the selected model).
    pub calibration: Calibration,
    /// The validation, with a validation set (the measurement frame fitted
    /// again on it: the instrument may have moved).
    pub validation: Option<ValidationReport>,
    /// The split-half check, when asked for.
    pub split: Option<SplitCheck>,
    /// Predicted 95 % bounds at the validation observations and the share
    /// of them that the measured errors respect, with a validation set.
    pub coverage: Option<calib::AccuracyMap>,
    /// Predicted accuracy at the configurations of
    /// [`CalibrationConfig::accuracy_grid`] (of every target).
    pub accuracy_map: Option<calib::AccuracyMap>,
    /// The cross-series check, when asked for.
    pub cross: Option<CrossCheck>,
    /// Each station held out in turn, when asked for.
    pub station_hold_out: Vec<calib::StationHoldOut>,
    /// The fuzzy residual model, when asked for (one target per pose; not
    /// in the serialised run: the JSON report has its figures).
    #[serde(skip)]
    pub residual: Option<ResidualFit>,
}

impl CalibrationRun {
    /// Whether the run's set has several targets per pose (read with a
    /// targets description), rather than the one target `tcp`: its text,
    /// page and JSON then give per-target figures.
    pub fn several_targets(&self) -> bool {
        !self.data.is_one_target()
    }

    /// The per-pose errors after calibration: of the validation set when
    /// there is one, else of the identification set; with the set's name
    /// (`validation`, `identification`) and the set.
    pub fn per_pose(&self) -> (&'static str, &MeasurementSet, Cow<'_, [PoseError]>) {
        match (&self.validation, &self.validation_set) {
            (Some(v), Some(set)) => ("validation", set, Cow::Borrowed(&v.after_per_pose[..])),
            _ => (
                "identification",
                &self.data,
                Cow::Owned(
                    self.calibration
                        .observation_errors
                        .iter()
                        .map(PoseError::from)
                        .collect(),
                ),
            ),
        }
    }

    /// The JSON report of the run (`docs/calibration-report.md`).
    pub fn report(&self, robot: &crate::kinematics::Model) -> CalibrationReportJson {
        let mut report =
            CalibrationReportJson::new(robot.name(), &self.calibration, self.validation.as_ref());
        report.split_check = self.split.clone();
        report.cross_check = self.cross.clone();
        report.station_hold_out = self
            .station_hold_out
            .iter()
            .map(calib::StationHoldOutJson::from)
            .collect();
        report.selection = self.selection.clone();
        report.extrapolation = self
            .coverage
            .iter()
            .chain(&self.accuracy_map)
            .find_map(|map| map.extrapolation.clone());
        report.residual_model = self.residual.as_ref().map(|r| {
            ResidualModelJson::new(robot.actuated_names(), &r.model, r.validation.as_ref())
        });
        report
    }
}

/// The files a calibration run writes (none by default).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CalibrationOutputs {
    /// The per-pose errors after calibration (CSV, [`CalibrationRun::per_pose`]).
    pub residuals: Option<PathBuf>,
    /// The configurations file of the accuracy map: the predicted accuracy
    /// is written beside it as `<name>.accuracy.csv`.
    pub accuracy_grid: Option<PathBuf>,
    /// The calibrated robot description (TOML).
    pub description: Option<PathBuf>,
    /// The JSON report ([`CalibrationRun::report`]).
    pub report: Option<PathBuf>,
    /// The self-contained HTML page of the run
    /// ([`CalibrationRun::html_report`]): errors, selection, unknowns,
    /// measured errors against their predicted bounds, the accuracy map.
    pub html: Option<PathBuf>,
}

impl CalibrationRun {
    /// Writes the files `outputs` names, each atomically, and returns one
    /// line per file written saying what it holds.
    ///
    /// # Errors
    /// The file that could not be written; a calibrated description that
    /// cannot be built.
    pub fn write_outputs(
        &self,
        robot: &crate::kinematics::Model,
        outputs: &CalibrationOutputs,
    ) -> Result<Vec<String>> {
        if self.several_targets() {
            return self.write_target_outputs(robot, outputs);
        }
        let mut written = Vec::new();
        if let Some(path) = &outputs.residuals {
            let (name, set, errors) = self.per_pose();
            calib::temperature::write_pose_errors(path, set, &errors)?;
            written.push(format!(
                "per-pose errors of the {name} set written to {}",
                path.display()
            ));
        }
        if let (Some(grid), Some(map)) = (&outputs.accuracy_grid, &self.accuracy_map) {
            let path = grid.with_extension("accuracy.csv");
            map.write_csv(&path)?;
            written.push(format!(
                "predicted accuracy at {} poses written to {}{}",
                map.poses.len(),
                path.display(),
                extrapolation_note(map)
            ));
        }
        if let Some(path) = &outputs.description {
            let description = self.calibration.description(robot)?;
            flexcal_io::write_atomic(path, description.to_toml_string())?;
            written.push(format!("calibrated robot written to {}", path.display()));
        }
        if let Some(path) = &outputs.report {
            flexcal_io::write_atomic(path, self.report(robot).to_json_string()?)?;
            written.push(format!("report written to {}", path.display()));
        }
        if let Some(path) = &outputs.html {
            flexcal_io::write_atomic(path, self.html_report(robot).to_html())?;
            written.push(format!("HTML report written to {}", path.display()));
        }
        Ok(written)
    }
}

/// Names the workflow step of a calibration error.
fn step(step: &'static str) -> impl FnOnce(calib::CalibError) -> Error {
    move |source| Error::CalibrationStep { step, source }
}

/// The identification files, one station each: `config.data` then
/// `config.station_data`.
///
/// # Errors
/// [`Error::InvalidParameter`] for a file given twice: two stations that
/// saw the very same poses are a slip of the command line, not a campaign.
pub(crate) fn station_files(config: &CalibrationConfig) -> Result<Vec<&PathBuf>> {
    let files: Vec<&PathBuf> = std::iter::once(&config.data)
        .chain(&config.station_data)
        .collect();
    if let Some((k, path)) = files
        .iter()
        .enumerate()
        .find(|(k, p)| files[..*k].contains(p))
    {
        return Err(Error::InvalidParameter {
            parameter: "station_data".into(),
            message: format!(
                "{} is given twice (as station {} and an earlier one): each file is one station",
                path.display(),
                k + 1
            ),
        });
    }
    Ok(files)
}

/// The growth of `calibration`'s error outside its training ranges
/// ([`calib::Calibration::extrapolation`]) when the configuration asks for
/// it and there are bounds to widen (a validation set, an accuracy grid).
pub(crate) fn extrapolation_growth(
    config: &CalibrationConfig,
    has_validation: bool,
    (robot, calibration, data, options): (
        &crate::kinematics::Model,
        &calib::Calibration,
        &MeasurementSet,
        &calib::CalibrationOptions,
    ),
) -> Result<Option<calib::ExtrapolationModel>> {
    (config.extrapolation && (has_validation || config.accuracy_grid.is_some()))
        .then(|| calibration.extrapolation(robot, data, options))
        .transpose()
        .map_err(step("held-out-range folds"))
}

/// `map` with the error growth outside the training ranges added to its
/// bounds, when there is one.
pub(crate) fn widened(
    map: calib::AccuracyMap,
    extrapolation: Option<&calib::ExtrapolationModel>,
) -> calib::AccuracyMap {
    match extrapolation {
        Some(e) => map.with_extrapolation(e),
        None => map,
    }
}

/// The configurations the calibrated robot is to be used at, as far as
/// the run knows them: the accuracy map's grid
/// ([`calib::SelectionOptions::region`]). The validation poses are not
/// part of it: a validation set judges the model and never chooses it
/// (given with `--validate`, it would otherwise change the calibration).
fn region_of_use(config: &CalibrationConfig) -> Result<Vec<Vec<f64>>> {
    match &config.accuracy_grid {
        Some(grid) => calib::read_configurations(grid).map_err(step("--accuracy-map")),
        None => Ok(Vec::new()),
    }
}

/// The accuracy map at the configurations of
/// [`CalibrationConfig::accuracy_grid`] (`None` without one), predicted by
/// `predict`.
pub(crate) fn grid_accuracy(
    config: &CalibrationConfig,
    predict: impl FnOnce(&[Vec<f64>]) -> std::result::Result<calib::AccuracyMap, calib::CalibError>,
) -> Result<Option<calib::AccuracyMap>> {
    let Some(grid) = &config.accuracy_grid else {
        return Ok(None);
    };
    let configurations = calib::read_configurations(grid).map_err(step("--accuracy-map"))?;
    predict(&configurations)
        .map(Some)
        .map_err(step("--accuracy-map"))
}

fn read_excluding(
    path: &Path,
    format: MeasurementFormat,
    labels: &[String],
    option: &'static str,
    exclusions: &mut Vec<Exclusion>,
) -> Result<MeasurementSet> {
    exclude(format.read(path)?, labels, option, exclusions)
}

/// `set` without the poses labelled `labels`, the exclusion recorded.
pub(crate) fn exclude(
    set: MeasurementSet,
    labels: &[String],
    option: &'static str,
    exclusions: &mut Vec<Exclusion>,
) -> Result<MeasurementSet> {
    if labels.is_empty() {
        return Ok(set);
    }
    let kept = set.excluding(labels).map_err(step(option))?;
    exclusions.push(Exclusion {
        option: option.to_string(),
        left_out: set.len() - kept.len(),
        total: set.len(),
        source: set.source.clone(),
        // A one-target set has one observation per pose.
        observations: (!set.is_one_target()).then(|| {
            (
                set.n_observations() - kept.n_observations(),
                set.n_observations(),
            )
        }),
    });
    Ok(kept)
}

/// Runs a calibration of `robot` as `config` says: of one target per
/// pose, or of several when `config.targets` describes them (then the
/// own CSV format only, and no target start, target re-fit or residual
/// model).
///
/// # Errors
/// A setting of `config` a run with several targets cannot take, by name;
/// unreadable measurement files (file and line), labels that name no pose,
/// a non-finite `target_mm`, `cross_check` or `exclude_validation` without a
/// validation set, and every error of the identification and its checks,
/// named by step (`identification`, `validation`, ...): a rank-deficient
/// system with `require_full_rank`, unknown parameter names.
pub fn run_calibration(
    robot: &crate::kinematics::Model,
    config: &CalibrationConfig,
) -> Result<CalibrationRun> {
    let targets = match &config.targets {
        Some(_) => Some(targets::check_targets_config(config)?),
        None => {
            check_one_target_config(config)?;
            None
        }
    };
    let mut exclusions = Vec::new();
    let (data, validation_set) = match targets {
        Some(path) => targets::read_target_sets(config, path, &mut exclusions)?,
        None => read_one_target_sets(config, &mut exclusions)?,
    };
    let mut options = config.options.clone();
    if let Some(start) = target_start(config, &data)? {
        options.target_value = Some(start);
    }
    let selection_options = calib::SelectionOptions {
        method: config
            .selection
            .unwrap_or_else(|| calib::default_method(&data)),
        // With several targets the selection does not take the region of
        // use yet: it chooses on the training poses' folds.
        select_on: if targets.is_some() {
            calib::SelectOn::default()
        } else {
            config.select_on
        },
        region: if targets.is_some() {
            Vec::new()
        } else {
            region_of_use(config)?
        },
        every_extrapolation_score: config.every_extrapolation_score,
        ..Default::default()
    };
    // The options before selection, for the stations held out (each
    // selects its own model on the other stations).
    let base_options = options.clone();
    let (calibration, selection, options) =
        calib::calibrate_selected(robot, &data, &options, &selection_options)
            .map_err(step("identification"))?;
    let split = config
        .split_check
        .then(|| SplitCheck::new(robot, &data, &options, &calibration))
        .transpose()
        .map_err(step("split-half check on halves of the poses"))?;
    let validation = validation_set
        .as_ref()
        .map(|set| calibration.validate(robot, set, config.refit_target))
        .transpose()
        .map_err(step("validation"))?;
    let extrapolation = extrapolation_growth(
        config,
        validation_set.is_some(),
        (robot, &calibration, &data, &options),
    )?;
    let with_extrapolation = |map| widened(map, extrapolation.as_ref());
    // The bounds against the errors of the validation just made, unless
    // that one re-fitted the target too (the bounds are for the target as
    // identified).
    let coverage = validation_set
        .as_ref()
        .zip(validation.as_ref())
        .map(|(set, report)| {
            if config.refit_target {
                calibration.accuracy_coverage(robot, set, split.as_ref())
            } else {
                calibration.accuracy_coverage_of(robot, set, report, split.as_ref())
            }
        })
        .transpose()
        .map_err(step("predicted accuracy at the validation poses"))?
        .map(with_extrapolation);
    let accuracy_map = grid_accuracy(config, |configurations| {
        calibration
            .predicted_accuracy(robot, configurations, split.as_ref())
            .map(with_extrapolation)
    })?;
    let station_hold_out = if config.hold_out_stations {
        calib::hold_out_stations(robot, &data, &base_options, &selection_options)
            .map_err(step("each station held out"))?
    } else {
        Vec::new()
    };
    let cross = match (&validation_set, config.cross_check) {
        (Some(set), true) => Some(
            CrossCheck::new(robot, set, &options, &calibration, split.as_ref())
                .map_err(step("cross-series check on the validation poses"))?,
        ),
        _ => None,
    };
    let residual = residual_fit(config, robot, &calibration, &data, validation_set.as_ref())?;
    Ok(CalibrationRun {
        data,
        validation_set,
        exclusions,
        options,
        calibration,
        split,
        validation,
        cross,
        station_hold_out,
        residual,
        selection,
        coverage,
        accuracy_map,
    })
}

/// The settings of `config` that a run of one target per pose cannot take
/// (validation options without a validation set).
fn check_one_target_config(config: &CalibrationConfig) -> Result<()> {
    let invalid = |parameter: &str, message: &str| Error::InvalidParameter {
        parameter: parameter.to_string(),
        message: message.to_string(),
    };
    if config.validate.is_none() {
        if !config.exclude_validation.is_empty() {
            return Err(invalid("exclude_validation", "needs a validation set"));
        }
        if config.cross_check {
            return Err(invalid("cross_check", "needs a validation set"));
        }
    }
    Ok(())
}

/// The identification set (one file, or one per station pooled) and the
/// validation set of `config`, each without its excluded poses (recorded
/// in `exclusions`).
fn read_one_target_sets(
    config: &CalibrationConfig,
    exclusions: &mut Vec<Exclusion>,
) -> Result<(MeasurementSet, Option<MeasurementSet>)> {
    let data = if config.station_data.is_empty() {
        read_excluding(
            &config.data,
            config.format,
            &config.exclude,
            "--exclude",
            exclusions,
        )?
    } else {
        let sets = station_files(config)?
            .iter()
            .map(|path| config.format.read(path))
            .collect::<Result<Vec<_>>>()?;
        let pooled = MeasurementSet::pooled(&sets).map_err(step("pooling the stations"))?;
        exclude(pooled, &config.exclude, "--exclude", exclusions)?
    };
    if config.hold_out_stations && data.n_stations() < 2 {
        return Err(Error::InvalidParameter {
            parameter: "hold_out_stations".into(),
            message: format!(
                "{} holds one station: holding one out needs measurements from at least two (--data A --data B)",
                data.source
            ),
        });
    }
    let validation_set = config
        .validate
        .as_deref()
        .map(|p| {
            read_excluding(
                p,
                config.format,
                &config.exclude_validation,
                "--exclude-validation",
                exclusions,
            )
        })
        .transpose()?;
    Ok((data, validation_set))
}

/// The target's starting pose of `config.target_mm` (its orientation the
/// file's nominal one), or `None` without it.
fn target_start(
    config: &CalibrationConfig,
    data: &MeasurementSet,
) -> Result<Option<Isometry3<f64>>> {
    let Some([x, y, z]) = config.target_mm else {
        return Ok(None);
    };
    if ![x, y, z].iter().all(|v| v.is_finite()) {
        return Err(Error::InvalidParameter {
            parameter: "--target-mm".into(),
            message: format!("values must be finite, got {x},{y},{z}"),
        });
    }
    let rotation = data
        .nominal_target()
        .map(|t| t.rotation)
        .unwrap_or_else(UnitQuaternion::identity);
    Ok(Some(Isometry3::from_parts(
        Translation3::new(x * 1e-3, y * 1e-3, z * 1e-3),
        rotation,
    )))
}

/// The fuzzy model of the residuals over `config.residual_inputs`, and the
/// validation with it; `None` without inputs.
fn residual_fit(
    config: &CalibrationConfig,
    robot: &crate::kinematics::Model,
    calibration: &Calibration,
    data: &MeasurementSet,
    validation_set: Option<&MeasurementSet>,
) -> Result<Option<ResidualFit>> {
    if config.residual_inputs.is_empty() {
        return Ok(None);
    }
    let inputs: Vec<&str> = config.residual_inputs.iter().map(String::as_str).collect();
    let model = ResidualModel::fit(
        robot,
        calibration,
        data,
        &inputs,
        &crate::fuzzy::FuzzyParams::default(),
        1,
    )
    .map_err(step("--residual-model"))?;
    let validation = validation_set
        .map(|set| {
            calibration.validate_with_residual_model(robot, set, &model, config.refit_target)
        })
        .transpose()
        .map_err(step("validation with the residual model"))?;
    Ok(Some(ResidualFit {
        inputs: config.residual_inputs.clone(),
        model,
        validation,
    }))
}

/// `"; N of them outside the identification poses' range ..."` when a map
/// holds extrapolated poses, else empty.
pub(crate) fn extrapolation_note(map: &calib::AccuracyMap) -> String {
    if map.extrapolated_poses == 0 {
        return String::new();
    }
    if let Some(extrapolation) = &map.extrapolation {
        let largest = map
            .poses
            .iter()
            .map(|p| p.parts.extrapolation_mm)
            .fold(0.0, f64::max);
        let notes = extrapolation.notes();
        return format!(
            "; {} of them outside the identification poses' range of some coordinate, whose bounds include the model's error growth outside the range measured by held-out-range folds (largest part {largest:.3} mm, column extrapolation_95_mm; {})",
            map.extrapolated_poses,
            if notes.is_empty() {
                "the folds found no growth".to_string()
            } else {
                notes.join("; ")
            }
        );
    }
    format!(
        "; {} of them outside the identification poses' range of some coordinate, where the bound assumes the model holds beyond the data (column outside_training_range)",
        map.extrapolated_poses
    )
}
