//! `flexcal compensate`: the commanded path that makes a loaded robot reach
//! its target path (the paper's compensation, equations (39)-(41)), written
//! as CSV and optionally as a KRL program.
//!
//! Units at this boundary: positions in mm, angles in deg, forces in N,
//! moments in N.m; joint coordinates in the robot's own units (rad for
//! revolute, m for prismatic), as in `flexcal fk`/`ik`.

use std::path::PathBuf;

use anyhow::Context;
use flexcal::compensation::{
    CompensationSetup, ElasticSpec, PathExport, ProcessSpec, calibrated_xi, compensate_path_file,
    load_elastic,
};

use crate::robot_arg::load_model;

/// Arguments of `flexcal compensate`.
#[derive(clap::Args, Debug)]
pub struct CompensateArgs {
    /// Robot: a built-in name or a robot file (.toml, .urdf, .par).
    #[arg(long)]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// Robot description TOML whose geometric parameters xi are used (the
    /// output of `flexcal calibrate`); default the robot's nominal xi.
    #[arg(long)]
    pub calibrated: Option<PathBuf>,
    /// Elastic model: `fe:NAME|FILE` (FE beam model: built-in `ir663` or an
    /// elastic description TOML) or `fuzzy:FILE` (fuzzy compliance TOML from
    /// `flexcal identify compliance`).
    #[arg(long)]
    pub elastic: String,
    /// Identified stiffness Gamma for an `fe:` model: the JSON report of
    /// `flexcal identify stiffness --report`; default the description's nominal Gamma.
    #[arg(long)]
    pub gamma_report: Option<PathBuf>,
    /// Target path CSV in the part frame: `x_mm,y_mm,z_mm` plus optionally
    /// `qw,qx,qy,qz` or `a_deg,b_deg,c_deg` (default orientation: tool z axis
    /// along -z of the part).
    #[arg(long)]
    pub path: PathBuf,
    /// Part frame in the robot base frame: `x_mm,y_mm,z_mm,a_deg,b_deg,c_deg`
    /// (KUKA A, B, C = rotations about z, y, x).
    #[arg(long, allow_hyphen_values = true)]
    pub part_pose: String,
    /// Process load on the tool: `constant:fx,fy,fz,mx,my,mz` (N, N.m, part
    /// frame) or `cantilever:LENGTH_MM,WIDTH_MM,THICKNESS_MM,MATERIAL[,small|large][,friction=MU]`
    /// (a clamped beam along +x of the part frame, clamp at its origin, top
    /// surface at z = 0; default large-deflection theory, no friction).
    #[arg(long, allow_hyphen_values = true)]
    pub process: String,
    /// Constant force on the tool (payload, dead weight) in the base frame:
    /// `fx,fy,fz` (N), e.g. `0,0,-920`.
    #[arg(long, allow_hyphen_values = true)]
    pub payload: Option<String>,
    /// Starting configuration of the inverse model for the first point:
    /// comma-separated actuated coordinates (rad, m). Default: a built-in
    /// start for six-joint arms (upper arm forward, forearm down), else the
    /// middle of the joint limits.
    #[arg(long, allow_hyphen_values = true)]
    pub seed_joints: Option<String>,
    /// Output CSV: per point `line, q1..qn, x_mm,y_mm,z_mm,qw,qx,qy,qz`
    /// (commanded TCP, base frame), `pred_dx_mm,pred_dy_mm,pred_dz_mm`
    /// (predicted error without compensation), `res_mm`, `iterations`, `method`.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the commanded path as a KRL program (PTP to the first point,
    /// then one LIN per point).
    #[arg(long)]
    pub krl: Option<PathBuf>,
    /// Also write the commanded path as an ABB RAPID module (`MoveL`
    /// through `robtarget`s, mm and quaternions).
    #[arg(long)]
    pub rapid: Option<PathBuf>,
    /// Also write the commanded actuated coordinates as a joint-trajectory
    /// CSV (deg, mm; one row per point).
    #[arg(long)]
    pub joints_csv: Option<PathBuf>,
}

/// Runs `flexcal compensate`.
pub fn run(args: CompensateArgs) -> anyhow::Result<()> {
    let model = load_model(&args.robot, &args.robot_file)?;
    let xi = calibrated_xi(&model, args.calibrated.as_deref())?;
    let spec = args
        .elastic
        .parse::<ElasticSpec>()?
        .with_gamma_report(args.gamma_report.clone())?;
    let elastic =
        load_elastic(&spec, &model, &xi).with_context(|| format!("--elastic {}", args.elastic))?;
    let process: ProcessSpec = args.process.parse()?;
    let setup = CompensationSetup::from_text(
        &model,
        &args.part_pose,
        args.payload.as_deref(),
        args.seed_joints.as_deref(),
    )?;
    let commanded = compensate_path_file(
        &model,
        xi,
        elastic.as_ref(),
        process.as_process(),
        &setup,
        &args.path,
    )?;
    let exports: Vec<(PathExport, PathBuf)> = [
        (PathExport::Krl, args.krl),
        (PathExport::Rapid, args.rapid),
        (PathExport::JointCsv, args.joints_csv),
    ]
    .into_iter()
    .filter_map(|(kind, path)| Some((kind, path?)))
    .collect();
    let written = commanded.write(&model, &args.out, &exports)?;
    println!("{}", commanded.summary_line());
    written.iter().for_each(|line| println!("{line}"));
    Ok(())
}
