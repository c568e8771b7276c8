//! The forming experiment of the reference paper (section 4, Figure 17) on
//! the virtual IR-663, from the files a user has: a tool carrying a dead
//! weight (650 N by default, unlike every load of the elastic campaign)
//! plunges 25 mm into a clamped Al-5005 bar and travels 200 mm, commanded
//! without compensation and with each elastic model given (`flexcal twin
//! forming`).
//!
//! The twin ([`flexcal_twin::forming::TwinCell`]) plays the cell: its own
//! robot, bar, clamp, tool tip, friction and weight, and a camera. The
//! user's side ([`run_forming`]) has the calibrated geometry, the
//! identified models, the handbook bar of [`CantileverBeam`] and the
//! weighed dead weight, and locates the part as a cell does: it fits the
//! part's drawing to its reference points measured by the camera
//! ([`flexcal_calib::register_points`]) and carries that pose into the
//! calibrated robot's base through the registered camera frame. The
//! deviations are measured by the same camera, relative to the part so
//! located, and reported over the points where the tool is in contact
//! with the bar (below its undeformed surface, where the process load
//! acts) and over the whole path.

use std::path::{Path, PathBuf};

use flexcal_compensate::compensation::{
    Cell, CompensationOptions, DynTcpDeflection, ElastoGeometricModel,
};
use flexcal_compensate::path::{PathPoint, target_path_to_csv};
use flexcal_compensate::process::{BeamTheory, CantileverBeam, ProcessModel};
use flexcal_elastic::description::ElasticDescription;
use flexcal_elastic::fuzzy_compliance::{FuzzyCompliance, RobotFuzzyCompliance};
use flexcal_elastic::model::ElasticModel;
use flexcal_elastic::tcp::FeTcpModel;
use flexcal_elastic::workflow::StiffnessReport;
use flexcal_kinematics::{Model, actuated_from_joint_angles, inverse_pose};
use flexcal_twin::forming::{FormingOptions, TwinCell, forming_path};
use flexcal_twin::truth::TruthSwitches;
use nalgebra::{Isometry3, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// The deviation a path may keep along z_p to meet the paper's bar (mm).
pub const PAPER_TOLERANCE_MM: f64 = 0.15;

/// One measured path: per point, the deviation of the measured TCP from the
/// target along x_p and z_p (mm), in the part frame as the camera located it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct MeasuredPath {
    /// Which command produced it.
    pub label: String,
    /// Deviation along x_p (mm).
    pub deviation_x_mm: Vec<f64>,
    /// Deviation along z_p (mm).
    pub deviation_z_mm: Vec<f64>,
    /// Largest |deviation along z_p| over the whole path (mm).
    pub max_abs_deviation_z_mm: f64,
    /// Largest |deviation along z_p| over the contact points (mm).
    pub max_abs_deviation_z_contact_mm: f64,
    /// Deviation predicted by the user's model before compensation (z_p, mm),
    /// when the path was compensated with a model.
    pub predicted_uncompensated_z_mm: Option<Vec<f64>>,
    /// The twin's truth: the bar's normal push on the tool at each point (N).
    pub true_contact_force_n: Vec<f64>,
}

/// Result of the forming experiment.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FormingResult {
    /// Target path points in the part frame: (x_p, z_p) (mm).
    pub target_mm: Vec<(f64, f64)>,
    /// Whether each point is a contact point: the target lies below the
    /// bar's undeformed top surface, so the tool presses on it.
    pub contact: Vec<bool>,
    /// The dead weight as weighed (N).
    pub dead_weight_n: f64,
    /// RMS distance between the part's measured reference points and the
    /// fitted drawing (mm): how well the part was located, as a user sees it.
    pub part_fit_rms_mm: f64,
    /// The path commanded without compensation (inverse geometric model of
    /// the calibrated robot).
    pub uncompensated: MeasuredPath,
    /// One measured path per elastic model used for compensation.
    pub compensated: Vec<MeasuredPath>,
}

impl FormingResult {
    /// The columns of [`FormingResult::paths_csv`].
    pub const PATH_COLUMNS: [&'static str; 6] = [
        "path",
        "point",
        "x_target_mm",
        "z_target_mm",
        "x_measured_mm",
        "z_measured_mm",
    ];

    /// The measured paths in order: the uncompensated one (path 0), then
    /// one per elastic model.
    pub fn paths(&self) -> impl Iterator<Item = &MeasuredPath> {
        std::iter::once(&self.uncompensated).chain(&self.compensated)
    }

    /// The data of the paper's Figure 17 as CSV ([`Self::PATH_COLUMNS`]):
    /// one row per (path, point), the path's index in [`Self::paths`], the
    /// point's index, the target and the measured TCP in the part frame
    /// (x_p, z_p, mm).
    pub fn paths_csv(&self) -> String {
        let rows = self.paths().enumerate().flat_map(|(p, path)| {
            self.target_mm.iter().enumerate().map(move |(k, &(x, z))| {
                vec![
                    p as f64,
                    k as f64,
                    x,
                    z,
                    x + path.deviation_x_mm[k],
                    z + path.deviation_z_mm[k],
                ]
            })
        });
        flexcal_io::format_csv(&Self::PATH_COLUMNS, rows)
    }
}

/// The user's side of the forming cell: what was identified and weighed.
pub struct UserCell<'a> {
    /// The robot's nominal model.
    pub robot: &'a Model,
    /// The calibrated geometric parameters (m, rad).
    pub calibrated_xi: &'a [f64],
    /// The registered camera frame `x_meas_base` of the calibration; none:
    /// the part's true pose in the base is taken as known.
    pub x_meas_base: Option<Isometry3<f64>>,
    /// The bar as the user models it (handbook modulus, no friction, point
    /// contact at the TCP).
    pub beam: CantileverBeam,
}

fn payload(x_base_part: Isometry3<f64>, weight_n: f64) -> Cell {
    Cell {
        x_base_part,
        payload_base: Vector6::new(0.0, 0.0, -weight_n, 0.0, 0.0, 0.0),
    }
}

/// Largest |value| over the points where `keep` holds.
fn largest(values: &[f64], keep: impl Fn(usize) -> bool) -> f64 {
    values
        .iter()
        .enumerate()
        .filter(|(k, _)| keep(*k))
        .fold(0.0f64, |m, (_, v)| m.max(v.abs()))
}

/// Runs the forming experiment: locates the part, commands the path
/// without compensation, then with each of `models` (label, elastic
/// model), and lets the twin `twin` execute and measure each.
///
/// # Errors
/// A part that cannot be located, a path point that cannot be commanded
/// or executed (named).
pub fn run_forming(
    twin: &TwinCell,
    user: &UserCell,
    models: &[(&str, &dyn DynTcpDeflection)],
    options: &FormingOptions,
) -> Result<FormingResult> {
    let point_error = |k: usize, e: String| Error::InvalidParameter {
        parameter: format!("forming path point {k}"),
        message: e,
    };
    user.beam.validate().map_err(|e| Error::InvalidParameter {
        parameter: "beam".into(),
        message: e.to_string(),
    })?;
    // Locate the part: its drawing fitted to the measured reference points.
    let points = twin.locate_part(options);
    let measured: Vec<Vector3<f64>> = points.iter().map(|p| p.measured_camera_m).collect();
    let nominal: Vec<Vector3<f64>> = points.iter().map(|p| p.nominal_part_m).collect();
    let x_meas_part = flexcal_calib::register_points(&measured, &nominal)?;
    let fit_rms_mm = (measured
        .iter()
        .zip(&nominal)
        .map(|(m, n)| (x_meas_part.transform_point(&(*n).into()).coords - m).norm_squared())
        .sum::<f64>()
        / measured.len() as f64)
        .sqrt()
        * 1e3;
    let x_base_part_user = match &user.x_meas_base {
        Some(frame) => frame.inverse() * x_meas_part,
        None => options.x_base_part,
    };
    let x_part_meas = x_meas_part.inverse();
    let path = forming_path(options);
    let contact: Vec<bool> = path
        .iter()
        .map(|p| p.x_part_tcp.translation.vector.z < -1e-9)
        .collect();
    let compensation = CompensationOptions::default();
    let robot = user.robot;
    let mut data = flexcal_kinematics::Data::new(robot);
    let start = actuated_from_joint_angles(robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0])?;
    // Without compensation: the inverse geometric model of the calibrated robot.
    let mut seed = start;
    let mut uncompensated_q = Vec::with_capacity(path.len());
    for (k, p) in path.iter().enumerate() {
        let target = x_base_part_user * p.x_part_tcp;
        let s = inverse_pose(
            robot,
            &mut data,
            &target,
            &seed,
            user.calibrated_xi,
            &compensation.inverse,
        )
        .map_err(|e| point_error(k, e.to_string()))?;
        seed.clone_from(&s.q);
        uncompensated_q.push(s.q);
    }
    let process: &dyn ProcessModel = &user.beam;
    let mut commanded = vec![("uncompensated".to_string(), uncompensated_q.clone(), None)];
    for (label, elastic) in models {
        let model = ElastoGeometricModel {
            model: robot,
            xi: user.calibrated_xi.to_vec(),
            elastic: *elastic,
            process: Some(process),
            cell: payload(x_base_part_user, options.dead_weight_n),
        };
        let mut model_data = model.data()?;
        let outcomes =
            model.compensate_path(&mut model_data, &path, &uncompensated_q[0], &compensation);
        let mut commands = Vec::with_capacity(outcomes.len());
        let mut predicted = Vec::with_capacity(outcomes.len());
        for (k, o) in outcomes.into_iter().enumerate() {
            let c = o.result.map_err(|e| point_error(k, e.to_string()))?;
            let e = c.uncompensated_error;
            let e_part = x_base_part_user.rotation.inverse() * Vector3::new(e[0], e[1], e[2]);
            predicted.push(e_part.z * 1e3);
            commands.push(c.q_commanded);
        }
        commanded.push((label.to_string(), commands, Some(predicted)));
    }
    let mut measured_paths = Vec::with_capacity(commanded.len());
    for (stream, (label, commands, predicted)) in commanded.into_iter().enumerate() {
        let executed = twin.run_path(&commands, options, stream as u64)?;
        let (mut dx, mut dz) = (Vec::new(), Vec::new());
        for (m, p) in executed.measured_camera_m.iter().zip(&path) {
            let in_part = x_part_meas.transform_point(&(*m).into());
            let target = p.x_part_tcp.translation.vector;
            dx.push((in_part.x - target.x) * 1e3);
            dz.push((in_part.z - target.z) * 1e3);
        }
        measured_paths.push(MeasuredPath {
            label,
            max_abs_deviation_z_mm: largest(&dz, |_| true),
            max_abs_deviation_z_contact_mm: largest(&dz, |k| contact[k]),
            deviation_x_mm: dx,
            deviation_z_mm: dz,
            predicted_uncompensated_z_mm: predicted,
            true_contact_force_n: executed.contact_normal_n,
        });
    }
    let uncompensated = measured_paths.remove(0);
    Ok(FormingResult {
        target_mm: path
            .iter()
            .map(|p| {
                let t = p.x_part_tcp.translation.vector;
                (t.x * 1e3, t.z * 1e3)
            })
            .collect(),
        contact,
        dead_weight_n: options.dead_weight_n,
        part_fit_rms_mm: fit_rms_mm,
        uncompensated,
        compensated: measured_paths,
    })
}

/// The user's bar: the paper's Al-5005 bar with the handbook modulus, no
/// friction, large deflection.
pub fn user_beam() -> CantileverBeam {
    CantileverBeam::reference(BeamTheory::LargeDeflection)
}

/// The user's files of a forming experiment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FormingConfig {
    /// Seed of the measurement noise (default 17).
    pub seed: u64,
    /// Calibrated robot description (`flexcal calibrate --out`) whose xi
    /// commands the robot; none: the nominal xi.
    pub calibrated: Option<PathBuf>,
    /// The calibration's report (`flexcal calibrate --report`): its
    /// identified measurement frame carries the part, located by the
    /// camera, into the calibrated robot's base; none: the part's pose in
    /// the base is taken as known exactly.
    pub calibration_report: Option<PathBuf>,
    /// Stiffness report (`flexcal identify stiffness --report`) whose Gamma
    /// the FE beam model uses; none: the nominal Gamma.
    pub fe_report: Option<PathBuf>,
    /// Fuzzy compliance model (`flexcal identify compliance --out`) to
    /// compensate with too.
    pub fuzzy: Option<PathBuf>,
}

impl Default for FormingConfig {
    fn default() -> Self {
        Self {
            seed: FormingOptions::default().seed,
            calibrated: None,
            calibration_report: None,
            fe_report: None,
            fuzzy: None,
        }
    }
}

/// A forming experiment: its target path and what the twin measured.
#[derive(Debug, Clone, PartialEq)]
pub struct FormingExperiment {
    /// The target path in the part frame.
    pub target_path: Vec<PathPoint>,
    /// The measured paths: uncompensated, then one per elastic model (the
    /// fuzzy model first when given, then the FE beam model).
    pub result: FormingResult,
}

impl FormingExperiment {
    /// The files [`FormingExperiment::write`] writes, in order.
    pub const FILES: [&'static str; 3] = [
        "target_path.csv",
        "forming_result.json",
        "forming_paths.csv",
    ];

    /// Writes the target path (`target_path.csv`), the result
    /// (`forming_result.json`) and the data of Figure 17
    /// (`forming_paths.csv`, [`FormingResult::paths_csv`]) into `dir`
    /// (created if missing), each atomically.
    ///
    /// # Errors
    /// The file that could not be written.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let json = serde_json::to_string_pretty(&self.result).map_err(|source| Error::Json {
            context: "forming result".into(),
            source,
        })?;
        let texts = [
            target_path_to_csv(&self.target_path),
            json + "\n",
            self.result.paths_csv(),
        ];
        for (name, text) in Self::FILES.iter().zip(texts) {
            flexcal_io::write_atomic(dir.join(name), text)?;
        }
        Ok(())
    }
}

impl FormingExperiment {
    /// What `flexcal twin forming` prints once [`FormingExperiment::write`]
    /// has written into `dir`: the largest |deviation along z_p| (mm)
    /// uncompensated and with each model, then the files and the paths'
    /// numbers in `forming_paths.csv`; `seed` is the measurement noise's.
    pub fn summary_text(&self, seed: u64, dir: &Path) -> String {
        let result = &self.result;
        let mut text = format!(
            "virtual IR-663 forming (seed {seed}, {:.0} N dead weight): max |deviation along z_p| over the contact points (whole path) {:.3} mm ({:.3} mm) uncompensated\n",
            result.dead_weight_n,
            result.uncompensated.max_abs_deviation_z_contact_mm,
            result.uncompensated.max_abs_deviation_z_mm
        );
        for c in &result.compensated {
            text += &format!(
                "  {}: {:.3} mm ({:.3} mm)\n",
                c.label, c.max_abs_deviation_z_contact_mm, c.max_abs_deviation_z_mm
            );
        }
        let labels: Vec<String> = result
            .paths()
            .enumerate()
            .map(|(p, path)| format!("{p}: {}", path.label))
            .collect();
        text + &format!(
            "target_path.csv, forming_result.json and forming_paths.csv (paths {}) written to {}\n",
            labels.join("; "),
            dir.display()
        )
    }
}

/// Runs the forming experiment on the virtual IR-663 with the user's files.
///
/// # Errors
/// An unreadable or mismatched file (calibrated robot, reports, fuzzy
/// model), named; a path point that cannot be commanded.
pub fn run_forming_experiment(config: &FormingConfig) -> Result<FormingExperiment> {
    let robot = crate::load_robot("ir663")?;
    let twin = TwinCell::new(TruthSwitches::default())?;
    let xi = crate::compensation::calibrated_xi(&robot, config.calibrated.as_deref())?;
    // The FE model the user would have: the built-in description, not the twin's truth.
    let description = ElasticDescription::builtin("ir663")?;
    let fe_model = ElasticModel::new(&robot, &description)?;
    let (gamma, origin) = match &config.fe_report {
        Some(path) => (
            StiffnessReport::read(path)?.gamma_for(&fe_model, path)?,
            "identified Gamma",
        ),
        None => (fe_model.nominal_gamma(), "nominal Gamma"),
    };
    let fe_label = format!("compensated, FE beam model ({origin})");
    let fe = FeTcpModel::new(fe_model, xi.clone(), gamma, fe_label.clone())?;
    let fuzzy = match &config.fuzzy {
        Some(path) => Some(RobotFuzzyCompliance::new(
            FuzzyCompliance::read(path)?,
            robot.clone(),
        )?),
        None => None,
    };
    let mut models: Vec<(&str, &dyn DynTcpDeflection)> = Vec::new();
    if let Some(f) = &fuzzy {
        models.push(("compensated, fuzzy model", f));
    }
    models.push((&fe_label, &fe));
    let x_meas_base = match &config.calibration_report {
        Some(path) => Some(flexcal_calib::read_measurement_frame(path)?),
        None => None,
    };
    let options = FormingOptions {
        seed: config.seed,
        ..FormingOptions::default()
    };
    let user = UserCell {
        robot: &robot,
        calibrated_xi: &xi,
        x_meas_base,
        beam: user_beam(),
    };
    let result = run_forming(&twin, &user, &models, &options)?;
    Ok(FormingExperiment {
        target_path: forming_path(&options),
        result,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_experiment_writes_the_measured_paths_of_figure_17() {
        let experiment = run_forming_experiment(&FormingConfig::default()).unwrap();
        let result = &experiment.result;
        assert_eq!(result.compensated.len(), 1, "the FE beam model only");
        assert_eq!(result.target_mm.len(), experiment.target_path.len());
        let dir = tempfile::tempdir().unwrap();
        experiment.write(dir.path()).unwrap();
        let table = flexcal_io::CsvTable::read(
            dir.path().join("forming_paths.csv"),
            &flexcal_io::CsvOptions::default(),
        )
        .unwrap();
        let n = result.target_mm.len();
        assert_eq!(table.len(), 2 * n);
        // Row (path 1, point k): the compensated path's measured z is the
        // target's plus its deviation.
        let k = n / 2;
        let z_measured = table.column_f64("z_measured_mm").unwrap()[n + k];
        let expected = result.target_mm[k].1 + result.compensated[0].deviation_z_mm[k];
        assert!((z_measured - expected).abs() < 1e-12);
        let json = std::fs::read_to_string(dir.path().join("forming_result.json")).unwrap();
        let value: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(
            value["uncompensated"]["max_abs_deviation_z_mm"].as_f64(),
            Some(result.uncompensated.max_abs_deviation_z_mm)
        );
        // The summary: the uncompensated deviation, one line per model,
        // then the files with the paths' numbers.
        let text = experiment.summary_text(17, dir.path());
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2 + result.compensated.len(), "{text}");
        assert!(
            lines[0].starts_with("virtual IR-663 forming (seed 17, 650 N dead weight): max |deviation along z_p| over the contact points "),
            "{text}"
        );
        assert!(
            lines[1].starts_with("  compensated, FE beam model (nominal Gamma): "),
            "{text}"
        );
        assert!(lines[2].contains("(paths 0: "), "{text}");
        assert!(lines[2].ends_with(&format!("written to {}", dir.path().display())));
    }
}
