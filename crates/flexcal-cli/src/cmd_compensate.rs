//! `flexcal compensate`: the commanded path that makes a loaded robot reach
//! its target path (the paper's compensation, equations (39)-(41)), written
//! as CSV and optionally as a KRL program.
//!
//! Units at this boundary: positions in mm, angles in deg, forces in N,
//! moments in N.m; joint coordinates in the robot's own units (rad for
//! revolute, m for prismatic), as in `flexcal fk`/`ik`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use flexcal::compensation::{
    CompensationSetup, ElasticSpec, ProcessSpec, calibrated_xi as facade_calibrated_xi,
    compensate_path_file, default_start_joints, load_elastic, parse_numbers, pose_mm_deg,
};
use flexcal::elastic::workflow::StiffnessReport;
use flexcal::kinematics::Model;
use flexcal::nalgebra::{Isometry3, Vector6};

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

fn parse_part_pose(text: &str) -> anyhow::Result<Isometry3<f64>> {
    let v = parse_numbers(text, 6, "--part-pose x_mm,y_mm,z_mm,a_deg,b_deg,c_deg")?;
    Ok(pose_mm_deg(&[v[0], v[1], v[2], v[3], v[4], v[5]]))
}

/// Reads the identified Gamma of a `flexcal identify stiffness --report`
/// JSON file, checked by name against the elastic model's parameters.
pub(crate) fn read_gamma_report(
    path: &Path,
    model: &flexcal::elastic::model::ElasticModel,
) -> anyhow::Result<Vec<f64>> {
    Ok(StiffnessReport::read(path)?.gamma_for(model, path)?)
}

/// Geometric parameters of a calibrated robot description, checked against `model`.
pub(crate) fn calibrated_xi(model: &Model, file: Option<&Path>) -> anyhow::Result<Vec<f64>> {
    Ok(facade_calibrated_xi(model, file)?)
}

/// Runs `flexcal compensate`.
pub fn run(args: CompensateArgs) -> anyhow::Result<()> {
    let model = load_model(&args.robot, &args.robot_file)?;
    let xi = calibrated_xi(&model, args.calibrated.as_deref())?;
    let mut spec: ElasticSpec = args.elastic.parse()?;
    match (&mut spec, &args.gamma_report) {
        (ElasticSpec::Fe { gamma_report, .. }, Some(path)) => *gamma_report = Some(path.clone()),
        (ElasticSpec::Fuzzy(_), Some(_)) => {
            crate::usage_bail!("--gamma-report applies to an fe: elastic model, not fuzzy:")
        }
        _ => {}
    }
    let elastic =
        load_elastic(&spec, &model, &xi).with_context(|| format!("--elastic {}", args.elastic))?;
    let process: ProcessSpec = args.process.parse()?;
    let x_base_part = parse_part_pose(&args.part_pose)?;
    let payload_base = match &args.payload {
        Some(text) => {
            let f = parse_numbers(text, 3, "--payload fx,fy,fz")?;
            Vector6::new(f[0], f[1], f[2], 0.0, 0.0, 0.0)
        }
        None => Vector6::zeros(),
    };
    let start_joints = match &args.seed_joints {
        Some(text) => parse_numbers(text, model.n_actuated(), "--seed-joints")?,
        None => default_start_joints(&model),
    };
    let setup = CompensationSetup {
        x_base_part,
        payload_base,
        start_joints,
    };
    let commanded = compensate_path_file(
        &model,
        xi,
        elastic.as_ref(),
        process.as_process(),
        &setup,
        &args.path,
    )?;
    // Every export is built before anything is written, so a failing one
    // leaves no file half-updated.
    let mut exports = Vec::new();
    if let Some(path) = &args.krl {
        exports.push((path, "KRL program", commanded.to_krl()?));
    }
    if let Some(path) = &args.rapid {
        exports.push((path, "RAPID module", commanded.to_rapid()?));
    }
    if let Some(path) = &args.joints_csv {
        exports.push((path, "joint trajectory", commanded.to_joint_csv(&model)?));
    }
    flexcal::io::write_atomic(&args.out, commanded.to_csv(model.n_actuated()))?;
    for (path, _, text) in &exports {
        flexcal::io::write_atomic(path, text)?;
    }
    println!(
        "compensated {} points with {} and {}: max predicted deviation {:.4} mm, max residual {:.3e} mm",
        commanded.points.len(),
        commanded.elastic,
        commanded.process,
        commanded.max_predicted_deviation_m() * 1e3,
        commanded.max_residual_m() * 1e3
    );
    println!("commanded path written to {}", args.out.display());
    for (path, what, _) in &exports {
        println!("{what} written to {}", path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexcal::nalgebra::Vector3;

    #[test]
    fn part_pose_is_read_in_mm_and_deg() {
        let x = parse_part_pose("1200,0,1450,90,0,0").unwrap();
        assert!((x.translation.vector - Vector3::new(1.2, 0.0, 1.45)).norm() < 1e-12);
        // A = 90 deg turns the part's x axis onto the base y axis.
        let x_axis = x.rotation * Vector3::x();
        assert!((x_axis - Vector3::y()).norm() < 1e-12);
        assert!(parse_part_pose("1200,0,1450,0,0").is_err());
        assert!(parse_part_pose("1200,0,inf,0,0,0").is_err());
    }
}
