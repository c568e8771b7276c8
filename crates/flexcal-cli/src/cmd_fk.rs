//! `flexcal fk` and `flexcal ik`: forward and inverse models from the command line.
//!
//! Joint files have a header `q1,...,qn` (actuated coordinates in the
//! robot's actuated order, rad for revolute joints and m for prismatic joints
//! and screws). Pose files have the columns `x_m,y_m,z_m,qw,qx,qy,qz`: the
//! TCP in the robot base frame, position in metres, orientation as a unit
//! quaternion. `fk` output adds one column `passive_<frame>` per passive
//! joint of a closed loop (rad or m).

use anyhow::{Context, bail};
use flexcal::io::{CsvOptions, CsvTable, write_atomic};
use flexcal::kinematics::{Data, InverseOptions, Model, forward_pose, inverse_pose};
use flexcal::nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use std::fmt::Write as _;
use std::path::PathBuf;

use crate::robot_arg::load_model;

/// Pose columns of `fk` output and `ik` input.
pub const POSE_COLUMNS: [&str; 7] = ["x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"];

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

fn parse_joint_list(text: &str, model: &Model) -> anyhow::Result<Vec<f64>> {
    let values: Vec<f64> = text
        .split(',')
        .map(|s| {
            let s = s.trim();
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .with_context(|| format!("'{s}' is not a finite number"))
        })
        .collect::<anyhow::Result<_>>()?;
    if values.len() != model.n_actuated() {
        bail!(
            "robot '{}' has {} actuated coordinates ({}), {} given",
            model.name(),
            model.n_actuated(),
            model.actuated_names().join(", "),
            values.len()
        );
    }
    Ok(values)
}

fn emit(output: &Option<PathBuf>, text: String) -> anyhow::Result<()> {
    match output {
        Some(path) => {
            write_atomic(path, text)?;
            Ok(())
        }
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

fn format_row(out: &mut String, values: impl IntoIterator<Item = f64>) {
    let mut first = true;
    for v in values {
        if !first {
            out.push(',');
        }
        first = false;
        let _ = write!(out, "{v}");
    }
    out.push('\n');
}

/// Runs `flexcal fk`.
pub fn run_fk(args: FkArgs) -> anyhow::Result<()> {
    let model = load_model(&args.robot, &args.robot_file)?;
    let n = model.n_actuated();
    let (configurations, lines): (Vec<Vec<f64>>, Vec<String>) = match (&args.joints, &args.input) {
        (Some(text), None) => (
            vec![parse_joint_list(text, &model).context("--joints")?],
            vec!["--joints".into()],
        ),
        (None, Some(path)) => {
            let table = CsvTable::read(path, &CsvOptions::default())?;
            table.require_rows()?;
            let columns: Vec<Vec<f64>> = (1..=n)
                .map(|i| table.column_f64(&format!("q{i}")))
                .collect::<Result<_, _>>()?;
            let rows = (0..table.len())
                .map(|r| columns.iter().map(|c| c[r]).collect())
                .collect();
            let lines = (0..table.len())
                .map(|r| format!("{}:{}", path.display(), table.line_of(r)))
                .collect();
            (rows, lines)
        }
        _ => bail!("give either --joints or --input"),
    };
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let mut out = String::with_capacity(configurations.len() * 160);
    let mut header: Vec<String> = POSE_COLUMNS.iter().map(|s| s.to_string()).collect();
    header.extend(model.passive_names().iter().map(|n| format!("passive_{n}")));
    out.push_str(&header.join(","));
    out.push('\n');
    for (q, line) in configurations.iter().zip(&lines) {
        // forward_pose also assembles the loops, so the passive joint values
        // are in `data` afterwards.
        let x = forward_pose(&model, &mut data, q, &xi).with_context(|| line.clone())?;
        let t = x.translation.vector;
        let r = x.rotation;
        format_row(
            &mut out,
            [t.x, t.y, t.z, r.w, r.i, r.j, r.k]
                .into_iter()
                .chain(data.passive_values().iter().copied()),
        );
    }
    emit(&args.output, out)
}

/// Reads a pose file (columns [`POSE_COLUMNS`]); returns the poses and the
/// line of each in the file.
pub fn read_poses(path: &PathBuf) -> anyhow::Result<Vec<(Isometry3<f64>, usize)>> {
    let table = CsvTable::read(path, &CsvOptions::default())?;
    table.require_rows()?;
    let c: Vec<Vec<f64>> = POSE_COLUMNS
        .iter()
        .map(|name| table.column_f64(name))
        .collect::<Result<_, _>>()?;
    (0..table.len())
        .map(|r| {
            let q = Quaternion::new(c[3][r], c[4][r], c[5][r], c[6][r]);
            if q.norm() < 1e-9 {
                bail!(
                    "{}:{}: the orientation quaternion has zero norm",
                    path.display(),
                    table.line_of(r)
                );
            }
            Ok((
                Isometry3::from_parts(
                    Translation3::new(c[0][r], c[1][r], c[2][r]),
                    UnitQuaternion::from_quaternion(q),
                ),
                table.line_of(r),
            ))
        })
        .collect()
}

/// Runs `flexcal ik`.
pub fn run_ik(args: IkArgs) -> anyhow::Result<()> {
    let model = load_model(&args.robot, &args.robot_file)?;
    let poses = read_poses(&args.input)?;
    let mut seed = match &args.seed {
        Some(text) => parse_joint_list(text, &model).context("--seed")?,
        None => model
            .actuated_limits()
            .iter()
            .map(|(lo, hi)| 0.5 * (lo + hi))
            .collect(),
    };
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let options = InverseOptions::default();
    let n = model.n_actuated();
    let mut out = String::with_capacity(poses.len() * 20 * n);
    let header: Vec<String> = (1..=n).map(|i| format!("q{i}")).collect();
    out.push_str(&header.join(","));
    out.push('\n');
    for (target, line) in &poses {
        let solution = inverse_pose(&model, &mut data, target, &seed, &xi, &options)
            .with_context(|| format!("{}:{line}", args.input.display()))?;
        format_row(&mut out, solution.q.iter().copied());
        seed = solution.q;
    }
    emit(&args.output, out)
}
