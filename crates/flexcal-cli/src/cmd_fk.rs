//! `flexcal fk` and `flexcal ik`: forward and inverse models from the
//! command line, over the configuration and pose files of
//! [`flexcal::pose_file`].

use std::path::PathBuf;

use flexcal::pose_file::{self, Located};

use crate::robot_arg::load_model;

/// Arguments of `flexcal fk`.
#[derive(clap::Args, Debug)]
pub struct FkArgs {
    /// A built-in robot name or a robot file (.toml, .urdf, .par).
    #[arg(long)]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// One configuration: comma-separated actuated coordinates (rad, m).
    #[arg(long, conflicts_with = "input", allow_hyphen_values = true)]
    pub joints: Option<String>,
    /// CSV file of configurations with header q1..qn.
    #[arg(long)]
    pub input: Option<PathBuf>,
    /// Output CSV file (default: standard output).
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Give the pose of this frame or link instead of the TCP (repeatable:
    /// `--frame wrist_2_link --frame tool0`); columns `NAME.x_m` ...
    /// `NAME.qz`. `flexcal robot show` lists the names (`0` is the base).
    #[arg(long = "frame", value_name = "NAME")]
    pub frames: Vec<String>,
}

/// Arguments of `flexcal ik`.
#[derive(clap::Args, Debug)]
pub struct IkArgs {
    /// A built-in robot name or a robot file (.toml, .urdf, .par).
    #[arg(long)]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// CSV file of TCP poses with columns x_m,y_m,z_m,qw,qx,qy,qz (base frame).
    #[arg(long)]
    pub input: PathBuf,
    /// Output CSV file of actuated coordinates q1..qn (default: standard output).
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Starting configuration for the first pose (comma-separated, rad, m);
    /// each later pose starts from the previous solution, so a path stays on
    /// one branch. Default: the middle of the joint limits.
    #[arg(long, allow_hyphen_values = true)]
    pub seed: Option<String>,
}

/// Writes `text` to `output`, or prints it when there is none.
fn emit(output: &Option<PathBuf>, text: String) -> anyhow::Result<()> {
    match output {
        Some(path) => flexcal::io::write_atomic(path, text)?,
        None => print!("{text}"),
    }
    Ok(())
}

/// Runs `flexcal fk`.
pub fn run_fk(args: FkArgs) -> anyhow::Result<()> {
    let model = load_model(&args.robot, &args.robot_file)?;
    let configurations = match (&args.joints, &args.input) {
        (Some(text), None) => vec![Located {
            value: pose_file::parse_configuration(text, &model, "--joints")?,
            origin: "--joints".into(),
        }],
        (None, Some(path)) => pose_file::read_configurations(path, &model)?,
        _ => crate::usage_bail!("give either --joints or --input"),
    };
    if !args.frames.is_empty() {
        let poses = pose_file::forward_frame_poses(&model, &configurations, &args.frames)?;
        return emit(&args.output, poses.to_csv());
    }
    let poses = pose_file::forward_poses(&model, &configurations)?;
    emit(&args.output, poses.to_csv())
}

/// Runs `flexcal ik`.
pub fn run_ik(args: IkArgs) -> anyhow::Result<()> {
    let model = load_model(&args.robot, &args.robot_file)?;
    let targets = pose_file::read_poses(&args.input)?;
    let start = match &args.seed {
        Some(text) => pose_file::parse_configuration(text, &model, "--seed")?,
        None => pose_file::middle_of_limits(&model),
    };
    let solutions = pose_file::inverse_path(&model, &targets, &start)?;
    emit(
        &args.output,
        pose_file::configurations_to_csv(model.n_actuated(), &solutions),
    )
}
