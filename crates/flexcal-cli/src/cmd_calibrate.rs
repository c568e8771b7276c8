//! `flexcal calibrate`: geometric identification from a measurement file,
//! with optional validation on another file.

use std::path::PathBuf;

use anyhow::Context;
use flexcal::calib::{CalibrationOptions, FrameTreatment, Method, Weighting};
use flexcal::calibration::{
    CalibrationConfig, CalibrationOutputs, MeasurementFormat, run_calibration,
};
use flexcal::kinematics::Model;
use flexcal::targets::run_target_calibration;

/// Measurement file formats.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataFormat {
    /// flexcal's CSV (q1..qn, x_mm, y_mm, z_mm, ...).
    Own,
    /// IPA laser-tracker export (`;`, decimal comma, T-Mac probe).
    Ipa,
}

/// Identification models.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    /// Geometric parameters (+ measurement frame and target offset).
    Geometric,
    /// Geometric parameters plus joint compliances under gravity and the
    /// payload's mass and centre (mass table: --masses, a URDF's inertials,
    /// or built-in for ur10).
    ElastoGeometric,
}

/// Solvers.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverKind {
    /// Levenberg-Marquardt.
    Lm,
    /// Gauss-Newton re-linearisation (the paper's iteration).
    Gn,
}

/// Row weighting.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum WeightsKind {
    /// 1/sigma from the file's standard deviations.
    File,
    /// Uniform (default for the IPA format, whose std columns are sample spreads).
    Uniform,
}

/// Arguments of `flexcal calibrate`.
#[derive(clap::Args, Debug)]
pub struct CalibrateArgs {
    /// Robot: a built-in name (ur10, ir663, puma560) or a robot file (.toml, .urdf, .par).
    #[arg(long)]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// Identification measurements. Give it again for each further station
    /// (another placement of the tracker, another campaign of the same
    /// robot and target): the files are pooled, each with its own
    /// measurement frame (`frame_s2_x`, ...), and pose labels carry the
    /// station's number (`--exclude s2:line 534`).
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// Format of the measurement files.
    #[arg(long, value_enum, default_value = "own")]
    pub format: DataFormat,
    /// Validation measurements (same format), ideally other poses.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Parameters to keep at nominal, comma-separated (robot parameters or
    /// frame_x..frame_rz, target_x..target_rz; frame_s2_x.. of a second
    /// station).
    #[arg(long, value_delimiter = ',')]
    pub fix: Vec<String>,
    /// Parameters to leave out of the base set first when the data cannot
    /// separate them (default for ir663: the paper's six).
    #[arg(long, value_delimiter = ',')]
    pub defer: Vec<String>,
    /// Identification model.
    #[arg(long, value_enum, default_value = "geometric")]
    pub model: ModelKind,
    /// Mass table of the elasto-geometric model (TOML, see the README);
    /// default: a URDF robot's `<inertial>` masses, else the robot's
    /// built-in table (ur10).
    #[arg(long)]
    pub masses: Option<PathBuf>,
    /// Solver.
    #[arg(long, value_enum, default_value = "lm")]
    pub method: SolverKind,
    /// Row weighting (default: file for the own format, uniform for ipa).
    #[arg(long, value_enum)]
    pub weights: Option<WeightsKind>,
    /// Ignore measured orientations.
    #[arg(long)]
    pub position_only: bool,
    /// With --format ipa, use the probe's measured orientations too (the
    /// dataset's protocol, and the default, uses positions only).
    #[arg(long, conflicts_with = "position_only")]
    pub with_orientation: bool,
    /// The measurements are already in the robot base frame: do not identify
    /// the measurement frame.
    #[arg(long)]
    pub fixed_frame: bool,
    /// Keep the target offset at its nominal value (the TCP, or the IPA probe offset).
    #[arg(long)]
    pub fixed_target: bool,
    /// On validation, re-fit the target offset too (not only the measurement frame).
    #[arg(long)]
    pub refit_target: bool,
    /// Starting position of the target in the end frame, `x,y,z` (mm),
    /// instead of the file's nominal (the IPA probe offset) or the TCP: a
    /// probe offset known from elsewhere (hand-eye calibration, another
    /// series). It stays there along the directions the poses cannot
    /// identify, and everywhere with --fixed-target.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub target_mm: Vec<f64>,
    /// Noise-aware rank: a length unknown whose standard error would exceed
    /// this is kept at nominal (mm; default 5).
    #[arg(long)]
    pub max_se_length_mm: Option<f64>,
    /// Same for angles (deg; default 0.25).
    #[arg(long)]
    pub max_se_angle_deg: Option<f64>,
    /// An absolute limit for the compliances: one whose standard error
    /// exceeds it is left at its start (urad/N.m; default 1000, which never
    /// binds: compliances are judged on their own scale, --min-compliance-z).
    #[arg(long, allow_hyphen_values = true)]
    pub max_se_compliance: Option<f64>,
    /// A compliance is kept when its value is at least this many standard
    /// errors (default 2); one the fit puts this far below zero is held at
    /// zero.
    #[arg(long, allow_hyphen_values = true)]
    pub min_compliance_z: Option<f64>,
    /// A joint whose gravity torque spans less than this share of the most
    /// loaded joint's keeps its compliance at the start (default 0.05; 0
    /// lets every loaded joint's compliance in).
    #[arg(long, allow_hyphen_values = true)]
    pub min_torque_share: Option<f64>,
    /// The instrument's noise, one standard deviation per position axis
    /// (mm): weighs every observation and replaces the noise estimated
    /// from the fit in the standard errors and identifiability judgements.
    #[arg(long, allow_hyphen_values = true)]
    pub noise_mm: Option<f64>,
    /// With --noise-mm and fitted orientations: the instrument's noise per
    /// orientation axis (deg).
    #[arg(long, requires = "noise_mm", allow_hyphen_values = true)]
    pub noise_deg: Option<f64>,
    /// Fail instead of freezing non-identifiable parameters.
    #[arg(long)]
    pub strict: bool,
    /// Leave these identification poses out, comma-separated, by the label
    /// the reports print (`line 534` for the IPA format, a pose_id or `#k`);
    /// a bare number N stands for `line N`. With --targets every target of
    /// the pose is left out, or one as the data checks name it
    /// (`right at p7`).
    #[arg(long, value_delimiter = ',')]
    pub exclude: Vec<String>,
    /// The same for the validation poses.
    #[arg(long, value_delimiter = ',')]
    pub exclude_validation: Vec<String>,
    /// Check the standard errors: identify the same unknowns on odd / even
    /// and first / second halves of the poses and compare (about twice the
    /// identification time).
    #[arg(long)]
    pub split_check: bool,
    /// With several --data files (stations): hold each out in turn,
    /// identify on the others (the model selected on them) and validate on
    /// it, its measurement frame re-fitted (one more identification per
    /// station).
    #[arg(long)]
    pub hold_out_stations: bool,
    /// Check what transfers: identify the same unknowns again on the
    /// validation set and compare them in combined standard errors
    /// (needs --validate).
    #[arg(long, requires = "validate")]
    pub cross_check: bool,
    /// Also fit a fuzzy residual model of the remaining position errors over
    /// these actuated coordinates (comma-separated, e.g. theta2,theta3), on
    /// the identification poses only, and report the validation with it
    /// separately.
    #[arg(long, value_delimiter = ',')]
    pub residual_model: Vec<String>,
    /// Model selection on the training poses: which groups of unknowns
    /// (offsets, tilts, compliances, joint law, cyclic errors) to identify,
    /// by cross-validation (cv), BIC (bic) or none (default: cv from 100
    /// poses, else none).
    #[arg(long)]
    pub select: Option<flexcal::calib::SelectionMethod>,
    /// Predicted accuracy at the configurations of this CSV (columns
    /// q1..qn), written beside it as `<name>.accuracy.csv`.
    #[arg(long)]
    pub accuracy_map: Option<PathBuf>,
    /// Several targets per pose: their description (TOML: name, frame,
    /// offset_mm, identify), the measurement files having per-target
    /// columns `<target>_x_mm..` (docs/file-formats.md).
    #[arg(long)]
    pub targets: Option<PathBuf>,
    /// Write the calibrated robot description here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the HTML report here (errors, selection, unknowns, predicted
    /// bounds and the accuracy map as charts).
    #[arg(long)]
    pub html: Option<PathBuf>,
    /// Write the per-pose errors after calibration here (CSV: the validation
    /// set when given, else the identification set).
    #[arg(long)]
    pub residuals: Option<PathBuf>,
}

/// Runs `flexcal calibrate`: flags -> [`CalibrationConfig`] ->
/// [`run_calibration`] (or [`run_target_calibration`] with `--targets`) ->
/// print and write.
pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let model = crate::robot_arg::load_model(&args.robot, &args.robot_file)?;
    let config = config(&args, &model)?;
    let outputs = CalibrationOutputs {
        residuals: args.residuals,
        accuracy_grid: args.accuracy_map,
        description: args.out,
        report: args.report,
        html: args.html,
    };
    let written = if config.targets.is_some() {
        let run = run_target_calibration(&model, &config)?;
        print!("{}", run.summary_text(&model));
        run.write_outputs(&model, &outputs)?
    } else {
        let run = run_calibration(&model, &config)?;
        print!("{}", run.summary_text(&model));
        run.write_outputs(&model, &outputs)?
    };
    written.iter().for_each(|line| println!("{line}"));
    Ok(())
}

/// The validated configuration of a run from the flags.
fn config(args: &CalibrateArgs, model: &Model) -> anyhow::Result<CalibrationConfig> {
    if !args.exclude_validation.is_empty() && args.validate.is_none() {
        crate::usage_bail!("--exclude-validation needs --validate");
    }
    let format = match args.format {
        DataFormat::Own => MeasurementFormat::Own,
        DataFormat::Ipa => MeasurementFormat::Ipa,
    };
    let mut options = CalibrationOptions::for_model(model);
    options.method = match args.method {
        SolverKind::Lm => Method::LevenbergMarquardt,
        SolverKind::Gn => Method::GaussNewton,
    };
    options.weighting = match args.weights {
        Some(WeightsKind::File) => Weighting::FromFile,
        Some(WeightsKind::Uniform) => Weighting::Uniform,
        None => format.default_weighting(),
    };
    if args.with_orientation && args.format != DataFormat::Ipa {
        crate::usage_bail!(
            "--with-orientation is for --format ipa (flexcal's own files use their orientation columns when present)"
        );
    }
    if args.position_only || !(args.with_orientation || format.uses_orientation_by_default()) {
        options.use_orientation = Some(false);
    }
    options.fixed = crate::list_items(&args.fix);
    if !args.defer.is_empty() {
        options.deferred = args.defer.iter().map(|s| s.trim().to_string()).collect();
    }
    if args.fixed_frame {
        options.measurement_frame = FrameTreatment::Fixed;
    }
    if args.fixed_target {
        options.target = FrameTreatment::Fixed;
    }
    let target_mm = match args.target_mm[..] {
        [] => None,
        [x, y, z] => Some([x, y, z]),
        _ => crate::usage_bail!(
            "--target-mm takes three values x,y,z (mm), got {}",
            args.target_mm.len()
        ),
    };
    options.require_full_rank = args.strict;
    if let Some(v) = args.max_se_length_mm {
        options.max_standard_error_length = v * 1e-3;
    }
    if let Some(v) = args.max_se_angle_deg {
        options.max_standard_error_angle = v.to_radians();
    }
    let positive = |flag: &str, v: f64| -> anyhow::Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            crate::usage_bail!("{flag} must be a finite number > 0, got {v}")
        }
    };
    if let Some(v) = args.max_se_compliance {
        options.max_standard_error_compliance = positive("--max-se-compliance", v)? * 1e-6;
    }
    if let Some(v) = args.min_compliance_z {
        options.min_compliance_z = positive("--min-compliance-z", v)?;
    }
    if let Some(v) = args.min_torque_share {
        if !(0.0..1.0).contains(&v) {
            crate::usage_bail!("--min-torque-share must be in [0, 1), got {v}");
        }
        options.min_torque_share = v;
    }
    if let Some(v) = args.noise_mm {
        options.instrument_noise = Some(flexcal::calib::InstrumentNoise {
            position_std: positive("--noise-mm", v)? * 1e-3,
            orientation_std: args
                .noise_deg
                .map(|d| positive("--noise-deg", d).map(f64::to_radians))
                .transpose()?,
        });
    }
    if args.model == ModelKind::ElastoGeometric {
        options.gravity = Some(
            flexcal::RobotSpec::parse(&args.robot)?
                .mass_table(&args.robot_file.options(), model, args.masses.as_deref())
                .context("--model elasto-geometric")?,
        );
    } else if args.masses.is_some() {
        crate::usage_bail!("--masses is for --model elasto-geometric");
    }
    Ok(CalibrationConfig {
        format,
        validate: args.validate.clone(),
        exclude: crate::list_items(&args.exclude),
        exclude_validation: crate::list_items(&args.exclude_validation),
        target_mm,
        refit_target: args.refit_target,
        split_check: args.split_check,
        hold_out_stations: args.hold_out_stations,
        cross_check: args.cross_check,
        residual_inputs: crate::list_items(&args.residual_model),
        selection: args.select,
        accuracy_grid: args.accuracy_map.clone(),
        targets: args.targets.clone(),
        station_data: args.data[1..].to_vec(),
        ..CalibrationConfig::new(&args.data[0], options)
    })
}
