//! The paper's forming experiment (section 4) on the virtual IR-663.
//!
//! A clamped Al-5005 beam (585 x 50 x 14 mm) is bent elastically by the
//! tool: the tool plunges 25 mm at the free end, then travels 200 mm along the
//! beam towards the clamp, with a 920 N dead weight on the end-effector. The
//! beam pushes back according to where the tool actually is, so the robot
//! and the beam are solved together.
//!
//! The twin plays the real cell ([`TwinCell`]): the robot is the
//! [`TwinRobot`] of the other campaigns (Appendix C
//! geometry, its own weight through its own FE structure, the drives' lost
//! motion and hardening, transmission errors), the beam is stiffer than its
//! handbook value and rubs on the tool with Coulomb friction, the dead
//! weight is what the scale could not tell ([`crate::truth::process`]), and
//! the path is measured by the same photogrammetry system. The user's side
//! commands the robot with what was identified only: the calibrated
//! geometry, an identified elastic model (the fuzzy compliance model or the
//! FE beam model) and the process model of [`FormingOptions::beam`] with the
//! handbook modulus, no friction and the weighed 920 N.
//!
//! Measured deviations are reported along the part frame's z axis (the
//! paper's Figure 17), in millimetres.

use flexcal_compensate::compensation::{
    Cell, CompensationData, CompensationError, CompensationOptions, DynTcpDeflection,
    ElastoGeometricModel,
};
use flexcal_compensate::path::PathPoint;
use flexcal_compensate::process::{BeamTheory, CantileverBeam, ProcessModel};
/// The FE beam model seen from the TCP (it lives with the elastic models).
pub use flexcal_elastic::tcp::FeTcpModel;
use flexcal_kinematics::{actuated_from_joint_angles, inverse_pose};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::truth::{
    FormingTruth, Photogrammetry, TruthError, TruthSwitches, TwinAsElastic, TwinRobot, TwinTerms,
    twin_terms,
};

/// Settings of the forming experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct FormingOptions {
    /// Seed of the measurement noise.
    pub seed: u64,
    /// Dead weight on the end-effector as weighed (N) (paper: 920); the
    /// twin's true weight differs by the scale's accuracy.
    pub dead_weight_n: f64,
    /// Plunge depth at the free end (m) (paper: 0.025).
    pub plunge_m: f64,
    /// Travel along the beam towards the clamp (m) (paper: 0.200).
    pub travel_m: f64,
    /// Distance between path points (m) (default 0.005).
    pub step_m: f64,
    /// Where the plunge starts, from the free end towards the clamp (m)
    /// (default 0.005: a tool exactly at the edge would slide off the bent beam).
    pub edge_margin_m: f64,
    /// Pose of the part frame (clamp at its origin, beam along +x, top surface
    /// at z = 0) in the robot base frame: where the part truly is.
    pub x_base_part: Isometry3<f64>,
    /// The part pose the user commands with, when it differs from the true
    /// one: a user locates the part with the measurement system and carries
    /// it into the calibrated robot's base frame through the registered
    /// camera frame, `x_base_part_user = x_meas_base_identified^-1 *
    /// x_meas_part` (default `None`: the true pose). The calibrated robot's
    /// base differs from the true base by what the registration absorbed
    /// (the base parameters, the mean of the gravity sag).
    pub x_base_part_user: Option<Isometry3<f64>>,
    /// The beam as the user models it (handbook modulus, no friction); the
    /// twin's true beam differs ([`FormingTruth::true_beam`]).
    pub beam: CantileverBeam,
}

impl Default for FormingOptions {
    fn default() -> Self {
        Self {
            seed: 17,
            dead_weight_n: 920.0,
            plunge_m: 0.025,
            travel_m: 0.200,
            step_m: 0.005,
            edge_margin_m: 0.005,
            // The beam lies along the base x axis in the plane y = 0, clamped at
            // x = 1.2 m, top surface 1.45 m above the base: the tool then works
            // at x 1.58-1.78 m, z 1.425-1.45 m, inside both the geometric
            // calibration's box (59) and the elastic campaign's grid (65), where
            // the identified models hold.
            x_base_part: Isometry3::translation(1.2, 0.0, 1.45),
            x_base_part_user: None,
            beam: CantileverBeam::reference(BeamTheory::LargeDeflection),
        }
    }
}

/// The target path in the part frame: the plunge, then the travel, tool
/// pointing down (its z axis along -z_p).
pub fn forming_path(options: &FormingOptions) -> Vec<PathPoint> {
    let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let x0 = options.beam.length_m - options.edge_margin_m;
    let mut points = Vec::new();
    let plunge_steps = (options.plunge_m / options.step_m).round().max(1.0) as usize;
    for i in 0..=plunge_steps {
        let z = -options.plunge_m * i as f64 / plunge_steps as f64;
        points.push((x0, z));
    }
    let travel_steps = (options.travel_m / options.step_m).round().max(1.0) as usize;
    for i in 1..=travel_steps {
        let x = x0 - options.travel_m * i as f64 / travel_steps as f64;
        points.push((x, -options.plunge_m));
    }
    points
        .into_iter()
        .enumerate()
        .map(|(k, (x, z))| PathPoint {
            line: k + 2,
            x_part_tcp: Isometry3::from_parts(Translation3::new(x, 0.0, z), down),
        })
        .collect()
}

/// One measured path: per point, the deviation of the measured TCP from the
/// target along x_p and z_p (mm).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct MeasuredPath {
    /// Which command produced it.
    pub label: String,
    /// Deviation along x_p (mm).
    pub deviation_x_mm: Vec<f64>,
    /// Deviation along z_p (mm).
    pub deviation_z_mm: Vec<f64>,
    /// Largest |deviation along z_p| (mm).
    pub max_abs_deviation_z_mm: f64,
    /// Deviation predicted by the user's model before compensation (z_p, mm),
    /// when the path was compensated with a model.
    pub predicted_uncompensated_z_mm: Option<Vec<f64>>,
}

/// Result of the forming experiment.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct FormingResult {
    /// Target path points in the part frame: (x_p, z_p) (mm).
    pub target_mm: Vec<(f64, f64)>,
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

/// Errors of the forming experiment.
#[derive(Debug, thiserror::Error)]
pub enum FormingError {
    /// A path point could not be commanded or measured.
    #[error("forming path point {point}: {source}")]
    Point {
        /// 0-based point index.
        point: usize,
        /// Why.
        source: CompensationError,
    },
    /// The robot geometry failed.
    #[error(transparent)]
    Kinematics(#[from] flexcal_kinematics::KinematicsError),
    /// The twin's truth failed.
    #[error(transparent)]
    Truth(Box<TruthError>),
    /// An option is out of range.
    #[error("invalid forming option: {0}")]
    InvalidOption(String),
    /// An elastic model could not set up its workspace.
    #[error("elastic model workspace: {0}")]
    Workspace(CompensationError),
}

impl From<TruthError> for FormingError {
    fn from(e: TruthError) -> Self {
        Self::Truth(Box::new(e))
    }
}

/// The forming cell as it is: the true robot, the true beam, contact and
/// dead weight, and the measurement system.
pub struct TwinCell {
    /// The true robot seen from its TCP.
    pub robot: TwinAsElastic,
    /// The forming truth terms.
    pub forming: FormingTruth,
    /// The measurement system.
    pub camera: Photogrammetry,
}

impl TwinCell {
    /// The cell with the given truth switches.
    ///
    /// # Errors
    /// As [`TwinRobot::new`].
    pub fn new(switches: TruthSwitches) -> Result<Self, TruthError> {
        Ok(Self {
            robot: TwinAsElastic::new(TwinRobot::new(switches)?)?,
            forming: FormingTruth::default(),
            camera: Photogrammetry::default(),
        })
    }

    /// The truth's terms.
    pub fn terms(&self) -> TwinTerms {
        twin_terms(self.robot.robot(), &self.camera, &self.forming)
    }

    /// Where the user places the part: the camera locates it (at its true
    /// pose `x_base_part`), and the user carries that into the calibrated
    /// robot's base frame through the identified camera frame
    /// `x_meas_base_identified` (from the calibration):
    /// `x_meas_base_identified^-1 * x_meas_base_true * x_base_part`.
    pub fn part_located_by_camera(
        &self,
        x_base_part: &Isometry3<f64>,
        x_meas_base_identified: &Isometry3<f64>,
    ) -> Isometry3<f64> {
        x_meas_base_identified.inverse() * self.camera.x_meas_base * x_base_part
    }
}

fn payload(x_base_part: Isometry3<f64>, weight_n: f64) -> Cell {
    Cell {
        x_base_part,
        payload_base: Vector6::new(0.0, 0.0, -weight_n, 0.0, 0.0, 0.0),
    }
}

/// Runs the experiment: commands the path without compensation, then with
/// each of `models` (label, elastic model), all with the calibrated geometry
/// `calibrated_xi`, and "measures" what the twin does.
///
/// # Errors
/// [`FormingError`] naming the path point that failed.
pub fn run_forming(
    twin: &TwinCell,
    calibrated_xi: &[f64],
    models: &[(&str, &dyn DynTcpDeflection)],
    options: &FormingOptions,
) -> Result<FormingResult, FormingError> {
    if !(options.dead_weight_n.is_finite() && options.dead_weight_n >= 0.0) {
        return Err(FormingError::InvalidOption(format!(
            "dead_weight_n must be finite and >= 0, found {}",
            options.dead_weight_n
        )));
    }
    options
        .beam
        .validate()
        .map_err(|e| FormingError::InvalidOption(e.to_string()))?;
    let robot = twin.robot.robot();
    let switches = robot.switches;
    let model = robot.model();
    let path = forming_path(options);
    let true_beam = twin.forming.true_beam(
        &options.beam,
        switches.beam_modulus_offset,
        switches.tool_friction,
    );
    let true_weight = twin
        .forming
        .true_payload_n(options.dead_weight_n, switches.payload_error);
    let true_process: &dyn ProcessModel = &true_beam;
    let user_process: &dyn ProcessModel = &options.beam;
    let truth = ElastoGeometricModel {
        model,
        xi: robot.true_xi().to_vec(),
        elastic: &twin.robot,
        process: Some(true_process),
        cell: payload(options.x_base_part, true_weight),
    };
    let compensation = CompensationOptions::default();
    let mut data = truth.data().map_err(FormingError::Workspace)?;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let mut camera = twin.camera.clone();
    if !switches.measurement_frame {
        camera.x_meas_base = Isometry3::identity();
    }
    let x_part_base = options.x_base_part.inverse();
    // Start near the working area: upper arm forward, forearm down.
    let start = actuated_from_joint_angles(model, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0])?;
    let x_base_part_user = options.x_base_part_user.unwrap_or(options.x_base_part);
    let targets: Vec<Isometry3<f64>> = path
        .iter()
        .map(|p| x_base_part_user * p.x_part_tcp)
        .collect();
    let motion = |k: usize| -> Vector3<f64> {
        if k + 1 < targets.len() {
            targets[k + 1].translation.vector - targets[k].translation.vector
        } else if k > 0 {
            targets[k].translation.vector - targets[k - 1].translation.vector
        } else {
            Vector3::zeros()
        }
    };
    let mut measure = |label: &str,
                       commands: &[Vec<f64>],
                       predicted: Option<Vec<f64>>,
                       data: &mut CompensationData<_>|
     -> Result<MeasuredPath, FormingError> {
        let mut dx = Vec::with_capacity(commands.len());
        let mut dz = Vec::with_capacity(commands.len());
        for (k, q) in commands.iter().enumerate() {
            let actual = truth
                .actual_pose(data, q, &motion(k), &compensation)
                .map_err(|source| FormingError::Point { point: k, source })?;
            let measured = camera
                .measure(
                    &actual.x_base_tcp,
                    switches.measurement_noise,
                    true,
                    &mut rng,
                )
                .translation
                .vector;
            let in_part = x_part_base.transform_point(&measured.into());
            let target = path[k].x_part_tcp.translation.vector;
            dx.push((in_part.x - target.x) * 1e3);
            dz.push((in_part.z - target.z) * 1e3);
        }
        let max = dz.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        Ok(MeasuredPath {
            label: label.to_string(),
            deviation_x_mm: dx,
            deviation_z_mm: dz,
            max_abs_deviation_z_mm: max,
            predicted_uncompensated_z_mm: predicted,
        })
    };
    // Without compensation: the inverse geometric model of the calibrated robot.
    let mut seed = start.clone();
    let mut uncompensated_q = Vec::with_capacity(targets.len());
    for (k, target) in targets.iter().enumerate() {
        let s = inverse_pose(
            model,
            &mut data.kinematics,
            target,
            &seed,
            calibrated_xi,
            &compensation.inverse,
        )
        .map_err(|e| FormingError::Point {
            point: k,
            source: e.into(),
        })?;
        seed.clone_from(&s.q);
        uncompensated_q.push(s.q);
    }
    let uncompensated = measure("uncompensated", &uncompensated_q, None, &mut data)?;
    let mut compensated = Vec::new();
    for (label, elastic) in models {
        let user = ElastoGeometricModel {
            model,
            xi: calibrated_xi.to_vec(),
            elastic: *elastic,
            process: Some(user_process),
            cell: payload(x_base_part_user, options.dead_weight_n),
        };
        let mut user_data = user.data().map_err(FormingError::Workspace)?;
        let outcomes =
            user.compensate_path(&mut user_data, &path, &uncompensated_q[0], &compensation);
        let mut commands = Vec::with_capacity(outcomes.len());
        let mut predicted = Vec::with_capacity(outcomes.len());
        for (k, o) in outcomes.into_iter().enumerate() {
            let c = o
                .result
                .map_err(|source| FormingError::Point { point: k, source })?;
            let e = c.uncompensated_error;
            let e_part = x_part_base.rotation * Vector3::new(e[0], e[1], e[2]);
            predicted.push(e_part.z * 1e3);
            commands.push(c.q_commanded);
        }
        compensated.push(measure(label, &commands, Some(predicted), &mut data)?);
    }
    Ok(FormingResult {
        target_mm: path
            .iter()
            .map(|p| {
                let t = p.x_part_tcp.translation.vector;
                (t.x * 1e3, t.z * 1e3)
            })
            .collect(),
        uncompensated,
        compensated,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_path_plunges_then_travels_towards_the_clamp() {
        let options = FormingOptions::default();
        let path = forming_path(&options);
        assert_eq!(path.len(), 6 + 40);
        let first = path[0].x_part_tcp.translation.vector;
        let plunged = path[5].x_part_tcp.translation.vector;
        let last = path.last().unwrap().x_part_tcp.translation.vector;
        assert!((first.x - 0.580).abs() < 1e-12 && first.z == 0.0);
        assert!((plunged.z + 0.025).abs() < 1e-12);
        assert!((last.x - 0.380).abs() < 1e-12 && (last.z + 0.025).abs() < 1e-12);
    }
}

#[cfg(test)]
mod twin_tests {
    use super::*;

    #[test]
    fn compensation_with_the_twins_own_truth_leaves_no_deviation() {
        // The process terms off so that the user's beam and weight are
        // the true ones; the user's elastic model is the twin itself.
        let switches = TruthSwitches {
            measurement_noise: false,
            beam_modulus_offset: false,
            tool_friction: false,
            payload_error: false,
            ..TruthSwitches::default()
        };
        let twin = TwinCell::new(switches).unwrap();
        let perfect = TwinAsElastic::new(TwinRobot::new(switches).unwrap()).unwrap();
        let true_xi = twin.robot.robot().true_xi().to_vec();
        let options = FormingOptions::default();
        let result = run_forming(&twin, &true_xi, &[("truth", &perfect)], &options).unwrap();
        // Uncompensated, the true geometry leaves the own weight's sag,
        // the drives' yield, the transmission errors and the process load:
        // millimetres.
        let unc = &result.uncompensated;
        assert!(unc.max_abs_deviation_z_mm > 0.3, "{unc:?}");
        // A perfect model compensates to solver tolerance.
        let perfect = &result.compensated[0];
        assert!(perfect.max_abs_deviation_z_mm < 1e-5, "{perfect:?}");
        // And it predicted the uncompensated deviation exactly.
        let predicted = perfect.predicted_uncompensated_z_mm.as_ref().unwrap();
        for (p, m) in predicted.iter().zip(&unc.deviation_z_mm) {
            assert!((p - m).abs() < 1e-5, "{p} vs {m}");
        }
    }
}
