//! `flexcal calibrate`: geometric identification from a measurement file,
//! with optional validation on another file.

use std::path::{Path, PathBuf};

use anyhow::Context;
use flexcal_calib::{
    Calibration, CalibrationOptions, CalibrationReportJson, ErrorStatistics, FrameTreatment,
    MeasurementSet, Method, UnknownKind, UnknownStatus, ValidationReport, Weighting, calibrate,
};
use flexcal_kinematics::{Model, RobotDescription};

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
    /// Robot: a built-in name (ur10, ir663, puma560) or a description file (.toml).
    #[arg(long)]
    pub robot: String,
    /// Identification measurements.
    #[arg(long)]
    pub data: PathBuf,
    /// Format of the measurement files.
    #[arg(long, value_enum, default_value = "own")]
    pub format: DataFormat,
    /// Validation measurements (same format), ideally other poses.
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Parameters to keep at nominal, comma-separated (robot parameters or
    /// frame_x..frame_rz, target_x..target_rz).
    #[arg(long, value_delimiter = ',')]
    pub fix: Vec<String>,
    /// Parameters to leave out of the base set first when the data cannot
    /// separate them (default for ir663: the paper's six).
    #[arg(long, value_delimiter = ',')]
    pub defer: Vec<String>,
    /// Identification model.
    #[arg(long, value_enum, default_value = "geometric")]
    pub model: ModelKind,
    /// Solver.
    #[arg(long, value_enum, default_value = "lm")]
    pub method: SolverKind,
    /// Row weighting (default: file for the own format, uniform for ipa).
    #[arg(long, value_enum)]
    pub weights: Option<WeightsKind>,
    /// Ignore measured orientations.
    #[arg(long)]
    pub position_only: bool,
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
    /// Fail instead of freezing non-identifiable parameters.
    #[arg(long)]
    pub strict: bool,
    /// Write the calibrated robot description here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// Loads a robot by built-in name or description file.
pub fn load_robot(robot: &str) -> anyhow::Result<Model> {
    let path = Path::new(robot);
    let description = if path.exists() || robot.ends_with(".toml") {
        RobotDescription::from_toml_file(path)?
    } else {
        RobotDescription::builtin(robot)?
    };
    description
        .build()
        .with_context(|| format!("robot `{robot}`"))
}

fn read_set(path: &Path, format: DataFormat) -> anyhow::Result<MeasurementSet> {
    Ok(match format {
        DataFormat::Own => MeasurementSet::read_csv(path)?,
        DataFormat::Ipa => MeasurementSet::read_ipa(path)?,
    })
}

/// Runs `flexcal calibrate`.
pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let ModelKind::Geometric = args.model;
    let model = load_robot(&args.robot)?;
    let data = read_set(&args.data, args.format)?;
    let validation_set = args
        .validate
        .as_deref()
        .map(|p| read_set(p, args.format))
        .transpose()?;
    let mut options = CalibrationOptions::for_model(&model);
    options.method = match args.method {
        SolverKind::Lm => Method::LevenbergMarquardt,
        SolverKind::Gn => Method::GaussNewton,
    };
    options.weighting = match args.weights.unwrap_or(match args.format {
        DataFormat::Own => WeightsKind::File,
        DataFormat::Ipa => WeightsKind::Uniform,
    }) {
        WeightsKind::File => Weighting::FromFile,
        WeightsKind::Uniform => Weighting::Uniform,
    };
    if args.position_only || args.format == DataFormat::Ipa {
        options.use_orientation = Some(false);
    }
    options.fixed = args
        .fix
        .iter()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect();
    if !args.defer.is_empty() {
        options.deferred = args.defer.iter().map(|s| s.trim().to_string()).collect();
    }
    if args.fixed_frame {
        options.measurement_frame = FrameTreatment::Fixed;
    }
    if args.fixed_target {
        options.target = FrameTreatment::Fixed;
    }
    options.require_full_rank = args.strict;
    println!(
        "Calibrating `{}` ({} parameters) from {} poses of {}",
        model.name(),
        model.n_params(),
        data.len(),
        args.data.display()
    );
    let calibration = calibrate(&model, &data, &options).context("identification")?;
    print_identification(&calibration);
    let validation = validation_set
        .as_ref()
        .map(|set| calibration.validate(&model, set, args.refit_target))
        .transpose()
        .context("validation")?;
    print_before_after(&calibration, validation.as_ref());
    if let Some(out) = &args.out {
        let description = calibration.description(&model)?;
        flexcal_io::write_atomic(out, description.to_toml_string())?;
        println!("calibrated robot written to {}", out.display());
    }
    if let Some(path) = &args.report {
        let report = CalibrationReportJson::new(model.name(), &calibration, validation.as_ref());
        flexcal_io::write_atomic(path, report.to_json_string()?)?;
        println!("report written to {}", path.display());
    }
    Ok(())
}

fn status(s: UnknownStatus) -> &'static str {
    match s {
        UnknownStatus::Identified => "identified",
        UnknownStatus::Fixed => "fixed",
        UnknownStatus::NonIdentifiable => "NON-IDENTIFIABLE",
        UnknownStatus::PoorlyIdentifiable => "poorly identifiable",
        UnknownStatus::NoInfluence => "no influence",
    }
}

fn print_identification(c: &Calibration) {
    println!();
    println!("Identifiability and identified values (lengths mm, angles deg)");
    println!(
        "{:<10} {:>19} {:>14} {:>12} {:>12}  status",
        "unknown", "nominal", "identified", "delta", "std error"
    );
    for u in &c.unknowns {
        let scale = match u.kind {
            UnknownKind::Length => 1e3,
            UnknownKind::Angle => 180.0 / std::f64::consts::PI,
        };
        let se = u
            .standard_error
            .map(|s| format!("{:12.5}", s * scale))
            .unwrap_or_else(|| format!("{:>12}", "-"));
        println!(
            "{:<10} {:>19.5} {:>14.5} {:>12.5} {se}  {}",
            u.name,
            u.initial * scale,
            u.value * scale,
            (u.value - u.initial) * scale,
            status(u.status)
        );
    }
    println!(
        "rank {} of {} free unknowns; condition number {:.3e}",
        c.rank(),
        c.identifiability.names.len(),
        c.solve.condition_number
    );
    let non = c.non_identifiable();
    if !non.is_empty() {
        println!(
            "not identifiable from these poses (kept at nominal): {}",
            non.join(", ")
        );
        println!("the identified values stand for the combinations:");
        for line in &c.combination_lines {
            println!("  {line}");
        }
    }
    let poor = c.poorly_identifiable();
    if !poor.is_empty() {
        println!(
            "poorly identifiable (standard error above the limit; kept at nominal): {}",
            poor.join(", ")
        );
    }
    println!();
    println!("Iteration history (cost 1/2 |W r|^2, every solve in order)");
    for (k, cost) in c.cost_history.iter().enumerate() {
        println!("  {k:3}  {cost:.6e}");
    }
    println!(
        "termination: {:?} after {} iterations",
        c.solve.termination, c.solve.iterations
    );
}

fn row(label: &str, s: &ErrorStatistics) {
    let o = s
        .orientation_mean_rms_max
        .map(|(m, r, x)| {
            format!(
                "{:10.4} {:10.4} {:10.4}",
                m.to_degrees(),
                r.to_degrees(),
                x.to_degrees()
            )
        })
        .unwrap_or_default();
    println!(
        "{label:<24} {:5} {:10.4} {:10.4} {:10.4} {o}",
        s.n_poses,
        s.position_mean * 1e3,
        s.position_rms * 1e3,
        s.position_max * 1e3
    );
}

fn print_before_after(c: &Calibration, validation: Option<&ValidationReport>) {
    println!();
    println!(
        "{:<24} {:>5} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "errors", "poses", "mean mm", "rms mm", "max mm", "mean deg", "rms deg", "max deg"
    );
    row("identification before", &c.training_before);
    row("identification after", &c.training_after);
    if let Some(v) = validation {
        row("validation before", &v.before);
        row("validation after", &v.after);
        println!("validation: {}", v.frame_note);
    }
}
