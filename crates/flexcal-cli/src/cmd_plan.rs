//! `flexcal plan`: which poses to measure, how many, and the accuracy they
//! will buy over the region that matters, before measuring.
//!
//! Units at this boundary: noise in mm, joint boxes in deg (revolute) and
//! mm (prismatic, screws); configuration files in the robot's own units
//! (rad, m), as `flexcal fk` and `poses select`.

use std::path::PathBuf;

use anyhow::Context;
use flexcal::calib::{CalibrationOptions, FrameTreatment};
use flexcal::kinematics::Model;
use flexcal::plan::output::PlanOutputs;
use flexcal::plan::{JointBox, LineOfSight, PlanConfig, PoseSource, Sight, plan_campaign};

use flexcal::campaign::ModelKind;

/// Arguments of `flexcal plan`.
#[derive(clap::Args, Debug)]
pub struct PlanArgs {
    /// Robot: a built-in name (ur10, ir663, puma560) or a robot file (.toml, .urdf, .par).
    #[arg(long)]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// Identification model, as for `calibrate` (default: the --prior's
    /// model, else geometric).
    #[arg(long, value_parser = crate::cmd_calibrate::model_kind())]
    pub model: Option<ModelKind>,
    /// An earlier calibration of the same robot: its JSON report
    /// (`calibrate --report`, made with --split-check, and --extrapolation
    /// for its growth outside the training ranges). The plan identifies
    /// its model (its chosen groups), floors the noise at its residual
    /// scatter, raises the identification part of the bounds by its
    /// split-half inflation and adds its growth outside the planned poses'
    /// ranges (docs/planning.md).
    #[arg(long)]
    pub prior: Option<PathBuf>,
    /// Mass table of the elasto-geometric model (TOML); default: a URDF
    /// robot's inertials, else the robot's built-in table (ur10).
    #[arg(long)]
    pub masses: Option<PathBuf>,
    /// Parameters to keep at nominal, comma-separated, as for `calibrate`.
    #[arg(long, value_delimiter = ',')]
    pub fix: Vec<String>,
    /// Parameters to leave out of the base set first, as for `calibrate`.
    #[arg(long, value_delimiter = ',')]
    pub defer: Vec<String>,
    /// The measurements will be in the robot base frame (no measurement
    /// frame to identify).
    #[arg(long)]
    pub fixed_frame: bool,
    /// The target offset will be kept at its nominal value (the TCP).
    #[arg(long)]
    pub fixed_target: bool,
    /// Several targets per pose: their description (TOML: name, frame,
    /// offset_mm, identify), as for `calibrate --targets`
    /// (docs/file-formats.md); default one target at the TCP.
    #[arg(long)]
    pub targets: Option<PathBuf>,
    /// Instrument noise per position axis (mm): one value for all axes or
    /// `x,y,z`.
    #[arg(long, value_delimiter = ',', required = true)]
    pub noise_mm: Vec<f64>,
    /// The instrument measures full poses: its orientation noise about
    /// each axis of the measurement frame (deg), one value for all axes or
    /// `x,y,z`. Default: positions only.
    #[arg(long, value_delimiter = ',')]
    pub orientation_noise_deg: Option<Vec<f64>>,
    /// How the measurement frame's uncertainty enters the predicted
    /// bounds: `registered` (default: the frame registered again where the
    /// region is measured or used) or `as-identified` (the region measured
    /// from the campaign's instrument placement: the frame's uncertainty
    /// counted; docs/planning.md).
    #[arg(long, default_value = "registered")]
    pub frame_uncertainty: flexcal::calib::FrameUncertainty,
    /// The instrument's reach box in the robot's base frame (mm),
    /// `x_lo:x_hi,y_lo:y_hi,z_lo:z_hi`: candidates whose target lies
    /// outside are left out.
    #[arg(long, allow_hyphen_values = true)]
    pub reach_box_mm: Option<String>,
    /// The instrument's position in the robot's base frame (mm), `x,y,z`:
    /// with --max-incidence-deg, candidates whose target faces away from
    /// it are left out.
    #[arg(
        long,
        value_delimiter = ',',
        allow_hyphen_values = true,
        requires = "max_incidence_deg"
    )]
    pub sight_from_mm: Option<Vec<f64>>,
    /// Largest angle between the target's z axis (the tool axis for the
    /// TCP) and the line to the instrument (deg): the reflector's
    /// acceptance half-angle, the LEDs' viewing half-angle.
    #[arg(long, requires = "sight_from_mm")]
    pub max_incidence_deg: Option<f64>,
    /// Candidate configurations the cell allows (CSV q1..qn, rad or m).
    /// Default: --candidate-count configurations drawn in --box-deg.
    #[arg(long)]
    pub candidates: Option<PathBuf>,
    /// Joint box of the candidates, `lo:hi` per actuated coordinate,
    /// comma-separated (deg; mm for prismatic joints and screws); default
    /// the joint limits.
    #[arg(long, allow_hyphen_values = true)]
    pub box_deg: Option<String>,
    /// Number of candidates drawn in the box.
    #[arg(long, default_value_t = 200)]
    pub candidate_count: usize,
    /// The region where accuracy matters: configurations (CSV q1..qn, rad
    /// or m), e.g. the joint path of the task. Default: --region-count
    /// configurations drawn in the candidates' box.
    #[arg(long)]
    pub region: Option<PathBuf>,
    /// Number of region configurations drawn in the box.
    #[arg(long, default_value_t = 200)]
    pub region_count: usize,
    /// Seed of the draws (candidates with it, the region with it + 1).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of poses to plan (default: the knee of the curve).
    #[arg(long)]
    pub poses: Option<usize>,
    /// Largest number of poses on the curve (default: the larger of
    /// --poses and 100, at most the candidates).
    #[arg(long)]
    pub max_poses: Option<usize>,
    /// The knee: the smallest count within this fraction of the curve's
    /// last mean bound.
    #[arg(long, default_value_t = 0.05)]
    pub knee_tolerance: f64,
    /// Write the planned configurations here (CSV q1..qn, rad or m, in
    /// measurement order).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write them as a joint trajectory CSV (deg, mm).
    #[arg(long)]
    pub joints_csv: Option<PathBuf>,
    /// Also write a KRL program through the planned TCP poses.
    #[arg(long)]
    pub krl: Option<PathBuf>,
    /// Also write an ABB RAPID module through the planned TCP poses.
    #[arg(long)]
    pub rapid: Option<PathBuf>,
    /// Write the plan as JSON here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the plan as an HTML page here (the curve and the map).
    #[arg(long)]
    pub html: Option<PathBuf>,
}

/// Runs `flexcal plan`: flags -> [`PlanConfig`] -> [`plan_campaign`] ->
/// print and write (nothing is written when planning fails).
pub fn run(args: PlanArgs) -> anyhow::Result<()> {
    let model = crate::robot_arg::load_model(&args.robot, &args.robot_file)?;
    let config = config(&args, &model)?;
    let plan = plan_campaign(&model, &config)?;
    print!("{}", plan.summary_text());
    let outputs = PlanOutputs {
        configurations: Some(args.out.clone()),
        joint_trajectory: args.joints_csv.clone(),
        krl: args.krl.clone(),
        rapid: args.rapid.clone(),
        report: args.report.clone(),
        html: args.html.clone(),
    };
    let written = plan.write_outputs(&model, &outputs)?;
    written.iter().for_each(|line| println!("{line}"));
    Ok(())
}

/// The validated configuration of a plan from the flags.
fn config(args: &PlanArgs, model: &Model) -> anyhow::Result<PlanConfig> {
    let noise_mm = per_axis(&args.noise_mm, "--noise-mm", "mm")?;
    let orientation_noise_deg = args
        .orientation_noise_deg
        .as_deref()
        .map(|v| per_axis(v, "--orientation-noise-deg", "deg"))
        .transpose()?;
    let mut options = CalibrationOptions::for_model(model);
    options.fixed = crate::list_items(&args.fix);
    if !args.defer.is_empty() {
        options.deferred = crate::list_items(&args.defer);
    }
    if args.fixed_frame {
        options.measurement_frame = FrameTreatment::Fixed;
    }
    if args.fixed_target {
        options.target = FrameTreatment::Fixed;
    }
    let prior = args
        .prior
        .as_deref()
        .map(flexcal::plan::Prior::read)
        .transpose()?;
    let model_kind = match (args.model, &prior) {
        (Some(kind), _) => kind,
        (None, Some(p)) if p.model == "elasto-geometric" => ModelKind::ElastoGeometric,
        _ => ModelKind::Geometric,
    };
    if model_kind == ModelKind::ElastoGeometric {
        options.gravity = Some(
            flexcal::RobotSpec::parse(&args.robot)?
                .mass_table(&args.robot_file.options(), model, args.masses.as_deref())
                .context("--model elasto-geometric")?,
        );
    } else if args.masses.is_some() {
        crate::usage_bail!("--masses is for --model elasto-geometric");
    }
    let joint_box = match &args.box_deg {
        Some(text) => JointBox::from_text(model, text, "--box-deg")?,
        None => JointBox::of_limits(model),
    };
    let from_file = |path: &PathBuf| -> anyhow::Result<PoseSource> {
        Ok(PoseSource::Configurations(
            flexcal::pose_file::read_configurations(path, model)?,
        ))
    };
    let candidates = match &args.candidates {
        Some(path) => from_file(path)?,
        None => PoseSource::Box {
            joint_box: joint_box.clone(),
            count: args.candidate_count,
            seed: args.seed,
        },
    };
    let region = match &args.region {
        Some(path) => from_file(path)?,
        None => PoseSource::Box {
            joint_box,
            count: args.region_count,
            seed: args.seed.wrapping_add(1),
        },
    };
    let mut config = PlanConfig::new(options, noise_mm, candidates, region);
    config.instrument.orientation_noise_deg = orientation_noise_deg;
    config.instrument.frame = args.frame_uncertainty;
    config.instrument.sight = sight(args)?;
    if let Some(path) = &args.targets {
        if args.fixed_target {
            crate::usage_bail!(
                "--fixed-target is for one target: with --targets each target's `identify` decides"
            );
        }
        config.targets = Some(flexcal::calib::read_targets(path)?);
    }
    config.prior = prior;
    config.count = args.poses;
    config.max_poses = args.max_poses;
    config.knee_tolerance = args.knee_tolerance;
    Ok(config)
}

/// The instrument's sight from `--reach-box-mm`, `--sight-from-mm` and
/// `--max-incidence-deg` (checked by the plan).
fn sight(args: &PlanArgs) -> anyhow::Result<Sight> {
    let reach_box_mm = args.reach_box_mm.as_deref().map(reach_box).transpose()?;
    let line_of_sight = match (&args.sight_from_mm, args.max_incidence_deg) {
        (Some(p), Some(max_incidence_deg)) => match p[..] {
            [x, y, z] => Some(LineOfSight {
                position_mm: [x, y, z],
                max_incidence_deg,
            }),
            _ => crate::usage_bail!(
                "--sight-from-mm takes three values x,y,z (mm), got {}",
                p.len()
            ),
        },
        _ => None,
    };
    Ok(Sight {
        reach_box_mm,
        line_of_sight,
    })
}

/// `x_lo:x_hi,y_lo:y_hi,z_lo:z_hi` (mm) of `--reach-box-mm`.
fn reach_box(text: &str) -> anyhow::Result<[[f64; 2]; 3]> {
    let ranges = text
        .split(',')
        .map(|r| {
            let (lo, hi) = r.split_once(':')?;
            Some([lo.trim().parse().ok()?, hi.trim().parse().ok()?])
        })
        .collect::<Option<Vec<[f64; 2]>>>();
    match ranges.as_deref() {
        Some(&[x, y, z]) => Ok([x, y, z]),
        _ => crate::usage_bail!(
            "--reach-box-mm takes three ranges lo:hi (mm) for x, y, z, comma-separated, got `{text}`"
        ),
    }
}

/// One value for the three axes or three `x,y,z` of the flag `flag` (unit
/// `unit`).
fn per_axis(values: &[f64], flag: &str, unit: &str) -> anyhow::Result<[f64; 3]> {
    match values[..] {
        [s] => Ok([s; 3]),
        [x, y, z] => Ok([x, y, z]),
        _ => crate::usage_bail!(
            "{flag} takes one value or three x,y,z ({unit}), got {}",
            values.len()
        ),
    }
}
