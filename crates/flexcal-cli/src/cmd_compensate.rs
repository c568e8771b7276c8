//! `flexcal compensate`: the commanded path that makes a loaded robot reach
//! its target path (the paper's compensation, equations (39)-(41)), written
//! as CSV and optionally as a KRL program.
//!
//! Units at this boundary: positions in mm, angles in deg, forces in N,
//! moments in N.m; joint coordinates in the robot's own units (rad for
//! revolute, m for prismatic), as in `flexcal fk`/`ik`.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flexcal_compensate::compensation::{
    Cell, CompensatedPoint, CompensationOptions, ElasticModel as TcpElastic, ElastoGeometricModel,
    Method, position_norm,
};
use flexcal_compensate::path::{KrlOptions, krl_program, read_target_path, rotation_from_abc};
use flexcal_compensate::process::{BeamTheory, CantileverBeam, ConstantWrench, ProcessModel};
use flexcal_kinematics::{Data, Model, actuated_from_joint_angles};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};

use crate::robot_arg::load_model;

/// Arguments of `flexcal compensate`.
#[derive(clap::Args, Debug)]
pub struct CompensateArgs {
    /// Robot: a built-in name or a description TOML file.
    #[arg(long)]
    pub robot: String,
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
}

/// Parses `n` comma-separated finite numbers; `what` names the argument.
pub(crate) fn parse_numbers(text: &str, n: usize, what: &str) -> anyhow::Result<Vec<f64>> {
    let values: Vec<f64> = text
        .split(',')
        .map(|s| {
            let s = s.trim();
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .with_context(|| format!("{what}: '{s}' is not a finite number"))
        })
        .collect::<anyhow::Result<_>>()?;
    if values.len() != n {
        bail!(
            "{what}: expected {n} comma-separated numbers, found {}",
            values.len()
        );
    }
    Ok(values)
}

fn parse_part_pose(text: &str) -> anyhow::Result<Isometry3<f64>> {
    let v = parse_numbers(text, 6, "--part-pose x_mm,y_mm,z_mm,a_deg,b_deg,c_deg")?;
    Ok(Isometry3::from_parts(
        Translation3::new(v[0] * 1e-3, v[1] * 1e-3, v[2] * 1e-3),
        rotation_from_abc(v[3].to_radians(), v[4].to_radians(), v[5].to_radians()),
    ))
}

/// A process model chosen on the command line.
enum Process {
    Constant(ConstantWrench),
    Cantilever(CantileverBeam),
}

impl Process {
    fn as_dyn(&self) -> &dyn ProcessModel {
        match self {
            Process::Constant(p) => p,
            Process::Cantilever(p) => p,
        }
    }
}

fn parse_process(text: &str) -> anyhow::Result<Process> {
    let (kind, value) = text
        .split_once(':')
        .with_context(|| format!("--process '{text}': expected constant:... or cantilever:..."))?;
    match kind.trim() {
        "constant" => {
            let v = parse_numbers(value, 6, "--process constant:fx,fy,fz,mx,my,mz")?;
            Ok(Process::Constant(ConstantWrench {
                wrench: Vector6::from_column_slice(&v),
            }))
        }
        "cantilever" => {
            let fields: Vec<&str> = value.split(',').map(str::trim).collect();
            if fields.len() < 4 {
                bail!(
                    "--process cantilever: expected LENGTH_MM,WIDTH_MM,THICKNESS_MM,MATERIAL[,small|large][,friction=MU], found '{value}'"
                );
            }
            let dims = parse_numbers(
                &fields[..3].join(","),
                3,
                "--process cantilever LENGTH_MM,WIDTH_MM,THICKNESS_MM",
            )?;
            let material = flexcal_compensate::process::material(fields[3]).with_context(|| {
                format!("--process cantilever: unknown material '{}'", fields[3])
            })?;
            let mut beam = CantileverBeam {
                length_m: dims[0] * 1e-3,
                width_m: dims[1] * 1e-3,
                thickness_m: dims[2] * 1e-3,
                youngs_modulus_pa: material.youngs_modulus_pa,
                friction_coefficient: 0.0,
                theory: BeamTheory::LargeDeflection,
            };
            for option in &fields[4..] {
                match *option {
                    "small" => beam.theory = BeamTheory::SmallDeflection,
                    "large" => beam.theory = BeamTheory::LargeDeflection,
                    other => {
                        let mu = other
                            .strip_prefix("friction=")
                            .and_then(|m| m.trim().parse::<f64>().ok())
                            .with_context(|| {
                                format!(
                                    "--process cantilever: '{other}' is neither small, large nor friction=MU"
                                )
                            })?;
                        beam.friction_coefficient = mu;
                    }
                }
            }
            beam.validate().context("--process cantilever")?;
            Ok(Process::Cantilever(beam))
        }
        other => bail!("--process: unknown kind '{other}' (expected constant or cantilever)"),
    }
}

/// Reads the identified Gamma of a `flexcal identify stiffness --report`
/// JSON file, checked by name against the elastic model's parameters.
pub(crate) fn read_gamma_report(
    path: &Path,
    model: &flexcal_elastic::model::ElasticModel,
) -> anyhow::Result<Vec<f64>> {
    use flexcal_elastic::workflow::StiffnessReport;
    Ok(StiffnessReport::read(path)?.gamma_for(model, path)?)
}

/// Geometric parameters of a calibrated robot description, checked against `model`.
pub(crate) fn calibrated_xi(model: &Model, file: Option<&Path>) -> anyhow::Result<Vec<f64>> {
    let Some(file) = file else {
        return Ok(model.nominal_params().to_vec());
    };
    let spec = file.display().to_string();
    let calibrated = load_model(&spec)?;
    let same = calibrated.n_params() == model.n_params()
        && calibrated
            .params()
            .iter()
            .zip(model.params())
            .all(|(a, b)| a.name == b.name);
    if !same {
        bail!(
            "--calibrated {spec}: its geometric parameters do not match robot '{}' ({} vs {} parameters or different names)",
            model.name(),
            calibrated.n_params(),
            model.n_params()
        );
    }
    Ok(calibrated.nominal_params().to_vec())
}

/// Builds the elastic model of a `--elastic` argument.
fn load_elastic(
    spec: &str,
    model: &Model,
    xi: &[f64],
    gamma_report: Option<&Path>,
) -> anyhow::Result<Box<dyn TcpElastic>> {
    let (kind, value) = spec
        .split_once(':')
        .with_context(|| format!("--elastic '{spec}': expected fe:NAME|FILE or fuzzy:FILE"))?;
    match kind {
        "fe" => {
            let description =
                flexcal_elastic::description::ElasticDescription::builtin_or_file(value)
                    .with_context(|| format!("--elastic fe:{value}"))?;
            let elastic = flexcal_elastic::model::ElasticModel::new(model, &description)
                .with_context(|| format!("building the FE model '{}'", description.name))?;
            let (gamma, origin) = match gamma_report {
                Some(path) => (read_gamma_report(path, &elastic)?, "identified Gamma"),
                None => (elastic.nominal_gamma(), "nominal Gamma"),
            };
            let label = format!("FE beam model '{}' ({origin})", description.name);
            Ok(Box::new(flexcal_twin::forming::FeTcpModel::new(
                elastic,
                xi.to_vec(),
                gamma,
                label,
            )?))
        }
        "fuzzy" => {
            if gamma_report.is_some() {
                bail!("--gamma-report applies to an fe: elastic model, not fuzzy:");
            }
            let compliance = flexcal_elastic::fuzzy_compliance::FuzzyCompliance::load(value)
                .with_context(|| format!("--elastic fuzzy:{value}"))?;
            Ok(Box::new(
                flexcal_elastic::fuzzy_compliance::RobotFuzzyCompliance::new(
                    compliance,
                    model.clone(),
                )?,
            ))
        }
        other => bail!("--elastic: unknown kind '{other}' (expected fe or fuzzy)"),
    }
}

fn default_seed(model: &Model) -> Vec<f64> {
    // The working area of the forming cell: upper arm forward, forearm down.
    if model.n_actuated() == 6 {
        if let Ok(q) = actuated_from_joint_angles(model, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0]) {
            return q;
        }
    }
    model
        .actuated_limits()
        .iter()
        .map(|&(lo, hi)| 0.5 * (lo + hi))
        .collect()
}

fn output_csv(model: &Model, points: &[(usize, CompensatedPoint)]) -> String {
    let n = model.n_actuated();
    let mut header: Vec<String> = vec!["line".into()];
    header.extend((1..=n).map(|j| format!("q{j}")));
    for h in [
        "x_mm",
        "y_mm",
        "z_mm",
        "qw",
        "qx",
        "qy",
        "qz",
        "pred_dx_mm",
        "pred_dy_mm",
        "pred_dz_mm",
        "res_mm",
        "iterations",
        "method",
    ] {
        header.push(h.into());
    }
    let mut out = header.join(",") + "\n";
    for (line, p) in points {
        let mut row: Vec<String> = vec![line.to_string()];
        row.extend(p.q_commanded.iter().map(|q| format!("{q:.12}")));
        let t = p.commanded_base.translation.vector * 1e3;
        let r = p.commanded_base.rotation;
        row.extend(
            [t.x, t.y, t.z]
                .iter()
                .map(|v| format!("{v:.6}"))
                .chain([r.w, r.i, r.j, r.k].iter().map(|v| format!("{v:.12}"))),
        );
        let e = p.uncompensated_error * 1e3;
        row.extend([e[0], e[1], e[2]].iter().map(|v| format!("{v:.6}")));
        row.push(format!("{:.3e}", position_norm(&p.residual) * 1e3));
        row.push(p.iterations.to_string());
        row.push(
            match p.method {
                Method::FixedPoint => "fixed_point",
                Method::Newton => "newton",
            }
            .into(),
        );
        out += &(row.join(",") + "\n");
    }
    out
}

/// Runs `flexcal compensate`.
pub fn run(args: CompensateArgs) -> anyhow::Result<()> {
    let model = load_model(&args.robot)?;
    let xi = calibrated_xi(&model, args.calibrated.as_deref())?;
    let elastic = load_elastic(&args.elastic, &model, &xi, args.gamma_report.as_deref())?;
    let process = parse_process(&args.process)?;
    let x_base_part = parse_part_pose(&args.part_pose)?;
    let payload = match &args.payload {
        Some(text) => {
            let f = parse_numbers(text, 3, "--payload fx,fy,fz")?;
            Vector6::new(f[0], f[1], f[2], 0.0, 0.0, 0.0)
        }
        None => Vector6::zeros(),
    };
    let seed = match &args.seed_joints {
        Some(text) => parse_numbers(text, model.n_actuated(), "--seed-joints")?,
        None => default_seed(&model),
    };
    let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let path = read_target_path(&args.path, down)?;

    let system = ElastoGeometricModel {
        model: &model,
        xi,
        elastic: elastic.as_ref(),
        process: Some(process.as_dyn()),
        cell: Cell {
            x_base_part,
            payload_base: payload,
        },
    };
    let mut data = Data::new(&model);
    let outcomes = system.compensate_path(&mut data, &path, &seed, &CompensationOptions::default());
    let total = outcomes.len();
    let mut done = Vec::with_capacity(total);
    let mut failures = Vec::new();
    for outcome in outcomes {
        match outcome.result {
            Ok(point) => done.push((outcome.line, point)),
            Err(e) => failures.push(format!(
                "{} line {}: {e}",
                args.path.display(),
                outcome.line
            )),
        }
    }
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("{f}");
        }
        bail!(
            "{} of {total} path points could not be compensated (listed above); nothing written",
            failures.len()
        );
    }

    let csv = output_csv(&model, &done);
    let krl = match &args.krl {
        Some(_) => {
            let commanded: Vec<Isometry3<f64>> =
                done.iter().map(|(_, p)| p.commanded_base).collect();
            Some(krl_program(&commanded, &KrlOptions::default())?)
        }
        None => None,
    };
    flexcal_io::write_atomic(&args.out, csv)?;
    if let (Some(path), Some(text)) = (&args.krl, krl) {
        flexcal_io::write_atomic(path, text)?;
    }
    let max_pred = done
        .iter()
        .map(|(_, p)| position_norm(&p.uncompensated_error))
        .fold(0.0, f64::max);
    let max_res = done
        .iter()
        .map(|(_, p)| position_norm(&p.residual))
        .fold(0.0, f64::max);
    println!(
        "compensated {total} points with {} and {}: max predicted deviation {:.4} mm, max residual {:.3e} mm",
        elastic.describe(),
        process.as_dyn().describe(),
        max_pred * 1e3,
        max_res * 1e3
    );
    println!("commanded path written to {}", args.out.display());
    if let Some(path) = &args.krl {
        println!("KRL program written to {}", path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cantilever_options_are_parsed_in_si() {
        let Process::Cantilever(beam) =
            parse_process("cantilever:585,50,14,Al-5005,small,friction=0.2").unwrap()
        else {
            panic!("a cantilever was asked for");
        };
        assert!((beam.length_m - 0.585).abs() < 1e-12);
        assert!((beam.width_m - 0.050).abs() < 1e-12);
        assert!((beam.thickness_m - 0.014).abs() < 1e-12);
        assert_eq!(beam.theory, BeamTheory::SmallDeflection);
        assert!((beam.friction_coefficient - 0.2).abs() < 1e-12);
        let al = flexcal_compensate::process::material("Al-5005").unwrap();
        assert_eq!(beam.youngs_modulus_pa, al.youngs_modulus_pa);
    }

    #[test]
    fn bad_process_arguments_name_what_is_wrong() {
        let cases = [
            ("cantilever:585,50,14,unobtainium", "unobtainium"),
            ("cantilever:585,50,14,Al-5005,medium", "medium"),
            ("cantilever:585,50", "LENGTH_MM"),
            ("cantilever:-585,50,14,Al-5005", "length_m"),
            ("constant:1,2,3", "expected 6"),
            ("spring:1", "spring"),
            ("constant", "expected constant"),
        ];
        for (text, expected) in cases {
            let err = match parse_process(text) {
                Ok(_) => panic!("'{text}' was accepted"),
                Err(e) => format!("{e:#}"),
            };
            assert!(err.contains(expected), "'{text}': {err}");
        }
    }

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
