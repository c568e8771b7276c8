//! The compensation workflow: a target path, a process model and an
//! elastic model give the commanded path (the paper's fake poses,
//! equations (39)-(41)), written as CSV and optionally as a KRL program.
//!
//! Units at this boundary: positions in mm, angles in deg, forces in N,
//! moments in N.m in the text forms ([`ElasticSpec`], [`ProcessSpec`]) and
//! in the output file; SI inside.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use flexcal_compensate::compensation::{
    Cell, CompensatedPoint, CompensationMethod, CompensationOptions, DynTcpDeflection,
    ElastoGeometricModel, position_norm,
};
use flexcal_compensate::path::{KrlOptions, krl_program, read_target_path};
use flexcal_compensate::process::{BeamTheory, CantileverBeam, ConstantWrench, ProcessModel};
use flexcal_elastic::description::ElasticDescription;
use flexcal_elastic::fuzzy_compliance::{FuzzyCompliance, RobotFuzzyCompliance};
use flexcal_elastic::model::ElasticModel;
use flexcal_elastic::workflow::StiffnessReport;
use flexcal_kinematics::{Model, actuated_from_joint_angles};
use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

fn invalid(parameter: &str, message: impl Into<String>) -> Error {
    Error::InvalidParameter {
        parameter: parameter.to_string(),
        message: message.into(),
    }
}

/// An elastic model for compensation, as named by `fe:NAME|FILE` or
/// `fuzzy:FILE`.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum ElasticSpec {
    /// The FE beam model of a built-in elastic description or a description
    /// TOML, with the identified Gamma of a stiffness report (else nominal).
    Fe {
        /// Built-in name or description file.
        description: String,
        /// `flexcal identify stiffness --report` file.
        gamma_report: Option<PathBuf>,
    },
    /// A fuzzy compliance model file (`flexcal identify compliance --out`).
    Fuzzy(PathBuf),
}

impl ElasticSpec {
    /// This spec with the stiffness report whose identified Gamma an `fe:`
    /// model uses (none: leave it as it is).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] `--gamma-report` for a fuzzy model.
    pub fn with_gamma_report(mut self, report: Option<PathBuf>) -> Result<Self> {
        match (&mut self, report) {
            (Self::Fe { gamma_report, .. }, Some(path)) => *gamma_report = Some(path),
            (Self::Fuzzy(_), Some(_)) => {
                return Err(invalid(
                    "--gamma-report",
                    "applies to an fe: elastic model, not fuzzy:",
                ));
            }
            (_, None) => {}
        }
        Ok(self)
    }
}

impl FromStr for ElasticSpec {
    type Err = Error;
    fn from_str(spec: &str) -> Result<Self> {
        let (kind, value) = spec.split_once(':').ok_or_else(|| {
            invalid(
                "elastic",
                format!("'{spec}': expected fe:NAME|FILE or fuzzy:FILE"),
            )
        })?;
        match kind {
            "fe" => Ok(Self::Fe {
                description: value.to_string(),
                gamma_report: None,
            }),
            "fuzzy" => Ok(Self::Fuzzy(PathBuf::from(value))),
            other => Err(invalid(
                "elastic",
                format!("unknown kind '{other}' (expected fe or fuzzy)"),
            )),
        }
    }
}

/// Builds the elastic model of `spec` for `model` with geometric parameters
/// `xi` (the elastic-model factory).
pub fn load_elastic(
    spec: &ElasticSpec,
    model: &Model,
    xi: &[f64],
) -> Result<Box<dyn DynTcpDeflection>> {
    match spec {
        ElasticSpec::Fe {
            description,
            gamma_report,
        } => {
            let description = ElasticDescription::builtin_or_file(description)?;
            let elastic = ElasticModel::new(model, &description)?;
            let (gamma, origin) = match gamma_report {
                Some(path) => (
                    StiffnessReport::read(path)?.gamma_for(&elastic, path)?,
                    "identified Gamma",
                ),
                None => (elastic.nominal_gamma(), "nominal Gamma"),
            };
            let label = format!("FE beam model '{}' ({origin})", description.name);
            Ok(Box::new(flexcal_elastic::tcp::FeTcpModel::new(
                elastic,
                xi.to_vec(),
                gamma,
                label,
            )?))
        }
        ElasticSpec::Fuzzy(path) => {
            let compliance = FuzzyCompliance::read(path)?;
            Ok(Box::new(RobotFuzzyCompliance::new(
                compliance,
                model.clone(),
            )?))
        }
    }
}

/// A process model, as named by `constant:fx,fy,fz,mx,my,mz` (N, N.m, part
/// frame) or `cantilever:LENGTH_MM,WIDTH_MM,THICKNESS_MM,MATERIAL[,small|large][,friction=MU]`.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum ProcessSpec {
    /// A constant wrench on the tool.
    Constant(ConstantWrench),
    /// A clamped beam formed by the tool.
    Cantilever(CantileverBeam),
}

impl ProcessSpec {
    /// The process model.
    pub fn as_process(&self) -> &dyn ProcessModel {
        match self {
            Self::Constant(p) => p,
            Self::Cantilever(p) => p,
        }
    }
}

/// Parses comma-separated finite numbers, as many as there are; `what`
/// names the parameter in errors.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `what` and the item that is not a
/// finite number.
pub fn parse_number_list(text: &str, what: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(|s| {
            let s = s.trim();
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| invalid(what, format!("'{s}' is not a finite number")))
        })
        .collect()
}

/// Parses `n` comma-separated finite numbers; `what` names the parameter.
///
/// # Errors
/// [`Error::InvalidParameter`] naming `what`: an item that is not a finite
/// number, or a count other than `n`.
pub fn parse_numbers(text: &str, n: usize, what: &str) -> Result<Vec<f64>> {
    let values = parse_number_list(text, what)?;
    if values.len() != n {
        return Err(invalid(
            what,
            format!(
                "expected {n} comma-separated numbers, found {}",
                values.len()
            ),
        ));
    }
    Ok(values)
}

impl FromStr for ProcessSpec {
    type Err = Error;
    fn from_str(text: &str) -> Result<Self> {
        let (kind, value) = text.split_once(':').ok_or_else(|| {
            invalid(
                "--process",
                format!("'{text}': expected constant:... or cantilever:..."),
            )
        })?;
        match kind.trim() {
            "constant" => {
                let v = parse_numbers(value, 6, "--process constant:fx,fy,fz,mx,my,mz")?;
                Ok(Self::Constant(ConstantWrench {
                    wrench: Vector6::from_column_slice(&v),
                }))
            }
            "cantilever" => {
                let fields: Vec<&str> = value.split(',').map(str::trim).collect();
                if fields.len() < 4 {
                    return Err(invalid(
                        "--process cantilever",
                        format!(
                            "expected LENGTH_MM,WIDTH_MM,THICKNESS_MM,MATERIAL[,small|large][,friction=MU], found '{value}'"
                        ),
                    ));
                }
                let dims = parse_numbers(
                    &fields[..3].join(","),
                    3,
                    "--process cantilever LENGTH_MM,WIDTH_MM,THICKNESS_MM",
                )?;
                let material =
                    flexcal_compensate::process::material(fields[3]).ok_or_else(|| {
                        invalid(
                            "--process cantilever",
                            format!("unknown material '{}'", fields[3]),
                        )
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
                            beam.friction_coefficient = other
                                .strip_prefix("friction=")
                                .and_then(|m| m.trim().parse::<f64>().ok())
                                .ok_or_else(|| {
                                    invalid(
                                        "--process cantilever",
                                        format!(
                                            "'{other}' is neither small, large nor friction=MU"
                                        ),
                                    )
                                })?;
                        }
                    }
                }
                beam.validate()
                    .map_err(|e| invalid("--process cantilever", e.to_string()))?;
                Ok(Self::Cantilever(beam))
            }
            other => Err(invalid(
                "--process",
                format!("unknown kind '{other}' (expected constant or cantilever)"),
            )),
        }
    }
}

/// A pose given as `x_mm, y_mm, z_mm, a_deg, b_deg, c_deg` (KUKA A, B, C =
/// rotations about z, y, x), in SI.
pub fn pose_mm_deg(v: &[f64; 6]) -> Isometry3<f64> {
    Isometry3::from_parts(
        nalgebra::Translation3::new(v[0] * 1e-3, v[1] * 1e-3, v[2] * 1e-3),
        flexcal_compensate::path::rotation_from_abc(
            v[3].to_radians(),
            v[4].to_radians(),
            v[5].to_radians(),
        ),
    )
}

/// Geometric parameters of a calibrated robot description (the output of
/// `flexcal calibrate --out`), checked against `model`; none: nominal.
pub fn calibrated_xi(model: &Model, file: Option<&Path>) -> Result<Vec<f64>> {
    let Some(file) = file else {
        return Ok(model.nominal_params().to_vec());
    };
    let spec = file.display().to_string();
    let calibrated = crate::load_robot(&spec)?;
    let same = calibrated.n_params() == model.n_params()
        && calibrated
            .params()
            .iter()
            .zip(model.params())
            .all(|(a, b)| a.name == b.name);
    if !same {
        return Err(invalid(
            &format!("--calibrated {spec}"),
            format!(
                "its geometric parameters do not match robot '{}' ({} vs {} parameters or different names)",
                model.name(),
                calibrated.n_params(),
                model.n_params()
            ),
        ));
    }
    Ok(calibrated.nominal_params().to_vec())
}

/// The default start of the inverse model for the first path point: for
/// six-joint arms the working area of the forming cell (upper arm forward,
/// forearm down), else the middle of the joint limits.
pub fn default_start_joints(model: &Model) -> Vec<f64> {
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

/// The cell and the start of a compensation.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensationSetup {
    /// Part frame in the robot base frame.
    pub x_base_part: Isometry3<f64>,
    /// Constant wrench on the tool (payload, dead weight), base frame [N; N.m].
    pub payload_base: Vector6<f64>,
    /// Start of the inverse model for the first point (actuated coordinates).
    pub start_joints: Vec<f64>,
}

impl CompensationSetup {
    /// The set-up from its text forms: the part frame in the robot base
    /// `x_mm,y_mm,z_mm,a_deg,b_deg,c_deg` (KUKA A, B, C = rotations about
    /// z, y, x), the constant force on the tool in the base frame `fx,fy,fz`
    /// (N; none: no payload) and the start of the inverse model (actuated
    /// coordinates, rad or m; none: [`default_start_joints`]).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the option (`--part-pose`,
    /// `--payload`, `--seed-joints`) whose text is not the right count of
    /// finite numbers.
    pub fn from_text(
        model: &Model,
        part_pose: &str,
        payload: Option<&str>,
        start_joints: Option<&str>,
    ) -> Result<Self> {
        let v = parse_numbers(part_pose, 6, "--part-pose x_mm,y_mm,z_mm,a_deg,b_deg,c_deg")?;
        let payload_base = match payload {
            Some(text) => {
                let f = parse_numbers(text, 3, "--payload fx,fy,fz")?;
                Vector6::new(f[0], f[1], f[2], 0.0, 0.0, 0.0)
            }
            None => Vector6::zeros(),
        };
        let start_joints = match start_joints {
            Some(text) => parse_numbers(text, model.n_actuated(), "--seed-joints")?,
            None => default_start_joints(model),
        };
        Ok(Self {
            x_base_part: pose_mm_deg(&[v[0], v[1], v[2], v[3], v[4], v[5]]),
            payload_base,
            start_joints,
        })
    }
}

/// The controller formats a commanded path is exported to, besides its CSV.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum PathExport {
    /// A KRL program ([`CommandedPath::to_krl`]).
    Krl,
    /// An ABB RAPID module ([`CommandedPath::to_rapid`]).
    Rapid,
    /// A joint-trajectory CSV ([`CommandedPath::to_joint_csv`]).
    JointCsv,
}

impl PathExport {
    /// What the export is, for messages (`KRL program`, ...).
    pub fn description(self) -> &'static str {
        match self {
            Self::Krl => "KRL program",
            Self::Rapid => "RAPID module",
            Self::JointCsv => "joint trajectory",
        }
    }
}

/// The commanded path: one compensated point per target point.
#[derive(Debug, Clone)]
pub struct CommandedPath {
    /// The points, with the line of their target in the path file.
    pub points: Vec<(usize, CompensatedPoint)>,
    /// Description of the elastic model used.
    pub elastic: String,
    /// Description of the process model used.
    pub process: String,
}

/// Compensates the target path of the file `path` (`x_mm,y_mm,z_mm` plus
/// optionally an orientation; default: tool z along -z of the part).
///
/// # Errors
/// An unreadable path file, or points that cannot be compensated (every one
/// is named by its line).
pub fn compensate_path_file(
    model: &Model,
    xi: Vec<f64>,
    elastic: &dyn DynTcpDeflection,
    process: &dyn ProcessModel,
    setup: &CompensationSetup,
    path: &Path,
) -> Result<CommandedPath> {
    let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let targets = read_target_path(path, down)?;
    let system = ElastoGeometricModel {
        model,
        xi,
        elastic,
        process: Some(process),
        cell: Cell {
            x_base_part: setup.x_base_part,
            payload_base: setup.payload_base,
        },
    };
    // Parallel threads sharing the model, each with its own workspace.
    let outcomes = system.compensate_path_parallel(
        &targets,
        &setup.start_joints,
        &CompensationOptions::default(),
    )?;
    let total = outcomes.len();
    let mut points = Vec::with_capacity(total);
    let mut failures = Vec::new();
    for outcome in outcomes {
        match outcome.result {
            Ok(point) => points.push((outcome.line, point)),
            Err(e) => failures.push(format!("{} line {}: {e}", path.display(), outcome.line)),
        }
    }
    if !failures.is_empty() {
        return Err(Error::PathPoints {
            failed: failures.len(),
            total,
            failures,
        });
    }
    Ok(CommandedPath {
        points,
        elastic: elastic.describe_dyn(),
        process: process.describe(),
    })
}

impl CommandedPath {
    /// Largest predicted position deviation without compensation (m).
    pub fn max_predicted_deviation_m(&self) -> f64 {
        self.points
            .iter()
            .map(|(_, p)| position_norm(&p.uncompensated_error))
            .fold(0.0, f64::max)
    }

    /// Largest position residual after compensation (m).
    pub fn max_residual_m(&self) -> f64 {
        self.points
            .iter()
            .map(|(_, p)| position_norm(&p.residual))
            .fold(0.0, f64::max)
    }

    /// The commanded path as CSV: per point `line, q1..qn,
    /// x_mm,y_mm,z_mm,qw,qx,qy,qz` (commanded TCP, base frame),
    /// `pred_dx_mm,pred_dy_mm,pred_dz_mm` (predicted error without
    /// compensation), `res_mm`, `iterations`, `method`.
    pub fn to_csv(&self, n_actuated: usize) -> String {
        let mut header: Vec<String> = vec!["line".into()];
        header.extend((1..=n_actuated).map(|j| format!("q{j}")));
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
        for (line, p) in &self.points {
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
                    CompensationMethod::FixedPoint => "fixed_point",
                    CompensationMethod::Newton => "newton",
                }
                .into(),
            );
            out += &(row.join(",") + "\n");
        }
        out
    }

    /// The text of the export `kind` (`robot` gives the joint names and
    /// units of a joint trajectory).
    ///
    /// # Errors
    /// A path the format cannot express.
    pub fn export(&self, kind: PathExport, robot: &Model) -> Result<String> {
        match kind {
            PathExport::Krl => self.to_krl(),
            PathExport::Rapid => self.to_rapid(),
            PathExport::JointCsv => self.to_joint_csv(robot),
        }
    }

    /// Writes the commanded path as CSV to `csv` ([`CommandedPath::to_csv`])
    /// and each export of `exports` to its file, and returns one line per
    /// file written. Every text is built before any file is written, so a
    /// path a format cannot express leaves every file as it was.
    ///
    /// # Errors
    /// A path an export cannot express; a file that cannot be written.
    pub fn write(
        &self,
        robot: &Model,
        csv: &Path,
        exports: &[(PathExport, PathBuf)],
    ) -> Result<Vec<String>> {
        let texts = exports
            .iter()
            .map(|(kind, _)| self.export(*kind, robot))
            .collect::<Result<Vec<_>>>()?;
        flexcal_io::write_atomic(csv, self.to_csv(robot.n_actuated()))?;
        let mut written = vec![format!("commanded path written to {}", csv.display())];
        for ((kind, path), text) in exports.iter().zip(texts) {
            flexcal_io::write_atomic(path, text)?;
            written.push(format!(
                "{} written to {}",
                kind.description(),
                path.display()
            ));
        }
        Ok(written)
    }

    /// One line: the number of points, the models, the largest predicted
    /// deviation without compensation and the largest residual (mm).
    pub fn summary_line(&self) -> String {
        format!(
            "compensated {} points with {} and {}: max predicted deviation {:.4} mm, max residual {:.3e} mm",
            self.points.len(),
            self.elastic,
            self.process,
            self.max_predicted_deviation_m() * 1e3,
            self.max_residual_m() * 1e3
        )
    }

    /// The commanded path as a KRL program (PTP to the first point, then
    /// one LIN per point).
    pub fn to_krl(&self) -> Result<String> {
        Ok(krl_program(
            &self.commanded_poses(),
            &KrlOptions::default(),
        )?)
    }

    /// The commanded path as an ABB RAPID module (`MoveL` through
    /// `robtarget`s; [`flexcal_compensate::export::rapid_module`] with its
    /// default speed, zone, tool and work object).
    pub fn to_rapid(&self) -> Result<String> {
        Ok(flexcal_compensate::export::rapid_module(
            &self.commanded_poses(),
            &flexcal_compensate::export::RapidOptions::default(),
        )?)
    }

    /// The commanded actuated coordinates as a joint-trajectory CSV (one
    /// row per point, no time column; deg and mm, in columns named by the
    /// robot's actuated coordinates with their unit).
    pub fn to_joint_csv(&self, robot: &Model) -> Result<String> {
        let q: Vec<Vec<f64>> = self
            .points
            .iter()
            .map(|(_, p)| p.q_commanded.clone())
            .collect();
        Ok(flexcal_compensate::export::joint_trajectory_csv(
            robot, &q, None,
        )?)
    }

    /// The commanded TCP poses in the robot base frame.
    fn commanded_poses(&self) -> Vec<Isometry3<f64>> {
        self.points.iter().map(|(_, p)| p.commanded_base).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_pose_is_read_in_mm_and_deg() {
        let model = crate::load_robot("ir663").unwrap();
        let setup =
            CompensationSetup::from_text(&model, "1200,0,1450,90,0,0", Some("0,0,-920"), None)
                .unwrap();
        let x = setup.x_base_part;
        assert!((x.translation.vector - Vector3::new(1.2, 0.0, 1.45)).norm() < 1e-12);
        // A = 90 deg turns the part's x axis onto the base y axis.
        let x_axis = x.rotation * Vector3::x();
        assert!((x_axis - Vector3::y()).norm() < 1e-12);
        assert_eq!(
            setup.payload_base,
            Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)
        );
        assert_eq!(setup.start_joints, default_start_joints(&model));
        for (pose, payload, seed, named) in [
            ("1200,0,1450,0,0", None, None, "--part-pose"),
            ("1200,0,inf,0,0,0", None, None, "--part-pose"),
            ("0,0,0,0,0,0", Some("0,-920"), None, "--payload"),
            ("0,0,0,0,0,0", None, Some("0,0"), "--seed-joints"),
        ] {
            let err = CompensationSetup::from_text(&model, pose, payload, seed)
                .unwrap_err()
                .to_string();
            assert!(err.starts_with(named), "{err}");
        }
    }

    #[test]
    fn a_gamma_report_belongs_to_an_fe_model() {
        let fe: ElasticSpec = "fe:ir663".parse().unwrap();
        let with = fe.with_gamma_report(Some("s.json".into())).unwrap();
        assert_eq!(
            with,
            ElasticSpec::Fe {
                description: "ir663".into(),
                gamma_report: Some("s.json".into())
            }
        );
        let fuzzy: ElasticSpec = "fuzzy:c.toml".parse().unwrap();
        assert_eq!(fuzzy.clone().with_gamma_report(None).unwrap(), fuzzy);
        let err = fuzzy.with_gamma_report(Some("s.json".into())).unwrap_err();
        assert!(err.to_string().starts_with("--gamma-report"), "{err}");
    }

    #[test]
    fn cantilever_options_are_parsed_in_si() {
        let Ok(ProcessSpec::Cantilever(beam)) =
            "cantilever:585,50,14,Al-5005,small,friction=0.2".parse::<ProcessSpec>()
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
            let err = match text.parse::<ProcessSpec>() {
                Ok(_) => panic!("'{text}' was accepted"),
                Err(e) => e.to_string(),
            };
            assert!(err.contains(expected), "'{text}': {err}");
        }
    }

    #[test]
    fn elastic_specs_name_their_kind() {
        assert_eq!(
            "fe:ir663".parse::<ElasticSpec>().unwrap(),
            ElasticSpec::Fe {
                description: "ir663".into(),
                gamma_report: None
            }
        );
        assert_eq!(
            "fuzzy:model.toml".parse::<ElasticSpec>().unwrap(),
            ElasticSpec::Fuzzy("model.toml".into())
        );
        let err = "spring:x".parse::<ElasticSpec>().unwrap_err().to_string();
        assert!(
            err.contains("spring") && err.contains("fe or fuzzy"),
            "{err}"
        );
    }
}
