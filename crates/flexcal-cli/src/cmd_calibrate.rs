//! `flexcal calibrate`: geometric identification from a measurement file,
//! with optional validation on another file; the command line is a
//! campaign ([`flexcal::campaign::Campaign`]), read from a file with
//! `--config` (flags given with it override the file's values) and written
//! to one with `--save-config`.

use std::path::{Path, PathBuf};

use clap::builder::{PossibleValuesParser, TypedValueParser};
use flexcal::calibration::MeasurementFormat;
use flexcal::campaign::{Campaign, ModelKind, SolverKind, ValidationSection, WeightsKind};
use serde::de::DeserializeOwned;

/// A parser of the kebab-case names `names` of a campaign setting (the
/// names its TOML spells), listed in `--help`.
pub fn named<T>(names: &'static [&'static str]) -> impl TypedValueParser<Value = T>
where
    T: DeserializeOwned + Clone + Send + Sync + 'static,
{
    PossibleValuesParser::new(names).try_map(|name: String| {
        T::deserialize(serde::de::value::StrDeserializer::<serde::de::value::Error>::new(&name))
    })
}

/// Arguments of `flexcal calibrate`. Every setting can come from a campaign
/// file (`--config`); a flag given with it wins over the file's value.
#[derive(clap::Args, Debug)]
pub struct CalibrateArgs {
    /// Campaign file (TOML, docs/file-formats.md; or a JSON report, whose
    /// `config` section is the campaign it was run with): every setting of
    /// the command line, paths relative to the file. Flags given as well
    /// override the file's values (a list flag replaces the file's list; a
    /// switch turns a setting on, it cannot turn the file's off).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Write the campaign file this command line stands for (with
    /// `--config`: the file's settings with the flags' over them), paths
    /// relative to the file's folder, then run it.
    #[arg(long)]
    pub save_config: Option<PathBuf>,
    /// Robot: a built-in name (ur10, ir663, puma560) or a robot file (.toml, .urdf, .par).
    #[arg(long, required_unless_present = "config")]
    pub robot: Option<String>,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// Identification measurements. Give it again for each further station
    /// (another placement of the tracker, another campaign of the same
    /// robot and target): the files are pooled, each with its own
    /// measurement frame (`frame_s2_x`, ...), and pose labels carry the
    /// station's number (`--exclude s2:line 534`).
    #[arg(long, required_unless_present = "config")]
    pub data: Vec<PathBuf>,
    /// Format of the measurement files: own (flexcal's CSV: q1..qn,
    /// x_mm, y_mm, z_mm, ...; the default) or ipa (IPA laser-tracker
    /// export: `;`, decimal comma, T-Mac probe).
    #[arg(long, value_parser = named::<MeasurementFormat>(&["own", "ipa"]))]
    pub format: Option<MeasurementFormat>,
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
    /// Identification model: geometric (the default: geometric parameters,
    /// measurement frame, target offset) or elasto-geometric (plus joint
    /// compliances under gravity and the payload's mass and centre; mass
    /// table: --masses, a URDF's inertials, or built-in for ur10).
    #[arg(long, value_parser = model_kind())]
    pub model: Option<ModelKind>,
    /// Mass table of the elasto-geometric model (TOML, see the README);
    /// default: a URDF robot's `<inertial>` masses, else the robot's
    /// built-in table (ur10).
    #[arg(long)]
    pub masses: Option<PathBuf>,
    /// Elastic deflection: one-step (torques on the commanded
    /// configuration, the default), equilibrium (on the deflected one) or
    /// auto (the equilibrium when the one step changes a joint's torque by
    /// more than 5 % of its span); overrides the mass table's.
    #[arg(long, value_parser = ["one-step", "equilibrium", "auto"])]
    pub deflection: Option<String>,
    /// Solver: lm (Levenberg-Marquardt, the default) or gn (Gauss-Newton
    /// re-linearisation, the paper's iteration).
    #[arg(long, value_parser = named::<SolverKind>(&["lm", "gn"]))]
    pub method: Option<SolverKind>,
    /// Row weighting: file (1/sigma from the file's standard deviations)
    /// or uniform (default: file for the own format, uniform for ipa, whose
    /// std columns are sample spreads).
    #[arg(long, value_parser = named::<WeightsKind>(&["file", "uniform"]))]
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
    #[arg(long, allow_hyphen_values = true)]
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
    /// Bounds that hold beyond the training poses: hold out the ends of
    /// each joint's range, identify again on the rest, and add to every
    /// predicted 95 % bound the error growth measured outside the range
    /// (two more identifications per joint; with --validate or
    /// --accuracy-map).
    #[arg(long)]
    pub extrapolation: bool,
    /// With several --data files (stations): hold each out in turn,
    /// identify on the others (the model selected on them) and validate on
    /// it, its measurement frame re-fitted (one more identification per
    /// station).
    #[arg(long)]
    pub hold_out_stations: bool,
    /// Check what transfers: identify the same unknowns again on the
    /// validation set and compare them in combined standard errors
    /// (needs --validate).
    #[arg(long)]
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
    /// Which cross-validated score the selection chooses on:
    /// interpolation (folds inside the training ranges), extrapolation
    /// (folds holding out the ends of each joint's angle and gravity-torque
    /// ranges) or auto (default: extrapolation when the --accuracy-map grid
    /// leaves the training range; the --validate poses never choose). The
    /// report gives both scores: for every candidate when the
    /// extrapolating ones choose, else for the models the search moved
    /// through.
    #[arg(long)]
    pub select_on: Option<flexcal::calib::SelectOn>,
    /// Score every candidate on the extrapolating folds, also when the
    /// ordinary scores choose (one fit per joint more for each candidate).
    #[arg(long)]
    pub every_extrapolation_score: bool,
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

/// The parser of `--model`.
pub fn model_kind() -> impl TypedValueParser<Value = ModelKind> {
    named::<ModelKind>(&["geometric", "elasto-geometric"])
}

/// Runs `flexcal calibrate`: flags (over `--config`'s campaign) ->
/// [`Campaign`] -> [`Campaign::run`] -> print and write.
pub fn run(args: CalibrateArgs) -> anyhow::Result<()> {
    let campaign = campaign(args.config.as_deref(), &args)?;
    if let Some(path) = &args.save_config {
        campaign.write(path)?;
        println!("campaign written to {}", path.display());
    }
    let run = campaign.run()?;
    print!("{}", run.summary_text());
    run.write_outputs()?
        .iter()
        .for_each(|line| println!("{line}"));
    Ok(())
}

/// The campaign of the command line: the file's (`config`: a campaign
/// TOML, or a JSON report's embedded campaign) or an empty one, with the
/// flags given over it.
fn campaign(config: Option<&Path>, args: &CalibrateArgs) -> anyhow::Result<Campaign> {
    let mut campaign = match config {
        Some(path)
            if path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("json")) =>
        {
            Campaign::from_report(path)?
        }
        Some(path) => Campaign::read(path)?,
        None => Campaign::default(),
    };
    robot_flags(&mut campaign, args)?;
    data_flags(&mut campaign, args)?;
    model_flags(&mut campaign, args)?;
    let checks = &mut campaign.checks;
    checks.split |= args.split_check;
    checks.extrapolation |= args.extrapolation;
    checks.hold_out_stations |= args.hold_out_stations;
    checks.cross |= args.cross_check;
    set_list(&mut checks.residual_model, &args.residual_model);
    set(&mut checks.accuracy_map, &args.accuracy_map);
    let outputs = &mut campaign.outputs;
    set(&mut outputs.calibrated_robot, &args.out);
    set(&mut outputs.report, &args.report);
    set(&mut outputs.html, &args.html);
    set(&mut outputs.residuals, &args.residuals);
    Ok(campaign)
}

/// `value` over `slot` when given.
fn set<T: Clone>(slot: &mut Option<T>, value: &Option<T>) {
    if value.is_some() {
        slot.clone_from(value);
    }
}

/// A list flag's items over `slot` when given.
fn set_list(slot: &mut Vec<String>, values: &[String]) {
    let items = crate::list_items(values);
    if !items.is_empty() {
        *slot = items;
    }
}

fn robot_flags(campaign: &mut Campaign, args: &CalibrateArgs) -> anyhow::Result<()> {
    let robot = &mut campaign.robot;
    if let Some(spec) = &args.robot {
        match flexcal::RobotSpec::parse(spec)? {
            flexcal::RobotSpec::Builtin(name) => (robot.name, robot.file) = (Some(name), None),
            flexcal::RobotSpec::File(file) => (robot.name, robot.file) = (None, Some(file)),
            other => anyhow::bail!("--robot: {other} is neither a built-in robot nor a file"),
        }
    }
    let file = &args.robot_file;
    set(&mut robot.tip, &file.tip);
    set(&mut robot.root, &file.root);
    set(&mut robot.values, &file.values);
    Ok(())
}

fn data_flags(campaign: &mut Campaign, args: &CalibrateArgs) -> anyhow::Result<()> {
    let data = &mut campaign.data;
    if !args.data.is_empty() {
        data.files.clone_from(&args.data);
    }
    if let Some(format) = args.format {
        data.format = format;
    }
    set_list(&mut data.exclude, &args.exclude);
    set(&mut data.targets, &args.targets);
    if let Some(file) = &args.validate {
        let validation = campaign
            .validation
            .get_or_insert_with(ValidationSection::default);
        validation.file.clone_from(file);
    }
    match campaign.validation.as_mut() {
        Some(validation) => {
            set_list(&mut validation.exclude, &args.exclude_validation);
            validation.refit_target |= args.refit_target;
        }
        None if !args.exclude_validation.is_empty() => {
            crate::usage_bail!("--exclude-validation needs --validate")
        }
        None if args.cross_check => {
            crate::usage_bail!("--cross-check needs --validate")
        }
        None => {}
    }
    Ok(())
}

fn model_flags(campaign: &mut Campaign, args: &CalibrateArgs) -> anyhow::Result<()> {
    let m = &mut campaign.model;
    if let Some(kind) = args.model {
        m.kind = kind;
    }
    set(&mut m.masses, &args.masses);
    set(&mut m.deflection, &args.deflection);
    if let Some(method) = args.method {
        m.method = method;
    }
    set(&mut m.weights, &args.weights);
    if args.position_only {
        m.orientation = Some(false);
    } else if args.with_orientation {
        m.orientation = Some(true);
    }
    set_list(&mut m.fix, &args.fix);
    set_list(&mut m.defer, &args.defer);
    m.fixed_frame |= args.fixed_frame;
    m.fixed_target |= args.fixed_target;
    match args.target_mm[..] {
        [] => {}
        [x, y, z] => m.target_mm = Some([x, y, z]),
        _ => crate::usage_bail!(
            "--target-mm takes three values x,y,z (mm), got {}",
            args.target_mm.len()
        ),
    }
    set(&mut m.select, &args.select);
    set(&mut m.select_on, &args.select_on);
    m.every_extrapolation_score |= args.every_extrapolation_score;
    m.strict |= args.strict;
    set(&mut m.max_se_length_mm, &args.max_se_length_mm);
    set(&mut m.max_se_angle_deg, &args.max_se_angle_deg);
    set(
        &mut m.max_se_compliance_urad_per_nm,
        &args.max_se_compliance,
    );
    set(&mut m.min_compliance_z, &args.min_compliance_z);
    set(&mut m.min_torque_share, &args.min_torque_share);
    set(&mut m.noise_mm, &args.noise_mm);
    set(&mut m.noise_deg, &args.noise_deg);
    Ok(())
}
