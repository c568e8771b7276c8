//! `flexcal calibrate`: geometric identification from a measurement file,
//! with optional validation on another file.

use std::path::{Path, PathBuf};

use anyhow::Context;
use flexcal::calib::temperature::{TemperatureCheck, write_pose_errors};
use flexcal::calib::{
    Calibration, CalibrationOptions, CrossCheck, ErrorStatistics, FrameTreatment, MeasurementSet,
    Method, SplitCheck, UnknownStatus, ValidationReport, Weighting,
};
use flexcal::calibration::{CalibrationConfig, CalibrationRun, MeasurementFormat, run_calibration};
use flexcal::kinematics::Model;

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
    /// Fail instead of freezing non-identifiable parameters.
    #[arg(long)]
    pub strict: bool,
    /// Leave these identification poses out, comma-separated, by the label
    /// the reports print (`line 534` for the IPA format, a pose_id or `#k`);
    /// a bare number N stands for `line N`.
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
    /// Write the calibrated robot description here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the per-pose errors after calibration here (CSV: the validation
    /// set when given, else the identification set).
    #[arg(long)]
    pub residuals: Option<PathBuf>,
}

/// Runs `flexcal calibrate`: flags -> [`CalibrationConfig`] ->
/// [`run_calibration`] -> print and write.
pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let model = crate::robot_arg::load_model(&args.robot, &args.robot_file)?;
    let config = config(&args, &model)?;
    let run = run_calibration(&model, &config)?;
    print_run(&model, &args.data, &run);
    let (per_pose_name, per_pose_set, per_pose) = run.per_pose();
    if let Some(path) = &args.residuals {
        write_pose_errors(path, per_pose_set, per_pose)?;
        println!(
            "per-pose errors of the {per_pose_name} set written to {}",
            path.display()
        );
    }
    if let (Some(grid), Some(map)) = (&args.accuracy_map, &run.accuracy_map) {
        let path = grid.with_extension("accuracy.csv");
        map.write_csv(&path)?;
        println!(
            "predicted accuracy at {} poses written to {}",
            map.poses.len(),
            path.display()
        );
    }
    if let Some(out) = &args.out {
        let description = run.calibration.description(&model)?;
        flexcal::io::write_atomic(out, description.to_toml_string())?;
        println!("calibrated robot written to {}", out.display());
    }
    if let Some(path) = &args.report {
        flexcal::io::write_atomic(path, run.report(&model).to_json_string()?)?;
        println!("report written to {}", path.display());
    }
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
    options.weighting = match args.weights.unwrap_or(match args.format {
        DataFormat::Own => WeightsKind::File,
        DataFormat::Ipa => WeightsKind::Uniform,
    }) {
        WeightsKind::File => Weighting::FromFile,
        WeightsKind::Uniform => Weighting::Uniform,
    };
    if args.with_orientation && args.format != DataFormat::Ipa {
        crate::usage_bail!(
            "--with-orientation is for --format ipa (flexcal's own files use their orientation columns when present)"
        );
    }
    if args.position_only || (args.format == DataFormat::Ipa && !args.with_orientation) {
        options.use_orientation = Some(false);
    }
    options.fixed = crate::list_items(&args.fix)
        .into_iter()
        .map(String::from)
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
    if args.model == ModelKind::ElastoGeometric {
        options.gravity = Some(
            flexcal::RobotSpec::parse(&args.robot)?
                .mass_table(&args.robot_file.options(), model, args.masses.as_deref())
                .context("--model elasto-geometric")?,
        );
    } else if args.masses.is_some() {
        crate::usage_bail!("--masses is for --model elasto-geometric");
    }
    let items = |v: &[String]| -> Vec<String> {
        crate::list_items(v).into_iter().map(String::from).collect()
    };
    Ok(CalibrationConfig {
        format,
        validate: args.validate.clone(),
        exclude: items(&args.exclude),
        exclude_validation: items(&args.exclude_validation),
        target_mm,
        refit_target: args.refit_target,
        split_check: args.split_check,
        cross_check: args.cross_check,
        residual_inputs: items(&args.residual_model),
        selection: args.select,
        accuracy_grid: args.accuracy_map.clone(),
        ..CalibrationConfig::new(&args.data, options)
    })
}

/// Prints a run in the order of its steps.
fn print_run(model: &Model, data: &Path, run: &CalibrationRun) {
    for e in &run.exclusions {
        println!(
            "{}: {} of the {} poses of {} left out",
            e.option, e.left_out, e.total, e.source
        );
    }
    println!(
        "Calibrating `{}` ({} parameters{}) from {} poses of {}",
        model.name(),
        model.n_params(),
        if run.options.gravity.is_some() {
            ", elasto-geometric: joint compliances under gravity and the payload"
        } else {
            ""
        },
        run.data.len(),
        data.display()
    );
    if let Some(selection) = &run.selection {
        selection.lines().iter().for_each(|l| println!("{l}"));
    }
    print_identification(&run.calibration);
    if let Some(split) = &run.split {
        print_split_check(split);
    }
    print_before_after(&run.calibration, run.validation.as_ref());
    if let Some(map) = &run.coverage {
        println!(
            "predicted 95 % bounds (mean {:.3} mm) cover {:.1} % of the validation poses",
            map.mean_bound_95_mm,
            100.0 * map.coverage.unwrap_or(f64::NAN)
        );
    }
    if let Some(cross) = &run.cross {
        print_cross_check(cross);
    }
    if let Some(fit) = &run.residual {
        let r = &fit.model;
        println!();
        println!(
            "Fuzzy residual model over {} (fitted on the identification poses; not part of the robot model): {:?} rules for x, y, z; held-out RMS {:.4} / {:.4} / {:.4} mm",
            fit.inputs.join(", "),
            r.rule_counts(),
            r.reports[0].test.rmse * 1e3,
            r.reports[1].test.rmse * 1e3,
            r.reports[2].test.rmse * 1e3
        );
        if let Some(v) = &fit.validation {
            row("validation, + residual", &v.after);
        }
    }
    let (name, set, errors) = run.per_pose();
    print_temperature_analysis(name, set, errors);
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
    println!("Identifiability and identified values");
    println!(
        "{:<16} {:>9} {:>13} {:>14} {:>12} {:>12} {:>9}  status",
        "unknown", "unit", "nominal", "identified", "delta", "std error", "vs spread"
    );
    for u in &c.unknowns {
        let (unit, scale) = u.kind.display_unit();
        let se = u
            .standard_error
            .map(|s| format!("{:12.5}", s * scale))
            .unwrap_or_else(|| format!("{:>12}", "-"));
        let ratio = u
            .spread_ratio
            .map(|r| format!("{r:9.1}"))
            .unwrap_or_else(|| format!("{:>9}", "-"));
        println!(
            "{:<16} {unit:>9} {:>13.5} {:>14.5} {:>12.5} {se} {ratio}  {}",
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
    for note in c.identifiability_notes() {
        println!("note: {note}");
    }
    println!();
    println!(
        "Iteration history, every solve in order (cost 1/2 |W r|^2; RMS errors of the iterate)"
    );
    println!(
        "  {:>3}  {:>13}  {:>12}  {:>12}",
        "", "cost", "pos RMS mm", "rot RMS deg"
    );
    for (k, h) in c.residual_history.iter().enumerate() {
        let rotation = h
            .orientation_rms
            .map(|r| format!("{:12.5}", r.to_degrees()))
            .unwrap_or_default();
        println!(
            "  {k:3}  {:13.6e}  {:12.5}  {rotation}",
            h.cost,
            h.position_rms * 1e3
        );
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

/// Whether temperature explains the remaining error: its range over the set
/// and the correlation and slope of the position error against it.
fn print_temperature_analysis(
    name: &str,
    set: &MeasurementSet,
    errors: &[flexcal::calib::PoseError],
) {
    let Some(check) = TemperatureCheck::of(set, errors) else {
        return;
    };
    let (lo, hi) = (check.min_c, check.max_c);
    match (check.correlation, check.slope_mm_per_k) {
        (Some(r), Some(slope)) => println!(
            "temperature on the {name} set: {lo:.2} to {hi:.2} C; correlation of the position error with it r = {r:.3} (r^2 = {:.3}), slope {slope:.4} mm/K",
            r * r
        ),
        _ => println!("temperature on the {name} set: constant {lo:.2} C; no analysis"),
    }
}

/// `v` with `digits` decimals, or `-` when there is none.
fn dash_or(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.digits$}"))
}

fn print_split_check(split: &SplitCheck) {
    println!();
    println!("Split-half check (identified again on odd / even and first / second halves)");
    println!(
        "{:<16} {:>9} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12} {:>7}",
        "unknown", "unit", "std error", "odd", "even", "first", "second", "split err", "ratio"
    );
    for u in &split.unknowns {
        println!(
            "{:<16} {:>9} {:>12.5} {:>12} {:>12} {:>12} {:>12} {:>12} {:>7}",
            u.name,
            u.unit,
            u.standard_error,
            dash_or(u.half_values[0], 5),
            dash_or(u.half_values[1], 5),
            dash_or(u.half_values[2], 5),
            dash_or(u.half_values[3], 5),
            dash_or(u.split_error, 5),
            dash_or(u.ratio, 1)
        );
    }
    for note in split.notes() {
        println!("note: {note}");
    }
}

fn print_cross_check(cross: &CrossCheck) {
    println!();
    println!(
        "Cross-series check (identified again on the {} validation poses{})",
        cross.other_poses,
        if cross.unknowns.iter().any(|u| u.z_split.is_some()) {
            "; z split: each standard error raised to its split error where larger"
        } else {
            ""
        }
    );
    println!(
        "{:<18} {:>9} {:>14} {:>12} {:>14} {:>12} {:>7} {:>8}",
        "unknown", "unit", "identified", "std error", "validation set", "std error", "z", "z split"
    );
    for u in &cross.unknowns {
        println!(
            "{:<18} {:>9} {:>14.5} {:>12.5} {:>14} {:>12} {:>7} {:>8}",
            u.name,
            u.unit,
            u.value,
            u.standard_error,
            dash_or(u.other_value, 5),
            dash_or(u.other_standard_error, 5),
            dash_or(u.z, 1),
            dash_or(u.z_split, 1)
        );
    }
    for note in cross.notes() {
        println!("note: {note}");
    }
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
        if !v.extrapolated_coordinates.is_empty() {
            let list: Vec<String> = v
                .extrapolated_coordinates
                .iter()
                .map(|(name, f)| format!("{name} ({:.0} % of the poses)", f * 100.0))
                .collect();
            println!(
                "validation poses outside the identification poses' range of: {}",
                list.join(", ")
            );
        }
    }
    let validation_notes = validation.map(|v| v.data_checks.notes("validation"));
    for note in c
        .data_checks
        .notes("identification")
        .iter()
        .chain(validation_notes.iter().flatten())
    {
        println!("data check: {note}");
    }
    let checks = std::iter::once(("--exclude", &c.data_checks))
        .chain(validation.map(|v| ("--exclude-validation", &v.data_checks)));
    for (option, checks) in checks {
        if !checks.suspect_poses.is_empty() {
            let labels: Vec<&str> = checks
                .suspect_poses
                .iter()
                .map(|s| s.pose.strip_prefix("line ").unwrap_or(&s.pose))
                .collect();
            println!(
                "data check: to compare without the suspect poses, run again with {option} '{}'",
                labels.join(",")
            );
        }
    }
}
