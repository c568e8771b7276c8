//! A calibration campaign as one file: everything `flexcal calibrate`
//! takes (the robot and its reading options, the measurement files of every
//! station, the targets description, the mass table, exclusions, the model
//! and its judgement, the checks, the validation set and the outputs) in a
//! typed, serialisable [`Campaign`], read from and written to TOML
//! ([`Campaign::read`], [`Campaign::write`], `docs/file-formats.md`), and
//! run in one call ([`Campaign::run`]).
//!
//! The command line is a campaign too: its flags build a [`Campaign`]
//! (merged over a campaign file's with `--config`), which is then run.
//! The JSON report and the HTML page of a run carry the campaign they were
//! run with ([`CampaignRun::write_outputs`]), so a result can be re-run from
//! its report ([`Campaign::from_report`]).
//!
//! Paths in a campaign file are relative to the file's folder (absolute
//! ones are kept); in memory they are as the program uses them (relative to
//! the working directory, or absolute). Units are those of the command
//! line: mm, deg and urad/N.m in fields named with their unit.
//!
//! Pipeline: [`Campaign::read`] (parse, resolve paths, check the input
//! files exist) -> [`Campaign::model`] (the robot) ->
//! [`Campaign::calibration_config`] (validated options) ->
//! [`Campaign::run`] -> [`CampaignRun::write_outputs`].

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::calib::{self, CalibrationOptions, FrameTreatment, SelectionMethod};
use crate::calibration::{
    CalibrationConfig, CalibrationOutputs, CalibrationRun, MeasurementFormat, run_calibration,
};
use crate::kinematics::{ImportOptions, Model};
use crate::report::{Report, Section};
use crate::{Error, Result, RobotSpec};

mod file;

pub use file::relative_path;

/// The identification model of a campaign.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// Geometric parameters (with the measurement frame and target offset).
    #[default]
    Geometric,
    /// Geometric parameters plus joint compliances under gravity and the
    /// payload's mass and centre (a mass table: [`ModelSection::masses`],
    /// a URDF's inertials, or a built-in robot's table).
    ElastoGeometric,
}

/// The iterative solver of the identification ([`calib::Method`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// Levenberg-Marquardt.
    #[default]
    Lm,
    /// Gauss-Newton re-linearisation (the paper's iteration).
    Gn,
}

impl From<SolverKind> for calib::Method {
    fn from(kind: SolverKind) -> Self {
        match kind {
            SolverKind::Lm => Self::LevenbergMarquardt,
            SolverKind::Gn => Self::GaussNewton,
        }
    }
}

/// How residual rows are weighted ([`calib::Weighting`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WeightsKind {
    /// 1/sigma from the file's standard deviations.
    File,
    /// Uniform (the IPA format's default: its std columns are sample spreads).
    Uniform,
}

impl From<WeightsKind> for calib::Weighting {
    fn from(kind: WeightsKind) -> Self {
        match kind {
            WeightsKind::File => Self::FromFile,
            WeightsKind::Uniform => Self::Uniform,
        }
    }
}

/// The robot of a campaign: a built-in one by `name`, or a description
/// `file`, with the options of URDF and `.par` files.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSection {
    /// A built-in robot (`ur10`, `ir663`, `puma560`, ...); exclusive with `file`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// A robot description file (`.toml`, `.urdf`, `.par`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// The tip link or frame (`--tip`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip: Option<String>,
    /// A URDF's root link (`--root`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub root: Option<String>,
    /// A `.par` file's symbol values (TOML, SI units; `--values`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub values: Option<PathBuf>,
}

/// The identification measurements.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSection {
    /// One file per station (`--data`, given once per file): pooled, each
    /// with its own measurement frame.
    pub files: Vec<PathBuf>,
    /// Format of every measurement file, the validation set's included.
    #[serde(default)]
    pub format: MeasurementFormat,
    /// Poses to leave out, by label (`--exclude`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude: Vec<String>,
    /// Targets description of files with several targets per pose (`--targets`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub targets: Option<PathBuf>,
}

/// The validation set.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationSection {
    /// Validation measurements (`--validate`), same format as the data.
    pub file: PathBuf,
    /// Validation poses to leave out (`--exclude-validation`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude: Vec<String>,
    /// Re-fit the target offset too on validation (`--refit-target`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub refit_target: bool,
}

/// The model, its unknowns, solver and judgement. Every field left out
/// takes the command line's default.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSection {
    /// Identification model (`--model`, default geometric).
    #[serde(default)]
    pub kind: ModelKind,
    /// Mass table of the elasto-geometric model (`--masses`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub masses: Option<PathBuf>,
    /// How the elastic deflection is computed: `one-step`, `equilibrium`
    /// or `auto` (`--deflection`; default the mass table's, else one
    /// step; [`crate::calib::Deflection`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deflection: Option<String>,
    /// Solver (`--method`, default lm).
    #[serde(default)]
    pub method: SolverKind,
    /// Row weighting (`--weights`; default: file for the own format,
    /// uniform for ipa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights: Option<WeightsKind>,
    /// Use measured orientations: false is `--position-only`, true
    /// `--with-orientation` (ipa only); default: the format's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation: Option<bool>,
    /// Parameters kept at nominal (`--fix`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fix: Vec<String>,
    /// Parameters left out of the base set first (`--defer`; default: the
    /// robot's own list).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub defer: Vec<String>,
    /// Do not identify the measurement frame (`--fixed-frame`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub fixed_frame: bool,
    /// Keep the target offset at its start (`--fixed-target`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub fixed_target: bool,
    /// Starting position of the target in the end frame, mm (`--target-mm`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_mm: Option<[f64; 3]>,
    /// Model selection: cv, bic or none (`--select`; default: cv from 100 poses).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "selection_name"
    )]
    pub select: Option<SelectionMethod>,
    /// Which cross-validated score the selection chooses on: interpolation,
    /// extrapolation or auto (`--select-on`; default auto: extrapolation
    /// when the validation poses or the accuracy map leave the training
    /// range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub select_on: Option<crate::calib::SelectOn>,
    /// Score every candidate on the extrapolating folds, also when the
    /// ordinary scores choose (`--every-extrapolation-score`; default: the
    /// models the search moved through only).
    #[serde(default, skip_serializing_if = "is_false")]
    pub every_extrapolation_score: bool,
    /// Fail instead of freezing non-identifiable parameters (`--strict`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub strict: bool,
    /// Largest standard error of an identified length, mm (`--max-se-length-mm`, default 5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_se_length_mm: Option<f64>,
    /// Largest standard error of an identified angle, deg (`--max-se-angle-deg`, default 0.25).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_se_angle_deg: Option<f64>,
    /// Absolute limit of a compliance's standard error, urad/N.m (`--max-se-compliance`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_se_compliance_urad_per_nm: Option<f64>,
    /// Standard errors a compliance needs to be kept (`--min-compliance-z`, default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_compliance_z: Option<f64>,
    /// Share of the most loaded joint's torque span a joint needs for its
    /// compliance to be identified (`--min-torque-share`, default 0.05).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_torque_share: Option<f64>,
    /// Instrument noise per position axis, mm (`--noise-mm`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_mm: Option<f64>,
    /// Instrument noise per orientation axis, deg (`--noise-deg`, needs `noise_mm`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_deg: Option<f64>,
}

/// The optional checks.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChecksSection {
    /// Split-half check of the standard errors (`--split-check`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub split: bool,
    /// Hold each station out in turn (`--hold-out-stations`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub hold_out_stations: bool,
    /// Identify again on the validation set and compare (`--cross-check`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub cross: bool,
    /// Actuated coordinates of a fuzzy residual model (`--residual-model`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub residual_model: Vec<String>,
    /// Configurations (CSV `q1..qn`) of the predicted-accuracy map
    /// (`--accuracy-map`), written beside it as `<name>.accuracy.csv`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accuracy_map: Option<PathBuf>,
    /// Bounds that include the model's error growth outside the training
    /// ranges, from held-out-range folds (`--extrapolation`).
    #[serde(default, skip_serializing_if = "is_false")]
    pub extrapolation: bool,
}

/// The files a run writes.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputsSection {
    /// The calibrated robot description (`--out`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibrated_robot: Option<PathBuf>,
    /// The JSON report (`--report`), with this campaign in its `config`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub report: Option<PathBuf>,
    /// The HTML page (`--html`), with this campaign's TOML.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub html: Option<PathBuf>,
    /// The per-pose errors after calibration (`--residuals`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residuals: Option<PathBuf>,
}

/// A model selection by the command line's names: `cv`, `bic`, `none`.
mod selection_name {
    use serde::{Deserialize, Deserializer, Serializer};

    use crate::calib::SelectionMethod;

    pub(super) fn serialize<S: Serializer>(
        method: &Option<SelectionMethod>,
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        match method {
            Some(SelectionMethod::CrossValidation) => serializer.serialize_str("cv"),
            Some(SelectionMethod::Bic) => serializer.serialize_str("bic"),
            Some(SelectionMethod::None) => serializer.serialize_str("none"),
            None => serializer.serialize_none(),
        }
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Option<SelectionMethod>, D::Error> {
        let name = String::deserialize(deserializer)?;
        name.parse().map(Some).map_err(serde::de::Error::custom)
    }
}

fn is_false(b: &bool) -> bool {
    !*b
}

fn is_default<T: Default + PartialEq>(t: &T) -> bool {
    *t == T::default()
}

/// A calibration campaign: everything one `flexcal calibrate` run takes.
/// The TOML tables are the fields (`[robot]`, `[data]`, `[validation]`,
/// `[model]`, `[checks]`, `[outputs]`); unknown keys are refused.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Campaign {
    /// The robot.
    pub robot: RobotSection,
    /// The identification measurements.
    pub data: DataSection,
    /// The validation set, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<ValidationSection>,
    /// The model and its options.
    #[serde(default)]
    pub model: ModelSection,
    /// The optional checks.
    #[serde(default, skip_serializing_if = "is_default")]
    pub checks: ChecksSection,
    /// The files to write.
    #[serde(default, skip_serializing_if = "is_default")]
    pub outputs: OutputsSection,
    /// The file the campaign was read from (named in its errors), if any.
    #[serde(skip)]
    pub source: Option<PathBuf>,
}

impl Campaign {
    /// An error about the campaign's `key` (the command line's `flag`):
    /// [`Error::Campaign`] naming the file when the campaign was read from
    /// one, else [`Error::InvalidParameter`] naming the flag.
    pub(crate) fn invalid(&self, key: &str, flag: &str, message: impl Into<String>) -> Error {
        match &self.source {
            Some(file) => Error::Campaign {
                origin: file.display().to_string(),
                key: key.to_string(),
                message: message.into(),
            },
            None => Error::InvalidParameter {
                parameter: flag.to_string(),
                message: message.into(),
            },
        }
    }

    /// The robot argument: the built-in name or the file.
    ///
    /// # Errors
    /// No robot, or both a name and a file; an unknown built-in name.
    pub fn robot_spec(&self) -> Result<RobotSpec> {
        match (&self.robot.name, &self.robot.file) {
            (Some(name), None) => RobotSpec::parse(name)
                .and_then(|spec| match spec {
                    RobotSpec::Builtin(_) => Ok(spec),
                    _ => Err(Error::UnknownRobot {
                        spec: name.clone(),
                        known: crate::kinematics::builtin_robot_names().join(", "),
                    }),
                })
                .map_err(|e| self.invalid("robot.name", "--robot", e.to_string())),
            (None, Some(file)) => Ok(RobotSpec::File(file.clone())),
            (None, None) => Err(self.invalid(
                "robot",
                "--robot",
                "no robot: a built-in `name` or a description `file`",
            )),
            (Some(_), Some(_)) => Err(self.invalid(
                "robot",
                "--robot",
                "give a built-in `name` or a description `file`, not both",
            )),
        }
    }

    /// The reading options of the robot's file.
    pub fn import_options(&self) -> ImportOptions {
        ImportOptions {
            tip: self.robot.tip.clone(),
            root: self.robot.root.clone(),
            values: self.robot.values.clone(),
        }
    }

    /// Reads and builds the campaign's robot.
    ///
    /// # Errors
    /// The robot's errors ([`RobotSpec::model_with`]).
    pub fn model(&self) -> Result<Model> {
        self.robot_spec()?.model_with(&self.import_options())
    }

    /// The validated configuration of the run, for the robot `model` (the
    /// campaign's: [`Campaign::model`]).
    ///
    /// # Errors
    /// A setting out of its range, or without meaning with the others,
    /// named by its key (and file) or by its flag; a mass table that
    /// cannot be read.
    pub fn calibration_config(&self, model: &Model) -> Result<CalibrationConfig> {
        let Some((first, stations)) = self.data.files.split_first() else {
            return Err(self.invalid(
                "data.files",
                "--data",
                "no measurement file: give one per station",
            ));
        };
        let validation = self.validation.as_ref();
        if self.checks.cross && validation.is_none() {
            return Err(self.invalid(
                "checks.cross",
                "--cross-check",
                "needs a validation set ([validation] file, --validate)",
            ));
        }
        let options = self.options(model)?;
        Ok(CalibrationConfig {
            format: self.data.format,
            validate: validation.map(|v| v.file.clone()),
            exclude: self.data.exclude.clone(),
            exclude_validation: validation.map(|v| v.exclude.clone()).unwrap_or_default(),
            target_mm: self.target_mm()?,
            refit_target: validation.is_some_and(|v| v.refit_target),
            split_check: self.checks.split,
            hold_out_stations: self.checks.hold_out_stations,
            cross_check: self.checks.cross,
            residual_inputs: self.checks.residual_model.clone(),
            selection: self.model.select,
            select_on: self.model.select_on.unwrap_or_default(),
            every_extrapolation_score: self.model.every_extrapolation_score,
            accuracy_grid: self.checks.accuracy_map.clone(),
            extrapolation: self.checks.extrapolation,
            targets: self.data.targets.clone(),
            station_data: stations.to_vec(),
            ..CalibrationConfig::new(first, options)
        })
    }

    fn target_mm(&self) -> Result<Option<[f64; 3]>> {
        match self.model.target_mm {
            Some(t) if !t.iter().all(|v| v.is_finite()) => Err(self.invalid(
                "model.target_mm",
                "--target-mm",
                format!("values must be finite, got {},{},{}", t[0], t[1], t[2]),
            )),
            other => Ok(other),
        }
    }

    /// A value that must be finite and > 0.
    fn positive(&self, key: &str, flag: &str, v: f64) -> Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.invalid(key, flag, format!("must be a finite number > 0, got {v}")))
        }
    }

    /// The identification options (SI) of the model section.
    fn options(&self, model: &Model) -> Result<CalibrationOptions> {
        let m = &self.model;
        let format = self.data.format;
        let mut options = CalibrationOptions::for_model(model);
        options.method = m.method.into();
        options.weighting = m
            .weights
            .map_or_else(|| format.default_weighting(), Into::into);
        match m.orientation {
            Some(true) if format != MeasurementFormat::Ipa => {
                return Err(self.invalid(
                    "model.orientation",
                    "--with-orientation",
                    "is for format ipa (--format ipa): flexcal's own files use their orientation columns when present",
                ));
            }
            Some(false) => options.use_orientation = Some(false),
            None if !format.uses_orientation_by_default() => options.use_orientation = Some(false),
            _ => {}
        }
        options.fixed = trimmed(&m.fix);
        if !m.defer.is_empty() {
            options.deferred = trimmed(&m.defer);
        }
        if m.fixed_frame {
            options.measurement_frame = FrameTreatment::Fixed;
        }
        if m.fixed_target {
            options.target = FrameTreatment::Fixed;
        }
        options.require_full_rank = m.strict;
        self.judgement(&mut options)?;
        match (m.kind, &m.masses) {
            (ModelKind::ElastoGeometric, masses) => {
                options.gravity = Some(
                    self.robot_spec()?
                        .mass_table(&self.import_options(), model, masses.as_deref())
                        .map_err(|e| self.invalid("model.masses", "--masses", format!("{e}")))?,
                );
            }
            (ModelKind::Geometric, Some(_)) => {
                return Err(self.invalid(
                    "model.masses",
                    "--masses",
                    "is for the elasto-geometric model (kind = \"elasto-geometric\", --model elasto-geometric)",
                ));
            }
            (ModelKind::Geometric, None) => {}
        }
        if let Some(name) = &m.deflection {
            let deflection: crate::calib::Deflection = name
                .parse()
                .map_err(|e: String| self.invalid("model.deflection", "--deflection", e))?;
            let Some(gravity) = options.gravity.as_mut() else {
                return Err(self.invalid(
                    "model.deflection",
                    "--deflection",
                    "is for the elasto-geometric model (--model elasto-geometric)",
                ));
            };
            gravity.deflection = deflection;
        }
        Ok(options)
    }

    /// The noise-aware judgement's thresholds and the instrument noise.
    fn judgement(&self, options: &mut CalibrationOptions) -> Result<()> {
        let m = &self.model;
        if let Some(v) = m.max_se_length_mm {
            options.max_standard_error_length = v * 1e-3;
        }
        if let Some(v) = m.max_se_angle_deg {
            options.max_standard_error_angle = v.to_radians();
        }
        if let Some(v) = m.max_se_compliance_urad_per_nm {
            options.max_standard_error_compliance = self.positive(
                "model.max_se_compliance_urad_per_nm",
                "--max-se-compliance",
                v,
            )? * 1e-6;
        }
        if let Some(v) = m.min_compliance_z {
            options.min_compliance_z =
                self.positive("model.min_compliance_z", "--min-compliance-z", v)?;
        }
        if let Some(v) = m.min_torque_share {
            if !(0.0..1.0).contains(&v) {
                return Err(self.invalid(
                    "model.min_torque_share",
                    "--min-torque-share",
                    format!("must be in [0, 1), got {v}"),
                ));
            }
            options.min_torque_share = v;
        }
        match (m.noise_mm, m.noise_deg) {
            (Some(mm), deg) => {
                options.instrument_noise = Some(calib::InstrumentNoise {
                    position_std: self.positive("model.noise_mm", "--noise-mm", mm)? * 1e-3,
                    orientation_std: deg
                        .map(|d| {
                            self.positive("model.noise_deg", "--noise-deg", d)
                                .map(f64::to_radians)
                        })
                        .transpose()?,
                });
            }
            (None, Some(_)) => {
                return Err(self.invalid("model.noise_deg", "--noise-deg", "needs noise_mm"));
            }
            (None, None) => {}
        }
        Ok(())
    }

    /// The files of the outputs section, for [`CalibrationRun::write_outputs`]
    /// (the report and HTML page are written by [`CampaignRun::write_outputs`]).
    fn calibration_outputs(&self) -> CalibrationOutputs {
        CalibrationOutputs {
            residuals: self.outputs.residuals.clone(),
            accuracy_grid: self.checks.accuracy_map.clone(),
            description: self.outputs.calibrated_robot.clone(),
            report: None,
            html: None,
        }
    }

    /// Runs the campaign: the robot, the validated configuration, then the
    /// calibration ([`run_calibration`]: of one target per pose or, with a
    /// targets description, of several).
    ///
    /// # Errors
    /// Those of [`Campaign::model`], [`Campaign::calibration_config`] and
    /// the calibration run.
    pub fn run(&self) -> Result<CampaignRun> {
        self.run_cancellable(None)
    }

    /// [`Campaign::run`] that stops within one solver iteration once
    /// `cancel` is cancelled (an interrupt from a caller's thread), with
    /// [`calib::CalibError::Cancelled`] named by its step.
    ///
    /// # Errors
    /// Those of [`Campaign::run`], and the cancellation.
    pub fn run_cancellable(&self, cancel: Option<calib::CancelToken>) -> Result<CampaignRun> {
        let robot = self.model()?;
        let mut config = self.calibration_config(&robot)?;
        config.options.cancel = cancel;
        let result = run_calibration(&robot, &config)?;
        Ok(CampaignRun {
            campaign: self.clone(),
            robot,
            result,
        })
    }
}

/// The items of a list, trimmed, empty ones dropped.
fn trimmed(items: &[String]) -> Vec<String> {
    items
        .iter()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

/// A campaign and what it gave.
#[derive(Debug, Clone)]
pub struct CampaignRun {
    /// The campaign run.
    pub campaign: Campaign,
    /// Its robot (nominal).
    pub robot: Model,
    /// The calibration (of one target per pose or of several).
    pub result: CalibrationRun,
}

impl CampaignRun {
    /// The run as text for a terminal (what `flexcal calibrate` prints).
    pub fn summary_text(&self) -> String {
        self.result.summary_text(&self.robot)
    }

    /// The JSON report (`docs/calibration-report.md`) with the campaign in
    /// its `config` section, paths relative to `folder` (the report's).
    ///
    /// # Errors
    /// A value that does not serialise.
    pub fn report_json(&self, folder: &Path) -> Result<String> {
        /// A report with the campaign after its own fields.
        #[derive(Serialize)]
        struct WithConfig<T: Serialize> {
            #[serde(flatten)]
            report: T,
            config: Campaign,
        }
        let config = self.campaign.relative_to(folder);
        let run = &self.result;
        let text = if run.several_targets() {
            serde_json::to_string_pretty(&WithConfig {
                report: run.json(),
                config,
            })
        } else {
            serde_json::to_string_pretty(&WithConfig {
                report: run.report(&self.robot),
                config,
            })
        };
        text.map_err(|source| Error::Json {
            context: "calibration report".into(),
            source,
        })
    }

    /// The HTML page of the run, ending with the campaign's TOML (paths
    /// relative to `folder`, the page's).
    pub fn html_report(&self, folder: &Path) -> Report {
        let mut page = self.result.html_report(&self.robot);
        let mut section = Section::new("Configuration");
        section.paragraph(
            "The campaign file of this run (flexcal calibrate --config FILE re-runs it; paths relative to this page's folder):",
        );
        section.code(self.campaign.to_toml_string(folder));
        page.push(section);
        page
    }

    /// Writes the files of the campaign's outputs section, each atomically
    /// (the report and the page with the campaign in them), and returns
    /// one line per file written saying what it holds.
    ///
    /// # Errors
    /// The file that could not be written; a calibrated description that
    /// cannot be built.
    pub fn write_outputs(&self) -> Result<Vec<String>> {
        let outputs = self.campaign.calibration_outputs();
        let mut written = self.result.write_outputs(&self.robot, &outputs)?;
        if let Some(path) = &self.campaign.outputs.report {
            flexcal_io::write_atomic(path, self.report_json(file::folder_of(path))?)?;
            written.push(format!("report written to {}", path.display()));
        }
        if let Some(path) = &self.campaign.outputs.html {
            flexcal_io::write_atomic(path, self.html_report(file::folder_of(path)).to_html())?;
            written.push(format!("HTML report written to {}", path.display()));
        }
        Ok(written)
    }
}
